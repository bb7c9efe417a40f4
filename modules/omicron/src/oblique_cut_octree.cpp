// Explicit instantiation for PCL's common xyz point types (and pclx::PointXYZRGBI,
// pclx::PointXYZIPacked), so users link instead of recompiling.
#include <pclx/omicron/impl/oblique_cut_octree.hpp>
#include <pclx/omicron/point_xyzi_packed.h>
#include <pclx/omicron/point_xyzrgbi.h>

#include <pcl/impl/instantiate.hpp>
#include <pcl/point_types.h>

#ifndef PCL_NO_PRECOMPILE
#define PCLX_OMICRON_POINT_TYPES \
  (pcl::PointXYZ)(pcl::PointXYZRGB)(pcl::PointXYZRGBA)(pcl::PointXYZI)(pcl::PointNormal)(pclx::PointXYZRGBI) \
      (pclx::PointXYZIPacked)
PCL_INSTANTIATE (MortonSorter, PCLX_OMICRON_POINT_TYPES)
PCL_INSTANTIATE (ObliqueCut, PCLX_OMICRON_POINT_TYPES)
PCL_INSTANTIATE (ObliqueCutFront, PCLX_OMICRON_POINT_TYPES)
PCL_INSTANTIATE (ObliqueCutOctree, PCLX_OMICRON_POINT_TYPES)
#endif
