// MortonCode, MortonSorter and the WorkerPool its passes run on.
#include "omicron_test_util.h"

#include <pclx/omicron/morton_code.h>
#include <pclx/omicron/detail/morton_sorter.h>
#include <pclx/omicron/detail/worker_pool.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <limits>
#include <thread>

using pcl::MortonCode;
using namespace omitest;

TEST (MortonCode, CellRoundTripAtEveryDepth)
{
  std::mt19937 rng (1);
  for (int l = 1; l <= MortonCode::kMaxDepth; ++l)
    for (int k = 0; k < 200; ++k)
    {
      const std::uint32_t mask = (std::uint32_t (1) << l) - 1;
      const std::uint32_t x = rng () & mask, y = rng () & mask, z = rng () & mask;
      const MortonCode c = MortonCode::fromCell (x, y, z, l);
      ASSERT_EQ (c.level (), l);
      std::uint32_t a, b, d;
      c.cell (a, b, d);
      ASSERT_EQ (a, x);
      ASSERT_EQ (b, y);
      ASSERT_EQ (d, z);
    }
}

TEST (MortonCode, PrefixBitAndDepth21UsesAll64Bits)
{
  EXPECT_EQ (MortonCode::root ().level (), 0);
  const std::uint32_t m = (1u << 21) - 1;
  const MortonCode c = MortonCode::fromCell (m, m, m, 21);
  EXPECT_EQ (c.bits (), ~std::uint64_t (0));
  EXPECT_EQ (c.level (), 21);
  EXPECT_EQ (MortonCode::fromCell (0, 0, 0, 21).bits (), std::uint64_t (1) << 63);
  EXPECT_EQ (MortonCode::root ().span (21), c);
}

TEST (MortonCode, ParentChildAndIndexFollowFigure22)
{
  // Child index = x << 2 | y << 1 | z (PCL's octree convention).
  const MortonCode c = MortonCode::fromCell (1, 0, 1, 1);
  EXPECT_EQ (c.bits (), 0b1101u);
  EXPECT_EQ (c.childIndex (), 5);
  EXPECT_EQ (c.parent (), MortonCode::root ());
  for (int i = 0; i < 8; ++i)
  {
    EXPECT_EQ (c.child (i).parent (), c);
    EXPECT_EQ (c.child (i).childIndex (), i);
    EXPECT_EQ (c.child (i).level (), 2);
  }
  // Parent of a cell = cell of the halved coordinates.
  EXPECT_EQ (MortonCode::fromCell (13, 6, 9, 4).parent (), MortonCode::fromCell (6, 3, 4, 3));
}

TEST (MortonCode, SpanAndPlaceholder)
{
  // Fig. 3.2: span(root) at depth 2 is the last code of level 2 (63 without the prefix).
  EXPECT_EQ (MortonCode::root ().span (2).bits (), (1u << 6) | 63u);
  const MortonCode x = MortonCode::fromCell (2, 1, 3, 2);
  // §3.1.3: P_{x,l+i} = x followed by 111 per extra level; P_{x,lmax} = span(x).
  EXPECT_EQ (x.placeholder (3).bits (), (x.bits () << 3) | 7u);
  EXPECT_EQ (x.placeholder (5).bits (), (x.bits () << 9) | 0x1ffu);
  EXPECT_EQ (x.span (5), x.placeholder (5));
  EXPECT_EQ (x.span (2), x);
  // span = the largest descendant: every descendant lies in [first, span].
  for (int i = 0; i < 8; ++i)
    for (int j = 0; j < 8; ++j)
    {
      EXPECT_LE (x.child (i).child (j), x.span (4));
      EXPECT_GE (x.child (i).child (j), x.first (4));
    }
  EXPECT_EQ (x.child (7).child (7), x.span (4));
}

