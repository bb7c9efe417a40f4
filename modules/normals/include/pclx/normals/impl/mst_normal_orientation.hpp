#pragma once
#include <pclx/normals/mst_normal_orientation.h>

#include <pcl/common/point_tests.h>
#include <pcl/search/kdtree.h>

#include <boost/graph/compressed_sparse_row_graph.hpp>
#include <boost/graph/kruskal_min_spanning_tree.hpp>

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
  std::vector<std::vector<float>> thread_costs (threads);
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
      for (const auto j : nn)
      {
        const std::uint32_t w = vertex_of[j];
        if (w == UINT32_MAX || w == static_cast<std::uint32_t> (v))
          continue;
        const auto nj = normals[j].getNormalVector3fMap ().normalized ();
        thread_edges[t].emplace_back (static_cast<std::uint32_t> (v), w);
        thread_costs[t].push_back (1.f - std::abs (ni.dot (nj)));
      }
    }
  }
  std::vector<Edge> edges;
  std::vector<float> costs;
  for (int t = 0; t < threads; ++t)
  {
    edges.insert (edges.end (), thread_edges[t].begin (), thread_edges[t].end ());
    costs.insert (costs.end (), thread_costs[t].begin (), thread_costs[t].end ());
    std::vector<Edge> ().swap (thread_edges[t]);
    std::vector<float> ().swap (thread_costs[t]);
  }
  edges_ = edges.size ();

  // Minimum spanning forest with Boost Graph's Kruskal over a CSR edge list.
  struct Cost { float w; };
  using Graph = boost::compressed_sparse_row_graph<boost::directedS, boost::no_property, Cost,
                                                   boost::no_property, std::uint32_t, std::uint32_t>;
  std::vector<Cost> cost_props (costs.size ());
  for (std::size_t e = 0; e < costs.size (); ++e)
    cost_props[e].w = costs[e];
  std::vector<float> ().swap (costs);
  const Graph g (boost::edges_are_unsorted_multi_pass, edges.begin (), edges.end (), cost_props.begin (), nv);
  std::vector<Edge> ().swap (edges);
  std::vector<Cost> ().swap (cost_props);
  std::vector<typename boost::graph_traits<Graph>::edge_descriptor> tree;
  tree.reserve (nv);
  {
    // 32-bit vertices halve the graph's memory; Kruskal then needs explicit maps.
    std::vector<std::uint32_t> rank (nv), pred (nv);
    const auto index = boost::get (boost::vertex_index, g);
    boost::kruskal_minimum_spanning_tree (
        g, std::back_inserter (tree),
        boost::weight_map (boost::get (&Cost::w, g))
            .vertex_index_map (index)
            .rank_map (boost::make_iterator_property_map (rank.begin (), index))
            .predecessor_map (boost::make_iterator_property_map (pred.begin (), index)));
  }

  // Forest adjacency (CSR arrays).
  std::vector<std::uint32_t> offset (nv + 1, 0), adj (2 * tree.size ());
  for (const auto& e : tree)
  {
    ++offset[boost::source (e, g) + 1];
    ++offset[boost::target (e, g) + 1];
  }
  std::partial_sum (offset.begin (), offset.end (), offset.begin ());
  {
    std::vector<std::uint32_t> fill (offset.begin (), offset.end () - 1);
    for (const auto& e : tree)
    {
      const auto a = boost::source (e, g), b = boost::target (e, g);
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
