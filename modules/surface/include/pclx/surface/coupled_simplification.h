#pragma once
#include <pclx/surface/frame_mesh.h>

#include <Eigen/Core>

#include <cstdint>
#include <limits>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace pcl {

/** \brief One posed depth frame becomes a small world-space triangle mesh with per-vertex
  * quadrics: the front end of incremental dual contouring (da Paz 2017, §3.2–3.3).
  *
  * - §3.2, connected cloud: every valid pixel is back-projected; 4-neighbours form triangles
  *   when all their edges are below a threshold. The dissertation derives the threshold from the
  *   mean neighbour distance (§4.2); here it is the mean of edge length / depth, trimmed of
  *   discontinuities, times a factor and the depth of the edge, because pixel spacing and noise
  *   grow with depth.
  * - §3.3, coupled simplification (Garland and Shaffer 2002): vertex clustering in
  *   camera-frustum cells (B × B pixel blocks × depth intervals that grow with range: a block's
  *   pixels are split along the ray where their ranges jump by more than r · range, and a cell
  *   is at most 2 r · range deep). Each dense face's area-weighted plane quadric is added to the
  *   clusters of its vertices; the representative minimises the cluster quadric (truncated
  *   pseudo-inverse biased to the mean, kept inside the cluster's box). Then Garland–Heckbert
  *   edge collapse on the clustered mesh with those original quadrics: no fold-overs, the link
  *   condition (no non-manifold edges made), boundary edges held by perpendicular constraint
  *   planes.
  *
  * Quadrics are area-weighted, so the trace of their 3×3 block is the dense area they stand
  * for, and vᵀQv / trace is the area-weighted mean squared distance to the dense faces.
  *
  * Bad input (null data, sizes ≤ 0, zero or non-finite intrinsics, a non-rigid or non-finite
  * pose, no valid pixel) or bad settings give false, a PCL_ERROR and getLastError (), and leave
  * the output untouched. NaN / Inf pixels and depths outside [min, max] are skipped and counted
  * in the stats.
  *
  * \note H. O. da Paz, 2017, "Reconstrução Adaptativa de Superfícies Implícitas a partir de
  * Imagens de Profundidade", MSc dissertation, IMPA (§3.2–3.3); M. Garland, E. Shaffer, 2002,
  * "A Multiphase Approach to Efficient Surface Simplification", IEEE Visualization;
  * M. Garland, P. S. Heckbert, 1997, "Surface Simplification Using Quadric Error Metrics",
  * ACM SIGGRAPH.
  * \ingroup surface
  */
class CoupledSimplification
{
public:
  /** \brief A symmetric 4×4 quadric packed as its 10 upper-triangle entries (see FrameMesh::quadrics). */
  using Quadric = Eigen::Matrix<double, 10, 1>;

  /** \brief Counts and per-stage wall times (milliseconds) of the last compute. */
  struct Stats
  {
    std::size_t pixels = 0;               ///< pixels of the frame
    std::size_t valid_pixels = 0;         ///< pixels with a usable depth
    std::size_t nonfinite_pixels = 0;     ///< pixels with NaN / Inf coordinates
    std::size_t out_of_range_pixels = 0;  ///< pixels with a depth outside the depth range
    std::size_t dense_triangles = 0;      ///< triangles of the connected cloud (§3.2), after block averaging
    std::size_t clusters = 0;             ///< frustum-cell clusters (§3.3)
    std::size_t clustered_triangles = 0;  ///< triangles between clusters, before edge collapse
    std::size_t backfacing = 0;  ///< clustered faces dropped: turned away from the camera
    std::size_t collapses = 0;            ///< edge collapses done
    std::size_t rejected_foldover = 0;    ///< collapses refused: a face would fold over
    std::size_t rejected_topology = 0;    ///< collapses refused by the link condition
    std::size_t cluster_fallbacks = 0;  ///< representatives set to the cluster mean or clamped to its box
    std::size_t vertices = 0;             ///< vertices of the output
    std::size_t triangles = 0;            ///< triangles of the output
    double edge_ratio_mean = 0;   ///< trimmed mean of neighbour distance / range
    double median_range = 0;      ///< median range of the valid pixels (metres)
    double range_noise = 0;       ///< the input's trimmed mean |second difference of range| along rows, in pixel spacings
    int cell_pixels = 0;          ///< frustum cell side used (pixels of the input frame)
    bool block_averaged = false;  ///< the frame was reduced by 2 × 2 block averages before clustering
    int averaging_scale = 1;      ///< input pixels per side of a pixel after block averaging (1, 2 or 4)
    double max_error = 0;         ///< RMS quadric error (metres) of the worst accepted collapse
    double t_backproject = 0;     ///< back-projection (ms)
    double t_spacing = 0;         ///< neighbour spacing and range noise (ms)
    double t_connect = 0;         ///< connected cloud (ms)
    double t_cluster = 0;         ///< clustering (ms)
    double t_collapse = 0;        ///< representatives and edge collapse (ms)
    double t_output = 0;          ///< world-space output (ms)
    double t_total = 0;           ///< whole compute (ms)
  };

