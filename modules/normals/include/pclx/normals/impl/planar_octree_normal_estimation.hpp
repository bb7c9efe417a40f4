#pragma once
#include <pclx/normals/planar_octree_normal_estimation.h>

#include <pcl/common/centroid.h>
#include <pcl/common/point_tests.h>

#include <Eigen/Eigenvalues>

#include <cmath>
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

// Hoppe's plane over growing prefixes (k0, 2·k0, 4·k0, ..., all) of a neighbourhood sorted
// by distance (the point itself first): the first that passes λ2 > sα·λ3, else the one with
// the largest λ2 / λ3; growth stops at the first one-sided prefix.
template <typename PointT> bool
adaptivePlane (const PointCloud<PointT>& cloud, const Indices& sorted, std::size_t k0, double s_alpha,
               Eigen::Vector3f& normal, float& curvature, double* best_ratio = nullptr)
{
  if (sorted.size () < 3)
    return false;
  const Eigen::Vector3d ref = cloud[sorted[0]].getVector3fMap ().template cast<double> ();
  Eigen::Vector3d s1 = Eigen::Vector3d::Zero ();
  Eigen::Matrix3d s2 = Eigen::Matrix3d::Zero ();
  double best = -1;
  std::size_t next = std::max<std::size_t> (k0, 3);
  for (std::size_t i = 0; i < sorted.size (); ++i)
  {
    const Eigen::Vector3d d = cloud[sorted[i]].getVector3fMap ().template cast<double> () - ref;
    s1 += d;
    s2.noalias () += d * d.transpose ();
    const std::size_t n = i + 1;
    if (n != next && n != sorted.size ())
      continue;
    next *= 2;
    const Eigen::Vector3d mean = s1 / n;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es (s2 / n - mean * mean.transpose ());
    const Eigen::Vector3d ev = es.eigenvalues ().cwiseMax (0.0);  // ascending
    if (!(ev (2) > 0) || ev (1) <= 1e-12 * ev (2))
      continue;
    const double ratio = ev (1) / std::max (ev (0), 1e-300);
    // A grown set whose centroid lies off the point by more than 0.3 of its radius (in the
    // plane) is one-sided: it grew past a rim or a border, where more points bring another
    // sheet, not less noise (a half disc's centroid sits at 0.42 r, a full disc's at 0).
    // Without this, growing to 200 turned the rim of a thin plate into its sheets' plane.
    if (n > k0)
    {
      const Eigen::Vector3d v = es.eigenvectors ().col (0);
      if ((mean - mean.dot (v) * v).norm () > 0.3 * d.norm ())
        break;
    }
    if (ratio > best)
    {
      best = ratio;
      normal = es.eigenvectors ().col (0).cast<float> ();
      curvature = static_cast<float> (ev (0) / ev.sum ());
    }
    if (ratio > s_alpha)
      break;
  }
  if (best_ratio)
    *best_ratio = best;
  return best >= 0;
}

// Neighbours sorted by distance (the default feature tree returns them unsorted).
inline void
sortByDistance (Indices& nn, std::vector<float>& dist)
{
  std::vector<std::pair<float, index_t>> order (nn.size ());
  for (std::size_t i = 0; i < nn.size (); ++i)
    order[i] = {dist[i], nn[i]};
  std::sort (order.begin (), order.end ());
  for (std::size_t i = 0; i < nn.size (); ++i)
  {
    dist[i] = order[i].first;
    nn[i] = order[i].second;
  }
}
}  // namespace detail

