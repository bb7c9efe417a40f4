#pragma once
// omicron_viewer's input: the file the octree reads itself (PCD, PLY), or an XYZ text cloud
// read into memory with its bounds.
#include <pclx/apps/cloud_loader.h>
#include <pclx/apps/process_stats.h>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Core>

#include <chrono>
#include <cmath>
#include <limits>
#include <string>

namespace omicron_viewer {

/** \brief The input and its axis-aligned bounds (empty bounds, lo > hi, when unknown). */
template <typename PointT>
struct Input
{
  typename pcl::PointCloud<PointT>::Ptr cloud{new pcl::PointCloud<PointT>};  ///< the points read
  Eigen::Vector3f lo = Eigen::Vector3f::Constant (std::numeric_limits<float>::max ());  ///< minimum corner
  Eigen::Vector3f hi = -lo;  ///< maximum corner
  bool color = false;        ///< the file has rgb
  std::string file;          ///< the octree reads this file itself (PCD, PLY; cloud left empty)
  std::string summary;       ///< one line about the input
  double seconds = 0;        ///< the time the reading took
};

/** \brief Reads an XYZ text cloud into memory with the kit's loader (its column rules:
  * x y z [nx ny nz]); PCD and PLY files are read by the octree itself.
  * \param[in] path the file
  * \return the cloud, its bounds and summary
  * \throw pclx::apps::LoadError on an unreadable file or one without a finite point
  */
inline Input<pcl::PointXYZ>
readXyzInput (const std::string& path)
{
  Input<pcl::PointXYZ> in;
  const auto t0 = std::chrono::steady_clock::now ();
  pclx::apps::CloudInfo info;
  in.cloud = pclx::apps::loadCloud<pcl::PointXYZ> (path, &info);
  pclx::apps::requireFinitePoints (info);
  in.summary = info.summary ();
  for (const auto& p : *in.cloud)
    if (std::isfinite (p.x) && std::isfinite (p.y) && std::isfinite (p.z))
    {
      in.lo = in.lo.cwiseMin (p.getVector3fMap ());
      in.hi = in.hi.cwiseMax (p.getVector3fMap ());
    }
  in.seconds = pclx::apps::secondsSince (t0);
  return in;
}

}  // namespace omicron_viewer
