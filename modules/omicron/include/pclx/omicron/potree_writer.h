#pragma once
// pcl::PotreeWriter: an OMiCroN hierarchy as a Potree 2.0 folder, see the class.
#include <pclx/omicron/detail/octree_node.h>
#include <pclx/omicron/detail/potree_format.h>

#include <pcl/point_cloud.h>

#include <array>
#include <cstddef>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace pclx {
namespace omicron {
namespace detail {
class WorkerPool;
}  // namespace detail
}  // namespace omicron
}  // namespace pclx

namespace pcl {

template <typename PointT>
class ObliqueCutOctree;

/** \brief Writes an OMiCroN hierarchy in the Potree 2.0 format: metadata.json,
  * hierarchy.bin and octree.bin in one folder, readable by potree's 2.0 loader.
  *
  * \code
  * pcl::PotreeWriter<pcl::PointXYZRGB> writer;
  * if (!writer.write (octree, "out/cloud"))     // after octree.build ()
  *   std::cerr << writer.getLastError ();
  * \endcode
  *
  * or streamed, subtree by subtree, while the hierarchy is still being built (octree.bin is
  * appended; hierarchy.bin and metadata.json are written by close ()): open (), then
  * appendSubtree () ..., then close ().
  *
  * Positions are stored as int32 (x - offset) / scale with offset = the root cube's min
  * corner; colour (PointT with rgb) as uint16 x 3 (8-bit value x 257, LAS style); intensity
  * (PointT with intensity) as float, PCL's type, with its range in the metadata, so no value
  * is rounded (Potree's loaders decode an attribute of any declared type).
  *
  * Potree's LOD is additive: a node is drawn together with its ancestors, so each input point
  * is stored exactly once, in the coarsest node that samples it. A node at level l keeps one
  * point per cell of a grid of 128 · 2^l cells per root edge (the first point, in Morton
  * order, that no coarser node took), the spacing PotreeConverter 2's indexer gives its inner
  * nodes; OMiCroN's own parent samples, sized by the parent ratio for its front, are not
  * written. A node is never empty when its subtree stores a point (its grid took the first
  * point of that point's cell); subtrees that store nothing are dropped.
  *
  * Node size: a subtree of at most getLeafPointLimit () points is written as one leaf holding
  * all of them that no coarser node took, as PotreeConverter sizes its nodes. Potree loads a node at a
  * time, so OMiCroN's deep leaves of a few points each would otherwise make a request each.
  *
  * Errors (unwritable folder, failed write, inconsistent hierarchy) make the call return
  * false with PCL_ERROR; getLastError () says why. No exception leaves this class.
  *
  * \note M. Schütz, 2016, "Potree: Rendering Large Point Clouds in Web Browsers", MSc thesis,
  * TU Wien (the format: PotreeConverter 2.x). The hierarchy: V. da Silva, 2018, "Concomitant
  * Hierarchy Construction and Rendering of Large Point Clouds", DSc thesis, UFRJ/COPPE.
  * \ingroup omicron
  */
template <typename PointT>
class PotreeWriter
{
public:
  using Node = pclx::omicron::detail::Node<PointT>;  ///< A node of the hierarchy to write.

  /** \brief A writer with the default settings; colour is written when PointT has it. */
  PotreeWriter ();
  /** \brief Closes the files of an unfinished write (the folder is left incomplete). */
  ~PotreeWriter ();
  PotreeWriter (const PotreeWriter&) = delete;
  PotreeWriter& operator= (const PotreeWriter&) = delete;

