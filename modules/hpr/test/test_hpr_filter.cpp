// HPRFilter: the exact operator against analytic / ray-cast oracles, PCL filter
// semantics, and every bad input the class handles.
#include "hpr_test_util.h"

#include <pclx/hpr/hpr_filter.h>
#include <pclx/testing/ray_caster.h>
#include <pclx/testing/shapes.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

using namespace pclx::testing;
using hprtest::xyz;
using Filter = pcl::HPRFilter<pcl::PointXYZ>;

namespace {
const float kNaN = std::numeric_limits<float>::quiet_NaN ();

pcl::Indices
run (Filter& f)
{
  pcl::Indices out;
  f.filter (out);
  return out;
}
}  // namespace

TEST (HPRExact, SphereFromOutsideSeesTheCapFacingTheViewpoint)
{
  const SampledCloud s = sampleUniform (makeSphere (1.f, 5), 4000, 3);
  const auto cloud = xyz (s);
  const Eigen::Vector3f C (0, 0, 3);
  Filter f;
  f.setInputCloud (cloud);
  f.setViewPoint (C);
  f.setMethod (Filter::Method::EXACT);
  // A sparse cloud needs a small R (Katz et al.): with γ = 3 the thin flipped shell turns
  // hidden points near the silhouette into hull vertices (precision drops to ~0.7).
  f.setGamma (1.0);
  const pcl::Indices vis = run (f);
  // Oracle: on the unit sphere a point is visible from C iff p·C > 1 (|C| = 3).
  std::vector<bool> truth (cloud->size ());
  for (std::size_t i = 0; i < cloud->size (); ++i)
    truth[i] = (*cloud)[i].getVector3fMap ().dot (C) > 1.f;
  const auto sc = hprtest::score (vis, truth);
  EXPECT_GT (sc.precision, 0.93);
  EXPECT_GT (sc.recall, 0.99);
  EXPECT_EQ (f.getMethodUsed (), Filter::Method::EXACT);
  EXPECT_NEAR (f.getRadiusUsed (), 4.0 * 10.0, 0.05);  // max|p − C| = 4
}

TEST (HPRExact, MatchesRayCastVisibilityOnAConcaveScene)
{
  const TriangleMesh torus = makeTorus (1.f, 0.35f, 160, 64);
  const SampledCloud s = sampleUniform (torus, 30000, 5);
  const auto cloud = xyz (s);
  const RayCaster rc (torus);
  for (const Eigen::Vector3f C : {Eigen::Vector3f (0, -4, 2), Eigen::Vector3f (3, 1, 0.5f)})
  {
    const std::vector<bool> truth = rc.visibleFrom (s.cloud, C);
    Filter f;
    f.setInputCloud (cloud);
    f.setViewPoint (C);
    f.setMethod (Filter::Method::EXACT);
    f.setGamma (3.0);
    const auto sc = hprtest::score (run (f), truth);
    EXPECT_GT (sc.f1, 0.9) << "viewpoint " << C.transpose ();
  }
}

TEST (HPRExact, PrefilterLeavesTheVisibleSetUnchangedAndTriangulates)
{
  TriangleMesh scene = makeTorus (1.f, 0.3f, 128, 48);
  scene.append (makeSphere (0.4f, 4, Eigen::Vector3f (0, 0, 0.2f)));
  const auto cloud = xyz (sampleUniform (scene, 40000, 8));
  Filter f;
  f.setInputCloud (cloud);
  f.setViewPoint (Eigen::Vector3f (0.5f, -3, 2));
  f.setMethod (Filter::Method::EXACT);
  f.setGamma (2.5);
  f.setExactPrefilter (false);
  const pcl::Indices plain = run (f);
  f.setExactPrefilter (true);
  f.setReconstructMesh (true);
  f.setComputeNormals (true);
  const pcl::Indices fast = run (f);
  EXPECT_EQ (plain, fast);
  // Katz's reconstruction: hull triangles over visible points only, facing the viewpoint.
  const pcl::PolygonMesh& mesh = f.getMesh ();
  ASSERT_GT (mesh.polygons.size (), fast.size ());
  std::vector<bool> vis (cloud->size (), false);
  for (auto i : fast)
    vis[i] = true;
  for (const auto& poly : mesh.polygons)
  {
    ASSERT_EQ (poly.vertices.size (), 3u);
    for (auto v : poly.vertices)
      EXPECT_TRUE (vis[v]);
  }
  EXPECT_EQ (f.getNormals ().size (), cloud->size ());
  for (auto i : fast)
  {
    const Eigen::Vector3f n = f.getNormals ()[i].getNormalVector3fMap ();
    EXPECT_NEAR (n.norm (), 1.f, 1e-4f);
    EXPECT_GT (n.dot (f.getViewPoint () - (*cloud)[i].getVector3fMap ()), 0.f);
  }
}

