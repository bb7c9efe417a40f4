// ObliqueCut: invariants 1.1–1.5 after every concatenate / fix, the finished hierarchy against
// a plain top-down octree, placeholders, leaf collapse, the parallel fix, and bad input.
#include "omicron_test_util.h"

#include <pclx/omicron/detail/morton_sorter.h>
#include <pclx/omicron/oblique_cut.h>
#include <pclx/omicron/oblique_cut_front.h>

using pcl::MortonCode;
using namespace omitest;
using Cut = pcl::ObliqueCut<pcl::PointXYZ>;

namespace {
struct Sorted
{
  Cloud::VectorType points;
  std::vector<MortonCode> codes;
  Eigen::Vector3d origin;
  double edge;
};
Sorted
sortAll (const Cloud& c, int depth)
{
  Sorted s;
  pclx::omicron::detail::MortonSorter<pcl::PointXYZ> sorter;
  sorter.setMaxDepth (depth);
  sorter.setChunks (3);
  sorter.sort (c, s.points, [&] (std::size_t, std::size_t, const std::vector<MortonCode>& codes) {
    s.codes.insert (s.codes.end (), codes.begin (), codes.end ());
  });
  s.origin = sorter.getOrigin ();
  s.edge = sorter.getEdge ();
  return s;
}
// Leaves (one per distinct code) of a sorted array.
std::vector<CutNode>
leavesOf (const Sorted& s)
{
  std::vector<CutNode> out;
  for (std::size_t i = 0; i < s.codes.size ();)
  {
    std::size_t j = i;
    while (j < s.codes.size () && s.codes[j] == s.codes[i])
      ++j;
    out.push_back (CutNode::leaf (s.codes[i], s.points.data () + i, static_cast<std::uint32_t> (j - i)));
    i = j;
  }
  return out;
}
Cut::Parameters
params (int depth, float ratio, bool collapse, std::size_t wl, int threads)
{
  Cut::Parameters p;
  p.max_depth = depth;
  p.parent_ratio = ratio;
  p.leaf_collapse = collapse;
  p.worklist_size = wl;
  p.threads = threads;
  return p;
}
}  // namespace

TEST (ObliqueCut, InvariantsHoldAfterEveryConcatenateAndFix)
{
  std::mt19937 rng (11);
  for (Shape shape : kShapes)
    for (bool collapse : {false, true})
    {
      const int depth = 4;
      const auto cloud = makeCloud (shape, 3000, 100 + static_cast<unsigned> (shape));
      const Sorted s = sortAll (*cloud, depth);
      const std::vector<CutNode> leaves = leavesOf (s);
      Cut cut (params (depth, 0.25f, collapse, 1 + rng () % 16, 1 + static_cast<int> (rng () % 3)));
      std::vector<MortonCode> seen;
      std::size_t i = 0, step = 0;
      while (i < leaves.size ())
      {
        const std::size_t k = std::min<std::size_t> (leaves.size () - i, 1 + rng () % 40);
        std::vector<CutNode> w (leaves.begin () + i, leaves.begin () + i + k);
        for (const CutNode& c : w)
          seen.push_back (c.code);
        ASSERT_TRUE (cut.concatenate (w));
        i += k;
        const std::string ctx = std::string (shapeName (shape)) + (collapse ? " collapse" : "") + " step " + std::to_string (step++);
        checkCutInvariants (cut.snapshot (), depth, seen, false, ctx + " after concatenate");
        ASSERT_EQ (cut.getBoundary (), seen.back ());
        // Sometimes only some levels, so fix passes interleave with concatenation.
        if (rng () % 3 == 0)
          cut.fixLevel (depth);
        else
        {
          cut.fix ();
          checkCutInvariants (cut.snapshot (), depth, seen, true, ctx + " after fix");
        }
      }
      cut.fix ();
      checkCutInvariants (cut.snapshot (), depth, seen, true, "before finishing");
      cut.finishInput ();
      cut.fix ();
      ASSERT_TRUE (cut.isComplete ());
      ASSERT_NE (cut.getRoot (), nullptr);
      const RefNode ref = referenceOctree (*cloud, s.origin, s.edge, depth, 0.25f, collapse);
      EXPECT_EQ (compareTrees (*cut.getRoot (), ref), "") << shapeName (shape);
    }
}

