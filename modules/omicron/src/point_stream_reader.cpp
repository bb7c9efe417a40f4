#include <pclx/omicron/point_stream_reader.h>

#include <pcl/console/print.h>
#include <pcl/io/lzf.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace {
std::string
lower (std::string s)
{
  std::transform (s.begin (), s.end (), s.begin (), [] (unsigned char c) { return static_cast<char> (std::tolower (c)); });
  return s;
}
std::vector<std::string>
split (const std::string& line)
{
  std::vector<std::string> w;
  std::istringstream in (line);
  for (std::string t; in >> t;)
    w.push_back (t);
  return w;
}
bool
parseCount (const std::string& s, std::uint64_t& v)
{
  if (s.empty () || s.size () > 19 || !std::all_of (s.begin (), s.end (), [] (unsigned char c) { return std::isdigit (c); }))
    return false;
  v = std::strtoull (s.c_str (), nullptr, 10);
  return true;
}
// PCL's field name, and CloudCompare's PLY scalar field ("scalar_Intensity").
bool
isIntensityName (const std::string& name)
{
  const std::string n = lower (name);
  return n == "intensity" || n == "scalar_intensity";
}
// Points above this are refused: per-node counts are 32-bit, and it bounds header numbers.
constexpr std::uint64_t kMaxPoints = (std::uint64_t (1) << 40);
}  // namespace

pcl::PointStreamReader::~PointStreamReader ()
{
  close ();
}

// Parsing errors unwind (std::runtime_error) to open (), rewind () and read (), which turn
// them into false + PCL_ERROR; nothing is thrown past this class.
void
pcl::PointStreamReader::fail (const std::string& what) const
{
  throw std::runtime_error (path_ + ": " + what);
}

bool
pcl::PointStreamReader::error (const char* method, const std::string& why)
{
  PCL_ERROR ("[pcl::PointStreamReader::%s] %s\n", method, why.c_str ());
  last_error_ = why;
  close ();
  return false;
}

bool
pcl::PointStreamReader::open (const std::string& path)
{
  last_error_.clear ();
  try
  {
    openImpl (path);
    return true;
  }
  catch (const std::exception& e)
  {
    return error ("open", e.what ());
  }
}

bool
pcl::PointStreamReader::rewind ()
{
  if (!file_)
    return error ("rewind", path_ + ": not open");
  try
  {
    rewindImpl ();
    return true;
  }
  catch (const std::exception& e)
  {
    return error ("rewind", e.what ());
  }
}

void
pcl::PointStreamReader::close ()
{
  if (file_)
    std::fclose (file_);
  file_ = nullptr;
  buffer_ = {};
  soa_ = {};
}

std::size_t
pcl::PointStreamReader::bufferBytes () const
{
  return buffer_.capacity () + soa_.capacity () + tmp_.size () * sizeof (pcl::PointXYZRGB) +
         intensities_.capacity () * sizeof (float);
}

bool
pcl::PointStreamReader::nextLine (std::string& line)
{
  line.clear ();
  int c;
  while ((c = std::fgetc (file_)) != EOF && c != '\n')
    line.push_back (static_cast<char> (c));
  if (c == EOF && line.empty ())
    return false;
  if (!line.empty () && line.back () == '\r')
    line.pop_back ();
  ++line_no_;
  return true;
}

