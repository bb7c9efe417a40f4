#pragma once
// pcl::ObliqueCutFront: the rendering front of OMiCroN (da Silva 2018, §3.2), see the class.
#include <pclx/omicron/detail/octree_node.h>

#include <Eigen/Core>

#include <array>
#include <atomic>
#include <chrono>
#include <deque>
#include <mutex>
#include <vector>

namespace pcl {

/** \brief The Oblique Hierarchy Cut Front of OMiCroN (da Silva 2018, §3.2, Algorithms 5-8):
  * a rendering front over the part of the hierarchy the cut has finished, evaluated while
  * fix keeps building.
  *
  * Each evaluate (camera):
  * 1. takes the leaf list of the substitution level (the level with most pending leaves,
  *    §3.2.3), then appends the new placeholders at the end of the front (§3.2.1);
  * 2. walks the front once: a placeholder is replaced by the head of that list when the head
  *    is its ancestor (Algorithm 6, O(1)); a node whose parent is culled or projects below the
  *    threshold is pruned together with its siblings (Algorithm 7, siblings are adjacent by
  *    invariant 2.1); a visible node that projects above the threshold is branched into its
  *    children (Algorithm 8); the others are drawn.
  *
  * Invariants: 2.1 spans strictly increase along the front; 2.2 only nodes that left L_C
  * enter it (nodes reach the front through leaf lists filled when their grandparent exists,
  * or through parent links set at the same moment). Placeholders are never pruned.
  *
  * Calls to evaluate () are serialized by a mutex (one front tracker). The node data it
  * returns stays valid as long as the octree that built it.
  *
  * \note V. da Silva, 2018, "Concomitant Hierarchy Construction and Rendering of Large Point
  * Clouds" (OMiCroN: Oblique Multipass Hierarchy Creation while Navigating), DSc thesis,
  * UFRJ/COPPE.
  * \ingroup omicron
  */
template <typename PointT>
class ObliqueCutFront
{
public:
  using Node = pclx::omicron::detail::Node<PointT>;  ///< A node of the hierarchy.

  /** \brief The view the front is evaluated for. */
  struct Camera
  {
    Eigen::Matrix4f view_projection = Eigen::Matrix4f::Identity ();  ///< world to clip (OpenGL)
    int width = 1;   ///< viewport width in pixels (splat sizes in pixels, for renderers)
    int height = 1;  ///< viewport height in pixels
  };
  /** \brief What to draw: a node's points with the splat radius of its level. */
  struct Item
  {
    const Node* node = nullptr;      ///< the node
    const PointT* points = nullptr;  ///< its points
    std::uint32_t num_points = 0;    ///< how many
    float splat_radius = 0.f;        ///< splat radius of its level (world units)
  };
  /** \brief A front entry: a node, or a placeholder with its leaf-level code. */
  struct Entry
  {
    const Node* node = nullptr;  ///< the node, nullptr for a placeholder
    MortonCode code;             ///< the placeholder's code (leaf level)
  };

  /** \brief An empty front. */
  ObliqueCutFront () = default;
  ObliqueCutFront (const ObliqueCutFront&) = delete;
  ObliqueCutFront& operator= (const ObliqueCutFront&) = delete;

  /** \brief Start an empty front for a hierarchy over a root cube.
    * \param[in] max_depth the hierarchy's l_max
    * \param[in] origin the root cube's min corner
    * \param[in] edge the root cube's edge
    * \param[in] splat_radius splat radius of each level l (max_depth + 1 values)
    */
  void reset (int max_depth, const Eigen::Vector3d& origin, double edge, std::vector<float> splat_radius);

  /** \brief Set the projection threshold: prune below it, branch above it.
    * \param[in] t a projected box diagonal in NDC, finite and > 0; default 0.2 (thesis
    * §4.3). Otherwise PCL_ERROR and the value is kept.
    */
  void setProjectionThreshold (float t);
  /** \brief The projection threshold.
    * \return the projected box diagonal in NDC */
  float getProjectionThreshold () const { return threshold_; }

  /** \brief Algorithm 5: one front evaluation.
    * \param[in] camera the view
    * \param[out] out what to draw this frame
    */
  void evaluate (const Camera& camera, std::vector<Item>& out);

