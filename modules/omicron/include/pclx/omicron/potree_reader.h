#pragma once
// pcl::PotreeReader: reads a Potree 2.0 folder (metadata.json, hierarchy.bin, octree.bin) as
// written by pcl::PotreeWriter or PotreeConverter 2.x with position (+ rgb) attributes and
// the DEFAULT encoding. The hierarchy is walked like potree's 2.0 loader does it (root chunk
// of firstChunkSize bytes, proxies opening further chunks), but all at once.
//
//   pcl::PotreeReader reader;
//   reader.open ("out/cloud");                        // throws pcl::IOException
//   for (std::size_t i = 0; i < reader.getNodes ().size (); ++i)
//     reader.readNode (i, cloud);                     // the node's points
#include <pclx/omicron/potree_format.h>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cstdint>
#include <string>
#include <vector>

namespace pcl {

class PotreeReader
{
public:
  struct NodeInfo
  {
    MortonCode code;
    std::string name;
    std::uint8_t type = 0;        // omicron::potree::NodeType of its real record
    std::uint8_t child_mask = 0;
    std::uint32_t num_points = 0;
    std::uint64_t byte_offset = 0, byte_size = 0;  // in octree.bin
  };

  // Reads metadata.json and hierarchy.bin and checks every node's range against octree.bin.
  // Throws pcl::IOException saying what is wrong.
  void open (const std::string& directory);

  const omicron::potree::Metadata& getMetadata () const { return meta_; }
  // Nodes breadth-first (level, then Morton order).
  const std::vector<NodeInfo>& getNodes () const { return nodes_; }
  // Index of a node in getNodes () (-1 when absent).
  long find (MortonCode code) const;
  // Sum of the nodes' point counts (metadata "points" is the input's count).
  std::uint64_t getStoredPoints () const;

  // Points of node i: positions decoded as int32 · scale + offset, colour when stored.
  void readNode (std::size_t i, pcl::PointCloud<pcl::PointXYZRGB>& out) const;
  void readNode (std::size_t i, pcl::PointCloud<pcl::PointXYZ>& out) const;

private:
  std::vector<std::uint8_t> readRange (std::uint64_t offset, std::uint64_t size) const;

  std::string directory_;
  omicron::potree::Metadata meta_;
  std::vector<NodeInfo> nodes_;
  std::uint64_t octree_bytes_ = 0;
};

}  // namespace pcl
