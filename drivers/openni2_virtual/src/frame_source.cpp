#include "frame_source.h"

#include "png_io.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

namespace fs = std::filesystem;

namespace pclx {
namespace openni2_virtual {

float
CameraModel::horizontalFov () const
{
  return float (2.0 * std::atan (width / (2.0 * fx)));
}

float
CameraModel::verticalFov () const
{
  return float (2.0 * std::atan (height / (2.0 * fy)));
}

std::vector<std::pair<int, int>>
FrameSource::resolutions () const
{
  const CameraModel& c = camera ();
  std::vector<std::pair<int, int>> r{{c.width, c.height}};
  if (c.width % 2 == 0 && c.height % 2 == 0 && c.width >= 320)
    r.emplace_back (c.width / 2, c.height / 2);
  return r;
}

void
shadeFromDepth (const std::vector<std::uint16_t>& depth, int width, int height, double fx, double fy, double cx,
                double cy, std::vector<std::uint8_t>& rgb)
{
  rgb.assign (std::size_t (width) * std::size_t (height) * 3, 0);
  auto point = [&] (int u, int v, double z) {
    return std::array<double, 3>{(u - cx) * z / fx, (v - cy) * z / fy, z};
  };
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u)
    {
      const std::size_t i = std::size_t (v) * width + u;
      if (depth[i] == 0)
        continue;
      // Forward differences where possible, backward at the right/bottom border or a hole.
      const int du = (u + 1 < width && depth[i + 1] != 0) ? 1 : (u > 0 && depth[i - 1] != 0 ? -1 : 0);
      const int dv = (v + 1 < height && depth[i + width] != 0) ? 1 : (v > 0 && depth[i - width] != 0 ? -1 : 0);
      const double z = depth[i] * 1e-3;
      double shade = 0.6;
      if (du != 0 && dv != 0)
      {
        const auto p = point (u, v, z);
        const auto a = point (u + du, v, depth[i + du] * 1e-3);
        const auto b = point (u, v + dv, depth[i + std::ptrdiff_t (dv) * width] * 1e-3);
        const double e1[3] = {a[0] - p[0], a[1] - p[1], a[2] - p[2]};
        const double e2[3] = {b[0] - p[0], b[1] - p[1], b[2] - p[2]};
        const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                             e1[0] * e2[1] - e1[1] * e2[0]};
        const double nl = std::sqrt (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        const double pl = std::sqrt (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
        if (nl > 0 && pl > 0)
          shade = 0.15 + 0.85 * std::abs ((n[0] * p[0] + n[1] * p[1] + n[2] * p[2]) / (nl * pl));
      }
      // A slight warm-to-cool tint with distance keeps depth readable in the colour image.
      const double t = std::min (1.0, z / 6.0);
      rgb[3 * i] = std::uint8_t (std::lround (255.0 * shade * (1.0 - 0.35 * t)));
      rgb[3 * i + 1] = std::uint8_t (std::lround (255.0 * shade * 0.9));
      rgb[3 * i + 2] = std::uint8_t (std::lround (255.0 * shade * (0.65 + 0.35 * t)));
    }
}

// ----------------------------------------------------------------------------------------------
// Configuration

namespace {

std::string
trim (const std::string& s)
{
  std::size_t b = 0, e = s.size ();
  while (b < e && std::isspace (static_cast<unsigned char> (s[b])))
    ++b;
  while (e > b && std::isspace (static_cast<unsigned char> (s[e - 1])))
    --e;
  return s.substr (b, e - b);
}

bool
isOff (std::string v)
{
  std::transform (v.begin (), v.end (), v.begin (), [] (unsigned char c) { return char (std::tolower (c)); });
  return v == "0" || v == "off" || v == "false" || v == "no";
}

}  // namespace

SourceConfig
readConfig ()
{
  SourceConfig cfg;
  const char* conf_env = std::getenv ("PCLX_VIRTUAL_CAMERA_CONF");
  const std::string conf = conf_env ? conf_env : "/etc/pclx/virtual_camera.conf";
  std::ifstream in (conf);
  std::string line;
  while (std::getline (in, line))
  {
    line = trim (line.substr (0, line.find ('#')));
    const std::size_t eq = line.find ('=');
    if (eq == std::string::npos)
      continue;
    const std::string key = trim (line.substr (0, eq)), value = trim (line.substr (eq + 1));
    if (key == "dir")
    {
      cfg.dir = value;
      cfg.origin = conf;
    }
    else if (key == "enabled")
      cfg.enabled = !isOff (value);
  }
  if (const char* dir = std::getenv ("PCLX_VIRTUAL_CAMERA_DIR"))
  {
    // Set but empty selects the generated scene even when the file names a folder.
    cfg.dir = dir;
    cfg.origin = "PCLX_VIRTUAL_CAMERA_DIR";
  }
  if (const char* on = std::getenv ("PCLX_VIRTUAL_CAMERA"))
    cfg.enabled = !isOff (on);
  return cfg;
}

std::unique_ptr<FrameSource>
openSource (const SourceConfig& config, std::string& error)
{
  if (config.dir.empty ())
    return makeGeneratedSource ();
  std::unique_ptr<FrameSource> s = openFolderSource (config.dir, error);
  if (!s)
    error += " (folder set by " + config.origin + ")";
  return s;
}

// ----------------------------------------------------------------------------------------------
// Recorded folder: frame-NNNNNN.depth.png [+ frame-NNNNNN.color.png], camera-intrinsics.txt

namespace {

class FolderSource : public FrameSource
{
public:
  struct Entry
  {
    std::string depth, colour;  // colour empty when not recorded
  };

