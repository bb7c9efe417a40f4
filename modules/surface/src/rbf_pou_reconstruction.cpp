#include <pclx/surface/rbf_pou_reconstruction.h>
#include <pclx/surface/impl/rbf_pou_reconstruction.hpp>

#include <pcl/point_types.h>

template class pcl::RBFPOUReconstruction<pcl::PointNormal>;
template class pcl::RBFPOUReconstruction<pcl::PointXYZRGBNormal>;
template class pcl::RBFPOUReconstruction<pcl::PointXYZINormal>;
