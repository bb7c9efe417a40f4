#include <pclx/apps/file_check.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

namespace pclx {
namespace apps {

namespace {

namespace fs = std::filesystem;

// Byte counts from header numbers: 2^31 points × a large point cannot overflow this.
using Wide = unsigned __int128;

// Headers longer than this are refused (PCL's own are a few hundred bytes).
constexpr std::size_t kMaxHeader = 1 << 20;

[[noreturn]] void
fail (const std::string& path, const std::string& what)
{
  throw LoadError (path + ": " + what);
}

std::vector<std::string>
split (const std::string& line)
{
  std::istringstream s (line);
  std::vector<std::string> words;
  for (std::string w; s >> w;)
    words.push_back (w);
  return words;
}

// A whole non-negative integer (no sign, no trailing characters), up to 2^64 - 1.
bool
parseCount (const std::string& s, std::uint64_t& value)
{
  if (s.empty () || s.size () > 20 || !std::all_of (s.begin (), s.end (), [] (char c) { return std::isdigit (static_cast<unsigned char> (c)); }))
    return false;
  value = 0;
  for (char c : s)
  {
    const std::uint64_t digit = static_cast<std::uint64_t> (c - '0');
    if (value > (std::numeric_limits<std::uint64_t>::max () - digit) / 10)
      return false;
    value = value * 10 + digit;
  }
  return true;
}

bool
parseNumber (const std::string& s, double& value)
{
  std::istringstream in (s);
  in >> value;
  return !in.fail () && in.peek () == std::char_traits<char>::eof () && std::isfinite (value);
}

// Reads the next header line from `head` at `pos` (without the line end); false at the
// end of `head` or when a line has no end within it.
bool
nextLine (const std::string& head, std::size_t& pos, std::string& line, bool keep_cr = false)
{
  const std::size_t end = head.find ('\n', pos);
  if (end == std::string::npos)
    return false;
  line.assign (head, pos, end - pos);
  if (!keep_cr && !line.empty () && line.back () == '\r')
    line.pop_back ();
  pos = end + 1;
  return true;
}

std::string
plural (std::uint64_t n, const char* what)
{
  return std::to_string (n) + " " + what + (n == 1 ? "" : "s");
}

// The PCD header as read so far (checkPcd's stages share it).
struct PcdHeader
{
  FileCheck info;
  std::vector<std::uint64_t> sizes, counts;
  std::vector<char> types;
  bool have_width = false, have_height = false, have_points = false;
  std::size_t pos = 0;  // after the DATA line: where the data starts
};

// SIZE, TYPE or COUNT: one entry per field, in PCL's order FIELDS, SIZE, TYPE, COUNT.
void
readPcdFieldList (const std::string& path, const std::vector<std::string>& w, PcdHeader& h)
{
  const std::string& key = w[0];
  const std::size_t n = w.size () - 1;
  if (h.info.fields.empty () || (key != "SIZE" && h.sizes.empty ()) || (key == "COUNT" && h.types.empty ()))
    fail (path, key + " comes before FIELDS, SIZE or TYPE");
  if ((key == "SIZE" && !h.sizes.empty ()) || (key == "TYPE" && !h.types.empty ()) ||
      (key == "COUNT" && !h.counts.empty ()))
    fail (path, key + " appears twice");
  if (n != h.info.fields.size ())
    fail (path, key + " has " + std::to_string (n) + " entries for " + plural (h.info.fields.size (), "field"));
  for (std::size_t i = 1; i <= n; ++i)
  {
    if (key == "TYPE")
    {
      if (w[i].size () != 1 || std::string ("IUF").find (w[i][0]) == std::string::npos)
        fail (path, "TYPE '" + w[i] + "' is not I, U or F");
      h.types.push_back (w[i][0]);
      continue;
    }
    std::uint64_t v;
    if (!parseCount (w[i], v))
      fail (path, key + " '" + w[i] + "' is not a count");
    if (key == "SIZE" && v != 1 && v != 2 && v != 4 && v != 8)
      fail (path, "SIZE " + w[i] + " is not 1, 2, 4 or 8 bytes");
    if (key == "COUNT" && (v == 0 || v > 1u << 20))
      fail (path, "COUNT " + w[i] + " is out of range");
    (key == "SIZE" ? h.sizes : h.counts).push_back (v);
  }
}

// WIDTH, HEIGHT or POINTS: one count, not absurd.
void
readPcdDimension (const std::string& path, const std::vector<std::string>& w, PcdHeader& h)
{
  const std::string& key = w[0];
  std::uint64_t v;
  if (w.size () != 2 || !parseCount (w[1], v))
    fail (path, key + " is not a count");
  if (v > kMaxPoints)
    fail (path, key + " " + w[1] + " is absurd (more than " + std::to_string (kMaxPoints) + ")");
  if (key == "POINTS" && h.sizes.empty ())
    fail (path, "POINTS comes before SIZE");
  if (key == "WIDTH")
    h.info.width = static_cast<std::uint32_t> (v), h.have_width = true;
  else if (key == "HEIGHT")
    h.info.height = static_cast<std::uint32_t> (v), h.have_height = true;
  else
    h.info.points = v, h.have_points = true;
}

// One header line split into words; returns true at the DATA line.
bool
readPcdHeaderLine (const std::string& path, const std::string& line, const std::vector<std::string>& w, PcdHeader& h)
{
  const std::string& key = w[0];
  const std::size_t n = w.size () - 1;
  if (key == "VERSION")
    return false;
  if (key == "FIELDS" || key == "COLUMNS")
  {
    if (n == 0)
      fail (path, "FIELDS lists no fields");
    if (!h.info.fields.empty ())
      fail (path, "FIELDS appears twice");
    h.info.fields.assign (w.begin () + 1, w.end ());
    return false;
  }
  if (key == "SIZE" || key == "TYPE" || key == "COUNT")
  {
    readPcdFieldList (path, w, h);
    return false;
  }
  if (key == "WIDTH" || key == "HEIGHT" || key == "POINTS")
  {
    readPcdDimension (path, w, h);
    return false;
  }
  if (key == "VIEWPOINT")
  {
    double v;
    if (n != 7 || !std::all_of (w.begin () + 1, w.end (), [&v] (const std::string& s) { return parseNumber (s, v); }))
      fail (path, "VIEWPOINT needs 7 numbers");
    return false;
  }
  if (key == "DATA")
  {
    if (n != 1 || (w[1] != "ascii" && w[1] != "binary" && w[1] != "binary_compressed"))
      fail (path, "DATA must be ascii, binary or binary_compressed");
    h.info.encoding = w[1];
    return true;
  }
  fail (path, "unknown PCD header line '" + line.substr (0, 40) + "'");
}

// The header lines up to DATA, read the way PCL reads them.
void
readPcdHeader (const std::string& path, const std::string& head, PcdHeader& h)
{
  std::string line;
  while (true)
  {
    if (h.pos >= kMaxHeader)
      fail (path, "no DATA line in the first " + std::to_string (kMaxHeader) + " bytes (not a PCD file?)");
    // With the CR: PCL skips only truly empty lines, and stops its header at a line of
    // white space such as a lone "\r".
    if (!nextLine (head, h.pos, line, true))
      fail (path, "the PCD header ends before its DATA line (truncated or not a PCD file)");
    if (line.empty ())
      continue;
    if (line.back () == '\r')
      line.pop_back ();
    // PCL splits FIELDS on space, tab and CR only, other lines on any white space: allow
    // only those in the header so both readings agree.
    if (std::any_of (line.begin (), line.end (), [] (char c) { return c != '\t' && (c < 0x20 || c > 0x7e); }))
      fail (path, "the PCD header has a control or non-ASCII byte (not a PCD file?)");
    const auto w = split (line);
    if (w.empty ())  // PCL stops its header here
      fail (path, "the PCD header has a blank line before DATA");
    if (w[0][0] == '#')
      continue;
    if (readPcdHeaderLine (path, line, w, h))
      return;
  }
}

// The header's parts agree with each other; returns the bytes and the values of a point.
std::pair<std::uint64_t, std::uint64_t>
checkPcdLayout (const std::string& path, PcdHeader& h)
{
  FileCheck& info = h.info;
  if (info.fields.empty () || h.sizes.empty () || h.types.empty ())
    fail (path, "the PCD header lacks FIELDS, SIZE or TYPE");
  if (h.counts.empty ())
    h.counts.assign (info.fields.size (), 1);
  if (!h.have_width || !h.have_height)
    fail (path, "the PCD header lacks WIDTH or HEIGHT");
  if (!h.have_points)
    info.points = std::uint64_t (info.width) * info.height;
  if (std::uint64_t (info.width) * info.height != info.points)
    fail (path, "WIDTH x HEIGHT (" + std::to_string (info.width) + " x " + std::to_string (info.height) +
                    ") is not POINTS (" + std::to_string (info.points) + ")");
  if (info.points == 0)
    fail (path, "declares no points");
  std::uint64_t point_bytes = 0, values = 0;
  for (std::size_t i = 0; i < info.fields.size (); ++i)
  {
    if (h.types[i] == 'F' && h.sizes[i] != 4 && h.sizes[i] != 8)
      fail (path, "field '" + info.fields[i] + "' is F with SIZE " + std::to_string (h.sizes[i]));
    point_bytes += h.sizes[i] * h.counts[i];
    values += h.counts[i];
  }
  return {point_bytes, values};
}

// PCL goes on reading header lines after DATA until one is not a header keyword: data
// that starts like one (binary bytes "WIDTH...") would be read as header.
void
refuseHeaderAfterData (const std::string& path, const std::string& head, std::size_t data_offset)
{
  for (std::size_t p = data_offset; p < head.size ();)
  {
    std::size_t end = head.find ('\n', p);
    if (end == std::string::npos)
      end = head.size ();
    const bool empty = end == p;  // PCL skips empty lines and reads the next
    std::istringstream s (head.substr (p, std::min<std::size_t> (end - p, 64)));
    std::string token;
    s >> token;
    p = end + 1;
    if (empty)
      continue;
    static const char* keys[] = {"FIELDS", "COLUMNS", "SIZE", "TYPE", "COUNT", "WIDTH", "HEIGHT", "VIEWPOINT", "POINTS", "DATA"};
    if (std::any_of (std::begin (keys), std::end (keys), [&token] (const char* k) { return token.rfind (k, 0) == 0; }))
      fail (path, "the data after DATA starts with a header keyword ('" + token.substr (0, 12) + "'); PCL would misread it");
    if (token.empty () || (token[0] != '#' && token.rfind ("VERSION", 0) != 0))
      break;
  }
}

// The data after the header is long enough for the declared points.
void
checkPcdDataSize (const std::string& path, const std::string& head, std::uintmax_t file_size, const FileCheck& info,
                  std::uint64_t data_offset, std::uint64_t point_bytes, std::uint64_t values)
{
  const std::uint64_t available = file_size > data_offset ? file_size - data_offset : 0;
  if (info.encoding == "binary")
  {
    const Wide need = Wide (info.points) * point_bytes;
    if (available < need)
      fail (path, "binary data is " + std::to_string (available) + " bytes, " + plural (info.points, "point") +
                      " of " + std::to_string (point_bytes) + " bytes need more (truncated?)");
  }
  else if (info.encoding == "binary_compressed")
  {
    if (available < 8 || head.size () < data_offset + 8)
      fail (path, "binary_compressed data lacks its size header (truncated?)");
    std::uint32_t sizes_hdr[2];
    std::memcpy (sizes_hdr, head.data () + data_offset, 8);
    if (sizes_hdr[0] == 0 || sizes_hdr[0] > available - 8)
      fail (path, "compressed block of " + std::to_string (sizes_hdr[0]) + " bytes does not fit in the " +
                      std::to_string (available - 8) + " bytes left (truncated?)");
    if (sizes_hdr[1] != Wide (info.points) * point_bytes)
      fail (path, "uncompressed size " + std::to_string (sizes_hdr[1]) + " is not " + plural (info.points, "point") +
                      " x " + std::to_string (point_bytes) + " bytes");
  }
  else if (Wide (available) + 1 < Wide (2) * info.points * values)
    fail (path, "ascii data of " + std::to_string (available) + " bytes cannot hold " + plural (info.points, "point") +
                    " of " + plural (values, "value"));
}

// Header lines, then their agreement, then what follows DATA, then the data's size.
FileCheck
checkPcd (const std::string& path, const std::string& head, std::uintmax_t file_size)
{
  PcdHeader h;
  h.info.format = CloudFormat::PCD;
  h.info.file_size = file_size;
  readPcdHeader (path, head, h);
  const auto [point_bytes, values] = checkPcdLayout (path, h);
  refuseHeaderAfterData (path, head, h.pos);
  checkPcdDataSize (path, head, file_size, h.info, h.pos, point_bytes, values);
  return h.info;
}

std::uint64_t
plyTypeSize (const std::string& t)
{
  static const std::pair<const char*, std::uint64_t> types[] = {
      {"char", 1},  {"uchar", 1}, {"int8", 1},    {"uint8", 1},   {"short", 2},   {"ushort", 2},  {"int16", 2},
      {"uint16", 2}, {"int", 4},  {"uint", 4},    {"int32", 4},   {"uint32", 4},  {"float", 4},   {"float32", 4},
      {"double", 8}, {"float64", 8}};
  for (const auto& p : types)
    if (t == p.first)
      return p.second;
  return 0;
}

bool
plyIntegerType (const std::string& t)
{
  return plyTypeSize (t) > 0 && t.find ("float") == std::string::npos && t != "double";
}

// A PLY element as its header declares it.
struct PlyElement
{
  std::string name;
  std::uint64_t count = 0, fixed_bytes = 0, lists = 0, list_bytes = 0, values = 0;
  std::vector<std::string> properties;
};

// An "element <name> <count>" line.
void
readPlyElement (const std::string& path, const std::string& line, const std::vector<std::string>& w,
                std::vector<PlyElement>& elements)
{
  PlyElement e;
  if (w.size () != 3 || !parseCount (w[2], e.count))
    fail (path, "element line '" + line.substr (0, 60) + "' needs a name and a count");
  if (e.count > kMaxPoints)
    fail (path, "element " + w[1] + " count " + w[2] + " is absurd (more than " + std::to_string (kMaxPoints) + ")");
  for (const auto& other : elements)
    if (other.name == w[1])
      fail (path, "element " + w[1] + " appears twice");
  e.name = w[1];
  elements.push_back (e);
}

// A "property <type> <name>" or "property list <count type> <type> <name>" line.
void
readPlyProperty (const std::string& path, const std::string& line, const std::vector<std::string>& w,
                 std::vector<PlyElement>& elements)
{
  if (elements.empty ())
    fail (path, "property before any element");
  PlyElement& e = elements.back ();
  if (w.size () == 3 && plyTypeSize (w[1]) > 0)
  {
    e.fixed_bytes += plyTypeSize (w[1]);
    ++e.values;
    e.properties.push_back (w[2]);
  }
  else if (w.size () == 5 && w[1] == "list" && plyIntegerType (w[2]) && plyTypeSize (w[3]) > 0)
  {
    ++e.lists;
    e.list_bytes += plyTypeSize (w[2]);
    e.properties.push_back (w[4]);
  }
  else
    fail (path, "property line '" + line.substr (0, 60) + "' is malformed");
  const auto& props = e.properties;
  if (std::count (props.begin (), props.end (), props.back ()) > 1)
    fail (path, "property " + props.back () + " of element " + e.name + " appears twice");
}

// The header lines up to end_header; returns the offset of the data.
std::size_t
readPlyHeader (const std::string& path, const std::string& head, FileCheck& info, std::vector<PlyElement>& elements)
{
  std::size_t pos = 0;
  std::string line;
  if (!nextLine (head, pos, line) || line != "ply")
    fail (path, "does not start with the PLY magic line 'ply'");
  bool have_format = false;
  while (true)
  {
    if (pos >= kMaxHeader)
      fail (path, "no end_header in the first " + std::to_string (kMaxHeader) + " bytes");
    if (!nextLine (head, pos, line))
      fail (path, "the PLY header ends before end_header (truncated?)");
    // PCL's PLY parser asserts that a line starts with its keyword (a leading tab aborts
    // it, found by the fuzzer): printable ASCII only, no leading white space.
    if (std::any_of (line.begin (), line.end (), [] (char c) { return c != '\t' && (c < 0x20 || c > 0x7e); }) ||
        (!line.empty () && std::isspace (static_cast<unsigned char> (line[0]))))
      fail (path, "the PLY header has a control byte or leading white space (not a PLY file?)");
    const auto w = split (line);
    if (w.empty ())
      continue;
    const std::string& key = w[0];
    if (key == "comment" || key == "obj_info")
      continue;
    if (key == "format")
    {
      if (w.size () != 3 || (w[1] != "ascii" && w[1] != "binary_little_endian" && w[1] != "binary_big_endian") ||
          w[2] != "1.0")
        fail (path, "format line '" + line.substr (0, 60) + "' is not ascii / binary_little_endian / binary_big_endian 1.0");
      if (have_format)
        fail (path, "two format lines");
      have_format = true;
      info.encoding = w[1];
    }
    else if (key == "element")
      readPlyElement (path, line, w, elements);
    else if (key == "property")
      readPlyProperty (path, line, w, elements);
    else if (key == "end_header")
      break;
    else
      fail (path, "unknown PLY header line '" + line.substr (0, 40) + "'");
  }
  if (!have_format)
    fail (path, "the PLY header has no format line");
  return pos;
}

// A vertex element with x, y, z and no lists, and only elements PCL reads; returns the vertex element.
const PlyElement&
checkPlyElements (const std::string& path, const std::vector<PlyElement>& elements, FileCheck& info)
{
  const auto vertex =
      std::find_if (elements.begin (), elements.end (), [] (const PlyElement& e) { return e.name == "vertex"; });
  if (vertex == elements.end ())
    fail (path, "has no vertex element");
  for (const char* axis : {"x", "y", "z"})
    if (std::find (vertex->properties.begin (), vertex->properties.end (), axis) == vertex->properties.end ())
      fail (path, std::string ("vertex element has no property ") + axis);
  if (vertex->lists > 0)
    fail (path, "vertex element has list properties");
  if (vertex->count == 0)
    fail (path, "declares no vertices");
  for (const auto& e : elements)
  {
    // PCL's reader knows these elements; others would be skipped with a warning per property.
    if (e.name == "camera")
      info.ply_camera = true;
    else if (e.name != "vertex" && e.name != "face" && e.name != "range_grid")
      fail (path, "element " + e.name + " is not one PCL reads (vertex, face, range_grid, camera)");
    if (e.name == "camera" && (e.lists > 0 || e.count > 1))
      fail (path, "camera element is malformed");
    if (e.properties.empty () && e.count > 0)
      fail (path, "element " + e.name + " has no properties");
  }
  return *vertex;
}

// Header lines, then the elements, then the data's size: the smallest data the elements
// need (fixed rows exact, each list at least its count).
FileCheck
checkPly (const std::string& path, const std::string& head, std::uintmax_t file_size)
{
  FileCheck info;
  info.format = CloudFormat::PLY;
  info.file_size = file_size;
  std::vector<PlyElement> elements;
  const std::size_t pos = readPlyHeader (path, head, info, elements);
  const PlyElement& vertex = checkPlyElements (path, elements, info);
  info.points = vertex.count;
  info.width = static_cast<std::uint32_t> (vertex.count);
  info.height = 1;
  info.fields = vertex.properties;
  const std::uint64_t available = file_size > pos ? file_size - pos : 0;
  Wide need = 0;
  const bool ascii = info.encoding == "ascii";
  for (const auto& e : elements)
    need += ascii ? Wide (2) * e.count * (e.values + e.lists) : Wide (e.count) * (e.fixed_bytes + e.list_bytes);
  if (ascii ? Wide (available) + 1 < need : available < need)
    fail (path, (ascii ? "ascii" : "binary") + std::string (" data of ") + std::to_string (available) +
                    " bytes cannot hold " + plural (vertex.count, "vertex") + " and the other elements" +
                    (ascii ? "" : " (truncated?)"));
  return info;
}

}  // namespace

CloudFormat
formatFromPath (const std::string& path)
{
  std::string ext = fs::path (path).extension ().string ();
  std::transform (ext.begin (), ext.end (), ext.begin (), [] (unsigned char c) { return std::tolower (c); });
  if (ext == ".pcd")
    return CloudFormat::PCD;
  if (ext == ".ply")
    return CloudFormat::PLY;
  if (ext == ".xyz")
    return CloudFormat::XYZ;
  fail (path, "unknown file type '" + ext + "' (want .pcd, .ply or .xyz)");
}

FileCheck
checkCloudBytes (const std::string& path, CloudFormat format, const std::string& head, std::uintmax_t file_size)
{
  if (file_size == 0)
    fail (path, "is empty (0 bytes)");
  switch (format)
  {
  case CloudFormat::PCD: return checkPcd (path, head, file_size);
  case CloudFormat::PLY: return checkPly (path, head, file_size);
  case CloudFormat::XYZ: break;
  }
  FileCheck info;
  info.format = CloudFormat::XYZ;
  info.file_size = file_size;
  info.encoding = "ascii";
  return info;
}

FileCheck
checkCloudFile (const std::string& path)
{
  std::error_code ec;
  const auto status = fs::status (path, ec);
  if (ec || !fs::exists (status))
    fail (path, "no such file");
  if (fs::is_directory (status))
    fail (path, "is a directory, not a cloud file");
  if (!fs::is_regular_file (status))
    fail (path, "is not a regular file");
  const CloudFormat format = formatFromPath (path);
  const std::uintmax_t size = fs::file_size (path, ec);
  if (ec)
    fail (path, "cannot read its size: " + ec.message ());
  std::string head;
  if (format != CloudFormat::XYZ)
  {
    // The header plus the 8-byte size block of binary_compressed PCD data.
    head.resize (static_cast<std::size_t> (std::min<std::uintmax_t> (size, kMaxHeader + 8)));
    std::ifstream in (path, std::ios::binary);
    if (!in || !in.read (&head[0], static_cast<std::streamsize> (head.size ())))
      fail (path, "cannot be read");
  }
  return checkCloudBytes (path, format, head, size);
}

}  // namespace apps
}  // namespace pclx
