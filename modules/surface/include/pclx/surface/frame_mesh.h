#pragma once
// Plain data shared by the front end of incremental dual contouring (seed 004 §3.2–3.3:
// CoupledSimplification) and its core (§3.4–3.6: IncrementalDualContouring).
#include <Eigen/Core>

#include <limits>
#include <vector>

namespace pclx {
namespace surface {

// Pinhole intrinsics in pixels (camera looks along +z, x right, y down).
struct DepthIntrinsics
{
  float fx = 0, fy = 0, cx = 0, cy = 0;
};

// A triangle mesh in world coordinates, the unit the extrinsic octree consumes (§3.4).
struct FrameMesh
{
  std::vector<Eigen::Vector3f> vertices;
  // Counter-clockwise seen from outside: the face normal (b − a) × (c − a) points out of the
  // object (for a depth frame: towards the camera). Signs use (C − A)·N (Eq. 3.1).
  std::vector<Eigen::Vector3i> triangles;
  // Optional (empty when unknown, e.g. addMesh input): per vertex, the Garland–Heckbert quadric
  // accumulated on the dense connected cloud and carried through the coupled simplification
  // (§3.3), packed as the 10 upper-triangle entries of the symmetric 4×4 matrix
  // (a², ab, ac, ad, b², bc, bd, c², cd, d²) for planes ax + by + cz + d = 0.
  std::vector<Eigen::Matrix<double, 10, 1>> quadrics;
  // Camera centre in world coordinates; NaN when unknown.
  Eigen::Vector3f viewpoint = Eigen::Vector3f::Constant (std::numeric_limits<float>::quiet_NaN ());
};

} // namespace surface
} // namespace pclx
