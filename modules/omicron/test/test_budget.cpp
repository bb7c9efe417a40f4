// ObliqueCutOctree under a memory budget: the out-of-core build gives the in-memory build's
// hierarchy (Potree output node by node, retained tree point by point), from a cloud and from
// a file larger than the budget, within the budget; impossible budgets and unwritable folders
// are clear errors; the front never reaches dropped nodes.
#include "omicron_test_util.h"

#include <pclx/omicron/detail/budget_plan.h>
#include <pclx/omicron/oblique_cut_octree.h>
#include <pclx/omicron/potree_reader.h>
#include <pclx/omicron/potree_writer.h>
#include <pclx/testing/run_stats.h>

#include <pcl/common/common.h>
#include <pcl/io/pcd_io.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <numeric>
#include <random>
#include <thread>

#include <sys/wait.h>
#include <unistd.h>

using namespace omitest;
using Octree = pcl::ObliqueCutOctree<pcl::PointXYZ>;
namespace fs = std::filesystem;

namespace {

// Several shapes in one cloud, shuffled: uniform (5 %), five tight clusters (10 %), a plane
// (35 %), eight wide clusters (30 %) and exact duplicates of earlier points (20 %; the
// stable order of equal codes matters for the samples). Point-bound at depth 6 (about 0.07
// nodes per point), the regime a budget is for (see the README on node-bound trees).
Cloud::Ptr
mixedCloud (std::size_t n, unsigned seed)
{
  Cloud::Ptr c (new Cloud);
  const std::pair<Shape, double> parts[] = {{Shape::UNIFORM, 0.05}, {Shape::CLUSTERED, 0.1}, {Shape::FLAT, 0.35}};
  for (const auto& p : parts)
  {
    const auto part = makeCloud (p.first, static_cast<std::size_t> (n * p.second), seed++);
    c->insert (c->end (), part->begin (), part->end ());
  }
  std::mt19937 rng (seed);
  std::normal_distribution<float> g (0.f, 0.25f);
  std::uniform_real_distribution<float> u (-1.f, 3.f);
  std::vector<pcl::PointXYZ> centres;
  for (int i = 0; i < 8; ++i)
    centres.emplace_back (u (rng), u (rng), u (rng));
  for (std::size_t i = 0, m = static_cast<std::size_t> (n * 0.3); i < m; ++i)
  {
    const pcl::PointXYZ& k = centres[rng () % centres.size ()];
    c->push_back (pcl::PointXYZ (k.x + g (rng), k.y + g (rng), k.z + g (rng)));
  }
  const std::size_t base = c->size ();
  while (c->size () < n)
    c->push_back ((*c)[rng () % base]);
  std::shuffle (c->begin (), c->end (), rng);
  return c;
}

void
configure (Octree& o, int depth, bool collapse)
{
  o.setMaxDepth (depth);
  o.setLeafCollapse (collapse);
  o.setThreads (2);
  o.setLeafSplatRadius (0.01f);
}

// Potree folders equal node by node: codes, point counts, and the stored points.
std::string
comparePotree (const std::string& a, const std::string& b)
{
  pcl::PotreeReader ra, rb;
  ra.open (a);
  rb.open (b);
  if (ra.getNodes ().size () != rb.getNodes ().size ())
    return "node counts differ: " + std::to_string (ra.getNodes ().size ()) + " vs " + std::to_string (rb.getNodes ().size ());
  if (ra.getMetadata ().points != rb.getMetadata ().points)
    return "metadata point counts differ";
  pcl::PointCloud<pcl::PointXYZ> pa, pb;
  for (std::size_t i = 0; i < ra.getNodes ().size (); ++i)
  {
    const auto& na = ra.getNodes ()[i];
    const long j = rb.find (na.code);
    if (j < 0)
      return "node " + na.name + " missing";
    if (rb.getNodes ()[j].num_points != na.num_points || rb.getNodes ()[j].type != na.type)
      return "node " + na.name + ": point count or type differs";
    ra.readNode (i, pa);
    rb.readNode (static_cast<std::size_t> (j), pb);
    for (std::size_t k = 0; k < pa.size (); ++k)
      if (!samePoint (pa[k], pb[k]))
        return "node " + na.name + ": point " + std::to_string (k) + " differs";
  }
  return "";
}

// The retained tree of a budgeted build against the in-memory tree: same codes, levels and
// points; spilled nodes are at the spill level with children in the in-memory tree.
std::string
compareRetained (const Octree& budgeted, const Octree& full, int spill, std::size_t& retained)
{
  std::map<std::uint64_t, const Node*> index;
  std::vector<const Node*> stack{full.getRoot ()};
  while (!stack.empty ())
  {
    const Node* n = stack.back ();
    stack.pop_back ();
    index[n->code.bits ()] = n;
    for (int j = 0; j < n->num_children; ++j)
      stack.push_back (n->children + j);
  }
  retained = 0;
  stack.push_back (budgeted.getRoot ());
  while (!stack.empty ())
  {
    const Node* n = stack.back ();
    stack.pop_back ();
    ++retained;
    const auto it = index.find (n->code.bits ());
    const std::string where = "node " + std::to_string (n->code.bits ());
    if (it == index.end ())
      return where + " not in the in-memory tree";
    const Node* f = it->second;
    if (f->level != n->level || f->num_points != n->num_points)
      return where + ": level or point count differs";
    for (std::uint32_t k = 0; k < n->num_points; ++k)
      if (!samePoint (f->points[k], n->points[k]))
        return where + ": point " + std::to_string (k) + " differs";
    if (n->flags & pclx::omicron::detail::kSpilled)
    {
      if (n->level != spill || n->num_children != 0 || f->num_children == 0)
        return where + ": spilled node off the spill level, or with children";
    }
    else if (n->num_children != f->num_children || n->level >= spill)
      return where + ": children differ, or a node at/below the spill level was not spilled";
    for (int j = 0; j < n->num_children; ++j)
    {
      if (n->children[j].parent () != n)
        return where + ": child without parent link";
      stack.push_back (n->children + j);
    }
  }
  return "";
}

}  // namespace

