// The approximate operators: agreement with exact as k grows, propagation modes,
// calibration, the partial triangulation, grid normals and the other hulls.
#include "hpr_test_util.h"

#include <pclx/hpr/detail/angular_grid.h>
#include <pclx/hpr/hpr_filter.h>
#include <pclx/hpr/detail/visibility.h>
#include <pclx/testing/ray_caster.h>
#include <pclx/testing/shapes.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

using namespace pclx::testing;
using hprtest::xyz;
using Filter = pcl::HPRFilter<pcl::PointXYZ>;

namespace {
struct Scene
{
  TriangleMesh mesh;
  SampledCloud samples;
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud;
  Eigen::Vector3f C;
  std::vector<bool> truth;
};

Scene
torusScene (std::size_t n)
{
  Scene s;
  s.mesh = makeTorus (1.f, 0.35f, 160, 64);
  s.samples = sampleUniform (s.mesh, n, 21);
  s.cloud = xyz (s.samples);
  s.C = Eigen::Vector3f (0.3f, -4.f, 2.f);
  s.truth = RayCaster (s.mesh).visibleFrom (s.samples.cloud, s.C);
  return s;
}

pcl::Indices
runGrid (const Scene& s, std::size_t k, Filter::Propagation mode = Filter::Propagation::ADAPTIVE, int steps = 0,
         double gamma = 2.5)
{
  Filter f;
  f.setInputCloud (s.cloud);
  f.setViewPoint (s.C);
  f.setMethod (Filter::Method::ANGULAR_GRID);
  f.setGamma (gamma);
  f.setSectorCount (k);
  f.setPropagation (mode, steps);
  pcl::Indices out;
  f.filter (out);
  return out;
}
}  // namespace

TEST (HPRGrid, AgreesWithExactBetterAsKGrows)
{
  const Scene s = torusScene (20000);
  Filter exact;
  exact.setInputCloud (s.cloud);
  exact.setViewPoint (s.C);
  exact.setMethod (Filter::Method::EXACT);
  exact.setGamma (2.5);
  pcl::Indices ex;
  exact.filter (ex);
  double prev = 0;
  for (std::size_t k : {1000, 10000, 40000, 100000})
  {
    const double j = hprtest::jaccard (runGrid (s, k), ex);
    EXPECT_GT (j, prev - 0.01) << "k = " << k;
    prev = j;
  }
  EXPECT_GT (prev, 0.75);
  EXPECT_GT (hprtest::score (runGrid (s, 100000), s.truth).f1, 0.85);
}

TEST (HPRGrid, PropagationOnlyRemovesCandidatesAndModesAgree)
{
  const Scene s = torusScene (20000);
  // Fixed m = 1 does nothing: every sector keeps its own extreme point.
  const pcl::Indices none = runGrid (s, 60000, Filter::Propagation::FIXED, 1);
  std::size_t prev = none.size ();
  for (int steps : {1, 2, 4, 8})
  {
    const pcl::Indices a = runGrid (s, 60000, Filter::Propagation::ADAPTIVE, steps);
    EXPECT_LE (a.size (), prev) << "steps " << steps;
    prev = a.size ();
  }
  // One adaptive (Jacobi) step over the 8-neighbourhood is exactly a 3×3 gather.
  EXPECT_EQ (runGrid (s, 60000, Filter::Propagation::ADAPTIVE, 1), runGrid (s, 60000, Filter::Propagation::FIXED, 3));
  // Propagation improves precision against the ray-cast truth.
  const auto p0 = hprtest::score (none, s.truth);
  const auto p8 = hprtest::score (runGrid (s, 60000, Filter::Propagation::ADAPTIVE, 8), s.truth);
  EXPECT_GT (p8.precision, p0.precision);
  // Until stable (ℓ = 0 with a given k still calibrates ℓ; a large ℓ runs to stability).
  Filter f;
  f.setInputCloud (s.cloud);
  f.setViewPoint (s.C);
  f.setMethod (Filter::Method::ANGULAR_GRID);
  f.setGamma (2.5);
  f.setSectorCount (60000);
  f.setPropagation (Filter::Propagation::ADAPTIVE, 100000);
  pcl::Indices stable;
  f.filter (stable);
  EXPECT_LT (f.getPropagationStepsUsed (), 100000);
  EXPECT_LE (stable.size (), prev);
}