template <typename PointInT, typename PointOutT> bool
PlanarOctreeNormalEstimation<PointInT, PointOutT>::initCompute ()
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
  if (!Feature<PointInT, PointOutT>::initCompute ())
    return false;

  // The octree is built over the finite points of the search surface.
  surface_points_.clear ();
  surface_to_octree_.assign (surface_->size (), -1);
  octree_to_surface_.clear ();
  for (std::size_t i = 0; i < surface_->size (); ++i)
    if (isFinite ((*surface_)[i]))
    {
      surface_to_octree_[i] = static_cast<int> (surface_points_.size ());
      octree_to_surface_.push_back (static_cast<int> (i));
      surface_points_.push_back ((*surface_)[i].getVector3fMap ());
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
  if (method_ == Method::MERGED)
  {
    octree_.mergeCoplanarLeaves (merge_angle_deg_, merge_thickness_factor_);
    octree_.fitRegions (quadric_);
    if (patch_size_ > 0)
      octree_.fitPatches (patch_size_, quadric_, std::tan (max_patch_slope_deg_ * M_PI / 180.0), patch_scales_, patch_support_);
  }
  const bool patches = method_ == Method::MERGED && patch_size_ > 0;
  // The valid patch of an octree point, -1 if none.
  auto patchOf = [&] (int octree_point) {
    const int f = octree_.patchOfPoint ()[octree_point];
    return f >= 0 && octree_.patches ()[f].valid ? f : -1;
  };
  const auto& regions = octree_.regions ();
  const auto& leaf_of_point = octree_.leafOfPoint ();
  const double abs_eps = 1e-6 * nodes[0].half;
  const int threads = threads_ > 0 ? static_cast<int> (threads_) : omp_get_max_threads ();

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
  else if (method_ == Method::MERGED && region_validation_ratio_ > 0)
  {
    // Without patches: the median thickness of kNN planes sampled inside the region.
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
            if (this->searchForNeighbors (*surface_, j, search_parameter_, nn, dist) < 3)
              continue;
            Eigen::Matrix3d cov;
            Eigen::Vector4d centroid;
            computeMeanAndCovarianceMatrix (*surface_, nn, cov, centroid);
            Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es (cov, Eigen::EigenvaluesOnly);
            thickness.push_back (std::sqrt (std::max (0.0, es.eigenvalues () (0))));
          }
        }
        if (thickness.empty ())
          continue;
        std::nth_element (thickness.begin (), thickness.begin () + thickness.size () / 2, thickness.end ());
        region_ok_[r] = regions[r].surface.rms <= region_validation_ratio_ * thickness[thickness.size () / 2] + abs_eps;
      }
    }
  }

  // Region of every search-surface point; MERGED grows regions into the non-planar cells:
  // a point joins the neighbouring region whose surface passes within tolerance of it.
  std::vector<int> surface_region (surface_->size (), -1);
  for (std::size_t j = 0; j < surface_->size (); ++j)
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
  // The local plane of a point where no region applies: Hoppe's kNN PCA, and for MERGED
  // with k growing until the neighbourhood passes the planarity test (noise needs support).
  const bool adaptive = method_ == Method::MERGED && this->getKSearch () > 0 &&
                        max_adaptive_neighbours_ > this->getKSearch ();
  auto localPlane = [&] (const PointCloudIn& cloud, int index, pcl::Indices& nn, std::vector<float>& dist,
                         Eigen::Vector3f& normal, float& curvature) {
    if (!adaptive)
      return detail::planeOfNeighbours (*surface_, nn, normal, curvature);
    detail::sortByDistance (nn, dist);
    double ratio = 0;
    bool ok = detail::adaptivePlane (*surface_, nn, nn.size (), s_alpha, normal, curvature, &ratio);
    if (!(ok && ratio > s_alpha))
    {
      pcl::Indices big;
      std::vector<float> big_dist;
      if (this->searchForNeighbors (cloud, index, max_adaptive_neighbours_, big, big_dist) > 0)
      {
        detail::sortByDistance (big, big_dist);
        ok = detail::adaptivePlane (*surface_, big, this->getKSearch (), s_alpha, normal, curvature) || ok;
      }
    }
    return ok;
  };

  // When the input is its own search surface, orphans' results are reused as they are.
  const bool same_cloud = surface_ == input_;
  // Orphans: search-surface points in non-planar cells (or rejected regions).
  std::vector<int> orphans, orphan_slot;
  std::vector<Eigen::Vector3f> orphan_normal;
  std::vector<float> orphan_curvature;
  std::vector<char> orphan_ok;
  if (method_ == Method::MERGED && growth_passes_ > 0 && !regions.empty ())
  {
    orphan_slot.assign (surface_->size (), -1);
    for (std::size_t j = 0; j < surface_->size (); ++j)
      if (surface_to_octree_[j] >= 0 && surface_region[j] < 0 &&
          !(patches && patchOf (surface_to_octree_[j]) >= 0))
      {
        orphan_slot[j] = static_cast<int> (orphans.size ());
        orphans.push_back (static_cast<int> (j));
      }
    const int no = static_cast<int> (orphans.size ());
    std::vector<pcl::Indices> orphan_nn (no);
    orphan_normal.resize (no);
    orphan_curvature.resize (no);
    orphan_ok.assign (no, 0);
#pragma omp parallel num_threads(threads)
    {
      std::vector<float> dist;
      pcl::Indices nn;
#pragma omp for schedule(dynamic, 256)
      for (int o = 0; o < no; ++o)
      {
        this->searchForNeighbors (*surface_, orphans[o], search_parameter_, orphan_nn[o], dist);
        nn = orphan_nn[o];
        orphan_ok[o] = localPlane (*surface_, orphans[o], nn, dist, orphan_normal[o], orphan_curvature[o]);
      }
    }
    // Region growing in Jacobi passes (read the previous pass, write the next): deterministic in parallel.
    for (int pass = 0; pass < growth_passes_; ++pass)
    {
      std::vector<int> next = surface_region;
      int changed = 0;
#pragma omp parallel for schedule(dynamic, 256) num_threads(threads) reduction(+ : changed)
      for (int o = 0; o < no; ++o)
      {
        const int j = orphans[o];
        if (surface_region[j] >= 0)
          continue;  // first come, first kept: re-judging lets far quadrics steal points
        const int r = bestRegion ((*surface_)[j].getVector3fMap (), orphan_ok[o] ? &orphan_normal[o] : nullptr,
                                  orphan_nn[o], surface_region);
        if (r >= 0)
        {
          next[j] = r;
          ++changed;
        }
      }
      surface_region.swap (next);
      if (changed == 0)
        break;
    }
  }
  const int n = static_cast<int> (indices_->size ());
  status_.assign (n, INVALID_POINT);
  region_ids_.assign (n, -1);
  bool dense = true;

