// Fairing solves a sparse system: CGAL's default solver is Eigen's.
#define CGAL_EIGEN3_ENABLED
#include <pclx/surface/detail/hole_filling.h>

#include <pcl/console/print.h>

#include <Eigen/Geometry>

#include <omp.h>

#include <CGAL/Polygon_mesh_processing/border.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <iterator>
#include <numeric>
#include <unordered_map>
#include <unordered_set>
#include <utility>

namespace pclx {
namespace surface {
namespace detail {

namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using Mesh = CGAL::Surface_mesh<Kernel::Point_3>;
using Halfedge = Mesh::Halfedge_index;

}  // namespace

struct HoleFillingScratch
{
  std::vector<std::uint64_t> balance, hash;               // OpenVertices
  std::vector<std::uint32_t> open;                        // OpenVertices
  std::vector<std::uint8_t> ring;                         // OpenVertices
  std::vector<std::uint32_t> begin, corner;               // HalfEdges
  std::vector<std::uint32_t> parent, group_of;            // findBoundaries
  // RingCollector's marks and LocalSurface's numbering, one set per thread of the search.
  struct RingMarks
  {
    std::vector<std::uint32_t> vertex_mark, triangle_mark, local_index;
  };
  std::vector<RingMarks> rings;
};

std::size_t
HolePatchCache::scratchBytes () const
{
  if (!scratch)
    return 0;
  const HoleFillingScratch& s = *scratch;
  std::size_t words = 0;
  for (const auto* v : {&s.open, &s.begin, &s.corner, &s.parent, &s.group_of})
    words += v->capacity ();
  for (const auto& r : s.rings)
    words += r.vertex_mark.capacity () + r.triangle_mark.capacity () + r.local_index.capacity ();
  return 4 * words + sizeof (std::uint64_t) * (s.balance.capacity () + s.hash.capacity ()) + s.ring.capacity ();
}

namespace {

// Sizes a working array for n elements: exactly the first time, and with a quarter more when it
// grows, so that a mesh growing frame by frame does not reallocate it every time.
template <typename T>
void
fitScratch (std::vector<T>& v, std::size_t n)
{
  if (v.capacity () < n)
  {
    const bool first = v.capacity () == 0;
    std::vector<T> ().swap (v);
    v.reserve (first ? n : n + n / 4);
  }
  v.resize (n);
}

// A 64-bit hash of a vertex index (splitmix64's finaliser).
std::uint64_t
spreadIndex (std::uint64_t x)
{
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// The vertices where the mesh may be open, and the triangles near them: all that the search for
// holes reads, so that its cost follows the holes instead of the mesh.
//
// Each corner of a triangle adds the hash of the vertex after it and subtracts the hash of the
// vertex before it. A vertex's sum is then the sum over its neighbours w of (uses of v → w minus
// uses of w → v) · hash (w): zero around a closed fan, and non-zero (but for a cancellation of
// 64-bit hashes) at both ends of a boundary edge and of an edge used more often in one direction
// than in the other. Such vertices are open.
struct OpenVertices
{
  std::vector<std::uint32_t>& vertices;       // the open vertices, in index order
  std::vector<std::uint32_t> near_triangles;  // within two rings of an open vertex, in index order

  OpenVertices (std::size_t num_vertices, const std::vector<Triangle>& triangles, HoleFillingScratch& s)
    : vertices (s.open)
  {
    sumAroundVertices (num_vertices, triangles, s);
    vertices.clear ();
    for (std::uint32_t v = 0; v < num_vertices; ++v)
      if (s.balance[v] != 0)
        vertices.push_back (v);
    if (!vertices.empty ())
      markNearTriangles (num_vertices, triangles, s.ring);
  }

private:
  // The sums. A vertex's hash depends on its index only, so the scratch keeps the hashes from
  // call to call and computes those of new indices.
  static void
  sumAroundVertices (std::size_t num_vertices, const std::vector<Triangle>& triangles, HoleFillingScratch& s)
  {
    const std::size_t known = s.hash.size ();
    if (known < num_vertices)
    {
      s.hash.resize (num_vertices);
#pragma omp parallel for schedule(static)
      for (std::ptrdiff_t v = static_cast<std::ptrdiff_t> (known); v < static_cast<std::ptrdiff_t> (num_vertices); ++v)
        s.hash[std::size_t (v)] = spreadIndex (std::uint64_t (v));
    }
    fitScratch (s.balance, num_vertices);
    std::fill (s.balance.begin (), s.balance.end (), std::uint64_t (0));
    std::vector<std::uint64_t>& sum = s.balance;
    const std::vector<std::uint64_t>& h = s.hash;
    for (const Triangle& t : triangles)
    {
      const std::uint64_t h0 = h[t[0]], h1 = h[t[1]], h2 = h[t[2]];
      sum[t[0]] += h1 - h2;
      sum[t[1]] += h2 - h0;
      sum[t[2]] += h0 - h1;
    }
  }
  // The triangles with a vertex in the first ring of an open vertex: every triangle a row of an
  // open vertex or of its first ring lists, which is what the boundary search and the two rings
  // around a hole read.
  void
  markNearTriangles (std::size_t num_vertices, const std::vector<Triangle>& triangles, std::vector<std::uint8_t>& ring)
  {
    enum : std::uint8_t { kFar = 0, kOpen = 1, kFirstRing = 2 };
    fitScratch (ring, num_vertices);
    std::fill (ring.begin (), ring.end (), std::uint8_t (kFar));
    for (const std::uint32_t v : vertices)
      ring[v] = kOpen;
    const auto any = [&] (const Triangle& t, auto is) { return is (ring[t[0]]) || is (ring[t[1]]) || is (ring[t[2]]); };
    const std::vector<std::uint32_t> at_open =
        selectTriangles (triangles, [&] (const Triangle& t) { return any (t, [] (std::uint8_t r) { return r == kOpen; }); });
    for (const std::uint32_t t : at_open)
      for (const std::uint32_t v : triangles[t])
        if (ring[v] == kFar)
          ring[v] = kFirstRing;
    near_triangles =
        selectTriangles (triangles, [&] (const Triangle& t) { return any (t, [] (std::uint8_t r) { return r != kFar; }); });
  }
  // The indices of the triangles that pass `keep`, in index order (threads take contiguous
  // blocks, joined in order).
  template <typename Keep>
  static std::vector<std::uint32_t>
  selectTriangles (const std::vector<Triangle>& triangles, const Keep& keep)
  {
    std::vector<std::vector<std::uint32_t>> parts (static_cast<std::size_t> (omp_get_max_threads ()));
#pragma omp parallel
    {
      std::vector<std::uint32_t>& mine = parts[static_cast<std::size_t> (omp_get_thread_num ())];
#pragma omp for schedule(static)
      for (std::ptrdiff_t t = 0; t < static_cast<std::ptrdiff_t> (triangles.size ()); ++t)
        if (keep (triangles[std::size_t (t)]))
          mine.push_back (static_cast<std::uint32_t> (t));
    }
    std::vector<std::uint32_t> out;
    for (const auto& part : parts)
      out.insert (out.end (), part.begin (), part.end ());
    return out;
  }
};

// The corners of the triangles near the open vertices, grouped by their vertex (compressed rows,
// in the scratch's arrays): a vertex's row lists its corners, each with the edge leaving the
// vertex and the edge entering it in that triangle, so a row answers every question about its
// vertex's edges. The rows of the open vertices and of their first ring are complete.
struct HalfEdges
{
  const std::vector<std::uint32_t>& begin;   // per vertex, and one past the last
  const std::vector<std::uint32_t>& corner;  // per row entry: 3 · triangle + the vertex's place in it
  const std::vector<Triangle>& triangles;

  HalfEdges (std::size_t num_vertices, const std::vector<Triangle>& mesh, const std::vector<std::uint32_t>& subset,
             HoleFillingScratch& s)
    : begin (s.begin), corner (s.corner), triangles (mesh)
  {
    fitScratch (s.begin, num_vertices + 1);
    std::fill (s.begin.begin (), s.begin.end (), 0u);
    for (const std::uint32_t t : subset)
      for (const std::uint32_t v : triangles[t])
        ++s.begin[v + 1];
    for (std::size_t v = 0; v < num_vertices; ++v)
      s.begin[v + 1] += s.begin[v];
    fitScratch (s.corner, 3 * subset.size ());
    // Each row is filled from its start, which moves to the next row's; then moved back.
    for (const std::uint32_t t : subset)
      for (std::uint32_t j = 0; j < 3; ++j)
        s.corner[s.begin[triangles[t][j]]++] = 3 * t + j;
    for (std::size_t v = num_vertices; v > 0; --v)
      s.begin[v] = s.begin[v - 1];
    s.begin[0] = 0;
  }
  std::uint32_t
  triangle (std::uint32_t k) const
  {
    return corner[k] / 3;
  }
  // The vertex `step` places after the row's vertex in the corner's triangle.
  std::uint32_t
  around (std::uint32_t k, std::uint32_t step) const
  {
    return triangles[corner[k] / 3][(corner[k] % 3 + step) % 3];
  }
  // The vertex after the row's vertex (edge v → target).
  std::uint32_t
  target (std::uint32_t k) const
  {
    return around (k, 1);
  }
  // The vertex before it (edge source → v).
  std::uint32_t
  source (std::uint32_t k) const
  {
    return around (k, 2);
  }
  // How often the directed edge a → b occurs.
  int
  count (std::uint32_t a, std::uint32_t b) const
  {
    return countInRow (a, b, 1);
  }
  // How often the directed edge b → a occurs, from a's row.
  int
  countInto (std::uint32_t a, std::uint32_t b) const
  {
    return countInRow (a, b, 2);
  }
  // How often b is `step` places after a in a's triangles.
  int
  countInRow (std::uint32_t a, std::uint32_t b, std::uint32_t step) const
  {
    int n = 0;
    for (std::uint32_t k = begin[a]; k < begin[a + 1]; ++k)
      n += around (k, step) == b;
    return n;
  }
};

// The boundary edges of an oriented 2-manifold, as connected groups of their vertices with the
// diagonal of each group's bounding box; false when an edge has two triangles of one
// orientation or more than two (then no halfedge structure holds the mesh).
struct BoundaryGroups
{
  std::vector<std::uint32_t>& group_of;  // per vertex: its group, or kNone when not on a boundary
  std::vector<double> diameter;          // per group
  static constexpr std::uint32_t kNone = ~std::uint32_t (0);
};

std::uint32_t
findRoot (std::vector<std::uint32_t>& parent, std::uint32_t v)
{
  while (parent[v] != v)
    v = parent[v] = parent[parent[v]];
  return v;
}

bool
findBoundaries (const std::vector<Eigen::Vector3f>& vertices, const OpenVertices& open, const HalfEdges& he,
                HoleFillingScratch& s, BoundaryGroups& out)
{
  const std::size_t n = vertices.size ();
  // A directed edge a → b is on a boundary when no edge b → a exists; one that is repeated or has
  // two twins is not a 2-manifold's. Both ends of such an edge are open (unless it is used
  // equally often each way), and a vertex's row answers both questions, so the open vertices'
  // rows are read in parallel, keeping only the boundary edges; they join into groups serially.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> boundary;
  bool manifold = true;
#pragma omp parallel reduction(&& : manifold)
  {
    std::vector<std::pair<std::uint32_t, std::uint32_t>> mine;
#pragma omp for schedule(static, 256) nowait
    for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t> (open.vertices.size ()); ++i)
    {
      const std::uint32_t a = open.vertices[std::size_t (i)], lo = he.begin[a], hi = he.begin[a + 1];
      // The row's edges, leaving and entering, read once into a small buffer (most vertices have a handful).
      std::array<std::uint32_t, 32> small_leaving, small_entering;
      std::vector<std::uint32_t> large_leaving, large_entering;
      const std::uint32_t d = hi - lo;
      std::uint32_t* leaving = small_leaving.data ();
      std::uint32_t* entering = small_entering.data ();
      if (d > small_leaving.size ())
      {
        large_leaving.resize (d);
        large_entering.resize (d);
        leaving = large_leaving.data ();
        entering = large_entering.data ();
      }
      for (std::uint32_t k = 0; k < d; ++k)
      {
        leaving[k] = he.target (lo + k);
        entering[k] = he.source (lo + k);
      }
      for (std::uint32_t k = 0; k < d; ++k)
      {
        const std::uint32_t b = leaving[k];
        int twins = 0;
        bool repeated = false;
        for (std::uint32_t j = 0; j < d; ++j)
        {
          twins += entering[j] == b;
          repeated = repeated || (j > k && leaving[j] == b);
        }
        manifold = manifold && !repeated && twins <= 1;
        if (twins == 0)
          mine.emplace_back (a, b);
      }
    }
#pragma omp critical(pclx_hole_boundaries)
    boundary.insert (boundary.end (), mine.begin (), mine.end ());
  }
  if (!manifold)
    return false;
  std::vector<std::uint32_t>& parent = s.parent;
  fitScratch (parent, n);
  std::fill (parent.begin (), parent.end (), BoundaryGroups::kNone);
  std::vector<std::uint32_t> on_boundary;
  for (const auto& [a, b] : boundary)
  {
    for (const std::uint32_t v : {a, b})
      if (parent[v] == BoundaryGroups::kNone)
      {
        parent[v] = v;
        on_boundary.push_back (v);
      }
    parent[findRoot (parent, a)] = findRoot (parent, b);
  }
  // Groups numbered in the order of their smallest vertex, whatever order the edges came in.
  std::sort (on_boundary.begin (), on_boundary.end ());
  fitScratch (out.group_of, n);
  std::fill (out.group_of.begin (), out.group_of.end (), BoundaryGroups::kNone);
  std::vector<Eigen::AlignedBox3d> boxes;
  for (const std::uint32_t v : on_boundary)
  {
    const std::uint32_t r = findRoot (parent, v);
    if (out.group_of[r] == BoundaryGroups::kNone)
    {
      out.group_of[r] = static_cast<std::uint32_t> (boxes.size ());
      boxes.emplace_back ();
    }
    out.group_of[v] = out.group_of[r];
    boxes[out.group_of[v]].extend (vertices[v].cast<double> ());
  }
  out.diameter.clear ();
  for (const auto& b : boxes)
    out.diameter.push_back (b.diagonal ().norm ());
  return true;
}

// Gathers the triangles within some rings of a set of vertices: enough of the surface around a
// hole for the patch's refinement and fairing, which read the ring around its boundary. Its
// marks are kept from call to call, so that each hole costs what its neighbourhood holds.
class RingCollector
{
public:
  RingCollector (const HalfEdges& he, const std::vector<Triangle>& triangles, HoleFillingScratch::RingMarks& s)
    : he_ (he)
    , triangles_ (triangles)
    , vertex_mark_ (s.vertex_mark)
    , triangle_mark_ (s.triangle_mark)
    , local_index_ (s.local_index)
  {
    fitScratch (vertex_mark_, he.begin.size () - 1);
    fitScratch (triangle_mark_, triangles.size ());
    fitScratch (local_index_, he.begin.size () - 1);
    std::fill (vertex_mark_.begin (), vertex_mark_.end (), 0u);
    std::fill (triangle_mark_.begin (), triangle_mark_.end (), 0u);
    std::fill (local_index_.begin (), local_index_.end (), kNoIndex);
  }

