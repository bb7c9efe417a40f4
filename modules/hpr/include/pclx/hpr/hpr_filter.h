#pragma once
// pcl::HPRFilter: hidden point removal (Katz, Tal, Basri 2007) as a PCL filter, with the
// exact convex-hull operator and the fast approximate angular-grid operator of Machado e
// Silva et al. ("Image Space Rendering of Point Clouds Using the HPR Operator").
//
//   pcl::HPRFilter<pcl::PointXYZ> hpr;
//   hpr.setInputCloud (cloud);
//   hpr.setViewPoint (Eigen::Vector3f (0, 0, 2));
//   pcl::Indices visible;
//   hpr.filter (visible);          // or hpr.filter (visible_cloud)
//
// Kept indices are the visible points, removed indices the hidden ones; setNegative,
// setKeepOrganized and setIndices behave as in every pcl::FilterIndices. NaN/Inf points
// are never visible. By default R, the grid size k and the propagation length ℓ are
// calibrated from the cloud itself (balls in bins, seed §6).
//
// Flat input seen edge-on (every point in one plane through the viewpoint, to float
// precision, or on one line) is all visible for every method: each point lies on the
// silhouette of a sheet seen exactly edge-on, and it is the limit of HPR as C approaches
// the plane (a flat cloud is entirely visible from any C off its plane). Normals are NaN
// there (no normal faces the viewer).
//
// Far viewpoints: p − C is formed in double and the calibrated R grows as distance² (the
// same angular occlusion criterion at every distance), so the calibrated results hold from
// ~1× to 1000× the diameter (tested at 100× and 1000×).
#include <pcl/PolygonMesh.h>
#include <pcl/filters/filter_indices.h>
#include <pcl/point_types.h>
#include <pclx/hpr/visibility.h>

namespace pcl {

template <typename PointT>
class HPRFilter : public FilterIndices<PointT>
{
protected:
  using PointCloud = typename FilterIndices<PointT>::PointCloud;
  using PointCloudPtr = typename PointCloud::Ptr;
  using PointCloudConstPtr = typename PointCloud::ConstPtr;

public:
  using Ptr = shared_ptr<HPRFilter<PointT>>;
  using ConstPtr = shared_ptr<const HPRFilter<PointT>>;

  enum class Method
  {
    AUTO,          // EXACT for small clouds and whenever R is given (setRadius, setGamma);
                   // ANGULAR_GRID when a view resolution is set (only the detail the screen
                   // shows); CANDIDATE_HULL otherwise, which calibrates its own R
    EXACT,         // Katz et al.: Qhull on the flipped cloud (+ an exact interior pre-filter)
    ANGULAR_GRID,  // Machado e Silva et al.: sector candidates + propagation
    CANDIDATE_HULL,  // ours: every point not strictly inside a tetrahedron (C, a, b, c) of
                     // neighbouring grid candidates (k = 2·n^0.7, ℓ = 4 by default), then the
                     // survivors again on grids 2× and 4× finer (setRefinementPasses); keeps
                     // all hull vertices, so recall matches EXACT at a fraction of its time
    BENTLEY_FAUST_PREPARATA,  // seed 000 §3.1: grid extremes, then exact hull of those
    KAVAN,         // seed 000 §3.2: sector candidates refined against all others, O(k²)
    HYBRID         // seed 000 §3.3: sector candidates (Kavan sampling), then exact hull
  };
  enum class Propagation
  {
    ADAPTIVE,  // scatter from changed sectors until stable or ℓ steps (§4.3.1)
    FIXED      // one gather pass over an m×m neighbourhood (§4.3.2)
  };
  enum class RadiusMode
  {
    AUTO,      // from the angular separation of visible points (§6)
    ABSOLUTE,  // R as given
    GAMMA      // R = max‖p − C‖ · 10^γ (Katz's parametrisation)
  };

  HPRFilter (bool extract_removed_indices = false) : FilterIndices<PointT> (extract_removed_indices)
  {
    filter_name_ = "HPRFilter";
  }

  void setViewPoint (const Eigen::Vector3f& c) { viewpoint_ = c; }
  const Eigen::Vector3f& getViewPoint () const { return viewpoint_; }

  // Flip radius R; must exceed the distance from the viewpoint to the farthest point.
  void setRadius (double radius) { radius_ = radius; radius_mode_ = RadiusMode::ABSOLUTE; }
  // R = max‖p − C‖ · 10^γ, γ > 0 (Katz et al. use γ around 2–4 for dense clouds).
  void setGamma (double gamma) { gamma_ = gamma; radius_mode_ = RadiusMode::GAMMA; }
  // Calibrated R (default): a point `occlusion_depth` × cloud radius behind two
  // neighbouring visible points is hidden (seed §6, Fig. 9). CANDIDATE_HULL (what AUTO runs
  // above 20k points) calibrates its own R at 0.8 of this depth (measured on the wide bench),
  // or deeper on noisy input (60 × the measured noise, see candidateHullDepth in visibility.h).
  void setAutoRadius (double occlusion_depth = 0.05) { occlusion_depth_ = occlusion_depth; radius_mode_ = RadiusMode::AUTO; }
  RadiusMode getRadiusMode () const { return radius_mode_; }