TEST (HPRFilterSemantics, NegativeRemovedIndicesAndSetIndices)
{
  const auto cloud = xyz (sampleUniform (makeSphere (1.f, 4), 3000, 1));
  Filter f (true);
  f.setInputCloud (cloud);
  f.setViewPoint (Eigen::Vector3f (0, 3, 0));
  f.setMethod (Filter::Method::EXACT);
  f.setGamma (2.0);
  const pcl::Indices vis = run (f);
  const pcl::Indices hidden = *f.getRemovedIndices ();
  EXPECT_EQ (vis.size () + hidden.size (), cloud->size ());
  EXPECT_EQ (hprtest::jaccard (vis, hidden), 0.0);

  f.setNegative (true);
  pcl::Indices neg = run (f);
  std::sort (neg.begin (), neg.end ());
  pcl::Indices hidden_sorted = hidden;
  std::sort (hidden_sorted.begin (), hidden_sorted.end ());
  EXPECT_EQ (neg, hidden_sorted);

  // setIndices: only the listed points take part; the answer uses input indices.
  f.setNegative (false);
  pcl::IndicesPtr subset (new pcl::Indices);
  for (int i = 0; i < int (cloud->size ()); i += 2)
    subset->push_back (i);
  f.setIndices (subset);
  const pcl::Indices sub = run (f);
  ASSERT_FALSE (sub.empty ());
  for (auto i : sub)
    EXPECT_EQ (i % 2, 0);
  EXPECT_EQ (sub.size () + f.getRemovedIndices ()->size (), subset->size ());

  // filter(cloud) copies the visible points.
  f.setIndices (pcl::IndicesPtr ());
  pcl::PointCloud<pcl::PointXYZ> out;
  f.filter (out);
  EXPECT_EQ (out.size (), vis.size ());
}

// The filter copies the finite requested points and writes its output per block of 65536
// indices, in parallel. Over several blocks, with non-finite points and a subset of indices:
// the same answer for 1 and 3 threads, every requested index either kept or removed (in the
// requested order), and the visible set of the finite points alone, mapped back.
TEST (HPRFilterSemantics, BlockedCopyAndOutputKeepOrderOverSeveralBlocks)
{
  const auto clean = xyz (sampleUniform (makeSphere (1.f, 4), 200000, 12));
  auto cloud = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>> (*clean);
  pcl::IndicesPtr subset (new pcl::Indices);
  for (int i = 0; i < int (cloud->size ()); ++i)
    if (i % 3 != 1)
      subset->push_back (i);
  for (std::size_t i = 0; i < cloud->size (); i += 7)
    (*cloud)[i].y = kNaN;
  // The finite requested points alone, and where each came from.
  auto finite = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>> ();
  pcl::Indices origin;
  for (auto i : *subset)
    if (i % 7 != 0)
    {
      finite->push_back ((*clean)[i]);
      origin.push_back (i);
    }
  const Eigen::Vector3f C (0.3f, 2.5f, 0.4f);
  auto configure = [&] (Filter& f, unsigned threads) {
    f.setViewPoint (C);
    f.setMethod (Filter::Method::CANDIDATE_HULL);
    f.setNumberOfThreads (threads);
  };
  Filter ref;
  configure (ref, 1);
  ref.setInputCloud (finite);
  pcl::Indices expected;
  for (auto j : run (ref))
    expected.push_back (origin[j]);
  ASSERT_GT (expected.size (), 10000u);

  for (bool negative : {false, true})
  {
    std::vector<pcl::Indices> kept_by_threads;
    for (unsigned t : {1u, 3u})
    {
      Filter f (true);
      configure (f, t);
      f.setInputCloud (cloud);
      f.setIndices (subset);
      f.setNegative (negative);
      const pcl::Indices kept = run (f);
      const pcl::Indices& removed = *f.getRemovedIndices ();
      ASSERT_EQ (kept.size () + removed.size (), subset->size ());
      EXPECT_TRUE (std::is_sorted (kept.begin (), kept.end ()));
      EXPECT_TRUE (std::is_sorted (removed.begin (), removed.end ()));
      pcl::Indices both (kept);
      both.insert (both.end (), removed.begin (), removed.end ());
      std::sort (both.begin (), both.end ());
      EXPECT_EQ (both, *subset);
      if (!negative)
        EXPECT_EQ (kept, expected);
      for (auto i : kept)
        EXPECT_NE (i % 7, 0) << "a non-finite point kept";
      kept_by_threads.push_back (kept);
    }
    EXPECT_EQ (kept_by_threads[1], kept_by_threads[0]) << "negative " << negative;
  }
}

