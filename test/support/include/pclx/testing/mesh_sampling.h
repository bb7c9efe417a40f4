#pragma once
// Random point sampling of a triangle mesh with ground-truth normals.
#include <pclx/testing/triangle_mesh.h>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cstdint>

namespace pclx {
namespace testing {

struct SampledCloud
{
  pcl::PointCloud<pcl::PointNormal> cloud;  // points + ground-truth (face) normals
  std::vector<int> face;                    // source face of every point
};

// Area-uniform sampling: every point lies on the mesh.
SampledCloud sampleUniform (const TriangleMesh& mesh, std::size_t n, std::uint32_t seed = 1);

// Density gradient along `axis` (0,1,2): density falls linearly from 1 at the
// low end of the bounding box to `min_ratio` (0 < min_ratio <= 1) at the high end.
SampledCloud sampleDensityGradient (const TriangleMesh& mesh, std::size_t n, int axis,
                                    float min_ratio, std::uint32_t seed = 1);

// The positions of a cloud with normals, as the PointXYZ cloud most filters take.
pcl::PointCloud<pcl::PointXYZ>::Ptr positions (const pcl::PointCloud<pcl::PointNormal>& cloud);

// Vertices of the mesh as a cloud with area-weighted vertex normals.
SampledCloud meshVertices (const TriangleMesh& mesh);

}  // namespace testing
}  // namespace pclx
