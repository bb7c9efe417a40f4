#pragma once
// Hoppe's consistent orientation (seed 002 §5.3.2), usable with any normals: a
// Riemannian graph (symmetric kNN graph) with edge cost 1 − |ni·nj| (+ a tiny length
// term that only breaks ties), its minimum
// spanning forest (Kruskal with Boost's disjoint sets), and in every component a traversal from the
// point of largest z; each child is flipped to agree with its parent (ni·nj > 0; across a
// sharp edge or a fold, by the side the edge vector leaves the two tangent planes: see
// setEdgeSideSignificance ()).
// The seed points the root's normal to +z; here, where the visibility votes (below) leave a
// component's sign open, its extreme points in 21
// directions of the upper hemisphere vote it (Σ n·d > 0): outward on closed shapes,
// "up" on open sheets, and not decided by one crease point at the top.
// One wrong crossing flips everything downstream of it, which no local rule can see. So the
// signs are then checked against a global cue, visibility: seen from outside (26 orthographic
// directions), a closed surface's visible points face the viewer. Every vertex's votes (Σ n·d,
// counted by their margin over half their weight) are weighed against the cost of overruling
// each tree crossing (low where the side was read or the normals are > 60° apart, high for
// parallel normals), and the best set of crossings to overrule is found exactly by dynamic
// programming over the tree (setVisibilityWeight ()). An open sheet's votes cancel.
#include <pcl/point_cloud.h>
#include <pcl/search/search.h>

#include <cstddef>

namespace pcl {

template <typename PointT, typename NormalT>
class MSTNormalOrientation
{
public:
  using PointCloudConstPtr = typename PointCloud<PointT>::ConstPtr;
  using SearchPtr = typename search::Search<PointT>::Ptr;

  void setInputCloud (const PointCloudConstPtr& cloud) { input_ = cloud; }
  // Neighbours per point in the Riemannian graph (>= 1; default 10).
  void setKSearch (int k) { k_ = k; }
  int getKSearch () const { return k_; }
  // Optional; FLANN's kd-tree (what pcl::search::KdTree builds) over the valid points is
  // used otherwise, queried directly, which is ~4x faster per query.
  void setSearchMethod (const SearchPtr& search) { search_ = search; }
  void setNumberOfThreads (unsigned int threads) { threads_ = threads; }
  // Edge cost is 1 − |ni·nj| + w · length / mean length: a small w (default 1e-3) only
  // breaks ties between equally parallel normals in favour of the shorter edge.
  void setDistanceTieBreak (double w) { tie_break_ = w; }
  double getDistanceTieBreak () const { return tie_break_; }
  // Adds w · max(|ni·ê|, |nj·ê|) to the cost of edge e (unit ê): edges that leave the tangent
  // plane (across a thin part) are avoided. 0 gives Hoppe's cost; the default 0.5 took a thin
  // plate from 50 % to 0.2 % flipped and changed nothing on sphere, torus and box (clean or
  // noisy). For normals > 60° apart (a sharp edge) it adds w · (1 − min(|ni·ê|, |nj·ê|))
  // instead: the crossing that leaves both tangent planes is the one whose side can be read
  // (exact normals on a box: 36 % flipped with Hoppe's rule, 0 with this).
  void setAcrossSurfacePenalty (double w) { across_penalty_ = w; }
  double getAcrossSurfacePenalty () const { return across_penalty_; }
  // Noise of the positions along the normal (a length; e.g. the estimator's
  // getNoiseEstimate ().sigma). Negative (default): estimated by orient () with
  // pclx::normals::sampleNoise on ~500 points. Not finite: orient () fails.
  void setNoiseScale (double sigma) { noise_scale_ = sigma; }
  double getNoiseScale () const { return noise_scale_; }
  // The noise orient () used last (given or estimated).
  double getUsedNoiseScale () const { return used_noise_; }
  // Nearly parallel normals (a fold: the faces of a thin part, or of a ridge or groove
  // narrower than the graph's edges, look parallel to Hoppe's rule, which flips one face) take
  // their relative sign from the edge's side where both lean off the edge vector e by more
  // than this many noise sigmas plus a quarter of the mean edge plus 0.5 |e| (default 4): that
  // offset is geometry, not noise. Such crossings, and sharp-edge crossings above the same
  // floor, count half their turn in the cost. Must be finite and >= 0.
  void setEdgeSideSignificance (double z) { side_significance_ = z; }
  double getEdgeSideSignificance () const { return side_significance_; }
  // Weight of the visibility votes against the cost of overruling the MST's crossings
  // (default 1; 0: the MST's crossings alone, the old behaviour). Must be finite and >= 0.
  void setVisibilityWeight (double w) { visibility_weight_ = w; }
  double getVisibilityWeight () const { return visibility_weight_; }

  // Orients `normals` (one per input point) in place. Points or normals that are not
  // finite, and zero normals, stay out of the graph and are left untouched.
  // Returns false with PCL_ERROR on bad input (no cloud, size mismatch, k < 1, a setter's
  // value out of range).
  bool orient (PointCloud<NormalT>& normals);

  std::size_t getNumberOfComponents () const { return components_; }  // of the last orient ()
  std::size_t getNumberOfFlipped () const { return flipped_; }
  std::size_t getNumberOfEdges () const { return edges_; }
  // Points whose sign the visibility votes decided against the MST's propagation.
  std::size_t getNumberOfVisibilityFlips () const { return visibility_flipped_; }

private:
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
};

}  // namespace pcl

#ifdef PCL_NO_PRECOMPILE
#include <pclx/normals/impl/mst_normal_orientation.hpp>
#endif
