// pclx::surface::detail::fillSmallHoles, and RBFPOUReconstruction's hole filling on scan-like input.
#include <pclx/surface/detail/hole_filling.h>
#include <pclx/surface/rbf_pou_reconstruction.h>
#include <pclx/testing/degradation.h>
#include <pclx/testing/mesh_sampling.h>
#include <pclx/testing/shapes.h>

#include <pcl/conversions.h>

#include <gtest/gtest.h>

#include <omp.h>

#include <algorithm>
#include <map>
#include <numeric>
#include <random>
#include <utility>

namespace {

using pclx::surface::detail::fillSmallHoles;
using pclx::surface::detail::HoleFillingStats;
using pclx::surface::detail::Triangle;

struct Mesh
{
  std::vector<Eigen::Vector3f> vertices;
  std::vector<Triangle> triangles;
};

// The unit icosphere without the triangles whose centroid lies within a hole's radius of the
// hole's point on the sphere: one round hole per (direction, radius).
Mesh
sphereWithHoles (const std::vector<std::pair<Eigen::Vector3f, float>>& holes)
{
  const auto sphere = pclx::testing::makeSphere (1.f, 4);
  Mesh m;
  m.vertices = sphere.vertices;
  for (const auto& f : sphere.faces)
  {
    const Eigen::Vector3f c = (sphere.vertices[f[0]] + sphere.vertices[f[1]] + sphere.vertices[f[2]]) / 3.f;
    const bool cut = std::any_of (holes.begin (), holes.end (), [&] (const auto& h) {
      return (c - h.first.normalized ()).norm () < h.second;
    });
    if (cut)
      continue;
    m.triangles.push_back ({std::uint32_t (f[0]), std::uint32_t (f[1]), std::uint32_t (f[2])});
  }
  return m;
}

// How many triangles use each edge, whatever its direction (smaller index first).
std::map<std::pair<std::uint32_t, std::uint32_t>, int>
undirectedEdgeUses (const std::vector<Triangle>& triangles)
{
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> uses;
  for (const auto& t : triangles)
    for (int j = 0; j < 3; ++j)
      ++uses[{std::min (t[j], t[(j + 1) % 3]), std::max (t[j], t[(j + 1) % 3])}];
  return uses;
}

std::size_t
boundaryEdges (const std::vector<Triangle>& triangles)
{
  const auto uses = undirectedEdgeUses (triangles);
  std::size_t open = 0;
  for (const auto& [e, n] : uses)
    open += n == 1;
  return open;
}

std::size_t
boundaryEdges (const std::vector<pcl::Vertices>& polygons)
{
  std::vector<Triangle> triangles;
  for (const auto& p : polygons)
    triangles.push_back ({std::uint32_t (p.vertices[0]), std::uint32_t (p.vertices[1]), std::uint32_t (p.vertices[2])});
  return boundaryEdges (triangles);
}

// Boundary loops counted as fillSmallHoles counts holes: connected groups of the vertices on
// edges that only one triangle uses (loops that share a vertex are one group).
std::size_t
boundaryGroups (const std::vector<Triangle>& triangles)
{
  const auto uses = undirectedEdgeUses (triangles);
  std::map<std::uint32_t, std::uint32_t> parent;
  const auto root = [&] (std::uint32_t v) {
    while (parent[v] != v)
      v = parent[v];
    return v;
  };
  for (const auto& [e, n] : uses)
    if (n == 1)
    {
      parent.emplace (e.first, e.first);
      parent.emplace (e.second, e.second);
      parent[root (e.first)] = root (e.second);
    }
  std::size_t groups = 0;
  for (const auto& [v, p] : parent)
    groups += v == p;
  return groups;
}

// Directed edges used by more than one triangle: an edge of more than two triangles, or of two
// of opposite orientations.
std::size_t
repeatedEdges (const std::vector<Triangle>& triangles)
{
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> uses;
  for (const auto& t : triangles)
    for (int j = 0; j < 3; ++j)
      ++uses[{t[j], t[(j + 1) % 3]}];
  return std::count_if (uses.begin (), uses.end (), [] (const auto& e) { return e.second > 1; });
}

// The unit icosphere without two pairs of triangles on opposite sides of one vertex: each pair
// is a triangle of the vertex's fan and its neighbour across the edge facing the vertex, so the
// two holes touch at the vertex and their boundary passes through it twice.
Mesh
sphereWithPinchedHole ()
{
  Mesh m = sphereWithHoles ({});
  const std::uint32_t v = m.triangles.front ()[0];
  std::vector<std::size_t> fan;
  for (std::size_t t = 0; t < m.triangles.size (); ++t)
    if (std::find (m.triangles[t].begin (), m.triangles[t].end (), v) != m.triangles[t].end ())
      fan.push_back (t);
  // Two fan triangles that share no edge, and for each the triangle across its far edge.
  std::vector<std::size_t> cut;
  const auto shareEdge = [&] (std::size_t a, std::size_t b) {
    int common = 0;
    for (const std::uint32_t x : m.triangles[a])
      common += std::count (m.triangles[b].begin (), m.triangles[b].end (), x);
    return common >= 2;
  };
  for (const std::size_t b : fan)
    if (b != fan.front () && !shareEdge (fan.front (), b))
    {
      cut = {fan.front (), b};
      break;
    }
  for (const std::size_t f : std::vector<std::size_t> (cut))
    for (std::size_t t = 0; t < m.triangles.size (); ++t)
      if (std::find (fan.begin (), fan.end (), t) == fan.end () && shareEdge (f, t))
        cut.push_back (t);
  std::sort (cut.rbegin (), cut.rend ());
  for (const std::size_t t : cut)
    m.triangles.erase (m.triangles.begin () + std::ptrdiff_t (t));
  return m;
}

// A scan-like sample of the unit sphere: density falling 5× along x, 5 % of it in 5 holes.
pcl::PointCloud<pcl::PointNormal>::Ptr
scanLikeSphere (std::size_t n)
{
  auto s = pclx::testing::sampleDensityGradient (pclx::testing::makeSphere (1.f, 5), n, 0, 0.2f, 3);
  pclx::testing::applyShadowHoles (s, 0.05f, 5);
  return s.cloud.makeShared ();
}

}  // namespace

