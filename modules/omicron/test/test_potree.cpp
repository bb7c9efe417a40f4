// PotreeWriter / PotreeReader: an octree written and read back agrees with the in-memory
// hierarchy; the bytes follow PotreeConverter 2.x's layout; bad folders and files are errors.
#include "omicron_test_util.h"

#include <pclx/omicron/oblique_cut_octree.h>
#include <pclx/omicron/potree_reader.h>
#include <pclx/omicron/potree_writer.h>

#include <pcl/exceptions.h>

#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <set>

namespace fs = std::filesystem;
using omitest::TempDir;
using omitest::Shape;

namespace {
pcl::PointCloud<pcl::PointXYZRGB>::Ptr
colouredCloud (Shape shape, std::size_t n, unsigned seed)
{
  const auto c = omitest::makeCloud (shape, n, seed);
  pcl::PointCloud<pcl::PointXYZRGB>::Ptr out (new pcl::PointCloud<pcl::PointXYZRGB>);
  out->resize (c->size ());
  for (std::size_t i = 0; i < c->size (); ++i)
  {
    (*out)[i].x = (*c)[i].x;
    (*out)[i].y = (*c)[i].y;
    (*out)[i].z = (*c)[i].z;
    (*out)[i].r = static_cast<std::uint8_t> (i * 7);
    (*out)[i].g = static_cast<std::uint8_t> (i * 13);
    (*out)[i].b = static_cast<std::uint8_t> (255 - i % 256);
  }
  return out;
}

std::vector<std::uint8_t>
slurp (const fs::path& p)
{
  std::ifstream in (p, std::ios::binary);
  return std::vector<std::uint8_t> ((std::istreambuf_iterator<char> (in)), std::istreambuf_iterator<char> ());
}

// What the output should hold, from the specification alone: records are whole subtrees of
// at most `limit` points (or leaves), else a node and its children's records; in depth-first
// order, a point goes to the first level l below its record's level whose cell of edge
// root / (128 · 2^l) no earlier point took at l (one set of cells per level, over the whole
// cloud), else to its record.
template <typename PointT>
struct ExpectedOutput
{
  std::map<std::uint64_t, std::vector<PointT>> records;  // by code bits, each in depth-first order
  std::map<std::uint64_t, bool> whole;                    // a whole subtree (leaf record)

