// Intensity from the input file to the Potree folder and back: PointStreamReader reads the
// field in every format, PotreeWriter stores it unrounded, PotreeReader reads it (and the
// attributes of PotreeConverter's LAS output it skips); malformed attribute lists are errors.
#include "omicron_test_util.h"

#include <pclx/omicron/oblique_cut_octree.h>
#include <pclx/omicron/point_stream_reader.h>
#include <pclx/omicron/point_xyzi_packed.h>
#include <pclx/omicron/point_xyzrgbi.h>
#include <pclx/omicron/potree_reader.h>
#include <pclx/omicron/potree_writer.h>

#include <pcl/common/io.h>
#include <pcl/io/pcd_io.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <tuple>
#include <unistd.h>

namespace fs = std::filesystem;
using omitest::TempDir;
using CloudI = pcl::PointCloud<pcl::PointXYZI>;

namespace {
// Points (clustered by default) with intensities beyond uint16's range and below zero,
// fractions, one NaN and one Inf (stored as they are, left out of the metadata range).
CloudI::Ptr
intensityCloud (std::size_t n, omitest::Shape shape = omitest::Shape::CLUSTERED)
{
  const auto xyz = omitest::makeCloud (shape, n, 11);
  CloudI::Ptr c (new CloudI);
  c->resize (xyz->size ());
  for (std::size_t i = 0; i < xyz->size (); ++i)
  {
    (*c)[i].getVector3fMap () = (*xyz)[i].getVector3fMap ();
    (*c)[i].intensity = static_cast<float> (i % 1000) * 70.25f - 3.5f;
  }
  (*c)[7].intensity = std::numeric_limits<float>::quiet_NaN ();
  (*c)[8].intensity = std::numeric_limits<float>::infinity ();
  return c;
}

// (position quantum of the folder's grid, intensity bits) of every point, as a multiset.
using Keyed = std::multiset<std::pair<std::array<std::int64_t, 3>, std::uint32_t>>;
Keyed
keyed (const CloudI& cloud, const pclx::omicron::detail::potree::Metadata& m)
{
  Keyed out;
  for (const auto& p : cloud)
  {
    std::uint32_t bits;
    std::memcpy (&bits, &p.intensity, 4);
    std::array<std::int64_t, 3> q;
    for (int a = 0; a < 3; ++a)
      q[a] = std::llround ((double (p.data[a]) - m.offset[a]) / m.scale[a]);
    out.emplace (q, bits);
  }
  return out;
}

// Every point of a folder, read as PointXYZI.
CloudI
readFolder (const std::string& dir)
{
  pcl::PotreeReader r;
  EXPECT_TRUE (r.open (dir)) << r.getLastError ();
  CloudI all, node;
  for (std::size_t i = 0; i < r.getNodes ().size (); ++i)
  {
    EXPECT_TRUE (r.readNode (i, node));
    all += node;
  }
  return all;
}

std::string
slurpText (const fs::path& p)
{
  std::ifstream in (p);
  return std::string ((std::istreambuf_iterator<char> (in)), std::istreambuf_iterator<char> ());
}

void
writeBytes (const fs::path& p, const std::vector<std::uint8_t>& bytes)
{
  std::ofstream (p, std::ios::binary).write (reinterpret_cast<const char*> (bytes.data ()), bytes.size ());
}
}  // namespace

TEST (PotreeIntensity, StoredUnroundedWithItsRangeAndReadBack)
{
  const auto cloud = intensityCloud (20000);
  pcl::ObliqueCutOctree<pcl::PointXYZI> o;
  o.setInputCloud (cloud);
  o.setMaxDepth (6);
  ASSERT_TRUE (o.build ()) << o.getLastError ();
  TempDir dir;
  pcl::PotreeWriter<pcl::PointXYZI> w;
  w.setScale (0.0001);
  ASSERT_TRUE (w.write (o, dir.path.string ())) << w.getLastError ();
  const std::string js = slurpText (dir.path / "metadata.json");
  EXPECT_NE (js.find ("\"name\": \"intensity\""), std::string::npos) << js;
  EXPECT_EQ (js.find ("null"), std::string::npos) << "NaN or Inf in the metadata:\n" << js;

  pcl::PotreeReader r;
  ASSERT_TRUE (r.open (dir.path.string ()));
  const auto& m = r.getMetadata ();
  EXPECT_TRUE (m.intensity);
  EXPECT_FALSE (m.rgb);
  EXPECT_EQ (m.intensity_type, pclx::omicron::detail::potree::ScalarType::kFloat);
  EXPECT_EQ (m.bytesPerPoint (), 16u);
  EXPECT_DOUBLE_EQ (m.intensity_min, -3.5);
  EXPECT_DOUBLE_EQ (m.intensity_max, 999 * 70.25 - 3.5);

  // Every input point once, with its intensity's exact bits (NaN and Inf included).
  const Keyed got = keyed (readFolder (dir.path.string ()), m);
  EXPECT_EQ (got.size (), cloud->size ());
  EXPECT_TRUE (got == keyed (*cloud, m));

  // Turned off, the records are positions only; PointXYZI reads 0.
  pcl::PotreeWriter<pcl::PointXYZI> plain;
  plain.setWriteIntensity (false);
  TempDir other;
  ASSERT_TRUE (plain.write (o, (other.path / "plain").string ()));
  pcl::PotreeReader rp;
  ASSERT_TRUE (rp.open ((other.path / "plain").string ()));
  EXPECT_FALSE (rp.getMetadata ().intensity);
  EXPECT_EQ (rp.getMetadata ().bytesPerPoint (), 12u);
  for (const auto& p : readFolder ((other.path / "plain").string ()))
    ASSERT_EQ (p.intensity, 0.f);
}

