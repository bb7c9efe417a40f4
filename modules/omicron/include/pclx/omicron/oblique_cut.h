#pragma once
// pcl::ObliqueCut: the Oblique Hierarchy Cut of OMiCroN (§3.1): a delimiting code m_C at the
// leaf level and per-level lists L_{C,l} of subtree roots, kept as worklists.
//
//   concatenate (W)  Algorithm 2: appends leaves (strictly after m_C, strictly increasing) to
//                    L_{C,lmax}; m_C becomes the last one. Shallower leaves enter as their
//                    placeholder P_{X,lmax} (§3.1.3) and climb as degenerate subtrees.
//   fixLevel (l)     one step of Algorithm 3 at level l: every complete sibling group of L_{C,l}
//                    gets its parent (Algorithm 4) in L_{C,l−1}; a group whose parent has
//                    span > m_C (the boundary S) waits for more input. Worklists are processed
//                    in parallel into per-worklist segments that the master merges back into
//                    worklists of the configured size.
//   fix ()           fixLevel (lmax … 1): the fix operator of §3.1.2.
//   finishInput ()   no more leaves: m_C moves to the last code, so fix climbs to the root.
//   runMaster ()     Algorithm 3's loop, for a thread of its own while another concatenates.
//   advanceBoundary  moves m_C to the end of a finished input range without a leaf there, so
//                    the range's last sibling groups close without waiting for more input.
//   setSpill (s, f)  out-of-core build: subtrees below level s are handed to f when their
//                    level-s ancestor is created, then cut off (see setSpill).
//
// Mutual exclusion is per level (one mutex per list), as in the paper. Placeholders and
// leaves for the front go to an ObliqueCutFront when one is attached.
#include <pclx/omicron/octree_node.h>
#include <pclx/omicron/worker_pool.h>

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

template <typename PointT>
class ObliqueCut
{
public:
  using Node = omicron::Node<PointT>;
  using CutNode = omicron::CutNode<PointT>;
  using Worklist = std::vector<CutNode>;

  struct Parameters
  {
    int max_depth = 7;                  // l_max, 1..21
    float parent_ratio = 0.2f;          // points a parent keeps per child point, (0, 1]
    bool leaf_collapse = false;         // an only child at l_max is folded into its parent
    std::size_t worklist_size = 32;     // nodes per worklist (Table 4.2: 32–64 is best)
    int threads = 1;                    // fix workers (the master is one of them)
  };

  // Throws std::invalid_argument on parameters out of range.
  explicit ObliqueCut (const Parameters& params);
  ~ObliqueCut ();
  ObliqueCut (const ObliqueCut&) = delete;
  ObliqueCut& operator= (const ObliqueCut&) = delete;

  const Parameters& getParameters () const { return params_; }
  void setFront (ObliqueCutFront<PointT>* front) { front_ = front; }

  // Algorithm 2. Returns false (PCL_ERROR, cut unchanged) unless every node is a leaf at a
  // level <= l_max, the nodes are in strictly increasing Morton order, and the first one's
  // subtree lies entirely after m_C. An empty worklist is accepted and changes nothing.
  bool concatenate (Worklist w);
  // m_C (invalid, i.e. 0, before the first concatenate).
  MortonCode getBoundary () const;

  // Moves m_C forward to `m` (a code at l_max, not before m_C) without concatenating a leaf
  // there: the caller promises no leaf in (m_C, m] will come, so fix can close every sibling
  // group up to m now (e.g. at the end of a chunk of whole cells). False (PCL_ERROR) otherwise.
  bool advanceBoundary (MortonCode m);

  // Out-of-core build. When a node X at `level` is created its subtree is complete: X is
  // handed to `sink` with its children (which writes their subtrees somewhere; it is called
  // from the fix workers, concurrently, and must not throw), then X loses its children and is flagged
  // omicron::kSpilled, so it is drawn as a leaf from its own sample. Nodes and samples below
  // `level` live in scratch arenas that releaseScratch () frees. The front receives
  // placeholders at `level` (not l_max) and no node below it. 1 <= level < l_max (< l_max − 1
  // with leaf collapse, so no leaf is at or above it); every leaf must be deeper than `level`.
  // Call before the first concatenate. Throws std::invalid_argument.
  using SpillSink = std::function<void (const Node& spilled)>;
  void setSpill (int level, SpillSink sink);
  int getSpillLevel () const { return spill_level_; }
  // Frees the scratch arenas. Only between fix passes, when L_C holds no root below the spill
  // level (after a fix with m_C at the end of a range of whole spill-level cells).
  void releaseScratch ();
  std::size_t scratchBytes () const;

  bool fixLevel (int level);
  void fix ();
  void finishInput ();
  // Runs Algorithm 3 until finishInput() has been called and the root exists.
  void runMaster ();

  bool isComplete () const;
  // Permanent root once complete (nullptr for an empty input).
  const Node* getRoot () const { return root_; }

  struct Snapshot
  {
    MortonCode boundary;
    std::vector<std::vector<CutNode>> lists;  // lists[l] = L_{C,l} in order
    const Node* root = nullptr;
    bool complete = false;
  };
  Snapshot snapshot () const;

  std::size_t memoryBytes () const;  // node and parent-point arenas (scratch included)

private:
  struct Segment
  {
    Worklist parents;
    std::vector<MortonCode> placeholders;
    std::vector<const Node*> leaves;  // grandchildren that are leaves (level l + 1)
  };
  struct Slot
  {
    omicron::BlockArena<Node> nodes{1024};
    omicron::BlockArena<PointT> points{8192};
    omicron::BlockArena<Node> scratch_nodes{1024};     // below the spill level
    omicron::BlockArena<PointT> scratch_points{8192};
  };
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
  std::unique_ptr<omicron::WorkerPool> pool_;
};

}  // namespace pcl
