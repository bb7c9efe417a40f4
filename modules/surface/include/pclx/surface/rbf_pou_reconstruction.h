#pragma once
#include <pcl/kdtree/kdtree.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_types.h>
#include <pcl/surface/reconstruction.h>

#include <pclx/surface/detail/hole_filling.h>

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace pclx {
namespace surface {
namespace detail {
template <typename PointNT> class SearchOverValidPoints;
}  // namespace detail
}  // namespace surface
}  // namespace pclx

namespace pcl {

/** \brief Implicit surface from oriented points by radial basis functions blended with a
  * partition of unity, polygonised by marching cubes (Musmanno 2016, ch. 4).
  *
  * - §4.2 (Carr et al. 2001): every point is a zero constraint; off-surface constraints at
  *   p ± ε·n carry the values ±ε, with ε halved per point until the created point's nearest
  *   input point is its origin.
  * - §4.3 (Tobor, Reuter and Schlick 2004): an octree splits the constraints until every
  *   subdomain (an octree cell enlarged by the overlap factor d) holds at most Tmax; leaves
  *   with fewer than Tmin grow (and shrink back) until Tmin ≤ n ≤ Tmax (§4.3.2). Each subdomain
  *   gets a local RBF fit f_i (polyharmonic r³ and a linear polynomial);
  *   F = Σ W_i f_i / Σ W_i with W_i = V ∘ D_i (Eqs. 4.4–4.6).
  *
  * On noisy input (a noise level measured from the points, or set) each fit approximates
  * instead of interpolating: Carr et al. 2001's smoothing spline (A + ρI) with a quadratic
  * polynomial, ρ chosen per subdomain so that the residual at the centres matches the noise.
  * A subdomain that holds two opposed sheets (the sides of a thin plate, told apart by their
  * normals) gets one height-field fit per side, combined by max or min as in Ohtake et al.
  * 2003's sharp features, so that the noise does not push the sides apart.
  * The zero set of F − iso is polygonised by marching cubes (PCL's tables) on a sparse grid:
  * only the cells within a band of the input points, so no sheets appear far from the data.
  * F is undefined where no subdomain covers a point (evaluate () gives NaN); band corners no
  * subdomain covers take the local fit of the nearest subdomain, so the band has no gaps.
  *
  * Bad input and parameters give a PCL_ERROR, an empty mesh and getLastError () (no
  * exceptions, as PCL's own reconstructions); so does reconstruct () without an input cloud.
  * NaN / Inf points and zero normals are dropped and counted.
  *
  * \code
  * pcl::RBFPOUReconstruction<pcl::PointNormal> rbf;
  * rbf.setInputCloud (cloud_with_oriented_normals);
  * pcl::PolygonMesh mesh;
  * rbf.reconstruct (mesh);  // empty mesh and rbf.getLastError () on failure
  * \endcode
  *
  * \note I. Tobor, P. Reuter, C. Schlick, 2004, "Efficient Reconstruction of Large Scattered
  * Geometric Datasets Using the Partition of Unity and Radial Basis Functions", WSCG;
  * R. M. Musmanno, 2016, "Estimação de Normais em Nuvens de Pontos para Reconstrução de
  * Superfícies 3D com Funções de Base Radial", MSc dissertation, UFF; J. C. Carr, R. K. Beatson,
  * J. B. Cherrie, T. J. Mitchell, W. R. Fright, B. C. McCallum, T. R. Evans, 2001,
  * "Reconstruction and Representation of 3D Objects with Radial Basis Functions", ACM SIGGRAPH;
  * Y. Ohtake, A. Belyaev, M. Alexa, G. Turk, H.-P. Seidel, 2003, "Multi-level Partition of
  * Unity Implicits", ACM SIGGRAPH (piecewise fits combined by max / min).
  * \tparam PointNT a point type with x, y, z and normal_x, normal_y, normal_z; other fields of
  * the output vertices come from the nearest input point
  * \ingroup surface
  */
template <typename PointNT>
class RBFPOUReconstruction : public SurfaceReconstruction<PointNT>
{
public:
  /** \brief Shared pointer. */
  using Ptr = shared_ptr<RBFPOUReconstruction<PointNT>>;
  /** \brief Shared pointer to const. */
  using ConstPtr = shared_ptr<const RBFPOUReconstruction<PointNT>>;
  using SurfaceReconstruction<PointNT>::input_;
  using SurfaceReconstruction<PointNT>::indices_;
  using SurfaceReconstruction<PointNT>::check_tree_;
  using SurfaceReconstruction<PointNT>::tree_;

