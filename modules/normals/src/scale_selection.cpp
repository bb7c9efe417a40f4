#include <pclx/normals/scale_selection.h>

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
    double count;
  };
  Rung fitted[24];
  int m = 0;
  Eigen::Vector3d s1 = Eigen::Vector3d::Zero ();
  Eigen::Matrix3d s2 = Eigen::Matrix3d::Zero ();
  std::size_t r = 0;
  // Standard error (radians) of rung q's normal under noise variance l3: the eigenvector
  // perturbation formula; infinite when the in-plane spread is no larger than the noise.
  auto stderror = [&] (const Rung& q, double l3) {
    const double e1 = q.lambda (2) - l3, e2 = q.lambda (1) - l3;
    if (!(e2 > 1e-9 * q.lambda (2)))
      return M_PI;
    return std::min (M_PI, std::sqrt ((q.lambda (2) * l3 / (e1 * e1) + q.lambda (1) * l3 / (e2 * e2)) / q.count));
  };
  int best = -1;
  out.exhausted = true;
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
    Eigen::Matrix3d v;
    Eigen::Vector3d l;
    eigenAscending (s2 / count - mean * mean.transpose (), v, l);
    if (!(l (2) > 0) || l (1) <= 1e-12 * l (2))
      continue;  // no plane yet (collinear or coincident): try a larger support
    Rung& q = fitted[m];
    q.normal = v.col (0);
    q.lambda = l;
    q.count = count;
    if (best >= 0)
    {
      // One-sided: a rim or a border; more points bring another sheet, not less noise.
      // (x itself is off the surface by the noise: that much offset says nothing.)
      if ((mean - mean.dot (q.normal) * q.normal).norm () > 0.3 * d.norm () + 3.0 * std::sqrt (noise2))
      {
        out.exhausted = false;
        break;
      }
      bool agrees = true;
      for (int a = 0; a < m && agrees; ++a)
      {
        const double angle = std::acos (std::min (1.0, std::abs (fitted[a].normal.dot (q.normal))));
        agrees = angle <= tau * (stderror (fitted[a], noise2) + stderror (q, noise2)) + 1e-3;
      }
      if (!agrees)
      {
        out.exhausted = false;
        break;
      }
    }
    ++m;
    best = m - 1;
    out.normal = q.normal.cast<float> ();
    out.curvature = static_cast<float> (l (0) / l.sum ());
    out.support = count;
    out.ok = true;
  }
  return out;
}

}  // namespace normals
}  // namespace pclx
