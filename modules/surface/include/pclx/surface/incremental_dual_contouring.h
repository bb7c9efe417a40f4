#pragma once
// IncrementalDualContouring: posed depth frames (or meshes) become an adaptive mesh that is
// updated frame by frame (H. O. da Paz, "Reconstrução adaptativa de superfícies implícitas a
// partir de imagens de profundidade", MSc dissertation, IMPA, 2017, ch. 3).
//   §3.2–3.3  each frame → pcl::CoupledSimplification (connected cloud, coupled
//             simplification, frustum cells of 2 leaves) → a small world-space FrameMesh;
//   §3.4–3.5  the FrameMesh is fused into an extrinsic hashed octree of Hermite data averaged
//             over frames and grid vertex signs (pcl::DualContouringOctree, see there);
//   §3.6      reconstruct (): manifold dual contouring over minimal edges, optional
//             topology-safe simplification within ε (flat regions get few triangles) and
//             optional removal of the dominant plane (RANSAC) to isolate an object (§4.4).
//             Only roots touched since the last call are re-polygonised.
//
// Bad input (no valid pixel, NaN / Inf, zero intrinsics, singular or non-finite pose, frames
// of different sizes, empty meshes) gives false, PCL_ERROR and getLastError (); the map is left
// as it was.
#include <pcl/PolygonMesh.h>
#include <pcl/point_cloud.h>

#include <pclx/surface/coupled_simplification.h>
#include <pclx/surface/dual_contouring_octree.h>
#include <pclx/surface/frame_mesh.h>

#include <Eigen/Core>

#include <cstdint>
#include <string>

namespace pcl {

template <typename PointT>
class IncrementalDualContouring
{
public:
  using Ptr = shared_ptr<IncrementalDualContouring<PointT>>;
  using ConstPtr = shared_ptr<const IncrementalDualContouring<PointT>>;
  using SignRule = DualContouringOctree::SignRule;

  struct Stats
  {
    std::size_t frames = 0;
    std::size_t cells = 0;         // cells with a dual vertex at the last reconstruct
    std::size_t leaves = 0;        // leaves of the octree (map size)
    std::size_t roots = 0;
    std::size_t memory_bytes = 0;  // octree + cached polygons
    std::size_t triangles = 0, vertices = 0;
    std::size_t escaped_vertices = 0;   // QEF minimisers outside their cell (mass point used)
    std::size_t ambiguous_vertices = 0;  // grid vertices whose votes cancel (taken as exterior)
    std::size_t rim_cells = 0;           // cells whose surface reaches an unobserved vertex
    std::size_t frame_triangles = 0;    // triangles of the last frame after §3.3
    std::size_t repolygonised_roots = 0;
    std::size_t removed_plane_triangles = 0;
    // Last frame: front end (§3.2–3.3), octree update (§3.4–3.5), total.
    double last_frame_ms = 0, last_frontend_ms = 0, last_octree_ms = 0;
    // Last reconstruct (§3.6).
    double last_reconstruct_ms = 0;
  };

  // The front end's frustum cells follow the leaf size (kCellLeaves leaves at the frame's
  // median range), so that a finer leaf gets finer frames.
  IncrementalDualContouring () { simplification_.setFrustumCellSize (kCellLeaves * octree_.getLeafSize ()); }

