#pragma once
#include <pclx/hpr/detail/visibility.h>
#include <pclx/hpr/hpr_filter.h>

#include <pcl/common/io.h>
#include <pcl/conversions.h>

#include <cmath>
#include <limits>

template <typename PointT> void
pcl::HPRFilter<PointT>::setViewPoint (const Eigen::Vector3f& c)
{
  if (!c.allFinite ())
  {
    PCL_ERROR ("[pcl::%s::setViewPoint] the viewpoint is not finite; keeping the previous one\n",
               getClassName ().c_str ());
    return;
  }
  viewpoint_ = c;
}

template <typename PointT> void
pcl::HPRFilter<PointT>::setRadius (double radius)
{
  if (!(radius > 0 && std::isfinite (radius)))
  {
    PCL_ERROR ("[pcl::%s::setRadius] R must be a finite number > 0; keeping the previous setting\n",
               getClassName ().c_str ());
    return;
  }
  radius_ = radius;
  radius_mode_ = RadiusMode::ABSOLUTE;
}

template <typename PointT> void
pcl::HPRFilter<PointT>::setGamma (double gamma)
{
  if (!(gamma > 0 && std::isfinite (gamma)))
  {
    PCL_ERROR ("[pcl::%s::setGamma] gamma must be a finite number > 0 (R = max|p - C| * 10^gamma); keeping the "
               "previous setting\n",
               getClassName ().c_str ());
    return;
  }
  gamma_ = gamma;
  radius_mode_ = RadiusMode::GAMMA;
}

template <typename PointT> void
pcl::HPRFilter<PointT>::setAutoRadius (double occlusion_depth)
{
  if (!(occlusion_depth > 0 && std::isfinite (occlusion_depth)))
  {
    PCL_ERROR ("[pcl::%s::setAutoRadius] the occlusion depth for the calibrated R must be a finite number > 0; "
               "keeping the previous setting\n",
               getClassName ().c_str ());
    return;
  }
  occlusion_depth_ = occlusion_depth;
  radius_mode_ = RadiusMode::AUTO;
}

template <typename PointT> void
pcl::HPRFilter<PointT>::setGridOversampling (double factor)
{
  if (!(factor > 0 && std::isfinite (factor)))
  {
    PCL_ERROR ("[pcl::%s::setGridOversampling] the grid oversampling must be a finite number > 0; keeping %g\n",
               getClassName ().c_str (), oversampling_);
    return;
  }
  oversampling_ = factor;
}

template <typename PointT> void
pcl::HPRFilter<PointT>::setViewResolution (int pixels, double fov)
{
  if (pixels > 0 && !(fov > 0 && std::isfinite (fov)))
  {
    PCL_ERROR ("[pcl::%s::setViewResolution] the field of view must be a finite number of radians > 0; keeping "
               "the previous setting\n",
               getClassName ().c_str ());
    return;
  }
  view_pixels_ = pixels;
  view_fov_ = fov;
}

template <typename PointT> void
pcl::HPRFilter<PointT>::setPropagation (Propagation mode, int steps)
{
  if (mode == Propagation::FIXED && (steps < 1 || steps % 2 == 0))
  {
    PCL_ERROR ("[pcl::%s::setPropagation] fixed propagation needs an odd mask size m >= 1; keeping the previous "
               "setting\n",
               getClassName ().c_str ());
    return;
  }
  if (steps < 0)
  {
    PCL_ERROR ("[pcl::%s::setPropagation] the number of propagation steps must be >= 0; keeping the previous "
               "setting\n",
               getClassName ().c_str ());
    return;
  }
  propagation_ = mode;
  steps_ = steps;
}

template <typename PointT> void
pcl::HPRFilter<PointT>::setRefinementPasses (int passes)
{
  if (passes < 0 || passes > 8)
  {
    PCL_ERROR ("[pcl::%s::setRefinementPasses] the number of refinement passes must be in 0..8 (each doubles the "
               "culling grid); keeping %d\n",
               getClassName ().c_str (), refinement_);
    return;
  }
  refinement_ = passes;
}

