// MSTNormalOrientation and viewpoint orientation, with our normals and PCL's.
#include "test_util.h"

#include <pclx/normals/mst_normal_orientation.h>
#include <pclx/normals/normal_error.h>
#include <pclx/normals/planar_octree_normal_estimation.h>
#include <pclx/normals/viewpoint_normal_orientation.h>
#include <pclx/testing/mesh_sampling.h>
#include <pclx/testing/shapes.h>

#include <pcl/search/kdtree.h>

#include <gtest/gtest.h>

#include <limits>
#include <random>

using pcl::compareNormals;
using namespace normals_test;
using pclx::testing::positions;

namespace {


// Randomly flips half of the normals so that orientation has something to fix.
void
scramble (pcl::PointCloud<pcl::Normal>& n, std::uint32_t seed = 3)
{
  std::mt19937 rng (seed);
  for (auto& p : n)
    if (rng () & 1)
      p.getNormalVector3fMap () *= -1.f;
}

double
flippedShare (const pcl::PointCloud<pcl::Normal>& n, const pcl::PointCloud<pcl::PointNormal>& truth)
{
  return compareNormals (n, truth, true).flipped;
}

// PlanarOctreeNormalEstimation's normals (defaults), unoriented input for the MST.
pcl::PointCloud<pcl::Normal>
ourNormals (const pcl::PointCloud<pcl::PointXYZ>::ConstPtr& cloud)
{
  pcl::PlanarOctreeNormalEstimation<pcl::PointXYZ, pcl::Normal> ne;
  ne.setInputCloud (cloud);
  pcl::PointCloud<pcl::Normal> n;
  ne.compute (n);
  return n;
}

}  // namespace

TEST (MSTOrientation, PclNormalsOnClosedShapesPointOutward)
{
  using pclx::testing::sampleUniform;
  const std::pair<const char*, pclx::testing::TriangleMesh> shapes[] = {
      {"sphere", pclx::testing::makeSphere (1.f, 5)},
      {"torus", pclx::testing::makeTorus (1.f, 0.3f, 128, 48)},
      {"box", pclx::testing::makeBox (Eigen::Vector3f (1, 2, 0.5f), 8)}};
  for (const auto& [name, mesh] : shapes)
  {
    const auto s = sampleUniform (mesh, 20000, 2);
    const auto cloud = positions (s.cloud);
    auto n = pcaNormals<pcl::PointXYZ> (cloud, 18);
    scramble (n);
    ASSERT_GT (flippedShare (n, s.cloud), 0.3);
    pcl::MSTNormalOrientation<pcl::PointXYZ, pcl::Normal> mst;
    mst.setInputCloud (cloud);
    ASSERT_TRUE (mst.orient (n));
    EXPECT_EQ (mst.getNumberOfComponents (), 1u) << name;
    // The root (max z) points to +z, i.e. outward on these shapes: all must follow.
    EXPECT_LT (flippedShare (n, s.cloud), 0.01) << name;
  }
}

namespace {

// An L-shaped prism: convex edges and one concave edge, outward faces.
pclx::testing::TriangleMesh
makeLPrism ()
{
  const Eigen::Vector2f l[6] = {{0, 0}, {2, 0}, {2, 1}, {1, 1}, {1, 2}, {0, 2}};  // counter-clockwise
  pclx::testing::TriangleMesh m;
  for (int z = 0; z < 2; ++z)
    for (const auto& v : l)
      m.vertices.emplace_back (v.x (), v.y (), float (z));
  for (int i = 1; i + 1 < 6; ++i)  // fan from (0, 0): the L is star-shaped from there
  {
    m.faces.emplace_back (0, i + 1, i);          // bottom, facing -z
    m.faces.emplace_back (6, 6 + i, 6 + i + 1);  // top, facing +z
  }
  for (int i = 0; i < 6; ++i)  // sides, facing right of each counter-clockwise edge
  {
    const int j = (i + 1) % 6;
    m.faces.emplace_back (i, j, 6 + j);
    m.faces.emplace_back (i, 6 + j, 6 + i);
  }
  return m;
}

}  // namespace