  /** \brief Empty constructor. */
  CoupledSimplification () = default;

  /** \brief Set the relative edge threshold of the connected cloud (§3.2): an edge (a, b) is
    * kept when |a − b| < factor · mean(|p − q| / depth) · min(depth_a, depth_b).
    * \param[in] f the factor (> 0, default 3)
    */
  void setEdgeThresholdFactor (double f) { edge_factor_ = f; }
  /** \brief Get the relative edge threshold factor.
    * \return the factor set with setEdgeThresholdFactor ()
    */
  double getEdgeThresholdFactor () const { return edge_factor_; }
  /** \brief Set an absolute edge threshold, which replaces the relative one.
    * \param[in] metres the longest edge kept (> 0); 0 (default) returns to the relative threshold
    */
  void setEdgeThreshold (double metres) { edge_abs_ = metres; }
  /** \brief Get the absolute edge threshold.
    * \return the threshold in metres, 0 when the relative one is used
    */
  double getEdgeThreshold () const { return edge_abs_; }
  /** \brief Set the valid depths of depth images: depths outside [min, max] are no data.
    * \param[in] min_m the nearest valid depth in metres (default 0.1)
    * \param[in] max_m the farthest valid depth in metres (default 8)
    */
  void setDepthRange (float min_m, float max_m) { min_depth_ = min_m; max_depth_ = max_m; }
  /** \brief Set the pixel block side B of the frustum cells (§3.3); cancels setFrustumCellSize ()
    * (the last of the two setters wins).
    * \param[in] b block side in pixels (≥ 1, default 8; 1: no clustering)
    */
  void setFrustumCellPixels (int b) { cell_pixels_ = b; cell_size_ = 0; }
  /** \brief Get the pixel block side of the frustum cells.
    * \return B in pixels
    */
  int getFrustumCellPixels () const { return cell_pixels_; }
  /** \brief Set the fewest pixels a frustum cell keeps a side. When a cell is at least twice
    * that wide and the frame is noisy (range noise of at least half a pixel spacing, as with
    * structured-light and time-of-flight cameras; see Stats::range_noise), the frame is first
    * reduced by 2 × 2 block averages (pixels across a depth edge are not mixed), so the cells
    * are built from a quarter of the pixels, each less noisy. A frame whose pixel noise at its
    * median range exceeds half a frustum cell (a distant view of a depth camera) is averaged
    * once more, whatever the cell width, and again while that holds (at most 4 × 4 pixels).
    * Low-noise range scans keep every pixel.
    * \param[in] pixels the fewest pixels per cell side (default 2); 0: always the full resolution
    */
  void setMinCellPixels (int pixels) { min_cell_pixels_ = pixels; }
  /** \brief Get the fewest pixels a frustum cell keeps a side.
    * \return the value set with setMinCellPixels ()
    */
  int getMinCellPixels () const { return min_cell_pixels_; }
  /** \brief Set the narrowest frustum cell, in pixels of the input frame, when the cells
    * follow a size in metres (setFrustumCellSize ()) and the frame is noisy (as for block
    * averaging, see setMinCellPixels ()): B is then at least this. A cell of 2 × 2 pixels fits
    * its quadric to four noisy depths and leaves most of the reduction to the edge collapses, so
    * a fine leaf seen from afar would cost several times the work of the same leaf seen from
    * nearby, for a noisier mesh (docs/surface.md, "Narrowest frustum cell").
    * \param[in] pixels the narrowest cell side (≥ 1, default 3; 1: cells follow the size alone)
    */
  void setNarrowestCellPixels (int pixels) { narrowest_cell_pixels_ = pixels; }
  /** \brief Get the narrowest frustum cell when the cells follow a size in metres.
    * \return the value set with setNarrowestCellPixels ()
    */
  int getNarrowestCellPixels () const { return narrowest_cell_pixels_; }
  /** \brief Set the depth-bin ratio r of the frustum cells (§3.3).
    * \param[in] r the ratio (> 0); 0 (default) is automatic: B / fx, about cubic cells, or for
    * organized clouds without intrinsics B × the mean neighbour spacing / range
    */
  void setDepthBinRatio (double r) { bin_ratio_ = r; }
  /** \brief Set the frustum cell side in metres at the frame's median range: B is then chosen
    * per frame as size · fx / median range (1–64 pixels; on noisy frames at least
    * getNarrowestCellPixels ()), not rounded: blocks of ⌊B⌋ and ⌈B⌉ pixels alternate, so the
    * cells keep the size on average. pcl::IncrementalDualContouring sets it to two octree leaves.
    * \param[in] metres the cell side (> 0); 0 (default) uses setFrustumCellPixels () instead
    */
  void setFrustumCellSize (double metres) { cell_size_ = metres; }
  /** \brief Get the frustum cell side in metres.
    * \return the side, 0 when the pixel block side is used
    */
  double getFrustumCellSize () const { return cell_size_; }
  /** \brief Set the triangle count at which the edge collapse stops.
    *
    * The collapse stops at the first of: triangles ≤ ratio · clustered triangles, or a
    * collapse whose RMS quadric error exceeds the error bound (setCollapseMaxError ()). Ratio 1,
    * or ratio 0 without an error bound, means no collapse. A count target alone ignores the
    * error, which can coarsen flat and curved parts alike; the automatic error bound keeps the
    * error of the final mesh.
    * \param[in] ratio the target share of the clustered triangles, in [0, 1]; 0 (default): no
    * count target
    */
  void setCollapseTargetRatio (double ratio) { target_ratio_ = ratio; }
  /** \brief Get the collapse target ratio.
    * \return the ratio set with setCollapseTargetRatio ()
    */
  double getCollapseTargetRatio () const { return target_ratio_; }
  /** \brief Set the error bound of the edge collapse (see setCollapseTargetRatio ()).
    * \param[in] metres the largest RMS quadric error of a collapse (> 0); 0 (default) is
    * automatic: 0.1 × the frustum cell size at that depth; < 0: no bound
    */
  void setCollapseMaxError (double metres) { max_error_ = metres; }
  /** \brief Get the error bound of the edge collapse.
    * \return the bound set with setCollapseMaxError ()
    */
  double getCollapseMaxError () const { return max_error_; }
  /** \brief Set the weight of the boundary constraint planes relative to the face quadrics.
    * \param[in] w the weight (default 10)
    */
  void setBoundaryWeight (double w) { boundary_weight_ = w; }
  /** \brief Set the largest turn of a face normal that a collapse may cause.
    * \param[in] deg the angle in degrees (default 60)
    */
  void setMaxNormalTurn (double deg) { max_turn_deg_ = deg; }

