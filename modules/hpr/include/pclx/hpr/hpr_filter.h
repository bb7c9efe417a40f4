#pragma once

#include <pcl/PolygonMesh.h>
#include <pcl/filters/filter_indices.h>
#include <pcl/point_types.h>
#include <pclx/hpr/detail/visibility.h>

#include <string>
#include <vector>

namespace pcl {

/** \brief HPRFilter removes the points of a cloud that are hidden from a viewpoint: the
  * hidden point removal (HPR) operator of Katz et al., with its exact convex-hull form and
  * the fast approximate angular-grid form of Machado e Silva et al.
  *
  * The kept indices are the visible points, the removed indices the hidden ones;
  * setNegative (), setKeepOrganized () and setIndices () behave as in every
  * pcl::FilterIndices. Points with a NaN or infinite coordinate are never visible.
  *
  * \code
  * pcl::HPRFilter<pcl::PointXYZ> hpr;
  * hpr.setInputCloud (cloud);
  * hpr.setViewPoint (Eigen::Vector3f (0, 0, 2));
  * pcl::Indices visible;
  * hpr.filter (visible);   // or hpr.filter (visible_cloud)
  * \endcode
  *
  * By default the flip radius R, the number of sectors k and the propagation length are
  * calibrated from the cloud itself by the balls-in-bins estimate of Machado e Silva et
  * al. 2014, §6.
  *
  * Flat input seen edge-on (every point, to float precision, in one plane through the
  * viewpoint, or on one line) is entirely visible for every method: each point lies on the
  * silhouette of a sheet seen exactly edge-on, which is also the limit of HPR as the
  * viewpoint approaches the plane. Normals are NaN there (no normal faces the viewer).
  *
  * Far viewpoints: p − C is formed in double and the calibrated R grows as the square of
  * the distance (the same angular occlusion criterion at every distance), so the calibrated
  * results hold from about one to a thousand cloud diameters away.
  *
  * A bad setter argument is refused with PCL_ERROR and the previous value is kept; a
  * request that cannot be served for the current cloud (e.g. R below the distance of the
  * farthest point) prints PCL_ERROR, keeps no point and is readable through getLastError ().
  *
  * \note R. Machado e Silva, C. Esperança, R. Marroquim, A. A. F. Oliveira, 2014, "Image
  * Space Rendering of Point Clouds Using the HPR Operator", Computer Graphics Forum 33(1);
  * S. Katz, A. Tal, R. Basri, 2007, "Direct Visibility of Point Sets", ACM SIGGRAPH. The
  * Bentley–Faust–Preparata, Kavan and hybrid hulls follow the long form: R. G. Machado e
  * Silva, 2012, "Renderização Eficiente de Nuvens de Pontos Baseada no Operador HPR", MSc
  * dissertation, UFRJ/COPPE.
  * \ingroup hpr
  */
template <typename PointT>
class HPRFilter : public FilterIndices<PointT>
{
protected:
  /** \brief The input and output cloud type. */
  using PointCloud = typename FilterIndices<PointT>::PointCloud;
  /** \brief Shared pointer to a PointCloud. */
  using PointCloudPtr = typename PointCloud::Ptr;
  /** \brief Shared pointer to a const PointCloud. */
  using PointCloudConstPtr = typename PointCloud::ConstPtr;

public:
  /** \brief Shared pointer to an HPRFilter. */
  using Ptr = shared_ptr<HPRFilter<PointT>>;
  /** \brief Shared pointer to a const HPRFilter. */
  using ConstPtr = shared_ptr<const HPRFilter<PointT>>;

