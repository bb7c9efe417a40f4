#include <pclx/surface/coupled_simplification.h>
#include <pclx/surface/detail/plane_quadric.h>

#include <pcl/console/print.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <functional>
#include <sstream>
#ifdef _OPENMP
#include <omp.h>
#endif

namespace {

using Quadric = pcl::CoupledSimplification::Quadric;
using Clock = std::chrono::steady_clock;
using pclx::surface::detail::addPlane;
using pclx::surface::detail::evaluate;
using pclx::surface::detail::minimiseEdge;
using pclx::surface::detail::weightOf;

double ms (Clock::time_point a, Clock::time_point b)
{
  return std::chrono::duration<double, std::milli> (b - a).count ();
}

// Eigenvalues of a cluster quadric at most this share of the largest are dropped when placing
// its representative.
constexpr double kClusterKeepEigen = 0.02;

// Qw = T⁻ᵀ Q T⁻¹ for T = camera_to_world (planes map with T⁻ᵀ).
Quadric transformQuadric (const Quadric& q, const Eigen::Matrix4d& inv)
{
  Eigen::Matrix4d Q;
  Q << q[0], q[1], q[2], q[3], q[1], q[4], q[5], q[6], q[2], q[5], q[7], q[8], q[3], q[6], q[8], q[9];
  const Eigen::Matrix4d W = inv.transpose () * Q * inv;
  Quadric out;
  out << W (0, 0), W (0, 1), W (0, 2), W (0, 3), W (1, 1), W (1, 2), W (1, 3), W (2, 2), W (2, 3), W (3, 3);
  return out;
}

// Sum and count of the n samples at x below a limit, in four interleaved partial sums: one
// running sum would make every addition wait for the one before.
std::pair<double, std::size_t>
sumBelow (const float* x, std::size_t n, double limit)
{
  double s[4] = {0, 0, 0, 0};
  std::size_t k[4] = {0, 0, 0, 0};
  std::size_t i = 0;
  for (; i + 4 <= n; i += 4)
    for (int j = 0; j < 4; ++j)
      if (x[i + j] < limit) { s[j] += x[i + j]; ++k[j]; }
  for (; i < n; ++i)
    if (x[i] < limit) { s[0] += x[i]; ++k[0]; }
  return {(s[0] + s[1]) + (s[2] + s[3]), k[0] + k[1] + k[2] + k[3]};
}

// Mean of the n samples at x after three trims at 4 × the mean: depth jumps inflate a plain
// mean, the trims leave the surface's own spread.
double
trimmedMean (const float* x, std::size_t n)
{
  if (n == 0)
    return 0;
  double mean = sumBelow (x, n, std::numeric_limits<double>::infinity ()).first / n;
  for (int it = 0; it < 3 && mean > 0; ++it)
  {
    const auto [s, k] = sumBelow (x, n, 4 * mean);
    mean = k ? s / k : mean;
  }
  return mean;
}

// Frames whose range noise (in pixel spacings) is below this keep every pixel and any cell width.
constexpr double kMinAveragedNoise = 0.5;
// Whether a frame is noisy enough for block averaging and the narrowest frustum cell (depth
// cameras: 1–2 pixel spacings; laser range scans: about 0.1).
bool
isNoisy (double range_noise)
{
  return range_noise >= kMinAveragedNoise;
}
// Mean |second difference| of white noise per standard deviation: E|N (0, 6 σ²)| = √(12 / π) σ.
const double kSecondDifferencePerSigma = std::sqrt (12.0 / M_PI);
// Most input pixels per side that block averaging merges (two levels of the pyramid).
constexpr int kMaxAveragingScale = 4;
// Rows the frame statistics sample at least (evenly spaced): tens of thousands of samples on a
// depth camera's frame, enough for a mean, without a pass over every pixel.
constexpr int kStatisticsRows = 64;

// Every how many rows the frame statistics sample a frame of `height` rows (every other row
// on small frames).
inline int statisticsRowStep (int height) { return std::max (2, height / kStatisticsRows); }
// Fewest clusters or edges for which the collapse stage's independent loops run in parallel.
constexpr std::ptrdiff_t kMinParallelItems = 4096;

// Block borders 0 = e_0 < e_1 < … < e_m = n for blocks of mean width b ≥ 1: e_k = ⌊k b + ½⌋,
// so the blocks are ⌊b⌋ or ⌈b⌉ pixels wide (all b when b is whole).
void
blockEdges (int n, double b, std::vector<int>& edges)
{
  edges.clear ();
  for (int k = 0; edges.empty () || edges.back () < n; ++k)
    edges.push_back (std::min (n, static_cast<int> (std::floor (k * b + 0.5))));
}

inline std::uint64_t triKey (int a, int b, int c)
{
  if (a > b) std::swap (a, b);
  if (b > c) std::swap (b, c);
  if (a > b) std::swap (a, b);
  return (static_cast<std::uint64_t> (a) << 42) | (static_cast<std::uint64_t> (b) << 21) |
         static_cast<std::uint64_t> (c);
}

}  // namespace