TEST (ObliqueCutOctreeBudget, QuarterBudgetGivesTheInMemoryHierarchy)
{
  const auto cloud = mixedCloud (1000000, 41);
  for (bool collapse : {false, true})
  {
    SCOPED_TRACE (collapse ? "collapse" : "no collapse");
    TempDir tmp;
    Octree full;
    full.setInputCloud (cloud);
    configure (full, 6, collapse);
    ASSERT_TRUE (full.build ());
    const auto fs_ = full.getStatistics ();
    pcl::PotreeWriter<pcl::PointXYZ> writer;
    writer.write (full, (tmp.path / "full").string ());

    // A quarter of the in-memory build's footprint: its own buffers plus the cloud it needs in RAM.
    const std::size_t footprint = fs_.accounted_peak_bytes + cloud->size () * sizeof (pcl::PointXYZ);
    const std::size_t budget = footprint / 4;
    Octree o;
    o.setInputCloud (cloud);
    configure (o, 6, collapse);
    o.setMemoryBudget (budget);
    o.setOutputDirectory ((tmp.path / "budget").string ());
    ASSERT_TRUE (o.build ()) << o.getLastError ();
    const auto st = o.getStatistics ();
    RecordProperty ("footprint", std::to_string (footprint));
    RecordProperty ("accounted_peak", std::to_string (st.accounted_peak_bytes));
    EXPECT_LE (st.accounted_peak_bytes, budget);
    EXPECT_LE (st.planned_peak_bytes, budget);
    EXPECT_GT (st.chunks, 2u);
    EXPECT_GE (st.spill_level, 1);
    EXPECT_EQ (st.spill_level, o.getSpillLevel ());
    EXPECT_GT (st.spilled_nodes, 0u);
    EXPECT_EQ (st.kept_points, cloud->size ());
    EXPECT_EQ (st.nodes_per_level, fs_.nodes_per_level);
    EXPECT_EQ (st.points_per_level, fs_.points_per_level);
    EXPECT_EQ (st.leaves_per_level, fs_.leaves_per_level);
    EXPECT_EQ (o.getOutputDirectory (), (tmp.path / "budget").string ());
    EXPECT_FALSE (fs::exists (tmp.path / "budget" / ".omicron_chunks.bin"));
    EXPECT_EQ (comparePotree ((tmp.path / "full").string (), (tmp.path / "budget").string ()), "");
    std::size_t retained = 0;
    EXPECT_EQ (compareRetained (o, full, st.spill_level, retained), "");
    EXPECT_LT (retained, std::accumulate (fs_.nodes_per_level.begin (), fs_.nodes_per_level.end (), std::size_t (0)));
    // The whole tree is not kept: the octree refuses to be written again from memory.
    pcl::PotreeWriter<pcl::PointXYZ> again;
    EXPECT_FALSE (again.write (o, (tmp.path / "again").string ()));
    EXPECT_NE (again.getLastError ().find ("budgeted"), std::string::npos) << again.getLastError ();
    EXPECT_FALSE (fs::exists (tmp.path / "again"));
  }
}

