#pragma once
// pcl::ObliqueCutOctree: OMiCroN's level-of-detail octree (da Silva 2018), see the class.
#include <pclx/omicron/detail/budget_plan.h>
#include <pclx/omicron/detail/morton_sorter.h>
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

/** \brief OMiCroN's level-of-detail octree: built bottom-up from a Morton-sorted stream
  * while a rendering front can be evaluated on the part already built.
  *
  * \code
  * pcl::ObliqueCutOctree<pcl::PointXYZ> octree;
  * octree.setInputCloud (cloud);
  * octree.setMaxDepth (7);
  * octree.startBuild ();                       // or build () to block
  * while (!octree.isFinished ())
  *   octree.evaluate (camera, items);          // draw items[i].points with items[i].splat_radius
  * octree.wait ();
  * \endcode
  *
  * Threads as in the thesis' Fig. 3.6: a sorter thread (partial Morton sort in chunks,
  * Algorithm 1), the fix master (Algorithm 3) with worker threads, and whichever thread
  * calls evaluate () as the front tracker (Algorithm 5).
  *
  * The kept points are reordered once into a sorted array; leaves are ranges of it and
  * parents hold their own sampled points. NaN/Inf points are dropped and counted.
  *
  * With a memory budget (setMemoryBudget ()) the build is out of core: the input is read in
  * blocks (bounds, counts per cell, then a scatter of whole cells into chunk regions of a
  * file on disk), chunks are sorted and fixed one at a time in Morton order, and when a node
  * at the spill level is created its descendants are written to the Potree folder and
  * dropped. The result (node codes, levels and points) equals the in-memory build's.
  *
  * Errors follow PCL's convention: a setter given a bad value (or called while a build
  * runs) prints PCL_ERROR and keeps its previous value; build () / wait () return false with
  * PCL_ERROR and getLastError () says why. No exception leaves this class.
  *
  * \note V. da Silva, 2018, "Concomitant Hierarchy Construction and Rendering of Large Point
  * Clouds" (OMiCroN: Oblique Multipass Hierarchy Creation while Navigating), DSc thesis,
  * UFRJ/COPPE. The optional Potree output follows M. Schütz, 2016, "Potree: Rendering Large
  * Point Clouds in Web Browsers", MSc thesis, TU Wien.
  * \ingroup omicron
  */
template <typename PointT>
class ObliqueCutOctree
{
public:
  using PointCloud = pcl::PointCloud<PointT>;          ///< The input cloud type.
  using PointCloudConstPtr = typename PointCloud::ConstPtr;  ///< Shared pointer to the input.
  using Node = pclx::omicron::detail::Node<PointT>;                  ///< A node of the built hierarchy.
  using Front = ObliqueCutFront<PointT>;               ///< The rendering front.
  using Camera = typename Front::Camera;               ///< The camera evaluate () takes.
  using Item = typename Front::Item;                   ///< What evaluate () returns to draw.

  /** \brief What the last build did (counts, times, memory). */
  struct Statistics
  {
    std::size_t input_points = 0;      ///< points in the input, dropped ones included
    std::size_t kept_points = 0;       ///< points in the hierarchy
    std::size_t dropped_invalid = 0;   ///< dropped for a NaN / Inf coordinate
    std::size_t dropped_outside = 0;   ///< dropped outside a user root cube
    std::size_t chunks = 0;            ///< sort chunks (budgeted: chunk file regions)
    std::vector<std::size_t> nodes_per_level;   ///< nodes per level (spilled ones included)
    std::vector<std::size_t> points_per_level;  ///< points held by the nodes of each level
    std::vector<std::size_t> leaves_per_level;  ///< leaves per level
    double seconds_read = 0;            ///< bounds + bucket passes (the whole input is read)
    double seconds_to_first_chunk = 0;  ///< ... and the first chunk sorted
    double seconds_to_first_front = 0;  ///< first leaf handed to the front (something to draw)
    double seconds_total = 0;           ///< the whole build
    std::size_t sorted_bytes = 0;       ///< the sorted point array
    std::size_t hierarchy_bytes = 0;    ///< node and parent-point arenas
    std::size_t memory_budget = 0;      ///< the budget the build ran with (0: none)
    /** The peak sum of the build's large buffers (the caller's input cloud not counted).
      * In memory: sorted array + sort buffers + arenas; budgeted: see pclx::omicron::detail::MemoryLedger. */
    std::size_t accounted_peak_bytes = 0;
    std::size_t planned_peak_bytes = 0; ///< budgeted: the planner's bound (<= the budget)
    int spill_level = -1;   ///< budgeted: nodes below it were written out and dropped
    int count_level = -1;   ///< budgeted: level of the count grid
    std::size_t spilled_nodes = 0;      ///< budgeted: nodes written out and dropped
    std::size_t spilled_points = 0;     ///< budgeted: points of those nodes
    double seconds_chunks = 0;  ///< budgeted: reading, counting and writing the chunk file
  };