void
pcl::PointStreamReader::openImpl (const std::string& path)
{
  close ();
  path_ = path;
  binary_ = big_endian_ = compressed_ = color_ = packed_rgb_ = false;
  intensities_.clear ();
  declared_ = data_offset_ = record_bytes_ = line_no_ = data_line_ = 0;
  tokens_ = 0;
  x_ = y_ = z_ = r_ = g_ = b_ = rgb_ = intensity_ = Field ();
  field_sizes_.clear ();
  soa_field_offset_.clear ();
  const std::string p = lower (path);
  const auto ends = [&] (const char* e) {
    const std::size_t n = std::strlen (e);
    return p.size () >= n && p.compare (p.size () - n, n, e) == 0;
  };
  if (ends (".pcd"))
    format_ = Format::PCD;
  else if (ends (".ply"))
    format_ = Format::PLY;
  else if (ends (".xyz") || ends (".txt"))
    format_ = Format::XYZ;
  else
    fail ("unknown extension (PointStreamReader reads .pcd, .ply, .xyz)");
  file_ = std::fopen (path.c_str (), "rb");
  if (!file_)
    fail (std::string ("cannot open: ") + std::strerror (errno));
  if (std::fseek (file_, 0, SEEK_END) != 0)
    fail ("cannot seek (not a regular file?)");
  const long size = std::ftell (file_);
  std::rewind (file_);
  if (size <= 0)
    fail ("the file is empty");
  if (format_ == Format::PCD)
    parsePCDHeader ();
  else if (format_ == Format::PLY)
    parsePLYHeader ();
  else
  {
    x_.index = 0, y_.index = 1, z_.index = 2;
    data_offset_ = 0;
  }
  if (binary_ && !compressed_)
  {
    const std::uint64_t need = data_offset_ + declared_ * record_bytes_;
    if (static_cast<std::uint64_t> (size) < need)
      fail ("truncated: the header declares " + std::to_string (declared_) + " points of " +
            std::to_string (record_bytes_) + " bytes after byte " + std::to_string (data_offset_) + ", but the file has " +
            std::to_string (size) + " bytes (" + std::to_string ((size - data_offset_) / std::max<std::uint64_t> (1, record_bytes_)) +
            " whole points)");
  }
  if (compressed_)
  {
    // binary_compressed: one LZF block of all points, fields stored one after another.
    std::uint32_t sizes[2];
    if (std::fread (sizes, 4, 2, file_) != 2)
      fail ("truncated: no compressed block after DATA binary_compressed");
    const std::uint64_t expect = declared_ * record_bytes_;
    if (sizes[1] != expect)
      fail ("the compressed block holds " + std::to_string (sizes[1]) + " bytes, the header declares " +
            std::to_string (expect));
    if (static_cast<std::uint64_t> (size) < data_offset_ + 8 + sizes[0])
      fail ("truncated: the compressed block is " + std::to_string (sizes[0]) + " bytes, the file ends earlier");
    std::vector<std::uint8_t> packed (sizes[0]);
    if (std::fread (packed.data (), 1, packed.size (), file_) != packed.size ())
      fail ("truncated compressed block");
    soa_.resize (expect);
    if (expect > 0 && pcl::lzfDecompress (packed.data (), sizes[0], soa_.data (), sizes[1]) != sizes[1])
      fail ("the compressed block does not decompress to the declared size (corrupt)");
    soa_field_offset_.assign (field_sizes_.size () + 1, 0);
    for (std::size_t f = 0; f < field_sizes_.size (); ++f)
      soa_field_offset_[f + 1] = soa_field_offset_[f] + field_sizes_[f] * declared_;
  }
  rewindImpl ();
}

void
pcl::PointStreamReader::rewindImpl ()
{
  if (std::fseek (file_, static_cast<long> (data_offset_), SEEK_SET) != 0)
    fail ("cannot seek");
  consumed_ = read_ = dropped_ = 0;
  line_no_ = data_line_;
}

