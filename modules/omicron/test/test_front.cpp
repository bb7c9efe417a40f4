// ObliqueCutFront: invariants 2.1–2.2 after every evaluation with random cameras while the cut
// is being fixed, and what the front converges to once the hierarchy is complete.
#include "omicron_test_util.h"

#include <pclx/omicron/camera.h>
#include <pclx/omicron/detail/morton_sorter.h>
#include <pclx/omicron/oblique_cut.h>
#include <pclx/omicron/oblique_cut_front.h>

using pcl::MortonCode;
using namespace omitest;
using Cut = pcl::ObliqueCut<pcl::PointXYZ>;
using Front = pcl::ObliqueCutFront<pcl::PointXYZ>;

namespace {
// OpenGL-style perspective · look-at.
Front::Camera
lookAt (const Eigen::Vector3f& eye, const Eigen::Vector3f& target, float fov_deg = 60.f)
{
  Front::Camera c;
  c.view_projection = pcl::perspectiveLookAt (eye, target, fov_deg * float (M_PI) / 180.f, 1.f, 0.01f, 1e5f);
  c.width = 640;
  c.height = 480;
  return c;
}
Front::Camera
randomCamera (std::mt19937& rng, const Eigen::Vector3f& centre, float size)
{
  std::uniform_real_distribution<float> u (-1.f, 1.f), d (0.05f, 6.f);
  const Eigen::Vector3f dir = Eigen::Vector3f (u (rng), u (rng), u (rng)).normalized ();
  const Eigen::Vector3f eye = centre + d (rng) * size * dir;
  // Some cameras look away from the cloud (everything culled).
  const Eigen::Vector3f target = (rng () % 4 == 0) ? Eigen::Vector3f (eye + dir) : Eigen::Vector3f (centre + 0.3f * size * Eigen::Vector3f (u (rng), u (rng), u (rng)));
  return lookAt (eye, target);
}
struct Built
{
  Cloud::Ptr cloud;
  Cloud::VectorType points;
  std::vector<CutNode> leaves;
  Eigen::Vector3d origin;
  double edge;
};
Built
build (Shape shape, std::size_t n, int depth, unsigned seed)
{
  Built s;
  s.cloud = makeCloud (shape, n, seed);
  pclx::omicron::detail::MortonSorter<pcl::PointXYZ> sorter;
  sorter.setMaxDepth (depth);
  std::vector<MortonCode> codes;
  sorter.sort (*s.cloud, s.points, [&] (std::size_t, std::size_t, const std::vector<MortonCode>& c) {
    codes.insert (codes.end (), c.begin (), c.end ());
  });
  for (std::size_t i = 0; i < codes.size ();)
  {
    std::size_t j = i;
    while (j < codes.size () && codes[j] == codes[i])
      ++j;
    s.leaves.push_back (CutNode::leaf (codes[i], s.points.data () + i, static_cast<std::uint32_t> (j - i)));
    i = j;
  }
  s.origin = sorter.getOrigin ();
  s.edge = sorter.getEdge ();
  return s;
}
std::size_t
drawnPoints (const std::vector<Front::Item>& items)
{
  std::size_t n = 0;
  for (const auto& it : items)
    n += it.num_points;
  return n;
}
}  // namespace