  /** \brief Simplify one frame given as organized camera-frame points.
    * \param[in] camera_points row-major width × height points in the camera frame (NaN: invalid)
    * \param[in] width the frame's width in pixels
    * \param[in] height the frame's height in pixels
    * \param[in] camera_to_world the rigid pose mapping camera to world coordinates
    * \param[out] out the simplified mesh in world coordinates (untouched on failure)
    * \return false (with a PCL_ERROR and getLastError ()) on bad input or settings
    */
  bool compute (const Eigen::Vector3f* camera_points, int width, int height,
                const Eigen::Matrix4d& camera_to_world, pcl::FrameMesh& out);
  /** \brief Simplify one frame given as a depth image.
    * \param[in] depth_m row-major width × height depths in metres (0 / NaN: no data)
    * \param[in] width the image's width in pixels
    * \param[in] height the image's height in pixels
    * \param[in] K the camera's pinhole intrinsics
    * \param[in] camera_to_world the rigid pose mapping camera to world coordinates
    * \param[out] out the simplified mesh in world coordinates (untouched on failure)
    * \return false (with a PCL_ERROR and getLastError ()) on bad input or settings
    */
  bool compute (const float* depth_m, int width, int height, const pcl::DepthIntrinsics& K,
                const Eigen::Matrix4d& camera_to_world, pcl::FrameMesh& out);