TEST (ObliqueCut, FixStopsAtTheBoundary)
{
  // Depth 2: leaves 0..7 of parent 0 and leaf 8 (first of parent 1). After fix, the complete
  // group of parent 0 has moved up; leaf 8 waits, since span(parent 1) > m_C.
  Cloud::VectorType pts (9);
  const int depth = 2;
  Cut cut (params (depth, 1.f, false, 4, 1));
  std::vector<CutNode> w;
  for (int i = 0; i < 9; ++i)
    w.push_back (CutNode::leaf (MortonCode::root ().child (i / 8).child (i % 8), pts.data () + i, 1));
  ASSERT_TRUE (cut.concatenate (w));
  cut.fix ();
  const Cut::Snapshot s = cut.snapshot ();
  ASSERT_EQ (s.lists[2].size (), 1u);
  EXPECT_EQ (s.lists[2][0].code, MortonCode::root ().child (1).child (0));
  ASSERT_EQ (s.lists[1].size (), 1u);
  EXPECT_EQ (s.lists[1][0].code, MortonCode::root ().child (0));
  EXPECT_EQ (s.lists[1][0].num_children, 8);
  EXPECT_EQ (s.lists[1][0].num_points, 8u);  // ratio 1: every child point
  EXPECT_TRUE (s.lists[0].empty ());  // the root's span is past m_C
}

TEST (ObliqueCut, OutOfOrderConcatenateIsRejectedAndLeavesTheCutUnchanged)
{
  Cloud::VectorType pts (4);
  Cut cut (params (3, 0.2f, false, 8, 1));
  const MortonCode a = MortonCode::fromCell (1, 1, 1, 3), b = MortonCode::fromCell (5, 1, 1, 3);
  ASSERT_TRUE (cut.concatenate ({CutNode::leaf (b, pts.data (), 1)}));
  cut.fix ();
  const auto before = cut.snapshot ();
  // Before m_C, equal to m_C, unsorted inside, duplicated, wrong level bookkeeping.
  EXPECT_FALSE (cut.concatenate ({CutNode::leaf (a, pts.data (), 1)}));
  EXPECT_FALSE (cut.concatenate ({CutNode::leaf (b, pts.data (), 1)}));
  const MortonCode c = MortonCode::fromCell (6, 6, 6, 3), d = MortonCode::fromCell (7, 7, 7, 3);
  EXPECT_FALSE (cut.concatenate ({CutNode::leaf (d, pts.data (), 1), CutNode::leaf (c, pts.data (), 1)}));
  EXPECT_FALSE (cut.concatenate ({CutNode::leaf (c, pts.data (), 1), CutNode::leaf (c, pts.data (), 1)}));
  CutNode bad = CutNode::leaf (c, pts.data (), 1);
  bad.level = 2;
  EXPECT_FALSE (cut.concatenate ({bad}));
  // A shallow leaf whose subtree starts before m_C (it would contain b).
  EXPECT_FALSE (cut.concatenate ({CutNode::leaf (b.parent (), pts.data (), 1)}));
  const auto after = cut.snapshot ();
  EXPECT_EQ (after.boundary, before.boundary);
  for (int l = 0; l <= 3; ++l)
  {
    ASSERT_EQ (after.lists[l].size (), before.lists[l].size ());
    for (std::size_t i = 0; i < after.lists[l].size (); ++i)
      EXPECT_EQ (after.lists[l][i].code, before.lists[l][i].code);
  }
  EXPECT_TRUE (cut.concatenate ({}));
  EXPECT_TRUE (cut.concatenate ({CutNode::leaf (c, pts.data (), 1), CutNode::leaf (d, pts.data (), 1)}));
  cut.finishInput ();
  EXPECT_FALSE (cut.concatenate ({CutNode::leaf (MortonCode::fromCell (7, 7, 7, 3), pts.data (), 1)}));
}

