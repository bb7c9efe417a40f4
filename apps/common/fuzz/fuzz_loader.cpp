// libFuzzer target for the kit's loader: the first byte picks the format (PCD, PLY, XYZ,
// 16-bit depth PNG), the rest is the file. Built by scripts/fuzz-loader.sh with clang.
// Any input must end in a cloud or a LoadError, never a crash, a hang or a huge allocation.
#include <pclx/apps/cloud_loader.h>
#include <pclx/apps/depth_frames.h>

#include <pcl/console/print.h>
#include <pcl/point_types.h>

#include <cstdint>
#include <fstream>
#include <string>
#include <unistd.h>

extern "C" int
LLVMFuzzerTestOneInput (const std::uint8_t* data, std::size_t size)
{
  if (size < 1)
    return 0;
  static const char* ext[] = {".pcd", ".ply", ".xyz", ".depth.png"};
  static const std::string base = "/dev/shm/pclx_fuzz_" + std::to_string (getpid ());
  const std::string path = base + ext[data[0] % 4];
  {
    std::ofstream out (path, std::ios::binary | std::ios::trunc);
    out.write (reinterpret_cast<const char*> (data + 1), static_cast<std::streamsize> (size - 1));
  }
  try
  {
    if (data[0] % 4 == 3)
    {
      const auto img = pclx::apps::readDepthPng (path);
      pclx::apps::depthToCloud (img, pclx::apps::DepthIntrinsics{500.f, 500.f, 10.f, 10.f});
    }
    else
    {
      pclx::apps::CloudInfo info;
      const auto blob = pclx::apps::loadCloudBlob (path, &info);
      pclx::apps::toCloud<pcl::PointXYZRGBA> (*blob);
      pclx::apps::toCloud<pcl::PointNormal> (*blob);
      pclx::apps::toCloud<pcl::PointXYZI> (*blob);
    }
  }
  catch (const pclx::apps::LoadError&)
  {
  }
  std::remove (path.c_str ());
  return 0;
}
