// PointStreamReader: every format PCL writes (and hand-made PLY / XYZ) read back in chunks
// equals the cloud; NaN/Inf dropped and counted; empty, truncated and garbage files are refused.
#include "omicron_test_util.h"

#include <pclx/omicron/detail/block_reader.h>
#include <pclx/omicron/point_stream_reader.h>

#include <pcl/exceptions.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <stdexcept>
#include <unistd.h>

namespace fs = std::filesystem;
using omitest::TempDir;
using Cloud = pcl::PointCloud<pcl::PointXYZRGB>;

namespace {
Cloud
randomCloud (std::size_t n, std::size_t nans)
{
  std::mt19937 rng (7);
  std::uniform_real_distribution<float> u (-50.f, 50.f);
  Cloud c;
  for (std::size_t i = 0; i < n; ++i)
  {
    pcl::PointXYZRGB p;
    p.x = u (rng);
    p.y = u (rng);
    p.z = u (rng);
    p.r = static_cast<std::uint8_t> (rng ());
    p.g = static_cast<std::uint8_t> (rng ());
    p.b = static_cast<std::uint8_t> (rng ());
    if (i % (n / std::max<std::size_t> (1, nans)) == 3 && nans)
      (i % 2 ? p.x : p.z) = i % 3 ? std::numeric_limits<float>::quiet_NaN () : std::numeric_limits<float>::infinity ();
    c.push_back (p);
  }
  return c;
}

Cloud
readAll (const std::string& path, std::size_t chunk, pcl::PointStreamReader* keep = nullptr)
{
  pcl::PointStreamReader local;
  pcl::PointStreamReader& r = keep ? *keep : local;
  Cloud all, part;
  if (!r.open (path))
    return all;
  while (r.read (chunk, part))
  {
    EXPECT_LE (part.size (), chunk);
    all += part;
  }
  return all;
}

void
expectSame (const Cloud& got, const Cloud& want, bool colour, float tol)
{
  Cloud finite;
  for (const auto& p : want)
    if (std::isfinite (p.x) && std::isfinite (p.y) && std::isfinite (p.z))
      finite.push_back (p);
  ASSERT_EQ (got.size (), finite.size ());
  for (std::size_t i = 0; i < got.size (); ++i)
  {
    ASSERT_NEAR (got[i].x, finite[i].x, tol) << i;
    ASSERT_NEAR (got[i].y, finite[i].y, tol) << i;
    ASSERT_NEAR (got[i].z, finite[i].z, tol) << i;
    if (colour)
    {
      ASSERT_EQ (got[i].r, finite[i].r) << i;
      ASSERT_EQ (got[i].g, finite[i].g) << i;
      ASSERT_EQ (got[i].b, finite[i].b) << i;
    }
  }
}

// The file is refused by open () or read (): false, a message naming the file and the
// problem, and the reader closed.
void
expectError (const std::string& path, const std::string& fragment)
{
  pcl::PointStreamReader r;
  readAll (path, 1000, &r);
  const std::string& e = r.getLastError ();
  EXPECT_FALSE (e.empty ()) << "no error for " << path;
  EXPECT_NE (e.find (fragment), std::string::npos) << e;
  EXPECT_NE (e.find (path), std::string::npos) << e;
  EXPECT_FALSE (r.isOpen ());
  pcl::PointCloud<pcl::PointXYZRGB> more;
  EXPECT_FALSE (r.read (10, more));
  EXPECT_TRUE (more.empty ());
}
}  // namespace