TEST (ObliqueCut, PlaceholdersCarryShallowLeavesToTheirLevel)
{
  // Leaves at levels 5, 2, 5, 3 and 1 (depth 5). Shallow ones climb as placeholders
  // P_{X,l}; the finished tree has each leaf at its own level under its ancestors.
  const int depth = 5;
  Cloud::VectorType pts (5);
  const MortonCode r = MortonCode::root ();
  const std::vector<MortonCode> leaves = {
      r.child (0).child (0).child (0).child (0).child (3),
      r.child (0).child (1),
      r.child (0).child (2).child (0).child (0).child (0),
      r.child (0).child (2).child (5).child (1),
      r.child (6),
  };
  for (int threads : {1, 2})
  {
    Cut cut (params (depth, 1.f, false, 2, threads));
    pcl::ObliqueCutFront<pcl::PointXYZ> front;
    front.reset (depth, Eigen::Vector3d::Zero (), 1.0, std::vector<float> (depth + 1, 1.f));
    cut.setFront (&front);
    std::vector<MortonCode> seen;
    for (std::size_t i = 0; i < leaves.size (); ++i)
    {
      ASSERT_TRUE (cut.concatenate ({CutNode::leaf (leaves[i], pts.data () + i, 1)}));
      seen.push_back (leaves[i]);
      const auto s = cut.snapshot ();
      // Inside L_{lmax} a shallow leaf is its placeholder P_{X,lmax} = span(X).
      bool found = false;
      for (const CutNode& c : s.lists[depth])
        found |= c.code == leaves[i].span (depth) && c.leaf_level == leaves[i].level ();
      EXPECT_TRUE (found) << i;
      checkCutInvariants (s, depth, seen, false, "concatenate " + std::to_string (i));
      cut.fix ();
      checkCutInvariants (cut.snapshot (), depth, seen, true, "fix " + std::to_string (i));
    }
    cut.finishInput ();
    cut.fix ();
    ASSERT_TRUE (cut.isComplete ());
    // Walk the tree: every leaf of the input is a leaf of the tree at its level.
    std::set<std::uint64_t> tree_leaves;
    std::vector<const Node*> stack{cut.getRoot ()};
    while (!stack.empty ())
    {
      const Node* n = stack.back ();
      stack.pop_back ();
      ASSERT_EQ (n->level, n->code.level ());
      if (n->isLeaf ())
        tree_leaves.insert (n->code.bits ());
      for (int j = 0; j < n->num_children; ++j)
        stack.push_back (n->children + j);
    }
    std::set<std::uint64_t> expected;
    for (MortonCode c : leaves)
      expected.insert (c.bits ());
    EXPECT_EQ (tree_leaves, expected);
    EXPECT_EQ (cut.getRoot ()->num_points, 5u);
  }
}

TEST (ObliqueCut, ParallelFixBuildsTheSameHierarchy)
{
  const auto cloud = makeCloud (Shape::CLUSTERED, 40000, 5);
  const int depth = 6;
  const Sorted s = sortAll (*cloud, depth);
  const std::vector<CutNode> leaves = leavesOf (s);
  for (bool collapse : {false, true})
  {
    const RefNode ref = referenceOctree (*cloud, s.origin, s.edge, depth, 0.2f, collapse);
    for (std::size_t wl : {1, 5, 64})
      for (int threads : {1, 2, 3})
      {
        Cut cut (params (depth, 0.2f, collapse, wl, threads));
        for (std::size_t i = 0; i < leaves.size (); i += 500)
        {
          ASSERT_TRUE (cut.concatenate (std::vector<CutNode> (leaves.begin () + i,
                                                              leaves.begin () + std::min (leaves.size (), i + 500))));
          cut.fixLevel (depth);
          cut.fixLevel (depth - 1);
        }
        cut.finishInput ();
        cut.fix ();
        ASSERT_TRUE (cut.isComplete ());
        EXPECT_EQ (compareTrees (*cut.getRoot (), ref), "")
            << "collapse " << collapse << " worklist " << wl << " threads " << threads;
      }
  }
}

TEST (ObliqueCut, MasterThreadWithAConcurrentSorter)
{
  const auto cloud = makeCloud (Shape::UNIFORM, 30000, 8);
  const int depth = 5;
  const Sorted s = sortAll (*cloud, depth);
  const std::vector<CutNode> leaves = leavesOf (s);
  Cut cut (params (depth, 0.25f, true, 16, 2));
  std::thread sorter ([&] {
    for (std::size_t i = 0; i < leaves.size (); i += 16)
      cut.concatenate (std::vector<CutNode> (leaves.begin () + i, leaves.begin () + std::min (leaves.size (), i + 16)));
    cut.finishInput ();
  });
  cut.runMaster ();
  sorter.join ();
  ASSERT_TRUE (cut.isComplete ());
  EXPECT_EQ (compareTrees (*cut.getRoot (), referenceOctree (*cloud, s.origin, s.edge, depth, 0.25f, true)), "");
}