// A PCD file with intensity, built from the file in memory and under a memory budget: the
// intensity arrives in the folder, and both folders hold the same points node by node.
TEST (PotreeIntensity, FromAFileInMemoryAndUnderABudget)
{
  TempDir dir;
  auto cloud = intensityCloud (200000, omitest::Shape::UNIFORM);
  (*cloud)[5].x = std::numeric_limits<float>::quiet_NaN ();  // a dropped row
  const std::string pcd = (dir.path / "in.pcd").string ();
  ASSERT_EQ (pcl::io::savePCDFileBinary (pcd, *cloud), 0);
  cloud->erase (cloud->begin () + 5);

  pcl::ObliqueCutOctree<pcl::PointXYZI> mem;
  mem.setInputFile (pcd);
  mem.setMaxDepth (5);
  mem.setThreads (2);
  ASSERT_TRUE (mem.build ()) << mem.getLastError ();
  pcl::PotreeWriter<pcl::PointXYZI> w;
  ASSERT_TRUE (w.write (mem, (dir.path / "memory").string ()));

  pcl::ObliqueCutOctree<pcl::PointXYZI> bud;
  bud.setInputFile (pcd);
  bud.setMaxDepth (5);
  bud.setThreads (2);
  bud.setMemoryBudget (mem.getStatistics ().accounted_peak_bytes / 2);
  bud.setOutputDirectory ((dir.path / "budget").string ());
  ASSERT_TRUE (bud.build ()) << bud.getLastError ();
  EXPECT_GT (bud.getStatistics ().chunks, 1u);

  EXPECT_TRUE (keyed (readFolder ((dir.path / "memory").string ()), w.getMetadata ()) ==
               keyed (*cloud, w.getMetadata ()));
  pcl::PotreeReader rm, rb;
  ASSERT_TRUE (rm.open ((dir.path / "memory").string ()));
  ASSERT_TRUE (rb.open ((dir.path / "budget").string ()));
  EXPECT_DOUBLE_EQ (rb.getMetadata ().intensity_min, rm.getMetadata ().intensity_min);
  EXPECT_DOUBLE_EQ (rb.getMetadata ().intensity_max, rm.getMetadata ().intensity_max);
  ASSERT_EQ (rm.getNodes ().size (), rb.getNodes ().size ());
  CloudI a, b;
  for (std::size_t i = 0; i < rm.getNodes ().size (); ++i)
  {
    const long j = rb.find (rm.getNodes ()[i].code);
    ASSERT_GE (j, 0) << rm.getNodes ()[i].name;
    ASSERT_TRUE (rm.readNode (i, a) && rb.readNode (static_cast<std::size_t> (j), b));
    ASSERT_TRUE (keyed (a, rm.getMetadata ()) == keyed (b, rb.getMetadata ())) << rm.getNodes ()[i].name;
  }
}

