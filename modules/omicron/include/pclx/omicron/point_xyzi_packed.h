#pragma once
// pclx::PointXYZIPacked: x, y, z and intensity in 16 bytes, see the struct.
#include <pcl/point_types.h>
#include <pcl/register_point_struct.h>

namespace pclx {

/** \brief A point with position and intensity in 16 bytes: the intensity takes the fourth
  * float that pcl::PointXYZI leaves as padding (it pads to 32 bytes).
  *
  * For building large intensity scans (a laser scanner's x y z intensity) where the sorted
  * points are most of the memory: pcl::ObliqueCutOctree holds them in half the bytes of
  * pcl::PointXYZI, and pcl::PotreeWriter writes the same intensity attribute. Registered as
  * fields x, y, z and intensity. getVector4fMap () includes the intensity as its fourth value,
  * so it is no homogeneous point.
  * \ingroup omicron
  */
struct EIGEN_ALIGN16 PointXYZIPacked
{
  /// The coordinates and the intensity, also as data[4] (PCL's Eigen maps read it).
  union EIGEN_ALIGN16
  {
    float data[4];  ///< x, y, z, intensity
    struct
    {
      float x;          ///< x
      float y;          ///< y
      float z;          ///< z
      float intensity;  ///< the return's intensity, in the unit of its source
    };
  };
  PCL_ADD_EIGEN_MAPS_POINT4D
  PCL_MAKE_ALIGNED_OPERATOR_NEW
};

}  // namespace pclx

POINT_CLOUD_REGISTER_POINT_STRUCT (pclx::PointXYZIPacked,
                                   (float, x, x)(float, y, y)(float, z, z)(float, intensity, intensity))
