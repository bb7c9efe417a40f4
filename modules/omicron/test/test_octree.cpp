// ObliqueCutOctree: the whole pipeline (sorter thread, fix master + workers, front) against
// the top-down reference, a background build evaluated concurrently, and bad input.
#include "omicron_test_util.h"

#include <pclx/omicron/oblique_cut_octree.h>

#include <pcl/point_types.h>

#include <limits>
#include <thread>

using pcl::MortonCode;
using namespace omitest;
using Octree = pcl::ObliqueCutOctree<pcl::PointXYZ>;

namespace {
Octree::Camera
topView (const Eigen::Vector3d& origin, double edge, float distance)
{
  // Orthographic-like: a scaled view of the root cube from +z, in front of the camera.
  Octree::Camera c;
  const float s = 2.f / (static_cast<float> (edge) * distance);
  const Eigen::Vector3f centre = (origin + Eigen::Vector3d::Constant (0.5 * edge)).cast<float> ();
  Eigen::Matrix4f m = Eigen::Matrix4f::Identity ();
  m (0, 0) = s;
  m (1, 1) = s;
  m (2, 2) = s * 0.1f;
  m.block<3, 1> (0, 3) = -s * Eigen::Vector3f (centre.x (), centre.y (), 0.1f * centre.z ());
  c.view_projection = m;
  return c;
}
std::size_t
countPoints (const std::vector<Octree::Item>& items)
{
  std::size_t n = 0;
  for (const auto& it : items)
    n += it.num_points;
  return n;
}
}  // namespace

TEST (ObliqueCutOctree, EqualsTopDownConstructionForEverySetting)
{
  struct Case
  {
    Shape shape;
    int depth;
    bool collapse;
    float ratio;
    std::size_t worklist, chunks;
    int threads;
  };
  const Case cases[] = {
      {Shape::UNIFORM, 5, false, 0.2f, 32, 16, 1},   {Shape::UNIFORM, 5, true, 0.2f, 8, 4, 2},
      {Shape::CLUSTERED, 7, false, 0.25f, 1, 1, 2},  {Shape::CLUSTERED, 7, true, 0.25f, 64, 37, 3},
      {Shape::FLAT, 6, true, 0.2f, 5, 8, 2},         {Shape::FLAT, 6, false, 0.25f, 32, 2, 1},
      {Shape::LATTICE, 4, true, 0.25f, 3, 16, 2},    {Shape::LATTICE, 8, false, 0.2f, 128, 5, 2},
      {Shape::DUPLICATES, 9, true, 0.2f, 16, 16, 2}, {Shape::DUPLICATES, 9, false, 0.25f, 2, 3, 1},
      {Shape::IDENTICAL, 3, true, 0.2f, 32, 16, 2},  {Shape::IDENTICAL, 3, false, 0.25f, 32, 16, 1},
      {Shape::UNIFORM, 1, true, 0.25f, 1, 2, 2},     {Shape::CLUSTERED, 21, false, 0.2f, 16, 8, 2},
  };
  for (const Case& c : cases)
  {
    const std::string ctx = std::string (shapeName (c.shape)) + " depth " + std::to_string (c.depth) +
                            (c.collapse ? " collapse" : "") + " ratio " + std::to_string (c.ratio) + " worklist " +
                            std::to_string (c.worklist) + " chunks " + std::to_string (c.chunks) + " threads " +
                            std::to_string (c.threads);
    SCOPED_TRACE (ctx);
    const auto cloud = makeCloud (c.shape, 20000, 300 + c.depth);
    Octree o;
    o.setInputCloud (cloud);
    o.setMaxDepth (c.depth);
    o.setLeafCollapse (c.collapse);
    o.setParentPointRatio (c.ratio);
    o.setWorklistSize (c.worklist);
    o.setSortChunks (c.chunks);
    o.setThreads (c.threads);
    ASSERT_TRUE (o.build ());
    ASSERT_TRUE (o.isFinished ());
    ASSERT_NE (o.getRoot (), nullptr);
    const RefNode ref = referenceOctree (*cloud, o.getRootOrigin (), o.getRootEdge (), c.depth, c.ratio, c.collapse);
    EXPECT_EQ (compareTrees (*o.getRoot (), ref), "");
    const auto st = o.getStatistics ();
    EXPECT_EQ (st.kept_points, cloud->size ());
    EXPECT_EQ (st.nodes_per_level[0], 1u);
    EXPECT_LE (st.chunks, c.chunks);
    // Every point is in exactly one leaf.
    std::size_t leaf_points = 0;
    std::vector<const Octree::Node*> stack{o.getRoot ()};
    while (!stack.empty ())
    {
      const auto* n = stack.back ();
      stack.pop_back ();
      if (n->isLeaf ())
        leaf_points += n->num_points;
      for (int j = 0; j < n->num_children; ++j)
        stack.push_back (n->children + j);
    }
    EXPECT_EQ (leaf_points, cloud->size ());
  }
}