// The filter keeps its working memory between calls. A call must not see what the previous
// one left there: clouds of other sizes, another method, fewer refinement passes, other
// options, and after releasing the memory, all give what a fresh filter gives.
TEST (HPRFilterSemantics, ReusedWorkingMemoryGivesTheFreshAnswer)
{
  const auto big = xyz (sampleUniform (makeTorus (1.f, 0.3f, 64, 32), 90000, 21));
  const auto small = xyz (sampleUniform (makeSphere (1.f, 4), 30000, 22));
  struct Call
  {
    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud;
    Filter::Method method;
    int refinement;
    Eigen::Vector3f C;
  };
  const std::vector<Call> calls = {
      {big, Filter::Method::CANDIDATE_HULL, 2, Eigen::Vector3f (0.2f, 2.5f, 1.f)},
      {small, Filter::Method::CANDIDATE_HULL, 0, Eigen::Vector3f (0.f, 0.f, 3.f)},
      {big, Filter::Method::EXACT, 2, Eigen::Vector3f (0.2f, 2.5f, 1.f)},
      {big, Filter::Method::CANDIDATE_HULL, 1, Eigen::Vector3f (-2.f, 0.3f, 0.5f)},
      {small, Filter::Method::ANGULAR_GRID, 2, Eigen::Vector3f (0.f, 3.f, 0.f)},
      {big, Filter::Method::CANDIDATE_HULL, 2, Eigen::Vector3f (0.2f, 2.5f, 1.f)},
  };
  auto configure = [] (Filter& f, const Call& c) {
    f.setInputCloud (c.cloud);
    f.setViewPoint (c.C);
    f.setMethod (c.method);
    f.setRefinementPasses (c.refinement);
    f.setNumberOfThreads (2);
  };
  Filter reused;
  for (std::size_t i = 0; i < calls.size (); ++i)
  {
    Filter fresh;
    configure (fresh, calls[i]);
    const pcl::Indices expected = run (fresh);
    ASSERT_FALSE (expected.empty ());
    configure (reused, calls[i]);
    EXPECT_EQ (run (reused), expected) << "call " << i;
    if (i == 3)
    {
      reused.releaseWorkingMemory ();
      EXPECT_EQ (run (reused), expected) << "after releasing, call " << i;
    }
  }
  // A copy starts with its own (empty) working memory and answers the same.
  Filter copy (reused);
  EXPECT_EQ (run (copy), run (reused));
}