TEST (PointStreamReader, EveryPCLFormatReadsBackInChunks)
{
  TempDir dir;
  const Cloud cloud = randomCloud (5000, 40);
  const std::string base = (dir.path / "c").string ();
  ASSERT_EQ (pcl::io::savePCDFileBinary (base + "_b.pcd", cloud), 0);
  ASSERT_EQ (pcl::io::savePCDFileASCII (base + "_a.pcd", cloud), 0);
  ASSERT_EQ (pcl::io::savePCDFileBinaryCompressed (base + "_c.pcd", cloud), 0);
  ASSERT_EQ (pcl::io::savePLYFileBinary (base + "_b.ply", cloud), 0);
  ASSERT_EQ (pcl::io::savePLYFileASCII (base + "_a.ply", cloud), 0);
  for (const char* suffix : {"_b.pcd", "_a.pcd", "_c.pcd", "_b.ply", "_a.ply"})
    for (std::size_t chunk : {1ul, 777ul, 100000ul})
    {
      SCOPED_TRACE (std::string (suffix) + " chunk " + std::to_string (chunk));
      pcl::PointStreamReader r;
      const Cloud got = readAll (base + suffix, chunk, &r);
      EXPECT_TRUE (r.hasColor ());
      EXPECT_EQ (r.getDeclaredPoints (), cloud.size ());
      const bool ascii = std::strstr (suffix, "_a") != nullptr;
      expectSame (got, cloud, true, ascii ? 1e-4f : 0.f);
      // PCL's ascii PLY writer drops non-finite points itself.
      if (std::string (suffix) != "_a.ply")
        EXPECT_EQ (r.getDroppedInvalid (), 40u);
      EXPECT_EQ (r.getPointsRead (), got.size ());
      // A second pass gives the same points.
      r.rewind ();
      Cloud again, part;
      while (r.read (chunk == 1 ? 1000 : chunk, part))
        again += part;
      EXPECT_EQ (again.size (), got.size ());
      // Read as PointXYZ (binary float files take the direct path): the same coordinates.
      r.rewind ();
      pcl::PointCloud<pcl::PointXYZ> xyz, xyz_part;
      while (r.read (chunk, xyz_part))
        xyz += xyz_part;
      EXPECT_TRUE (r.getLastError ().empty ()) << r.getLastError ();
      ASSERT_EQ (xyz.size (), got.size ());
      std::size_t differ = 0;
      for (std::size_t i = 0; i < xyz.size (); ++i)
        differ += (xyz[i].x != got[i].x || xyz[i].y != got[i].y || xyz[i].z != got[i].z) ? 1 : 0;
      EXPECT_EQ (differ, 0u);
      EXPECT_EQ (r.getPointsRead (), got.size ());
      EXPECT_EQ (r.getDroppedInvalid () + r.getPointsRead (), cloud.size ());
    }
  // Other point types: xyz only.
  pcl::PointStreamReader r (base + "_b.pcd");
  pcl::PointCloud<pcl::PointXYZ> xyz;
  ASSERT_TRUE (r.read (10, xyz));
  EXPECT_EQ (xyz.size (), 10u);
}

TEST (PointStreamReader, HandMadePLYAndXYZ)
{
  TempDir dir;
  // Binary PLY with double coordinates, ushort colour, an element before the vertices.
  {
    std::ofstream f (dir.path / "d.ply", std::ios::binary);
    f << "ply\nformat binary_little_endian 1.0\ncomment made by hand\nelement info 2\nproperty int a\n"
         "element vertex 3\nproperty double x\nproperty double y\nproperty double z\nproperty float nx\n"
         "property ushort red\nproperty ushort green\nproperty ushort blue\nelement face 0\n"
         "property list uchar int vertex_indices\nend_header\n";
    const std::int32_t info[2] = {11, 22};
    f.write (reinterpret_cast<const char*> (info), 8);
    for (int i = 0; i < 3; ++i)
    {
      const double xyz[3] = {i + 0.5, i == 1 ? std::nan ("") : -2.0 * i, 1e6 + i};
      const float nx = 1.f;
      const std::uint16_t c[3] = {static_cast<std::uint16_t> (257 * 10 * i), 65535, 0};
      f.write (reinterpret_cast<const char*> (xyz), 24);
      f.write (reinterpret_cast<const char*> (&nx), 4);
      f.write (reinterpret_cast<const char*> (c), 6);
    }
  }
  pcl::PointStreamReader r;
  const Cloud got = readAll ((dir.path / "d.ply").string (), 2, &r);
  ASSERT_EQ (got.size (), 2u);
  EXPECT_EQ (r.getDroppedInvalid (), 1u);
  EXPECT_FLOAT_EQ (got[1].x, 2.5f);
  EXPECT_FLOAT_EQ (got[1].y, -4.f);
  EXPECT_FLOAT_EQ (got[1].z, 1e6f + 2.f);
  EXPECT_EQ (got[1].r, 20);
  EXPECT_EQ (got[1].g, 255);
  EXPECT_EQ (got[1].b, 0);
  // XYZ text: comments, commas, tabs, optional colour.
  std::ofstream (dir.path / "p.xyz") << "# comment\n1 2 3\n\n4,5,6, 10, 20, 30\r\n7\t8\t9\nnan 1 1\n";
  const Cloud xyz = readAll ((dir.path / "p.xyz").string (), 2, &r);
  ASSERT_EQ (xyz.size (), 3u);
  EXPECT_EQ (r.getDroppedInvalid (), 1u);
  EXPECT_FLOAT_EQ (xyz[1].y, 5.f);
  EXPECT_EQ (xyz[1].g, 20);
  EXPECT_FLOAT_EQ (xyz[2].z, 9.f);
}

