#pragma once
#include <pclx/normals/planar_octree_normal_estimation.h>
#include <pclx/normals/plane_pca.h>

#include <pcl/common/centroid.h>
#include <pcl/common/point_tests.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <omp.h>

namespace pcl {

namespace detail {
// Hoppe's plane of a neighbourhood: false when it spans no plane (< 3 points, collinear).
template <typename PointT> bool
planeOfNeighbours (const PointCloud<PointT>& cloud, const Indices& nn, Eigen::Vector3f& normal,
                   float& curvature)
{
  if (nn.size () < 3)
    return false;
  Eigen::Matrix3d cov;
  Eigen::Vector4d centroid;
  if (computeMeanAndCovarianceMatrix (cloud, nn, cov, centroid) < 3 || !cov.allFinite ())
    return false;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es (cov);
  const Eigen::Vector3d ev = es.eigenvalues ().cwiseMax (0.0);  // ascending
  if (!(ev (2) > 0) || ev (1) <= 1e-12 * ev (2))
    return false;
  normal = es.eigenvectors ().col (0).cast<float> ();
  curvature = static_cast<float> (ev (0) / ev.sum ());
  return true;
}

// The same plane over the positions of the first k keys' slots (pclx::normals::distanceSlotKey),
// with PCL's shifted sums (here by x, close to all of them) and the closed-form PCA.
inline bool
planeOfPositions (const Eigen::Vector3f& x, const std::uint64_t* keys, int k, const std::vector<Eigen::Vector3f>& positions,
                  Eigen::Vector3f& normal, float& curvature)
{
  if (k < 3)
    return false;
  double s[9] = {};
  pclx::normals::shiftedSums (x, keys, k, positions, s);
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
  const pclx::normals::PlanePca p = pclx::normals::planePca (cov);
  if (!(p.lambda (0) > 0) || p.lambda (1) <= 1e-12 * p.lambda (0))
    return false;
  normal = p.normal.cast<float> ();
  curvature = static_cast<float> (p.lambda (2) / p.lambda.sum ());
  return true;
}

}  // namespace detail

template <typename PointInT, typename PointOutT> bool
PlanarOctreeNormalEstimation<PointInT, PointOutT>::initCompute ()
{
  // Neither k nor a radius set: this call searches kDefaultNeighbours, and the user's
  // settings are given back unchanged afterwards.
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
PlanarOctreeNormalEstimation<PointInT, PointOutT>::prepare ()
{
  const char* name = "PlanarOctreeNormalEstimation::initCompute";
  // Parameters first: a bad threshold is an error, never a silently odd octree.
  if (growth_passes_ < 0)
  {
    PCL_ERROR ("[pcl::%s] growth passes must be >= 0 (got %d)\n", name, growth_passes_);
    return false;
  }
  if (!(params_.s_alpha > 0) || !(params_.s_beta > 0) || !std::isfinite (params_.s_alpha) ||
      !std::isfinite (params_.s_beta))
  {
    PCL_ERROR ("[pcl::%s] planarity thresholds must be positive and finite (s_alpha %g, s_beta %g)\n",
               name, params_.s_alpha, params_.s_beta);
    return false;
  }
  if (params_.max_depth < 0 || params_.max_depth > 21)
  {
    PCL_ERROR ("[pcl::%s] max depth must be in [0, 21] (got %d)\n", name, params_.max_depth);
    return false;
  }
  if (params_.min_points < 3)
  {
    PCL_ERROR ("[pcl::%s] min points per cell must be >= 3 (got %d)\n", name, params_.min_points);
    return false;
  }
  if (!(border_ratio_ >= 0 && border_ratio_ < 1))
  {
    PCL_ERROR ("[pcl::%s] border ratio must be in [0, 1) (got %g)\n", name, border_ratio_);
    return false;
  }
  if (!(merge_angle_deg_ > 0 && merge_angle_deg_ < 90) || !(merge_thickness_factor_ >= 1) ||
      !std::isfinite (merge_thickness_factor_) || !(adoption_tolerance_ > 0) || !std::isfinite (adoption_tolerance_) ||
      !(residual_split_ratio_ >= 0) || !(adoption_angle_deg_ > 0 && adoption_angle_deg_ <= 90) ||
      !(region_validation_ratio_ >= 0))
  {
    PCL_ERROR ("[pcl::%s] merge angle must be in (0, 90) degrees, thickness factor >= 1 and adoption "
               "tolerance > 0 (got %g, %g, %g)\n", name, merge_angle_deg_, merge_thickness_factor_,
               adoption_tolerance_);
    return false;
  }
  if (patch_size_ < 0 || (patch_size_ > 0 && (patch_support_ < 3 || patch_scales_ < 1 ||
                                                !(max_patch_slope_deg_ > 0 && max_patch_slope_deg_ < 90))))
  {
    PCL_ERROR ("[pcl::%s] patches need size >= 0, support >= 3, scales >= 1 and a slope error in (0, 90) "
               "degrees (got %d, %d, %d, %g)\n", name, patch_size_, patch_support_, patch_scales_,
               max_patch_slope_deg_);
    return false;
  }
  if (!(ladder_tau_ > 0) || !std::isfinite (ladder_tau_) || !(max_patch_noise_ratio_ >= 0))
  {
    PCL_ERROR ("[pcl::%s] scale agreement must be > 0 and finite, patch noise ratio >= 0 (got %g, %g)\n", name,
               ladder_tau_, max_patch_noise_ratio_);
    return false;
  }
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
        lazy_tree_.reset (new pcl::search::LazyKdTree<PointInT> ());
      this->tree_ = lazy_tree_;
    }
  }
  if (!Feature<PointInT, PointOutT>::initCompute ())
    return false;

