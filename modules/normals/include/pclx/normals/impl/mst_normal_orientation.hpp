#pragma once
#include <pclx/normals/mst_normal_orientation.h>
#include <pclx/normals/scale_selection.h>

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
#ifdef __linux__
#include <sys/mman.h>
#endif

namespace pcl {
namespace mst_detail {

constexpr float kSideFloor = 0.25f;  // × mean edge length
constexpr float kFoldSlack = 0.5f;   // × |e|, nearly parallel lines
// Visibility votes (see orient ()). Tuned on the grooved slab of bench_normals --orient
// (100k points): pixel 1 / 1.5 / 2 edges, toggle 0.5 + 2 s² or 1 + 4 s² moved ours by
// < 0.5 % of the points; a majority share of 0.3 let an open wavy sheet's residual votes
// flip 11 % of it.
constexpr float kPixelEdges = 1.5f;    // pixel side, × mean edge length
constexpr float kToggleBase = 0.5f;    // cost of overruling any crossing (a pixel's vote is <= 1)
constexpr float kToggleSpan = 2.f;     // ... plus this × s², s = 0 at 60° between the normals, 1 at 0°
constexpr float kMajority = 0.5f;      // a vertex's vote counts by its margin over this share of its mass
constexpr double kRootShare = 0.2;     // a component's votes decide its sign past this share of its mass

// Large buffers go on transparent huge pages: first-touch page faults, not the
// algorithm, took half of the time at 1M points (4 KiB faults cost ~3 ms per MB on our
// VMs, ~30x more than with 2 MiB pages).
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

}  // namespace mst_detail

template <typename PointT, typename NormalT> bool
MSTNormalOrientation<PointT, NormalT>::orient (PointCloud<NormalT>& normals)
{
  components_ = flipped_ = edges_ = visibility_flipped_ = 0;
  if (!input_)
  {
    PCL_ERROR ("[pcl::MSTNormalOrientation::orient] no input cloud\n");
    return false;
  }
  if (input_->size () != normals.size ())
  {
    PCL_ERROR ("[pcl::MSTNormalOrientation::orient] %zu points but %zu normals\n", input_->size (),
               normals.size ());
    return false;
  }
  if (k_ < 1)
  {
    PCL_ERROR ("[pcl::MSTNormalOrientation::orient] k must be >= 1 (got %d)\n", k_);
    return false;
  }
  if (!std::isfinite (noise_scale_))
  {
    PCL_ERROR ("[pcl::MSTNormalOrientation::orient] the noise scale must be finite (got %g; < 0: estimate it)\n",
               noise_scale_);
    return false;
  }
  if (!std::isfinite (side_significance_) || side_significance_ < 0)
  {
    PCL_ERROR ("[pcl::MSTNormalOrientation::orient] the edge-side significance must be finite and >= 0 (got %g)\n",
               side_significance_);
    return false;
  }
  if (!std::isfinite (visibility_weight_) || visibility_weight_ < 0)
  {
    PCL_ERROR ("[pcl::MSTNormalOrientation::orient] the visibility weight must be finite and >= 0 (got %g)\n",
               visibility_weight_);
    return false;
  }
  used_noise_ = 0;

  // Graph vertices: the points with a finite position and a finite non-zero normal.
  auto valid = [&] (std::size_t i) {
    const auto n = normals[i].getNormalVector3fMap ();
    return isFinite ((*input_)[i]) && n.allFinite () && n.squaredNorm () > 0;
  };
  mst_detail::Buffer<std::uint32_t> input_ids;
  Eigen::Vector3f lo = Eigen::Vector3f::Constant (std::numeric_limits<float>::max ()), hi = -lo;
  for (std::size_t i = 0; i < input_->size (); ++i)
    if (valid (i))
    {
      input_ids.push_back (static_cast<std::uint32_t> (i));
      lo = lo.cwiseMin ((*input_)[i].getVector3fMap ());
      hi = hi.cwiseMax ((*input_)[i].getVector3fMap ());
    }
  const std::size_t nv = input_ids.size ();
  if (nv == 0)
    return true;
  // Row width: the query returns the point itself too.
  const std::size_t k = static_cast<std::size_t> (k_);
  const std::size_t row = std::min (k + 1, nv);
  if (nv * row >= UINT32_MAX)
  {
    PCL_ERROR ("[pcl::MSTNormalOrientation::orient] %zu points x k = %d exceed the 32-bit edge ids\n", nv, k_);
    return false;
  }
  const int threads = threads_ > 0 ? static_cast<int> (threads_) : omp_get_max_threads ();

  // Vertices in Morton (Z) order, so that kNN queries, edge costs, union-find and the
  // traversal touch nearby memory (random-order input made every stage cache-bound).
  {
    const float extent = (hi - lo).maxCoeff ();
    const float scale = extent > 0 ? 1023.f / extent : 0.f;
    mst_detail::Buffer<std::uint64_t> keys (nv);
#pragma omp parallel for num_threads(threads)
    for (std::ptrdiff_t j = 0; j < static_cast<std::ptrdiff_t> (nv); ++j)
    {
      const Eigen::Vector3f q = ((*input_)[input_ids[j]].getVector3fMap () - lo) * scale;
      const std::uint32_t code = mst_detail::spreadBits (static_cast<std::uint32_t> (q.x ())) |
                                 mst_detail::spreadBits (static_cast<std::uint32_t> (q.y ())) << 1 |
                                 mst_detail::spreadBits (static_cast<std::uint32_t> (q.z ())) << 2;
      keys[j] = static_cast<std::uint64_t> (code) << 32 | input_ids[j];
    }
    boost::sort::block_indirect_sort (keys.begin (), keys.end (), static_cast<std::uint32_t> (threads));
    for (std::size_t v = 0; v < nv; ++v)
      input_ids[v] = static_cast<std::uint32_t> (keys[v]);
  }
  // Vertex v (Morton rank) is input point input_ids[v].
  mst_detail::Buffer<float> pos (3 * nv);
  mst_detail::Buffer<Eigen::Vector3f> nrm (nv);
#pragma omp parallel for num_threads(threads)
  for (std::ptrdiff_t v = 0; v < static_cast<std::ptrdiff_t> (nv); ++v)
  {
    Eigen::Map<Eigen::Vector3f> p (&pos[3 * v]);
    p = (*input_)[input_ids[v]].getVector3fMap ();
    nrm[v] = normals[input_ids[v]].getNormalVector3fMap ().normalized ();
  }

  // Riemannian graph: row v holds v's k nearest other vertices (UINT32_MAX pads).
  mst_detail::Buffer<std::uint32_t> nbr (nv * row);
  // Keeps the first k neighbours other than v itself (absent when k + 1 points coincide).
  auto keep = [&] (std::size_t v, std::size_t found, auto&& id_of, const float* sqr_dist, double& sum,
                   std::size_t& cnt) {
    std::size_t slot = v * row;
    for (std::size_t q = 0; q < found && slot < v * row + k; ++q)
    {
      const std::uint32_t w = id_of (q);
      if (w == UINT32_MAX || w == v)
        continue;
      nbr[slot++] = w;
      sum += std::sqrt (sqr_dist[q]);
      ++cnt;
    }
    for (; slot < (v + 1) * row; ++slot)
      nbr[slot] = UINT32_MAX;
  };
  std::vector<double> len_sum (threads, 0.0);
  std::vector<std::size_t> len_count (threads, 0);
  // Noise along the normal, unless given: pclx::normals::sampleNoise (robust quadric residuals
  // over 24-100 neighbours) on about 500 vertices (the estimator uses 2000). knn (v, ids)
  // lists v's nearest vertices sorted by distance, v first.
  const bool estimate_noise = noise_scale_ < 0;
  struct NoiseScratch
  {
    std::vector<std::uint32_t> ids;
  };
  auto estimateNoise = [&] (auto&& knn, int team) {
    return pclx::normals::estimateCloudNoise<NoiseScratch> (
               nv, 500, team,
               [&] (std::size_t v, std::vector<Eigen::Vector3f>& sorted, NoiseScratch& t) {
                 knn (static_cast<std::uint32_t> (v), t.ids);
                 for (const std::uint32_t id : t.ids)
                   sorted.emplace_back (pos[3 * id], pos[3 * id + 1], pos[3 * id + 2]);
               })
        .sigma;
  };
  constexpr std::size_t kNoiseNeighbours = 101;
  if (search_)
  {
    // The search holds a Morton-ordered copy of the vertices, so its indices are vertex ids.
    typename PointCloud<PointT>::Ptr sorted (new PointCloud<PointT>);
    sorted->resize (nv);
    for (std::size_t v = 0; v < nv; ++v)
      (*sorted)[v] = (*input_)[input_ids[v]];
    search_->setInputCloud (sorted);
    // Plain threads, not OpenMP: PCL's FLANN query opens an OpenMP region per call, which
    // nested in our own region ran 2x slower than from one thread.
    auto query = [&] (int t) {
      pcl::Indices nn;
      std::vector<float> dist;
      double sum = 0;
      std::size_t count = 0;
      for (std::size_t v = nv * t / threads; v < nv * (t + 1) / threads; ++v)
      {
        search_->nearestKSearch ((*sorted)[v], static_cast<int> (row), nn, dist);
        keep (v, std::min (nn.size (), row), [&] (std::size_t q) { return static_cast<std::uint32_t> (nn[q]); },
              dist.data (), sum, count);
      }
      len_sum[t] = sum;
      len_count[t] = count;
    };
    std::vector<std::thread> workers;
    for (int t = 0; t < threads; ++t)
      workers.emplace_back (query, t);
    for (auto& w : workers)
      w.join ();
    if (estimate_noise)
      // One thread: PCL's FLANN query opens an OpenMP region of its own (see above).
      used_noise_ = estimateNoise (
          [&] (std::uint32_t v, std::vector<std::uint32_t>& ids) {
            pcl::Indices nn;
            std::vector<float> dist;
            search_->nearestKSearch ((*sorted)[v], static_cast<int> (std::min (kNoiseNeighbours, nv)), nn, dist);
            ids.assign (nn.begin (), nn.end ());
          },
          1);
  }
  else
  {
    // FLANN's kd-tree (the one pcl::search::KdTree builds), queried directly: FLANN's
    // knnSearch opens an OpenMP region per call; through PCL a query took 3.7 us, the
    // search itself 0.8 us.
    flann::Matrix<float> data (pos.data (), nv, 3);
    flann::KDTreeSingleIndex<flann::L2_Simple<float>> index (data, flann::KDTreeSingleIndexParams (15));
    index.buildIndex ();
#pragma omp parallel num_threads(threads)
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
        index.findNeighbors (result, &pos[3 * v], params);
        const std::size_t found = std::min (result.size (), row);
        result.copy (ids.data (), dist.data (), found);
        keep (v, found, [&] (std::size_t q) { return static_cast<std::uint32_t> (ids[q]); }, dist.data (), sum,
              count);
      }
      len_sum[t] = sum;
      len_count[t] = count;
    }
    if (estimate_noise)
      used_noise_ = estimateNoise (
          [&] (std::uint32_t v, std::vector<std::uint32_t>& ids) {
            const std::size_t want = std::min (kNoiseNeighbours, nv);
            flann::KNNSimpleResultSet<float> result (want);
            std::vector<std::size_t> found (want);
            std::vector<float> dist (want);
            index.findNeighbors (result, &pos[3 * v], flann::SearchParams (-1, 0.f, true));
            const std::size_t m = std::min (result.size (), want);
            result.copy (found.data (), dist.data (), m);
            ids.assign (found.begin (), found.begin () + m);
          },
          threads);
  }
  if (!estimate_noise)
    used_noise_ = noise_scale_;
  const double sum = std::accumulate (len_sum.begin (), len_sum.end (), 0.0);
  const std::size_t count = std::accumulate (len_count.begin (), len_count.end (), std::size_t (0));
  const double mean_len = count ? sum / count : 0.0;
  // The edge-side reading (see flipAcross) needs e to leave both tangent planes. For normals
  // > 60° apart (a sharp edge, where Hoppe's rule is a coin toss) 0.2 |e| suffices: noise
  // blurs the reading less than it blurs the toss. For nearly parallel lines Hoppe's rule is
  // usually right, so the reading overrides it only where it is significant, geometry rather
  // than noise or a blended normal: both offsets above side_significance_ noise sigmas plus a
  // quarter of the mean edge, plus 0.5 |e| (a fold: the faces of a thin part or of a ridge
  // narrower than the edges) or 0.2 |e| (a sharp edge). a, b: |ni·e|, |nj·e|; dn: ni·nj.
  const float fold_floor = static_cast<float> (side_significance_ * used_noise_ + mst_detail::kSideFloor * mean_len);
  const auto sideSignificant = [fold_floor] (float a, float b, float length, float dn) {
    return std::min (a, b) > fold_floor + (std::abs (dn) < 0.5f ? 0.2f : mst_detail::kFoldSlack) * length;
  };
  const auto sideReadable = [&sideSignificant] (float a, float b, float length, float dn) {
    return std::abs (dn) < 0.5f ? std::min (a, b) > 0.2f * length : sideSignificant (a, b, length, dn);
  };
  // A significant pair's turn 1 − |ni·nj| counts this much: two faces of a ridge narrower than
  // the graph's edges meet at 152° and look 28° apart to Hoppe's rule, so an edge along the
  // crease (unreadable, Hoppe flips) must cost more than one across it (readable). Sharp
  // pairs readable only by the looser 0.2 |e| keep their cost: made cheaper, they were used
  // more on noisy clouds (fertility σ = 0.012: 1.2 → 1.29 % flipped; exact normals 1.59 → 2.02 %).
  constexpr float kReadableTurn = 0.5f;

  // One key per undirected edge (a mutual pair is kept once): the cost's float bits
  // (costs are >= 0, so they order like the floats) above the slot of the edge.
  // Ties (exactly parallel normals, e.g. both sides of a thin plate fitted by one plane)
  // go to the shorter edge, so propagation stays on a sheet instead of jumping across.
  // Every thread takes one contiguous range of vertices and writes its keys after those of
  // the threads before it (count, then fill: no per-thread vectors to merge).
  auto listed_from_w = [&] (std::size_t v, std::uint32_t w) {
    const auto r = nbr.begin () + w * row;
    return w < v && std::find (r, r + row, static_cast<std::uint32_t> (v)) != r + row;
  };
  mst_detail::Buffer<std::uint64_t> keys;
  std::vector<std::size_t> first (threads + 1, 0);
