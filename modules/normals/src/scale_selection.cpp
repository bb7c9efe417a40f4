#include <pclx/normals/scale_selection.h>
#include <pclx/normals/plane_pca.h>

#include <pcl/common/eigen.h>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>

namespace pclx {
namespace normals {

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
// freedom make √(2/dof) a poor guide; on the wide set's noisy clouds reading from 30 was
// as good as from 12, or up to 0.05° better).
constexpr int kResidualMinCount = 30;

}  // namespace

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
    // coordinates scaled by the largest spread (normal equations: 6 × 6), fitted twice:
    // the second time without points beyond 3 robust sigmas (a few points of another
    // sheet, e.g. across a thin plate, must not read as noise). σ from the median
    // absolute residual.
    const double scale = std::sqrt (l (2));
    thread_local std::vector<Eigen::Matrix<double, 6, 1>> rows;
    thread_local std::vector<double> heights, absres;
    rows.resize (k);
    heights.resize (k);
    for (int i = 0; i < k; ++i)
    {
      const Eigen::Vector3d d = (sorted[i] - x).cast<double> () - mean;
      const double u = d.dot (v.col (2)) / scale, w = d.dot (v.col (1)) / scale;
      rows[i] << u * u, u * w, w * w, u, w, 1.0;
      heights[i] = d.dot (v.col (0));
    }
    double limit = std::numeric_limits<double>::infinity (), mad = 0;
    Eigen::Matrix<double, 6, 1> c = Eigen::Matrix<double, 6, 1>::Zero ();
    for (int pass = 0; pass < 2; ++pass)
    {
      Eigen::Matrix<double, 6, 6> ata = Eigen::Matrix<double, 6, 6>::Zero ();
      Eigen::Matrix<double, 6, 1> ath = Eigen::Matrix<double, 6, 1>::Zero ();
      int used = 0;
      for (int i = 0; i < k; ++i)
        if (pass == 0 || std::abs (heights[i] - c.dot (rows[i])) <= limit)
        {
          ata.noalias () += rows[i] * rows[i].transpose ();
          ath += rows[i] * heights[i];
          ++used;
        }
      if (used < 12)
        break;
      c = ata.ldlt ().solve (ath);
      if (!c.allFinite ())
        return any;
      absres.resize (k);
      for (int i = 0; i < k; ++i)
        absres[i] = std::abs (heights[i] - c.dot (rows[i]));
      std::nth_element (absres.begin (), absres.begin () + k / 2, absres.end ());
      mad = absres[k / 2];
      limit = 3.0 * 1.4826 * mad;
    }
    const double sigma = 1.4826 * mad * std::sqrt (static_cast<double> (k) / (k - 6));
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
  // Standard error (radians) of rung q's normal under noise variance l3: the eigenvector
  // perturbation formula; π when the in-plane spread is no larger than the noise.
  auto stderror = [&] (const Rung& q, double l3) {
    const double e1 = q.lambda (2) - l3, e2 = q.lambda (1) - l3;
    if (!(e2 > 1e-9 * q.lambda (2)))
      return M_PI;
    return std::min (M_PI, std::sqrt ((q.lambda (2) * l3 / (e1 * e1) + q.lambda (1) * l3 / (e2 * e2)) / q.count));
  };
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
      if (count < 3)
        continue;
      const Eigen::Vector3d mean = s1 / count;
      // Only the normal is read here: one eigenvector, not eigen33's three.
      const PlanePca p = planePca (s2 / count - mean * mean.transpose ());
      const Eigen::Vector3d l = p.lambda.reverse ();  // ascending
      if (!(l (2) > 0) || l (1) <= 1e-12 * l (2))
        continue;  // no plane yet (collinear or coincident): try a larger support
      const int j = m++;
      Rung& q = fitted[j];
      q.normal = p.normal;
      q.lambda = l;
      q.count = count;
      q.error = stderror (q, noise2);
      q.residual = std::numeric_limits<double>::quiet_NaN ();
      q.agrees = true;
      if (j > 0)
      {
        // One-sided: a rim or a border; more points bring another sheet, not less noise.
        // (x itself is off the surface by the noise: that much offset says nothing.)
        refused = (mean - mean.dot (q.normal) * q.normal).norm () > 0.3 * d.norm () + 3.0 * std::sqrt (noise2);
        if (refused)
        {
          --m;
          break;
        }
        // Agreement with every smaller, well-defined rung. Prefixes are nested, so the two
        // normals share their errors: the difference has variance err_a² − err_q² (the
        // larger support is the more efficient estimate), not (err_a + err_q)², which let
        // slowly growing bias through (bunny σ = 0.0012: 200 taken where 50 was best).
        for (int a = 0; a < j && q.agrees; ++a)
        {
          if (!(fitted[a].error < kCompareError))
            continue;  // noise-dominated: its normal says nothing about the bias of q
          const double angle = std::acos (std::min (1.0, std::abs (fitted[a].normal.dot (q.normal))));
          const double spread =
              std::sqrt (std::max (0.0, fitted[a].error * fitted[a].error - q.error * q.error));
          q.agrees = angle <= tau * spread + 1e-3;
        }
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
    const Eigen::Vector3d nz = fitted[m - 1].normal;
    const Eigen::Vector3d e1 = nz.unitOrthogonal (), e2 = nz.cross (e1);
    const double scale = std::sqrt (fitted[m - 1].lambda (1) + fitted[m - 1].lambda (2));
    // Moments of the monomials up to degree 4 (the normal equations' entries), summed by
    // hand: Eigen's rank update of the 6 × 6 matrix was 3/4 of the selection's time.
    enum { U, W, UU, UW, WW, U3, U2W, UW2, W3, U4, U3W, U2W2, UW3, W4, HUU, HUW, HWW, HU, HW, H, HH, MOMENTS };
    double mom[MOMENTS] = {};
    int q = 0;
    for (int i = 0; i < n && q <= last; ++i)
    {
      const Eigen::Vector3d d = (sorted[i] - x).cast<double> ();
      const double u = d.dot (e1) / scale, w = d.dot (e2) / scale, h = d.dot (nz);
      const double uu = u * u, uw = u * w, ww = w * w;
      mom[U] += u;
      mom[W] += w;
      mom[UU] += uu;
      mom[UW] += uw;
      mom[WW] += ww;
      mom[U3] += uu * u;
      mom[U2W] += uu * w;
      mom[UW2] += u * ww;
      mom[W3] += ww * w;
      mom[U4] += uu * uu;
      mom[U3W] += uu * uw;
      mom[U2W2] += uu * ww;
      mom[UW3] += uw * ww;
      mom[W4] += ww * ww;
      mom[HUU] += h * uu;
      mom[HUW] += h * uw;
      mom[HWW] += h * ww;
      mom[HU] += h * u;
      mom[HW] += h * w;
      mom[H] += h;
      mom[HH] += h * h;
      if (i + 1 != fitted[q].count)
        continue;
      Rung& r = fitted[q];
      if (r.count >= kResidualMinCount)
      {
        // Unknowns in the order uu, uw, ww, u, w, 1.
        Eigen::Matrix<double, 6, 6> ata;
        ata << mom[U4], mom[U3W], mom[U2W2], mom[U3], mom[U2W], mom[UU],  //
            mom[U3W], mom[U2W2], mom[UW3], mom[U2W], mom[UW2], mom[UW],   //
            mom[U2W2], mom[UW3], mom[W4], mom[UW2], mom[W3], mom[WW],     //
            mom[U3], mom[U2W], mom[UW2], mom[UU], mom[UW], mom[U],        //
            mom[U2W], mom[UW2], mom[W3], mom[UW], mom[WW], mom[W],        //
            mom[UU], mom[UW], mom[WW], mom[U], mom[W], static_cast<double> (r.count);
        Eigen::Matrix<double, 6, 1> ath;
        ath << mom[HUU], mom[HUW], mom[HWW], mom[HU], mom[HW], mom[H];
        const Eigen::Matrix<double, 6, 1> c = ata.ldlt ().solve (ath);
        if (c.allFinite ())
          r.residual = std::max (0.0, mom[HH] - c.dot (ath)) / (r.count - 6);
      }
      if (q > 0)
      {
        const Rung& p = fitted[q - 1];
        if (p.error < kResidualError && p.count >= kResidualMinCount &&
            r.residual > p.residual * (1.0 + kResidualZ * std::sqrt (2.0 / (p.count - 6))))
        {
          // The largest agreeing rung below the growth.
          last = 0;
          for (int a = q - 1; a > 0 && last == 0; --a)
            if (fitted[a].agrees)
              last = a;
          out.exhausted = false;
          break;
        }
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

}  // namespace normals
}  // namespace pclx
