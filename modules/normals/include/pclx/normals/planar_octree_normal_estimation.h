#pragma once
#include <pclx/normals/detail/grid_knn.h>
#include <pclx/normals/detail/lazy_kd_tree.h>
#include <pclx/normals/detail/planar_octree.h>
#include <pclx/normals/detail/scale_selection.h>

#include <pcl/features/feature.h>

#include <cstdint>
#include <string>
#include <vector>

namespace pclx {
namespace normals {
namespace detail {
struct KnnScratch;
struct OrphanScratch;
}  // namespace detail
}  // namespace normals
}  // namespace pclx

namespace pcl {

/** \brief Normal estimation on the planarity octree of Musmanno (2016).
  *
  * The space is split until every cell holds an approximately planar patch (Musmanno's
  * Algorithm 1), and a point's normal comes from its cell (Algorithm 2). Three methods:
  * - OCTREE: Musmanno's method, the PCA plane of the point's leaf;
  * - HYBRID (Musmanno §5.4.3): Hoppe's kNN PCA for points near a cell border, the leaf plane inside;
  * - MERGED (Musmanno ch. 7, the default): adjacent leaves whose planes agree are merged into
  *   regions, each with one least-squares surface (a plane or a quadric height field,
  *   Musmanno's "polynomial fit"). Planar leaves are cut into patches of a few points, each
  *   with a quadric over a kNN-sized disc: the normal of most points on clean input, with no
  *   kNN search. A region replaces its patches only where it explains its points as well as
  *   they do. Every other point gets a kNN PCA normal whose support is chosen per point: a
  *   ladder of 12, 18, 30, 50, 100, 200 neighbours, the largest whose normal agrees with
  *   every smaller one within their standard errors (Lepski's rule), the errors computed
  *   with the noise of the whole cloud, estimated once. Noise makes supports grow; edges and
  *   fine detail stop them. On noisy input (setMaxPatchNoiseRatio ()) patches and regions
  *   are not used: the ladder serves every point.
  *
  * The output normals are unoriented (the sign of the fitted eigenvector or surface); orient
  * them with pcl::MSTNormalOrientation or pcl::orientNormalsTowardsViewpoint ().
  *
  * Every valid input point gets a finite normal. Invalid input points get a NaN normal and
  * curvature, as pcl::NormalEstimation gives them (status INVALID_POINT); points whose
  * neighbourhood spans no plane get the normal of the smallest enclosing octree cell that
  * does (status NEIGHBOUR_FALLBACK). Parameters are checked by compute (): a value out of
  * range prints PCL_ERROR and compute () returns an empty output.
  *
  * Usage:
  * \code
  * pcl::PlanarOctreeNormalEstimation<pcl::PointXYZ, pcl::Normal> ne;
  * ne.setInputCloud (cloud);
  * pcl::PointCloud<pcl::Normal> normals;
  * ne.compute (normals);
  * \endcode
  *
  * \note R. M. Musmanno, 2016, "Estimação de Normais em Nuvens de Pontos para Reconstrução
  * de Superfícies 3D com Funções de Base Radial", MSc dissertation, UFF; and H. Hoppe,
  * T. DeRose, T. Duchamp, J. McDonald, W. Stuetzle, 1992, "Surface Reconstruction from
  * Unorganized Points", ACM SIGGRAPH.
  * \ingroup normals
  */
template <typename PointInT, typename PointOutT>
class PlanarOctreeNormalEstimation : public Feature<PointInT, PointOutT>
{
public:
  /** \brief Shared pointer to an estimator. */
  using Ptr = shared_ptr<PlanarOctreeNormalEstimation<PointInT, PointOutT>>;
  /** \brief Shared pointer to a constant estimator. */
  using ConstPtr = shared_ptr<const PlanarOctreeNormalEstimation<PointInT, PointOutT>>;
  /** \brief The output cloud type. */
  using PointCloudOut = typename Feature<PointInT, PointOutT>::PointCloudOut;
  /** \brief The input cloud type. */
  using PointCloudIn = typename Feature<PointInT, PointOutT>::PointCloudIn;
  using Feature<PointInT, PointOutT>::feature_name_;
  using Feature<PointInT, PointOutT>::input_;
  using Feature<PointInT, PointOutT>::indices_;
  using Feature<PointInT, PointOutT>::surface_;
  using Feature<PointInT, PointOutT>::search_parameter_;

