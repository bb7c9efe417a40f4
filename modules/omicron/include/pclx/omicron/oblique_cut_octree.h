#pragma once
// pcl::ObliqueCutOctree: OMiCroN (Oblique Multipass Hierarchy Creation while Navigating,
// seed 001): an LOD octree built bottom-up from a Morton-sorted stream while a rendering
// front can be evaluated on the part already built.
//
//   pcl::ObliqueCutOctree<pcl::PointXYZ> octree;
//   octree.setInputCloud (cloud);
//   octree.setMaxDepth (7);
//   octree.startBuild ();                       // or build () to block
//   while (!octree.isFinished ())
//     octree.evaluate (camera, items);          // draw items[i].points with items[i].splat_radius
//   octree.wait ();
//
// Threads as in Fig. 3.6: a sorter thread (partial Morton sort in chunks, Algorithm 1, then
// concatenate), the fix master (Algorithm 3) with worker threads, and whichever thread calls
// evaluate() as the front tracker (Algorithm 5).
//
// Data: the kept points are reordered once into a sorted array; leaves are ranges of it and
// parents hold their own sampled points (arena blocks). NaN/Inf points are dropped and counted.
//
// Memory budget (setMemoryBudget): the input (a file through pcl::PointStreamReader, or the
// cloud) is read in blocks: bounds, counts per cell, then a scatter of whole cells into chunk
// regions of a file on disk, in input order. Chunks are loaded, sorted and fixed one at a
// time in Morton order; when a node at the spill level is created its descendants are
// written to the Potree folder (PotreeWriter::appendSubtree) and dropped, so the front stops
// at the spill level and draws those nodes from their own samples. The result (node codes,
// levels and points) equals the in-memory build's; the Potree folder holds all of it.
#include <pclx/omicron/budget_plan.h>
#include <pclx/omicron/morton_sorter.h>
#include <pclx/omicron/oblique_cut.h>
#include <pclx/omicron/oblique_cut_front.h>
#include <pclx/omicron/point_stream_reader.h>

#include <pcl/point_cloud.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace pcl {

template <typename PointT>
class ObliqueCutOctree
{
public:
  using PointCloud = pcl::PointCloud<PointT>;
  using PointCloudConstPtr = typename PointCloud::ConstPtr;
  using Node = omicron::Node<PointT>;
  using Front = ObliqueCutFront<PointT>;
  using Camera = typename Front::Camera;
  using Item = typename Front::Item;

  struct Statistics
  {
    std::size_t input_points = 0, kept_points = 0;
    std::size_t dropped_invalid = 0;   // NaN / Inf coordinates
    std::size_t dropped_outside = 0;   // outside a user root cube
    std::size_t chunks = 0;
    std::vector<std::size_t> nodes_per_level, points_per_level, leaves_per_level;
    double seconds_read = 0;            // bounds + bucket passes (the whole input is read)
    double seconds_to_first_chunk = 0;  // … and the first chunk sorted
    double seconds_to_first_front = 0;  // first leaf handed to the front (something to draw)
    double seconds_total = 0;
    std::size_t sorted_bytes = 0, hierarchy_bytes = 0;  // sorted array; node + parent-point arenas
    // Memory accounting (both builds; the caller's input cloud is not counted): the peak sum of
    // the build's large buffers. In-memory: sorted array + sort buffers + arenas. Budgeted:
    // see omicron::MemoryLedger; planned_peak_bytes is the planner's bound (<= the budget).
    std::size_t memory_budget = 0, accounted_peak_bytes = 0, planned_peak_bytes = 0;
    int spill_level = -1;   // budgeted: nodes below it were written out and dropped
    int count_level = -1;   // budgeted: level of the count grid
    std::size_t spilled_nodes = 0, spilled_points = 0;  // written out and dropped
    double seconds_chunks = 0;  // budgeted: reading, counting and writing the chunk file
  };

  ObliqueCutOctree () = default;
  ~ObliqueCutOctree ();
  ObliqueCutOctree (const ObliqueCutOctree&) = delete;
  ObliqueCutOctree& operator= (const ObliqueCutOctree&) = delete;

