#pragma once
// pcl::PotreeWriter: an OMiCroN hierarchy as a Potree 2.0 folder, see the class.
#include <pclx/omicron/detail/octree_node.h>
#include <pclx/omicron/detail/potree_format.h>

#include <pcl/point_cloud.h>

#include <cstdio>
#include <limits>
#include <map>
#include <mutex>
#include <string>
#include <vector>

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
  * corner; colour (PointT with rgb) as uint16 x 3 (8-bit value x 257, LAS style).
  *
  * Potree's LOD is additive: a node is drawn together with its ancestors. OMiCroN's parents
  * hold copies of points sampled from their children, so a node is written without the
  * points its parent took (PotreeConverter 2 likewise moves sampled points up): every input
  * point is stored exactly once. Inner nodes left empty are written with no points, as
  * PotreeConverter does; subtrees left empty are dropped.
  *
  * Node size: a subtree that stores at most getLeafPointLimit () points is written as one
  * leaf holding all of them, as PotreeConverter sizes its nodes. Potree loads a node at a
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
  /** \brief Write the rgb attribute.
    * \param[in] on default: when PointT has colour */
  void setWriteColors (bool on) { colors_ = on; }
  /** \brief Set the parent point ratio of the octree whose nodes are appended, which tells
    * which points each parent took from its children (the writer leaves them out).
    * \param[in] ratio the octree's ratio, in (0, 1]; write () takes it from the octree.
    * Default 0.2, the octree's default (out of range: PCL_ERROR, value kept)
    */
  void setParentPointRatio (float ratio);
  /** \brief The parent point ratio the appended nodes are read with.
    * \return the parent point ratio the appended nodes are read with */
  float getParentPointRatio () const { return parent_ratio_; }
  /** \brief Set the node size: a subtree storing at most this many points is written as one
    * leaf holding all of them, as PotreeConverter sizes its nodes.
    * \param[in] points the limit; 0 writes every node of the octree
    */
  void setLeafPointLimit (std::uint32_t points) { leaf_limit_ = points; }
  /** \brief The node size limit (default kDefaultLeafPointLimit).
    * \return the node size limit (default kDefaultLeafPointLimit) */
  std::uint32_t getLeafPointLimit () const { return leaf_limit_; }
  /** \brief PotreeConverter's nodes hold up to about 20k points. */
  static constexpr std::uint32_t kDefaultLeafPointLimit = 20000;

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
  /** \brief Append one node of an octree: its points minus those its parent took (all of them
    * at the root). May be called from several threads.
    * \param[in] node the node (its children are not written)
    * \return false (PCL_ERROR, getLastError ()) when not open or the write fails
    */
  bool appendNode (const Node& node);
  /** \brief Append a subtree: one leaf when it stores at most getLeafPointLimit () points, else
    * its root as appendNode (const Node&) and each child's subtree the same way.
    * \param[in] node the subtree's root; nodes flagged pclx::omicron::detail::kSpilled stand for what
    * appendSpilled () received
    * \return false (PCL_ERROR, getLastError ()) on a failed write or an inconsistent hierarchy
    */
  bool appendSubtree (const Node& node);
  /** \brief Append the subtree of a node an out-of-core build is about to drop.
    * \param[in] node a node with its complete children
    * \return false (PCL_ERROR, getLastError ()) on a failed write
    * \note Writes the children's subtrees, or, when the whole subtree fits one leaf, keeps it
    * aside (octree.pending.bin) until appendSubtree () reaches `node`, since an ancestor may take
    * it into a larger leaf. close () fails if a kept subtree was never reached.
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
  };
  // A subtree appendSpilled () kept aside (in the pending file) or wrote out.
  struct Spilled
  {
    std::uint64_t points = 0;  // stored by the whole subtree
    bool pending = false, written = false;
    std::uint64_t offset = 0;  // in the pending file
    Eigen::Vector3d lo = Eigen::Vector3d::Zero (), hi = Eigen::Vector3d::Zero ();
  };
  std::uint32_t storedPoints (const Node& node) const;
  std::uint64_t subtreePoints (const Node& node) const;
  // Appends points [0, n) except the `taken` picks of pclx::omicron::detail::parentSampleIndex.
  void encode (const PointT* points, std::uint32_t n, std::uint32_t taken, Encoded& out) const;
  // Appends the points `node` stores (all but those its parent took).
  void encodeNode (const Node& node, Encoded& out) const;
  // Appends the stored points of the subtree in depth-first order.
  void encodeSubtree (const Node& node, Encoded& out);
  void record (MortonCode code, const Encoded& data);
  void closePending ();
  void abandon ();
  // The operations behind the public ones; they throw on errors, which guarded () turns
  // into false + PCL_ERROR at the public boundary.
  void openImpl (const std::string& directory, const Eigen::Vector3d& origin, double edge);
  void appendNodeImpl (const Node& node);
  void appendNodeImpl (MortonCode code, const PointT* points, std::uint32_t n);
  void appendSubtreeImpl (const Node& node);
  void appendSpilledImpl (const Node& node);
  void closeImpl (std::uint64_t points);
  // One record of a subtree's write: a node alone, or a whole subtree as one leaf.
  struct WriteTask
  {
    const Node* node;
    bool subtree;
    std::uint64_t points;  // what the record stores
  };
  // Calls f (const WriteTask&) for each record of the subtree of `node`, in octree.bin's
  // order: a subtree storing at most the leaf limit is one record, else the node and then
  // each child's subtree the same way; subtrees storing nothing are left out.
  template <typename F> void forEachRecord (const Node& node, F&& f);
  // Appends the task's points to `out`.
  void encodeTask (const WriteTask& task, Encoded& out);
  // Encodes the tasks on `threads` threads, a window of them at a time, and records each
  // window in order (the same octree.bin as appendSubtree ()).
  void writeTasks (const std::vector<WriteTask>& tasks, int threads);
  template <typename F> bool guarded (const char* method, F&& f);
  bool fail (const char* method, const std::string& why);

  pclx::omicron::detail::potree::Metadata meta_;
  double scale_ = 0;
  float parent_ratio_ = 0.2f;
  std::uint32_t leaf_limit_ = kDefaultLeafPointLimit;
  bool colors_;
  std::string directory_;
  std::FILE* file_ = nullptr;
  std::FILE* pending_ = nullptr;  // octree.pending.bin: subtrees appendSpilled () kept aside
  std::uint64_t pending_bytes_ = 0;
  std::map<std::uint64_t, Spilled> spilled_;  // by MortonCode::bits ()
  mutable std::mutex mutex_;
  std::uint64_t offset_ = 0;
  std::vector<pclx::omicron::detail::potree::NodeRecord> records_;
  Eigen::Vector3d lo_, hi_;
  mutable std::mutex error_mutex_;
  std::string last_error_;
};

}  // namespace pcl

#ifdef PCL_NO_PRECOMPILE
#include <pclx/omicron/impl/potree_writer.hpp>
#endif