// The 16-byte intensity point: from the same file, the same stored points and intensities as
// PointXYZI (32 bytes).
TEST (PotreeIntensity, PackedPointGivesThePointXYZIFolder)
{
  static_assert (sizeof (pclx::PointXYZIPacked) == 16, "x, y, z, intensity in 16 bytes");
  TempDir dir;
  const auto cloud = intensityCloud (40000);
  const std::string pcd = (dir.path / "in.pcd").string ();
  ASSERT_EQ (pcl::io::savePCDFileBinary (pcd, *cloud), 0);
  pcl::ObliqueCutOctree<pcl::PointXYZI> wide;
  pcl::ObliqueCutOctree<pclx::PointXYZIPacked> packed;
  wide.setInputFile (pcd);
  packed.setInputFile (pcd);
  wide.setMaxDepth (6);
  packed.setMaxDepth (6);
  ASSERT_TRUE (wide.build () && packed.build ());
  pcl::PotreeWriter<pcl::PointXYZI> ww;
  pcl::PotreeWriter<pclx::PointXYZIPacked> wp;
  ASSERT_TRUE (ww.write (wide, (dir.path / "wide").string ()));
  ASSERT_TRUE (wp.write (packed, (dir.path / "packed").string ()));
  for (const char* f : {"metadata.json", "hierarchy.bin", "octree.bin"})
    EXPECT_EQ (slurpText (dir.path / "wide" / f), slurpText (dir.path / "packed" / f)) << f;
  EXPECT_TRUE (keyed (readFolder ((dir.path / "packed").string ()), wp.getMetadata ()) ==
               keyed (*cloud, wp.getMetadata ()));
}

TEST (PointStreamReader, IntensityInEveryFormat)
{
  TempDir dir;
  const auto cloud = intensityCloud (3000);
  const auto same = [&] (const std::string& path, bool with_intensity) {
    pcl::PointStreamReader r;
    EXPECT_TRUE (r.open (path)) << r.getLastError ();
    EXPECT_EQ (r.hasIntensity (), with_intensity) << path;
    CloudI all, part;
    while (r.read (700, part))
      all += part;
    EXPECT_TRUE (r.getLastError ().empty ()) << r.getLastError ();
    if (all.size () != cloud->size ())
      return testing::AssertionFailure () << path << ": " << all.size () << " points";
    for (std::size_t i = 0; i < all.size (); ++i)
    {
      const float want = with_intensity ? (*cloud)[i].intensity : 0.f;
      const bool equal = std::isnan (want) ? std::isnan (all[i].intensity) : all[i].intensity == want;
      if (all[i].x != (*cloud)[i].x || !equal)
        return testing::AssertionFailure () << path << ": point " << i << " intensity " << all[i].intensity
                                            << " instead of " << want;
    }
    return testing::AssertionSuccess ();
  };
  pcl::PCDWriter pcd;
  ASSERT_EQ (pcd.writeBinary ((dir.path / "b.pcd").string (), *cloud), 0);
  ASSERT_EQ (pcd.writeBinaryCompressed ((dir.path / "c.pcd").string (), *cloud), 0);
  ASSERT_EQ (pcd.writeASCII ((dir.path / "a.pcd").string (), *cloud, 9), 0);
  EXPECT_TRUE (same ((dir.path / "b.pcd").string (), true));
  EXPECT_TRUE (same ((dir.path / "c.pcd").string (), true));
  EXPECT_TRUE (same ((dir.path / "a.pcd").string (), true));
  // Without the field, a PointXYZI reads 0 (and the float fast path still reads positions).
  pcl::PointCloud<pcl::PointXYZ> xyz;
  pcl::copyPointCloud (*cloud, xyz);
  ASSERT_EQ (pcd.writeBinary ((dir.path / "xyz.pcd").string (), xyz), 0);
  EXPECT_TRUE (same ((dir.path / "xyz.pcd").string (), false));

  // PLY as CloudCompare writes scalar fields (float) and as integer intensity (ushort).
  const auto ply = [&] (const std::string& name, const char* property, bool as_ushort) {
    std::ofstream f (dir.path / name, std::ios::binary);
    f << "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
         "property float z\nproperty "
      << (as_ushort ? "ushort " : "float ") << property << "\nend_header\n";
    for (int i = 0; i < 4; ++i)
    {
      const float v[3] = {float (i), 2.f * i, 3.f * i};
      f.write (reinterpret_cast<const char*> (v), sizeof v);
      if (as_ushort)
      {
        const std::uint16_t s = static_cast<std::uint16_t> (60000 + i);
        f.write (reinterpret_cast<const char*> (&s), 2);
      }
      else
      {
        const float s = 0.25f * i;
        f.write (reinterpret_cast<const char*> (&s), 4);
      }
    }
  };
  ply ("cc.ply", "scalar_Intensity", false);
  ply ("u16.ply", "intensity", true);
  for (const char* name : {"cc.ply", "u16.ply"})
  {
    pcl::PointStreamReader r ((dir.path / name).string ());
    ASSERT_TRUE (r.hasIntensity ()) << name;
    CloudI c;
    ASSERT_TRUE (r.read (10, c));
    ASSERT_EQ (c.size (), 4u);
    for (int i = 0; i < 4; ++i)
    {
      EXPECT_EQ (c[i].y, 2.f * i);
      EXPECT_EQ (c[i].intensity, std::string (name) == "cc.ply" ? 0.25f * i : 60000.f + i) << name << " " << i;
    }
  }
}