TEST (HPRGrid, CalibrationPicksUsefulRKAndSteps)
{
  const Scene s = torusScene (40000);
  Filter f;
  f.setInputCloud (s.cloud);
  f.setViewPoint (s.C);
  f.setMethod (Filter::Method::ANGULAR_GRID);  // everything else automatic
  pcl::Indices vis;
  f.filter (vis);
  const auto auto_score = hprtest::score (vis, s.truth);
  EXPECT_GT (auto_score.f1, 0.88);
  EXPECT_GT (f.getRadiusUsed (), 4.5);  // > max|p − C|
  EXPECT_GT (f.getPropagationStepsUsed (), 0);
  const std::size_t k_auto = f.getSectorCountUsed ();
  EXPECT_GT (k_auto, 20000u);
  // The calibrated R is close to the best of a γ sweep for the exact operator.
  double best = 0;
  for (double g : {1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0})
  {
    Filter e;
    e.setInputCloud (s.cloud);
    e.setViewPoint (s.C);
    e.setMethod (Filter::Method::EXACT);
    e.setGamma (g);
    pcl::Indices v;
    e.filter (v);
    best = std::max (best, hprtest::score (v, s.truth).f1);
  }
  Filter e;
  e.setInputCloud (s.cloud);
  e.setViewPoint (s.C);
  e.setMethod (Filter::Method::EXACT);
  pcl::Indices v;
  e.filter (v);
  EXPECT_GT (hprtest::score (v, s.truth).f1, best - 0.03);

  // k follows the view: a small viewport caps it, a sparser cloud needs fewer sectors.
  f.setViewResolution (100, 0.5);
  f.filter (vis);
  EXPECT_LT (f.getSectorCountUsed (), k_auto / 4);
  Filter sparse;
  const Scene few = torusScene (5000);
  sparse.setInputCloud (few.cloud);
  sparse.setViewPoint (few.C);
  sparse.setMethod (Filter::Method::ANGULAR_GRID);
  sparse.filter (vis);
  EXPECT_LT (sparse.getSectorCountUsed (), k_auto / 3);
}

TEST (HPRGrid, PartialTriangulationIsValid)
{
  const Scene s = torusScene (20000);
  Filter f;
  f.setInputCloud (s.cloud);
  f.setViewPoint (s.C);
  f.setMethod (Filter::Method::ANGULAR_GRID);
  f.setGamma (2.5);
  f.setSectorCount (40000);
  f.setReconstructMesh (true, 0.15f);
  pcl::Indices vis;
  f.filter (vis);
  std::vector<bool> v (s.cloud->size (), false);
  for (auto i : vis)
    v[i] = true;
  const auto& mesh = f.getMesh ();
  ASSERT_GT (mesh.polygons.size (), vis.size ());  // ~2 triangles per visible point
  EXPECT_EQ (mesh.cloud.width * mesh.cloud.height, s.cloud->size ());
  for (const auto& poly : mesh.polygons)
  {
    ASSERT_EQ (poly.vertices.size (), 3u);
    const auto a = poly.vertices[0], b = poly.vertices[1], c = poly.vertices[2];
    EXPECT_TRUE (a != b && b != c && a != c);
    EXPECT_TRUE (v[a] && v[b] && v[c]);
    const Eigen::Vector3f pa = (*s.cloud)[a].getVector3fMap (), pb = (*s.cloud)[b].getVector3fMap (),
                          pc = (*s.cloud)[c].getVector3fMap ();
    EXPECT_LE ((pa - pb).norm (), 0.15f + 1e-5f);
    EXPECT_LE ((pb - pc).norm (), 0.15f + 1e-5f);
    EXPECT_LE ((pc - pa).norm (), 0.15f + 1e-5f);
    EXPECT_GE ((pb - pa).cross (pc - pa).dot (s.C - pa), 0.f) << "triangle faces away from the viewer";
  }
}

TEST (HPRGrid, GridNormalsAndSplatsOnASphere)
{
  const auto cloud = xyz (sampleUniform (makeSphere (1.f, 5), 30000, 4));
  Filter f;
  f.setInputCloud (cloud);
  f.setViewPoint (Eigen::Vector3f (0, 0, 4));
  f.setMethod (Filter::Method::ANGULAR_GRID);
  f.setGamma (2.5);
  f.setComputeNormals (true);
  pcl::Indices vis;
  f.filter (vis);
  ASSERT_GT (vis.size (), 5000u);
  double sum = 0;
  for (auto i : vis)
  {
    const Eigen::Vector3f n = f.getNormals ()[i].getNormalVector3fMap ();
    const Eigen::Vector3f truth = (*cloud)[i].getVector3fMap ().normalized ();
    sum += std::acos (std::clamp (n.dot (truth), -1.f, 1.f)) * 180.0 / M_PI;
    EXPECT_GT (f.getSplatRadii ()[i], 0.f);
    EXPECT_LT (f.getSplatRadii ()[i], 0.2f);
  }
  EXPECT_LT (sum / vis.size (), 10.0);  // mean angle error, degrees
}