#pragma omp parallel num_threads(threads) reduction(&& : dense)
  {
    pcl::Indices nn;
    std::vector<float> dist;
#pragma omp for schedule(dynamic, 256)
    for (int i = 0; i < n; ++i)
    {
      PointOutT& out = output[i];
      const int index = (*indices_)[i];
      const PointInT& p = (*input_)[index];
      if (!isFinite (p))
      {
        out.normal_x = out.normal_y = out.normal_z = 0.f;
        out.curvature = 0.f;
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

      if (leaf >= 0)
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
        }
        else if (patches && L.planar)
        {
          const int c = same_cloud ? patchOf (surface_to_octree_[index]) : octree_.locatePatch (x);
          if (c >= 0)
          {
            status = PATCH_FIT;
            normal = octree_.patchNormalAt (c, x);
            curvature = octree_.patches ()[c].curvature;
            region = L.region;  // the merged region the patch lies in, used or not
          }
        }
        if (status == LEAF_PLANE)
        {
          normal = L.normal;
          curvature = L.curvature;
          region = L.planar ? leaf : -1;
        }
      }

      const int slot = same_cloud && !orphan_slot.empty () ? orphan_slot[index] : -1;
      if (status == INVALID_POINT && slot >= 0)
      {
        if (surface_region[index] >= 0)
        {
          status = ADOPTED_REGION;
          region = surface_region[index];
          normal = octree_.regionNormalAt (region, x);
          curvature = regions[region].surface.curvature;
        }
        else if (orphan_ok[slot])
        {
          status = KNN_PCA;
          normal = orphan_normal[slot];
          curvature = orphan_curvature[slot];
        }
      }
      else if (status == INVALID_POINT && this->searchForNeighbors (index, search_parameter_, nn, dist) > 0)
      {
        const pcl::Indices knn = nn;
        if (localPlane (*input_, index, nn, dist, normal, curvature))
          status = KNN_PCA;
        if (method_ == Method::MERGED)
        {
          // Planarity-aware border: join the (grown) region whose surface passes through x.
          region = bestRegion (x, status == KNN_PCA ? &normal : nullptr, knn, surface_region);
          if (region >= 0)
          {
            status = ADOPTED_REGION;
            normal = octree_.regionNormalAt (region, x);
            curvature = regions[region].surface.curvature;
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
      }
      out.normal_x = normal.x ();
      out.normal_y = normal.y ();
      out.normal_z = normal.z ();
      out.curvature = curvature;
      status_[i] = status;
      region_ids_[i] = region;
    }
  }
  output.is_dense = dense;
}

}  // namespace pcl

#define PCL_INSTANTIATE_PlanarOctreeNormalEstimation(T, NT) \
  template class PCL_EXPORTS pcl::PlanarOctreeNormalEstimation<T, NT>;