TEST (MortonCode, Ancestry)
{
  const MortonCode a = MortonCode::fromCell (5, 2, 7, 3);
  const MortonCode d = a.child (3).child (6).child (0);
  EXPECT_TRUE (a.isAncestorOf (d));
  EXPECT_TRUE (a.isAncestorOf (a));
  EXPECT_TRUE (MortonCode::root ().isAncestorOf (d));
  EXPECT_FALSE (d.isAncestorOf (a));
  EXPECT_FALSE (a.child (2).isAncestorOf (d));
  EXPECT_EQ (d.ancestorAt (3), a);
  EXPECT_TRUE (a.isAncestorOf (a.placeholder (9)));
  EXPECT_FALSE (MortonCode::fromCell (5, 2, 6, 3).isAncestorOf (a.placeholder (9)));
}

TEST (MortonCode, PointsOnTheMaxFacesClampIntoTheLastCell)
{
  const Eigen::Vector3d o (-1, 0, 2);
  const double e = 4.0;
  for (int l : {1, 7, 21})
  {
    const std::uint32_t last = (std::uint32_t (1) << l) - 1;
    std::uint32_t x, y, z;
    MortonCode::fromPoint (Eigen::Vector3f (3.f, 4.f, 6.f), o, e, l).cell (x, y, z);
    EXPECT_EQ (x, last);
    EXPECT_EQ (y, last);
    EXPECT_EQ (z, last);
    MortonCode::fromPoint (Eigen::Vector3f (-1.f, 0.f, 2.f), o, e, l).cell (x, y, z);
    EXPECT_EQ (x + y + z, 0u);
    // Just below the max face stays in the last cell, midpoint splits at the half.
    MortonCode::fromPoint (Eigen::Vector3f (0.999f, 1.999f, 3.999f), o, e, 1).cell (x, y, z);
    EXPECT_EQ (x, 0u);
    EXPECT_EQ (y, 0u);
    EXPECT_EQ (z, 0u);
  }
  std::uint32_t x, y, z;
  MortonCode::fromPoint (Eigen::Vector3f (1.f, 2.f, 4.f), o, e, 1).cell (x, y, z);
  EXPECT_EQ (x + y + z, 3u);
}

TEST (MortonCode, BoxesNest)
{
  const Eigen::Vector3d o (0, 0, 0);
  const MortonCode c = MortonCode::fromCell (3, 1, 2, 2);
  Eigen::Vector3f lo, hi;
  c.box (o, 8.0, lo, hi);
  EXPECT_TRUE (lo.isApprox (Eigen::Vector3f (6, 2, 4)));
  EXPECT_TRUE (hi.isApprox (Eigen::Vector3f (8, 4, 6)));
}

namespace {
// Sorts with MortonSorter and returns (codes in output order, sorted points, chunk sizes).
struct SortResult
{
  std::vector<MortonCode> codes;
  Cloud::VectorType points;
  std::vector<std::size_t> chunk_sizes;
  std::size_t dropped = 0;
  Eigen::Vector3d origin;
  double edge = 0;
};
SortResult
sortCloud (const Cloud& c, int depth, std::size_t chunks, int threads)
{
  pclx::omicron::detail::MortonSorter<pcl::PointXYZ> s;
  s.setMaxDepth (depth);
  s.setChunks (chunks);
  s.setThreads (threads);
  SortResult r;
  s.sort (c, r.points, [&] (std::size_t b, std::size_t e, const std::vector<MortonCode>& codes) {
    EXPECT_EQ (codes.size (), e - b);
    EXPECT_EQ (b, r.codes.size ()) << "chunks arrive in order";
    r.codes.insert (r.codes.end (), codes.begin (), codes.end ());
    r.chunk_sizes.push_back (e - b);
  });
  r.dropped = s.getDroppedInvalid ();
  r.origin = s.getOrigin ();
  r.edge = s.getEdge ();
  return r;
}
}  // namespace

