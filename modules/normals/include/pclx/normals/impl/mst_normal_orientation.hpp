#pragma once
#include <pclx/normals/mst_normal_orientation.h>

#include <pcl/common/point_tests.h>
#include <pcl/search/kdtree.h>

#include <boost/pending/disjoint_sets.hpp>

#include <algorithm>
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

  SearchPtr search = search_;
  if (!search)
    search.reset (new search::KdTree<PointT> (false));
  search->setInputCloud (input_, vertices);

  // Riemannian graph: each vertex to its k nearest valid neighbours, cost 1 − |ni·nj|.
  using Edge = std::pair<std::uint32_t, std::uint32_t>;
  const int threads = threads_ > 0 ? static_cast<int> (threads_) : omp_get_max_threads ();
  std::vector<std::vector<Edge>> thread_edges (threads);
  std::vector<std::vector<float>> thread_costs (threads), thread_dist (threads);
#pragma omp parallel num_threads(threads)
  {
    const int t = omp_get_thread_num ();
    pcl::Indices nn;
    std::vector<float> dist;
#pragma omp for schedule(dynamic, 1024)
    for (std::ptrdiff_t v = 0; v < static_cast<std::ptrdiff_t> (nv); ++v)
    {
      const auto i = (*vertices)[v];
      search->nearestKSearch ((*input_)[i], k_ + 1, nn, dist);
      const auto ni = normals[i].getNormalVector3fMap ().normalized ();
      for (std::size_t q = 0; q < nn.size (); ++q)
      {
        const auto j = nn[q];
        const std::uint32_t w = vertex_of[j];
        if (w == UINT32_MAX || w == static_cast<std::uint32_t> (v))
          continue;
        const auto nj = normals[j].getNormalVector3fMap ().normalized ();
        thread_edges[t].emplace_back (static_cast<std::uint32_t> (v), w);
        thread_costs[t].push_back (1.f - std::abs (ni.dot (nj)));
        thread_dist[t].push_back (std::sqrt (dist[q]));
      }
    }
  }
  std::vector<Edge> edges;
  std::vector<float> costs, lengths;
  for (int t = 0; t < threads; ++t)
  {
    edges.insert (edges.end (), thread_edges[t].begin (), thread_edges[t].end ());
    costs.insert (costs.end (), thread_costs[t].begin (), thread_costs[t].end ());
    lengths.insert (lengths.end (), thread_dist[t].begin (), thread_dist[t].end ());
    std::vector<Edge> ().swap (thread_edges[t]);
    std::vector<float> ().swap (thread_costs[t]);
    std::vector<float> ().swap (thread_dist[t]);
  }
  // Ties (exactly parallel normals, e.g. both sides of a thin plate fitted by one plane)
  // go to the shorter edge, so propagation stays on a sheet instead of jumping across.
  if (tie_break_ > 0 && !lengths.empty ())
  {
    const double mean = std::accumulate (lengths.begin (), lengths.end (), 0.0) / lengths.size ();
    if (mean > 0)
      for (std::size_t e = 0; e < costs.size (); ++e)
        costs[e] += static_cast<float> (tie_break_ * lengths[e] / mean);
  }
  std::vector<float> ().swap (lengths);
  edges_ = edges.size ();

  // Minimum spanning forest: Kruskal, i.e. edges by increasing cost into Boost's
  // disjoint sets (boost::kruskal_minimum_spanning_tree's priority queue was 3x slower).
  std::vector<std::uint32_t> by_cost (edges.size ());
  std::iota (by_cost.begin (), by_cost.end (), 0u);
  std::sort (by_cost.begin (), by_cost.end (), [&] (std::uint32_t a, std::uint32_t b) { return costs[a] < costs[b]; });
  std::vector<float> ().swap (costs);
  std::vector<Edge> tree;
  tree.reserve (nv);
  {
    boost::disjoint_sets_with_storage<> sets (nv);
    for (std::size_t v = 0; v < nv; ++v)
      sets.make_set (v);
    for (const std::uint32_t e : by_cost)
    {
      const auto a = sets.find_set (edges[e].first), b = sets.find_set (edges[e].second);
      if (a == b)
        continue;
      sets.link (a, b);
      tree.push_back (edges[e]);
      if (tree.size () + 1 == nv)
        break;
    }
  }
  std::vector<Edge> ().swap (edges);

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
