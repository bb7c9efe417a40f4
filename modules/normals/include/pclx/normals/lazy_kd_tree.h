#pragma once
// A kd-tree (pcl::search::KdTree, FLANN) built on its first query instead of in
// setInputCloud (). PlanarOctreeNormalEstimation installs it when the user sets no search
// method: on clean input its own neighbour searches go to a grid over the few points
// that need them (pclx::normals::GridKnn), and the full tree, 0.4 s serial at 1M points,
// is only built if some other path (another input than the search surface, OCTREE /
// HYBRID) asks for a neighbour. Queries are thread-safe; the first one builds.
#include <pcl/search/kdtree.h>
#include <pcl/search/search.h>

#include <atomic>
#include <mutex>

namespace pcl {
namespace search {

template <typename PointT>
class LazyKdTree : public Search<PointT>
{
public:
  using Ptr = shared_ptr<LazyKdTree<PointT>>;
  using PointCloudConstPtr = typename Search<PointT>::PointCloudConstPtr;
  using IndicesConstPtr = typename Search<PointT>::IndicesConstPtr;
  using Search<PointT>::nearestKSearch;
  using Search<PointT>::radiusSearch;

  LazyKdTree () : Search<PointT> ("LazyKdTree", false) {}

  void
  setInputCloud (const PointCloudConstPtr& cloud, const IndicesConstPtr& indices = IndicesConstPtr ()) override
  {
    std::lock_guard<std::mutex> lock (mutex_);
    Search<PointT>::setInputCloud (cloud, indices);
    tree_.reset ();
    built_ = false;
  }
  // Whether a query has built the tree since the last setInputCloud ().
  bool isBuilt () const { return built_.load (); }

  int
  nearestKSearch (const PointT& point, int k, Indices& k_indices, std::vector<float>& k_sqr_distances) const override
  {
    return tree ().nearestKSearch (point, k, k_indices, k_sqr_distances);
  }
  int
  radiusSearch (const PointT& point, double radius, Indices& k_indices, std::vector<float>& k_sqr_distances,
                unsigned int max_nn = 0) const override
  {
    return tree ().radiusSearch (point, radius, k_indices, k_sqr_distances, max_nn);
  }

private:
  const KdTree<PointT>&
  tree () const
  {
    if (!built_.load (std::memory_order_acquire))
    {
      std::lock_guard<std::mutex> lock (mutex_);
      if (!built_.load (std::memory_order_relaxed))
      {
        tree_.reset (new KdTree<PointT> (this->sorted_results_));
        tree_->setInputCloud (this->input_, this->indices_);
        built_.store (true, std::memory_order_release);
      }
    }
    return *tree_;
  }

  mutable std::mutex mutex_;
  mutable std::atomic<bool> built_ {false};
  mutable typename KdTree<PointT>::Ptr tree_;
};

}  // namespace search
}  // namespace pcl
