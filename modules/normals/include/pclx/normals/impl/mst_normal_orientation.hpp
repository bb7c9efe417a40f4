#pragma once
#include <pclx/normals/detail/error_message.h>
#include <pclx/normals/detail/scale_selection.h>
#include <pclx/normals/mst_normal_orientation.h>

#include <pcl/common/point_tests.h>

#include <boost/pending/disjoint_sets.hpp>
#include <boost/sort/sort.hpp>
#include <flann/algorithms/dist.h>
#include <flann/algorithms/kdtree_single_index.h>
#include <flann/util/result_set.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <new>
#include <numeric>
#include <omp.h>
#include <thread>
#include <utility>
#include <vector>
#ifdef __linux__
#include <sys/mman.h>
#endif

namespace pclx {
namespace normals {
namespace detail {

constexpr float kSideFloor = 0.25f;  // × mean edge length
constexpr float kFoldSlack = 0.5f;   // × |e|, nearly parallel lines
// Visibility votes (see MSTNormalOrientation::orient ()); docs/normals.md explains the values.
constexpr float kPixelEdges = 1.5f;    // pixel side, × mean edge length
constexpr float kToggleBase = 0.5f;    // cost of overruling any crossing (a pixel's vote is <= 1)
constexpr float kToggleSpan = 2.f;     // ... plus this × s², s = 0 at 60° between the normals, 1 at 0°
constexpr float kMajority = 0.5f;      // a vertex's vote counts by its margin over this share of its mass
constexpr double kRootShare = 0.2;     // a component's votes decide its sign past this share of its mass
// A significant pair's turn 1 − |ni·nj| counts this much: two faces of a ridge narrower than
// the graph's edges look nearly parallel to Hoppe's rule, so an edge along the crease
// (unreadable, Hoppe flips) must cost more than one across it (readable). Sharp pairs
// readable only by the looser 0.2 |e| keep their cost (made cheaper, they were used more
// on noisy clouds and flipped more points).
constexpr float kReadableTurn = 0.5f;
// Neighbours per noise sample (pclx::normals::detail::sampleNoise reads up to 100 besides
// the point itself).
constexpr std::size_t kNoiseNeighbours = 101;

// Large buffers go on transparent huge pages: on large clouds first-touch page faults,
// not the algorithm, dominated the run time with 4 KiB pages.
template <typename T>
struct HugePageAllocator
{
  using value_type = T;
  HugePageAllocator () = default;
  template <typename U>
  HugePageAllocator (const HugePageAllocator<U>&) {}
  T*
  allocate (std::size_t n)
  {
    constexpr std::size_t kHuge = std::size_t (2) << 20;
    std::size_t bytes = n * sizeof (T);
    void* p = nullptr;
    if (bytes >= 2 * kHuge)
    {
      bytes = (bytes + kHuge - 1) / kHuge * kHuge;
      p = std::aligned_alloc (kHuge, bytes);
#if defined(__linux__) && defined(MADV_HUGEPAGE)
      if (p)
        madvise (p, bytes, MADV_HUGEPAGE);
#endif
    }
    else
      p = std::malloc (bytes > 0 ? bytes : 1);
    if (!p)
      throw std::bad_alloc ();
    return static_cast<T*> (p);
  }
  void deallocate (T* p, std::size_t) { std::free (p); }
  template <typename U>
  bool operator== (const HugePageAllocator<U>&) const { return true; }
  template <typename U>
  bool operator!= (const HugePageAllocator<U>&) const { return false; }
};
template <typename T>
using Buffer = std::vector<T, HugePageAllocator<T>>;

// 10 bits of x spread to every third bit (Morton / Z-order interleaving).
inline std::uint32_t
spreadBits (std::uint32_t x)
{
  x &= 0x3ff;
  x = (x | x << 16) & 0x30000ff;
  x = (x | x << 8) & 0x300f00f;
  x = (x | x << 4) & 0x30c30c3;
  x = (x | x << 2) & 0x9249249;
  return x;
}

// The Riemannian graph: vertex v (Morton rank) is input point input_ids[v], at
// pos[3v .. 3v+2] with unit normal nrm[v]; row v of nbr holds v's k nearest other
// vertices (UINT32_MAX pads).
struct MstGraph
{
  std::size_t nv = 0;   // vertices
  std::size_t k = 0;    // neighbours per vertex
  std::size_t row = 0;  // row width of nbr: min (k + 1, nv), the query returns the point too
  int threads = 1;
  Eigen::Vector3f lo, hi;  // bounding box of the vertices
  Buffer<std::uint32_t> input_ids;
  Buffer<float> pos;
  Buffer<Eigen::Vector3f> nrm;
  Buffer<std::uint32_t> nbr;
  std::vector<double> len_sum;         // per thread: sum of the kept edges' lengths
  std::vector<std::size_t> len_count;  // per thread: their number
  double mean_len = 0;                 // mean edge length
};

// Orders the vertices along a Morton (Z) curve, so that kNN queries, edge costs, union-find
// and the traversal touch nearby memory (random-order input made every stage cache-bound).
// position (i) is input point i's position.
template <typename Position>
void
mortonOrder (MstGraph& g, Position&& position)
{
  const std::size_t nv = g.nv;
  const float extent = (g.hi - g.lo).maxCoeff ();
  const float scale = extent > 0 ? 1023.f / extent : 0.f;
  Buffer<std::uint64_t> keys (nv);
#pragma omp parallel for num_threads(g.threads)
  for (std::ptrdiff_t j = 0; j < static_cast<std::ptrdiff_t> (nv); ++j)
  {
    const Eigen::Vector3f q = (position (g.input_ids[j]) - g.lo) * scale;
    const std::uint32_t code = spreadBits (static_cast<std::uint32_t> (q.x ())) |
                               spreadBits (static_cast<std::uint32_t> (q.y ())) << 1 |
                               spreadBits (static_cast<std::uint32_t> (q.z ())) << 2;
    keys[j] = static_cast<std::uint64_t> (code) << 32 | g.input_ids[j];
  }
  boost::sort::block_indirect_sort (keys.begin (), keys.end (), static_cast<std::uint32_t> (g.threads));
  for (std::size_t v = 0; v < nv; ++v)
    g.input_ids[v] = static_cast<std::uint32_t> (keys[v]);
}

// Writes row v of the graph: the first k of the `found` neighbours other than v itself
// (fewer when k + 1 points coincide), and adds their lengths to sum and cnt.
template <typename IdOf>
void
keepNeighbours (MstGraph& g, std::size_t v, std::size_t found, IdOf&& id_of, const float* sqr_dist, double& sum,
                std::size_t& cnt)
{
  const std::size_t row = g.row, k = g.k;
  std::size_t slot = v * row;
  for (std::size_t q = 0; q < found && slot < v * row + k; ++q)
  {
    const std::uint32_t w = id_of (q);
    if (w == UINT32_MAX || w == v)
      continue;
    g.nbr[slot++] = w;
    sum += std::sqrt (sqr_dist[q]);
    ++cnt;
  }
  for (; slot < (v + 1) * row; ++slot)
    g.nbr[slot] = UINT32_MAX;
}

// Noise along the normal from about 500 vertices (pclx::normals::detail::sampleNoise):
// knn (v, ids) lists v's nearest vertices sorted by distance, v first.
template <typename Knn>
double
estimateGraphNoise (const MstGraph& g, Knn&& knn, int team)
{
  struct NoiseScratch
  {
    std::vector<std::uint32_t> ids;
  };
  return estimateCloudNoise<NoiseScratch> (
             g.nv, 500, team,
             [&] (std::size_t v, std::vector<Eigen::Vector3f>& sorted, NoiseScratch& t) {
               knn (static_cast<std::uint32_t> (v), t.ids);
               for (const std::uint32_t id : t.ids)
                 sorted.emplace_back (g.pos[3 * id], g.pos[3 * id + 1], g.pos[3 * id + 2]);
             })
      .sigma;
}

// Fills the graph's rows with FLANN's kd-tree (the one pcl::search::KdTree builds),
// queried directly: through PCL every query opens an OpenMP region of its own, which
// costs more than the search. Returns the noise estimate (0 unless estimate_noise).
inline double
flannNeighbourGraph (MstGraph& g, bool estimate_noise)
{
  const std::size_t nv = g.nv, row = g.row;
  flann::Matrix<float> data (g.pos.data (), nv, 3);
  flann::KDTreeSingleIndex<flann::L2_Simple<float>> index (data, flann::KDTreeSingleIndexParams (15));
  index.buildIndex ();
#pragma omp parallel num_threads(g.threads)
  {
    const int t = omp_get_thread_num ();
    flann::KNNSimpleResultSet<float> result (row);
    std::vector<std::size_t> ids (row);
    std::vector<float> dist (row);
    const flann::SearchParams params (-1, 0.f, true);
    double sum = 0;
    std::size_t count = 0;
#pragma omp for schedule(static)
    for (std::ptrdiff_t v = 0; v < static_cast<std::ptrdiff_t> (nv); ++v)
    {
      result.clear ();
      index.findNeighbors (result, &g.pos[3 * v], params);
      const std::size_t found = std::min (result.size (), row);
      result.copy (ids.data (), dist.data (), found);
      keepNeighbours (g, v, found, [&] (std::size_t q) { return static_cast<std::uint32_t> (ids[q]); }, dist.data (),
                      sum, count);
    }
    g.len_sum[t] = sum;
    g.len_count[t] = count;
  }
  if (!estimate_noise)
    return 0;
  return estimateGraphNoise (
      g,
      [&] (std::uint32_t v, std::vector<std::uint32_t>& ids) {
        const std::size_t want = std::min (kNoiseNeighbours, nv);
        flann::KNNSimpleResultSet<float> result (want);
        std::vector<std::size_t> found (want);
        std::vector<float> dist (want);
        index.findNeighbors (result, &g.pos[3 * v], flann::SearchParams (-1, 0.f, true));
        const std::size_t m = std::min (result.size (), want);
        result.copy (found.data (), dist.data (), m);
        ids.assign (found.begin (), found.begin () + m);
      },
      g.threads);
}

// The edge-side reading (see flipAcross ()) needs the edge vector e to leave both tangent
// planes. For normals > 60° apart (a sharp edge, where Hoppe's rule is a coin toss) 0.2 |e|
// suffices: noise blurs the reading less than it blurs the toss. For nearly parallel lines
// Hoppe's rule is usually right, so the reading overrides it only where it is significant,
// geometry rather than noise or a blended normal: both offsets above the edge-side
// significance in noise sigmas plus a quarter of the mean edge, plus 0.5 |e| (a fold: the
// faces of a thin part or of a ridge narrower than the edges) or 0.2 |e| (a sharp edge).
// a, b: |ni·e|, |nj·e|; dn: ni·nj.
struct EdgeSideTest
{
  float fold_floor = 0;
  bool
  significant (float a, float b, float length, float dn) const
  {
    return std::min (a, b) > fold_floor + (std::abs (dn) < 0.5f ? 0.2f : kFoldSlack) * length;
  }
  bool
  readable (float a, float b, float length, float dn) const
  {
    return std::abs (dn) < 0.5f ? std::min (a, b) > 0.2f * length : significant (a, b, length, dn);
  }
};

// One key per undirected edge (a mutual pair is kept once): the cost's float bits (costs
// are >= 0, so they order like the floats) above the slot of the edge, sorted. Ties
// (exactly parallel normals, e.g. both sides of a thin plate fitted by one plane) go to the
// shorter edge, so propagation stays on a sheet instead of jumping across. Every thread
// takes one contiguous range of vertices and writes its keys after those of the threads
// before it (count, then fill: no per-thread vectors to merge).
inline Buffer<std::uint64_t>
sortedEdgeKeys (const MstGraph& g, const EdgeSideTest& side, double across_penalty, double tie_break)
{
  const std::size_t nv = g.nv, row = g.row;
  const auto& nbr = g.nbr;
  const auto& nrm = g.nrm;
  const auto& pos = g.pos;
  const double mean_len = g.mean_len;
  auto listed_from_w = [&] (std::size_t v, std::uint32_t w) {
    const auto r = nbr.begin () + w * row;
    return w < v && std::find (r, r + row, static_cast<std::uint32_t> (v)) != r + row;
  };
  Buffer<std::uint64_t> keys;
  std::vector<std::size_t> first (g.threads + 1, 0);
#pragma omp parallel num_threads(g.threads)
  {
    const std::size_t nt = omp_get_num_threads (), t = omp_get_thread_num ();
    const std::size_t v_lo = nv * t / nt, v_hi = nv * (t + 1) / nt;
    std::size_t count = 0;
    for (std::size_t slot = v_lo * row; slot < v_hi * row; ++slot)
      count += nbr[slot] != UINT32_MAX && !listed_from_w (slot / row, nbr[slot]);
    first[t + 1] = count;
#pragma omp barrier
#pragma omp single
    {
      std::partial_sum (first.begin (), first.begin () + nt + 1, first.begin ());
      keys.resize (first[nt]);
    }
    std::size_t at = first[t];
    const float penalty = static_cast<float> (across_penalty);
    const float length_weight = tie_break > 0 && mean_len > 0 ? static_cast<float> (tie_break / mean_len) : 0.f;
    for (std::size_t v = v_lo; v < v_hi; ++v)
    {
      const Eigen::Vector3f& ni = nrm[v];
      const Eigen::Map<const Eigen::Vector3f> pi (&pos[3 * v]);
      for (std::size_t slot = v * row; slot < (v + 1) * row && nbr[slot] != UINT32_MAX; ++slot)
      {
        const std::uint32_t w = nbr[slot];
        if (listed_from_w (v, w))
          continue;
        const Eigen::Vector3f& nj = nrm[w];
        const Eigen::Vector3f d = Eigen::Map<const Eigen::Vector3f> (&pos[3 * w]) - pi;
        const float length = d.norm ();
        const float dn = ni.dot (nj);
        float cost = std::max (0.f, 1.f - std::abs (dn));
        if (penalty > 0 && length > 0)
        {
          const float a = std::abs (ni.dot (d)), b = std::abs (nj.dot (d));
          // Where both normals lean off e by more than noise and slack (readable), the
          // traversal reads the sign from the edge's side: prefer the crossings that leave
          // both tangent planes most (an edge along a crease says nothing). Elsewhere Hoppe's
          // rule decides, which an edge along the normals (through a thin plate, from one
          // sheet to the other) misleads: make those expensive, so that the tree goes around
          // along the surface. Unreadable pairs > 60° apart keep the first form (no rule is
          // reliable there; the least bad crossing leaves both planes most).
          const bool readable = side.readable (a, b, length, dn);
          if (readable && side.significant (a, b, length, dn))
            cost *= kReadableTurn;
          cost += penalty * (readable || std::abs (dn) < 0.5f ? 1.f - std::min (a, b) / length : std::max (a, b) / length);
        }
        cost += length_weight * length;
        std::uint32_t bits;
        std::memcpy (&bits, &cost, sizeof bits);
        keys[at++] = (static_cast<std::uint64_t> (bits) << 32) | static_cast<std::uint32_t> (slot);
      }
    }
  }
  // Keys are unique (the slot is in the low bits), so a full sort orders by cost, then slot.
  boost::sort::block_indirect_sort (keys.begin (), keys.end (), static_cast<std::uint32_t> (g.threads));
  return keys;
}

// The minimum spanning forest as adjacency lists (CSR: the neighbours of v are
// adj[offset[v] .. offset[v + 1])), and the root of every component: its highest point
// (lowest input index among equal z), stored at the component's representative
// (UINT32_MAX elsewhere).
struct SpanningForest
{
  Buffer<std::uint32_t> offset, adj, root;
};

// Kruskal: edges by increasing cost into Boost's disjoint sets (faster than
// boost::kruskal_minimum_spanning_tree's priority queue). Frees the keys and the graph's rows.
inline SpanningForest
minimumSpanningForest (MstGraph& g, Buffer<std::uint64_t>& keys)
{
  const std::size_t nv = g.nv, row = g.row;
  const auto& pos = g.pos;
  Buffer<std::uint32_t> parent (nv), rank (nv, 0);
  std::iota (parent.begin (), parent.end (), 0u);
  boost::disjoint_sets<std::uint32_t*, std::uint32_t*> sets (rank.data (), parent.data ());
  Buffer<std::pair<std::uint32_t, std::uint32_t>> tree;
  tree.reserve (nv - 1);
  for (const std::uint64_t key : keys)
  {
    const std::uint32_t slot = static_cast<std::uint32_t> (key);
    const std::uint32_t v = static_cast<std::uint32_t> (slot / row), w = g.nbr[slot];
    const std::uint32_t a = sets.find_set (v), b = sets.find_set (w);
    if (a == b)
      continue;
    sets.link (a, b);
    tree.emplace_back (v, w);
    if (tree.size () + 1 == nv)
      break;
  }
  Buffer<std::uint64_t> ().swap (keys);
  Buffer<std::uint32_t> ().swap (g.nbr);

  SpanningForest forest;
  // Root of every component, by representative; reuses the ranks' storage.
  forest.root.swap (rank);
  std::fill (forest.root.begin (), forest.root.end (), UINT32_MAX);
  for (std::uint32_t v = 0; v < nv; ++v)
  {
    std::uint32_t& r = forest.root[sets.find_set (v)];
    if (r == UINT32_MAX || pos[3 * v + 2] > pos[3 * r + 2] ||
        (pos[3 * v + 2] == pos[3 * r + 2] && g.input_ids[v] < g.input_ids[r]))
      r = v;
  }

  forest.offset.assign (nv + 1, 0);
  forest.adj.resize (2 * tree.size ());
  for (const auto& e : tree)
  {
    ++forest.offset[e.first + 1];
    ++forest.offset[e.second + 1];
  }
  std::partial_sum (forest.offset.begin (), forest.offset.end (), forest.offset.begin ());
  Buffer<std::uint32_t>& fill = parent;  // no longer needed
  std::copy (forest.offset.begin (), forest.offset.end () - 1, fill.begin ());
  for (const auto& e : tree)
  {
    forest.adj[fill[e.first]++] = e.second;
    forest.adj[fill[e.second]++] = e.first;
  }
  return forest;
}

// The traversal of the forest: its order (parents first), every vertex's tree parent
// (UINT32_MAX at a root), the cost of overruling the crossing from it, its component and
// whether propagation flipped it.
struct Traversal
{
  std::size_t components = 0;
  std::vector<char> flip;
  std::vector<std::uint32_t> component;
  Buffer<std::uint32_t> order, up;
  Buffer<float> toggle_cost;
};

// Depth-first from every root, as in Hoppe et al.; the root's normal points to +z.
// A child takes its parent's sign by Hoppe's rule (ni·nj > 0) where the normals are
// within 60° of each other. Across a sharp edge (exact normals at 90° on a box) ni·nj ≈ 0
// is a coin toss; there the edge vector e = pj − pi decides: on any consistently
// oriented surface, convex or concave, ni·e and nj·e have opposite signs (a sphere's
// chord gives ni·e = −nj·e). Used only when both lean off e by > 0.2 |e|; otherwise Hoppe.
// Also gives the cost of overruling the decision (see the visibility votes): low where
// the side was read or the normals are > 60° apart, rising to its maximum at parallel normals.
// Flips g.nrm as it goes.
inline Traversal
propagateSigns (MstGraph& g, const SpanningForest& forest, const EdgeSideTest& side)
{
  const std::size_t nv = g.nv;
  auto& nrm = g.nrm;
  const auto& pos = g.pos;
  const auto flipAcross = [&] (std::uint32_t u, std::uint32_t w, float& toggle) {
    const Eigen::Vector3f e = Eigen::Map<const Eigen::Vector3f> (&pos[3 * w]) -
                              Eigen::Map<const Eigen::Vector3f> (&pos[3 * u]);
    const float a = nrm[u].dot (e), b = nrm[w].dot (e), dn = nrm[w].dot (nrm[u]);
    toggle = kToggleBase;
    if (side.readable (std::abs (a), std::abs (b), e.norm (), dn))
      return a * b > 0;
    const float sure = std::max (0.f, 2 * std::abs (dn) - 1);  // 0 at 60°, 1 at 0°
    toggle += kToggleSpan * sure * sure;
    return dn < 0;
  };
  Traversal t;
  std::vector<char> seen (nv, 0);
  t.flip.assign (nv, 0);
  t.component.assign (nv, 0);
  std::vector<std::uint32_t> stack;
  t.up.assign (nv, UINT32_MAX);
  t.order.reserve (nv);
  t.toggle_cost.assign (nv, 0.f);
  for (const std::uint32_t r : forest.root)
  {
    if (r == UINT32_MAX)
      continue;
    const std::uint32_t c = static_cast<std::uint32_t> (t.components++);
    t.component[r] = c;
    seen[r] = 1;
    t.order.push_back (r);
    if (nrm[r].z () < 0)
    {
      nrm[r] = -nrm[r];
      t.flip[r] = 1;
    }
    stack.push_back (r);
    while (!stack.empty ())
    {
      const std::uint32_t u = stack.back ();
      stack.pop_back ();
      for (std::uint32_t e = forest.offset[u]; e < forest.offset[u + 1]; ++e)
      {
        const std::uint32_t w = forest.adj[e];
        if (seen[w])
          continue;
        seen[w] = 1;
        t.component[w] = t.component[u];
        if (flipAcross (u, w, t.toggle_cost[w]))
        {
          nrm[w] = -nrm[w];
          t.flip[w] = 1;
        }
        t.up[w] = u;
        t.order.push_back (w);
        stack.push_back (w);
      }
    }
  }
  return t;
}


// The front depth of every pixel of a side × side depth grid (smaller is nearer, +inf where
// empty) with its holes closed: a front pixel that by chance holds none of the front's
// samples would let the vertices behind it be seen (Grossman and Dally 1998). A pixel whose
// opposite neighbours (row, column or diagonal) are both nearer by more than a pixel, deeper
// than a groove with 45° walls (the slope the depth tolerance admits) can sink between them,
// takes the farther of the two plus a pixel. A plane at any slope is unchanged; at a
// silhouette one of the pair is empty or behind.
inline void
closeFrontHoles (const std::vector<float>& front, std::vector<float>& closed, std::size_t side, float pixel)
{
  closed = front;
  const std::ptrdiff_t n = static_cast<std::ptrdiff_t> (side);
  for (std::ptrdiff_t i = 1; i + 1 < n; ++i)
    for (std::ptrdiff_t j = 1; j + 1 < n; ++j)
    {
      const std::ptrdiff_t c = i * n + j;
      for (const std::ptrdiff_t step : {std::ptrdiff_t (1), n, n + 1, n - 1})
        closed[c] = std::min (closed[c], std::max (front[c - step], front[c + step]) + pixel);
    }
}

// Visibility votes, a global cue that local sign propagation lacks: seen from outside along
// a direction d (orthographic), the first surface point of every line of sight has its
// outward normal facing the viewer (n·d > 0), on any closed surface, convex or not. For each
// of 26 directions (the cube's faces, edges and corners), every pixel (1.5 mean edges wide,
// so that the front surface leaves few holes) gives a vote of n·d to the vertices it sees.
// Hand-written rather than pcl::HPRFilter: one orthographic z-buffer pass per direction is
// O(n), where every HPR viewpoint builds a convex hull of the whole cloud.
// Adds every vertex's votes (Σ n·d) to vote and their weights (Σ |n·d|) to mass.
inline void
accumulateVisibilityVotes (const MstGraph& g, double noise, Buffer<float>& vote, Buffer<float>& mass)
{
  const std::size_t nv = g.nv;
  const auto& pos = g.pos;
  const auto& nrm = g.nrm;
  const Eigen::Vector3f centre = 0.5f * (g.lo + g.hi);
  const float radius = 0.5f * (g.hi - g.lo).norm ();
  // Cells: at most 4 per vertex (a long thin cloud would otherwise ask for a huge grid).
  float pixel = kPixelEdges * static_cast<float> (g.mean_len);
  const double max_cells = std::max (4.0 * nv, 4096.0);
  if (std::pow (2 * radius / pixel + 1, 2) > max_cells)
    pixel = 2 * radius / static_cast<float> (std::sqrt (max_cells) - 1);
  const std::size_t side = static_cast<std::size_t> (2 * radius / pixel) + 1;
  // 13 lines of sight, each looked along from both ends: one grid serves d and −d.
  std::vector<Eigen::Vector3f> dirs;
  for (int x = -1; x <= 1; ++x)
    for (int y = -1; y <= 1; ++y)
      for (int z = -1; z <= 1; ++z)
        if (x > 0 || (x == 0 && (y > 0 || (y == 0 && z > 0))))
          dirs.push_back (Eigen::Vector3f (float (x), float (y), float (z)).normalized ());
  // A vertex is seen from d where its depth is within a pixel (a 45° slope) plus two noise
  // sigmas of its pixel's front-most; the pixel's vote n·d is shared among those. An open
  // sheet's points are then seen from both sides and their votes cancel point by point.
  // The fronts' holes are closed first (closeFrontHoles ()), so that no vertex is seen
  // through the gaps between the front surface's samples.
  const float tolerance = pixel + 2 * static_cast<float> (noise);
  std::vector<Buffer<float>> part (g.threads);
#pragma omp parallel num_threads(g.threads)
  {
    // Per cell: the nearest and farthest depth along d (far negated, so that both ends
    // take the minimum), the same with holes closed, and how many vertices each end sees.
    std::vector<float> near (side * side), far (side * side), scratch (side * side);
    std::vector<std::uint32_t> near_count (side * side), far_count (side * side), cell_of (nv);
    std::vector<float> depth (nv);
    Buffer<float>& mine = part[omp_get_thread_num ()];
    mine.assign (2 * nv, 0.f);
#pragma omp for schedule(dynamic, 1)
    for (std::ptrdiff_t di = 0; di < static_cast<std::ptrdiff_t> (dirs.size ()); ++di)
    {
      const Eigen::Vector3f d = dirs[di], a = d.unitOrthogonal (), b = d.cross (a);
      std::fill (near.begin (), near.end (), std::numeric_limits<float>::infinity ());
      std::fill (far.begin (), far.end (), std::numeric_limits<float>::infinity ());
      std::fill (near_count.begin (), near_count.end (), 0u);
      std::fill (far_count.begin (), far_count.end (), 0u);
      for (std::uint32_t v = 0; v < nv; ++v)
      {
        const Eigen::Vector3f q = Eigen::Map<const Eigen::Vector3f> (&pos[3 * v]) - centre;
        const auto at = [&] (const Eigen::Vector3f& axis) {
          return std::min (side - 1, static_cast<std::size_t> (std::max (0.f, (q.dot (axis) + radius) / pixel)));
        };
        const std::uint32_t c = static_cast<std::uint32_t> (at (a) * side + at (b));
        cell_of[v] = c;
        depth[v] = -q.dot (d);  // from a viewer at +d
        near[c] = std::min (near[c], depth[v]);
        far[c] = std::min (far[c], -depth[v]);
      }
      closeFrontHoles (near, scratch, side, pixel);
      near.swap (scratch);
      closeFrontHoles (far, scratch, side, pixel);
      far.swap (scratch);
      for (std::uint32_t v = 0; v < nv; ++v)
      {
        const std::uint32_t c = cell_of[v];
        near_count[c] += depth[v] <= near[c] + tolerance;
        far_count[c] += -depth[v] <= far[c] + tolerance;
      }
      for (std::uint32_t v = 0; v < nv; ++v)
      {
        const std::uint32_t c = cell_of[v];
        const float x = nrm[v].dot (d);
        if (depth[v] <= near[c] + tolerance)  // seen from +d
        {
          mine[2 * v] += x / static_cast<float> (near_count[c]);
          mine[2 * v + 1] += std::abs (x) / static_cast<float> (near_count[c]);
        }
        if (-depth[v] <= far[c] + tolerance)  // seen from −d
        {
          mine[2 * v] -= x / static_cast<float> (far_count[c]);
          mine[2 * v + 1] += std::abs (x) / static_cast<float> (far_count[c]);
        }
      }
    }
  }
  for (const auto& mine : part)
    if (!mine.empty ())
      for (std::size_t v = 0; v < nv; ++v)
      {
        vote[v] += mine[2 * v];
        mass[v] += mine[2 * v + 1];
      }
}

// The votes as they enter the labelling: only a clear majority counts, by its margin (a
// point seen from both sides of an open sheet, or with a normal at grazing angles, gets
// nothing, so that small biases of many points cannot add up to a toggle), times weight.
inline void
weighVotes (std::size_t nv, float weight, Buffer<float>& vote, Buffer<float>& mass)
{
  for (std::size_t v = 0; v < nv; ++v)
  {
    const float margin = std::max (0.f, std::abs (vote[v]) - kMajority * mass[v]);
    vote[v] = weight * std::copysign (margin, vote[v]);
    mass[v] *= weight;
  }
}

// The labelling of the vertices (1: flip the sign propagation gave it) and, per component,
// whether the votes decided its sign.
struct Labelling
{
  std::vector<char> label, decided;
  std::size_t overruled = 0;  // vertices whose label differs from their root's
};

// Which crossings to overrule: the labelling of the tree (keep or flip every vertex's sign)
// that minimises −Σ votes agreeing + Σ toggle costs of the crossings whose decision it
// overrules, exactly, by dynamic programming over the tree (children before parents, then
// parents before children). Without votes nothing is overruled. A component's own sign
// comes from its votes where they clearly decide (an open sheet's cancel); the others are
// left to voteUndecidedComponents (). Applies the labels to g.nrm.
inline Labelling
overruleCrossings (MstGraph& g, const Traversal& t, const Buffer<float>& vote, const Buffer<float>& mass)
{
  const std::size_t nv = g.nv;
  Buffer<double> keep_cost (nv), flip_cost (nv);
  for (std::uint32_t v = 0; v < nv; ++v)
  {
    keep_cost[v] = -vote[v];
    flip_cost[v] = vote[v];
  }
  for (std::size_t i = t.order.size (); i-- > 0;)
  {
    const std::uint32_t v = t.order[i], p = t.up[v];
    if (p == UINT32_MAX)
      continue;
    const double tc = t.toggle_cost[v];
    keep_cost[p] += std::min (keep_cost[v], flip_cost[v] + tc);
    flip_cost[p] += std::min (flip_cost[v], keep_cost[v] + tc);
  }
  std::vector<double> comp_mass (t.components, 0.0);
  for (std::uint32_t v = 0; v < nv; ++v)
    comp_mass[t.component[v]] += mass[v];
  Labelling l;
  l.label.assign (nv, 0);
  l.decided.assign (t.components, 0);
  std::vector<std::uint32_t> comp_root (t.components, 0);
  for (const std::uint32_t v : t.order)
  {
    const std::uint32_t p = t.up[v];
    if (p == UINT32_MAX)
    {
      comp_root[t.component[v]] = v;
      const double gain = keep_cost[v] - flip_cost[v];
      l.decided[t.component[v]] =
          std::abs (gain) >= std::max<double> (kToggleBase, kRootShare * comp_mass[t.component[v]]);
      l.label[v] = l.decided[t.component[v]] && gain > 0;
      continue;
    }
    const double tc = t.toggle_cost[v];
    l.label[v] = l.label[p] ? flip_cost[v] <= keep_cost[v] + tc : keep_cost[v] > flip_cost[v] + tc;
    l.overruled += l.label[v] != l.label[comp_root[t.component[v]]];
  }
  for (std::uint32_t v = 0; v < nv; ++v)
    if (l.label[v])
      g.nrm[v] = -g.nrm[v];
  return l;
}

// The highest point alone is a weak witness where it sits on a crease or a thin ridge: its
// normal is nearly horizontal, or wrong. The sign of every undecided component is voted by
// its extreme points in 21 directions d of the upper hemisphere, each adding n·d: outward
// normals on a closed surface make every term ≥ 0, and on an open sheet the upper
// directions still ask for "up". On a smooth top this agrees with the highest point's +z.
// Toggles the labels of the components it inverts.
inline void
voteUndecidedComponents (const MstGraph& g, const Traversal& t, Labelling& l)
{
  const std::size_t nv = g.nv;
  std::vector<Eigen::Vector3f> dirs;
  for (const auto& [elevation, count] : {std::pair{0.0, 8}, std::pair{30.0, 8}, std::pair{60.0, 4}, std::pair{90.0, 1}})
    for (int a = 0; a < count; ++a)
    {
      const double el = elevation * M_PI / 180, az = 2 * M_PI * (a + 0.5 * (elevation == 30.0)) / count;
      dirs.emplace_back (Eigen::Vector3d (std::cos (el) * std::cos (az), std::cos (el) * std::sin (az), std::sin (el)).cast<float> ());
    }
  const std::size_t nd = dirs.size ();
  std::vector<std::pair<float, std::uint32_t>> extreme (t.components * nd, {-std::numeric_limits<float>::infinity (), 0u});
  for (std::uint32_t v = 0; v < nv; ++v)
  {
    const Eigen::Map<const Eigen::Vector3f> p (&g.pos[3 * v]);
    auto* e = &extreme[std::size_t (t.component[v]) * nd];
    for (std::size_t d = 0; d < nd; ++d)
    {
      const float h = p.dot (dirs[d]);
      if (h > e[d].first)
        e[d] = {h, v};
    }
  }
  std::vector<char> invert (t.components, 0);
  for (std::size_t c = 0; c < t.components; ++c)
    if (!l.decided[c])
    {
      double sum = 0;
      for (std::size_t d = 0; d < nd; ++d)
        sum += g.nrm[extreme[c * nd + d].second].dot (dirs[d]);
      invert[c] = sum < 0;
    }
  for (std::uint32_t v = 0; v < nv; ++v)
    l.label[v] ^= invert[t.component[v]];
}

}  // namespace detail
}  // namespace normals
}  // namespace pclx