void
pcl::PointStreamReader::parsePCDHeader ()
{
  std::vector<std::string> fields;
  std::vector<std::uint64_t> sizes, counts;
  std::vector<char> types;
  std::uint64_t width = 0, height = 1, points = 0;
  bool have_points = false, have_width = false;
  std::string line;
  while (true)
  {
    if (!nextLine (line))
      fail (line_no_ == 0 ? "the file is empty" : "the header has no DATA line");
    if (line.size () > 4096)
      fail ("header line " + std::to_string (line_no_) + " is too long (not a PCD file?)");
    const auto w = split (line);
    if (w.empty () || w[0][0] == '#')
      continue;
    const std::string key = w[0];
    const auto numbers = [&] (std::vector<std::uint64_t>& out) {
      out.clear ();
      for (std::size_t i = 1; i < w.size (); ++i)
      {
        std::uint64_t v;
        if (!parseCount (w[i], v))
          fail ("header line " + std::to_string (line_no_) + ": '" + w[i] + "' is not a count");
        out.push_back (v);
      }
    };
    std::vector<std::uint64_t> v;
    if (key == "VERSION" || key == "VIEWPOINT")
      continue;
    else if (key == "FIELDS" || key == "COLUMNS")
      fields.assign (w.begin () + 1, w.end ());
    else if (key == "SIZE")
      numbers (sizes);
    else if (key == "COUNT")
      numbers (counts);
    else if (key == "TYPE")
    {
      types.clear ();
      for (std::size_t i = 1; i < w.size (); ++i)
        types.push_back (w[i].size () == 1 ? w[i][0] : '?');
    }
    else if (key == "WIDTH" || key == "HEIGHT" || key == "POINTS")
    {
      numbers (v);
      if (v.size () != 1)
        fail ("header line " + std::to_string (line_no_) + ": " + key + " needs one count");
      (key == "WIDTH" ? width : key == "HEIGHT" ? height : points) = v[0];
      have_width = have_width || key == "WIDTH";
      have_points = have_points || key == "POINTS";
    }
    else if (key == "DATA")
    {
      if (w.size () != 2)
        fail ("header line " + std::to_string (line_no_) + ": DATA needs one of ascii, binary, binary_compressed");
      binary_ = w[1] == "binary" || w[1] == "binary_compressed";
      compressed_ = w[1] == "binary_compressed";
      if (!binary_ && w[1] != "ascii")
        fail ("unknown DATA type '" + w[1] + "'");
      break;
    }
    else
      fail ("header line " + std::to_string (line_no_) + ": unknown keyword '" + key.substr (0, 32) + "' (not a PCD file?)");
  }
  data_offset_ = static_cast<std::uint64_t> (std::ftell (file_));
  data_line_ = line_no_;
  if (fields.empty ())
    fail ("the header has no FIELDS");
  if (counts.empty ())
    counts.assign (fields.size (), 1);
  if (sizes.size () != fields.size () || types.size () != fields.size () || counts.size () != fields.size ())
    fail ("FIELDS, SIZE, TYPE and COUNT disagree in length");
  if (!have_points && !have_width)
    fail ("the header has neither POINTS nor WIDTH");
  declared_ = have_points ? points : width * height;
  if (have_points && have_width && width * height != points)
    fail ("WIDTH × HEIGHT (" + std::to_string (width * height) + ") differs from POINTS (" + std::to_string (points) + ")");
  if (declared_ > kMaxPoints)
    fail ("the header declares " + std::to_string (declared_) + " points");
  std::size_t offset = 0, token = 0;
  for (std::size_t f = 0; f < fields.size (); ++f)
  {
    const std::uint64_t s = sizes[f], c = counts[f];
    const char t = types[f];
    if ((s != 1 && s != 2 && s != 4 && s != 8) || c == 0 || c > 1000000 || (t != 'F' && t != 'U' && t != 'I') ||
        (t == 'F' && s != 4 && s != 8))
      fail ("field " + fields[f] + " has an invalid SIZE/TYPE/COUNT");
    Type type = t == 'F' ? (s == 4 ? F32 : F64)
                         : t == 'U' ? (s == 1 ? U8 : s == 2 ? U16 : U32) : (s == 1 ? I8 : s == 2 ? I16 : I32);
    if (s == 8 && t != 'F')
      type = t == 'U' ? U32 : I32;  // 64-bit integers: only skipped
    Field fd{binary_ ? static_cast<int> (offset) : static_cast<int> (token), type};
    if (compressed_)
      fd.index = static_cast<int> (f);
    const std::string& n = fields[f];
    if ((n == "x" || n == "y" || n == "z") && c == 1)
    {
      if (s == 8 && t != 'F')
        fail ("field " + n + " is a 64-bit integer");
      (n == "x" ? x_ : n == "y" ? y_ : z_) = fd;
    }
    else if ((n == "rgb" || n == "rgba") && c == 1 && s == 4)
    {
      rgb_ = fd;
      color_ = packed_rgb_ = true;
    }
    else if (isIntensityName (n) && c == 1 && !(s == 8 && t != 'F'))
      intensity_ = fd;
    field_sizes_.push_back (s * c);
    offset += s * c;
    token += c;
  }
  if (x_.index < 0 || y_.index < 0 || z_.index < 0)
    fail ("the file has no x, y and z fields");
  record_bytes_ = offset;
  tokens_ = token;
}