  // "Detail": the leaf edge in metres (> 0, default 0.01 = 1 cm). Before the first frame. Frustum
  // cells still at their default follow it.
  bool
  setLeafSize (double h)
  {
    const bool cells_follow =
        simplification_.getFrustumCellSize () == kCellLeaves * octree_.getLeafSize ();
    if (!settled (octree_.setLeafSize (h)))
      return false;
    if (cells_follow)
      simplification_.setFrustumCellSize (kCellLeaves * h);
    return true;
  }
  // Default frustum cell side, in leaves.
  static constexpr double kCellLeaves = 2.0;
  double getLeafSize () const { return octree_.getLeafSize (); }
  // Volume of interest; unset: from the first frame (§3.4.1). Growth (default on) adds roots
  // for geometry outside it; off: such geometry is dropped and counted.
  bool setVolume (const Eigen::Vector3d& min, const Eigen::Vector3d& max) { return settled (octree_.setVolume (min, max)); }
  void setGrowVolume (bool on) { octree_.setGrowVolume (on); }
  // ε of the octree simplification in metres (0 = off, default): cells merge while the merge
  // keeps the topology and the merged vertex stays within ε of every crossing plane of the
  // merged cells. False for ε < 0 or NaN.
  bool setSimplificationError (double eps) { return settled (octree_.setSimplificationError (eps)); }
  double getSimplificationError () const { return octree_.getSimplificationError (); }
  void setSignRule (SignRule r) { octree_.setSignRule (r); }
  // Optional plane removal (§4.4): the largest RANSAC plane of the output vertices
  // (pcl::SACSegmentation, distance threshold in metres, default 1.5 leaves) is cut away.
  void setPlaneRemoval (bool on, double distance_threshold = 0) { remove_plane_ = on; plane_threshold_ = distance_threshold; }
  // Depth images: depths outside [min, max] metres are no data (forwarded to §3.2).
  void setDepthRange (float min_m, float max_m) { simplification_.setDepthRange (min_m, max_m); }

  // §3.2–3.3 settings.
  CoupledSimplification& getSimplification () { return simplification_; }

  // The pose of every addFrame is camera-to-world: it maps camera coordinates (x right, y down,
  // z forward) to the world, so its last column is the camera's position. Its inverse
  // (world-to-camera, as some SLAM tools export) is a rigid motion too and cannot be told
  // apart from one frame: the frame is fused in the wrong place.
  // An organized cloud in the camera frame (NaN = no data).
  bool addFrame (const pcl::PointCloud<PointT>& organized_camera_frame_cloud,
                 const Eigen::Matrix4d& camera_to_world);
  // Depth in metres (0 / NaN = no data).
  bool addFrame (const float* depth_m, int width, int height, const pclx::surface::DepthIntrinsics& K,
                 const Eigen::Matrix4d& camera_to_world);
  // 16-bit depth (PNG in mm: depth_scale 0.001; 0 = no data).
  bool addFrame (const std::uint16_t* depth, int width, int height, const pclx::surface::DepthIntrinsics& K,
                 const Eigen::Matrix4d& camera_to_world, float depth_scale = 0.001f);
  // A triangle mesh in its own frame, counter-clockwise seen from outside, placed by pose.
  bool addMesh (const pcl::PolygonMesh& mesh, const Eigen::Matrix4d& pose);
  // The common entry: a world-space mesh (§3.4–3.5).
  bool addFrameMesh (const pclx::surface::FrameMesh& world_mesh);

  // The current mesh (x, y, z vertices; triangles counter-clockwise seen from outside).
  void reconstruct (pcl::PolygonMesh& mesh);

  const Stats& getStats () const { return stats_; }
  // The reason of the last refused call; empty after a call that succeeded.
  const std::string& getLastError () const { return error_; }
  // The extrinsic representation, for diagnostics.
  const DualContouringOctree& getOctree () const { return octree_; }
  DualContouringOctree& getOctree () { return octree_; }
  // The last frame's mesh after §3.3 (world coordinates).
  const pclx::surface::FrameMesh& getLastFrameMesh () const { return frame_; }

private:
  bool fail (const std::string& msg);
  bool forward (const std::string& msg);
  // The octree's answer to a setter, with its error kept here.
  bool settled (bool ok) { return ok ? (error_.clear (), true) : forward (octree_.getLastError ()); }
  bool checkFrameSize (int width, int height);
  bool fuse (double frontend_ms);
  void removePlane (pcl::PolygonMesh& mesh);

  CoupledSimplification simplification_;
  DualContouringOctree octree_;
  pclx::surface::FrameMesh frame_;
  std::vector<float> depth_buffer_;
  std::vector<Eigen::Vector3f> point_buffer_;
  int width_ = 0, height_ = 0;  // size of the first frame
  bool remove_plane_ = false;
  double plane_threshold_ = 0;
  Stats stats_;
  std::string error_;
};

}  // namespace pcl

#ifdef PCL_NO_PRECOMPILE
#include <pclx/surface/impl/incremental_dual_contouring.hpp>
#endif