  FolderSource (std::string dir, std::vector<Entry> frames, CameraModel cam, bool any_colour)
    : dir_ (std::move (dir)), frames_ (std::move (frames)), cam_ (cam), any_colour_ (any_colour)
  {}

  const CameraModel&
  camera () const override
  {
    return cam_;
  }

  bool
  colourRegistered () const override
  {
    // Recorded colour comes from a second camera (7-Scenes does not register it to depth).
    return !any_colour_;
  }

  int
  maxDepth () const override
  {
    return 65534;  // recordings are passed through unchanged; 65535 is "no data"
  }

  std::string
  description () const override
  {
    return "recording " + dir_ + " (" + std::to_string (frames_.size ()) + " frames, " +
           std::to_string (cam_.width) + "x" + std::to_string (cam_.height) +
           (any_colour_ ? ", colour" : ", colour shaded from depth") + ")";
  }

  bool
  present () const override
  {
    std::error_code ec;
    return fs::is_directory (dir_, ec);
  }

  bool
  render (std::uint64_t index, int width, int height, bool colour, Frame& out, std::string& error) override
  {
    const Entry& e = frames_[index % frames_.size ()];
    int w = 0, h = 0;
    if (!readPngDepth (e.depth, native_, w, h, error))
      return false;
    if (w != cam_.width || h != cam_.height)
    {
      error = e.depth + " is " + std::to_string (w) + "x" + std::to_string (h) + ", the recording is " +
              std::to_string (cam_.width) + "x" + std::to_string (cam_.height);
      return false;
    }
    // 7-Scenes marks missing depth with 65535; OpenNI's convention is 0.
    for (auto& d : native_)
      if (d == 65535)
        d = 0;
    const int factor = width == w ? 1 : 2;
    if (width * factor != w || height * factor != h)
    {
      error = "unsupported output size " + std::to_string (width) + "x" + std::to_string (height);
      return false;
    }
    out.width = width;
    out.height = height;
    if (factor == 1)
      out.depth = native_;
    else
    {
      // Nearest valid: the first non-zero sample of each 2x2 block, scanned row by row.
      out.depth.assign (std::size_t (width) * height, 0);
      for (int v = 0; v < height; ++v)
        for (int u = 0; u < width; ++u)
        {
          const std::size_t i = std::size_t (2 * v) * w + 2 * u;
          const std::uint16_t c[4] = {native_[i], native_[i + 1], native_[i + w], native_[i + w + 1]};
          for (std::uint16_t d : c)
            if (d != 0)
            {
              out.depth[std::size_t (v) * width + u] = d;
              break;
            }
        }
    }
    out.rgb.clear ();
    if (!colour)
      return true;
    if (e.colour.empty ())
    {
      shadeFromDepth (out.depth, width, height, cam_.fx / factor, cam_.fy / factor, cam_.cx / factor,
                      cam_.cy / factor, out.rgb);
      return true;
    }
    int cw = 0, ch = 0;
    if (!readPngRgb (e.colour, colour_, cw, ch, error))
      return false;
    // Nearest-neighbour resampling to the output size (the colour camera may differ in size).
    out.rgb.resize (std::size_t (width) * height * 3);
    for (int v = 0; v < height; ++v)
    {
      const int sv = std::min (ch - 1, int ((v + 0.5) * ch / height));
      for (int u = 0; u < width; ++u)
      {
        const int su = std::min (cw - 1, int ((u + 0.5) * cw / width));
        std::copy_n (&colour_[(std::size_t (sv) * cw + su) * 3], 3, &out.rgb[(std::size_t (v) * width + u) * 3]);
      }
    }
    return true;
  }

private:
  std::string dir_;
  std::vector<Entry> frames_;
  CameraModel cam_;
  bool any_colour_;
  std::vector<std::uint16_t> native_;  // decode buffers reused between frames
  std::vector<std::uint8_t> colour_;
};

bool
readIntrinsics (const std::string& path, CameraModel& cam, std::string& error)
{
  std::ifstream in (path);
  std::vector<double> k;
  double x;
  while (in >> x)
    k.push_back (x);
  if (k.size () != 9 || !(k[0] > 0) || !(k[4] > 0) || !std::isfinite (k[2]) || !std::isfinite (k[5]))
  {
    error = path + " does not hold a 3x3 camera matrix (fx 0 cx / 0 fy cy / 0 0 1)";
    return false;
  }
  cam.fx = k[0];
  cam.cx = k[2];
  cam.fy = k[4];
  cam.cy = k[5];
  return true;
}

}  // namespace

std::unique_ptr<FrameSource>
openFolderSource (const std::string& dir, std::string& error)
{
  std::error_code ec;
  if (!fs::is_directory (dir, ec))
  {
    error = "recording folder " + dir + " does not exist or is not a folder";
    return nullptr;
  }
  // frame-<digits>.depth.png
  const std::string prefix = "frame-", suffix = ".depth.png";
  std::vector<std::pair<long long, std::string>> numbered;
  for (fs::directory_iterator it (dir, ec), end; !ec && it != end; it.increment (ec))
  {
    const std::string name = it->path ().filename ().string ();
    if (name.size () <= prefix.size () + suffix.size () || name.compare (0, prefix.size (), prefix) != 0 ||
        name.compare (name.size () - suffix.size (), suffix.size (), suffix) != 0)
      continue;
    const std::string digits = name.substr (prefix.size (), name.size () - prefix.size () - suffix.size ());
    if (digits.size () > 12 || !std::all_of (digits.begin (), digits.end (), [] (unsigned char c) { return std::isdigit (c); }))
      continue;
    numbered.emplace_back (std::stoll (digits), it->path ().string ());
  }
  if (ec)
  {
    error = "cannot list " + dir + ": " + ec.message ();
    return nullptr;
  }
  if (numbered.empty ())
  {
    error = "no frame-NNNNNN.depth.png files in " + dir;
    return nullptr;
  }
  std::sort (numbered.begin (), numbered.end ());

  // Every header now (cheap), so a bad file is reported at open and not as a mid-stream failure.
  std::vector<FolderSource::Entry> frames;
  PngInfo first;
  bool any_colour = false;
  for (const auto& [number, path] : numbered)
  {
    PngInfo info;
    if (!readPngInfo (path, info, error))
      return nullptr;
    if (info.bit_depth != 16 || info.channels != 1)
    {
      error = path + " is not a 16-bit grayscale PNG (" + std::to_string (info.bit_depth) + " bits, " +
              std::to_string (info.channels) + " channels)";
      return nullptr;
    }
    if (frames.empty ())
      first = info;
    else if (info.width != first.width || info.height != first.height)
    {
      error = path + " is " + std::to_string (info.width) + "x" + std::to_string (info.height) +
              ", the first frame is " + std::to_string (first.width) + "x" + std::to_string (first.height);
      return nullptr;
    }
    FolderSource::Entry e{path, {}};
    const std::string colour = path.substr (0, path.size () - std::string ("depth.png").size ()) + "color.png";
    if (fs::exists (colour, ec))
    {
      if (!readPngInfo (colour, info, error))
        return nullptr;
      e.colour = colour;
      any_colour = true;
    }
    frames.push_back (std::move (e));
  }

  // 7-Scenes intrinsics (fx = fy = 585, centre at the image centre) unless the folder has its own.
  CameraModel cam;
  cam.width = first.width;
  cam.height = first.height;
  cam.fx = cam.fy = 585.0 * first.width / 640.0;
  cam.cx = first.width / 2.0;
  cam.cy = first.height / 2.0;
  const std::string intrinsics = (fs::path (dir) / "camera-intrinsics.txt").string ();
  if (fs::exists (intrinsics, ec) && !readIntrinsics (intrinsics, cam, error))
    return nullptr;

  auto source = std::make_unique<FolderSource> (dir, std::move (frames), cam, any_colour);
  // Decode the first frame completely: a header can be fine and the data still corrupt.
  Frame probe;
  if (!source->render (0, cam.width, cam.height, true, probe, error))
    return nullptr;
  return source;
}

}  // namespace openni2_virtual
}  // namespace pclx