TEST (ObliqueCutFront, InvariantsHoldAfterEveryEvaluationDuringTheBuild)
{
  std::mt19937 rng (21);
  for (Shape shape : kShapes)
    for (bool collapse : {false, true})
    {
      const int depth = 5;
      const Built s = build (shape, 4000, depth, 40 + static_cast<unsigned> (shape));
      Cut::Parameters p;
      p.max_depth = depth;
      p.leaf_collapse = collapse;
      p.worklist_size = 1 + rng () % 8;
      p.threads = 1 + static_cast<int> (rng () % 2);
      Cut cut (p);
      Front front;
      front.reset (depth, s.origin, s.edge, std::vector<float> (depth + 1, 0.01f));
      front.setProjectionThreshold (0.05f + 0.3f * static_cast<float> (rng () % 4));
      cut.setFront (&front);
      const Eigen::Vector3f centre = (s.origin + Eigen::Vector3d::Constant (0.5 * s.edge)).cast<float> ();
      std::vector<Front::Item> items;
      int step = 0;
      const auto evaluate = [&] (const std::string& when) {
        for (int k = 0; k < 2; ++k)
        {
          front.evaluate (randomCamera (rng, centre, static_cast<float> (s.edge)), items);
          const auto snap = cut.snapshot ();
          checkFrontInvariants (front.entries (), &snap, depth,
                                std::string (shapeName (shape)) + " " + when + " " + std::to_string (step));
          for (const auto& it : items)
            ASSERT_EQ (it.points, it.node->points);
        }
      };
      for (std::size_t i = 0; i < s.leaves.size (); i += 37, ++step)
      {
        ASSERT_TRUE (cut.concatenate (std::vector<CutNode> (s.leaves.begin () + i,
                                                            s.leaves.begin () + std::min (s.leaves.size (), i + 37))));
        evaluate ("after concatenate");
        if (step % 2)
          cut.fixLevel (depth);
        else
          cut.fix ();
        evaluate ("after fix");
      }
      cut.finishInput ();
      cut.fix ();
      ASSERT_TRUE (cut.isComplete ());
      evaluate ("complete");
    }
}

TEST (ObliqueCutFront, ConvergesToTheRootFromAfarAndToAllLeavesFromClose)
{
  for (bool collapse : {false, true})
  {
    const int depth = 4;
    const Built s = build (Shape::CLUSTERED, 5000, depth, 77);
    Cut::Parameters p;
    p.max_depth = depth;
    p.leaf_collapse = collapse;
    p.worklist_size = 8;
    Cut cut (p);
    Front front;
    front.reset (depth, s.origin, s.edge, {0.5f, 0.4f, 0.3f, 0.2f, 0.1f});
    cut.setFront (&front);
    ASSERT_TRUE (cut.concatenate (s.leaves));
    cut.finishInput ();
    cut.fix ();
    ASSERT_TRUE (cut.isComplete ());
    const Eigen::Vector3f centre = (s.origin + Eigen::Vector3d::Constant (0.5 * s.edge)).cast<float> ();
    std::vector<Front::Item> items;

    // Close up with a tiny threshold: every leaf, hence every point once.
    front.setProjectionThreshold (1e-6f);
    const Front::Camera wide = lookAt (centre + Eigen::Vector3f (0, 0, 3.f * static_cast<float> (s.edge)), centre, 90.f);
    for (int k = 0; k < 4 * depth + 4; ++k)
    {
      front.evaluate (wide, items);
      checkFrontInvariants (front.entries (), nullptr, depth, "close");
    }
    std::size_t leaves = 0;
    for (const auto& e : front.entries ())
    {
      ASSERT_NE (e.node, nullptr) << "a placeholder left after the build";
      EXPECT_TRUE (e.node->isLeaf ());
      leaves += 1;
    }
    EXPECT_EQ (drawnPoints (items), s.points.size ());
    EXPECT_EQ (front.pendingLeaves (), 0u);
    EXPECT_GE (leaves, 2u);

    // Far away: everything projects small, the front collapses to the root.
    front.setProjectionThreshold (0.2f);
    const Front::Camera far = lookAt (centre + Eigen::Vector3f (0, 0, 1000.f * static_cast<float> (s.edge)), centre);
    for (int k = 0; k < 4 * depth + 4; ++k)
      front.evaluate (far, items);
    ASSERT_EQ (front.entries ().size (), 1u);
    EXPECT_EQ (front.entries ()[0].node, cut.getRoot ());
    ASSERT_EQ (items.size (), 1u);
    EXPECT_EQ (items[0].num_points, cut.getRoot ()->num_points);
    EXPECT_FLOAT_EQ (items[0].splat_radius, 0.5f);

    // Looking away: culled nodes are pruned too, and nothing is drawn.
    front.setProjectionThreshold (1e-6f);
    for (int k = 0; k < 4 * depth + 4; ++k)
      front.evaluate (wide, items);
    const Front::Camera away = lookAt (centre + Eigen::Vector3f (0, 0, 3.f * static_cast<float> (s.edge)),
                                       centre + Eigen::Vector3f (0, 0, 6.f * static_cast<float> (s.edge)));
    for (int k = 0; k < 4 * depth + 4; ++k)
      front.evaluate (away, items);
    EXPECT_TRUE (items.empty ());
    EXPECT_EQ (front.entries ().size (), 1u);
  }
}

