#pragma once
// Point-to-mesh distance with CGAL's AABB tree.
#include <pclx/testing/triangle_mesh.h>

#include <memory>

namespace pclx {
namespace testing {

class MeshDistance
{
public:
  explicit MeshDistance (const TriangleMesh& mesh);
  ~MeshDistance ();
  MeshDistance (const MeshDistance&) = delete;
  MeshDistance& operator= (const MeshDistance&) = delete;

  double distance (const Eigen::Vector3f& p) const;
  Eigen::Vector3f closestPoint (const Eigen::Vector3f& p) const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace testing
}  // namespace pclx
