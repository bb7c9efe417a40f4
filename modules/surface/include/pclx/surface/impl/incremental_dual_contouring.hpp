#pragma once
#include <pclx/surface/incremental_dual_contouring.h>

#include <pcl/ModelCoefficients.h>
#include <pcl/PointIndices.h>
#include <pcl/conversions.h>
#include <pcl/console/print.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/method_types.h>
#include <pcl/sample_consensus/model_types.h>
#include <pcl/segmentation/sac_segmentation.h>

#include <chrono>
#include <cmath>

namespace pcl {

template <typename PointT> bool
IncrementalDualContouring<PointT>::fail (const std::string& msg)
{
  error_ = msg;
  PCL_ERROR ("[pcl::IncrementalDualContouring] %s\n", msg.c_str ());
  return false;
}

template <typename PointT> bool
IncrementalDualContouring<PointT>::forward (const std::string& msg)
{
  error_ = msg;  // the stage that refused has logged it already
  return false;
}

template <typename PointT> bool
IncrementalDualContouring<PointT>::checkFrameSize (int width, int height)
{
  if (width <= 0 || height <= 0)
    return fail ("frame size must be positive");
  // Frames of one sequence share a sensor; a different size means mixed inputs.
  if (width_ != 0 && (width != width_ || height != height_))
    return fail ("frame size " + std::to_string (width) + "x" + std::to_string (height) +
                 " differs from the first frame's " + std::to_string (width_) + "x" +
                 std::to_string (height_));
  return true;
}

template <typename PointT> void
IncrementalDualContouring<PointT>::checkPoseConvention (const Eigen::Matrix4d& camera_to_world)
{
  // Consecutive frames' surfaces agree within a few leaves (the frustum cells are two).
  if (!pose_check_.add (frame_.vertices, camera_to_world, kPoseOverlapLeaves * getLeafSize ()))
    return;
  if (stats_.suspect_pose_frames++ == 0)
  {
    double given, inverse;
    pose_check_.lastOverlaps (given, inverse);
    PCL_WARN ("[pcl::IncrementalDualContouring] frame %zu lines up with the previous one under the inverse "
              "poses (%.0f %% overlap) better than under the poses given (%.0f %%): addFrame takes "
              "camera-to-world poses; were world-to-camera poses given?\n",
              getStats ().frames, 100 * inverse, 100 * given);
  }
}

template <typename PointT> bool
IncrementalDualContouring<PointT>::fuse (double frontend_ms)
{
  stats_.frame_triangles = frame_.triangles.size ();
  // The octree's counts are read by getStats (): reading them here would wait for the merge.
  if (!octree_.addFrameMesh (frame_))
    return forward (octree_.getLastError ());
  stats_.last_frontend_ms = frontend_ms;
  stats_.total_frontend_ms += frontend_ms;
  error_.clear ();
  return true;
}

template <typename PointT> const typename IncrementalDualContouring<PointT>::Stats&
IncrementalDualContouring<PointT>::getStats () const
{
  const auto& os = octree_.getStats ();  // waits for the last frame's merge
  stats_.frames = os.frames;
  stats_.leaves = os.leaves;
  stats_.roots = os.roots;
  stats_.memory_bytes = os.memory_bytes;
  stats_.last_octree_ms = os.last_frame_ms;
  stats_.last_frame_ms = stats_.last_frontend_ms + os.last_frame_ms;
  return stats_;
}

template <typename PointT> bool
IncrementalDualContouring<PointT>::addFrame (const pcl::PointCloud<PointT>& cloud,
                                             const Eigen::Matrix4d& camera_to_world)
{
  if (!cloud.isOrganized () || cloud.empty ())
    return fail ("addFrame needs an organized, non-empty cloud");
  if (!checkFrameSize (static_cast<int> (cloud.width), static_cast<int> (cloud.height)))
    return false;
  const auto t0 = std::chrono::steady_clock::now ();
  point_buffer_.resize (cloud.size ());
  for (std::size_t i = 0; i < cloud.size (); ++i)
    point_buffer_[i] = cloud[i].getVector3fMap ();
  if (!simplification_.compute (point_buffer_.data (), static_cast<int> (cloud.width),
                                static_cast<int> (cloud.height), camera_to_world, frame_))
    return forward (simplification_.getLastError ());
  const double ms = std::chrono::duration<double, std::milli> (std::chrono::steady_clock::now () - t0).count ();
  if (!fuse (ms))
    return false;
  checkPoseConvention (camera_to_world);
  width_ = static_cast<int> (cloud.width);
  height_ = static_cast<int> (cloud.height);
  return true;
}

template <typename PointT> bool
IncrementalDualContouring<PointT>::addFrame (const float* depth_m, int width, int height,
                                             const pcl::DepthIntrinsics& K,
                                             const Eigen::Matrix4d& camera_to_world)
{
  if (!depth_m)
    return fail ("null depth image");
  if (!checkFrameSize (width, height))
    return false;
  const auto t0 = std::chrono::steady_clock::now ();
  if (!simplification_.compute (depth_m, width, height, K, camera_to_world, frame_))
    return forward (simplification_.getLastError ());
  const double ms = std::chrono::duration<double, std::milli> (std::chrono::steady_clock::now () - t0).count ();
  if (!fuse (ms))
    return false;
  checkPoseConvention (camera_to_world);
  width_ = width;
  height_ = height;
  return true;
}

template <typename PointT> bool
IncrementalDualContouring<PointT>::addFrame (const std::uint16_t* depth, int width, int height,
                                             const pcl::DepthIntrinsics& K,
                                             const Eigen::Matrix4d& camera_to_world, float depth_scale)
{
  if (!depth)
    return fail ("null depth image");
  if (!(depth_scale > 0) || !std::isfinite (depth_scale))
    return fail ("depth scale must be positive and finite");
  if (!checkFrameSize (width, height))
    return false;
  depth_buffer_.resize (static_cast<std::size_t> (width) * height);
  for (std::size_t i = 0; i < depth_buffer_.size (); ++i)
    depth_buffer_[i] = depth[i] * depth_scale;  // 0 stays "no data"
  return addFrame (depth_buffer_.data (), width, height, K, camera_to_world);
}

template <typename PointT> bool
IncrementalDualContouring<PointT>::addMesh (const pcl::PolygonMesh& mesh, const Eigen::Matrix4d& pose)
{
  const std::string pose_error = CoupledSimplification::checkPose (pose);
  if (!pose_error.empty ())
    return fail (pose_error);
  pcl::PointCloud<pcl::PointXYZ> xyz;
  pcl::fromPCLPointCloud2 (mesh.cloud, xyz);
  frame_ = pcl::FrameMesh ();
  frame_.vertices.reserve (xyz.size ());
  const Eigen::Matrix3f R = pose.topLeftCorner<3, 3> ().cast<float> ();
  const Eigen::Vector3f t = pose.topRightCorner<3, 1> ().cast<float> ();
  for (const auto& p : xyz)
    frame_.vertices.push_back (R * p.getVector3fMap () + t);
  std::size_t non_triangles = 0;
  for (const auto& poly : mesh.polygons)
  {
    if (poly.vertices.size () != 3)
    {
      ++non_triangles;
      continue;
    }
    frame_.triangles.emplace_back (static_cast<int> (poly.vertices[0]), static_cast<int> (poly.vertices[1]),
                                   static_cast<int> (poly.vertices[2]));
  }
  if (non_triangles)
    PCL_WARN ("[pcl::IncrementalDualContouring] addMesh: %zu non-triangle polygons skipped\n", non_triangles);
  return fuse (0);
}

template <typename PointT> bool
IncrementalDualContouring<PointT>::addFrameMesh (const pcl::FrameMesh& world_mesh)
{
  frame_ = world_mesh;
  return fuse (0);
}

template <typename PointT> void
IncrementalDualContouring<PointT>::removePlane (pcl::PolygonMesh& mesh)
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr xyz (new pcl::PointCloud<pcl::PointXYZ>);
  pcl::fromPCLPointCloud2 (mesh.cloud, *xyz);
  if (xyz->size () < 3)
    return;
  pcl::SACSegmentation<pcl::PointXYZ> seg;
  seg.setModelType (pcl::SACMODEL_PLANE);
  seg.setMethodType (pcl::SAC_RANSAC);
  seg.setDistanceThreshold (plane_threshold_ > 0 ? plane_threshold_ : 1.5 * getLeafSize ());
  seg.setMaxIterations (200);
  seg.setInputCloud (xyz);
  pcl::PointIndices inliers;
  pcl::ModelCoefficients coeff;
  seg.segment (inliers, coeff);
  if (inliers.indices.empty ())
    return;
  std::vector<char> on_plane (xyz->size (), 0);
  for (int i : inliers.indices)
    on_plane[i] = 1;
  // A triangle goes when all its corners are on the plane; then unreferenced vertices go.
  std::vector<pcl::Vertices> kept;
  kept.reserve (mesh.polygons.size ());
  for (const auto& p : mesh.polygons)
    if (!(on_plane[p.vertices[0]] && on_plane[p.vertices[1]] && on_plane[p.vertices[2]]))
      kept.push_back (p);
  stats_.removed_plane_triangles = mesh.polygons.size () - kept.size ();
  std::vector<int> remap (xyz->size (), -1);
  pcl::PointCloud<pcl::PointXYZ> out;
  for (auto& p : kept)
    for (auto& v : p.vertices)
    {
      if (remap[v] < 0)
      {
        remap[v] = static_cast<int> (out.size ());
        out.push_back ((*xyz)[v]);
      }
      v = remap[v];
    }
  pcl::toPCLPointCloud2 (out, mesh.cloud);
  mesh.polygons.swap (kept);
}

template <typename PointT> void
IncrementalDualContouring<PointT>::reconstruct (pcl::PolygonMesh& mesh)
{
  octree_.reconstruct (mesh);
  error_.clear ();  // reconstruct always succeeds: an earlier refusal is no longer the last call
  const auto& os = octree_.getStats ();
  stats_.removed_plane_triangles = 0;
  if (remove_plane_)
    removePlane (mesh);
  stats_.cells = os.cells;
  stats_.leaves = os.leaves;
  stats_.roots = os.roots;
  stats_.memory_bytes = os.memory_bytes;
  stats_.triangles = mesh.polygons.size ();
  stats_.vertices = mesh.cloud.width * mesh.cloud.height;
  stats_.escaped_vertices = os.escaped_vertices;
  stats_.ambiguous_vertices = os.ambiguous_vertices;
  stats_.rim_cells = os.rim_cells;
  stats_.repolygonised_roots = os.repolygonised_roots;
  stats_.last_reconstruct_ms = os.last_reconstruct_ms;
}

}  // namespace pcl
