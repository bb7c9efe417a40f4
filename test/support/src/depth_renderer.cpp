#include <pclx/testing/depth_renderer.h>

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

namespace pclx {
namespace testing {

DepthImage
renderDepth (const RayCaster& caster, const PinholeIntrinsics& K, const Eigen::Isometry3f& camera_to_world,
             const KinectNoise& noise, std::uint32_t seed)
{
  if (K.width <= 0 || K.height <= 0 || !(K.fx > 0) || !(K.fy > 0))
    throw std::invalid_argument ("renderDepth: intrinsics need positive size and focal lengths");
  DepthImage img;
  img.width = K.width;
  img.height = K.height;
  img.depth_mm.assign (static_cast<std::size_t> (K.width) * K.height, 0);
  const Eigen::Vector3f eye = camera_to_world.translation ();
  const Eigen::Matrix3f R = camera_to_world.linear ();
  const float cos_grazing = std::cos (noise.grazing_deg * static_cast<float> (M_PI) / 180.f);

#pragma omp parallel for schedule(dynamic, 8)
  for (int v = 0; v < K.height; ++v)
  {
    // One generator per row keeps the result independent of the thread count.
    std::mt19937 rng (seed * 2654435761u + static_cast<std::uint32_t> (v));
    std::normal_distribution<float> N (0.f, 1.f);
    std::uniform_real_distribution<float> U (0.f, 1.f);
    for (int u = 0; u < K.width; ++u)
    {
      // With the camera-frame direction ((u-cx)/fx, (v-cy)/fy, 1), the hit parameter is the depth z.
      const Eigen::Vector3f d_cam ((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.f);
      int face = -1;
      float z = caster.cast (eye, R * d_cam, &face);
      if (!std::isfinite (z))
        continue;
      if (noise.enabled)
      {
        if (z < noise.min_range || z > noise.max_range || U (rng) < noise.dropout)
          continue;
        // Structured-light sensors lose surfaces seen at grazing angles.
        const Eigen::Vector3f ray = (R * d_cam).normalized ();
        if (std::abs (ray.dot (caster.faceNormal (face))) < cos_grazing)
          continue;
        z += (noise.a + noise.b * (z - 0.4f) * (z - 0.4f)) * N (rng);
      }
      const float mm = std::round (z * 1000.f);
      if (mm > 0.f && mm <= 65535.f)
        img.depth_mm[static_cast<std::size_t> (v) * K.width + u] = static_cast<std::uint16_t> (mm);
    }
  }
  return img;
}

pcl::PointCloud<pcl::PointXYZ>
depthToCloud (const DepthImage& depth, const PinholeIntrinsics& K, const Eigen::Isometry3f& camera_to_world)
{
  pcl::PointCloud<pcl::PointXYZ> cloud (depth.width, depth.height);
  cloud.is_dense = false;
  const float nan = std::numeric_limits<float>::quiet_NaN ();
  for (int v = 0; v < depth.height; ++v)
    for (int u = 0; u < depth.width; ++u)
    {
      pcl::PointXYZ& p = cloud.at (u, v);
      const std::uint16_t mm = depth.at (u, v);
      if (mm == 0)
      {
        p.x = p.y = p.z = nan;
        continue;
      }
      const float z = mm * 0.001f;
      const Eigen::Vector3f pc ((u - K.cx) / K.fx * z, (v - K.cy) / K.fy * z, z);
      p.getVector3fMap () = camera_to_world * pc;
    }
  return cloud;
}

Eigen::Isometry3f
lookAt (const Eigen::Vector3f& eye, const Eigen::Vector3f& target, const Eigen::Vector3f& up)
{
  const Eigen::Vector3f z = (target - eye).normalized ();
  Eigen::Vector3f x = z.cross (up);
  if (x.norm () < 1e-6f)  // looking along `up`: pick any perpendicular
    x = z.unitOrthogonal ();
  x.normalize ();
  const Eigen::Vector3f y = z.cross (x);  // camera y points down in the image
  Eigen::Isometry3f T = Eigen::Isometry3f::Identity ();
  T.linear ().col (0) = x;
  T.linear ().col (1) = y;
  T.linear ().col (2) = z;
  T.translation () = eye;
  return T;
}

}  // namespace testing
}  // namespace pclx