namespace pcl {

bool
CoupledSimplification::fail (const std::string& msg)
{
  error_ = msg;
  PCL_ERROR ("[pcl::CoupledSimplification] %s\n", msg.c_str ());
  return false;
}

std::string
CoupledSimplification::checkPose (const Eigen::Matrix4d& T)
{
  if (!T.allFinite ())
    return "camera pose has NaN / Inf entries";
  if ((T.row (3) - Eigen::RowVector4d (0, 0, 0, 1)).cwiseAbs ().maxCoeff () > 1e-6)
    return "camera pose is not a rigid transform (last row is not 0 0 0 1)";
  const Eigen::Matrix3d R = T.topLeftCorner<3, 3> ();
  if ((R.transpose () * R - Eigen::Matrix3d::Identity ()).cwiseAbs ().maxCoeff () > 1e-3 ||
      R.determinant () < 0.5)
    return "camera pose is singular or not a rotation (RᵀR ≠ I or det R ≤ 0)";
  return {};
}

std::string
CoupledSimplification::checkIntrinsics (const pcl::DepthIntrinsics& K)
{
  if (!std::isfinite (K.fx) || !std::isfinite (K.fy) || !std::isfinite (K.cx) || !std::isfinite (K.cy))
    return "intrinsics have NaN / Inf entries";
  if (!(K.fx > 0) || !(K.fy > 0))
    return "intrinsics fx, fy must be > 0";
  return {};
}

bool
CoupledSimplification::backProject (const float* depth, int width, int height,
                                    const pcl::DepthIntrinsics& K, const Eigen::Matrix4d& pose)
{
  if (!depth)
    return fail ("depth image is null");
  if (width <= 0 || height <= 0)
    return fail ("frame size must be positive, got " + std::to_string (width) + "×" + std::to_string (height));
  std::string e = checkIntrinsics (K);
  if (e.empty ())
    e = checkPose (pose);
  if (!e.empty ())
    return fail (e);
  if (!(min_depth_ >= 0) || !(max_depth_ > min_depth_))
    return fail ("depth range must satisfy 0 ≤ min < max");
  stats_ = Stats ();
  w_ = width; h_ = height; fx_ = K.fx;
  const std::size_t n = static_cast<std::size_t> (width) * height;
  pts_.resize (n);
  range_.resize (n);
  stats_.pixels = n;
  const float ifx = 1.f / K.fx, ify = 1.f / K.fy, nan = std::numeric_limits<float>::quiet_NaN ();
  std::size_t valid = 0, nonfinite = 0, out = 0;
  for (int v = 0; v < height; ++v)
  {
    const float y = (v - K.cy) * ify;
    for (int u = 0; u < width; ++u)
    {
      const std::size_t i = static_cast<std::size_t> (v) * width + u;
      const float z = depth[i];
      if (!std::isfinite (z))
      {
        ++nonfinite;
        pts_[i].setConstant (nan); range_[i] = 0;
        continue;
      }
      if (z == 0.f || z < min_depth_ || z > max_depth_)
      {
        out += (z != 0.f);
        pts_[i].setConstant (nan); range_[i] = 0;
        continue;
      }
      pts_[i] = Eigen::Vector3f ((u - K.cx) * ifx * z, y * z, z);
      range_[i] = pts_[i].norm ();
      ++valid;
    }
  }
  stats_.valid_pixels = valid;
  stats_.nonfinite_pixels = nonfinite;
  stats_.out_of_range_pixels = out;
  if (valid == 0)
    return fail ("frame has no valid pixel (" + std::to_string (nonfinite) + " NaN/Inf, " +
                 std::to_string (out) + " outside the depth range)");
  return true;
}

bool
CoupledSimplification::takePoints (const Eigen::Vector3f* pts, int width, int height,
                                   const Eigen::Matrix4d& pose)
{
  if (!pts)
    return fail ("organized cloud is null");
  if (width <= 0 || height <= 0)
    return fail ("frame size must be positive, got " + std::to_string (width) + "×" + std::to_string (height));
  const std::string e = checkPose (pose);
  if (!e.empty ())
    return fail (e);
  stats_ = Stats ();
  w_ = width; h_ = height; fx_ = 0;
  const std::size_t n = static_cast<std::size_t> (width) * height;
  pts_.assign (pts, pts + n);
  range_.resize (n);
  stats_.pixels = n;
  std::size_t valid = 0, nonfinite = 0;
  const float nan = std::numeric_limits<float>::quiet_NaN ();
  for (std::size_t i = 0; i < n; ++i)
  {
    const float r = pts_[i].norm ();
    if (!std::isfinite (r) || !(r > 0))
    {
      // NaN is the organized clouds' "no data"; only count Inf (or partly NaN) points.
      nonfinite += !(std::isnan (pts_[i][0]) && std::isnan (pts_[i][1]) && std::isnan (pts_[i][2])) &&
                   !(r == 0);
      pts_[i].setConstant (nan);
      range_[i] = 0;
      continue;
    }
    range_[i] = r;
    ++valid;
  }
  stats_.valid_pixels = valid;
  stats_.nonfinite_pixels = nonfinite;
  if (valid == 0)
    return fail ("frame has no valid point");
  return true;
}

bool
CoupledSimplification::compute (const float* depth_m, int width, int height,
                                const pcl::DepthIntrinsics& K,
                                const Eigen::Matrix4d& camera_to_world, pcl::FrameMesh& out)
{
  const auto t0 = Clock::now ();
  if (!backProject (depth_m, width, height, K, camera_to_world))
    return false;
  stats_.t_backproject = ms (t0, Clock::now ());
  return run (camera_to_world, false, out);
}

bool
CoupledSimplification::compute (const Eigen::Vector3f* camera_points, int width, int height,
                                const Eigen::Matrix4d& camera_to_world, pcl::FrameMesh& out)
{
  const auto t0 = Clock::now ();
  if (!takePoints (camera_points, width, height, camera_to_world))
    return false;
  stats_.t_backproject = ms (t0, Clock::now ());
  return run (camera_to_world, false, out);
}

bool
CoupledSimplification::computeConnectedCloud (const float* depth_m, int width, int height,
                                              const pcl::DepthIntrinsics& K,
                                              const Eigen::Matrix4d& camera_to_world,
                                              pcl::FrameMesh& out)
{
  const auto t0 = Clock::now ();
  if (!backProject (depth_m, width, height, K, camera_to_world))
    return false;
  stats_.t_backproject = ms (t0, Clock::now ());
  return run (camera_to_world, true, out);
}

bool
CoupledSimplification::computeConnectedCloud (const Eigen::Vector3f* camera_points, int width, int height,
                                              const Eigen::Matrix4d& camera_to_world,
                                              pcl::FrameMesh& out)
{
  const auto t0 = Clock::now ();
  if (!takePoints (camera_points, width, height, camera_to_world))
    return false;
  stats_.t_backproject = ms (t0, Clock::now ());
  return run (camera_to_world, true, out);
}

bool
CoupledSimplification::run (const Eigen::Matrix4d& pose, bool dense_only, pcl::FrameMesh& out)
{
  if (!(edge_factor_ > 0) && !(edge_abs_ > 0))
    return fail ("edge threshold: factor or absolute threshold must be > 0");
  if (cell_pixels_ < 1)
    return fail ("frustum cell must be ≥ 1 pixel");
  if (min_cell_pixels_ < 0)
    return fail ("fewest pixels per frustum cell must be ≥ 0");
  if (narrowest_cell_pixels_ < 1)
    return fail ("narrowest frustum cell must be ≥ 1 pixel");
  if (bin_ratio_ < 0 || !std::isfinite (bin_ratio_))
    return fail ("depth-bin ratio must be ≥ 0");
  if (!(target_ratio_ >= 0 && target_ratio_ <= 1))
    return fail ("collapse target ratio must be in [0, 1]");
  if (std::isnan (max_error_))
    return fail ("collapse error bound is NaN");
  if (!(cell_size_ >= 0))
    return fail ("frustum cell size must be ≥ 0");
  error_.clear ();
  const auto t0 = Clock::now ();
  auto t = Clock::now ();
  measureSpacing ();
  measureNoise ();
  stats_.t_spacing = ms (t, Clock::now ());
  t = Clock::now ();
  if (dense_only)
  {
    // Every valid pixel is its own vertex.
    scale_ = 1;
    cid_.assign (pts_.size (), -1);
    std::int32_t k = 0;
    for (std::size_t i = 0; i < pts_.size (); ++i)
      if (range_[i] > 0)
        cid_[i] = k++;
    cq_.assign (k, Quadric::Zero ());
    blockEdges (h_, 1.0, row_edges_);
  }
  else
  {
    reduceResolution ();
    cluster ();
    stats_.t_cluster = ms (t, Clock::now ());
  }
  t = Clock::now ();
  connect (dense_only);
  stats_.t_connect = ms (t, Clock::now ());
  if (!dense_only)
  {
    t = Clock::now ();
    collapse ();
    stats_.t_collapse = ms (t, Clock::now ());
  }
  t = Clock::now ();
  emit (pose, dense_only, out);
  stats_.t_output = ms (t, Clock::now ());
  stats_.t_total = stats_.t_backproject + ms (t0, Clock::now ());
  return true;
}

double
CoupledSimplification::pixelsPerRadian () const
{
  // fx, or for organized clouds 1 / (mean neighbour spacing / range).
  return fx_ > 0 ? fx_ : (stats_.edge_ratio_mean > 0 ? 1.0 / stats_.edge_ratio_mean : 500.0);
}

double
CoupledSimplification::cellWidth () const
{
  if (cell_size_ > 0 && stats_.median_range > 0)
  {
    // The narrowest cell holds for noisy frames only (low-noise scans fit 2 × 2 cells well), in
    // input pixels: an averaged pixel is scale_ of them. Between the bounds the width is not
    // rounded: cells of ⌊B⌋ and ⌈B⌉ pixels alternate, so the cell count follows the range
    // smoothly instead of jumping when the median range crosses a rounding step (from 3 to 2
    // pixels: 2.25 times the cells).
    const double narrowest = std::ceil (static_cast<double> (narrowest_cell_pixels_) / scale_);
    const double lo = isNoisy (stats_.range_noise) ? narrowest : 1.0;
    const double hi = std::max (64.0 / scale_, lo);
    return std::clamp (cell_size_ * pixelsPerRadian () / stats_.median_range, lo, hi);
  }
  return std::max (1, cell_pixels_ / scale_);
}

// Levels of 2 × 2 block averages (the depth pyramid of Newcombe et al. 2011) before
// clustering, on noisy frames only (range noise of at least half a pixel spacing; low-noise range
// scans would only be blurred). One level when a frustum cell is at least twice the set number of
// pixels wide: the cells then come from a quarter of the faces, each less noisy. Further levels,
// up to kMaxAveragingScale, while a pixel's noise at the median range exceeds half a frustum cell
// (a leaf of the octree), as in a depth camera's distant views: at full resolution their bumps
// would cross the lattice as surface, in front of and behind the true one.
void
CoupledSimplification::reduceResolution ()
{
  scale_ = 1;
  if (min_cell_pixels_ <= 0 || !isNoisy (stats_.range_noise))
    return;
  double sigma = stats_.range_noise / (kSecondDifferencePerSigma * pixelsPerRadian ()) * stats_.median_range;
  const bool wide_cells = std::lround (cellWidth ()) >= 2 * min_cell_pixels_;
  const auto noisier_than_cells = [this, &sigma] { return cell_size_ > 0 && sigma > 0.5 * cell_size_; };
  while (w_ >= 2 && h_ >= 2 && scale_ < kMaxAveragingScale && ((scale_ == 1 && wide_cells) || noisier_than_cells ()))
  {
    halveResolution ();
    scale_ *= 2;
    sigma *= 0.5;  // the mean of four independent pixels
    measureSpacing ();
  }
  stats_.block_averaged = scale_ > 1;
  stats_.averaging_scale = scale_;
}

// Each 2 × 2 block becomes the mean of its valid pixels within the diagonal edge threshold of
// its nearest one, so a block across a depth edge keeps the near surface, not a point between.
void
CoupledSimplification::halveResolution ()
{
  const int W = w_, H = h_, w2 = (W + 1) / 2, h2 = (H + 1) / 2;
  const float rel = static_cast<float> (std::sqrt (2.0) * edge_factor_ * stats_.edge_ratio_mean);
  const float abs_tol = static_cast<float> (std::sqrt (2.0) * edge_abs_);
  const float nan = std::numeric_limits<float>::quiet_NaN ();
  half_pts_.resize (static_cast<std::size_t> (w2) * h2);
  half_range_.resize (half_pts_.size ());
  for (int v2 = 0; v2 < h2; ++v2)
    for (int u2 = 0; u2 < w2; ++u2)
    {
      std::size_t idx[4];
      int n = 0;
      float nearest = std::numeric_limits<float>::infinity ();
      for (int dv = 0; dv < 2; ++dv)
        for (int du = 0; du < 2; ++du)
        {
          const int u = 2 * u2 + du, v = 2 * v2 + dv;
          if (u >= W || v >= H)
            continue;
          const std::size_t i = static_cast<std::size_t> (v) * W + u;
          if (range_[i] > 0)
            idx[n++] = i, nearest = std::min (nearest, range_[i]);
        }
      const std::size_t o = static_cast<std::size_t> (v2) * w2 + u2;
      if (n == 0)
      {
        half_pts_[o].setConstant (nan);
        half_range_[o] = 0;
        continue;
      }
      const float tol = edge_abs_ > 0 ? abs_tol : rel * nearest;
      Eigen::Vector3f sum = Eigen::Vector3f::Zero ();
      int k = 0;
      for (int j = 0; j < n; ++j)
        if (range_[idx[j]] - nearest <= tol)
          sum += pts_[idx[j]], ++k;
      half_pts_[o] = sum / static_cast<float> (k);
      half_range_[o] = half_pts_[o].norm ();
    }
  pts_.swap (half_pts_);
  range_.swap (half_range_);
  w_ = w2;
  h_ = h2;
  if (fx_ > 0)
    fx_ *= 0.5;
}

// §3.3 first phase, the cells: B × B pixel blocks × geometric depth bins. A block's pixels
// fall in few bins, so a small linear list per block replaces a hash map.
void
CoupledSimplification::cluster ()
{
  const double fx_eff = pixelsPerRadian ();
  const double B = cellWidth ();
  stats_.cell_pixels = static_cast<int> (std::lround (B * scale_));
  blockEdges (w_, B, col_edges_);
  blockEdges (h_, B, row_edges_);
  const double r = bin_ratio_ > 0 ? bin_ratio_ : B / fx_eff;
  cid_.assign (pts_.size (), -1);
  cq_.clear (); csum_.clear (); cmin_.clear (); cmax_.clear (); ccount_.clear (); cscale_.clear ();
  // Per block: its pixels sorted by range, split where consecutive ranges jump by more than a
  // bin (r · range) or the cell grows deeper than two bins. Fixed bin boundaries would cut a
  // continuous (noisy) surface into slivers; gaps are where the surfaces along the rays part.
  std::vector<std::pair<float, std::int32_t>> block;
  const int side = static_cast<int> (std::ceil (B));
  block.reserve (static_cast<std::size_t> (side) * side);
  const float rf = static_cast<float> (r);
  for (std::size_t j = 0; j + 1 < row_edges_.size (); ++j)
    for (std::size_t k = 0; k + 1 < col_edges_.size (); ++k)
    {
      block.clear ();
      for (int v = row_edges_[j]; v < row_edges_[j + 1]; ++v)
        for (int u = col_edges_[k]; u < col_edges_[k + 1]; ++u)
        {
          const std::int32_t i = v * w_ + u;
          if (range_[i] > 0)
            block.emplace_back (range_[i], i);
        }
      if (block.empty ())
        continue;
      // Most blocks see one surface within a bin: no sort needed then.
      float lo = block[0].first, hi = lo;
      for (const auto& e : block)
        lo = std::min (lo, e.first), hi = std::max (hi, e.first);
      if (hi - lo > rf * lo)
        std::sort (block.begin (), block.end ());
      std::int32_t c = -1;
      float start = 0, prev = 0;
      for (const auto& e : block)
      {
        const float rr = e.first;
        if (c < 0 || rr - prev > rf * rr || rr - start > 2 * rf * rr)
        {
          c = static_cast<std::int32_t> (ccount_.size ());
          start = rr;
          const Eigen::Vector3f& p = pts_[e.second];
          csum_.emplace_back (Eigen::Vector3d::Zero ());
          cmin_.push_back (p); cmax_.push_back (p);
          ccount_.push_back (0);
          cscale_.push_back (static_cast<float> (B * rr / fx_eff));
        }
        prev = rr;
        const Eigen::Vector3f& p = pts_[e.second];
        csum_[c] += p.cast<double> ();
        cmin_[c] = cmin_[c].cwiseMin (p);
        cmax_[c] = cmax_[c].cwiseMax (p);
        ++ccount_[c];
        cid_[e.second] = c;
      }
    }
  cq_.assign (ccount_.size (), Quadric::Zero ());
  stats_.clusters = ccount_.size ();
}

// Trimmed mean of |p − q| / range over horizontal and vertical neighbours (§4.2's mean
// neighbour distance, made depth-independent), and the median range of the frame.
void
CoupledSimplification::measureSpacing ()
{
  const int W = w_, H = h_, step = statisticsRowStep (H);
  // The samples go by index into a buffer that holds them all (push_back would cost a
  // function call per sample).
  float* r = sampleBuffer (static_cast<std::size_t> (W) * (H + 1));
  std::size_t n = 0;
  for (int v = 0; v < H; v += step)
    for (int u = 0; u < W; ++u)
    {
      const std::size_t i = static_cast<std::size_t> (v) * W + u;
      if (!(range_[i] > 0))
        continue;
      if (u + 1 < W && range_[i + 1] > 0)
        r[n++] = (pts_[i] - pts_[i + 1]).norm () / std::min (range_[i], range_[i + 1]);
      if (v + 1 < H && range_[i + W] > 0)
        r[n++] = (pts_[i] - pts_[i + W]).norm () / std::min (range_[i], range_[i + W]);
    }
  stats_.edge_ratio_mean = trimmedMean (r, n);
  // The median range over every seventh pixel, or over all when none of those is valid (the
  // buffer holds at least one sample per pixel).
  n = 0;
  for (std::size_t i = 0; i < range_.size (); i += 7)
    if (range_[i] > 0)
      r[n++] = range_[i];
  if (n == 0)
    for (float x : range_)
      if (x > 0) r[n++] = x;
  std::nth_element (r, r + n / 2, r + n);
  stats_.median_range = n == 0 ? 0 : r[n / 2];
}

// Trimmed mean of the second difference of range along rows, in pixel spacings: a smooth
// surface's is far below one, the sensor's noise makes it about √6 σ.
void
CoupledSimplification::measureNoise ()
{
  const int W = w_, H = h_, step = statisticsRowStep (H);
  // Written by index, as in measureSpacing ().
  float* r = sampleBuffer (static_cast<std::size_t> (W) * (H + 1) / 2);
  std::size_t n = 0;
  for (int v = 0; v < H; v += step)
    for (int u = 1; u + 1 < W; ++u)
    {
      const std::size_t i = static_cast<std::size_t> (v) * W + u;
      if (range_[i - 1] > 0 && range_[i] > 0 && range_[i + 1] > 0)
        r[n++] = std::abs (range_[i - 1] - 2 * range_[i] + range_[i + 1]) / range_[i];
    }
  stats_.range_noise = trimmedMean (r, n) * pixelsPerRadian ();
}

// The sample buffer of measureSpacing () and measureNoise (), at least n long. It only grows,
// so a frame does not clear what it is about to overwrite.
float*
CoupledSimplification::sampleBuffer (std::size_t n)
{
  if (ratios_.size () < n)
    ratios_.resize (n);
  return ratios_.data ();
}

// The row bands of connect (), one per thread: cut[t] is band t's first quad row, and
// cut[threads] = H − 1 ends the last band. Each inner cut is the last cluster-block border at or
// before an even split of the rows; there are at most a quarter as many bands as block rows.
std::vector<int>
CoupledSimplification::connectBands () const
{
  const int block_rows = static_cast<int> (row_edges_.size ()) - 1;
#ifdef _OPENMP
  const int threads = std::max (1, std::min (omp_get_max_threads (), block_rows / 4));
#else
  const int threads = 1;
#endif
  std::vector<int> cut (threads + 1, 0);
  for (int t = 1; t < threads; ++t)
    cut[t] = *(std::upper_bound (row_edges_.begin (), row_edges_.end (), h_ * t / threads) - 1);
  cut[threads] = h_ - 1;  // quad rows are 0 … H − 2
  return cut;
}

// §3.2: 4-neighbour triangles under the edge threshold; each face's area-weighted plane
// quadric goes to the clusters (or dense vertices) of its three corners.
void
CoupledSimplification::connect (bool dense_only)
{
  const int W = w_;
  const double ratio = stats_.edge_ratio_mean;
  const float kf = static_cast<float> (edge_factor_ * ratio);
  const float abs2 = static_cast<float> (edge_abs_ * edge_abs_);
  auto ok = [&] (std::size_t a, std::size_t b, float scale2) {
    const float d2 = (pts_[a] - pts_[b]).squaredNorm ();
    if (edge_abs_ > 0)
      return d2 < abs2 * scale2;
    const float t = kf * std::min (range_[a], range_[b]);
    return d2 < t * t * scale2;
  };
  // Per thread: its faces (clustered or dense), orientation vote and dense-face count, each on
  // its own cache line (the counters change with every face). A border row between two bands
  // keeps its quadrics for the pixels before `defer_before` (the rows above the border) in
  // `deferred`.
  // The faces inside one cluster that follow each other along a quad row are summed in `run`
  // first (`run_pixel`: a pixel of that cluster), so a cluster's quadric is loaded and stored
  // once per run rather than once per face.
  struct alignas (64) Part
  {
    std::vector<Eigen::Vector3i> tris;
    long vote = 0;
    std::size_t dense = 0;
    std::size_t defer_before = 0;
    std::vector<std::pair<std::int32_t, Quadric>> deferred;
    Quadric run = Quadric::Zero ();
    std::int64_t run_pixel = -1;
  };
  auto addQuadric = [&] (Part& part, std::size_t pixel, const Quadric& k) {
    if (pixel < part.defer_before)
      part.deferred.emplace_back (cid_[pixel], k);
    else
      cq_[cid_[pixel]] += k;
  };
  auto flushRun = [&] (Part& part) {
    if (part.run_pixel >= 0)
      addQuadric (part, static_cast<std::size_t> (part.run_pixel), part.run);
    part.run.setZero ();
    part.run_pixel = -1;
  };
  auto face = [&] (Part& part, std::size_t a, std::size_t b, std::size_t c, bool diag_ab, bool diag_bc,
                   bool diag_ca) {
    if (!ok (a, b, diag_ab ? 2.f : 1.f) || !ok (b, c, diag_bc ? 2.f : 1.f) || !ok (c, a, diag_ca ? 2.f : 1.f))
      return;
    const Eigen::Vector3f& pa = pts_[a];
    const Eigen::Vector3f cr = (pts_[b] - pa).cross (pts_[c] - pa);
    const float len = cr.norm ();
    if (!(len > 0))
      return;
    const Eigen::Vector3f nf = cr / len;
    const float d = -nf.dot (pa);
    part.vote += (d > 0) ? 1 : -1;  // n·(0 − a) > 0: faces the camera
    const std::int32_t ia = cid_[a], ib = cid_[b], ic = cid_[c];
    // One face quadric (area-weighted), added at each corner; most faces lie in one cluster.
    // A face's first corner lies on the quad row's upper pixel row, so a run never spans the
    // rows a border defers.
    if (ia == ib && ib == ic)
    {
      if (part.run_pixel < 0 || cid_[static_cast<std::size_t> (part.run_pixel)] != ia)
      {
        flushRun (part);
        part.run_pixel = static_cast<std::int64_t> (a);
      }
      addPlane (part.run, nf.cast<double> (), d, 1.5 * len);
    }
    else
    {
      Quadric k = Quadric::Zero ();
      addPlane (k, nf.cast<double> (), d, 0.5 * len);
      addQuadric (part, a, k);
      addQuadric (part, b, k);
      addQuadric (part, c, k);
    }
    ++part.dense;
    if (dense_only || (ia != ib && ib != ic && ic != ia))
      part.tris.emplace_back (ia, ib, ic);
  };
  auto quadRow = [&] (Part& part, int v) {
    for (int u = 0; u + 1 < W; ++u)
    {
      const std::size_t i00 = static_cast<std::size_t> (v) * W + u, i10 = i00 + 1, i01 = i00 + W,
                        i11 = i01 + 1;
      const bool v00 = range_[i00] > 0, v10 = range_[i10] > 0, v01 = range_[i01] > 0, v11 = range_[i11] > 0;
      const int nvalid = v00 + v10 + v01 + v11;
      if (nvalid < 3)
        continue;
      // Counter-clockwise seen from the camera (x right, y down, looking along +z).
      if (nvalid == 4)
      {
        if ((pts_[i00] - pts_[i11]).squaredNorm () <= (pts_[i10] - pts_[i01]).squaredNorm ())
        {
          face (part, i00, i01, i11, false, false, true);
          face (part, i00, i11, i10, true, false, false);
        }
        else
        {
          face (part, i00, i01, i10, false, true, false);
          face (part, i10, i01, i11, true, false, false);
        }
      }
      else if (!v11) face (part, i00, i01, i10, false, true, false);
      else if (!v00) face (part, i10, i01, i11, true, false, false);
      else if (!v10) face (part, i00, i01, i11, false, false, true);
      else face (part, i00, i11, i10, true, false, false);
    }
    flushRun (part);
  };
  // Row bands, one per thread, cut at cluster-block rows: a band's quads below its last row
  // touch only its own clusters (or dense vertices), so the bands run in parallel. The quad row
  // across each border runs first for the clusters below it and last for those above, and the
  // faces are joined in row order: every cluster sums its quadrics in the order one thread
  // does, so the result depends neither on timing nor on the thread count.
  const std::vector<int> cut = connectBands ();
  const int threads = static_cast<int> (cut.size ()) - 1;
  std::vector<Part> bands (threads), borders (threads);
  std::vector<Eigen::Vector3i>& tris = dense_only ? dense_tris_ : ctris_;
  tris.clear ();
  bands[0].tris.swap (tris);  // the first band fills the output's buffer, which keeps its memory
  for (int t = 1; t < threads; ++t)
    if (cut[t] >= 1)
    {
      borders[t].defer_before = static_cast<std::size_t> (cut[t]) * W;
      quadRow (borders[t], cut[t] - 1);
    }
#pragma omp parallel for num_threads (threads) schedule (static, 1)
  for (int t = 0; t < threads; ++t)
    for (int v = cut[t]; v < (t + 1 < threads ? cut[t + 1] - 1 : cut[t + 1]); ++v)
      quadRow (bands[t], v);
  tris.swap (bands[0].tris);  // borders[0] is empty: the first band's faces come first
  orientation_vote_ = 0;
  std::size_t dense = 0;
  for (int t = 0; t < threads; ++t)
    for (Part* p : {&borders[t], &bands[t]})
    {
      for (const auto& [cluster, k] : p->deferred)
        cq_[cluster] += k;
      if (p != &bands[0])
        tris.insert (tris.end (), p->tris.begin (), p->tris.end ());
      orientation_vote_ += p->vote;
      dense += p->dense;
    }
  stats_.dense_triangles = dense;
}

bool
CoupledSimplification::CollapseState::facesCamera (const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                                   const Eigen::Vector3d& c) const
{
  return facing * (b - a).cross (c - a).dot (-a) > 0;
}

void
CoupledSimplification::placeRepresentatives ()
{
  // The cluster quadric's minimiser, kept near the cluster; clusters are independent.
  const std::ptrdiff_t nc = static_cast<std::ptrdiff_t> (ccount_.size ());
  cpos_.resize (nc);
  std::size_t fallbacks = 0;
#pragma omp parallel for schedule (static) reduction (+ : fallbacks) if (nc > kMinParallelItems)
  for (std::ptrdiff_t c = 0; c < nc; ++c)
  {
    const Eigen::Vector3d mean = csum_[c] / ccount_[c];
    if (ccount_[c] == 1 || !(weightOf (cq_[c]) > 0))
    {
      cpos_[c] = mean;
      continue;
    }
    Eigen::Vector3d x = pclx::surface::detail::minimise (cq_[c], mean, kClusterKeepEigen);
    const Eigen::Vector3d margin = Eigen::Vector3d::Constant (0.1 * cscale_[c]);
    const Eigen::Vector3d lo = cmin_[c].cast<double> () - margin, hi = cmax_[c].cast<double> () + margin;
    if (!x.allFinite ())
    {
      x = mean;
      ++fallbacks;
    }
    else if ((x.array () < lo.array ()).any () || (x.array () > hi.array ()).any ())
    {
      x = x.cwiseMax (lo).cwiseMin (hi);
      ++fallbacks;
    }
    cpos_[c] = x;
  }
  stats_.cluster_fallbacks += fallbacks;
}

void
CoupledSimplification::dropBackfacingAndDuplicateFaces (const CollapseState& s)
{
  // Every surface a depth frame sees faces it, so faces turned away are clustering fold-overs;
  // duplicates are two dense faces between the same three clusters.
  {
    std::size_t k = 0;
    for (std::size_t f = 0; f < ctris_.size (); ++f)
      if (s.facesCamera (cpos_[ctris_[f][0]], cpos_[ctris_[f][1]], cpos_[ctris_[f][2]]))
        ctris_[k++] = ctris_[f];
      else
        ++stats_.backfacing;
    ctris_.resize (k);
  }
  auto& keys = tri_keys_;
  keys.resize (ctris_.size ());
  for (std::size_t f = 0; f < ctris_.size (); ++f)
    keys[f] = {triKey (ctris_[f][0], ctris_[f][1], ctris_[f][2]), static_cast<std::int32_t> (f)};
  std::sort (keys.begin (), keys.end ());
  // Keep the first face of each key (the lowest index of its run), in the original order.
  auto& keep = face_keep_;
  keep.assign (ctris_.size (), 0);
  for (std::size_t i = 0; i < keys.size (); ++i)
    if (i == 0 || keys[i].first != keys[i - 1].first)
      keep[keys[i].second] = 1;
  std::size_t k = 0;
  for (std::size_t f = 0; f < ctris_.size (); ++f)
    if (keep[f])
      ctris_[k++] = ctris_[f];
  ctris_.resize (k);
}

void
CoupledSimplification::buildCollapseConnectivity (CollapseState& s)
{
  const std::size_t nc = ccount_.size ();
  if (vf_.size () < nc)
    vf_.resize (nc);
  for (std::size_t v = 0; v < nc; ++v)
    vf_[v].clear ();  // keeps the capacity of earlier frames
  auto& vf = vf_;
  for (std::size_t f = 0; f < ctris_.size (); ++f)
    for (int k = 0; k < 3; ++k)
      vf[ctris_[f][k]].push_back (static_cast<std::int32_t> (f));
  s.face_alive.assign (ctris_.size (), 1);
  s.vert_alive.assign (nc, 1);
  s.locked.assign (nc, 0);
  s.stamp.assign (nc, 0);
  cb_.assign (nc, Quadric::Zero ());

  // The edges (a, b), a < b, in (a, b) order with their face counts, from each vertex's faces.
  auto& ends = s.na;
  for (std::size_t v = 0; v < nc; ++v)
  {
    const std::int32_t a = static_cast<std::int32_t> (v);
    ends.clear ();
    for (std::int32_t f : vf[a])
      for (int k = 0; k < 3; ++k)
        if (ctris_[f][k] > a)
          ends.push_back (ctris_[f][k]);
    std::sort (ends.begin (), ends.end ());
    for (std::size_t k = 0; k < ends.size ();)
    {
      std::size_t j = k;
      while (j < ends.size () && ends[j] == ends[k]) ++j;
      const std::int32_t b = ends[k];
      const std::size_t count = j - k;
      if (count > 2)
        s.locked[a] = s.locked[b] = 1;  // non-manifold: leave as it is
      else if (count == 1)
        addBoundaryConstraint (a, b);
      s.unique_edges.emplace_back (a, b);
      k = j;
    }
  }
}

void
CoupledSimplification::addBoundaryConstraint (std::int32_t a, std::int32_t b)
{
  // A plane through the boundary edge, perpendicular to its face (Garland–Heckbert).
  for (std::int32_t f : vf_[a])
  {
    const auto& t = ctris_[f];
    if ((t[0] == b || t[1] == b || t[2] == b))
    {
      const Eigen::Vector3d fn = (cpos_[t[1]] - cpos_[t[0]]).cross (cpos_[t[2]] - cpos_[t[0]]);
      Eigen::Vector3d n;
      double d;
      if (pclx::surface::detail::boundaryPlane (cpos_[a], cpos_[b], fn, n, d))
      {
        const double w = boundary_weight_ * (cpos_[b] - cpos_[a]).squaredNorm ();
        addPlane (cb_[a], n, d, w);
        addPlane (cb_[b], n, d, w);
      }
      break;
    }
  }
}

Eigen::Vector3d
CoupledSimplification::placeCollapse (std::int32_t a, std::int32_t b, double& err) const
{
  Quadric q = cq_[a] + cq_[b] + cb_[a] + cb_[b];
  const Eigen::Vector3d m = 0.5 * (cpos_[a] + cpos_[b]);
  Eigen::Vector3d x = minimiseEdge (q);
  if (!x.allFinite () || (x - m).squaredNorm () > (cpos_[a] - cpos_[b]).squaredNorm ())
  {
    // Best of the endpoints and the midpoint (Garland–Heckbert's fallback).
    const double ea = evaluate (q, cpos_[a]), eb = evaluate (q, cpos_[b]), em = evaluate (q, m);
    x = ea < eb ? (ea < em ? cpos_[a] : m) : (eb < em ? cpos_[b] : m);
  }
  const double wsum = weightOf (cq_[a]) + weightOf (cq_[b]);
  err = std::sqrt (std::max (0.0, evaluate (q, x)) / std::max (wsum, 1e-30));
  return x;
}

double
CoupledSimplification::collapseBound (std::int32_t a, std::int32_t b) const
{
  if (max_error_ > 0)
    return max_error_;
  if (max_error_ < 0)
    return std::numeric_limits<double>::infinity ();
  return 0.05 * (cscale_[a] + cscale_[b]);  // 0.1 × the mean cell size
}

double
CoupledSimplification::collapseKey (std::int32_t a, std::int32_t b) const
{
  double err;
  placeCollapse (a, b, err);
  const double bnd = collapseBound (a, b);
  return std::isinf (bnd) ? err : err / bnd;
}

void
CoupledSimplification::pushCollapse (CollapseState& s, std::int32_t a, std::int32_t b) const
{
  if (s.locked[a] || s.locked[b])
    return;
  const double key = collapseKey (a, b);
  if (key > s.key_limit)
    return;
  s.heap.push_back ({key, a, b, s.stamp[a], s.stamp[b]});
  std::push_heap (s.heap.begin (), s.heap.end (), std::greater<CollapseState::Entry> ());
}

// The candidates of every edge of the clustered mesh: their keys are independent, so they are
// computed in parallel, and the heap is built once (its order is total, see Entry).
void
CoupledSimplification::pushAllEdges (CollapseState& s) const
{
  const auto& edges = s.unique_edges;
  s.heap.resize (edges.size ());
  const std::ptrdiff_t n = static_cast<std::ptrdiff_t> (edges.size ());
#pragma omp parallel for schedule (static) if (n > kMinParallelItems)
  for (std::ptrdiff_t i = 0; i < n; ++i)
  {
    const std::int32_t a = edges[i].first, b = edges[i].second;
    const bool open = !s.locked[a] && !s.locked[b];
    s.heap[i] = {open ? collapseKey (a, b) : std::numeric_limits<double>::infinity (), a, b, s.stamp[a], s.stamp[b]};
  }
  s.heap.erase (std::remove_if (s.heap.begin (), s.heap.end (),
                                [&s] (const CollapseState::Entry& e) {
                                  return s.locked[e.a] || s.locked[e.b] || e.key > s.key_limit;
                                }),
                s.heap.end ());
  std::make_heap (s.heap.begin (), s.heap.end (), std::greater<CollapseState::Entry> ());
}

bool
CoupledSimplification::linkConditionHolds (CollapseState& s, std::int32_t a, std::int32_t b) const
{
  // The common neighbours of a and b are exactly the opposite corners of the faces on the
  // edge, otherwise the collapse pinches the surface.
  auto& na = s.na;
  auto& nb = s.nb;
  na.clear (); nb.clear ();
  int shared = 0;
  for (std::int32_t f : vf_[a])
  {
    if (!s.face_alive[f]) continue;
    const auto& t = ctris_[f];
    bool has_b = false;
    for (int k = 0; k < 3; ++k)
    {
      if (t[k] == b) has_b = true;
      if (t[k] != a) na.push_back (t[k]);
    }
    shared += has_b;
  }
  for (std::int32_t f : vf_[b])
  {
    if (!s.face_alive[f]) continue;
    const auto& t = ctris_[f];
    for (int k = 0; k < 3; ++k)
      if (t[k] != b) nb.push_back (t[k]);
  }
  std::sort (na.begin (), na.end ()); na.erase (std::unique (na.begin (), na.end ()), na.end ());
  std::sort (nb.begin (), nb.end ()); nb.erase (std::unique (nb.begin (), nb.end ()), nb.end ());
  int common = 0;
  for (std::size_t i = 0, j = 0; i < na.size () && j < nb.size ();)
  {
    if (na[i] < nb[j]) ++i;
    else if (nb[j] < na[i]) ++j;
    else { common += (na[i] != a && na[i] != b); ++i; ++j; }
  }
  return shared != 0 && common == shared;
}

bool
CoupledSimplification::foldsOver (const CollapseState& s, std::int32_t a, std::int32_t b, const Eigen::Vector3d& x,
                                  double cos_turn) const
{
  // No remaining face of a or b may turn by more than the limit, degenerate, or turn away
  // from the camera.
  for (std::int32_t v : {a, b})
  {
    for (std::int32_t f : vf_[v])
    {
      if (!s.face_alive[f]) continue;
      const auto& t = ctris_[f];
      if ((t[0] == a || t[1] == a || t[2] == a) && (t[0] == b || t[1] == b || t[2] == b))
        continue;
      Eigen::Vector3d p[3], q[3];
      for (int k = 0; k < 3; ++k)
      {
        p[k] = cpos_[t[k]];
        q[k] = (t[k] == v) ? x : p[k];
      }
      const Eigen::Vector3d n0 = (p[1] - p[0]).cross (p[2] - p[0]);
      const Eigen::Vector3d n1 = (q[1] - q[0]).cross (q[2] - q[0]);
      const double l0 = n0.norm (), l1 = n1.norm ();
      if (!(l1 > 1e-12 * std::max (l0, 1e-30)) || n0.dot (n1) < cos_turn * l0 * l1 ||
          !s.facesCamera (q[0], q[1], q[2]))
        return true;
    }
  }
  return false;
}

std::size_t
CoupledSimplification::collapseInto (CollapseState& s, std::int32_t a, std::int32_t b, const Eigen::Vector3d& x)
{
  // Collapse b into a; returns the number of faces removed.
  auto& vf = vf_;
  std::size_t removed = 0;
  cpos_[a] = x;
  cq_[a] += cq_[b];
  cb_[a] += cb_[b];
  s.vert_alive[b] = 0;
  ++s.stamp[a];
  for (std::int32_t f : vf[b])
  {
    if (!s.face_alive[f]) continue;
    auto& t = ctris_[f];
    if (t[0] == a || t[1] == a || t[2] == a)
    {
      s.face_alive[f] = 0;
      ++removed;
      continue;
    }
    for (int k = 0; k < 3; ++k)
      if (t[k] == b) t[k] = a;
    vf[a].push_back (f);
  }
  vf[b].clear ();
  vf[a].erase (std::remove_if (vf[a].begin (), vf[a].end (), [&] (std::int32_t f) { return !s.face_alive[f]; }),
               vf[a].end ());
  // New candidates: a with each of its neighbours.
  auto& na = s.na;
  na.clear ();
  for (std::int32_t f : vf[a])
    for (int k = 0; k < 3; ++k)
      if (ctris_[f][k] != a) na.push_back (ctris_[f][k]);
  std::sort (na.begin (), na.end ()); na.erase (std::unique (na.begin (), na.end ()), na.end ());
  for (std::int32_t n : na)
    pushCollapse (s, a, n);
  return removed;
}

void
CoupledSimplification::collapseEdges (CollapseState& s, bool count_stop, bool error_stop)
{
  std::size_t faces = ctris_.size ();
  const std::size_t target = static_cast<std::size_t> (std::ceil (target_ratio_ * faces));
  // With the error bound on, the first candidate over it ends the collapses.
  s.key_limit = error_stop ? 1.0 : std::numeric_limits<double>::infinity ();
  pushAllEdges (s);

  const double cos_turn = std::cos (max_turn_deg_ * M_PI / 180.0);
  while (!s.heap.empty ())
  {
    if (count_stop && faces <= target)
      break;
    std::pop_heap (s.heap.begin (), s.heap.end (), std::greater<CollapseState::Entry> ());
    const CollapseState::Entry e = s.heap.back ();
    s.heap.pop_back ();
    const std::int32_t a = e.a, b = e.b;
    if (!s.vert_alive[a] || !s.vert_alive[b] || e.sa != s.stamp[a] || e.sb != s.stamp[b])
      continue;
    if (error_stop && !std::isinf (collapseBound (a, b)) && e.key > 1.0)
      break;
    if (!linkConditionHolds (s, a, b))
    {
      ++stats_.rejected_topology;
      continue;
    }
    double err;
    const Eigen::Vector3d x = placeCollapse (a, b, err);
    if (foldsOver (s, a, b, x, cos_turn))
    {
      ++stats_.rejected_foldover;
      continue;
    }
    faces -= collapseInto (s, a, b, x);
    ++stats_.collapses;
    stats_.max_error = std::max (stats_.max_error, err);
  }
}

void
CoupledSimplification::collapse ()
{
  // First phase: cluster representatives; then the clustered faces.
  placeRepresentatives ();
  CollapseState& s = collapse_state_;
  s.facing = orientation_vote_ < 0 ? -1.0 : 1.0;
  s.unique_edges.clear ();
  s.heap.clear ();
  dropBackfacingAndDuplicateFaces (s);
  stats_.clustered_triangles = ctris_.size ();

  // Second phase: edge collapse with the original (dense) quadrics.
  buildCollapseConnectivity (s);
  const bool count_stop = target_ratio_ > 0 && target_ratio_ < 1;
  const bool error_stop = max_error_ >= 0;
  if (target_ratio_ >= 1 || (!count_stop && !error_stop))
  {
    // No collapse: the clustered mesh is the result.
    stats_.triangles = ctris_.size ();
    return;
  }
  collapseEdges (s, count_stop, error_stop);
  // Keep the live faces only.
  std::size_t k = 0;
  for (std::size_t f = 0; f < ctris_.size (); ++f)
    if (s.face_alive[f])
      ctris_[k++] = ctris_[f];
  ctris_.resize (k);
}

void
CoupledSimplification::emit (const Eigen::Matrix4d& pose, bool dense_only, pcl::FrameMesh& out)
{
  const Eigen::Matrix3f R = pose.topLeftCorner<3, 3> ().cast<float> ();
  const Eigen::Vector3f t = pose.topRightCorner<3, 1> ().cast<float> ();
  Eigen::Matrix4d inv = Eigen::Matrix4d::Identity ();
  inv.topLeftCorner<3, 3> () = pose.topLeftCorner<3, 3> ().transpose ();
  inv.topRightCorner<3, 1> () = -inv.topLeftCorner<3, 3> () * pose.topRightCorner<3, 1> ();
  const bool flip = orientation_vote_ < 0;  // e.g. an organized grid stored bottom-up
  // Written in place: out's buffers (the caller's previous frame, usually) keep their memory.
  pcl::FrameMesh& m = out;
  m.vertices.clear ();
  m.triangles.clear ();
  m.quadrics.clear ();
  m.viewpoint = t;
  const std::vector<Eigen::Vector3i>& tris = dense_only ? dense_tris_ : ctris_;
  std::vector<std::int32_t> remap (cq_.size (), -1);
  m.triangles.reserve (tris.size ());
  for (const auto& tri : tris)
  {
    Eigen::Vector3i o;
    for (int k = 0; k < 3; ++k)
    {
      std::int32_t& r = remap[tri[k]];
      if (r < 0)
        r = static_cast<std::int32_t> (m.vertices.size ()), m.vertices.emplace_back ();
      o[k] = r;
    }
    if (flip)
      std::swap (o[1], o[2]);
    m.triangles.push_back (o);
  }
  m.quadrics.resize (m.vertices.size ());
  if (dense_only)
  {
    for (std::size_t i = 0; i < pts_.size (); ++i)
      if (cid_[i] >= 0 && remap[cid_[i]] >= 0)
      {
        m.vertices[remap[cid_[i]]] = R * pts_[i] + t;
        m.quadrics[remap[cid_[i]]] = transformQuadric (cq_[cid_[i]], inv);
      }
  }
  else
  {
    for (std::size_t c = 0; c < remap.size (); ++c)
      if (remap[c] >= 0)
      {
        m.vertices[remap[c]] = R * cpos_[c].cast<float> () + t;
        m.quadrics[remap[c]] = transformQuadric (cq_[c], inv);
      }
  }
  stats_.vertices = m.vertices.size ();
  stats_.triangles = m.triangles.size ();
}

}  // namespace pcl
