#pragma once
// Node records shared by pcl::ObliqueCut and pcl::ObliqueCutFront (OMiCroN §3).
//
// A subtree root in a cut list L_{C,l} is a value (CutNode) in a worklist: fix moves it from
// list to list. When its parent is created it is copied into permanent storage (Node, in a
// NodeArena, siblings contiguous) and never moves again. The front only ever holds permanent
// nodes, which is what keeps roots of L_C out of it (invariant 2.2). A node's parent link
// is set when its grandparent is created (Algorithm 4), so a front node can be pruned into
// its parent only once that parent has itself left L_C. Siblings share that link, so it is
// stored once, in a header before their group, which keeps a node at 32 bytes.
#include <pclx/omicron/morton_code.h>

#include <algorithm>
#include <cmath>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <utility>
#include <vector>

namespace pclx {
namespace omicron {
namespace detail {

using pcl::MortonCode;

enum NodeFlags : std::uint8_t
{
  kCollapsed = 1,  // leaf that took the points of its only child (leaf collapse)
  kSpilled = 2     // budgeted build: children written to disk and dropped; drawn as a leaf
};

template <typename PointT>
struct Node
{
  // What precedes a sibling group in its NodeArena: the group's parent link, set when the
  // grandparent is created.
  struct GroupHeader
  {
    std::atomic<const Node*> parent{nullptr};
  };

  MortonCode code;
  const PointT* points = nullptr;    // leaves: a range of the sorted array; parents: own sample
  const Node* children = nullptr;    // contiguous, Morton order
  std::uint32_t num_points = 0;
  std::uint8_t level = 0;
  std::uint8_t num_children = 0;
  std::uint8_t flags = 0;
  std::uint8_t sibling = 0;          // index in the sibling group

  bool isLeaf () const { return num_children == 0; }

  // The parent, or null while the grandparent is not created (and for the root). Only for
  // nodes allocated by a NodeArena: a copy has no group header.
  const Node*
  parent () const
  {
    return header (this - sibling).parent.load (std::memory_order_acquire);
  }

  // Links the children to this node (they must come from a NodeArena).
  void
  linkChildren () const
  {
    if (num_children > 0)
      header (children).parent.store (this, std::memory_order_release);
  }

  static GroupHeader&
  header (const Node* first)
  {
    const unsigned char* at = reinterpret_cast<const unsigned char*> (first) - sizeof (GroupHeader);
    return *std::launder (reinterpret_cast<GroupHeader*> (const_cast<unsigned char*> (at)));
  }
};

template <typename PointT>
struct CutNode
{
  MortonCode code;  // at `level`; for a placeholder P_{X,level} of the leaf X
  const PointT* points = nullptr;
  std::uint32_t num_points = 0;
  std::uint8_t level = 0;
  std::uint8_t leaf_level = 0;  // == level, or the level of X for a placeholder (§3.1.3)
  std::uint8_t num_children = 0;
  std::uint8_t flags = 0;
  const Node<PointT>* children = nullptr;

  bool isPlaceholder () const { return leaf_level < level; }

  // A leaf at `level` holding [points, points + n).
  static CutNode
  leaf (MortonCode code, const PointT* points, std::uint32_t n)
  {
    CutNode c;
    c.code = code;
    c.points = points;
    c.num_points = n;
    c.level = c.leaf_level = static_cast<std::uint8_t> (code.level ());
    return c;
  }
};

/** \brief Copy a cut node's fields into a permanent node (its parent link is set when its
  * grandparent is created).
  * \param[out] n the permanent node
  * \param[in] c the cut node
  */
template <typename PointT>
void
assignNode (Node<PointT>& n, const CutNode<PointT>& c)
{
  n.code = c.code;
  n.points = c.points;
  n.num_points = c.num_points;
  n.level = c.level;
  n.num_children = c.num_children;
  n.flags = c.flags;
  n.children = c.children;
}

// Blocks that never move: pointers into them stay valid while other threads allocate more
// (a std::vector would relocate). One arena per worker, so allocation takes no lock.
template <typename T>
class BlockArena
{
public:
  explicit BlockArena (std::size_t block = 4096) : block_ (block) {}