// Colour and intensity together (colourised laser scans): a PCD file with both, read into
// pclx::PointXYZRGBI, built from the file and written; both attributes read back per point.
TEST (PotreeIntensity, ColourAndIntensityTogether)
{
  TempDir dir;
  const auto xyzi = intensityCloud (30000);
  pcl::PointCloud<pclx::PointXYZRGBI> cloud;
  cloud.resize (xyzi->size ());
  for (std::size_t i = 0; i < cloud.size (); ++i)
  {
    cloud[i].getVector3fMap () = (*xyzi)[i].getVector3fMap ();
    cloud[i].intensity = (*xyzi)[i].intensity;
    cloud[i].r = static_cast<std::uint8_t> (i * 7);
    cloud[i].g = static_cast<std::uint8_t> (i * 13);
    cloud[i].b = static_cast<std::uint8_t> (255 - i % 256);
  }
  const std::string pcd = (dir.path / "both.pcd").string ();
  ASSERT_EQ (pcl::io::savePCDFileBinary (pcd, cloud), 0);
  {
    pcl::PointStreamReader r (pcd);
    EXPECT_TRUE (r.hasColor () && r.hasIntensity ());
  }
  pcl::ObliqueCutOctree<pclx::PointXYZRGBI> o;
  o.setInputFile (pcd);
  o.setMaxDepth (6);
  ASSERT_TRUE (o.build ()) << o.getLastError ();
  pcl::PotreeWriter<pclx::PointXYZRGBI> w;
  ASSERT_TRUE (w.write (o, (dir.path / "potree").string ())) << w.getLastError ();

  pcl::PotreeReader r;
  ASSERT_TRUE (r.open ((dir.path / "potree").string ()));
  const auto& m = r.getMetadata ();
  EXPECT_TRUE (m.rgb && m.intensity);
  EXPECT_EQ (m.bytesPerPoint (), 12u + 6u + 4u);
  // Position quantum, colour and intensity bits of every point, as multisets.
  using Key = std::tuple<std::int64_t, std::int64_t, std::int64_t, int, int, int, std::uint32_t>;
  const auto key = [&] (const pclx::PointXYZRGBI& p) {
    std::uint32_t bits;
    std::memcpy (&bits, &p.intensity, 4);
    std::int64_t q[3];
    for (int a = 0; a < 3; ++a)
      q[a] = std::llround ((double (p.data[a]) - m.offset[a]) / m.scale[a]);
    return Key (q[0], q[1], q[2], p.r, p.g, p.b, bits);
  };
  std::multiset<Key> want, got;
  for (const auto& p : cloud)
    want.insert (key (p));
  pcl::PointCloud<pclx::PointXYZRGBI> node;
  for (std::size_t i = 0; i < r.getNodes ().size (); ++i)
  {
    ASSERT_TRUE (r.readNode (i, node));
    for (const auto& p : node)
      got.insert (key (p));
  }
  EXPECT_EQ (got.size (), cloud.size ());
  EXPECT_TRUE (got == want);
}