template <typename PointT> void
pcl::HPRFilter<PointT>::applyFilter (Indices& indices)
{
  resetOutputs (indices);
  Gathered in;
  gatherFinitePoints (in);
  const pclx::hpr::detail::VisibilityOptions opt = makeOptions (in);

  const pclx::hpr::detail::VisibilityResult res =
      pclx::hpr::detail::computeVisibility (workspace_.points, opt, &workspace_);
  if (!res.error.empty ())
    return reject (res.error, indices);
  if (!res.warning.empty ())
    PCL_WARN ("[pcl::%s::applyFilter] %s\n", getClassName ().c_str (), res.warning.c_str ());
  radius_used_ = res.radius;
  sectors_used_ = res.sectors;
  steps_used_ = res.steps;
  threads_used_ = res.threads;

  writeIndices (res, in, indices);
  writeMeshAndNormals (res);
}

template <typename PointT> void
pcl::HPRFilter<PointT>::resetOutputs (Indices& indices)
{
  indices.clear ();
  removed_indices_->clear ();
  mesh_ = PolygonMesh ();
  normals_.clear ();
  splat_radii_.clear ();
  radius_used_ = 0;
  sectors_used_ = 0;
  steps_used_ = 0;
  last_error_.clear ();
}

template <typename PointT> void
pcl::HPRFilter<PointT>::reject (const std::string& why, Indices& indices)
{
  // Nothing is visible on a request that cannot be served: report it and keep nothing.
  PCL_ERROR ("[pcl::%s::applyFilter] %s\n", getClassName ().c_str (), why.c_str ());
  last_error_ = why;
  indices.clear ();
  if (extract_removed_indices_)
    *removed_indices_ = *indices_;
}

template <typename PointT> void
pcl::HPRFilter<PointT>::gatherFinitePoints (Gathered& in)
{
  // p − C in double: in float it loses the depth differences when C is far from the cloud.
  // In parallel over fixed blocks of the indices. The first pass writes every point where it
  // would be if all were finite (the usual case: then it is the only pass); otherwise a
  // second pass writes the finite ones again from the input at their blocks' offsets. The
  // result is the serial one for any thread count.
  in.threads = threads_ > 0 ? int (threads_) : pclx::hpr::detail::autoThreads (indices_->size ());
  const int threads = in.threads;
  const std::size_t m = indices_->size ();
  in.requested = m;
  // computeVisibility's blocks: when every point is finite, the sums here are its own.
  constexpr std::size_t kBlock = pclx::hpr::detail::kStatsBlock;
  const std::size_t blocks = (m + kBlock - 1) / kBlock;
  in.blocks = blocks;
  // Per requested index: 0 = not finite, 1 = finite (hidden once the visibility is known),
  // 2 = visible. Per block: finite points before it.
  std::vector<std::uint8_t>& state = workspace_.state;
  std::vector<int>& finite = workspace_.finite;
  std::vector<Eigen::Vector3d>& rel = workspace_.points;
  state.resize (m);
  finite.resize (m);
  rel.resize (m);
  std::vector<std::size_t>& block_start = in.block_start;
  block_start.assign (blocks + 1, 0);
  const Eigen::Vector3d eye = viewpoint_.cast<double> ();
  double max_rho2 = 0, min_rho2 = std::numeric_limits<double>::infinity (), max_coord2 = 0;
  pclx::hpr::detail::PointStats& stats = in.stats;
  stats.block_sum.assign (blocks, Eigen::Vector3d::Zero ());
#pragma omp parallel for num_threads(threads) schedule(static) reduction(max : max_rho2, max_coord2) \
    reduction(min : min_rho2)
  for (std::ptrdiff_t b = 0; b < std::ptrdiff_t (blocks); ++b)
  {
    std::size_t count = 0;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero ();
    for (std::size_t pos = std::size_t (b) * kBlock, end = std::min (m, pos + kBlock); pos < end; ++pos)
    {
      const auto i = (*indices_)[pos];
      const PointT& p = (*input_)[i];
      state[pos] = std::isfinite (p.x) && std::isfinite (p.y) && std::isfinite (p.z);
      if (!state[pos])
        continue;
      ++count;
      finite[pos] = static_cast<int> (i);
      rel[pos] = p.getVector3fMap ().template cast<double> () - eye;
      const double r2 = rel[pos].squaredNorm ();
      max_rho2 = std::max (max_rho2, r2);
      min_rho2 = std::min (min_rho2, r2);
      sum += rel[pos];
      max_coord2 = std::max<double> (max_coord2, p.getVector3fMap ().squaredNorm ());
    }
    block_start[b + 1] = count;
    stats.block_sum[b] = sum;
  }
  stats.max_rho2 = max_rho2;
  stats.min_rho2 = min_rho2;
  for (std::size_t b = 0; b < blocks; ++b)
    block_start[b + 1] += block_start[b];
  if (block_start[blocks] < m)
  {
#pragma omp parallel for num_threads(threads) schedule(static)
    for (std::ptrdiff_t b = 0; b < std::ptrdiff_t (blocks); ++b)
    {
      std::size_t j = block_start[b];
      for (std::size_t pos = std::size_t (b) * kBlock, end = std::min (m, pos + kBlock); pos < end; ++pos)
        if (state[pos])
        {
          const auto i = (*indices_)[pos];
          finite[j] = static_cast<int> (i);
          rel[j++] = (*input_)[i].getVector3fMap ().template cast<double> () - eye;
        }
    }
    finite.resize (block_start[blocks]);
    rel.resize (block_start[blocks]);
  }
  in.max_rho = std::sqrt (max_rho2);
  in.max_coord = std::sqrt (max_coord2);
}

