#pragma once
// Internal to pcl::IncrementalDualContouring: detects poses given as world-to-camera.
#include <Eigen/Geometry>

#include <vector>

namespace pclx {
namespace surface {
namespace detail {

/** \brief Tells camera-to-world poses from their inverses across the frames of one scan.
  *
  * A rigid pose moves a frame's mesh and its viewpoint together, so one frame cannot tell the two
  * conventions apart. Consecutive frames of a scan overlap, though: each frame is compared with
  * the previous one under the given poses and under their inverses, and the hypothesis under
  * which they line up is the convention the caller uses.
  */
class PoseConventionCheck
{
public:
  /** \brief Compare the next frame with the previous one and keep it for the next call.
    * \param[in] world_vertices the frame's mesh vertices placed with the given pose
    * \param[in] camera_to_world the given pose
    * \param[in] radius how near a vertex must come to the previous frame's vertices to overlap (m)
    * \return true when, for this frame and the one before it, 4 in 5 of the frame's vertices
    * overlap the previous frame under the inverse poses, and a quarter of them more than under the
    * given poses
    */
  bool
  add (const std::vector<Eigen::Vector3f>& world_vertices, const Eigen::Matrix4d& camera_to_world, double radius);

  /** \brief The overlaps of the last comparison, as shares of the probed vertices.
    * \param[out] given under the given poses
    * \param[out] inverse under the inverse poses
    */
  void
  lastOverlaps (double& given, double& inverse) const
  {
    given = given_;
    inverse = inverse_;
  }

  /** \brief Forget the previous frame. */
  void
  clear ()
  {
    previous_.clear ();
    given_ = inverse_ = 0;
    streak_ = 0;
  }

private:
  std::vector<Eigen::Vector3f> previous_;  // the previous frame's sampled vertices, camera frame
  Eigen::Isometry3d previous_pose_ = Eigen::Isometry3d::Identity ();
  double given_ = 0, inverse_ = 0;
  int streak_ = 0;  // consecutive suspect comparisons
};

}  // namespace detail
}  // namespace surface
}  // namespace pclx
