// Where the virtual camera's frames come from: a recorded folder (7-Scenes layout) or a
// scene rendered analytically inside the driver. Independent of OpenNI so it can be tested alone.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace pclx {
namespace openni2_virtual {

// Pinhole model at the source's native resolution.
struct CameraModel
{
  int width = 640;
  int height = 480;
  double fx = 585.0, fy = 585.0, cx = 320.0, cy = 240.0;

  float
  horizontalFov () const;
  float
  verticalFov () const;
};

struct Frame
{
  int width = 0;
  int height = 0;
  std::vector<std::uint16_t> depth;  // millimetres, 0 = no data
  std::vector<std::uint8_t> rgb;     // packed RGB888, empty unless asked for
};

class FrameSource
{
public:
  virtual ~FrameSource () = default;

  virtual const CameraModel&
  camera () const = 0;

  // Output resolutions, native first; the second (if any) is half the native size.
  std::vector<std::pair<int, int>>
  resolutions () const;

  // True when colour pixels line up with depth pixels (rendered or synthesised colour).
  virtual bool
  colourRegistered () const = 0;

  virtual int
  maxDepth () const = 0;

  virtual std::string
  description () const = 0;

  // Frame `index` (0-based, loops over the recording) at one of resolutions ().
  virtual bool
  render (std::uint64_t index, int width, int height, bool colour, Frame& out, std::string& error) = 0;

  // False once a recorded folder has gone (the "unplugged" case).
  virtual bool
  present () const
  {
    return true;
  }
};

struct SourceConfig
{
  bool enabled = true;
  std::string dir;     // empty: the generated scene
  std::string origin;  // where `dir` came from, for messages
};

// PCLX_VIRTUAL_CAMERA (0 hides the device), PCLX_VIRTUAL_CAMERA_DIR (overrides the file),
// the config file (PCLX_VIRTUAL_CAMERA_CONF or /etc/pclx/virtual_camera.conf: `dir = <folder>`,
// `enabled = 0|1`).
SourceConfig
readConfig ();

std::unique_ptr<FrameSource>
openSource (const SourceConfig& config, std::string& error);

std::unique_ptr<FrameSource>
makeGeneratedSource ();

std::unique_ptr<FrameSource>
openFolderSource (const std::string& dir, std::string& error);

// Lambertian shading of the depth map's own normals (for recordings without colour).
void
shadeFromDepth (const std::vector<std::uint16_t>& depth, int width, int height, double fx, double fy, double cx,
                double cy, std::vector<std::uint8_t>& rgb);

}  // namespace openni2_virtual
}  // namespace pclx
