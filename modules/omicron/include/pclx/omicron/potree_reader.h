#pragma once
// pcl::PotreeReader: reads a Potree 2.0 folder, see the class.
#include <pclx/omicron/detail/potree_format.h>
#include <pclx/omicron/point_xyzrgbi.h>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cstdint>
#include <string>
#include <vector>

namespace pcl {

/** \brief Reads a Potree 2.0 folder (metadata.json, hierarchy.bin, octree.bin) as written by
  * pcl::PotreeWriter or PotreeConverter 2.x in the DEFAULT encoding: position, rgb and
  * intensity are read, other attributes (classification, gps-time, ...) are skipped. The
  * hierarchy is walked as potree's 2.0 loader walks it (root chunk of firstChunkSize bytes,
  * proxies opening further chunks), but all at once.
  *
  * \code
  * pcl::PotreeReader reader;
  * if (reader.open ("out/cloud"))                    // false + PCL_ERROR on a bad folder
  *   for (std::size_t i = 0; i < reader.getNodes ().size (); ++i)
  *     reader.readNode (i, cloud);                   // the node's points
  * \endcode
  *
  * \note M. Schütz, 2016, "Potree: Rendering Large Point Clouds in Web Browsers", MSc thesis,
  * TU Wien (the format: PotreeConverter 2.x).
  * \ingroup omicron
  */
class PotreeReader
{
public:
  /** \brief One node of the hierarchy. */
  struct NodeInfo
  {
    MortonCode code;              ///< the node
    std::string name;             ///< its Potree name ("r" and one digit per level)
    std::uint8_t type = 0;        ///< pclx::omicron::detail::potree::NodeType of its real record
    std::uint8_t child_mask = 0;  ///< bit k: child k exists
    std::uint32_t num_points = 0; ///< points stored in the node
    std::uint64_t byte_offset = 0;  ///< start of its points in octree.bin
    std::uint64_t byte_size = 0;    ///< bytes of its points in octree.bin
  };

  /** \brief Read metadata.json and hierarchy.bin and check every node's range against octree.bin.
    * \param[in] directory the folder
    * \return false (PCL_ERROR, getLastError () says what is wrong; no nodes) on a missing or
    * malformed file
    */
  bool open (const std::string& directory);

  /** \brief The metadata of the open folder.
    * \return the metadata of the open folder */
  const pclx::omicron::detail::potree::Metadata& getMetadata () const { return meta_; }
  /** \brief The nodes, breadth-first (level, then Morton order).
    * \return the nodes, breadth-first (level, then Morton order) */
  const std::vector<NodeInfo>& getNodes () const { return nodes_; }
  /** \brief Index of a node in getNodes ().
    * \param[in] code the node
    * \return the index, -1 when absent
    */
  long find (MortonCode code) const;
  /** \brief Sum of the nodes' point counts (metadata "points" is the input's count).
    * \return sum of the nodes' point counts (metadata "points" is the input's count) */
  std::uint64_t getStoredPoints () const;

  /** \brief Points of a node: positions decoded as int32 x scale + offset, colour when stored
    * (else the points keep PCL's default colour).
    * \param[in] i the node's index in getNodes ()
    * \param[out] out its points (empty on failure)
    * \return false (PCL_ERROR, getLastError ()) for a bad index or an unreadable octree.bin
    */
  bool readNode (std::size_t i, pcl::PointCloud<pcl::PointXYZRGB>& out) const;
  /** \brief Positions of a node (see the PointXYZRGB overload).
    * \param[in] i the node's index in getNodes ()
    * \param[out] out its points (empty on failure)
    * \return false (PCL_ERROR, getLastError ()) for a bad index or an unreadable octree.bin
    */
  bool readNode (std::size_t i, pcl::PointCloud<pcl::PointXYZ>& out) const;
  /** \brief Positions and intensity of a node (0 when the folder stores no intensity; see the
    * PointXYZRGB overload).
    * \param[in] i the node's index in getNodes ()
    * \param[out] out its points (empty on failure)
    * \return false (PCL_ERROR, getLastError ()) for a bad index or an unreadable octree.bin
    */
  bool readNode (std::size_t i, pcl::PointCloud<pcl::PointXYZI>& out) const;
  /** \brief Positions, colour and intensity of a node (see the PointXYZRGB and PointXYZI
    * overloads).
    * \param[in] i the node's index in getNodes ()
    * \param[out] out its points (empty on failure)
    * \return false (PCL_ERROR, getLastError ()) for a bad index or an unreadable octree.bin
    */
  bool readNode (std::size_t i, pcl::PointCloud<pclx::PointXYZRGBI>& out) const;
  /** \brief Why the last failed call failed.
    * \return why the last failed call failed */
  const std::string& getLastError () const { return last_error_; }

private:
  void openImpl (const std::string& directory);
  // Decodes node i into `out`: the attributes PointT has (readNode's overloads).
  template <typename PointT> bool readNodeAs (std::size_t i, pcl::PointCloud<PointT>& out) const;
  bool refuse (const char* method, const std::string& why) const;
  std::vector<std::uint8_t> readRange (std::uint64_t offset, std::uint64_t size) const;

  std::string directory_;
  pclx::omicron::detail::potree::Metadata meta_;
  std::vector<NodeInfo> nodes_;
  std::uint64_t octree_bytes_ = 0;
  mutable std::string last_error_;
};

}  // namespace pcl