TEST (MSTOrientation, ExactNormalsAcrossSharpEdgesPointOutward)
{
  // Exact normals turn by 90 degrees at a box edge, where ni·nj ≈ 0 says nothing about the
  // relative sign; where the tree crosses such an edge, the edge's side (both normals lean
  // away from the edge vector in opposite directions, convex or concave) decides it.
  const std::pair<const char*, pclx::testing::TriangleMesh> shapes[] = {
      {"box", pclx::testing::makeBox (Eigen::Vector3f (1, 2, 0.5f), 8)}, {"L prism", makeLPrism ()}};
  for (const auto& [name, mesh] : shapes)
  {
    const auto s = pclx::testing::sampleUniform (mesh, 20000, 5);
    const auto cloud = positions (s.cloud);
    pcl::PointCloud<pcl::Normal> n (s.cloud.size (), 1);
    for (std::size_t i = 0; i < n.size (); ++i)
      n[i].getNormalVector3fMap () = s.cloud[i].getNormalVector3fMap ();
    ASSERT_LT (flippedShare (n, s.cloud), 1e-9) << name << ": the truth is outward";
    scramble (n);
    pcl::MSTNormalOrientation<pcl::PointXYZ, pcl::Normal> mst;
    mst.setInputCloud (cloud);
    ASSERT_TRUE (mst.orient (n));
    EXPECT_EQ (mst.getNumberOfComponents (), 1u) << name;
    EXPECT_LT (flippedShare (n, s.cloud), 0.01) << name;
  }
}

TEST (MSTOrientation, ExtremePointsVoteTheSignNotTheHighestPointAlone)
{
  // The highest point on a crease or a thin ridge gets a nearly horizontal normal, which
  // says nothing about "up". Here the sphere's top point gets a horizontal normal (±x, so
  // one of the two signs disagrees with the side its tree neighbour lies on); every other
  // normal is exact (scrambled). The extremes in 21 upper directions settle the sign.
  auto s = analyticSphere (3000, 1.f, Eigen::Vector3f (0, 0, 0), 9);
  const auto cloud = positions (s);
  std::size_t top = 0;
  for (std::size_t i = 1; i < s.size (); ++i)
    if (s[i].z > s[top].z)
      top = i;
  for (const float sx : {1.f, -1.f})
  {
    pcl::PointCloud<pcl::Normal> n (s.size (), 1);
    for (std::size_t i = 0; i < n.size (); ++i)
      n[i].getNormalVector3fMap () = s[i].getNormalVector3fMap ();
    scramble (n, 11);
    n[top].getNormalVector3fMap () = Eigen::Vector3f (sx, 0, 0);
    pcl::MSTNormalOrientation<pcl::PointXYZ, pcl::Normal> mst;
    mst.setInputCloud (cloud);
    ASSERT_TRUE (mst.orient (n));
    EXPECT_LT (flippedShare (n, s), 0.01) << "top normal " << sx << " x";
  }
}

TEST (MSTOrientation, OurMergedNormalsOnATorusPointOutward)
{
  const auto s = pclx::testing::sampleUniform (pclx::testing::makeTorus (1.f, 0.3f, 128, 48), 30000, 4);
  const auto cloud = positions (s.cloud);
  pcl::PointCloud<pcl::Normal> n = ourNormals (cloud);
  pcl::MSTNormalOrientation<pcl::PointXYZ, pcl::Normal> mst;
  mst.setInputCloud (cloud);
  ASSERT_TRUE (mst.orient (n));
  EXPECT_LT (flippedShare (n, s.cloud), 0.01);
}

