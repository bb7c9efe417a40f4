#include "bench_rbf_open3d.h"

#include <open3d/geometry/KDTreeSearchParam.h>
#include <open3d/geometry/PointCloud.h>
#include <open3d/geometry/TriangleMesh.h>
#include <open3d/utility/Logging.h>

#include <chrono>

namespace rbf_open3d {

std::vector<Eigen::Vector3d>
estimateNormals (const std::vector<Eigen::Vector3d>& points, int k, double& seconds)
{
  open3d::utility::SetVerbosityLevel (open3d::utility::VerbosityLevel::Error);
  open3d::geometry::PointCloud pc (points);
  const auto t0 = std::chrono::steady_clock::now ();
  pc.EstimateNormals (open3d::geometry::KDTreeSearchParamKNN (k));
  pc.OrientNormalsConsistentTangentPlane (std::size_t (k));
  seconds = std::chrono::duration<double> (std::chrono::steady_clock::now () - t0).count ();
  return pc.normals_;
}

Result
poisson (const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& normals, int depth,
         int threads)
{
  open3d::utility::SetVerbosityLevel (open3d::utility::VerbosityLevel::Error);
  open3d::geometry::PointCloud pc (points);
  pc.normals_ = normals;
  Result r;
  const auto t0 = std::chrono::steady_clock::now ();
  auto [mesh, density] = open3d::geometry::TriangleMesh::CreateFromPointCloudPoisson (
      pc, std::size_t (depth), 0.f, 1.1f, false, threads < 1 ? -1 : threads);
  r.seconds = std::chrono::duration<double> (std::chrono::steady_clock::now () - t0).count ();
  r.vertices.reserve (mesh->vertices_.size ());
  for (const auto& v : mesh->vertices_)
    r.vertices.push_back (v.cast<float> ());
  r.faces.assign (mesh->triangles_.begin (), mesh->triangles_.end ());
  r.density = std::move (density);
  return r;
}

}  // namespace rbf_open3d