TEST (PointStreamReader, EmptyTruncatedAndGarbageFilesAreClearErrors)
{
  TempDir dir;
  const Cloud cloud = randomCloud (1000, 0);
  const auto p = [&] (const char* name) { return (dir.path / name).string (); };
  ASSERT_EQ (pcl::io::savePCDFileBinary (p ("b.pcd"), cloud), 0);
  ASSERT_EQ (pcl::io::savePCDFileASCII (p ("a.pcd"), cloud), 0);
  ASSERT_EQ (pcl::io::savePLYFileBinary (p ("b.ply"), cloud), 0);
  ASSERT_EQ (pcl::io::savePCDFileBinaryCompressed (p ("c.pcd"), cloud), 0);
  const auto truncate = [&] (const char* from, const char* to, double keep) {
    fs::copy_file (p (from), p (to));
    fs::resize_file (p (to), static_cast<std::uintmax_t> (fs::file_size (p (from)) * keep));
  };
  truncate ("b.pcd", "tb.pcd", 0.7);
  truncate ("a.pcd", "ta.pcd", 0.7);
  truncate ("b.ply", "tb.ply", 0.7);
  truncate ("c.pcd", "tc.pcd", 0.7);
  truncate ("b.pcd", "header_only.pcd", 0.0);
  for (const char* e : {"e.pcd", "e.ply", "e.xyz"})
    std::ofstream (dir.path / e);
  std::ofstream (dir.path / "one.pcd") << "#";
  std::ofstream (dir.path / "g.pcd") << "hello world\n";
  std::ofstream (dir.path / "g.ply") << "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nend_header\n1\n2\n";
  std::ofstream (dir.path / "g.xyz") << "1 2 3\n4 5\n";
  std::ofstream (dir.path / "h.xyz") << "1 2 x\n";
  std::ofstream (dir.path / "big.pcd") << "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 99999999999\nPOINTS 99999999999\nDATA binary\n";
  expectError (p ("tb.pcd"), "truncated");
  expectError (p ("ta.pcd"), "truncated");
  expectError (p ("tb.ply"), "truncated");
  expectError (p ("tc.pcd"), "truncated");
  expectError (p ("e.pcd"), "empty");
  expectError (p ("e.ply"), "empty");
  expectError (p ("e.xyz"), "empty");
  expectError (p ("one.pcd"), "DATA");
  expectError (p ("g.pcd"), "unknown keyword");
  expectError (p ("g.ply"), "x, y and z");
  expectError (p ("g.xyz"), "line 2");
  expectError (p ("h.xyz"), "not a number");
  expectError (p ("big.pcd"), "truncated");
  expectError (p ("missing.pcd"), "cannot open");
  expectError (p ("cloud.las"), "extension");
  fs::create_directories (dir.path / "dir.pcd");
  expectError (p ("dir.pcd"), "");
  // A refused max_points leaves the reader open.
  pcl::PointStreamReader r;
  ASSERT_TRUE (r.open (p ("b.pcd")));
  pcl::PointCloud<pcl::PointXYZRGB> block;
  EXPECT_FALSE (r.read (0, block));
  EXPECT_FALSE (r.getLastError ().empty ());
  EXPECT_TRUE (r.isOpen ());
  EXPECT_TRUE (r.read (10, block));
  EXPECT_EQ (block.size (), 10u);
  // The direct PointXYZ path: a refused max_points and a reader closed by an error.
  pcl::PointCloud<pcl::PointXYZ> xyz;
  EXPECT_FALSE (r.read (0, xyz));
  EXPECT_TRUE (r.isOpen ());
  EXPECT_TRUE (r.read (10, xyz));
  EXPECT_EQ (xyz.size (), 10u);
  pcl::PointStreamReader t;
  EXPECT_FALSE (t.open (p ("tb.pcd")));
  EXPECT_FALSE (t.read (100, xyz));
  EXPECT_TRUE (xyz.empty ());
}