  /** \brief Only the dense connected cloud (§3.2) of organized camera-frame points: one vertex
    * per valid pixel, with the quadrics of its incident faces, in world coordinates.
    * \param[in] camera_points row-major width × height points in the camera frame (NaN: invalid)
    * \param[in] width the frame's width in pixels
    * \param[in] height the frame's height in pixels
    * \param[in] camera_to_world the rigid pose mapping camera to world coordinates
    * \param[out] out the connected cloud (untouched on failure)
    * \return false (with a PCL_ERROR and getLastError ()) on bad input or settings
    */
  bool computeConnectedCloud (const Eigen::Vector3f* camera_points, int width, int height,
                              const Eigen::Matrix4d& camera_to_world, pcl::FrameMesh& out);
  /** \brief Only the dense connected cloud (§3.2) of a depth image, in world coordinates.
    * \param[in] depth_m row-major width × height depths in metres (0 / NaN: no data)
    * \param[in] width the image's width in pixels
    * \param[in] height the image's height in pixels
    * \param[in] K the camera's pinhole intrinsics
    * \param[in] camera_to_world the rigid pose mapping camera to world coordinates
    * \param[out] out the connected cloud (untouched on failure)
    * \return false (with a PCL_ERROR and getLastError ()) on bad input or settings
    */
  bool computeConnectedCloud (const float* depth_m, int width, int height,
                              const pcl::DepthIntrinsics& K,
                              const Eigen::Matrix4d& camera_to_world, pcl::FrameMesh& out);

  /** \brief Get the counts and timings of the last compute.
    * \return the statistics
    */
  const Stats& getStats () const { return stats_; }
  /** \brief Get the reason of the last refused compute.
    * \return the message, empty after a compute that succeeded
    */
  const std::string& getLastError () const { return error_; }

  /** \brief Check a camera pose: finite, last row 0 0 0 1, a rotation block.
    * \param[in] camera_to_world the pose
    * \return an empty string when the pose is usable, else the reason
    */
  static std::string checkPose (const Eigen::Matrix4d& camera_to_world);
  /** \brief Check pinhole intrinsics: finite, positive focal lengths.
    * \param[in] K the intrinsics
    * \return an empty string when they are usable, else the reason
    */
  static std::string checkIntrinsics (const pcl::DepthIntrinsics& K);

private:
  bool fail (const std::string& msg);
  bool backProject (const float* depth_m, int width, int height,
                    const pcl::DepthIntrinsics& K, const Eigen::Matrix4d& pose);
  bool takePoints (const Eigen::Vector3f* pts, int width, int height, const Eigen::Matrix4d& pose);
  bool run (const Eigen::Matrix4d& pose, bool dense_only, pcl::FrameMesh& out);
  void measureSpacing ();
  void measureNoise ();
  float* sampleBuffer (std::size_t n);
  std::vector<int> connectBands () const;
  void connect (bool dense_only);
  double pixelsPerRadian () const;
  double cellWidth () const;
  void reduceResolution ();
  void halveResolution ();
  void cluster ();
  /** \brief Working state of the Garland–Heckbert edge collapse on the clustered mesh; a member,
    * so that its buffers keep their memory from frame to frame.
    */
  struct CollapseState
  {
    /** \brief A candidate collapse of edge (a, b); stale once a or b changed (stamps differ). */
    struct Entry
    {
      double key;        ///< collapse cost relative to its bound
      std::int32_t a;    ///< first clustered vertex of the edge
      std::int32_t b;    ///< second clustered vertex of the edge
      std::uint32_t sa;  ///< stamp of a when the entry was made
      std::uint32_t sb;  ///< stamp of b when the entry was made
      /** \brief Order of the min-heap: on key, ties broken by the vertices and stamps, so the
        * pop order does not depend on how the heap was filled.
        * \param[in] o the other entry
        * \return whether this entry comes after o
        */
      bool
      operator> (const Entry& o) const
      {
        return std::tie (key, a, b, sa, sb) > std::tie (o.key, o.a, o.b, o.sa, o.sb);
      }
    };