  /** \brief The decay V of the weight functions (Eq. 4.6). */
  enum class Decay
  {
    LINEAR,  ///< Musmanno's V(d) = 1 − d: W continuous, not smooth at a subdomain border
    CUBIC    ///< Tobor et al.'s V(d) = 2d³ − 3d² + 1: W smooth
  };

  /** \brief Per-stage wall times (seconds) and counts of the last reconstruction. */
  struct Stats
  {
    double t_prepare = 0;      ///< filtering, spacing, noise, normal vote / orientation
    double t_off_surface = 0;  ///< off-surface constraints
    double t_octree = 0;       ///< octree and subdomains
    double t_fits = 0;         ///< local fits
    double t_extraction = 0;   ///< marching cubes (and hole filling)
    double t_output = 0;  ///< the output polygons, vertex normals / attributes and cloud (after extraction)
    std::size_t input_points = 0;    ///< points of the input
    std::size_t dropped_points = 0;  ///< points dropped: NaN / Inf position
    std::size_t zero_normals = 0;    ///< points dropped: zero or NaN / Inf normal
    std::size_t normals_voted = 0;     ///< normals flipped by the neighbour vote
    std::size_t normals_oriented = 0;  ///< normals flipped by the MST orientation
    std::size_t off_surface_points = 0;   ///< off-surface constraints made
    std::size_t eps_halved = 0;           ///< times ε was halved
    std::size_t off_surface_dropped = 0;  ///< off-surface constraints given up
    std::size_t subdomains = 0;      ///< subdomains (local fits)
    std::size_t grown = 0;           ///< subdomains grown to reach Tmin
    std::size_t over_tmax = 0;       ///< subdomains left above Tmax
    std::size_t fit_fallbacks = 0;   ///< fits that needed least squares
    std::size_t subdomain_centres = 0;  ///< Σ constraints over subdomains (8 bytes each are kept)
    std::size_t band_cells = 0;      ///< cells within the band
    std::size_t active_cells = 0;    ///< cells visited (all of the band without surface continuation)
    std::size_t corners = 0;         ///< corners where F was evaluated
    std::size_t uncovered_corners = 0;  ///< corners no subdomain covers, evaluated by the nearest subdomain's fit
    std::size_t waves = 0;           ///< surface continuation steps
    std::size_t vertices = 0;        ///< vertices of the mesh
    std::size_t triangles = 0;       ///< triangles of the mesh
    double mean_spacing = 0;         ///< mean nearest-neighbour distance of the points
    double grid_resolution = 0;      ///< marching-cubes cell size used
    double epsilon = 0;              ///< initial off-surface ε used
    double noise = 0;                      ///< σ the fits smooth for (0: they interpolate)
    double noise_ratio = 0;                ///< estimated σ / point spacing (when estimated)
    int min_constraints = 0;               ///< Tmin used (grown under noise)
    int max_constraints = 0;               ///< Tmax used (grown under noise)
    std::size_t smoothed_subdomains = 0;   ///< fits with a smoothing term ρ > 0
    std::size_t polynomial_subdomains = 0; ///< of those, fits by the least-squares polynomial alone
    std::size_t two_sheet_subdomains = 0;  ///< of those, fits of two opposed sheets (one per side)
    double density_spread = 0;   ///< 90th / 10th percentile of the 16th-neighbour distance
    double max_hole_size = 0;    ///< the largest hole closed (0: none)
    std::size_t holes = 0;         ///< boundary loops of the mesh
    std::size_t holes_filled = 0;  ///< of those, closed
    std::size_t hole_triangles = 0;           ///< triangles the closed holes added
    double hole_area = 0;                     ///< area of those triangles
    double t_holes = 0;                       ///< seconds of the hole filling (in t_extraction)
  };

  /** \brief An off-surface constraint. */
  struct Constraint
  {
    Eigen::Vector3f p;  ///< position
    float value;        ///< value of F there (±ε)
    int origin;         ///< the input point that made it (index into getFilteredPoints ())
  };

  /** \brief Constructor. The neighbour searches over the input points use the search of
    * setSearchMethod () when one is set, and otherwise a kd-tree of the class's own over the
    * valid points. */
  RBFPOUReconstruction () { check_tree_ = false; }