  /** \brief Set the metadata "name".
    * \param[in] name the name */
  void setName (const std::string& name) { meta_.name = name; }
  /** \brief Set the metadata "projection" (a proj4 string or empty).
    * \param[in] projection the projection */
  void setProjection (const std::string& projection) { meta_.projection = projection; }
  /** \brief Set the position quantum.
    * \param[in] scale world units per int32 step; <= 0 (default): the largest power of ten
    * that keeps the root cube within 2^30 steps
    */
  void setScale (double scale) { scale_ = scale; }
  /** \brief Set the hierarchy levels per hierarchy.bin chunk (PotreeConverter uses 4).
    * \param[in] step in [1, 21] (out of range: PCL_ERROR, value kept)
    */
  void setHierarchyStepSize (int step);
  /** \brief Write the rgb attribute (never for a PointT without colour).
    * \param[in] on default: when PointT has colour */
  void setWriteColors (bool on) { colors_ = on; }
  /** \brief Write the intensity attribute (never for a PointT without intensity).
    * \param[in] on default: when PointT has intensity */
  void setWriteIntensity (bool on) { intensity_ = on; }
  /** \brief Set the node size: a subtree of at most this many points is written as one leaf
    * holding all of them that no coarser node took, as PotreeConverter sizes its nodes.
    * \param[in] points the limit; 0 writes every node of the octree
    */
  void setLeafPointLimit (std::uint32_t points) { leaf_limit_ = points; }
  /** \brief The node size limit (default kDefaultLeafPointLimit).
    * \return the node size limit (default kDefaultLeafPointLimit) */
  std::uint32_t getLeafPointLimit () const { return leaf_limit_; }
  /** \brief Set the threads appendSubtree () and appendSpilled () sample the levels and encode
    * the small records on (write () uses the octree's). The files do not depend on it.
    * \param[in] threads the thread count, the caller included: >= 1, and set while no write is
    * open (else PCL_ERROR and the count is kept)
    */
  void setThreads (int threads);
  /** \brief The threads of appendSubtree () and appendSpilled () (default 1).
    * \return the thread count */
  int getThreads () const;
  /** \brief The most points appendSubtree () and appendSpilled () hold encoded at once when
    * they encode small records in parallel: a piece (kPiecePoints) per thread.
    * \return getThreads () · kPiecePoints */
  std::size_t getEncodeWindowPoints () const;
  /** \brief PotreeConverter's nodes hold up to about 20k points. */
  static constexpr std::uint32_t kDefaultLeafPointLimit = 20000;
  /** \brief Points per piece when a record, or the pending file of a budgeted build, is
    * written or read back in pieces: what bounds those buffers. */
  static constexpr std::size_t kPiecePoints = std::size_t (1) << 14;

  /** \brief Write a built (in-memory) octree to a folder.
    * \param[in] octree the octree, after a successful build ()
    * \param[in] directory the folder (created if needed)
    * \note The points are encoded on the octree's getThreads () threads; the files are the
    * same for any thread count.
    * \return false (PCL_ERROR, getLastError ()) when the octree is not built, was built with
    * a memory budget (it already wrote its folder), or a file cannot be written
    */
  bool write (const ObliqueCutOctree<PointT>& octree, const std::string& directory);