TEST (ObliqueCutFront, PlaceholdersAreNeitherDrawnNorPruned)
{
  // Leaves arrive in the front only when their grandparent exists: right after the first
  // fix of the leaf level, the front holds placeholders only.
  const int depth = 4;
  const Built s = build (Shape::UNIFORM, 3000, depth, 5);
  Cut::Parameters p;
  p.max_depth = depth;
  Cut cut (p);
  Front front;
  front.reset (depth, s.origin, s.edge, std::vector<float> (depth + 1, 1.f));
  cut.setFront (&front);
  ASSERT_TRUE (cut.concatenate (s.leaves));
  cut.fixLevel (depth);
  std::vector<Front::Item> items;
  const Eigen::Vector3f centre = (s.origin + Eigen::Vector3d::Constant (0.5 * s.edge)).cast<float> ();
  const Front::Camera far = lookAt (centre + Eigen::Vector3f (0, 0, 1000.f), centre);
  for (int k = 0; k < 5; ++k)
    front.evaluate (far, items);
  EXPECT_TRUE (items.empty ());
  const auto e = front.entries ();
  EXPECT_FALSE (e.empty ());
  for (const auto& x : e)
    EXPECT_EQ (x.node, nullptr);
  // One placeholder per leaf processed at l_max: all but the group waiting at the boundary.
  EXPECT_EQ (e.size (), s.leaves.size () - cut.snapshot ().lists[depth].size ());
}

TEST (ObliqueCutFront, PlaceholdersKeepTheirCodesAtTheDeepestLevel)
{
  // A placeholder shares its 8-byte slot with a tag bit: at l_max = 21 its code uses all 64
  // bits, and it must come back whole, for the first and the last cell of the grid.
  const int depth = MortonCode::kMaxDepth;
  const std::uint32_t last = (std::uint32_t (1) << depth) - 1;
  const std::vector<MortonCode> codes{MortonCode::fromCell (0, 0, 0, depth), MortonCode::fromCell (5, 9, 1, depth),
                                      MortonCode::fromCell (last, last, last, depth)};
  Front front;
  front.reset (depth, Eigen::Vector3d::Zero (), 1.0, std::vector<float> (depth + 1, 1.f));
  front.insertPlaceholders (std::vector<MortonCode> (codes));
  EXPECT_EQ (front.entryCount (), codes.size ());
  std::vector<Front::Item> items;
  front.evaluate (lookAt (Eigen::Vector3f (0.5f, 0.5f, 5.f), Eigen::Vector3f::Constant (0.5f)), items);
  EXPECT_TRUE (items.empty ());
  const auto e = front.entries ();
  ASSERT_EQ (e.size (), codes.size ());
  for (std::size_t i = 0; i < codes.size (); ++i)
  {
    EXPECT_EQ (e[i].node, nullptr);
    EXPECT_EQ (e[i].code.bits (), codes[i].bits ()) << "placeholder " << i;
  }
}

TEST (ObliqueCutFront, RejectsABadThreshold)
{
  // Refused (PCL_ERROR); the previous threshold is kept.
  Front f;
  f.setProjectionThreshold (0.5f);
  f.setProjectionThreshold (0.f);
  EXPECT_FLOAT_EQ (f.getProjectionThreshold (), 0.5f);
  f.setProjectionThreshold (std::numeric_limits<float>::quiet_NaN ());
  EXPECT_FLOAT_EQ (f.getProjectionThreshold (), 0.5f);
}
