// Additive Potree output: every kept input point is stored exactly once. This test writes the
// folders that check_potree_additive.py (an independent parser, run by CTest with
// PCLX_OMICRON_CHECK_DIR set) checks against the input file, and checks in C++ what the
// library's own reader can tell: stored count, NaN rows dropped, empty nodes.
#include <pclx/omicron/oblique_cut_octree.h>
#include <pclx/omicron/potree_reader.h>
#include <pclx/omicron/potree_writer.h>

#include <pcl/io/pcd_io.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <random>

namespace fs = std::filesystem;
using Octree = pcl::ObliqueCutOctree<pcl::PointXYZRGB>;

namespace {

// Clusters, a plane, uniform noise and exact duplicates.
std::vector<std::array<float, 3>>
makePoints (std::size_t n, unsigned seed)
{
  std::mt19937 rng (seed);
  std::uniform_real_distribution<float> u (-2.f, 5.f);
  std::normal_distribution<float> g (0.f, 0.05f);
  std::vector<std::array<float, 3>> pts;
  std::array<float, 3> centres[6];
  for (auto& c : centres)
    c = {u (rng), u (rng), u (rng)};
  while (pts.size () < n)
  {
    const std::size_t i = pts.size ();
    if (i % 10 < 4)
    {
      const auto& c = centres[rng () % 6];
      pts.push_back ({c[0] + g (rng), c[1] + g (rng), c[2] + g (rng)});
    }
    else if (i % 10 < 7)
      pts.push_back ({u (rng), 0.75f, u (rng)});
    else if (i % 10 < 9 || i < 100)
      pts.push_back ({u (rng), u (rng), u (rng)});
    else
      pts.push_back (pts[rng () % i]);  // an exact duplicate: must be stored twice, not once
  }
  return pts;
}

// Writes an .xyz file "x y z r g b" of makePoints (), with `invalid` NaN / Inf rows spread
// through it; returns the number of rows written.
std::size_t
writeInput (const fs::path& path, std::size_t n, std::size_t invalid, unsigned seed)
{
  const std::vector<std::array<float, 3>> pts = makePoints (n, seed);
  std::ofstream f (path);
  f << std::setprecision (9);
  const std::size_t every = n / (invalid + 1);
  std::size_t rows = 0;
  for (std::size_t i = 0; i < n; ++i)
  {
    if (invalid && i % every == every / 2 && i / every < invalid)
    {
      const char* bad = (i / every) % 3 == 0 ? "nan" : ((i / every) % 3 == 1 ? "inf" : "-nan");
      f << "0.5 " << bad << " 1.25 10 20 30\n";
      ++rows;
    }
    f << pts[i][0] << ' ' << pts[i][1] << ' ' << pts[i][2] << ' ' << (i * 7) % 256 << ' ' << (i * 13) % 256 << ' '
      << 255 - i % 256 << '\n';
    ++rows;
  }
  return rows;
}

// The folder `sub` of what the checker reads (CTest sets PCLX_OMICRON_CHECK_DIR), or a fresh
// temp folder.
fs::path
outputRoot (const std::string& sub, bool& temporary)
{
  const char* env = std::getenv ("PCLX_OMICRON_CHECK_DIR");
  temporary = !env || !*env;
  const fs::path root =
      temporary ? fs::temp_directory_path () / ("pclx_additive_" + std::to_string (::getpid ()) + "_" + sub)
                : fs::path (env) / sub;
  fs::remove_all (root);
  fs::create_directories (root);
  return root;
}

// Stored points of a folder and its empty nodes (0 points), leaves among them.
struct Stored
{
  std::uint64_t points = 0;
  std::size_t nodes = 0, empty = 0, empty_leaves = 0;
};
Stored
stored (const std::string& dir)
{
  pcl::PotreeReader r;
  r.open (dir);
  Stored s;
  s.points = r.getStoredPoints ();
  s.nodes = r.getNodes ().size ();
  EXPECT_EQ (r.getMetadata ().points, s.points) << dir;
  for (const auto& n : r.getNodes ())
  {
    s.empty += n.num_points == 0 ? 1 : 0;
    s.empty_leaves += n.num_points == 0 && n.child_mask == 0 ? 1 : 0;
  }
  return s;
}

}  // namespace