TEST (HoleFilling, ClosesTheHolesUpToTheLimitNearTheSurface)
{
  // Holes about 0.3 across at ±x, one about 1.0 across at +y; a limit of 0.6 closes the two.
  const std::pair<Eigen::Vector3f, float> small_x{Eigen::Vector3f::UnitX (), 0.15f},
      small_mx{-Eigen::Vector3f::UnitX (), 0.15f}, wide{Eigen::Vector3f::UnitY (), 0.5f};
  Mesh m = sphereWithHoles ({small_x, small_mx, wide});
  const Mesh before = m;
  HoleFillingStats stats;
  ASSERT_TRUE (fillSmallHoles (m.vertices, m.triangles, 0.6, stats));
  EXPECT_EQ (stats.holes, 3u);
  EXPECT_EQ (stats.filled, 2u);
  EXPECT_EQ (stats.too_large, 1u);
  EXPECT_EQ (stats.failed, 0u);
  EXPECT_EQ (stats.added_triangles, m.triangles.size () - before.triangles.size ());
  EXPECT_EQ (stats.added_vertices, m.vertices.size () - before.vertices.size ());
  // The input is kept as it was, and only the wide hole stays open.
  for (std::size_t i = 0; i < before.triangles.size (); ++i)
    ASSERT_EQ (m.triangles[i], before.triangles[i]);
  for (std::size_t v = 0; v < before.vertices.size (); ++v)
    ASSERT_EQ (m.vertices[v], before.vertices[v]);
  EXPECT_EQ (boundaryEdges (m.triangles), boundaryEdges (sphereWithHoles ({wide}).triangles));
  // The faired patches stay near the sphere they close.
  double worst = 0;
  for (std::size_t v = before.vertices.size (); v < m.vertices.size (); ++v)
    worst = std::max (worst, std::abs (double (m.vertices[v].norm ()) - 1.0));
  EXPECT_GT (m.vertices.size (), before.vertices.size ());
  EXPECT_LT (worst, 0.01);
  EXPECT_GT (stats.filled_area, 0.0);
}

TEST (HoleFilling, ClosesAHoleWhoseBoundaryPassesAVertexTwice)
{
  Mesh m = sphereWithPinchedHole ();
  const std::size_t input_triangles = m.triangles.size ();
  ASSERT_EQ (input_triangles, sphereWithHoles ({}).triangles.size () - 4);
  ASSERT_EQ (boundaryEdges (m.triangles), 8u);
  HoleFillingStats stats;
  ASSERT_TRUE (fillSmallHoles (m.vertices, m.triangles, 1.0, stats, pclx::surface::detail::kCubicSearchEdges));
  EXPECT_EQ (stats.holes, 1u);  // the two loops share the vertex: one hole
  EXPECT_EQ (stats.filled, 1u);
  EXPECT_EQ (stats.failed, 0u);
  EXPECT_EQ (boundaryEdges (m.triangles), 0u);
  EXPECT_EQ (repeatedEdges (m.triangles), 0u);
  EXPECT_GE (m.triangles.size (), input_triangles + 4);
  for (std::size_t v = 0; v < m.vertices.size (); ++v)
    EXPECT_NEAR (m.vertices[v].norm (), 1.f, 0.01f) << v;
}

