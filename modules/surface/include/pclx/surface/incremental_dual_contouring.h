#pragma once
#include <pcl/PolygonMesh.h>
#include <pcl/point_cloud.h>

#include <pclx/surface/coupled_simplification.h>
#include <pclx/surface/detail/pose_convention_check.h>
#include <pclx/surface/dual_contouring_octree.h>
#include <pclx/surface/frame_mesh.h>

#include <Eigen/Core>

#include <cstdint>
#include <string>

namespace pcl {

/** \brief Incremental dual contouring: posed depth frames (or meshes) become an adaptive
  * triangle mesh that is updated frame by frame (da Paz 2017, ch. 3).
  *
  * - §3.2–3.3: each frame goes through pcl::CoupledSimplification (connected cloud, coupled
  *   simplification in frustum cells of two leaves) and becomes a small world-space
  *   pcl::FrameMesh;
  * - §3.4–3.5: the FrameMesh is fused into an extrinsic hashed octree of Hermite data averaged
  *   over frames and grid vertex signs (pcl::DualContouringOctree, see there);
  * - §3.6: reconstruct () runs manifold dual contouring over minimal edges, an optional
  *   topology-safe simplification within ε (octree merges, then edge collapses; flat regions
  *   get few triangles) and an optional
  *   removal of the dominant plane (RANSAC) to isolate an object (§4.4). Only roots touched
  *   since the last call are re-polygonised.
  *
  * With two OpenMP threads or more, a frame's fusion into the octree runs on while the next
  * frame goes through the front end (DualContouringOctree::setOverlapMerges ()); every other
  * call waits for it first, so the map is the same as fusing each frame in its call.
  *
  * Bad input (no valid pixel, NaN / Inf, zero intrinsics, a singular or non-finite pose,
  * frames of different sizes, empty meshes) gives false, one PCL_ERROR and getLastError ();
  * the map is left as it was.
  *
  * \code
  * pcl::IncrementalDualContouring<pcl::PointXYZ> idc;
  * idc.setLeafSize (0.01);
  * for (const auto& frame : frames)
  *   idc.addFrame (frame.depth_mm.data (), width, height, K, frame.camera_to_world);
  * pcl::PolygonMesh mesh;
  * idc.reconstruct (mesh);
  * \endcode
  *
  * \note H. O. da Paz, 2017, "Reconstrução Adaptativa de Superfícies Implícitas a partir de
  * Imagens de Profundidade", MSc dissertation, IMPA; T. Ju, F. Losasso, S. Schaefer, J. Warren,
  * 2002, "Dual Contouring of Hermite Data", ACM SIGGRAPH.
  * \tparam PointT the point type of organized input clouds (x, y, z are read)
  * \ingroup surface
  */
template <typename PointT>
class IncrementalDualContouring
{
public:
  /** \brief Shared pointer. */
  using Ptr = shared_ptr<IncrementalDualContouring<PointT>>;
  /** \brief Shared pointer to const. */
  using ConstPtr = shared_ptr<const IncrementalDualContouring<PointT>>;
  /** \brief How conflicting sign votes are resolved (see DualContouringOctree::SignRule). */
  using SignRule = DualContouringOctree::SignRule;

  /** \brief Counts and wall times of the map, the last frame and the last reconstruct. */
  struct Stats
  {
    std::size_t frames = 0;        ///< frames fused
    std::size_t cells = 0;         ///< cells with a dual vertex at the last reconstruct
    std::size_t leaves = 0;        ///< leaves of the octree (map size)
    std::size_t roots = 0;         ///< roots of the octree
    std::size_t memory_bytes = 0;  ///< octree and cached polygons
    std::size_t triangles = 0;     ///< triangles of the last reconstruct
    std::size_t vertices = 0;      ///< vertices of the last reconstruct
    std::size_t escaped_vertices = 0;    ///< QEF minimisers outside their cell (mass point used)
    std::size_t ambiguous_vertices = 0;  ///< grid vertices whose votes cancel (taken as exterior)
    std::size_t rim_cells = 0;           ///< cells whose surface reaches an unobserved vertex
    std::size_t frame_triangles = 0;     ///< triangles of the last frame after §3.3
    std::size_t repolygonised_roots = 0; ///< roots redone by the last reconstruct
    std::size_t removed_plane_triangles = 0;  ///< triangles cut away with the dominant plane
    std::size_t suspect_pose_frames = 0;  ///< frames that, like the one before, line up with their predecessor only under the inverse poses
    double last_frame_ms = 0;       ///< last frame: front end and octree update (ms)
    double last_frontend_ms = 0;    ///< last frame: front end, §3.2–3.3 (ms)
    double last_octree_ms = 0;      ///< last frame: octree update, §3.4–3.5 (ms)
    double total_frontend_ms = 0;   ///< every frame: front end (ms)
    double last_reconstruct_ms = 0; ///< last reconstruct, §3.6 (ms)
  };