  // The octree is built over the finite points of the search surface.
  // In parallel when every point is finite (the usual case; serially this copy took
  // ~0.1 s CPU of ~2 s at 1M points).
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
  pclx::normals::PlanarOctreeParams params = params_;
  params.s_alpha = getSAlpha ();
  params.threads = static_cast<int> (threads_);
  params.max_residual_ratio = method_ == Method::MERGED ? residual_split_ratio_ : 0.0;
  if (!octree_.build (surface_points_, params))
  {
    PCL_ERROR ("[pcl::%s] the search surface has %zu finite points that do not span a plane "
               "(fewer than 3, all identical or collinear): no normal is defined\n",
               name, surface_points_.size ());
    return false;
  }
  return true;
}

template <typename PointInT, typename PointOutT> void
PlanarOctreeNormalEstimation<PointInT, PointOutT>::computeFeature (PointCloudOut& output)
{
  const auto& nodes = octree_.nodes ();
  const bool patches = method_ == Method::MERGED && patch_size_ > 0;
  const auto& regions = octree_.regions ();
  const auto& leaf_of_point = octree_.leafOfPoint ();
  const double abs_eps = 1e-6 * nodes[0].half;
  const int threads = threads_ > 0 ? static_cast<int> (threads_) : omp_get_max_threads ();
  // Where no region applies, MERGED picks each point's kNN support from a ladder (Lepski's
  // rule, pclx::normals::selectScale) under the noise of the whole cloud.
  const bool adaptive = method_ == Method::MERGED && this->getKSearch () > 0 &&
                        max_adaptive_neighbours_ > this->getKSearch ();
  const std::vector<int> rungs = adaptive ? pclx::normals::ladderRungs (this->getKSearch (), max_adaptive_neighbours_)
                                          : std::vector<int> ();
  // MERGED's own searches (noise samples, orphans) go to a grid over the search surface
  // when the kd-tree is ours and unbuilt: a parallel grid build is a fraction of FLANN's
  // serial one, and on clean input only a few percent of the points are searched from.
  pclx::normals::GridKnn grid;
  if (adaptive && lazy_tree_ && this->tree_ == lazy_tree_ && !lazy_tree_->isBuilt ())
    grid.build (surface_points_, 24, threads);
  struct KnnScratch
  {
    std::vector<int> ids;
    std::vector<std::uint64_t> keys;  // distanceSlotKey selections (the grid's, the noise sample's)
    std::vector<Eigen::Vector3f> pos;  // positions of the last knn's neighbours, in its order
    // The grid's guesses of the k-th distance (GridKnn::nearestK's radius_hint), one for
    // each of the last two k: the orphans ask for a short and a long list in turn.
    float hint[2] = {0, 0};
    int hint_k[2] = {0, 0};
    float* hintFor (int k)
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
  // k nearest search-surface points of a query (any order), their positions in s.pos:
  // from the grid's cell-ordered copy, not gathered from the cloud point by point.
  auto knn = [&] (const PointInT& query, int k, pcl::Indices& out, std::vector<float>& dist, KnnScratch& s) {
    if (grid.empty ())
    {
      const int m = this->tree_->nearestKSearch (query, k, out, dist);
      s.pos.clear ();
      for (int i = 0; i < std::max (m, 0); ++i)
        s.pos.push_back ((*surface_)[out[i]].getVector3fMap ());
      return m;
    }
    // Orphans come sorted by cell, so the last query's k-th distance bounds this one's well.
    const int m = grid.nearestK (query.getVector3fMap (), k, s.ids, dist, s.keys, &s.pos, s.hintFor (k));
    out.resize (m);
    for (int i = 0; i < m; ++i)
      out[i] = octree_to_surface_[s.ids[i]];
    return m;
  };
  noise_ = pclx::normals::NoiseEstimate ();
  if (adaptive)
  {
    // Noise from ~2000 sampled points (quadric residuals, pclx::normals::sampleNoise).
    struct NoiseScratch
    {
      pcl::Indices nn;
      std::vector<float> dist;
      KnnScratch knn;
    };
    noise_ = pclx::normals::estimateCloudNoise<NoiseScratch> (
        surface_points_.size (), 2000, threads,
        [&] (std::size_t i, std::vector<Eigen::Vector3f>& sorted, NoiseScratch& t) {
          const int m = knn ((*surface_)[octree_to_surface_[i]], 200, t.nn, t.dist, t.knn);
          if (m < 50)
            return;
          t.knn.keys.resize (m);
          for (int q = 0; q < m; ++q)
            t.knn.keys[q] = pclx::normals::distanceSlotKey (t.dist[q], static_cast<std::uint32_t> (q));
          std::sort (t.knn.keys.begin (), t.knn.keys.end ());
          for (const auto key : t.knn.keys)
            sorted.push_back (t.knn.pos[pclx::normals::slotOfKey (key)]);
        });
  }
  const double noise2 = noise_.sigma * noise_.sigma;
  // Patches (quadrics over ~18 points) lose to a PCA plane over a larger support once the
  // noise is a sizeable share of the spacing; they still validate regions.
  const bool noisy = adaptive && noise_.ratio () > max_patch_noise_ratio_;
  const bool use_patches = patches && !noisy;
  // Regions and patches serve no point on noisy input (below): they are not built.
  if (method_ == Method::MERGED && !noisy)
  {
    octree_.mergeCoplanarLeaves (merge_angle_deg_, merge_thickness_factor_);
    octree_.fitRegions (quadric_);
    if (patch_size_ > 0)
      octree_.fitPatches (patch_size_, quadric_, std::tan (max_patch_slope_deg_ * M_PI / 180.0), patch_scales_, patch_support_);
  }
  // The valid patch of an octree point, -1 if none.
  auto patchOf = [&] (int octree_point) {
    const int f = octree_.patchOfPoint ()[octree_point];
    return f >= 0 && octree_.patches ()[f].valid ? f : -1;
  };
  // Points come in any order (a sampled mesh: random) and patches in octree order, so
  // each point's patch is a cache miss; loops that read them in input order fetch the
  // patch of the point kPatchAhead further on first (its index is a sequential read).
  // The record may straddle two cache lines: both ends are fetched.
  constexpr int kPatchAhead = 16;
  const auto& patch_of_point = octree_.patchOfPoint ();
  const pclx::normals::SurfaceFit* const patch_data = octree_.patches ().data ();

  // MERGED: keep a region only if its surface fits it as well as local fits do (its
  // patches, or without patches kNN planes at up to 16 sampled points): otherwise the
  // region is shape, not noise, and its points are better served locally.
  region_ok_.assign (regions.size (), 1);
  if (patches && region_validation_ratio_ > 0)
  {
    // A region is used when its one surface explains its points about as well as the
    // small patch fits do (median patch residual): then the rest is noise, and the big
    // support averages it; otherwise the region hides shape and the patches keep it.
    std::vector<std::vector<double>> patch_rms (regions.size ());
    for (const auto& P : octree_.patches ())
    {
      const int r = nodes[P.leaf].region;
      if (r >= 0 && P.valid)
        patch_rms[r].push_back (P.rms);
    }
#pragma omp parallel for schedule(dynamic, 16) num_threads(threads)
    for (int r = 0; r < static_cast<int> (regions.size ()); ++r)
    {
      auto& v = patch_rms[r];
      if (v.empty ())
        continue;
      std::nth_element (v.begin (), v.begin () + v.size () / 2, v.end ());
      region_ok_[r] = regions[r].surface.rms <= region_validation_ratio_ * v[v.size () / 2] + abs_eps;
    }
  }
  else if (method_ == Method::MERGED && region_validation_ratio_ > 0 && !noisy)
  {
    // Without patches (setPatchSize (0)): the median thickness of kNN planes sampled at up
    // to 16 points inside the region. (Dropped by mistake with the ladder: curved regions
    // were then kept, bunny100k 6.1° → 15.6°.)
    std::vector<std::vector<int>> samples (regions.size ());
    const auto& order = octree_.order ();
    for (int id = 0; id < static_cast<int> (nodes.size ()); ++id)
      if (nodes[id].isLeaf () && nodes[id].region >= 0)
        samples[nodes[id].region].push_back (id);
#pragma omp parallel num_threads(threads)
    {
      pcl::Indices nn;
      std::vector<float> dist;
      std::vector<double> thickness;
      KnnScratch scratch;
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
                                  ? knn ((*surface_)[j], this->getKSearch (), nn, dist, scratch)
                                  : this->searchForNeighbors (*surface_, j, search_parameter_, nn, dist);
            if (found < 3)
              continue;
            Eigen::Matrix3d cov;
            Eigen::Vector4d centroid;
            computeMeanAndCovarianceMatrix (*surface_, nn, cov, centroid);
            thickness.push_back (std::sqrt (pclx::normals::planePca (cov).lambda (2)));
          }
        }
        if (thickness.empty ())
          continue;
        std::nth_element (thickness.begin (), thickness.begin () + thickness.size () / 2, thickness.end ());
        region_ok_[r] = regions[r].surface.rms <= region_validation_ratio_ * thickness[thickness.size () / 2] + abs_eps;
      }
    }
  }
  if (noisy)
  {
    // Under noise the patches' residuals are noise too, and shape smaller than the noise
    // passes the test above (fertility σ = 0.0012: region points 7.4° against 5.2° by the
    // ladder). Requiring the region's rms to match the estimated noise (which is within
    // 3 % of the truth there) did not help: the shape hides inside the sampling error of
    // the rms. On noisy input the ladder serves every point.
    std::fill (region_ok_.begin (), region_ok_.end (), 0);
  }

  // Region of every search-surface point; MERGED grows regions into the non-planar cells:
  // a point joins the neighbouring region whose surface passes within tolerance of it.
  std::vector<int> surface_region (surface_->size (), -1);