TEST (MSTOrientation, ThinPlateSheetsGetOppositeNormals)
{
  // A plate about two sample spacings thick: both sheets get one plane's normals, so
  // Hoppe's cost 1 − |ni·nj| is 0 across the plate and the tree may cross it, giving both
  // sheets the same sign. The across-surface penalty (default) sends the tree around; where
  // it crosses anyway, the edge-side reading (offsets far above the noise) keeps the signs apart.
  const auto s = pclx::testing::sampleUniform (pclx::testing::makeThinPlate (1.f, 0.02f, 32), 30000, 6);
  const auto cloud = positions (s.cloud);
  const pcl::PointCloud<pcl::Normal> estimated = ourNormals (cloud);
  pcl::MSTNormalOrientation<pcl::PointXYZ, pcl::Normal> mst;
  mst.setInputCloud (cloud);
  EXPECT_GT (mst.getAcrossSurfacePenalty (), 0.0);
  pcl::PointCloud<pcl::Normal> n = estimated;
  ASSERT_TRUE (mst.orient (n));
  EXPECT_LT (flippedShare (n, s.cloud), 0.01);
  mst.setAcrossSurfacePenalty (0.0);  // Hoppe's cost: the tree crosses the plate ...
  n = estimated;
  ASSERT_TRUE (mst.orient (n));
  EXPECT_LT (flippedShare (n, s.cloud), 0.01);  // ... and the edge-side reading gets it right
  mst.setNoiseScale (0.1);  // the plate's thickness could be noise: Hoppe's rule alone
  mst.setVisibilityWeight (0);  // without the votes, which would overrule it
  n = estimated;
  ASSERT_TRUE (mst.orient (n));
  EXPECT_GT (flippedShare (n, s.cloud), 0.3);
}

TEST (MSTOrientation, ThinPlateTwoSpacingsThickGetsBothSheetsOutward)
{
  // At 20000 points the plate's sheets are two spacings apart: a noise estimate that read the
  // other sheet as noise (σ ≈ 0.7 of the thickness) made the estimator treat the cloud as noisy
  // and the MST's edge-side reading insignificant, and both sheets came out facing +z.
  const auto s = pclx::testing::sampleUniform (pclx::testing::makeThinPlate (1.f, 0.02f, 16), 20000, 2);
  const auto cloud = positions (s.cloud);
  pcl::PlanarOctreeNormalEstimation<pcl::PointXYZ, pcl::Normal> ne;
  ne.setInputCloud (cloud);
  pcl::PointCloud<pcl::Normal> n;
  ne.compute (n);
  ASSERT_EQ (n.size (), s.cloud.size ());
  EXPECT_LT (ne.getNoiseEstimate ().sigma, 0.01 * ne.getNoiseEstimate ().spacing);
  pcl::MSTNormalOrientation<pcl::PointXYZ, pcl::Normal> mst;
  mst.setInputCloud (cloud);
  ASSERT_TRUE (mst.orient (n));
  EXPECT_LT (mst.getUsedNoiseScale (), 0.01 * ne.getNoiseEstimate ().spacing);
  std::size_t bottom = 0, bottom_flipped = 0;
  for (std::size_t i = 0; i < n.size (); ++i)
    if (s.cloud[i].normal_z < -0.5f)
    {
      ++bottom;
      bottom_flipped += n[i].normal_z > 0.f;
    }
  ASSERT_GT (bottom, 9000u);
  EXPECT_LT (static_cast<double> (bottom_flipped) / bottom, 0.01);
  EXPECT_LT (flippedShare (n, s.cloud), 0.01);
}