  ExpectedOutput (const pcl::ObliqueCutOctree<PointT>& octree, std::uint32_t limit)
  {
    origin_ = octree.getRootOrigin ();
    edge_ = octree.getRootEdge ();
    visit (*octree.getRoot (), limit, {});
    // Records whose subtree stores nothing are left out.
    std::set<std::uint64_t> stored;
    for (const auto& [bits, points] : records)
      if (!points.empty ())
        for (std::uint64_t b = bits; b != 0 && stored.insert (b).second; b >>= 3)
        {
        }
    for (auto it = records.begin (); it != records.end ();)
      it = stored.count (it->first) ? std::next (it) : records.erase (it);
  }

private:
  static std::size_t
  total (const pclx::omicron::detail::Node<PointT>& n)
  {
    std::size_t k = n.isLeaf () ? n.num_points : 0;
    for (int c = 0; c < n.num_children; ++c)
      k += total (n.children[c]);
    return k;
  }
  void
  visit (const pclx::omicron::detail::Node<PointT>& n, std::uint32_t limit, std::vector<std::uint64_t> path)
  {
    if (total (n) == 0)
      return;
    path.push_back (n.code.bits ());
    if (n.isLeaf () || (limit > 0 && total (n) <= limit))
    {
      whole[n.code.bits ()] = true;
      records[n.code.bits ()];
      take (n, path);
      return;
    }
    whole[n.code.bits ()] = false;
    records[n.code.bits ()];
    for (int c = 0; c < n.num_children; ++c)
      visit (n.children[c], limit, path);
  }
  // The points of the whole subtree `n`; path[l] is its ancestor record at level l.
  void
  take (const pclx::omicron::detail::Node<PointT>& n, const std::vector<std::uint64_t>& path)
  {
    if (!n.isLeaf ())
    {
      for (int c = 0; c < n.num_children; ++c)
        take (n.children[c], path);
      return;
    }
    const int record_level = static_cast<int> (path.size ()) - 1;
    for (std::uint32_t i = 0; i < n.num_points; ++i)
    {
      const PointT& p = n.points[i];
      int level = record_level;
      for (int l = 0; l < record_level; ++l)
      {
        const int depth = std::min (l + 7, 21);
        const double cells = std::ldexp (1.0, depth);
        std::uint64_t key = 0;
        for (double v : {double (p.x) - origin_.x (), double (p.y) - origin_.y (), double (p.z) - origin_.z ()})
        {
          const double c = std::clamp (std::floor (v / edge_ * cells), 0.0, cells - 1);
          key = key * 2097152u + static_cast<std::uint64_t> (c);
        }
        if (taken_[l].insert (key).second)
        {
          level = l;
          break;
        }
      }
      records[path[level]].push_back (p);
    }
  }
  Eigen::Vector3d origin_;
  double edge_ = 1;
  std::map<int, std::set<std::uint64_t>> taken_;
};

// The written octree against ExpectedOutput: every record's count, child mask, type and
// points (within the scale), and each kept point stored once.
template <typename PointT> void
expectSameHierarchy (const pcl::ObliqueCutOctree<PointT>& octree, const pcl::PotreeReader& reader, std::uint32_t limit)
{
  const ExpectedOutput<PointT> expected (octree, limit);
  std::size_t stored = 0;
  EXPECT_EQ (reader.getNodes ().size (), expected.records.size ());
  const double tol = 0.5 * reader.getMetadata ().scale.x () + 1e-6;
  for (const auto& [bits, points] : expected.records)
  {
    const pcl::MortonCode code (bits);
    stored += points.size ();
    const long i = reader.find (code);
    EXPECT_GE (i, 0) << "node " << code << " missing";
    if (i < 0)
      continue;
    const auto& info = reader.getNodes ()[i];
    std::uint8_t mask = 0;
    for (int c = 0; c < 8; ++c)
      if (expected.records.count (code.child (c).bits ()))
        mask |= static_cast<std::uint8_t> (1u << c);
    EXPECT_EQ (info.num_points, points.size ()) << info.name;
    EXPECT_EQ (info.child_mask, mask) << info.name;
    EXPECT_EQ (info.type, mask ? pclx::omicron::detail::potree::kNormal : pclx::omicron::detail::potree::kLeaf)
        << info.name;
    if (expected.whole.at (bits))
      EXPECT_EQ (mask, 0) << info.name;
    pcl::PointCloud<pcl::PointXYZRGB> pts;
    reader.readNode (static_cast<std::size_t> (i), pts);
    if (pts.size () != points.size ())
    {
      ADD_FAILURE () << info.name << " read " << pts.size () << " points";
      continue;
    }
    for (std::size_t k = 0; k < points.size (); ++k)
    {
      const PointT& p = points[k];
      const bool same = std::abs (pts[k].x - p.x) <= tol && std::abs (pts[k].y - p.y) <= tol &&
                        std::abs (pts[k].z - p.z) <= tol;
      EXPECT_TRUE (same) << info.name << " point " << k;
      if constexpr (pcl::traits::has_color_v<PointT>)
        EXPECT_TRUE (pts[k].r == p.r && pts[k].g == p.g && pts[k].b == p.b) << info.name << " colour " << k;
      if (!same)
        break;
    }
  }
  EXPECT_EQ (stored, octree.getStatistics ().kept_points);
  EXPECT_EQ (reader.getStoredPoints (), stored);
}
}  // namespace