TEST (ObliqueCutOctree, BackgroundBuildWithAConcurrentFront)
{
  const auto cloud = makeCloud (Shape::CLUSTERED, 200000, 12);
  for (int threads : {1, 2})
  {
    Octree o;
    o.setInputCloud (cloud);
    o.setMaxDepth (8);
    o.setSortChunks (32);
    o.setWorklistSize (16);
    o.setThreads (threads);
    o.setLeafCollapse (threads == 2);
    // Small threshold: the front keeps branching towards the leaves while they arrive.
    o.setProjectionThreshold (0.01f);
    ASSERT_TRUE (o.startBuild ());
    std::vector<Octree::Item> items;
    int frames = 0;
    bool drew_during_build = false;
    Octree::Camera cam;
    while (!o.isFinished () || frames < 2)
    {
      cam = topView (o.getRootOrigin (), o.getRootEdge (), 1.f + 0.5f * static_cast<float> (frames % 3));
      o.evaluate (cam, items);
      ++frames;
      drew_during_build |= !o.isFinished () && !items.empty ();
      const auto front = o.getFront ().entries ();
      checkFrontInvariants (front, nullptr, 8, "frame " + std::to_string (frames));
      for (const auto& it : items)
        ASSERT_TRUE (it.num_points > 0 && it.points != nullptr);
      if (::testing::Test::HasFatalFailure ())
        break;
    }
    ASSERT_TRUE (o.wait ());
    // Converge with a close camera on the final root cube (the loop's last camera may predate
    // it when the build ran to its end while this thread was preempted): all leaves, every
    // point drawn exactly once.
    cam = topView (o.getRootOrigin (), o.getRootEdge (), 1.f);
    o.setProjectionThreshold (1e-7f);
    for (int k = 0; k < 40; ++k)
      o.evaluate (cam, items);
    EXPECT_EQ (countPoints (items), cloud->size ());
    std::set<const Octree::Node*> drawn;
    for (const auto& it : items)
    {
      EXPECT_TRUE (it.node->isLeaf ());
      EXPECT_TRUE (drawn.insert (it.node).second);
    }
    // Coarsest LOD: from afar the front is the root alone.
    o.setProjectionThreshold (0.2f);
    const auto far = topView (o.getRootOrigin (), o.getRootEdge (), 1e5f);
    for (int k = 0; k < 40; ++k)
      o.evaluate (far, items);
    ASSERT_EQ (items.size (), 1u);
    EXPECT_EQ (items[0].node, o.getRoot ());
    const auto st = o.getStatistics ();
    EXPECT_GT (st.seconds_total, 0.0);
    EXPECT_LE (st.seconds_to_first_front, st.seconds_total);
    RecordProperty ("frames_during_build_" + std::to_string (threads), frames);
    (void) drew_during_build;  // timing-dependent: reported, not asserted
  }
}