  /** \brief Set Tmax, the most constraints (input and off-surface points) per subdomain.
    * \param[in] t Tmax (≥ Tmin, default 150: about 50 input points, systems of at most 154
    * unknowns); checked by reconstruct ()
    */
  void setMaxPointsPerSubdomain (int t) { t_max_ = t; }
  /** \brief Get Tmax.
    * \return the most constraints per subdomain
    */
  int getMaxPointsPerSubdomain () const { return t_max_; }
  /** \brief Set Tmin, the fewest constraints per subdomain (smaller leaves grow).
    * \param[in] t Tmin (10 ≤ Tmin ≤ Tmax, default 50); checked by reconstruct ()
    */
  void setMinPointsPerSubdomain (int t) { t_min_ = t; }
  /** \brief Get Tmin.
    * \return the fewest constraints per subdomain
    */
  int getMinPointsPerSubdomain () const { return t_min_; }
  /** \brief Set the overlap factor d: a subdomain is its octree cell scaled by d about its
    * centre (d = 1 would leave F discontinuous across cell faces).
    * \param[in] d the factor (> 1, default 1.5)
    */
  void setOverlap (double d) { overlap_ = d; }
  /** \brief Get the overlap factor.
    * \return d
    */
  double getOverlap () const { return overlap_; }
  /** \brief Set the marching-cubes cell size.
    * \param[in] h the size (> 0); until set: 1.5 × the mean nearest-neighbour spacing
    */
  void setGridResolution (double h) { grid_resolution_ = h; grid_auto_ = false; }
  /** \brief Get the marching-cubes cell size set.
    * \return the size, 0 until set (the size used is in getStats ())
    */
  double getGridResolution () const { return grid_resolution_; }
  /** \brief Set the band: cells within that many cells (Chebyshev) of a cell holding an input
    * point are polygonised. Random samples leave gaps where the surface runs more than two
    * cells from every point cell, so a band of 2 can open a mesh.
    * \param[in] cells the band width (≥ 1, default 3)
    */
  void setBandWidth (int cells) { band_ = cells; }
  /** \brief Get the band width.
    * \return the width in cells
    */
  int getBandWidth () const { return band_; }
  /** \brief Surface continuation: F is evaluated at the cells holding a point, then only at
    * band cells reached across a face the surface crosses, wave by wave. This gives the same mesh
    * as polygonising the whole band, minus zero-set pieces that touch no cell holding a point
    * (sheets of F floating in the band), with a fraction of the evaluations.
    * \param[in] on true (default); false: F at every band corner
    */
  void setSurfaceContinuation (bool on) { continuation_ = on; }
  /** \brief Get whether surface continuation is on.
    * \return true when on
    */
  bool getSurfaceContinuation () const { return continuation_; }
  /** \brief Set the iso level of F that is polygonised.
    * \param[in] iso the level (default 0)
    */
  void setIsoLevel (double iso) { iso_ = iso; }
  /** \brief Get the iso level.
    * \return the level
    */
  double getIsoLevel () const { return iso_; }
  /** \brief Set the initial ε of the off-surface points.
    * \param[in] eps ε (> 0); until set: the mean spacing
    */
  void setOffSurfaceEpsilon (double eps) { epsilon_ = eps; epsilon_auto_ = false; }
  /** \brief Set the noise of the points along their normals, which the local fits smooth for.
    * \param[in] sigma standard deviation in the cloud's units (≥ 0, finite); 0 interpolates
    * every point. Until set, σ is estimated from quadric residuals around a few hundred points
    * and taken as 0 below a tenth of the mean spacing (clean samples).
    * \note Carr et al. 2001 (fitting with spline smoothing); the estimated value is in
    * getStats ().noise.
    */
  void setNoiseLevel (double sigma) { noise_ = sigma; noise_auto_ = false; }
  /** \brief Get the noise level set with setNoiseLevel ().
    * \return σ, 0 until set (the value used is in getStats ().noise)
    */
  double getNoiseLevel () const { return noise_; }
  /** \brief Close the holes of the mesh up to a size: scans leave holes where no view saw the
    * surface, and a hole closed smoothly is usually nearer the truth than a boundary.
    * \param[in] diameter the largest hole closed (the diagonal of its boundary's bounding box),
    * in the cloud's units; 0 leaves every hole open. Until set, holes up to
    * kAutoHoleFraction × the points' bounding-box diagonal are closed when the point density is
    * uneven, as in scans (getStats ().density_spread above kScanDensitySpread), and none
    * otherwise.
    * \note Each hole becomes a patch triangulated, refined and faired to meet the surface
    * (P. Liepa, 2003, "Filling Holes in Meshes", Eurographics Symposium on Geometry Processing,
    * as CGAL implements it); the closed area is in getStats ().
    */
  void setMaxHoleSize (double diameter) { max_hole_ = diameter; hole_auto_ = false; }
  /** \brief Get the size set with setMaxHoleSize ().
    * \return the diameter, 0 until set (the size used is in getStats ().max_hole_size)
    */
  double getMaxHoleSize () const { return hole_auto_ ? 0.0 : max_hole_; }
  /** \brief Automatic hole filling: the largest hole closed, as a share of the points'
    * bounding-box diagonal (occlusions scale with the object, not with the sampling). */
  static constexpr double kAutoHoleFraction = 0.25;
  /** \brief Automatic hole filling: density spread (the 90th / 10th percentile of the distance
    * to the 16th nearest neighbour) above which the input counts as a scan. */
  static constexpr double kScanDensitySpread = 1.55;
  /** \brief Set the decay of the weight functions.
    * \param[in] v the decay (default Decay::LINEAR)
    */
  void setDecay (Decay v) { decay_ = v; }
  /** \brief Get the decay of the weight functions.
    * \return the decay
    */
  Decay getDecay () const { return decay_; }
  /** \brief Orient the normals with pcl::MSTNormalOrientation first, for unoriented normals
    * (PCA, pcl::PlanarOctreeNormalEstimation). Without it, unoriented input gives a wrong F (a
    * warning is printed when the neighbour vote flips more than 10 % of the normals).
    * \param[in] on true to orient (default off)
    */
  void setOrientNormals (bool on) { orient_normals_ = on; }
  /** \brief Neighbour vote: a normal opposed (more than 120° away) to at least 6 of its 8
    * nearest neighbours' normals, counting only neighbours that lie on its tangent plane, is
    * flipped. Isolated flipped normals then cost nothing; the other side of a thin sheet and the
    * far side of a crease do not count, so correct normals are not turned.
    * \param[in] on true (default) to vote
    */
  void setNormalVote (bool on) { normal_vote_ = on; }
  /** \brief Set the number of OpenMP threads.
    * \param[in] threads the count; 0 (default): OpenMP's default
    */
  void setNumberOfThreads (unsigned int threads) { threads_ = threads; }