  T*
  allocate (std::size_t k)
  {
    // Large requests get a block of their own, so the current block's tail is not wasted:
    // reserved bytes stay within 1/16 of what is used (memory budgets count them).
    if (k > block_ / 16 && k > 1)
    {
      blocks_.emplace_back (new T[k]);
      reserved_ += k;
      T* p = blocks_.back ().get ();
      if (capacity_ > 0)
        std::swap (blocks_.back (), blocks_[blocks_.size () - 2]);  // the open block stays last
      return p;
    }
    if (used_ + k > capacity_)
    {
      capacity_ = std::max (block_, k);
      blocks_.emplace_back (new T[capacity_]);
      reserved_ += capacity_;
      used_ = 0;
    }
    T* p = blocks_.back ().get () + used_;
    used_ += k;
    return p;
  }
  std::size_t bytes () const { return reserved_ * sizeof (T); }
  // Frees every block (pointers into them become invalid).
  void
  clear ()
  {
    blocks_.clear ();
    used_ = capacity_ = reserved_ = 0;
  }

private:
  std::size_t block_;
  std::vector<std::unique_ptr<T[]>> blocks_;
  std::size_t used_ = 0, capacity_ = 0, reserved_ = 0;
};

// Sibling groups of Node, each behind the header that holds its parent link, in blocks that
// never move (a BlockArena of 8-byte words).
template <typename PointT>
class NodeArena
{
public:
  using NodeT = Node<PointT>;
  using Header = typename NodeT::GroupHeader;
  static_assert (sizeof (Header) % alignof (NodeT) == 0 && sizeof (NodeT) % sizeof (std::uint64_t) == 0,
                 "a group header and its nodes must tile 8-byte words");

  // `block`: nodes per block (in groups of eight).
  explicit NodeArena (std::size_t block = 1024) : words_ (groupWords (8) * (block / 8)) {}

  // k siblings, default-constructed, their indices set and their parent link null.
  NodeT*
  allocate (std::size_t k)
  {
    unsigned char* at = reinterpret_cast<unsigned char*> (words_.allocate (groupWords (k)));
    new (at) Header;
    at += sizeof (Header);
    for (std::size_t i = 0; i < k; ++i)
    {
      NodeT* n = new (at + i * sizeof (NodeT)) NodeT ();
      n->sibling = static_cast<std::uint8_t> (i);
    }
    return std::launder (reinterpret_cast<NodeT*> (at));
  }
  std::size_t bytes () const { return words_.bytes (); }
  // Frees every block (pointers into them become invalid).
  void clear () { words_.clear (); }
  // Bytes a group of k siblings takes.
  static constexpr std::size_t groupBytes (std::size_t k) { return sizeof (Header) + k * sizeof (NodeT); }

private:
  static constexpr std::size_t groupWords (std::size_t k) { return groupBytes (k) / sizeof (std::uint64_t); }
  BlockArena<std::uint64_t> words_;
};

// Points a parent takes from a child of n points: round (ratio · n), at least one.
inline std::uint32_t
parentSampleCount (std::uint32_t n, float ratio)
{
  if (n == 0)
    return 0;
  const double m = std::floor (static_cast<double> (ratio) * n + 0.5);
  return static_cast<std::uint32_t> (std::min<double> (n, std::max (1.0, m)));
}

// Index of the t-th of m picks among n points: the centres of m equal strides, so the
// sample spreads over the child's Morton-ordered points.
inline std::uint32_t
parentSampleIndex (std::uint32_t t, std::uint32_t m, std::uint32_t n)
{
  return static_cast<std::uint32_t> ((2 * std::uint64_t (t) + 1) * n / (2 * std::uint64_t (m)));
}

}  // namespace detail
}  // namespace omicron
}  // namespace pclx
