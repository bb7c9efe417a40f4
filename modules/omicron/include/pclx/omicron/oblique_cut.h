#pragma once
// pcl::ObliqueCut: the Oblique Hierarchy Cut of OMiCroN (da Silva 2018, §3.1), see the class.
#include <pclx/omicron/detail/octree_node.h>
#include <pclx/omicron/detail/worker_pool.h>

#include <array>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <vector>

namespace pcl {

template <typename PointT>
class ObliqueCutFront;

/** \brief The Oblique Hierarchy Cut of OMiCroN (da Silva 2018, §3.1): a delimiting code m_C
  * at the leaf level and per-level lists L_{C,l} of subtree roots, kept as worklists.
  *
  * - concatenate (W), Algorithm 2: appends leaves (strictly after m_C, strictly increasing)
  *   to L_{C,lmax}; m_C becomes the last one. Shallower leaves enter as their placeholder
  *   P_{X,lmax} (§3.1.3) and climb as degenerate subtrees.
  * - fixLevel (l), one step of Algorithm 3 at level l: every complete sibling group of
  *   L_{C,l} gets its parent (Algorithm 4) in L_{C,l-1}; a group whose parent has span > m_C
  *   (the boundary S) waits for more input. Worklists are processed in parallel into
  *   per-worklist segments that the master merges back into worklists of the configured size.
  * - fix (): fixLevel (lmax ... 1), the fix operator of §3.1.2.
  * - finishInput (): no more leaves; m_C moves to the last code, so fix climbs to the root.
  * - runMaster (): Algorithm 3's loop, for a thread of its own while another concatenates.
  * - advanceBoundary (): moves m_C to the end of a finished input range without a leaf there,
  *   so the range's last sibling groups close without waiting for more input.
  * - setSpill (): out-of-core build; subtrees below a level are handed to a sink when their
  *   ancestor at that level is created, then cut off.
  *
  * Mutual exclusion is per level (one mutex per list), as in the thesis. Placeholders and
  * leaves for the front go to an ObliqueCutFront when one is attached. pcl::ObliqueCutOctree
  * drives it; it is public for inspection (ObliqueCutOctree::getCut ()) and for callers that
  * feed their own sorted leaves.
  *
  * \note V. da Silva, 2018, "Concomitant Hierarchy Construction and Rendering of Large Point
  * Clouds" (OMiCroN: Oblique Multipass Hierarchy Creation while Navigating), DSc thesis,
  * UFRJ/COPPE.
  * \ingroup omicron
  */
template <typename PointT>
class ObliqueCut
{
public:
  using Node = pclx::omicron::detail::Node<PointT>;        ///< A permanent node of the hierarchy.
  using CutNode = pclx::omicron::detail::CutNode<PointT>;  ///< A subtree root in a cut list.
  using Worklist = std::vector<CutNode>;                   ///< A run of cut nodes in Morton order.

  /** \brief The cut's parameters. */
  struct Parameters
  {
    int max_depth = 7;                  ///< l_max, 1..21
    float parent_ratio = 0.2f;          ///< points a parent keeps per child point, (0, 1]
    bool leaf_collapse = false;         ///< an only child at l_max is folded into its parent
    std::size_t worklist_size = 32;     ///< nodes per worklist (thesis Table 4.2)
    int threads = 1;                    ///< fix workers (the master is one of them), >= 1
  };

  /** \brief A cut with these parameters.
    * \param[in] params the parameters; one out of range is refused with PCL_ERROR and its
    * default (Parameters ()) used instead
    */
  explicit ObliqueCut (const Parameters& params);
  /** \brief Stops the workers. */
  ~ObliqueCut ();
  ObliqueCut (const ObliqueCut&) = delete;
  ObliqueCut& operator= (const ObliqueCut&) = delete;

  /** \brief The parameters in use.
    * \return them (after the constructor's checks) */
  const Parameters& getParameters () const { return params_; }
  /** \brief Attach the front that receives placeholders and leaves.
    * \param[in] front the front (not owned), or nullptr */
  void setFront (ObliqueCutFront<PointT>* front) { front_ = front; }

  /** \brief Algorithm 2: append leaves to L_{C,lmax}.
    * \param[in] w leaves at a level <= l_max, in strictly increasing Morton order, the first
    * one's subtree entirely after m_C; an empty worklist changes nothing
    * \return false (PCL_ERROR, cut unchanged) when w breaks these rules
    */
  bool concatenate (Worklist w);
  /** \brief The delimiting code m_C.
    * \return it (invalid, i.e. 0, before the first concatenate) */
  MortonCode getBoundary () const;

  /** \brief Move m_C forward without concatenating a leaf there: the caller promises no leaf
    * in (m_C, m] will come, so fix can close every sibling group up to m now (e.g. at the
    * end of a chunk of whole cells).
    * \param[in] m a code at l_max, not before m_C
    * \return false (PCL_ERROR) otherwise
    */
  bool advanceBoundary (MortonCode m);

