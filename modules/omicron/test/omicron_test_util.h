#pragma once
// Shared helpers for the OMiCroN tests: random clouds of several shapes, a plain top-down
// octree with the same sampling rule (the reference), and invariant checkers.
#include <pclx/omicron/oblique_cut.h>
#include <pclx/omicron/oblique_cut_front.h>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <random>
#include <set>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include <stdlib.h>  // mkdtemp

namespace omitest {

// A fresh folder of its own under the temp directory (mkdtemp: no two tests or processes share
// one), removed with its contents.
struct TempDir
{
  std::filesystem::path path;
  TempDir ()
  {
    std::string t = (std::filesystem::temp_directory_path () / "pclx_omicron_XXXXXX").string ();
    if (!::mkdtemp (t.data ()))
      throw std::runtime_error ("cannot create a folder like " + t);
    path = t;
  }
  ~TempDir ()
  {
    std::error_code ec;
    std::filesystem::remove_all (path, ec);
  }
  TempDir (const TempDir&) = delete;
  TempDir& operator= (const TempDir&) = delete;
};

using Cloud = pcl::PointCloud<pcl::PointXYZ>;
using Node = pclx::omicron::detail::Node<pcl::PointXYZ>;
using CutNode = pclx::omicron::detail::CutNode<pcl::PointXYZ>;

enum class Shape
{
  UNIFORM,
  CLUSTERED,
  FLAT,
  LATTICE,
  DUPLICATES,
  IDENTICAL
};
inline const char*
shapeName (Shape s)
{
  switch (s)
  {
  case Shape::UNIFORM: return "uniform";
  case Shape::CLUSTERED: return "clustered";
  case Shape::FLAT: return "flat";
  case Shape::LATTICE: return "lattice";
  case Shape::DUPLICATES: return "duplicates";
  case Shape::IDENTICAL: return "identical";
  }
  return "?";
}
const Shape kShapes[] = {Shape::UNIFORM, Shape::CLUSTERED, Shape::FLAT, Shape::LATTICE, Shape::DUPLICATES,
                         Shape::IDENTICAL};

inline Cloud::Ptr
makeCloud (Shape shape, std::size_t n, unsigned seed)
{
  std::mt19937 rng (seed);
  std::uniform_real_distribution<float> u (-1.f, 3.f);
  std::normal_distribution<float> g (0.f, 0.02f);
  Cloud::Ptr c (new Cloud);
  c->resize (n);
  std::vector<pcl::PointXYZ> centres;
  for (int i = 0; i < 5; ++i)
    centres.emplace_back (u (rng), u (rng), u (rng));
  const int side = std::max (2, static_cast<int> (std::cbrt (static_cast<double> (n))));
  for (std::size_t i = 0; i < n; ++i)
  {
    pcl::PointXYZ& p = (*c)[i];
    switch (shape)
    {
    case Shape::UNIFORM: p = pcl::PointXYZ (u (rng), u (rng), u (rng)); break;
    case Shape::CLUSTERED:
    {
      const pcl::PointXYZ& k = centres[rng () % centres.size ()];
      p = pcl::PointXYZ (k.x + g (rng), k.y + g (rng), k.z + g (rng));
      break;
    }
    case Shape::FLAT: p = pcl::PointXYZ (u (rng), 0.5f, u (rng)); break;
    case Shape::LATTICE:
    {
      const std::size_t j = i % (std::size_t (side) * side * side);
      p = pcl::PointXYZ (0.25f * static_cast<float> (j % side), 0.25f * static_cast<float> ((j / side) % side),
                         0.25f * static_cast<float> (j / side / side));
      break;
    }
    case Shape::DUPLICATES:
    {
      const pcl::PointXYZ& k = centres[rng () % 3];
      p = k;
      break;
    }
    case Shape::IDENTICAL: p = pcl::PointXYZ (1.f, 2.f, 3.f); break;
    }
  }
  return c;
}

// Reference: a plain recursive top-down octree over the same root cube, leaves at max depth
// holding their points in input order, parents sampling each child by the library's rule,
// leaf collapse folding an only child at max depth into its parent.
struct RefNode
{
  pcl::MortonCode code;
  int level = 0;
  std::vector<pcl::PointXYZ> points;
  std::vector<RefNode> children;
  bool collapsed = false;
};

inline void
refBuild (RefNode& node, std::vector<std::pair<pcl::MortonCode, pcl::PointXYZ>>& pts, std::size_t b,
          std::size_t e, int lmax, float ratio, bool collapse)
{
  if (node.level == lmax)
  {
    for (std::size_t i = b; i < e; ++i)
      node.points.push_back (pts[i].second);
    return;
  }
  // Stable partition by child octant = stable sort by the child index at this level.
  std::stable_sort (pts.begin () + b, pts.begin () + e, [&] (const auto& x, const auto& y) {
    return x.first.ancestorAt (node.level + 1).childIndex () < y.first.ancestorAt (node.level + 1).childIndex ();
  });
  for (std::size_t i = b; i < e;)
  {
    const pcl::MortonCode cc = pts[i].first.ancestorAt (node.level + 1);
    std::size_t j = i;
    while (j < e && pts[j].first.ancestorAt (node.level + 1) == cc)
      ++j;
    RefNode child;
    child.code = cc;
    child.level = node.level + 1;
    refBuild (child, pts, i, j, lmax, ratio, collapse);
    node.children.push_back (std::move (child));
    i = j;
  }
  if (collapse && node.level == lmax - 1 && node.children.size () == 1)
  {
    node.points = node.children[0].points;
    node.children.clear ();
    node.collapsed = true;
    return;
  }
  for (const RefNode& c : node.children)
  {
    const auto n = static_cast<std::uint32_t> (c.points.size ());
    const std::uint32_t m = pclx::omicron::detail::parentSampleCount (n, ratio);
    for (std::uint32_t t = 0; t < m; ++t)
      node.points.push_back (c.points[pclx::omicron::detail::parentSampleIndex (t, m, n)]);
  }
}

// Top-down reference for the finite points of `cloud` over the cube (origin, edge).
inline RefNode
referenceOctree (const Cloud& cloud, const Eigen::Vector3d& origin, double edge, int lmax, float ratio,
                 bool collapse)
{
  std::vector<std::pair<pcl::MortonCode, pcl::PointXYZ>> pts;
  for (const auto& p : cloud)
    if (std::isfinite (p.x) && std::isfinite (p.y) && std::isfinite (p.z))
      pts.emplace_back (pcl::MortonCode::fromPoint (p.getVector3fMap (), origin, edge, lmax), p);
  RefNode root;
  root.code = pcl::MortonCode::root ();
  refBuild (root, pts, 0, pts.size (), lmax, ratio, collapse);
  return root;
}

inline bool
samePoint (const pcl::PointXYZ& a, const pcl::PointXYZ& b)
{
  return a.x == b.x && a.y == b.y && a.z == b.z;
}

// Compares the built hierarchy with the reference; returns the first difference ("" if none).
inline std::string
compareTrees (const Node& n, const RefNode& r)
{
  const std::string where = "node " + std::to_string (r.code.bits ()) + " level " + std::to_string (r.level);
  if (n.code != r.code || n.level != r.level)
    return where + ": code/level differ (got " + std::to_string (n.code.bits ()) + ")";
  if (n.num_children != r.children.size ())
    return where + ": " + std::to_string (n.num_children) + " children, expected " + std::to_string (r.children.size ());
  if (n.num_points != r.points.size ())
    return where + ": " + std::to_string (n.num_points) + " points, expected " + std::to_string (r.points.size ());
  for (std::size_t i = 0; i < r.points.size (); ++i)
    if (!samePoint (n.points[i], r.points[i]))
      return where + ": point " + std::to_string (i) + " differs";
  if (((n.flags & pclx::omicron::detail::kCollapsed) != 0) != r.collapsed)
    return where + ": collapse flag differs";
  for (std::size_t i = 0; i < r.children.size (); ++i)
  {
    if (n.children[i].parent () != &n)
      return where + ": child " + std::to_string (i) + " has no parent link";
    const std::string d = compareTrees (n.children[i], r.children[i]);
    if (!d.empty ())
      return d;
  }
  return "";
}

// Every node (level, code) of the hierarchy H spanned by the given leaf codes.
inline std::set<std::pair<int, std::uint64_t>>
hierarchyNodes (const std::vector<pcl::MortonCode>& leaves)
{
  std::set<std::pair<int, std::uint64_t>> h;
  for (pcl::MortonCode c : leaves)
    for (int l = c.level (); l >= 0; --l)
      h.emplace (l, c.ancestorAt (l).bits ());
  return h;
}

// Invariants 1.1–1.4 of a cut snapshot (and 1.5 when `check15`), against the hierarchy H of
// the leaves concatenated so far (`leaves`: codes at their own levels).
inline void
checkCutInvariants (const pcl::ObliqueCut<pcl::PointXYZ>::Snapshot& s, int lmax,
                    const std::vector<pcl::MortonCode>& leaves, bool check15, const std::string& ctx)
{
  SCOPED_TRACE (ctx);
  if (s.complete)
    return;
  // 1.1 m_C has level l_max.
  if (!leaves.empty ())
    ASSERT_EQ (s.boundary.level (), lmax) << "1.1";
  std::set<std::pair<int, std::uint64_t>> in_cut, collapsed;
  std::vector<std::pair<pcl::MortonCode, pcl::MortonCode>> ranges;  // [first, span] at lmax per root
  for (int l = 0; l <= lmax; ++l)
  {
    const auto& list = s.lists[l];
    for (std::size_t i = 0; i < list.size (); ++i)
    {
      const CutNode& c = list[i];
      // 1.2 roots of L_l are at level l.
      ASSERT_EQ (c.level, l) << "1.2";
      ASSERT_EQ (c.code.level (), l) << "1.2 code";
      // 1.4 sorted (strictly: distinct subtrees).
      if (i > 0)
        ASSERT_LT (list[i - 1].code, c.code) << "1.4 at level " << l;
      // Subtree contents (a placeholder stands for its leaf X).
      const pcl::MortonCode x = c.isPlaceholder () ? pcl::MortonCode (c.code.bits () >> (3 * (l - c.leaf_level))) : c.code;
      ranges.emplace_back (x.first (lmax), x.span (lmax));
      if (!c.isPlaceholder ())
      {
        in_cut.emplace (l, c.code.bits ());
        if (c.flags & pclx::omicron::detail::kCollapsed)
          collapsed.emplace (l, c.code.bits ());
        std::vector<const Node*> ns;
        for (int j = 0; j < c.num_children; ++j)
          ns.push_back (c.children + j);
        while (!ns.empty ())
        {
          const Node* n = ns.back ();
          ns.pop_back ();
          ASSERT_TRUE (in_cut.emplace (n->level, n->code.bits ()).second) << "1.3 node in two subtrees";
          if (n->flags & pclx::omicron::detail::kCollapsed)
            collapsed.emplace (n->level, n->code.bits ());
          for (int j = 0; j < n->num_children; ++j)
            ns.push_back (n->children + j);
        }
      }
      else
        ASSERT_TRUE (in_cut.emplace (x.level (), x.bits ()).second) << "1.3 placeholder leaf twice";
    }
  }
  // 1.3 disjoint subtrees: the [first, span] ranges at l_max do not overlap.
  std::sort (ranges.begin (), ranges.end ());
  for (std::size_t i = 1; i < ranges.size (); ++i)
    ASSERT_LT (ranges[i - 1].second, ranges[i].first) << "1.3 overlapping subtrees";
  // Nothing beyond m_C.
  for (const auto& r : ranges)
    ASSERT_LE (r.first, s.boundary) << "root after m_C";
  if (!check15)
    return;
  // 1.5 every node N of H with span(N) <= m_C is in a subtree of L_C.
  for (const auto& h : hierarchyNodes (leaves))
  {
    const pcl::MortonCode c (h.second);
    // A leaf folded into its parent by leaf collapse is represented by that parent.
    if (h.first == lmax && collapsed.count ({lmax - 1, c.parent ().bits ()}))
      continue;
    if (c.span (lmax) <= s.boundary)
      ASSERT_TRUE (in_cut.count (h)) << "1.5 node " << h.second << " at level " << h.first << " missing";
  }
}

// Invariants 2.1 (strictly increasing spans) and 2.2 (no root of L_C in the front).
inline void
checkFrontInvariants (const std::vector<pcl::ObliqueCutFront<pcl::PointXYZ>::Entry>& front,
                      const pcl::ObliqueCut<pcl::PointXYZ>::Snapshot* cut, int lmax, const std::string& ctx)
{
  SCOPED_TRACE (ctx);
  for (std::size_t i = 1; i < front.size (); ++i)
  {
    const pcl::MortonCode a = front[i - 1].node ? front[i - 1].node->code.span (lmax) : front[i - 1].code;
    const pcl::MortonCode b = front[i].node ? front[i].node->code.span (lmax) : front[i].code;
    ASSERT_LT (a, b) << "2.1 at front position " << i;
    // Disjoint too: the next entry starts after this one's span.
    const pcl::MortonCode bf = front[i].node ? front[i].node->code.first (lmax) : front[i].code;
    ASSERT_LT (a, bf) << "front entries overlap at " << i;
  }
  if (!cut || cut->complete)
    return;
  std::set<std::pair<int, std::uint64_t>> roots;
  for (int l = 0; l <= lmax; ++l)
    for (const CutNode& c : cut->lists[l])
      roots.emplace (l, c.code.bits ());
  for (const auto& e : front)
    if (e.node)
      ASSERT_FALSE (roots.count ({e.node->level, e.node->code.bits ()})) << "2.2 root of L_C in the front";
}

}  // namespace omitest