  /** \brief Empty octree with the default parameters. */
  ObliqueCutOctree () = default;
  /** \brief Waits for a running build and removes a temporary output folder. */
  ~ObliqueCutOctree ();
  ObliqueCutOctree (const ObliqueCutOctree&) = delete;
  ObliqueCutOctree& operator= (const ObliqueCutOctree&) = delete;

  /** \brief Set the input cloud (replaces an input file).
    * \param[in] cloud the points; kept (shared) until the next build ends
    */
  void
  setInputCloud (const PointCloudConstPtr& cloud)
  {
    if (checkIdle ("setInputCloud"))
    {
      input_ = cloud;
      input_file_.clear ();
    }
  }
  /** \brief Set an input file (replaces an input cloud). PCD/PLY/XYZ, read through
    * pcl::PointStreamReader. Without a memory budget it is read twice in blocks on a reader
    * thread: into the sorted array in file order (bounds and bucket counts), then scattered
    * from the second read into its buckets, so the points are held once; the result equals
    * the build from the loaded cloud.
    * \param[in] path the file
    */
  void
  setInputFile (const std::string& path)
  {
    if (checkIdle ("setInputFile"))
    {
      input_file_ = path;
      input_.reset ();
    }
  }
  /** \brief The input file (empty when the input is a cloud).
    * \return the input file (empty when the input is a cloud) */
  const std::string& getInputFile () const { return input_file_; }
  /** \brief Set the memory budget of the build's own buffers. With a budget the build is
    * out of core and fails, before allocating, when the budget cannot hold one chunk; the
    * peak of the accounted buffers stays within it (Statistics::accounted_peak_bytes).
    * \param[in] bytes the budget; 0 (default) is unlimited, the in-memory build
    */
  void
  setMemoryBudget (std::size_t bytes)
  {
    if (checkIdle ("setMemoryBudget"))
      budget_ = bytes;
  }
  /** \brief The memory budget in bytes (0: unlimited).
    * \return the memory budget in bytes (0: unlimited) */
  std::size_t getMemoryBudget () const { return budget_; }
  /** \brief Set the folder of a budgeted build's Potree output (metadata.json,
    * hierarchy.bin, octree.bin; the chunk file lives there during the build).
    * \param[in] directory the folder; empty (default): a fresh folder under the system temp
    * folder, removed with the octree or by the next build
    */
  void
  setOutputDirectory (const std::string& directory)
  {
    if (checkIdle ("setOutputDirectory"))
      output_dir_ = directory;
  }
  /** \brief The folder the last budgeted build wrote (empty for in-memory builds).
    * \return the folder the last budgeted build wrote (empty for in-memory builds) */
  std::string getOutputDirectory () const { std::lock_guard<std::mutex> g (cube_mutex_); return used_output_dir_; }
  /** \brief Spill level of the running or last budgeted build; front items never come from
    * deeper nodes.
    * \return the level, or -1 (none, or not chosen yet)
    */
  int getSpillLevel () const { return spill_level_; }
  /** \brief Why the last build failed (empty when it succeeded).
    * \return why the last build failed (empty when it succeeded) */
  std::string getLastError () const { std::lock_guard<std::mutex> g (cube_mutex_); return last_error_; }