TEST (MortonSorter, EqualsStdSortOnRandomInputs)
{
  for (Shape shape : kShapes)
    for (int depth : {1, 4, 7, 12, 21})
      for (std::size_t chunks : {std::size_t (1), std::size_t (5), std::size_t (64)})
      {
        SCOPED_TRACE (std::string (shapeName (shape)) + " depth " + std::to_string (depth) + " chunks " + std::to_string (chunks));
        const auto cloud = makeCloud (shape, 20000, 7 + depth);
        const SortResult r = sortCloud (*cloud, depth, chunks, 2);
        ASSERT_EQ (r.points.size (), cloud->size ());
        // Expected: std::stable_sort of (code, input index).
        std::vector<std::pair<MortonCode, std::size_t>> ref;
        for (std::size_t i = 0; i < cloud->size (); ++i)
          ref.emplace_back (MortonCode::fromPoint ((*cloud)[i].getVector3fMap (), r.origin, r.edge, depth), i);
        std::stable_sort (ref.begin (), ref.end (), [] (const auto& a, const auto& b) { return a.first < b.first; });
        for (std::size_t i = 0; i < ref.size (); ++i)
        {
          ASSERT_EQ (r.codes[i], ref[i].first) << i;
          ASSERT_TRUE (samePoint (r.points[i], (*cloud)[ref[i].second])) << i;
          // The code belongs to the point it sits beside.
          ASSERT_EQ (MortonCode::fromPoint (r.points[i].getVector3fMap (), r.origin, r.edge, depth), r.codes[i]);
        }
      }
}

TEST (MortonSorter, ChunksAreGloballySortedAndHonourTheCount)
{
  const auto cloud = makeCloud (Shape::UNIFORM, 100000, 3);
  for (std::size_t chunks : {1, 2, 7, 16, 100})
  {
    const SortResult r = sortCloud (*cloud, 7, chunks, 2);
    EXPECT_EQ (r.chunk_sizes.size (), chunks);
    std::size_t sum = 0;
    for (std::size_t s : r.chunk_sizes)
    {
      sum += s;
      // Balanced within a bucket's worth of points.
      EXPECT_NEAR (static_cast<double> (s), 100000.0 / chunks, 100000.0 / chunks * 0.2 + 200);
    }
    EXPECT_EQ (sum, cloud->size ());
    EXPECT_TRUE (std::is_sorted (r.codes.begin (), r.codes.end ()));
  }
  // Heavy duplicates: whole buckets, so at most the requested count.
  const auto dup = makeCloud (Shape::IDENTICAL, 5000, 1);
  const SortResult d = sortCloud (*dup, 7, 8, 2);
  EXPECT_EQ (d.chunk_sizes.size (), 1u);
  EXPECT_EQ (d.codes.size (), 5000u);
}

TEST (MortonSorter, DropsAndCountsNonFinitePoints)
{
  auto cloud = makeCloud (Shape::UNIFORM, 1000, 4);
  const float nan = std::numeric_limits<float>::quiet_NaN (), inf = std::numeric_limits<float>::infinity ();
  (*cloud)[3].x = nan;
  (*cloud)[10].y = inf;
  (*cloud)[11].z = -inf;
  const SortResult r = sortCloud (*cloud, 7, 4, 1);
  EXPECT_EQ (r.dropped, 3u);
  EXPECT_EQ (r.points.size (), 997u);
  for (const auto& p : r.points)
    EXPECT_TRUE (std::isfinite (p.x) && std::isfinite (p.y) && std::isfinite (p.z));
}

TEST (MortonSorter, SameOutputForAnyThreadCount)
{
  const auto cloud = makeCloud (Shape::DUPLICATES, 30000, 9);
  const SortResult a = sortCloud (*cloud, 9, 3, 1), b = sortCloud (*cloud, 9, 11, 4);
  ASSERT_EQ (a.points.size (), b.points.size ());
  for (std::size_t i = 0; i < a.points.size (); ++i)
    ASSERT_TRUE (samePoint (a.points[i], b.points[i]));
}

