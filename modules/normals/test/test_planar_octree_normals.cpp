// PlanarOctreeNormalEstimation: exact normals on analytic shapes, Algorithm 1 split
// behaviour, hybrid borders, merging, PCL feature semantics and bad inputs.
#include "test_util.h"

#include <pclx/normals/detail/grid_knn.h>
#include <pclx/normals/normal_error.h>
#include <pclx/normals/planar_octree_normal_estimation.h>
#include <pclx/testing/degradation.h>
#include <pclx/testing/mesh_sampling.h>
#include <pclx/testing/shapes.h>

#include <pcl/search/kdtree.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <map>
#include <numeric>
#include <random>
#include <set>

using Estimator = pcl::PlanarOctreeNormalEstimation<pcl::PointXYZ, pcl::Normal>;
using Method = Estimator::Method;
using pcl::compareNormals;
using namespace normals_test;
using pclx::testing::positions;

namespace {


pcl::PointCloud<pcl::Normal>
estimate (const pcl::PointCloud<pcl::PointXYZ>::ConstPtr& cloud, Method m, Estimator* keep = nullptr)
{
  Estimator local;
  Estimator& ne = keep ? *keep : local;
  ne.setInputCloud (cloud);
  ne.setMethod (m);
  pcl::PointCloud<pcl::Normal> out;
  ne.compute (out);
  return out;
}

void
expectAllFinite (const pcl::PointCloud<pcl::Normal>& n)
{
  for (const auto& p : n)
  {
    ASSERT_TRUE (std::isfinite (p.normal_x) && std::isfinite (p.normal_y) && std::isfinite (p.normal_z) &&
                 std::isfinite (p.curvature));
  }
}

const Method kAll[] = {Method::OCTREE, Method::HYBRID, Method::MERGED};

}  // namespace

// --- exact normals -----------------------------------------------------------

TEST (PlanarOctreeNormals, ExactOnTiltedPlaneAllMethods)
{
  const auto truth = analyticPlane (5000, Eigen::Vector3f (0.3f, -0.5f, 0.8f), 2.f);
  const auto cloud = positions (truth);
  for (Method m : kAll)
  {
    const auto n = estimate (cloud, m);
    ASSERT_EQ (n.size (), cloud->size ());
    const auto s = compareNormals (n, truth);
    EXPECT_LT (s.max_deg, 0.01) << "method " << int (m);  // float positions only
    EXPECT_EQ (s.invalid, 0u);
  }
}

TEST (PlanarOctreeNormals, PerfectPlaneIsOnePlanarLeaf)
{
  const auto cloud = positions (analyticPlane (2000, Eigen::Vector3f::UnitZ (), 1.f));
  Estimator ne;
  estimate (cloud, Method::OCTREE, &ne);
  // The whole cloud passes λ2 > sα·λ3 (λ3 = 0) and sβ·λ2 > λ1 (a square): no split.
  EXPECT_EQ (ne.getOctree ().nodes ().size (), 1u);
  EXPECT_TRUE (ne.getOctree ().nodes ()[0].planar);
}

TEST (PlanarOctreeNormals, SphereMergedQuadricCloseToExactAndNoWorseThanPca)
{
  const auto truth = analyticSphere (20000, 1.f, Eigen::Vector3f (0.5f, -1.f, 2.f));
  const auto cloud = positions (truth);
  const auto pca = compareNormals (pcaNormals<pcl::PointXYZ> (cloud, 18), truth);
  const auto merged = compareNormals (estimate (cloud, Method::MERGED), truth);
  // The quadric height field of a sphere cap is exact to second order: sub-degree errors.
  EXPECT_LT (merged.mean_deg, 0.5);
  EXPECT_LT (merged.rms_deg, std::max (1.0, pca.rms_deg));
  EXPECT_EQ (merged.invalid, 0u);
}

TEST (PlanarOctreeNormals, SphereOctreeLeafPlanesAreBoundedByCellSize)
{
  // Musmanno's Algorithm 2: one plane per leaf, so the error grows with the leaf's angular size
  // but a leaf that passed λ2 > 6.25·λ3 cannot span a hemisphere.
  const auto truth = analyticSphere (20000, 1.f, Eigen::Vector3f::Zero ());
  const auto n = estimate (positions (truth), Method::OCTREE);
  const auto s = compareNormals (n, truth);
  EXPECT_LT (s.max_deg, 60.0);
  EXPECT_GT (s.mean_deg, 0.5);  // and it is visibly worse than exact: Musmanno's finding
}

// --- Algorithm 1 split behaviour -------------------------------------------------

TEST (PlanarOctreeSplit, StricterThresholdsNeverGiveFewerLeaves)
{
  const auto cloud = positions (analyticSphere (10000, 1.f, Eigen::Vector3f::Zero ()));
  int previous = 0;
  for (double s_alpha : {2.0, 6.25, 25.0, 100.0})
  {
    Estimator ne;
    ne.setPlanarityThresholds (s_alpha, 1.5);
    estimate (cloud, Method::OCTREE, &ne);
    const int leaves = ne.getOctree ().numLeaves ();
    EXPECT_GE (leaves, previous) << "s_alpha " << s_alpha;
    previous = leaves;
  }
}

TEST (PlanarOctreeSplit, PlanarLeavesPassMusmannosCriterionAndOthersDoNot)
{
  const auto s = pclx::testing::sampleUniform (pclx::testing::makeBox (Eigen::Vector3f::Ones (), 8), 20000);
  Estimator ne;
  estimate (positions (s.cloud), Method::OCTREE, &ne);
  int planar = 0;
  for (const auto& node : ne.getOctree ().nodes ())
  {
    if (!node.isLeaf () || node.size () < 3 || node.degenerate)
      continue;
    const auto& l = node.eigenvalues;
    const bool passes = l (1) > 6.25 * l (2) && 1.5 * l (1) > l (0) && node.size () >= ne.getMinPointsPerCell ();
    EXPECT_EQ (node.planar, passes);
    planar += node.planar;
    // A split node was not planar.
  }
  for (const auto& node : ne.getOctree ().nodes ())
    if (!node.isLeaf ())
      EXPECT_FALSE (node.planar);
  EXPECT_GT (planar, 6);  // every face of the box needs at least one planar leaf
}

// Box face of a ground-truth normal: axis * 2 + (positive side).
int
faceOf (const Eigen::Vector3f& t)
{
  int axis;
  t.cwiseAbs ().maxCoeff (&axis);
  return axis * 2 + (t[axis] > 0);
}

// Share of points in planar leaves (or regions) that are not on the leaf's majority face.
template <typename Group> double
minorityShare (const pclx::testing::SampledCloud& s, Group group_of)
{
  std::map<int, std::map<int, int>> faces;
  std::size_t total = 0;
  for (std::size_t i = 0; i < s.cloud.size (); ++i)
    if (const int g = group_of (i); g >= 0)
    {
      ++faces[g][faceOf (s.cloud[i].getNormalVector3fMap ())];
      ++total;
    }
  std::size_t minority = 0;
  for (const auto& [g, count] : faces)
  {
    int most = 0, sum = 0;
    for (const auto& kv : count)
    {
      most = std::max (most, kv.second);
      sum += kv.second;
    }
    minority += sum - most;
  }
  return total ? double (minority) / total : 0.0;
}