  /** \brief Set the maximum depth l_max of the octree (the leaf level).
    * \param[in] depth 1..21; default 7, the thesis' (out of range: PCL_ERROR, value kept)
    */
  void setMaxDepth (int depth);
  /** \brief The maximum depth (leaf level).
    * \return the maximum depth (leaf level) */
  int getMaxDepth () const { return params_.max_depth; }
  /** \brief Set how many points a parent keeps per child point (Algorithm 4's sample).
    * \param[in] ratio in (0, 1]; default 0.2 (out of range: PCL_ERROR, value kept)
    */
  void setParentPointRatio (float ratio);
  /** \brief The parent point ratio (points a parent keeps per child point).
    * \return the parent point ratio (points a parent keeps per child point) */
  float getParentPointRatio () const { return params_.parent_ratio; }
  /** \brief Fold an only child at the deepest level into its parent.
    * \param[in] on default true
    */
  void
  setLeafCollapse (bool on)
  {
    if (checkIdle ("setLeafCollapse"))
      params_.leaf_collapse = on;
  }
  /** \brief Whether an only child at the deepest level is folded into its parent (default on).
    * \return whether an only child at the deepest level is folded into its parent (default on) */
  bool getLeafCollapse () const { return params_.leaf_collapse; }
  /** \brief Set the nodes per worklist of the cut.
    * \param[in] nodes >= 1; default 32 (thesis Table 4.2)
    */
  void setWorklistSize (std::size_t nodes);
  /** \brief Nodes per worklist of the cut.
    * \return nodes per worklist of the cut */
  std::size_t getWorklistSize () const { return params_.worklist_size; }
  /** \brief Set the number of chunks of the partial Morton sort (Algorithm 1).
    * \param[in] chunks >= 1; default 16
    */
  void setSortChunks (std::size_t chunks);
  /** \brief Chunks of the partial Morton sort.
    * \return chunks of the partial Morton sort */
  std::size_t getSortChunks () const { return chunks_; }
  /** \brief Set the fix workers and read passes.
    * \param[in] threads >= 1; default one per core
    */
  void setThreads (int threads);
  /** \brief Fix workers and read passes (default: one per core).
    * \return fix workers and read passes (default: one per core) */
  int getThreads () const { return params_.threads; }
  /** \brief Use a fixed root cube; points outside it are dropped and counted.
    * \param[in] origin the cube's min corner (finite)
    * \param[in] edge the cube's edge (finite, > 0)
    */
  void setRootCube (const Eigen::Vector3d& origin, double edge);
  /** \brief Back to the root cube of the input's bounds (the default). */
  void clearRootCube ();
  /** \brief Set the leaf splat radius.
    * \param[in] radius in world units; <= 0 (default): the leaf cell edge over the square
    * root of the mean points per occupied leaf of the first chunk, about the point spacing
    * on a surface
    */
  void
  setLeafSplatRadius (float radius)
  {
    if (checkIdle ("setLeafSplatRadius"))
      leaf_radius_ = radius;
  }
  /** \brief Set the splat radius multipliers applied going up the levels.
    * \param[in] m m[0] from l_max to l_max - 1, m[1] to l_max - 2, ..., the last one for every
    * shallower level; each finite and > 0. Default from the thesis' Table 4.5 (midpoints of
    * its ranges).
    */
  void setSplatMultipliers (const std::vector<float>& m);
  /** \brief The splat radius multipliers (see setSplatMultipliers ()).
    * \return the splat radius multipliers (see setSplatMultipliers ()) */
  const std::vector<float>& getSplatMultipliers () const { return multipliers_; }
  /** \brief Set the front's projection threshold (ObliqueCutFront::setProjectionThreshold).
    * \param[in] ndc the projected box diagonal in NDC
    */
  void setProjectionThreshold (float ndc) { front_.setProjectionThreshold (ndc); }
  /** \brief Send the cut's finished nodes to the front while the hierarchy is built, so it can
    * be drawn during construction (OMiCroN's point).
    * \param[in] on default true. Off is for builds nobody watches (a Potree export, a batch
    * job): the front then holds nothing during the build instead of an entry per leaf (a few
    * bytes per point on a cloud that fills every deepest cell); evaluate () draws nothing until
    * the build ends, then starts from the root and branches one level per frame.
    */
  void
  setFrontDuringBuild (bool on)
  {
    if (checkIdle ("setFrontDuringBuild"))
      front_during_build_ = on;
  }
  /** \brief Whether the front follows the build (default on).
    * \return whether the front follows the build */
  bool getFrontDuringBuild () const { return front_during_build_; }

  /** \brief Blocking build.
    * \return false (PCL_ERROR, getLastError ()) on no input, no finite point or an I/O error
    */
  bool build ();
  /** \brief Starts the build on a thread of its own; evaluate () may be called meanwhile.
    * \return false (PCL_ERROR) when a build is already running
    */
  bool startBuild ();
  /** \brief Whether the build started last has ended.
    * \return whether the build started last has ended */
  bool isFinished () const { return finished_; }
  /** \brief Waits for the build to end.
    * \return whether it succeeded (getLastError () says why not)
    */
  bool wait ();

  /** \brief One front evaluation (Algorithm 5); usable during and after the build.
    * \param[in] camera the view
    * \param[out] items what to draw this frame
    */
  void evaluate (const Camera& camera, std::vector<Item>& items) { front_.evaluate (camera, items); }
  /** \brief The rendering front.
    * \return the rendering front */
  Front& getFront () { return front_; }

