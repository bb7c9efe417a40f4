#pragma once
// omicron_viewer's input: the cloud read into memory with its bounds, or (memory budget, or no
// frames) the file the octree reads itself.
#include <pclx/apps/cloud_loader.h>
#include <pclx/apps/file_check.h>
#include <pclx/apps/process_stats.h>
#include <pclx/apps/progress.h>
#include <pclx/omicron/point_stream_reader.h>

#include <pcl/point_cloud.h>

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
  std::string file;          ///< the octree reads this file itself (budget or no frames; cloud left empty)
  std::string summary;       ///< one line about the input
  double seconds = 0;        ///< the time the reading took
};

/** \brief Reads a cloud file into memory.
  *
  * PCD and PLY: pcl::PointStreamReader in chunks straight into the cloud (no PCLPointCloud2
  * copy: half the peak memory of the kit's loader on big binary files). XYZ: the kit's loader
  * (its column rules: x y z [nx ny nz]).
  * \param[in] path the file
  * \param[in] check the kit's header check of the file
  * \return the cloud, its bounds and summary
  * \throw pclx::apps::LoadError on an unreadable file or one without a finite point
  */
template <typename PointT>
Input<PointT>
readInput (const std::string& path, const pclx::apps::FileCheck& check)
{
  Input<PointT> in;
  const auto t0 = std::chrono::steady_clock::now ();
  if (check.format == pclx::apps::CloudFormat::XYZ)
  {
    pclx::apps::CloudInfo info;
    in.cloud = pclx::apps::loadCloud<PointT> (path, &info);
    pclx::apps::requireFinitePoints (info);
    in.summary = info.summary ();
  }
  else
  {
    pcl::PointStreamReader reader (path);
    if (!reader.isOpen ())
      throw pclx::apps::LoadError (reader.getLastError ());
    in.color = reader.hasColor ();
    pclx::apps::Progress progress ("reading " + path, reader.getDeclaredPoints ());
    in.cloud->reserve (reader.getDeclaredPoints ());
    pcl::PointCloud<PointT> chunk;
    while (reader.read (1 << 20, chunk))
    {
      in.cloud->insert (in.cloud->end (), chunk.begin (), chunk.end ());
      progress.update (reader.getPointsRead () + reader.getDroppedInvalid ());
    }
    progress.done ();
    if (!reader.getLastError ().empty ())
      throw pclx::apps::LoadError (reader.getLastError ());
    if (in.cloud->empty ())
      throw pclx::apps::LoadError (path + ": no finite point (" + std::to_string (reader.getDroppedInvalid ()) +
                                   " NaN/Inf)");
    in.summary = path + ": " + std::to_string (in.cloud->size ()) + " points (xyz" + (in.color ? " rgb" : "") + ")";
    if (reader.getDroppedInvalid ())
      in.summary += ", " + std::to_string (reader.getDroppedInvalid ()) + " NaN/Inf dropped";
  }
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