  /** \brief How a normal is derived from the octree. */
  enum class Method
  {
    OCTREE,  ///< the PCA plane of the point's leaf (Musmanno's Algorithm 2)
    HYBRID,  ///< the leaf plane inside a cell, Hoppe's kNN PCA near its border (Musmanno §5.4.3)
    MERGED   ///< merged regions, patches and the adaptive kNN ladder (the default)
  };

  /** \brief How each output normal was obtained (getPointStatus ()). */
  enum PointStatus : std::uint8_t
  {
    LEAF_PLANE = 0,          ///< PCA of the point's octree leaf (OCTREE, HYBRID inside)
    REGION_FIT = 1,          ///< surface fit of the point's merged region (MERGED)
    ADOPTED_REGION = 2,      ///< point of a non-planar cell that lies on an adjacent region (MERGED)
    KNN_PCA = 3,             ///< kNN PCA (HYBRID borders; MERGED: the ladder's k, getSupportSizes ())
    NEIGHBOUR_FALLBACK = 4,  ///< degenerate neighbourhood: normal of the enclosing cell that spans a plane
    INVALID_POINT = 5,       ///< NaN / Inf input point: NaN normal and curvature
    PATCH_FIT = 6            ///< MERGED: quadric of the point's patch cell and its surroundings
  };

  /** \brief Neighbours of the PCA fits at borders and fallbacks when neither setKSearch ()
    * nor setRadiusSearch () was called (PCL's defaults leave both unset). */
  static constexpr int kDefaultNeighbours = 18;

  /** \brief Empty constructor. */
  PlanarOctreeNormalEstimation () { feature_name_ = "PlanarOctreeNormalEstimation"; }