TEST (PlanarOctreeSplit, CellsAcrossABoxEdgeAreSplitAndPlanarLeavesAreMostlyOneFace)
{
  const auto s = pclx::testing::sampleUniform (pclx::testing::makeBox (Eigen::Vector3f::Ones (), 8), 20000);
  Estimator octree, strict;
  estimate (positions (s.cloud), Method::OCTREE, &octree);
  estimate (positions (s.cloud), Method::MERGED, &strict);  // sα = 25 + residual split
  EXPECT_FALSE (octree.getOctree ().nodes ()[0].planar);
  auto leafGroup = [] (const Estimator& e) {
    return [&e] (std::size_t i) {
      const int leaf = e.getOctree ().leafOfPoint ()[i];
      return e.getOctree ().nodes ()[leaf].planar ? leaf : -1;
    };
  };
  // Musmanno's criterion tolerates a thin strip of the neighbouring face in a "planar"
  // leaf (a known weakness); the stricter MERGED octree must hold less of it.
  const double octree_minority = minorityShare (s, leafGroup (octree));
  const double strict_minority = minorityShare (s, leafGroup (strict));
  EXPECT_LT (octree_minority, 0.05);
  EXPECT_LE (strict_minority, octree_minority);
  EXPECT_LT (strict_minority, 0.01);
}

TEST (PlanarOctreeSplit, IsotropicBlobHasNoPlanarLeaf)
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr blob (new pcl::PointCloud<pcl::PointXYZ>);
  std::mt19937 rng (5);
  std::uniform_real_distribution<float> u (-1, 1);
  for (int i = 0; i < 3000; ++i)
    blob->push_back (pcl::PointXYZ (u (rng), u (rng), u (rng)));
  Estimator ne;
  ne.setMinPointsPerCell (20);
  const auto n = estimate (blob, Method::OCTREE, &ne);
  EXPECT_EQ (ne.getOctree ().numPlanarLeaves (), 0);
  expectAllFinite (n);
}

// --- hybrid borders -----------------------------------------------------------

TEST (PlanarOctreeHybrid, BorderPointsUseKnnPcaAndInnerPointsTheLeafPlane)
{
  const auto truth = analyticSphere (20000, 1.f, Eigen::Vector3f::Zero ());
  const auto cloud = positions (truth);
  Estimator ne;
  ne.setBorderRatio (0.3);
  const auto n = estimate (cloud, Method::HYBRID, &ne);
  const auto& tree = ne.getOctree ();
  std::size_t border = 0, inner = 0;
  for (std::size_t i = 0; i < cloud->size (); ++i)
  {
    const int leaf = tree.locate ((*cloud)[i].getVector3fMap ());
    if (!tree.nodes ()[leaf].planar)
      continue;
    const float d = tree.relativeCentreDistance (leaf, (*cloud)[i].getVector3fMap ());
    if (d > 0.7f)
    {
      ++border;
      EXPECT_EQ (ne.getPointStatus ()[i], Estimator::KNN_PCA);
    }
    else
    {
      ++inner;
      EXPECT_EQ (ne.getPointStatus ()[i], Estimator::LEAF_PLANE);
      EXPECT_EQ (ne.getRegionIds ()[i], leaf);
    }
  }
  EXPECT_GT (border, 0u);
  EXPECT_GT (inner, 0u);
  // Border points get Hoppe's estimate, which on a clean sphere beats the leaf planes.
  const auto octree = compareNormals (estimate (cloud, Method::OCTREE), truth);
  EXPECT_LT (compareNormals (n, truth).rms_deg, octree.rms_deg);
}

TEST (PlanarOctreeHybrid, ZeroBorderRatioKeepsEveryPlanarLeafPoint)
{
  const auto cloud = positions (analyticSphere (5000, 1.f, Eigen::Vector3f::Zero ()));
  Estimator ne;
  ne.setBorderRatio (0.0);
  estimate (cloud, Method::HYBRID, &ne);
  for (std::size_t i = 0; i < cloud->size (); ++i)
    if (ne.getOctree ().nodes ()[ne.getOctree ().leafOfPoint ()[i]].planar)
      EXPECT_EQ (ne.getPointStatus ()[i], Estimator::LEAF_PLANE);
}

// --- merge (Musmanno 2016, ch. 7) ----------------------------------------------------------

TEST (PlanarOctreeMerge, BoxFacesBecomeOneRegionEachWithoutMixingFaces)
{
  const auto s = pclx::testing::sampleUniform (pclx::testing::makeBox (Eigen::Vector3f::Ones (), 8), 30000);
  Estimator ne;
  const auto n = estimate (positions (s.cloud), Method::MERGED, &ne);
  const auto& tree = ne.getOctree ();
  EXPECT_GT (tree.numPlanarLeaves (), 6);  // the octree cut every face into several leaves
  // Regions do not merge faces: points off their region's majority face are rare.
  EXPECT_LT (minorityShare (s, [&] (std::size_t i) { return ne.getRegionIds ()[i]; }), 0.01);
  std::map<int, std::size_t> size_of_region;
  for (std::size_t i = 0; i < s.cloud.size (); ++i)
    if (ne.getRegionIds ()[i] >= 0)
      ++size_of_region[ne.getRegionIds ()[i]];
  // Six regions hold nearly every point: one per face.
  std::vector<std::size_t> sizes;
  for (const auto& kv : size_of_region)
    sizes.push_back (kv.second);
  std::sort (sizes.rbegin (), sizes.rend ());
  ASSERT_GE (sizes.size (), 6u);
  const std::size_t top6 = std::accumulate (sizes.begin (), sizes.begin () + 6, std::size_t (0));
  EXPECT_GT (top6, 0.9 * s.cloud.size ());
  // ... and clean faces then get exact normals, sharp edges included.
  const auto err = compareNormals (n, s.cloud);
  EXPECT_GT (err.below5, 0.97);
}

TEST (PlanarOctreeMerge, CurvedSurfaceDoesNotChainIntoOneRegion)
{
  const auto truth = analyticSphere (20000, 1.f, Eigen::Vector3f::Zero ());
  Estimator ne;
  estimate (positions (truth), Method::MERGED, &ne);
  // Per region, the widest spread of true normals stays far below a hemisphere.
  std::map<int, Eigen::Vector3f> first;
  double worst = 0;
  for (std::size_t i = 0; i < truth.size (); ++i)
  {
    const int r = ne.getRegionIds ()[i];
    if (r < 0)
      continue;
    const Eigen::Vector3f t = truth[i].getNormalVector3fMap ();
    auto it = first.emplace (r, t).first;
    worst = std::max (worst, std::acos (std::min (1.0, double (it->second.dot (t)))) * 180 / M_PI);
  }
  EXPECT_GT (first.size (), 8u);
  EXPECT_LT (worst, 90.0);
}

