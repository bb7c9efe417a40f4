#pragma once
// CGAL peers of bench_normals --wide: jet fitting and the Voronoi covariance
// measure from CGAL's Point Set Processing. Kept in their own translation unit behind a
// plain interface (CGAL headers are heavy to compile).
#include <Eigen/Core>
#include <string>
#include <vector>

namespace cgal_peer {

// "parallel (TBB)" or "sequential": how jet_estimate_normals runs in this build.
std::string jetConcurrency ();

// jet_estimate_normals over k neighbours (degree-2 jet, CGAL's default), on at most
// `threads` TBB threads; unoriented normals in the input order. Returns seconds.
double jetNormals (const std::vector<Eigen::Vector3f>& points, int k, int threads,
                   std::vector<Eigen::Vector3f>& normals);

// vcm_estimate_normals (sequential in CGAL 5.5): Voronoi cells cut by a ball of `offset_radius`,
// covariances summed over `convolution_radius`.
// Over several convolution radii for one offset radius: the offset step
// (Delaunay triangulation and clipped Voronoi cells, the expensive part) runs once and each
// radius is convolved from it, exactly as vcm_estimate_normals does in one call (CGAL 5.5's
// compute_vcm = internal::vcm_offset + internal::vcm_convolve). normals[i] and seconds[i]
// belong to convolution_radii[i]; seconds[i] = offset time + that convolution's time.
void vcmNormalsSweep (const std::vector<Eigen::Vector3f>& points, double offset_radius,
                      const std::vector<double>& convolution_radii,
                      std::vector<std::vector<Eigen::Vector3f>>& normals, std::vector<double>& seconds);

}  // namespace cgal_peer
