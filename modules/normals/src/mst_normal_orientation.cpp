#include <pclx/normals/mst_normal_orientation.h>
#include <pclx/normals/impl/mst_normal_orientation.hpp>

#include <pcl/impl/instantiate.hpp>
#include <pcl/point_types.h>

PCL_INSTANTIATE_PRODUCT (MSTNormalOrientation,
                         ((pcl::PointXYZ)(pcl::PointXYZI)(pcl::PointXYZRGB)(pcl::PointXYZRGBA)(pcl::PointNormal))
                         ((pcl::Normal)(pcl::PointNormal)(pcl::PointXYZRGBNormal)))
