#include "cgal_peer.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/jet_estimate_normals.h>
#include <CGAL/property_map.h>
#include <CGAL/vcm_estimate_normals.h>

#ifdef CGAL_LINKED_WITH_TBB
#include <tbb/global_control.h>
#endif

#include <array>
#include <chrono>
#include <memory>
#include <utility>

namespace cgal_peer {

namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using PointVector = std::pair<Kernel::Point_3, Kernel::Vector_3>;

std::vector<PointVector>
toCgal (const std::vector<Eigen::Vector3f>& points)
{
  std::vector<PointVector> pv (points.size ());
  for (std::size_t i = 0; i < points.size (); ++i)
    pv[i].first = Kernel::Point_3 (points[i].x (), points[i].y (), points[i].z ());
  return pv;
}

void
fromCgal (const std::vector<PointVector>& pv, std::vector<Eigen::Vector3f>& normals)
{
  normals.resize (pv.size ());
  for (std::size_t i = 0; i < pv.size (); ++i)
  {
    const auto& n = pv[i].second;
    normals[i] = Eigen::Vector3f (float (n.x ()), float (n.y ()), float (n.z ()));
  }
}

double
since (std::chrono::steady_clock::time_point t0)
{
  return std::chrono::duration<double> (std::chrono::steady_clock::now () - t0).count ();
}

auto
pairMaps ()
{
  return CGAL::parameters::point_map (CGAL::First_of_pair_property_map<PointVector> ())
      .normal_map (CGAL::Second_of_pair_property_map<PointVector> ());
}

}  // namespace

std::string
jetConcurrency ()
{
#ifdef CGAL_LINKED_WITH_TBB
  return "parallel (TBB)";
#else
  return "sequential";
#endif
}

double
jetNormals (const std::vector<Eigen::Vector3f>& points, int k, int threads, std::vector<Eigen::Vector3f>& normals)
{
  std::vector<PointVector> pv = toCgal (points);
#ifdef CGAL_LINKED_WITH_TBB
  tbb::global_control limit (tbb::global_control::max_allowed_parallelism, std::max (1, threads));
  const auto t0 = std::chrono::steady_clock::now ();
  CGAL::jet_estimate_normals<CGAL::Parallel_tag> (pv, unsigned (k), pairMaps ());
#else
  (void) threads;
  const auto t0 = std::chrono::steady_clock::now ();
  CGAL::jet_estimate_normals<CGAL::Sequential_tag> (pv, unsigned (k), pairMaps ());
#endif
  const double s = since (t0);
  fromCgal (pv, normals);
  return s;
}

void
vcmNormalsSweep (const std::vector<Eigen::Vector3f>& points, double offset_radius,
                 const std::vector<double>& convolution_radii, std::vector<std::vector<Eigen::Vector3f>>& normals,
                 std::vector<double>& seconds)
{
  using Covariance = std::array<double, 6>;
  using Diagonalize = CGAL::Default_diagonalize_traits<double, 3>;
  std::vector<Kernel::Point_3> pts (points.size ());
  for (std::size_t i = 0; i < points.size (); ++i)
    pts[i] = Kernel::Point_3 (points[i].x (), points[i].y (), points[i].z ());
  const CGAL::Identity_property_map<Kernel::Point_3> point_map;
  std::vector<Covariance> cov, ccov;
  const auto t0 = std::chrono::steady_clock::now ();
  // 20 planes discretize the sphere, as in vcm_estimate_normals.
  CGAL::internal::vcm_offset (pts.begin (), pts.end (), point_map, cov, offset_radius, 20, Kernel ());
  const double t_offset = since (t0);
  normals.assign (convolution_radii.size (), {});
  seconds.assign (convolution_radii.size (), 0);
  for (std::size_t r = 0; r < convolution_radii.size (); ++r)
  {
    const auto t1 = std::chrono::steady_clock::now ();
    const std::vector<Covariance>* use = &cov;
    if (convolution_radii[r] > 0)
    {
      CGAL::internal::vcm_convolve (pts.begin (), pts.end (), point_map, cov, ccov, convolution_radii[r], Kernel ());
      use = &ccov;
    }
    auto& out = normals[r];
    out.resize (pts.size ());
    for (std::size_t i = 0; i < pts.size (); ++i)
    {
      std::array<double, 3> n = {{0, 0, 0}};
      Diagonalize::extract_largest_eigenvector_of_covariance_matrix ((*use)[i], n);
      out[i] = Eigen::Vector3f (float (n[0]), float (n[1]), float (n[2]));
    }
    seconds[r] = t_offset + since (t1);
  }
}

}  // namespace cgal_peer