TEST (ObliqueCutOctreeBudget, FromAFileLargerThanTheBudget)
{
  TempDir tmp;
  const auto cloud = mixedCloud (800000, 7);
  (*cloud)[5].x = std::numeric_limits<float>::quiet_NaN ();  // dropped and counted on both paths
  const std::string pcd = (tmp.path / "in.pcd").string ();
  ASSERT_EQ (pcl::io::savePCDFileBinary (pcd, *cloud), 0);
  Octree full;
  full.setInputFile (pcd);  // no budget: read whole, the in-memory build
  configure (full, 6, false);
  ASSERT_TRUE (full.build ()) << full.getLastError ();
  EXPECT_TRUE (full.getOutputDirectory ().empty ());
  pcl::PotreeWriter<pcl::PointXYZ> writer;
  writer.write (full, (tmp.path / "full").string ());

  // A quarter of what loading the cloud and building in memory hold (the in-memory build from
  // the file keeps no second copy of the points, so the cloud is added).
  const std::size_t budget = (full.getStatistics ().accounted_peak_bytes + cloud->size () * sizeof (pcl::PointXYZ)) / 4;
  ASSERT_GT (fs::file_size (pcd), budget);
  Octree o;
  o.setInputFile (pcd);
  configure (o, 6, false);
  o.setMemoryBudget (budget);  // no output folder: a temp folder owned by the octree
  ASSERT_TRUE (o.build ()) << o.getLastError ();
  const auto st = o.getStatistics ();
  EXPECT_LE (st.accounted_peak_bytes, budget);
  EXPECT_EQ (st.dropped_invalid, 1u);
  EXPECT_EQ (st.kept_points, cloud->size () - 1);
  const std::string out = o.getOutputDirectory ();
  ASSERT_FALSE (out.empty ());
  EXPECT_EQ (comparePotree ((tmp.path / "full").string (), out), "");
  std::size_t retained = 0;
  EXPECT_EQ (compareRetained (o, full, st.spill_level, retained), "");
  // A second build replaces the temp folder.
  ASSERT_TRUE (o.build ());
  EXPECT_FALSE (fs::exists (out));
}

// Empty when two builds hold the same sorted points (positions, in order), else what differs.
std::string
sortedPointsDiffer (const Octree& x, const Octree& y)
{
  const auto& a = x.getSortedPoints ();
  const auto& b = y.getSortedPoints ();
  if (a.size () != b.size ())
    return std::to_string (a.size ()) + " against " + std::to_string (b.size ()) + " points";
  std::size_t differ = 0;
  for (std::size_t i = 0; i < a.size (); ++i)
    differ += (a[i].x != b[i].x || a[i].y != b[i].y || a[i].z != b[i].z) ? 1 : 0;
  return differ ? std::to_string (differ) + " points differ" : "";
}

// A budgeted build from a file in a forked child: its peak resident memory above the start
// (VmHWM after resetPeakMemory ()) and its ledger's peak, in bytes; -1 when the build fails.
std::pair<long long, long long>
childPeak (const std::string& pcd, std::size_t budget)
{
  int fds[2];
  if (::pipe (fds) != 0)
    return {-1, -1};
  const pid_t pid = ::fork ();
  if (pid == 0)
  {
    ::close (fds[0]);
    {
      // A first build pages in the code and starts the threads, so the measured one counts
      // what a build allocates, not the library's first use.
      Octree warm;
      warm.setInputFile (pcd);
      configure (warm, 6, false);
      warm.setMemoryBudget (budget);
      warm.build ();
    }
    const long long rss0 = static_cast<long long> (pclx::testing::resetPeakMemory ());
    long long out[2] = {-1, -1};
    {
      // Destroyed before _exit: it removes its temporary output folder.
      Octree o;
      o.setInputFile (pcd);
      configure (o, 6, false);
      o.setMemoryBudget (budget);
      if (o.build ())
      {
        out[0] = static_cast<long long> (pclx::testing::procStatusKb ("VmHWM")) * 1024 - rss0;
        out[1] = static_cast<long long> (o.getStatistics ().accounted_peak_bytes);
      }
    }
    const bool sent = ::write (fds[1], out, sizeof out) == static_cast<ssize_t> (sizeof out);
    ::_exit (sent ? 0 : 1);
  }
  ::close (fds[1]);
  long long in[2] = {-1, -1};
  const bool got = ::read (fds[0], in, sizeof in) == static_cast<ssize_t> (sizeof in);
  ::close (fds[0]);
  int status = 0;
  ::waitpid (pid, &status, 0);
  return got ? std::make_pair (in[0], in[1]) : std::make_pair (-1LL, -1LL);
}