  static constexpr std::uint32_t kNoIndex = ~std::uint32_t (0);

  // The triangles in index order.
  std::vector<std::uint32_t>
  collect (std::vector<std::uint32_t> frontier, int rings)
  {
    ++stamp_;
    for (const std::uint32_t v : frontier)
      vertex_mark_[v] = stamp_;
    std::vector<std::uint32_t> out, next;
    for (int r = 0; r < rings; ++r)
    {
      next.clear ();
      for (const std::uint32_t v : frontier)
        for (std::uint32_t k = he_.begin[v]; k < he_.begin[v + 1]; ++k)
        {
          const std::uint32_t t = he_.triangle (k);
          if (triangle_mark_[t] == stamp_)
            continue;
          triangle_mark_[t] = stamp_;
          out.push_back (t);
          for (const std::uint32_t w : triangles_[t])
            if (vertex_mark_[w] != stamp_)
            {
              vertex_mark_[w] = stamp_;
              next.push_back (w);
            }
        }
      frontier.swap (next);
    }
    std::sort (out.begin (), out.end ());
    return out;
  }

  const HalfEdges&
  halfEdges () const
  {
    return he_;
  }

  // Per vertex of the mesh: kNoIndex, or its number in the local surface being numbered (which
  // sets every entry it used back to kNoIndex).
  std::vector<std::uint32_t>&
  localIndex ()
  {
    return local_index_;
  }

private:
  const HalfEdges& he_;
  const std::vector<Triangle>& triangles_;
  std::vector<std::uint32_t>& vertex_mark_;
  std::vector<std::uint32_t>& triangle_mark_;
  std::vector<std::uint32_t>& local_index_;
  std::uint32_t stamp_ = 0;
};

// The triangles around a hole in a numbering of their own: vertices in order of first use
// (`global` maps them back), the triangles in that numbering, then the hole's vertices; and a
// hash of all of it with the positions, the key of HolePatchCache.
struct LocalSurface
{
  std::vector<std::uint32_t> global;
  std::vector<Eigen::Vector3f> positions;
  std::vector<std::uint32_t> layout;
  std::uint64_t key = 0;