  /** \brief The sink of an out-of-core build: receives a node at the spill level with its
    * complete children, from the fix workers, concurrently; it must not throw. */
  using SpillSink = std::function<void (const Node& spilled)>;
  /** \brief Out-of-core build: when a node X at `level` is created its subtree is complete;
    * X is handed to `sink` with its children (which writes their subtrees somewhere), then X
    * loses its children and is flagged kSpilled, so it is drawn as a leaf from its own sample.
    * Nodes and samples below `level` live in scratch arenas that releaseScratch () frees. The
    * front receives placeholders at `level` (not l_max) and no node below it.
    * \param[in] level 1 <= level < l_max (< l_max - 1 with leaf collapse, so no leaf is at or
    * above it); every leaf must be deeper
    * \param[in] sink the sink (not empty)
    * \return false (PCL_ERROR, nothing changed) for a bad level, an empty sink, or a call after
    * the first concatenate
    */
  bool setSpill (int level, SpillSink sink);
  /** \brief The spill level.
    * \return it, or -1 without setSpill () */
  int getSpillLevel () const { return spill_level_; }
  /** \brief Free the scratch arenas. Only between fix passes, when L_C holds no root below
    * the spill level (after a fix with m_C at the end of a range of whole spill-level cells). */
  void releaseScratch ();
  /** \brief Bytes of the scratch arenas.
    * \return their reserved bytes */
  std::size_t scratchBytes () const;

  /** \brief One step of Algorithm 3: parents for the complete sibling groups of L_{C,level}.
    * \param[in] level 1..l_max
    * \return false when the level is out of range or its list had nothing to fix */
  bool fixLevel (int level);
  /** \brief The fix operator (§3.1.2): fixLevel (l_max ... 1). */
  void fix ();
  /** \brief No more leaves will come: m_C moves to the last code, so fix climbs to the root. */
  void finishInput ();
  /** \brief Run Algorithm 3 until finishInput () has been called and the root exists. */
  void runMaster ();

  /** \brief Whether the hierarchy is complete (the root exists, or the input was empty).
    * \return true once complete */
  bool isComplete () const;
  /** \brief The permanent root once complete.
    * \return the root, nullptr before or for an empty input */
  const Node* getRoot () const { return root_; }

  /** \brief A copy of the cut's state, for inspection and tests. */
  struct Snapshot
  {
    MortonCode boundary;                       ///< m_C
    std::vector<std::vector<CutNode>> lists;   ///< lists[l] = L_{C,l} in order
    const Node* root = nullptr;                ///< the root once complete
    bool complete = false;                     ///< whether the hierarchy is complete
  };
  /** \brief Copy the cut's state (takes every level's lock in turn).
    * \return the snapshot */
  Snapshot snapshot () const;

  /** \brief Bytes of the node and parent-point arenas (scratch included).
    * \return the reserved bytes */
  std::size_t memoryBytes () const;

private:
  struct Segment
  {
    Worklist parents;
    std::vector<MortonCode> placeholders;
    std::vector<const Node*> leaves;  // grandchildren that are leaves (level l + 1)
  };
  struct Slot
  {
    pclx::omicron::detail::NodeArena<PointT> nodes{1024};
    pclx::omicron::detail::BlockArena<PointT> points{8192};
    pclx::omicron::detail::NodeArena<PointT> scratch_nodes{1024};     // below the spill level
    pclx::omicron::detail::BlockArena<PointT> scratch_points{8192};
  };
  // The state of one fixLevel () pass, shared by its stages.
  struct FixPass
  {
    MortonCode bnd;                   // the level's boundary
    std::vector<Worklist*> ws;        // its non-empty worklists
    std::vector<std::size_t> start;   // where each worklist's own groups start
    std::size_t ti = 0, tj = 0;       // where the group waiting at the boundary starts
    Worklist tail;                    // that group, put back after the pass
    std::vector<Segment> segs;        // per worklist: the parents created
  };
  MortonCode findGroupStarts (FixPass& f) const;
  void holdWaitingGroup (FixPass& f, MortonCode prev) const;
  void createParents (FixPass& f);
  void publishParents (int level, FixPass& f);
  void createParent (const CutNode* group, std::size_t k, Slot& slot, Segment& out) const;
  void finalize ();
  bool dirty (int level) const;
  std::size_t worklists (int level) const;

  Parameters params_;
  ObliqueCutFront<PointT>* front_ = nullptr;
  int spill_level_ = -1;
  SpillSink sink_;
  static constexpr int kLevels = MortonCode::kMaxDepth + 1;
  mutable std::array<std::mutex, kLevels> mutex_;
  std::array<std::deque<Worklist>, kLevels> lists_;
  std::array<MortonCode, kLevels> boundary_{};  // L_l holds every root with span <= boundary_[l]
  std::array<bool, kLevels> dirty_{};
  bool input_finished_ = false;
  std::atomic<bool> complete_{false};
  const Node* root_ = nullptr;
  std::mutex signal_mutex_;
  std::condition_variable signal_;
  std::vector<std::unique_ptr<Slot>> slots_;
  std::unique_ptr<pclx::omicron::detail::WorkerPool> pool_;
};

}  // namespace pcl
