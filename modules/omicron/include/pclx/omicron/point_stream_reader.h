#pragma once
// pcl::PointStreamReader: reads a point cloud file in chunks, so a file larger than memory can
// be streamed (the out-of-core build of pcl::ObliqueCutOctree reads its input twice through it).
//
//   pcl::PointStreamReader reader ("scan.ply");        // throws pcl::IOException
//   pcl::PointCloud<pcl::PointXYZRGB> chunk;
//   while (reader.read (1 << 20, chunk))
//     use (chunk);                                      // finite points only
//
// Formats: PCD (ascii, binary; binary_compressed is decompressed whole, its format has no
// smaller unit), PLY (ascii, binary little/big endian; vertex x/y/z of any scalar type plus
// optional red/green/blue), and .xyz text ("x y z [r g b]" per line, commas or white space,
// '#' comments). Positions and colour are read; other fields are skipped.
//
// The headers are parsed here rather than by pcl::PCDReader::readHeader: PCL 1.13 crashes on
// 0- and 1-byte PCD files and trusts the declared counts (see apps/common/file_check.h).
// Empty, truncated or malformed files throw pcl::IOException naming the file and the
// problem (line number for text). Points with a NaN/Inf coordinate are dropped and counted.
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

namespace pcl {

class PointStreamReader
{
public:
  enum class Format
  {
    PCD,
    PLY,
    XYZ
  };

  PointStreamReader () = default;
  // open (path).
  explicit PointStreamReader (const std::string& path) { open (path); }
  ~PointStreamReader ();
  PointStreamReader (const PointStreamReader&) = delete;
  PointStreamReader& operator= (const PointStreamReader&) = delete;

  // Opens the file and parses its header (format from the extension; any case).
  void open (const std::string& path);
  void close ();
  // Back to the first point (for a second pass).
  void rewind ();

  // Replaces `out` with the next up to `max_points` (>= 1) finite points. Returns false when
  // the file has no more points (out is then empty).
  bool read (std::size_t max_points, pcl::PointCloud<pcl::PointXYZRGB>& out);
  // The same for any point type with x/y/z (colour copied when both have it).
  template <typename PointT> bool read (std::size_t max_points, pcl::PointCloud<PointT>& out);

  const std::string& getPath () const { return path_; }
  Format getFormat () const { return format_; }
  bool hasColor () const { return color_; }
  // Points the header declares (0 for .xyz, which has no header).
  std::uint64_t getDeclaredPoints () const { return declared_; }
  // Since open () / rewind (): finite points returned, and points dropped as NaN/Inf.
  std::uint64_t getPointsRead () const { return read_; }
  std::uint64_t getDroppedInvalid () const { return dropped_; }
  // Bytes of this reader's own buffers (for memory budgets).
  std::size_t bufferBytes () const;

private:
  enum Type : std::uint8_t { I8, U8, I16, U16, I32, U32, F32, F64 };
  struct Field
  {
    int index = -1;          // byte offset (binary) or token index (text); -1: absent
    Type type = F32;
  };
  [[noreturn]] void fail (const std::string& what) const;
  void parsePCDHeader ();
  void parsePLYHeader ();
  bool nextLine (std::string& line);
  std::size_t readBinary (std::size_t max_points, pcl::PointCloud<pcl::PointXYZRGB>& out);
  std::size_t readText (std::size_t max_points, pcl::PointCloud<pcl::PointXYZRGB>& out);
  bool keep (pcl::PointXYZRGB& p);

  std::string path_;
  Format format_ = Format::PCD;
  std::FILE* file_ = nullptr;
  bool binary_ = false, big_endian_ = false, compressed_ = false, color_ = false;
  bool packed_rgb_ = false;  // PCD rgb/rgba: one 4-byte field
  std::uint64_t declared_ = 0, data_offset_ = 0, record_bytes_ = 0, line_no_ = 0, data_line_ = 0;
  std::size_t tokens_ = 0;  // text: values per line (0: at least 3, .xyz)
  Field x_, y_, z_, r_, g_, b_, rgb_;
  std::uint64_t consumed_ = 0;  // binary records / text points consumed
  std::uint64_t read_ = 0, dropped_ = 0;
  std::vector<std::uint8_t> buffer_;
  std::vector<std::uint8_t> soa_;  // decompressed binary_compressed data (fields one after another)
  std::vector<std::size_t> soa_field_offset_;
  std::vector<std::size_t> field_sizes_;  // PCD: size × count per field, in record order
  pcl::PointCloud<pcl::PointXYZRGB> tmp_;
};

template <typename PointT> bool
PointStreamReader::read (std::size_t max_points, pcl::PointCloud<PointT>& out)
{
  const bool more = read (max_points, tmp_);
  out.clear ();
  out.resize (tmp_.size ());
  for (std::size_t i = 0; i < tmp_.size (); ++i)
  {
    PointT& p = out[i];
    p.x = tmp_[i].x;
    p.y = tmp_[i].y;
    p.z = tmp_[i].z;
    if constexpr (pcl::traits::has_color_v<PointT>)
    {
      p.r = tmp_[i].r;
      p.g = tmp_[i].g;
      p.b = tmp_[i].b;
    }
  }
  return more;
}

}  // namespace pcl