TEST (ObliqueCut, EmptyInputFinishesWithoutRoot)
{
  Cut cut (params (4, 0.2f, false, 8, 1));
  cut.finishInput ();
  cut.runMaster ();
  EXPECT_TRUE (cut.isComplete ());
  EXPECT_EQ (cut.getRoot (), nullptr);
}

TEST (ObliqueCut, RejectsBadParameters)
{
  // A parameter out of range is refused (PCL_ERROR) and its default used; the others stay.
  const Cut::Parameters d;
  EXPECT_EQ (Cut (params (0, 0.3f, false, 8, 2)).getParameters ().max_depth, d.max_depth);
  EXPECT_EQ (Cut (params (22, 0.3f, false, 8, 2)).getParameters ().max_depth, d.max_depth);
  EXPECT_FLOAT_EQ (Cut (params (5, 0.f, false, 8, 2)).getParameters ().parent_ratio, d.parent_ratio);
  EXPECT_FLOAT_EQ (Cut (params (5, 1.5f, false, 8, 2)).getParameters ().parent_ratio, d.parent_ratio);
  EXPECT_EQ (Cut (params (5, 0.3f, false, 0, 2)).getParameters ().worklist_size, d.worklist_size);
  EXPECT_EQ (Cut (params (5, 0.3f, false, 8, 0)).getParameters ().threads, d.threads);
  const Cut mixed (params (0, 0.3f, false, 8, 2));
  EXPECT_FLOAT_EQ (mixed.getParameters ().parent_ratio, 0.3f);
  EXPECT_EQ (mixed.getParameters ().worklist_size, 8u);
  EXPECT_EQ (mixed.getParameters ().threads, 2);
  const Cut edge (params (21, 1.f, true, 1, 1));
  EXPECT_EQ (edge.getParameters ().max_depth, 21);
  EXPECT_FLOAT_EQ (edge.getParameters ().parent_ratio, 1.f);
  EXPECT_EQ (edge.getParameters ().worklist_size, 1u);
}

TEST (ObliqueCut, RefusesABadSpill)
{
  // setSpill returns false (PCL_ERROR) and leaves the cut without a spill level.
  Cut cut (params (6, 0.2f, true, 8, 1));
  const auto sink = [] (const Cut::Node&) {};
  EXPECT_FALSE (cut.setSpill (0, sink));
  EXPECT_FALSE (cut.setSpill (5, sink));  // >= l_max - 1 with leaf collapse
  EXPECT_FALSE (cut.setSpill (2, nullptr));
  EXPECT_EQ (cut.getSpillLevel (), -1);
  EXPECT_TRUE (cut.setSpill (2, sink));
  EXPECT_EQ (cut.getSpillLevel (), 2);
}

// Siblings share one parent link, stored before their group, so a node stays at 32 bytes.
TEST (NodeArena, SiblingsShareTheirGroupsParentLink)
{
  using Arena = pclx::omicron::detail::NodeArena<pcl::PointXYZ>;
  static_assert (sizeof (Node) == 32, "a node of the hierarchy is 32 bytes");
  Arena arena (16);
  Node* root = arena.allocate (1);
  std::vector<Node*> groups;
  for (std::size_t k : {8, 3, 1, 8, 5})  // more than one block, and a group of one
    groups.push_back (arena.allocate (k));
  EXPECT_EQ (root->parent (), nullptr);
  Node* parent = groups[1];  // the first of three siblings becomes the parent of the last group
  parent->children = groups[4];
  parent->num_children = 5;
  for (std::size_t j = 0; j < 5; ++j)
  {
    EXPECT_EQ (groups[4][j].sibling, j);
    EXPECT_EQ (groups[4][j].parent (), nullptr);
  }
  parent->linkChildren ();
  for (std::size_t j = 0; j < 5; ++j)
    EXPECT_EQ (groups[4][j].parent (), parent);
  // Other groups, before and after it in the arena, keep no parent.
  for (std::size_t g = 0; g < 4; ++g)
    EXPECT_EQ (groups[g][0].parent (), nullptr);
  EXPECT_EQ (groups[0][7].parent (), nullptr);
  EXPECT_GE (arena.bytes (), 25 * sizeof (Node) + 6 * Arena::groupBytes (0));
  arena.clear ();
  EXPECT_EQ (arena.bytes (), 0u);
}
