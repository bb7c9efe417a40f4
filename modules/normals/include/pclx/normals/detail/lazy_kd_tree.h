#pragma once
// A kd-tree (pcl::search::KdTree, FLANN) built on its first query instead of in
// setInputCloud (). PlanarOctreeNormalEstimation installs it when the user sets no search
// method: on clean input its own neighbour searches go to a grid over the few points
// that need them (pclx::normals::detail::GridKnn), and the full tree (a serial build),
// is only built if some other path (another input than the search surface, OCTREE /
// HYBRID) asks for a neighbour. Queries are thread-safe; the first one builds.
#include <pcl/search/kdtree.h>
#include <pcl/search/search.h>

#include <atomic>
#include <mutex>

namespace pclx {
namespace normals {
namespace detail {

template <typename PointT>
class LazyKdTree : public pcl::search::Search<PointT>
{
public:
  using Ptr = pcl::shared_ptr<LazyKdTree<PointT>>;
  using PointCloudConstPtr = typename pcl::search::Search<PointT>::PointCloudConstPtr;
  using IndicesConstPtr = typename pcl::search::Search<PointT>::IndicesConstPtr;
  using pcl::search::Search<PointT>::nearestKSearch;
  using pcl::search::Search<PointT>::radiusSearch;

  LazyKdTree () : pcl::search::Search<PointT> ("LazyKdTree", false) {}

  void
  setInputCloud (const PointCloudConstPtr& cloud, const IndicesConstPtr& indices = IndicesConstPtr ()) override
  {
    std::lock_guard<std::mutex> lock (mutex_);
    pcl::search::Search<PointT>::setInputCloud (cloud, indices);
    tree_.reset ();
    built_ = false;
  }
  // Whether a query has built the tree since the last setInputCloud ().
  bool isBuilt () const { return built_.load (); }

  int
  nearestKSearch (const PointT& point, int k, pcl::Indices& k_indices, std::vector<float>& k_sqr_distances) const override
  {
    return tree ().nearestKSearch (point, k, k_indices, k_sqr_distances);
  }
  int
  radiusSearch (const PointT& point, double radius, pcl::Indices& k_indices, std::vector<float>& k_sqr_distances,
                unsigned int max_nn = 0) const override
  {
    return tree ().radiusSearch (point, radius, k_indices, k_sqr_distances, max_nn);
  }

private:
  const pcl::search::KdTree<PointT>&
  tree () const
  {
    if (!built_.load (std::memory_order_acquire))
    {
      std::lock_guard<std::mutex> lock (mutex_);
      if (!built_.load (std::memory_order_relaxed))
      {
        tree_.reset (new pcl::search::KdTree<PointT> (this->sorted_results_));
        tree_->setInputCloud (this->input_, this->indices_);
        built_.store (true, std::memory_order_release);
      }
    }
    return *tree_;
  }

  mutable std::mutex mutex_;
  mutable std::atomic<bool> built_ {false};
  mutable typename pcl::search::KdTree<PointT>::Ptr tree_;
};

}  // namespace detail
}  // namespace normals
}  // namespace pclx