TEST (PotreeWriter, WrittenOctreeReadsBackAsTheInMemoryHierarchy)
{
  struct Case
  {
    Shape shape;
    int depth, step;
    bool collapse;
    std::uint32_t limit;
  };
  for (const Case& c : {Case{Shape::CLUSTERED, 6, 4, true, 0}, Case{Shape::UNIFORM, 7, 2, false, 0},
                        Case{Shape::LATTICE, 5, 1, true, 0}, Case{Shape::IDENTICAL, 3, 4, false, 0},
                        Case{Shape::UNIFORM, 9, 3, true, 0}, Case{Shape::CLUSTERED, 8, 2, true, 1000},
                        Case{Shape::UNIFORM, 7, 4, true, 20000}, Case{Shape::UNIFORM, 5, 4, true, 40000}})
  {
    SCOPED_TRACE (std::string (omitest::shapeName (c.shape)) + " depth " + std::to_string (c.depth) + " step " +
                  std::to_string (c.step) + " leaf limit " + std::to_string (c.limit));
    const auto cloud = colouredCloud (c.shape, 30000, 5 + c.depth);
    pcl::ObliqueCutOctree<pcl::PointXYZRGB> o;
    o.setInputCloud (cloud);
    o.setMaxDepth (c.depth);
    o.setLeafCollapse (c.collapse);
    o.setThreads (2);
    ASSERT_TRUE (o.build ());
    TempDir dir;
    pcl::PotreeWriter<pcl::PointXYZRGB> w;
    w.setHierarchyStepSize (c.step);
    w.setName ("test");
    w.setLeafPointLimit (c.limit);
    w.write (o, dir.path.string ());
    pcl::PotreeReader r;
    r.open (dir.path.string ());
    const auto& m = r.getMetadata ();
    EXPECT_EQ (m.points, cloud->size ());
    EXPECT_TRUE (m.rgb);
    EXPECT_EQ (m.step_size, c.step);
    int depth = 0;
    for (const auto& n : r.getNodes ())
      depth = std::max (depth, n.code.level ());
    EXPECT_EQ (m.depth, depth);
    // Bounds: the root cube, as PotreeConverter writes it; positions within it.
    EXPECT_TRUE (m.box_min.isApprox (o.getRootOrigin ()));
    EXPECT_NEAR (m.box_max.x () - m.box_min.x (), o.getRootEdge (), 1e-9);
    EXPECT_TRUE ((m.position_min.array () >= m.box_min.array () - 1e-6).all ());
    EXPECT_TRUE ((m.position_max.array () <= m.box_max.array () + 1e-6).all ());
    // The root chunk holds the nodes of levels 0..step.
    std::size_t first = 0;
    for (const auto& n : r.getNodes ())
      first += n.code.level () <= c.step ? 1 : 0;
    EXPECT_EQ (m.first_chunk_size, 22 * first);
    expectSameHierarchy (o, r, c.limit);
    const std::size_t nodes = r.getNodes ().size ();
    // hierarchy.bin holds each node once, plus one proxy record per chunk below the root.
    std::size_t proxies = 0;
    for (const auto& n : r.getNodes ())
      proxies += (n.code.level () > 0 && n.code.level () % c.step == 0 && n.child_mask) ? 1 : 0;
    EXPECT_EQ (fs::file_size (dir.path / "hierarchy.bin"), 22 * (nodes + proxies));
    if (c.step < depth)
      EXPECT_GT (proxies, 0u);
  }
}