  /** \brief PCL's reconstruct, refused with a PCL_ERROR, getLastError () and an empty mesh when
    * no input cloud is set (the base class would dereference it).
    * \param[out] output the mesh (empty on failure)
    */
  void reconstruct (PolygonMesh& output) override;
  /** \brief PCL's reconstruct into a cloud and polygons, refused with a PCL_ERROR,
    * getLastError () and empty results when no input cloud is set.
    * \param[out] points the mesh vertices (empty on failure)
    * \param[out] polygons the triangles (empty on failure)
    */
  void reconstruct (PointCloud<PointNT>& points, std::vector<Vertices>& polygons) override;

  /** \brief Get the counts and timings of the last reconstruction.
    * \return the statistics
    */
  const Stats& getStats () const { return stats_; }
  /** \brief Get the reason of the last refused reconstruction.
    * \return the message, empty after a reconstruction that succeeded
    */
  const std::string& getLastError () const { return error_; }

  /** \brief The implicit function of the last reconstruction.
    * \param[in] p a point
    * \param[out] weight_sum if not null, receives Σ_i W_i(p) (0: uncovered)
    * \return F(p), NaN where no subdomain covers p
    */
  double evaluate (const Eigen::Vector3f& p, double* weight_sum = nullptr) const;
  /** \brief The normalised weights w_i(p) (Eq. 4.4) of the subdomains covering a point.
    * \param[in] p a point
    * \return the weights, one per covering subdomain
    */
  std::vector<double> weightsAt (const Eigen::Vector3f& p) const;
  /** \brief The off-surface constraints of the last reconstruction.
    * \return the constraints
    */
  const std::vector<Constraint>& getOffSurfaceConstraints () const { return off_; }
  /** \brief The valid input points of the last reconstruction.
    * \return their positions
    */
  const std::vector<Eigen::Vector3f>& getFilteredPoints () const { return pts_; }
  /** \brief The unit normals of the valid input points, after the vote and orientation.
    * \return the normals, parallel to getFilteredPoints ()
    */
  const std::vector<Eigen::Vector3f>& getFilteredNormals () const { return nrm_; }
  /** \brief The number of subdomains of the last reconstruction.
    * \return the count
    */
  std::size_t getNumberOfSubdomains () const { return subs_.size (); }

protected:
  /** \brief Get the class name.
    * \return "RBFPOUReconstruction"
    */
  std::string getClassName () const override { return "RBFPOUReconstruction"; }
  /** \brief Build F and polygonise it into a PolygonMesh (called by reconstruct ()).
    * \param[out] output the mesh (empty on failure)
    */
  void performReconstruction (PolygonMesh& output) override;
  /** \brief Build F and polygonise it into a cloud and polygons (called by reconstruct ()).
    * \param[out] points the mesh vertices (empty on failure)
    * \param[out] polygons the triangles (empty on failure)
    */
  void performReconstruction (PointCloud<PointNT>& points, std::vector<Vertices>& polygons) override;

private:
  // A triangle of the extraction (vertex indices), the type the hole filling takes.
  using Triangle = pclx::surface::detail::Triangle;