void
pcl::PointStreamReader::parsePLYHeader ()
{
  std::string line;
  if (!nextLine (line) || line != "ply")
    fail ("not a PLY file (no 'ply' magic line)");
  struct Element
  {
    std::string name;
    std::uint64_t count = 0;
    std::uint64_t bytes = 0;
    bool list = false;
  };
  std::vector<Element> elements;
  std::size_t token = 0, offset = 0;
  bool format = false;
  const auto scalar = [&] (const std::string& t, Type& type, std::size_t& size) {
    static const struct
    {
      const char* a;
      const char* b;
      Type type;
      std::size_t size;
    } kTypes[] = {{"char", "int8", I8, 1},     {"uchar", "uint8", U8, 1},   {"short", "int16", I16, 2},
                  {"ushort", "uint16", U16, 2}, {"int", "int32", I32, 4},    {"uint", "uint32", U32, 4},
                  {"float", "float32", F32, 4}, {"double", "float64", F64, 8}};
    for (const auto& k : kTypes)
      if (t == k.a || t == k.b)
      {
        type = k.type;
        size = k.size;
        return true;
      }
    return false;
  };
  while (true)
  {
    if (!nextLine (line))
      fail ("the header has no end_header line");
    if (line.size () > 4096)
      fail ("header line " + std::to_string (line_no_) + " is too long");
    const auto w = split (line);
    if (w.empty () || w[0] == "comment" || w[0] == "obj_info")
      continue;
    if (w[0] == "end_header")
      break;
    if (w[0] == "format" && w.size () == 3)
    {
      format = true;
      binary_ = w[1] != "ascii";
      big_endian_ = w[1] == "binary_big_endian";
      if (w[1] != "ascii" && w[1] != "binary_little_endian" && !big_endian_)
        fail ("unknown PLY format '" + w[1] + "'");
    }
    else if (w[0] == "element" && w.size () == 3)
    {
      Element e;
      e.name = w[1];
      if (!parseCount (w[2], e.count) || e.count > kMaxPoints)
        fail ("header line " + std::to_string (line_no_) + ": bad element count '" + w[2] + "'");
      elements.push_back (e);
    }
    else if (w[0] == "property" && !elements.empty ())
    {
      Element& e = elements.back ();
      Type type;
      std::size_t size = 0;
      if (w.size () == 5 && w[1] == "list")
      {
        if (e.name == "vertex")
          fail ("vertex list properties are not supported");
        e.list = true;
        continue;
      }
      if (w.size () != 3 || !scalar (w[1], type, size))
        fail ("header line " + std::to_string (line_no_) + ": bad property '" + line.substr (0, 64) + "'");
      if (e.name == "vertex")
      {
        const Field f{binary_ ? static_cast<int> (offset) : static_cast<int> (token), type};
        const std::string& n = w[2];
        if (n == "x")
          x_ = f;
        else if (n == "y")
          y_ = f;
        else if (n == "z")
          z_ = f;
        else if (n == "red" || n == "r")
          r_ = f;
        else if (n == "green" || n == "g")
          g_ = f;
        else if (n == "blue" || n == "b")
          b_ = f;
        else if (isIntensityName (n))
          intensity_ = f;
        offset += size;
        ++token;
      }
      e.bytes += size;
    }
    else
      fail ("header line " + std::to_string (line_no_) + ": unexpected '" + line.substr (0, 64) + "'");
  }
  if (!format)
    fail ("the header has no format line");
  data_offset_ = static_cast<std::uint64_t> (std::ftell (file_));
  data_line_ = line_no_;
  // Elements before the vertices are skipped (fixed-size rows only in binary files).
  for (const Element& e : elements)
  {
    if (e.name == "vertex")
    {
      declared_ = e.count;
      break;
    }
    if (binary_)
    {
      if (e.list)
        fail ("element " + e.name + " with list properties precedes the vertices");
      data_offset_ += e.count * e.bytes;
    }
    else
      for (std::uint64_t i = 0; i < e.count; ++i)
        if (!nextLine (line))
          fail ("truncated: element " + e.name + " ends before the vertices");
  }
  if (!binary_)
  {
    data_offset_ = static_cast<std::uint64_t> (std::ftell (file_));
    data_line_ = line_no_;
  }
  if (x_.index < 0 || y_.index < 0 || z_.index < 0)
    fail ("the vertex element has no x, y and z properties");
  color_ = r_.index >= 0 && g_.index >= 0 && b_.index >= 0;
  record_bytes_ = offset;
  tokens_ = token;
}