TEST (PotreeWriter, BytesFollowPotreeConverterLayout)
{
  // Two points close together near each of two opposite corners, depth 1: each pair shares a
  // cell of the root's grid (128 per edge), so the root takes the first point of each pair
  // and each leaf keeps the other (additive: 4 points stored in all).
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud (new pcl::PointCloud<pcl::PointXYZ>);
  cloud->push_back (pcl::PointXYZ (0.01f, 0.01f, 0.01f));
  cloud->push_back (pcl::PointXYZ (2.01f, 3.01f, 3.99f));
  cloud->push_back (pcl::PointXYZ (0.011f, 0.011f, 0.011f));
  cloud->push_back (pcl::PointXYZ (2.011f, 3.011f, 3.989f));
  pcl::ObliqueCutOctree<pcl::PointXYZ> o;
  o.setInputCloud (cloud);
  o.setMaxDepth (1);
  ASSERT_TRUE (o.build ());
  TempDir dir;
  pcl::PotreeWriter<pcl::PointXYZ> w;
  w.setScale (0.001);
  w.setLeafPointLimit (0);  // every node of the octree
  w.write (o, dir.path.string ());
  const auto h = slurp (dir.path / "hierarchy.bin");
  ASSERT_EQ (h.size (), 3u * 22u);
  const auto u32 = [&] (std::size_t at) { std::uint32_t v; std::memcpy (&v, h.data () + at, 4); return v; };
  const auto u64 = [&] (std::size_t at) { std::uint64_t v; std::memcpy (&v, h.data () + at, 8); return v; };
  // Root: NORMAL, children 0 (x−y−z−) and 7 (x+y+z+); 2 points of 12 bytes at offset 0.
  EXPECT_EQ (h[0], 0);
  EXPECT_EQ (h[1], (1u << 0) | (1u << 7));
  EXPECT_EQ (u32 (2), 2u);
  EXPECT_EQ (u64 (14), 24u);
  // Leaves r0 then r7, breadth-first in child order, one point each.
  EXPECT_EQ (h[22], 1);
  EXPECT_EQ (h[23], 0);
  EXPECT_EQ (u32 (24), 1u);
  EXPECT_EQ (u64 (36), 12u);
  EXPECT_EQ (h[44], 1);
  EXPECT_EQ (u32 (46), 1u);
  const auto oct = slurp (dir.path / "octree.bin");
  ASSERT_EQ (oct.size (), 48u);
  // int32 (x − offset) / 0.001 with offset = the cube's min corner: the root holds the first
  // point of each pair, in Morton order, and r7 the second near (2, 3, 4).
  const Eigen::Vector3d origin = o.getRootOrigin ();
  const auto expect = [&] (std::uint64_t offset, const pcl::PointXYZ& p) {
    std::int32_t q[3];
    std::memcpy (q, oct.data () + offset, 12);
    for (int a = 0; a < 3; ++a)
      EXPECT_EQ (q[a], std::llround ((double (p.data[a]) - origin[a]) / 0.001)) << "offset " << offset << " axis " << a;
  };
  expect (0, (*cloud)[0]);
  expect (12, (*cloud)[1]);
  expect (u64 (22 + 6), (*cloud)[2]);
  expect (u64 (44 + 6), (*cloud)[3]);
  // metadata.json: the fields potree's loader reads.
  std::ifstream in (dir.path / "metadata.json");
  const std::string js ((std::istreambuf_iterator<char> (in)), std::istreambuf_iterator<char> ());
  for (const char* key : {"\"version\": \"2.0\"", "\"firstChunkSize\": 66", "\"stepSize\": 4", "\"depth\": 1",
                          "\"encoding\": \"DEFAULT\"", "\"name\": \"position\"", "\"type\": \"int32\"", "\"points\": 4"})
    EXPECT_NE (js.find (key), std::string::npos) << key << " in\n" << js;
  EXPECT_EQ (js.find ("rgb"), std::string::npos);
}

// write () encodes on the octree's threads in windows of nodes; the files must be those of
// one thread and of the streamed appendSubtree (), byte for byte, over several windows.
TEST (PotreeWriter, SameFilesForAnyThreadCountAndAsStreamed)
{
  const auto cloud = colouredCloud (Shape::UNIFORM, 1500000, 5);
  std::vector<std::vector<std::uint8_t>> files[4];
  for (int run = 0; run < 4; ++run)
  {
    pcl::ObliqueCutOctree<pcl::PointXYZRGB> o;
    o.setInputCloud (cloud);
    o.setThreads (run == 1 ? 2 : 1);
    ASSERT_TRUE (o.build ());
    TempDir dir;
    pcl::PotreeWriter<pcl::PointXYZRGB> w;
    if (run < 2)
      ASSERT_TRUE (w.write (o, dir.path.string ()));
    else
    {
      // Streamed on one thread, then on two (the small records encoded in parallel).
      w.setThreads (run == 3 ? 2 : 1);
      ASSERT_TRUE (w.open (dir.path.string (), o.getRootOrigin (), o.getRootEdge ()));
      ASSERT_TRUE (w.appendSubtree (*o.getRoot ()));
      ASSERT_TRUE (w.close (o.getStatistics ().kept_points));
    }
    for (const char* name : {"octree.bin", "hierarchy.bin", "metadata.json"})
      files[run].push_back (slurp (dir.path / name));
  }
  ASSERT_GT (files[0][0].size (), 18u * 1000000u);
  for (int run = 1; run < 4; ++run)
    for (std::size_t f = 0; f < 3; ++f)
      EXPECT_TRUE (files[run][f] == files[0][f]) << "run " << run << " file " << f;
}

