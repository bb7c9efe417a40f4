#pragma once
// CoupledSimplification: one posed depth frame becomes a small world-space triangle mesh with
// per-vertex quadrics, the front end of incremental dual contouring (seed 004 §3.2–3.3).
//   §3.2  Connected cloud: every valid pixel is back-projected; 4-neighbours form triangles when
//         all their edges are below a threshold (default from the mean neighbour distance, §4.2;
//         here the mean of edge length / depth, trimmed of discontinuities, times a factor and
//         the depth of the edge, because pixel spacing and noise grow with depth).
//   §3.3  Garland & Shaffer 2002 coupled simplification: vertex clustering in camera-frustum
//         cells (B × B pixel blocks × depth intervals that grow with range: a block's pixels
//         are split along the ray where their ranges jump by more than r · range, and a cell
//         is at most 2 r · range deep),
//         each dense face's area-weighted plane quadric added to the clusters of its vertices;
//         the representative minimises the cluster quadric (truncated pseudo-inverse biased to
//         the mean, kept inside the cluster's box). Then Garland–Heckbert edge collapse on the
//         clustered mesh with those original quadrics: no fold-overs, link condition (no
//         non-manifold edges made), boundary edges held by perpendicular constraint planes.
// Quadrics are area-weighted, so trace of their 3×3 block = the dense area they stand for;
// v^T Q v / trace is the area-weighted mean squared distance to the dense faces.
//
// Bad input (null data, sizes ≤ 0, zero / non-finite intrinsics, a non-rigid or non-finite
// pose, no valid pixel) gives false, getLastError () and leaves `out` untouched. NaN / Inf
// pixels and depths outside [min, max] are skipped and counted in the stats.
#include <pclx/surface/frame_mesh.h>

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

namespace pcl {

class CoupledSimplification
{
public:
  using Quadric = Eigen::Matrix<double, 10, 1>;

  // Counts and per-stage wall times (milliseconds) of the last compute.
  struct Stats
  {
    std::size_t pixels = 0, valid_pixels = 0, nonfinite_pixels = 0, out_of_range_pixels = 0;
    std::size_t dense_triangles = 0, clusters = 0, clustered_triangles = 0;
    std::size_t backfacing = 0;  // clustered faces dropped: turned away from the camera
    std::size_t collapses = 0, rejected_foldover = 0, rejected_topology = 0;
    std::size_t cluster_fallbacks = 0;  // representatives set to the cluster mean
    std::size_t vertices = 0, triangles = 0;
    double edge_ratio_mean = 0;   // trimmed mean of neighbour distance / range
    double median_range = 0;      // metres
    int cell_pixels = 0;          // frustum cell side used (pixels)
    double max_error = 0;         // RMS error (m) of the last accepted collapse
    double t_backproject = 0, t_spacing = 0, t_connect = 0, t_cluster = 0, t_collapse = 0, t_output = 0, t_total = 0;
  };

  CoupledSimplification () = default;

  // §3.2 edge threshold. factor > 0 (default 3): an edge (a, b) is kept when
  // |a − b| < factor · mean(|p − q| / depth) · min(depth_a, depth_b). An absolute threshold
  // (metres, > 0) replaces it; 0 returns to the relative one.
  void setEdgeThresholdFactor (double f) { edge_factor_ = f; }
  double getEdgeThresholdFactor () const { return edge_factor_; }
  void setEdgeThreshold (double metres) { edge_abs_ = metres; }
  double getEdgeThreshold () const { return edge_abs_; }
  // Depth images: depths outside [min, max] metres are no data (default 0.1–8).
  void setDepthRange (float min_m, float max_m) { min_depth_ = min_m; max_depth_ = max_m; }
  // §3.3 frustum cells: pixel block side B (≥ 1, default 8; 1 = no clustering) and depth-bin
  // ratio r (> 0; 0 = auto: B / fx, about cubic cells; organized clouds without intrinsics:
  // B × the mean neighbour spacing / range).
  void setFrustumCellPixels (int b) { cell_pixels_ = b; cell_size_ = 0; }  // the last setter wins
  int getFrustumCellPixels () const { return cell_pixels_; }
  void setDepthBinRatio (double r) { bin_ratio_ = r; }
  // Frustum cell side in metres at the frame's median range (> 0; 0 = off, default): B is
  // chosen per frame as size · fx / median range (1–64 pixels), e.g. the octree leaf size
  // (pcl::IncrementalDualContouring sets 2 leaves).
  void setFrustumCellSize (double metres) { cell_size_ = metres; }
  double getFrustumCellSize () const { return cell_size_; }
  // Edge collapse stops at the first of: triangles ≤ target_ratio · clustered triangles
  // (0 = no count target, default), or a collapse whose RMS quadric error exceeds max_error
  // (metres; 0 = auto, default: 0.1 · the frustum cell size at that depth; < 0: no bound).
  // Ratio 1 or (ratio 0 and no bound) = no collapse. A count target alone ignores the error:
  // on the bench's orbit at 1 cm leaves, cells of 2 cm and ratio 0.25 tripled the final
  // Chamfer error (2.2 vs 0.63 mm); the auto bound keeps it (0.63 mm).
  void setCollapseTargetRatio (double ratio) { target_ratio_ = ratio; }
  double getCollapseTargetRatio () const { return target_ratio_; }
  void setCollapseMaxError (double metres) { max_error_ = metres; }
  double getCollapseMaxError () const { return max_error_; }
  // Weight of the boundary constraint planes relative to the face quadrics (default 10).
  void setBoundaryWeight (double w) { boundary_weight_ = w; }
  // Rejects a collapse when a face normal turns by more than this (degrees, default 60).
  void setMaxNormalTurn (double deg) { max_turn_deg_ = deg; }

