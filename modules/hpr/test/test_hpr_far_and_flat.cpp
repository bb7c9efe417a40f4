// HPRFilter where HPR is ill-posed or numerically hard: viewpoints far from the object, and flat
// clouds seen edge-on. Every method, calibrated parameters (what a new user gets).
#include "hpr_test_util.h"

#include <pclx/hpr/hpr_filter.h>
#include <pclx/testing/shapes.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

using namespace pclx::testing;
using hprtest::xyz;
using Filter = pcl::HPRFilter<pcl::PointXYZ>;
using Method = Filter::Method;

namespace {
const Method kAll[] = {Method::AUTO,   Method::EXACT,  Method::ANGULAR_GRID, Method::CANDIDATE_HULL,
                       Method::BENTLEY_FAUST_PREPARATA, Method::KAVAN, Method::HYBRID};

const char*
name (Method m)
{
  static const char* names[] = {"AUTO", "EXACT", "ANGULAR_GRID", "CANDIDATE_HULL", "BFP", "KAVAN", "HYBRID"};
  return names[int (m)];
}

pcl::Indices
run (Filter& f)
{
  pcl::Indices out;
  f.filter (out);
  return out;
}

// Methods that report hull vertices of a sampled subset (BFP, Kavan, hybrid) see far fewer
// points than the cap holds: they are held to "one cap, near side", not to its share.
bool
subsetMethod (Method m)
{
  return m == Method::BENTLEY_FAUST_PREPARATA || m == Method::KAVAN || m == Method::HYBRID;
}
}  // namespace

TEST (HPRFarViewpoint, SphereShowsOneCapFromFarAway)
{
  // Unit sphere, diameter 2; viewpoints at 100× and 1000× the diameter, off-axis.
  // From distance D the visible cap is p·Ĉ > 1/D: a share of (1 − 1/D)/2 ≈ 0.5 minus the cap loss.
  const auto cloud = xyz (sampleUniform (makeSphere (1.f, 5), 30000, 41));
  const Eigen::Vector3f dir = Eigen::Vector3f (0.3f, -0.5f, 0.8f).normalized ();
  for (const float times : {3.f, 100.f, 1000.f})  // 3×: the reference the far views must match
  {
    const Eigen::Vector3f C = dir * (2.f * times);
    std::vector<bool> truth (cloud->size ());
    for (std::size_t i = 0; i < cloud->size (); ++i)
      truth[i] = (*cloud)[i].getVector3fMap ().dot (C) > 1.f;
    for (const Method m : kAll)
    {
      Filter f;
      f.setInputCloud (cloud);
      f.setViewPoint (C);
      f.setMethod (m);
      if (m == Method::KAVAN)
        f.setSectorCount (2000);  // O(k²): the calibrated k is for the other methods
      const pcl::Indices vis = run (f);
      const double share = double (vis.size ()) / double (cloud->size ());
      const double cap = (1.0 - 1.0 / C.norm ()) / 2;  // the true visible share
      // CANDIDATE_HULL keeps back points in its grid's outermost ring of cells (no quad
      // beyond the rim covers them): about one cell, 1/50 of the disc radius here, i.e.
      // p·Ĉ down to −0.3. That is its known precision gap (docs/hpr.md), the same at
      // every distance; the failure this test pins is the whole sphere being visible.
      const float band = m == Method::CANDIDATE_HULL || m == Method::AUTO ? -0.35f : -0.05f;
      std::size_t near_side = 0;
      for (const auto i : vis)
        near_side += (*cloud)[i].getVector3fMap ().dot (dir) > band;
      const auto sc = hprtest::score (vis, truth);
      std::printf ("%gx %-15s share %.3f near %.4f P %.3f R %.3f F1 %.3f R/d %.3g\n", times, name (m), share,
                   double (near_side) / std::max<std::size_t> (vis.size (), 1), sc.precision, sc.recall, sc.f1,
                   f.getRadiusUsed () / 2.0);
      const std::string what = std::string (name (m)) + " at " + std::to_string (int (times)) + "x";
      // One cap, not the whole sphere (the failure was: every point visible) ...
      EXPECT_LT (share, 1.3 * cap) << what;  // the whole sphere would be 2 × cap
      // ... on the side facing the viewer (a band around the silhouette allowed).
      EXPECT_GT (double (near_side), 0.99 * double (vis.size ())) << what;
      if (subsetMethod (m))
        EXPECT_GT (share, 0.1 * cap) << what;
      else
      {
        EXPECT_GT (share, 0.75 * cap) << what;  // the grid's recall is ~0.8 at the calibrated k
        EXPECT_GT (sc.f1, 0.85) << what;
      }
    }
  }
}

TEST (HPRFarViewpoint, ExactAgreesAcrossDistancesOnAConcaveScene)
{
  // The same scene from the same direction at 3×, 100× and 1000× the diameter: the exact
  // operator with R ∝ distance² (the calibrated R keeps the angular occlusion criterion) sees
  // nearly the same set: the far view is orthographic, and its precision must not depend on
  // the distance (p − C in double, then everything relative to C).
  const auto cloud = xyz (sampleUniform (makeTorus (1.f, 0.35f, 160, 64), 20000, 9));
  const Eigen::Vector3f dir = Eigen::Vector3f (0.1f, -0.8f, 0.6f).normalized ();
  const float diameter = 2.7f;
  std::vector<pcl::Indices> sets;
  for (const float times : {30.f, 100.f, 1000.f})
  {
    Filter f;
    f.setInputCloud (cloud);
    f.setViewPoint (dir * diameter * times);
    f.setMethod (Method::EXACT);
    sets.push_back (run (f));
  }
  EXPECT_GT (hprtest::jaccard (sets[0], sets[1]), 0.97);
  EXPECT_GT (hprtest::jaccard (sets[1], sets[2]), 0.99);
}