TEST (ObliqueCutOctree, FrontKeptOutOfTheBuildStartsAtTheRootAndBranches)
{
  // A build nobody watches: the same hierarchy, a front that holds nothing until the build
  // ends and then starts at the root, and, from close up, every point drawn once.
  const auto cloud = makeCloud (Shape::CLUSTERED, 100000, 21);
  Octree watched, unwatched;
  for (Octree* o : {&watched, &unwatched})
  {
    o->setInputCloud (cloud);
    o->setMaxDepth (6);
    o->setThreads (2);
  }
  EXPECT_TRUE (watched.getFrontDuringBuild ());
  unwatched.setFrontDuringBuild (false);
  EXPECT_FALSE (unwatched.getFrontDuringBuild ());
  ASSERT_TRUE (watched.build ());
  ASSERT_TRUE (unwatched.build ());
  EXPECT_EQ (unwatched.getStatistics ().nodes_per_level, watched.getStatistics ().nodes_per_level);
  EXPECT_EQ (unwatched.getStatistics ().seconds_to_first_front, unwatched.getStatistics ().seconds_total);
  EXPECT_EQ (unwatched.getFront ().pendingLeaves (), 0u);
  const auto start = unwatched.getFront ().entries ();
  ASSERT_EQ (start.size (), 1u);
  EXPECT_EQ (start[0].node, unwatched.getRoot ());

  std::vector<Octree::Item> items;
  unwatched.setProjectionThreshold (1e-7f);
  const auto cam = topView (unwatched.getRootOrigin (), unwatched.getRootEdge (), 1.f);
  unwatched.evaluate (cam, items);
  EXPECT_GT (unwatched.getFront ().entries ().size (), 1u) << "the first evaluation branches the root";
  for (int k = 0; k < 20; ++k)
    unwatched.evaluate (cam, items);
  checkFrontInvariants (unwatched.getFront ().entries (), nullptr, 6, "unwatched");
  EXPECT_EQ (countPoints (items), cloud->size ());
  for (const auto& it : items)
    EXPECT_TRUE (it.node->isLeaf ());

  // With the front on (again), the leaves wait in it for the first evaluation.
  EXPECT_GT (watched.getFront ().pendingLeaves (), 0u);
  unwatched.setFrontDuringBuild (true);
  ASSERT_TRUE (unwatched.build ());
  EXPECT_EQ (unwatched.getFront ().pendingLeaves (), watched.getFront ().pendingLeaves ());
}

TEST (ObliqueCutOctree, EmptyCloudIsAClearErrorAndAnEmptyResult)
{
  Octree o;
  std::vector<Octree::Item> items;
  EXPECT_FALSE (o.build ());  // no input
  EXPECT_NE (o.getLastError ().find ("no input"), std::string::npos) << o.getLastError ();
  o.setInputCloud (Cloud::Ptr (new Cloud));
  EXPECT_FALSE (o.build ());
  EXPECT_NE (o.getLastError ().find ("no finite point"), std::string::npos) << o.getLastError ();
  EXPECT_EQ (o.getRoot (), nullptr);
  o.evaluate (Octree::Camera (), items);
  EXPECT_TRUE (items.empty ());
  // Only NaN points: same.
  Cloud::Ptr nan (new Cloud);
  nan->push_back (pcl::PointXYZ (std::numeric_limits<float>::quiet_NaN (), 0, 0));
  o.setInputCloud (nan);
  EXPECT_FALSE (o.build ());
  EXPECT_EQ (o.getStatistics ().dropped_invalid, 1u);
}

TEST (ObliqueCutOctree, NonFinitePointsAreDroppedAndCounted)
{
  auto cloud = makeCloud (Shape::UNIFORM, 5000, 2);
  const float nan = std::numeric_limits<float>::quiet_NaN (), inf = std::numeric_limits<float>::infinity ();
  (*cloud)[0].x = nan;
  (*cloud)[100].z = inf;
  (*cloud)[4999].y = -inf;
  (*cloud)[2000] = pcl::PointXYZ (nan, nan, nan);
  Octree o;
  o.setInputCloud (cloud);
  o.setMaxDepth (5);
  o.setLeafCollapse (false);
  ASSERT_TRUE (o.build ());
  const auto st = o.getStatistics ();
  EXPECT_EQ (st.dropped_invalid, 4u);
  EXPECT_EQ (st.kept_points, 4996u);
  EXPECT_EQ (st.points_per_level[5], 4996u);
  EXPECT_EQ (compareTrees (*o.getRoot (), referenceOctree (*cloud, o.getRootOrigin (), o.getRootEdge (), 5, 0.2f, false)), "");
}