TEST (PlanarOctreeMerge, NoisyFacesGetLargeSupportsAwayFromEdges)
{
  // On noisy input (noise > 0.15 spacing) regions are not used (shape smaller than the
  // noise hid in their fits: fertility σ = 0.0012 lost 2°); the ladder serves every point
  // and takes large supports on flat faces. Before the ladder, merged regions gave 90 %
  // of these face points under 5°; the ladder gives 88 %, and 0.1–0.5° better RMS overall.
  auto s = pclx::testing::sampleUniform (pclx::testing::makeBox (Eigen::Vector3f::Ones (), 8), 30000);
  pclx::testing::addGaussianNoise (s, 0.006f);
  const auto cloud = positions (s.cloud);
  Estimator ne;
  const auto n = estimate (cloud, Method::MERGED, &ne);
  const auto p = pcaNormals<pcl::PointXYZ> (cloud, 18);
  EXPECT_LT (compareNormals (n, s.cloud).rms_deg, compareNormals (p, s.cloud).rms_deg);
  const float sigma = 0.006f * std::sqrt (3.f), half = 0.5f;
  pcl::PointCloud<pcl::Normal> n_in, p_in;
  pcl::PointCloud<pcl::PointNormal> t_in;
  for (std::size_t i = 0; i < s.cloud.size (); ++i)
  {
    const Eigen::Vector3f x = s.cloud[i].getVector3fMap ();
    const int axis = faceOf (s.cloud[i].getNormalVector3fMap ()) / 2;
    float to_edge = 1e9f;
    for (int a = 0; a < 3; ++a)
      if (a != axis)
        to_edge = std::min (to_edge, half - std::abs (x[a]));
    if (to_edge > 5 * sigma)
    {
      n_in.push_back (n[i]);
      p_in.push_back (p[i]);
      t_in.push_back (s.cloud[i]);
      EXPECT_EQ (ne.getPointStatus ()[i], Estimator::KNN_PCA);
    }
  }
  ASSERT_GT (t_in.size (), s.cloud.size () / 2);
  EXPECT_GT (compareNormals (n_in, t_in).below5, 0.85);
  EXPECT_LT (compareNormals (n_in, t_in).rms_deg, 0.25 * compareNormals (p_in, t_in).rms_deg);
}

TEST (PlanarOctreeMerge, NoisySphereBeatsPca)
{
  auto s = pclx::testing::sampleUniform (pclx::testing::makeSphere (1.f, 5), 30000);
  pclx::testing::addGaussianNoise (s, 0.006f);
  const auto cloud = positions (s.cloud);
  const auto pca = compareNormals (pcaNormals<pcl::PointXYZ> (cloud, 18), s.cloud);
  const auto merged = compareNormals (estimate (cloud, Method::MERGED), s.cloud);
  EXPECT_LT (merged.rms_deg, pca.rms_deg);
}

TEST (PlanarOctreeMerge, AdaptiveKnnStopsAtTheRimOfAThinPlate)
{
  // Growing a rim point's neighbourhood brings in both sheets, which look more planar than
  // the rim: without the one-sided stop, 400 neighbours left 15 % of the rim within 45°.
  const auto s = pclx::testing::sampleUniform (pclx::testing::makeThinPlate (1.f, 0.02f, 32), 30000, 6);
  const auto cloud = positions (s.cloud);
  Estimator ne;
  ne.setMaxAdaptiveNeighbours (400);
  const auto out = estimate (cloud, Method::MERGED, &ne);
  std::size_t rim = 0, kept = 0;
  for (std::size_t i = 0; i < out.size (); ++i)
    if (std::abs (s.cloud[i].normal_z) < 0.5f)
    {
      ++rim;
      kept += std::abs (out[i].getNormalVector3fMap ().dot (s.cloud[i].getNormalVector3fMap ())) > 0.7f;
    }
  ASSERT_GT (rim, 500u);
  EXPECT_GT (static_cast<double> (kept) / rim, 0.8);
}

// --- scale selection (MERGED: Lepski ladder over kNN supports) --------------------

namespace {
double
medianOf (std::vector<int> v)
{
  if (v.empty ())
    return 0;
  std::nth_element (v.begin (), v.begin () + v.size () / 2, v.end ());
  return v[v.size () / 2];
}
}  // namespace

TEST (PlanarOctreeScale, NoiseEstimateTracksTheAddedNoise)
{
  const auto clean = pclx::testing::sampleUniform (pclx::testing::makeSphere (1.f, 5), 20000, 3);
  for (float fraction : {0.f, 0.002f, 0.006f})
  {
    auto s = clean;
    if (fraction > 0)
      pclx::testing::addGaussianNoise (s, fraction, 5);
    Estimator ne;
    estimate (positions (s.cloud), Method::MERGED, &ne);
    const double truth = fraction * 2 * std::sqrt (3.0);  // σ = fraction × bounding-box diagonal
    const auto& e = ne.getNoiseEstimate ();
    EXPECT_GT (e.samples, 1000);
    EXPECT_GT (e.spacing, 0.0);
    if (fraction == 0)
      EXPECT_LT (e.sigma, 0.02 * e.spacing);  // the icosphere's facets, not noise
    else
      EXPECT_NEAR (e.sigma, truth, 0.2 * truth) << "fraction " << fraction;
  }
}

TEST (PlanarOctreeScale, SupportGrowsWithTheNoiseOnASphere)
{
  // Measured medians: 15, 18, 35, 400 (patches while the noise is < 0.15 spacing, then
  // the ladder; on a sphere of 5000 points 800 neighbours bend too much to be taken).
  const auto clean = pclx::testing::sampleUniform (pclx::testing::makeSphere (1.f, 5), 5000, 4);
  double previous = 0;
  for (float fraction : {0.f, 0.001f, 0.002f, 0.004f})
  {
    auto s = clean;
    if (fraction > 0)
      pclx::testing::addGaussianNoise (s, fraction, 9);
    Estimator ne;
    ne.setMaxAdaptiveNeighbours (800);  // room above the default's top rung (200)
    const auto out = estimate (positions (s.cloud), Method::MERGED, &ne);
    const auto& support = ne.getSupportSizes ();
    ASSERT_EQ (support.size (), out.size ());
    EXPECT_EQ (*std::min_element (support.begin (), support.end ()) > 0, true);
    const double median = medianOf (support);
    EXPECT_GT (median, previous) << "fraction " << fraction;
    previous = median;
    // The ladder's choice never exceeds its top rung.
    for (std::size_t i = 0; i < out.size (); ++i)
      if (ne.getPointStatus ()[i] == Estimator::KNN_PCA)
        ASSERT_LE (support[i], ne.getMaxAdaptiveNeighbours ());
  }
  EXPECT_GE (previous, 200);  // σ = 0.004 of the diagonal: large supports
}

TEST (PlanarOctreeScale, SupportShrinksNearABoxEdge)
{
  // Noisy enough for the ladder to serve every point: across an edge the normals of
  // growing supports disagree, so points near an edge stop at smaller supports.
  auto s = pclx::testing::sampleUniform (pclx::testing::makeBox (Eigen::Vector3f::Ones (), 8), 30000, 2);
  pclx::testing::addGaussianNoise (s, 0.002f, 3);
  Estimator ne;
  const auto out = estimate (positions (s.cloud), Method::MERGED, &ne);
  const double spacing = ne.getNoiseEstimate ().spacing;
  ASSERT_GT (spacing, 0.0);
  std::vector<int> near_edge, centre;
  for (std::size_t i = 0; i < out.size (); ++i)
  {
    if (ne.getPointStatus ()[i] != Estimator::KNN_PCA)
      continue;
    const Eigen::Vector3f x = s.cloud[i].getVector3fMap ();
    const int axis = faceOf (s.cloud[i].getNormalVector3fMap ()) / 2;
    float to_edge = 1e9f;
    for (int a = 0; a < 3; ++a)
      if (a != axis)
        to_edge = std::min (to_edge, 0.5f - std::abs (x[a]));
    if (to_edge < 2 * spacing)
      near_edge.push_back (ne.getSupportSizes ()[i]);
    else if (to_edge > 12 * spacing)
      centre.push_back (ne.getSupportSizes ()[i]);
  }
  ASSERT_GT (near_edge.size (), 500u);
  ASSERT_GT (centre.size (), 5000u);
  EXPECT_LT (medianOf (near_edge), 0.5 * medianOf (centre));
}

