#pragma once
// Checks a point cloud file before PCL's readers see it. PCL 1.13 trusts the header: a 0- or
// 1-byte .pcd segfaults PCDReader, and a declared point count larger than the file makes it
// read past the end or allocate without bound. Every problem becomes a LoadError with a
// one-line message.
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace pclx {
namespace apps {

// Every loader failure: "<path>: <what is wrong>", one line.
class LoadError : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

enum class CloudFormat { PCD, PLY, XYZ };

// What the header declares (nothing of the data is read).
struct FileCheck
{
  CloudFormat format = CloudFormat::PCD;
  std::uintmax_t file_size = 0;
  std::uint64_t points = 0;        // PCD POINTS, PLY vertex count; XYZ: 0 (one point a line)
  std::uint32_t width = 0, height = 0;  // PCD WIDTH / HEIGHT; PLY: points × 1
  std::string encoding;            // ascii, binary, binary_compressed, binary_little_endian, ...
  std::vector<std::string> fields; // PCD FIELDS, PLY vertex properties
  bool ply_camera = false;         // the PLY carries PCL's `camera` element
};

// Point counts above this are refused whatever the file size (PCL indexes points with int).
constexpr std::uint64_t kMaxPoints = (std::uint64_t (1) << 31) - 1;

// The format from the extension (.pcd, .ply, .xyz; any case); throws LoadError otherwise.
CloudFormat formatFromPath (const std::string& path);

// A regular, non-empty file whose header is well formed and whose declared points fit
// in its size (binary: the exact byte count; binary_compressed: the compressed block;
// ascii: at least two bytes per value). Throws LoadError.
FileCheck checkCloudFile (const std::string& path);

// The same checks on bytes in memory (`path` only names the file in messages).
FileCheck checkCloudBytes (const std::string& path, CloudFormat format, const std::string& head,
                           std::uintmax_t file_size);

}  // namespace apps
}  // namespace pclx