TEST (HPRFlatInput, EdgeOnPlaneIsAllVisibleForEveryMethod)
{
  // A tilted square patch with the viewpoint in its plane: a sheet seen exactly edge-on.
  // Defined answer: every point is on the silhouette, so all are visible (HPRFilter docs).
  const Eigen::Vector3f o (0.3f, -0.2f, 1.f);
  const Eigen::Vector3f u = Eigen::Vector3f (1.f, 0.2f, -0.1f).normalized ();
  const Eigen::Vector3f v = u.cross (Eigen::Vector3f (0.1f, 0.3f, 1.f)).normalized ();
  pcl::PointCloud<pcl::PointXYZ>::Ptr plane (new pcl::PointCloud<pcl::PointXYZ>);
  for (int i = 0; i < 160; ++i)
    for (int j = 0; j < 160; ++j)
    {
      const Eigen::Vector3f p = o + u * (i * 0.01f) + v * (j * 0.01f);
      plane->push_back (pcl::PointXYZ (p.x (), p.y (), p.z ()));
    }
  // Viewpoints in the plane: beside an edge, beyond a corner, and far away.
  for (const Eigen::Vector3f C : {Eigen::Vector3f (o - u * 0.5f + v * 0.8f), Eigen::Vector3f (o - u - v),
                                  Eigen::Vector3f (o + u * 400.f + v * 100.f)})
    for (const Method m : kAll)
    {
      Filter f (true);
      f.setInputCloud (plane);
      f.setViewPoint (C);
      f.setMethod (m);
      EXPECT_EQ (run (f).size (), plane->size ()) << name (m) << " from " << C.transpose ();
      EXPECT_TRUE (f.getRemovedIndices ()->empty ());
    }
  // A line (always in a plane through C) is edge-on too: all visible.
  pcl::PointCloud<pcl::PointXYZ>::Ptr line (new pcl::PointCloud<pcl::PointXYZ>);
  for (int i = 0; i < 100; ++i)
    line->push_back (pcl::PointXYZ (i * 0.01f, 0.5f, -0.2f));
  for (const Method m : kAll)
  {
    Filter f;
    f.setInputCloud (line);
    f.setViewPoint (Eigen::Vector3f (0.5f, 1.f, 0.f));
    f.setMethod (m);
    EXPECT_EQ (run (f).size (), line->size ()) << name (m);
  }
  // Lifted off the plane by 1 % of its size (no longer edge-on): the rule does not fire,
  // and a plane seen from just off itself is still (nearly) all visible, as the flip says.
  Filter f;
  f.setInputCloud (plane);
  f.setMethod (Method::EXACT);
  const Eigen::Vector3f n = u.cross (v);
  f.setViewPoint (o - u * 0.5f + v * 0.8f + n * 0.016f);
  EXPECT_GT (run (f).size (), 0.9 * plane->size ());
  // Two parallel sheets are not flat: the far one is hidden behind the near one.
  pcl::PointCloud<pcl::PointXYZ>::Ptr two (new pcl::PointCloud<pcl::PointXYZ> (*plane));
  for (const auto& p : *plane)
    two->push_back (pcl::PointXYZ (p.x + 0.3f * n.x (), p.y + 0.3f * n.y (), p.z + 0.3f * n.z ()));
  f.setInputCloud (two);
  f.setViewPoint (o + u * 0.8f + v * 0.8f - n * 2.f);
  const pcl::Indices vis = run (f);
  EXPECT_LT (vis.size (), 0.6 * two->size ());
}

TEST (HPRFarViewpoint, FilterKeepsTheDoublePrecisionOfPMinusC)
{
  // p − C at 1000× the diameter: in float its ulp is ~1e-4 of the diameter, comparable to
  // the depth differences that decide hull vertices at a distance-scaled R. The filter must
  // give the visible set of the operator on p − C formed in double (and its interior
  // pre-filter, whose margin scales with R, must change nothing at this distance either).
  const auto cloud = xyz (sampleUniform (makeTorus (1.f, 0.35f, 160, 64), 20000, 13));
  const Eigen::Vector3f C = Eigen::Vector3f (0.37f, -0.81f, 0.45f).normalized () * 2700.f;
  const std::vector<Eigen::Vector3d> rel = hprtest::relativeTo (*cloud, C);
  for (const double R_over_d : {1e5, 1e7})
  {
    pclx::hpr::detail::VisibilityOptions opt;
    opt.method = pclx::hpr::detail::VisibilityMethod::EXACT;
    opt.radius = R_over_d * 2.7;
    opt.exact_prefilter = false;  // Qhull on every point: the filter's pre-filter must not change it
    const pclx::hpr::detail::VisibilityResult ref = pclx::hpr::detail::computeVisibility (rel, opt);
    pcl::Indices expected;
    for (std::size_t i = 0; i < rel.size (); ++i)
      if (ref.visible[i])
        expected.push_back (int (i));
    Filter f;
    f.setInputCloud (cloud);
    f.setViewPoint (C);
    f.setMethod (Method::EXACT);
    f.setRadius (opt.radius);
    const pcl::Indices vis = run (f);
    EXPECT_GT (expected.size (), 1000u);
    EXPECT_GT (hprtest::jaccard (vis, expected), 0.9999) << "R = " << R_over_d << " d";
  }
}