TEST (HPRFilterSemantics, KeepOrganizedKeepsNaNInPlace)
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud (new pcl::PointCloud<pcl::PointXYZ> (40, 30));
  // An organized "depth image" of a bumpy surface seen from the origin, some pixels NaN.
  for (int v = 0; v < 30; ++v)
    for (int u = 0; u < 40; ++u)
    {
      auto& p = cloud->at (u, v);
      if ((u * 7 + v * 3) % 11 == 0)
      {
        p.x = p.y = p.z = kNaN;
        continue;
      }
      const float z = 2.f + 0.1f * std::sin (u * 0.3f) * std::cos (v * 0.2f);
      p.x = (u - 20) * 0.05f * z / 2;
      p.y = (v - 15) * 0.05f * z / 2;
      p.z = z;
    }
  cloud->is_dense = false;
  Filter f;
  f.setInputCloud (cloud);
  f.setViewPoint (Eigen::Vector3f::Zero ());
  f.setMethod (Filter::Method::EXACT);
  f.setGamma (2.0);
  f.setKeepOrganized (true);
  pcl::PointCloud<pcl::PointXYZ> out;
  f.filter (out);
  ASSERT_EQ (out.width, 40u);
  ASSERT_EQ (out.height, 30u);
  std::size_t kept = 0;
  for (std::size_t i = 0; i < out.size (); ++i)
  {
    if (!std::isfinite ((*cloud)[i].x))
      EXPECT_FALSE (std::isfinite (out[i].x)) << "NaN input stays NaN at " << i;
    kept += std::isfinite (out[i].x);
  }
  // A height field seen from the front is almost entirely visible.
  EXPECT_GT (kept, 0.9 * 1090);
}

TEST (HPRBadInput, EmptyAllNaNAndMixedNaN)
{
  Filter f;
  pcl::PointCloud<pcl::PointXYZ>::Ptr empty (new pcl::PointCloud<pcl::PointXYZ>);
  f.setInputCloud (empty);
  EXPECT_TRUE (run (f).empty ());

  pcl::PointCloud<pcl::PointXYZ>::Ptr nan (new pcl::PointCloud<pcl::PointXYZ>);
  for (int i = 0; i < 10; ++i)
    nan->push_back (pcl::PointXYZ (kNaN, kNaN, kNaN));
  f.setInputCloud (nan);
  EXPECT_TRUE (run (f).empty ());

  auto mixed = xyz (sampleUniform (makeSphere (1.f, 4), 2000, 4));
  const auto clean = *mixed;
  for (std::size_t i = 0; i < mixed->size (); i += 10)
    (*mixed)[i].x = (i % 20 == 0) ? kNaN : std::numeric_limits<float>::infinity ();
  f.setInputCloud (mixed);
  f.setViewPoint (Eigen::Vector3f (0, 0, 3));
  f.setMethod (Filter::Method::EXACT);
  f.setGamma (1.0);
  const pcl::Indices vis = run (f);
  ASSERT_GT (vis.size (), 500u);
  for (auto i : vis)
  {
    EXPECT_NE (i % 10, 0) << "non-finite point reported visible";
    EXPECT_GT (clean[i].z, 0.f);  // the cap facing +z
  }
}

TEST (HPRBadInput, FewPointsDuplicatesAndPointAtViewpoint)
{
  Filter f;
  f.setViewPoint (Eigen::Vector3f (0, 0, 5));
  f.setMethod (Filter::Method::EXACT);
  pcl::PointCloud<pcl::PointXYZ>::Ptr few (new pcl::PointCloud<pcl::PointXYZ>);
  few->push_back ({0, 0, 0});
  few->push_back ({1, 0, 0});
  few->push_back ({0, 1, 0});
  f.setInputCloud (few);
  EXPECT_EQ (run (f).size (), 3u);  // < 4 points: all visible

  // Duplicates: every copy of a visible point is visible, every copy of a hidden one hidden.
  auto dup = xyz (sampleUniform (makeSphere (1.f, 4), 1500, 6));
  const std::size_t n = dup->size ();
  for (std::size_t i = 0; i < n; i += 3)
    dup->push_back ((*dup)[i]);
  f.setInputCloud (dup);
  f.setGamma (2.5);
  const pcl::Indices vis = run (f);
  std::vector<bool> v (dup->size (), false);
  for (auto i : vis)
    v[i] = true;
  for (std::size_t j = n, i = 0; j < dup->size (); ++j, i += 3)
    EXPECT_EQ (v[j], v[i]) << "copy " << j << " of " << i;
  // ... and a visible copy gets its twin's normal.
  f.setComputeNormals (true);
  run (f);
  for (std::size_t j = n, i = 0; j < dup->size (); ++j, i += 3)
    if (v[j])
      EXPECT_TRUE (f.getNormals ()[j].getNormalVector3fMap ().isApprox (f.getNormals ()[i].getNormalVector3fMap ()))
          << "copy " << j;
  f.setComputeNormals (false);

  // A point exactly at the viewpoint is visible and does not break the flip.
  auto eye = xyz (sampleUniform (makeSphere (1.f, 4), 1500, 6));
  eye->push_back ({0, 0, 5});
  f.setInputCloud (eye);
  const pcl::Indices with_eye = run (f);
  EXPECT_NE (std::find (with_eye.begin (), with_eye.end (), int (eye->size () - 1)), with_eye.end ());
  EXPECT_GT (with_eye.size (), 200u);
}