namespace {
template <typename T> T
load (const std::uint8_t* p, bool swap)
{
  std::uint8_t b[sizeof (T)];
  std::memcpy (b, p, sizeof (T));
  if (swap)
    std::reverse (b, b + sizeof (T));
  T v;
  std::memcpy (&v, b, sizeof (T));
  return v;
}
}  // namespace

bool
pcl::PointStreamReader::keep (pcl::PointXYZRGB& p)
{
  if (std::isfinite (p.x) && std::isfinite (p.y) && std::isfinite (p.z))
  {
    ++read_;
    return true;
  }
  ++dropped_;
  return false;
}

std::size_t
pcl::PointStreamReader::readBinary (std::size_t max_points, pcl::PointCloud<pcl::PointXYZRGB>& out)
{
  const auto value = [&] (const std::uint8_t* p, Type t) -> double {
    switch (t)
    {
    case I8: return static_cast<std::int8_t> (*p);
    case U8: return *p;
    case I16: return load<std::int16_t> (p, big_endian_);
    case U16: return load<std::uint16_t> (p, big_endian_);
    case I32: return load<std::int32_t> (p, big_endian_);
    case U32: return load<std::uint32_t> (p, big_endian_);
    case F32: return load<float> (p, big_endian_);
    case F64: return load<double> (p, big_endian_);
    }
    return 0;
  };
  const auto colour = [&] (double v, Type t) {
    if (t == U16)
      v /= 257.0;
    else if (t == F32 || t == F64)
      v = v <= 1.0 ? v * 255.0 : v;
    return static_cast<std::uint8_t> (std::min (255.0, std::max (0.0, std::round (v))));
  };
  // Little-endian float x/y/z records (the common PCD/PLY case): the coordinates are copied,
  // not converted through double field by field.
  const bool float_xyz = !compressed_ && !big_endian_ && x_.type == F32 && y_.type == F32 && z_.type == F32;
  out.points.reserve (out.points.size () + static_cast<std::size_t> (std::min<std::uint64_t> (max_points, declared_ - consumed_)));
  std::size_t n = 0;
  while (n < max_points && consumed_ < declared_)
  {
    const std::size_t batch = static_cast<std::size_t> (std::min<std::uint64_t> (max_points - n, declared_ - consumed_));
    const std::uint8_t* base = nullptr;
    if (!compressed_)
    {
      buffer_.resize (batch * record_bytes_);
      const std::size_t got = std::fread (buffer_.data (), 1, buffer_.size (), file_);
      if (got != buffer_.size ())
        fail ("truncated: the file ends after " + std::to_string (consumed_ + got / record_bytes_) + " of " +
              std::to_string (declared_) + " points");
      base = buffer_.data ();
    }
    for (std::size_t i = 0; i < batch; ++i)
    {
      const auto at = [&] (const Field& f) {
        return compressed_ ? soa_.data () + soa_field_offset_[f.index] + field_sizes_[f.index] * (consumed_ + i)
                           : base + i * record_bytes_ + f.index;
      };
      pcl::PointXYZRGB p;
      if (float_xyz)
      {
        const std::uint8_t* r = base + i * record_bytes_;
        std::memcpy (&p.x, r + x_.index, sizeof (float));
        std::memcpy (&p.y, r + y_.index, sizeof (float));
        std::memcpy (&p.z, r + z_.index, sizeof (float));
      }
      else
      {
        p.x = static_cast<float> (value (at (x_), x_.type));
        p.y = static_cast<float> (value (at (y_), y_.type));
        p.z = static_cast<float> (value (at (z_), z_.type));
      }
      p.rgba = 0xff000000u;
      if (packed_rgb_)
        p.rgba = load<std::uint32_t> (at (rgb_), false) | 0xff000000u;
      else if (color_)
      {
        p.r = colour (value (at (r_), r_.type), r_.type);
        p.g = colour (value (at (g_), g_.type), g_.type);
        p.b = colour (value (at (b_), b_.type), b_.type);
      }
      if (keep (p))
      {
        out.push_back (p);
        if (intensity_.index >= 0)
          intensities_.push_back (static_cast<float> (value (at (intensity_), intensity_.type)));
        ++n;
      }
    }
    consumed_ += batch;
  }
  return n;
}

