#include <pclx/normals/detail/plane_pca.h>

#include <pcl/common/eigen.h>

#include <limits>

namespace pclx {
namespace normals {
namespace detail {

PlanePca
planePca (const Eigen::Matrix3d& cov)
{
  // Scaled to unit magnitude as pcl::eigen33 does, so the roots keep their precision.
  double scale = cov.cwiseAbs ().maxCoeff ();
  if (scale <= std::numeric_limits<double>::min ())
    scale = 1.0;
  Eigen::Matrix3d scaled = cov / scale;
  Eigen::Vector3d roots;  // ascending
  pcl::computeRoots (scaled, roots);
  PlanePca r;
  const Eigen::Vector3d ev = (roots * scale).cwiseMax (0.0);
  r.lambda = Eigen::Vector3d (ev (2), ev (1), ev (0));
  const double eps = Eigen::NumTraits<double>::epsilon ();
  if (roots (2) - roots (0) <= eps)
    r.normal = Eigen::Vector3d::UnitZ ();  // all three equal: any direction
  else if (roots (1) - roots (0) <= eps)
  {
    scaled.diagonal ().array () -= roots (2);
    r.normal = pcl::detail::getLargest3x3Eigenvector<Eigen::Vector3d> (scaled).vector.unitOrthogonal ();
  }
  else
  {
    scaled.diagonal ().array () -= roots (0);
    r.normal = pcl::detail::getLargest3x3Eigenvector<Eigen::Vector3d> (scaled).vector;
  }
  return r;
}

}  // namespace detail
}  // namespace normals
}  // namespace pclx
