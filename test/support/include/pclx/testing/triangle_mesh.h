#pragma once
// A plain indexed triangle mesh: the ground-truth surface that scenes are sampled
// from and that visibility / distance / depth ground truth is computed against.
#include <pcl/PolygonMesh.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace pclx {
namespace testing {

struct TriangleMesh
{
  std::vector<Eigen::Vector3f> vertices;
  std::vector<Eigen::Vector3i> faces;

  Eigen::Vector3f faceNormal (std::size_t f) const;  // unit, right-hand rule
  float faceArea (std::size_t f) const;
  float totalArea () const;
  Eigen::Vector3f bboxMin () const;
  Eigen::Vector3f bboxMax () const;
  float diagonal () const;  // bounding-box diagonal length
  void append (const TriangleMesh& other);
  // The quad a b c d (counter-clockwise seen from its front) as two triangles.
  void addQuad (const Eigen::Vector3f& a, const Eigen::Vector3f& b, const Eigen::Vector3f& c,
                const Eigen::Vector3f& d);
  void transform (const Eigen::Affine3f& t);
};

// Conversions through PCL's PolygonMesh, so PLY/OBJ I/O goes through pcl::io.
TriangleMesh fromPolygonMesh (const pcl::PolygonMesh& mesh);
pcl::PolygonMesh toPolygonMesh (const TriangleMesh& mesh);
// Loads a PLY mesh with pcl::io; throws std::runtime_error on failure.
TriangleMesh loadPlyMesh (const std::string& path);

}  // namespace testing
}  // namespace pclx
