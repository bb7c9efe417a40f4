#pragma once
#include <pclx/normals/detail/error_message.h>
#include <pclx/normals/planar_octree_normal_estimation.h>
#include <pclx/normals/detail/plane_pca.h>

#include <pcl/common/centroid.h>
#include <pcl/common/point_tests.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <omp.h>

namespace pclx {
namespace normals {
namespace detail {

// Hoppe's plane of a neighbourhood: false when it spans no plane (< 3 points, collinear).
template <typename PointT> bool
planeOfNeighbours (const pcl::PointCloud<PointT>& cloud, const pcl::Indices& nn, Eigen::Vector3f& normal,
                   float& curvature)
{
  if (nn.size () < 3)
    return false;
  Eigen::Matrix3d cov;
  Eigen::Vector4d centroid;
  if (pcl::computeMeanAndCovarianceMatrix (cloud, nn, cov, centroid) < 3 || !cov.allFinite ())
    return false;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es (cov);
  const Eigen::Vector3d ev = es.eigenvalues ().cwiseMax (0.0);  // ascending
  if (!(ev (2) > 0) || ev (1) <= 1e-12 * ev (2))
    return false;
  normal = es.eigenvectors ().col (0).cast<float> ();
  curvature = static_cast<float> (ev (0) / ev.sum ());
  return true;
}

// The same plane over the positions of the first k keys' slots (pclx::normals::detail::distanceSlotKey),
// with PCL's shifted sums (here by x, close to all of them) and the closed-form PCA.
inline bool
planeOfPositions (const Eigen::Vector3f& x, const std::uint64_t* keys, int k, const std::vector<Eigen::Vector3f>& positions,
                  Eigen::Vector3f& normal, float& curvature)
{
  if (k < 3)
    return false;
  double s[9] = {};
  shiftedSums (x, keys, k, positions, s);
  for (double& a : s)
    a /= k;
  Eigen::Matrix3d cov;
  cov (0, 0) = s[3] - s[0] * s[0];
  cov (0, 1) = cov (1, 0) = s[4] - s[0] * s[1];
  cov (0, 2) = cov (2, 0) = s[5] - s[0] * s[2];
  cov (1, 1) = s[6] - s[1] * s[1];
  cov (1, 2) = cov (2, 1) = s[7] - s[1] * s[2];
  cov (2, 2) = s[8] - s[2] * s[2];
  if (!cov.allFinite ())
    return false;
  const PlanePca p = planePca (cov);
  if (!(p.lambda (0) > 0) || p.lambda (1) <= 1e-12 * p.lambda (0))
    return false;
  normal = p.normal.cast<float> ();
  curvature = static_cast<float> (p.lambda (2) / p.lambda.sum ());
  return true;
}

// Points come in any order (a sampled mesh: random) and patches in octree order, so each
// point's patch is a cache miss; loops that read them in input order fetch the patch of
// the point this far ahead first (its index is a sequential read).
constexpr int kPatchAhead = 16;

// Per-thread scratch of the estimator's own kNN queries (the grid's or the search method's).
struct KnnScratch
{
  std::vector<int> ids;
  std::vector<std::uint64_t> keys;  // distanceSlotKey selections (the grid's, the noise sample's)
  std::vector<Eigen::Vector3f> pos;  // positions of the last knn's neighbours, in its order
  // The grid's guesses of the k-th distance (GridKnn::nearestK's radius_hint), one for
  // each of the last two k: the orphans ask for a short and a long list in turn.
  float hint[2] = {0, 0};
  int hint_k[2] = {0, 0};
  float*
  hintFor (int k)
  {
    if (hint_k[0] != k && hint_k[1] != k)
    {
      hint_k[1] = hint_k[0];
      hint[1] = hint[0];
      hint_k[0] = k;
      hint[0] = 0;
    }
    return hint_k[0] == k ? &hint[0] : &hint[1];
  }
};

// Per-thread scratch of the orphans' ladders.
struct OrphanScratch
{
  pcl::Indices candidates;
  std::vector<float> dist;
  std::vector<std::uint64_t> by_distance;
  std::vector<Eigen::Vector3f> sorted;
  std::vector<int> member_rungs;
  KnnScratch knn;
};

// Every candidate (slot c of positions) keyed by its squared distance from x.
inline void
distanceKeys (const Eigen::Vector3f& x, const std::vector<Eigen::Vector3f>& positions, std::size_t count,
              std::vector<std::uint64_t>& keys)
{
  keys.resize (count);
  for (std::size_t c = 0; c < count; ++c)
    keys[c] = distanceSlotKey ((positions[c] - x).squaredNorm (), static_cast<std::uint32_t> (c));
}

}  // namespace detail
}  // namespace normals
}  // namespace pclx