TEST (HoleFilling, FindsEveryHoleWhateverTheOrderOfTheMesh)
{
  // Holes of many sizes at random places, some touching; then the vertices renumbered and the
  // triangles shuffled, so that the triangles around a hole are scattered through the arrays.
  std::mt19937 rng (7);
  std::uniform_real_distribution<float> coord (-1.f, 1.f), radius (0.04f, 0.3f);
  std::vector<std::pair<Eigen::Vector3f, float>> holes;
  for (int i = 0; i < 24; ++i)
    holes.emplace_back (Eigen::Vector3f (coord (rng), coord (rng), coord (rng)), radius (rng));
  const Mesh ordered = sphereWithHoles (holes);
  std::vector<std::uint32_t> number (ordered.vertices.size ());
  std::iota (number.begin (), number.end (), 0u);
  std::shuffle (number.begin (), number.end (), rng);
  Mesh m;
  m.vertices.resize (ordered.vertices.size ());
  for (std::size_t v = 0; v < number.size (); ++v)
    m.vertices[number[v]] = ordered.vertices[v];
  for (const Triangle& t : ordered.triangles)
    m.triangles.push_back ({number[t[0]], number[t[1]], number[t[2]]});
  std::shuffle (m.triangles.begin (), m.triangles.end (), rng);
  const std::size_t expected = boundaryGroups (m.triangles);
  ASSERT_GT (expected, 10u);

  for (Mesh input : {ordered, m})
  {
    HoleFillingStats stats;
    ASSERT_TRUE (fillSmallHoles (input.vertices, input.triangles, 10.0, stats, pclx::surface::detail::kCubicSearchEdges));
    EXPECT_EQ (stats.holes, expected);
    EXPECT_EQ (stats.filled, expected);
    EXPECT_EQ (boundaryEdges (input.triangles), 0u);
    EXPECT_EQ (repeatedEdges (input.triangles), 0u);
  }
}

TEST (HoleFilling, SamePatchesOnAnyThreadCountAndFromTheCache)
{
  // Round holes of many sizes, one too large for the limit, and single missing triangles (closed
  // without a search): the holes are searched in parallel, and their patches must be appended
  // in hole order, each made from the mesh as it came in.
  std::mt19937 rng (11);
  std::uniform_real_distribution<float> coord (-1.f, 1.f), radius (0.04f, 0.25f);
  std::vector<std::pair<Eigen::Vector3f, float>> holes{{Eigen::Vector3f::UnitZ (), 0.7f}};
  for (int i = 0; i < 30; ++i)
    holes.emplace_back (Eigen::Vector3f (coord (rng), coord (rng), coord (rng)), radius (rng));
  Mesh input = sphereWithHoles (holes);
  for (int i = 0; i < 12; ++i)
    input.triangles.erase (input.triangles.begin () + std::ptrdiff_t (rng () % input.triangles.size ()));
  const int saved = omp_get_max_threads ();
  const auto fill = [&] (int threads, pclx::surface::detail::HolePatchCache* cache, HoleFillingStats& stats) {
    omp_set_num_threads (threads);
    Mesh m = input;
    EXPECT_TRUE (fillSmallHoles (m.vertices, m.triangles, 1.0, stats, pclx::surface::detail::kCubicSearchEdges, cache));
    omp_set_num_threads (saved);
    return m;
  };
  HoleFillingStats one_stats, two_stats, first_stats, again_stats;
  const Mesh one = fill (1, nullptr, one_stats);
  const Mesh two = fill (2, nullptr, two_stats);
  pclx::surface::detail::HolePatchCache cache;
  const Mesh first = fill (2, &cache, first_stats);
  const Mesh again = fill (2, &cache, again_stats);
  ASSERT_GT (one_stats.filled, 20u);
  EXPECT_EQ (one_stats.too_large, 1u);
  // The second call with the cache searched nothing: every searched hole's patch came from it.
  EXPECT_GT (cache.hits, 10u);
  EXPECT_EQ (cache.hits, cache.entries.size ());
  for (const Mesh* m : {&two, &first, &again})
  {
    EXPECT_EQ (m->triangles, one.triangles);
    EXPECT_EQ (m->vertices, one.vertices);
  }
  for (const HoleFillingStats* s : {&two_stats, &first_stats, &again_stats})
  {
    EXPECT_EQ (s->holes, one_stats.holes);
    EXPECT_EQ (s->filled, one_stats.filled);
    EXPECT_EQ (s->failed, one_stats.failed);
    EXPECT_EQ (s->added_vertices, one_stats.added_vertices);
    EXPECT_EQ (s->added_triangles, one_stats.added_triangles);
    EXPECT_EQ (s->filled_area, one_stats.filled_area);
  }
}

