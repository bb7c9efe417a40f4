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

namespace fs = std::filesystem;
using omitest::Shape;

namespace {
struct TempDir
{
  fs::path path;
  TempDir ()
  {
    path = fs::temp_directory_path () / ("pclx_omicron_" + std::to_string (::getpid ()) + "_" + std::to_string (counter ()++));
    fs::remove_all (path);
    fs::create_directories (path);
  }
  ~TempDir () { fs::remove_all (path); }
  static int& counter ()
  {
    static int c = 0;
    return c;
  }
};

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

// The points node `n` stores (additive LOD: its own minus those its parent took), appended.
template <typename PointT> void
keptPoints (const pclx::omicron::detail::Node<PointT>& n, float ratio, std::vector<PointT>& out)
{
  const std::uint32_t taken = n.code.level () > 0 ? pclx::omicron::detail::parentSampleCount (n.num_points, ratio) : 0;
  for (std::uint32_t j = 0, t = 0; j < n.num_points; ++j)
    if (t < taken && j == pclx::omicron::detail::parentSampleIndex (t, taken, n.num_points))
      ++t;
    else
      out.push_back (n.points[j]);
}

template <typename PointT> void
subtreeKeptPoints (const pclx::omicron::detail::Node<PointT>& n, float ratio, std::vector<PointT>& out)
{
  keptPoints (n, ratio, out);
  for (int c = 0; c < n.num_children; ++c)
    subtreeKeptPoints (n.children[c], ratio, out);
}

// The subtree of `n` as Potree stores it: each node holds its kept points, a node whose
// subtree keeps none is not written, and a subtree keeping at most `limit` points (> 0) is one
// leaf with them in depth-first order. Checks every written node's count, child mask, type
// and points (within the scale); returns the points the subtree stores, counts written nodes.
template <typename PointT> std::size_t
expectAdditiveSubtree (const pclx::omicron::detail::Node<PointT>& n, float ratio, std::uint32_t limit,
                       const pcl::PotreeReader& reader, std::size_t& written)
{
  std::vector<PointT> expected;
  subtreeKeptPoints (n, ratio, expected);
  const bool merged = limit > 0 && expected.size () <= limit;
  std::size_t below = 0;
  std::uint8_t mask = 0;
  if (merged)
    below = expected.size ();
  else
  {
    expected.clear ();
    keptPoints (n, ratio, expected);
    for (int c = 0; c < n.num_children; ++c)
      if (const std::size_t k = expectAdditiveSubtree (n.children[c], ratio, limit, reader, written))
      {
        below += k;
        mask |= static_cast<std::uint8_t> (1u << n.children[c].code.childIndex ());
      }
    below += expected.size ();
  }
  const long i = reader.find (n.code);
  if (below == 0)
  {
    EXPECT_LT (i, 0) << "node " << n.code << " stores nothing but was written";
    return 0;
  }
  ++written;
  EXPECT_GE (i, 0) << "node " << n.code << " missing";
  if (i < 0)
    return below;
  const auto& info = reader.getNodes ()[i];
  EXPECT_EQ (info.num_points, expected.size ()) << info.name;
  EXPECT_EQ (info.child_mask, mask) << info.name;
  EXPECT_EQ (info.type, mask ? pclx::omicron::detail::potree::kNormal : pclx::omicron::detail::potree::kLeaf) << info.name;
  pcl::PointCloud<pcl::PointXYZRGB> pts;
  reader.readNode (static_cast<std::size_t> (i), pts);
  if (pts.size () != expected.size ())
  {
    ADD_FAILURE () << info.name << " read " << pts.size () << " points";
    return below;
  }
  const double tol = 0.5 * reader.getMetadata ().scale.x () + 1e-6;
  for (std::size_t k = 0; k < expected.size (); ++k)
  {
    const PointT& p = expected[k];
    const bool same = std::abs (pts[k].x - p.x) <= tol && std::abs (pts[k].y - p.y) <= tol &&
                      std::abs (pts[k].z - p.z) <= tol;
    EXPECT_TRUE (same) << info.name << " point " << k;
    if constexpr (pcl::traits::has_color_v<PointT>)
      EXPECT_TRUE (pts[k].r == p.r && pts[k].g == p.g && pts[k].b == p.b) << info.name << " colour " << k;
    if (!same)
      break;
  }
  return below;
}

// The whole written octree against the in-memory one; every kept point is stored once.
template <typename PointT> void
expectSameHierarchy (const pcl::ObliqueCutOctree<PointT>& octree, const pcl::PotreeReader& reader, std::uint32_t limit)
{
  std::size_t written = 0;
  const std::size_t stored =
      expectAdditiveSubtree (*octree.getRoot (), octree.getParentPointRatio (), limit, reader, written);
  EXPECT_EQ (stored, octree.getStatistics ().kept_points);
  EXPECT_EQ (reader.getStoredPoints (), stored);
  EXPECT_EQ (written, reader.getNodes ().size ());
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
  // Two points near each of two opposite corners, depth 1, ratio 0.5: the root takes one
  // point of each leaf and each leaf keeps the other (additive: 4 points stored in all).
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud (new pcl::PointCloud<pcl::PointXYZ>);
  cloud->push_back (pcl::PointXYZ (0.f, 0.f, 0.f));
  cloud->push_back (pcl::PointXYZ (2.f, 3.f, 4.f));
  cloud->push_back (pcl::PointXYZ (0.5f, 0.5f, 0.5f));
  cloud->push_back (pcl::PointXYZ (2.5f, 2.5f, 3.5f));
  pcl::ObliqueCutOctree<pcl::PointXYZ> o;
  o.setInputCloud (cloud);
  o.setMaxDepth (1);
  o.setParentPointRatio (0.5f);
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
  // int32 (x − offset) / 0.001 with offset = the cube's min corner (0, 0, 0). The root and r7
  // together hold both points near (2, 3, 4), each once.
  const auto at = [&] (std::uint64_t offset) {
    std::int32_t q[3];
    std::memcpy (q, oct.data () + offset, 12);
    return std::array<std::int32_t, 3>{q[0], q[1], q[2]};
  };
  const std::array<std::int32_t, 3> a{2000, 3000, 4000}, b{2500, 2500, 3500};
  const auto leaf7 = at (u64 (44 + 6));
  EXPECT_TRUE (leaf7 == a || leaf7 == b);
  const auto other = leaf7 == a ? b : a;
  EXPECT_TRUE (at (0) == other || at (12) == other);
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
  std::vector<std::vector<std::uint8_t>> files[3];
  for (int run = 0; run < 3; ++run)
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
      w.setParentPointRatio (o.getParentPointRatio ());
      ASSERT_TRUE (w.open (dir.path.string (), o.getRootOrigin (), o.getRootEdge ()));
      ASSERT_TRUE (w.appendSubtree (*o.getRoot ()));
      ASSERT_TRUE (w.close (o.getStatistics ().kept_points));
    }
    for (const char* name : {"octree.bin", "hierarchy.bin", "metadata.json"})
      files[run].push_back (slurp (dir.path / name));
  }
  ASSERT_GT (files[0][0].size (), 18u * 1000000u);
  for (int run = 1; run < 3; ++run)
    for (std::size_t f = 0; f < 3; ++f)
      EXPECT_TRUE (files[run][f] == files[0][f]) << "run " << run << " file " << f;
}

