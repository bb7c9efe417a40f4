#pragma once
// Angle error statistics between estimated and ground-truth normals (seed 002 §6.2.1:
// min / max / mean; plus RMS and the shares under 5° and 10°). Unoriented error is
// acos|a·b| (use it when the truth is unoriented, e.g. PCPNet); oriented error also
// reports the share of normals pointing against the truth.
#include <pcl/point_cloud.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <vector>

namespace pclx {
namespace normals {

struct NormalErrorStats
{
  std::size_t count = 0;    // compared pairs (finite ground truth)
  std::size_t invalid = 0;  // estimates that are not finite or zero: counted as 90° error
  double rms_deg = 0, mean_deg = 0, min_deg = 0, max_deg = 0;
  double below5 = 0, below10 = 0;  // shares of errors < 5° and < 10°
  double flipped = 0;              // share with a·b < 0 (meaningful for oriented truth only)
};

// Per-point unoriented (or oriented) angle errors in degrees; NaN where the truth is not finite.
template <typename NA, typename NB> std::vector<double>
angleErrorsDeg (const pcl::PointCloud<NA>& estimate, const pcl::PointCloud<NB>& truth, bool oriented = false)
{
  if (estimate.size () != truth.size ())
    throw std::invalid_argument ("angleErrorsDeg: estimate and truth differ in size");
  std::vector<double> err (estimate.size ());
  for (std::size_t i = 0; i < estimate.size (); ++i)
  {
    const Eigen::Vector3d t = truth[i].getNormalVector3fMap ().template cast<double> ();
    const Eigen::Vector3d e = estimate[i].getNormalVector3fMap ().template cast<double> ();
    if (!t.allFinite () || t.norm () == 0)
    {
      err[i] = std::nan ("");
      continue;
    }
    if (!e.allFinite () || e.norm () == 0)
    {
      err[i] = 90.0;
      continue;
    }
    double c = e.dot (t) / (e.norm () * t.norm ());
    if (!oriented)
      c = std::abs (c);
    err[i] = std::acos (std::clamp (c, -1.0, 1.0)) * 180.0 / M_PI;
  }
  return err;
}

template <typename NA, typename NB> NormalErrorStats
compareNormals (const pcl::PointCloud<NA>& estimate, const pcl::PointCloud<NB>& truth, bool oriented = false)
{
  const std::vector<double> err = angleErrorsDeg (estimate, truth, oriented);
  NormalErrorStats s;
  s.min_deg = 180;
  double sum = 0, sum_sq = 0;
  for (std::size_t i = 0; i < err.size (); ++i)
  {
    if (std::isnan (err[i]))
      continue;
    const auto e = estimate[i].getNormalVector3fMap ();
    if (!e.allFinite () || e.squaredNorm () == 0)
      ++s.invalid;
    ++s.count;
    sum += err[i];
    sum_sq += err[i] * err[i];
    s.min_deg = std::min (s.min_deg, err[i]);
    s.max_deg = std::max (s.max_deg, err[i]);
    s.below5 += err[i] < 5.0;
    s.below10 += err[i] < 10.0;
    s.flipped += err[i] > 90.0;
  }
  if (s.count == 0)
    return NormalErrorStats ();
  s.mean_deg = sum / s.count;
  s.rms_deg = std::sqrt (sum_sq / s.count);
  s.below5 /= s.count;
  s.below10 /= s.count;
  s.flipped /= s.count;
  return s;
}

}  // namespace normals
}  // namespace pclx