TEST (PlanarOctreeScale, SharedRungIsCheckedByEachMemberWhenAsked)
{
  // Noise wider than a spacing: one ladder per cell, at its centroid. A member whose own
  // ladder refuses that rung (near an edge its larger support reaches the other face)
  // takes it anyway, unless setCheckSharedRung: then each member checks the shared rung on
  // its own neighbours and climbs its own ladder when refused, so no point's support
  // exceeds what its own ladder (selectScale over its exact neighbours) chooses, except
  // where that ladder refuses a rung for a reason the check does not read (a smaller rung
  // than the one below). Measured: 7.0 % of the points without the check (the default; 6.1 %
  // with a check that skipped the residual test), 0.03 % with it.
  auto s = pclx::testing::sampleUniform (pclx::testing::makeBox (Eigen::Vector3f::Ones (), 8), 30000, 2);
  pclx::testing::addGaussianNoise (s, 0.01f, 3);
  const auto cloud = positions (s.cloud);
  for (const bool check : {false, true})
  {
    Estimator ne;
    EXPECT_FALSE (ne.getCheckSharedRung ());
    ne.setCheckSharedRung (check);
    const auto out = estimate (cloud, Method::MERGED, &ne);
    const auto& noise = ne.getNoiseEstimate ();
    ASSERT_GT (noise.ratio (), 1.0);  // share mode
    pcl::search::KdTree<pcl::PointXYZ> tree;
    tree.setInputCloud (cloud);
    const std::vector<int> rungs = pclx::normals::detail::ladderRungs (Estimator::kDefaultNeighbours, ne.getMaxAdaptiveNeighbours ());
    int checked = 0, larger = 0;
    pcl::Indices nn;
    std::vector<float> d2;
    std::vector<Eigen::Vector3f> sorted;
    for (std::size_t i = 0; i < out.size (); ++i)
    {
      if (ne.getPointStatus ()[i] != Estimator::KNN_PCA)
        continue;
      tree.nearestKSearch ((*cloud)[i], ne.getMaxAdaptiveNeighbours (), nn, d2);
      sorted.clear ();
      for (const auto j : nn)
        sorted.push_back ((*cloud)[j].getVector3fMap ());
      const auto own = pclx::normals::detail::selectScale ((*cloud)[i].getVector3fMap (), sorted, rungs,
                                                   noise.sigma * noise.sigma, ne.getScaleAgreement ());
      ++checked;
      larger += own.ok && ne.getSupportSizes ()[i] > own.support;
    }
    ASSERT_GT (checked, 25000);
    if (check)
      EXPECT_LT (larger, checked / 500);  // < 0.2 %
    else
      EXPECT_GT (larger, checked / 50);  // > 2 %: what the check is for
  }
}

TEST (PlanarOctreeScale, LadderRungs)
{
  using pclx::normals::detail::ladderRungs;
  EXPECT_EQ (ladderRungs (18, 200), (std::vector<int>{12, 18, 30, 50, 100, 200}));
  EXPECT_EQ (ladderRungs (6, 50), (std::vector<int>{6, 12, 18, 30, 50}));
  EXPECT_EQ (ladderRungs (18, 1000), (std::vector<int>{12, 18, 30, 50, 100, 200, 400, 800, 1000}));
  EXPECT_EQ (ladderRungs (18, 40), (std::vector<int>{12, 18, 30, 40}));
}

// --- patches (MERGED) ------------------------------------------------------------

namespace {
std::size_t
countStatus (const Estimator& ne, std::uint8_t status)
{
  const auto& st = ne.getPointStatus ();
  return static_cast<std::size_t> (std::count (st.begin (), st.end (), status));
}
}  // namespace

TEST (PlanarOctreePatches, SphereNormalsComeFromPatchesWithoutKnn)
{
  const auto truth = analyticSphere (20000, 1.f, Eigen::Vector3f (0.5f, -1.f, 2.f));
  const auto cloud = positions (truth);
  Estimator ne;
  const auto out = estimate (cloud, Method::MERGED, &ne);
  // A smooth closed surface: every leaf is planar at some depth, so (almost) no point
  // needs a kNN search. Sub-degree errors; measured 0.50° against PCA's 0.42° here (an
  // 18-point quadric has 6 unknowns) and 0.17° against 0.19° at 100k points.
  EXPECT_GT (countStatus (ne, Estimator::PATCH_FIT) + countStatus (ne, Estimator::REGION_FIT), 0.98 * cloud->size ());
  EXPECT_GT (countStatus (ne, Estimator::PATCH_FIT), 0.5 * cloud->size ());
  const auto e = compareNormals (out, truth);
  EXPECT_LT (e.rms_deg, 0.6);
  EXPECT_LT (e.rms_deg, 1.4 * compareNormals (pcaNormals<pcl::PointXYZ> (cloud, 18), truth).rms_deg);
}

TEST (PlanarOctreePatches, CellsHoldAtMostMaxPointsAndCoverEveryPlanarLeafPoint)
{
  const auto s = pclx::testing::sampleUniform (pclx::testing::makeTorus (1.f, 0.3f, 128, 48), 20000, 5);
  const auto cloud = positions (s.cloud);
  for (int max_points : {1, 4, 16})
  {
    Estimator ne;
    ne.setPatchSize (max_points);
    estimate (cloud, Method::MERGED, &ne);
    const auto& oct = ne.getOctree ();
    const auto& nodes = oct.nodes ();
    std::size_t covered = 0;
    for (std::size_t i = 0; i < oct.leafOfPoint ().size (); ++i)
    {
      const int leaf = oct.leafOfPoint ()[i];
      const int fit = oct.patchOfPoint ()[i];
      if (!nodes[leaf].planar)
      {
        EXPECT_EQ (fit, -1);
        continue;
      }
      ASSERT_GE (fit, 0);
      EXPECT_EQ (oct.patches ()[fit].leaf, leaf);
      ++covered;
    }
    EXPECT_GT (covered, cloud->size () / 2);
    for (std::size_t id = 0; id < nodes.size (); ++id)
      for (const auto& cell : oct.patchCellsOfLeaf (static_cast<int> (id)))
        if (cell.first_child < 0)
          EXPECT_LE (cell.end - cell.begin, max_points);
  }
}

TEST (PlanarOctreePatches, BoxEdgesDoNotBendPatches)
{
  // Near an edge a larger disc reaches the other face: Lepski's rule must refuse it (the
  // normal jumps), else the quadric folds and patches near edges lose to the kNN plane.
  const auto s =
      pclx::testing::sampleUniform (pclx::testing::makeBox (Eigen::Vector3f (1.f, 0.6f, 0.4f), 16), 30000, 6);
  const auto cloud = positions (s.cloud);
  Estimator ne;
  const auto ours = compareNormals (estimate (cloud, Method::MERGED, &ne), s.cloud);
  const auto pca = compareNormals (pcaNormals<pcl::PointXYZ> (cloud, 18), s.cloud);
  EXPECT_GT (countStatus (ne, Estimator::PATCH_FIT), 0.3 * cloud->size ());
  EXPECT_LT (ours.rms_deg, pca.rms_deg);
  EXPECT_GE (ours.below10, pca.below10);
}

