#pragma once
// Open3D's screened Poisson (CreateFromPointCloudPoisson), in its own translation unit:
// Open3D's headers are heavy and bring their own Eigen settings (see bench/normals).
#include <Eigen/Core>
#include <vector>

namespace rbf_open3d {

struct Result
{
  std::vector<Eigen::Vector3f> vertices;
  std::vector<Eigen::Vector3i> faces;
  std::vector<double> density;  // per vertex: the octree depth of the samples around it
  double seconds = 0;           // CreateFromPointCloudPoisson only (not the copies)
};

// Open3D's normals as its users get them: EstimateNormals (k nearest) and then
// OrientNormalsConsistentTangentPlane (k); `seconds` is the time of both.
std::vector<Eigen::Vector3d> estimateNormals (const std::vector<Eigen::Vector3d>& points, int k, double& seconds);

// Oriented normals in, mesh out; threads < 1: Open3D's default.
Result poisson (const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& normals,
                int depth, int threads);

}  // namespace rbf_open3d
