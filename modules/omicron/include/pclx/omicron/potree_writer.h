#pragma once
// pcl::PotreeWriter: writes an OMiCroN hierarchy in the Potree 2.0 format (potree_format.h):
// metadata.json, hierarchy.bin, octree.bin in one folder, readable by potree's 2.0 loader.
//
//   pcl::PotreeWriter<pcl::PointXYZRGB> writer;
//   writer.write (octree, "out/cloud");        // after octree.build ()
//
// or streamed, subtree by subtree, while the hierarchy is still being built (octree.bin is
// appended; hierarchy.bin and metadata.json are written by close ()):
//
//   writer.open ("out/cloud", origin, edge);
//   writer.appendSubtree (*node);  ...
//   writer.close (point_count);
//
// Positions are stored as int32 (x − offset) / scale with offset = the root cube's min
// corner; colour (PointT with rgb) as uint16 × 3 (8-bit value × 257, LAS style).
//
// Potree's LOD is additive: a node is drawn together with its ancestors. OMiCroN's parents
// hold copies of points sampled from their children, so a node is written without the
// points its parent took (PotreeConverter 2 likewise moves sampled points up): every input
// point is stored exactly once. Inner nodes left empty are written with no points, as
// PotreeConverter does; subtrees left empty are dropped.
//
// Node size: a subtree that stores at most getLeafPointLimit () points is written as one
// leaf holding all of them (PotreeConverter's nodes hold up to about 20k points). Potree
// loads a node at a time, so OMiCroN's deep leaves of a few points each would otherwise make
// tens of thousands of requests and show a fraction of a percent of the cloud.
// Errors (unwritable folder, failed write, inconsistent hierarchy) throw pcl::IOException.
#include <pclx/omicron/octree_node.h>
#include <pclx/omicron/potree_format.h>

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

template <typename PointT>
class PotreeWriter
{
public:
  using Node = omicron::Node<PointT>;

  PotreeWriter ();
  ~PotreeWriter ();
  PotreeWriter (const PotreeWriter&) = delete;
  PotreeWriter& operator= (const PotreeWriter&) = delete;

  void setName (const std::string& name) { meta_.name = name; }
  void setProjection (const std::string& projection) { meta_.projection = projection; }
  // Position quantum (world units); <= 0 (default): the largest power of ten that keeps the
  // root cube within 2^30 steps.
  void setScale (double scale) { scale_ = scale; }
  // Hierarchy levels per hierarchy.bin chunk (PotreeConverter uses 4).
  void setHierarchyStepSize (int step);
  // Write the rgb attribute; default: when PointT has colour.
  void setWriteColors (bool on) { colors_ = on; }
  /** \brief Set the parent point ratio of the octree whose nodes are appended, which tells
    * which points each parent took from its children (the writer leaves them out).
    * \param[in] ratio the octree's ratio, in (0, 1]; write () takes it from the octree
    * \note Throws std::invalid_argument outside (0, 1]. Default 0.2, the octree's default.
    */
  void setParentPointRatio (float ratio);
  /** \brief The parent point ratio the appended nodes are read with. */
  float getParentPointRatio () const { return parent_ratio_; }
  /** \brief Set the node size: a subtree storing at most this many points is written as one
    * leaf holding all of them, as PotreeConverter sizes its nodes.
    * \param[in] points the limit; 0 writes every node of the octree
    */
  void setLeafPointLimit (std::uint32_t points) { leaf_limit_ = points; }
  /** \brief The node size limit (default kDefaultLeafPointLimit). */
  std::uint32_t getLeafPointLimit () const { return leaf_limit_; }
  /** \brief PotreeConverter's nodes hold up to about 20k points. */
  static constexpr std::uint32_t kDefaultLeafPointLimit = 20000;

  // Writes a built octree (throws pcl::IOException; std::logic_error when it is not built).
  void write (const ObliqueCutOctree<PointT>& octree, const std::string& directory);

  // Streaming. open () creates the folder and octree.bin; appendNode () / appendSubtree ()
  // may be called from several threads; close () writes hierarchy.bin and metadata.json with
  // `points` as the metadata point count (the input points the hierarchy holds).
  void open (const std::string& directory, const Eigen::Vector3d& origin, double edge);
  /** \brief Append one node of an octree: its points minus those its parent took (all of them
    * at the root).
    * \param[in] node the node (its children are not written)
    */
  void appendNode (const Node& node);
  /** \brief Append a subtree: one leaf when it stores at most getLeafPointLimit () points, else
    * its root as appendNode (const Node&) and each child's subtree the same way.
    * \param[in] node the subtree's root; nodes flagged omicron::kSpilled stand for what
    * appendSpilled () received
    */
  void appendSubtree (const Node& node);
  /** \brief Append the subtree of a node an out-of-core build is about to drop.
    * \param[in] node a node with its complete children
    * \note Writes the children's subtrees, or, when the whole subtree fits one leaf, keeps it
    * aside (octree.pending.bin) until appendSubtree () reaches `node`, since an ancestor may take
    * it into a larger leaf. close () fails if a kept subtree was never reached.
    */
  void appendSpilled (const Node& node);
  /** \brief Append exactly the given points as the node `code` (hierarchies of another origin).
    * \param[in] code the node
    * \param[in] points the points
    * \param[in] n how many
    */
  void appendNode (MortonCode code, const PointT* points, std::uint32_t n);
  void close (std::uint64_t points);
  // Reserves the node records (32 B each) so they never reallocate (memory budgets).
  void reserveNodes (std::size_t nodes);
  bool isOpen () const { return file_ != nullptr; }
  // Bytes appended to octree.bin so far.
  std::uint64_t bytesWritten () const;
  std::size_t nodesWritten () const;
  const omicron::potree::Metadata& getMetadata () const { return meta_; }

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
  // Appends points [0, n) except the `taken` picks of omicron::parentSampleIndex.
  void encode (const PointT* points, std::uint32_t n, std::uint32_t taken, Encoded& out) const;
  // Appends the stored points of the subtree in depth-first order.
  void encodeSubtree (const Node& node, Encoded& out);
  void record (MortonCode code, const Encoded& data);
  void closePending ();
  void abandon ();

  omicron::potree::Metadata meta_;
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
  std::vector<omicron::potree::NodeRecord> records_;
  Eigen::Vector3d lo_, hi_;
};

}  // namespace pcl

#ifdef PCL_NO_PRECOMPILE
#include <pclx/omicron/impl/potree_writer.hpp>
#endif
