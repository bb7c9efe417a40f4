#include <pclx/apps/depth_frames.h>
#include <pclx/apps/file_check.h>

#include <pcl/common/transforms.h>

#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>

namespace pclx {
namespace apps {

namespace {

namespace fs = std::filesystem;

// A depth image above this is refused before decoding (a corrupt header could ask for more).
constexpr std::uint64_t kMaxPixels = 64ull << 20;

const std::string kPngSuffix = ".depth.png";

// Numbers of a small text file (intrinsics, poses); throws unless it has exactly `n`.
std::vector<double>
readNumbers (const std::string& path, std::size_t n)
{
  std::error_code ec;
  if (!fs::is_regular_file (path, ec))
    throw LoadError (path + ": no such file");
  std::ifstream in (path);
  std::vector<double> v;
  for (std::string w; in >> w && v.size () <= n;)
  {
    char* end = nullptr;
    const double x = std::strtod (w.c_str (), &end);
    if (end == w.c_str () || *end != '\0' || !std::isfinite (x))
      throw LoadError (path + ": '" + w.substr (0, 20) + "' is not a number");
    v.push_back (x);
  }
  if (v.size () != n)
    throw LoadError (path + ": expected " + std::to_string (n) + " numbers");
  return v;
}

}  // namespace

DepthImage16
readDepthPng (const std::string& path)
{
  // libpng's simplified API reports errors in image.message instead of longjmp.
  png_image png;
  std::memset (&png, 0, sizeof png);
  png.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file (&png, path.c_str ()))
    throw LoadError (path + ": not a readable PNG (" + png.message + ")");
  struct Guard
  {
    png_image* p;
    ~Guard () { png_image_free (p); }
  } guard{&png};
  // 16-bit grey without alpha; 16-bit data without gAMA/sRGB is read as linear (unchanged).
  if (png.format != PNG_FORMAT_LINEAR_Y)
    throw LoadError (path + ": not a 16-bit grey PNG (depth in millimetres)");
  if (png.width == 0 || png.height == 0 || std::uint64_t (png.width) * png.height > kMaxPixels)
    throw LoadError (path + ": absurd size " + std::to_string (png.width) + " x " + std::to_string (png.height));
  DepthImage16 img;
  img.width = static_cast<int> (png.width);
  img.height = static_cast<int> (png.height);
  img.mm.resize (std::size_t (png.width) * png.height);
  if (!png_image_finish_read (&png, nullptr, img.mm.data (), 0, nullptr))
    throw LoadError (path + ": corrupt PNG data (" + png.message + ")");
  return img;
}

void
writeDepthPng (const std::string& path, const DepthImage16& image)
{
  png_image png;
  std::memset (&png, 0, sizeof png);
  png.version = PNG_IMAGE_VERSION;
  png.width = static_cast<png_uint_32> (image.width);
  png.height = static_cast<png_uint_32> (image.height);
  png.format = PNG_FORMAT_LINEAR_Y;
  if (!png_image_write_to_file (&png, path.c_str (), 0, image.mm.data (), 0, nullptr))
    throw std::runtime_error (path + ": cannot write PNG (" + png.message + ")");
}

DepthIntrinsics
readIntrinsics (const std::string& path)
{
  const auto v = readNumbers (path, 9);
  DepthIntrinsics k{float (v[0]), float (v[4]), float (v[2]), float (v[5])};
  if (!(k.fx > 0) || !(k.fy > 0) || v[1] != 0 || v[3] != 0 || v[6] != 0 || v[7] != 0 || v[8] != 1)
    throw LoadError (path + ": not a pinhole matrix (fx 0 cx / 0 fy cy / 0 0 1)");
  return k;
}

void
writeIntrinsics (const std::string& path, const DepthIntrinsics& k)
{
  std::ofstream out (path);
  out.precision (9);
  out << k.fx << " 0 " << k.cx << "\n0 " << k.fy << " " << k.cy << "\n0 0 1\n";
  if (!out)
    throw std::runtime_error (path + ": cannot write");
}

Eigen::Matrix4f
readPose (const std::string& path)
{
  const auto v = readNumbers (path, 16);
  Eigen::Matrix4f m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      m (r, c) = float (v[std::size_t (4 * r + c)]);
  return m;
}

void
writePose (const std::string& path, const Eigen::Matrix4f& camera_to_world)
{
  std::ofstream out (path);
  out.precision (9);
  for (int r = 0; r < 4; ++r)
    out << camera_to_world (r, 0) << " " << camera_to_world (r, 1) << " " << camera_to_world (r, 2) << " "
        << camera_to_world (r, 3) << "\n";
  if (!out)
    throw std::runtime_error (path + ": cannot write");
}

pcl::PointCloud<pcl::PointXYZ>::Ptr
depthToCloud (const DepthImage16& image, const DepthIntrinsics& k)
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud (new pcl::PointCloud<pcl::PointXYZ> (
      static_cast<std::uint32_t> (image.width), static_cast<std::uint32_t> (image.height)));
  const float nan = std::numeric_limits<float>::quiet_NaN ();
  bool dense = true;
  for (int v = 0; v < image.height; ++v)
    for (int u = 0; u < image.width; ++u)
    {
      const std::uint16_t d = image.mm[std::size_t (v) * image.width + u];
      pcl::PointXYZ& p = (*cloud) (static_cast<std::size_t> (u), static_cast<std::size_t> (v));
      if (d == 0 || d == 65535)
      {
        p.x = p.y = p.z = nan;
        dense = false;
        continue;
      }
      const float z = d * 0.001f;
      p.x = (float (u) - k.cx) * z / k.fx;
      p.y = (float (v) - k.cy) * z / k.fy;
      p.z = z;
    }
  cloud->is_dense = dense;
  return cloud;
}

DepthFrameFolder::DepthFrameFolder (const std::string& dir) : dir_ (dir)
{
  std::error_code ec;
  if (!fs::is_directory (dir, ec))
    throw LoadError (dir + ": not a folder of depth frames");
  for (const auto& e : fs::directory_iterator (dir, ec))
  {
    const std::string name = e.path ().filename ().string ();
    if (name.size () > kPngSuffix.size () && name.rfind ("frame-", 0) == 0 &&
        name.compare (name.size () - kPngSuffix.size (), kPngSuffix.size (), kPngSuffix) == 0)
      frames_.push_back (e.path ().string ());
  }
  if (ec)
    throw LoadError (dir + ": cannot list (" + ec.message () + ")");
  std::sort (frames_.begin (), frames_.end ());
  if (frames_.empty ())
    throw LoadError (dir + ": no frame-*.depth.png files");
  k_ = readIntrinsics ((fs::path (dir) / "camera-intrinsics.txt").string ());
}

bool
DepthFrameFolder::pose (std::size_t i, Eigen::Matrix4f& camera_to_world) const
{
  const std::string png = framePath (i);
  const std::string path = png.substr (0, png.size () - kPngSuffix.size ()) + ".pose.txt";
  std::error_code ec;
  if (!fs::exists (path, ec))
    return false;
  camera_to_world = readPose (path);
  return true;
}

pcl::PointCloud<pcl::PointXYZ>::Ptr
DepthFrameFolder::load (std::size_t i, bool world) const
{
  auto cloud = depthToCloud (readDepthPng (framePath (i)), k_);
  Eigen::Matrix4f pose;
  if (world && this->pose (i, pose))
    pcl::transformPointCloud (*cloud, *cloud, pose);
  return cloud;
}

}  // namespace apps
}  // namespace pclx
