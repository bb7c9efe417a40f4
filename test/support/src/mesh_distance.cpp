#include <pclx/testing/mesh_distance.h>

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>

#include <stdexcept>

namespace pclx {
namespace testing {

namespace {
using K = CGAL::Simple_cartesian<double>;
using Triangle = K::Triangle_3;
using Iterator = std::vector<Triangle>::const_iterator;
using Primitive = CGAL::AABB_triangle_primitive<K, Iterator>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<K, Primitive>>;

K::Point_3
toCgal (const Eigen::Vector3f& v)
{
  return {v.x (), v.y (), v.z ()};
}
}  // namespace

struct MeshDistance::Impl
{
  std::vector<Triangle> triangles;  // must outlive the tree
  Tree tree;
};

MeshDistance::MeshDistance (const TriangleMesh& mesh) : impl_ (new Impl)
{
  if (mesh.faces.empty ())
    throw std::invalid_argument ("MeshDistance: mesh has no faces");
  impl_->triangles.reserve (mesh.faces.size ());
  for (const auto& f : mesh.faces)
  {
    Triangle t (toCgal (mesh.vertices[f[0]]), toCgal (mesh.vertices[f[1]]), toCgal (mesh.vertices[f[2]]));
    if (!t.is_degenerate ())
      impl_->triangles.push_back (t);
  }
  if (impl_->triangles.empty ())
    throw std::invalid_argument ("MeshDistance: all faces are degenerate");
  impl_->tree.insert (impl_->triangles.begin (), impl_->triangles.end ());
  impl_->tree.accelerate_distance_queries ();
}

MeshDistance::~MeshDistance () = default;

double
MeshDistance::distance (const Eigen::Vector3f& p) const
{
  return std::sqrt (impl_->tree.squared_distance (toCgal (p)));
}

Eigen::Vector3f
MeshDistance::closestPoint (const Eigen::Vector3f& p) const
{
  const K::Point_3 c = impl_->tree.closest_point (toCgal (p));
  return Eigen::Vector3f (float (c.x ()), float (c.y ()), float (c.z ()));
}

}  // namespace testing
}  // namespace pclx