template <typename PointT, typename NormalT> bool
pcl::MSTNormalOrientation<PointT, NormalT>::fail (const char* format, ...)
{
  std::va_list args;
  va_start (args, format);
  last_error_ = pclx::normals::detail::vformatMessage (format, args);
  va_end (args);
  PCL_ERROR ("%s", last_error_.c_str ());
  return false;
}

template <typename PointT, typename NormalT> bool
pcl::MSTNormalOrientation<PointT, NormalT>::checkParameters (const PointCloud<NormalT>& normals)
{
  if (!input_)
    return fail ("[pcl::MSTNormalOrientation::orient] no input cloud\n");
  if (input_->size () != normals.size ())
    return fail ("[pcl::MSTNormalOrientation::orient] %zu points but %zu normals\n", input_->size (),
                 normals.size ());
  if (k_ < 1)
    return fail ("[pcl::MSTNormalOrientation::orient] k must be >= 1 (got %d)\n", k_);
  if (!std::isfinite (noise_scale_))
    return fail ("[pcl::MSTNormalOrientation::orient] the noise scale must be finite (got %g; < 0: estimate it)\n",
                 noise_scale_);
  if (!std::isfinite (side_significance_) || side_significance_ < 0)
    return fail ("[pcl::MSTNormalOrientation::orient] the edge-side significance must be finite and >= 0 (got %g)\n",
                 side_significance_);
  if (!std::isfinite (visibility_weight_) || visibility_weight_ < 0)
    return fail ("[pcl::MSTNormalOrientation::orient] the visibility weight must be finite and >= 0 (got %g)\n",
                 visibility_weight_);
  return true;
}

