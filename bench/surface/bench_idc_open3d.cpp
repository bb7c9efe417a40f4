#include "bench_idc_open3d.h"

#include <open3d/camera/PinholeCameraIntrinsic.h>
#include <open3d/geometry/Image.h>
#include <open3d/geometry/RGBDImage.h>
#include <open3d/geometry/TriangleMesh.h>
#include <open3d/pipelines/integration/ScalableTSDFVolume.h>
#include <open3d/pipelines/integration/UniformTSDFVolume.h>
#include <open3d/utility/Logging.h>

#include <chrono>
#include <cstring>

namespace idc_open3d {

struct Tsdf::Impl
{
  open3d::pipelines::integration::ScalableTSDFVolume volume;
  double depth_trunc;
  open3d::geometry::Image depth, color;
  Impl (double voxel, double trunc, double dt)
    : volume (voxel, trunc, open3d::pipelines::integration::TSDFVolumeColorType::NoColor), depth_trunc (dt)
  {}
};

Tsdf::Tsdf (double voxel, double sdf_trunc, double depth_trunc)
  : impl_ (std::make_unique<Impl> (voxel, sdf_trunc, depth_trunc))
{
  open3d::utility::SetVerbosityLevel (open3d::utility::VerbosityLevel::Error);
}

Tsdf::~Tsdf () = default;

double
Tsdf::integrate (const std::uint16_t* mm, int width, int height, double fx, double fy, double cx, double cy,
                 const Eigen::Matrix4d& camera_to_world)
{
  Impl& d = *impl_;
  const auto t0 = std::chrono::steady_clock::now ();
  // The time includes wrapping the image (what an Open3D user does per frame).
  if (d.depth.width_ != width || d.depth.height_ != height)
  {
    d.depth.Prepare (width, height, 1, 2);
    d.color.Prepare (width, height, 3, 1);  // unused (NoColor) but RGBDImage wants one
  }
  std::memcpy (d.depth.data_.data (), mm, static_cast<std::size_t> (width) * height * 2);
  const auto rgbd = open3d::geometry::RGBDImage::CreateFromColorAndDepth (d.color, d.depth, 1000.0, d.depth_trunc, false);
  const open3d::camera::PinholeCameraIntrinsic K (width, height, fx, fy, cx, cy);
  d.volume.Integrate (*rgbd, K, camera_to_world.inverse ());  // Open3D wants world-to-camera
  return std::chrono::duration<double> (std::chrono::steady_clock::now () - t0).count ();
}

double
Tsdf::extract (std::vector<Eigen::Vector3f>& vertices, std::vector<Eigen::Vector3i>& faces)
{
  const auto t0 = std::chrono::steady_clock::now ();
  const auto mesh = impl_->volume.ExtractTriangleMesh ();
  const double s = std::chrono::duration<double> (std::chrono::steady_clock::now () - t0).count ();
  vertices.clear ();
  for (const auto& v : mesh->vertices_)
    vertices.push_back (v.cast<float> ());
  faces.assign (mesh->triangles_.begin (), mesh->triangles_.end ());
  return s;
}

std::size_t
Tsdf::volumeUnits () const
{
  return impl_->volume.volume_units_.size ();
}

std::size_t
Tsdf::voxelBytes () const
{
  std::size_t bytes = 0;
  for (const auto& unit : impl_->volume.volume_units_)
    if (unit.second.volume_)
      bytes += unit.second.volume_->voxels_.capacity () * sizeof (open3d::geometry::TSDFVoxel);
  return bytes;
}

}  // namespace idc_open3d