  /** \brief The visibility operator to run. */
  enum class Method
  {
    /** EXACT for small clouds (up to kAutoExactLimit finite points) and whenever R is given
      * (setRadius (), setGamma ()); ANGULAR_GRID when a view resolution is set;
      * CANDIDATE_HULL otherwise. */
    AUTO,
    /** Katz et al. 2007: Qhull on the flipped cloud, after an exact interior pre-filter. */
    EXACT,
    /** Machado e Silva et al. 2014, §4: sector candidates plus propagation. */
    ANGULAR_GRID,
    /** Every point not strictly inside a tetrahedron (C, a, b, c) of neighbouring grid
      * candidates in flipped space, then the survivors again on finer grids
      * (setRefinementPasses ()). Keeps every hull vertex of the exact operator at the same R. */
    CANDIDATE_HULL,
    /** Machado e Silva 2012, §3.1: grid extremes, then the exact hull of those. */
    BENTLEY_FAUST_PREPARATA,
    /** Machado e Silva 2012, §3.2 (Kavan et al.): sector candidates refined against all
      * other candidates, O(k²). */
    KAVAN,
    /** Machado e Silva 2012, §3.3: sector candidates, then the exact hull of those. */
    HYBRID
  };

  /** \brief How the angular grid propagates candidates between sectors. */
  enum class Propagation
  {
    ADAPTIVE,  ///< scatter from the changed sectors until stable or ℓ steps (Machado e Silva et al. 2014, §4.3)
    FIXED      ///< one gather pass over an m×m neighbourhood (Machado e Silva 2012, §4.3.2)
  };

  /** \brief Where the flip radius R comes from. */
  enum class RadiusMode
  {
    AUTO,      ///< calibrated from the angular separation of visible points (Machado e Silva et al. 2014, §6)
    ABSOLUTE,  ///< R as given to setRadius ()
    GAMMA      ///< R = max‖p − C‖ · 10^γ, Katz et al.'s parametrisation (setGamma ())
  };

  /** \brief Constructor.
    * \param[in] extract_removed_indices set to true to read the hidden points with getRemovedIndices ()
    */
  HPRFilter (bool extract_removed_indices = false) : FilterIndices<PointT> (extract_removed_indices)
  {
    filter_name_ = "HPRFilter";
  }

  /** \brief Set the viewpoint C (in the coordinates of the input cloud).
    * \param[in] c the viewpoint; a non-finite one is refused (PCL_ERROR, previous value kept)
    */
  void
  setViewPoint (const Eigen::Vector3f& c);

  /** \brief Get the viewpoint C.
    * \return the viewpoint
    */
  const Eigen::Vector3f&
  getViewPoint () const
  {
    return viewpoint_;
  }

  /** \brief Set the flip radius R directly (RadiusMode::ABSOLUTE).
    * \param[in] radius R, a finite number > 0; it must also exceed the distance from the
    * viewpoint to the farthest point, which filter () checks
    */
  void
  setRadius (double radius);

  /** \brief Set R = max‖p − C‖ · 10^γ (RadiusMode::GAMMA); Katz et al. use γ around 2–4
    * for dense clouds.
    * \param[in] gamma γ, a finite number > 0
    */
  void
  setGamma (double gamma);

  /** \brief Calibrate R from the cloud (RadiusMode::AUTO, the default): a point
    * `occlusion_depth` × the cloud radius behind two neighbouring visible points is hidden
    * (Machado e Silva et al. 2014, §6, Fig. 9). CANDIDATE_HULL calibrates its own R at 0.8 of
    * this depth, or deeper on noisy input (see docs/hpr.md).
    * \param[in] occlusion_depth the depth relative to the cloud radius, a finite number > 0
    */
  void
  setAutoRadius (double occlusion_depth = 0.05);

  /** \brief Get where R comes from.
    * \return the radius mode set by the last of setRadius (), setGamma (), setAutoRadius ()
    */
  RadiusMode
  getRadiusMode () const
  {
    return radius_mode_;
  }

  /** \brief Set the visibility operator.
    * \param[in] m the method (Method::AUTO by default)
    */
  void
  setMethod (Method m)
  {
    method_ = m;
  }

  /** \brief Get the visibility operator requested.
    * \return the method set by setMethod ()
    */
  Method
  getMethod () const
  {
    return method_;
  }