TEST (PotreeWriter, ThreadCountBelowOneOrDuringAWriteIsKept)
{
  pcl::PotreeWriter<pcl::PointXYZ> w;
  EXPECT_EQ (w.getThreads (), 1);
  w.setThreads (0);
  w.setThreads (-3);
  EXPECT_EQ (w.getThreads (), 1);
  w.setThreads (2);
  EXPECT_EQ (w.getThreads (), 2);
  TempDir dir;
  ASSERT_TRUE (w.open (dir.path.string (), Eigen::Vector3d::Zero (), 1.0));
  w.setThreads (1);
  EXPECT_EQ (w.getThreads (), 2);
  const pcl::PointXYZ p (0.5f, 0.5f, 0.5f);
  ASSERT_TRUE (w.appendNode (pcl::MortonCode::root (), &p, 1));
  ASSERT_TRUE (w.close (1));
  w.setThreads (1);
  EXPECT_EQ (w.getThreads (), 1);
}

// The writer's rounding is std::llround's (half away from zero), also at the halves.
TEST (PotreeWriter, RoundingIsLlround)
{
  using pclx::omicron::detail::potree::roundHalfAway;
  for (double x : {0.0, 0.5, -0.5, 1.5, -1.5, 2.5, -2.5, 0.49999999999999994, -0.49999999999999994,
                   1073741823.5, -1073741823.5, 12345.499999, 7.000000001, -7.000000001, 1e15 + 0.5})
    EXPECT_EQ (roundHalfAway (x), std::llround (x)) << x;
}

// What a loader shows at level l (the nodes down to l) covers the cloud at that level's
// spacing, as PotreeConverter's output does: every input point lies within a cell diagonal
// of edge / (128 · 2^l) of a point stored at level l or above; `spacing` is edge / 128.
TEST (PotreeWriter, EveryLevelCoversTheCloudAtItsSpacing)
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud (new pcl::PointCloud<pcl::PointXYZ>);
  for (int i = 0; i < 400; ++i)
    for (int j = 0; j < 400; ++j)
      cloud->push_back (pcl::PointXYZ (0.005f * i, 0.005f * j, 0.3f + 0.001f * i + 0.0005f * j));
  pcl::ObliqueCutOctree<pcl::PointXYZ> o;
  o.setInputCloud (cloud);
  ASSERT_TRUE (o.build ());
  TempDir dir;
  pcl::PotreeWriter<pcl::PointXYZ> w;
  w.setLeafPointLimit (5000);
  ASSERT_TRUE (w.write (o, dir.path.string ()));
  pcl::PotreeReader r;
  ASSERT_TRUE (r.open (dir.path.string ()));
  const double edge = o.getRootEdge (), scale = r.getMetadata ().scale.x ();
  EXPECT_NEAR (r.getMetadata ().spacing, edge / 128, 1e-12);
  int depth = 0;
  for (const auto& n : r.getNodes ())
    depth = std::max (depth, n.code.level ());
  ASSERT_GE (depth, 2) << "the test needs inner nodes on several levels";
  std::vector<pcl::PointCloud<pcl::PointXYZRGB>> stored (depth + 1);
  for (std::size_t i = 0; i < r.getNodes ().size (); ++i)
  {
    pcl::PointCloud<pcl::PointXYZRGB> pts;
    r.readNode (i, pts);
    stored[r.getNodes ()[i].code.level ()] += pts;
  }
  EXPECT_GT (stored[0].size (), 1000u) << "the root shows the cloud at its spacing";
  for (int l = 0; l <= depth; ++l)
  {
    const double reach = std::sqrt (3.0) * edge / (128.0 * std::ldexp (1.0, l)) + scale;
    std::map<std::array<long, 3>, std::vector<Eigen::Vector3f>> grid;
    const auto cell = [&] (const Eigen::Vector3f& p) {
      return std::array<long, 3>{long (std::floor (p.x () / reach)), long (std::floor (p.y () / reach)),
                                 long (std::floor (p.z () / reach))};
    };
    for (int k = 0; k <= l; ++k)
      for (const auto& q : stored[k])
        grid[cell (q.getVector3fMap ())].push_back (q.getVector3fMap ());
    std::size_t uncovered = 0;
    for (const auto& p : *cloud)
    {
      const auto c = cell (p.getVector3fMap ());
      bool near = false;
      for (long dx = -1; dx <= 1 && !near; ++dx)
        for (long dy = -1; dy <= 1 && !near; ++dy)
          for (long dz = -1; dz <= 1 && !near; ++dz)
            if (const auto it = grid.find ({c[0] + dx, c[1] + dy, c[2] + dz}); it != grid.end ())
              for (const auto& q : it->second)
                if ((q - p.getVector3fMap ()).norm () <= reach)
                {
                  near = true;
                  break;
                }
      uncovered += near ? 0 : 1;
    }
    EXPECT_EQ (uncovered, 0u) << "level " << l;
  }
}