  /** \brief The root once the build has finished (nullptr before, or for an empty input).
    * \return the root once the build has finished (nullptr before, or for an empty input) */
  const Node* getRoot () const { return finished_ && cut_ ? cut_->getRoot () : nullptr; }
  /** \brief The kept points in Morton order (the leaves are ranges of it; in-memory builds).
    * \return the kept points in Morton order (the leaves are ranges of it; in-memory builds) */
  const typename PointCloud::VectorType& getSortedPoints () const { return sorted_; }
  /** \brief Min corner of the root cube of the current build (known once the input has
    * been read; safe to call from the front thread during the build).
    * \return the corner */
  Eigen::Vector3d getRootOrigin () const { std::lock_guard<std::mutex> g (cube_mutex_); return root_origin_; }
  /** \brief Edge of the root cube of the current build.
    * \return edge of the root cube of the current build */
  double getRootEdge () const { std::lock_guard<std::mutex> g (cube_mutex_); return root_edge_; }
  /** \brief Axis-aligned bounds of the finite input points of the current build (safe to
    * call from the front thread during the build).
    * \param[out] lo the minimum corner
    * \param[out] hi the maximum corner
    * \return false until the build has read them, and with setRootCube () (the bounds are not
    * measured then: the root cube is getRootOrigin () and getRootEdge ())
    */
  bool getInputBounds (Eigen::Vector3f& lo, Eigen::Vector3f& hi) const;
  /** \brief How far the current build is: the share of the kept points whose leaves the
    * hierarchy has received (da Silva 2018, Algorithm 1's concatenation); safe to call from
    * the front thread during the build.
    * \return in [0, 1]: 0 until the input has been counted, 1 once every kept point is in
    * a leaf of the hierarchy (a successful build ends there)
    */
  double getProgress () const;
  /** \brief Splat radius per level (index = level) of the current build.
    * \return splat radius per level (index = level) of the current build */
  std::vector<float> getSplatRadii () const { return radii_; }
  /** \brief Statistics of the last build.
    * \return them; empty (PCL_ERROR) while a build runs
    */
  Statistics getStatistics () const;
  /** \brief The oblique cut, for inspection (nullptr before a build).
    * \return the oblique cut, for inspection (nullptr before a build) */
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
  bool runInMemory (std::chrono::steady_clock::time_point t0);
  // The budgeted build and its stages (impl/oblique_cut_octree_budget.hpp), which share the
  // state of one build through Budgeted.
  struct Budgeted;
  bool runBudgeted (std::chrono::steady_clock::time_point t0);
  bool planSizes (Budgeted& b);
  bool prepareOutput (Budgeted& b);
  bool readBounds (Budgeted& b);
  bool countAndPlan (Budgeted& b);
  bool scatterChunks (Budgeted& b);
  bool openPotreeOutput (Budgeted& b);
  bool fixChunks (Budgeted& b);
  bool writeRetainedTree (Budgeted& b);
  void collectBudgetedStatistics (Budgeted& b);
  bool failBudgeted (Budgeted& b, const std::string& why);
  void startCut (const std::vector<MortonCode>& first_chunk_codes, const Eigen::Vector3d& origin, double edge);
  std::size_t concatenateLeaves (const std::vector<MortonCode>& codes, PointT* first);
  // Reads the whole file in blocks on a reader thread; on_block (const PointCloud&) runs
  // here, overlapped with the parsing of the next block. Returns false on a read error
  // (the reader's getLastError ()); rethrows what on_block throws.
  template <typename F> bool readFileBlocks (PointStreamReader& reader, F&& on_block);
  // The file path of the in-memory build: the file read into sorted_ in file order (bounds
  // folded in), the sorter's buckets counted from it, the file read again and scattered into
  // them (so the points are held once). Returns false (fail () called) on an error.
  bool readFileSorted (pclx::omicron::detail::MortonSorter<PointT>& sorter, std::size_t& kept);
  bool fail (const std::string& why);
  void removeTempOutput ();
  // True when no build runs; else PCL_ERROR naming `method` (the call is then ignored).
  bool checkIdle (const char* method) const;

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
  // The input's bounds once read (under cube_mutex_), and the build's progress (getProgress ()).
  Eigen::Vector3f input_lo_ = Eigen::Vector3f::Zero (), input_hi_ = Eigen::Vector3f::Zero ();
  bool input_bounds_ = false;
  std::atomic<std::size_t> progress_points_{0}, progress_total_{0};
  // Records the input's bounds (not with a user root cube) and the points to expect.
  void setInputSummary (const Eigen::Array3f& lo, const Eigen::Array3f& hi, std::size_t kept);
  Eigen::Vector3d root_origin_ = Eigen::Vector3d::Zero ();
  double root_edge_ = 1.0;
  std::vector<float> multipliers_{4.2f, 2.4f, 2.2f, 2.2f, 2.0f};
  std::vector<float> radii_;

  typename PointCloud::VectorType sorted_;
  std::unique_ptr<ObliqueCut<PointT>> cut_;
  Front front_;
  bool front_during_build_ = true;
  Statistics stats_;
  std::thread thread_;
  std::atomic<bool> running_{false}, finished_{false};
  bool result_ = false;
};

}  // namespace pcl

#ifdef PCL_NO_PRECOMPILE
#include <pclx/omicron/impl/oblique_cut_octree.hpp>
#endif
