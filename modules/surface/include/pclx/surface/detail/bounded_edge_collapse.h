#pragma once
// Edge-collapse simplification of a triangle mesh whose vertices stay near the planes they were
// fitted to, for dual-contouring meshes simplified beyond what the octree's topology test allows.
#include <pclx/surface/detail/triangle.h>

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace pclx {
namespace surface {
namespace detail {

/** \brief The planes each vertex of a mesh must stay near: those of vertex v are
  * planes[begin[v]] … planes[begin[v + 1] − 1], each (n, d) with |n| = 1 and n·x + d = 0.
  */
struct VertexPlanes
{
  std::vector<Eigen::Vector4f> planes;  ///< unit normal and offset
  std::vector<std::uint32_t> begin;     ///< one more entry than the mesh has vertices
};

/** \brief What collapseEdgesWithinDistance () did. */
struct EdgeCollapseStats
{
  std::size_t input_triangles = 0;    ///< triangles given
  std::size_t triangles = 0;          ///< triangles left
  std::size_t collapses = 0;          ///< edges collapsed
  std::size_t rejected_topology = 0;  ///< candidates that would pinch the surface or close a hole
  std::size_t rejected_distance = 0;  ///< candidates whose vertex would leave a plane by more than the bound
  std::size_t rejected_foldover = 0;  ///< candidates that would flip or degenerate a triangle
  std::size_t rejected_size = 0;      ///< candidates whose vertex would answer for too many planes
  double max_distance = 0;            ///< at most the bound, at least a collapsed vertex's largest plane distance
};

/** \brief Simplifies a triangle mesh by edge collapses in the order of their quadric error, each
  * placing the new vertex at the minimiser of its planes' quadric, while that vertex stays within
  * \a max_distance of every plane of every vertex it replaces.
  *
  * A vertex's planes are its own plus those of the vertices collapsed into it, so the bound holds
  * against the input's planes however many collapses a vertex absorbs, not only against its
  * neighbours of the moment. Each vertex also keeps a summary of its planes (a mean normal, how
  * far their normals spread from it, and its largest distance to them), which bounds its distance
  * to them at a new position: the planes themselves are read only where that bound exceeds
  * \a max_distance, and the collapses taken are those of the exact test. The mesh keeps its
  * topology: a collapse must pass the link condition, may not join two boundary vertices across
  * the surface, and no triangle may flip or degenerate.
  * Boundary edges add planes perpendicular to their triangle, so a boundary moves by at most
  * \a max_distance too and a hole never opens or grows beyond the bound. Vertices without planes
  * and vertices of non-manifold edges are never moved. The mesh is cut into four slabs that
  * collapse in parallel while the vertices on the cuts are held, then the cuts collapse: the
  * result depends on the input only, not on the number of threads.
  * \param[in,out] vertices vertex positions; on success only the vertices still used, in their order
  * \param[in,out] triangles triangles; on success the ones left, renumbered
  * \param[in] planes the planes of each input vertex (see VertexPlanes)
  * \param[in] max_distance the bound, in the units of the vertices (> 0, finite)
  * \param[in] max_planes most planes one vertex may answer for (> 0); bounds the cost of a check
  * \param[out] stats what was collapsed and why candidates were refused
  * \return false (with a PCL_ERROR, the mesh unchanged) for a bad bound, a triangle with an index
  * out of range or a repeated corner, or planes that do not match the vertices
  * \note Garland and Heckbert, "Surface simplification using quadric error metrics", SIGGRAPH 1997
  * (the quadric, the order and the boundary planes); Ronfard and Rossignac, "Full-range
  * approximation of triangulated polyhedra", Computer Graphics Forum 15(3), 1996 (the bound on
  * the largest distance to the planes a vertex replaces); Dey, Edelsbrunner, Guha and Nekhayev,
  * "Topology preserving edge contraction", 1999 (the link condition).
  */
bool
collapseEdgesWithinDistance (std::vector<Eigen::Vector3f>& vertices, std::vector<Triangle>& triangles,
                             const VertexPlanes& planes, double max_distance, std::size_t max_planes,
                             EdgeCollapseStats& stats);

}  // namespace detail
}  // namespace surface
}  // namespace pclx