#pragma omp parallel num_threads(threads)
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
    const float penalty = static_cast<float> (across_penalty_);
    const float length_weight = tie_break_ > 0 && mean_len > 0 ? static_cast<float> (tie_break_ / mean_len) : 0.f;
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
          // Where both normals lean off e by more than noise and slack (sideReadable), the
          // traversal reads the sign from the edge's side: prefer the crossings that leave
          // both tangent planes most (an edge along a crease says nothing). Elsewhere Hoppe's
          // rule decides, which an edge along the normals (through a thin plate, from one
          // sheet to the other) misleads: make those expensive, so that the tree goes around
          // along the surface. Unreadable pairs > 60° apart keep the first form (no rule is
          // reliable there; the least bad crossing leaves both planes most).
          const bool readable = sideReadable (a, b, length, dn);
          if (readable && sideSignificant (a, b, length, dn))
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
  edges_ = keys.size ();
  // Keys are unique (the slot is in the low bits), so a full sort orders by cost, then slot.
  boost::sort::block_indirect_sort (keys.begin (), keys.end (), static_cast<std::uint32_t> (threads));

  // Minimum spanning forest: Kruskal, i.e. edges by increasing cost into Boost's
  // disjoint sets (boost::kruskal_minimum_spanning_tree's priority queue was 3x slower).
  mst_detail::Buffer<std::uint32_t> parent (nv), rank (nv, 0);
  std::iota (parent.begin (), parent.end (), 0u);
  boost::disjoint_sets<std::uint32_t*, std::uint32_t*> sets (rank.data (), parent.data ());
  mst_detail::Buffer<std::pair<std::uint32_t, std::uint32_t>> tree;
  tree.reserve (nv - 1);
  for (const std::uint64_t key : keys)
  {
    const std::uint32_t slot = static_cast<std::uint32_t> (key);
    const std::uint32_t v = static_cast<std::uint32_t> (slot / row), w = nbr[slot];
    const std::uint32_t a = sets.find_set (v), b = sets.find_set (w);
    if (a == b)
      continue;
    sets.link (a, b);
    tree.emplace_back (v, w);
    if (tree.size () + 1 == nv)
      break;
  }
  mst_detail::Buffer<std::uint64_t> ().swap (keys);
  mst_detail::Buffer<std::uint32_t> ().swap (nbr);

  // Root of every component: its highest point (lowest input index among equal z).
  mst_detail::Buffer<std::uint32_t>& root = rank;  // by representative; reuses the ranks' storage
  std::fill (root.begin (), root.end (), UINT32_MAX);
  for (std::uint32_t v = 0; v < nv; ++v)
  {
    std::uint32_t& r = root[sets.find_set (v)];
    if (r == UINT32_MAX || pos[3 * v + 2] > pos[3 * r + 2] ||
        (pos[3 * v + 2] == pos[3 * r + 2] && input_ids[v] < input_ids[r]))
      r = v;
  }

  // Forest adjacency (CSR arrays).
  mst_detail::Buffer<std::uint32_t> offset (nv + 1, 0), adj (2 * tree.size ());
  for (const auto& e : tree)
  {
    ++offset[e.first + 1];
    ++offset[e.second + 1];
  }
  std::partial_sum (offset.begin (), offset.end (), offset.begin ());
  {
    mst_detail::Buffer<std::uint32_t>& fill = parent;  // no longer needed
    std::copy (offset.begin (), offset.end () - 1, fill.begin ());
    for (const auto& e : tree)
    {
      adj[fill[e.first]++] = e.second;
      adj[fill[e.second]++] = e.first;
    }
  }
  mst_detail::Buffer<std::pair<std::uint32_t, std::uint32_t>> ().swap (tree);

  // Depth-first from every root, as in the seed; the root's normal points to +z.
  // A child takes its parent's sign by Hoppe's rule (ni·nj > 0) where the normals are
  // within 60° of each other. Across a sharp edge (exact normals at 90° on a box) ni·nj ≈ 0
  // is a coin toss; there the edge vector e = pj − pi decides: on any consistently
  // oriented surface, convex or concave, ni·e and nj·e have opposite signs (a sphere's
  // chord gives ni·e = −nj·e). Used only when both lean off e by > 0.2 |e|; otherwise Hoppe.
  // Also gives the cost of overruling the decision (see the visibility votes below): low where
  // the side was read or the normals are > 60° apart, rising to its maximum at parallel normals.
  const auto flipAcross = [&] (std::uint32_t u, std::uint32_t w, float& toggle) {
    const Eigen::Vector3f e = Eigen::Map<const Eigen::Vector3f> (&pos[3 * w]) -
                              Eigen::Map<const Eigen::Vector3f> (&pos[3 * u]);
    const float a = nrm[u].dot (e), b = nrm[w].dot (e), dn = nrm[w].dot (nrm[u]);
    toggle = mst_detail::kToggleBase;
    if (sideReadable (std::abs (a), std::abs (b), e.norm (), dn))
      return a * b > 0;
    const float sure = std::max (0.f, 2 * std::abs (dn) - 1);  // 0 at 60°, 1 at 0°
    toggle += mst_detail::kToggleSpan * sure * sure;
    return dn < 0;
  };
  std::vector<char> seen (nv, 0), flip (nv, 0);
  std::vector<std::uint32_t> stack, component (nv, 0);
  // The traversal's order (parents first), every vertex's tree parent (UINT32_MAX at a root)
  // and the cost of overruling the crossing from it.
  mst_detail::Buffer<std::uint32_t> order, up (nv, UINT32_MAX);
  order.reserve (nv);
  mst_detail::Buffer<float> toggle_cost (nv, 0.f);
  for (const std::uint32_t r : root)
  {
    if (r == UINT32_MAX)
      continue;
    const std::uint32_t c = static_cast<std::uint32_t> (components_++);
    component[r] = c;
    seen[r] = 1;
    order.push_back (r);
    if (nrm[r].z () < 0)
    {
      nrm[r] = -nrm[r];
      flip[r] = 1;
    }
    stack.push_back (r);
    while (!stack.empty ())
    {
      const std::uint32_t u = stack.back ();
      stack.pop_back ();
      for (std::uint32_t e = offset[u]; e < offset[u + 1]; ++e)
      {
        const std::uint32_t w = adj[e];
        if (seen[w])
          continue;
        seen[w] = 1;
        component[w] = component[u];
        if (flipAcross (u, w, toggle_cost[w]))
        {
          nrm[w] = -nrm[w];
          flip[w] = 1;
        }
        up[w] = u;
        order.push_back (w);
        stack.push_back (w);
      }
    }
  }
  // Visibility votes, a global cue that local sign propagation lacks: seen from outside along
  // a direction d (orthographic), the first surface point of every line of sight has its
  // outward normal facing the viewer (n·d > 0), on any closed surface, convex or not. For each
  // of 26 directions (the cube's faces, edges and corners), every pixel (1.5 mean edges wide,
  // so that the front surface leaves few holes) gives a vote of n·d to the vertices it sees.
  // Hand-written rather than pcl::HPRFilter: one orthographic z-buffer pass per direction is
  // O(n), where every HPR viewpoint builds a convex hull of the whole cloud.
  mst_detail::Buffer<float> vote (nv, 0.f), mass (nv, 0.f);  // Σ n·d, Σ |n·d|
  const bool use_votes = visibility_weight_ > 0 && mean_len > 0;
  if (use_votes)
  {
    const Eigen::Vector3f centre = 0.5f * (lo + hi);
    const float radius = 0.5f * (hi - lo).norm ();
    // Cells: at most 4 per vertex (a long thin cloud would otherwise ask for a huge grid).
    float pixel = mst_detail::kPixelEdges * static_cast<float> (mean_len);
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
    const float tolerance = pixel + 2 * static_cast<float> (used_noise_);
    std::vector<mst_detail::Buffer<float>> part (threads);
#pragma omp parallel num_threads(threads)
    {
      // Per cell: the nearest and farthest depth along d, and how many vertices each end sees.
      std::vector<float> near (side * side), far (side * side);
      std::vector<std::uint32_t> near_count (side * side), far_count (side * side), cell_of (nv);
      std::vector<float> depth (nv);
      mst_detail::Buffer<float>& mine = part[omp_get_thread_num ()];
      mine.assign (2 * nv, 0.f);
#pragma omp for schedule(dynamic, 1)
      for (std::ptrdiff_t di = 0; di < static_cast<std::ptrdiff_t> (dirs.size ()); ++di)
      {
        const Eigen::Vector3f d = dirs[di], a = d.unitOrthogonal (), b = d.cross (a);
        std::fill (near.begin (), near.end (), std::numeric_limits<float>::infinity ());
        std::fill (far.begin (), far.end (), -std::numeric_limits<float>::infinity ());
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
          far[c] = std::max (far[c], depth[v]);
        }
        for (std::uint32_t v = 0; v < nv; ++v)
        {
          const std::uint32_t c = cell_of[v];
          near_count[c] += depth[v] <= near[c] + tolerance;
          far_count[c] += depth[v] >= far[c] - tolerance;
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
          if (depth[v] >= far[c] - tolerance)  // seen from −d
          {
            mine[2 * v] -= x / static_cast<float> (far_count[c]);
            mine[2 * v + 1] += std::abs (x) / static_cast<float> (far_count[c]);
          }
        }
      }
    }
    const float weight = static_cast<float> (visibility_weight_);
    for (const auto& mine : part)
      if (!mine.empty ())
        for (std::size_t v = 0; v < nv; ++v)
        {
          vote[v] += mine[2 * v];
          mass[v] += mine[2 * v + 1];
        }
    // Only a clear majority counts, by its margin: a point seen from both sides of an open
    // sheet (or with a normal at grazing angles) gets nothing, so that small biases of many
    // points cannot add up to a toggle.
    for (std::size_t v = 0; v < nv; ++v)
    {
      const float margin = std::max (0.f, std::abs (vote[v]) - mst_detail::kMajority * mass[v]);
      vote[v] = weight * std::copysign (margin, vote[v]);
      mass[v] *= weight;
    }
  }
  // Which crossings to overrule: the labelling of the tree (keep or flip every vertex's sign)
  // that minimises −Σ votes agreeing + Σ toggle costs of the crossings whose decision it
  // overrules, exactly, by dynamic programming over the tree (children before parents, then
  // parents before children). Without votes nothing is overruled.
  mst_detail::Buffer<double> keep_cost (nv), flip_cost (nv);
  for (std::uint32_t v = 0; v < nv; ++v)
  {
    keep_cost[v] = -vote[v];
    flip_cost[v] = vote[v];
  }
  for (std::size_t i = order.size (); i-- > 0;)
  {
    const std::uint32_t v = order[i], p = up[v];
    if (p == UINT32_MAX)
      continue;
    const double t = toggle_cost[v];
    keep_cost[p] += std::min (keep_cost[v], flip_cost[v] + t);
    flip_cost[p] += std::min (flip_cost[v], keep_cost[v] + t);
  }
  // A component's own sign: its votes where they clearly decide (an open sheet's cancel), else
  // the extreme points (below).
  std::vector<double> comp_mass (components_, 0.0);
  for (std::uint32_t v = 0; v < nv; ++v)
    comp_mass[component[v]] += mass[v];
  std::vector<char> label (nv, 0), decided (components_, 0);
  std::vector<std::uint32_t> comp_root (components_, 0);
  for (const std::uint32_t v : order)
  {
    const std::uint32_t p = up[v];
    if (p == UINT32_MAX)
    {
      comp_root[component[v]] = v;
      const double gain = keep_cost[v] - flip_cost[v];
      decided[component[v]] = std::abs (gain) >= std::max<double> (mst_detail::kToggleBase,
                                                                    mst_detail::kRootShare * comp_mass[component[v]]);
      label[v] = decided[component[v]] && gain > 0;
      continue;
    }
    const double t = toggle_cost[v];
    label[v] = label[p] ? flip_cost[v] <= keep_cost[v] + t : keep_cost[v] > flip_cost[v] + t;
    visibility_flipped_ += label[v] != label[comp_root[component[v]]];
  }
  for (std::uint32_t v = 0; v < nv; ++v)
    if (label[v])
      nrm[v] = -nrm[v];
  // The highest point alone is a weak witness where it sits on a crease or a thin ridge: its
  // normal is nearly horizontal, or wrong (a grooved slab came out 86 % flipped). The sign of
  // every undecided component is voted by its extreme points in 21 directions d of the upper
  // hemisphere, each adding n·d: outward normals on a closed surface make every term ≥ 0, and
  // on an open sheet the upper directions still ask for "up". On a smooth top this agrees with
  // the highest point's +z.
  {
    std::vector<Eigen::Vector3f> dirs;
    for (const auto& [elevation, count] : {std::pair{0.0, 8}, std::pair{30.0, 8}, std::pair{60.0, 4}, std::pair{90.0, 1}})
      for (int a = 0; a < count; ++a)
      {
        const double el = elevation * M_PI / 180, az = 2 * M_PI * (a + 0.5 * (elevation == 30.0)) / count;
        dirs.emplace_back (Eigen::Vector3d (std::cos (el) * std::cos (az), std::cos (el) * std::sin (az), std::sin (el)).cast<float> ());
      }
    const std::size_t nd = dirs.size ();
    std::vector<std::pair<float, std::uint32_t>> extreme (components_ * nd, {-std::numeric_limits<float>::infinity (), 0u});
    for (std::uint32_t v = 0; v < nv; ++v)
    {
      const Eigen::Map<const Eigen::Vector3f> p (&pos[3 * v]);
      auto* e = &extreme[std::size_t (component[v]) * nd];
      for (std::size_t d = 0; d < nd; ++d)
      {
        const float h = p.dot (dirs[d]);
        if (h > e[d].first)
          e[d] = {h, v};
      }
    }
    std::vector<char> invert (components_, 0);
    for (std::size_t c = 0; c < components_; ++c)
      if (!decided[c])
      {
        double sum = 0;
        for (std::size_t d = 0; d < nd; ++d)
          sum += nrm[extreme[c * nd + d].second].dot (dirs[d]);
        invert[c] = sum < 0;
      }
    for (std::uint32_t v = 0; v < nv; ++v)
      label[v] ^= invert[component[v]];
  }
  for (std::uint32_t v = 0; v < nv; ++v)
    flip[v] ^= label[v];
  for (std::size_t v = 0; v < nv; ++v)
    if (flip[v])
    {
      normals[input_ids[v]].getNormalVector3fMap () *= -1.f;
      ++flipped_;
    }
  return true;
}

}  // namespace pcl

#define PCL_INSTANTIATE_MSTNormalOrientation(T, NT) template class PCL_EXPORTS pcl::MSTNormalOrientation<T, NT>;