  // `local_index` holds RingCollector::kNoIndex for every vertex, and does again on return.
  LocalSurface (const std::vector<Eigen::Vector3f>& vertices, const std::vector<Triangle>& triangles,
                const std::vector<std::uint32_t>& subset, const std::vector<std::uint32_t>& hole,
                std::vector<std::uint32_t>& local_index)
  {
    auto localOf = [&] (std::uint32_t v) {
      std::uint32_t& i = local_index[v];
      if (i == RingCollector::kNoIndex)
      {
        i = static_cast<std::uint32_t> (global.size ());
        global.push_back (v);
        positions.push_back (vertices[v]);
      }
      return i;
    };
    layout.reserve (3 * subset.size () + hole.size ());
    for (const std::uint32_t t : subset)
      for (const std::uint32_t v : triangles[t])
        layout.push_back (localOf (v));
    for (const std::uint32_t v : hole)
      layout.push_back (localOf (v));
    for (const std::uint32_t v : global)
      local_index[v] = RingCollector::kNoIndex;
    // FNV-1a's step over 32-bit words: the layout, then the positions' bits.
    key = 1469598103934665603ull;
    auto mix = [this] (std::uint32_t word) { key = (key ^ word) * 1099511628211ull; };
    for (const std::uint32_t i : layout)
      mix (i);
    for (const Eigen::Vector3f& p : positions)
      for (int k = 0; k < 3; ++k)
      {
        std::uint32_t bits;
        std::memcpy (&bits, &p[k], sizeof bits);
        mix (bits);
      }
  }
  std::size_t
  numTriangles (std::size_t hole_size) const
  {
    return (layout.size () - hole_size) / 3;
  }
};

// A halfedge mesh of the local surface; false when its triangles do not form one.
bool
toMesh (const LocalSurface& surface, std::size_t hole_size, Mesh& mesh)
{
  for (const auto& p : surface.positions)
    mesh.add_vertex (Kernel::Point_3 (p.x (), p.y (), p.z ()));
  for (std::size_t t = 0; t < surface.numTriangles (hole_size); ++t)
  {
    const Mesh::Vertex_index a (surface.layout[3 * t]), b (surface.layout[3 * t + 1]), c (surface.layout[3 * t + 2]);
    if (mesh.add_face (a, b, c) == Mesh::null_face ())
      return false;
  }
  return true;
}

// The boundary cycles of the local mesh whose vertices all lie on boundary group `g`.
std::vector<Halfedge>
cyclesOf (Mesh& mesh, const std::vector<std::uint32_t>& global, const BoundaryGroups& groups, std::uint32_t g)
{
  std::vector<Halfedge> cycles, out;
  CGAL::Polygon_mesh_processing::extract_boundary_cycles (mesh, std::back_inserter (cycles));
  for (const Halfedge h : cycles)
  {
    bool hole = true;
    for (const Halfedge e : CGAL::halfedges_around_face (h, mesh))
      hole = hole && groups.group_of[global[mesh.target (e)]] == g;
    if (hole)
      out.push_back (h);
  }
  return out;
}

// Splits each border cycle that passes a vertex twice into one cycle per pass, by exchanging the
// successors of the two border halfedges that enter the vertex: the triangulation takes only
// simple cycles, and the two passes are two holes that touch at the vertex.
std::vector<Halfedge>
splitPinchedCycles (Mesh& mesh, std::vector<Halfedge> cycles)
{
  for (std::size_t c = 0; c < cycles.size ();)
  {
    std::unordered_map<std::uint32_t, Halfedge> entering;
    bool split = false;
    for (const Halfedge h : CGAL::halfedges_around_face (cycles[c], mesh))
    {
      const auto [it, first] = entering.emplace (std::uint32_t (mesh.target (h)), h);
      if (first)
        continue;
      const Halfedge other = it->second, after_other = mesh.next (other);
      mesh.set_next (other, mesh.next (h));
      mesh.set_next (h, after_other);
      cycles[c] = other;
      cycles.push_back (h);
      split = true;
      break;
    }
    c += split ? 0 : 1;  // a split cycle is walked again: it may pass another vertex twice
  }
  return cycles;
}

// The directed edges of the local surface and of the patches accepted so far. Around a vertex
// that a boundary passes twice the triangulation does not see every edge, so a patch is kept only
// when it repeats no edge and meets the surface only along its own cycle.
class PatchEdges
{
public:
  explicit PatchEdges (const Mesh& mesh)
  {
    for (const Halfedge h : mesh.halfedges ())
      if (!mesh.is_border (h))
        edges_.insert (key (mesh.source (h), mesh.target (h)));
  }