// The streaming pair (countBuckets, then scatter in blocks) gives what prepare () gives; points
// that moved between the count and the scatter are flagged by the chunk sort, and more points
// than were counted are refused.
TEST (MortonSorter, StreamedScatterEqualsPrepareAndFlagsMovedPoints)
{
  const auto cloud = makeCloud (Shape::UNIFORM, 50000, 21);
  const SortResult ref = sortCloud (*cloud, 7, 6, 2);
  const auto stream = [&] (const Cloud& counted, const Cloud& scattered, SortResult& r) {
    pclx::omicron::detail::MortonSorter<pcl::PointXYZ> s;
    s.setMaxDepth (7);
    s.setChunks (6);
    s.setThreads (2);
    r.points.resize (s.countBuckets (counted.data (), counted.size ()));
    for (std::size_t b = 0; b < scattered.size (); b += 7000)
      s.scatter (scattered.data () + b, std::min<std::size_t> (7000, scattered.size () - b), r.points);
    std::vector<MortonCode> codes;
    for (std::size_t k = 0; k < s.numChunks (); ++k)
    {
      s.sortChunk (k, r.points, codes);
      r.codes.insert (r.codes.end (), codes.begin (), codes.end ());
    }
    return s.pointsDifferFromCounted ();
  };
  SortResult same;
  EXPECT_FALSE (stream (*cloud, *cloud, same));
  ASSERT_EQ (same.points.size (), ref.points.size ());
  EXPECT_EQ (same.codes, ref.codes);
  for (std::size_t i = 0; i < ref.points.size (); ++i)
    ASSERT_TRUE (samePoint (same.points[i], ref.points[i])) << i;

  Cloud reversed = *cloud;
  std::reverse (reversed.begin (), reversed.end ());
  SortResult moved;
  EXPECT_TRUE (stream (*cloud, reversed, moved));

  pclx::omicron::detail::MortonSorter<pcl::PointXYZ> s;
  Cloud::VectorType sorted (s.countBuckets (cloud->data (), 1000));
  EXPECT_THROW (s.scatter (cloud->data (), 1001, sorted), std::runtime_error);
}

// An exception thrown by a loop's call reaches the caller once every call has returned, and
// the pool runs the next loop.
TEST (WorkerPool, RethrowsTheFirstErrorAfterTheLoop)
{
  pclx::omicron::detail::WorkerPool pool (2);
  std::atomic<int> running{0};
  EXPECT_THROW (pool.parallelFor (64,
                                  [&] (std::size_t i, int) {
                                    ++running;
                                    std::this_thread::sleep_for (std::chrono::microseconds (200));
                                    --running;
                                    if (i == 3)
                                      throw std::runtime_error ("call 3");
                                  }),
                std::runtime_error);
  EXPECT_EQ (running.load (), 0);
  std::atomic<std::size_t> sum{0};
  pool.parallelFor (100, [&] (std::size_t i, int) { sum += i; });
  EXPECT_EQ (sum.load (), 4950u);
}

TEST (MortonSorter, RejectsBadParameters)
{
  // Each bad value is refused (PCL_ERROR) and the previous one kept.
  pclx::omicron::detail::MortonSorter<pcl::PointXYZ> s;
  s.setMaxDepth (9);
  s.setChunks (5);
  s.setMaxDepth (0);
  EXPECT_EQ (s.getMaxDepth (), 9);
  s.setMaxDepth (22);
  EXPECT_EQ (s.getMaxDepth (), 9);
  s.setChunks (0);
  EXPECT_EQ (s.getChunks (), 5u);
  const Eigen::Vector3d origin = s.getOrigin ();
  const double edge = s.getEdge ();
  s.setRootCube (Eigen::Vector3d::Constant (1.0), 0.0);
  EXPECT_EQ (s.getOrigin (), origin);
  EXPECT_EQ (s.getEdge (), edge);
}
