#include <pclx/normals/detail/scale_selection.h>
#include <pclx/normals/detail/plane_pca.h>
#include <pclx/normals/detail/grid_knn.h>

#include <pcl/common/eigen.h>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>

namespace pclx {
namespace normals {
namespace detail {

namespace {

// Eigen decomposition of a covariance, ascending (λ3 ≤ λ2 ≤ λ1), PCL's closed form.
void
eigenAscending (const Eigen::Matrix3d& cov, Eigen::Matrix3d& vectors, Eigen::Vector3d& values)
{
  pcl::eigen33 (cov, vectors, values);
  values = values.cwiseMax (0.0);
}

// Rungs whose normal's standard error is at least this (radians) are noise-dominated:
// the perturbation formula no longer holds and their normal constrains nothing.
constexpr double kCompareError = 0.2;
// The residual-growth test reads rungs whose normal is better defined than this.
constexpr double kResidualError = 0.1;
// Residual growth, in relative sampling errors √(2/dof), that stops the growth.
constexpr double kResidualZ = 2.0;
// ... from rungs of at least this many points (over fewer, the residual's few degrees of
// freedom make √(2/dof) a poor guide).
constexpr int kResidualMinCount = 30;

// Standard error (radians) of a PCA normal over count points whose covariance has the
// eigenvalues lambda (ascending), under noise variance l3: the eigenvector perturbation
// formula; π when the in-plane spread is no larger than the noise.
double
normalStdError (const Eigen::Vector3d& lambda, int count, double l3)
{
  const double e1 = lambda (2) - l3, e2 = lambda (1) - l3;
  if (!(e2 > 1e-9 * lambda (2)))
    return M_PI;
  return std::min (M_PI, std::sqrt ((lambda (2) * l3 / (e1 * e1) + lambda (1) * l3 / (e2 * e2)) / count));
}

// One-sided support: its centroid lies off x in the plane by more than 0.3 of its radius
// (the farthest point's distance), beyond the noise (x itself is off the surface by that
// much). A rim or a border: more points bring another sheet, not less noise.
bool
oneSided (const Eigen::Vector3d& mean, const Eigen::Vector3d& normal, double radius, double noise2)
{
  return (mean - mean.dot (normal) * normal).norm () > 0.3 * radius + 3.0 * std::sqrt (noise2);
}

// Lepski's agreement of a larger support's normal (error err_q) with a smaller one's (err_a),
// nested: the difference has variance err_a² − err_q² (the larger support is the more
// efficient estimate), not (err_a + err_q)², which lets slowly growing bias
// through. A noise-dominated smaller support (error ≥
// kCompareError) says nothing about the bias of the larger one.
bool
agrees (const Eigen::Vector3d& na, double err_a, const Eigen::Vector3d& nq, double err_q, double tau)
{
  if (!(err_a < kCompareError))
    return true;
  const double angle = std::acos (std::min (1.0, std::abs (na.dot (nq))));
  return angle <= tau * std::sqrt (std::max (0.0, err_a * err_a - err_q * err_q)) + 1e-3;
}

// The PCA plane of a support from its sums (positions relative to x); false: no plane.
bool
fitSums (const Eigen::Vector3d& s1, const Eigen::Matrix3d& s2, int count, Eigen::Vector3d& mean, Eigen::Vector3d& normal,
         Eigen::Vector3d& lambda)
{
  if (count < 3)
    return false;
  mean = s1 / count;
  // Only the normal is read here: one eigenvector, not eigen33's three.
  const PlanePca p = planePca (s2 / count - mean * mean.transpose ());
  lambda = p.lambda.reverse ();  // ascending
  normal = p.normal;
  return lambda (2) > 0 && lambda (1) > 1e-12 * lambda (2);
}

// Residual variance of a quadric height field h = c0 u² + c1 uw + c2 w² + c3 u + c4 w + c5
// (6 unknowns) over the plane with normal nz (u, w scaled by `scale`), over nested
// prefixes of a support: the moments of the monomials up to degree 4 (the normal
// equations' entries) are summed point by point, by hand: Eigen's rank update of the
// 6 × 6 matrix is much slower here.
class QuadricMoments
{
public:
  QuadricMoments (const Eigen::Vector3d& nz, double scale)
    : nz_ (nz), e1_ (nz.unitOrthogonal ()), e2_ (nz.cross (e1_)), scale_ (scale)
  {}