namespace {

// A closed slab [-0.5, 0.5]² × [-0.2, profile] whose top profile (along x, extruded along y)
// has narrow ridges and V-grooves, `width` wide and `depth` deep: at 20000 points (spacing
// ≈ 0.012) width 0.036 puts the two faces of each within the kNN graph's edges of each other.
pclx::testing::TriangleMesh
makeRidgedSlab (float width, float depth)
{
  std::vector<Eigen::Vector2f> p{{-0.5f, 0.f}};
  float x = -0.4f;
  p.emplace_back (x, 0.f);
  for (int i = 0; i < 6; ++i)
  {
    p.emplace_back (x + width / 2, i % 2 ? -depth : depth);  // ridge, then V-groove
    x += width;
    p.emplace_back (x, 0.f);
    x += 0.1f;
    p.emplace_back (x, 0.f);
  }
  p.emplace_back (0.5f, 0.f);
  const float bottom = -0.2f;
  pclx::testing::TriangleMesh m;
  for (std::size_t i = 0; i + 1 < p.size (); ++i)
  {
    const Eigen::Vector2f a = p[i], b = p[i + 1];
    m.addQuad ({a.x (), -0.5f, a.y ()}, {b.x (), -0.5f, b.y ()}, {b.x (), 0.5f, b.y ()}, {a.x (), 0.5f, a.y ()});
    m.addQuad ({a.x (), -0.5f, bottom}, {b.x (), -0.5f, bottom}, {b.x (), -0.5f, b.y ()}, {a.x (), -0.5f, a.y ()});
    m.addQuad ({a.x (), 0.5f, bottom}, {a.x (), 0.5f, a.y ()}, {b.x (), 0.5f, b.y ()}, {b.x (), 0.5f, bottom});
  }
  m.addQuad ({-0.5f, -0.5f, bottom}, {-0.5f, -0.5f, 0.f}, {-0.5f, 0.5f, 0.f}, {-0.5f, 0.5f, bottom});
  m.addQuad ({0.5f, -0.5f, bottom}, {0.5f, 0.5f, bottom}, {0.5f, 0.5f, 0.f}, {0.5f, -0.5f, 0.f});
  m.addQuad ({-0.5f, -0.5f, bottom}, {-0.5f, 0.5f, bottom}, {0.5f, 0.5f, bottom}, {0.5f, -0.5f, bottom});
  return m;
}

pcl::PointCloud<pcl::Normal>
exactNormals (const pcl::PointCloud<pcl::PointNormal>& s)
{
  pcl::PointCloud<pcl::Normal> n (s.size (), 1);
  for (std::size_t i = 0; i < n.size (); ++i)
    n[i].getNormalVector3fMap () = s[i].getNormalVector3fMap ();
  return n;
}

}  // namespace

TEST (MSTOrientation, NarrowRidgesAndGroovesAreReadFromTheEdgeSide)
{
  // The two faces of a ridge or V-groove narrower than the graph's edges meet at ~150° and
  // look ~30° apart to Hoppe's rule (which then flips one face); an edge along the crease
  // reads nothing. The edge-side reading across the fold is right, and such crossings are
  // preferred. A noise scale as large as the ridges says the offsets could be noise: the
  // fold is not read and Hoppe's rule (the old behaviour) flips whole strips of the top.
  const auto s = pclx::testing::sampleUniform (makeRidgedSlab (0.036f, 0.06f), 20000, 8);
  const auto cloud = positions (s.cloud);
  pcl::MSTNormalOrientation<pcl::PointXYZ, pcl::Normal> mst;
  mst.setInputCloud (cloud);
  auto n = exactNormals (s.cloud);
  scramble (n);
  ASSERT_TRUE (mst.orient (n));
  EXPECT_LT (mst.getUsedNoiseScale (), 1e-4);  // clean: the estimate is ~0
  EXPECT_LT (flippedShare (n, s.cloud), 0.01);
  mst.setNoiseScale (0.05);
  mst.setVisibilityWeight (0);  // the MST's crossings alone (the votes are tested below)
  n = exactNormals (s.cloud);
  scramble (n);
  ASSERT_TRUE (mst.orient (n));
  EXPECT_EQ (mst.getUsedNoiseScale (), 0.05);
  EXPECT_GT (flippedShare (n, s.cloud), 0.03);
}

TEST (MSTOrientation, VisibilityVotesOverruleWrongCrossings)
{
  // The ridged slab with the fold reading switched off (a noise scale as large as the ridges):
  // Hoppe's rule flips whole strips of the top, and everything downstream of each wrong
  // crossing follows. Seen from outside, those strips face away from the viewers: the votes
  // overrule the crossings into them.
  const auto s = pclx::testing::sampleUniform (makeRidgedSlab (0.036f, 0.06f), 20000, 8);
  const auto cloud = positions (s.cloud);
  pcl::MSTNormalOrientation<pcl::PointXYZ, pcl::Normal> mst;
  mst.setInputCloud (cloud);
  mst.setNoiseScale (0.05);
  EXPECT_EQ (mst.getVisibilityWeight (), 1.0);
  auto n = exactNormals (s.cloud);
  scramble (n);
  ASSERT_TRUE (mst.orient (n));
  const double with_votes = flippedShare (n, s.cloud);
  EXPECT_GT (mst.getNumberOfVisibilityFlips (), 0u);
  mst.setVisibilityWeight (0);
  n = exactNormals (s.cloud);
  scramble (n);
  ASSERT_TRUE (mst.orient (n));
  const double without = flippedShare (n, s.cloud);
  EXPECT_EQ (mst.getNumberOfVisibilityFlips (), 0u);
  EXPECT_LT (with_votes, 0.025) << "without votes " << without;
  EXPECT_GT (without, 2 * with_votes);
}