  // The directed edges of a border cycle, which its patch runs along.
  std::unordered_set<std::uint64_t>
  rimOf (const Mesh& mesh, Halfedge cycle) const
  {
    std::unordered_set<std::uint64_t> rim;
    for (const Halfedge e : CGAL::halfedges_around_face (cycle, mesh))
      rim.insert (key (mesh.source (e), mesh.target (e)));
    return rim;
  }

  // Adds the patch's edges when it is valid.
  bool
  add (const std::unordered_set<std::uint64_t>& rim, const std::vector<std::array<Mesh::Vertex_index, 3>>& patch)
  {
    std::unordered_set<std::uint64_t> added;
    for (const auto& t : patch)
      for (int j = 0; j < 3; ++j)
      {
        const std::uint64_t e = key (t[j], t[(j + 1) % 3]), reverse = key (t[(j + 1) % 3], t[j]);
        if (e >> 32 == (e & 0xFFFFFFFFu) || edges_.count (e) || !added.insert (e).second)
          return false;
        if (edges_.count (reverse) && !rim.count (e))
          return false;
      }
    edges_.insert (added.begin (), added.end ());
    return true;
  }

private:
  static std::uint64_t
  key (Mesh::Vertex_index a, Mesh::Vertex_index b)
  {
    return std::uint64_t (std::uint32_t (a)) << 32 | std::uint32_t (b);
  }

