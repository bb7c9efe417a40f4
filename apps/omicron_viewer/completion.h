#pragma once
// How much of the input a growing pcl::ObliqueCutOctree holds, for the viewer's progress text.
#include <pclx/omicron/oblique_cut_octree.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <future>
#include <vector>

namespace omicron_viewer {

/** \brief Share of the input points whose leaves are in the hierarchy.
  *
  * The boundary m_C of the oblique cut (the last leaf concatenated; da Silva 2018, OMiCroN)
  * is located among a Morton-sorted sample of the input (at most 2^18 points, taken once the
  * root cube is known, off the render thread).
  */
template <typename PointT>
class Completion
{
public:
  /** \brief Tracks `octree`, whose input is `cloud` (both must outlive this).
    * \param[in] octree the octree being built
    * \param[in] cloud its input (empty: the octree streams a file, no share is known)
    */
  Completion (pcl::ObliqueCutOctree<PointT>& octree, const pcl::PointCloud<PointT>& cloud)
    : octree_ (octree), cloud_ (cloud)
  {}

  /** \brief The share so far.
    * \return percent of the input in the hierarchy (never decreasing), or < 0 while unknown
    */
  double
  percent ()
  {
    if (octree_.isFinished ())
      return 100;
    if (cloud_.empty ())
      return -1;
    // The cut exists once the first leaf reached the front (it is not replaced meanwhile).
    if (octree_.getFront ().secondsToFirstLeaf () < 0)
      return -1;
    if (!sample_.valid ())
      sample_ = std::async (std::launch::async, [this] { return sortedSample (); });
    // The first time, wait a little: a fresh front should not be labelled 0 %.
    if (sample_.wait_for (std::chrono::milliseconds (codes_.empty () ? 50 : 0)) != std::future_status::ready)
      return last_;
    if (codes_.empty ())
      codes_ = sample_.get ();
    const pcl::MortonCode b = octree_.getCut ()->getBoundary ();
    const int lmax = octree_.getMaxDepth ();
    if (!b.valid () || codes_.empty ())
      return last_;
    const std::uint64_t bound = (b.level () < lmax ? b.span (lmax) : b).bits ();
    const auto k = std::upper_bound (codes_.begin (), codes_.end (), bound) - codes_.begin ();
    last_ = std::max (last_, 100.0 * double (k) / double (codes_.size ()));
    return last_;
  }

private:
  std::vector<std::uint64_t>
  sortedSample () const
  {
    const Eigen::Vector3d origin = octree_.getRootOrigin ();
    const double edge = octree_.getRootEdge ();
    const int lmax = octree_.getMaxDepth ();
    const std::size_t stride = std::max<std::size_t> (1, cloud_.size () >> 18);
    std::vector<std::uint64_t> codes;
    codes.reserve (cloud_.size () / stride + 1);
    for (std::size_t i = 0; i < cloud_.size (); i += stride)
    {
      const auto& p = cloud_[i];
      if (std::isfinite (p.x) && std::isfinite (p.y) && std::isfinite (p.z))
        codes.push_back (pcl::MortonCode::fromPoint (p.getVector3fMap (), origin, edge, lmax).bits ());
    }
    std::sort (codes.begin (), codes.end ());
    return codes;
  }

  pcl::ObliqueCutOctree<PointT>& octree_;
  const pcl::PointCloud<PointT>& cloud_;
  std::future<std::vector<std::uint64_t>> sample_;
  std::vector<std::uint64_t> codes_;
  double last_ = -1;  // < 0: not known yet
};

}  // namespace omicron_viewer
