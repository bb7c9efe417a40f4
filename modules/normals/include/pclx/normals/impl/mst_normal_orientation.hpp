#pragma once
#include <pclx/normals/mst_normal_orientation.h>

#include <pcl/common/point_tests.h>
#include <pcl/search/kdtree.h>

#include <boost/pending/disjoint_sets.hpp>

#include <algorithm>
#include <cstring>
#include <parallel/algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <omp.h>

namespace pcl {

template <typename PointT, typename NormalT> bool
MSTNormalOrientation<PointT, NormalT>::orient (PointCloud<NormalT>& normals)
{
  components_ = flipped_ = edges_ = 0;
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

  // Graph vertices: the points with a finite position and a finite non-zero normal.
  auto valid = [&] (std::size_t i) {
    const auto n = normals[i].getNormalVector3fMap ();
    return isFinite ((*input_)[i]) && n.allFinite () && n.squaredNorm () > 0;
  };
  pcl::IndicesPtr vertices (new pcl::Indices);
  std::vector<std::uint32_t> vertex_of (input_->size (), UINT32_MAX);
  for (std::size_t i = 0; i < input_->size (); ++i)
    if (valid (i))
    {
      vertex_of[i] = static_cast<std::uint32_t> (vertices->size ());
      vertices->push_back (static_cast<pcl::index_t> (i));
    }
  const std::size_t nv = vertices->size ();
  if (nv == 0)
    return true;

  if (nv * static_cast<std::size_t> (k_) >= UINT32_MAX)
  {
    PCL_ERROR ("[pcl::MSTNormalOrientation::orient] %zu points x k = %d exceed the 32-bit edge ids\n", nv, k_);
    return false;
  }
  SearchPtr search = search_;
  if (!search)
    search.reset (new search::KdTree<PointT> (false));
  search->setInputCloud (input_, vertices);

  // Riemannian graph: each vertex to its k nearest valid neighbours, cost 1 − |ni·nj|.
  using Edge = std::pair<std::uint32_t, std::uint32_t>;
  const int threads = threads_ > 0 ? static_cast<int> (threads_) : omp_get_max_threads ();
  const std::size_t k = static_cast<std::size_t> (k_);
  std::vector<std::uint32_t> nbr (nv * k, UINT32_MAX);  // row v: v's neighbours (vertex ids)
  std::vector<float> len (nv * k, 0.f);
  double len_sum = 0;
  std::size_t len_count = 0;
#pragma omp parallel num_threads(threads) reduction(+ : len_sum, len_count)
  {
    pcl::Indices nn;
    std::vector<float> dist;
#pragma omp for schedule(dynamic, 1024)
    for (std::ptrdiff_t v = 0; v < static_cast<std::ptrdiff_t> (nv); ++v)
    {
      search->nearestKSearch ((*input_)[(*vertices)[v]], k_ + 1, nn, dist);
      std::size_t slot = v * k;
      for (std::size_t q = 0; q < nn.size () && slot < (v + 1) * k; ++q)
      {
        const std::uint32_t w = vertex_of[nn[q]];
        if (w == UINT32_MAX || w == static_cast<std::uint32_t> (v))
          continue;
        nbr[slot] = w;
        len[slot] = std::sqrt (dist[q]);
        len_sum += len[slot];
        ++len_count;
        ++slot;
      }
    }
  }
  const double mean_len = len_count ? len_sum / len_count : 0.0;

  // One key per undirected edge (a mutual pair is kept once): the cost's float bits
  // (costs are >= 0, so they order like the floats) above the slot of the edge.
  // Ties (exactly parallel normals, e.g. both sides of a thin plate fitted by one plane)
  // go to the shorter edge, so propagation stays on a sheet instead of jumping across.
  std::vector<std::vector<std::uint64_t>> thread_keys (threads);
#pragma omp parallel num_threads(threads)
  {
    auto& keys = thread_keys[omp_get_thread_num ()];
#pragma omp for schedule(dynamic, 1024)
    for (std::ptrdiff_t v = 0; v < static_cast<std::ptrdiff_t> (nv); ++v)
    {
      const auto ni = normals[(*vertices)[v]].getNormalVector3fMap ().normalized ();
      for (std::size_t slot = v * k; slot < (v + 1) * k && nbr[slot] != UINT32_MAX; ++slot)
      {
        const std::uint32_t w = nbr[slot];
        if (w < static_cast<std::uint32_t> (v))
        {
          const auto row = nbr.begin () + w * k;
          if (std::find (row, row + k, static_cast<std::uint32_t> (v)) != row + k)
            continue;  // already listed from w's side
        }
        const auto nj = normals[(*vertices)[w]].getNormalVector3fMap ().normalized ();
        float cost = std::max (0.f, 1.f - std::abs (ni.dot (nj)));
        if (across_penalty_ > 0)
        {
          // An edge along the normals (e.g. through a thin plate, from one sheet to the
          // other) says nothing about the relative sign of two parallel normals: make it
          // expensive, so the tree goes around along the surface instead.
          const Eigen::Vector3f e = ((*input_)[(*vertices)[w]].getVector3fMap () -
                                     (*input_)[(*vertices)[v]].getVector3fMap ()).normalized ();
          cost += static_cast<float> (across_penalty_) * std::max (std::abs (ni.dot (e)), std::abs (nj.dot (e)));
        }
        if (tie_break_ > 0 && mean_len > 0)
          cost += static_cast<float> (tie_break_ * len[slot] / mean_len);
        std::uint32_t bits;
        std::memcpy (&bits, &cost, sizeof bits);
        keys.push_back ((static_cast<std::uint64_t> (bits) << 32) | static_cast<std::uint32_t> (slot));
      }
    }
  }
  std::vector<float> ().swap (len);
  std::vector<std::uint64_t> keys;
  for (auto& t : thread_keys)
  {
    keys.insert (keys.end (), t.begin (), t.end ());
    std::vector<std::uint64_t> ().swap (t);
  }
  edges_ = keys.size ();
  __gnu_parallel::sort (keys.begin (), keys.end ());

  // Minimum spanning forest: Kruskal, i.e. edges by increasing cost into Boost's
  // disjoint sets (boost::kruskal_minimum_spanning_tree's priority queue was 3x slower).
  std::vector<Edge> tree;
  tree.reserve (nv);
  {
    boost::disjoint_sets_with_storage<> sets (nv);
    for (std::size_t v = 0; v < nv; ++v)
      sets.make_set (v);
    for (const std::uint64_t key : keys)
    {
      const std::uint32_t slot = static_cast<std::uint32_t> (key & 0xffffffffu);
      const std::uint32_t v = static_cast<std::uint32_t> (slot / k), w = nbr[slot];
      const auto a = sets.find_set (v), b = sets.find_set (w);
      if (a == b)
        continue;
      sets.link (a, b);
      tree.emplace_back (v, w);
      if (tree.size () + 1 == nv)
        break;
    }
  }
  std::vector<std::uint64_t> ().swap (keys);
  std::vector<std::uint32_t> ().swap (nbr);

  // Forest adjacency (CSR arrays).
  std::vector<std::uint32_t> offset (nv + 1, 0), adj (2 * tree.size ());
  for (const auto& e : tree)
  {
    ++offset[e.first + 1];
    ++offset[e.second + 1];
  }
  std::partial_sum (offset.begin (), offset.end (), offset.begin ());
  {
    std::vector<std::uint32_t> fill (offset.begin (), offset.end () - 1);
    for (const auto& e : tree)
    {
      const auto a = e.first, b = e.second;
      adj[fill[a]++] = b;
      adj[fill[b]++] = a;
    }
  }

  // Roots by decreasing z: the first unvisited vertex is the highest of its component.
  std::vector<std::uint32_t> by_z (nv);
  std::iota (by_z.begin (), by_z.end (), 0);
  std::sort (by_z.begin (), by_z.end (), [&] (std::uint32_t a, std::uint32_t b) {
    return (*input_)[(*vertices)[a]].z > (*input_)[(*vertices)[b]].z;
  });
  std::vector<char> seen (nv, 0);
  std::vector<std::uint32_t> stack;
  auto normal = [&] (std::uint32_t v) { return normals[(*vertices)[v]].getNormalVector3fMap (); };
  for (const std::uint32_t root : by_z)
  {
    if (seen[root])
      continue;
    ++components_;
    seen[root] = 1;
    if (normal (root).z () < 0)
    {
      normal (root) = -normal (root);
      ++flipped_;
    }
    stack.push_back (root);
    while (!stack.empty ())  // depth-first, as in the seed
    {
      const std::uint32_t u = stack.back ();
      stack.pop_back ();
      for (std::uint32_t e = offset[u]; e < offset[u + 1]; ++e)
      {
        const std::uint32_t w = adj[e];
        if (seen[w])
          continue;
        seen[w] = 1;
        if (normal (w).dot (normal (u)) < 0)
        {
          normal (w) = -normal (w);
          ++flipped_;
        }
        stack.push_back (w);
      }
    }
  }
  return true;
}

}  // namespace pcl

#define PCL_INSTANTIATE_MSTNormalOrientation(T, NT) template class PCL_EXPORTS pcl::MSTNormalOrientation<T, NT>;
