#pragma once
// A VTK camera placed from a bounding box rather than from the props on screen (see
// frameViewport in view.h for that): the box is known before anything is drawn, and the
// camera may have no renderer (a headless run that still evaluates views).
#include <Eigen/Core>

class vtkCamera;

namespace pclx {
namespace apps {

/** \brief One of the eight corners of an axis-aligned box.
  * \param[in] lo the minimum corner
  * \param[in] hi the maximum corner
  * \param[in] i the corner (bit 0: x, bit 1: y, bit 2: z; a set bit takes hi)
  * \return the corner
  */
Eigen::Vector3f
boxCorner (const Eigen::Vector3f& lo, const Eigen::Vector3f& hi, int i);

/** \brief Points the camera at the box's centre from direction `dir` and moves it back until
  * the eight corners fit the view with `margin` to spare.
  * \param[in,out] cam the camera (its view angle is kept)
  * \param[in] aspect the view's width over its height
  * \param[in] lo the box's minimum corner
  * \param[in] hi the box's maximum corner
  * \param[in] dir the direction from the box's centre to the camera
  * \param[in] up the camera's up direction (made orthogonal to the view direction)
  * \param[in] margin the share of the half-width left free around the box
  */
void
frameBounds (vtkCamera& cam, double aspect, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi,
             const Eigen::Vector3d& dir, const Eigen::Vector3d& up, double margin = 0.06);

/** \brief Sets the near and far planes just around the box, seen from the camera's position.
  * \param[in,out] cam the camera
  * \param[in] lo the box's minimum corner
  * \param[in] hi the box's maximum corner
  */
void
clipToBounds (vtkCamera& cam, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi);

/** \brief Places the camera on an orbit around `centre`: one turn about `up` per `period`
  * seconds, starting from `start_eye`.
  * \param[in,out] cam the camera
  * \param[in] centre the focal point
  * \param[in] start_eye the camera position at t = 0
  * \param[in] up the orbit's axis and the camera's up direction
  * \param[in] t the time in seconds
  * \param[in] period the seconds per turn
  */
void
orbitCamera (vtkCamera& cam, const Eigen::Vector3d& centre, const Eigen::Vector3d& start_eye,
             const Eigen::Vector3d& up, double t, double period);

/** \brief The camera's view-projection matrix (world to clip space, OpenGL convention) for a
  * view of the given size.
  * \param[in] cam the camera
  * \param[in] width the view's width in pixels
  * \param[in] height the view's height in pixels
  * \return the matrix
  */
Eigen::Matrix4f
viewProjection (vtkCamera& cam, int width, int height);

}  // namespace apps
}  // namespace pclx