    double facing = 1;  ///< +1 / −1: the orientation of the faces that look at the camera
    std::vector<char> face_alive;  ///< per clustered face
    std::vector<char> vert_alive;  ///< per clustered vertex
    std::vector<char> locked;      ///< per clustered vertex: next to a non-manifold edge
    std::vector<std::uint32_t> stamp;  ///< per clustered vertex, bumped when it moves
    std::vector<std::pair<std::int32_t, std::int32_t>> unique_edges;  ///< (a, b), a < b
    std::vector<Entry> heap;  ///< a min-heap on key (std::push_heap / std::pop_heap)
    /** \brief Entries whose key exceeds this are never collapsed (the error bound stops the
      * collapses first), so they are not pushed. */
    double key_limit = std::numeric_limits<double>::infinity ();
    std::vector<std::int32_t> na;  ///< neighbour buffer of the link test (and of the edge scan)
    std::vector<std::int32_t> nb;  ///< second neighbour buffer of the link test

    /** \brief Whether a triangle in camera coordinates faces the camera.
      * \param[in] a first corner
      * \param[in] b second corner
      * \param[in] c third corner
      * \return true when it faces the camera (given the frame's orientation, facing)
      */
    bool facesCamera (const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) const;
  };
  // §3.3 second phase, in stages: collapse () runs them in order.
  void collapse ();
  void placeRepresentatives ();
  void dropBackfacingAndDuplicateFaces (const CollapseState& s);
  void buildCollapseConnectivity (CollapseState& s);
  void addBoundaryConstraint (std::int32_t a, std::int32_t b);
  Eigen::Vector3d placeCollapse (std::int32_t a, std::int32_t b, double& err) const;
  double collapseBound (std::int32_t a, std::int32_t b) const;
  double collapseKey (std::int32_t a, std::int32_t b) const;
  void pushCollapse (CollapseState& s, std::int32_t a, std::int32_t b) const;
  void pushAllEdges (CollapseState& s) const;
  bool linkConditionHolds (CollapseState& s, std::int32_t a, std::int32_t b) const;
  bool foldsOver (const CollapseState& s, std::int32_t a, std::int32_t b, const Eigen::Vector3d& x,
                  double cos_turn) const;
  std::size_t collapseInto (CollapseState& s, std::int32_t a, std::int32_t b, const Eigen::Vector3d& x);
  void collapseEdges (CollapseState& s, bool count_stop, bool error_stop);
  void emit (const Eigen::Matrix4d& pose, bool dense_only, pcl::FrameMesh& out);

  double edge_factor_ = 3, edge_abs_ = 0, bin_ratio_ = 0, target_ratio_ = 0, max_error_ = 0;
  double boundary_weight_ = 10, max_turn_deg_ = 60, cell_size_ = 0;
  float min_depth_ = 0.1f, max_depth_ = 8.f;
  int cell_pixels_ = 8, min_cell_pixels_ = 2, narrowest_cell_pixels_ = 3;
  int scale_ = 1;  // input pixels per pixel side after block averaging (1, 2 or 4)

  Stats stats_;
  std::string error_;

  // Per-frame buffers, kept between frames so that their memory is reused.
  int w_ = 0, h_ = 0;
  double fx_ = 0;  // 0: organized input without intrinsics
  std::vector<Eigen::Vector3f> pts_;  // camera frame, NaN = invalid
  std::vector<float> range_;          // |p|, 0 = invalid
  std::vector<Eigen::Vector3f> half_pts_;  // the block-averaged frame, swapped with pts_ / range_
  std::vector<float> half_range_;
  std::vector<std::int32_t> cid_;     // cluster (or dense vertex) id per pixel, −1 = invalid
  std::vector<Eigen::Vector3i> dense_tris_;  // dense mode only
  std::vector<Quadric> dense_q_;
  // Clusters: quadric, position sum, count, box, representative, collapse state.
  std::vector<Quadric> cq_, cb_;      // face quadrics / boundary constraint quadrics
  std::vector<Eigen::Vector3d> csum_, cpos_;
  std::vector<Eigen::Vector3f> cmin_, cmax_;
  std::vector<std::int32_t> ccount_;
  std::vector<float> cscale_;         // frustum cell size at the cluster (m)
  std::vector<float> ratios_;         // spacing and noise samples (sampleBuffer ())
  std::vector<std::vector<std::int32_t>> vf_;  // clustered vertex → faces
  std::vector<char> face_keep_;
  std::vector<std::pair<std::uint64_t, std::int32_t>> tri_keys_;
  std::vector<Eigen::Vector3i> ctris_;
  CollapseState collapse_state_;
  long orientation_vote_ = 0;
  std::vector<int> row_edges_, col_edges_;  // cluster block borders; the parallel connect cuts at row borders
};

}  // namespace pcl