#pragma omp parallel for num_threads(threads)
  for (int j = 0; j < static_cast<int> (surface_->size ()); ++j)
    if (surface_to_octree_[j] >= 0)
    {
      const int r = nodes[leaf_of_point[surface_to_octree_[j]]].region;
      surface_region[j] = r >= 0 && region_ok_[r] ? r : -1;
    }
  const double s_alpha = getSAlpha ();
  const double cos_adopt = std::cos (adoption_angle_deg_ * M_PI / 180.0);
  // A region may take point x if its surface passes within tolerance of x and its normal
  // there agrees with x's own local plane (so a region cannot swallow the far side of an edge).
  auto bestRegion = [&] (const Eigen::Vector3f& x, const Eigen::Vector3f* own, const pcl::Indices& nn,
                         const std::vector<int>& region_of) {
    double best = 1.0;
    int region = -1;
    for (const auto j : nn)
    {
      const int r = region_of[j];
      if (r < 0 || r == region)
        continue;
      const double ratio = octree_.regionResidual (r, x) / (adoption_tolerance_ * regions[r].surface.rms + abs_eps);
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
  };
  (void) s_alpha;
  // Prefix sizes the ladder reads: its rungs and Hoppe's k (for region adoption).
  std::vector<int> boundaries = rungs;
  boundaries.push_back (this->getKSearch ());
  std::sort (boundaries.begin (), boundaries.end ());
  boundaries.erase (std::unique (boundaries.begin (), boundaries.end ()), boundaries.end ());
  // Lepski's rule over the ladder for x, from candidate neighbours (any order): sorts them
  // by distance from x; nn keeps the first k of them (Hoppe's set, for region adoption).
  // Every candidate (slot c of positions) keyed by its squared distance from x.
  auto distanceKeys = [] (const Eigen::Vector3f& x, const std::vector<Eigen::Vector3f>& positions, std::size_t count,
                          std::vector<std::uint64_t>& keys) {
    keys.resize (count);
    for (std::size_t c = 0; c < count; ++c)
      keys[c] = pclx::normals::distanceSlotKey ((positions[c] - x).squaredNorm (), static_cast<std::uint32_t> (c));
  };
  auto ladderPlane = [&] (const Eigen::Vector3f& x, const pcl::Indices& candidates,
                          const std::vector<Eigen::Vector3f>& positions, pcl::Indices& nn,
                          std::vector<std::uint64_t>& by_distance, std::vector<Eigen::Vector3f>& sorted,
                          Eigen::Vector3f& normal, float& curvature, int& support,
                          const std::vector<int>& use_rungs, bool* exhausted) {
    distanceKeys (x, positions, candidates.size (), by_distance);
    // Only the rungs' prefixes matter (as sets, with their farthest point last): selection
    // from the largest rung down costs a fraction of a full sort (which was 20 % of the time).
    auto end = by_distance.end ();
    for (auto r = boundaries.rbegin (); r != boundaries.rend (); ++r)
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
      const auto slot = pclx::normals::slotOfKey (key);
      sorted.push_back (positions[slot]);
      if (static_cast<int> (nn.size ()) < this->getKSearch ())
        nn.push_back (candidates[slot]);
    }
    const auto c = pclx::normals::selectScale (x, sorted, use_rungs, noise2, ladder_tau_);
    if (exhausted)
      *exhausted = c.exhausted;
    normal = c.normal;
    curvature = c.curvature;
    support = c.support;
    return c.ok;
  };
  // The local plane of a point where no region applies: Hoppe's kNN PCA, and for MERGED
  // the scale-selected ladder over one search of the largest rung.
  auto localPlane = [&] (const PointCloudIn& cloud, int index, pcl::Indices& nn, Eigen::Vector3f& normal,
                         float& curvature, int& support) {
    if (!adaptive)
    {
      support = static_cast<int> (nn.size ());
      return detail::planeOfNeighbours (*surface_, nn, normal, curvature);
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
    return ladderPlane (cloud[index].getVector3fMap (), big, positions, nn, by_distance, sorted, normal, curvature,
                        support, rungs, nullptr);
  };

  // When the input is its own search surface, orphans' results are reused as they are.
  const bool same_cloud = surface_ == input_;
  // Orphans: search-surface points in non-planar cells (or rejected regions; on noisy
  // input every point).
  std::vector<int> orphans, orphan_slot, groups;
  std::vector<Eigen::Vector3f> orphan_normal;
  std::vector<float> orphan_curvature;
  std::vector<int> orphan_support;
  std::vector<char> orphan_ok;
  if (method_ == Method::MERGED && (adaptive || (growth_passes_ > 0 && !regions.empty ())))
  {
    // Flagged in parallel (a random read of its patch per point), listed in surface
    // order: no result depends on the order (the adaptive path sorts them by cell below,
    // growth is Jacobi).
    orphan_slot.assign (surface_->size (), -1);
    const int nsurface = static_cast<int> (surface_->size ());
#pragma omp parallel for schedule(static) num_threads(threads)
    for (int j = 0; j < nsurface; ++j)
    {
      if (use_patches && j + kPatchAhead < nsurface && surface_to_octree_[j + kPatchAhead] >= 0)
        if (const int f = patch_of_point[surface_to_octree_[j + kPatchAhead]]; f >= 0)
        {
          __builtin_prefetch (&patch_data[f].o);
          __builtin_prefetch (&patch_data[f].valid);
        }
      const int o = surface_to_octree_[j];
      if (o >= 0 && surface_region[j] < 0 && !(use_patches && patchOf (o) >= 0))
        orphan_slot[j] = 0;
    }
    for (int j = 0; j < nsurface; ++j)
      if (orphan_slot[j] == 0)
      {
        orphan_slot[j] = static_cast<int> (orphans.size ());
        orphans.push_back (j);
      }
    const int no = static_cast<int> (orphans.size ());
    std::vector<pcl::Indices> orphan_nn (no);
    orphan_normal.resize (no);
    orphan_curvature.resize (no);
    orphan_support.assign (no, 0);
    orphan_ok.assign (no, 0);
    if (adaptive)
    {
      // One search per group of orphans (a grid cell of 3 spacings, <= 16 points) around
      // their centroid, for half again the largest rung; each member re-sorts the shared
      // list by its own distances. A search of 200+ per point is what made the noisy path
      // slower than fixed-k PCA. Clean input (noise <= getMaxPatchNoiseRatio () spacings)
      // climbs only to 50 (cells of 1.2 spacings): going on to 200 where growth reached 50
      // changed no RMS at the second decimal (fertility, bunny, fandisk, 151A at 100k,
      // fertility and bunny at 1M) and cost 15-20 % of the time at 1M.
      std::vector<int> short_rungs;
      for (const int k : rungs)
        if (k <= 50 && k < rungs.back ())
          short_rungs.push_back (k);
      const bool two_pass = noise_.ratio () <= max_patch_noise_ratio_ && short_rungs.size () >= 2;
      const double cell = (two_pass ? 1.2 : 3.0) * noise_.spacing;
      // Noise wider than a spacing: the ladder's choice is shared by a cell (below).
      const bool share = !two_pass && noise_.ratio () > 1.0;
      {
        std::vector<std::pair<std::uint64_t, int>> keyed (no);
        for (int o = 0; o < no; ++o)
        {
          std::uint64_t key = static_cast<std::uint64_t> (o);  // no spacing: every point alone
          if (cell > 0)
          {
            const Eigen::Vector3d c = ((*surface_)[orphans[o]].getVector3fMap ().template cast<double> () -
                                       octree_.origin ()) / cell;
            key = 0;
            for (int a = 0; a < 3; ++a)
            {
              // 21 bits per axis; far cells may share a key (the distance check below splits them).
              const auto cell_index = static_cast<std::int64_t> (std::floor (std::max (-1e15, std::min (1e15, c[a]))));
              key = (key << 21) | (static_cast<std::uint64_t> (cell_index + (1 << 20)) & ((1u << 21) - 1));
            }
          }
          keyed[o] = {key, orphans[o]};
        }
        std::sort (keyed.begin (), keyed.end ());
        for (int o = 0; o < no; ++o)
          orphans[o] = keyed[o].second;
        for (int o = 0; o < no; ++o)
          orphan_slot[orphans[o]] = o;
        std::vector<int> group_start;
        const float reach2 = static_cast<float> (4.0 * cell * cell);
        for (int o = 0; o < no; ++o)
          if (o == 0 || keyed[o].first != keyed[o - 1].first || o - group_start.back () >= 16 ||
              ((*surface_)[orphans[o]].getVector3fMap () - (*surface_)[orphans[group_start.back ()]].getVector3fMap ())
                      .squaredNorm () > reach2)
            group_start.push_back (o);
        group_start.push_back (no);
        groups.swap (group_start);
      }
      const int ng = static_cast<int> (groups.size ()) - 1;
      // Hoppe's sets (orphan_nn) serve region growth only.
      const bool grows = growth_passes_ > 0 && !regions.empty () && !noisy;
      const std::vector<int>& group_start = groups;
      const int nsurf = static_cast<int> (surface_points_.size ());
      // Members lie within a cell of the centroid: half again covers their own lists in
      // 3-spacing cells; clean input's 1.2-spacing cells need an eighth.
      const int long_k = std::min (nsurf, max_adaptive_neighbours_ + max_adaptive_neighbours_ / (two_pass ? 8 : 2) + 4);
      const int short_k = std::min (nsurf, short_rungs.empty () ? 0 : short_rungs.back () + short_rungs.back () / 4 + 4);
#pragma omp parallel num_threads(threads)
      {
        pcl::Indices candidates;
        std::vector<float> dist;
        std::vector<std::uint64_t> by_distance;
        std::vector<Eigen::Vector3f> sorted;
        std::vector<int> member_rungs;
        KnnScratch scratch;
#pragma omp for schedule(dynamic, 32)
        for (int g = 0; g < ng; ++g)
        {
          Eigen::Vector3f centre = Eigen::Vector3f::Zero ();
          for (int o = group_start[g]; o < group_start[g + 1]; ++o)
            centre += (*surface_)[orphans[o]].getVector3fMap ();
          PointInT query = (*surface_)[orphans[group_start[g]]];
          query.getVector3fMap () = centre / static_cast<float> (group_start[g + 1] - group_start[g]);
          bool more = !two_pass;
          if (two_pass && knn (query, short_k, candidates, dist, scratch) > 0)
            for (int o = group_start[g]; o < group_start[g + 1]; ++o)
            {
              orphan_ok[o] = ladderPlane ((*surface_)[orphans[o]].getVector3fMap (), candidates, scratch.pos, orphan_nn[o],
                                          by_distance, sorted, orphan_normal[o], orphan_curvature[o],
                                          orphan_support[o], short_rungs, nullptr);
              more = more || !orphan_ok[o];  // no plane within 50 points: try the long list
            }
          if (!more || knn (query, long_k, candidates, dist, scratch) <= 0)
            continue;
          if (share)
          {
            // Noise wider than a spacing: the ladder runs once, at the centroid (its choice
            // rarely changes across a cell); each member gets the PCA of its own neighbours
            // at that rung, checked (below).
            Eigen::Vector3f n0;
            float c0;
            int k0 = 0;
            pcl::Indices nn0;
            if (!ladderPlane (query.getVector3fMap (), candidates, scratch.pos, nn0, by_distance, sorted, n0, c0, k0, rungs,
                              nullptr))
              continue;
            for (int o = group_start[g]; o < group_start[g + 1]; ++o)
            {
              const Eigen::Vector3f x = (*surface_)[orphans[o]].getVector3fMap ();
              // The centroid's ladder is done with by_distance: it now keys the member's candidates.
              distanceKeys (x, scratch.pos, candidates.size (), by_distance);
              const int k = std::min<int> (k0, by_distance.size ());
              std::nth_element (by_distance.begin (), by_distance.begin () + (k - 1), by_distance.end ());
              // setCheckSharedRung: the member checks the shared rung on its own neighbours
              // against the rung below (the ladder's one-sided, agreement and residual rules)
              // and climbs its own ladder, capped at the shared rung, only where that refuses
              // it. Unchecked, 151A σ = 0.006 lost 0.65° (19.87° against 19.22°): near thin
              // parts and edges a member's own support disagrees where the centroid's does
              // not. The check costs 12-17 % of the noisy path's CPU there (a full ladder per
              // member 25-35 %), so it is off by default.
              int k1 = 0;  // the rung below k
              for (const int r : rungs)
                if (r < k)
                  k1 = r;
              pclx::normals::ScaleChoice c;
              if (k1 < 3 || !check_shared_rung_)
              {
                // From the candidates' gathered positions: the cloud's points are random reads.
                c.ok = detail::planeOfPositions (x, by_distance.data (), k, scratch.pos, c.normal, c.curvature);
                c.support = k;
              }
              else if (!pclx::normals::keepsLargerRung (x, by_distance.data (), scratch.pos, k1, k, noise2, ladder_tau_, c))
              {
                // Refused: the member's own ladder over its k nearest, each rung's prefix
                // with its farthest point last (selection from the largest down).
                member_rungs.clear ();
                for (const int r : rungs)
                  if (r < k)
                    member_rungs.push_back (r);
                member_rungs.push_back (k);
                std::nth_element (by_distance.begin (), by_distance.begin () + (k - 1), by_distance.begin () + k);
                for (auto r = member_rungs.rbegin () + 1; r < member_rungs.rend (); ++r)
                  std::nth_element (by_distance.begin (), by_distance.begin () + (*r - 1),
                                    by_distance.begin () + (*(r - 1) - 1));
                sorted.clear ();
                for (int q = 0; q < k; ++q)
                  sorted.push_back (scratch.pos[pclx::normals::slotOfKey (by_distance[q])]);
                c = pclx::normals::selectScale (x, sorted, member_rungs, noise2, ladder_tau_);
              }
              orphan_ok[o] = c.ok;
              orphan_normal[o] = c.normal;
              orphan_curvature[o] = c.curvature;
              orphan_support[o] = c.support;
              orphan_nn[o].clear ();
              if (grows)
              {
                // Hoppe's set, for region growth only (none on noisy input).
                const int kh = std::min<int> (this->getKSearch (), k);
                std::nth_element (by_distance.begin (), by_distance.begin () + (kh - 1), by_distance.begin () + k);
                for (int q = 0; q < kh; ++q)
                  orphan_nn[o].push_back (candidates[pclx::normals::slotOfKey (by_distance[q])]);
              }
              if (!orphan_ok[o])
              {
                orphan_normal[o] = n0;
                orphan_curvature[o] = c0;
                orphan_ok[o] = true;
                orphan_support[o] = k;
              }
            }
            continue;
          }
          for (int o = group_start[g]; o < group_start[g + 1]; ++o)
            orphan_ok[o] = ladderPlane ((*surface_)[orphans[o]].getVector3fMap (), candidates, scratch.pos, orphan_nn[o],
                                        by_distance, sorted, orphan_normal[o], orphan_curvature[o],
                                        orphan_support[o], rungs, nullptr);
        }
      }
    }
    else
    {
#pragma omp parallel num_threads(threads)
      {
        std::vector<float> dist;
        pcl::Indices nn;
#pragma omp for schedule(dynamic, 256)
        for (int o = 0; o < no; ++o)
        {
          this->searchForNeighbors (*surface_, orphans[o], search_parameter_, orphan_nn[o], dist);
          nn = orphan_nn[o];
          orphan_ok[o] = localPlane (*surface_, orphans[o], nn, orphan_normal[o], orphan_curvature[o],
                                     orphan_support[o]);
        }
      }
    }
    // Region growing in Jacobi passes (read the previous pass, write the next): deterministic in parallel.
    // Growing regions into noisy non-planar cells adopted points the ladder does better
    // (fertility σ = 0.0012: 11.6° against 5.6°): on noisy input regions do not grow.
    // A pass only revisits the orphans next to a point that joined a region in the pass
    // before (nothing else can change their answer), and writes a list of changes, not a
    // copy of the whole array (32 passes of a 1M-point copy were most of this stage).
    std::vector<std::pair<int, int>> changes, previous;
    std::vector<char> joined (surface_->size (), 0);  // joined a region in the previous pass
    for (int pass = 0; pass < growth_passes_ && !regions.empty () && !noisy; ++pass)
    {
#pragma omp parallel num_threads(threads)
      {
        std::vector<std::pair<int, int>> local;
#pragma omp for schedule(dynamic, 256) nowait
        for (int o = 0; o < no; ++o)
        {
          const int j = orphans[o];
          if (surface_region[j] >= 0)
            continue;  // first come, first kept: re-judging lets far quadrics steal points
          if (pass > 0 && std::none_of (orphan_nn[o].begin (), orphan_nn[o].end (), [&] (index_t q) { return joined[q]; }))
            continue;
          const int r = bestRegion ((*surface_)[j].getVector3fMap (), orphan_ok[o] ? &orphan_normal[o] : nullptr,
                                    orphan_nn[o], surface_region);
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
        surface_region[j] = r;
        joined[j] = 1;
      }
      if (changes.empty ())
        break;
      previous.swap (changes);
      changes.clear ();
    }
  }
  const int n = static_cast<int> (indices_->size ());
  status_.assign (n, INVALID_POINT);
  region_ids_.assign (n, -1);
  support_sizes_.assign (n, 0);
  bool dense = true;

  // MERGED on the input's own points: a non-orphan point's status follows from
  // surface_region (its leaf's region if used) and its patch, without its octree node.
  const bool fast = method_ == Method::MERGED && same_cloud && !orphan_slot.empty ();
  std::vector<int> patch_region;  // region of each patch's leaf (used or not)
  if (fast && use_patches)
  {
    patch_region.resize (octree_.patches ().size ());
    for (std::size_t c = 0; c < patch_region.size (); ++c)
      patch_region[c] = nodes[octree_.patches ()[c].leaf].region;
  }
#pragma omp parallel num_threads(threads) reduction(&& : dense)
  {
    pcl::Indices nn;
    std::vector<float> dist;
#pragma omp for schedule(dynamic, 256)
    for (int i = 0; i < n; ++i)
    {
      if (fast && use_patches && i + kPatchAhead < n)
      {
        const int ahead = (*indices_)[i + kPatchAhead];
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
      const int leaf = same_cloud ? leaf_of_point[surface_to_octree_[index]] : octree_.locate (x);
      Eigen::Vector3f normal;
      float curvature = 0.f;
      std::uint8_t status = INVALID_POINT;
      int region = -1;
      int support = 0;

      const int slot = same_cloud && !orphan_slot.empty () ? orphan_slot[index] : -1;

      if (leaf >= 0 && fast && slot < 0)
      {
        // Not an orphan: its leaf's region (if used) or else its valid patch, read from
        // per-point arrays in input order; the random reads of octree nodes were a third
        // of this loop's time at 1M points.
        if (surface_region[index] >= 0)
        {
          status = REGION_FIT;
          region = surface_region[index];
          normal = octree_.regionNormalAt (region, x);
          curvature = regions[region].surface.curvature;
          support = regions[region].points;
        }
        else if (const int c = patchOf (surface_to_octree_[index]); c >= 0)
        {
          status = PATCH_FIT;
          const auto& P = octree_.patches ()[c];
          normal = octree_.patchNormalAt (c, x);
          curvature = P.curvature;
          support = P.support;
          region = patch_region[c];
        }
      }
      else if (leaf >= 0)
      {
        const pclx::normals::OctreeNode& L = nodes[leaf];
        if (method_ == Method::OCTREE && !L.degenerate)
          status = LEAF_PLANE;  // Algorithm 2 on every leaf, planar or not (the seed's method)
        else if (method_ == Method::HYBRID && L.planar &&
                 octree_.relativeCentreDistance (leaf, x) <= 1.0 - border_ratio_)
          status = LEAF_PLANE;  // §5.4.3: inner points keep the cell's plane
        else if (method_ == Method::MERGED && L.planar && L.region >= 0 && region_ok_[L.region])
        {
          status = REGION_FIT;
          region = L.region;
          normal = octree_.regionNormalAt (region, x);
          curvature = regions[region].surface.curvature;
          support = regions[region].points;
        }
        else if (use_patches && L.planar)
        {
          const int c = same_cloud ? patchOf (surface_to_octree_[index]) : octree_.locatePatch (x);
          if (c >= 0)
          {
            status = PATCH_FIT;
            normal = octree_.patchNormalAt (c, x);
            curvature = octree_.patches ()[c].curvature;
            support = octree_.patches ()[c].support;
            region = L.region;  // the merged region the patch lies in, used or not
          }
        }
        if (status == LEAF_PLANE)
        {
          normal = L.normal;
          curvature = L.curvature;
          support = L.size ();
          region = L.planar ? leaf : -1;
        }
      }

      if (status == INVALID_POINT && slot >= 0)
      {
        if (surface_region[index] >= 0)
        {
          status = ADOPTED_REGION;
          region = surface_region[index];
          normal = octree_.regionNormalAt (region, x);
          curvature = regions[region].surface.curvature;
          support = regions[region].points;
        }
        else if (orphan_ok[slot])
        {
          status = KNN_PCA;
          normal = orphan_normal[slot];
          curvature = orphan_curvature[slot];
          support = orphan_support[slot];
        }
      }
      else if (status == INVALID_POINT && this->searchForNeighbors (index, search_parameter_, nn, dist) > 0)
      {
        const pcl::Indices knn = nn;
        if (localPlane (*input_, index, nn, normal, curvature, support))
          status = KNN_PCA;
        if (method_ == Method::MERGED && !noisy)
        {
          // Planarity-aware border: join the (grown) region whose surface passes through x.
          region = bestRegion (x, status == KNN_PCA ? &normal : nullptr, knn, surface_region);
          if (region >= 0)
          {
            status = ADOPTED_REGION;
            normal = octree_.regionNormalAt (region, x);
            curvature = regions[region].surface.curvature;
            support = regions[region].points;
          }
        }
      }

      if (status == INVALID_POINT || !normal.allFinite ())
      {
        // Degenerate neighbourhood: the smallest enclosing cell that spans a plane.
        const int cell = octree_.nonDegenerateAncestor (leaf >= 0 ? leaf : 0);
        normal = nodes[cell].normal;
        curvature = nodes[cell].curvature;
        status = NEIGHBOUR_FALLBACK;
        region = -1;
        support = nodes[cell].size ();
      }
      out.normal_x = normal.x ();
      out.normal_y = normal.y ();
      out.normal_z = normal.z ();
      out.curvature = curvature;
      status_[i] = status;
      region_ids_[i] = region;
      support_sizes_[i] = support;
    }
  }
  output.is_dense = dense;
}

}  // namespace pcl

#define PCL_INSTANTIATE_PlanarOctreeNormalEstimation(T, NT) \
  template class PCL_EXPORTS pcl::PlanarOctreeNormalEstimation<T, NT>;