TEST (MSTOrientation, OurNormalsOnANarrowlyRidgedSlab)
{
  // Ridges and grooves two edges wide (0.024 at ~0.012 spacing): the estimated normals of
  // their faces are nearly parallel across the fold, and the MST crosses them wrongly.
  const auto s = pclx::testing::sampleUniform (makeRidgedSlab (0.024f, 0.05f), 20000, 12);
  const auto cloud = positions (s.cloud);
  const pcl::PointCloud<pcl::Normal> estimated = ourNormals (cloud);
  pcl::MSTNormalOrientation<pcl::PointXYZ, pcl::Normal> mst;
  mst.setInputCloud (cloud);
  auto n = estimated;
  ASSERT_TRUE (mst.orient (n));
  const double with_votes = flippedShare (n, s.cloud);
  mst.setVisibilityWeight (0);
  n = estimated;
  ASSERT_TRUE (mst.orient (n));
  const double without = flippedShare (n, s.cloud);
  // Not under 1 %: faces two edges wide get their neighbour face's plane, a sign no crossing
  // can give (exact normals are oriented, below). The votes fix the rest.
  EXPECT_LT (with_votes, 0.08) << "without votes " << without;
  EXPECT_GT (without, 2 * with_votes);
  mst.setVisibilityWeight (1);
  n = exactNormals (s.cloud);
  scramble (n);
  ASSERT_TRUE (mst.orient (n));
  EXPECT_LT (flippedShare (n, s.cloud), 0.01);
}

TEST (MSTOrientation, OpenSheetStaysConsistentWithVotes)
{
  // An open wavy sheet is seen from both sides: its votes cancel and the extreme points sign
  // it "up", every point the same way.
  pcl::PointCloud<pcl::PointNormal> s;
  std::mt19937 rng (21);
  std::uniform_real_distribution<float> u (-1.f, 1.f);
  for (int i = 0; i < 20000; ++i)
  {
    const float x = u (rng), y = u (rng);
    pcl::PointNormal p;
    p.x = x;
    p.y = y;
    p.z = 0.1f * std::sin (3 * x) * std::cos (2 * y);
    const Eigen::Vector3f grad (0.3f * std::cos (3 * x) * std::cos (2 * y), -0.2f * std::sin (3 * x) * std::sin (2 * y), 0.f);
    p.getNormalVector3fMap () = Eigen::Vector3f (-grad.x (), -grad.y (), 1.f).normalized ();
    s.push_back (p);
  }
  const auto cloud = positions (s);
  auto n = pcaNormals<pcl::PointXYZ> (cloud, 12);
  scramble (n);
  pcl::MSTNormalOrientation<pcl::PointXYZ, pcl::Normal> mst;
  mst.setInputCloud (cloud);
  const auto scrambled = n;
  ASSERT_TRUE (mst.orient (n));
  EXPECT_LT (flippedShare (n, s), 0.001);
  n = scrambled;
  mst.setVisibilityWeight (0);
  ASSERT_TRUE (mst.orient (n));
  EXPECT_LT (flippedShare (n, s), 0.001);
}

TEST (MSTOrientation, ThinPlateExactNormalsAreReadAcrossTheFold)
{
  // Exact normals on the two sheets of a plate 0.02 thick (~2 spacings) are anti-parallel:
  // Hoppe's rule flips across it. Without the across-surface penalty the tree crosses the
  // plate freely (cost 0), and only the edge-side reading keeps the sheets apart.
  const auto s = pclx::testing::sampleUniform (pclx::testing::makeThinPlate (1.f, 0.02f, 32), 30000, 6);
  const auto cloud = positions (s.cloud);
  pcl::MSTNormalOrientation<pcl::PointXYZ, pcl::Normal> mst;
  mst.setInputCloud (cloud);
  mst.setAcrossSurfacePenalty (0.0);
  auto n = exactNormals (s.cloud);
  scramble (n);
  ASSERT_TRUE (mst.orient (n));
  EXPECT_LT (flippedShare (n, s.cloud), 0.01);
  mst.setNoiseScale (0.1);  // the plate's thickness could be noise: Hoppe's rule alone
  mst.setVisibilityWeight (0);  // without the votes, which would overrule it
  n = exactNormals (s.cloud);
  scramble (n);
  ASSERT_TRUE (mst.orient (n));
  EXPECT_GT (flippedShare (n, s.cloud), 0.2);
}

