#pragma once
// Ray casting against a triangle mesh with Embree: ground-truth visibility and depth.
#include <pclx/testing/triangle_mesh.h>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <memory>

namespace pclx {
namespace testing {

class RayCaster
{
public:
  explicit RayCaster (const TriangleMesh& mesh);
  ~RayCaster ();
  RayCaster (const RayCaster&) = delete;
  RayCaster& operator= (const RayCaster&) = delete;

  // Distance along `dir` (in units of |dir|) to the first hit, or +inf; face id in *face.
  float cast (const Eigen::Vector3f& origin, const Eigen::Vector3f& dir, int* face = nullptr) const;
  // Unit normal of a face of the mesh (as in TriangleMesh::faceNormal).
  const Eigen::Vector3f& faceNormal (int face) const;

  // True where the segment viewpoint → point is not blocked by the mesh, ignoring
  // hits within tol · (mesh diagonal) before the point (its own face). Points must
  // lie on the mesh: compute ground truth on clean samples, before adding noise.
  // The precision does not depend on the viewpoint's distance (the segment is cast back
  // from within two diagonals of the point, p - C in double).
  template <typename PointT> std::vector<bool>
  visibleFrom (const pcl::PointCloud<PointT>& cloud, const Eigen::Vector3f& viewpoint,
               float tol = 1e-4f) const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  bool occluded (const Eigen::Vector3f& viewpoint, const Eigen::Vector3f& p, float abs_tol) const;
};

}  // namespace testing
}  // namespace pclx