TEST (HPRGrid, OtherApproximateHullsAreSubsetsWithSensibleAccuracy)
{
  const Scene s = torusScene (20000);
  for (auto m : {Filter::Method::BENTLEY_FAUST_PREPARATA, Filter::Method::KAVAN, Filter::Method::HYBRID})
  {
    Filter f;
    f.setInputCloud (s.cloud);
    f.setViewPoint (s.C);
    f.setMethod (m);
    f.setGamma (2.5);
    f.setSectorCount (m == Filter::Method::KAVAN ? 4000 : 20000);
    pcl::Indices vis;
    f.filter (vis);
    const auto sc = hprtest::score (vis, s.truth);
    EXPECT_GT (sc.precision, 0.8) << int (m);
    EXPECT_GT (sc.recall, 0.1) << int (m);
  }
}

TEST (HPRBadInput, SectorCountZeroAndAbsurd)
{
  const Scene s = torusScene (3000);
  testing::internal::CaptureStderr ();
  const pcl::Indices huge = runGrid (s, std::size_t (-1));
  const std::string log = testing::internal::GetCapturedStderr ();
  EXPECT_NE (log.find ("clamped"), std::string::npos);
  EXPECT_FALSE (huge.empty ());
  EXPECT_FALSE (runGrid (s, 0).empty ());  // 0 = calibrated
}

TEST (AngularGrid, SectorsCoverTheCloudAndCandidatesAreExtreme)
{
  std::vector<Eigen::Vector3d> pts;
  // A flat patch at distance 5 facing the origin, plus a copy 1 unit behind it.
  for (int i = 0; i < 50; ++i)
    for (int j = 0; j < 50; ++j)
    {
      pts.emplace_back (5.0, (i - 25) * 0.02, (j - 25) * 0.02);
      pts.emplace_back (6.0, (i - 25) * 0.024 + 0.001, (j - 25) * 0.024 + 0.001);
    }
  pclx::hpr::detail::AngularGrid g;
  g.build (pts, Eigen::Vector3d (5.5, 0, 0), 1e4, 400);
  EXPECT_NEAR (double (g.sectorCount ()), 400.0, 60.0);
  // Every candidate is on the front patch: it is the nearer, so the more extreme when flipped.
  for (int c : g.candidates ())
    EXPECT_EQ (pts[c].x (), 5.0);
  EXPECT_GT (g.occupiedSectors (), 0.9 * g.sectorCount ());  // cells are square: the rim may be empty
}

TEST (HPRCandidateHull, KeepsEveryExactVisiblePointAndCullsMostHidden)
{
  const Scene s = torusScene (40000);
  Filter exact;
  exact.setInputCloud (s.cloud);
  exact.setViewPoint (s.C);
  exact.setMethod (Filter::Method::EXACT);
  exact.setGamma (2.5);
  exact.setExactPrefilter (false);
  pcl::Indices ex;
  exact.filter (ex);
  Filter f;
  f.setInputCloud (s.cloud);
  f.setViewPoint (s.C);
  f.setMethod (Filter::Method::CANDIDATE_HULL);
  f.setGamma (2.5);
  pcl::Indices ch;
  f.filter (ch);
  // Culling is exact: every hull vertex survives, so the result contains EXACT's.
  std::vector<bool> in (s.cloud->size (), false);
  for (auto i : ch)
    in[i] = true;
  for (auto i : ex)
    EXPECT_TRUE (in[i]) << "hull vertex " << i << " was culled";
  // ... and it is not everything: most hidden points are culled.
  const std::size_t hidden = std::count (s.truth.begin (), s.truth.end (), false);
  EXPECT_LT (ch.size (), ex.size () + hidden / 4);
  EXPECT_GT (hprtest::score (ch, s.truth).f1, hprtest::score (ex, s.truth).f1 - 0.1);
  EXPECT_EQ (f.getPropagationStepsUsed (), 4);
  EXPECT_GT (f.getSectorCountUsed (), 0u);
  // AUTO picks it for large clouds without a view resolution.
  Filter a;
  a.setInputCloud (s.cloud);
  a.setViewPoint (s.C);
  pcl::Indices av;
  a.filter (av);
  EXPECT_EQ (a.getMethodUsed (), Filter::Method::CANDIDATE_HULL);
  a.setViewResolution (200, 0.8);
  a.filter (av);
  EXPECT_EQ (a.getMethodUsed (), Filter::Method::ANGULAR_GRID);
}

