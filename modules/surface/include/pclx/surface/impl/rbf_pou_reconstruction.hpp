#pragma once
#include <pclx/normals/mst_normal_orientation.h>
#include <pclx/normals/detail/scale_selection.h>
#include <pclx/surface/detail/hole_filling.h>
#include <pclx/surface/rbf_pou_reconstruction.h>

#include <pcl/common/io.h>
#include <pcl/conversions.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/surface/marching_cubes.h>  // edgeTable / triTable

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <new>
#include <type_traits>
#include <utility>
#include <numeric>

#ifdef _OPENMP
#include <omp.h>
#endif
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace pclx {
namespace surface {
namespace detail {

using Clock = std::chrono::steady_clock;
// Axis-aligned bounds of a non-empty point list.
inline std::pair<Eigen::Vector3f, Eigen::Vector3f>
bounds (const std::vector<Eigen::Vector3f>& points)
{
  Eigen::Vector3f lo = points[0], hi = points[0];
  for (const auto& p : points)
  {
    lo = lo.cwiseMin (p);
    hi = hi.cwiseMax (p);
  }
  return {lo, hi};
}

inline double
seconds (Clock::time_point t0)
{
  return std::chrono::duration<double> (Clock::now () - t0).count ();
}

// Grid keys: 20 bits per axis, so that an edge key (corner key · 4 + axis) fits in 62 bits.
constexpr int kBits = 20;
constexpr std::int64_t kMaxIndex = (std::int64_t (1) << kBits) - 1;
inline std::uint64_t
pack (std::int64_t i, std::int64_t j, std::int64_t k)
{
  return std::uint64_t (i) | (std::uint64_t (j) << kBits) | (std::uint64_t (k) << (2 * kBits));
}
inline Eigen::Array3i
unpack (std::uint64_t key)
{
  const std::uint64_t m = std::uint64_t (kMaxIndex);
  return Eigen::Array3i (int (key & m), int ((key >> kBits) & m), int ((key >> (2 * kBits)) & m));
}

inline int
threadCount (unsigned int requested)
{
#ifdef _OPENMP
  return requested ? int (requested) : omp_get_max_threads ();
#else
  (void) requested;
  return 1;
#endif
}

inline void
sortUnique (std::vector<std::uint64_t>& v)
{
  std::sort (v.begin (), v.end ());
  v.erase (std::unique (v.begin (), v.end ()), v.end ());
}

// Union of the sorted `keys` shifted by o·stride for o in [lo, hi] (one axis). Each shifted
// copy is `keys` plus a constant, so one merge reads them in place: a first pass counts the
// union, a second writes it, and the peak memory is the input plus the result.
inline void
dilate (std::vector<std::uint64_t>& keys, int axis, int lo, int hi)
{
  const std::uint64_t stride = std::uint64_t (1) << (kBits * axis);
  const int copies = hi - lo + 1;
  auto merge = [&] (std::uint64_t* out) {
    std::vector<std::size_t> head (copies, 0);
    std::size_t count = 0;
    for (;;)
    {
      std::uint64_t least = ~std::uint64_t (0);
      for (int o = 0; o < copies; ++o)
        if (head[o] < keys.size ())
          least = std::min (least, keys[head[o]] + std::uint64_t (std::int64_t (lo + o)) * stride);
      if (least == ~std::uint64_t (0))
        return count;
      for (int o = 0; o < copies; ++o)
        if (head[o] < keys.size () && keys[head[o]] + std::uint64_t (std::int64_t (lo + o)) * stride == least)
          ++head[o];
      if (out)
        out[count] = least;
      ++count;
    }
  };
  std::vector<std::uint64_t> out (merge (nullptr));
  merge (out.data ());
  keys.swap (out);
}

// Σ_j λ_j |p − c_j|³ with c_j = xyz[3 ids[j] ...] (floats, world units). SSE2 by hand: GCC does
// not vectorise the sqrt of this reduction without -fno-math-errno, which we cannot ask of users.
inline double
sumR3 (const float* xyz, const std::uint32_t* ids, const float* lambda, std::uint32_t m, double px, double py,
       double pz)
{
  std::uint32_t j = 0;
  double f = 0;
#if defined(__SSE2__)
  const __m128d x = _mm_set1_pd (px), y = _mm_set1_pd (py), z = _mm_set1_pd (pz);
  __m128d acc0 = _mm_setzero_pd (), acc1 = _mm_setzero_pd ();
  for (; j + 4 <= m; j += 4)
  {
    const float* a = xyz + 3 * std::size_t (ids[j]);
    const float* b = xyz + 3 * std::size_t (ids[j + 1]);
    const float* c = xyz + 3 * std::size_t (ids[j + 2]);
    const float* d = xyz + 3 * std::size_t (ids[j + 3]);
    const __m128d dx0 = _mm_sub_pd (x, _mm_set_pd (b[0], a[0])), dx1 = _mm_sub_pd (x, _mm_set_pd (d[0], c[0]));
    const __m128d dy0 = _mm_sub_pd (y, _mm_set_pd (b[1], a[1])), dy1 = _mm_sub_pd (y, _mm_set_pd (d[1], c[1]));
    const __m128d dz0 = _mm_sub_pd (z, _mm_set_pd (b[2], a[2])), dz1 = _mm_sub_pd (z, _mm_set_pd (d[2], c[2]));
    const __m128d r0 = _mm_add_pd (_mm_add_pd (_mm_mul_pd (dx0, dx0), _mm_mul_pd (dy0, dy0)), _mm_mul_pd (dz0, dz0));
    const __m128d r1 = _mm_add_pd (_mm_add_pd (_mm_mul_pd (dx1, dx1), _mm_mul_pd (dy1, dy1)), _mm_mul_pd (dz1, dz1));
    const __m128 l4 = _mm_loadu_ps (lambda + j);
    acc0 = _mm_add_pd (acc0, _mm_mul_pd (_mm_mul_pd (_mm_cvtps_pd (l4), r0), _mm_sqrt_pd (r0)));
    acc1 = _mm_add_pd (acc1, _mm_mul_pd (_mm_mul_pd (_mm_cvtps_pd (_mm_movehl_ps (l4, l4)), r1), _mm_sqrt_pd (r1)));
  }
  double lanes[2];
  _mm_storeu_pd (lanes, _mm_add_pd (acc0, acc1));
  f = lanes[0] + lanes[1];
#endif
  for (; j < m; ++j)
  {
    const float* c = xyz + 3 * std::size_t (ids[j]);
    const double dx = px - c[0], dy = py - c[1], dz = pz - c[2];
    const double r2 = dx * dx + dy * dy + dz * dz;
    f += lambda[j] * r2 * std::sqrt (r2);
  }
  return f;
}

// out[k] = |q − (x, y, z)[k]|³ for k < count (doubles): the rows of the fit matrix, SSE2 as above.
inline void
r3Row (const double* x, const double* y, const double* z, int count, double qx, double qy, double qz, double* out)
{
  int k = 0;
#if defined(__SSE2__)
  const __m128d vx = _mm_set1_pd (qx), vy = _mm_set1_pd (qy), vz = _mm_set1_pd (qz);
  for (; k + 2 <= count; k += 2)
  {
    const __m128d dx = _mm_sub_pd (vx, _mm_loadu_pd (x + k)), dy = _mm_sub_pd (vy, _mm_loadu_pd (y + k));
    const __m128d dz = _mm_sub_pd (vz, _mm_loadu_pd (z + k));
    const __m128d r2 = _mm_add_pd (_mm_add_pd (_mm_mul_pd (dx, dx), _mm_mul_pd (dy, dy)), _mm_mul_pd (dz, dz));
    _mm_storeu_pd (out + k, _mm_mul_pd (r2, _mm_sqrt_pd (r2)));
  }
#endif
  for (; k < count; ++k)
  {
    const double dx = qx - x[k], dy = qy - y[k], dz = qz - z[k];
    const double r2 = dx * dx + dy * dy + dz * dz;
    out[k] = r2 * std::sqrt (r2);
  }
}

// PCL's marching-cubes corner order (MarchingCubes::getNeighborList1D) and edge ends.
constexpr int kCorner[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 0, 1}, {0, 0, 1},
                               {0, 1, 0}, {1, 1, 0}, {1, 1, 1}, {0, 1, 1}};
constexpr int kEdge[12][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {4, 5}, {5, 6},
                              {6, 7}, {7, 4}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};

// Neighbours of each point for the spacing and the normal vote.
constexpr int kNeighbours = 8;
// Noise below this share of the point spacing is left to interpolation (the normals module
// calls noise above 0.15 spacing significant).
constexpr double kCleanNoiseRatio = 0.1;
// The noise estimate's sample count and neighbours (its largest support is 200), and how many
// nearest points are searched for them: those on the other side of a thin sheet are skipped.
constexpr std::size_t kNoiseSamples = 500, kNoiseNeighbours = 201, kNoiseSearched = 2 * kNoiseNeighbours;
// Under noise Tmin and Tmax grow by this factor times σ / spacing, at most by the second.
constexpr double kNoiseSubdomainGrowth = 8, kMaxSubdomainGrowth = 16;
// Target RMS residual of a smoothing fit at its centres, in units of σ: pure noise leaves about
// 1 σ, the margin lets a fit that is slightly too stiff for the shape pass as the smoothest.
constexpr double kNoiseResidual = 1.5;
// Polynomial terms of a fit: [1 x y z] or [1 x y z x² y² z² xy xz yz].
constexpr int kLinearTerms = 4, kQuadricTerms = 10;

// Two opposed sheets in one subdomain: each side needs this many constraints (three per
// height-field term), and at most this share of the constraints may face neither side.
constexpr int kHeightFieldTerms = 7, kMinSheetConstraints = 3 * kHeightFieldTerms;
constexpr double kMaxBetweenSheets = 0.05;
// How many σ a point of one side may lie beyond the other side's surface (noise, not a crossing
// of the two fits), and how many σ apart the sides must lie on average (one surface whose
// normals disagree lies at 0).
constexpr double kSheetTolerance = 2, kSheetSeparation = 1;
// The sides' centres may lie this share of their tangential spread apart.
constexpr double kSheetOverlap = 0.25;

// The height field c · [1 u v w u² v² uv] (u, v, w along e1, e2, e3) as [1 q q²] coefficients.
inline Eigen::Matrix<double, kQuadricTerms, 1>
heightFieldToQuadric (const Eigen::VectorXd& c, const Eigen::Vector3d& e1, const Eigen::Vector3d& e2,
                      const Eigen::Vector3d& e3)
{
  Eigen::Matrix3d quad = c[4] * e1 * e1.transpose () + c[5] * e2 * e2.transpose () +
                         0.5 * c[6] * (e1 * e2.transpose () + e2 * e1.transpose ());
  const Eigen::Vector3d lin = c[1] * e1 + c[2] * e2 + c[3] * e3;
  Eigen::Matrix<double, kQuadricTerms, 1> p;
  p << c[0], lin[0], lin[1], lin[2], quad (0, 0), quad (1, 1), quad (2, 2), 2 * quad (0, 1), 2 * quad (0, 2),
      2 * quad (1, 2);
  return p;
}

inline Eigen::Matrix<double, kQuadricTerms, 1>
polynomialBasis (const Eigen::Vector3d& q)
{
  Eigen::Matrix<double, kQuadricTerms, 1> b;
  b << 1, q[0], q[1], q[2], q[0] * q[0], q[1] * q[1], q[2] * q[2], q[0] * q[1], q[0] * q[2], q[1] * q[2];
  return b;
}

// [A + ρI  P; Pᵀ 0] [λ; c] = [h; 0] by the null-space method: with P = QR and Q = [Q1 Q2],
// λ = Q2 μ and (Q2ᵀ A Q2 + ρI) μ = Q2ᵀ h, SPD because r³ is conditionally positive definite of
// order 2 (an LLT of size m − np, a third of an LU's flops); then R c = Q1ᵀ h − Q1ᵀ A Q2 μ.
// ρ = 0 interpolates (Carr et al. 2001); ρ > 0 is their smoothing spline, whose residual at the
// centres is ρ λ, of norm ρ ‖μ‖.
class ProjectedFit
{
public:
  // The QR of P; valid () when P has full column rank (else the centres are (nearly) flat).
  explicit ProjectedFit (const Eigen::MatrixXd& p) : m_ (int (p.rows ())), np_ (int (p.cols ())), qr_ (p)
  {
    const Eigen::VectorXd r = qr_.matrixQR ().topLeftCorner (np_, np_).diagonal ().cwiseAbs ();
    valid_ = m_ > np_ && r.minCoeff () > 1e-9 * r.maxCoeff ();
  }

  bool valid () const { return valid_; }
  // The limit ρ → ∞: the least-squares polynomial, λ = 0.
  Eigen::VectorXd leastSquares (const Eigen::VectorXd& h) const { return qr_.solve (h); }

  // Projects A and h for solve (ρ); only for a valid fit.
  void project (const Eigen::MatrixXd& a, const Eigen::VectorXd& h)
  {
    // Q = I − V T Vᵀ (LAPACK's larft), so Qᵀ A Q = A − U Vᵀ − V Uᵀ with U = A V T − ½ V M,
    // M = Tᵀ Vᵀ A V T: two rank-np products instead of 2 np rank-1 reflector updates.
    v_ = Eigen::MatrixXd::Zero (m_, np_);
    for (int i = 0; i < np_; ++i)
    {
      v_ (i, i) = 1;
      v_.col (i).tail (m_ - i - 1) = qr_.matrixQR ().col (i).tail (m_ - i - 1);
    }
    const Eigen::VectorXd tau = qr_.hCoeffs ();
    t_ = Eigen::MatrixXd::Zero (np_, np_);
    for (int i = 0; i < np_; ++i)
    {
      t_ (i, i) = tau[i];
      if (i > 0)
      {
        const Eigen::VectorXd vtv = v_.leftCols (i).transpose () * v_.col (i);
        const Eigen::VectorXd col = t_.topLeftCorner (i, i).triangularView<Eigen::Upper> () * vtv;
        t_.col (i).head (i) = -tau[i] * col;
      }
    }
    const Eigen::MatrixXd w = a * v_;
    const Eigen::MatrixXd mm = t_.transpose () * (v_.transpose () * w) * t_;
    const Eigen::MatrixXd u = w * t_ - 0.5 * v_ * mm;
    b_ = a;
    b_.noalias () -= u * v_.transpose ();
    b_.noalias () -= v_ * u.transpose ();
    g_ = h - v_ * (t_.transpose () * (v_.transpose () * h));  // Qᵀ h
  }

  // Mean diagonal of Q2ᵀ A Q2: the scale of ρ.
  double scale () const { return b_.bottomRightCorner (m_ - np_, m_ - np_).trace () / (m_ - np_); }

  // Factors for ρ; false when the projected matrix is not positive definite.
  bool solve (double rho)
  {
    const int k = m_ - np_;
    Eigen::MatrixXd c = b_.bottomRightCorner (k, k);
    c.diagonal ().array () += rho;
    llt_.compute (c);
    if (llt_.info () != Eigen::Success)
      return false;
    mu_ = llt_.solve (g_.tail (k));
    rho_ = rho;
    return mu_.allFinite ();
  }
  double residualNorm () const { return rho_ * mu_.norm (); }

  // λ = Q [0; μ] and the polynomial coefficients of the last solve.
  bool get (Eigen::VectorXd& lambda, Eigen::VectorXd& poly) const
  {
    const int k = m_ - np_;
    Eigen::VectorXd full = Eigen::VectorXd::Zero (m_);
    full.tail (k) = mu_;
    poly = qr_.matrixQR ().topLeftCorner (np_, np_).triangularView<Eigen::Upper> ().solve (
        g_.head (np_) - b_.topRightCorner (np_, k) * mu_);
    lambda = full - v_ * (t_ * (v_.transpose () * full));
    return lambda.allFinite () && poly.allFinite ();
  }

private:
  int m_, np_;
  bool valid_ = false;
  Eigen::HouseholderQR<Eigen::MatrixXd> qr_;
  Eigen::MatrixXd v_, t_, b_;
  Eigen::VectorXd g_, mu_;
  Eigen::LLT<Eigen::MatrixXd> llt_;
  double rho_ = 0;
};

// Morozov's discrepancy principle: the largest ρ whose residual at the centres stays below the
// target (the residual grows with ρ), by bisection in log ρ over 12 decades of the fit's scale.
inline double
chooseSmoothing (ProjectedFit& fit, double target)
{
  double lo = 1e-8 * fit.scale (), hi = 1e4 * fit.scale ();
  if (!(target > 0) || !fit.solve (hi))
    return 0;
  if (fit.residualNorm () <= target)
    return hi;
  for (int it = 0; it < 10; ++it)
  {
    const double mid = std::sqrt (lo * hi);
    if (fit.solve (mid) && fit.residualNorm () < target)
      lo = mid;
    else
      hi = mid;
  }
  return lo;
}

// The full saddle-point system by LU, then least squares when it is singular (duplicated
// centres, too few distinct ones). Returns whether least squares was needed.
inline bool
solveFull (const Eigen::MatrixXd& a, const Eigen::MatrixXd& p, const Eigen::VectorXd& h, Eigen::VectorXd& lambda,
           Eigen::VectorXd& poly)
{
  const int m = int (p.rows ()), np = int (p.cols ());
  Eigen::MatrixXd full = Eigen::MatrixXd::Zero (m + np, m + np);
  full.topLeftCorner (m, m) = a;
  full.topRightCorner (m, np) = p;
  full.bottomLeftCorner (np, m) = p.transpose ();
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero (m + np);
  rhs.head (m) = h;
  Eigen::VectorXd x = full.partialPivLu ().solve (rhs);
  bool least_squares = false;
  if (!x.allFinite () || (full * x - rhs).norm () > 1e-6 * rhs.norm () + 1e-12)
  {
    x = full.completeOrthogonalDecomposition ().solve (rhs);
    least_squares = true;
  }
  lambda = x.head (m);
  poly = x.tail (np);
  return least_squares;
}

// The search of setSearchMethod () seen as a kd-tree over the valid points: it answers for the
// input cloud, and its input indices map back to positions among the valid points (points
// dropped as invalid are skipped, so a query near them can return fewer than k).
template <typename PointNT>
class SearchOverValidPoints : public pcl::KdTree<pcl::PointXYZ>
{
public:
  SearchOverValidPoints (typename pcl::search::Search<PointNT>::Ptr search, std::vector<int> position_of_input,
                         std::size_t dropped)
    : search_ (std::move (search)), position_ (std::move (position_of_input)), dropped_ (dropped)
  {}

  int
  nearestKSearch (const pcl::PointXYZ& p, unsigned int k, pcl::Indices& indices,
                  std::vector<float>& sqr_distances) const override
  {
    const std::size_t extra = std::min<std::size_t> (dropped_, k);
    search_->nearestKSearch (query (p), int (k + extra), indices, sqr_distances);
    return keepValid (indices, sqr_distances, k);
  }

  int
  radiusSearch (const pcl::PointXYZ& p, double radius, pcl::Indices& indices, std::vector<float>& sqr_distances,
                unsigned int max_nn = 0) const override
  {
    search_->radiusSearch (query (p), radius, indices, sqr_distances, max_nn);
    return keepValid (indices, sqr_distances, std::numeric_limits<unsigned int>::max ());
  }

  std::string
  getName () const override
  {
    return "SearchOverValidPoints";
  }

private:
  static PointNT
  query (const pcl::PointXYZ& p)
  {
    PointNT q;
    q.getVector3fMap () = p.getVector3fMap ();
    return q;
  }

  int
  keepValid (pcl::Indices& indices, std::vector<float>& sqr_distances, unsigned int k) const
  {
    std::size_t kept = 0;
    for (std::size_t i = 0; i < indices.size () && kept < k; ++i)
      if (const int pos = position_[indices[i]]; pos >= 0)
      {
        indices[kept] = pos;
        sqr_distances[kept++] = sqr_distances[i];
      }
    indices.resize (kept);
    sqr_distances.resize (kept);
    return int (kept);
  }

  typename pcl::search::Search<PointNT>::Ptr search_;
  std::vector<int> position_;  // input index → valid-point position, or -1
  std::size_t dropped_;
};

}  // namespace detail
}  // namespace surface
}  // namespace pclx