  struct Subdomain
  {
    Eigen::Vector3d lo, hi;     // the box Ω_i
    Eigen::Vector3d centre;     // local frame: q = (p − centre) / scale
    double scale;
    Eigen::Matrix<double, 10, 1> poly;  // [1 q q²] coefficients (quadratic ones 0 when interpolating)
    std::uint32_t first, count;         // range in sub_ids_ and sub_lambda_
    float smoothing = 0;                // ρ of the fit (0: interpolating, ∞: polynomial alone)
    bool rbf = true;                    // false: the r³ terms are all 0
    // Two opposed sheets, one fit each (poly and sheet_poly_ of this subdomain): f_i is their
    // max (+1: solid between the sheets), their min (−1: empty between), or poly alone (0).
    std::int8_t sheets = 0;
  };

  // An octree leaf before it becomes a subdomain: centre, half size of its enlarged box, the
  // constraints inside and the growth factor (0: dropped below Tmin).
  struct Leaf
  {
    Eigen::Vector3d c;
    double half;
    std::vector<std::uint32_t> ids;
    double scale = 1;
  };

  // Subdomains of one lookup bucket (a range of bucket_subs_); cached per thread because
  // neighbouring grid corners mostly fall in the same bucket.
  struct BucketCache
  {
    std::uint64_t key = ~std::uint64_t (0);
    std::size_t begin = 0, end = 0;
  };