  /** \brief Empty map; the front end's frustum cells follow the leaf size (kCellLeaves leaves
    * at the frame's median range), so that a finer leaf gets finer frames. */
  IncrementalDualContouring () { simplification_.setFrustumCellSize (kCellLeaves * octree_.getLeafSize ()); }

  /** \brief Set the detail: the leaf edge. Only before the first frame; frustum cells still at
    * their default follow it.
    * \param[in] h the edge in metres (> 0, default 0.01)
    * \return false (with a PCL_ERROR and getLastError (), the old value kept) for a bad value or
    * after the first frame
    */
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
  /** \brief Default frustum cell side, in leaves. */
  static constexpr double kCellLeaves = 2.0;
  /** \brief Get the leaf edge.
    * \return the edge in metres
    */
  double getLeafSize () const { return octree_.getLeafSize (); }
  /** \brief Set the volume of interest; unset, it comes from the first frame (§3.4.1).
    * \param[in] min the lower corner (metres)
    * \param[in] max the upper corner (metres)
    * \return false (with a PCL_ERROR and getLastError (), the old volume kept) when the volume
    * is empty or not finite
    */
  bool setVolume (const Eigen::Vector3d& min, const Eigen::Vector3d& max) { return settled (octree_.setVolume (min, max)); }
  /** \brief Let the volume grow with the geometry.
    * \param[in] on true (default): geometry outside the volume adds roots; false: it is dropped
    * and counted
    */
  void setGrowVolume (bool on) { octree_.setGrowVolume (on); }
  /** \brief Set ε of the simplification: cells merge while the merge keeps the topology and the
    * merged vertex stays within ε of every crossing plane of the merged cells, then the mesh's
    * edges collapse under the same bound (see DualContouringOctree).
    * \param[in] eps ε in metres (≥ 0; 0 = off, default)
    * \note With ε > 0 every reconstruct () also collapses the whole mesh's edges, which takes
    * longer than the polygonisation itself on large maps (docs/surface.md).
    * \return false (with a PCL_ERROR and getLastError (), the old value kept) for ε < 0 or NaN
    */
  bool setSimplificationError (double eps) { return settled (octree_.setSimplificationError (eps)); }
  /** \brief Get ε of the simplification.
    * \return ε in metres
    */
  double getSimplificationError () const { return octree_.getSimplificationError (); }
  /** \brief Set the largest hole closed in the output (see DualContouringOctree::setMaxHoleSize).
    * \param[in] diameter the diagonal of the box around a hole's boundary, in metres (≥ 0; 0
    * leaves every hole open); until set, DualContouringOctree::kAutoHoleLeaves leaves
    * \note P. Liepa, 2003, "Filling Holes in Meshes", Eurographics Symposium on Geometry
    * Processing, as CGAL implements it.
    * \return false (with a PCL_ERROR and getLastError (), the old value kept) for a negative or
    * non-finite diameter
    */
  bool setMaxHoleSize (double diameter) { return settled (octree_.setMaxHoleSize (diameter)); }
  /** \brief Get the largest hole closed in the output.
    * \return the diameter in metres
    */
  double getMaxHoleSize () const { return octree_.getMaxHoleSize (); }
  /** \brief Set how conflicting sign votes are resolved.
    * \param[in] r the rule (default SignRule::WEIGHTED)
    */
  void setSignRule (SignRule r) { octree_.setSignRule (r); }
  /** \brief Cut the largest RANSAC plane of the output vertices away (§4.4), to isolate an
    * object standing on it.
    * \param[in] on true: remove the plane in reconstruct () (default off)
    * \param[in] distance_threshold the RANSAC distance threshold in metres; 0 (default): 1.5 leaves
    */
  void setPlaneRemoval (bool on, double distance_threshold = 0) { remove_plane_ = on; plane_threshold_ = distance_threshold; }
  /** \brief Set the valid depths of depth images (forwarded to the front end, §3.2).
    * \param[in] min_m the nearest valid depth in metres
    * \param[in] max_m the farthest valid depth in metres
    */
  void setDepthRange (float min_m, float max_m) { simplification_.setDepthRange (min_m, max_m); }

  /** \brief The front end (§3.2–3.3), for its settings.
    * \return the pcl::CoupledSimplification every frame goes through
    */
  CoupledSimplification& getSimplification () { return simplification_; }