// A folder laid out as PotreeConverter writes LAS input: intensity as uint16 among attributes
// this reader skips (returns, classification, gps-time, extra bytes of a type it does not
// know), rgb last.
TEST (PotreeReader, ReadsPotreeConverterAttributesAndSkipsTheOthers)
{
  TempDir dir;
  const fs::path d = dir.path / "converter";
  fs::create_directories (d);
  struct Attr
  {
    const char* name;
    const char* type;
    int size, elements;
  };
  const Attr attrs[] = {{"position", "int32", 12, 3},         {"intensity", "uint16", 2, 1},
                        {"return number", "uint8", 1, 1},    {"number of returns", "uint8", 1, 1},
                        {"classification", "uint8", 1, 1},   {"scan angle rank", "uint8", 1, 1},
                        {"user data", "uint8", 1, 1},        {"point source id", "uint16", 2, 1},
                        {"gps-time", "double", 8, 1},        {"extra", "undefined", 3, 3},
                        {"rgb", "uint16", 6, 3}};
  const auto metadata = [&] (const std::string& attributes) {
    std::ofstream (d / "metadata.json")
        << "{\"version\": \"2.0\", \"name\": \"las\", \"points\": 3, \"projection\": \"\","
           "\"hierarchy\": {\"firstChunkSize\": 22, \"stepSize\": 4, \"depth\": 0},"
           "\"offset\": [10, 20, 30], \"scale\": [0.01, 0.01, 0.01], \"spacing\": 1,"
           "\"boundingBox\": {\"min\": [10, 20, 30], \"max\": [20, 30, 40]}, \"encoding\": \"DEFAULT\","
           "\"attributes\": ["
        << attributes << "]}";
  };
  std::string list;
  int bpp = 0;
  for (const Attr& a : attrs)
  {
    const std::string range = a.elements == 3 ? "[0, 0, 0]" : "[0]";
    list += std::string (list.empty () ? "" : ",") + "{\"name\": \"" + a.name + "\", \"size\": " +
            std::to_string (a.size) + ", \"numElements\": " + std::to_string (a.elements) + ", \"elementSize\": " +
            std::to_string (a.size / a.elements) + ", \"type\": \"" + a.type + "\", \"min\": " + range +
            ", \"max\": " + range + "}";
    bpp += a.size;
  }
  ASSERT_EQ (bpp, 12 + 2 + 5 + 2 + 8 + 3 + 6);
  metadata (list);
  std::vector<std::uint8_t> octree (3 * bpp, 0xAB);  // the skipped bytes hold a pattern
  for (int k = 0; k < 3; ++k)
  {
    std::uint8_t* rec = octree.data () + k * bpp;
    const std::int32_t q[3] = {100 * k, 200 * k, 300 * k};
    std::memcpy (rec, q, 12);
    const std::uint16_t intensity = static_cast<std::uint16_t> (1000 * k + 7);
    std::memcpy (rec + 12, &intensity, 2);
    const std::uint16_t rgb[3] = {static_cast<std::uint16_t> (257 * 10 * k), 257 * 200, 0};
    std::memcpy (rec + bpp - 6, rgb, 6);
  }
  writeBytes (d / "octree.bin", octree);
  std::vector<std::uint8_t> h (22, 0);
  h[0] = 1;  // a leaf
  const std::uint32_t points = 3;
  const std::uint64_t offset = 0, size = octree.size ();
  std::memcpy (h.data () + 2, &points, 4);
  std::memcpy (h.data () + 6, &offset, 8);
  std::memcpy (h.data () + 14, &size, 8);
  writeBytes (d / "hierarchy.bin", h);

  pcl::PotreeReader r;
  ASSERT_TRUE (r.open (d.string ())) << r.getLastError ();
  EXPECT_EQ (r.getMetadata ().bytesPerPoint (), static_cast<std::uint32_t> (bpp));
  CloudI ci;
  pcl::PointCloud<pcl::PointXYZRGB> crgb;
  ASSERT_TRUE (r.readNode (0, ci));
  ASSERT_TRUE (r.readNode (0, crgb));
  ASSERT_EQ (ci.size (), 3u);
  for (int k = 0; k < 3; ++k)
  {
    EXPECT_FLOAT_EQ (ci[k].x, 10.f + k);
    EXPECT_FLOAT_EQ (ci[k].z, 30.f + 3.f * k);
    EXPECT_EQ (ci[k].intensity, 1000.f * k + 7.f);
    EXPECT_EQ (crgb[k].r, 10 * k);
    EXPECT_EQ (crgb[k].g, 200);
    EXPECT_FLOAT_EQ (crgb[k].y, 20.f + 2.f * k);
  }

  // Malformed attribute lists: an unknown type, an intensity of two values, rgb as bytes, a
  // zero-size attribute. Each is refused with a reason and no nodes.
  const std::string pos = "{\"name\": \"position\", \"size\": 12, \"type\": \"int32\", \"min\": [0, 0, 0], "
                          "\"max\": [0, 0, 0]}";
  for (const std::string bad :
       {pos + ", {\"name\": \"intensity\", \"size\": 2, \"type\": \"float16\"}",
        pos + ", {\"name\": \"intensity\", \"size\": 4, \"type\": \"uint16\"}",
        pos + ", {\"name\": \"rgb\", \"size\": 3, \"type\": \"uint8\"}",
        pos + ", {\"name\": \"classification\", \"size\": 0, \"type\": \"uint8\"}",
        std::string ("{\"name\": \"intensity\", \"size\": 2, \"type\": \"uint16\"}")})
  {
    metadata (bad);
    EXPECT_FALSE (r.open (d.string ())) << bad;
    EXPECT_FALSE (r.getLastError ().empty ());
    EXPECT_TRUE (r.getNodes ().empty ());
  }
}
