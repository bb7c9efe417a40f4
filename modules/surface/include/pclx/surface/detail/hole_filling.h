#pragma once
// Closing the small holes of a triangle mesh, for surfaces reconstructed from scans.
#include <pclx/surface/detail/triangle.h>

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <unordered_map>
#include <vector>

namespace pclx {
namespace surface {
namespace detail {

/** \brief What fillSmallHoles () found and did. */
struct HoleFillingStats
{
  std::size_t holes = 0;            ///< boundary loops of the mesh (loops that share a vertex count once)
  std::size_t filled = 0;           ///< of those, closed
  std::size_t too_large = 0;        ///< left open: larger than the limit
  std::size_t failed = 0;           ///< left open: the triangulation found no patch
  std::size_t unfaired = 0;         ///< closed, but the fairing's system had no solution
  std::size_t added_vertices = 0, added_triangles = 0;
  double filled_area = 0;           ///< area of the added triangles
};

/** \brief The patch of one hole, in the numbering of the surface around it: indices below the
  * number of vertices around the hole are those vertices, the rest are the patch's own. */
struct HolePatch
{
  std::vector<Eigen::Vector3f> added_vertices;  ///< the patch's own vertices
  std::vector<Triangle> triangles;              ///< the patch's triangles
  bool closed = false;                          ///< every boundary cycle of the hole got a patch
  std::size_t unfaired = 0;                     ///< patches whose fairing had no solution
  double area = 0;                              ///< area of the triangles
};

/** \brief Working arrays of fillSmallHoles () (defined where it is). */
struct HoleFillingScratch;

/** \brief Patches of an earlier call of fillSmallHoles (), keyed by everything the patch of a hole
  * depends on: the positions and triangles of the surface around it and which of its vertices
  * are on the hole. A mesh filled again after a local change (a reconstruction after each
  * frame) then recomputes only the patches whose surroundings changed, with the same result as
  * recomputing them all. Entries a call does not use are dropped at its end. */
struct HolePatchCache
{
  /** \brief One hole's surroundings and patch. */
  struct Entry
  {
    std::vector<Eigen::Vector3f> positions;  ///< the vertices around the hole, in local order
    std::vector<std::uint32_t> layout;       ///< the local triangles, then the hole's local vertices
    HolePatch patch;                         ///< what was added
    std::uint64_t generation = 0;            ///< the call that last used it
  };
  std::unordered_multimap<std::uint64_t, Entry> entries;  ///< by a hash of positions and layout
  std::uint64_t generation = 0;                           ///< calls so far
  std::size_t hits = 0;                                   ///< patches reused by the last call
  /** \brief The last call's working arrays (per vertex and per triangle corner), kept with their
    * capacity: the next call writes into pages the process already has instead of faulting in
    * fresh ones, which on a room's mesh cost as much as the work. */
  std::shared_ptr<HoleFillingScratch> scratch;
  /** \brief Bytes held by the working arrays. */
  std::size_t
  scratchBytes () const;
};

/** \brief Boundaries up to this many edges are triangulated by searching every triangulation
  * (cubic in the edges, and free of geometric predicates, so degenerate boundaries such as
  * coplanar lattice loops cannot stall it); longer ones search the faces of their 3D Delaunay
  * triangulation. */
constexpr std::size_t kCubicSearchEdges = 100;

/** \brief Closes every hole of a triangle mesh whose boundary loop fits in an axis-aligned box of
  * diagonal at most \a max_diameter, with a patch that is triangulated, refined to the density
  * around the hole and faired to meet the surface smoothly.
  *
  * The input triangles and vertices are kept as they are; the patches' vertices and triangles
  * are appended, oriented as the surface around them. A hole of three or four edges gets one or
  * two triangles; a boundary that passes a vertex twice is closed as the two holes it is, unless
  * a patch would repeat an edge of the mesh (then it stays open). The mesh is read once, for a
  * sum per vertex that vanishes where the triangles around it close; only the triangles near
  * the vertices where it does not are searched for holes, and only those around a hole go into a
  * halfedge structure, so the cost beyond that one read follows the holes, not the mesh. The
  * holes are searched on OpenMP's threads, each from the mesh as it came in, and their patches
  * appended in hole order: the result does not depend on the thread count.
  * \param[in,out] vertices the mesh's vertex positions
  * \param[in,out] triangles the mesh's triangles (three indices each)
  * \param[in] max_diameter the largest hole closed, in the units of the vertices (> 0)
  * \param[out] stats the holes found, closed and left open
  * \param[in] max_edges holes with more boundary edges stay open (counted as failed); 0: no limit
  * \param[in,out] cache patches of the previous call to reuse, or nullptr
  * \return false (with a PCL_ERROR, the mesh unchanged) when the mesh is not an oriented
  * 2-manifold (an edge with two triangles of one orientation, or more than two; an edge with as
  * many triangles of each orientation, such as two and two, is found only next to a boundary),
  * a triangle refers to a missing vertex, or max_diameter is not positive
  * \note Liepa, "Filling holes in meshes", Eurographics Symposium on Geometry Processing 2003,
  * as CGAL::Polygon_mesh_processing::triangulate_refine_and_fair_hole implements it.
  */
bool
fillSmallHoles (std::vector<Eigen::Vector3f>& vertices, std::vector<Triangle>& triangles, double max_diameter,
                HoleFillingStats& stats, std::size_t max_edges = 0, HolePatchCache* cache = nullptr);

}  // namespace detail
}  // namespace surface
}  // namespace pclx