std::size_t
pcl::PointStreamReader::readText (std::size_t max_points, pcl::PointCloud<pcl::PointXYZRGB>& out)
{
  std::string line;
  std::vector<double> v;
  std::size_t n = 0;
  while (n < max_points && (format_ == Format::XYZ || consumed_ < declared_))
  {
    if (!nextLine (line))
    {
      if (format_ != Format::XYZ)
        fail ("truncated: the file ends after " + std::to_string (consumed_) + " of " + std::to_string (declared_) +
              " points");
      break;
    }
    const char* s = line.c_str ();
    while (*s == ' ' || *s == '\t')
      ++s;
    if (*s == '\0' || (format_ == Format::XYZ && *s == '#'))
    {
      if (format_ == Format::XYZ)
        continue;
      fail ("line " + std::to_string (line_no_) + ": empty line inside the point data");
    }
    v.clear ();
    while (*s)
    {
      char* end = nullptr;
      errno = 0;
      const double d = std::strtod (s, &end);
      if (end == s)
        fail ("line " + std::to_string (line_no_) + ": '" + std::string (s).substr (0, 24) + "' is not a number");
      v.push_back (d);
      s = end;
      while (*s == ' ' || *s == '\t' || *s == ',' || *s == ';')
        ++s;
    }
    if ((format_ == Format::XYZ ? v.size () < 3 : v.size () < tokens_) && std::feof (file_))
      fail ("truncated: the file ends inside line " + std::to_string (line_no_) + " (" + std::to_string (v.size ()) +
            " values)");
    if (format_ == Format::XYZ ? v.size () < 3 : v.size () < tokens_)
      fail ("line " + std::to_string (line_no_) + ": " + std::to_string (v.size ()) + " values, expected " +
            (format_ == Format::XYZ ? std::string ("at least 3") : std::to_string (tokens_)));
    ++consumed_;
    pcl::PointXYZRGB p;
    p.x = static_cast<float> (v[x_.index]);
    p.y = static_cast<float> (v[y_.index]);
    p.z = static_cast<float> (v[z_.index]);
    p.rgba = 0xff000000u;
    const auto c = [] (double d) { return static_cast<std::uint8_t> (std::min (255.0, std::max (0.0, std::round (d)))); };
    if (format_ == Format::XYZ)
    {
      // Colour per line: lines without it keep black.
      if (v.size () >= 6)
      {
        color_ = true;
        p.r = c (v[3]);
        p.g = c (v[4]);
        p.b = c (v[5]);
      }
    }
    else if (packed_rgb_)
    {
      // PCL writes packed rgb as the float with the colour's bits (type F) or as an integer.
      std::uint32_t bits;
      if (rgb_.type == F32)
      {
        const float f = static_cast<float> (v[rgb_.index]);
        std::memcpy (&bits, &f, 4);
      }
      else
        bits = static_cast<std::uint32_t> (v[rgb_.index]);
      p.rgba = bits | 0xff000000u;
    }
    else if (color_)
    {
      const double k = r_.type == U16 ? 1.0 / 257.0 : 1.0;
      p.r = c (v[r_.index] * k);
      p.g = c (v[g_.index] * k);
      p.b = c (v[b_.index] * k);
    }
    if (keep (p))
    {
      out.push_back (p);
      if (intensity_.index >= 0)
        intensities_.push_back (static_cast<float> (v[intensity_.index]));
      ++n;
    }
  }
  return n;
}

