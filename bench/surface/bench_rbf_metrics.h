#pragma once
#include <cmath>
// Quality of a reconstructed mesh against the true surface (bench_rbf): two-sided sampled
// distances and topology (boundary / non-manifold edges, Euler characteristic, components).
#include <pclx/testing/mesh_distance.h>
#include <pclx/testing/triangle_mesh.h>

#include <pcl/PolygonMesh.h>

#include <Eigen/Core>
#include <vector>

namespace rbf_bench {

// An output mesh with shared vertices: positions closer than `tol` are one vertex (PCL's
// MarchingCubes writes three own vertices per triangle), degenerate triangles are dropped.
pclx::testing::TriangleMesh weld (const std::vector<Eigen::Vector3f>& vertices,
                                  const std::vector<Eigen::Vector3i>& faces, float tol);
pclx::testing::TriangleMesh weld (const pcl::PolygonMesh& mesh, float tol);

struct Topology
{
  std::size_t vertices = 0, triangles = 0, boundary_edges = 0, nonmanifold_edges = 0, components = 0;
  long euler = 0;  // V − E + F over the vertices that triangles use
  bool watertight () const { return triangles > 0 && boundary_edges == 0 && nonmanifold_edges == 0; }
};
Topology topology (const pclx::testing::TriangleMesh& mesh);

// Points every `step` along the edges that only one triangle uses (their midpoints at least).
std::vector<Eigen::Vector3f> boundaryPoints (const pclx::testing::TriangleMesh& mesh, double step);
// Open edges of an output against the truth's own holes (points along its open edges): the
// largest distance of an open edge's midpoint from them, and how many lie farther than
// `radius`. With no truth boundary every open edge counts and the distance is infinite.
struct OpenEdgesAtHoles
{
  std::size_t away = 0;
  double max_distance = 0;
};
OpenEdgesAtHoles openEdgesAtHoles (const pclx::testing::TriangleMesh& mesh,
                                   const std::vector<Eigen::Vector3f>& truth_boundary, double radius);
// The median edge length of a mesh (0 when it has no triangle).
double medianEdgeLength (const pclx::testing::TriangleMesh& mesh);

struct Error
{
  double out_to_truth_mean = 0, out_to_truth_max = 0;  // samples of the output, distance to the truth
  double truth_to_out_mean = 0, truth_to_out_max = 0;  // samples of the truth, distance to the output
  // Share of the output's area (its samples) farther than `far` from the truth: invented surface.
  double far_share = 0;
  double chamfer () const { return 0.5 * (out_to_truth_mean + truth_to_out_mean); }
  double hausdorff () const { return std::max (out_to_truth_max, truth_to_out_max); }
};
// `truth_samples` are area-uniform samples of the truth; the output is sampled with `samples`
// area-uniform points and measured against `truth` (CGAL AABB tree, built once per input).
Error meshError (const pclx::testing::TriangleMesh& output, const pclx::testing::MeshDistance& truth,
                 const std::vector<Eigen::Vector3f>& truth_samples, std::size_t samples, double far = HUGE_VAL);

// Removes the vertices whose density is below the q-quantile (and their triangles), as
// Open3D users do after CreateFromPointCloudPoisson.
void trimLowDensity (std::vector<Eigen::Vector3f>& vertices, std::vector<Eigen::Vector3i>& faces,
                     const std::vector<double>& density, double q);

}  // namespace rbf_bench