TEST (ObliqueCutOctreeBudget, TheBudgetBoundsTheProcessPeak)
{
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  GTEST_SKIP () << "the sanitizer runtimes hold memory of their own";
#endif
  TempDir tmp;
  const std::string pcd = (tmp.path / "in.pcd").string ();
  ASSERT_EQ (pcl::io::savePCDFileBinary (pcd, *mixedCloud (3000000, 11)), 0);
  // 48 MB of points: budgets from two thirds of the cloud down to a third.
  for (const std::size_t budget : {std::size_t (32) << 20, std::size_t (24) << 20, std::size_t (16) << 20})
  {
    const auto [real, accounted] = childPeak (pcd, budget);
    ASSERT_GE (real, 0) << "budgeted build failed at " << budget << " bytes";
    RecordProperty ("peak_" + std::to_string (budget >> 20) + "MiB", std::to_string (real));
    RecordProperty ("accounted_" + std::to_string (budget >> 20) + "MiB", std::to_string (accounted));
    EXPECT_LE (real, static_cast<long long> (budget)) << "accounted " << accounted;
    EXPECT_LE (accounted, static_cast<long long> (budget));
  }
}

TEST (ObliqueCutOctreeBudget, ImpossibleBudgetsAndUnwritableFoldersAreClearErrors)
{
  TempDir tmp;
  const auto cloud = makeCloud (Shape::UNIFORM, 20000, 3);
  {
    // Below the fixed overhead: refused before the output folder is even created.
    Octree o;
    o.setInputCloud (cloud);
    o.setMemoryBudget (100000);
    o.setOutputDirectory ((tmp.path / "never").string ());
    EXPECT_FALSE (o.build ());
    EXPECT_NE (o.getLastError ().find ("below the fixed overhead"), std::string::npos) << o.getLastError ();
    EXPECT_NE (o.getLastError ().find ("nothing was allocated"), std::string::npos);
    EXPECT_FALSE (fs::exists (tmp.path / "never"));
    EXPECT_EQ (o.getRoot (), nullptr);
  }
  {
    // One finest cell holds every point: no chunk can take it.
    Octree o;
    o.setInputCloud (makeCloud (Shape::IDENTICAL, 200000, 1));
    o.setMemoryBudget (4 << 20);
    o.setOutputDirectory ((tmp.path / "identical").string ());
    EXPECT_FALSE (o.build ());
    EXPECT_NE (o.getLastError ().find ("no spill level fits"), std::string::npos) << o.getLastError ();
    EXPECT_NE (o.getLastError ().find ("200000 points"), std::string::npos) << o.getLastError ();
    EXPECT_LE (o.getStatistics ().accounted_peak_bytes, std::size_t (4 << 20));
  }
  {
    // Output folder below a regular file (root may write anywhere, but not there).
    const fs::path file = tmp.path / "file";
    std::ofstream (file.string ()) << "x";
    Octree o;
    o.setInputCloud (cloud);
    o.setMemoryBudget (64 << 20);
    o.setOutputDirectory ((file / "out").string ());
    EXPECT_FALSE (o.build ());
    EXPECT_NE (o.getLastError ().find ("cannot create the output folder"), std::string::npos) << o.getLastError ();
  }
  {
    // Depth 2 with leaf collapse has no level to spill at.
    Octree o;
    o.setInputCloud (cloud);
    o.setMaxDepth (2);
    o.setLeafCollapse (true);
    o.setMemoryBudget (64 << 20);
    EXPECT_FALSE (o.build ());
    EXPECT_NE (o.getLastError ().find ("max depth"), std::string::npos) << o.getLastError ();
  }
}

