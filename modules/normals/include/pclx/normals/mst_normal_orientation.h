#pragma once
#include <pcl/point_cloud.h>
#include <pcl/search/search.h>

#include <cstddef>
#include <string>

namespace pclx {
namespace normals {
namespace detail {
struct MstGraph;
}  // namespace detail
}  // namespace normals
}  // namespace pclx

namespace pcl {

/** \brief Consistent orientation of unoriented normals by Hoppe's minimum spanning tree,
  * with a global visibility check.
  *
  * The stages, as in Hoppe et al. (Musmanno 2016, §5.3.2):
  * - the Riemannian graph: a symmetric kNN graph with edge cost 1 − |ni·nj| (plus a tiny
  *   length term that only breaks ties, setDistanceTieBreak (), and a penalty for edges
  *   that leave the tangent planes, setAcrossSurfacePenalty ());
  * - its minimum spanning forest (Kruskal with Boost's disjoint sets);
  * - in every component a traversal from its highest point, flipping each child to agree
  *   with its parent (ni·nj > 0; across a sharp edge or a fold, by the side the edge vector
  *   leaves the two tangent planes: setEdgeSideSignificance ()).
  *
  * One wrong crossing flips everything downstream of it, which no local rule can see. The
  * signs are therefore checked against a global cue, visibility: seen from outside (26
  * orthographic directions), a closed surface's visible points face the viewer; holes
  * between the samples of the front surface are closed first, so that no point is seen
  * through them. Every vertex's votes are weighed against the cost of overruling each tree
  * crossing, and the best set of crossings to overrule is found exactly by dynamic
  * programming over the tree (setVisibilityWeight ()). An open sheet's votes cancel. Where
  * the votes leave a component's sign open, its extreme points in 21 directions of the
  * upper hemisphere vote it: outward on closed shapes, "up" on open sheets (Hoppe et al.
  * point the root's normal to +z, which one crease point at the top can get wrong).
  *
  * Usage:
  * \code
  * pcl::MSTNormalOrientation<pcl::PointXYZ, pcl::Normal> mst;
  * mst.setInputCloud (cloud);
  * mst.setKSearch (10);
  * if (!mst.orient (*normals))  // normals: one per point of cloud, oriented in place
  *   return;
  * \endcode
  *
  * \note R. M. Musmanno, 2016, "Estimação de Normais em Nuvens de Pontos para Reconstrução
  * de Superfícies 3D com Funções de Base Radial", MSc dissertation, UFF; and H. Hoppe,
  * T. DeRose, T. Duchamp, J. McDonald, W. Stuetzle, 1992, "Surface Reconstruction from
  * Unorganized Points", ACM SIGGRAPH; the closing of the z-buffer's holes follows
  * J. P. Grossman, W. J. Dally, 1998, "Point Sample Rendering", Eurographics Workshop on
  * Rendering.
  * \ingroup normals
  */
template <typename PointT, typename NormalT>
class MSTNormalOrientation
{
public:
  /** \brief Shared pointer to a constant input cloud. */
  using PointCloudConstPtr = typename PointCloud<PointT>::ConstPtr;
  /** \brief Shared pointer to a search method. */
  using SearchPtr = typename search::Search<PointT>::Ptr;

