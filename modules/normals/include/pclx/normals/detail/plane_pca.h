#pragma once
// The plane of a 3x3 covariance: its eigenvalues and the eigenvector of the smallest one,
// which is all the octree, the patches and the scale ladder read. PCL's closed-form roots
// plus one eigenvector: pcl::eigen33's full form solves all three, at a noticeable share of
// the octree and patch time.
#include <Eigen/Core>

namespace pclx {
namespace normals {
namespace detail {

struct PlanePca
{
  Eigen::Vector3d lambda;  // λ1 ≥ λ2 ≥ λ3 ≥ 0
  Eigen::Vector3d normal;  // unit eigenvector of λ3
};

// Equal smallest eigenvalues give a direction across the largest (as pcl::eigen33 does);
// all three equal give +z.
PlanePca planePca (const Eigen::Matrix3d& cov);

}  // namespace detail
}  // namespace normals
}  // namespace pclx