  // Organized camera-frame points (row-major width × height, NaN = invalid).
  bool compute (const Eigen::Vector3f* camera_points, int width, int height,
                const Eigen::Matrix4d& camera_to_world, pclx::surface::FrameMesh& out);
  // Depth image in metres (0 / NaN = no data).
  bool compute (const float* depth_m, int width, int height, const pclx::surface::DepthIntrinsics& K,
                const Eigen::Matrix4d& camera_to_world, pclx::surface::FrameMesh& out);

  // §3.2 alone: the dense connected cloud in world coordinates (one vertex per valid pixel,
  // per-vertex quadrics of its incident faces), for tests, the app and benchmarks.
  bool computeConnectedCloud (const Eigen::Vector3f* camera_points, int width, int height,
                              const Eigen::Matrix4d& camera_to_world, pclx::surface::FrameMesh& out);
  bool computeConnectedCloud (const float* depth_m, int width, int height,
                              const pclx::surface::DepthIntrinsics& K,
                              const Eigen::Matrix4d& camera_to_world, pclx::surface::FrameMesh& out);

  const Stats& getStats () const { return stats_; }
  const std::string& getLastError () const { return error_; }

  // Checks shared with IncrementalDualContouring: an empty string when fine, else the reason.
  static std::string checkPose (const Eigen::Matrix4d& camera_to_world);
  static std::string checkIntrinsics (const pclx::surface::DepthIntrinsics& K);

private:
  bool fail (const std::string& msg);
  bool backProject (const float* depth_m, int width, int height,
                    const pclx::surface::DepthIntrinsics& K, const Eigen::Matrix4d& pose);
  bool takePoints (const Eigen::Vector3f* pts, int width, int height, const Eigen::Matrix4d& pose);
  bool run (const Eigen::Matrix4d& pose, bool dense_only, pclx::surface::FrameMesh& out);
  void measureSpacing ();
  void connect (bool dense_only);
  void cluster ();
  void collapse ();
  void emit (const Eigen::Matrix4d& pose, bool dense_only, pclx::surface::FrameMesh& out);

  double edge_factor_ = 3, edge_abs_ = 0, bin_ratio_ = 0, target_ratio_ = 0, max_error_ = 0;
  double boundary_weight_ = 10, max_turn_deg_ = 60, cell_size_ = 0;
  float min_depth_ = 0.1f, max_depth_ = 8.f;
  int cell_pixels_ = 8;

  Stats stats_;
  std::string error_;

  // Per-frame buffers, kept between frames so that their memory is reused.
  int w_ = 0, h_ = 0;
  double fx_ = 0;  // 0: organized input without intrinsics
  std::vector<Eigen::Vector3f> pts_;  // camera frame, NaN = invalid
  std::vector<float> range_;          // |p|, 0 = invalid
  std::vector<std::int32_t> cid_;     // cluster (or dense vertex) id per pixel, −1 = invalid
  std::vector<Eigen::Vector3i> dense_tris_;  // dense mode only
  std::vector<Quadric> dense_q_;
  // Clusters: quadric, position sum, count, box, representative, collapse state.
  std::vector<Quadric> cq_, cb_;      // face quadrics / boundary constraint quadrics
  std::vector<Eigen::Vector3d> csum_, cpos_;
  std::vector<Eigen::Vector3f> cmin_, cmax_;
  std::vector<std::int32_t> ccount_;
  std::vector<float> cscale_;         // frustum cell size at the cluster (m)
  std::vector<float> ratios_;
  std::vector<std::vector<std::int32_t>> vf_;  // clustered vertex → faces
  std::vector<std::uint64_t> edges_;
  std::vector<std::pair<std::uint64_t, std::int32_t>> tri_keys_;
  std::vector<Eigen::Vector3i> ctris_;
  long orientation_vote_ = 0;
  int block_rows_ = 1;  // rows of a cluster block (band cuts for the parallel connect)
};

}  // namespace pcl
