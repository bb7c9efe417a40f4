// Explicit instantiation of the Potree writer for the octree's point types.
#include <pclx/omicron/impl/potree_writer.hpp>
#include <pclx/omicron/point_xyzi_packed.h>
#include <pclx/omicron/point_xyzrgbi.h>

#include <pcl/impl/instantiate.hpp>
#include <pcl/point_types.h>

#ifndef PCL_NO_PRECOMPILE
PCL_INSTANTIATE (PotreeWriter, (pcl::PointXYZ)(pcl::PointXYZRGB)(pcl::PointXYZRGBA)(pcl::PointXYZI)(pcl::PointNormal)
                                   (pclx::PointXYZRGBI)(pclx::PointXYZIPacked))
#endif