  /** \brief Fuse an organized cloud in the camera frame.
    *
    * The pose of every addFrame is camera-to-world: it maps camera coordinates (x right, y
    * down, z forward) to the world, so its last column is the camera's position. Its inverse
    * (world-to-camera, as some SLAM tools export) is a rigid motion too and cannot be told apart
    * from one frame. Across frames it can: each frame is compared with the previous one under
    * the given poses and under their inverses. When two frames in a row line up only under the
    * inverses, the frame is still fused, counted in Stats::suspect_pose_frames, and the first
    * such frame prints a PCL_WARN.
    * \param[in] organized_camera_frame_cloud the frame (NaN: no data)
    * \param[in] camera_to_world the rigid camera pose
    * \return false (with a PCL_ERROR and getLastError ()) on bad input; the map is then unchanged
    */
  bool addFrame (const pcl::PointCloud<PointT>& organized_camera_frame_cloud,
                 const Eigen::Matrix4d& camera_to_world);
  /** \brief Fuse a depth image in metres.
    * \param[in] depth_m row-major width × height depths in metres (0 / NaN: no data)
    * \param[in] width the image's width in pixels
    * \param[in] height the image's height in pixels
    * \param[in] K the camera's pinhole intrinsics
    * \param[in] camera_to_world the rigid camera pose (see the first addFrame ())
    * \return false (with a PCL_ERROR and getLastError ()) on bad input; the map is then unchanged
    */
  bool addFrame (const float* depth_m, int width, int height, const pcl::DepthIntrinsics& K,
                 const Eigen::Matrix4d& camera_to_world);
  /** \brief Fuse a 16-bit depth image.
    * \param[in] depth row-major width × height depths (0: no data)
    * \param[in] width the image's width in pixels
    * \param[in] height the image's height in pixels
    * \param[in] K the camera's pinhole intrinsics
    * \param[in] camera_to_world the rigid camera pose (see the first addFrame ())
    * \param[in] depth_scale metres per depth unit (> 0; default 0.001: PNG depth in mm)
    * \return false (with a PCL_ERROR and getLastError ()) on bad input; the map is then unchanged
    */
  bool addFrame (const std::uint16_t* depth, int width, int height, const pcl::DepthIntrinsics& K,
                 const Eigen::Matrix4d& camera_to_world, float depth_scale = 0.001f);
  /** \brief Fuse a triangle mesh given in its own frame.
    * \param[in] mesh the mesh, counter-clockwise seen from outside (non-triangles are skipped
    * with a warning)
    * \param[in] pose the rigid transform placing the mesh in the world
    * \return false (with a PCL_ERROR and getLastError ()) on bad input; the map is then unchanged
    */
  bool addMesh (const pcl::PolygonMesh& mesh, const Eigen::Matrix4d& pose);
  /** \brief Fuse a world-space mesh: the common entry of the addFrame ()s (§3.4–3.5).
    * \param[in] world_mesh the mesh, counter-clockwise seen from outside
    * \return false (with a PCL_ERROR and getLastError ()) on bad input; the map is then unchanged
    */
  bool addFrameMesh (const pcl::FrameMesh& world_mesh);

  /** \brief The current mesh; clears getLastError ().
    * \param[out] mesh x, y, z vertices and triangles counter-clockwise seen from outside
    */
  void reconstruct (pcl::PolygonMesh& mesh);

  /** \brief Get the counts and timings (waits for the last frame's merge, see
    * DualContouringOctree::setOverlapMerges ()).
    * \return the statistics
    */
  const Stats& getStats () const;
  /** \brief Get the reason of the last refused call.
    * \return the message, empty after a call that succeeded
    */
  const std::string& getLastError () const { return error_; }
  /** \brief The extrinsic representation, for diagnostics (waits for the last frame's merge).
    * \return the octree
    */
  const DualContouringOctree& getOctree () const { octree_.waitForMerge (); return octree_; }
  /** \brief The extrinsic representation, for diagnostics and its settings (waits for the
    * last frame's merge).
    * \return the octree
    */
  DualContouringOctree& getOctree () { octree_.waitForMerge (); return octree_; }
  /** \brief The last frame's mesh after §3.3.
    * \return the mesh in world coordinates
    */
  const pcl::FrameMesh& getLastFrameMesh () const { return frame_; }

private:
  bool fail (const std::string& msg);
  bool forward (const std::string& msg);
  // The octree's answer to a setter, with its error kept here.
  bool settled (bool ok) { return ok ? (error_.clear (), true) : forward (octree_.getLastError ()); }
  bool checkFrameSize (int width, int height);
  bool fuse (double frontend_ms);
  void checkPoseConvention (const Eigen::Matrix4d& camera_to_world);
  // How near, in leaves, a vertex must come to the previous frame's vertices to overlap them.
  static constexpr double kPoseOverlapLeaves = 2.0;
  void removePlane (pcl::PolygonMesh& mesh);

  CoupledSimplification simplification_;
  DualContouringOctree octree_;
  pcl::FrameMesh frame_;
  pclx::surface::detail::PoseConventionCheck pose_check_;
  std::vector<float> depth_buffer_;
  std::vector<Eigen::Vector3f> point_buffer_;
  int width_ = 0, height_ = 0;  // size of the first frame
  bool remove_plane_ = false;
  double plane_threshold_ = 0;
  mutable Stats stats_;  // its octree counts are brought up to date by getStats ()
  std::string error_;
};

}  // namespace pcl

#ifdef PCL_NO_PRECOMPILE
#include <pclx/surface/impl/incremental_dual_contouring.hpp>
#endif