TEST (ObliqueCutOctree, AllIdenticalPointsMakeOneChain)
{
  const auto cloud = makeCloud (Shape::IDENTICAL, 1000, 1);
  for (bool collapse : {false, true})
  {
    Octree o;
    o.setInputCloud (cloud);
    o.setMaxDepth (6);
    o.setLeafCollapse (collapse);
    ASSERT_TRUE (o.build ());
    const auto st = o.getStatistics ();
    for (int l = 0; l <= 6; ++l)
      EXPECT_EQ (st.nodes_per_level[l], (collapse && l == 6) ? 0u : 1u) << l;
    EXPECT_EQ (st.points_per_level[collapse ? 5 : 6], 1000u);
    // Each parent keeps round (0.2 · n), at least one: 1000, 200, 40, 8, 2, 1, 1.
    for (int l = collapse ? 4 : 5; l >= 0; --l)
      EXPECT_EQ (st.points_per_level[l], pclx::omicron::detail::parentSampleCount (static_cast<std::uint32_t> (st.points_per_level[l + 1]), 0.2f));
    EXPECT_EQ (st.points_per_level[0], 1u);
  }
}

TEST (ObliqueCutOctree, UserRootCubeDropsOutsidePointsAndClampsTheMaxFace)
{
  Cloud::Ptr c (new Cloud);
  c->push_back (pcl::PointXYZ (0, 0, 0));
  c->push_back (pcl::PointXYZ (1, 1, 1));      // on the max faces: last cell
  c->push_back (pcl::PointXYZ (1.5f, 0, 0));   // outside
  c->push_back (pcl::PointXYZ (0.5f, 0.5f, 0.5f));
  Octree o;
  o.setInputCloud (c);
  o.setMaxDepth (3);
  o.setLeafCollapse (false);
  o.setRootCube (Eigen::Vector3d::Zero (), 1.0);
  ASSERT_TRUE (o.build ());
  const auto st = o.getStatistics ();
  EXPECT_EQ (st.dropped_outside, 1u);
  EXPECT_EQ (st.kept_points, 3u);
  EXPECT_EQ (st.leaves_per_level[3], 3u);
  EXPECT_EQ (o.getSortedPoints ().back ().x, 1.f);
}

TEST (ObliqueCutOctree, DefaultsAreTheViewersAndTheReadmes)
{
  // A user who only sets the input gets the hierarchy omicron_viewer and the README build:
  // leaf collapse on, one worker per core.
  Octree o;
  EXPECT_TRUE (o.getLeafCollapse ());
  EXPECT_EQ (o.getThreads (), std::max (1, static_cast<int> (std::thread::hardware_concurrency ())));
  EXPECT_EQ (o.getMaxDepth (), 7);
  EXPECT_FLOAT_EQ (o.getParentPointRatio (), 0.2f);
}

TEST (ObliqueCutOctree, RejectsBadParameters)
{
  // Each bad value is refused (PCL_ERROR) and the previous one kept.
  Octree o;
  o.setMaxDepth (21);
  EXPECT_EQ (o.getMaxDepth (), 21);
  o.setMaxDepth (1);
  EXPECT_EQ (o.getMaxDepth (), 1);
  o.setMaxDepth (0);
  EXPECT_EQ (o.getMaxDepth (), 1);
  o.setMaxDepth (22);
  EXPECT_EQ (o.getMaxDepth (), 1);
  o.setParentPointRatio (0.f);
  EXPECT_FLOAT_EQ (o.getParentPointRatio (), 0.2f);
  o.setParentPointRatio (1.01f);
  EXPECT_FLOAT_EQ (o.getParentPointRatio (), 0.2f);
  o.setWorklistSize (0);
  EXPECT_EQ (o.getWorklistSize (), 32u);
  o.setSortChunks (0);
  EXPECT_EQ (o.getSortChunks (), 16u);
  o.setThreads (3);
  o.setThreads (0);
  EXPECT_EQ (o.getThreads (), 3);
  const std::vector<float> m = o.getSplatMultipliers ();
  o.setSplatMultipliers ({});
  EXPECT_EQ (o.getSplatMultipliers (), m);
  o.setSplatMultipliers ({2.f, -1.f});
  EXPECT_EQ (o.getSplatMultipliers (), m);
  o.setProjectionThreshold (-1.f);
  EXPECT_FLOAT_EQ (o.getFront ().getProjectionThreshold (), 0.2f);
  // A refused root cube keeps the one set before: the build uses it.
  const auto cloud = makeCloud (Shape::UNIFORM, 2000, 5);
  o.setMaxDepth (5);
  o.setInputCloud (cloud);
  o.setRootCube (Eigen::Vector3d::Constant (-1.0), 4.0);
  o.setRootCube (Eigen::Vector3d::Zero (), -1.0);
  o.setRootCube (Eigen::Vector3d::Constant (std::numeric_limits<double>::quiet_NaN ()), 1.0);
  ASSERT_TRUE (o.build ());
  EXPECT_DOUBLE_EQ (o.getRootEdge (), 4.0);
  EXPECT_EQ (o.getRootOrigin (), Eigen::Vector3d::Constant (-1.0));
}