  void setMethod (Method m) { method_ = m; }
  Method getMethod () const { return method_; }

  // Number of sectors k (0 = calibrated). Sectors are square in angle, k is approximate.
  void setSectorCount (std::size_t k) { sectors_ = k; }
  std::size_t getSectorCount () const { return sectors_; }
  // Calibrated k gives this many sectors per expected visible-point cell (default 4).
  void setGridOversampling (double factor) { oversampling_ = factor; }
  // Caps k at what a viewport shows: `pixels` across a field of view of `fov` radians
  // (0 pixels = no cap). k follows the screen, not the cloud size.
  void setViewResolution (int pixels, double fov) { view_pixels_ = pixels; view_fov_ = fov; }

  // Adaptive: `steps` = ℓ (0 = calibrated). Fixed: `steps` = m, the odd mask size.
  void setPropagation (Propagation mode, int steps = 0) { propagation_ = mode; steps_ = steps; }

  // CANDIDATE_HULL: culling passes over the survivors of the first, on grids 2×, 4×, ...
  // finer at the same R (default 2, 0..8). Each halves the size of the triangles, so the
  // depth band in which hidden points survive shrinks 4×; the test stays conservative.
  void setRefinementPasses (int passes) { refinement_ = passes; }
  int getRefinementPasses () const { return refinement_; }

  // Exact method: cull points that are provably interior before Qhull (default on;
  // the visible set is the same either way).
  void setExactPrefilter (bool on) { exact_prefilter_ = on; }

  // Partial view-dependent reconstruction: the hull triangles (exact) or the grid
  // triangles (§4.4) of the visible points, edges longer than max_edge dropped
  // (<= 0: 5 × the median edge). Read it with getMesh() after filter().
  void setReconstructMesh (bool on, float max_edge = 0.f) { reconstruct_ = on; max_edge_ = max_edge; }
  // Per-point normals (§5.3, facing the viewpoint) and splat radii (§5.5) of the visible
  // points, NaN / 0 for the others; aligned with the input cloud. Read after filter().
  void setComputeNormals (bool on) { compute_normals_ = on; }

  // OpenMP threads (as pcl::NormalEstimationOMP). 0 (default): decided per call from the
  // cloud size and the cores other processes leave free (hpr::autoThreads), so a busy
  // machine gets one thread instead of barriers that wait for a preempted one.
  void setNumberOfThreads (unsigned int threads = 0) { threads_ = threads; }
  int getThreadsUsed () const { return threads_used_; }

  // The filter keeps its working memory between calls (about 120 bytes per point of the
  // largest cloud so far, see hpr::VisibilityWorkspace), so a filter run on every frame does
  // not fault in fresh pages each time. This gives it back.
  void releaseWorkingMemory () { workspace_.release (); }

  const PolygonMesh& getMesh () const { return mesh_; }
  const pcl::PointCloud<pcl::Normal>& getNormals () const { return normals_; }
  const std::vector<float>& getSplatRadii () const { return splat_radii_; }

  // What the last filter() used.
  double getRadiusUsed () const { return radius_used_; }
  std::size_t getSectorCountUsed () const { return sectors_used_; }
  int getPropagationStepsUsed () const { return steps_used_; }
  Method getMethodUsed () const { return method_used_; }

  // Largest grid the approximate methods accept (also at most 64 sectors per point);
  // larger requests are clamped with a warning.
  static constexpr std::size_t kMaxSectors = hpr::kMaxSectors;
  // Below this many points, AUTO picks the exact method (above it too when R is given).
  static constexpr std::size_t kAutoExactLimit = 20000;

protected:
  using FilterIndices<PointT>::filter_name_;
  using FilterIndices<PointT>::getClassName;
  using FilterIndices<PointT>::input_;
  using FilterIndices<PointT>::indices_;
  using FilterIndices<PointT>::negative_;
  using FilterIndices<PointT>::extract_removed_indices_;
  using FilterIndices<PointT>::removed_indices_;

  void applyFilter (Indices& indices) override;

private:
  Eigen::Vector3f viewpoint_ = Eigen::Vector3f::Zero ();
  RadiusMode radius_mode_ = RadiusMode::AUTO;
  double radius_ = 0, gamma_ = 0, occlusion_depth_ = 0.05;
  Method method_ = Method::AUTO;
  std::size_t sectors_ = 0;
  double oversampling_ = 4.0;
  int view_pixels_ = 0;
  double view_fov_ = 0;
  Propagation propagation_ = Propagation::ADAPTIVE;
  int steps_ = 0;
  bool exact_prefilter_ = true;
  int refinement_ = 2;
  bool reconstruct_ = false;
  float max_edge_ = 0.f;
  bool compute_normals_ = false;
  unsigned int threads_ = 0;
  int threads_used_ = 0;

  PolygonMesh mesh_;
  pcl::PointCloud<pcl::Normal> normals_;
  std::vector<float> splat_radii_;
  double radius_used_ = 0;
  std::size_t sectors_used_ = 0;
  int steps_used_ = 0;
  Method method_used_ = Method::AUTO;
  hpr::VisibilityWorkspace workspace_;
};

}  // namespace pcl

#ifdef PCL_NO_PRECOMPILE
#include <pclx/hpr/impl/hpr_filter.hpp>
#endif
