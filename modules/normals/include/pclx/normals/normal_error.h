#pragma once
#include <pcl/console/print.h>
#include <pcl/point_cloud.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace pcl {

/** \brief Angle error statistics between estimated and ground-truth normals.
  *
  * The statistics of Musmanno's evaluation (min / max / mean angle) plus the RMS and the
  * shares of errors under 5° and 10°. The unoriented error is acos |a·b| (use it when the
  * truth is unoriented); the oriented error also reports the share of normals pointing
  * against the truth.
  *
  * \note R. M. Musmanno, 2016, "Estimação de Normais em Nuvens de Pontos para Reconstrução
  * de Superfícies 3D com Funções de Base Radial", MSc dissertation, UFF, §6.2.1.
  * \ingroup normals
  */
struct NormalErrorStats
{
  std::size_t count = 0;    ///< Compared pairs (those with a finite ground truth).
  std::size_t invalid = 0;  ///< Estimates that are not finite or zero; counted as a 90° error.
  double rms_deg = 0;       ///< Root mean square of the errors, in degrees.
  double mean_deg = 0;      ///< Mean error, in degrees.
  double min_deg = 0;       ///< Smallest error, in degrees.
  double max_deg = 0;       ///< Largest error, in degrees.
  double below5 = 0;        ///< Share of errors below 5°.
  double below10 = 0;       ///< Share of errors below 10°.
  double flipped = 0;       ///< Share with a·b < 0 (meaningful for an oriented truth only).
};

/** \brief Per-point angle errors between estimated and ground-truth normals.
  * \param[in] estimate the estimated normals
  * \param[in] truth the ground-truth normals, one per estimate
  * \param[in] oriented false: acos |a·b| (sign ignored); true: acos (a·b)
  * \return the error of every pair in degrees, NaN where the truth is not finite or zero and
  * 90 where the estimate is; empty, with PCL_ERROR, when the clouds differ in size
  * \ingroup normals
  */
template <typename NA, typename NB> std::vector<double>
angleErrorsDeg (const pcl::PointCloud<NA>& estimate, const pcl::PointCloud<NB>& truth, bool oriented = false)
{
  if (estimate.size () != truth.size ())
  {
    PCL_ERROR ("[pcl::angleErrorsDeg] %zu estimated normals but %zu ground-truth normals\n", estimate.size (),
               truth.size ());
    return {};
  }
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

/** \brief Error statistics of estimated normals against the ground truth.
  * \param[in] estimate the estimated normals
  * \param[in] truth the ground-truth normals, one per estimate
  * \param[in] oriented false: unoriented errors; true: oriented errors (see angleErrorsDeg ())
  * \return the statistics over the pairs with a finite truth; all zero when there is none, or
  * (with PCL_ERROR) when the clouds differ in size
  * \ingroup normals
  */
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

}  // namespace pcl
