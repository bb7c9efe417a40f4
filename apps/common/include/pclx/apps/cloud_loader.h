#pragma once
// Loads PCD, PLY and XYZ text files after checkCloudFile(), into the point type the caller
// wants, copying only the fields the file has (no "Failed to find match for field" warnings).
#include <pclx/apps/file_check.h>

#include <pcl/PCLPointCloud2.h>
#include <pcl/conversions.h>
#include <pcl/point_cloud.h>

#include <algorithm>
#include <string>

namespace pclx {
namespace apps {

// Which of the usual fields a cloud has.
struct CloudFields
{
  bool xyz = false, rgb = false, alpha = false, normals = false, intensity = false, curvature = false;

  static CloudFields of (const pcl::PCLPointCloud2& blob);
  std::string str () const;  // "xyz rgb normals"
};

struct CloudInfo
{
  std::string path;
  FileCheck file;
  CloudFields fields;
  std::size_t points = 0, finite = 0;  // finite: x, y and z all finite
  std::uint32_t width = 0, height = 0;

  bool organized () const { return height > 1; }
  std::string summary () const;  // "scene.ply: 200000 points (xyz normals)"
};

// Checks the file, then reads it with PCL (PCD, PLY: PCL's `camera` element read quietly)
// or our XYZ parser (three numbers a line, or six with unit normals; '#' comments).
// Throws LoadError with a one-line message. `info` gets the fields and counts.
pcl::PCLPointCloud2::Ptr loadCloudBlob (const std::string& path, CloudInfo* info = nullptr);

// Throws LoadError when the cloud has no finite point (apps have nothing to work on).
void requireFinitePoints (const CloudInfo& info);

namespace detail {
// pcl::detail::FieldMapper without its warning for fields the data does not have.
template <typename PointT>
struct PresentFieldMapper
{
  const std::vector<pcl::PCLPointField>& fields;
  pcl::MsgFieldMap& map;

  template <typename Tag>
  void
  operator() ()
  {
    for (const auto& field : fields)
      if (pcl::FieldMatches<PointT, Tag> () (field))
      {
        pcl::detail::FieldMapping m;
        m.serialized_offset = field.offset;
        m.struct_offset = pcl::traits::offset<PointT, Tag>::value;
        m.size = sizeof (typename pcl::traits::datatype<PointT, Tag>::type);
        map.push_back (m);
        return;
      }
  }
};
}  // namespace detail

// Copies the fields of `blob` that PointT has; PointT's other fields keep their defaults.
// Throws LoadError if the blob's layout is inconsistent.
template <typename PointT>
typename pcl::PointCloud<PointT>::Ptr
toCloud (const pcl::PCLPointCloud2& blob)
{
  const std::uint64_t need = std::uint64_t (blob.row_step) * blob.height;
  if (std::uint64_t (blob.point_step) * blob.width > blob.row_step || blob.data.size () < need)
    throw LoadError ("inconsistent cloud layout (" + std::to_string (blob.data.size ()) + " data bytes)");
  pcl::MsgFieldMap map;
  pcl::for_each_type<typename pcl::traits::fieldList<PointT>::type> (
      detail::PresentFieldMapper<PointT>{blob.fields, map});
  for (const auto& m : map)
    if (m.serialized_offset + m.size > blob.point_step)
      throw LoadError ("a field lies outside the point");
  // Merge adjacent fields into one copy, as pcl::createMapping does.
  std::sort (map.begin (), map.end (), pcl::detail::fieldOrdering);
  for (std::size_t i = 1; i < map.size ();)
    if (map[i - 1].serialized_offset + map[i - 1].size == map[i].serialized_offset &&
        map[i - 1].struct_offset + map[i - 1].size == map[i].struct_offset)
    {
      map[i - 1].size += map[i].size;
      map.erase (map.begin () + static_cast<std::ptrdiff_t> (i));
    }
    else
      ++i;
  typename pcl::PointCloud<PointT>::Ptr cloud (new pcl::PointCloud<PointT>);
  if (blob.width * std::uint64_t (blob.height) > 0)
    pcl::fromPCLPointCloud2 (blob, *cloud, map);
  return cloud;
}

// loadCloudBlob + toCloud. The cloud's sensor pose is identity: a PCD VIEWPOINT is not
// applied (PCLVisualizer would turn PCL's recorded Kinect frames by 180° otherwise).
template <typename PointT>
typename pcl::PointCloud<PointT>::Ptr
loadCloud (const std::string& path, CloudInfo* info = nullptr)
{
  const auto blob = loadCloudBlob (path, info);
  try
  {
    return toCloud<PointT> (*blob);
  }
  catch (const LoadError& e)
  {
    throw LoadError (path + ": " + e.what ());
  }
}

}  // namespace apps
}  // namespace pclx