  /** \brief Set the number of sectors k of the approximate methods. Sectors are square in
    * angle, so k is approximate; k above kMaxSectors or 64 per point is clamped with a warning.
    * \param[in] k the number of sectors (0, the default: calibrated)
    */
  void
  setSectorCount (std::size_t k)
  {
    sectors_ = k;
  }

  /** \brief Get the number of sectors requested.
    * \return k as set by setSectorCount () (0: calibrated)
    */
  std::size_t
  getSectorCount () const
  {
    return sectors_;
  }

  /** \brief Set the number of sectors per expected visible-point cell of the calibrated k.
    * \param[in] factor a finite number > 0 (default 4)
    */
  void
  setGridOversampling (double factor);

  /** \brief Cap k at what a viewport shows, so that k follows the screen rather than the
    * cloud size; with a cap, Method::AUTO runs ANGULAR_GRID.
    * \param[in] pixels the viewport's size in pixels (<= 0: no cap)
    * \param[in] fov its field of view in radians, a finite number > 0 when pixels > 0
    */
  void
  setViewResolution (int pixels, double fov);

  /** \brief Set how the angular grid propagates candidates.
    * \param[in] mode adaptive (scatter) or fixed (gather) propagation
    * \param[in] steps adaptive: the number of steps ℓ (0: calibrated, < 0 refused); fixed:
    * the mask size m, odd and >= 1
    */
  void
  setPropagation (Propagation mode, int steps = 0);

  /** \brief Set the number of CANDIDATE_HULL culling passes over the survivors of the
    * first, on grids 2×, 4×, ... finer at the same R. Each halves the size of the triangles,
    * so the depth band in which hidden points survive shrinks 4×; the test stays conservative.
    * \param[in] passes 0..8 (default 2)
    */
  void
  setRefinementPasses (int passes);

  /** \brief Get the number of CANDIDATE_HULL refinement passes.
    * \return the number of passes
    */
  int
  getRefinementPasses () const
  {
    return refinement_;
  }

  /** \brief Cull the points that are provably interior before Qhull (Method::EXACT). The
    * visible set is the same either way.
    * \param[in] on true (the default) to pre-filter
    */
  void
  setExactPrefilter (bool on)
  {
    exact_prefilter_ = on;
  }

  /** \brief Compute a partial view-dependent reconstruction: the hull triangles (exact
    * methods) or the grid triangles (Machado e Silva et al. 2014, §4.4) of the visible
    * points. Read it with getMesh () after filter ().
    * \param[in] on true to compute the mesh
    * \param[in] max_edge triangles with a longer edge are dropped (<= 0: 5 × the median edge)
    */
  void
  setReconstructMesh (bool on, float max_edge = 0.f)
  {
    reconstruct_ = on;
    max_edge_ = max_edge;
  }

  /** \brief Compute per-point normals facing the viewpoint (Machado e Silva et al. 2014,
    * §5.3) and splat radii (§5.5) of the visible points. Read them with getNormals () and
    * getSplatRadii () after filter ().
    * \param[in] on true to compute them
    */
  void
  setComputeNormals (bool on)
  {
    compute_normals_ = on;
  }

  /** \brief Set the number of OpenMP threads, as pcl::NormalEstimationOMP. The result does
    * not depend on it.
    * \param[in] threads the number of threads; 0 (the default) decides per call from the
    * cloud size and the cores other processes leave free
    */
  void
  setNumberOfThreads (unsigned int threads = 0)
  {
    threads_ = threads;
  }

  /** \brief Get the number of threads the last filter () used.
    * \return the number of threads
    */
  int
  getThreadsUsed () const
  {
    return threads_used_;
  }

  /** \brief Give back the working memory kept between calls. The filter keeps buffers sized
    * for the largest cloud so far, so that a filter run on every frame does not fault in
    * fresh pages each time; a copy of a filter starts without them.
    */
  void
  releaseWorkingMemory ()
  {
    workspace_.release ();
  }