template <typename PointT, typename NormalT> void
pcl::MSTNormalOrientation<PointT, NormalT>::collectVertices (const PointCloud<NormalT>& normals,
                                                              pclx::normals::detail::MstGraph& g) const
{
  // Graph vertices: the points with a finite position and a finite non-zero normal.
  auto valid = [&] (std::size_t i) {
    const auto n = normals[i].getNormalVector3fMap ();
    return isFinite ((*input_)[i]) && n.allFinite () && n.squaredNorm () > 0;
  };
  g.lo = Eigen::Vector3f::Constant (std::numeric_limits<float>::max ());
  g.hi = -g.lo;
  for (std::size_t i = 0; i < input_->size (); ++i)
    if (valid (i))
    {
      g.input_ids.push_back (static_cast<std::uint32_t> (i));
      g.lo = g.lo.cwiseMin ((*input_)[i].getVector3fMap ());
      g.hi = g.hi.cwiseMax ((*input_)[i].getVector3fMap ());
    }
  g.nv = g.input_ids.size ();
}

template <typename PointT, typename NormalT> double
pcl::MSTNormalOrientation<PointT, NormalT>::searchNeighbourGraph (pclx::normals::detail::MstGraph& g,
                                                                   bool estimate_noise)
{
  const std::size_t nv = g.nv, row = g.row;
  const int threads = g.threads;
  // The search holds a Morton-ordered copy of the vertices, so its indices are vertex ids.
  typename PointCloud<PointT>::Ptr sorted (new PointCloud<PointT>);
  sorted->resize (nv);
  for (std::size_t v = 0; v < nv; ++v)
    (*sorted)[v] = (*input_)[g.input_ids[v]];
  search_->setInputCloud (sorted);
  // Plain threads, not OpenMP: PCL's FLANN query opens an OpenMP region per call, which
  // is slower nested in our own region than from one thread.
  auto query = [&] (int t) {
    pcl::Indices nn;
    std::vector<float> dist;
    double sum = 0;
    std::size_t count = 0;
    for (std::size_t v = nv * t / threads; v < nv * (t + 1) / threads; ++v)
    {
      search_->nearestKSearch ((*sorted)[v], static_cast<int> (row), nn, dist);
      pclx::normals::detail::keepNeighbours (
          g, v, std::min (nn.size (), row), [&] (std::size_t q) { return static_cast<std::uint32_t> (nn[q]); },
          dist.data (), sum, count);
    }
    g.len_sum[t] = sum;
    g.len_count[t] = count;
  };
  std::vector<std::thread> workers;
  for (int t = 0; t < threads; ++t)
    workers.emplace_back (query, t);
  for (auto& w : workers)
    w.join ();
  if (!estimate_noise)
    return 0;
  // One thread: PCL's FLANN query opens an OpenMP region of its own (see above).
  return pclx::normals::detail::estimateGraphNoise (
      g,
      [&] (std::uint32_t v, std::vector<std::uint32_t>& ids) {
        pcl::Indices nn;
        std::vector<float> dist;
        search_->nearestKSearch ((*sorted)[v],
                                 static_cast<int> (std::min (pclx::normals::detail::kNoiseNeighbours, nv)), nn, dist);
        ids.assign (nn.begin (), nn.end ());
      },
      1);
}

