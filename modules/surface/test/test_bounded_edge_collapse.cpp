// pclx::surface::detail::collapseEdgesWithinDistance: the edge collapse that simplifies
// incremental dual contouring's mesh beyond its octree.
#include <pclx/surface/detail/bounded_edge_collapse.h>
#include <pclx/surface/detail/plane_set_bound.h>
#include <pclx/testing/shapes.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <utility>

namespace {

using pclx::surface::detail::collapseEdgesWithinDistance;
using pclx::surface::detail::EdgeCollapseStats;
using pclx::surface::detail::PlaneSetBound;
using pclx::surface::detail::Triangle;
using pclx::surface::detail::VertexPlanes;

struct Mesh
{
  std::vector<Eigen::Vector3f> vertices;
  std::vector<Triangle> triangles;
  VertexPlanes planes;
};

// An n × n grid of squares of side s on z = 0 with noise of `sigma` in z; every vertex stands
// for the true plane z = 0. Squares with both indices in [hole_lo, hole_hi) are left out.
Mesh
noisyGrid (int n, float s, float sigma, int hole_lo = 0, int hole_hi = 0)
{
  Mesh m;
  std::mt19937 rng (7);
  std::normal_distribution<float> g (0.f, sigma);
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i)
      m.vertices.emplace_back (i * s, j * s, g (rng));
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
    {
      if (i >= hole_lo && i < hole_hi && j >= hole_lo && j < hole_hi)
        continue;
      const std::uint32_t a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      m.triangles.push_back ({a, b, d});
      m.triangles.push_back ({a, d, c});
    }
  m.planes.begin.push_back (0);
  for (std::size_t v = 0; v < m.vertices.size (); ++v)
  {
    m.planes.planes.emplace_back (0.f, 0.f, 1.f, 0.f);
    m.planes.begin.push_back (static_cast<std::uint32_t> (m.planes.planes.size ()));
  }
  return m;
}

// Edges used once and more than twice, and the number of boundary loops.
struct Topology
{
  std::size_t boundary = 0, nonmanifold = 0, loops = 0;
  long euler = 0;
};

Topology
topology (const Mesh& m)
{
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> uses;
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k)
      ++uses[std::minmax (t[k], t[(k + 1) % 3])];
  Topology r;
  std::map<std::uint32_t, std::vector<std::uint32_t>> next;
  for (const auto& [e, n] : uses)
  {
    r.boundary += n == 1;
    r.nonmanifold += n > 2;
    if (n == 1)
    {
      next[e.first].push_back (e.second);
      next[e.second].push_back (e.first);
    }
  }
  std::set<std::uint32_t> seen;
  for (const auto& [v, nb] : next)
  {
    if (seen.count (v))
      continue;
    ++r.loops;
    std::vector<std::uint32_t> stack{v};
    while (!stack.empty ())
    {
      const std::uint32_t u = stack.back ();
      stack.pop_back ();
      if (!seen.insert (u).second)
        continue;
      for (std::uint32_t w : next[u])
        stack.push_back (w);
    }
  }
  r.euler = static_cast<long> (m.vertices.size ()) - static_cast<long> (uses.size ()) +
            static_cast<long> (m.triangles.size ());
  return r;
}

double
area (const Mesh& m)
{
  double a = 0;
  for (const auto& t : m.triangles)
    a += 0.5 * (m.vertices[t[1]] - m.vertices[t[0]]).cross (m.vertices[t[2]] - m.vertices[t[0]]).norm ();
  return a;
}