TEST (PlanarOctreePatches, UncertainPatchesAreNotUsed)
{
  // Noise: every patch that is used has a slope certain to the set limit; the others
  // leave their points to regions or kNN.
  pclx::testing::SampledCloud noisy;
  noisy.cloud = analyticPlane (20000, Eigen::Vector3f (0.2f, 0.3f, 1.f), 1.f);
  pclx::testing::addGaussianNoise (noisy, 0.003f, 9);
  const auto cloud = positions (noisy.cloud);
  Estimator ne;
  ne.setMaxPatchSlopeError (1.0);
  ne.setMaxPatchNoiseRatio (1e9);   // keep patches (and regions) on noisy input
  ne.setRegionValidationRatio (0);  // regions are always used then: only patches are judged
  estimate (cloud, Method::MERGED, &ne);
  const double limit = std::tan (1.0 * M_PI / 180.0);
  std::size_t valid = 0, invalid = 0;
  for (const auto& P : ne.getOctree ().patches ())
  {
    if (P.valid)
    {
      EXPECT_LE (P.slope_sigma, limit + 1e-6);
      ++valid;
    }
    else
      ++invalid;
  }
  EXPECT_GT (valid + invalid, 0u);
  const auto& st = ne.getPointStatus ();
  const auto& fit_of = ne.getOctree ().patchOfPoint ();
  for (std::size_t i = 0; i < st.size (); ++i)
    if (st[i] == Estimator::PATCH_FIT)
    {
      ASSERT_GE (fit_of[i], 0);
      EXPECT_TRUE (ne.getOctree ().patches ()[fit_of[i]].valid);
    }
}

TEST (PlanarOctreePatches, PatchSizeZeroLeavesPatchesOut)
{
  const auto truth = analyticSphere (5000, 1.f, Eigen::Vector3f::Zero ());
  const auto cloud = positions (truth);
  Estimator ne;
  ne.setPatchSize (0);
  const auto out = estimate (cloud, Method::MERGED, &ne);
  EXPECT_EQ (countStatus (ne, Estimator::PATCH_FIT), 0u);
  EXPECT_TRUE (ne.getOctree ().patches ().empty ());
  EXPECT_LT (compareNormals (out, truth).rms_deg, 2.0);
}

TEST (PlanarOctreePatches, WithoutPatchesRegionsAreStillValidated)
{
  // setPatchSize (0): a merged region is kept only if its surface is as thin as kNN planes
  // sampled inside it; without that check curved and folded regions swallowed their points
  // (the box's faces bent over its edges: 23.7° RMS against PCA k = 18's 9.3°).
  const auto s =
      pclx::testing::sampleUniform (pclx::testing::makeBox (Eigen::Vector3f (1.f, 0.6f, 0.4f), 16), 30000, 6);
  const auto cloud = positions (s.cloud);
  Estimator ne;
  ne.setPatchSize (0);
  const auto ours = compareNormals (estimate (cloud, Method::MERGED, &ne), s.cloud);
  const auto pca = compareNormals (pcaNormals<pcl::PointXYZ> (cloud, 18), s.cloud);
  EXPECT_EQ (countStatus (ne, Estimator::PATCH_FIT), 0u);
  EXPECT_LT (ours.rms_deg, pca.rms_deg);
}

// --- PCL feature semantics -------------------------------------------------------

TEST (PlanarOctreeFeature, IndicesSelectTheOutputAndMatchTheFullRun)
{
  const auto truth = analyticSphere (8000, 1.f, Eigen::Vector3f::Zero ());
  const auto cloud = positions (truth);
  for (Method m : kAll)
  {
    const auto full = estimate (cloud, m);
    pcl::IndicesPtr idx (new pcl::Indices);
    for (int i = 0; i < static_cast<int> (cloud->size ()); i += 7)
      idx->push_back (i);
    Estimator ne;
    ne.setInputCloud (cloud);
    ne.setIndices (idx);
    ne.setMethod (m);
    pcl::PointCloud<pcl::Normal> part;
    ne.compute (part);
    ASSERT_EQ (part.size (), idx->size ());
    ASSERT_EQ (ne.getPointStatus ().size (), idx->size ());
    for (std::size_t k = 0; k < idx->size (); ++k)
      EXPECT_LT ((part[k].getNormalVector3fMap () - full[(*idx)[k]].getNormalVector3fMap ()).norm (), 1e-5f);
  }
}

TEST (PlanarOctreeFeature, SearchSurfaceIsUsedForTheOctreeAndNeighbours)
{
  const auto truth = analyticSphere (8000, 1.f, Eigen::Vector3f::Zero ());
  const auto surface = positions (truth);
  pcl::PointCloud<pcl::PointXYZ>::Ptr sparse (new pcl::PointCloud<pcl::PointXYZ>);
  for (std::size_t i = 0; i < surface->size (); i += 20)
    sparse->push_back ((*surface)[i]);
  for (Method m : kAll)
  {
    Estimator whole;
    const auto full = estimate (surface, m, &whole);
    Estimator ne;
    ne.setInputCloud (sparse);
    ne.setSearchSurface (surface);
    ne.setMethod (m);
    pcl::PointCloud<pcl::Normal> out;
    ne.compute (out);
    ASSERT_EQ (out.size (), sparse->size ());
    EXPECT_EQ (ne.getOctree ().order ().size (), surface->size ());
    for (std::size_t k = 0; k < sparse->size (); ++k)
    {
      EXPECT_LT ((out[k].getNormalVector3fMap () - full[k * 20].getNormalVector3fMap ()).norm (), 1e-5f);
      // Region and patch points: the full run reads them from per-point arrays, this run
      // from octree nodes (other input than the surface); both must agree.
      const auto st = whole.getPointStatus ()[k * 20];
      if (st == Estimator::REGION_FIT || st == Estimator::PATCH_FIT)
      {
        EXPECT_EQ (ne.getPointStatus ()[k], st);
        EXPECT_EQ (ne.getRegionIds ()[k], whole.getRegionIds ()[k * 20]);
        EXPECT_EQ (ne.getSupportSizes ()[k], whole.getSupportSizes ()[k * 20]);
      }
    }
  }
}

TEST (PlanarOctreeFeature, OtherPointAndNormalTypes)
{
  auto truth = analyticSphere (3000, 1.f, Eigen::Vector3f::Zero ());
  pcl::PointCloud<pcl::PointNormal>::Ptr in (new pcl::PointCloud<pcl::PointNormal> (truth));
  pcl::PlanarOctreeNormalEstimation<pcl::PointNormal, pcl::PointNormal> ne;
  ne.setInputCloud (in);
  pcl::PointCloud<pcl::PointNormal> out;
  ne.compute (out);
  ASSERT_EQ (out.size (), in->size ());
  EXPECT_LT (compareNormals (out, truth).mean_deg, 2.0);
}