template <typename PointT, typename NormalT> void
pcl::MSTNormalOrientation<PointT, NormalT>::buildRiemannianGraph (const PointCloud<NormalT>& normals,
                                                                   pclx::normals::detail::MstGraph& g)
{
  const std::size_t nv = g.nv;
  pclx::normals::detail::mortonOrder (g, [&] (std::uint32_t i) { return (*input_)[i].getVector3fMap (); });
  g.pos.resize (3 * nv);
  g.nrm.resize (nv);
#pragma omp parallel for num_threads(g.threads)
  for (std::ptrdiff_t v = 0; v < static_cast<std::ptrdiff_t> (nv); ++v)
  {
    Eigen::Map<Eigen::Vector3f> p (&g.pos[3 * v]);
    p = (*input_)[g.input_ids[v]].getVector3fMap ();
    g.nrm[v] = normals[g.input_ids[v]].getNormalVector3fMap ().normalized ();
  }
  g.nbr.resize (nv * g.row);
  g.len_sum.assign (g.threads, 0.0);
  g.len_count.assign (g.threads, 0);
  // Noise along the normal, unless given.
  const bool estimate_noise = noise_scale_ < 0;
  const double noise = search_ ? searchNeighbourGraph (g, estimate_noise)
                               : pclx::normals::detail::flannNeighbourGraph (g, estimate_noise);
  used_noise_ = estimate_noise ? noise : noise_scale_;
  const double sum = std::accumulate (g.len_sum.begin (), g.len_sum.end (), 0.0);
  const std::size_t count = std::accumulate (g.len_count.begin (), g.len_count.end (), std::size_t (0));
  g.mean_len = count ? sum / count : 0.0;
}