TEST (MSTOrientation, NoiseScaleIsEstimatedUnlessGiven)
{
  // A sphere of radius 1 with Gaussian noise σ = 0.01 along every axis (so along the normal).
  auto s = analyticSphere (20000, 1.f, Eigen::Vector3f::Zero (), 4);
  std::mt19937 rng (5);
  std::normal_distribution<float> g (0.f, 0.01f);
  for (auto& p : s)
    p.getVector3fMap () += Eigen::Vector3f (g (rng), g (rng), g (rng));
  const auto cloud = positions (s);
  auto n = pcaNormals<pcl::PointXYZ> (cloud, 30);
  pcl::MSTNormalOrientation<pcl::PointXYZ, pcl::Normal> mst;
  mst.setInputCloud (cloud);
  EXPECT_LT (mst.getNoiseScale (), 0.0);  // default: estimate
  ASSERT_TRUE (mst.orient (n));
  EXPECT_NEAR (mst.getUsedNoiseScale (), 0.01, 0.004);
  EXPECT_LT (flippedShare (n, s), 0.01);
  mst.setNoiseScale (0.02);
  ASSERT_TRUE (mst.orient (n));
  EXPECT_EQ (mst.getUsedNoiseScale (), 0.02);
  // Through a user's search method (a separate code path for the queries).
  pcl::MSTNormalOrientation<pcl::PointXYZ, pcl::Normal> with_search;
  with_search.setInputCloud (cloud);
  with_search.setSearchMethod (pcl::search::KdTree<pcl::PointXYZ>::Ptr (new pcl::search::KdTree<pcl::PointXYZ>));
  ASSERT_TRUE (with_search.orient (n));
  EXPECT_NEAR (with_search.getUsedNoiseScale (), 0.01, 0.004);
  EXPECT_LT (flippedShare (n, s), 0.01);
}

TEST (MSTOrientation, EveryComponentIsRootedAtItsHighestPoint)
{
  auto a = analyticSphere (3000, 1.f, Eigen::Vector3f (0, 0, 0), 1);
  const auto b = analyticSphere (3000, 0.5f, Eigen::Vector3f (10, 0, -3), 2);
  a += b;
  const auto cloud = positions (a);
  auto n = pcaNormals<pcl::PointXYZ> (cloud, 12);
  scramble (n);
  pcl::MSTNormalOrientation<pcl::PointXYZ, pcl::Normal> mst;
  mst.setInputCloud (cloud);
  ASSERT_TRUE (mst.orient (n));
  EXPECT_EQ (mst.getNumberOfComponents (), 2u);
  EXPECT_EQ (flippedShare (n, a), 0.0);
  EXPECT_GT (mst.getNumberOfFlipped (), 0u);
}

TEST (MSTOrientation, InvalidNormalsStayOutOfTheGraph)
{
  const auto truth = analyticSphere (2000, 1.f, Eigen::Vector3f::Zero ());
  const auto cloud = positions (truth);
  auto n = pcaNormals<pcl::PointXYZ> (cloud, 12);
  n[5].normal_x = std::numeric_limits<float>::quiet_NaN ();
  n[6].getNormalVector3fMap ().setZero ();
  pcl::MSTNormalOrientation<pcl::PointXYZ, pcl::Normal> mst;
  mst.setInputCloud (cloud);
  ASSERT_TRUE (mst.orient (n));
  EXPECT_TRUE (std::isnan (n[5].normal_x));
  EXPECT_EQ (n[6].getNormalVector3fMap ().norm (), 0.f);
  std::size_t wrong = 0;
  for (std::size_t i = 0; i < n.size (); ++i)
    if (i != 5 && i != 6)
      wrong += n[i].getNormalVector3fMap ().dot (truth[i].getNormalVector3fMap ()) < 0;
  EXPECT_EQ (wrong, 0u);
}