TEST (PlanarOctreeFeature, NoSearchMethodGivenUsesADefaultKdTree)
{
  const auto cloud = positions (analyticSphere (3000, 1.f, Eigen::Vector3f::Zero ()));
  Estimator ne;
  ne.setSearchMethod (nullptr);
  ne.setMethod (Method::HYBRID);
  const auto n = estimate (cloud, Method::HYBRID, &ne);
  EXPECT_EQ (n.size (), cloud->size ());
  expectAllFinite (n);
}

TEST (PlanarOctreeFeature, DefaultSearchMatchesAUserKdTreeAndBuildsNoTreeOnCleanInput)
{
  // Without a search method, MERGED searches a grid and leaves the kd-tree unbuilt; a
  // user's tree is used as given; both give the same normals.
  const auto cloud = positions (analyticSphere (20000, 1.f, Eigen::Vector3f::Zero ()));
  Estimator lazy;
  const auto a = estimate (cloud, Method::MERGED, &lazy);
  const auto tree = std::dynamic_pointer_cast<pclx::normals::detail::LazyKdTree<pcl::PointXYZ>> (lazy.getSearchMethod ());
  ASSERT_TRUE (tree);
  EXPECT_FALSE (tree->isBuilt ());
  const int knn = static_cast<int> (std::count (lazy.getPointStatus ().begin (), lazy.getPointStatus ().end (),
                                                static_cast<std::uint8_t> (Estimator::KNN_PCA)));
  EXPECT_GT (knn, 0);  // the grid served some points
  Estimator user;
  pcl::search::KdTree<pcl::PointXYZ>::Ptr kd (new pcl::search::KdTree<pcl::PointXYZ>);
  user.setSearchMethod (kd);
  const auto b = estimate (cloud, Method::MERGED, &user);
  EXPECT_EQ (user.getSearchMethod (), kd);
  ASSERT_EQ (a.size (), b.size ());
  int differ = 0;
  for (std::size_t i = 0; i < a.size (); ++i)
    differ += (a[i].getNormalVector3fMap () - b[i].getNormalVector3fMap ()).norm () > 1e-4f;
  EXPECT_LE (differ, static_cast<int> (a.size () / 1000));  // equidistant neighbours may swap
  // A second input on the same estimator rebuilds nothing stale.
  const auto moved = positions (analyticSphere (5000, 2.f, Eigen::Vector3f (3.f, 0.f, 0.f)));
  const auto c = estimate (moved, Method::MERGED, &lazy);
  EXPECT_LT (compareNormals (c, analyticSphere (5000, 2.f, Eigen::Vector3f (3.f, 0.f, 0.f))).mean_deg, 2.0);
}

TEST (GridKnn, MatchesBruteForce)
{
  std::mt19937 rng (7);
  std::normal_distribution<float> g (0.f, 1.f);
  std::uniform_real_distribution<float> u (-3.f, 3.f);
  // A sphere, a dense cluster and a far outlier: uneven density across cells.
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < 20000; ++i)
    pts.push_back (Eigen::Vector3f (g (rng), g (rng), g (rng)).normalized ());
  for (int i = 0; i < 3000; ++i)
    pts.push_back (Eigen::Vector3f (0.5f, 0.f, 0.f) + 1e-3f * Eigen::Vector3f (g (rng), g (rng), g (rng)));
  pts.push_back (Eigen::Vector3f (40.f, -7.f, 3.f));
  pclx::normals::detail::GridKnn grid;
  grid.build (pts, 16, 2);
  std::vector<int> ids;
  std::vector<float> d2;
  std::vector<std::uint64_t> scratch;
  for (int t = 0; t < 200; ++t)
  {
    const Eigen::Vector3f q = t % 4 == 0 ? Eigen::Vector3f (u (rng), u (rng), u (rng)) : pts[rng () % pts.size ()];
    const int k = 1 + static_cast<int> (rng () % 300);
    ASSERT_EQ (grid.nearestK (q, k, ids, d2, scratch), k);
    std::vector<float> all (pts.size ());
    for (std::size_t i = 0; i < pts.size (); ++i)
      all[i] = (pts[i] - q).squaredNorm ();
    std::nth_element (all.begin (), all.begin () + (k - 1), all.end ());
    const float kth = all[k - 1];
    for (int i = 0; i < k; ++i)
    {
      EXPECT_LE (d2[i], kth);
      EXPECT_FLOAT_EQ (d2[i], (pts[ids[i]] - q).squaredNorm ());
    }
    EXPECT_FLOAT_EQ (*std::max_element (d2.begin (), d2.end ()), kth);
    std::set<int> unique (ids.begin (), ids.end ());
    EXPECT_EQ (unique.size (), ids.size ());
  }
  // More than the cloud holds: all of it; a query far away still terminates.
  EXPECT_EQ (grid.nearestK (Eigen::Vector3f (1e6f, 1e6f, -1e6f), 30000, ids, d2, scratch), static_cast<int> (pts.size ()));
  pclx::normals::detail::GridKnn empty;
  empty.build ({}, 16, 1);
  EXPECT_EQ (empty.nearestK (Eigen::Vector3f::Zero (), 5, ids, d2, scratch), 0);
}

// A radius hint only changes which cells are scanned first: any hint (too small, too large,
// stale from a far query, zero) gives the same neighbours as none, and it is updated.
TEST (GridKnn, RadiusHintGivesTheSameNeighbours)
{
  std::mt19937 rng (5);
  std::normal_distribution<float> g (0.f, 1.f);
  std::uniform_real_distribution<float> u (-2.f, 2.f);
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < 20000; ++i)
    pts.push_back (Eigen::Vector3f (g (rng), g (rng), 0.2f * g (rng)).normalized () * (1.f + 0.02f * g (rng)));
  for (int i = 0; i < 2000; ++i)  // a dense cluster: the hint from a sparse region is far too large there
    pts.push_back (Eigen::Vector3f (0.f, 0.f, 1.f) + 1e-3f * Eigen::Vector3f (g (rng), g (rng), g (rng)));
  // Small cells (many per ball): a cell missed at the ball's rim would show.
  pclx::normals::detail::GridKnn grid;
  grid.build (pts, 3, 2);
  std::vector<int> ids0, ids1;
  std::vector<float> d0, d1;
  std::vector<std::uint64_t> scratch;
  std::vector<Eigen::Vector3f> pos0, pos1;
  float hint = 0.f;
  int ball_answers = 0;
  for (int t = 0; t < 400; ++t)
  {
    // Mostly neighbouring queries (as the orphans come), some anywhere, some outside the grid.
    const Eigen::Vector3f q = t % 10 == 9 ? Eigen::Vector3f (u (rng), u (rng), 3.f * u (rng))
                                          : pts[(t * 37) % pts.size ()];
    const int k = t % 3 == 0 ? 229 : 66;
    if (t % 50 == 7)
      hint = 1e-6f;  // far too small: falls back to the rings
    if (t % 50 == 19)
      hint = 10.f;  // far too large: scans much, same answer
    const float before = hint;
    ASSERT_EQ (grid.nearestK (q, k, ids0, d0, scratch, &pos0), k);
    ASSERT_EQ (grid.nearestK (q, k, ids1, d1, scratch, &pos1, &hint), k);
    ball_answers += before > 0 && before * before >= *std::max_element (d1.begin (), d1.end ());
    EXPECT_GT (hint, 0.f);
    EXPECT_FLOAT_EQ (hint, 1.15f * std::sqrt (*std::max_element (d1.begin (), d1.end ())));
    // Same set (the order within it may differ), same distances and positions per id.
    std::vector<std::pair<int, float>> a, b;
    for (int i = 0; i < k; ++i)
    {
      a.emplace_back (ids0[i], d0[i]);
      b.emplace_back (ids1[i], d1[i]);
      EXPECT_EQ (pos1[i], pts[ids1[i]]);
    }
    std::sort (a.begin (), a.end ());
    std::sort (b.begin (), b.end ());
    EXPECT_EQ (a, b) << "query " << t;
  }
  EXPECT_GT (ball_answers, 200);  // the hinted ball did answer most queries
}

