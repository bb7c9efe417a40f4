#include <pclx/testing/triangle_mesh.h>

#include <pcl/conversions.h>
#include <pcl/io/ply_io.h>

#include <stdexcept>

namespace pclx {
namespace testing {

Eigen::Vector3f
TriangleMesh::faceNormal (std::size_t f) const
{
  const Eigen::Vector3i& t = faces[f];
  return (vertices[t[1]] - vertices[t[0]]).cross (vertices[t[2]] - vertices[t[0]]).normalized ();
}

float
TriangleMesh::faceArea (std::size_t f) const
{
  const Eigen::Vector3i& t = faces[f];
  return 0.5f * (vertices[t[1]] - vertices[t[0]]).cross (vertices[t[2]] - vertices[t[0]]).norm ();
}

float
TriangleMesh::totalArea () const
{
  double a = 0;
  for (std::size_t f = 0; f < faces.size (); ++f)
    a += faceArea (f);
  return static_cast<float> (a);
}

Eigen::Vector3f
TriangleMesh::bboxMin () const
{
  Eigen::Vector3f m = Eigen::Vector3f::Constant (std::numeric_limits<float>::max ());
  for (const auto& v : vertices)
    m = m.cwiseMin (v);
  return m;
}

Eigen::Vector3f
TriangleMesh::bboxMax () const
{
  Eigen::Vector3f m = Eigen::Vector3f::Constant (std::numeric_limits<float>::lowest ());
  for (const auto& v : vertices)
    m = m.cwiseMax (v);
  return m;
}

float
TriangleMesh::diagonal () const
{
  return vertices.empty () ? 0.f : (bboxMax () - bboxMin ()).norm ();
}

void
TriangleMesh::addQuad (const Eigen::Vector3f& a, const Eigen::Vector3f& b, const Eigen::Vector3f& c,
                       const Eigen::Vector3f& d)
{
  const int o = static_cast<int> (vertices.size ());
  vertices.insert (vertices.end (), {a, b, c, d});
  faces.emplace_back (o, o + 1, o + 2);
  faces.emplace_back (o, o + 2, o + 3);
}

void
TriangleMesh::append (const TriangleMesh& other)
{
  const int offset = static_cast<int> (vertices.size ());
  vertices.insert (vertices.end (), other.vertices.begin (), other.vertices.end ());
  for (const auto& f : other.faces)
    faces.push_back (f + Eigen::Vector3i::Constant (offset));
}

void
TriangleMesh::transform (const Eigen::Affine3f& t)
{
  for (auto& v : vertices)
    v = t * v;
}

TriangleMesh
fromPolygonMesh (const pcl::PolygonMesh& mesh)
{
  pcl::PointCloud<pcl::PointXYZ> cloud;
  pcl::fromPCLPointCloud2 (mesh.cloud, cloud);
  TriangleMesh out;
  out.vertices.reserve (cloud.size ());
  for (const auto& p : cloud)
    out.vertices.emplace_back (p.x, p.y, p.z);
  for (const auto& poly : mesh.polygons)
  {
    // Fan-triangulate polygons with more than three vertices.
    for (std::size_t i = 2; i < poly.vertices.size (); ++i)
      out.faces.emplace_back (poly.vertices[0], poly.vertices[i - 1], poly.vertices[i]);
  }
  return out;
}

pcl::PolygonMesh
toPolygonMesh (const TriangleMesh& mesh)
{
  pcl::PointCloud<pcl::PointXYZ> cloud;
  for (const auto& v : mesh.vertices)
    cloud.push_back (pcl::PointXYZ (v.x (), v.y (), v.z ()));
  pcl::PolygonMesh out;
  pcl::toPCLPointCloud2 (cloud, out.cloud);
  for (const auto& f : mesh.faces)
  {
    pcl::Vertices poly;
    poly.vertices = {static_cast<pcl::index_t> (f[0]), static_cast<pcl::index_t> (f[1]),
                     static_cast<pcl::index_t> (f[2])};
    out.polygons.push_back (poly);
  }
  return out;
}

TriangleMesh
loadPlyMesh (const std::string& path)
{
  pcl::PolygonMesh mesh;
  if (pcl::io::loadPLYFile (path, mesh) < 0 || mesh.polygons.empty ())
    throw std::runtime_error ("loadPlyMesh: cannot read a triangle mesh from " + path);
  return fromPolygonMesh (mesh);
}

}  // namespace testing
}  // namespace pclx