  /** \brief Get the mesh of the last filter () (see setReconstructMesh ()).
    * \return the mesh: the input cloud and triangles facing the viewpoint
    */
  const PolygonMesh&
  getMesh () const
  {
    return mesh_;
  }

  /** \brief Get the normals of the last filter () (see setComputeNormals ()).
    * \return one normal per input point, NaN for the points that are not visible
    */
  const pcl::PointCloud<pcl::Normal>&
  getNormals () const
  {
    return normals_;
  }

  /** \brief Get the splat radii of the last filter () (see setComputeNormals ()).
    * \return one radius per input point, 0 for the points that are not visible
    */
  const std::vector<float>&
  getSplatRadii () const
  {
    return splat_radii_;
  }

  /** \brief Get the flip radius R the last filter () used.
    * \return R (0 when nothing was computed)
    */
  double
  getRadiusUsed () const
  {
    return radius_used_;
  }

  /** \brief Get the number of sectors the last filter () used.
    * \return k (0 for the exact method and when nothing was computed)
    */
  std::size_t
  getSectorCountUsed () const
  {
    return sectors_used_;
  }

  /** \brief Get the number of propagation steps the last filter () used.
    * \return the number of steps
    */
  int
  getPropagationStepsUsed () const
  {
    return steps_used_;
  }

  /** \brief Get the method the last filter () ran (what Method::AUTO chose).
    * \return the method
    */
  Method
  getMethodUsed () const
  {
    return method_used_;
  }

  /** \brief Get why the last filter () kept no point.
    * \return the message printed with PCL_ERROR, empty when the last call succeeded
    */
  const std::string&
  getLastError () const
  {
    return last_error_;
  }

  /** \brief Largest grid the approximate methods accept (also at most 64 sectors per
    * point); larger requests are clamped with a warning. */
  static constexpr std::size_t kMaxSectors = pclx::hpr::detail::kMaxSectors;
  /** \brief Up to this many finite points, Method::AUTO runs the exact method. */
  static constexpr std::size_t kAutoExactLimit = 20000;

protected:
  using FilterIndices<PointT>::filter_name_;
  using FilterIndices<PointT>::getClassName;
  using FilterIndices<PointT>::input_;
  using FilterIndices<PointT>::indices_;
  using FilterIndices<PointT>::negative_;
  using FilterIndices<PointT>::extract_removed_indices_;
  using FilterIndices<PointT>::removed_indices_;

  /** \brief Filtered results are indexed by an indices array.
    * \param[out] indices the indices of the visible points (hidden ones when negative)
    */
  void
  applyFilter (Indices& indices) override;

private:
  using Gathered = pclx::hpr::detail::GatheredPoints;

  // applyFilter's stages. Clear every output of the previous call.
  void
  resetOutputs (Indices& indices);
  // Keep nothing: print `why`, remember it for getLastError (), every requested index removed.
  void
  reject (const std::string& why, Indices& indices);
  // The finite requested points relative to the viewpoint (workspace_.points, their input
  // indices in workspace_.finite), with the statistics computeVisibility would gather.
  void
  gatherFinitePoints (Gathered& in);
  // The method AUTO stands for, and the core's options for this call.
  pclx::hpr::detail::VisibilityOptions
  makeOptions (const Gathered& in);
  // Kept and removed indices from the visibility of the finite points, in request order.
  void
  writeIndices (const pclx::hpr::detail::VisibilityResult& res, const Gathered& in, Indices& indices);
  // getMesh (), getNormals () and getSplatRadii () from the core's result.
  void
  writeMeshAndNormals (const pclx::hpr::detail::VisibilityResult& res);

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
  std::string last_error_;
  pclx::hpr::detail::VisibilityWorkspace workspace_;
};

}  // namespace pcl

#ifdef PCL_NO_PRECOMPILE
#include <pclx/hpr/impl/hpr_filter.hpp>
#endif