TEST (BoundedEdgeCollapse, NoisyPlaneBecomesFewTrianglesWithinTheBound)
{
  const int n = 40;
  const float s = 0.01f, eps = 0.002f;
  Mesh m = noisyGrid (n, s, 0.0005f);
  const double area0 = area (m);
  EdgeCollapseStats st;
  ASSERT_TRUE (collapseEdgesWithinDistance (m.vertices, m.triangles, m.planes, eps, 1024, st));
  EXPECT_EQ (st.input_triangles, std::size_t (2 * n * n));
  EXPECT_EQ (st.triangles, m.triangles.size ());
  EXPECT_LT (m.triangles.size () * 20, st.input_triangles) << m.triangles.size ();
  EXPECT_LE (st.max_distance, eps);
  for (const auto& v : m.vertices)
  {
    EXPECT_LE (std::abs (v.z ()), eps + 1e-6f);
    // The border stays where it was: planes through the boundary edges bound it too.
    EXPECT_GE (v.x (), -eps);
    EXPECT_GE (v.y (), -eps);
    EXPECT_LE (v.x (), n * s + eps);
    EXPECT_LE (v.y (), n * s + eps);
  }
  const Topology t = topology (m);
  EXPECT_EQ (t.nonmanifold, 0u);
  EXPECT_EQ (t.loops, 1u);
  EXPECT_EQ (t.euler, 1);  // still a disk
  EXPECT_NEAR (area (m), area0, 4 * n * s * eps);
}

TEST (BoundedEdgeCollapse, HoleNeitherOpensNorCloses)
{
  const int n = 30;
  const float s = 0.01f, eps = 0.003f;
  Mesh m = noisyGrid (n, s, 0.0005f, 12, 18);
  const Topology before = topology (m);
  ASSERT_EQ (before.loops, 2u);
  EdgeCollapseStats st;
  ASSERT_TRUE (collapseEdgesWithinDistance (m.vertices, m.triangles, m.planes, eps, 1024, st));
  EXPECT_LT (m.triangles.size () * 5, st.input_triangles);
  const Topology after = topology (m);
  EXPECT_EQ (after.loops, 2u);
  EXPECT_EQ (after.euler, 0);  // still an annulus (the hole's unused vertices are gone)
  EXPECT_EQ (after.nonmanifold, 0u);
  // No triangle reaches into the hole by more than the bound.
  const float lo = 12 * s + eps, hi = 18 * s - eps;
  for (const auto& t : m.triangles)
  {
    const Eigen::Vector3f c = (m.vertices[t[0]] + m.vertices[t[1]] + m.vertices[t[2]]) / 3.f;
    EXPECT_FALSE (c.x () > lo && c.x () < hi && c.y () > lo && c.y () < hi) << c.transpose ();
  }
}

TEST (BoundedEdgeCollapse, ClosedSphereStaysClosedAndNearItsPlanes)
{
  const auto sphere = pclx::testing::makeSphere (1.f, 4);
  Mesh m;
  m.vertices = sphere.vertices;
  for (const auto& f : sphere.faces)
    m.triangles.push_back ({std::uint32_t (f[0]), std::uint32_t (f[1]), std::uint32_t (f[2])});
  m.planes.begin.push_back (0);
  for (const auto& v : m.vertices)
  {
    const Eigen::Vector3f nrm = v.normalized ();
    m.planes.planes.emplace_back (nrm.x (), nrm.y (), nrm.z (), -nrm.dot (v));
    m.planes.begin.push_back (static_cast<std::uint32_t> (m.planes.planes.size ()));
  }
  auto volume = [&m] () {
    double v = 0;
    for (const auto& f : m.triangles)
      v += m.vertices[f[0]].cast<double> ().dot (m.vertices[f[1]].cast<double> ().cross (m.vertices[f[2]].cast<double> ())) / 6;
    return v;
  };
  const double volume0 = volume ();
  const float eps = 0.01f;
  EdgeCollapseStats st;
  ASSERT_TRUE (collapseEdgesWithinDistance (m.vertices, m.triangles, m.planes, eps, 1024, st));
  EXPECT_LT (m.triangles.size () * 2, st.input_triangles);
  EXPECT_LE (st.max_distance, eps);
  const Topology t = topology (m);
  EXPECT_EQ (t.boundary, 0u);
  EXPECT_EQ (t.nonmanifold, 0u);
  EXPECT_EQ (t.euler, 2);
  // The bound is on the tangent planes a vertex replaced, which lie close together: the
  // vertex stays near the sphere, though not within ε of it exactly.
  for (const auto& v : m.vertices)
    EXPECT_NEAR (v.norm (), 1.f, 2 * eps);
  // Still outward, and the enclosed volume about the same.
  EXPECT_NEAR (volume (), volume0, 0.02 * volume0);
}