TEST (HPRThreads, SameAnswerForAnyThreadCountAndAutomaticCountIsSane)
{
  const Scene s = torusScene (40000);
  for (const auto m : {Filter::Method::CANDIDATE_HULL, Filter::Method::ANGULAR_GRID, Filter::Method::EXACT})
  {
    std::vector<pcl::Indices> out;
    for (unsigned t : {1u, 2u, 3u, 0u})
    {
      Filter f;
      f.setInputCloud (s.cloud);
      f.setViewPoint (s.C);
      f.setMethod (m);
      f.setNumberOfThreads (t);
      pcl::Indices v;
      f.filter (v);
      out.push_back (v);
      if (t > 0)
        EXPECT_EQ (f.getThreadsUsed (), int (t));
      else
        EXPECT_GE (f.getThreadsUsed (), 1);
    }
    for (std::size_t i = 1; i < out.size (); ++i)
      EXPECT_EQ (out[i], out[0]) << "method " << int (m) << ", run " << i;
  }
  // Small clouds never pay for a parallel region.
  EXPECT_EQ (pclx::hpr::detail::autoThreads (1000), 1);
  EXPECT_GE (pclx::hpr::detail::autoThreads (10000000), 1);
}

// The refinement passes go on only over the uncertain band (interiorPoints' survivor_in_band):
// survivors within one sector of a culled point or of a sector without candidate. A front
// sheet with a small sheet hidden behind its centre: the band is the centre and the outline,
// not the rest of the sheet.
TEST (AngularGrid, UncertainBandIsAroundCulledPointsAndTheOutline)
{
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < 60; ++i)
    for (int j = 0; j < 60; ++j)
      pts.emplace_back (5.0, (i - 30) * 0.02 + 0.003, (j - 30) * 0.02 + 0.007);
  const std::size_t front = pts.size ();
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j)
      pts.emplace_back (5.5, (i - 5) * 0.02 + 0.011, (j - 5) * 0.02 + 0.013);
  pclx::hpr::detail::AngularGrid g;
  g.build (pts, Eigen::Vector3d (5.0, 0, 0), 1e4, 400);
  std::vector<int> survivors;
  std::vector<Eigen::Vector3d> survivor_points;
  std::vector<std::uint8_t> in_band;
  g.interiorPoints (pts, &survivors, &survivor_points, &in_band);
  ASSERT_EQ (in_band.size (), survivors.size ());
  std::size_t hidden_culled = 0, centre = 0, outline = 0, rest = 0;
  for (std::size_t j = 0; j < survivors.size (); ++j)
  {
    const Eigen::Vector3d& p = pts[std::size_t (survivors[j])];
    EXPECT_EQ (survivor_points[j], p);
    if (std::size_t (survivors[j]) >= front)
      continue;
    const double r = std::max (std::abs (p.y ()), std::abs (p.z ()));
    if (r < 0.06)
    {
      EXPECT_TRUE (in_band[j]) << p.transpose ();  // in front of the hidden sheet
      ++centre;
    }
    else if (r > 0.57)
    {
      EXPECT_TRUE (in_band[j]) << p.transpose ();  // the outline
      ++outline;
    }
    else if (r > 0.3 && r < 0.45)
    {
      EXPECT_FALSE (in_band[j]) << p.transpose ();  // front surface only around it
      ++rest;
    }
  }
  for (std::size_t i = front; i < pts.size (); ++i)
    hidden_culled += std::find (survivors.begin (), survivors.end (), int (i)) == survivors.end ();
  EXPECT_GT (hidden_culled, 50u);  // the hidden sheet is mostly culled (that seeds the band)
  EXPECT_GT (centre, 20u);
  EXPECT_GT (outline, 100u);
  EXPECT_GT (rest, 500u);
}

