// Fairing solves a sparse system: CGAL's default solver is Eigen's.
#define CGAL_EIGEN3_ENABLED
#include <pclx/surface/detail/hole_filling.h>

#include <pcl/console/print.h>

#include <CGAL/Polygon_mesh_processing/border.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <utility>

namespace pclx {
namespace surface {
namespace detail {

namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using Mesh = CGAL::Surface_mesh<Kernel::Point_3>;
using Halfedge = Mesh::Halfedge_index;

// True when some edge is used by one triangle only: most meshes need no halfedge structure.
bool
hasBoundary (const std::vector<Triangle>& triangles)
{
  std::vector<std::pair<std::uint32_t, std::uint32_t>> edges;
  edges.reserve (3 * triangles.size ());
  for (const auto& t : triangles)
    for (int j = 0; j < 3; ++j)
    {
      const std::uint32_t a = t[j], b = t[(j + 1) % 3];
      edges.emplace_back (std::min (a, b), std::max (a, b));
    }
  std::sort (edges.begin (), edges.end ());
  for (std::size_t i = 0; i < edges.size ();)
  {
    std::size_t j = i;
    while (j < edges.size () && edges[j] == edges[i])
      ++j;
    if (j - i == 1)
      return true;
    i = j;
  }
  return false;
}

bool
toMesh (const std::vector<Eigen::Vector3f>& vertices, const std::vector<Triangle>& triangles, Mesh& mesh)
{
  mesh.reserve (Mesh::size_type (vertices.size ()), Mesh::size_type (3 * triangles.size () / 2),
                Mesh::size_type (triangles.size ()));
  for (const auto& v : vertices)
    mesh.add_vertex (Kernel::Point_3 (v.x (), v.y (), v.z ()));
  for (const auto& t : triangles)
  {
    if (std::size_t (std::max ({t[0], t[1], t[2]})) >= vertices.size ())
      return false;
    const Mesh::Vertex_index a (t[0]), b (t[1]), c (t[2]);
    if (mesh.add_face (a, b, c) == Mesh::null_face ())
      return false;
  }
  return true;
}

// One halfedge per boundary loop, with the diagonal of the loop's bounding box.
std::vector<std::pair<Halfedge, double>>
boundaryLoops (Mesh& mesh)
{
  std::vector<Halfedge> cycles;
  CGAL::Polygon_mesh_processing::extract_boundary_cycles (mesh, std::back_inserter (cycles));
  std::vector<std::pair<Halfedge, double>> loops;
  for (const Halfedge h : cycles)
  {
    Eigen::Vector3d lo = Eigen::Vector3d::Constant (HUGE_VAL), hi = -lo;
    for (const Halfedge e : CGAL::halfedges_around_face (h, mesh))
    {
      const auto& p = mesh.point (mesh.target (e));
      const Eigen::Vector3d q (p.x (), p.y (), p.z ());
      lo = lo.cwiseMin (q);
      hi = hi.cwiseMax (q);
    }
    loops.emplace_back (h, (hi - lo).norm ());
  }
  return loops;
}

double
triangleArea (const Mesh& mesh, Mesh::Face_index f)
{
  const Halfedge h = mesh.halfedge (f);
  const auto& a = mesh.point (mesh.source (h));
  const auto& b = mesh.point (mesh.target (h));
  const auto& c = mesh.point (mesh.target (mesh.next (h)));
  return std::sqrt (CGAL::squared_area (a, b, c));
}

}  // namespace

bool
fillSmallHoles (std::vector<Eigen::Vector3f>& vertices, std::vector<Triangle>& triangles, double max_diameter,
                HoleFillingStats& stats)
{
  stats = HoleFillingStats ();
  if (!(max_diameter > 0) || !std::isfinite (max_diameter))
  {
    PCL_ERROR ("[pclx::surface::detail::fillSmallHoles] the largest hole must be positive and finite (got %g)\n",
               max_diameter);
    return false;
  }
  if (!hasBoundary (triangles))
    return true;
  Mesh mesh;
  if (!toMesh (vertices, triangles, mesh))
  {
    PCL_ERROR ("[pclx::surface::detail::fillSmallHoles] the mesh is not an oriented 2-manifold; no hole was filled\n");
    return false;
  }
  const auto loops = boundaryLoops (mesh);
  stats.holes = loops.size ();
  std::vector<Mesh::Face_index> added_faces;
  for (const auto& [h, diameter] : loops)
  {
    if (diameter > max_diameter)
    {
      ++stats.too_large;
      continue;
    }
    std::vector<Mesh::Face_index> faces;
    std::vector<Mesh::Vertex_index> new_vertices;
    // The flag is the fairing's: a patch whose fairing failed stays, refined but not faired.
    const bool faired = std::get<0> (CGAL::Polygon_mesh_processing::triangulate_refine_and_fair_hole (
        mesh, h, std::back_inserter (faces), std::back_inserter (new_vertices)));
    if (faces.empty ())
    {
      ++stats.failed;
      continue;
    }
    ++stats.filled;
    stats.unfaired += !faired;
    stats.added_vertices += new_vertices.size ();
    added_faces.insert (added_faces.end (), faces.begin (), faces.end ());
  }
  // New vertices follow the input's in index order (nothing was removed).
  for (std::size_t v = vertices.size (); v < mesh.number_of_vertices (); ++v)
  {
    const auto& p = mesh.point (Mesh::Vertex_index (Mesh::size_type (v)));
    vertices.emplace_back (float (p.x ()), float (p.y ()), float (p.z ()));
  }
  for (const auto f : added_faces)
  {
    Triangle t;
    std::size_t j = 0;
    for (const auto v : CGAL::vertices_around_face (mesh.halfedge (f), mesh))
      if (j < t.size ())
        t[j++] = std::uint32_t (v);  // the patches are triangulated
    triangles.push_back (t);
    stats.filled_area += triangleArea (mesh, f);
  }
  stats.added_triangles = added_faces.size ();
  return true;
}

}  // namespace detail
}  // namespace surface
}  // namespace pclx