// The grid's radix sort and the octree's bounds and copies run in parallel: any thread
// count must give the serial order (the answers' order and the cells' ranges depend on it).
TEST (GridKnn, ThreadCountDoesNotChangeTheOrder)
{
  std::mt19937 rng (11);
  std::normal_distribution<float> g (0.f, 1.f);
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < 30000; ++i)
    pts.push_back (Eigen::Vector3f (g (rng), g (rng), 0.3f * g (rng)).normalized () * (1.f + 0.01f * g (rng)));
  pclx::normals::detail::GridKnn serial, parallel;
  serial.build (pts, 24, 1);
  std::vector<int> ids1, ids3;
  std::vector<float> d1, d3;
  std::vector<std::uint64_t> scratch;
  std::vector<Eigen::Vector3f> pos1, pos3;
  for (int threads : {2, 3, 7})
  {
    parallel.build (pts, 24, threads);
    for (int t = 0; t < 100; ++t)
    {
      const Eigen::Vector3f q = pts[(t * 7919) % pts.size ()];
      ASSERT_EQ (serial.nearestK (q, 66, ids1, d1, scratch, &pos1), 66);
      ASSERT_EQ (parallel.nearestK (q, 66, ids3, d3, scratch, &pos3), 66);
      EXPECT_EQ (ids1, ids3) << threads << " threads";
      EXPECT_EQ (d1, d3);
      EXPECT_EQ (pos1, pos3);
    }
  }
  pclx::normals::detail::PlanarOctreeParams params;
  pclx::normals::detail::PlanarOctree a, b;
  params.threads = 1;
  a.build (pts, params);
  params.threads = 3;
  b.build (pts, params);
  EXPECT_EQ (a.order (), b.order ());
  EXPECT_EQ (a.leafOfPoint (), b.leafOfPoint ());
  EXPECT_EQ (a.origin (), b.origin ());
  ASSERT_EQ (a.nodes ().size (), b.nodes ().size ());
  EXPECT_EQ (a.nodes ()[0].center, b.nodes ()[0].center);
  EXPECT_EQ (a.nodes ()[0].half, b.nodes ()[0].half);
}

// The kNN selections order distanceSlotKey integers: the same order as (distance, slot)
// pairs, ties (and zero distances) included, and both halves read back exactly.
TEST (GridKnn, DistanceSlotKeysOrderLikePairs)
{
  std::mt19937 rng (3);
  std::uniform_real_distribution<float> u (0.f, 2.f);
  std::vector<std::pair<float, std::uint32_t>> pairs;
  for (std::uint32_t i = 0; i < 2000; ++i)
    pairs.emplace_back (i % 7 == 0 ? 0.f : (i % 5 == 0 ? 1.f : (i % 3 == 0 ? 1e-30f : u (rng) * u (rng))), 1999 - i);
  pairs.emplace_back (3e38f, 0xffffffffu);
  std::vector<std::uint64_t> keys;
  for (const auto& [d, slot] : pairs)
    keys.push_back (pclx::normals::detail::distanceSlotKey (d, slot));
  std::sort (pairs.begin (), pairs.end ());
  std::sort (keys.begin (), keys.end ());
  for (std::size_t i = 0; i < keys.size (); ++i)
  {
    EXPECT_EQ (pclx::normals::detail::distanceOfKey (keys[i]), pairs[i].first);
    EXPECT_EQ (pclx::normals::detail::slotOfKey (keys[i]), pairs[i].second);
  }
}

// --- bad inputs ------------------------------------------------------------------

TEST (PlanarOctreeBadInput, EmptyCloudGivesEmptyOutput)
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr empty (new pcl::PointCloud<pcl::PointXYZ>);
  for (Method m : kAll)
    EXPECT_TRUE (estimate (empty, m).empty ());
}

TEST (PlanarOctreeBadInput, NanAndInfPointsGetNanNormalsAndFlags)
{
  auto cloud = positions (analyticSphere (3000, 1.f, Eigen::Vector3f::Zero ()));
  const float nan = std::numeric_limits<float>::quiet_NaN (), inf = std::numeric_limits<float>::infinity ();
  (*cloud)[10].x = nan;
  (*cloud)[20].y = inf;
  (*cloud)[30].z = -inf;
  cloud->is_dense = false;
  for (Method m : kAll)
  {
    Estimator ne;
    const auto n = estimate (cloud, m, &ne);
    ASSERT_EQ (n.size (), cloud->size ());
    EXPECT_FALSE (n.is_dense);
    // As pcl::NormalEstimation: NaN for the invalid points, finite for every other.
    for (std::size_t i = 0; i < n.size (); ++i)
    {
      const bool bad = i == 10 || i == 20 || i == 30;
      EXPECT_EQ (ne.getPointStatus ()[i] == Estimator::INVALID_POINT, bad) << i;
      EXPECT_EQ (pcl::isFinite (n[i]), !bad) << i;
      EXPECT_EQ (std::isnan (n[i].curvature), bad) << i;
    }
    EXPECT_NEAR (n[0].getNormalVector3fMap ().norm (), 1.f, 1e-5f);
  }
}

TEST (PlanarOctreeBadInput, AllPointsIdenticalIsAnError)
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr same (new pcl::PointCloud<pcl::PointXYZ>);
  for (int i = 0; i < 100; ++i)
    same->push_back (pcl::PointXYZ (1, 2, 3));
  for (Method m : kAll)
    EXPECT_TRUE (estimate (same, m).empty ());
}

TEST (PlanarOctreeBadInput, CollinearCloudIsAnError)
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr line (new pcl::PointCloud<pcl::PointXYZ>);
  for (int i = 0; i < 100; ++i)
    line->push_back (pcl::PointXYZ (0.1f * i, 0.2f * i, -0.05f * i));
  for (Method m : kAll)
    EXPECT_TRUE (estimate (line, m).empty ());
}

TEST (PlanarOctreeBadInput, FewerPointsThanKStillGiveExactPlaneNormals)
{
  const auto truth = analyticPlane (10, Eigen::Vector3f (1, 1, 1), 1.f);
  for (Method m : kAll)
  {
    const auto n = estimate (positions (truth), m);  // k = 18 > 10 points
    ASSERT_EQ (n.size (), 10u);
    EXPECT_LT (compareNormals (n, truth).max_deg, 0.01);
  }
}