TEST (ObliqueCutOctreeBudget, FrontDuringABudgetedBuildOnlyReturnsRetainedNodes)
{
  const auto cloud = mixedCloud (800000, 5);
  Octree o;
  o.setInputCloud (cloud);
  configure (o, 6, true);
  o.setMemoryBudget (10 << 20);
  o.setProjectionThreshold (1e-6f);  // branch as deep as the front can go
  ASSERT_TRUE (o.startBuild ());
  struct Seen
  {
    const Octree::Node* node;
    std::uint32_t n;
    double sum;
  };
  std::map<std::uint64_t, Seen> seen;
  std::vector<Octree::Item> items;
  Octree::Camera cam;  // identity: the clip cube [-1, 1]^3; the cloud spans [-1, 3]
  cam.view_projection = Eigen::Matrix4f::Identity () * 0.5f;
  cam.view_projection (3, 3) = 1.f;
  // Evaluated during the build and at least three times after it: the spill-level nodes reach
  // the front when their grandparents are created, which can be the build's last fix.
  int after = 0;
  while (after < 3)
  {
    const bool finished = o.isFinished ();
    o.evaluate (cam, items);
    after += finished ? 1 : 0;
    const int spill = o.getSpillLevel ();
    for (const auto& it : items)
    {
      ASSERT_GE (spill, 1) << "items before the spill level is known";
      ASSERT_LE (it.node->level, spill);
      ASSERT_TRUE (it.node->num_children == 0 ? (it.node->flags & pclx::omicron::detail::kSpilled) != 0 : true);
      double sum = 0;
      for (std::uint32_t k = 0; k < it.num_points; ++k)
        sum += it.points[k].x + 2.0 * it.points[k].y + 3.0 * it.points[k].z;
      seen[it.node->code.bits ()] = Seen{it.node, it.num_points, sum};
    }
  }
  ASSERT_TRUE (o.wait ()) << o.getLastError ();
  EXPECT_GT (seen.size (), 0u);
  // Every node ever drawn is in the retained tree, at the same address with the same points.
  std::map<std::uint64_t, const Octree::Node*> retained;
  std::vector<const Octree::Node*> stack{o.getRoot ()};
  while (!stack.empty ())
  {
    const auto* n = stack.back ();
    stack.pop_back ();
    retained[n->code.bits ()] = n;
    for (int j = 0; j < n->num_children; ++j)
      stack.push_back (n->children + j);
  }
  for (const auto& s : seen)
  {
    const auto it = retained.find (s.first);
    ASSERT_NE (it, retained.end ()) << "drawn node " << s.first << " is not retained";
    ASSERT_EQ (it->second, s.second.node);
    double sum = 0;
    for (std::uint32_t k = 0; k < it->second->num_points; ++k)
      sum += it->second->points[k].x + 2.0 * it->second->points[k].y + 3.0 * it->second->points[k].z;
    EXPECT_EQ (sum, s.second.sum);
  }
  // Converged with the root cube filling the view: the front is the spill level, every
  // spilled node drawn.
  const auto st = o.getStatistics ();
  const float sc = 2.f / static_cast<float> (o.getRootEdge ());
  cam.view_projection = Eigen::Matrix4f::Identity ();
  for (int a = 0; a < 3; ++a)
  {
    cam.view_projection (a, a) = sc;
    cam.view_projection (a, 3) = -1.f - sc * static_cast<float> (o.getRootOrigin ()[a]);
  }
  for (int k = 0; k < 40; ++k)
    o.evaluate (cam, items);
  std::size_t spilled_drawn = 0;
  for (const auto& it : items)
    spilled_drawn += (it.node->flags & pclx::omicron::detail::kSpilled) ? 1 : 0;
  EXPECT_EQ (spilled_drawn, st.nodes_per_level[st.spill_level]);
}