TEST (BoundedEdgeCollapse, VerticesWithoutPlanesStay)
{
  Mesh m = noisyGrid (20, 0.01f, 0.f);
  // The planes of the middle row of vertices are taken away: those vertices must not move.
  VertexPlanes vp;
  vp.begin.push_back (0);
  std::vector<Eigen::Vector3f> fixed;
  for (std::size_t v = 0; v < m.vertices.size (); ++v)
  {
    if (v / 21 == 10)
      fixed.push_back (m.vertices[v]);
    else
      vp.planes.emplace_back (0.f, 0.f, 1.f, 0.f);
    vp.begin.push_back (static_cast<std::uint32_t> (vp.planes.size ()));
  }
  EdgeCollapseStats st;
  ASSERT_TRUE (collapseEdgesWithinDistance (m.vertices, m.triangles, vp, 0.002, 1024, st));
  EXPECT_GT (st.collapses, 0u);
  for (const auto& p : fixed)
    EXPECT_TRUE (std::find (m.vertices.begin (), m.vertices.end (), p) != m.vertices.end ()) << p.transpose ();
}

// Planes near p: normals within `spread_deg` of a random direction (some flipped), offsets
// putting p within `offset` of each.
std::vector<Eigen::Vector4f>
planesNear (const Eigen::Vector3f& p, float spread_deg, float offset, std::mt19937& rng)
{
  std::uniform_int_distribution<int> count (1, 8);
  std::normal_distribution<float> g (0.f, 1.f);
  std::uniform_real_distribution<float> u (-1.f, 1.f);
  const Eigen::Vector3f base = Eigen::Vector3f (g (rng), g (rng), g (rng)).normalized ();
  std::vector<Eigen::Vector4f> planes;
  for (int k = count (rng); k > 0; --k)
  {
    const float tilt = spread_deg * static_cast<float> (M_PI) / 180.f * std::abs (u (rng));
    const Eigen::Vector3f side = base.cross (Eigen::Vector3f (g (rng), g (rng), g (rng))).normalized ();
    Eigen::Vector3f n = (std::cos (tilt) * base + std::sin (tilt) * side).normalized ();
    if (u (rng) > 0.8f)
      n = -n;
    planes.emplace_back (n.x (), n.y (), n.z (), -n.dot (p) + offset * u (rng));
  }
  return planes;
}

// The largest distance of x to the planes, in float as the collapse computes it.
float
largestDistance (const std::vector<Eigen::Vector4f>& planes, const Eigen::Vector3f& x)
{
  float worst = 0;
  for (const auto& pl : planes)
    worst = std::max (worst, std::abs (pl.head<3> ().dot (x) + pl[3]));
  return worst;
}

