#include <pclx/omicron/potree_reader.h>

#include <pcl/console/print.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>

namespace {
// Errors deep in the parsing unwind to the public entry points, which turn them into false
// + PCL_ERROR; nothing is thrown past this file.
[[noreturn]] void
fail (const std::string& msg)
{
  throw std::runtime_error (msg);
}
// The little-endian value at p (the format's byte order, and every platform PCL builds on).
template <typename T> T
load (const std::uint8_t* p)
{
  T v;
  std::memcpy (&v, p, sizeof (T));
  return v;
}
}  // namespace

bool
pcl::PotreeReader::open (const std::string& directory)
{
  last_error_.clear ();
  try
  {
    openImpl (directory);
    return true;
  }
  catch (const std::exception& e)
  {
    nodes_.clear ();
    meta_ = pclx::omicron::detail::potree::Metadata ();
    return refuse ("open", e.what ());
  }
}

bool
pcl::PotreeReader::refuse (const char* method, const std::string& why) const
{
  PCL_ERROR ("[pcl::PotreeReader::%s] %s\n", method, why.c_str ());
  last_error_ = why;
  return false;
}

void
pcl::PotreeReader::openImpl (const std::string& directory)
{
  namespace potree = pclx::omicron::detail::potree;
  directory_ = directory;
  nodes_.clear ();
  meta_ = potree::readMetadata (directory + "/metadata.json");
  std::error_code ec;
  octree_bytes_ = std::filesystem::file_size (directory + "/octree.bin", ec);
  if (ec)
    fail ("cannot read '" + directory + "/octree.bin': " + ec.message ());
  std::ifstream in (directory + "/hierarchy.bin", std::ios::binary);
  if (!in)
    fail ("cannot open '" + directory + "/hierarchy.bin'");
  const std::vector<std::uint8_t> h ((std::istreambuf_iterator<char> (in)), std::istreambuf_iterator<char> ());

  // As OctreeLoader.parseHierarchy: a chunk's records are its root followed by the children
  // of each non-proxy record in order; a proxy's chunk starts with the proxy itself.
  struct Pending
  {
    std::size_t node;  // index in nodes_ of the chunk root
    std::uint64_t offset, size;
  };
  nodes_.push_back (NodeInfo{MortonCode::root (), "r"});
  std::deque<Pending> chunks{{0, 0, meta_.first_chunk_size}};
  const std::uint32_t bpp = meta_.bytesPerPoint ();
  while (!chunks.empty ())
  {
    const Pending c = chunks.front ();
    chunks.pop_front ();
    if (c.size == 0 || c.size % potree::kRecordBytes != 0 || c.offset > h.size () || c.size > h.size () - c.offset)
      fail ("hierarchy chunk of node " + nodes_[c.node].name + " (bytes " + std::to_string (c.offset) +
            "+" + std::to_string (c.size) + ") lies outside hierarchy.bin (" + std::to_string (h.size ()) +
            " bytes) or is not a whole number of 22-byte records");
    const std::size_t count = c.size / potree::kRecordBytes;
    std::vector<std::size_t> order{c.node};
    for (std::size_t i = 0; i < count; ++i)
    {
      if (i >= order.size ())
        fail ("hierarchy chunk of node " + nodes_[c.node].name + " has records that no child mask names");
      const std::size_t at = c.offset + i * potree::kRecordBytes;
      NodeInfo& n = nodes_[order[i]];
      const std::uint8_t type = h[at];
      n.child_mask = h[at + 1];
      n.num_points = load<std::uint32_t> (h.data () + at + 2);
      const std::uint64_t off = load<std::uint64_t> (h.data () + at + 6);
      const std::uint64_t size = load<std::uint64_t> (h.data () + at + 14);
      if (type > potree::kProxy || (i == 0 && type == potree::kProxy))
        fail ("node " + n.name + " has record type " + std::to_string (type));
      if (type == potree::kProxy)
      {
        chunks.push_back ({order[i], off, size});
        continue;
      }
      n.type = type;
      n.byte_offset = off;
      n.byte_size = size;
      if (size != std::uint64_t (n.num_points) * bpp || off > octree_bytes_ || size > octree_bytes_ - off)
        fail ("node " + n.name + " (" + std::to_string (n.num_points) + " points, bytes " +
              std::to_string (off) + "+" + std::to_string (size) + ") does not match octree.bin (" +
              std::to_string (octree_bytes_) + " bytes, " + std::to_string (bpp) + " bytes per point)");
      const MortonCode code = n.code;
      const std::string name = n.name;
      const std::uint8_t mask = n.child_mask;
      if (mask && code.level () >= MortonCode::kMaxDepth)
        fail ("node " + name + " is deeper than 21 levels");
      for (int k = 0; k < 8; ++k)
        if (mask & (1u << k))
        {
          nodes_.push_back (NodeInfo{code.child (k), name + static_cast<char> ('0' + k)});  // n is invalid now
          order.push_back (nodes_.size () - 1);
        }
    }
    if (order.size () != count)
      fail ("hierarchy chunk of node " + nodes_[c.node].name + " names " + std::to_string (order.size ()) +
            " nodes but holds " + std::to_string (count) + " records");
  }
  std::stable_sort (nodes_.begin (), nodes_.end (), [] (const NodeInfo& a, const NodeInfo& b) {
    return a.code.level () != b.code.level () ? a.code.level () < b.code.level () : a.code < b.code;
  });
}

