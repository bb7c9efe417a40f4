#pragma once
// pcl::perspectiveLookAt: a camera matrix for ObliqueCutFront::evaluate (), the world-to-clip
// matrix a renderer would use.
#include <Eigen/Core>

namespace pcl {

/** \brief OpenGL world-to-clip matrix (projection · view) of a perspective camera.
  * \param[in] eye the camera's position
  * \param[in] target the point it looks at (the up direction is +z, or +y when looking along z)
  * \param[in] vertical_fov the vertical field of view in radians, in (0, π)
  * \param[in] aspect the viewport's width / height
  * \param[in] near_plane the near clipping distance (> 0)
  * \param[in] far_plane the far clipping distance (> near_plane)
  * \return the matrix, as gluPerspective · gluLookAt build it
  * \ingroup omicron
  */
Eigen::Matrix4f
perspectiveLookAt (const Eigen::Vector3f& eye, const Eigen::Vector3f& target, float vertical_fov, float aspect,
                   float near_plane, float far_plane);

}  // namespace pcl
