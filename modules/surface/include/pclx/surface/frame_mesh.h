#pragma once
/** \file
  * Plain data shared by the front end of incremental dual contouring
  * (pcl::CoupledSimplification, da Paz 2017 §3.2–3.3) and its core (pcl::DualContouringOctree
  * and pcl::IncrementalDualContouring, §3.4–3.6).
  */
#include <Eigen/Core>

#include <limits>
#include <vector>

namespace pcl {

/** \brief Pinhole intrinsics of a depth camera, in pixels.
  *
  * The camera looks along +z, with x to the right and y down; a pixel (u, v) with depth z is
  * the point ((u − cx) z / fx, (v − cy) z / fy, z).
  * \ingroup surface
  */
struct DepthIntrinsics
{
  float fx = 0;  ///< focal length along x (pixels, > 0)
  float fy = 0;  ///< focal length along y (pixels, > 0)
  float cx = 0;  ///< principal point, column (pixels)
  float cy = 0;  ///< principal point, row (pixels)
};

/** \brief A triangle mesh in world coordinates: the unit that the extrinsic octree of
  * incremental dual contouring consumes (da Paz 2017, §3.4).
  * \ingroup surface
  */
struct FrameMesh
{
  /** \brief Vertex positions (world coordinates). */
  std::vector<Eigen::Vector3f> vertices;
  /** \brief Triangles as indices into \a vertices, counter-clockwise seen from outside: the
    * face normal (b − a) × (c − a) points out of the object (for a depth frame: towards the
    * camera). Signs use (C − A)·N (da Paz 2017, Eq. 3.1).
    */
  std::vector<Eigen::Vector3i> triangles;
  /** \brief Optional per-vertex Garland–Heckbert quadrics (empty when unknown, e.g. for
    * IncrementalDualContouring::addMesh input): accumulated on the dense connected cloud and
    * carried through the coupled simplification (§3.3), packed as the 10 upper-triangle entries
    * of the symmetric 4×4 matrix (a², ab, ac, ad, b², bc, bd, c², cd, d²) for planes
    * ax + by + cz + d = 0.
    */
  std::vector<Eigen::Matrix<double, 10, 1>> quadrics;
  /** \brief Camera centre in world coordinates; NaN when unknown. */
  Eigen::Vector3f viewpoint = Eigen::Vector3f::Constant (std::numeric_limits<float>::quiet_NaN ());
};

}  // namespace pcl