TEST (ObliqueCutOctree, RefusesChangesWhileBuilding)
{
  // Setters called during a build print PCL_ERROR and change nothing; statistics are empty
  // until the build ends. The build takes far longer than the calls right after startBuild.
  const auto cloud = makeCloud (Shape::UNIFORM, 400000, 6);
  Octree o;
  o.setInputCloud (cloud);
  o.setThreads (2);
  ASSERT_TRUE (o.startBuild ());
  o.setMaxDepth (3);
  o.setParentPointRatio (0.5f);
  o.setThreads (1);
  o.setMemoryBudget (1u << 30);
  o.setInputCloud (nullptr);
  o.setFrontDuringBuild (false);
  const Octree::Statistics during = o.getStatistics ();
  ASSERT_TRUE (o.wait ()) << o.getLastError ();
  if (during.kept_points == 0)  // the calls came while it ran (as they almost always do)
  {
    EXPECT_EQ (o.getMaxDepth (), 7);
    EXPECT_FLOAT_EQ (o.getParentPointRatio (), 0.2f);
    EXPECT_EQ (o.getThreads (), 2);
    EXPECT_EQ (o.getMemoryBudget (), 0u);
    EXPECT_TRUE (o.getFrontDuringBuild ());
  }
  EXPECT_EQ (o.getStatistics ().kept_points, cloud->size ());
}

TEST (ObliqueCutOctree, SplatRadiiFollowTheMultipliers)
{
  const auto cloud = makeCloud (Shape::UNIFORM, 2000, 3);
  Octree o;
  o.setInputCloud (cloud);
  o.setMaxDepth (4);
  o.setLeafSplatRadius (0.01f);
  o.setSplatMultipliers ({4.f, 2.f});
  ASSERT_TRUE (o.build ());
  const auto r = o.getSplatRadii ();
  ASSERT_EQ (r.size (), 5u);
  EXPECT_FLOAT_EQ (r[4], 0.01f);
  EXPECT_FLOAT_EQ (r[3], 0.04f);
  EXPECT_FLOAT_EQ (r[2], 0.08f);
  EXPECT_FLOAT_EQ (r[0], 0.32f);
}

TEST (ObliqueCutOctree, OtherPointTypesBuild)
{
  pcl::PointCloud<pcl::PointXYZRGB>::Ptr c (new pcl::PointCloud<pcl::PointXYZRGB>);
  for (int i = 0; i < 1000; ++i)
  {
    pcl::PointXYZRGB p (static_cast<std::uint8_t> (i), 0, 255);
    p.x = static_cast<float> (i % 10);
    p.y = static_cast<float> (i / 10 % 10);
    p.z = static_cast<float> (i / 100);
    c->push_back (p);
  }
  pcl::ObliqueCutOctree<pcl::PointXYZRGB> o;
  o.setInputCloud (c);
  o.setMaxDepth (4);
  o.setLeafCollapse (false);
  ASSERT_TRUE (o.build ());
  EXPECT_EQ (o.getStatistics ().leaves_per_level[4], 1000u);
  EXPECT_EQ (o.getRoot ()->points[0].b, 255);
  pcl::ObliqueCutOctree<pcl::PointNormal> on;
  pcl::PointCloud<pcl::PointNormal>::Ptr cn (new pcl::PointCloud<pcl::PointNormal>);
  cn->push_back (pcl::PointNormal (1, 2, 3, 0, 0, 1));
  on.setInputCloud (cn);
  ASSERT_TRUE (on.build ());
  EXPECT_EQ (on.getRoot ()->points[0].normal_z, 1.f);
}