TEST (PlanarOctreeBadInput, BadThresholdsAreErrors)
{
  const auto cloud = positions (analyticSphere (500, 1.f, Eigen::Vector3f::Zero ()));
  auto run = [&] (auto configure) {
    Estimator ne;
    configure (ne);
    return estimate (cloud, ne.getMethod (), &ne).size ();
  };
  EXPECT_EQ (run ([] (Estimator& e) { e.setPlanarityThresholds (0, 1.5); }), 0u);
  EXPECT_EQ (run ([] (Estimator& e) { e.setPlanarityThresholds (6.25, -1); }), 0u);
  EXPECT_EQ (run ([] (Estimator& e) { e.setPlanarityThresholds (std::nan (""), 1.5); }), 0u);
  EXPECT_EQ (run ([] (Estimator& e) { e.setMinPointsPerCell (2); }), 0u);
  EXPECT_EQ (run ([] (Estimator& e) { e.setMaxDepth (-1); }), 0u);
  EXPECT_EQ (run ([] (Estimator& e) { e.setBorderRatio (1.0); }), 0u);
  EXPECT_EQ (run ([] (Estimator& e) { e.setMergeAngle (0); }), 0u);
  EXPECT_EQ (run ([] (Estimator& e) { e.setMergeThicknessFactor (0.5); }), 0u);
  EXPECT_EQ (run ([] (Estimator& e) { e.setAdoptionTolerance (0); }), 0u);
  EXPECT_EQ (run ([] (Estimator& e) { e.setPatchSize (-1); }), 0u);
  EXPECT_EQ (run ([] (Estimator& e) { e.setPatchSupport (2); }), 0u);
  EXPECT_EQ (run ([] (Estimator& e) { e.setPatchScales (0); }), 0u);
  EXPECT_EQ (run ([] (Estimator& e) { e.setMaxPatchSlopeError (0); }), 0u);
  EXPECT_EQ (run ([] (Estimator& e) { e.setScaleAgreement (0); }), 0u);
  EXPECT_EQ (run ([] (Estimator& e) { e.setScaleAgreement (std::nan ("")); }), 0u);
  EXPECT_EQ (run ([] (Estimator& e) { e.setMaxPatchNoiseRatio (-0.1); }), 0u);
  EXPECT_EQ (run ([] (Estimator& e) {
              e.setKSearch (10);
              e.setRadiusSearch (0.1);
            }),
             0u);  // both k and radius, as pcl::Feature
  EXPECT_EQ (run ([] (Estimator&) {}), cloud->size ());  // and the defaults work
}

TEST (PlanarOctreeBadInput, LastErrorKeepsTheRefusal)
{
  const auto cloud = positions (analyticSphere (500, 1.f, Eigen::Vector3f::Zero ()));
  Estimator ne;
  ne.setMergeAngle (0);
  EXPECT_EQ (estimate (cloud, ne.getMethod (), &ne).size (), 0u);
  EXPECT_NE (ne.getLastError ().find ("merge angle"), std::string::npos) << ne.getLastError ();
  ne.setMergeAngle (15);
  EXPECT_EQ (estimate (cloud, ne.getMethod (), &ne).size (), cloud->size ());
  EXPECT_TRUE (ne.getLastError ().empty ());
  pcl::PointCloud<pcl::PointXYZ>::Ptr line (new pcl::PointCloud<pcl::PointXYZ>);
  for (int i = 0; i < 100; ++i)
    line->push_back (pcl::PointXYZ (0.1f * i, 0.2f * i, -0.05f * i));
  EXPECT_TRUE (estimate (line, ne.getMethod (), &ne).empty ());
  EXPECT_NE (ne.getLastError ().find ("do not span a plane"), std::string::npos) << ne.getLastError ();
}

TEST (PlanarOctreeBadInput, DegenerateLocalCellsFallBackAndAreFlagged)
{
  // A plane plus a far tight cluster of duplicates and a short line: locally nothing
  // spans a plane there, so those points get the fallback normal (finite, flagged).
  auto cloud = positions (analyticPlane (2000, Eigen::Vector3f::UnitZ (), 1.f));
  for (int i = 0; i < 30; ++i)
    cloud->push_back (pcl::PointXYZ (5, 5, 5));
  for (int i = 0; i < 30; ++i)
    cloud->push_back (pcl::PointXYZ (-5, -5, -5 + 0.01f * i));
  for (Method m : kAll)
  {
    Estimator ne;
    ne.setMaxAdaptiveNeighbours (0);  // MERGED would otherwise grow kNN sets into the plane
    const auto n = estimate (cloud, m, &ne);
    ASSERT_EQ (n.size (), cloud->size ());
    expectAllFinite (n);
    int fallback = 0;
    for (std::size_t i = 2000; i < cloud->size (); ++i)
    {
      fallback += ne.getPointStatus ()[i] == Estimator::NEIGHBOUR_FALLBACK;
      EXPECT_NEAR (n[i].getNormalVector3fMap ().norm (), 1.f, 1e-4f);
    }
    EXPECT_GT (fallback, 0) << "method " << int (m);
  }
}

TEST (PlanarOctreeBadInput, RandomSmallCloudsNeverProduceNaN)
{
  std::mt19937 rng (11);
  std::uniform_int_distribution<int> size (3, 40), coord (-2, 2);  // many duplicates
  for (int trial = 0; trial < 200; ++trial)
  {
    pcl::PointCloud<pcl::PointXYZ>::Ptr c (new pcl::PointCloud<pcl::PointXYZ>);
    const int n = size (rng);
    for (int i = 0; i < n; ++i)
      c->push_back (pcl::PointXYZ (coord (rng), coord (rng), 0.5f * coord (rng)));
    for (Method m : kAll)
      expectAllFinite (estimate (c, m));
  }
}

TEST (PlanarOctreeSearch, PclDefaultsAndARadiusAloneAsInPclFeature)
{
  // PCL's defaults leave k and the radius unset: the class then uses kDefaultNeighbours for
  // the call and gives the settings back unchanged; a radius alone is a valid setting.
  const auto cloud = positions (analyticSphere (3000, 1.f, Eigen::Vector3f::Zero ()));
  Estimator ne;
  EXPECT_EQ (ne.getKSearch (), 0);
  EXPECT_EQ (ne.getRadiusSearch (), 0.0);
  const auto by_default = estimate (cloud, Method::MERGED, &ne);
  ASSERT_EQ (by_default.size (), cloud->size ());
  EXPECT_EQ (ne.getKSearch (), 0);
  Estimator with_k;
  with_k.setKSearch (Estimator::kDefaultNeighbours);
  const auto explicit_k = estimate (cloud, Method::MERGED, &with_k);
  ASSERT_EQ (explicit_k.size (), cloud->size ());
  for (std::size_t i = 0; i < cloud->size (); ++i)
    ASSERT_EQ (by_default[i].getNormalVector3fMap (), explicit_k[i].getNormalVector3fMap ()) << i;
  for (Method m : kAll)
  {
    Estimator radius;
    radius.setRadiusSearch (0.15);
    const auto n = estimate (cloud, m, &radius);
    ASSERT_EQ (n.size (), cloud->size ());
    expectAllFinite (n);
    EXPECT_EQ (radius.getKSearch (), 0);
    if (m != Method::MERGED)
      continue;  // Musmanno's leaf planes are coarse on 3000 points whatever the search
    std::size_t off = 0;
    for (std::size_t i = 0; i < n.size (); ++i)
      off += std::abs (n[i].getNormalVector3fMap ().dot ((*cloud)[i].getVector3fMap ().normalized ())) < 0.95f;
    EXPECT_LT (off, n.size () / 100);
  }
}
