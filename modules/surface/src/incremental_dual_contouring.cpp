#include <pclx/surface/incremental_dual_contouring.h>
#include <pclx/surface/impl/incremental_dual_contouring.hpp>

#include <pcl/point_types.h>

template class pcl::IncrementalDualContouring<pcl::PointXYZ>;
template class pcl::IncrementalDualContouring<pcl::PointXYZRGB>;
template class pcl::IncrementalDualContouring<pcl::PointXYZRGBA>;