TEST (PotreeWriter, UnwritableFolderIsAClearError)
{
  const auto cloud = omitest::makeCloud (Shape::UNIFORM, 1000, 3);
  pcl::ObliqueCutOctree<pcl::PointXYZ> o;
  o.setInputCloud (cloud);
  ASSERT_TRUE (o.build ());
  TempDir dir;
  // A regular file where a folder is needed (permissions would not stop root).
  std::ofstream (dir.path / "file") << "x";
  const std::string bad = (dir.path / "file" / "out").string ();
  pcl::PotreeWriter<pcl::PointXYZ> w;
  EXPECT_FALSE (w.write (o, bad));
  EXPECT_NE (w.getLastError ().find (bad), std::string::npos) << w.getLastError ();
  EXPECT_FALSE (w.isOpen ());
  pcl::PotreeWriter<pcl::PointXYZ> unbuilt;
  pcl::ObliqueCutOctree<pcl::PointXYZ> empty;
  EXPECT_FALSE (unbuilt.write (empty, (dir.path / "x").string ()));
  EXPECT_NE (unbuilt.getLastError ().find ("not built"), std::string::npos) << unbuilt.getLastError ();
  EXPECT_FALSE (fs::exists (dir.path / "x"));
  EXPECT_FALSE (unbuilt.isOpen ());
  // Streaming calls out of order are refused too.
  EXPECT_FALSE (unbuilt.close (0));
  EXPECT_FALSE (unbuilt.appendSubtree (*o.getRoot ()));
  EXPECT_FALSE (unbuilt.open ((dir.path / "y").string (), Eigen::Vector3d::Zero (), 0.0));
  EXPECT_FALSE (unbuilt.isOpen ());
}

