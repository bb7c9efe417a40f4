#include <pclx/omicron/detail/potree_format.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <deque>
#include <fstream>
#include <cerrno>
#include <limits>
#include <stdexcept>
#include <utility>

namespace pclx {
namespace omicron {
namespace detail {
namespace potree {

namespace {
[[noreturn]] void
fail (const std::string& msg)
{
  throw std::runtime_error (msg);
}

template <typename T> void
put (std::vector<std::uint8_t>& buf, std::size_t at, T v)
{
  // The format is little endian, as is every platform PCL builds on.
  std::memcpy (buf.data () + at, &v, sizeof (T));
}

nlohmann::ordered_json
vec (const Eigen::Vector3d& v)
{
  return nlohmann::ordered_json::array ({v.x (), v.y (), v.z ()});
}

struct ScalarTypeInfo
{
  ScalarType type;
  const char* name;
  std::size_t size;
};
constexpr ScalarTypeInfo kScalarTypes[] = {
    {ScalarType::kInt8, "int8", 1},    {ScalarType::kUInt8, "uint8", 1},   {ScalarType::kInt16, "int16", 2},
    {ScalarType::kUInt16, "uint16", 2}, {ScalarType::kInt32, "int32", 4},  {ScalarType::kUInt32, "uint32", 4},
    {ScalarType::kInt64, "int64", 8},  {ScalarType::kUInt64, "uint64", 8}, {ScalarType::kFloat, "float", 4},
    {ScalarType::kDouble, "double", 8}};

template <typename T> double
loadAs (const std::uint8_t* p)
{
  T v;
  std::memcpy (&v, p, sizeof (T));
  return static_cast<double> (v);
}
}  // namespace

ScalarType
scalarTypeFromName (const std::string& name)
{
  for (const ScalarTypeInfo& t : kScalarTypes)
    if (name == t.name)
      return t.type;
  fail ("unknown attribute type '" + name + "'");
}

const char*
scalarTypeName (ScalarType type)
{
  return kScalarTypes[static_cast<int> (type)].name;
}

std::size_t
scalarTypeSize (ScalarType type)
{
  return kScalarTypes[static_cast<int> (type)].size;
}

double
scalarAt (const std::uint8_t* p, ScalarType type)
{
  switch (type)
  {
  case ScalarType::kInt8: return loadAs<std::int8_t> (p);
  case ScalarType::kUInt8: return loadAs<std::uint8_t> (p);
  case ScalarType::kInt16: return loadAs<std::int16_t> (p);
  case ScalarType::kUInt16: return loadAs<std::uint16_t> (p);
  case ScalarType::kInt32: return loadAs<std::int32_t> (p);
  case ScalarType::kUInt32: return loadAs<std::uint32_t> (p);
  case ScalarType::kInt64: return loadAs<std::int64_t> (p);
  case ScalarType::kUInt64: return loadAs<std::uint64_t> (p);
  case ScalarType::kFloat: return loadAs<float> (p);
  case ScalarType::kDouble: return loadAs<double> (p);
  }
  return 0;
}

void
Metadata::setWrittenAttributes (bool with_rgb, bool with_intensity)
{
  rgb = with_rgb;
  intensity = with_intensity;
  intensity_type = ScalarType::kFloat;
  record_bytes = 12;
  rgb_offset = rgb ? record_bytes : 0;
  record_bytes += rgb ? 6 : 0;
  intensity_offset = intensity ? record_bytes : 0;
  record_bytes += intensity ? 4 : 0;
}

std::string
nodeName (MortonCode code)
{
  std::string s (code.level () + 1, 'r');
  for (int l = code.level (); l >= 1; --l, code = code.parent ())
    s[l] = static_cast<char> ('0' + code.childIndex ());
  return s;
}

MortonCode
codeFromName (const std::string& name)
{
  if (name.empty () || name[0] != 'r' || name.size () > MortonCode::kMaxDepth + 1u)
    throw std::runtime_error ("potree: bad node name '" + name + "'");
  MortonCode c = MortonCode::root ();
  for (std::size_t i = 1; i < name.size (); ++i)
  {
    if (name[i] < '0' || name[i] > '7')
      throw std::runtime_error ("potree: bad node name '" + name + "'");
    c = c.child (name[i] - '0');
  }
  return c;
}

void
writeHierarchy (const std::string& path, const std::vector<NodeRecord>& records, Metadata& meta)
{
  // Lean on memory (about 10 B per node beside the records: budgeted builds hold the whole
  // hierarchy here): a sorted index instead of a hash map, one flat list of chunk members,
  // and each chunk's records encoded and written on its own.
  const int step = meta.step_size;
  if (records.size () >= std::numeric_limits<std::uint32_t>::max ())
    fail ("PotreeWriter: too many nodes for one hierarchy");
  std::vector<std::uint32_t> order (records.size ());
  for (std::size_t i = 0; i < records.size (); ++i)
    order[i] = static_cast<std::uint32_t> (i);
  std::sort (order.begin (), order.end (),
             [&] (std::uint32_t a, std::uint32_t b) { return records[a].code.bits () < records[b].code.bits (); });
  for (std::size_t i = 1; i < order.size (); ++i)
    if (records[order[i]].code == records[order[i - 1]].code)
      fail ("PotreeWriter: node " + nodeName (records[order[i]].code) + " was written twice");
  const auto find = [&] (MortonCode c) -> long {
    const auto it = std::lower_bound (order.begin (), order.end (), c.bits (),
                                      [&] (std::uint32_t a, std::uint64_t v) { return records[a].code.bits () < v; });
    return it != order.end () && records[*it].code == c ? static_cast<long> (*it) : -1;
  };
  // Child masks bottom-up, so a node whose whole subtree stores no point is left out (an
  // empty leaf, or an inner node above empty leaves only).
  std::vector<std::uint32_t> by_level (order);
  std::stable_sort (by_level.begin (), by_level.end (), [&] (std::uint32_t a, std::uint32_t b) {
    return records[a].code.level () > records[b].code.level ();
  });
  std::vector<std::uint8_t> mask (records.size (), 0);
  int depth = 0;
  for (const std::uint32_t i : by_level)
  {
    const NodeRecord& r = records[i];
    if (r.code.level () == 0)
      continue;
    const long p = find (r.code.parent ());
    if (p < 0)
      fail ("PotreeWriter: node " + nodeName (r.code) + " has no parent in the output");
    if (r.num_points == 0 && mask[i] == 0)
      continue;
    depth = std::max (depth, r.code.level ());
    mask[p] |= static_cast<std::uint8_t> (1u << r.code.childIndex ());
  }
  const long root = find (MortonCode::root ());
  if (root < 0)
    fail ("PotreeWriter: the output has no root node");

  // Chunks as PotreeConverter cuts them: breadth-first from each chunk root down to `step`
  // levels below; bottom nodes with children start chunks of their own (in this order, so a
  // proxy's chunk is the next unassigned one).
  std::vector<std::uint32_t> members;            // chunk after chunk
  std::vector<std::size_t> chunk_begin{0};
  std::vector<std::pair<std::uint64_t, std::uint32_t>> chunk_of;  // chunk root code -> chunk
  std::deque<std::uint32_t> roots{static_cast<std::uint32_t> (root)};
  while (!roots.empty ())
  {
    const std::uint32_t r = roots.front ();
    roots.pop_front ();
    chunk_of.emplace_back (records[r].code.bits (), static_cast<std::uint32_t> (chunk_begin.size () - 1));
    const std::size_t first = members.size ();
    members.push_back (r);
    const int bottom = records[r].code.level () + step;
    for (std::size_t i = first; i < members.size (); ++i)
    {
      const std::uint32_t n = members[i];
      if (records[n].code.level () == bottom)
      {
        if (mask[n])
          roots.push_back (n);
        continue;
      }
      for (int c = 0; c < 8; ++c)
        if (mask[n] & (1u << c))
          members.push_back (static_cast<std::uint32_t> (find (records[n].code.child (c))));
    }
    chunk_begin.push_back (members.size ());
  }
  std::sort (chunk_of.begin (), chunk_of.end ());
  const auto chunkOffset = [&] (std::size_t k) { return kRecordBytes * chunk_begin[k]; };

  std::FILE* f = std::fopen (path.c_str (), "wb");
  if (!f)
    fail ("PotreeWriter: cannot write '" + path + "': " + std::strerror (errno));
  std::vector<std::uint8_t> buf;
  bool ok = true;
  for (std::size_t k = 0; k + 1 < chunk_begin.size () && ok; ++k)
  {
    buf.assign (kRecordBytes * (chunk_begin[k + 1] - chunk_begin[k]), 0);
    const int bottom = records[members[chunk_begin[k]]].code.level () + step;
    std::size_t at = 0;
    for (std::size_t m = chunk_begin[k]; m < chunk_begin[k + 1]; ++m)
    {
      const std::uint32_t n = members[m];
      const NodeRecord& r = records[n];
      std::uint8_t type = mask[n] ? kNormal : kLeaf;
      std::uint64_t offset = r.byte_offset, size = r.byte_size;
      if (r.code.level () == bottom && mask[n])
      {
        const auto it = std::lower_bound (chunk_of.begin (), chunk_of.end (),
                                          std::make_pair (r.code.bits (), std::uint32_t (0)));
        const std::size_t target = it->second;
        type = kProxy;
        offset = chunkOffset (target);
        size = chunkOffset (target + 1) - chunkOffset (target);
      }
      put<std::uint8_t> (buf, at + 0, type);
      put<std::uint8_t> (buf, at + 1, mask[n]);
      put<std::uint32_t> (buf, at + 2, r.num_points);
      put<std::uint64_t> (buf, at + 6, offset);
      put<std::uint64_t> (buf, at + 14, size);
      at += kRecordBytes;
    }
    ok = std::fwrite (buf.data (), 1, buf.size (), f) == buf.size ();
  }
  if (std::fclose (f) != 0 || !ok)
    fail ("PotreeWriter: writing '" + path + "' failed (disk full?)");
  meta.first_chunk_size = chunkOffset (1);
  meta.depth = depth;
}

void
writeMetadata (const std::string& path, const Metadata& meta)
{
  using json = nlohmann::ordered_json;  // keeps PotreeConverter's field order
  json attributes = json::array ();
  attributes.push_back ({{"name", "position"},
                         {"description", ""},
                         {"size", 12},
                         {"numElements", 3},
                         {"elementSize", 4},
                         {"type", "int32"},
                         {"min", vec (meta.position_min)},
                         {"max", vec (meta.position_max)},
                         {"scale", vec (Eigen::Vector3d::Ones ())},
                         {"offset", vec (Eigen::Vector3d::Zero ())}});
  if (meta.rgb)
    attributes.push_back ({{"name", "rgb"},
                           {"description", ""},
                           {"size", 6},
                           {"numElements", 3},
                           {"elementSize", 2},
                           {"type", "uint16"},
                           {"min", vec (Eigen::Vector3d::Zero ())},
                           {"max", vec (Eigen::Vector3d::Constant (65535))},
                           {"scale", vec (Eigen::Vector3d::Ones ())},
                           {"offset", vec (Eigen::Vector3d::Zero ())}});
  if (meta.intensity)
    attributes.push_back ({{"name", "intensity"},
                           {"description", ""},
                           {"size", scalarTypeSize (meta.intensity_type)},
                           {"numElements", 1},
                           {"elementSize", scalarTypeSize (meta.intensity_type)},
                           {"type", scalarTypeName (meta.intensity_type)},
                           {"min", json::array ({meta.intensity_min})},
                           {"max", json::array ({meta.intensity_max})},
                           {"scale", json::array ({1})},
                           {"offset", json::array ({0})}});
  json j;
  j["version"] = "2.0";
  j["name"] = meta.name;
  j["description"] = meta.description;
  j["points"] = meta.points;
  j["projection"] = meta.projection;
  j["hierarchy"] = {{"firstChunkSize", meta.first_chunk_size}, {"stepSize", meta.step_size}, {"depth", meta.depth}};
  j["offset"] = vec (meta.offset);
  j["scale"] = vec (meta.scale);
  j["spacing"] = meta.spacing;
  j["boundingBox"] = {{"min", vec (meta.box_min)}, {"max", vec (meta.box_max)}};
  j["encoding"] = "DEFAULT";
  j["attributes"] = attributes;
  std::ofstream out (path);
  out << j.dump (1, '\t') << '\n';
  out.close ();
  if (!out)
    fail ("PotreeWriter: cannot write '" + path + "'");
}

namespace {
// A JSON array of three numbers.
Eigen::Vector3d
v3 (const nlohmann::json& a)
{
  return Eigen::Vector3d (a.at (0).get<double> (), a.at (1).get<double> (), a.at (2).get<double> ());
}

// The record layout from metadata.json's attribute list: position first (int32 × 3), rgb
// (uint16 × 3) and intensity (one scalar of any type) where they are, the others skipped.
void
readAttributes (const nlohmann::json& attrs, Metadata& m)
{
  if (attrs.empty () || attrs.at (0).at ("name") != "position" || attrs.at (0).at ("type") != "int32" ||
      attrs.at (0).at ("size").get<int> () != 12)
    fail ("the first attribute must be position int32 × 3");
  m.position_min = v3 (attrs.at (0).at ("min"));
  m.position_max = v3 (attrs.at (0).at ("max"));
  std::uint32_t at = 12;
  for (std::size_t i = 1; i < attrs.size (); ++i)
  {
    const std::string name = attrs[i].at ("name").get<std::string> ();
    const int size = attrs[i].at ("size").get<int> ();
    // A bound far above any attribute's size, so a corrupt size cannot make absurd records.
    if (size < 1 || size > 1024)
      fail ("attribute " + name + " has size " + std::to_string (size));
    if (name != "rgb" && name != "intensity")
    {
      at += static_cast<std::uint32_t> (size);  // skipped, whatever its type
      continue;
    }
    const ScalarType type = scalarTypeFromName (attrs[i].at ("type").get<std::string> ());
    if (name == "rgb")
    {
      if (type != ScalarType::kUInt16 || size != 6)
        fail ("the rgb attribute must be uint16 × 3");
      m.rgb = true;
      m.rgb_offset = at;
    }
    else
    {
      if (static_cast<std::size_t> (size) != scalarTypeSize (type))
        fail ("the intensity attribute must be one " + std::string (scalarTypeName (type)));
      m.intensity = true;
      m.intensity_type = type;
      m.intensity_offset = at;
      m.intensity_min = attrs[i].value ("min", nlohmann::json::array ({0})).at (0).get<double> ();
      m.intensity_max = attrs[i].value ("max", nlohmann::json::array ({0})).at (0).get<double> ();
    }
    at += static_cast<std::uint32_t> (size);
  }
  m.record_bytes = at;
}
}  // namespace

Metadata
readMetadata (const std::string& path)
{
  std::ifstream in (path);
  if (!in)
    fail ("cannot open '" + path + "'");
  Metadata m;
  try
  {
    const nlohmann::json j = nlohmann::json::parse (in);
    if (j.at ("version").get<std::string> () != "2.0")
      fail ("'" + path + "' is version " + j.at ("version").get<std::string> () + ", not 2.0");
    if (j.value ("encoding", "DEFAULT") != "DEFAULT")
      fail ("only the DEFAULT encoding is read (got " + j.value ("encoding", "") + ")");
    m.name = j.value ("name", "");
    m.description = j.value ("description", "");
    m.projection = j.value ("projection", "");
    m.points = j.at ("points").get<std::uint64_t> ();
    m.first_chunk_size = j.at ("hierarchy").at ("firstChunkSize").get<std::uint64_t> ();
    m.step_size = j.at ("hierarchy").at ("stepSize").get<int> ();
    m.depth = j.at ("hierarchy").at ("depth").get<int> ();
    m.offset = v3 (j.at ("offset"));
    m.scale = v3 (j.at ("scale"));
    m.spacing = j.at ("spacing").get<double> ();
    m.box_min = v3 (j.at ("boundingBox").at ("min"));
    m.box_max = v3 (j.at ("boundingBox").at ("max"));
    readAttributes (j.at ("attributes"), m);
  }
  catch (const nlohmann::json::exception& e)
  {
    fail ("malformed '" + path + "': " + e.what ());
  }
  if (m.step_size < 1 || m.depth < 0 || m.depth > MortonCode::kMaxDepth || !(m.scale.array () > 0).all ())
    fail ("'" + path + "' has an out-of-range stepSize, depth or scale");
  return m;
}

}  // namespace potree
}  // namespace detail
}  // namespace omicron
}  // namespace pclx