// setBandDepth: only culls at most that far behind the nearest candidate seed the band. A front
// sheet with one small sheet just behind it (0.05) and one far behind (0.5): with a band depth
// of 0.2 only the shallow one seeds the band; with none (every cull) both do.
TEST (AngularGrid, BandDepthKeepsDeepCullsOutOfTheBand)
{
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < 60; ++i)
    for (int j = 0; j < 60; ++j)
      pts.emplace_back (5.0, (i - 30) * 0.02 + 0.003, (j - 30) * 0.02 + 0.007);
  const std::size_t front = pts.size ();
  for (int i = 0; i < 8; ++i)
    for (int j = 0; j < 8; ++j)
    {
      pts.emplace_back (5.05, -0.3 + (i - 4) * 0.02 + 0.011, (j - 4) * 0.02 + 0.013);  // shallow
      pts.emplace_back (5.5, 0.3 + (i - 4) * 0.02 + 0.011, (j - 4) * 0.02 + 0.013);    // deep
    }
  for (const double depth : {0.0, 0.2})
  {
    pclx::hpr::detail::AngularGrid g;
    g.setBandDepth (depth);
    g.build (pts, Eigen::Vector3d (5.0, 0, 0), 20.0, 400);
    std::vector<int> survivors, settled;
    std::vector<Eigen::Vector3d> survivor_points;
    g.interiorPoints (pts, &survivors, &survivor_points, nullptr, &settled);
    std::vector<int> band_of (pts.size (), -1);  // 1: in the band, 0: settled
    for (int i : survivors)
      band_of[std::size_t (i)] = 1;
    for (int i : settled)
      band_of[std::size_t (i)] = 0;
    std::size_t culled_shallow = 0, culled_deep = 0, near_shallow = 0, near_deep = 0, deep_in_band = 0;
    for (std::size_t i = 0; i < pts.size (); ++i)
    {
      const Eigen::Vector3d& p = pts[i];
      if (i >= front)
      {
        (p.x () < 5.2 ? culled_shallow : culled_deep) += band_of[i] < 0;
        continue;
      }
      // Front points right in front of each hidden sheet's centre.
      if (std::abs (p.z ()) < 0.04 && std::abs (p.y () + 0.3) < 0.04)
      {
        ++near_shallow;
        EXPECT_EQ (band_of[i], 1) << "depth " << depth << ": " << p.transpose ();
      }
      if (std::abs (p.z ()) < 0.04 && std::abs (p.y () - 0.3) < 0.04)
      {
        ++near_deep;
        deep_in_band += band_of[i] == 1;
      }
    }
    EXPECT_GT (culled_shallow, 20u) << depth;
    EXPECT_GT (culled_deep, 40u) << depth;
    EXPECT_GT (near_shallow, 10u);
    EXPECT_GT (near_deep, 10u);
    if (depth > 0)
      EXPECT_EQ (deep_in_band, 0u);  // the deep sheet's culls seed nothing
    else
      EXPECT_EQ (deep_in_band, near_deep);  // every cull seeds the band
  }
}

// setCellSize: a refinement grid over a subset keeps the cell it would have over all points;
// the sector count then only caps it.
TEST (AngularGrid, FixedCellSizeIsKeptOverASubsetAndCappedByK)
{
  std::vector<Eigen::Vector3d> all, part;
  for (int i = 0; i < 80; ++i)
    for (int j = 0; j < 80; ++j)
    {
      all.emplace_back (5.0, (i - 40) * 0.01, (j - 40) * 0.01);
      if (i < 20 && j < 30)
        part.push_back (all.back ());
    }
  pclx::hpr::detail::AngularGrid full;
  full.build (all, Eigen::Vector3d (5.0, 0, 0), 1e4, 1600);
  const double cell = full.cellAngle ();
  pclx::hpr::detail::AngularGrid sub;
  sub.setCellSize (cell);
  sub.build (part, Eigen::Vector3d (5.0, 0, 0), 1e4, 1600);
  EXPECT_NEAR (sub.cellAngle (), cell, 1e-9 * cell);
  EXPECT_LT (sub.sectorCount (), 1600u / 4);  // the subset spans under a tenth of the extent
  // Without it, k is spread over the subset: cells ~3x smaller.
  pclx::hpr::detail::AngularGrid spread;
  spread.build (part, Eigen::Vector3d (5.0, 0, 0), 1e4, 1600);
  EXPECT_LT (spread.cellAngle (), 0.5 * cell);
  // A cell finer than k allows is capped by k.
  pclx::hpr::detail::AngularGrid capped;
  capped.setCellSize (cell / 100);
  capped.build (part, Eigen::Vector3d (5.0, 0, 0), 1e4, 100);
  EXPECT_LE (capped.sectorCount (), 120u);
}

