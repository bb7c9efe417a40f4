#pragma once
// pcl::ObliqueCutFront: the Oblique Hierarchy Cut Front of OMiCroN (§3.2, Algorithms 5–8):
// a rendering front over the part of the hierarchy the cut has finished, evaluated while fix
// keeps building.
//
// Each evaluate (camera):
//   1. takes the leaf list of the substitution level (the level with most pending leaves,
//      §3.2.3), then appends the new placeholders at the end of the front (§3.2.1);
//   2. walks the front once: a placeholder is replaced by the head of that list when the
//      head is its ancestor (Algorithm 6, O(1)); a node whose parent is culled or projects
//      below the threshold is pruned together with its siblings (Algorithm 7, siblings are
//      adjacent by invariant 2.1); a visible node that projects above the threshold is
//      branched into its children (Algorithm 8); the others are drawn.
// Invariants: 2.1 spans strictly increase along the front; 2.2 only nodes that left L_C
// enter it (nodes reach the front through leaf lists filled when their grandparent exists,
// or through parent links set at the same moment). Placeholders are never pruned.
//
// Calls to evaluate() are serialized by a mutex (one front tracker). The node data it returns
// stays valid as long as the octree that built it.
#include <pclx/omicron/octree_node.h>

#include <Eigen/Core>

#include <array>
#include <atomic>
#include <chrono>
#include <deque>
#include <mutex>
#include <vector>

namespace pcl {

template <typename PointT>
class ObliqueCutFront
{
public:
  using Node = omicron::Node<PointT>;

  struct Camera
  {
    Eigen::Matrix4f view_projection = Eigen::Matrix4f::Identity ();  // world → clip (OpenGL)
    int width = 1, height = 1;  // viewport in pixels (splat sizes in pixels, for renderers)
  };
  // What to draw: a node's points with the splat radius of its level (world units).
  struct Item
  {
    const Node* node = nullptr;
    const PointT* points = nullptr;
    std::uint32_t num_points = 0;
    float splat_radius = 0.f;
  };
  // A front entry: a node, or a placeholder (node == nullptr) with its leaf-level code.
  struct Entry
  {
    const Node* node = nullptr;
    MortonCode code;
  };

  ObliqueCutFront () = default;
  ObliqueCutFront (const ObliqueCutFront&) = delete;
  ObliqueCutFront& operator= (const ObliqueCutFront&) = delete;

  // Starts an empty front for a hierarchy of depth `max_depth` over the root cube.
  // `splat_radius[l]` is the splat radius of level l (max_depth + 1 values).
  void reset (int max_depth, const Eigen::Vector3d& origin, double edge, std::vector<float> splat_radius);

  // Prune below / branch above this projected box diagonal in NDC (default 0.2, §4.3).
  void setProjectionThreshold (float t);
  float getProjectionThreshold () const { return threshold_; }

  // Algorithm 5. `out` receives what to draw this frame.
  void evaluate (const Camera& camera, std::vector<Item>& out);

  // Fed by ObliqueCut (under the per-level mutexes).
  void insertPlaceholders (std::vector<MortonCode>&& placeholders);
  void insertLeaves (int level, std::vector<const Node*>&& leaves);

  std::vector<Entry> entries () const;
  // Front entries plus placeholders waiting to enter (for memory accounting).
  std::size_t entryCount () const;
  std::size_t pendingLeaves () const;
  // Seconds from reset() to the first leaf handed to the front (< 0: none yet).
  double secondsToFirstLeaf () const;

  // Projected size (NDC diagonal) and culling of a node's box.
  bool culled (const Node& n, const Camera& camera, float& ndc_diagonal) const;
  float splatRadius (const Node& n) const;

private:
  bool trySubstitution (Entry& e, std::deque<const Node*>& subs) const;

  static constexpr int kLevels = MortonCode::kMaxDepth + 1;
  int max_depth_ = 0;
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero ();
  double edge_ = 1.0;
  std::vector<float> radius_;
  float threshold_ = 0.2f;

  mutable std::mutex front_mutex_;
  std::vector<Entry> front_, next_;
  mutable std::mutex placeholder_mutex_;
  std::vector<MortonCode> placeholders_;
  mutable std::array<std::mutex, kLevels> leaf_mutex_;
  std::array<std::deque<const Node*>, kLevels> leaves_;
  std::chrono::steady_clock::time_point start_;
  std::atomic<double> first_leaf_{-1.0};
};

}  // namespace pcl
