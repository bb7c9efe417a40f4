#pragma once
// Depth frames in the 7-Scenes layout: frame-NNNNNN.depth.png (16-bit grey, millimetres,
// 0 and 65535 = no depth), camera-intrinsics.txt (3 x 3 K), optional frame-NNNNNN.pose.txt
// (4 x 4 camera-to-world). Read as organized clouds in the camera frame (x right, y down,
// z forward), the way a depth sensor delivers them.
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

namespace pclx {
namespace apps {

struct DepthImage16
{
  int width = 0, height = 0;
  std::vector<std::uint16_t> mm;  // row-major
};

// libpng; throws LoadError unless the file is a 16-bit grey PNG.
DepthImage16 readDepthPng (const std::string& path);
// Throws std::runtime_error when the file cannot be written.
void writeDepthPng (const std::string& path, const DepthImage16& image);

// Pinhole intrinsics as camera-intrinsics.txt stores them (fx 0 cx / 0 fy cy / 0 0 1).
struct DepthIntrinsics
{
  float fx = 0, fy = 0, cx = 0, cy = 0;
};
DepthIntrinsics readIntrinsics (const std::string& path);
void writeIntrinsics (const std::string& path, const DepthIntrinsics& k);
Eigen::Matrix4f readPose (const std::string& path);
void writePose (const std::string& path, const Eigen::Matrix4f& camera_to_world);

// Organized cloud (NaN where there is no depth) in the camera frame.
pcl::PointCloud<pcl::PointXYZ>::Ptr depthToCloud (const DepthImage16& image, const DepthIntrinsics& k);

class DepthFrameFolder
{
public:
  // Lists the frames (sorted by name) and reads the intrinsics; throws LoadError when the
  // folder is missing, has no camera-intrinsics.txt or no frame-*.depth.png.
  explicit DepthFrameFolder (const std::string& dir);

  std::size_t size () const { return frames_.size (); }
  const std::string& framePath (std::size_t i) const { return frames_.at (i); }
  const DepthIntrinsics& intrinsics () const { return k_; }
  // Camera-to-world of frame i; false when it has no pose file. Throws on a malformed one.
  bool pose (std::size_t i, Eigen::Matrix4f& camera_to_world) const;
  // Frame i as an organized cloud; in world coordinates when `world` and the pose exists.
  // Throws LoadError on a corrupt PNG.
  pcl::PointCloud<pcl::PointXYZ>::Ptr load (std::size_t i, bool world = false) const;

private:
  std::string dir_;
  std::vector<std::string> frames_;
  DepthIntrinsics k_;
};

}  // namespace apps
}  // namespace pclx
