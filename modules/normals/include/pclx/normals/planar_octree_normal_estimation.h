#pragma once
// PlanarOctreeNormalEstimation: normals from the planarity octree of seed 002
// (MSc dissertation, ch. 5): the space is split until every cell holds an
// approximately planar patch (Algorithm 1), and a point's normal comes from its cell
// (Algorithm 2). Three methods:
//   OCTREE  the seed's method: the PCA plane of the point's leaf;
//   HYBRID  seed §5.4.3: Hoppe's kNN PCA for points near a cell border, the leaf plane inside;
//   MERGED  seed ch. 7 (the default): adjacent leaves whose planes agree are merged into
//           regions, each with one least-squares surface (plane or quadric height field:
//           the seed's "polynomial fit"). Planar leaves are cut into patches of a few points,
//           each with a quadric over a kNN-sized disc (PlanarOctree::fitPatches): the normal
//           of most points on clean input, with no kNN search. A region replaces its patches
//           only where it explains its points as well as they do. Every other point gets a
//           kNN PCA normal whose support is chosen per point (not in the seed, issue 13): a
//           ladder of 12, 18, 30, 50, 100, 200 neighbours, the largest whose normal agrees
//           with every smaller one within their standard errors (Lepski's rule), the errors
//           computed with the noise of the whole cloud, estimated once
//           (pclx::normals::selectScale / sampleNoise). Noise makes supports grow; edges
//           and fine detail stop them. On noisy input (noise > 0.15 point spacing) patches
//           and regions lose to that ladder and are not used: it serves every point, which
//           tracks the best fixed k chosen in hindsight, where the seed's planarity-driven
//           growth fell 3-18° behind it at σ >= 0.006 of the diagonal.
// Orientation is separate (MSTNormalOrientation, orientNormalsTowardsViewpoint): the
// output normals here are unoriented (sign of the fitted eigenvector / surface).
//
// Every valid input point gets a finite normal. Invalid input points get NaN normal and
// curvature, as pcl::NormalEstimation gives them (status INVALID_POINT), so downstream NaN
// filters drop them; points whose neighbourhood spans no plane get the normal of the
// smallest enclosing octree cell that does (status NEIGHBOUR_FALLBACK).
#include <pclx/normals/grid_knn.h>
#include <pclx/normals/lazy_kd_tree.h>
#include <pclx/normals/planar_octree.h>
#include <pclx/normals/scale_selection.h>

#include <pcl/features/feature.h>

#include <cstdint>
#include <vector>

namespace pcl {

template <typename PointInT, typename PointOutT>
class PlanarOctreeNormalEstimation : public Feature<PointInT, PointOutT>
{
public:
  using Ptr = shared_ptr<PlanarOctreeNormalEstimation<PointInT, PointOutT>>;
  using ConstPtr = shared_ptr<const PlanarOctreeNormalEstimation<PointInT, PointOutT>>;
  using PointCloudOut = typename Feature<PointInT, PointOutT>::PointCloudOut;
  using PointCloudIn = typename Feature<PointInT, PointOutT>::PointCloudIn;
  using Feature<PointInT, PointOutT>::feature_name_;
  using Feature<PointInT, PointOutT>::input_;
  using Feature<PointInT, PointOutT>::indices_;
  using Feature<PointInT, PointOutT>::surface_;
  using Feature<PointInT, PointOutT>::search_parameter_;

  enum class Method { OCTREE, HYBRID, MERGED };

  // How each output normal was obtained (getPointStatus ()).
  enum PointStatus : std::uint8_t
  {
    LEAF_PLANE = 0,          // PCA of the point's octree leaf (OCTREE, HYBRID inside)
    REGION_FIT = 1,          // surface fit of the point's merged region (MERGED)
    ADOPTED_REGION = 2,      // point of a non-planar cell that lies on an adjacent region (MERGED)
    KNN_PCA = 3,             // kNN PCA (HYBRID borders; MERGED: the ladder's k, getSupportSizes ())
    NEIGHBOUR_FALLBACK = 4,  // degenerate neighbourhood: normal of the enclosing planar-enough cell
    INVALID_POINT = 5,       // NaN / Inf input point: NaN normal and curvature
    PATCH_FIT = 6            // MERGED: quadric of the point's patch cell and its ring (fitPatches)
  };

