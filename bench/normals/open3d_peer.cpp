#include "open3d_peer.h"

#include <open3d/geometry/KDTreeSearchParam.h>
#include <open3d/geometry/PointCloud.h>

#include <chrono>

namespace open3d_peer {

namespace {
double
since (std::chrono::steady_clock::time_point t0)
{
  return std::chrono::duration<double> (std::chrono::steady_clock::now () - t0).count ();
}
}  // namespace

double
estimateNormals (const std::vector<Eigen::Vector3d>& points, int k, std::vector<Eigen::Vector3d>& normals)
{
  open3d::geometry::PointCloud pc (points);
  const auto t0 = std::chrono::steady_clock::now ();
  pc.EstimateNormals (open3d::geometry::KDTreeSearchParamKNN (k));
  const double s = since (t0);
  normals = pc.normals_;
  return s;
}

double
estimateNormalsHybrid (const std::vector<Eigen::Vector3d>& points, double radius, int max_nn,
                       std::vector<Eigen::Vector3d>& normals)
{
  open3d::geometry::PointCloud pc (points);
  const auto t0 = std::chrono::steady_clock::now ();
  pc.EstimateNormals (open3d::geometry::KDTreeSearchParamHybrid (radius, max_nn));
  const double s = since (t0);
  normals = pc.normals_;
  return s;
}

double
orientConsistent (const std::vector<Eigen::Vector3d>& points, std::vector<Eigen::Vector3d>& normals, int k)
{
  open3d::geometry::PointCloud pc (points);
  pc.normals_ = normals;
  const auto t0 = std::chrono::steady_clock::now ();
  pc.OrientNormalsConsistentTangentPlane (k);
  const double s = since (t0);
  normals = pc.normals_;
  return s;
}

}  // namespace open3d_peer
