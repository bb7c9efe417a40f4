#pragma once
// pcl::PointStreamReader: PCD/PLY/XYZ files read in blocks, see the class.
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

namespace pcl {

/** \brief Reads a point cloud file in blocks, so a file larger than memory can be streamed
  * (the out-of-core build of pcl::ObliqueCutOctree reads its input twice through it).
  *
  * \code
  * pcl::PointStreamReader reader;
  * if (!reader.open ("scan.ply"))                      // PCL_ERROR, getLastError ()
  *   return;
  * pcl::PointCloud<pcl::PointXYZRGB> block;
  * while (reader.read (1 << 20, block))
  *   use (block);                                      // finite points only
  * if (!reader.getLastError ().empty ())
  *   ...                                               // truncated or malformed data
  * \endcode
  *
  * Formats: PCD (ascii, binary; binary_compressed is decompressed whole, its format has no
  * smaller unit), PLY (ascii, binary little/big endian; vertex x/y/z of any scalar type plus
  * optional red/green/blue), and .xyz text ("x y z [r g b]" per line, commas or white space,
  * '#' comments). Positions, colour and intensity (the PCD/PLY field "intensity", or PLY's
  * "scalar_intensity", of any scalar type) are read into the point types that have them;
  * other fields are skipped.
  *
  * The headers are parsed here rather than by pcl::PCDReader::readHeader, which crashes on
  * 0- and 1-byte PCD files and trusts the declared counts. Empty, truncated or malformed files
  * make open () or read () return false with PCL_ERROR naming the file and the problem (line
  * number for text) and close the reader; getLastError () keeps the message. Points with a
  * NaN/Inf coordinate are dropped and counted.
  * \ingroup omicron
  */
class PointStreamReader
{
public:
  /** \brief The file formats, chosen by the extension. */
  enum class Format
  {
    PCD,  ///< .pcd: ascii, binary or binary_compressed
    PLY,  ///< .ply: ascii or binary (either endianness)
    XYZ   ///< .xyz / .txt: "x y z [r g b]" per line
  };

  /** \brief A reader with no file open. */
  PointStreamReader () = default;
  /** \brief A reader that opens a file at once; check isOpen () or getLastError ().
    * \param[in] path the file (see open ())
    */
  explicit PointStreamReader (const std::string& path) { open (path); }
  /** \brief Closes the file. */
  ~PointStreamReader ();
  PointStreamReader (const PointStreamReader&) = delete;
  PointStreamReader& operator= (const PointStreamReader&) = delete;

  /** \brief Open a file and parse its header (format from the extension, any case).
    * \param[in] path the file
    * \return false (PCL_ERROR, getLastError ()) on an unknown extension, an unreadable,
    * empty, truncated or malformed file
    */
  bool open (const std::string& path);
  /** \brief Close the file (open () may be called again). */
  void close ();
  /** \brief Whether a file is open.
    * \return whether a file is open */
  bool isOpen () const { return file_ != nullptr; }
  /** \brief Go back to the first point (for a second pass).
    * \return false (PCL_ERROR, getLastError ()) when no file is open or it cannot seek
    */
  bool rewind ();

  /** \brief Replace `out` with the next points.
    * \param[in] max_points at most this many finite points (>= 1)
    * \param[out] out the points (empty at the end or on an error)
    * \return false at the end of the file, and on an error (then getLastError () is not
    * empty, PCL_ERROR was printed and the reader is closed)
    */
  bool read (std::size_t max_points, pcl::PointCloud<pcl::PointXYZRGB>& out);
  /** \brief The same for any point type with x/y/z (colour and intensity copied when both
    * the file and the type have them; a type's intensity is 0 for a file without it).
    * \param[in] max_points at most this many finite points (>= 1)
    * \param[out] out the points (empty at the end or on an error)
    * \return false at the end of the file or on an error (see the PointXYZRGB overload)
    */
  template <typename PointT> bool read (std::size_t max_points, pcl::PointCloud<PointT>& out);