  /** \brief Set the method.
    * \param[in] m the method (default MERGED)
    */
  void setMethod (Method m) { method_ = m; }
  /** \brief Get the method.
    * \return the value of setMethod ()
    */
  Method getMethod () const { return method_; }
  /** \brief Set the planarity tolerances of Musmanno's Algorithm 1.
    *
    * A cell is planar when λ2 > sα·λ3 and sβ·λ2 > λ1 (λ1 ≥ λ2 ≥ λ3 the eigenvalues of its
    * covariance). Until set, OCTREE and HYBRID use Musmanno's sα = 6.25, sβ = 1.5, and
    * MERGED uses sα = 20, sβ = 1.5: a merged region's single surface fit needs flatter
    * cells than per-leaf PCA does (docs/normals.md).
    * \param[in] s_alpha sα, > 0 and finite
    * \param[in] s_beta sβ, > 0 and finite
    */
  void setPlanarityThresholds (double s_alpha, double s_beta)
  {
    params_.s_alpha = s_alpha;
    params_.s_beta = s_beta;
    thresholds_set_ = true;
  }
  /** \brief Get sα of the planarity test.
    * \return the value of setPlanarityThresholds (), else the method's default
    */
  double getSAlpha () const { return thresholds_set_ || method_ != Method::MERGED ? params_.s_alpha : 20.0; }
  /** \brief Get sβ of the planarity test.
    * \return the value of setPlanarityThresholds (), else 1.5
    */
  double getSBeta () const { return params_.s_beta; }
  /** \brief Set the maximum depth of the octree.
    * \param[in] depth the maximum depth, in [0, 21] (default 10)
    */
  void setMaxDepth (int depth) { params_.max_depth = depth; }
  /** \brief Get the maximum depth of the octree.
    * \return the value of setMaxDepth ()
    */
  int getMaxDepth () const { return params_.max_depth; }
  /** \brief Set the size below which cells are not split and never count as planar.
    * \param[in] n points per cell (>= 3; default 10)
    */
  void setMinPointsPerCell (int n) { params_.min_points = n; }
  /** \brief Get the size below which cells are not split.
    * \return the value of setMinPointsPerCell ()
    */
  int getMinPointsPerCell () const { return params_.min_points; }
  /** \brief HYBRID: set the width of a cell's border.
    *
    * Points farther than (1 − ratio) of the half edge from their cell's centre (max norm)
    * are border points and get Hoppe's kNN PCA.
    * \param[in] r the ratio, in [0, 1) (default 0.25)
    */
  void setBorderRatio (double r) { border_ratio_ = r; }
  /** \brief Get the border ratio.
    * \return the value of setBorderRatio ()
    */
  double getBorderRatio () const { return border_ratio_; }
  /** \brief MERGED: set the largest angle between the normals of leaves that merge.
    * \param[in] degrees the angle, in (0, 90) (default 15)
    */
  void setMergeAngle (double degrees) { merge_angle_deg_ = degrees; }
  /** \brief Get the merge angle.
    * \return the value of setMergeAngle (), in degrees
    */
  double getMergeAngle () const { return merge_angle_deg_; }
  /** \brief MERGED: set how much thicker than its thickest part a merged union may be.
    * \param[in] f the factor, >= 1 (default 1.5)
    */
  void setMergeThicknessFactor (double f) { merge_thickness_factor_ = f; }
  /** \brief Get the merge thickness factor.
    * \return the value of setMergeThicknessFactor ()
    */
  double getMergeThicknessFactor () const { return merge_thickness_factor_; }
  /** \brief MERGED: fit a quadric height field per region, or a plane.
    * \param[in] q true: quadric (default); false: plane
    */
  void setQuadricFit (bool q) { quadric_ = q; }
  /** \brief Get whether regions get a quadric fit.
    * \return the value of setQuadricFit ()
    */
  bool getQuadricFit () const { return quadric_; }
  /** \brief MERGED: set the tolerance of region growth.
    *
    * A point of a non-planar cell joins a neighbouring region if it lies within this many
    * RMS residuals of the region's surface; regions grow this way over the search surface
    * for up to getGrowthPasses () passes (planarity-aware borders). A looser tolerance
    * loses accuracy (docs/normals.md).
    * \param[in] t the tolerance, > 0 and finite (default 0.5)
    */
  void setAdoptionTolerance (double t) { adoption_tolerance_ = t; }
  /** \brief Get the adoption tolerance.
    * \return the value of setAdoptionTolerance ()
    */
  double getAdoptionTolerance () const { return adoption_tolerance_; }
  /** \brief MERGED: set when a region's fit is used.
    *
    * A region is used only when its fit's RMS residual is at most this factor × the median
    * RMS residual of its patches' fits, or, with patches off (setPatchSize (0)), × the
    * median thickness of kNN planes sampled inside it (use 0.5 there): that is, when one
    * surface explains the region as well as local fits do (noise, not shape).
    * \param[in] r the ratio, >= 0 (default 1; 0: always use)
    */
  void setRegionValidationRatio (double r) { region_validation_ratio_ = r; }
  /** \brief Get the region validation ratio.
    * \return the value of setRegionValidationRatio ()
    */
  double getRegionValidationRatio () const { return region_validation_ratio_; }
  /** \brief MERGED: set the largest support of the adaptive kNN ladder.
    *
    * Where no region or patch applies (on noisy input: every point), the support is chosen
    * per point from a ladder of kNN sizes (12, 18, 30, 50, 100, 200, ... up to this many
    * points): the largest whose PCA normal agrees with every smaller one within
    * getScaleAgreement () standard errors, the errors computed with the noise of the whole
    * cloud (getNoiseEstimate ()). Growth also stops where the set turns one-sided (a rim or
    * a border). Clean input stops at 50.
    * \param[in] n the largest support (default 200); <= getKSearch (): plain Hoppe PCA
    */
  void setMaxAdaptiveNeighbours (int n) { max_adaptive_neighbours_ = n; }
  /** \brief Get the largest support of the adaptive kNN ladder.
    * \return the value of setMaxAdaptiveNeighbours ()
    */
  int getMaxAdaptiveNeighbours () const { return max_adaptive_neighbours_; }
  /** \brief MERGED: set the largest angle between a region's normal and a point's own
    * local plane for the region to adopt the point.
    * \param[in] degrees the angle, in (0, 90] (default 15)
    */
  void setAdoptionAngle (double degrees) { adoption_angle_deg_ = degrees; }
  /** \brief Get the adoption angle.
    * \return the value of setAdoptionAngle (), in degrees
    */
  double getAdoptionAngle () const { return adoption_angle_deg_; }
  /** \brief MERGED: set the size of the patch cells.
    *
    * Planar leaves are cut into patch cells of at most this many points, each with a
    * quadric fitted over a disc of about getPatchSupport () points of the same leaf or
    * merged region. Larger cells fit fewer quadrics (docs/normals.md has the trade-off).
    * \param[in] max_points points per patch cell, >= 0 (default 6; 0: no patches, their
    * points get the adaptive kNN PCA)
    */
  void setPatchSize (int max_points) { patch_size_ = max_points; }
  /** \brief Get the size of the patch cells.
    * \return the value of setPatchSize ()
    */
  int getPatchSize () const { return patch_size_; }
  /** \brief MERGED: set the support of a patch's quadric.
    * \param[in] points points in the support, >= 3 (default 18, Hoppe's k)
    */
  void setPatchSupport (int points) { patch_support_ = points; }
  /** \brief Get the support of a patch's quadric.
    * \return the value of setPatchSupport ()
    */
  int getPatchSupport () const { return patch_support_; }
  /** \brief MERGED: set the largest standard error of a patch's slope.
    * \param[in] degrees the angle, in (0, 90) (default 2): a patch is used when its slope's
    * standard error is below it; its disc doubles up to getPatchScales () sizes to get there
    */
  void setMaxPatchSlopeError (double degrees) { max_patch_slope_deg_ = degrees; }
  /** \brief Get the largest standard error of a patch's slope.
    * \return the value of setMaxPatchSlopeError (), in degrees
    */
  double getMaxPatchSlopeError () const { return max_patch_slope_deg_; }
  /** \brief MERGED: set how many disc sizes a patch tries.
    * \param[in] scales the number of sizes, >= 1 (default 3)
    */
  void setPatchScales (int scales) { patch_scales_ = scales; }
  /** \brief Get how many disc sizes a patch tries.
    * \return the value of setPatchScales ()
    */
  int getPatchScales () const { return patch_scales_; }
  /** \brief Set Lepski's agreement of the kNN ladder.
    * \param[in] tau how many standard errors of their difference the normals of two rungs
    * may differ by, > 0 and finite (default 2.5; docs/normals.md explains the value)
    */
  void setScaleAgreement (double tau) { ladder_tau_ = tau; }
  /** \brief Get Lepski's agreement of the kNN ladder.
    * \return the value of setScaleAgreement ()
    */
  double getScaleAgreement () const { return ladder_tau_; }
  /** \brief Set whether each point checks a rung shared by its cell.
    *
    * With noise wider than a spacing, the ladder runs once per cell (3 spacings), at its
    * centroid, and every member takes that rung. With this on, each member checks the rung
    * on its own neighbours and climbs its own ladder where refused: more accurate near thin
    * parts and edges, at a noticeable CPU cost (docs/normals.md).
    * \param[in] on true: check (default false)
    */
  void setCheckSharedRung (bool on) { check_shared_rung_ = on; }
  /** \brief Get whether each point checks a rung shared by its cell.
    * \return the value of setCheckSharedRung ()
    */
  bool getCheckSharedRung () const { return check_shared_rung_; }
  /** \brief Set the noise above which the input counts as noisy.
    *
    * Input is noisy when the estimated noise exceeds this share of the point spacing; noisy
    * input gets no regions and no patches (they are not even built), since small quadrics
    * and region fits lose to the kNN ladder there (docs/normals.md).
    * \param[in] r the ratio, >= 0 (default 0.15; a huge value keeps regions and patches
    * whatever the noise)
    */
  void setMaxPatchNoiseRatio (double r) { max_patch_noise_ratio_ = r; }
  /** \brief Get the noise ratio above which the input counts as noisy.
    * \return the value of setMaxPatchNoiseRatio ()
    */
  double getMaxPatchNoiseRatio () const { return max_patch_noise_ratio_; }
  /** \brief MERGED: set the number of region growth passes.
    * \param[in] passes the number of passes, >= 0 (default 32)
    */
  void setGrowthPasses (int passes) { growth_passes_ = passes; }
  /** \brief Get the number of region growth passes.
    * \return the value of setGrowthPasses ()
    */
  int getGrowthPasses () const { return growth_passes_; }
  /** \brief MERGED: split a planar cell whose plane leaves a point far out.
    *
    * A planar cell is split when a point lies farther than this many RMS thicknesses from
    * its plane (a minority surface across an edge). Not in Musmanno's method.
    * \param[in] r the ratio, >= 0 (default 5; 0: off)
    */
  void setResidualSplitRatio (double r) { residual_split_ratio_ = r; }
  /** \brief Get the residual split ratio.
    * \return the value of setResidualSplitRatio ()
    */
  double getResidualSplitRatio () const { return residual_split_ratio_; }
  /** \brief Set the number of threads.
    * \param[in] threads threads to use; 0 (default): OpenMP's default
    */
  void setNumberOfThreads (unsigned int threads) { threads_ = threads; }