  /** \brief Start the front at one node of a finished hierarchy that sent it nothing while it
    * was built; evaluate () branches from there (Algorithm 8).
    * \param[in] node the node (the root), valid as long as the front is used */
  void startFrom (const Node& node);

  /** \brief Receive new placeholders (called by ObliqueCut under its per-level mutexes).
    * \param[in] placeholders codes at the hierarchy's l_max (P_{X,l_max}), in Morton order */
  void insertPlaceholders (std::vector<MortonCode>&& placeholders);
  /** \brief Receive leaves that left L_C (called by ObliqueCut under its per-level mutexes).
    * \param[in] level their level
    * \param[in] leaves the leaves, in Morton order */
  void insertLeaves (int level, std::vector<const Node*>&& leaves);

  /** \brief A copy of the front.
    * \return its entries in order */
  std::vector<Entry> entries () const;
  /** \brief Front entries plus placeholders waiting to enter (for memory accounting).
    * \return the count */
  std::size_t entryCount () const;
  /** \brief The most bytes the front holds per entry (for memory accounting): its slot, and
    * up to two more while it waits as a placeholder, while the front grows, or while a branch
    * has moved the rest of the front aside.
    * \return the bytes */
  static constexpr std::size_t bytesPerEntry () { return 3 * sizeof (Slot); }
  /** \brief Leaves received and not yet substituted.
    * \return the count */
  std::size_t pendingLeaves () const;
  /** \brief Seconds from reset () to the first leaf handed to the front.
    * \return them, < 0 when none yet */
  double secondsToFirstLeaf () const;

  /** \brief Culling and projected size of a node's box.
    * \param[in] n the node
    * \param[in] camera the view
    * \param[out] ndc_diagonal the box's projected diagonal in NDC
    * \return true when the box is outside the view */
  bool culled (const Node& n, const Camera& camera, float& ndc_diagonal) const;
  /** \brief The splat radius of a node's level.
    * \param[in] n the node
    * \return the radius (world units) */
  float splatRadius (const Node& n) const;

private:
  // A front entry in 8 bytes: a node's address (nodes are at least 8-byte aligned, so bit 0 is
  // clear), or a placeholder. Placeholders are always at l_max, so their prefix bit is implied:
  // the 3 · l_max bits below it are stored shifted left once, with bit 0 set.
  class Slot
  {
  public:
    static Slot
    of (const Node* n)
    {
      return Slot (reinterpret_cast<std::uintptr_t> (n));
    }
    static Slot
    placeholder (MortonCode c, int max_depth)
    {
      return Slot (((c.bits () ^ (std::uint64_t (1) << (3 * max_depth))) << 1) | 1u);
    }
    const Node*
    node () const
    {
      return (v_ & 1u) ? nullptr : reinterpret_cast<const Node*> (static_cast<std::uintptr_t> (v_));
    }
    MortonCode
    code (int max_depth) const
    {
      return (v_ & 1u) ? MortonCode ((v_ >> 1) | (std::uint64_t (1) << (3 * max_depth))) : node ()->code;
    }

  private:
    explicit Slot (std::uint64_t v) : v_ (v) {}
    std::uint64_t v_;
  };
  static_assert (alignof (Node) >= 2, "a node's address must leave bit 0 for the placeholder tag");

  bool trySubstitution (Slot& e, std::deque<const Node*>& subs) const;

  static constexpr int kLevels = MortonCode::kMaxDepth + 1;
  int max_depth_ = 0;
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero ();
  double edge_ = 1.0;
  std::vector<float> radius_;
  float threshold_ = 0.2f;

  mutable std::mutex front_mutex_;
  std::vector<Slot> front_;
  mutable std::mutex placeholder_mutex_;
  std::deque<MortonCode> placeholders_;  // blocks of their own: no copy as it grows
  mutable std::array<std::mutex, kLevels> leaf_mutex_;
  std::array<std::deque<const Node*>, kLevels> leaves_;
  std::chrono::steady_clock::time_point start_;
  std::atomic<double> first_leaf_{-1.0};
};

}  // namespace pcl
