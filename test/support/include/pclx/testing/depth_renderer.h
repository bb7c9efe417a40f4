#pragma once
// Posed pinhole depth renderer with a Kinect-like sensor model.
#include <pclx/testing/ray_caster.h>

#include <cstdint>

namespace pclx {
namespace testing {

struct PinholeIntrinsics
{
  int width = 640, height = 480;
  float fx = 525.f, fy = 525.f, cx = 319.5f, cy = 239.5f;
};

// Kinect v1 style: axial sigma(z) = a + b·(z − 0.4)² metres (Nguyen et al. 2012),
// 1 mm quantisation in the 16-bit image, random dropouts, dropouts at grazing
// angles and outside [min_range, max_range]. `enabled = false` renders exact depth.
struct KinectNoise
{
  bool enabled = true;
  float a = 0.0012f, b = 0.0019f;
  float dropout = 0.01f;           // probability that a valid pixel is lost
  float grazing_deg = 80.f;        // drop when angle(normal, ray) exceeds this
  float min_range = 0.4f, max_range = 8.f;
};

struct DepthImage
{
  int width = 0, height = 0;
  std::vector<std::uint16_t> depth_mm;  // row-major, 0 = no data
  std::uint16_t at (int u, int v) const { return depth_mm[static_cast<std::size_t> (v) * width + u]; }
};

// camera_to_world: camera looks along +z, x right, y down (OpenCV / Kinect convention).
DepthImage renderDepth (const RayCaster& caster, const PinholeIntrinsics& K,
                        const Eigen::Isometry3f& camera_to_world,
                        const KinectNoise& noise = KinectNoise (), std::uint32_t seed = 1);

// Back-projects to an organized cloud (NaN where depth is 0), in camera or world frame.
pcl::PointCloud<pcl::PointXYZ> depthToCloud (const DepthImage& depth, const PinholeIntrinsics& K,
                                             const Eigen::Isometry3f& camera_to_world =
                                                 Eigen::Isometry3f::Identity ());

// A camera at `eye` looking at `target` with world `up` (camera y points down).
Eigen::Isometry3f lookAt (const Eigen::Vector3f& eye, const Eigen::Vector3f& target,
                          const Eigen::Vector3f& up = Eigen::Vector3f::UnitZ ());

}  // namespace testing
}  // namespace pclx
