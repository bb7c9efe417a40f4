#pragma once
// Analytic test shapes as closed (or explicitly open) triangle meshes.
#include <pclx/testing/triangle_mesh.h>

namespace pclx {
namespace testing {

// Icosphere: 20·4^subdivisions faces, vertices exactly on the sphere.
TriangleMesh makeSphere (float radius = 1.f, int subdivisions = 4,
                         const Eigen::Vector3f& center = Eigen::Vector3f::Zero ());
// Torus around z: major radius R, minor radius r, nu × nv quads split in two.
TriangleMesh makeTorus (float R = 1.f, float r = 0.3f, int nu = 128, int nv = 48);
// Axis-aligned box (sharp edges, flat faces), each face split in a grid.
TriangleMesh makeBox (const Eigen::Vector3f& size = Eigen::Vector3f::Ones (), int grid = 8);
// Two parallel open squares (side `size`) at z = ±gap/2, normals pointing apart.
TriangleMesh makeParallelSheets (float size = 1.f, float gap = 0.02f, int grid = 16);
// A closed thin box: size × size × thickness.
TriangleMesh makeThinPlate (float size = 1.f, float thickness = 0.01f, int grid = 16);
// Deep concavities and thin parts (for HPR): a 2.4 × 2 × 0.2 slab with five fins 0.04
// thick, 1.05 tall (slots 0.2 wide and 1 deep) and a thin-walled open box (a cup). Boxes
// that overlap: their overlapped faces are hidden from everywhere. Face grids: slab, parts.
TriangleMesh makeFinsScene (int slab_grid = 24, int part_grid = 16);

}  // namespace testing
}  // namespace pclx
