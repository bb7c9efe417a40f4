#include <pclx/omicron/camera.h>

#include <Eigen/Geometry>

#include <cmath>

namespace pcl {

Eigen::Matrix4f
perspectiveLookAt (const Eigen::Vector3f& eye, const Eigen::Vector3f& target, float vertical_fov, float aspect,
                   float near_plane, float far_plane)
{
  const Eigen::Vector3f f = (target - eye).normalized ();
  const Eigen::Vector3f up = std::abs (f.z ()) > 0.9f ? Eigen::Vector3f::UnitY () : Eigen::Vector3f::UnitZ ();
  const Eigen::Vector3f s = f.cross (up).normalized (), u = s.cross (f);
  Eigen::Matrix4f view = Eigen::Matrix4f::Identity ();
  view.block<1, 3> (0, 0) = s.transpose ();
  view.block<1, 3> (1, 0) = u.transpose ();
  view.block<1, 3> (2, 0) = -f.transpose ();
  view (0, 3) = -s.dot (eye);
  view (1, 3) = -u.dot (eye);
  view (2, 3) = f.dot (eye);
  const float t = 1.f / std::tan (0.5f * vertical_fov);
  Eigen::Matrix4f proj = Eigen::Matrix4f::Zero ();
  proj (0, 0) = t / aspect;
  proj (1, 1) = t;
  proj (2, 2) = -(far_plane + near_plane) / (far_plane - near_plane);
  proj (2, 3) = -2.f * far_plane * near_plane / (far_plane - near_plane);
  proj (3, 2) = -1.f;
  return proj * view;
}

}  // namespace pcl