  /** \brief Set the points whose normals orient () orients.
    * \param[in] cloud the input cloud
    */
  void setInputCloud (const PointCloudConstPtr& cloud) { input_ = cloud; }
  /** \brief Set the number of neighbours per point in the Riemannian graph.
    * \param[in] k neighbours per point (>= 1, checked by orient (); default 10)
    */
  void setKSearch (int k) { k_ = k; }
  /** \brief Get the number of neighbours per point in the Riemannian graph.
    * \return the value of setKSearch ()
    */
  int getKSearch () const { return k_; }
  /** \brief Set the search method for the graph's kNN queries (optional).
    *
    * By default FLANN's kd-tree (what pcl::search::KdTree builds) over the valid points is
    * queried directly, which is faster per query than going through pcl::search.
    * \param[in] search the search method; its input cloud is replaced by orient ()
    */
  void setSearchMethod (const SearchPtr& search) { search_ = search; }
  /** \brief Set the number of threads.
    * \param[in] threads threads to use; 0 (default): OpenMP's default
    */
  void setNumberOfThreads (unsigned int threads) { threads_ = threads; }
  /** \brief Set the weight of the length term of the edge cost.
    *
    * The edge cost is 1 − |ni·nj| + w · length / mean length: a small w only breaks ties
    * between equally parallel normals in favour of the shorter edge.
    * \param[in] w the weight (default 1e-3)
    */
  void setDistanceTieBreak (double w) { tie_break_ = w; }
  /** \brief Get the weight of the length term of the edge cost.
    * \return the value of setDistanceTieBreak ()
    */
  double getDistanceTieBreak () const { return tie_break_; }
  /** \brief Set the penalty for edges that leave the tangent planes.
    *
    * Adds w · max(|ni·ê|, |nj·ê|) to the cost of edge e (unit ê): edges that leave the
    * tangent plane (across a thin part) are avoided. For normals more than 60° apart (a
    * sharp edge) it adds w · (1 − min(|ni·ê|, |nj·ê|)) instead: the crossing that leaves both
    * tangent planes is the one whose side can be read. 0 gives Hoppe's cost.
    * \param[in] w the penalty weight (default 0.5; docs/normals.md explains the value)
    */
  void setAcrossSurfacePenalty (double w) { across_penalty_ = w; }
  /** \brief Get the penalty for edges that leave the tangent planes.
    * \return the value of setAcrossSurfacePenalty ()
    */
  double getAcrossSurfacePenalty () const { return across_penalty_; }
  /** \brief Set the noise of the positions along the normal.
    * \param[in] sigma a length, e.g. the estimator's getNoiseEstimate ().sigma; negative
    * (default): orient () estimates it from about 500 points; not finite: orient () fails
    */
  void setNoiseScale (double sigma) { noise_scale_ = sigma; }
  /** \brief Get the noise scale as set.
    * \return the value of setNoiseScale ()
    */
  double getNoiseScale () const { return noise_scale_; }
  /** \brief Get the noise the last orient () used (given or estimated).
    * \return the noise scale, a length
    */
  double getUsedNoiseScale () const { return used_noise_; }
  /** \brief Set how significant an edge's side must be to decide a crossing.
    *
    * Nearly parallel normals (a fold: the faces of a thin part, or of a ridge or groove
    * narrower than the graph's edges, look parallel to Hoppe's rule, which flips one face)
    * take their relative sign from the edge's side where both lean off the edge vector e by
    * more than this many noise sigmas plus a quarter of the mean edge plus 0.5 |e|: that
    * offset is geometry, not noise. Such crossings, and sharp-edge crossings above the same
    * floor, count half their turn in the cost.
    * \param[in] z the significance in noise sigmas (finite and >= 0, checked by orient ();
    * default 4)
    */
  void setEdgeSideSignificance (double z) { side_significance_ = z; }
  /** \brief Get the edge-side significance.
    * \return the value of setEdgeSideSignificance ()
    */
  double getEdgeSideSignificance () const { return side_significance_; }
  /** \brief Set the weight of the visibility votes.
    * \param[in] w weight of the votes against the cost of overruling the tree's crossings
    * (finite and >= 0, checked by orient (); default 1; 0: the tree's crossings alone)
    */
  void setVisibilityWeight (double w) { visibility_weight_ = w; }
  /** \brief Get the weight of the visibility votes.
    * \return the value of setVisibilityWeight ()
    */
  double getVisibilityWeight () const { return visibility_weight_; }

  /** \brief Orient normals consistently, in place.
    *
    * Points or normals that are not finite, and zero normals, stay out of the graph and are
    * left untouched.
    * \param[in,out] normals one normal per input point
    * \return false, with PCL_ERROR and the normals untouched, on bad input (no cloud, size
    * mismatch, k < 1, a setter's value out of range, too many edges for 32-bit ids)
    */
  bool orient (PointCloud<NormalT>& normals);

  /** \brief Get the number of connected components of the last orient ()'s graph.
    * \return the number of components
    */
  std::size_t getNumberOfComponents () const { return components_; }
  /** \brief Get the number of normals the last orient () flipped.
    * \return the number of flipped normals
    */
  std::size_t getNumberOfFlipped () const { return flipped_; }
  /** \brief Get the number of edges of the last orient ()'s graph.
    * \return the number of undirected edges
    */
  std::size_t getNumberOfEdges () const { return edges_; }
  /** \brief Get the number of points whose sign the visibility votes decided against the
    * tree's propagation in the last orient ().
    * \return the number of points
    */
  std::size_t getNumberOfVisibilityFlips () const { return visibility_flipped_; }
  /** \brief Get the error of the last orient ().
    * \return the message it printed with PCL_ERROR; empty when it succeeded
    */
  const std::string& getLastError () const { return last_error_; }

private:
  /** \brief The checks of orient ()'s input and parameters (PCL_ERROR on failure). */
  bool checkParameters (const PointCloud<NormalT>& normals);
  /** \brief Prints a printf-style message with PCL_ERROR, keeps it for getLastError ().
    * \return false */
  bool fail (const char* format, ...);
  /** \brief The graph's vertices: valid points and their bounding box. */
  void collectVertices (const PointCloud<NormalT>& normals, pclx::normals::detail::MstGraph& graph) const;
  /** \brief Morton order, positions, normals, neighbour rows, noise and mean edge length. */
  void buildRiemannianGraph (const PointCloud<NormalT>& normals, pclx::normals::detail::MstGraph& graph);
  /** \brief The neighbour rows from the user's search method; returns the noise estimate. */
  double searchNeighbourGraph (pclx::normals::detail::MstGraph& graph, bool estimate_noise);

  PointCloudConstPtr input_;
  SearchPtr search_;
  int k_ = 10;
  double tie_break_ = 1e-3;
  double across_penalty_ = 0.5;
  double noise_scale_ = -1;
  double side_significance_ = 4;
  double visibility_weight_ = 1;
  double used_noise_ = 0;
  unsigned int threads_ = 0;
  std::size_t components_ = 0, flipped_ = 0, edges_ = 0, visibility_flipped_ = 0;
  std::string last_error_;
};

}  // namespace pcl

#ifdef PCL_NO_PRECOMPILE
#include <pclx/normals/impl/mst_normal_orientation.hpp>
#endif