template <typename PointT, typename NormalT> bool
pcl::MSTNormalOrientation<PointT, NormalT>::orient (PointCloud<NormalT>& normals)
{
  namespace nd = pclx::normals::detail;
  components_ = flipped_ = edges_ = visibility_flipped_ = 0;
  last_error_.clear ();
  if (!checkParameters (normals))
    return false;
  used_noise_ = 0;

  nd::MstGraph g;
  collectVertices (normals, g);
  const std::size_t nv = g.nv;
  if (nv == 0)
    return true;
  g.k = static_cast<std::size_t> (k_);
  g.row = std::min (g.k + 1, nv);
  if (nv * g.row >= UINT32_MAX)
    return fail ("[pcl::MSTNormalOrientation::orient] %zu points x k = %d exceed the 32-bit edge ids\n", nv, k_);
  g.threads = threads_ > 0 ? static_cast<int> (threads_) : omp_get_max_threads ();

  // Hoppe et al.'s stages: the Riemannian graph, its minimum spanning forest, and sign
  // propagation from a root per component; then the visibility votes overrule crossings.
  buildRiemannianGraph (normals, g);
  const nd::EdgeSideTest side{static_cast<float> (side_significance_ * used_noise_ + nd::kSideFloor * g.mean_len)};
  nd::Buffer<std::uint64_t> keys = nd::sortedEdgeKeys (g, side, across_penalty_, tie_break_);
  edges_ = keys.size ();
  const nd::SpanningForest forest = nd::minimumSpanningForest (g, keys);
  const nd::Traversal traversal = nd::propagateSigns (g, forest, side);
  components_ = traversal.components;

  nd::Buffer<float> vote (nv, 0.f), mass (nv, 0.f);  // Σ n·d, Σ |n·d|
  if (visibility_weight_ > 0 && g.mean_len > 0)
  {
    nd::accumulateVisibilityVotes (g, used_noise_, vote, mass);
    nd::weighVotes (nv, static_cast<float> (visibility_weight_), vote, mass);
  }
  nd::Labelling labelling = nd::overruleCrossings (g, traversal, vote, mass);
  visibility_flipped_ = labelling.overruled;
  nd::voteUndecidedComponents (g, traversal, labelling);

  for (std::size_t v = 0; v < nv; ++v)
    if (traversal.flip[v] ^ labelling.label[v])
    {
      normals[g.input_ids[v]].getNormalVector3fMap () *= -1.f;
      ++flipped_;
    }
  return true;
}

#define PCL_INSTANTIATE_MSTNormalOrientation(T, NT) template class PCL_EXPORTS pcl::MSTNormalOrientation<T, NT>;