TEST (PotreeAdditive, FoldersForTheIndependentChecker)
{
  bool temporary = false;
  const fs::path root = outputRoot ("xyz", temporary);
  const std::size_t n = 200000, invalid = 12;
  const std::size_t rows = writeInput (root / "input.xyz", n, invalid, 17);
  ASSERT_EQ (rows, n + invalid);

  // In memory at the library's defaults (leaf collapse, all cores, subtrees of up to 20k
  // points as one leaf) but depth 5, so half of this small input's footprint still holds a
  // budgeted build's retained tree.
  Octree mem;
  mem.setInputFile ((root / "input.xyz").string ());
  mem.setMaxDepth (5);
  ASSERT_TRUE (mem.build ()) << mem.getLastError ();
  const auto ms = mem.getStatistics ();
  EXPECT_EQ (ms.dropped_invalid, invalid);
  EXPECT_EQ (ms.kept_points, n);
  pcl::PotreeWriter<pcl::PointXYZRGB> writer;
  writer.write (mem, (root / "memory").string ());
  const Stored sm = stored ((root / "memory").string ());
  EXPECT_EQ (sm.points, n);
  EXPECT_EQ (sm.empty_leaves, 0u);

  // Budgeted, half the in-memory footprint: the same folder, written while spilling.
  Octree bud;
  bud.setInputFile ((root / "input.xyz").string ());
  bud.setMaxDepth (5);
  bud.setMemoryBudget (ms.accounted_peak_bytes / 2);
  bud.setOutputDirectory ((root / "budget").string ());
  ASSERT_TRUE (bud.build ()) << bud.getLastError ();
  EXPECT_GE (bud.getSpillLevel (), 1);
  EXPECT_GT (bud.getStatistics ().chunks, 1u);
  const Stored sb = stored ((root / "budget").string ());
  EXPECT_EQ (sb.points, n);
  EXPECT_EQ (sb.nodes, sm.nodes);

  // Deep, without leaf collapse and with every node written: about one point per leaf, so
  // coarser levels take whole nodes and the output has empty nodes to drop. An inner node
  // above a stored point is never empty: its grid took the first point of that point's cell.
  Octree deep;
  deep.setInputFile ((root / "input.xyz").string ());
  deep.setMaxDepth (10);
  deep.setLeafCollapse (false);
  ASSERT_TRUE (deep.build ()) << deep.getLastError ();
  writer.setLeafPointLimit (0);  // every node, not subtrees merged into leaves
  writer.write (deep, (root / "deep").string ());
  const Stored sd = stored ((root / "deep").string ());
  EXPECT_EQ (sd.points, n);
  EXPECT_EQ (sd.empty_leaves, 0u);
  std::size_t built = 0;
  for (std::size_t c : deep.getStatistics ().nodes_per_level)
    built += c;
  EXPECT_LT (sd.nodes, built);  // empty leaves were dropped
  EXPECT_EQ (sd.empty, 0u);
  if (temporary)
    fs::remove_all (root);
}

// Intensity from an ASCII PCD file (PCL's writer, 9 digits: every float exact), in memory and
// under a budget, for the checker to compare as float bits with the file's values.
TEST (PotreeAdditive, IntensityFoldersForTheIndependentChecker)
{
  bool temporary = false;
  const fs::path root = outputRoot ("intensity", temporary);
  const std::size_t n = 200000;
  const std::vector<std::array<float, 3>> pts = makePoints (n, 23);
  pcl::PointCloud<pcl::PointXYZI> cloud;
  for (std::size_t i = 0; i < n; ++i)
  {
    pcl::PointXYZI p;
    p.x = pts[i][0];
    p.y = pts[i][1];
    p.z = pts[i][2];
    p.intensity = static_cast<float> (i % 4099) * 16.0625f - 1000.f;
    cloud.push_back (p);
  }
  cloud[10].intensity = std::numeric_limits<float>::quiet_NaN ();
  cloud[20].y = std::numeric_limits<float>::quiet_NaN ();  // a dropped row
  const std::string input = (root / "input.pcd").string ();
  ASSERT_EQ (pcl::PCDWriter ().writeASCII (input, cloud, 9), 0);

  using OctreeI = pcl::ObliqueCutOctree<pcl::PointXYZI>;
  OctreeI mem;
  mem.setInputFile (input);
  mem.setMaxDepth (5);
  ASSERT_TRUE (mem.build ()) << mem.getLastError ();
  EXPECT_EQ (mem.getStatistics ().dropped_invalid, 1u);
  pcl::PotreeWriter<pcl::PointXYZI> writer;
  ASSERT_TRUE (writer.write (mem, (root / "memory").string ()));
  EXPECT_EQ (stored ((root / "memory").string ()).points, n - 1);

  OctreeI bud;
  bud.setInputFile (input);
  bud.setMaxDepth (5);
  bud.setMemoryBudget (mem.getStatistics ().accounted_peak_bytes * 2 / 3);
  bud.setOutputDirectory ((root / "budget").string ());
  ASSERT_TRUE (bud.build ()) << bud.getLastError ();
  EXPECT_GT (bud.getStatistics ().chunks, 1u);
  EXPECT_EQ (stored ((root / "budget").string ()).points, n - 1);
  if (temporary)
    fs::remove_all (root);
}