  bool fail (const std::string& msg);
  bool build ();  // filtering, off-surface points, octree, fits
  // The stages of build (), in order.
  bool checkParameters ();
  bool collectPoints ();  // finite points with usable normals
  // The density spread of the points, and from it the largest hole to close.
  void measureDensitySpread (const pcl::KdTree<pcl::PointXYZ>& tree);
  // Closes the mesh's holes up to stats_.max_hole_size (a stage of extract ()).
  void closeHoles (std::vector<Eigen::Vector3f>& vertices, std::vector<Triangle>& triangles);
  // The search of setSearchMethod () over the input, answering for the valid points.
  std::unique_ptr<pclx::surface::detail::SearchOverValidPoints<PointNT>> searchOverValidPoints ();
  // Mean spacing, and every point's kNeighbours nearest neighbours for the vote (−1: fewer
  // found; empty without a vote).
  bool measureSpacing (const pcl::KdTree<pcl::PointXYZ>& tree, std::vector<int>& nn);
  bool orientNormals (const pcl::PointCloud<pcl::PointXYZ>::ConstPtr& xyz);
  // The noise σ, and the subdomain sizes that follow from it.
  void estimateNoise (const pcl::KdTree<pcl::PointXYZ>& tree);
  void voteNormals (const std::vector<int>& nn);
  void placeOffSurfaceConstraints (const pcl::KdTree<pcl::PointXYZ>& tree);
  std::vector<Leaf> splitOctree ();
  void growLeaves (std::vector<Leaf>& leaves);
  // Subdomains from the kept leaves (freed); returns the value h of every renumbered constraint
  // and, under noise, the input point that made it (`origin`, for its normal).
  std::vector<float> makeSubdomains (std::vector<Leaf>& leaves, std::vector<std::uint32_t>& origin);
  void buildBuckets ();
  void fitSubdomains (const std::vector<float>& value, const std::vector<std::uint32_t>& origin);
  // One local fit with np polynomial terms (4 or 10); false when it needed least squares.
  bool fitSubdomain (Subdomain& s, const std::vector<float>& value, const std::vector<std::uint32_t>& origin, int np);
  // Under noise, a subdomain holding two opposed sheets (a thin plate's sides) gets one
  // height-field fit per sheet; false (nothing set) when it holds one sheet or a fit misses.
  bool fitTwoSheets (Subdomain& s, const std::vector<float>& value, const std::vector<std::uint32_t>& origin);
  // Constraint c: an input point (c < pts_.size ()) or an off-surface point.
  const Eigen::Vector3f& constraintPosition (std::uint32_t c) const
  {
    return c < pts_.size () ? pts_[c] : off_[c - pts_.size ()].p;
  }
  // Marching cubes: vertex positions and triangles (vertex normals / attributes come after).
  bool extract (std::vector<Eigen::Vector3f>& vertices, std::vector<Triangle>& triangles);
  // The stages of extract (), in order.
  struct ExtractState;  // defined in the .hpp
  bool setUpExtractGrid (ExtractState& g);
  void findBand (ExtractState& g);
  void marchWaves (ExtractState& g);
  void evaluateFrontierCorners (ExtractState& g);
  void classifyFrontier (ExtractState& g);
  void sortCellsByKey (ExtractState& g);
  void collectCrossedEdges (ExtractState& g);
  void interpolateVertices (ExtractState& g, std::vector<Eigen::Vector3f>& vertices);
  void triangulateCells (const ExtractState& g, std::vector<Triangle>& triangles);
  // The output polygons from the triangles (freed), one allocation each: made after the
  // extraction's buffers are freed and before the output points, so that the peak holds neither.
  void makePolygons (std::vector<Triangle>& triangles, std::vector<Vertices>& polygons);
  // Output points: positions (then freed), the attributes of the nearest input point and
  // area-weighted normals, written through at (i) -> PointNT& (the cloud or the blob).
  template <typename At> void
  makeVertices (std::vector<Eigen::Vector3f>& vertices, const std::vector<Vertices>& polygons, At&& at);
  double weight (const Subdomain& s, const Eigen::Vector3d& p) const;
  double local (const Subdomain& s, const Eigen::Vector3d& p) const;
  template <typename F> void forCovering (const Eigen::Vector3d& p, BucketCache& cache, F&& f) const;
  double evaluateCached (const Eigen::Vector3d& p, BucketCache& cache, double* weight_sum = nullptr) const;
  // The local fit of the subdomain whose box is nearest to p, for band corners no subdomain
  // covers; `centres` is a kd-tree of the subdomain centres, built on the first call.
  double nearestLocal (const Eigen::Vector3d& p, std::unique_ptr<pcl::KdTreeFLANN<pcl::PointXYZ>>& centres) const;

  int t_max_ = 150, t_min_ = 50, band_ = 3;
  double overlap_ = 1.5, grid_resolution_ = 0, iso_ = 0, epsilon_ = 0, noise_ = 0;
  bool grid_auto_ = true, epsilon_auto_ = true, noise_auto_ = true, orient_normals_ = false, normal_vote_ = true;
  bool continuation_ = true, hole_auto_ = true;
  double max_hole_ = 0;
  Decay decay_ = Decay::LINEAR;
  unsigned int threads_ = 0;

  Stats stats_;
  std::string error_;
  std::vector<Eigen::Vector3f> pts_, nrm_;
  std::vector<int> src_;  // input index of every filtered point
  std::vector<Constraint> off_;
  std::vector<Subdomain> subs_;
  // The second sheet's fit of every subdomain (under noise only; used where sheets != 0).
  std::vector<Eigen::Matrix<double, 10, 1>> sheet_poly_;
  // Per subdomain: its centres (constraint numbers into cpos_) and their RBF weights λ (float:
  // half the memory of doubles, without a measurable change of the mesh): 8 bytes per centre,
  // where a local float copy of every centre would add 12 (docs/surface.md has the numbers).
  std::vector<std::uint32_t> sub_ids_;
  std::vector<float> sub_lambda_;
  std::vector<float> cpos_;  // x, y, z of every constraint, numbered in octree order
  // Subdomain lookup: the sorted keys of the buckets some subdomain overlaps; bucket b's
  // subdomains (ascending) are bucket_subs_[bucket_first_[b] .. bucket_first_[b + 1]).
  std::vector<std::uint64_t> bucket_keys_;
  std::vector<std::uint32_t> bucket_first_, bucket_subs_;
  Eigen::Vector3d bucket_origin_ = Eigen::Vector3d::Zero ();
  double bucket_size_ = 1;
};

}  // namespace pcl

#ifdef PCL_NO_PRECOMPILE
#include <pclx/surface/impl/rbf_pou_reconstruction.hpp>
#endif