  // The input: a cloud, or a file (PCD/PLY/XYZ, read through pcl::PointStreamReader; without a
  // memory budget it is read into memory in blocks, on a reader thread, with the bounds folded
  // in as the blocks arrive, so the sorter skips its bounds pass: one pass over the bytes; the
  // result equals the build from the loaded cloud). Each replaces the other.
  void setInputCloud (const PointCloudConstPtr& cloud) { checkIdle (); input_ = cloud; input_file_.clear (); }
  void setInputFile (const std::string& path) { checkIdle (); input_file_ = path; input_.reset (); }
  const std::string& getInputFile () const { return input_file_; }
  // Memory budget in bytes for the build's own buffers (0, the default: unlimited, the
  // in-memory build). With a budget the build is out of core (see above) and fails with a
  // clear error, before allocating, when the budget cannot hold one chunk. The peak of the
  // accounted buffers stays <= the budget (Statistics::accounted_peak_bytes).
  void setMemoryBudget (std::size_t bytes) { checkIdle (); budget_ = bytes; }
  std::size_t getMemoryBudget () const { return budget_; }
  // Folder of a budgeted build's Potree output (metadata.json, hierarchy.bin, octree.bin; the
  // chunk file lives there during the build). Empty (default): a fresh folder under the
  // system temp folder, removed with the octree or by the next build.
  void setOutputDirectory (const std::string& directory) { checkIdle (); output_dir_ = directory; }
  // The folder the last budgeted build wrote (empty for in-memory builds).
  std::string getOutputDirectory () const { std::lock_guard<std::mutex> g (cube_mutex_); return used_output_dir_; }
  // Spill level of the running or last budgeted build (-1: none, or not chosen yet). Front
  // items never come from deeper nodes.
  int getSpillLevel () const { return spill_level_; }
  // Why the last build failed (empty when it succeeded).
  std::string getLastError () const { std::lock_guard<std::mutex> g (cube_mutex_); return last_error_; }
  // Setters throw std::invalid_argument on values out of range (and std::logic_error while
  // a build runs).
  void setMaxDepth (int depth);                  // 1..21, default 7 (the paper's)
  int getMaxDepth () const { return params_.max_depth; }
  void setParentPointRatio (float ratio);        // (0, 1], default 0.2
  /** \brief The parent point ratio (points a parent keeps per child point). */
  float getParentPointRatio () const { return params_.parent_ratio; }
  void setLeafCollapse (bool on) { checkIdle (); params_.leaf_collapse = on; }  // default on
  /** \brief Whether an only child at the deepest level is folded into its parent (default on). */
  bool getLeafCollapse () const { return params_.leaf_collapse; }
  void setWorklistSize (std::size_t nodes);      // >= 1, default 32
  void setSortChunks (std::size_t chunks);       // >= 1, default 16
  void setThreads (int threads);                 // fix workers and read passes, >= 1; default all cores
  /** \brief Fix workers and read passes (default: one per core). */
  int getThreads () const { return params_.threads; }
  void setRootCube (const Eigen::Vector3d& origin, double edge);
  void clearRootCube ();
  // Leaf splat radius (world units); <= 0: the leaf cell edge / sqrt (mean points per
  // occupied leaf of the first chunk), about the point spacing on a surface.
  void setLeafSplatRadius (float radius) { checkIdle (); leaf_radius_ = radius; }
  // Radius multipliers applied going up: m[0] from l_max to l_max − 1, m[1] to l_max − 2, …,
  // the last one for every shallower level. Default from Table 4.5 (range midpoints).
  void setSplatMultipliers (const std::vector<float>& m);
  void setProjectionThreshold (float ndc) { front_.setProjectionThreshold (ndc); }

  // Blocking build. Returns false (PCL_ERROR) on no input or no finite point.
  bool build ();
  // Background build; evaluate() may be called meanwhile from another thread.
  bool startBuild ();
  bool isFinished () const { return finished_; }
  bool wait ();

  // One front evaluation (Algorithm 5); usable during and after the build.
  void evaluate (const Camera& camera, std::vector<Item>& items) { front_.evaluate (camera, items); }
  Front& getFront () { return front_; }

  // After the build:
  const Node* getRoot () const { return finished_ && cut_ ? cut_->getRoot () : nullptr; }
  const typename PointCloud::VectorType& getSortedPoints () const { return sorted_; }
  // Root cube of the current build (known once the input has been read; safe to call from
  // the front thread during the build).
  Eigen::Vector3d getRootOrigin () const { std::lock_guard<std::mutex> g (cube_mutex_); return root_origin_; }
  double getRootEdge () const { std::lock_guard<std::mutex> g (cube_mutex_); return root_edge_; }
  std::vector<float> getSplatRadii () const { return radii_; }
  Statistics getStatistics () const;
  // The cut, for inspection (nullptr before a build).
  const ObliqueCut<PointT>* getCut () const { return cut_.get (); }

private:
  // The cut's parameters with the octree's defaults: leaf collapse on, one worker per core.
  static typename ObliqueCut<PointT>::Parameters
  defaultParameters ()
  {
    typename ObliqueCut<PointT>::Parameters p;
    p.leaf_collapse = true;
    p.threads = std::max (1, static_cast<int> (std::thread::hardware_concurrency ()));
    return p;
  }
  bool run ();
  bool runBudgeted (std::chrono::steady_clock::time_point t0);
  void startCut (const std::vector<MortonCode>& first_chunk_codes, const Eigen::Vector3d& origin, double edge);
  std::size_t concatenateLeaves (const std::vector<MortonCode>& codes, PointT* first);
  // Reads the whole file in blocks on a reader thread; on_block (const PointCloud&) runs
  // here, overlapped with the parsing of the next block. Rethrows the reader's errors.
  template <typename F> void readFileBlocks (PointStreamReader& reader, F&& on_block);
  bool fail (const std::string& why);
  void removeTempOutput ();
  void checkIdle () const;

  PointCloudConstPtr input_;
  std::string input_file_;
  std::size_t budget_ = 0;
  std::string output_dir_, used_output_dir_, temp_output_dir_, last_error_;
  std::atomic<int> spill_level_{-1};
  typename ObliqueCut<PointT>::Parameters params_ = defaultParameters ();
  std::size_t chunks_ = 16;
  bool user_cube_ = false;
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero ();
  double edge_ = 1.0;
  float leaf_radius_ = 0.f;
  mutable std::mutex cube_mutex_;
  Eigen::Vector3d root_origin_ = Eigen::Vector3d::Zero ();
  double root_edge_ = 1.0;
  std::vector<float> multipliers_{4.2f, 2.4f, 2.2f, 2.2f, 2.0f};
  std::vector<float> radii_;

  typename PointCloud::VectorType sorted_;
  std::unique_ptr<ObliqueCut<PointT>> cut_;
  Front front_;
  Statistics stats_;
  std::thread thread_;
  std::atomic<bool> running_{false}, finished_{false};
  bool result_ = false;
};

}  // namespace pcl

#ifdef PCL_NO_PRECOMPILE
#include <pclx/omicron/impl/oblique_cut_octree.hpp>
#endif