TEST (HPRBadInput, CoplanarAndCollinearCloudsGiveADefinedAnswer)
{
  Filter f;
  f.setMethod (Filter::Method::EXACT);
  f.setGamma (2.0);
  // A plane seen from the front: all of it is visible.
  pcl::PointCloud<pcl::PointXYZ>::Ptr plane (new pcl::PointCloud<pcl::PointXYZ>);
  for (int i = 0; i < 30; ++i)
    for (int j = 0; j < 30; ++j)
      plane->push_back (pcl::PointXYZ (i * 0.1f, j * 0.1f, 0.f));
  f.setInputCloud (plane);
  f.setViewPoint (Eigen::Vector3f (1.5f, 1.5f, 4.f));
  EXPECT_GT (run (f).size (), 0.95 * plane->size ());
  // The viewpoint in the plane (Qhull's flat case) and a line: edge-on, all visible
  // (test_hpr_far_and_flat.cpp covers every method).
  f.setViewPoint (Eigen::Vector3f (-1.f, -1.f, 0.f));
  const pcl::Indices edge_on = run (f);
  EXPECT_EQ (edge_on.size (), plane->size ());
  pcl::PointCloud<pcl::PointXYZ>::Ptr line (new pcl::PointCloud<pcl::PointXYZ>);
  for (int i = 0; i < 100; ++i)
    line->push_back (pcl::PointXYZ (i * 0.01f, 0.f, 0.f));
  f.setInputCloud (line);
  f.setViewPoint (Eigen::Vector3f (0.5f, 1.f, 0.f));
  const pcl::Indices on_line = run (f);
  EXPECT_EQ (on_line.size (), line->size ());
  for (auto m : {Filter::Method::ANGULAR_GRID, Filter::Method::HYBRID, Filter::Method::BENTLEY_FAUST_PREPARATA})
  {
    f.setMethod (m);
    EXPECT_EQ (run (f).size (), line->size ());
  }
}

