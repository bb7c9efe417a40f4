// Explicit instantiation for PCL's xyz point types, so users link instead of recompiling.
#include <pclx/hpr/hpr_filter.h>
#include <pclx/hpr/impl/hpr_filter.hpp>

#include <pcl/impl/instantiate.hpp>

#ifndef PCL_NO_PRECOMPILE
PCL_INSTANTIATE (HPRFilter, PCL_XYZ_POINT_TYPES)
#endif