// The depth cut of interiorPoints: where sectors hold many points (a gnomonic grid, ~14 points
// per sector here), a point deeper than every plane of the tetrahedra around its sector is
// culled before the tests. On a closed surface that is most of the far side. It must keep every
// vertex of the exact hull at the same R, give the same answer on one or two threads and
// through both outputs (mask, survivors), and stay off on a wide grid (C inside the cloud).
TEST (AngularGrid, DepthCutCullsTheFarSideAndStaysConservative)
{
  const Scene s = torusScene (60000);
  Filter f;
  f.setInputCloud (s.cloud);
  f.setViewPoint (s.C);
  f.setMethod (Filter::Method::CANDIDATE_HULL);
  pcl::Indices v;
  f.filter (v);
  const double R = f.getRadiusUsed ();
  Eigen::Vector3d centre, centre_inside;
  const std::vector<Eigen::Vector3d> pts = hprtest::relativeTo (*s.cloud, s.C, &centre);
  // A wide grid (the viewer in the torus's hole).
  const std::vector<Eigen::Vector3d> inside =
      hprtest::relativeTo (*s.cloud, Eigen::Vector3f (0.f, 0.f, 0.05f), &centre_inside);
  const std::size_t k = std::size_t (2.0 * std::pow (double (pts.size ()), 0.7));
  auto cull = [&] (const std::vector<Eigen::Vector3d>& p, int threads, std::size_t* cut,
                   std::vector<int>* survivors = nullptr) {
    pclx::hpr::detail::AngularGrid g;
    g.setThreads (threads);
    g.setOutlineCandidates (true);
    g.build (p, &p == &pts ? centre : centre_inside, R, k);
    g.propagateAdaptive (4);
    std::vector<Eigen::Vector3d> survivor_points;
    std::vector<std::uint8_t> mask = g.interiorPoints (p, survivors, survivors ? &survivor_points : nullptr);
    *cut = g.depthCulled ();
    EXPECT_EQ (g.gnomonic (), &p == &pts);
    return mask;
  };
  std::size_t cut1 = 0, cut2 = 0, cut_s = 0;
  const std::vector<std::uint8_t> mask = cull (pts, 1, &cut1);
  EXPECT_EQ (cull (pts, 2, &cut2), mask);
  EXPECT_EQ (cut2, cut1);
  const std::size_t hidden = std::count (s.truth.begin (), s.truth.end (), false);
  const std::size_t culled = std::size_t (std::count (mask.begin (), mask.end (), 1));
  std::printf ("depth cut %zu, culled in all %zu, hidden %zu of %zu\n", cut1, culled, hidden, pts.size ());
  EXPECT_GT (cut1, hidden / 2);
  EXPECT_LE (cut1, culled);
  // The survivors' output lists exactly the points the mask keeps.
  std::vector<int> survivors;
  cull (pts, 2, &cut_s, &survivors);
  EXPECT_EQ (cut_s, cut1);
  std::sort (survivors.begin (), survivors.end ());
  std::vector<int> kept;
  for (std::size_t i = 0; i < mask.size (); ++i)
    if (!mask[i])
      kept.push_back (int (i));
  EXPECT_EQ (survivors, kept);
  // Conservative: no vertex of the exact hull at the same R is culled.
  pclx::hpr::detail::VisibilityOptions opt;
  opt.method = pclx::hpr::detail::VisibilityMethod::EXACT;
  opt.radius = R;
  opt.exact_prefilter = false;
  opt.threads = 1;
  const pclx::hpr::detail::VisibilityResult exact = pclx::hpr::detail::computeVisibility (pts, opt);
  ASSERT_TRUE (exact.error.empty ()) << exact.error;
  std::size_t lost = 0, exact_visible = 0;
  for (std::size_t i = 0; i < pts.size (); ++i)
    if (exact.visible[i])
    {
      ++exact_visible;
      lost += mask[i];
    }
  EXPECT_GT (exact_visible, pts.size () / 5);
  EXPECT_EQ (lost, 0u) << "of " << exact_visible << " exact-visible points";
  // The wide grid: no cut.
  std::size_t cut_wide = 1;
  cull (inside, 2, &cut_wide);
  EXPECT_EQ (cut_wide, 0u);
}