TEST (ObliqueCutOctreeBudget, PlannerBoundsAndFitsTheBudget)
{
  // 8^2 cells at level 2 of a depth-4 tree; one heavy cell.
  std::vector<std::uint32_t> counts (64, 100);
  counts[10] = 5000;
  pclx::omicron::detail::PlanParameters p;
  p.max_depth = 4;
  p.count_level = 2;
  p.budget = 4 << 20;
  const auto plan = pclx::omicron::detail::planChunks (counts, p);
  ASSERT_GE (plan.spill_level, 1) << plan.error;
  EXPECT_LE (plan.peak_bound, p.budget);
  std::uint64_t total = 0;
  for (auto c : plan.chunk_points)
    total += c;
  EXPECT_EQ (total, 63u * 100u + 5000u);
  EXPECT_EQ (plan.cell_begin.front (), 0u);
  EXPECT_EQ (plan.cell_begin.back (), std::uint64_t (1) << (3 * plan.spill_level));
  p.budget = 200000;  // the heavy cell alone needs more
  const auto none = pclx::omicron::detail::planChunks (counts, p);
  EXPECT_LT (none.spill_level, 0);
  EXPECT_NE (none.error.find ("5000 points"), std::string::npos) << none.error;
}

// The in-memory build from a file (read twice in blocks on a reader thread: bounds and bucket
// counts, then the scatter) equals the build from the loaded cloud: same root cube, same
// sorted array, same hierarchy. 1.3M points: several blocks of the reader.
TEST (ObliqueCutOctreeBudget, FileWithoutBudgetEqualsTheCloudBuild)
{
  TempDir tmp;
  const auto cloud = mixedCloud (1300000, 11);
  (*cloud)[7].z = std::numeric_limits<float>::infinity ();  // dropped and counted on both paths
  const std::string pcd = (tmp.path / "in.pcd").string ();
  ASSERT_EQ (pcl::io::savePCDFileBinary (pcd, *cloud), 0);
  for (bool collapse : {false, true})
  {
    Octree from_cloud, from_file;
    from_cloud.setInputCloud (cloud);
    from_file.setInputFile (pcd);
    configure (from_cloud, 7, collapse);
    configure (from_file, 7, collapse);
    ASSERT_TRUE (from_cloud.build ()) << from_cloud.getLastError ();
    ASSERT_TRUE (from_file.build ()) << from_file.getLastError ();
    EXPECT_EQ (from_file.getRootOrigin (), from_cloud.getRootOrigin ());
    EXPECT_EQ (from_file.getRootEdge (), from_cloud.getRootEdge ());
    const auto sc = from_cloud.getStatistics (), sf = from_file.getStatistics ();
    EXPECT_EQ (sf.input_points, sc.input_points);
    EXPECT_EQ (sf.kept_points, sc.kept_points);
    EXPECT_EQ (sf.dropped_invalid, 1u);
    EXPECT_EQ (sc.dropped_invalid, 1u);
    EXPECT_EQ (sf.nodes_per_level, sc.nodes_per_level);
    EXPECT_EQ (sf.points_per_level, sc.points_per_level);
    EXPECT_EQ (sortedPointsDiffer (from_cloud, from_file), "");
    pcl::PotreeWriter<pcl::PointXYZ> writer;
    const std::string dc = (tmp.path / ("cloud" + std::to_string (collapse))).string ();
    const std::string df = (tmp.path / ("file" + std::to_string (collapse))).string ();
    writer.write (from_cloud, dc);
    writer.write (from_file, df);
    EXPECT_EQ (comparePotree (dc, df), "");
  }
}

// With a root cube that leaves points out, the file path drops the same points as the cloud
// path (its second read scatters fewer points than the first one read).
TEST (ObliqueCutOctreeBudget, FileWithARootCubeEqualsTheCloudBuild)
{
  TempDir tmp;
  const auto cloud = mixedCloud (400000, 13);
  const std::string pcd = (tmp.path / "in.pcd").string ();
  ASSERT_EQ (pcl::io::savePCDFileBinary (pcd, *cloud), 0);
  Eigen::Vector4f lo, hi;
  pcl::getMinMax3D (*cloud, lo, hi);
  const Eigen::Vector3d origin = lo.head<3> ().cast<double> ();
  const double edge = 0.6 * static_cast<double> ((hi - lo).head<3> ().maxCoeff ());
  Octree from_cloud, from_file;
  from_cloud.setInputCloud (cloud);
  from_file.setInputFile (pcd);
  for (Octree* o : {&from_cloud, &from_file})
  {
    configure (*o, 7, true);
    o->setRootCube (origin, edge);
    ASSERT_TRUE (o->build ()) << o->getLastError ();
  }
  const auto sc = from_cloud.getStatistics (), sf = from_file.getStatistics ();
  EXPECT_GT (sc.dropped_outside, 0u);
  EXPECT_EQ (sf.dropped_outside, sc.dropped_outside);
  EXPECT_EQ (sf.kept_points, sc.kept_points);
  EXPECT_EQ (sf.nodes_per_level, sc.nodes_per_level);
  EXPECT_EQ (sortedPointsDiffer (from_cloud, from_file), "");
  pcl::PotreeWriter<pcl::PointXYZ> writer;
  const std::string dc = (tmp.path / "cloud").string (), df = (tmp.path / "file").string ();
  writer.write (from_cloud, dc);
  writer.write (from_file, df);
  EXPECT_EQ (comparePotree (dc, df), "");
}