// readBlocksAhead: every block in file order; on_block stopping the read, throwing, and a
// reader error all end it with the reader thread joined (no hang).
TEST (PointStreamReader, BlocksReadAheadInOrderAndStopCleanly)
{
  TempDir dir;
  const Cloud cloud = randomCloud (10000, 0);
  const std::string path = (dir.path / "b.pcd").string ();
  ASSERT_EQ (pcl::io::savePCDFileBinary (path, cloud), 0);
  // A text file whose line 3001 is not a number: the reader fails in the fourth block.
  const std::string bad = (dir.path / "bad.xyz").string ();
  {
    std::ofstream f (bad);
    for (int i = 0; i < 3000; ++i)
      f << i * 0.001 << " " << i * 0.002 << " 0.5\n";
    f << "1.0 oops 2.0\n";
  }
  Cloud blocks[2];
  {
    pcl::PointStreamReader r (path);
    Cloud all;
    int after = 0;
    EXPECT_TRUE (pclx::omicron::detail::readBlocksAhead (
        r, 1000, blocks,
        [&] (const Cloud& b) {
          all.insert (all.end (), b.begin (), b.end ());
          return true;
        },
        [&] { ++after; }));
    ASSERT_EQ (all.size (), cloud.size ());
    for (std::size_t i = 0; i < all.size (); ++i)
      ASSERT_TRUE (all[i].x == cloud[i].x && all[i].y == cloud[i].y && all[i].z == cloud[i].z && all[i].rgba == cloud[i].rgba) << i;
    EXPECT_GE (after, 10);
  }
  {
    pcl::PointStreamReader r (path);
    int seen = 0;
    EXPECT_FALSE (pclx::omicron::detail::readBlocksAhead (r, 1000, blocks, [&] (const Cloud&) { return ++seen < 3; }, [] {}));
    EXPECT_EQ (seen, 3);
  }
  {
    pcl::PointStreamReader r (path);
    int seen = 0;
    EXPECT_THROW (pclx::omicron::detail::readBlocksAhead (r, 1000, blocks,
                                                          [&] (const Cloud&) {
                                                            if (++seen == 2)
                                                              throw std::runtime_error ("stop");
                                                            return true;
                                                          },
                                                          [] {}),
                  std::runtime_error);
    EXPECT_EQ (seen, 2);
  }
  {
    pcl::PointStreamReader r (bad);
    ASSERT_TRUE (r.isOpen ()) << r.getLastError ();
    std::size_t points = 0;
    EXPECT_FALSE (pclx::omicron::detail::readBlocksAhead (
        r, 1000, blocks,
        [&] (const Cloud& b) {
          points += b.size ();
          return true;
        },
        [] {}));
    EXPECT_NE (r.getLastError ().find ("bad.xyz"), std::string::npos) << r.getLastError ();
    EXPECT_EQ (points, 3000u);
  }
}
