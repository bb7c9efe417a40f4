// PNG reading and writing for the virtual camera (libpng, classic API).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace pclx {
namespace openni2_virtual {

struct PngInfo
{
  int width = 0;
  int height = 0;
  int bit_depth = 0;
  int channels = 0;  // 1 gray, 2 gray+alpha, 3 RGB, 4 RGBA (palette counts as 3)
};

// Reads only the signature and IHDR: cheap enough to validate a whole recording at open.
bool
readPngInfo (const std::string& path, PngInfo& info, std::string& error);

// A 16-bit single-channel PNG (depth in millimetres), host byte order.
bool
readPngDepth (const std::string& path, std::vector<std::uint16_t>& depth, int& width, int& height,
              std::string& error);

// Any PNG as packed 8-bit RGB (palette and gray expanded, alpha dropped, 16 bits reduced).
bool
readPngRgb (const std::string& path, std::vector<std::uint8_t>& rgb, int& width, int& height,
            std::string& error);

bool
writePngDepth (const std::string& path, const std::vector<std::uint16_t>& depth, int width, int height,
               std::string& error);

bool
writePngRgb (const std::string& path, const std::vector<std::uint8_t>& rgb, int width, int height,
             std::string& error);

}  // namespace openni2_virtual
}  // namespace pclx
