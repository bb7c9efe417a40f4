#pragma once
// The Potree 2.0 file format as PotreeConverter 2.x writes it and potree's 2.0 loader reads it
// (PotreeConverter Converter/src/indexer.cpp createHierarchy / writeMetadata and
// Converter/include/HierarchyBuilder.h; potree src/modules/loader/2.0/OctreeLoader.js
// parseHierarchy). Shared by pcl::PotreeWriter and pcl::PotreeReader.
//
//   metadata.json  version "2.0", points, hierarchy {firstChunkSize, stepSize, depth}, offset,
//                  scale, spacing, boundingBox (the root cube), encoding "DEFAULT", attributes
//                  (position int32 × 3, scaled; optionally rgb uint16 × 3 and intensity; a
//                  reader skips the attributes it does not use by their size)
//   hierarchy.bin  chunks of 22-byte little-endian records {uint8 type, uint8 childMask,
//                  uint32 numPoints, int64 byteOffset, int64 byteSize}, breadth-first from the
//                  chunk root down to stepSize levels below it. A node on that last level that
//                  has children is a proxy (type 2): its offset/size locate its own chunk in
//                  hierarchy.bin, whose first record is the node again with its real type.
//                  The root chunk comes first (firstChunkSize bytes).
//   octree.bin     per node numPoints records, attributes interleaved per point.
// Node names: "r" and one digit per level, the child index (x << 2) | (y << 1) | z, which is
// MortonCode's child index.
#include <pclx/omicron/morton_code.h>

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

namespace pclx {
namespace omicron {
namespace detail {
namespace potree {

using pcl::MortonCode;

enum NodeType : std::uint8_t
{
  kNormal = 0,
  kLeaf = 1,
  kProxy = 2
};
constexpr std::size_t kRecordBytes = 22;

// The scalar types an attribute may have, by their names in metadata.json.
enum class ScalarType : std::uint8_t
{
  kInt8,
  kUInt8,
  kInt16,
  kUInt16,
  kInt32,
  kUInt32,
  kInt64,
  kUInt64,
  kFloat,
  kDouble
};
// Throws std::runtime_error on a name that is not a Potree type.
ScalarType scalarTypeFromName (const std::string& name);
const char* scalarTypeName (ScalarType type);
std::size_t scalarTypeSize (ScalarType type);
// The little-endian value of `type` at `p`.
double scalarAt (const std::uint8_t* p, ScalarType type);

// One node as stored in octree.bin.
struct NodeRecord
{
  MortonCode code;
  std::uint32_t num_points = 0;
  std::uint64_t byte_offset = 0, byte_size = 0;
};

struct Metadata
{
  std::string name, description, projection;
  std::uint64_t points = 0;
  std::uint64_t first_chunk_size = 0;
  int step_size = 4, depth = 0;
  Eigen::Vector3d offset = Eigen::Vector3d::Zero (), scale = Eigen::Vector3d::Constant (0.001);
  double spacing = 0;
  Eigen::Vector3d box_min = Eigen::Vector3d::Zero (), box_max = Eigen::Vector3d::Zero ();
  Eigen::Vector3d position_min = Eigen::Vector3d::Zero (), position_max = Eigen::Vector3d::Zero ();
  bool rgb = false;
  // Intensity: written as float, PCL's type, so no value is rounded; read in any scalar type
  // (PotreeConverter stores LAS intensity as uint16). Its range over the finite values.
  bool intensity = false;
  ScalarType intensity_type = ScalarType::kFloat;
  double intensity_min = 0, intensity_max = 0;
  // A point record's layout: where rgb and intensity start, and its size (the attributes
  // neither is, such as PotreeConverter's classification or gps-time, only take their bytes).
  std::uint32_t rgb_offset = 0, intensity_offset = 0, record_bytes = 12;

  std::uint32_t bytesPerPoint () const { return record_bytes; }
  // The layout PotreeWriter writes: position, then rgb, then intensity, each when on.
  void setWrittenAttributes (bool with_rgb, bool with_intensity);
};

// std::llround (half away from zero) without its libm call on baseline x86-64: for |x| < 2^52,
// x - trunc (x) is exact, so the result is llround's.
inline std::int64_t
roundHalfAway (double x)
{
  const auto t = static_cast<std::int64_t> (x);
  const double f = x - static_cast<double> (t);
  return t + (f >= 0.5 ? 1 : 0) - (f <= -0.5 ? 1 : 0);
}

std::string nodeName (MortonCode code);
// Throws std::runtime_error on a malformed name.
MortonCode codeFromName (const std::string& name);

// Writes hierarchy.bin for `records` (any order; every node's parent must be present) and
// returns firstChunkSize and depth through `meta`. Nodes whose subtree holds no point are
// left out. Throws std::runtime_error (caught by PotreeWriter).
void writeHierarchy (const std::string& path, const std::vector<NodeRecord>& records, Metadata& meta);
void writeMetadata (const std::string& path, const Metadata& meta);

// Throws std::runtime_error with the reason on anything malformed (caught by PotreeReader).
Metadata readMetadata (const std::string& path);

}  // namespace potree
}  // namespace detail
}  // namespace omicron
}  // namespace pclx