  /** \brief Neighbours of the PCA fits at borders and fallbacks when neither setKSearch ()
    * nor setRadiusSearch () was called (PCL's defaults leave both unset). */
  static constexpr int kDefaultNeighbours = 18;

  PlanarOctreeNormalEstimation () { feature_name_ = "PlanarOctreeNormalEstimation"; }

  void setMethod (Method m) { method_ = m; }
  Method getMethod () const { return method_; }
  // Planarity tolerances of Algorithm 1; both must be > 0. Until set, OCTREE and HYBRID
  // use the seed's sα = 6.25, sβ = 1.5 and MERGED uses sα = 20, sβ = 1.5: at 6.25 a whole
  // torus (R = 1, r = 0.3) or a 90° sphere octant passes as one plane, which per-leaf
  // PCA tolerates no better, but a merged region's single surface fit cannot (and patch
  // supports then reach across the torus: 1.41° against 1.25°). Measured at 100k points:
  // 16, 20 and 25 are within 0.05° clean; 20 was best or tied on bunny, fandisk, box and
  // torus, clean and noisy.
  void setPlanarityThresholds (double s_alpha, double s_beta)
  {
    params_.s_alpha = s_alpha;
    params_.s_beta = s_beta;
    thresholds_set_ = true;
  }
  double getSAlpha () const { return thresholds_set_ || method_ != Method::MERGED ? params_.s_alpha : 20.0; }
  double getSBeta () const { return params_.s_beta; }
  void setMaxDepth (int depth) { params_.max_depth = depth; }
  int getMaxDepth () const { return params_.max_depth; }
  // Cells with fewer points are not split further and never count as planar (>= 3).
  void setMinPointsPerCell (int n) { params_.min_points = n; }
  int getMinPointsPerCell () const { return params_.min_points; }
  // HYBRID: points farther than (1 − ratio) of the half edge from their cell's centre
  // (max norm) are border points and get Hoppe's kNN PCA. In [0, 1).
  void setBorderRatio (double r) { border_ratio_ = r; }
  double getBorderRatio () const { return border_ratio_; }
  // MERGED: leaves merge when their normals differ by less than this angle (0, 90) ...
  void setMergeAngle (double degrees) { merge_angle_deg_ = degrees; }
  double getMergeAngle () const { return merge_angle_deg_; }
  // ... and their union is at most this factor thicker than its thickest part (>= 1).
  void setMergeThicknessFactor (double f) { merge_thickness_factor_ = f; }
  double getMergeThicknessFactor () const { return merge_thickness_factor_; }
  // MERGED: quadric height field per region (default) or a plane.
  void setQuadricFit (bool q) { quadric_ = q; }
  bool getQuadricFit () const { return quadric_; }
  // MERGED: a point of a non-planar cell joins a neighbouring region if it lies within
  // this many RMS residuals of the region's surface (> 0); regions grow this way over
  // the search surface for up to getGrowthPasses () passes (planarity-aware borders).
  // Default 0.5: measured, a looser tolerance only lost accuracy (bunny σ = 0.0012:
  // 9.2° at 0.5, 9.6° at 1, 10.9° at 2).
  void setAdoptionTolerance (double t) { adoption_tolerance_ = t; }
  double getAdoptionTolerance () const { return adoption_tolerance_; }
  // MERGED: a region is only used when its fit's RMS residual is at most this factor ×
  // the median RMS residual of its patches' fits (default 1), or, with patches off
  // (setPatchSize (0)), × the median thickness of kNN planes sampled inside it (use 0.5):
  // i.e. when one surface explains the region as well as local fits do (noise, not
  // shape). 0 = always use.
  void setRegionValidationRatio (double r) { region_validation_ratio_ = r; }
  double getRegionValidationRatio () const { return region_validation_ratio_; }
  // MERGED: where no region or patch applies (on noisy input: every point), the support
  // is chosen per point from a ladder of kNN sizes (12, 18, 30, 50, 100, 200, ... up to
  // this many points; pclx::normals::selectScale): the largest whose PCA normal agrees
  // with every smaller one within getScaleAgreement () standard errors, the errors
  // computed with the noise of the whole cloud (getNoiseEstimate ()). Growth also stops
  // where the set turns one-sided (centroid off the point by > 0.3 of its radius plus 3
  // noise sigmas: a rim or a border; without that, a thin plate's rim took its sheets'
  // plane and MST flipped one sheet). Clean input stops at 50. <= getKSearch (): plain
  // Hoppe PCA. Default 200: the best fixed k at σ >= 0.006 of the diagonal on PCPNet and
  // fertility.
  void setMaxAdaptiveNeighbours (int n) { max_adaptive_neighbours_ = n; }
  int getMaxAdaptiveNeighbours () const { return max_adaptive_neighbours_; }
  // MERGED: ... and if the region's normal there is within this angle of the point's own
  // local plane (degrees, (0, 90]).
  void setAdoptionAngle (double degrees) { adoption_angle_deg_ = degrees; }
  double getAdoptionAngle () const { return adoption_angle_deg_; }
  // MERGED: planar leaves are cut into patch cells of at most this many points (default
  // 6), each with a quadric fitted over a disc of about getPatchSupport () points (default
  // 18, Hoppe's k) of the same leaf or merged region. Fewer, larger cells fit fewer
  // quadrics (the patch stage is the largest cost on clean input at 1M points); 4 -> 6
  // moved the clean wide RMS by -0.11..+0.02° (8: -0.22..+0.05°). 0: no patches (their points get the
  // adaptive kNN PCA, the previous behaviour).
  void setPatchSize (int max_points) { patch_size_ = max_points; }
  int getPatchSize () const { return patch_size_; }
  void setPatchSupport (int points) { patch_support_ = points; }
  int getPatchSupport () const { return patch_support_; }
  // A patch is used when its slope's standard error is below this angle (degrees, > 0);
  // its disc doubles up to getPatchScales () sizes (>= 1) to get there.
  void setMaxPatchSlopeError (double degrees) { max_patch_slope_deg_ = degrees; }
  double getMaxPatchSlopeError () const { return max_patch_slope_deg_; }
  void setPatchScales (int scales) { patch_scales_ = scales; }
  int getPatchScales () const { return patch_scales_; }
  // Lepski's agreement: rung normals may differ by this many standard errors of their
  // difference (> 0, default 2.5: on the wide set's noisy clouds 2 stopped too often by
  // chance, 3 let the bunnies' bias through; see pclx::normals::selectScale).
  void setScaleAgreement (double tau) { ladder_tau_ = tau; }
  double getScaleAgreement () const { return ladder_tau_; }
  // Noise wider than a spacing: the ladder runs once per cell (3 spacings), at its centroid,
  // and every member takes that rung. With this on, each member checks the rung on its own
  // neighbours (pclx::normals::keepsLargerRung) and climbs its own ladder where refused:
  // 151A σ = 0.006 19.87° -> 19.22° (oracle PCA 19.45°), the rest of the wide set within
  // 0.04°, but ~15 % more CPU there, which made it slower than PCA at the oracle's k = 100.
  // Off by default.
  void setCheckSharedRung (bool on) { check_shared_rung_ = on; }
  bool getCheckSharedRung () const { return check_shared_rung_; }
  // Input is noisy when the estimated noise exceeds this share of the point spacing (>= 0,
  // default 0.15; clean scans measure <= 0.05, σ = 0.0012 of the diagonal at 100k points
  // 0.27-0.41). Noisy input gets no regions and no patches (they are not even built): an
  // 18-point quadric lost to the ladder by 0.4-1.3°, region fits by 2°. A huge value keeps
  // them whatever the noise.
  void setMaxPatchNoiseRatio (double r) { max_patch_noise_ratio_ = r; }
  double getMaxPatchNoiseRatio () const { return max_patch_noise_ratio_; }
  void setGrowthPasses (int passes) { growth_passes_ = passes; }
  int getGrowthPasses () const { return growth_passes_; }
  // MERGED only (not in the seed): split a planar cell when a point lies farther than
  // this many RMS thicknesses from its plane (a minority surface across an edge). 0 = off.
  void setResidualSplitRatio (double r) { residual_split_ratio_ = r; }
  double getResidualSplitRatio () const { return residual_split_ratio_; }
  void setNumberOfThreads (unsigned int threads) { threads_ = threads; }