  /** \brief Get how each normal of the last compute () was obtained.
    * \return one PointStatus per output point, in output order
    */
  const std::vector<std::uint8_t>& getPointStatus () const { return status_; }
  /** \brief Get the planar region of each normal of the last compute ().
    * \return per output point: the leaf id for OCTREE / HYBRID planar leaves, the merged
    * region for MERGED (also for patch points: the region their leaf belongs to), -1 where
    * the normal did not come from a planar cell
    */
  const std::vector<int>& getRegionIds () const { return region_ids_; }
  /** \brief Get the number of points behind each normal of the last compute ().
    * \return per output point: the chosen kNN rung (KNN_PCA), the patch fit's support, the
    * region's points or the leaf's points; 0 for invalid points
    */
  const std::vector<int>& getSupportSizes () const { return support_sizes_; }
  /** \brief MERGED: get the noise of the search surface as estimated by the last compute ().
    * \return sigma (along the normal) and spacing of the search surface
    */
  const pclx::normals::detail::NoiseEstimate& getNoiseEstimate () const { return noise_; }
  /** \brief Get the octree of the last compute () (over the search surface), for diagnostics.
    * \return the octree
    */
  const pclx::normals::detail::PlanarOctree& getOctree () const { return octree_; }
  /** \brief Get the error of the last compute ()'s own checks.
    * \return the message it printed with PCL_ERROR for a parameter out of range or a search
    * surface that spans no plane; empty otherwise (pcl::Feature's input checks only print)
    */
  const std::string& getLastError () const { return last_error_; }

protected:
  /** \brief Checks the parameters and builds the octree.
    * \return false, with PCL_ERROR, on a parameter out of range or a search surface that
    * spans no plane
    */
  bool initCompute () override;
  /** \brief Gives back the user's k when compute () used kDefaultNeighbours.
    * \return the result of Feature::deinitCompute ()
    */
  bool deinitCompute () override;
  /** \brief Estimates the normals of the input points.
    * \param[out] output one normal per input index
    */
  void computeFeature (PointCloudOut& output) override;

private:
  struct ComputeState;
  struct NormalChoice;