template <typename PointT> pclx::hpr::detail::VisibilityOptions
pcl::HPRFilter<PointT>::makeOptions (const Gathered& in)
{
  namespace hd = pclx::hpr::detail;
  const std::size_t finite = workspace_.finite.size ();
  hd::VisibilityOptions opt;
  method_used_ = method_;
  if (method_ == Method::AUTO)
  {
    // A given R is a request for Katz et al.'s operator at that R, which only EXACT computes.
    const bool radius_given = radius_mode_ != RadiusMode::AUTO && view_pixels_ <= 0;
    if (finite <= kAutoExactLimit || radius_given)
      method_used_ = Method::EXACT;
    else
      method_used_ = view_pixels_ > 0 ? Method::ANGULAR_GRID : Method::CANDIDATE_HULL;
  }
  switch (method_used_)
  {
  case Method::EXACT: opt.method = hd::VisibilityMethod::EXACT; break;
  case Method::CANDIDATE_HULL: opt.method = hd::VisibilityMethod::CANDIDATE_HULL; break;
  case Method::BENTLEY_FAUST_PREPARATA: opt.method = hd::VisibilityMethod::BENTLEY_FAUST_PREPARATA; break;
  case Method::KAVAN: opt.method = hd::VisibilityMethod::KAVAN; break;
  case Method::HYBRID: opt.method = hd::VisibilityMethod::HYBRID; break;
  default: opt.method = hd::VisibilityMethod::ANGULAR_GRID; break;
  }
  if (radius_mode_ == RadiusMode::ABSOLUTE)
    opt.radius = radius_;
  else if (radius_mode_ == RadiusMode::GAMMA)
    opt.radius = in.max_rho * std::pow (10.0, gamma_);
  opt.occlusion_depth = occlusion_depth_;
  opt.sectors = sectors_;
  opt.oversampling = oversampling_;
  opt.view_pixels = view_pixels_;
  opt.view_fov = view_fov_;
  opt.fixed_propagation = propagation_ == Propagation::FIXED;
  opt.steps = steps_;
  opt.exact_prefilter = exact_prefilter_;
  opt.refinement = refinement_;
  opt.triangles = reconstruct_;
  opt.max_edge = max_edge_;
  opt.normals = compute_normals_;
  opt.coordinate_scale = in.max_coord + double (viewpoint_.norm ());
  opt.threads = in.threads;
  opt.stats = finite == in.requested ? &in.stats : nullptr;
  return opt;
}