  // Per output point (same order as the output cloud), filled by compute ():
  const std::vector<std::uint8_t>& getPointStatus () const { return status_; }
  // Planar region of each output point: the leaf id for OCTREE/HYBRID planar leaves,
  // the merged region for MERGED (also for patch points: the region their leaf belongs
  // to), -1 where the normal did not come from a planar cell.
  const std::vector<int>& getRegionIds () const { return region_ids_; }
  // Number of points behind each output normal: the chosen kNN rung (KNN_PCA), the patch
  // fit's support, the region's points, the leaf's points; 0 for invalid points.
  const std::vector<int>& getSupportSizes () const { return support_sizes_; }
  // MERGED: noise of the search surface (sigma, spacing) as estimated by the last compute ().
  const pclx::normals::NoiseEstimate& getNoiseEstimate () const { return noise_; }
  // The octree of the last compute () (over the search surface).
  const pclx::normals::PlanarOctree& getOctree () const { return octree_; }

protected:
  bool initCompute () override;
  bool deinitCompute () override;
  void computeFeature (PointCloudOut& output) override;

private:
  // The parameter checks and the octree of initCompute ().
  bool prepare ();

  pclx::normals::PlanarOctreeParams params_;
  Method method_ = Method::MERGED;
  double border_ratio_ = 0.25;
  double merge_angle_deg_ = 15.0;
  double merge_thickness_factor_ = 1.5;
  double adoption_tolerance_ = 0.5;
  double residual_split_ratio_ = 5.0;
  bool quadric_ = true;
  bool thresholds_set_ = false;
  bool default_k_ = false;  // this compute () runs with kDefaultNeighbours
  int growth_passes_ = 32;
  double adoption_angle_deg_ = 15.0;
  double region_validation_ratio_ = 1.0;
  int max_adaptive_neighbours_ = 200;
  int patch_size_ = 6;
  int patch_support_ = 18;
  double max_patch_slope_deg_ = 2.0;
  int patch_scales_ = 3;
  double ladder_tau_ = 2.5;
  bool check_shared_rung_ = false;
  double max_patch_noise_ratio_ = 0.15;
  unsigned int threads_ = 0;
  pclx::normals::PlanarOctree octree_;
  // Installed when no search method is set (non-organized input): MERGED's own searches
  // then use a grid (pclx::normals::GridKnn), and the kd-tree is built only if another
  // path needs it.
  typename pcl::search::LazyKdTree<PointInT>::Ptr lazy_tree_;
  pclx::normals::NoiseEstimate noise_;
  std::vector<int> support_sizes_;
  std::vector<Eigen::Vector3f> surface_points_;
  std::vector<int> surface_to_octree_;  // surface index -> octree point, -1 if not finite
  std::vector<int> octree_to_surface_;
  std::vector<char> region_ok_;  // MERGED: region passed validation
  std::vector<std::uint8_t> status_;
  std::vector<int> region_ids_;
};

}  // namespace pcl

#ifdef PCL_NO_PRECOMPILE
#include <pclx/normals/impl/planar_octree_normal_estimation.hpp>
#endif
