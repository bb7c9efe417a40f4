#pragma once
// Open3D's ScalableTSDFVolume (CPU) + marching cubes, the peer of bench_idc, isolated in its own
// translation unit (Open3D's headers bring their own Eigen settings; see bench/normals).
#include <Eigen/Core>

#include <cstdint>
#include <memory>
#include <vector>

namespace idc_open3d {

class Tsdf
{
public:
  // voxel and sdf_trunc in metres; depths beyond depth_trunc are ignored.
  Tsdf (double voxel, double sdf_trunc, double depth_trunc);
  ~Tsdf ();
  // 16-bit depth in millimetres, camera-to-world pose; returns seconds.
  double integrate (const std::uint16_t* mm, int width, int height, double fx, double fy, double cx, double cy,
                    const Eigen::Matrix4d& camera_to_world);
  // Marching cubes over the volume; returns seconds.
  double extract (std::vector<Eigen::Vector3f>& vertices, std::vector<Eigen::Vector3i>& faces);
  std::size_t volumeUnits () const;
  // Bytes of the voxel blocks (their allocated capacity), counted without asking the allocator.
  std::size_t voxelBytes () const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace idc_open3d