  std::unordered_set<std::uint64_t> edges_;
};

double
triangleArea (const Mesh& mesh, Mesh::Face_index f)
{
  const Halfedge h = mesh.halfedge (f);
  const auto& a = mesh.point (mesh.source (h));
  const auto& b = mesh.point (mesh.target (h));
  const auto& c = mesh.point (mesh.target (mesh.next (h)));
  return std::sqrt (CGAL::squared_area (a, b, c));
}

// The vertices of a boundary cycle in the order of its edges, when `boundary` is one simple
// cycle; empty otherwise.
std::vector<std::uint32_t>
cycleOrder (const HalfEdges& he, const std::vector<std::uint32_t>& boundary)
{
  std::vector<std::uint32_t> cycle{boundary.front ()};
  while (cycle.size () <= boundary.size ())
  {
    const std::uint32_t a = cycle.back ();
    std::uint32_t next = BoundaryGroups::kNone;
    for (std::uint32_t k = he.begin[a]; k < he.begin[a + 1]; ++k)
      if (he.countInto (a, he.target (k)) == 0)
      {
        if (next != BoundaryGroups::kNone)
          return {};  // two boundary edges leave a: not a simple cycle
        next = he.target (k);
      }
    if (next == BoundaryGroups::kNone)
      return {};
    if (next == cycle.front ())
      break;
    cycle.push_back (next);
  }
  return cycle.size () == boundary.size () ? cycle : std::vector<std::uint32_t>{};
}

// The area of triangle t.
double
areaOf (const std::vector<Eigen::Vector3f>& vertices, const Triangle& t)
{
  return double ((vertices[t[1]] - vertices[t[0]]).cross (vertices[t[2]] - vertices[t[0]]).norm ()) / 2;
}

// A hole of three or four edges (one missing triangle or dual quad) closes with one or two
// triangles along the shorter free diagonal: the density around it, nothing to fair. Empty when
// the hole is not such a cycle or every way to close it would repeat an edge or have no area.
std::vector<Triangle>
tinyHolePatch (const HalfEdges& he, const std::vector<std::uint32_t>& boundary,
               const std::vector<Eigen::Vector3f>& vertices)
{
  if (boundary.size () != 3 && boundary.size () != 4)
    return {};
  std::vector<std::uint32_t> r = cycleOrder (he, boundary);
  if (r.empty ())
    return {};
  std::reverse (r.begin () + 1, r.end ());  // the patch runs against the boundary's edges
  std::vector<Triangle> patch;
  if (r.size () == 3)
    patch.push_back ({r[0], r[1], r[2]});
  else
  {
    const bool first =
        (vertices[r[0]] - vertices[r[2]]).squaredNorm () <= (vertices[r[1]] - vertices[r[3]]).squaredNorm ();
    for (const int d : {first ? 0 : 1, first ? 1 : 0})
    {
      const std::uint32_t a = r[d], b = r[d + 1], c = r[d + 2], e = r[(d + 3) % 4];
      if (he.count (a, c) + he.countInto (a, c) == 0 && areaOf (vertices, {a, b, c}) > 0 &&
          areaOf (vertices, {a, c, e}) > 0)
      {
        patch = {{a, b, c}, {a, c, e}};
        break;
      }
    }
  }
  if (patch.empty () || areaOf (vertices, patch[0]) <= 0)
    return {};
  return patch;
}

// The patch of every boundary cycle of group `g` in the local mesh.
HolePatch
computePatch (Mesh& mesh, const std::vector<std::uint32_t>& global, const BoundaryGroups& groups, std::uint32_t g,
              std::size_t max_edges)
{
  HolePatch patch;
  const std::size_t old_vertices = mesh.number_of_vertices ();
  PatchEdges edges (mesh);
  const std::vector<Halfedge> cycles = splitPinchedCycles (mesh, cyclesOf (mesh, global, groups, g));
  std::vector<std::array<Mesh::Vertex_index, 3>> kept;
  std::size_t closed = 0;
  for (const Halfedge h : cycles)
  {
    const std::size_t cycle_edges = CGAL::halfedges_around_face (h, mesh).size ();
    if (max_edges > 0 && cycle_edges > max_edges)
      continue;
    const std::unordered_set<std::uint64_t> rim = edges.rimOf (mesh, h);
    std::vector<Mesh::Face_index> faces;
    // Liepa's search over every triangulation of the boundary (cubic in its edges) up to
    // kCubicSearchEdges; above, the faces of the boundary's 3D Delaunay triangulation. The flag is
    // the fairing's: a patch whose fairing failed stays, refined but not faired.
    const bool faired = std::get<0> (CGAL::Polygon_mesh_processing::triangulate_refine_and_fair_hole (
        mesh, h, std::back_inserter (faces), CGAL::Emptyset_iterator (),
        CGAL::parameters::use_delaunay_triangulation (cycle_edges > kCubicSearchEdges)));
    std::vector<std::array<Mesh::Vertex_index, 3>> triangles;
    for (const auto f : faces)
    {
      std::array<Mesh::Vertex_index, 3> t;
      std::size_t j = 0;
      for (const auto v : CGAL::vertices_around_face (mesh.halfedge (f), mesh))
        if (j < t.size ())
          t[j++] = v;  // the patches are triangulated
      triangles.push_back (t);
    }
    if (triangles.empty () || !edges.add (rim, triangles))
      continue;  // no triangulation without a repeated edge
    ++closed;
    patch.unfaired += !faired;
    for (const auto f : faces)
      patch.area += triangleArea (mesh, f);
    kept.insert (kept.end (), triangles.begin (), triangles.end ());
  }
  // The patches' own vertices (those of rejected patches dropped), numbered after the surface's.
  std::vector<std::uint32_t> number (mesh.number_of_vertices (), BoundaryGroups::kNone);
  std::iota (number.begin (), number.begin () + std::ptrdiff_t (old_vertices), 0u);
  for (const auto& t : kept)
  {
    Triangle out;
    for (int j = 0; j < 3; ++j)
    {
      std::uint32_t& n = number[std::size_t (t[j])];
      if (n == BoundaryGroups::kNone)
      {
        n = static_cast<std::uint32_t> (old_vertices + patch.added_vertices.size ());
        const auto& p = mesh.point (t[j]);
        patch.added_vertices.emplace_back (float (p.x ()), float (p.y ()), float (p.z ()));
      }
      out[j] = n;
    }
    patch.triangles.push_back (out);
  }
  patch.closed = !cycles.empty () && closed == cycles.size ();
  return patch;
}

// Appends a patch to the mesh; its vertices follow the mesh's in index order.
void
applyPatch (const HolePatch& patch, const std::vector<std::uint32_t>& global, std::vector<Eigen::Vector3f>& vertices,
            std::vector<Triangle>& triangles, HoleFillingStats& stats)
{
  const std::size_t base = vertices.size ();
  vertices.insert (vertices.end (), patch.added_vertices.begin (), patch.added_vertices.end ());
  for (const Triangle& t : patch.triangles)
  {
    Triangle out;
    for (int j = 0; j < 3; ++j)
      out[j] = t[j] < global.size () ? global[t[j]] : static_cast<std::uint32_t> (base + t[j] - global.size ());
    triangles.push_back (out);
  }
  stats.added_vertices += patch.added_vertices.size ();
  stats.added_triangles += patch.triangles.size ();
  stats.unfaired += patch.unfaired;
  stats.filled_area += patch.area;
}

// The cache's entry made for the same surroundings, or nullptr.
HolePatchCache::Entry*
cachedEntry (HolePatchCache* cache, const LocalSurface& surface)
{
  if (!cache)
    return nullptr;
  const auto range = cache->entries.equal_range (surface.key);
  for (auto it = range.first; it != range.second; ++it)
    if (it->second.layout == surface.layout && it->second.positions == surface.positions)
      return &it->second;
  return nullptr;
}

// What the search found for one hole. It reads the mesh as it came in (the triangles and vertices
// before any patch), so the holes are searched in parallel and their patches appended in hole
// order afterwards, as if one after the other.
struct HoleOutcome
{
  enum class Kind : std::uint8_t
  {
    kTooLarge,
    kFailed,
    kTiny,      // `tiny` closes it (in the mesh's indices)
    kCached,    // the cache's patch `cached`
    kComputed,  // `computed`, a new patch for the cache
  };
  Kind kind = Kind::kFailed;
  std::vector<Triangle> tiny;
  HolePatchCache::Entry* cached = nullptr;
  HolePatchCache::Entry computed;
  std::uint64_t key = 0;              // the cache key of `computed`
  std::vector<std::uint32_t> global;  // the patch's surroundings in the mesh (kCached, kComputed)
};

// The patch of group `g`: only the triangles around the hole go into a halfedge structure, with
// two rings and, where a vertex there is not a manifold one, with one.
HoleOutcome
findHolePatch (std::uint32_t g, const std::vector<std::uint32_t>& boundary, const BoundaryGroups& groups,
               RingCollector& rings, std::size_t max_edges, HolePatchCache* cache,
               const std::vector<Eigen::Vector3f>& vertices, const std::vector<Triangle>& triangles)
{
  HoleOutcome out;
  out.tiny = tinyHolePatch (rings.halfEdges (), boundary, vertices);
  if (!out.tiny.empty ())
  {
    out.kind = HoleOutcome::Kind::kTiny;
    return out;
  }
  for (const int ring_count : {2, 1})
  {
    LocalSurface surface (vertices, triangles, rings.collect (boundary, ring_count), boundary, rings.localIndex ());
    if (HolePatchCache::Entry* hit = cachedEntry (cache, surface))
    {
      out.kind = HoleOutcome::Kind::kCached;
      out.cached = hit;
      out.global = std::move (surface.global);
      return out;
    }
    Mesh mesh;
    if (!toMesh (surface, boundary.size (), mesh))
      continue;
    out.kind = HoleOutcome::Kind::kComputed;
    out.computed.patch = computePatch (mesh, surface.global, groups, g, max_edges);
    out.computed.positions = std::move (surface.positions);
    out.computed.layout = std::move (surface.layout);
    out.key = surface.key;
    out.global = std::move (surface.global);
    return out;
  }
  return out;
}

// Appends a hole's patch to the mesh and counts it; a new patch goes into the cache.
void
applyOutcome (HoleOutcome& o, HolePatchCache* cache, std::vector<Eigen::Vector3f>& vertices,
              std::vector<Triangle>& triangles, HoleFillingStats& stats)
{
  bool closed = false;
  switch (o.kind)
  {
  case HoleOutcome::Kind::kTooLarge:
    ++stats.too_large;
    return;
  case HoleOutcome::Kind::kFailed:
    break;
  case HoleOutcome::Kind::kTiny:
    for (const Triangle& t : o.tiny)
    {
      stats.filled_area += areaOf (vertices, t);
      triangles.push_back (t);
    }
    stats.added_triangles += o.tiny.size ();
    closed = true;
    break;
  case HoleOutcome::Kind::kCached:
    o.cached->generation = cache->generation;
    ++cache->hits;
    applyPatch (o.cached->patch, o.global, vertices, triangles, stats);
    closed = o.cached->patch.closed;
    break;
  case HoleOutcome::Kind::kComputed:
    applyPatch (o.computed.patch, o.global, vertices, triangles, stats);
    closed = o.computed.patch.closed;
    if (cache)
    {
      o.computed.generation = cache->generation;
      cache->entries.emplace (o.key, std::move (o.computed));
    }
    break;
  }
  ++(closed ? stats.filled : stats.failed);
}

}  // namespace

bool
fillSmallHoles (std::vector<Eigen::Vector3f>& vertices, std::vector<Triangle>& triangles, double max_diameter,
                HoleFillingStats& stats, std::size_t max_edges, HolePatchCache* cache)
{
  stats = HoleFillingStats ();
  if (!(max_diameter > 0) || !std::isfinite (max_diameter))
  {
    PCL_ERROR ("[pclx::surface::detail::fillSmallHoles] the largest hole must be positive and finite (got %g)\n",
               max_diameter);
    return false;
  }
  const bool indices_valid = std::all_of (triangles.begin (), triangles.end (), [&] (const Triangle& t) {
    return std::max ({t[0], t[1], t[2]}) < vertices.size ();
  });
  if (!indices_valid)
  {
    PCL_ERROR ("[pclx::surface::detail::fillSmallHoles] a triangle refers to a missing vertex; no hole was filled\n");
    return false;
  }
  // With a cache, the working arrays of the last call are reused.
  HoleFillingScratch local;
  if (cache && !cache->scratch)
    cache->scratch = std::make_shared<HoleFillingScratch> ();
  HoleFillingScratch& scratch = cache ? *cache->scratch : local;
  const OpenVertices open (vertices.size (), triangles, scratch);
  const HalfEdges he (vertices.size (), triangles, open.near_triangles, scratch);
  BoundaryGroups groups{scratch.group_of, {}};
  if (!findBoundaries (vertices, open, he, scratch, groups))
  {
    PCL_ERROR ("[pclx::surface::detail::fillSmallHoles] the mesh is not an oriented 2-manifold; no hole was filled\n");
    return false;
  }
  stats.holes = groups.diameter.size ();
  // The vertices of each hole up to the limit, hole by hole.
  std::vector<std::vector<std::uint32_t>> hole_vertices (groups.diameter.size ());
  for (const std::uint32_t v : open.vertices)
    if (groups.group_of[v] != BoundaryGroups::kNone && groups.diameter[groups.group_of[v]] <= max_diameter)
      hole_vertices[groups.group_of[v]].push_back (v);
  if (cache)
  {
    ++cache->generation;
    cache->hits = 0;
  }
  std::vector<HoleOutcome> outcomes (groups.diameter.size ());
  const std::ptrdiff_t holes = static_cast<std::ptrdiff_t> (outcomes.size ());
  const int threads = holes > 1 ? omp_get_max_threads () : 1;
  scratch.rings.resize (static_cast<std::size_t> (threads));
#pragma omp parallel num_threads (threads)
  {
    RingCollector rings (he, triangles, scratch.rings[static_cast<std::size_t> (omp_get_thread_num ())]);
#pragma omp for schedule(dynamic, 4)
    for (std::ptrdiff_t g = 0; g < holes; ++g)
    {
      if (groups.diameter[g] > max_diameter)
        outcomes[g].kind = HoleOutcome::Kind::kTooLarge;
      else
        outcomes[g] = findHolePatch (static_cast<std::uint32_t> (g), hole_vertices[g], groups, rings, max_edges, cache,
                                     vertices, triangles);
    }
  }
  for (HoleOutcome& o : outcomes)
    applyOutcome (o, cache, vertices, triangles, stats);
  if (cache)
    for (auto it = cache->entries.begin (); it != cache->entries.end ();)
      it = it->second.generation == cache->generation ? std::next (it) : cache->entries.erase (it);
  return true;
}

}  // namespace detail
}  // namespace surface
}  // namespace pclx