  // The parameter checks and the octree of initCompute ().
  bool prepare ();
  // Prints a printf-style message with PCL_ERROR and keeps it for getLastError (); false.
  bool fail (const char* format, ...);

  // computeFeature ()'s stages, in order.
  void setUpCompute (ComputeState& s);
  void estimateNoise (ComputeState& s);
  void buildRegions (ComputeState& s);
  void validateRegionsByPatches (ComputeState& s);
  void validateRegionsByKnnThickness (ComputeState& s);
  void collectOrphans (ComputeState& s);
  void groupOrphans (ComputeState& s, double cell);
  void fitOrphansAdaptive (ComputeState& s);
  bool fitSharedRung (ComputeState& s, int group, const PointInT& query, bool grows,
                      pclx::normals::detail::OrphanScratch& scratch);
  void fitOrphansFixed (ComputeState& s);
  void growRegions (ComputeState& s);
  void writeNormals (ComputeState& s, PointCloudOut& output);
  void leafNormal (const ComputeState& s, int index, int leaf, const Eigen::Vector3f& x, NormalChoice& r) const;
  void searchedNormal (ComputeState& s, int index, const Eigen::Vector3f& x, pcl::Indices& nn,
                       std::vector<float>& dist, NormalChoice& r);
  void setRegionNormal (NormalChoice& r, int region, const Eigen::Vector3f& x) const;