  void
  add (const Eigen::Vector3d& d)
  {
    const double u = d.dot (e1_) / scale_, w = d.dot (e2_) / scale_, h = d.dot (nz_);
    const double uu = u * u, uw = u * w, ww = w * w;
    mom_[U] += u;
    mom_[W] += w;
    mom_[UU] += uu;
    mom_[UW] += uw;
    mom_[WW] += ww;
    mom_[U3] += uu * u;
    mom_[U2W] += uu * w;
    mom_[UW2] += u * ww;
    mom_[W3] += ww * w;
    mom_[U4] += uu * uu;
    mom_[U3W] += uu * uw;
    mom_[U2W2] += uu * ww;
    mom_[UW3] += uw * ww;
    mom_[W4] += ww * ww;
    mom_[HUU] += h * uu;
    mom_[HUW] += h * uw;
    mom_[HWW] += h * ww;
    mom_[HU] += h * u;
    mom_[HW] += h * w;
    mom_[H] += h;
    mom_[HH] += h * h;
  }

  // Over the `count` points added so far (> 6); NaN when the fit fails.
  double
  residual (int count) const
  {
    const double* m = mom_;
    // Unknowns in the order uu, uw, ww, u, w, 1.
    Eigen::Matrix<double, 6, 6> ata;
    ata << m[U4], m[U3W], m[U2W2], m[U3], m[U2W], m[UU],  //
        m[U3W], m[U2W2], m[UW3], m[U2W], m[UW2], m[UW],   //
        m[U2W2], m[UW3], m[W4], m[UW2], m[W3], m[WW],     //
        m[U3], m[U2W], m[UW2], m[UU], m[UW], m[U],        //
        m[U2W], m[UW2], m[W3], m[UW], m[WW], m[W],        //
        m[UU], m[UW], m[WW], m[U], m[W], static_cast<double> (count);
    Eigen::Matrix<double, 6, 1> ath;
    ath << m[HUU], m[HUW], m[HWW], m[HU], m[HW], m[H];
    const Eigen::Matrix<double, 6, 1> c = ata.ldlt ().solve (ath);
    if (!c.allFinite ())
      return std::numeric_limits<double>::quiet_NaN ();
    return std::max (0.0, m[HH] - c.dot (ath)) / (count - 6);
  }

private:
  enum { U, W, UU, UW, WW, U3, U2W, UW2, W3, U4, U3W, U2W2, UW3, W4, HUU, HUW, HWW, HU, HW, H, HH, MOMENTS };
  Eigen::Vector3d nz_, e1_, e2_;
  double scale_;
  double mom_[MOMENTS] = {};
};

// Residual growth from a rung (p: its normal's error, point count and residual) to the
// next: detail or another sheet came in. Read only from a well-defined rung of enough points.
bool
residualGrows (double p_error, int p_count, double p_residual, double residual)
{
  return p_error < kResidualError && p_count >= kResidualMinCount &&
         residual > p_residual * (1.0 + kResidualZ * std::sqrt (2.0 / (p_count - 6)));
}

// Least-squares height field (coefficients c) over the first k rows whose residual under
// the current c is at most `limit` (all of them for an infinite limit); absres gets every
// row's absolute residual under the new fit. False, with c and absres unchanged, when fewer
// than 12 rows are used or the fit fails.
bool
fitHeightField (const std::vector<Eigen::Matrix<double, 6, 1>>& rows, const std::vector<double>& heights, int k,
                double limit, Eigen::Matrix<double, 6, 1>& c, std::vector<double>& absres)
{
  Eigen::Matrix<double, 6, 6> ata = Eigen::Matrix<double, 6, 6>::Zero ();
  Eigen::Matrix<double, 6, 1> ath = Eigen::Matrix<double, 6, 1>::Zero ();
  int used = 0;
  for (int i = 0; i < k; ++i)
    if (std::isinf (limit) || absres[i] <= limit)
    {
      ata.noalias () += rows[i] * rows[i].transpose ();
      ath += rows[i] * heights[i];
      ++used;
    }
  if (used < 12)
    return false;
  const Eigen::Matrix<double, 6, 1> fit = ata.ldlt ().solve (ath);
  if (!fit.allFinite ())
    return false;
  c = fit;
  absres.resize (k);
  for (int i = 0; i < k; ++i)
    absres[i] = std::abs (heights[i] - c.dot (rows[i]));
  return true;
}

// The r-th smallest of the first k values (a copy is partially sorted).
double
orderStatistic (const std::vector<double>& values, int k, int r, std::vector<double>& scratch)
{
  scratch.assign (values.begin (), values.begin () + k);
  std::nth_element (scratch.begin (), scratch.begin () + r, scratch.end ());
  return scratch[r];
}

// Sum of the h smallest squared residuals: the least-trimmed-squares objective.
double
trimmedObjective (const std::vector<double>& absres, int k, int h, std::vector<double>& scratch)
{
  scratch.assign (absres.begin (), absres.begin () + k);
  std::nth_element (scratch.begin (), scratch.begin () + (h - 1), scratch.end ());
  double sum = 0;
  for (int i = 0; i < h; ++i)
    sum += scratch[i] * scratch[i];
  return sum;
}

// Least trimmed squares over h of k rows by concentration steps (refit on the h rows of
// smallest residual; Rousseeuw and Van Driessen 2006, FAST-LTS) from two starts: the
// least-squares fit (c, absres on entry) and the plane through row 0 (the sample itself)
// parallel to the support's plane. Returns the lower trimmed objective, with its fit in
// lts and its residuals in lts_res; infinity when neither start can be concentrated.
double
trimmedHeightField (const std::vector<Eigen::Matrix<double, 6, 1>>& rows, const std::vector<double>& heights, int k,
                    int h, const Eigen::Matrix<double, 6, 1>& c, const std::vector<double>& absres,
                    Eigen::Matrix<double, 6, 1>& lts, std::vector<double>& lts_res)
{
  thread_local std::vector<double> scratch, res;
  double best = std::numeric_limits<double>::infinity ();
  for (int start = 0; start < 2; ++start)
  {
    Eigen::Matrix<double, 6, 1> fit = c;
    res = absres;
    if (start == 1)
      for (int i = 0; i < k; ++i)
        res[i] = std::abs (heights[i] - heights[0]);
    bool ok = true;
    for (int step = 0; step < 2 && ok; ++step)
      ok = fitHeightField (rows, heights, k, orderStatistic (res, k, h - 1, scratch), fit, res);
    const double objective = ok ? trimmedObjective (res, k, h, scratch) : best;
    if (objective < best)
    {
      best = objective;
      lts = fit;
      lts_res = res;
    }
  }
  return best;
}

// Noise of k rows from a fit (c, absres): refitted without rows beyond 3 robust sigmas
// (1.4826 × the median absolute residual over all rows), σ from the median absolute
// residual of the rows the refit kept (corrected for 6 unknowns); without enough of them,
// from the fit as given.
double
refittedNoise (const std::vector<Eigen::Matrix<double, 6, 1>>& rows, const std::vector<double>& heights, int k,
               Eigen::Matrix<double, 6, 1> c, std::vector<double> absres)
{
  thread_local std::vector<double> scratch;
  const double limit = 3.0 * 1.4826 * orderStatistic (absres, k, k / 2, scratch);
  const std::vector<double> start_res = absres;
  double mad = 0;
  int used = k;
  if (fitHeightField (rows, heights, k, limit, c, absres))
  {
    scratch.clear ();
    for (int i = 0; i < k; ++i)
      if (start_res[i] <= limit)
        scratch.push_back (absres[i]);
    used = static_cast<int> (scratch.size ());
    std::nth_element (scratch.begin (), scratch.begin () + used / 2, scratch.end ());
    mad = scratch[used / 2];
  }
  else
    mad = orderStatistic (absres, k, k / 2, scratch);
  return 1.4826 * mad * std::sqrt (static_cast<double> (used) / (used - 6));
}

// Robust noise σ of a support's k rows: a least-squares height field refitted without
// outliers (refittedNoise). Where a second surface holds a large minority of the rows (the
// other sheet across a thin plate a few spacings thick), the least-squares fit splits the
// difference, its median residual reads the gap as noise and the limit keeps both sheets.
// So where that σ is not below `accept` (the support would be refused), the refit starts
// from least trimmed squares over h = (k + 7) / 2 rows instead, if that fits its rows more
// than 3× better in scale (a noisy single sheet stays far from that ratio). False when the
// least-squares fit fails.
bool
supportNoise (const std::vector<Eigen::Matrix<double, 6, 1>>& rows, const std::vector<double>& heights, int k,
              double accept, double& sigma)
{
  thread_local std::vector<double> scratch, absres, lts_res;
  Eigen::Matrix<double, 6, 1> c;
  if (!fitHeightField (rows, heights, k, std::numeric_limits<double>::infinity (), c, absres))
    return false;
  sigma = refittedNoise (rows, heights, k, c, absres);
  if (sigma < accept)
    return true;
  const int h = (k + 7) / 2;
  Eigen::Matrix<double, 6, 1> lts = c;
  lts_res = absres;
  if (trimmedHeightField (rows, heights, k, h, c, absres, lts, lts_res) < trimmedObjective (absres, k, h, scratch) / 9)
    sigma = refittedNoise (rows, heights, k, lts, lts_res);
  return true;
}

}  // namespace

double
shiftedSums (const Eigen::Vector3f& x, const std::uint64_t* keys, int count, const std::vector<Eigen::Vector3f>& positions,
             double* s)
{
  double radius2 = 0;
  for (int i = 0; i < count; ++i)
  {
    const Eigen::Vector3f& p = positions[slotOfKey (keys[i])];
    const double dx = static_cast<double> (p.x ()) - x.x (), dy = static_cast<double> (p.y ()) - x.y (),
                 dz = static_cast<double> (p.z ()) - x.z ();
    s[0] += dx;
    s[1] += dy;
    s[2] += dz;
    s[3] += dx * dx;
    s[4] += dx * dy;
    s[5] += dx * dz;
    s[6] += dy * dy;
    s[7] += dy * dz;
    s[8] += dz * dz;
    radius2 = std::max (radius2, dx * dx + dy * dy + dz * dz);
  }
  return radius2;
}

bool
keepsLargerRung (const Eigen::Vector3f& x, std::uint64_t* keys, const std::vector<Eigen::Vector3f>& positions, int k1,
                 int k, double noise2, double tau, ScaleChoice& out)
{
  out = ScaleChoice ();
  if (k1 < 3 || k1 >= k)
    return false;
  // Sums of the 3 + 6 distinct moments by hand (a full 3 × 3 rank update per point made
  // the check a sixth of the noisy path's time).
  auto accumulate = [&] (int count, double* acc, double& radius2) {
    radius2 = std::max (radius2, shiftedSums (x, keys, count, positions, acc));
  };
  auto fit = [&] (const double* a, int count, Eigen::Vector3d& mean, Eigen::Vector3d& normal, Eigen::Vector3d& lambda) {
    Eigen::Vector3d s1;
    Eigen::Matrix3d s2;
    s1 << a[0], a[1], a[2];
    s2 << a[3], a[4], a[5], a[4], a[6], a[7], a[5], a[7], a[8];
    return fitSums (s1, s2, count, mean, normal, lambda);
  };
  double acc[9] = {}, radius2 = 0;
  accumulate (k, acc, radius2);
  Eigen::Vector3d mean, normal, lambda;
  out.ok = fit (acc, k, mean, normal, lambda);
  if (!out.ok)
    return false;
  out.normal = normal.cast<float> ();
  out.curvature = static_cast<float> (lambda (0) / lambda.sum ());
  out.support = k;
  if (oneSided (mean, normal, std::sqrt (radius2), noise2))
    return false;
  const double err = normalStdError (lambda, k, noise2);
  // The smaller rung's error predicted from this one's spread (on a surface the in-plane
  // spread grows with the count): far above the comparison limit, it constrains nothing and
  // is not fitted (nor selected): under heavy noise, most members.
  Eigen::Vector3d predicted = lambda;
  predicted.tail<2> () *= static_cast<double> (k1) / k;
  if (!(normalStdError (predicted, k1, noise2) < 2.0 * kCompareError))
    return true;
  std::nth_element (keys, keys + (k1 - 1), keys + k);
  double acc_a[9] = {}, radius2_a = 0;
  accumulate (k1, acc_a, radius2_a);
  Eigen::Vector3d mean_a, normal_a, lambda_a;
  if (!fit (acc_a, k1, mean_a, normal_a, lambda_a))
    return true;  // the smaller support spans no plane: nothing to compare (as in selectScale)
  const double err_a = normalStdError (lambda_a, k1, noise2);
  if (!agrees (normal_a, err_a, normal, err, tau))
    return false;
  if (!(err_a < kResidualError && k1 >= kResidualMinCount))
    return true;
  // selectScale's pass 2 over the two rungs, in the larger one's frame.
  QuadricMoments moments (normal, std::sqrt (lambda (1) + lambda (2)));
  double residual_a = 0;
  for (int i = 0; i < k; ++i)
  {
    moments.add ((positions[slotOfKey (keys[i])] - x).cast<double> ());
    if (i + 1 == k1)
      residual_a = moments.residual (k1);
  }
  return !residualGrows (err_a, k1, residual_a, moments.residual (k));
}

bool
sampleNoise (const std::vector<Eigen::Vector3f>& sorted, double& residual2, double& spacing2)
{
  const int n = static_cast<int> (sorted.size ());
  if (n < 50)
    return false;
  const Eigen::Vector3f& x = sorted[0];
  spacing2 = M_PI * (sorted[49] - x).squaredNorm () / 50.0;
  bool any = false;
  for (int k : {24, 50, 100, 200})
  {
    if (k > n)
      break;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero ();
    for (int i = 0; i < k; ++i)
      mean += (sorted[i] - x).cast<double> ();
    mean /= k;
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero ();
    for (int i = 0; i < k; ++i)
    {
      const Eigen::Vector3d d = (sorted[i] - x).cast<double> () - mean;
      cov.noalias () += d * d.transpose ();
    }
    cov /= k;
    Eigen::Matrix3d v;
    Eigen::Vector3d l;
    eigenAscending (cov, v, l);
    if (!(l (2) > 0) || l (1) <= 1e-12 * l (2))
      return any;
    // Height field h = c0 x² + c1 xy + c2 y² + c3 x + c4 y + c5 over the PCA plane, in
    // coordinates scaled by the largest spread (normal equations: 6 × 6), fitted robustly
    // (supportNoise): a few points of another sheet, or up to half the support across a
    // thin plate, must not read as noise. σ from the median absolute residual.
    const double scale = std::sqrt (l (2));
    thread_local std::vector<Eigen::Matrix<double, 6, 1>> rows;
    thread_local std::vector<double> heights;
    rows.resize (k);
    heights.resize (k);
    for (int i = 0; i < k; ++i)
    {
      const Eigen::Vector3d d = (sorted[i] - x).cast<double> () - mean;
      const double u = d.dot (v.col (2)) / scale, w = d.dot (v.col (1)) / scale;
      rows[i] << u * u, u * w, w * w, u, w, 1.0;
      heights[i] = d.dot (v.col (0));
    }
    double sigma = 0;
    if (!supportNoise (rows, heights, k, std::sqrt (l (1) / 9.0), sigma))
      return any;
    residual2 = sigma * sigma;
    any = true;
    if (l (1) > 9.0 * residual2)
      break;
  }
  return any;
}

NoiseEstimate
combineNoiseSamples (std::vector<double> residual2, std::vector<double> spacing2)
{
  NoiseEstimate e;
  e.samples = static_cast<int> (residual2.size ());
  auto median = [] (std::vector<double>& v) {
    if (v.empty ())
      return 0.0;
    std::nth_element (v.begin (), v.begin () + v.size () / 2, v.end ());
    return v[v.size () / 2];
  };
  e.sigma = std::sqrt (median (residual2));
  e.spacing = std::sqrt (median (spacing2));
  return e;
}

std::vector<int>
ladderRungs (int first, int max_k)
{
  static const int series[] = {12, 18, 30, 50, 100, 200};
  std::vector<int> rungs;
  const int start = std::max (3, std::min (first, 12));
  if (start < 12)
    rungs.push_back (start);
  for (int k : series)
    if (k <= max_k)
      rungs.push_back (k);
  for (int k = 400; k <= max_k; k *= 2)
    rungs.push_back (k);
  if (rungs.empty () || rungs.back () != max_k)
    rungs.push_back (std::max (3, max_k));
  return rungs;
}

ScaleChoice
selectScale (const Eigen::Vector3f& x, const std::vector<Eigen::Vector3f>& sorted, const std::vector<int>& rungs,
             double noise2, double tau)
{
  ScaleChoice out;
  const int n = static_cast<int> (sorted.size ());
  struct Rung
  {
    Eigen::Vector3d normal, lambda;  // λ ascending
    int count;
    double error;     // standard error of the normal (radians) under the cloud's noise
    double residual;  // quadric residual variance (below)
    bool agrees;      // with every smaller, well-defined rung
  };
  Rung fitted[24];
  int m = 0;
  // Pass 1: the PCA plane of each rung (prefix sums), growing from the smallest until a
  // rung is one-sided, and whether each agrees with the smaller ones.
  int last = -1;
  bool refused = false, refused_any = false;
  {
    Eigen::Vector3d s1 = Eigen::Vector3d::Zero ();
    Eigen::Matrix3d s2 = Eigen::Matrix3d::Zero ();
    std::size_t r = 0;
    for (int i = 0; i < n && r < rungs.size () && m < 24; ++i)
    {
      const Eigen::Vector3d d = (sorted[i] - x).cast<double> ();
      s1 += d;
      s2.noalias () += d * d.transpose ();
      const int count = i + 1;
      if (count != rungs[r] && count != n)
        continue;
      ++r;
      Eigen::Vector3d mean, normal, l;
      if (!fitSums (s1, s2, count, mean, normal, l))
        continue;  // no plane yet (collinear or coincident): try a larger support
      const int j = m++;
      Rung& q = fitted[j];
      q.normal = normal;
      q.lambda = l;
      q.count = count;
      q.error = normalStdError (l, count, noise2);
      q.residual = std::numeric_limits<double>::quiet_NaN ();
      q.agrees = true;
      if (j > 0)
      {
        // One-sided: a rim or a border; more points bring another sheet, not less noise.
        // (x itself is off the surface by the noise: that much offset says nothing.)
        refused = oneSided (mean, q.normal, d.norm (), noise2);
        if (refused)
        {
          --m;
          break;
        }
        // Agreement with every smaller, well-defined rung. Prefixes are nested, so the two
        // normals share their errors: the difference has variance err_a² − err_q² (the
        // larger support is the more efficient estimate), not (err_a + err_q)², which lets
        // slowly growing bias through.
        for (int a = 0; a < j && q.agrees; ++a)
          q.agrees = agrees (fitted[a].normal, fitted[a].error, q.normal, q.error, tau);
      }
      // Lepski: the largest rung that agrees with all smaller ones, whether or not the
      // rungs between do (a chance disagreement of a small rung does not cap the support).
      if (q.agrees)
        last = j;
      else
        refused_any = true;
    }
  }
  if (last < 0)
    return out;
  out.exhausted = !refused && !refused_any;
  // Pass 2, only where it can still stop the growth (a well-defined rung of >= 30 points
  // below the choice): detail. The residual of a quadric height field (6 unknowns) over
  // each rung, in the frame of the largest rung's plane, from prefix sums of its normal
  // equations, must not grow past its sampling error (relative √(2/dof)). A quadric takes
  // the curvature, which does not bias a PCA normal over a support centred on x (on a
  // sphere the support must keep growing); what it leaves is detail or another sheet.
  bool readable = false;
  for (int j = 0; j < last && !readable; ++j)
    readable = fitted[j].error < kResidualError && fitted[j].count >= kResidualMinCount;
  if (readable)
  {
    QuadricMoments moments (fitted[m - 1].normal,
                            std::sqrt (fitted[m - 1].lambda (1) + fitted[m - 1].lambda (2)));
    int q = 0;
    for (int i = 0; i < n && q <= last; ++i)
    {
      moments.add ((sorted[i] - x).cast<double> ());
      if (i + 1 != fitted[q].count)
        continue;
      Rung& r = fitted[q];
      if (r.count >= kResidualMinCount)
        r.residual = moments.residual (r.count);
      if (q > 0 && residualGrows (fitted[q - 1].error, fitted[q - 1].count, fitted[q - 1].residual, r.residual))
      {
        // The largest agreeing rung below the growth.
        last = 0;
        for (int a = q - 1; a > 0 && last == 0; --a)
          if (fitted[a].agrees)
            last = a;
        out.exhausted = false;
        break;
      }
      ++q;
    }
  }
  const Rung& q = fitted[last];
  out.normal = q.normal.cast<float> ();
  out.curvature = static_cast<float> (q.lambda (0) / q.lambda.sum ());
  out.support = q.count;
  out.ok = true;
  return out;
}

}  // namespace detail
}  // namespace normals
}  // namespace pclx