template <typename PointT> void
pcl::HPRFilter<PointT>::writeIndices (const pclx::hpr::detail::VisibilityResult& res, const Gathered& in,
                                      Indices& indices)
{
  // Kept = visible (or hidden when negative); non-finite points are removed either way.
  // Per block as in gatherFinitePoints (): count, then write in order.
  constexpr std::size_t kBlock = pclx::hpr::detail::kStatsBlock;
  const std::size_t m = in.requested, blocks = in.blocks;
  const int threads = in.threads;
  const std::vector<std::size_t>& block_start = in.block_start;
  std::vector<std::uint8_t>& state = workspace_.state;
  std::vector<std::size_t> block_kept (blocks + 1, 0);
#pragma omp parallel for num_threads(threads) schedule(static)
  for (std::ptrdiff_t b = 0; b < std::ptrdiff_t (blocks); ++b)
  {
    std::size_t j = block_start[b], kept = 0;
    for (std::size_t pos = std::size_t (b) * kBlock, end = std::min (m, pos + kBlock); pos < end; ++pos)
      if (state[pos])
      {
        state[pos] = res.visible[j++] ? 2 : 1;
        kept += (state[pos] == 2) != negative_;
      }
    block_kept[b + 1] = kept;
  }
  for (std::size_t b = 0; b < blocks; ++b)
    block_kept[b + 1] += block_kept[b];
  indices.resize (block_kept[blocks]);
  if (extract_removed_indices_)
    removed_indices_->resize (m - block_kept[blocks]);
#pragma omp parallel for num_threads(threads) schedule(static)
  for (std::ptrdiff_t b = 0; b < std::ptrdiff_t (blocks); ++b)
  {
    std::size_t kept = block_kept[b], removed = std::size_t (b) * kBlock - block_kept[b];
    for (std::size_t pos = std::size_t (b) * kBlock, end = std::min (m, pos + kBlock); pos < end; ++pos)
    {
      const bool keep = state[pos] != 0 && (state[pos] == 2) != negative_;
      if (keep)
        indices[kept++] = (*indices_)[pos];
      else if (extract_removed_indices_)
        (*removed_indices_)[removed++] = (*indices_)[pos];
    }
  }
}

template <typename PointT> void
pcl::HPRFilter<PointT>::writeMeshAndNormals (const pclx::hpr::detail::VisibilityResult& res)
{
  const std::vector<int>& finite = workspace_.finite;
  if (reconstruct_)
  {
    pcl::toPCLPointCloud2 (*input_, mesh_.cloud);
    mesh_.header = input_->header;
    for (const auto& t : res.triangles)
    {
      Vertices v;
      v.vertices.resize (3);
      for (int c = 0; c < 3; ++c)
        v.vertices[c] = finite[t[c]];
      mesh_.polygons.push_back (v);
    }
  }
  if (compute_normals_)
  {
    const float nan = std::numeric_limits<float>::quiet_NaN ();
    normals_.resize (input_->size ());
    normals_.width = input_->width;
    normals_.height = input_->height;
    normals_.is_dense = false;
    splat_radii_.assign (input_->size (), 0.f);
    for (auto& nrm : normals_)
      nrm.normal_x = nrm.normal_y = nrm.normal_z = nrm.curvature = nan;
    for (std::size_t j = 0; j < finite.size (); ++j)
      if (res.visible[j])
      {
        normals_[finite[j]].getNormalVector3fMap () = res.normals[j];
        normals_[finite[j]].curvature = 0.f;
        splat_radii_[finite[j]] = res.splat_radius[j];
      }
  }
}

#define PCL_INSTANTIATE_HPRFilter(T) template class PCL_EXPORTS pcl::HPRFilter<T>;