TEST (BoundedEdgeCollapse, PlaneSetBoundStaysAboveEveryDistance)
{
  std::mt19937 rng (11);
  std::uniform_real_distribution<float> u (-1.f, 1.f);
  std::uniform_real_distribution<float> spread (0.f, 120.f);
  const auto randomMove = [&] (float scale) -> Eigen::Vector3f {
    return Eigen::Vector3f (u (rng), u (rng), u (rng)) * scale;
  };
  for (int trial = 0; trial < 2000; ++trial)
  {
    // A cluster merged from up to six sets, as collapses merge vertices, far from the origin so
    // that the rounding slack matters.
    const Eigen::Vector3f centre = randomMove (50.f);
    Eigen::Vector3f at = centre + randomMove (0.01f);
    std::vector<Eigen::Vector4f> all = planesNear (at, spread (rng), 0.005f, rng);
    PlaneSetBound b = PlaneSetBound::of (all.data (), all.data () + all.size (), at);
    ASSERT_GE (b.reach, largestDistance (all, at) - PlaneSetBound::slackAt (at));
    for (int merges = static_cast<int> (rng () % 6); merges > 0; --merges)
    {
      const Eigen::Vector3f other_at = centre + randomMove (0.01f);
      const std::vector<Eigen::Vector4f> other = planesNear (other_at, spread (rng), 0.005f, rng);
      const PlaneSetBound ob = PlaneSetBound::of (other.data (), other.data () + other.size (), other_at);
      const Eigen::Vector3f x = centre + randomMove (0.01f);
      const float slack = PlaneSetBound::slackAt (x);
      const float reach = std::max (b.at (x - at, slack), ob.at (x - other_at, slack));
      b = PlaneSetBound::merge (b, static_cast<float> (all.size ()), ob, static_cast<float> (other.size ()), reach);
      all.insert (all.end (), other.begin (), other.end ());
      at = x;
    }
    for (float scale : {1e-4f, 1e-2f, 0.5f})
    {
      const Eigen::Vector3f delta = randomMove (scale), x = at + delta;
      ASSERT_GE (b.at (delta, PlaneSetBound::slackAt (x)), largestDistance (all, x)) << "trial " << trial;
    }
  }
  // On one plane, moving within it, the bound stays at the rounding slack: the collapse can
  // skip reading such a cluster's planes.
  const std::vector<Eigen::Vector4f> flat (5, Eigen::Vector4f (0.f, 0.f, 1.f, -2.f));
  const Eigen::Vector3f p (3.f, 4.f, 2.f);
  const PlaneSetBound fb = PlaneSetBound::of (flat.data (), flat.data () + flat.size (), p);
  EXPECT_LE (fb.at (Eigen::Vector3f (0.01f, -0.02f, 0.f), PlaneSetBound::slackAt (p)), 1e-4f);
  EXPECT_NEAR (fb.at (Eigen::Vector3f (0.f, 0.f, 0.003f), 0.f), 0.003f, 1e-6f);
}

TEST (BoundedEdgeCollapse, BadInputLeavesTheMeshUnchanged)
{
  const Mesh good = noisyGrid (4, 0.01f, 0.f);
  // Refused, with the vertices (bit for bit, NaN included) and triangles as they were.
  auto refused = [&] (const Mesh& in, double eps, std::size_t max_planes) {
    Mesh m = in;
    EdgeCollapseStats st;
    if (collapseEdgesWithinDistance (m.vertices, m.triangles, m.planes, eps, max_planes, st))
      return false;
    EXPECT_EQ (m.vertices.size (), in.vertices.size ());
    EXPECT_EQ (0, std::memcmp (m.vertices.data (), in.vertices.data (), in.vertices.size () * sizeof (in.vertices[0])));
    EXPECT_EQ (m.triangles, in.triangles);
    return true;
  };
  for (double eps : {0.0, -1.0, std::nan (""), std::numeric_limits<double>::infinity ()})
    EXPECT_TRUE (refused (good, eps, 1024)) << eps;
  EXPECT_TRUE (refused (good, 0.01, 0));
  Mesh out_of_range = good;
  out_of_range.triangles[3][1] = static_cast<std::uint32_t> (good.vertices.size ());
  EXPECT_TRUE (refused (out_of_range, 0.01, 1024));
  Mesh repeated = good;
  repeated.triangles[2][2] = repeated.triangles[2][0];
  EXPECT_TRUE (refused (repeated, 0.01, 1024));
  Mesh short_planes = good;
  short_planes.planes.begin.pop_back ();
  EXPECT_TRUE (refused (short_planes, 0.01, 1024));
  Mesh not_unit = good;
  not_unit.planes.planes[5] = Eigen::Vector4f (0.f, 0.f, 2.f, 0.f);
  EXPECT_TRUE (refused (not_unit, 0.01, 1024));
  Mesh nan_vertex = good;
  nan_vertex.vertices[7].x () = std::nanf ("");
  EXPECT_TRUE (refused (nan_vertex, 0.01, 1024));
  EXPECT_FALSE (refused (good, 0.01, 1024));
}

}  // namespace