namespace pcl {

template <typename PointNT> bool
RBFPOUReconstruction<PointNT>::fail (const std::string& msg)
{
  error_ = msg;
  PCL_ERROR ("[pcl::%s] %s\n", getClassName ().c_str (), msg.c_str ());
  return false;
}

template <typename PointNT> double
RBFPOUReconstruction<PointNT>::weight (const Subdomain& s, const Eigen::Vector3d& p) const
{
  // Eq. 4.5: D = 1 − Π 4 (p − S)(T − p) / (T − S)², zero at the centre, one on the border.
  double prod = 1;
  for (int r = 0; r < 3; ++r)
  {
    const double a = p[r] - s.lo[r], b = s.hi[r] - p[r];
    if (a <= 0 || b <= 0)
      return 0;
    const double e = s.hi[r] - s.lo[r];
    prod *= 4 * a * b / (e * e);
  }
  const double d = 1 - prod;
  if (decay_ == Decay::LINEAR)
    return 1 - d;  // Eq. 4.6
  return 2 * d * d * d - 3 * d * d + 1;
}

template <typename PointNT> double
RBFPOUReconstruction<PointNT>::local (const Subdomain& s, const Eigen::Vector3d& p) const
{
  // In the frame of the fit: q = (p − centre) / scale, so |q − q_j|³ = |p − c_j|³ / scale³.
  const Eigen::Vector3d q = (p - s.centre) / s.scale;
  const double rbf = s.rbf ? pclx::surface::detail::sumR3 (cpos_.data (), sub_ids_.data () + s.first,
                                                   sub_lambda_.data () + s.first, s.count, p[0], p[1], p[2])
                           : 0.0;
  const Eigen::Matrix<double, 10, 1> b = pclx::surface::detail::polynomialBasis (q);
  double f = s.poly.dot (b);
  if (s.sheets != 0)
  {
    const double g = sheet_poly_[std::size_t (&s - subs_.data ())].dot (b);
    f = s.sheets > 0 ? std::max (f, g) : std::min (f, g);
  }
  return f + rbf / (s.scale * s.scale * s.scale);
}

template <typename PointNT> template <typename F> void
RBFPOUReconstruction<PointNT>::forCovering (const Eigen::Vector3d& p, BucketCache& cache, F&& f) const
{
  if (subs_.empty ())
    return;
  const Eigen::Array3d b = ((p - bucket_origin_) / bucket_size_).array ().floor ();
  if ((b < 0).any () || (b > double (pclx::surface::detail::kMaxIndex)).any ())
    return;
  const std::uint64_t key = pclx::surface::detail::pack (std::int64_t (b[0]), std::int64_t (b[1]), std::int64_t (b[2]));
  if (key != cache.key)
  {
    const auto it = std::lower_bound (bucket_keys_.begin (), bucket_keys_.end (), key);
    const std::size_t b = std::size_t (it - bucket_keys_.begin ());
    cache.key = key;
    cache.begin = cache.end = 0;
    if (it != bucket_keys_.end () && *it == key)
    {
      cache.begin = bucket_first_[b];
      cache.end = bucket_first_[b + 1];
    }
  }
  for (std::size_t i = cache.begin; i < cache.end; ++i)
  {
    const Subdomain& s = subs_[bucket_subs_[i]];
    if ((p.array () > s.lo.array ()).all () && (p.array () < s.hi.array ()).all ())
      f (s);
  }
}

template <typename PointNT> double
RBFPOUReconstruction<PointNT>::evaluateCached (const Eigen::Vector3d& p, BucketCache& cache, double* weight_sum) const
{
  double sw = 0, swf = 0;
  forCovering (p, cache, [&] (const Subdomain& s) {
    const double w = weight (s, p);
    if (w > 0)
    {
      sw += w;
      swf += w * local (s, p);
    }
  });
  if (weight_sum)
    *weight_sum = sw;
  return sw > 0 ? swf / sw : std::numeric_limits<double>::quiet_NaN ();  // Eq. 4.3–4.4
}

template <typename PointNT> double
RBFPOUReconstruction<PointNT>::nearestLocal (const Eigen::Vector3d& p,
                                             std::unique_ptr<pcl::KdTreeFLANN<pcl::PointXYZ>>& centres) const
{
  if (!centres)
  {
    pcl::PointCloud<pcl::PointXYZ>::Ptr c (new pcl::PointCloud<pcl::PointXYZ>);
    c->resize (subs_.size ());
    for (std::size_t i = 0; i < subs_.size (); ++i)
      (*c)[i].getVector3fMap () = subs_[i].centre.template cast<float> ();
    centres = std::make_unique<pcl::KdTreeFLANN<pcl::PointXYZ>> (false);
    centres->setInputCloud (c);
  }
  // The nearest box among the subdomains of the nearest centres (boxes differ in size).
  pcl::PointXYZ q;
  q.getVector3fMap () = p.template cast<float> ();
  pcl::Indices k;
  std::vector<float> d;
  centres->nearestKSearch (q, int (std::min<std::size_t> (8, subs_.size ())), k, d);
  const Subdomain* best = nullptr;
  double best_d = std::numeric_limits<double>::infinity ();
  for (const auto i : k)
  {
    const Subdomain& s = subs_[i];
    const double dist = (p - p.cwiseMax (s.lo).cwiseMin (s.hi)).squaredNorm ();
    if (dist < best_d)
    {
      best_d = dist;
      best = &s;
    }
  }
  return best ? local (*best, p) : std::numeric_limits<double>::quiet_NaN ();
}

template <typename PointNT> double
RBFPOUReconstruction<PointNT>::evaluate (const Eigen::Vector3f& pf, double* weight_sum) const
{
  BucketCache cache;
  return evaluateCached (pf.cast<double> (), cache, weight_sum);
}

template <typename PointNT> std::vector<double>
RBFPOUReconstruction<PointNT>::weightsAt (const Eigen::Vector3f& pf) const
{
  const Eigen::Vector3d p = pf.cast<double> ();
  std::vector<double> w;
  BucketCache cache;
  forCovering (p, cache, [&] (const Subdomain& s) {
    const double x = weight (s, p);
    if (x > 0)
      w.push_back (x);
  });
  const double sum = std::accumulate (w.begin (), w.end (), 0.0);
  for (double& x : w)
    x /= sum;  // Eq. 4.4
  return w;
}

template <typename PointNT> bool
RBFPOUReconstruction<PointNT>::checkParameters ()
{
  if (t_min_ < 10)
    return fail ("Tmin must be >= 10 (got " + std::to_string (t_min_) + ")");
  if (t_min_ > t_max_)
    return fail ("Tmin (" + std::to_string (t_min_) + ") > Tmax (" + std::to_string (t_max_) + ")");
  if (!(overlap_ > 1) || !std::isfinite (overlap_))
    return fail ("overlap factor d must be a finite value > 1 (got " + std::to_string (overlap_) + ")");
  if (!grid_auto_ && !(grid_resolution_ > 0 && std::isfinite (grid_resolution_)))
    return fail ("grid resolution must be > 0 (got " + std::to_string (grid_resolution_) + ")");
  if (band_ < 1)
    return fail ("band width must be >= 1 cell (got " + std::to_string (band_) + ")");
  if (!epsilon_auto_ && !(epsilon_ > 0 && std::isfinite (epsilon_)))
    return fail ("off-surface epsilon must be > 0 (got " + std::to_string (epsilon_) + ")");
  if (!noise_auto_ && !(noise_ >= 0 && std::isfinite (noise_)))
    return fail ("noise level must be a finite value >= 0 (got " + std::to_string (noise_) + ")");
  if (!std::isfinite (iso_))
    return fail ("iso level must be finite");
  if (!hole_auto_ && !(max_hole_ >= 0 && std::isfinite (max_hole_)))
    return fail ("the largest hole to close must be a finite value >= 0 (got " + std::to_string (max_hole_) + ")");
  return true;
}

template <typename PointNT> bool
RBFPOUReconstruction<PointNT>::collectPoints ()
{
  stats_.input_points = indices_->size ();
  for (const auto idx : *indices_)
  {
    const PointNT& q = (*input_)[idx];
    const Eigen::Vector3f p = q.getVector3fMap ();
    const Eigen::Vector3f n = q.getNormalVector3fMap ();
    if (!p.allFinite ())
    {
      ++stats_.dropped_points;
      continue;
    }
    const float len = n.norm ();
    if (!n.allFinite () || !(len > 1e-6f))
    {
      ++stats_.zero_normals;
      continue;
    }
    pts_.push_back (p);
    nrm_.push_back (n / len);
    src_.push_back (idx);
  }
  if (pts_.empty ())
    return fail (stats_.zero_normals ? "no usable normals: all " + std::to_string (stats_.zero_normals) +
                                           " finite points have zero or non-finite normals"
                                     : "no finite input points");
  if (3 * pts_.size () < std::size_t (t_min_))
    return fail ("too few points: " + std::to_string (pts_.size ()) + " valid points give " +
                 std::to_string (3 * pts_.size ()) + " constraints, fewer than Tmin = " + std::to_string (t_min_));
  if (stats_.dropped_points || stats_.zero_normals)
    PCL_WARN ("[pcl::%s] dropped %zu non-finite points and %zu zero / non-finite normals\n",
              getClassName ().c_str (), stats_.dropped_points, stats_.zero_normals);
  return true;
}

template <typename PointNT> std::unique_ptr<pclx::surface::detail::SearchOverValidPoints<PointNT>>
RBFPOUReconstruction<PointNT>::searchOverValidPoints ()
{
  if (tree_->getInputCloud () != input_ || tree_->getIndices () != indices_)
    tree_->setInputCloud (input_, indices_);
  std::vector<int> position (input_->size (), -1);
  for (std::size_t i = 0; i < src_.size (); ++i)
    position[src_[i]] = int (i);
  return std::make_unique<pclx::surface::detail::SearchOverValidPoints<PointNT>> (tree_, std::move (position),
                                                                          indices_->size () - src_.size ());
}

template <typename PointNT> bool
RBFPOUReconstruction<PointNT>::measureSpacing (const pcl::KdTree<pcl::PointXYZ>& tree, std::vector<int>& nn)
{
  using namespace pclx::surface::detail;
  const std::size_t n = pts_.size ();
  const int nt = threadCount (threads_);
  // The point itself is its first neighbour: the second gives the spacing. The vote's
  // neighbours come from the same search, and only when there is a vote.
  const bool vote = normal_vote_ && n > std::size_t (kNeighbours);
  const int kq = vote ? kNeighbours + 1 : 2;
  nn.assign (vote ? kNeighbours * n : 0, -1);
  double spacing_sum = 0;
#pragma omp parallel for num_threads(nt) reduction(+ : spacing_sum) schedule(static)
  for (std::ptrdiff_t i = 0; i < std::ptrdiff_t (n); ++i)
  {
    pcl::Indices k (kq);
    std::vector<float> d (kq);
    pcl::PointXYZ q;
    q.getVector3fMap () = pts_[i];
    const int found = tree.nearestKSearch (q, kq, k, d);
    if (found >= 2)
      spacing_sum += std::sqrt (d[1]);
    if (vote)
      for (int j = 0, o = 0; j < found && o < kNeighbours; ++j)
        if (k[j] != int (i))
          nn[kNeighbours * i + o++] = k[j];
  }
  stats_.mean_spacing = spacing_sum / double (n);
  if (!(stats_.mean_spacing > 0))
    return fail ("all valid points coincide (mean spacing 0)");
  stats_.grid_resolution = grid_auto_ ? 1.5 * stats_.mean_spacing : grid_resolution_;
  stats_.epsilon = epsilon_auto_ ? stats_.mean_spacing : epsilon_;
  return true;
}

template <typename PointNT> void
RBFPOUReconstruction<PointNT>::estimateNoise (const pcl::KdTree<pcl::PointXYZ>& tree)
{
  using namespace pclx::surface::detail;
  if (!noise_auto_)
    stats_.noise = noise_;
  else
  {
    // The normals module's estimate: quadric height-field residuals around a few hundred
    // evenly spread points, on the smallest support (24–200 neighbours) whose plane is defined.
    // Neighbours whose normal is opposed to the point's (more than 120°, as in the vote) are
    // left out: they lie on the other side of a thin sheet, and a support holding both sides
    // reads the sheet's thickness as noise. Creases (normals about 90° apart) stay in.
    struct Scratch
    {
      pcl::Indices ids;
      std::vector<float> d2;
    };
    const int k = int (std::min<std::size_t> (kNoiseSearched, pts_.size ()));
    const pclx::normals::detail::NoiseEstimate e = pclx::normals::detail::estimateCloudNoise<Scratch> (
        pts_.size (), kNoiseSamples, 1, [&] (std::size_t i, std::vector<Eigen::Vector3f>& sorted, Scratch& t) {
          pcl::PointXYZ q;
          q.getVector3fMap () = pts_[i];
          tree.nearestKSearch (q, k, t.ids, t.d2);
          for (const auto id : t.ids)
            if (sorted.size () < kNoiseNeighbours && nrm_[id].dot (nrm_[i]) >= -0.5f)
              sorted.push_back (pts_[id]);
        });
    stats_.noise_ratio = e.ratio ();
    // Below this share of the spacing the residuals are sampling and shape, not noise.
    stats_.noise = e.ratio () > kCleanNoiseRatio ? e.sigma : 0.0;
  }
  // Under noise each fit averages more points, so its own error (about σ √(10 / points)) falls;
  // docs/surface.md has the sweep behind the factor.
  // Never beyond what a quarter of the constraints (about 3 per point) could fill.
  const double room = std::max (1.0, 0.75 * double (pts_.size ()) / t_min_);
  const double f = stats_.noise > 0 ? std::clamp (kNoiseSubdomainGrowth * stats_.noise / stats_.mean_spacing, 1.0,
                                                  std::min (kMaxSubdomainGrowth, room))
                                    : 1.0;
  stats_.max_constraints = int (std::lround (f * t_max_));
  stats_.min_constraints = int (std::lround (f * t_min_));
}

template <typename PointNT> void
RBFPOUReconstruction<PointNT>::measureDensitySpread (const pcl::KdTree<pcl::PointXYZ>& tree)
{
  // The 16th neighbour's distance at up to 2000 points spread over the cloud: uniform samples of
  // a surface spread it little, a scan's falloff with range and angle more (the threshold's
  // measurements are in docs/surface.md).
  constexpr int kSamples = 2000, kNeighbour = 16;
  const std::size_t n = pts_.size ();
  std::vector<double> r;
  pcl::Indices k;
  std::vector<float> d2;
  const std::size_t step = std::max<std::size_t> (1, n / kSamples);
  for (std::size_t i = 0; i < n; i += step)
  {
    pcl::PointXYZ q;
    q.getVector3fMap () = pts_[i];
    if (tree.nearestKSearch (q, kNeighbour + 1, k, d2) == kNeighbour + 1)
      r.push_back (std::sqrt (double (d2[kNeighbour])));
  }
  if (r.size () >= 10)
  {
    std::sort (r.begin (), r.end ());
    const double low = r[r.size () / 10], high = r[r.size () * 9 / 10];
    stats_.density_spread = low > 0 ? high / low : 0;
  }
  const bool scan = stats_.density_spread > kScanDensitySpread;
  const auto [lo, hi] = pclx::surface::detail::bounds (pts_);
  const double diagonal = double ((hi - lo).norm ());
  stats_.max_hole_size = hole_auto_ ? (scan ? kAutoHoleFraction * diagonal : 0.0) : max_hole_;
}

template <typename PointNT> void
RBFPOUReconstruction<PointNT>::closeHoles (std::vector<Eigen::Vector3f>& vertices, std::vector<Triangle>& triangles)
{
  if (!(stats_.max_hole_size > 0) || triangles.empty ())
    return;
  const auto t0 = pclx::surface::detail::Clock::now ();
  pclx::surface::detail::HoleFillingStats holes;
  if (pclx::surface::detail::fillSmallHoles (vertices, triangles, stats_.max_hole_size, holes))
  {
    stats_.holes = holes.holes;
    stats_.holes_filled = holes.filled;
    stats_.hole_triangles = holes.added_triangles;
    stats_.hole_area = holes.filled_area;
  }
  stats_.t_holes = pclx::surface::detail::seconds (t0);
}

template <typename PointNT> bool
RBFPOUReconstruction<PointNT>::orientNormals (const pcl::PointCloud<pcl::PointXYZ>::ConstPtr& xyz)
{
  const std::size_t n = pts_.size ();
  pcl::PointCloud<pcl::PointNormal> nc;
  nc.resize (n);
  for (std::size_t i = 0; i < n; ++i)
  {
    nc[i].getVector3fMap () = pts_[i];
    nc[i].getNormalVector3fMap () = nrm_[i];
  }
  pcl::MSTNormalOrientation<pcl::PointXYZ, pcl::PointNormal> mst;
  mst.setInputCloud (xyz);
  mst.setNumberOfThreads (threads_);
  if (!mst.orient (nc))
  {
    error_ = "MST normal orientation failed";  // MSTNormalOrientation has printed the reason
    return false;
  }
  for (std::size_t i = 0; i < n; ++i)
    nrm_[i] = nc[i].getNormalVector3fMap ();
  stats_.normals_oriented = mst.getNumberOfFlipped ();
  return true;
}

template <typename PointNT> void
RBFPOUReconstruction<PointNT>::voteNormals (const std::vector<int>& nn)
{
  using namespace pclx::surface::detail;
  // A few Jacobi passes so that small clusters of flips also turn. A neighbour counts when it
  // lies on the point's tangent plane (within half the mean spacing): a thin sheet's other side
  // lies off it. Under noise fewer neighbours count, so fewer correct normals are turned.
  const std::size_t n = pts_.size ();
  const int nt = threadCount (threads_);
  std::vector<char> flip (n, 0);
  const float on_plane = float (0.5 * stats_.mean_spacing);
  for (int pass = 0; pass < 4; ++pass)
  {
    std::size_t changed = 0;
#pragma omp parallel for num_threads(nt) reduction(+ : changed) schedule(static)
    for (std::ptrdiff_t i = 0; i < std::ptrdiff_t (n); ++i)
    {
      int against = 0;
      for (int j = 0; j < kNeighbours; ++j)
      {
        const int k = nn[kNeighbours * i + j];
        against += k >= 0 && nrm_[i].dot (nrm_[k]) < -0.5f && std::abs (nrm_[i].dot (pts_[k] - pts_[i])) <= on_plane;
      }
      flip[i] = nn[kNeighbours * i + kNeighbours - 1] >= 0 && against >= 6;
      changed += flip[i];
    }
    if (!changed)
      break;
    for (std::size_t i = 0; i < n; ++i)
      if (flip[i])
        nrm_[i] = -nrm_[i];
    stats_.normals_voted += changed;
  }
  if (stats_.normals_voted > n / 10)
    PCL_WARN ("[pcl::%s] %zu of %zu normals disagreed with their neighbours: are the normals oriented? "
              "(setOrientNormals (true) orients them with an MST)\n",
              getClassName ().c_str (), stats_.normals_voted, n);
}

template <typename PointNT> void
RBFPOUReconstruction<PointNT>::placeOffSurfaceConstraints (const pcl::KdTree<pcl::PointXYZ>& tree)
{
  using namespace pclx::surface::detail;
  // Carr et al. 2001: halve ε until the point's nearest input point is its origin.
  const std::size_t n = pts_.size ();
  const int nt = threadCount (threads_);
  const float eps0 = float (stats_.epsilon);
  std::vector<float> eps (2 * n, 0.f);
  std::size_t halved = 0;
#pragma omp parallel for num_threads(nt) reduction(+ : halved) schedule(static)
  for (std::ptrdiff_t i = 0; i < std::ptrdiff_t (n); ++i)
  {
    pcl::Indices k (1);
    std::vector<float> d (1);
    for (int side = 0; side < 2; ++side)
    {
      const float sign = side == 0 ? 1.f : -1.f;
      float e = eps0;
      for (int it = 0; it < 12; ++it, e *= 0.5f, ++halved)
      {
        pcl::PointXYZ q;
        q.getVector3fMap () = pts_[i] + sign * e * nrm_[i];
        // Ties (another point exactly as near) count as failures.
        if (tree.nearestKSearch (q, 1, k, d) == 1 &&
            (k[0] == int (i) || d[0] > (q.getVector3fMap () - pts_[i]).squaredNorm () * (1.f + 1e-5f)))
        {
          eps[2 * i + side] = sign * e;
          break;
        }
      }
    }
  }
  off_.reserve (2 * n);
  for (std::size_t i = 0; i < 2 * n; ++i)
  {
    if (eps[i] == 0.f)
    {
      ++stats_.off_surface_dropped;
      continue;
    }
    off_.push_back ({pts_[i / 2] + eps[i] * nrm_[i / 2], eps[i], int (i / 2)});
  }
  stats_.eps_halved = halved - stats_.off_surface_dropped * 12;
  stats_.off_surface_points = off_.size ();
}

template <typename PointNT> std::vector<typename RBFPOUReconstruction<PointNT>::Leaf>
RBFPOUReconstruction<PointNT>::splitOctree ()
{
  // Tobor et al. 2004 §4.3.2: split until every enlarged cell holds at most Tmax constraints.
  struct Node
  {
    Eigen::Vector3d c;
    double half;  // of the octree cell
    int depth;
    std::vector<std::uint32_t> ids;  // constraints in the enlarged cell
  };
  const std::uint32_t nc = std::uint32_t (pts_.size () + off_.size ());
  Eigen::Vector3f bmin = pts_[0], bmax = pts_[0];
  for (std::uint32_t c = 0; c < nc; ++c)
  {
    bmin = bmin.cwiseMin (constraintPosition (c));
    bmax = bmax.cwiseMax (constraintPosition (c));
  }
  std::vector<Leaf> leaves;
  std::vector<Node> stack (1);
  stack[0].c = 0.5 * (bmin + bmax).cast<double> ();
  stack[0].half = 0.5 * double ((bmax - bmin).maxCoeff ()) * 1.001 + 1e-9;
  stack[0].depth = 0;
  stack[0].ids.resize (nc);
  std::iota (stack[0].ids.begin (), stack[0].ids.end (), 0u);
  while (!stack.empty ())
  {
    Node node = std::move (stack.back ());
    stack.pop_back ();
    if (int (node.ids.size ()) <= stats_.max_constraints || node.depth >= 20)
    {
      stats_.over_tmax += int (node.ids.size ()) > stats_.max_constraints;
      leaves.push_back ({node.c, overlap_ * node.half, std::move (node.ids)});
      continue;
    }
    // Children enlarged by d stay inside the parent's enlarged box (d ≥ 1): filter its list.
    // Per axis a constraint lies in the low child's range, the high one's or both (the
    // overlap), so it is tested 3 × 2 times and appended to its ~d³ children only.
    std::array<Node, 8> child;
    for (int o = 0; o < 8; ++o)
    {
      child[o].half = node.half / 2;
      child[o].depth = node.depth + 1;
      child[o].c = node.c + child[o].half * Eigen::Vector3d (o & 1 ? 1 : -1, o & 2 ? 1 : -1, o & 4 ? 1 : -1);
    }
    const double r = overlap_ * node.half / 2;
    for (const auto id : node.ids)
    {
      const Eigen::Vector3d p = constraintPosition (id).template cast<double> ();
      int side[3];  // bit 0: in the low child's range, bit 1: in the high child's
      for (int a = 0; a < 3; ++a)
        side[a] = (std::abs (p[a] - child[0].c[a]) < r) | (std::abs (p[a] - child[7].c[a]) < r) << 1;
      for (int o = 0; o < 8; ++o)
        if ((side[0] >> (o & 1) & 1) && (side[1] >> (o >> 1 & 1) & 1) && (side[2] >> (o >> 2 & 1) & 1))
          child[o].ids.push_back (id);
    }
    for (int o = 0; o < 8; ++o)
      if (!child[o].ids.empty ())
        stack.push_back (std::move (child[o]));
  }
  return leaves;
}

template <typename PointNT> void
RBFPOUReconstruction<PointNT>::growLeaves (std::vector<Leaf>& leaves)
{
  using namespace pclx::surface::detail;
  // Leaves below Tmin grow (factor 1.25 per step, at most 4×), shrinking back by bisection when
  // a step overshoots Tmax; leaves that cannot reach Tmin are dropped (scale 0).
  const std::uint32_t nc = std::uint32_t (pts_.size () + off_.size ());
  pcl::PointCloud<pcl::PointXYZ>::Ptr cxyz (new pcl::PointCloud<pcl::PointXYZ>);
  cxyz->resize (nc);
  for (std::uint32_t c = 0; c < nc; ++c)
    (*cxyz)[c].getVector3fMap () = constraintPosition (c);
  pcl::KdTreeFLANN<pcl::PointXYZ> ctree (false);
  ctree.setInputCloud (cxyz);
  std::size_t grown = 0;
#pragma omp parallel for num_threads(threadCount (threads_)) reduction(+ : grown) schedule(dynamic, 16)
  for (std::ptrdiff_t l = 0; l < std::ptrdiff_t (leaves.size ()); ++l)
  {
    Leaf& leaf = leaves[l];
    if (int (leaf.ids.size ()) >= stats_.min_constraints)
      continue;
    ++grown;
    pcl::PointXYZ q;
    q.getVector3fMap () = leaf.c.template cast<float> ();
    pcl::Indices k;
    std::vector<float> d;
    // Constraints near the leaf with their L∞ distance to its centre, sorted: the count in the
    // box scaled by any f ≤ `covered` is a binary search. A query covers two grow steps, so a
    // leaf costs 1–4 radius searches instead of one per step and per bisection step.
    std::vector<std::pair<double, std::uint32_t>> near;
    double covered = 0;
    auto inBox = [&] (double f, std::vector<std::uint32_t>* out) {
      if (f > covered)
      {
        covered = std::max (f * 1.25, covered * 1.5625);
        ctree.radiusSearch (q, float (leaf.half * covered * std::sqrt (3.0) * 1.0001), k, d);
        near.clear ();
        for (const auto id : k)
          near.emplace_back ((constraintPosition (id).template cast<double> () - leaf.c).array ().abs ().maxCoeff (),
                             std::uint32_t (id));
        std::sort (near.begin (), near.end ());
      }
      const auto end = std::lower_bound (near.begin (), near.end (), std::make_pair (leaf.half * f, std::uint32_t (0)));
      if (out)
        for (auto it = near.begin (); it != end; ++it)
          out->push_back (it->second);
      return int (end - near.begin ());
    };
    double lo = 1, f = 1;
    int count = int (leaf.ids.size ());
    while (count < stats_.min_constraints && f < 4)
    {
      lo = f;
      f *= 1.25;
      count = inBox (f, nullptr);
    }
    if (count < stats_.min_constraints)
    {
      leaf.scale = 0;
      continue;
    }
    double hi = f;
    for (int it = 0; it < 10 && count > stats_.max_constraints; ++it)
    {
      const double mid = 0.5 * (lo + hi);
      const int c = inBox (mid, nullptr);
      if (c < stats_.min_constraints)
        lo = mid;
      else
      {
        hi = mid;
        count = c;
      }
    }
    leaf.scale = hi;
    leaf.ids.clear ();
    inBox (hi, &leaf.ids);
    std::sort (leaf.ids.begin (), leaf.ids.end ());
  }
  stats_.grown = grown;
}

template <typename PointNT> std::vector<float>
RBFPOUReconstruction<PointNT>::makeSubdomains (std::vector<Leaf>& leaves, std::vector<std::uint32_t>& origin)
{
  for (const Leaf& leaf : leaves)
  {
    if (!(leaf.scale > 0))
      continue;
    Subdomain s;
    const double h = leaf.half * leaf.scale;
    s.centre = leaf.c;
    s.lo = s.centre.array () - h;
    s.hi = s.centre.array () + h;
    s.scale = h;
    s.poly.setZero ();
    s.first = std::uint32_t (sub_ids_.size ());
    s.count = std::uint32_t (leaf.ids.size ());
    stats_.over_tmax += leaf.ids.size () > std::size_t (stats_.max_constraints) && leaf.scale > 1;
    sub_ids_.insert (sub_ids_.end (), leaf.ids.begin (), leaf.ids.end ());
    subs_.push_back (s);
  }
  std::vector<Leaf> ().swap (leaves);
  // Renumber the constraints in the order the octree's depth-first leaves first list them, so
  // that the centres of a subdomain lie close together in cpos_ (evaluation gathers them).
  const std::uint32_t nc = std::uint32_t (pts_.size () + off_.size ());
  std::vector<float> value (nc);  // h of every constraint, new numbering
  std::vector<std::uint32_t> rank (nc, std::numeric_limits<std::uint32_t>::max ());
  std::uint32_t next = 0;
  for (auto& id : sub_ids_)
  {
    if (rank[id] == std::numeric_limits<std::uint32_t>::max ())
      rank[id] = next++;
    id = rank[id];
  }
  for (auto& r : rank)
    if (r == std::numeric_limits<std::uint32_t>::max ())
      r = next++;
  cpos_.resize (3 * std::size_t (nc));
  for (std::uint32_t c = 0; c < nc; ++c)
  {
    Eigen::Map<Eigen::Vector3f> dst (&cpos_[3 * std::size_t (rank[c])]);
    dst = constraintPosition (c);
    value[rank[c]] = c < pts_.size () ? 0.f : off_[c - pts_.size ()].value;
  }
  if (stats_.noise > 0)
  {
    origin.resize (nc);
    for (std::uint32_t c = 0; c < nc; ++c)
      origin[rank[c]] = c < pts_.size () ? c : std::uint32_t (off_[c - pts_.size ()].origin);
  }
  stats_.subdomains = subs_.size ();
  stats_.subdomain_centres = sub_ids_.size ();
  return value;
}

template <typename PointNT> void
RBFPOUReconstruction<PointNT>::buildBuckets ()
{
  // Lookup buckets of the median subdomain size.
  std::vector<double> sizes (subs_.size ());
  Eigen::Vector3d o = subs_[0].lo;
  for (std::size_t i = 0; i < subs_.size (); ++i)
  {
    sizes[i] = 2 * subs_[i].scale;
    o = o.cwiseMin (subs_[i].lo);
  }
  std::nth_element (sizes.begin (), sizes.begin () + sizes.size () / 2, sizes.end ());
  bucket_size_ = sizes[sizes.size () / 2];
  bucket_origin_ = o.array () - bucket_size_;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> buckets;  // (key, subdomain)
  for (std::uint32_t i = 0; i < subs_.size (); ++i)
  {
    const Eigen::Array3i a = ((subs_[i].lo - bucket_origin_) / bucket_size_).array ().floor ().template cast<int> ();
    const Eigen::Array3i b = ((subs_[i].hi - bucket_origin_) / bucket_size_).array ().floor ().template cast<int> ();
    for (int z = a[2]; z <= b[2]; ++z)
      for (int y = a[1]; y <= b[1]; ++y)
        for (int x = a[0]; x <= b[0]; ++x)
          buckets.emplace_back (pclx::surface::detail::pack (x, y, z), i);
  }
  std::sort (buckets.begin (), buckets.end ());
  // Kept as one key per bucket and the subdomain numbers, not a key per (bucket, subdomain).
  bucket_subs_.resize (buckets.size ());
  for (std::size_t i = 0; i < buckets.size (); ++i)
  {
    if (i == 0 || buckets[i].first != buckets[i - 1].first)
    {
      bucket_keys_.push_back (buckets[i].first);
      bucket_first_.push_back (std::uint32_t (i));
    }
    bucket_subs_[i] = buckets[i].second;
  }
  bucket_first_.push_back (std::uint32_t (buckets.size ()));
}

template <typename PointNT> bool
RBFPOUReconstruction<PointNT>::fitSubdomain (Subdomain& s, const std::vector<float>& value,
                                             const std::vector<std::uint32_t>& origin, int np)
{
  using namespace pclx::surface::detail;
  const int m = int (s.count);
  const bool smooth = stats_.noise > 0;
  Eigen::MatrixXd p (m, np);  // the polynomial basis at the centres, in the frame of the fit
  Eigen::VectorXd h (m);
  for (int j = 0; j < m; ++j)
  {
    const std::uint32_t c = sub_ids_[s.first + j];
    const Eigen::Vector3d q =
        (Eigen::Vector3f (&cpos_[3 * std::size_t (c)]).template cast<double> () - s.centre) / s.scale;
    p.row (j) = polynomialBasis (q).head (np).transpose ();
    h[j] = double (value[c]);
  }
  ProjectedFit fit (p);
  if (!fit.valid () && np > kLinearTerms)
    return fitSubdomain (s, value, origin, kLinearTerms);  // centres too flat for a quadric
  const double target = std::sqrt (double (m)) * kNoiseResidual * stats_.noise;
  if (smooth && np == kQuadricTerms && fitTwoSheets (s, value, origin))
    return true;
  if (smooth && fit.valid ())
  {
    // As ρ grows the smoothing spline tends to the least-squares polynomial; when that one's
    // residual is within the noise already, Morozov's principle takes it and no r³ system is solved.
    const Eigen::VectorXd c = fit.leastSquares (h);
    if (c.allFinite () && (p * c - h).norm () <= target)
    {
      s.poly.setZero ();
      s.poly.head (np) = c;
      s.smoothing = std::numeric_limits<float>::infinity ();
      s.rbf = false;
      return true;
    }
  }
  Eigen::MatrixXd a (m, m);
  for (int j = 0; j < m; ++j)  // upper triangle by columns, then mirrored
  {
    r3Row (&p (0, 1), &p (0, 2), &p (0, 3), j, p (j, 1), p (j, 2), p (j, 3), &a (0, j));
    a (j, j) = 0;
  }
  a.template triangularView<Eigen::StrictlyLower> () = a.transpose ();

  Eigen::VectorXd lambda, poly;
  double rho = 0;
  bool ok = false;
  if (fit.valid ())
  {
    fit.project (a, h);
    rho = smooth ? chooseSmoothing (fit, target) : 0.0;
    ok = fit.solve (rho) && fit.get (lambda, poly);
  }
  // The residual of the full system decides: duplicated centres or too few distinct ones make
  // the projection singular, then an LU and least squares.
  a.diagonal ().array () += rho;
  auto residual = [&] {
    return std::sqrt ((a * lambda + p * poly - h).squaredNorm () + (p.transpose () * lambda).squaredNorm ());
  };
  bool fallback = false;
  if (!ok || !(residual () <= 1e-6 * h.norm () + 1e-12))
    fallback = solveFull (a, p, h, lambda, poly);
  for (int j = 0; j < m; ++j)
    sub_lambda_[s.first + j] = float (lambda[j]);
  s.poly.setZero ();
  s.poly.head (np) = poly;
  s.smoothing = float (rho);
  s.rbf = true;
  return !fallback;
}

template <typename PointNT> bool
RBFPOUReconstruction<PointNT>::fitTwoSheets (Subdomain& s, const std::vector<float>& value,
                                             const std::vector<std::uint32_t>& origin)
{
  using namespace pclx::surface::detail;
  // Across a plate thinner than the subdomain one quadric models both sides through its
  // quadratic term along the normal, whose least squares read the noise as thickness (the
  // sides move apart). Split by the normals (Ohtake et al. 2003's MPU splits sharp features
  // the same way): each side gets a height field over its own tangent plane, linear along
  // the normal, so it cannot bend back to the other side, and f_i is their max or min.
  const int m = int (s.count);
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero ();
  for (int j = 0; j < m; ++j)
  {
    const Eigen::Vector3d n = nrm_[origin[sub_ids_[s.first + j]]].template cast<double> ();
    scatter.noalias () += n * n.transpose ();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig (scatter);
  const Eigen::Vector3d axis = eig.eigenvectors ().col (2);
  // Side of every constraint: +1 / −1 within 60° of ±axis, 0 between (a rim, a crease).
  std::vector<std::int8_t> side (m);
  int count[3] = {0, 0, 0};
  for (int j = 0; j < m; ++j)
  {
    const double a = axis.dot (nrm_[origin[sub_ids_[s.first + j]]].template cast<double> ());
    side[j] = std::int8_t (a > 0.5 ? 1 : a < -0.5 ? -1 : 0);
    ++count[side[j] + 1];
  }
  if (std::min (count[0], count[2]) < kMinSheetConstraints || count[1] > kMaxBetweenSheets * m)
    return false;
  // Tangent frame (u, v, axis): rows [1 u v w u² v² uv], w along the axis.
  const Eigen::Vector3d e1 = axis.unitOrthogonal (), e2 = axis.cross (e1);
  std::array<Eigen::Matrix<double, kQuadricTerms, 1>, 2> poly;
  std::array<Eigen::Vector3d, 2> mean;
  std::array<double, 2> slope;  // |∂f/∂w| per unit of length: f / slope is a distance
  auto position = [&] (int j) -> Eigen::Vector3d {
    return (Eigen::Vector3f (&cpos_[3 * std::size_t (sub_ids_[s.first + j])]).template cast<double> () - s.centre) /
           s.scale;
  };
  for (int g = 0; g < 2; ++g)
  {
    const std::int8_t want = g == 0 ? 1 : -1;
    const int k = count[want + 1];
    Eigen::MatrixXd rows (k, kHeightFieldTerms);
    Eigen::VectorXd h (k);
    mean[g].setZero ();
    for (int j = 0, r = 0; j < m; ++j)
    {
      if (side[j] != want)
        continue;
      const Eigen::Vector3d q = position (j);
      const double u = e1.dot (q), v = e2.dot (q), w = axis.dot (q);
      rows.row (r) << 1, u, v, w, u * u, v * v, u * v;
      h[r++] = double (value[sub_ids_[s.first + j]]);
      mean[g] += q / k;
    }
    const Eigen::HouseholderQR<Eigen::MatrixXd> qr (rows);
    const Eigen::VectorXd r = qr.matrixQR ().topLeftCorner (kHeightFieldTerms, kHeightFieldTerms).diagonal ().cwiseAbs ();
    if (!(r.minCoeff () > 1e-9 * r.maxCoeff ()))
      return false;
    const Eigen::VectorXd c = qr.solve (h);
    if (!c.allFinite () || (rows * c - h).norm () > std::sqrt (double (k)) * kNoiseResidual * stats_.noise)
      return false;
    poly[g] = heightFieldToQuadric (c, e1, e2, axis);
    slope[g] = std::abs (c[3]) / s.scale;
    if (!(slope[g] > 0))
      return false;
  }
  // The sides must lie over each other: their centres apart along the tangent plane by less than
  // kSheetOverlap of the points' spread there (a wrongly oriented patch lies beside the rest).
  {
    const Eigen::Vector3d d = mean[1] - mean[0];
    const double apart = std::hypot (e1.dot (d), e2.dot (d));
    double spread = 0;
    for (int j = 0; j < m; ++j)
      if (side[j] != 0)
      {
        const Eigen::Vector3d q = position (j) - mean[side[j] > 0 ? 0 : 1];
        spread += (q.dot (e1) * q.dot (e1) + q.dot (e2) * q.dot (e2)) / (count[0] + count[2]);
      }
    if (!(apart < kSheetOverlap * std::sqrt (spread)))
      return false;
  }
  // The second side lies behind the first one's outside (a plate: solid between, F = max) or
  // in front of it (a slot: empty between, F = min).
  s.sheets = std::int8_t ((mean[1] - mean[0]).dot (axis) < 0 ? 1 : -1);
  // Each side's fit must put the other side's points inside its solid (max) or outside it
  // (min), each up to the noise and on average beyond it, as distances (under noise a fit's
  // slope along the normal is below 1): otherwise the max / min would let one fit's far field
  // cut the other's surface, or the "sides" are one surface whose normals disagree (wrongly
  // oriented patches), where a split makes islands.
  double depth = 0;
  int on_surface = 0;
  for (int j = 0; j < m; ++j)
    if (side[j] != 0 && value[sub_ids_[s.first + j]] == 0.f)
    {
      const int g = side[j] > 0 ? 1 : 0;  // the other side's fit
      const double other = s.sheets * poly[g].dot (polynomialBasis (position (j))) / slope[g];
      depth += other;
      ++on_surface;
      if (other >= kSheetTolerance * stats_.noise)
      {
        s.sheets = 0;
        return false;
      }
    }
  if (!(on_surface > 0 && depth / on_surface < -kSheetSeparation * stats_.noise))
  {
    s.sheets = 0;
    return false;
  }
  s.poly = poly[0];
  sheet_poly_[std::size_t (&s - subs_.data ())] = poly[1];
  s.smoothing = std::numeric_limits<float>::infinity ();
  s.rbf = false;
  return true;
}

template <typename PointNT> void
RBFPOUReconstruction<PointNT>::fitSubdomains (const std::vector<float>& value, const std::vector<std::uint32_t>& origin)
{
  sub_lambda_.assign (sub_ids_.size (), 0.f);
  if (stats_.noise > 0)
    sheet_poly_.assign (subs_.size (), Eigen::Matrix<double, 10, 1>::Zero ());
  std::size_t fallbacks = 0, smoothed = 0, polynomial = 0, two_sheets = 0;
#pragma omp parallel for num_threads(pclx::surface::detail::threadCount (threads_)) \
    reduction(+ : fallbacks, smoothed, polynomial, two_sheets) \
    schedule(dynamic, 4)
  for (std::ptrdiff_t si = 0; si < std::ptrdiff_t (subs_.size ()); ++si)
  {
    // Smoothing fits also carry the quadratic terms: for a large ρ the fit tends to the
    // least-squares quadric through the constraints, which follows curvature a plane cannot.
    fallbacks += !fitSubdomain (subs_[si], value, origin,
                                stats_.noise > 0 ? pclx::surface::detail::kQuadricTerms
                                                 : pclx::surface::detail::kLinearTerms);
    smoothed += subs_[si].smoothing > 0;
    polynomial += !subs_[si].rbf;
    two_sheets += subs_[si].sheets != 0;
  }
  stats_.fit_fallbacks = fallbacks;
  stats_.smoothed_subdomains = smoothed;
  stats_.polynomial_subdomains = polynomial;
  stats_.two_sheet_subdomains = two_sheets;
}

template <typename PointNT> bool
RBFPOUReconstruction<PointNT>::build ()
{
  using namespace pclx::surface::detail;
  stats_ = Stats ();
  error_.clear ();
  pts_.clear (); nrm_.clear (); src_.clear (); off_.clear (); subs_.clear (); sheet_poly_.clear ();
  sub_ids_.clear (); sub_lambda_.clear (); cpos_.clear ();
  bucket_keys_.clear (); bucket_first_.clear (); bucket_subs_.clear ();
  if (!checkParameters ())
    return false;

  auto t0 = Clock::now ();
  if (!collectPoints ())
    return false;
  {
    // The points' kd-tree, freed before the octree: the constraints get one of their own.
    pcl::PointCloud<pcl::PointXYZ>::Ptr xyz (new pcl::PointCloud<pcl::PointXYZ>);
    xyz->resize (pts_.size ());
    for (std::size_t i = 0; i < pts_.size (); ++i)
      (*xyz)[i].getVector3fMap () = pts_[i];
    pcl::KdTreeFLANN<pcl::PointXYZ> own (false);
    std::unique_ptr<pclx::surface::detail::SearchOverValidPoints<PointNT>> given;
    if (tree_)
      given = searchOverValidPoints ();
    else
      own.setInputCloud (xyz);
    const pcl::KdTree<pcl::PointXYZ>& tree = given ? static_cast<const pcl::KdTree<pcl::PointXYZ>&> (*given) : own;
    std::vector<int> nn;
    if (!measureSpacing (tree, nn) || (orient_normals_ && !orientNormals (xyz)))
      return false;
    estimateNoise (tree);
    measureDensitySpread (tree);
    if (!nn.empty ())
      voteNormals (nn);
    std::vector<int> ().swap (nn);
    stats_.t_prepare = seconds (t0);

    t0 = Clock::now ();
    placeOffSurfaceConstraints (tree);
    stats_.t_off_surface = seconds (t0);
  }

  t0 = Clock::now ();
  std::vector<Leaf> leaves = splitOctree ();
  growLeaves (leaves);
  std::vector<std::uint32_t> origin;
  const std::vector<float> value = makeSubdomains (leaves, origin);
  if (subs_.empty ())
    return fail ("no subdomain reached Tmin = " + std::to_string (stats_.min_constraints) + " constraints");
  buildBuckets ();
  stats_.t_octree = seconds (t0);

  t0 = Clock::now ();
  fitSubdomains (value, origin);
  stats_.t_fits = seconds (t0);
  return true;
}

// The sparse marching-cubes grid of extract () and what its stages hand on to each other.
template <typename PointNT>
struct RBFPOUReconstruction<PointNT>::ExtractState
{
  int nt = 1;                          // threads
  double h = 0;                        // cell size
  Eigen::Vector3d origin = Eigen::Vector3d::Zero ();
  std::array<std::uint64_t, 3> stride{};  // key step of one cell along each axis
  std::array<int, 6> face_edges{};        // edges of each cell face (PCL corner order)
  std::vector<std::uint64_t> frontier, visited;  // cells (sorted keys)
  // The band as runs of cells along x, [band_first[r], band_last[r]] in keys (x is the lowest
  // key field, so a run is a key range): a fraction of the memory of its cells' keys.
  std::vector<std::uint64_t> band_first, band_last;
  std::vector<std::uint64_t> ckeys;    // evaluated corners (sorted)
  std::vector<double> cvals;           // F − iso at ckeys
  std::vector<std::uint64_t> mc_cells; // cells with a triangle, and their cube index
  std::vector<std::uint8_t> mc_cube;
  std::vector<std::uint64_t> edges;    // grid edges the surface crosses (sorted)
  std::vector<std::vector<std::uint64_t>> next_t;  // per thread: cells across crossed faces
  std::size_t uncovered = 0;
  std::unique_ptr<pcl::KdTreeFLANN<pcl::PointXYZ>> nearest;  // subdomain centres, built when first needed

  Eigen::Vector3d
  position (std::uint64_t key) const
  {
    return Eigen::Vector3d (origin + pclx::surface::detail::unpack (key).cast<double> ().matrix () * h);
  }
  // A vertex is named by its grid edge (low corner key · 4 + axis), so cells that share an
  // edge share the vertex.
  std::uint64_t
  edgeKey (std::uint64_t cell, int e) const
  {
    const int* a = pclx::surface::detail::kCorner[pclx::surface::detail::kEdge[e][0]];
    const int* b = pclx::surface::detail::kCorner[pclx::surface::detail::kEdge[e][1]];
    int axis = 0;
    while (a[axis] == b[axis])
      ++axis;
    const int* low = a[axis] < b[axis] ? a : b;
    return 4 * (cell + low[0] * stride[0] + low[1] * stride[1] + low[2] * stride[2]) + std::uint64_t (axis);
  }
  double
  cornerValue (std::uint64_t key) const
  {
    return cvals[std::size_t (std::lower_bound (ckeys.begin (), ckeys.end (), key) - ckeys.begin ())];
  }
  // Appends the cells of the sorted `cells` that lie in the band to `out`.
  void
  keepInBand (const std::vector<std::uint64_t>& cells, std::vector<std::uint64_t>& out) const
  {
    std::size_t r = 0;
    for (const std::uint64_t c : cells)
    {
      while (r < band_last.size () && band_last[r] < c)
        ++r;
      if (r < band_last.size () && band_first[r] <= c)
        out.push_back (c);
    }
  }
};

template <typename PointNT> bool
RBFPOUReconstruction<PointNT>::setUpExtractGrid (ExtractState& g)
{
  using namespace pclx::surface::detail;
  g.nt = threadCount (threads_);
  g.h = stats_.grid_resolution;
  const double h = g.h;
  const auto [bmin, bmax] = bounds (pts_);
  g.origin = bmin.cast<double> ().array () - (band_ + 2) * h;
  const Eigen::Vector3d extent = (bmax.cast<double> () - g.origin).array () / h + band_ + 3;
  if (extent.maxCoeff () >= double (kMaxIndex))
    return fail ("grid resolution " + std::to_string (h) + " too fine for the extent (more than 2^20 cells per axis)");
  for (int axis = 0; axis < 3; ++axis)
  {
    g.stride[axis] = std::uint64_t (1) << (kBits * axis);
    for (int side = 0; side < 2; ++side)
      for (int e = 0; e < 12; ++e)
        if (kCorner[kEdge[e][0]][axis] == side && kCorner[kEdge[e][1]][axis] == side)
          g.face_edges[2 * axis + side] |= 1 << e;
  }
  return true;
}

template <typename PointNT> void
RBFPOUReconstruction<PointNT>::findBand (ExtractState& g)
{
  // Cells holding a point, and the band: those dilated by band_ cells (one axis at a time).
  using namespace pclx::surface::detail;
  auto& frontier = g.frontier;
  frontier.resize (pts_.size ());
  for (std::size_t i = 0; i < pts_.size (); ++i)
  {
    const Eigen::Array3d c = ((pts_[i].cast<double> () - g.origin) / g.h).array ().floor ();
    frontier[i] = pack (std::int64_t (c[0]), std::int64_t (c[1]), std::int64_t (c[2]));
  }
  sortUnique (frontier);
  // Dilated along y and z as keys, then along x as runs: a key ± band_ stays in its row, since
  // the grid's margin of band_ + 2 cells keeps every x ± band_ within [0, 2^20).
  std::vector<std::uint64_t> rows = frontier;
  dilate (rows, 1, -band_, band_);
  dilate (rows, 2, -band_, band_);
  stats_.band_cells = 0;
  for (const std::uint64_t k : rows)
  {
    const std::uint64_t first = k - std::uint64_t (band_), last = k + std::uint64_t (band_);
    if (!g.band_last.empty () && first <= g.band_last.back () + 1)
    {
      stats_.band_cells += last - g.band_last.back ();
      g.band_last.back () = last;
    }
    else
    {
      stats_.band_cells += last - first + 1;
      g.band_first.push_back (first);
      g.band_last.push_back (last);
    }
  }
  std::vector<std::uint64_t> ().swap (rows);
  if (continuation_)
    return;
  frontier.clear ();
  for (std::size_t r = 0; r < g.band_first.size (); ++r)
    for (std::uint64_t c = g.band_first[r]; c <= g.band_last[r]; ++c)
      frontier.push_back (c);
}

template <typename PointNT> void
RBFPOUReconstruction<PointNT>::evaluateFrontierCorners (ExtractState& g)
{
  // F at the corners of the frontier cells not evaluated yet, merged into ckeys / cvals.
  using namespace pclx::surface::detail;
  std::vector<std::uint64_t> fresh;
  {
    std::vector<std::uint64_t> need = g.frontier;  // corners: cells dilated by {0, 1}³
    for (int axis = 0; axis < 3; ++axis)
      dilate (need, axis, 0, 1);
    fresh.reserve (need.size ());
    std::set_difference (need.begin (), need.end (), g.ckeys.begin (), g.ckeys.end (), std::back_inserter (fresh));
  }
  std::vector<double> fvals (fresh.size ());
  // Through float, as evaluate (): F at a vertex's corners is what a user can query.
  auto corner = [&] (std::uint64_t key) -> Eigen::Vector3d {
    return g.position (key).template cast<float> ().template cast<double> ();
  };
#pragma omp parallel num_threads(g.nt)
  {
    BucketCache cache;
#pragma omp for schedule(dynamic, 256)
    for (std::ptrdiff_t i = 0; i < std::ptrdiff_t (fresh.size ()); ++i)
      fvals[i] = evaluateCached (corner (fresh[i]), cache) - iso_;
  }
  // Near sharp corners and sparse patches the enlarged octree cells can leave band corners
  // uncovered; skipping their cells would open the mesh, so they take the nearest fit.
  for (std::size_t i = 0; i < fresh.size (); ++i)
    if (std::isnan (fvals[i]))
    {
      ++g.uncovered;
      fvals[i] = nearestLocal (corner (fresh[i]), g.nearest) - iso_;
    }
  auto& ckeys = g.ckeys;
  auto& cvals = g.cvals;
  std::vector<std::uint64_t> keys (ckeys.size () + fresh.size ());
  std::vector<double> vals (keys.size ());
  std::size_t a = 0, b = 0, o = 0;
  while (a < ckeys.size () || b < fresh.size ())
  {
    const bool take_a = b == fresh.size () || (a < ckeys.size () && ckeys[a] < fresh[b]);
    keys[o] = take_a ? ckeys[a] : fresh[b];
    vals[o++] = take_a ? cvals[a++] : fvals[b++];
  }
  ckeys.swap (keys);
  cvals.swap (vals);
}

template <typename PointNT> void
RBFPOUReconstruction<PointNT>::classifyFrontier (ExtractState& g)
{
  // Cube index of every frontier cell, in contiguous per-thread chunks (deterministic
  // concatenation); with continuation, the neighbours across crossed faces go to next_t.
  using namespace pclx::surface::detail;
  const int nt = g.nt;
  const auto& frontier = g.frontier;
  const auto& ckeys = g.ckeys;
  const auto& cvals = g.cvals;
  const auto& stride = g.stride;
  g.next_t.assign (nt, {});
  std::vector<std::vector<std::uint64_t>> cells_t (nt);
  std::vector<std::vector<std::uint8_t>> cube_t (nt);
#pragma omp parallel num_threads(nt)
  {
#ifdef _OPENMP
    const int tid = omp_get_thread_num ();
#else
    const int tid = 0;
#endif
    const std::size_t lo = frontier.size () * tid / nt, hi = frontier.size () * (tid + 1) / nt;
    for (std::size_t ci = lo; ci < hi; ++ci)
    {
      const std::uint64_t c = frontier[ci];
      // Corners (x, x + 1) are neighbours in ckeys: four searches for the eight corners.
      double v[8];
      for (int yz = 0; yz < 4; ++yz)
      {
        const std::uint64_t k = c + (yz & 1 ? stride[1] : 0) + (yz & 2 ? stride[2] : 0);
        const std::size_t i = std::size_t (std::lower_bound (ckeys.begin (), ckeys.end (), k) - ckeys.begin ());
        // PCL order: corners 0, 1 at (y, z) = (0, 0); 3, 2 at (0, 1); 4, 5 at (1, 0); 7, 6 at (1, 1).
        static constexpr int kLow[4] = {0, 4, 3, 7}, kHigh[4] = {1, 5, 2, 6};
        v[kLow[yz]] = cvals[i];
        v[kHigh[yz]] = cvals[i + 1];
      }
      int index = 0, defined = 0;
      for (int k = 0; k < 8; ++k)
      {
        index |= (v[k] < 0) << k;
        defined |= !std::isnan (v[k]) << k;
      }
      if (defined == 0xff && edgeTable[index] != 0)
      {
        cells_t[tid].push_back (c);
        cube_t[tid].push_back (std::uint8_t (index));
      }
      if (!continuation_)
        continue;
      int crossed = 0;
      for (int e = 0; e < 12; ++e)
      {
        const int a = kEdge[e][0], b = kEdge[e][1];
        crossed |= (((defined >> a) & (defined >> b) & 1) && ((index >> a) & 1) != ((index >> b) & 1)) << e;
      }
      for (int f = 0; f < 6; ++f)
        if (crossed & g.face_edges[f])
          g.next_t[tid].push_back (f & 1 ? c + stride[f / 2] : c - stride[f / 2]);
    }
  }
  for (int t = 0; t < nt; ++t)
  {
    g.mc_cells.insert (g.mc_cells.end (), cells_t[t].begin (), cells_t[t].end ());
    g.mc_cube.insert (g.mc_cube.end (), cube_t[t].begin (), cube_t[t].end ());
  }
}

template <typename PointNT> void
RBFPOUReconstruction<PointNT>::marchWaves (ExtractState& g)
{
  // Waves: evaluate F at the corners of the frontier cells not seen yet, classify the cells,
  // then the next frontier is the band cells across crossed faces not visited yet.
  using namespace pclx::surface::detail;
  auto& frontier = g.frontier;
  auto& visited = g.visited;
  while (!frontier.empty ())
  {
    ++stats_.waves;
    evaluateFrontierCorners (g);
    classifyFrontier (g);
    {
      std::vector<std::uint64_t> merged;
      merged.reserve (visited.size () + frontier.size ());
      std::set_union (visited.begin (), visited.end (), frontier.begin (), frontier.end (), std::back_inserter (merged));
      visited.swap (merged);
    }
    if (!continuation_)
      break;
    std::vector<std::uint64_t> cand;
    for (int t = 0; t < g.nt; ++t)
      cand.insert (cand.end (), g.next_t[t].begin (), g.next_t[t].end ());
    sortUnique (cand);
    std::vector<std::uint64_t> fresh_cells;
    std::set_difference (cand.begin (), cand.end (), visited.begin (), visited.end (), std::back_inserter (fresh_cells));
    frontier.clear ();
    g.keepInBand (fresh_cells, frontier);
  }
  stats_.active_cells = visited.size ();
  stats_.corners = g.ckeys.size ();
  stats_.uncovered_corners = g.uncovered;
  std::vector<std::uint64_t> ().swap (g.band_first);
  std::vector<std::uint64_t> ().swap (g.band_last);
  std::vector<std::uint64_t> ().swap (visited);
  std::vector<std::uint64_t> ().swap (frontier);
  std::vector<std::vector<std::uint64_t>> ().swap (g.next_t);
}

template <typename PointNT> void
RBFPOUReconstruction<PointNT>::sortCellsByKey (ExtractState& g)
{
  // Cells in key order: the mesh does not depend on the order the waves found them in.
  auto& mc_cells = g.mc_cells;
  auto& mc_cube = g.mc_cube;
  std::vector<std::uint32_t> order (mc_cells.size ());
  std::iota (order.begin (), order.end (), 0u);
  std::sort (order.begin (), order.end (), [&] (std::uint32_t a, std::uint32_t b) { return mc_cells[a] < mc_cells[b]; });
  std::vector<std::uint64_t> cells (order.size ());
  std::vector<std::uint8_t> cube (order.size ());
  for (std::size_t i = 0; i < order.size (); ++i)
  {
    cells[i] = mc_cells[order[i]];
    cube[i] = mc_cube[order[i]];
  }
  mc_cells.swap (cells);
  mc_cube.swap (cube);
}

template <typename PointNT> void
RBFPOUReconstruction<PointNT>::collectCrossedEdges (ExtractState& g)
{
  // The grid edges the surface crosses, from every cell's edge table (per thread, then merged).
  using namespace pclx::surface::detail;
  const int nt = g.nt;
  const auto& mc_cells = g.mc_cells;
  const auto& mc_cube = g.mc_cube;
  auto& edges = g.edges;
  std::vector<std::vector<std::uint64_t>> edges_t (nt);
#pragma omp parallel num_threads(nt)
  {
#ifdef _OPENMP
    const int tid = omp_get_thread_num ();
#else
    const int tid = 0;
#endif
    const std::size_t lo = mc_cells.size () * tid / nt, hi = mc_cells.size () * (tid + 1) / nt;
    for (std::size_t ci = lo; ci < hi; ++ci)
      for (int e = 0; e < 12; ++e)
        if (edgeTable[mc_cube[ci]] & (1 << e))
          edges_t[tid].push_back (g.edgeKey (mc_cells[ci], e));
    sortUnique (edges_t[tid]);
  }
  for (int t = 0; t < nt; ++t)
  {
    std::vector<std::uint64_t> merged;
    merged.reserve (edges.size () + edges_t[t].size ());
    std::set_union (edges.begin (), edges.end (), edges_t[t].begin (), edges_t[t].end (), std::back_inserter (merged));
    edges.swap (merged);
    std::vector<std::uint64_t> ().swap (edges_t[t]);
  }
}

template <typename PointNT> void
RBFPOUReconstruction<PointNT>::interpolateVertices (ExtractState& g, std::vector<Eigen::Vector3f>& vertices)
{
  // Vertices: linear interpolation on the edge.
  const auto& edges = g.edges;
  vertices.resize (edges.size ());
#pragma omp parallel for num_threads(g.nt) schedule(static)
  for (std::ptrdiff_t i = 0; i < std::ptrdiff_t (edges.size ()); ++i)
  {
    const std::uint64_t k0 = edges[i] >> 2;
    const std::uint64_t k1 = k0 + g.stride[edges[i] & 3];
    const double v0 = g.cornerValue (k0), v1 = g.cornerValue (k1);
    const double t = v0 == v1 ? 0.5 : std::clamp (v0 / (v0 - v1), 0.0, 1.0);
    vertices[i] = ((1 - t) * g.position (k0) + t * g.position (k1)).template cast<float> ();
  }
  // The corner values are no longer needed: free them before the polygons are allocated.
  std::vector<std::uint64_t> ().swap (g.ckeys);
  std::vector<double> ().swap (g.cvals);
}

template <typename PointNT> void
RBFPOUReconstruction<PointNT>::triangulateCells (const ExtractState& g, std::vector<Triangle>& triangles)
{
  // Marching cubes' triangles of every cell, their corners named by the crossed edges.
  using namespace pclx::surface::detail;
  const auto& mc_cells = g.mc_cells;
  const auto& mc_cube = g.mc_cube;
  const auto& edges = g.edges;
  std::vector<std::size_t> first_tri (mc_cells.size () + 1, 0);
  for (std::size_t ci = 0; ci < mc_cells.size (); ++ci)
  {
    int t = 0;
    while (triTable[mc_cube[ci]][3 * t] != -1)
      ++t;
    first_tri[ci + 1] = first_tri[ci] + t;
  }
  triangles.resize (first_tri.back ());
#pragma omp parallel for num_threads(g.nt) schedule(static)
  for (std::ptrdiff_t ci = 0; ci < std::ptrdiff_t (mc_cells.size ()); ++ci)
  {
    const int* tri = triTable[mc_cube[ci]];
    for (std::size_t t = first_tri[ci], i = 0; t < first_tri[ci + 1]; ++t)
    {
      Triangle& v = triangles[t];
      for (int j = 0; j < 3; ++j, ++i)
        v[j] = std::uint32_t (std::lower_bound (edges.begin (), edges.end (), g.edgeKey (mc_cells[ci], tri[i])) - edges.begin ());
    }
  }
}

template <typename PointNT> bool
RBFPOUReconstruction<PointNT>::extract (std::vector<Eigen::Vector3f>& vertices, std::vector<Triangle>& triangles)
{
  using namespace pclx::surface::detail;
  const auto t0 = Clock::now ();
  {
    ExtractState g;  // freed before the holes are closed
    if (!setUpExtractGrid (g))
      return false;
    findBand (g);
    marchWaves (g);
    sortCellsByKey (g);
    collectCrossedEdges (g);
    interpolateVertices (g, vertices);
    triangulateCells (g, triangles);
  }
  closeHoles (vertices, triangles);
  stats_.vertices = vertices.size ();
  stats_.triangles = triangles.size ();
  stats_.t_extraction = seconds (t0);
  return true;
}

template <typename PointNT> template <typename At> void
RBFPOUReconstruction<PointNT>::makeVertices (std::vector<Eigen::Vector3f>& vertices, const std::vector<Vertices>& polygons,
                                             At&& at)
{
  using namespace pclx::surface::detail;
  const auto t0 = Clock::now ();
  const int nt = threadCount (threads_);
  // Other fields (colour, intensity, ...) come from the nearest input point; a point type with
  // nothing but position, normal and curvature needs no search.
  bool attributes = false;
  for (const auto& f : pcl::getFields<PointNT> ())
    attributes = attributes || (f.name != "x" && f.name != "y" && f.name != "z" && f.name != "normal_x" &&
                                f.name != "normal_y" && f.name != "normal_z" && f.name != "curvature");
  {
    pcl::PointCloud<pcl::PointXYZ>::Ptr xyz (new pcl::PointCloud<pcl::PointXYZ>);
    pcl::KdTreeFLANN<pcl::PointXYZ> tree (false);
    if (attributes)
    {
      xyz->resize (pts_.size ());
      for (std::size_t i = 0; i < pts_.size (); ++i)
        (*xyz)[i].getVector3fMap () = pts_[i];
      tree.setInputCloud (xyz);
    }
#pragma omp parallel for num_threads(nt) schedule(static)
    for (std::ptrdiff_t i = 0; i < std::ptrdiff_t (vertices.size ()); ++i)
    {
      PointNT out;
      if (attributes)
      {
        pcl::PointXYZ q;
        q.getVector3fMap () = vertices[i];
        pcl::Indices nn (1);
        std::vector<float> d (1);
        if (tree.nearestKSearch (q, 1, nn, d) == 1)
          out = (*input_)[src_[nn[0]]];
      }
      out.getVector3fMap () = vertices[i];
      out.getNormalVector3fMap ().setZero ();
      if constexpr (pcl::traits::has_curvature_v<PointNT>)
        out.curvature = 0;
      at (std::size_t (i)) = out;
    }
  }
  const std::size_t nv = vertices.size ();
  std::vector<Eigen::Vector3f> ().swap (vertices);
  // Area-weighted face normals, summed in the output itself (no extra array; serial, so the
  // sums and the mesh do not depend on the thread count).
  for (const auto& poly : polygons)
  {
    const Eigen::Vector3f a = at (poly.vertices[0]).getVector3fMap ();
    const Eigen::Vector3f fn = (at (poly.vertices[1]).getVector3fMap () - a).cross (at (poly.vertices[2]).getVector3fMap () - a);
    for (const auto v : poly.vertices)
      at (v).getNormalVector3fMap () += fn;
  }
#pragma omp parallel for num_threads(nt) schedule(static)
  for (std::ptrdiff_t i = 0; i < std::ptrdiff_t (nv); ++i)
  {
    PointNT& p = at (std::size_t (i));
    const float len = p.getNormalVector3fMap ().norm ();
    if (len > 0)
      p.getNormalVector3fMap () /= len;
  }
  stats_.t_output += seconds (t0);
}

template <typename PointNT> void
RBFPOUReconstruction<PointNT>::makePolygons (std::vector<Triangle>& triangles, std::vector<Vertices>& polygons)
{
  // Serial: the small allocations then come from one heap, where the extraction's freed buffers are.
  const auto t0 = pclx::surface::detail::Clock::now ();
  polygons.resize (triangles.size ());
  for (std::size_t t = 0; t < triangles.size (); ++t)
    polygons[t].vertices.assign (triangles[t].begin (), triangles[t].end ());
  std::vector<Triangle> ().swap (triangles);
  stats_.t_output = pclx::surface::detail::seconds (t0);
}

template <typename PointNT> void
RBFPOUReconstruction<PointNT>::reconstruct (PolygonMesh& output)
{
  if (!input_)
  {
    fail ("no input cloud (setInputCloud)");
    output = PolygonMesh ();
    return;
  }
  SurfaceReconstruction<PointNT>::reconstruct (output);
}

template <typename PointNT> void
RBFPOUReconstruction<PointNT>::reconstruct (PointCloud<PointNT>& points, std::vector<Vertices>& polygons)
{
  if (!input_)
  {
    fail ("no input cloud (setInputCloud)");
    points.clear ();
    polygons.clear ();
    return;
  }
  SurfaceReconstruction<PointNT>::reconstruct (points, polygons);
}

template <typename PointNT> void
RBFPOUReconstruction<PointNT>::performReconstruction (PointCloud<PointNT>& points, std::vector<Vertices>& polygons)
{
  points.clear ();
  std::vector<Vertices> ().swap (polygons);  // reconstruct () reserved 2 per input point
  std::vector<Eigen::Vector3f> vertices;
  std::vector<Triangle> triangles;
  if (!build () || !extract (vertices, triangles))
    return;
  makePolygons (triangles, polygons);
  points.resize (vertices.size ());
  points.width = std::uint32_t (vertices.size ());
  points.height = 1;
  points.is_dense = true;
  makeVertices (vertices, polygons, [&] (std::size_t i) -> PointNT& { return points[i]; });
}

template <typename PointNT> void
RBFPOUReconstruction<PointNT>::performReconstruction (PolygonMesh& output)
{
  // reconstruct () filled output.cloud with a copy of the input and reserved 2 polygons per
  // input point: release both, or they would be held through the whole run.
  output.cloud.data.clear ();
  output.cloud.data.shrink_to_fit ();
  std::vector<Vertices> ().swap (output.polygons);
  std::vector<Eigen::Vector3f> vertices;
  std::vector<Triangle> triangles;
  const PointCloud<PointNT> empty;
  pcl::toPCLPointCloud2 (empty, output.cloud);  // fields and point_step of PointNT, no data
  if (!build () || !extract (vertices, triangles))
    return;
  makePolygons (triangles, output.polygons);
  // The vertices are built in the blob itself, one PointNT per point_step as toPCLPointCloud2
  // lays them out, instead of in a PointCloud and then copied (one output cloud less at peak).
  auto& c = output.cloud;
  c.width = std::uint32_t (vertices.size ());
  c.height = 1;
  c.is_dense = true;
  c.row_step = c.point_step * c.width;
  c.data.assign (std::size_t (c.row_step), 0);
  static_assert (std::is_trivially_destructible<PointNT>::value, "points live in the byte blob");
  // operator new aligns to 16 bytes, point_step = sizeof (PointNT): every record is aligned.
  for (std::size_t i = 0; i < vertices.size (); ++i)
    new (&c.data[i * c.point_step]) PointNT;
  makeVertices (vertices, output.polygons, [&] (std::size_t i) -> PointNT& {
    return *std::launder (reinterpret_cast<PointNT*> (&c.data[i * c.point_step]));
  });
}

}  // namespace pcl