TEST (HPRBadInput, BadRadiusViewpointAndPropagationAreRejected)
{
  const auto cloud = xyz (sampleUniform (makeSphere (1.f, 4), 1000, 2));
  Filter f (true);
  f.setInputCloud (cloud);
  f.setViewPoint (Eigen::Vector3f (0, 0, 3));
  // An R the cloud cannot use is refused by filter (): nothing kept, the reason kept.
  f.setRadius (2.0);  // farthest point is at distance 4
  EXPECT_TRUE (run (f).empty ());
  EXPECT_EQ (f.getRemovedIndices ()->size (), cloud->size ());
  EXPECT_FALSE (f.getLastError ().empty ());
  f.setRadius (5.0);
  const pcl::Indices reference = run (f);
  EXPECT_FALSE (reference.empty ());
  EXPECT_TRUE (f.getLastError ().empty ());  // cleared by a call that succeeds

  // Bad setter arguments are refused (PCL_ERROR) and the previous setting is kept: the
  // filter gives the answer of that setting.
  auto unchanged = [&] (const char* what) {
    EXPECT_EQ (f.getRadiusMode (), Filter::RadiusMode::ABSOLUTE) << what;
    EXPECT_EQ (run (f), reference) << what;
    EXPECT_TRUE (f.getLastError ().empty ()) << what;
  };
  f.setRadius (-1.0);
  unchanged ("R < 0");
  f.setRadius (std::numeric_limits<double>::infinity ());
  unchanged ("R infinite");
  f.setGamma (0.0);
  unchanged ("gamma = 0");
  f.setGamma (kNaN);
  unchanged ("gamma NaN");
  f.setAutoRadius (-1.0);
  unchanged ("occlusion depth < 0");
  f.setViewPoint (Eigen::Vector3f (kNaN, 0, 0));
  EXPECT_EQ (f.getViewPoint (), Eigen::Vector3f (0, 0, 3));
  unchanged ("viewpoint NaN");
  f.setGridOversampling (0.0);
  unchanged ("oversampling 0");
  f.setViewResolution (800, 0.0);
  unchanged ("field of view 0");

  f.setMethod (Filter::Method::ANGULAR_GRID);
  f.setSectorCount (2000);
  f.setPropagation (Filter::Propagation::FIXED, 3);
  const pcl::Indices fixed3 = run (f);
  EXPECT_FALSE (fixed3.empty ());
  f.setPropagation (Filter::Propagation::FIXED, 4);  // m must be odd
  EXPECT_EQ (run (f), fixed3);
  f.setPropagation (Filter::Propagation::FIXED, 0);
  EXPECT_EQ (run (f), fixed3);
  f.setPropagation (Filter::Propagation::ADAPTIVE, -2);
  EXPECT_EQ (run (f), fixed3);
  EXPECT_EQ (f.getPropagationStepsUsed (), 3);
  f.setAutoRadius ();
  EXPECT_EQ (f.getRadiusMode (), Filter::RadiusMode::AUTO);
  EXPECT_FALSE (run (f).empty ());
}

TEST (HPRBadInput, ViewpointInsideTheCloud)
{
  // Inside a closed sphere every point is visible; both methods must say nearly so.
  const auto cloud = xyz (sampleUniform (makeSphere (1.f, 5), 5000, 12));
  for (auto m : {Filter::Method::EXACT, Filter::Method::ANGULAR_GRID})
  {
    Filter f;
    f.setInputCloud (cloud);
    f.setViewPoint (Eigen::Vector3f (0.1f, 0.2f, 0.f));
    f.setMethod (m);
    f.setGamma (2.0);
    const std::size_t vis = run (f).size ();
    EXPECT_GT (vis, (m == Filter::Method::EXACT ? 0.97 : 0.6) * cloud->size ()) << int (m);
  }
}

TEST (HPRGivenRadius, AutoHonoursAGivenRadiusAboveTheExactLimit)
{
  // Above kAutoExactLimit, AUTO with a user-set R (or γ) must compute the operator at that R,
  // as EXACT does, and keep a sphere's far side hidden.
  const auto cloud = xyz (sampleUniform (makeSphere (1.f, 5), 30000, 43));
  ASSERT_GT (cloud->size (), Filter::kAutoExactLimit);
  const Eigen::Vector3f C (0.f, 0.f, 4.f);
  for (const bool gamma : {false, true})
  {
    auto configure = [&] (Filter& f, Filter::Method m) {
      f.setInputCloud (cloud);
      f.setViewPoint (C);
      f.setMethod (m);
      if (gamma)
        f.setGamma (2.0);
      else
        f.setRadius (500.0);
    };
    Filter automatic, exact;
    configure (automatic, Filter::Method::AUTO);
    configure (exact, Filter::Method::EXACT);
    const pcl::Indices a = run (automatic), e = run (exact);
    EXPECT_EQ (automatic.getMethodUsed (), Filter::Method::EXACT) << (gamma ? "gamma" : "radius");
    EXPECT_EQ (a, e) << (gamma ? "gamma" : "radius");
    EXPECT_DOUBLE_EQ (automatic.getRadiusUsed (), exact.getRadiusUsed ());
    std::size_t far_side = 0;
    for (const int i : a)
      far_side += (*cloud)[i].z < -0.1f;
    EXPECT_EQ (far_side, 0u) << (gamma ? "gamma" : "radius");
    EXPECT_LT (double (a.size ()), 0.5 * double (cloud->size ()));
  }
}
