#include <pclx/normals/planar_octree_normal_estimation.h>
#include <pclx/normals/impl/planar_octree_normal_estimation.hpp>

#include <pcl/impl/instantiate.hpp>
#include <pcl/point_types.h>

// The common input types × the two normal outputs.
PCL_INSTANTIATE_PRODUCT (PlanarOctreeNormalEstimation,
                         ((pcl::PointXYZ)(pcl::PointXYZI)(pcl::PointXYZRGB)(pcl::PointXYZRGBA)(pcl::PointNormal))
                         ((pcl::Normal)(pcl::PointNormal)))