TEST (PotreeReader, CorruptFilesAreClearErrors)
{
  const auto cloud = omitest::makeCloud (Shape::CLUSTERED, 5000, 4);
  pcl::ObliqueCutOctree<pcl::PointXYZ> o;
  o.setInputCloud (cloud);
  o.setMaxDepth (6);
  ASSERT_TRUE (o.build ());
  TempDir dir;
  pcl::PotreeWriter<pcl::PointXYZ> w;
  w.setHierarchyStepSize (2);
  w.setLeafPointLimit (0);  // deep enough for proxy chunks
  w.write (o, dir.path.string ());
  pcl::PotreeReader r;
  EXPECT_TRUE (r.open (dir.path.string ()));
  EXPECT_TRUE (r.getLastError ().empty ());
  // Each failure: false, a reason, and no nodes left from the folder read before.
  const auto refused = [&] (const std::string& d) {
    const bool opened = r.open (d);
    return !opened && !r.getLastError ().empty () && r.getNodes ().empty ();
  };
  EXPECT_TRUE (refused ((dir.path / "missing").string ()));
  pcl::PointCloud<pcl::PointXYZ> none;
  EXPECT_FALSE (r.readNode (0, none));
  EXPECT_TRUE (none.empty ());
  const auto h = slurp (dir.path / "hierarchy.bin");
  const auto o_bin = slurp (dir.path / "octree.bin");
  const auto rewrite = [&] (const char* name, const std::vector<std::uint8_t>& bytes) {
    std::ofstream (dir.path / name, std::ios::binary).write (reinterpret_cast<const char*> (bytes.data ()), bytes.size ());
  };
  // Truncated hierarchy (a proxy's chunk is cut off).
  rewrite ("hierarchy.bin", std::vector<std::uint8_t> (h.begin (), h.end () - 30));
  EXPECT_TRUE (refused (dir.path.string ()));
  // A child mask naming more nodes than the chunk holds.
  auto bad = h;
  bad[1] = 0xff;
  rewrite ("hierarchy.bin", bad);
  EXPECT_TRUE (refused (dir.path.string ()));
  rewrite ("hierarchy.bin", h);
  // Truncated octree.bin.
  rewrite ("octree.bin", std::vector<std::uint8_t> (o_bin.begin (), o_bin.begin () + o_bin.size () / 2));
  EXPECT_TRUE (refused (dir.path.string ()));
  rewrite ("octree.bin", o_bin);
  // Not JSON / wrong version.
  std::ofstream (dir.path / "metadata.json") << "{\"version\": \"1.8\"}";
  EXPECT_TRUE (refused (dir.path.string ()));
  std::ofstream (dir.path / "metadata.json") << "{ not json";
  EXPECT_TRUE (refused (dir.path.string ()));
  std::ofstream (dir.path / "metadata.json") << "";
  EXPECT_TRUE (refused (dir.path.string ()));
}

#include <pclx/omicron/point_stream_reader.h>

#include <pcl/io/pcd_io.h>

TEST (PotreeWriter, StreamedLatticeAndMillionsOfDuplicatesEndToEnd)
{
  // File → PointStreamReader (chunks) → octree → Potree → PotreeReader, against the octree
  // built from the cloud in memory.
  TempDir dir;
  struct Case
  {
    const char* name;
    std::size_t n;
    Shape shape;
    int depth;
  };
  for (const Case& c : {Case{"lattice", 64 * 64 * 64, Shape::LATTICE, 8}, Case{"duplicates", 2000000, Shape::DUPLICATES, 7}})
  {
    SCOPED_TRACE (c.name);
    const auto cloud = omitest::makeCloud (c.shape, c.n, 21);
    const std::string file = (dir.path / (std::string (c.name) + ".pcd")).string ();
    ASSERT_EQ (pcl::io::savePCDFileBinary (file, *cloud), 0);
    pcl::PointStreamReader reader (file);
    pcl::PointCloud<pcl::PointXYZ>::Ptr streamed (new pcl::PointCloud<pcl::PointXYZ>), part (new pcl::PointCloud<pcl::PointXYZ>);
    while (reader.read (100000, *part))
      *streamed += *part;
    ASSERT_EQ (streamed->size (), cloud->size ());
    pcl::ObliqueCutOctree<pcl::PointXYZ> a, b;
    for (auto* o : {&a, &b})
    {
      o->setMaxDepth (c.depth);
      o->setLeafCollapse (true);
      o->setThreads (2);
    }
    a.setInputCloud (cloud);
    b.setInputCloud (streamed);
    ASSERT_TRUE (a.build ());
    ASSERT_TRUE (b.build ());
    EXPECT_EQ (a.getStatistics ().nodes_per_level, b.getStatistics ().nodes_per_level);
    EXPECT_EQ (a.getStatistics ().points_per_level, b.getStatistics ().points_per_level);
    const std::string out = (dir.path / (std::string (c.name) + "_potree")).string ();
    pcl::PotreeWriter<pcl::PointXYZ> w;
    w.write (b, out);
    pcl::PotreeReader r;
    r.open (out);
    EXPECT_EQ (r.getMetadata ().points, c.n);
    expectSameHierarchy (a, r, w.getLeafPointLimit ());
    if (c.shape == Shape::DUPLICATES)
    {
      // Three distinct positions: three leaves hold every point.
      EXPECT_EQ (b.getStatistics ().leaves_per_level[c.depth] + b.getStatistics ().leaves_per_level[c.depth - 1], 3u);
    }
  }
}