long
pcl::PotreeReader::find (MortonCode code) const
{
  const auto it = std::lower_bound (nodes_.begin (), nodes_.end (), code, [] (const NodeInfo& a, MortonCode c) {
    return a.code.level () != c.level () ? a.code.level () < c.level () : a.code < c;
  });
  return it != nodes_.end () && it->code == code ? static_cast<long> (it - nodes_.begin ()) : -1;
}

std::uint64_t
pcl::PotreeReader::getStoredPoints () const
{
  std::uint64_t n = 0;
  for (const NodeInfo& i : nodes_)
    n += i.num_points;
  return n;
}

std::vector<std::uint8_t>
pcl::PotreeReader::readRange (std::uint64_t offset, std::uint64_t size) const
{
  std::vector<std::uint8_t> buf (size);
  if (size == 0)
    return buf;
  const std::string path = directory_ + "/octree.bin";
  std::FILE* f = std::fopen (path.c_str (), "rb");
  if (!f)
    fail ("cannot open '" + path + "'");
  const bool ok = std::fseek (f, static_cast<long> (offset), SEEK_SET) == 0 && std::fread (buf.data (), 1, size, f) == size;
  std::fclose (f);
  if (!ok)
    fail ("'" + path + "' is shorter than its hierarchy says");
  return buf;
}

template <typename PointT> bool
pcl::PotreeReader::readNodeAs (std::size_t i, pcl::PointCloud<PointT>& out) const
{
  out.clear ();
  if (i >= nodes_.size ())
    return refuse ("readNode", "node " + std::to_string (i) + " of " + std::to_string (nodes_.size ()));
  try
  {
    const NodeInfo& n = nodes_[i];
    const std::vector<std::uint8_t> buf = readRange (n.byte_offset, n.byte_size);
    const std::uint32_t bpp = meta_.bytesPerPoint ();
    out.resize (n.num_points);
    for (std::uint32_t k = 0; k < n.num_points; ++k)
    {
      PointT& p = out[k];
      const std::uint8_t* record = buf.data () + std::size_t (k) * bpp;
      for (int a = 0; a < 3; ++a)
        p.data[a] = static_cast<float> (load<std::int32_t> (record + 4 * a) * meta_.scale[a] + meta_.offset[a]);
      if constexpr (pcl::traits::has_color_v<PointT>)
        if (meta_.rgb)
        {
          p.r = static_cast<std::uint8_t> (load<std::uint16_t> (record + meta_.rgb_offset) / 257);
          p.g = static_cast<std::uint8_t> (load<std::uint16_t> (record + meta_.rgb_offset + 2) / 257);
          p.b = static_cast<std::uint8_t> (load<std::uint16_t> (record + meta_.rgb_offset + 4) / 257);
        }
      if constexpr (pcl::traits::has_intensity_v<PointT>)
        p.intensity = meta_.intensity ? static_cast<float> (pclx::omicron::detail::potree::scalarAt (
                                            record + meta_.intensity_offset, meta_.intensity_type))
                                      : 0.f;
    }
    out.width = static_cast<std::uint32_t> (out.size ());
    out.height = 1;
    return true;
  }
  catch (const std::exception& e)
  {
    out.clear ();
    return refuse ("readNode", e.what ());
  }
}

bool
pcl::PotreeReader::readNode (std::size_t i, pcl::PointCloud<pcl::PointXYZRGB>& out) const
{
  return readNodeAs (i, out);
}

bool
pcl::PotreeReader::readNode (std::size_t i, pcl::PointCloud<pcl::PointXYZ>& out) const
{
  return readNodeAs (i, out);
}

bool
pcl::PotreeReader::readNode (std::size_t i, pcl::PointCloud<pcl::PointXYZI>& out) const
{
  return readNodeAs (i, out);
}

bool
pcl::PotreeReader::readNode (std::size_t i, pcl::PointCloud<pclx::PointXYZRGBI>& out) const
{
  return readNodeAs (i, out);
}
