#pragma once
// Closing the small holes of a triangle mesh, for surfaces reconstructed from scans.
#include <pclx/surface/detail/triangle.h>

#include <Eigen/Core>

#include <cstddef>
#include <vector>

namespace pclx {
namespace surface {
namespace detail {

/** \brief What fillSmallHoles () found and did. */
struct HoleFillingStats
{
  std::size_t holes = 0;            ///< boundary loops of the mesh
  std::size_t filled = 0;           ///< of those, closed
  std::size_t too_large = 0;        ///< left open: larger than the limit
  std::size_t failed = 0;           ///< left open: the triangulation found no patch
  std::size_t unfaired = 0;         ///< closed, but the fairing's system had no solution
  std::size_t added_vertices = 0, added_triangles = 0;
  double filled_area = 0;           ///< area of the added triangles
};

/** \brief Closes every hole of a triangle mesh whose boundary loop fits in an axis-aligned box of
  * diagonal at most \a max_diameter, with a patch that is triangulated, refined to the density
  * around the hole and faired to meet the surface smoothly.
  *
  * The input triangles and vertices are kept as they are; the patches' vertices and triangles
  * are appended, oriented as the surface around them.
  * \param[in,out] vertices the mesh's vertex positions
  * \param[in,out] triangles the mesh's triangles (three indices each)
  * \param[in] max_diameter the largest hole closed, in the units of the vertices (> 0)
  * \param[out] stats the holes found, closed and left open
  * \return false (with a PCL_ERROR, the mesh unchanged) when the mesh is not an oriented
  * 2-manifold that CGAL's halfedge structure can hold, or max_diameter is not positive
  * \note Liepa, "Filling holes in meshes", Eurographics Symposium on Geometry Processing 2003,
  * as CGAL::Polygon_mesh_processing::triangulate_refine_and_fair_hole implements it.
  */
bool
fillSmallHoles (std::vector<Eigen::Vector3f>& vertices, std::vector<Triangle>& triangles, double max_diameter,
                HoleFillingStats& stats);

}  // namespace detail
}  // namespace surface
}  // namespace pclx