  /** \brief The file path.
    * \return the file path */
  const std::string& getPath () const { return path_; }
  /** \brief The file format.
    * \return the file format */
  Format getFormat () const { return format_; }
  /** \brief Whether the file has colour.
    * \return whether the file has colour */
  bool hasColor () const { return color_; }
  /** \brief Whether the file has an intensity field.
    * \return whether the file has an intensity field */
  bool hasIntensity () const { return intensity_.index >= 0; }
  /** \brief Points the header declares (0 for .xyz, which has no header).
    * \return points the header declares (0 for .xyz, which has no header) */
  std::uint64_t getDeclaredPoints () const { return declared_; }
  /** \brief Finite points returned since open () / rewind ().
    * \return finite points returned since open () / rewind () */
  std::uint64_t getPointsRead () const { return read_; }
  /** \brief Points dropped as NaN/Inf since open () / rewind ().
    * \return points dropped as NaN/Inf since open () / rewind () */
  std::uint64_t getDroppedInvalid () const { return dropped_; }
  /** \brief Bytes of this reader's own buffers (for memory budgets).
    * \return bytes of this reader's own buffers (for memory budgets) */
  std::size_t bufferBytes () const;
  /** \brief Why the last open (), rewind () or read () failed.
    * \return the message, empty when none failed since the last open () */
  const std::string& getLastError () const { return last_error_; }

private:
  enum Type : std::uint8_t { I8, U8, I16, U16, I32, U32, F32, F64 };
  struct Field
  {
    int index = -1;          // byte offset (binary) or token index (text); -1: absent
    Type type = F32;
  };
  // Throws std::runtime_error ("path: what"); caught by the public entry points.
  [[noreturn]] void fail (const std::string& what) const;
  // PCL_ERROR, getLastError () and close (); returns false.
  bool error (const char* method, const std::string& why);
  void openImpl (const std::string& path);
  void rewindImpl ();
  void parsePCDHeader ();
  void parsePLYHeader ();
  bool nextLine (std::string& line);
  std::size_t readBinary (std::size_t max_points, pcl::PointCloud<pcl::PointXYZRGB>& out);
  std::size_t readText (std::size_t max_points, pcl::PointCloud<pcl::PointXYZRGB>& out);
  bool keep (pcl::PointXYZRGB& p);
  // The next at most max_points finite points of a binary little-endian float x/y/z file, their
  // x, y, z written as floats at `first` + i * stride bytes (NaN/Inf rows dropped and counted),
  // and, with `intensity`, the file's float intensity at `intensity` + i * stride bytes; n: the
  // points written. Returns false on an error (as read ()). An empty `first` range
  // (max_points 0, or at the end) writes nothing and returns true.
  bool readFloatXYZ (std::size_t max_points, float* first, std::size_t stride, std::size_t& n,
                     float* intensity = nullptr);

  std::string path_;
  Format format_ = Format::PCD;
  std::FILE* file_ = nullptr;
  bool binary_ = false, big_endian_ = false, compressed_ = false, color_ = false;
  bool packed_rgb_ = false;  // PCD rgb/rgba: one 4-byte field
  std::uint64_t declared_ = 0, data_offset_ = 0, record_bytes_ = 0, line_no_ = 0, data_line_ = 0;
  std::size_t tokens_ = 0;  // text: values per line (0: at least 3, .xyz)
  Field x_, y_, z_, r_, g_, b_, rgb_, intensity_;
  std::uint64_t consumed_ = 0;  // binary records / text points consumed
  std::uint64_t read_ = 0, dropped_ = 0;
  std::vector<std::uint8_t> buffer_;
  std::vector<std::uint8_t> soa_;  // decompressed binary_compressed data (fields one after another)
  std::vector<std::size_t> soa_field_offset_;
  std::vector<std::size_t> field_sizes_;  // PCD: size × count per field, in record order
  pcl::PointCloud<pcl::PointXYZRGB> tmp_;
  std::vector<float> intensities_;  // of the points the last read () returned, when the file has it
  std::string last_error_;
};

template <typename PointT> bool
PointStreamReader::read (std::size_t max_points, pcl::PointCloud<PointT>& out)
{
  // Binary little-endian float x/y/z (and float intensity, when both the file and the type
  // have it) without colour in the point type: straight into `out`.
  bool intensity_read = false;
  if constexpr (pcl::traits::has_intensity_v<PointT>)
    intensity_read = hasIntensity ();
  if constexpr (!pcl::traits::has_color_v<PointT>)
    if (file_ && binary_ && !compressed_ && !big_endian_ && x_.type == F32 && y_.type == F32 && z_.type == F32 &&
        max_points > 0 && (!intensity_read || intensity_.type == F32))
    {
      // A PointXYZ block of the last block's size is reused as it is: the read overwrites every
      // field it has. Other types are built afresh, so no field keeps an earlier value.
      if constexpr (!std::is_same_v<PointT, pcl::PointXYZ>)
        out.clear ();
      try
      {
        out.resize (static_cast<std::size_t> (std::min<std::uint64_t> (max_points, declared_ - consumed_)));
      }
      catch (const std::exception& e)  // a declared count far beyond memory
      {
        out.clear ();
        return error ("read", path_ + ": " + e.what ());
      }
      std::size_t n = 0;
      float* intensity = nullptr;
      if constexpr (pcl::traits::has_intensity_v<PointT>)
        intensity = intensity_read && !out.empty () ? &out[0].intensity : nullptr;
      const bool ok = readFloatXYZ (out.size (), out.empty () ? nullptr : &out[0].x, sizeof (PointT), n, intensity);
      out.resize (n);
      out.width = static_cast<std::uint32_t> (n);
      out.height = 1;
      return ok && n > 0;
    }
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
    if constexpr (pcl::traits::has_intensity_v<PointT>)
      p.intensity = intensity_read ? intensities_[i] : 0.f;
  }
  return more;
}

}  // namespace pcl