// The writer's rounding is std::llround's (half away from zero), also at the halves.
TEST (PotreeWriter, RoundingIsLlround)
{
  using pclx::omicron::detail::potree::roundHalfAway;
  for (double x : {0.0, 0.5, -0.5, 1.5, -1.5, 2.5, -2.5, 0.49999999999999994, -0.49999999999999994,
                   1073741823.5, -1073741823.5, 12345.499999, 7.000000001, -7.000000001, 1e15 + 0.5})
    EXPECT_EQ (roundHalfAway (x), std::llround (x)) << x;
}

TEST (PotreeWriter, SpacingHalvedPerLevelIsTheNodesPointSpacing)
{
  // A 200 × 200 lattice of step 0.01 on a plane. Loaders size points by metadata spacing
  // / 2^level: with every node written most points are in depth-6 leaves, so spacing / 64
  // should be the lattice step; with everything in one leaf, spacing itself should.
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud (new pcl::PointCloud<pcl::PointXYZ>);
  for (int i = 0; i < 200; ++i)
    for (int j = 0; j < 200; ++j)
      cloud->push_back (pcl::PointXYZ (0.01f * i, 0.01f * j, 0.5f));
  pcl::ObliqueCutOctree<pcl::PointXYZ> o;
  o.setInputCloud (cloud);
  o.setMaxDepth (6);
  ASSERT_TRUE (o.build ());
  const auto spacing = [&] (std::uint32_t limit, std::size_t& nodes) {
    TempDir dir;
    pcl::PotreeWriter<pcl::PointXYZ> w;
    w.setLeafPointLimit (limit);
    w.write (o, dir.path.string ());
    pcl::PotreeReader r;
    r.open (dir.path.string ());
    nodes = r.getNodes ().size ();
    return r.getMetadata ().spacing;
  };
  std::size_t nodes = 0;
  const double every = spacing (0, nodes);
  EXPECT_GT (nodes, 1000u);
  EXPECT_GT (every / 64, 0.006);
  EXPECT_LT (every / 64, 0.012);
  const double one = spacing (50000, nodes);
  EXPECT_EQ (nodes, 1u);
  EXPECT_NEAR (one, 0.01, 2e-4);
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
  EXPECT_FALSE (unbuilt.appendNode (*o.getRoot ()));
  EXPECT_FALSE (unbuilt.open ((dir.path / "y").string (), Eigen::Vector3d::Zero (), 0.0));
  EXPECT_FALSE (unbuilt.isOpen ());
  // A parent ratio outside (0, 1] is refused and the writer keeps its own.
  w.setParentPointRatio (0.f);
  w.setParentPointRatio (1.5f);
  w.setParentPointRatio (std::numeric_limits<float>::quiet_NaN ());
  EXPECT_FLOAT_EQ (w.getParentPointRatio (), 0.2f);
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