  /** \brief Start a streamed write: creates the folder and octree.bin.
    * \param[in] directory the folder
    * \param[in] origin the root cube's min corner
    * \param[in] edge the root cube's edge (> 0)
    * \return false (PCL_ERROR, getLastError ()) when already open or the folder cannot be written
    */
  bool open (const std::string& directory, const Eigen::Vector3d& origin, double edge);
  /** \brief Append a subtree: one leaf when it holds at most getLeafPointLimit () points, else
    * its root (the points its grid samples) and each child's subtree the same way.
    * \param[in] node the subtree's root; nodes flagged pclx::omicron::detail::kSpilled stand for what
    * appendSpilled () received
    * \return false (PCL_ERROR, getLastError ()) on a failed write or an inconsistent hierarchy
    */
  bool appendSubtree (const Node& node);
  /** \brief Append the subtree of a node an out-of-core build is about to drop.
    * \param[in] node a node with its complete children
    * \return false (PCL_ERROR, getLastError ()) on a failed write
    * \note Writes the subtree's nodes and keeps aside (octree.pending.bin) the points that
    * coarser levels sample, until appendSubtree () reaches `node`; when the whole subtree fits
    * one leaf it keeps all of it aside, since an ancestor may take it into a larger leaf.
    * close () fails if a kept subtree was never reached.
    */
  bool appendSpilled (const Node& node);
  /** \brief Append exactly the given points as the node `code` (hierarchies of another origin).
    * \param[in] code the node
    * \param[in] points the points
    * \param[in] n how many
    * \return false (PCL_ERROR, getLastError ()) when not open or the write fails
    */
  bool appendNode (MortonCode code, const PointT* points, std::uint32_t n);
  /** \brief Finish a streamed write: writes hierarchy.bin and metadata.json.
    * \param[in] points the metadata point count (the input points the hierarchy holds)
    * \return false (PCL_ERROR, getLastError ()) when not open, a write failed or a subtree
    * appendSpilled () kept aside was never reached
    */
  bool close (std::uint64_t points);
  /** \brief Reserve the node records (32 B each) so they never reallocate (memory budgets).
    * \param[in] nodes how many */
  void reserveNodes (std::size_t nodes);
  /** \brief Whether a streamed write is open.
    * \return whether a streamed write is open */
  bool isOpen () const { return file_ != nullptr; }
  /** \brief Bytes appended to octree.bin so far.
    * \return bytes appended to octree.bin so far */
  std::uint64_t bytesWritten () const;
  /** \brief Node records written so far.
    * \return node records written so far */
  std::size_t nodesWritten () const;
  /** \brief The metadata of the current or last write.
    * \return the metadata of the current or last write */
  const pclx::omicron::detail::potree::Metadata& getMetadata () const { return meta_; }
  /** \brief Why the last failed call failed (empty when none did).
    * \return why the last failed call failed (empty when none did) */
  std::string getLastError () const;

private:
  // Encoded points with their bounds.
  struct Encoded
  {
    std::vector<std::uint8_t> bytes;
    std::uint64_t points = 0;
    Eigen::Vector3d lo = Eigen::Vector3d::Constant (std::numeric_limits<double>::max ());
    Eigen::Vector3d hi = Eigen::Vector3d::Constant (-std::numeric_limits<double>::max ());
    float intensity_lo = std::numeric_limits<float>::max (), intensity_hi = -std::numeric_limits<float>::max ();
  };
  // A subtree appendSpilled () received, and where its points wait in the pending file.
  struct Spilled
  {
    std::uint64_t points = 0;  // in the whole subtree
    bool whole = false;        // all of it kept aside (it fits one leaf): its points, then their levels
    bool written = false;      // read back by appendSubtree ()
    std::uint64_t offset = 0;  // in the pending file
    // Not whole: the points each level above the node samples from it, level by level.
    std::array<std::uint64_t, MortonCode::kMaxDepth + 1> level_points{};
  };
  // One record of a subtree's write: a node with the points its level samples, or a whole
  // subtree as one leaf with every point no coarser record took.
  struct WriteTask
  {
    const Node* node;
    bool subtree;
    std::uint64_t points;  // in the node's subtree
    std::uint64_t first;   // the subtree's first in-memory point in the depth-first order
  };
  // A run of points with their levels (none: all of them belong to the record).
  struct Run
  {
    const PointT* points;
    const std::uint8_t* levels;
    std::size_t n;
  };
  // Points in a subtree: all (the leaves', and what spilled nodes stand for), and those of
  // its in-memory leaves.
  struct PointCounts
  {
    std::uint64_t total = 0, in_memory = 0;
  };
  PointCounts countPoints (const Node& node) const;
  // The records of the subtree of `node`, in octree.bin's order: a subtree of at most the
  // leaf limit is one record, else the node and then each child's subtree the same way;
  // empty subtrees and the nodes appendSpilled () wrote out are left out.
  std::vector<WriteTask> records (const Node& node) const;
  // records (), appending to `tasks`; `first` counts the in-memory points before `node` in
  // depth-first order.
  void addRecords (const Node& node, std::uint64_t& first, std::vector<WriteTask>& tasks) const;
  // The level (LevelSampler) of each in-memory point of the records' subtree, in depth-first
  // order, capped at the level of the record that holds the point whole; with no records,
  // at `cap`.
  void computeLevels (const Node& root, const std::vector<WriteTask>& tasks, int cap,
                      pclx::omicron::detail::WorkerPool& pool, std::vector<std::uint8_t>& levels) const;
  // Calls f (const Run&) for the task's points in depth-first order: its in-memory leaves
  // and the points spilled subtrees kept aside for it.
  template <typename F> void forEachRun (const WriteTask& task, const std::vector<std::uint8_t>& levels, F&& f);
  // Appends the points of `run` the task keeps.
  void encodeRun (const WriteTask& task, const Run& run, Encoded& out) const;
  // Appends all of the task's points.
  void encodeTask (const WriteTask& task, const std::vector<std::uint8_t>& levels, Encoded& out);
  // Encodes tasks [first, last) on the pool's threads into `encoded` and records them in order.
  void encodeAndRecord (const std::vector<WriteTask>& tasks, std::size_t first, std::size_t last,
                        const std::vector<std::uint8_t>& levels, pclx::omicron::detail::WorkerPool& pool,
                        std::vector<Encoded>& encoded);
  // Writes one task in pieces (bounded buffers, for budgeted builds).
  void writeTaskStreamed (const WriteTask& task, const std::vector<std::uint8_t>& levels);
  // Writes the tasks in order with buffers of at most a piece per thread: the small whole
  // subtrees encoded in parallel, the others one at a time in pieces.
  void writeTasksStreamed (const std::vector<WriteTask>& tasks, const std::vector<std::uint8_t>& levels);
  // Encodes the tasks on the pool's threads, a window of them at a time, and records each
  // window in order (the same octree.bin as appendSubtree ()).
  void writeTasks (const std::vector<WriteTask>& tasks, const std::vector<std::uint8_t>& levels,
                   pclx::omicron::detail::WorkerPool& pool);
  // Keeps the points of the spilled subtree `node` that coarser records take, or all of it.
  void keepAside (const Node& node, const std::vector<std::uint8_t>& levels, bool whole, Spilled& sp);
  // Reads `n` items of `size` bytes at `offset` of the pending file.
  void readPending (std::uint64_t offset, std::size_t size, std::size_t n, void* out);
  void record (MortonCode code, const Encoded& data);
  // Widens the bounds and the intensity range of what was written by those of `data`.
  void addRange (const Encoded& data);
  void closePending ();
  void abandon ();
  // The operations behind the public ones; they throw on errors, which guarded () turns
  // into false + PCL_ERROR at the public boundary.
  void openImpl (const std::string& directory, const Eigen::Vector3d& origin, double edge);
  void appendNodeImpl (MortonCode code, const PointT* points, std::uint32_t n);
  void appendSubtreeImpl (const Node& node);
  void appendSpilledImpl (const Node& node);
  void closeImpl (std::uint64_t points);
  template <typename F> bool guarded (const char* method, F&& f);
  bool fail (const char* method, const std::string& why);

  pclx::omicron::detail::potree::Metadata meta_;
  double scale_ = 0;
  std::uint32_t leaf_limit_ = kDefaultLeafPointLimit;
  std::unique_ptr<pclx::omicron::detail::WorkerPool> pool_;  // appendSubtree () and appendSpilled ()
  bool colors_, intensity_;
  std::string directory_;
  std::FILE* file_ = nullptr;
  std::FILE* pending_ = nullptr;  // octree.pending.bin: points appendSpilled () kept aside
  std::uint64_t pending_bytes_ = 0;
  std::map<std::uint64_t, Spilled> spilled_;  // by MortonCode::bits ()
  mutable std::mutex mutex_;
  std::mutex record_mutex_;  // held while a record's bytes are appended (before mutex_)
  std::uint64_t offset_ = 0;
  std::vector<pclx::omicron::detail::potree::NodeRecord> records_;
  Eigen::Vector3d lo_, hi_;
  float intensity_lo_ = 0, intensity_hi_ = 0;
  mutable std::mutex error_mutex_;
  std::string last_error_;
};

}  // namespace pcl

#ifdef PCL_NO_PRECOMPILE
#include <pclx/omicron/impl/potree_writer.hpp>
#endif