namespace pcl {

template <typename PointInT, typename PointOutT> bool
PlanarOctreeNormalEstimation<PointInT, PointOutT>::initCompute ()
{
  // Neither k nor a radius set: this call searches kDefaultNeighbours, and the user's
  // settings are given back unchanged afterwards.
  last_error_.clear ();
  default_k_ = this->getKSearch () == 0 && this->getRadiusSearch () == 0;
  if (default_k_)
    this->setKSearch (kDefaultNeighbours);
  if (prepare ())
    return true;
  deinitCompute ();
  return false;
}

template <typename PointInT, typename PointOutT> bool
PlanarOctreeNormalEstimation<PointInT, PointOutT>::deinitCompute ()
{
  if (default_k_)
    this->setKSearch (0);
  default_k_ = false;
  return Feature<PointInT, PointOutT>::deinitCompute ();
}

template <typename PointInT, typename PointOutT> bool
PlanarOctreeNormalEstimation<PointInT, PointOutT>::fail (const char* format, ...)
{
  std::va_list args;
  va_start (args, format);
  last_error_ = "[pcl::PlanarOctreeNormalEstimation::initCompute] " +
                pclx::normals::detail::vformatMessage (format, args);
  va_end (args);
  PCL_ERROR ("%s", last_error_.c_str ());
  return false;
}

template <typename PointInT, typename PointOutT> bool
PlanarOctreeNormalEstimation<PointInT, PointOutT>::prepare ()
{
  // Parameters first: a bad threshold is an error, never a silently odd octree.
  if (growth_passes_ < 0)
    return fail ("growth passes must be >= 0 (got %d)\n", growth_passes_);
  if (!(params_.s_alpha > 0) || !(params_.s_beta > 0) || !std::isfinite (params_.s_alpha) ||
      !std::isfinite (params_.s_beta))
    return fail ("planarity thresholds must be positive and finite (s_alpha %g, s_beta %g)\n", params_.s_alpha,
                 params_.s_beta);
  if (params_.max_depth < 0 || params_.max_depth > 21)
    return fail ("max depth must be in [0, 21] (got %d)\n", params_.max_depth);
  if (params_.min_points < 3)
    return fail ("min points per cell must be >= 3 (got %d)\n", params_.min_points);
  if (!(border_ratio_ >= 0 && border_ratio_ < 1))
    return fail ("border ratio must be in [0, 1) (got %g)\n", border_ratio_);
  if (!(merge_angle_deg_ > 0 && merge_angle_deg_ < 90) || !(merge_thickness_factor_ >= 1) ||
      !std::isfinite (merge_thickness_factor_) || !(adoption_tolerance_ > 0) || !std::isfinite (adoption_tolerance_) ||
      !(residual_split_ratio_ >= 0) || !(adoption_angle_deg_ > 0 && adoption_angle_deg_ <= 90) ||
      !(region_validation_ratio_ >= 0))
    return fail ("merge angle must be in (0, 90) degrees, thickness factor >= 1 and adoption "
                 "tolerance > 0 (got %g, %g, %g)\n", merge_angle_deg_, merge_thickness_factor_, adoption_tolerance_);
  if (patch_size_ < 0 || (patch_size_ > 0 && (patch_support_ < 3 || patch_scales_ < 1 ||
                                                !(max_patch_slope_deg_ > 0 && max_patch_slope_deg_ < 90))))
    return fail ("patches need size >= 0, support >= 3, scales >= 1 and a slope error in (0, 90) "
                 "degrees (got %d, %d, %d, %g)\n", patch_size_, patch_support_, patch_scales_, max_patch_slope_deg_);
  if (!(ladder_tau_ > 0) || !std::isfinite (ladder_tau_) || !(max_patch_noise_ratio_ >= 0))
    return fail ("scale agreement must be > 0 and finite, patch noise ratio >= 0 (got %g, %g)\n", ladder_tau_,
                 max_patch_noise_ratio_);
  // No search method set: a tree that builds on first use (MERGED rarely needs it, below).
  // Organized clouds keep PCL's default (OrganizedNeighbor, cheap to set up).
  if (input_ && (!this->tree_ || this->tree_ == lazy_tree_))
  {
    const auto& surface = surface_ ? surface_ : input_;
    if (surface->isOrganized () && input_->isOrganized ())
    {
      if (this->tree_ == lazy_tree_)
        this->tree_.reset ();
    }
    else
    {
      if (!lazy_tree_)
        lazy_tree_.reset (new pclx::normals::detail::LazyKdTree<PointInT> ());
      this->tree_ = lazy_tree_;
    }
  }
  if (!Feature<PointInT, PointOutT>::initCompute ())
    return false;

  // The octree is built over the finite points of the search surface.
  // In parallel when every point is finite (the usual case).
  const int nsurface = static_cast<int> (surface_->size ());
  const int threads = threads_ > 0 ? static_cast<int> (threads_) : omp_get_max_threads ();
  int finite = 0;
#pragma omp parallel for reduction(+ : finite) num_threads(threads)
  for (int i = 0; i < nsurface; ++i)
    finite += isFinite ((*surface_)[i]) ? 1 : 0;
  surface_to_octree_.resize (nsurface);
  if (finite == nsurface)
  {
    octree_to_surface_.resize (nsurface);
    surface_points_.resize (nsurface);
#pragma omp parallel for num_threads(threads)
    for (int i = 0; i < nsurface; ++i)
    {
      surface_to_octree_[i] = octree_to_surface_[i] = i;
      surface_points_[i] = (*surface_)[i].getVector3fMap ();
    }
  }
  else
  {
    surface_points_.clear ();
    octree_to_surface_.clear ();
    for (int i = 0; i < nsurface; ++i)
    {
      surface_to_octree_[i] = -1;
      if (isFinite ((*surface_)[i]))
      {
        surface_to_octree_[i] = static_cast<int> (surface_points_.size ());
        octree_to_surface_.push_back (i);
        surface_points_.push_back ((*surface_)[i].getVector3fMap ());
      }
    }
  }
  pclx::normals::detail::PlanarOctreeParams params = params_;
  params.s_alpha = getSAlpha ();
  params.threads = static_cast<int> (threads_);
  params.max_residual_ratio = method_ == Method::MERGED ? residual_split_ratio_ : 0.0;
  if (!octree_.build (surface_points_, params))
    return fail ("the search surface has %zu finite points that do not span a plane "
                 "(fewer than 3, all identical or collinear): no normal is defined\n",
                 surface_points_.size ());
  return true;
}

// The state computeFeature ()'s stages share.
template <typename PointInT, typename PointOutT>
struct PlanarOctreeNormalEstimation<PointInT, PointOutT>::ComputeState
{
  int threads = 1;
  double abs_eps = 0;       // absolute slack of residual comparisons (1e-6 of the root's half edge)
  bool patches = false;     // MERGED with patches enabled
  bool adaptive = false;    // MERGED with the kNN ladder (max adaptive neighbours > k)
  std::vector<int> rungs;   // the ladder's support sizes
  std::vector<int> boundaries;  // prefix sizes the ladder reads: its rungs and Hoppe's k
  // MERGED's own searches (noise samples, orphans) go to a grid over the search surface
  // when the kd-tree is ours and unbuilt: a parallel grid build is a fraction of FLANN's
  // serial one, and on clean input only a few percent of the points are searched from.
  pclx::normals::detail::GridKnn grid;
  double noise2 = 0;         // squared noise sigma
  bool noisy = false;        // noise above getMaxPatchNoiseRatio () spacings
  bool use_patches = false;  // patches serve points (MERGED, patches on, not noisy)
  bool same_cloud = false;   // the input is its own search surface
  std::vector<int> surface_region;  // used region of every search-surface point, -1 if none
  // Orphans: search-surface points in non-planar cells (or rejected regions; on noisy
  // input every point). orphan_slot: surface index -> orphan, -1 if none.
  std::vector<int> orphans, orphan_slot, groups;
  std::vector<pcl::Indices> orphan_nn;  // Hoppe's sets, for region growth
  std::vector<Eigen::Vector3f> orphan_normal;
  std::vector<float> orphan_curvature;
  std::vector<int> orphan_support;
  std::vector<char> orphan_ok;
};

// The normal of one output point as the stages decide it.
template <typename PointInT, typename PointOutT>
struct PlanarOctreeNormalEstimation<PointInT, PointOutT>::NormalChoice
{
  Eigen::Vector3f normal;
  float curvature = 0.f;
  std::uint8_t status = INVALID_POINT;
  int region = -1;
  int support = 0;
};

template <typename PointInT, typename PointOutT> int
PlanarOctreeNormalEstimation<PointInT, PointOutT>::knn (const ComputeState& s, const PointInT& query, int k,
                                                        pcl::Indices& out, std::vector<float>& dist,
                                                        pclx::normals::detail::KnnScratch& scratch) const
{
  // k nearest search-surface points of a query (any order), their positions in scratch.pos:
  // from the grid's cell-ordered copy, not gathered from the cloud point by point.
  if (s.grid.empty ())
  {
    const int m = this->tree_->nearestKSearch (query, k, out, dist);
    scratch.pos.clear ();
    for (int i = 0; i < std::max (m, 0); ++i)
      scratch.pos.push_back ((*surface_)[out[i]].getVector3fMap ());
    return m;
  }
  // Orphans come sorted by cell, so the last query's k-th distance bounds this one's well.
  const int m = s.grid.nearestK (query.getVector3fMap (), k, scratch.ids, dist, scratch.keys, &scratch.pos,
                                 scratch.hintFor (k));
  out.resize (m);
  for (int i = 0; i < m; ++i)
    out[i] = octree_to_surface_[scratch.ids[i]];
  return m;
}

template <typename PointInT, typename PointOutT> int
PlanarOctreeNormalEstimation<PointInT, PointOutT>::validPatchOf (int octree_point) const
{
  const int f = octree_.patchOfPoint ()[octree_point];
  return f >= 0 && octree_.patches ()[f].valid ? f : -1;
}

template <typename PointInT, typename PointOutT> int
PlanarOctreeNormalEstimation<PointInT, PointOutT>::bestRegion (const ComputeState& s, const Eigen::Vector3f& x,
                                                               const Eigen::Vector3f* own, const pcl::Indices& nn,
                                                               const std::vector<int>& region_of) const
{
  // A region may take point x if its surface passes within tolerance of x and its normal
  // there agrees with x's own local plane (so a region cannot swallow the far side of an edge).
  const auto& regions = octree_.regions ();
  const double cos_adopt = std::cos (adoption_angle_deg_ * M_PI / 180.0);
  double best = 1.0;
  int region = -1;
  for (const auto j : nn)
  {
    const int r = region_of[j];
    if (r < 0 || r == region)
      continue;
    const double ratio = octree_.regionResidual (r, x) / (adoption_tolerance_ * regions[r].surface.rms + s.abs_eps);
    // On the surface within 2 RMS residuals, x belongs to r whatever its own (possibly
    // edge-blended) plane says; farther out, the two normals must agree.
    if (ratio < best && (!own || ratio * adoption_tolerance_ <= 2.0 ||
                         std::abs (octree_.regionNormalAt (r, x).dot (*own)) >= cos_adopt))
    {
      best = ratio;
      region = r;
    }
  }
  return region;
}

template <typename PointInT, typename PointOutT> bool
PlanarOctreeNormalEstimation<PointInT, PointOutT>::ladderPlane (const ComputeState& s, const Eigen::Vector3f& x,
                                                                const pcl::Indices& candidates,
                                                                const std::vector<Eigen::Vector3f>& positions,
                                                                pcl::Indices& nn,
                                                                std::vector<std::uint64_t>& by_distance,
                                                                std::vector<Eigen::Vector3f>& sorted,
                                                                Eigen::Vector3f& normal, float& curvature,
                                                                int& support, const std::vector<int>& use_rungs) const
{
  // Lepski's rule over the ladder for x, from candidate neighbours (any order): sorts them
  // by distance from x; nn keeps the first k of them (Hoppe's set, for region adoption).
  pclx::normals::detail::distanceKeys (x, positions, candidates.size (), by_distance);
  // Only the rungs' prefixes matter (as sets, with their farthest point last): selection
  // from the largest rung down costs a fraction of a full sort.
  auto end = by_distance.end ();
  for (auto r = s.boundaries.rbegin (); r != s.boundaries.rend (); ++r)
    if (*r < end - by_distance.begin ())
    {
      std::nth_element (by_distance.begin (), by_distance.begin () + (*r - 1), end);
      end = by_distance.begin () + *r;
    }
  sorted.clear ();
  nn.clear ();
  // One allocation per orphan's Hoppe set, not one per doubling.
  nn.reserve (std::min<std::size_t> (this->getKSearch (), by_distance.size ()));
  for (const auto key : by_distance)
  {
    const auto slot = pclx::normals::detail::slotOfKey (key);
    sorted.push_back (positions[slot]);
    if (static_cast<int> (nn.size ()) < this->getKSearch ())
      nn.push_back (candidates[slot]);
  }
  const auto c = pclx::normals::detail::selectScale (x, sorted, use_rungs, s.noise2, ladder_tau_);
  normal = c.normal;
  curvature = c.curvature;
  support = c.support;
  return c.ok;
}

template <typename PointInT, typename PointOutT> bool
PlanarOctreeNormalEstimation<PointInT, PointOutT>::localPlane (const ComputeState& s, const PointCloudIn& cloud,
                                                               int index, pcl::Indices& nn, Eigen::Vector3f& normal,
                                                               float& curvature, int& support)
{
  // The local plane of a point where no region applies: Hoppe's kNN PCA, and for MERGED
  // the scale-selected ladder over one search of the largest rung.
  if (!s.adaptive)
  {
    support = static_cast<int> (nn.size ());
    return pclx::normals::detail::planeOfNeighbours (*surface_, nn, normal, curvature);
  }
  pcl::Indices big;
  std::vector<float> big_dist;
  std::vector<std::uint64_t> by_distance;
  std::vector<Eigen::Vector3f> sorted;
  std::vector<Eigen::Vector3f> positions;
  if (this->searchForNeighbors (cloud, index, max_adaptive_neighbours_, big, big_dist) <= 0)
    return false;
  for (const auto q : big)
    positions.push_back ((*surface_)[q].getVector3fMap ());
  return ladderPlane (s, cloud[index].getVector3fMap (), big, positions, nn, by_distance, sorted, normal, curvature,
                      support, s.rungs);
}

template <typename PointInT, typename PointOutT> void
PlanarOctreeNormalEstimation<PointInT, PointOutT>::setUpCompute (ComputeState& s)
{
  s.threads = threads_ > 0 ? static_cast<int> (threads_) : omp_get_max_threads ();
  s.abs_eps = 1e-6 * octree_.nodes ()[0].half;
  s.patches = method_ == Method::MERGED && patch_size_ > 0;
  // Where no region applies, MERGED picks each point's kNN support from a ladder (Lepski's
  // rule, pclx::normals::detail::selectScale) under the noise of the whole cloud.
  s.adaptive = method_ == Method::MERGED && this->getKSearch () > 0 && max_adaptive_neighbours_ > this->getKSearch ();
  if (s.adaptive)
    s.rungs = pclx::normals::detail::ladderRungs (this->getKSearch (), max_adaptive_neighbours_);
  if (s.adaptive && lazy_tree_ && this->tree_ == lazy_tree_ && !lazy_tree_->isBuilt ())
    s.grid.build (surface_points_, 24, s.threads);
  s.boundaries = s.rungs;
  s.boundaries.push_back (this->getKSearch ());
  std::sort (s.boundaries.begin (), s.boundaries.end ());
  s.boundaries.erase (std::unique (s.boundaries.begin (), s.boundaries.end ()), s.boundaries.end ());
  s.same_cloud = surface_ == input_;
}

template <typename PointInT, typename PointOutT> void
PlanarOctreeNormalEstimation<PointInT, PointOutT>::estimateNoise (ComputeState& s)
{
  noise_ = pclx::normals::detail::NoiseEstimate ();
  if (s.adaptive)
  {
    // Noise from about 2000 sampled points (quadric residuals, pclx::normals::detail::sampleNoise).
    struct NoiseScratch
    {
      pcl::Indices nn;
      std::vector<float> dist;
      pclx::normals::detail::KnnScratch knn;
    };
    noise_ = pclx::normals::detail::estimateCloudNoise<NoiseScratch> (
        surface_points_.size (), 2000, s.threads,
        [&] (std::size_t i, std::vector<Eigen::Vector3f>& sorted, NoiseScratch& t) {
          const int m = knn (s, (*surface_)[octree_to_surface_[i]], 200, t.nn, t.dist, t.knn);
          if (m < 50)
            return;
          t.knn.keys.resize (m);
          for (int q = 0; q < m; ++q)
            t.knn.keys[q] = pclx::normals::detail::distanceSlotKey (t.dist[q], static_cast<std::uint32_t> (q));
          std::sort (t.knn.keys.begin (), t.knn.keys.end ());
          for (const auto key : t.knn.keys)
            sorted.push_back (t.knn.pos[pclx::normals::detail::slotOfKey (key)]);
        });
  }
  s.noise2 = noise_.sigma * noise_.sigma;
  // Patches (quadrics over a kNN-sized support) lose to a PCA plane over a larger support
  // once the noise is a sizeable share of the spacing.
  s.noisy = s.adaptive && noise_.ratio () > max_patch_noise_ratio_;
  s.use_patches = s.patches && !s.noisy;
}

template <typename PointInT, typename PointOutT> void
PlanarOctreeNormalEstimation<PointInT, PointOutT>::validateRegionsByPatches (ComputeState& s)
{
  // A region is used when its one surface explains its points about as well as the small
  // patch fits do (median patch residual): then the rest is noise, and the big support
  // averages it; otherwise the region hides shape and the patches keep it.
  const auto& nodes = octree_.nodes ();
  const auto& regions = octree_.regions ();
  std::vector<std::vector<double>> patch_rms (regions.size ());
  for (const auto& P : octree_.patches ())
  {
    const int r = nodes[P.leaf].region;
    if (r >= 0 && P.valid)
      patch_rms[r].push_back (P.rms);
  }
#pragma omp parallel for schedule(dynamic, 16) num_threads(s.threads)
  for (int r = 0; r < static_cast<int> (regions.size ()); ++r)
  {
    auto& v = patch_rms[r];
    if (v.empty ())
      continue;
    std::nth_element (v.begin (), v.begin () + v.size () / 2, v.end ());
    region_ok_[r] = regions[r].surface.rms <= region_validation_ratio_ * v[v.size () / 2] + s.abs_eps;
  }
}

template <typename PointInT, typename PointOutT> void
PlanarOctreeNormalEstimation<PointInT, PointOutT>::validateRegionsByKnnThickness (ComputeState& s)
{
  // Without patches (setPatchSize (0)): the median thickness of kNN planes sampled at up
  // to 16 points inside the region.
  const auto& nodes = octree_.nodes ();
  const auto& regions = octree_.regions ();
  std::vector<std::vector<int>> samples (regions.size ());
  const auto& order = octree_.order ();
  for (int id = 0; id < static_cast<int> (nodes.size ()); ++id)
    if (nodes[id].isLeaf () && nodes[id].region >= 0)
      samples[nodes[id].region].push_back (id);
#pragma omp parallel num_threads(s.threads)
  {
    pcl::Indices nn;
    std::vector<float> dist;
    std::vector<double> thickness;
    pclx::normals::detail::KnnScratch scratch;
#pragma omp for schedule(dynamic, 4)
    for (int r = 0; r < static_cast<int> (regions.size ()); ++r)
    {
      thickness.clear ();
      const auto& leaves = samples[r];
      const int per_leaf = std::max (1, 16 / static_cast<int> (leaves.size ()));
      for (std::size_t l = 0; l < leaves.size () && thickness.size () < 16; ++l)
      {
        const auto& L = nodes[leaves[l]];
        for (int q = 0; q < per_leaf && q < L.size (); ++q)
        {
          const int j = octree_to_surface_[order[L.begin + q * L.size () / per_leaf]];
          const int found = this->getKSearch () > 0
                                ? knn (s, (*surface_)[j], this->getKSearch (), nn, dist, scratch)
                                : this->searchForNeighbors (*surface_, j, search_parameter_, nn, dist);
          if (found < 3)
            continue;
          Eigen::Matrix3d cov;
          Eigen::Vector4d centroid;
          computeMeanAndCovarianceMatrix (*surface_, nn, cov, centroid);
          thickness.push_back (std::sqrt (pclx::normals::detail::planePca (cov).lambda (2)));
        }
      }
      if (thickness.empty ())
        continue;
      std::nth_element (thickness.begin (), thickness.begin () + thickness.size () / 2, thickness.end ());
      region_ok_[r] = regions[r].surface.rms <= region_validation_ratio_ * thickness[thickness.size () / 2] + s.abs_eps;
    }
  }
}

template <typename PointInT, typename PointOutT> void
PlanarOctreeNormalEstimation<PointInT, PointOutT>::buildRegions (ComputeState& s)
{
  // Regions and patches serve no point on noisy input: they are not built.
  if (method_ == Method::MERGED && !s.noisy)
  {
    octree_.mergeCoplanarLeaves (merge_angle_deg_, merge_thickness_factor_);
    octree_.fitRegions (quadric_);
    if (patch_size_ > 0)
      octree_.fitPatches (patch_size_, quadric_, std::tan (max_patch_slope_deg_ * M_PI / 180.0), patch_scales_,
                          patch_support_);
  }
  // MERGED: keep a region only if its surface fits it as well as local fits do (its
  // patches, or without patches kNN planes at up to 16 sampled points): otherwise the
  // region is shape, not noise, and its points are better served locally.
  region_ok_.assign (octree_.regions ().size (), 1);
  if (s.patches && region_validation_ratio_ > 0)
    validateRegionsByPatches (s);
  else if (method_ == Method::MERGED && region_validation_ratio_ > 0 && !s.noisy)
    validateRegionsByKnnThickness (s);
  if (s.noisy)
  {
    // Under noise the patches' residuals are noise too, and shape smaller than the noise
    // passes the test above; requiring the region's residual to match the estimated noise
    // does not help either (the shape hides inside the sampling error of the residual).
    // On noisy input the ladder serves every point.
    std::fill (region_ok_.begin (), region_ok_.end (), 0);
  }

  // Region of every search-surface point (grown into the non-planar cells later).
  const auto& nodes = octree_.nodes ();
  const auto& leaf_of_point = octree_.leafOfPoint ();
  s.surface_region.assign (surface_->size (), -1);
#pragma omp parallel for num_threads(s.threads)
  for (int j = 0; j < static_cast<int> (surface_->size ()); ++j)
    if (surface_to_octree_[j] >= 0)
    {
      const int r = nodes[leaf_of_point[surface_to_octree_[j]]].region;
      s.surface_region[j] = r >= 0 && region_ok_[r] ? r : -1;
    }
}

template <typename PointInT, typename PointOutT> void
PlanarOctreeNormalEstimation<PointInT, PointOutT>::collectOrphans (ComputeState& s)
{
  // Flagged in parallel (a random read of its patch per point), listed in surface order:
  // no result depends on the order (the adaptive path sorts them by cell, growth is Jacobi).
  const auto& patch_of_point = octree_.patchOfPoint ();
  const pclx::normals::detail::SurfaceFit* const patch_data = octree_.patches ().data ();
  constexpr int ahead = pclx::normals::detail::kPatchAhead;
  s.orphan_slot.assign (surface_->size (), -1);
  const int nsurface = static_cast<int> (surface_->size ());
#pragma omp parallel for schedule(static) num_threads(s.threads)
  for (int j = 0; j < nsurface; ++j)
  {
    // The record may straddle two cache lines: both ends are fetched.
    if (s.use_patches && j + ahead < nsurface && surface_to_octree_[j + ahead] >= 0)
      if (const int f = patch_of_point[surface_to_octree_[j + ahead]]; f >= 0)
      {
        __builtin_prefetch (&patch_data[f].o);
        __builtin_prefetch (&patch_data[f].valid);
      }
    const int o = surface_to_octree_[j];
    if (o >= 0 && s.surface_region[j] < 0 && !(s.use_patches && validPatchOf (o) >= 0))
      s.orphan_slot[j] = 0;
  }
  for (int j = 0; j < nsurface; ++j)
    if (s.orphan_slot[j] == 0)
    {
      s.orphan_slot[j] = static_cast<int> (s.orphans.size ());
      s.orphans.push_back (j);
    }
  const int no = static_cast<int> (s.orphans.size ());
  s.orphan_nn.resize (no);
  s.orphan_normal.resize (no);
  s.orphan_curvature.resize (no);
  s.orphan_support.assign (no, 0);
  s.orphan_ok.assign (no, 0);
}

template <typename PointInT, typename PointOutT> void
PlanarOctreeNormalEstimation<PointInT, PointOutT>::groupOrphans (ComputeState& s, double cell)
{
  // Orphans sorted by grid cell (of side `cell`), in groups of <= 16 within 2 cells of the
  // group's first point; s.groups holds the groups' first orphans and a last end.
  const int no = static_cast<int> (s.orphans.size ());
  std::vector<std::pair<std::uint64_t, int>> keyed (no);
  for (int o = 0; o < no; ++o)
  {
    std::uint64_t key = static_cast<std::uint64_t> (o);  // no spacing: every point alone
    if (cell > 0)
    {
      const Eigen::Vector3d c =
          ((*surface_)[s.orphans[o]].getVector3fMap ().template cast<double> () - octree_.origin ()) / cell;
      key = 0;
      for (int a = 0; a < 3; ++a)
      {
        // 21 bits per axis; far cells may share a key (the distance check below splits them).
        const auto cell_index = static_cast<std::int64_t> (std::floor (std::max (-1e15, std::min (1e15, c[a]))));
        key = (key << 21) | (static_cast<std::uint64_t> (cell_index + (1 << 20)) & ((1u << 21) - 1));
      }
    }
    keyed[o] = {key, s.orphans[o]};
  }
  std::sort (keyed.begin (), keyed.end ());
  for (int o = 0; o < no; ++o)
    s.orphans[o] = keyed[o].second;
  for (int o = 0; o < no; ++o)
    s.orphan_slot[s.orphans[o]] = o;
  std::vector<int> group_start;
  const float reach2 = static_cast<float> (4.0 * cell * cell);
  for (int o = 0; o < no; ++o)
    if (o == 0 || keyed[o].first != keyed[o - 1].first || o - group_start.back () >= 16 ||
        ((*surface_)[s.orphans[o]].getVector3fMap () - (*surface_)[s.orphans[group_start.back ()]].getVector3fMap ())
                .squaredNorm () > reach2)
      group_start.push_back (o);
  group_start.push_back (no);
  s.groups.swap (group_start);
}

template <typename PointInT, typename PointOutT> bool
PlanarOctreeNormalEstimation<PointInT, PointOutT>::fitSharedRung (ComputeState& s, int g, const PointInT& query,
                                                                  bool grows,
                                                                  pclx::normals::detail::OrphanScratch& t)
{
  // Noise wider than a spacing: the ladder runs once, at the centroid (its choice rarely
  // changes across a cell); each member gets the PCA of its own neighbours at that rung,
  // checked (setCheckSharedRung ()). Returns false when the centroid's ladder finds no plane.
  Eigen::Vector3f n0;
  float c0;
  int k0 = 0;
  pcl::Indices nn0;
  if (!ladderPlane (s, query.getVector3fMap (), t.candidates, t.knn.pos, nn0, t.by_distance, t.sorted, n0, c0, k0,
                    s.rungs))
    return false;
  const auto& group_start = s.groups;
  for (int o = group_start[g]; o < group_start[g + 1]; ++o)
  {
    const Eigen::Vector3f x = (*surface_)[s.orphans[o]].getVector3fMap ();
    // The centroid's ladder is done with by_distance: it now keys the member's candidates.
    pclx::normals::detail::distanceKeys (x, t.knn.pos, t.candidates.size (), t.by_distance);
    const int k = std::min<int> (k0, t.by_distance.size ());
    std::nth_element (t.by_distance.begin (), t.by_distance.begin () + (k - 1), t.by_distance.end ());
    // setCheckSharedRung: the member checks the shared rung on its own neighbours against
    // the rung below (the ladder's one-sided, agreement and residual rules) and climbs its
    // own ladder, capped at the shared rung, only where that refuses it.
    int k1 = 0;  // the rung below k
    for (const int r : s.rungs)
      if (r < k)
        k1 = r;
    pclx::normals::detail::ScaleChoice c;
    if (k1 < 3 || !check_shared_rung_)
    {
      // From the candidates' gathered positions: the cloud's points are random reads.
      c.ok = pclx::normals::detail::planeOfPositions (x, t.by_distance.data (), k, t.knn.pos, c.normal, c.curvature);
      c.support = k;
    }
    else if (!pclx::normals::detail::keepsLargerRung (x, t.by_distance.data (), t.knn.pos, k1, k, s.noise2,
                                                      ladder_tau_, c))
    {
      // Refused: the member's own ladder over its k nearest, each rung's prefix with its
      // farthest point last (selection from the largest down).
      t.member_rungs.clear ();
      for (const int r : s.rungs)
        if (r < k)
          t.member_rungs.push_back (r);
      t.member_rungs.push_back (k);
      std::nth_element (t.by_distance.begin (), t.by_distance.begin () + (k - 1), t.by_distance.begin () + k);
      for (auto r = t.member_rungs.rbegin () + 1; r < t.member_rungs.rend (); ++r)
        std::nth_element (t.by_distance.begin (), t.by_distance.begin () + (*r - 1),
                          t.by_distance.begin () + (*(r - 1) - 1));
      t.sorted.clear ();
      for (int q = 0; q < k; ++q)
        t.sorted.push_back (t.knn.pos[pclx::normals::detail::slotOfKey (t.by_distance[q])]);
      c = pclx::normals::detail::selectScale (x, t.sorted, t.member_rungs, s.noise2, ladder_tau_);
    }
    s.orphan_ok[o] = c.ok;
    s.orphan_normal[o] = c.normal;
    s.orphan_curvature[o] = c.curvature;
    s.orphan_support[o] = c.support;
    s.orphan_nn[o].clear ();
    if (grows)
    {
      // Hoppe's set, for region growth only (none on noisy input).
      const int kh = std::min<int> (this->getKSearch (), k);
      std::nth_element (t.by_distance.begin (), t.by_distance.begin () + (kh - 1), t.by_distance.begin () + k);
      for (int q = 0; q < kh; ++q)
        s.orphan_nn[o].push_back (t.candidates[pclx::normals::detail::slotOfKey (t.by_distance[q])]);
    }
    if (!s.orphan_ok[o])
    {
      s.orphan_normal[o] = n0;
      s.orphan_curvature[o] = c0;
      s.orphan_ok[o] = true;
      s.orphan_support[o] = k;
    }
  }
  return true;
}

template <typename PointInT, typename PointOutT> void
PlanarOctreeNormalEstimation<PointInT, PointOutT>::fitOrphansAdaptive (ComputeState& s)
{
  // One search per group of orphans (a grid cell of 3 spacings, <= 16 points) around their
  // centroid, for half again the largest rung; each member re-sorts the shared list by its
  // own distances (a search of the largest rung per point costs more than the ladder).
  // Clean input (noise <= getMaxPatchNoiseRatio () spacings) climbs only to 50 (cells of
  // 1.2 spacings): going on to 200 where growth reached 50 changed no result noticeably
  // and cost time.
  std::vector<int> short_rungs;
  for (const int k : s.rungs)
    if (k <= 50 && k < s.rungs.back ())
      short_rungs.push_back (k);
  const bool two_pass = noise_.ratio () <= max_patch_noise_ratio_ && short_rungs.size () >= 2;
  const double cell = (two_pass ? 1.2 : 3.0) * noise_.spacing;
  // Noise wider than a spacing: the ladder's choice is shared by a cell (fitSharedRung ()).
  const bool share = !two_pass && noise_.ratio () > 1.0;
  groupOrphans (s, cell);
  const int ng = static_cast<int> (s.groups.size ()) - 1;
  // Hoppe's sets (orphan_nn) serve region growth only.
  const bool grows = growth_passes_ > 0 && !octree_.regions ().empty () && !s.noisy;
  const std::vector<int>& group_start = s.groups;
  const int nsurf = static_cast<int> (surface_points_.size ());
  // Members lie within a cell of the centroid: half again covers their own lists in
  // 3-spacing cells; clean input's 1.2-spacing cells need an eighth.
  const int long_k = std::min (nsurf, max_adaptive_neighbours_ + max_adaptive_neighbours_ / (two_pass ? 8 : 2) + 4);
  const int short_k = std::min (nsurf, short_rungs.empty () ? 0 : short_rungs.back () + short_rungs.back () / 4 + 4);
#pragma omp parallel num_threads(s.threads)
  {
    pclx::normals::detail::OrphanScratch t;
#pragma omp for schedule(dynamic, 32)
    for (int g = 0; g < ng; ++g)
    {
      Eigen::Vector3f centre = Eigen::Vector3f::Zero ();
      for (int o = group_start[g]; o < group_start[g + 1]; ++o)
        centre += (*surface_)[s.orphans[o]].getVector3fMap ();
      PointInT query = (*surface_)[s.orphans[group_start[g]]];
      query.getVector3fMap () = centre / static_cast<float> (group_start[g + 1] - group_start[g]);
      bool more = !two_pass;
      if (two_pass && knn (s, query, short_k, t.candidates, t.dist, t.knn) > 0)
        for (int o = group_start[g]; o < group_start[g + 1]; ++o)
        {
          s.orphan_ok[o] = ladderPlane (s, (*surface_)[s.orphans[o]].getVector3fMap (), t.candidates, t.knn.pos,
                                        s.orphan_nn[o], t.by_distance, t.sorted, s.orphan_normal[o],
                                        s.orphan_curvature[o], s.orphan_support[o], short_rungs);
          more = more || !s.orphan_ok[o];  // no plane within 50 points: try the long list
        }
      if (!more || knn (s, query, long_k, t.candidates, t.dist, t.knn) <= 0)
        continue;
      if (share)
      {
        fitSharedRung (s, g, query, grows, t);
        continue;
      }
      for (int o = group_start[g]; o < group_start[g + 1]; ++o)
        s.orphan_ok[o] = ladderPlane (s, (*surface_)[s.orphans[o]].getVector3fMap (), t.candidates, t.knn.pos,
                                      s.orphan_nn[o], t.by_distance, t.sorted, s.orphan_normal[o],
                                      s.orphan_curvature[o], s.orphan_support[o], s.rungs);
    }
  }
}

template <typename PointInT, typename PointOutT> void
PlanarOctreeNormalEstimation<PointInT, PointOutT>::fitOrphansFixed (ComputeState& s)
{
  // Without the ladder: Hoppe's kNN PCA over the user's k or radius.
  const int no = static_cast<int> (s.orphans.size ());
#pragma omp parallel num_threads(s.threads)
  {
    std::vector<float> dist;
    pcl::Indices nn;
#pragma omp for schedule(dynamic, 256)
    for (int o = 0; o < no; ++o)
    {
      this->searchForNeighbors (*surface_, s.orphans[o], search_parameter_, s.orphan_nn[o], dist);
      nn = s.orphan_nn[o];
      s.orphan_ok[o] = localPlane (s, *surface_, s.orphans[o], nn, s.orphan_normal[o], s.orphan_curvature[o],
                                   s.orphan_support[o]);
    }
  }
}

template <typename PointInT, typename PointOutT> void
PlanarOctreeNormalEstimation<PointInT, PointOutT>::growRegions (ComputeState& s)
{
  // Region growing in Jacobi passes (read the previous pass, write the next): deterministic
  // in parallel. Regions do not grow on noisy input: there they adopt points the ladder
  // does better. A pass only revisits the orphans next to a point that joined a region in
  // the pass before (nothing else can change their answer), and writes a list of changes,
  // not a copy of the whole array.
  const int no = static_cast<int> (s.orphans.size ());
  std::vector<std::pair<int, int>> changes, previous;
  std::vector<char> joined (surface_->size (), 0);  // joined a region in the previous pass
  for (int pass = 0; pass < growth_passes_ && !octree_.regions ().empty () && !s.noisy; ++pass)
  {
#pragma omp parallel num_threads(s.threads)
    {
      std::vector<std::pair<int, int>> local;
#pragma omp for schedule(dynamic, 256) nowait
      for (int o = 0; o < no; ++o)
      {
        const int j = s.orphans[o];
        if (s.surface_region[j] >= 0)
          continue;  // first come, first kept: re-judging lets far quadrics steal points
        if (pass > 0 &&
            std::none_of (s.orphan_nn[o].begin (), s.orphan_nn[o].end (), [&] (index_t q) { return joined[q]; }))
          continue;
        const int r = bestRegion (s, (*surface_)[j].getVector3fMap (), s.orphan_ok[o] ? &s.orphan_normal[o] : nullptr,
                                  s.orphan_nn[o], s.surface_region);
        if (r >= 0)
          local.emplace_back (j, r);
      }
#pragma omp critical
      changes.insert (changes.end (), local.begin (), local.end ());
    }
    for (const auto& c : previous)
      joined[c.first] = 0;
    for (const auto& [j, r] : changes)
    {
      s.surface_region[j] = r;
      joined[j] = 1;
    }
    if (changes.empty ())
      break;
    previous.swap (changes);
    changes.clear ();
  }
}

template <typename PointInT, typename PointOutT> void
PlanarOctreeNormalEstimation<PointInT, PointOutT>::setRegionNormal (NormalChoice& r, int region,
                                                                    const Eigen::Vector3f& x) const
{
  r.region = region;
  r.normal = octree_.regionNormalAt (region, x);
  r.curvature = octree_.regions ()[region].surface.curvature;
  r.support = octree_.regions ()[region].points;
}

template <typename PointInT, typename PointOutT> void
PlanarOctreeNormalEstimation<PointInT, PointOutT>::leafNormal (const ComputeState& s, int index, int leaf,
                                                               const Eigen::Vector3f& x, NormalChoice& r) const
{
  // The normal a point's leaf gives: its plane (OCTREE, HYBRID inside), its region or its
  // patch (MERGED); r.status stays INVALID_POINT where none applies.
  const pclx::normals::detail::OctreeNode& L = octree_.nodes ()[leaf];
  if (method_ == Method::OCTREE && !L.degenerate)
    r.status = LEAF_PLANE;  // Algorithm 2 on every leaf, planar or not (Musmanno's method)
  else if (method_ == Method::HYBRID && L.planar && octree_.relativeCentreDistance (leaf, x) <= 1.0 - border_ratio_)
    r.status = LEAF_PLANE;  // Musmanno §5.4.3: inner points keep the cell's plane
  else if (method_ == Method::MERGED && L.planar && L.region >= 0 && region_ok_[L.region])
  {
    r.status = REGION_FIT;
    setRegionNormal (r, L.region, x);
  }
  else if (s.use_patches && L.planar)
  {
    const int c = s.same_cloud ? validPatchOf (surface_to_octree_[index]) : octree_.locatePatch (x);
    if (c >= 0)
    {
      r.status = PATCH_FIT;
      r.normal = octree_.patchNormalAt (c, x);
      r.curvature = octree_.patches ()[c].curvature;
      r.support = octree_.patches ()[c].support;
      r.region = L.region;  // the merged region the patch lies in, used or not
    }
  }
  if (r.status == LEAF_PLANE)
  {
    r.normal = L.normal;
    r.curvature = L.curvature;
    r.support = L.size ();
    r.region = L.planar ? leaf : -1;
  }
}

template <typename PointInT, typename PointOutT> void
PlanarOctreeNormalEstimation<PointInT, PointOutT>::searchedNormal (ComputeState& s, int index,
                                                                   const Eigen::Vector3f& x, pcl::Indices& nn,
                                                                   std::vector<float>& dist, NormalChoice& r)
{
  // A point that is no orphan of the search surface and got nothing from its leaf: its own
  // kNN plane, or (MERGED) the grown region whose surface passes through it.
  if (this->searchForNeighbors (index, search_parameter_, nn, dist) <= 0)
    return;
  const pcl::Indices neighbours = nn;
  if (localPlane (s, *input_, index, nn, r.normal, r.curvature, r.support))
    r.status = KNN_PCA;
  if (method_ == Method::MERGED && !s.noisy)
  {
    // Planarity-aware border: join the (grown) region whose surface passes through x.
    const int region = bestRegion (s, x, r.status == KNN_PCA ? &r.normal : nullptr, neighbours, s.surface_region);
    r.region = region;
    if (region >= 0)
    {
      r.status = ADOPTED_REGION;
      setRegionNormal (r, region, x);
    }
  }
}

template <typename PointInT, typename PointOutT> void
PlanarOctreeNormalEstimation<PointInT, PointOutT>::writeNormals (ComputeState& s, PointCloudOut& output)
{
  const int n = static_cast<int> (indices_->size ());
  status_.assign (n, INVALID_POINT);
  region_ids_.assign (n, -1);
  support_sizes_.assign (n, 0);
  bool dense = true;
  const auto& nodes = octree_.nodes ();
  const auto& leaf_of_point = octree_.leafOfPoint ();
  const auto& patch_of_point = octree_.patchOfPoint ();
  const pclx::normals::detail::SurfaceFit* const patch_data = octree_.patches ().data ();

  // MERGED on the input's own points: a non-orphan point's status follows from
  // surface_region (its leaf's region if used) and its patch, without its octree node.
  const bool fast = method_ == Method::MERGED && s.same_cloud && !s.orphan_slot.empty ();
  std::vector<int> patch_region;  // region of each patch's leaf (used or not)
  if (fast && s.use_patches)
  {
    patch_region.resize (octree_.patches ().size ());
    for (std::size_t c = 0; c < patch_region.size (); ++c)
      patch_region[c] = nodes[octree_.patches ()[c].leaf].region;
  }
#pragma omp parallel num_threads(s.threads) reduction(&& : dense)
  {
    pcl::Indices nn;
    std::vector<float> dist;
#pragma omp for schedule(dynamic, 256)
    for (int i = 0; i < n; ++i)
    {
      if (fast && s.use_patches && i + pclx::normals::detail::kPatchAhead < n)
      {
        const int ahead = (*indices_)[i + pclx::normals::detail::kPatchAhead];
        if (surface_to_octree_[ahead] >= 0)
          if (const int f = patch_of_point[surface_to_octree_[ahead]]; f >= 0)
          {
            __builtin_prefetch (&patch_region[f]);
            __builtin_prefetch (&patch_data[f].o);
            __builtin_prefetch (&patch_data[f].valid);
          }
      }
      PointOutT& out = output[i];
      const int index = (*indices_)[i];
      const PointInT& p = (*input_)[index];
      if (!isFinite (p))
      {
        out.normal_x = out.normal_y = out.normal_z = out.curvature = std::numeric_limits<float>::quiet_NaN ();
        dense = false;
        continue;
      }
      const Eigen::Vector3f x = p.getVector3fMap ();
      // The input's own points know their leaf; other points descend the octree.
      const int leaf = s.same_cloud ? leaf_of_point[surface_to_octree_[index]] : octree_.locate (x);
      NormalChoice r;
      const int slot = s.same_cloud && !s.orphan_slot.empty () ? s.orphan_slot[index] : -1;

      if (leaf >= 0 && fast && slot < 0)
      {
        // Not an orphan: its leaf's region (if used) or else its valid patch, read from
        // per-point arrays in input order, not from random reads of octree nodes.
        if (s.surface_region[index] >= 0)
        {
          r.status = REGION_FIT;
          setRegionNormal (r, s.surface_region[index], x);
        }
        else if (const int c = validPatchOf (surface_to_octree_[index]); c >= 0)
        {
          r.status = PATCH_FIT;
          const auto& P = octree_.patches ()[c];
          r.normal = octree_.patchNormalAt (c, x);
          r.curvature = P.curvature;
          r.support = P.support;
          r.region = patch_region[c];
        }
      }
      else if (leaf >= 0)
        leafNormal (s, index, leaf, x, r);

      if (r.status == INVALID_POINT && slot >= 0)
      {
        if (s.surface_region[index] >= 0)
        {
          r.status = ADOPTED_REGION;
          setRegionNormal (r, s.surface_region[index], x);
        }
        else if (s.orphan_ok[slot])
        {
          r.status = KNN_PCA;
          r.normal = s.orphan_normal[slot];
          r.curvature = s.orphan_curvature[slot];
          r.support = s.orphan_support[slot];
        }
      }
      else if (r.status == INVALID_POINT)
        searchedNormal (s, index, x, nn, dist, r);

      if (r.status == INVALID_POINT || !r.normal.allFinite ())
      {
        // Degenerate neighbourhood: the smallest enclosing cell that spans a plane.
        const int cell = octree_.nonDegenerateAncestor (leaf >= 0 ? leaf : 0);
        r.normal = nodes[cell].normal;
        r.curvature = nodes[cell].curvature;
        r.status = NEIGHBOUR_FALLBACK;
        r.region = -1;
        r.support = nodes[cell].size ();
      }
      out.normal_x = r.normal.x ();
      out.normal_y = r.normal.y ();
      out.normal_z = r.normal.z ();
      out.curvature = r.curvature;
      status_[i] = r.status;
      region_ids_[i] = r.region;
      support_sizes_[i] = r.support;
    }
  }
  output.is_dense = dense;
}

template <typename PointInT, typename PointOutT> void
PlanarOctreeNormalEstimation<PointInT, PointOutT>::computeFeature (PointCloudOut& output)
{
  // The stages: noise of the cloud; MERGED's regions and patches and their validation;
  // the orphans' kNN planes (the ladder, or Hoppe's PCA) and region growth; then every
  // output point's normal from its leaf, region, patch or kNN plane.
  ComputeState s;
  setUpCompute (s);
  estimateNoise (s);
  buildRegions (s);
  if (method_ == Method::MERGED && (s.adaptive || (growth_passes_ > 0 && !octree_.regions ().empty ())))
  {
    collectOrphans (s);
    if (s.adaptive)
      fitOrphansAdaptive (s);
    else
      fitOrphansFixed (s);
    growRegions (s);
  }
  writeNormals (s, output);
}

}  // namespace pcl

#define PCL_INSTANTIATE_PlanarOctreeNormalEstimation(T, NT) \
  template class PCL_EXPORTS pcl::PlanarOctreeNormalEstimation<T, NT>;