TEST (MSTOrientation, BadInputIsRejected)
{
  const auto cloud = positions (analyticSphere (100, 1.f, Eigen::Vector3f::Zero ()));
  pcl::PointCloud<pcl::Normal> n (50, 1);
  pcl::MSTNormalOrientation<pcl::PointXYZ, pcl::Normal> mst;
  EXPECT_FALSE (mst.orient (n));  // no input
  mst.setInputCloud (cloud);
  EXPECT_FALSE (mst.orient (n));  // size mismatch
  n.resize (100);
  mst.setKSearch (0);
  EXPECT_FALSE (mst.orient (n));
  EXPECT_NE (mst.getLastError ().find ("k must be >= 1"), std::string::npos) << mst.getLastError ();
  mst.setKSearch (10);
  for (const double bad : {std::numeric_limits<double>::quiet_NaN (), std::numeric_limits<double>::infinity ()})
  {
    mst.setNoiseScale (bad);
    EXPECT_FALSE (mst.orient (n)) << bad;
    mst.setNoiseScale (-1);
    mst.setEdgeSideSignificance (bad);
    EXPECT_FALSE (mst.orient (n)) << bad;
    mst.setEdgeSideSignificance (4);
  }
  mst.setEdgeSideSignificance (-1);
  EXPECT_FALSE (mst.orient (n));
  mst.setEdgeSideSignificance (4);
  for (const double bad : {std::numeric_limits<double>::quiet_NaN (), std::numeric_limits<double>::infinity (), -0.5})
  {
    mst.setVisibilityWeight (bad);
    EXPECT_FALSE (mst.orient (n)) << bad;
  }
  mst.setVisibilityWeight (0);
  EXPECT_TRUE (mst.orient (n));
  EXPECT_TRUE (mst.getLastError ().empty ());
  mst.setVisibilityWeight (1);
  EXPECT_TRUE (mst.orient (n));
  pcl::PointCloud<pcl::PointXYZ>::Ptr empty (new pcl::PointCloud<pcl::PointXYZ>);
  pcl::PointCloud<pcl::Normal> none;
  mst.setKSearch (10);
  mst.setInputCloud (empty);
  EXPECT_TRUE (mst.orient (none));
  EXPECT_EQ (mst.getNumberOfComponents (), 0u);
}

TEST (ViewpointOrientation, NormalsFaceTheViewpoint)
{
  const auto truth = analyticSphere (2000, 1.f, Eigen::Vector3f::Zero ());
  const auto cloud = positions (truth);
  auto n = pcaNormals<pcl::PointXYZ> (cloud, 12);
  scramble (n);
  const Eigen::Vector3f vp (0, 0, 0);  // from inside the sphere: all normals point inward
  std::size_t flipped = 0;
  ASSERT_TRUE (pcl::orientNormalsTowardsViewpoint (*cloud, n, vp, &flipped));
  EXPECT_GT (flipped, 0u);
  for (std::size_t i = 0; i < n.size (); ++i)
    EXPECT_GT (n[i].getNormalVector3fMap ().dot (vp - (*cloud)[i].getVector3fMap ()), 0.f);
  pcl::PointCloud<pcl::Normal> wrong (3, 1);
  EXPECT_FALSE (pcl::orientNormalsTowardsViewpoint (*cloud, wrong, vp));
}

TEST (NormalError, CloudsOfDifferentSizesAreRejected)
{
  pcl::PointCloud<pcl::Normal> estimate (3, 1), truth (4, 1);
  for (auto& n : estimate)
    n.getNormalVector3fMap () = Eigen::Vector3f::UnitZ ();
  for (auto& n : truth)
    n.getNormalVector3fMap () = Eigen::Vector3f::UnitZ ();
  EXPECT_TRUE (pcl::angleErrorsDeg (estimate, truth).empty ());
  const pcl::NormalErrorStats s = compareNormals (estimate, truth);
  EXPECT_EQ (s.count, 0u);
  EXPECT_EQ (s.rms_deg, 0.0);
  truth.resize (3);
  EXPECT_EQ (compareNormals (estimate, truth).count, 3u);
}