bool
pcl::PointStreamReader::readFloatXYZ (std::size_t max_points, float* first, std::size_t stride, std::size_t& n,
                                      float* intensity)
{
  n = 0;
  if (!file_)
    return error ("read", path_ + ": not open");
  try
  {
    auto* out = reinterpret_cast<std::uint8_t*> (first);
    while (n < max_points && consumed_ < declared_)
    {
      const std::size_t batch = static_cast<std::size_t> (std::min<std::uint64_t> (max_points - n, declared_ - consumed_));
      buffer_.resize (batch * record_bytes_);
      const std::size_t got = std::fread (buffer_.data (), 1, buffer_.size (), file_);
      if (got != buffer_.size ())
        fail ("truncated: the file ends after " + std::to_string (consumed_ + got / record_bytes_) + " of " +
              std::to_string (declared_) + " points");
      for (std::size_t i = 0; i < batch; ++i)
      {
        const std::uint8_t* r = buffer_.data () + i * record_bytes_;
        float v[3];
        std::memcpy (v, r + x_.index, sizeof (float));
        std::memcpy (v + 1, r + y_.index, sizeof (float));
        std::memcpy (v + 2, r + z_.index, sizeof (float));
        if (!std::isfinite (v[0]) || !std::isfinite (v[1]) || !std::isfinite (v[2]))
        {
          ++dropped_;
          continue;
        }
        std::memcpy (out + n * stride, v, sizeof v);
        if (intensity)
          std::memcpy (reinterpret_cast<std::uint8_t*> (intensity) + n * stride, r + intensity_.index, sizeof (float));
        ++n;
      }
      consumed_ += batch;
    }
  }
  catch (const std::exception& e)
  {
    n = 0;
    return error ("read", e.what ());
  }
  read_ += n;
  return true;
}

bool
pcl::PointStreamReader::read (std::size_t max_points, pcl::PointCloud<pcl::PointXYZRGB>& out)
{
  out.clear ();
  intensities_.clear ();
  if (!file_)
    return error ("read", path_ + ": not open");
  if (max_points == 0)
  {
    // A refused argument: the reader stays open.
    PCL_ERROR ("[pcl::PointStreamReader::read] max_points must be >= 1\n");
    last_error_ = "max_points must be >= 1";
    return false;
  }
  try
  {
    if (binary_)
      readBinary (max_points, out);
    else
      readText (max_points, out);
  }
  catch (const std::exception& e)
  {
    out.clear ();
    out.width = 0;
    out.height = 1;
    intensities_.clear ();
    return error ("read", e.what ());
  }
  out.width = static_cast<std::uint32_t> (out.size ());
  out.height = 1;
  return !out.empty ();
}