// A file that fails while it is read (truncated text) is a clear error of the build, in memory
// and out of core.
TEST (ObliqueCutOctreeBudget, FileReadErrorsFailTheInMemoryBuild)
{
  TempDir tmp;
  const std::string xyz = (tmp.path / "bad.xyz").string ();
  {
    std::ofstream f (xyz);
    for (int i = 0; i < 3000; ++i)
      f << i * 0.001 << " " << i * 0.002 << " 0.5\n";
    f << "1.0 oops 2.0\n";
  }
  for (std::size_t budget : {std::size_t (0), std::size_t (4) << 20})
  {
    Octree o;
    o.setInputFile (xyz);
    configure (o, 5, true);
    if (budget > 0)
      o.setMemoryBudget (budget);
    EXPECT_FALSE (o.build ());
    EXPECT_NE (o.getLastError ().find ("bad.xyz"), std::string::npos) << o.getLastError ();
  }
}

// getInputBounds () is the finite points' bounds on every input path (none with a root cube),
// and getProgress () climbs from 0 to 1 while a background build runs.
TEST (ObliqueCutOctreeBudget, InputBoundsAndProgressOnEveryPath)
{
  TempDir tmp;
  const auto cloud = mixedCloud (300000, 11);
  (*cloud)[9].y = std::numeric_limits<float>::infinity ();
  Eigen::Vector3f lo = Eigen::Vector3f::Constant (std::numeric_limits<float>::max ()), hi = -lo;
  for (const auto& p : *cloud)
    if (std::isfinite (p.x) && std::isfinite (p.y) && std::isfinite (p.z))
    {
      lo = lo.cwiseMin (p.getVector3fMap ());
      hi = hi.cwiseMax (p.getVector3fMap ());
    }
  const std::string pcd = (tmp.path / "in.pcd").string ();
  ASSERT_EQ (pcl::io::savePCDFileBinary (pcd, *cloud), 0);
  for (int path = 0; path < 4; ++path)
  {
    SCOPED_TRACE ("path " + std::to_string (path));
    Octree o;
    Eigen::Vector3f l, h;
    EXPECT_FALSE (o.getInputBounds (l, h));
    EXPECT_EQ (o.getProgress (), 0.0);
    if (path == 0 || path == 3)
      o.setInputCloud (cloud);
    else
      o.setInputFile (pcd);
    configure (o, 6, true);
    o.setSortChunks (32);
    if (path == 2)
      o.setMemoryBudget (cloud->size () * sizeof (pcl::PointXYZ));
    if (path == 3)
      o.setRootCube (lo.cast<double> (), 2.0 * (hi - lo).maxCoeff ());
    ASSERT_TRUE (o.startBuild ());
    double last = 0;
    while (!o.isFinished ())
    {
      const double p = o.getProgress ();
      EXPECT_GE (p, last);
      EXPECT_LE (p, 1.0);
      last = p;
      std::this_thread::yield ();
    }
    ASSERT_TRUE (o.wait ()) << o.getLastError ();
    EXPECT_EQ (o.getProgress (), 1.0);
    EXPECT_EQ (o.getSpillLevel () >= 0, path == 2);
    if (path == 3)
    {
      EXPECT_FALSE (o.getInputBounds (l, h));
      continue;
    }
    ASSERT_TRUE (o.getInputBounds (l, h));
    EXPECT_EQ (l, lo);
    EXPECT_EQ (h, hi);
  }
}
