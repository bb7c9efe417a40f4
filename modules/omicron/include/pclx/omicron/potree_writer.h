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
// corner; colour (PointT with rgb) as uint16 × 3 (8-bit value × 257, LAS style). Each node
// stores its own points: Potree draws a node together with its ancestors, so OMiCroN's
// parent samples (copies of child points) are drawn twice where both levels are shown.
// Errors (unwritable folder, failed write, inconsistent hierarchy) throw pcl::IOException.
#include <pclx/omicron/octree_node.h>
#include <pclx/omicron/potree_format.h>

#include <pcl/point_cloud.h>

#include <cstdio>
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

  // Writes a built octree (throws pcl::IOException; std::logic_error when it is not built).
  void write (const ObliqueCutOctree<PointT>& octree, const std::string& directory);

  // Streaming. open () creates the folder and octree.bin; appendNode () / appendSubtree ()
  // may be called from several threads; close () writes hierarchy.bin and metadata.json with
  // `points` as the metadata point count (the input points the hierarchy holds).
  void open (const std::string& directory, const Eigen::Vector3d& origin, double edge);
  void appendNode (MortonCode code, const PointT* points, std::uint32_t n);
  void appendSubtree (const Node& node);
  void close (std::uint64_t points);
  // Reserves the node records (32 B each) so they never reallocate (memory budgets).
  void reserveNodes (std::size_t nodes);
  bool isOpen () const { return file_ != nullptr; }
  // Bytes appended to octree.bin so far.
  std::uint64_t bytesWritten () const;
  std::size_t nodesWritten () const;
  const omicron::potree::Metadata& getMetadata () const { return meta_; }

private:
  void encode (const PointT* points, std::uint32_t n, std::vector<std::uint8_t>& out) const;
  void abandon ();

  omicron::potree::Metadata meta_;
  double scale_ = 0;
  bool colors_;
  std::string directory_;
  std::FILE* file_ = nullptr;
  mutable std::mutex mutex_;
  std::uint64_t offset_ = 0;
  std::vector<omicron::potree::NodeRecord> records_;
  Eigen::Vector3d lo_, hi_;
};

}  // namespace pcl

#ifdef PCL_NO_PRECOMPILE
#include <pclx/omicron/impl/potree_writer.hpp>
#endif