  // The stages' tools.
  int knn (const ComputeState& s, const PointInT& query, int k, pcl::Indices& out, std::vector<float>& dist,
           pclx::normals::detail::KnnScratch& scratch) const;
  int validPatchOf (int octree_point) const;
  int bestRegion (const ComputeState& s, const Eigen::Vector3f& x, const Eigen::Vector3f* own, const pcl::Indices& nn,
                  const std::vector<int>& region_of) const;
  bool ladderPlane (const ComputeState& s, const Eigen::Vector3f& x, const pcl::Indices& candidates,
                    const std::vector<Eigen::Vector3f>& positions, pcl::Indices& nn,
                    std::vector<std::uint64_t>& by_distance, std::vector<Eigen::Vector3f>& sorted,
                    Eigen::Vector3f& normal, float& curvature, int& support, const std::vector<int>& use_rungs) const;
  bool localPlane (const ComputeState& s, const PointCloudIn& cloud, int index, pcl::Indices& nn,
                   Eigen::Vector3f& normal, float& curvature, int& support);

  pclx::normals::detail::PlanarOctreeParams params_;
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
  pclx::normals::detail::PlanarOctree octree_;
  // Installed when no search method is set (non-organized input): MERGED's own searches
  // then use a grid (pclx::normals::detail::GridKnn), and the kd-tree is built only if
  // another path needs it.
  typename pclx::normals::detail::LazyKdTree<PointInT>::Ptr lazy_tree_;
  pclx::normals::detail::NoiseEstimate noise_;
  std::vector<int> support_sizes_;
  std::vector<Eigen::Vector3f> surface_points_;
  std::vector<int> surface_to_octree_;  // surface index -> octree point, -1 if not finite
  std::vector<int> octree_to_surface_;
  std::vector<char> region_ok_;  // MERGED: region passed validation
  std::vector<std::uint8_t> status_;
  std::vector<int> region_ids_;
  std::string last_error_;
};

}  // namespace pcl

#ifdef PCL_NO_PRECOMPILE
#include <pclx/normals/impl/planar_octree_normal_estimation.hpp>
#endif
