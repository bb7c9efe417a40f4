#pragma once
// pclx::PointXYZRGBI: a point with position, colour and intensity, see the struct.
#include <pcl/point_types.h>
#include <pcl/register_point_struct.h>

#include <cstdint>

namespace pclx {

/** \brief A point with position, colour and intensity, as colourised laser scans carry them
  * (terrestrial scanners export x y z rgb intensity), which no PCL point type holds.
  *
  * pcl::PointStreamReader fills all three from PCD/PLY files, pcl::ObliqueCutOctree builds on
  * it, and pcl::PotreeWriter writes both the rgb and the intensity attribute. Registered as
  * fields x, y, z, rgba and intensity: 32 bytes, as pcl::PointXYZRGB.
  * \ingroup omicron
  */
struct EIGEN_ALIGN16 PointXYZRGBI
{
  PCL_ADD_POINT4D;  ///< x, y, z (and the padding of PCL point types)
  PCL_ADD_RGB;      ///< r, g, b, a, also as the packed rgba
  float intensity;  ///< the return's intensity, in the unit of its source
  PCL_MAKE_ALIGNED_OPERATOR_NEW
};

}  // namespace pclx

POINT_CLOUD_REGISTER_POINT_STRUCT (pclx::PointXYZRGBI,
                                   (float, x, x)(float, y, y)(float, z, z)(std::uint32_t, rgba, rgba)(float, intensity,
                                                                                                     intensity))