TEST (HoleFilling, BadInputLeavesTheMeshUnchanged)
{
  Mesh m = sphereWithHoles ({{Eigen::Vector3f::UnitX (), 0.15f}});
  HoleFillingStats stats;
  const Mesh before = m;
  for (const double bad : {0.0, -1.0, std::numeric_limits<double>::quiet_NaN ()})
  {
    EXPECT_FALSE (fillSmallHoles (m.vertices, m.triangles, bad, stats)) << bad;
    EXPECT_EQ (m.triangles.size (), before.triangles.size ());
  }
  // Three triangles on one edge: not a 2-manifold.
  Mesh fan;
  fan.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}};
  for (const std::uint32_t apex : {2u, 3u, 4u})
    fan.triangles.push_back ({0u, 1u, apex});
  const Mesh fan_before = fan;
  EXPECT_FALSE (fillSmallHoles (fan.vertices, fan.triangles, 10.0, stats));
  EXPECT_EQ (fan.triangles.size (), fan_before.triangles.size ());
  EXPECT_EQ (fan.vertices.size (), fan_before.vertices.size ());
  // Four triangles on one edge, two of each orientation, at the fan's open rim.
  Mesh balanced;
  balanced.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  balanced.triangles = {{0u, 1u, 2u}, {1u, 0u, 3u}, {0u, 1u, 4u}, {1u, 0u, 5u}};
  EXPECT_FALSE (fillSmallHoles (balanced.vertices, balanced.triangles, 10.0, stats));
  EXPECT_EQ (balanced.triangles.size (), 4u);
  EXPECT_EQ (balanced.vertices.size (), 6u);
  // A closed mesh has nothing to fill.
  Mesh closed = sphereWithHoles ({});
  ASSERT_TRUE (fillSmallHoles (closed.vertices, closed.triangles, 1.0, stats));
  EXPECT_EQ (stats.holes, 0u);
}

TEST (RBFPOUReconstruction, ScanLikeInputHasItsHolesClosed)
{
  // Uneven density reads as a scan, so the holes are closed by default; setMaxHoleSize (0)
  // leaves them open, and uniform samples are never filled.
  const auto scan = scanLikeSphere (30000);
  pcl::RBFPOUReconstruction<pcl::PointNormal> filled, open;
  filled.setInputCloud (scan);
  open.setInputCloud (scan);
  open.setMaxHoleSize (0);
  pcl::PolygonMesh a, b;
  filled.reconstruct (a);
  open.reconstruct (b);
  ASSERT_FALSE (a.polygons.empty ());
  ASSERT_FALSE (b.polygons.empty ());
  const auto& s = filled.getStats ();
  EXPECT_GT (s.density_spread, filled.kScanDensitySpread);
  EXPECT_GT (s.holes_filled, 0u);
  EXPECT_GT (boundaryEdges (b.polygons), 0u);
  EXPECT_EQ (boundaryEdges (a.polygons), 0u) << s.holes_filled << " of " << s.holes << " holes closed, up to "
                                             << s.max_hole_size << " (spacing " << s.mean_spacing << ")";
  EXPECT_EQ (open.getStats ().holes_filled, 0u);
  pcl::PointCloud<pcl::PointXYZ> v;
  pcl::fromPCLPointCloud2 (a.cloud, v);
  double worst = 0;
  for (const auto& p : v)
    worst = std::max (worst, std::abs (double (p.getVector3fMap ().norm ()) - 1.0));
  EXPECT_LT (worst, 0.02);

  auto uniform = pclx::testing::sampleUniform (pclx::testing::makeSphere (1.f, 5), 30000, 4).cloud.makeShared ();
  pcl::RBFPOUReconstruction<pcl::PointNormal> plain;
  plain.setInputCloud (uniform);
  pcl::PolygonMesh c;
  plain.reconstruct (c);
  EXPECT_LT (plain.getStats ().density_spread, plain.kScanDensitySpread);
  EXPECT_EQ (plain.getStats ().max_hole_size, 0.0);
}

TEST (RBFPOUReconstruction, BadHoleSizeIsRefused)
{
  const auto scan = scanLikeSphere (3000);
  for (const double bad : {-1.0, std::numeric_limits<double>::infinity ()})
  {
    pcl::RBFPOUReconstruction<pcl::PointNormal> rbf;
    rbf.setInputCloud (scan);
    rbf.setMaxHoleSize (bad);
    pcl::PolygonMesh mesh;
    rbf.reconstruct (mesh);
    EXPECT_TRUE (mesh.polygons.empty ()) << bad;
    EXPECT_NE (rbf.getLastError ().find ("hole"), std::string::npos) << rbf.getLastError ();
  }
}
