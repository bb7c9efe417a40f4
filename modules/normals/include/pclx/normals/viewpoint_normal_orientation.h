#pragma once
// Viewpoint orientation (seed 002 §5.4.2): when the capture position vp is known,
// every normal is flipped so that ni · (vp − xi) > 0.
#include <pcl/common/point_tests.h>
#include <pcl/point_cloud.h>

#include <Eigen/Core>
#include <cstddef>

namespace pcl {

// Returns false with PCL_ERROR when the clouds differ in size. Invalid points and
// non-finite normals are left untouched. `flipped` (optional) receives the flip count.
template <typename PointT, typename NormalT> bool
orientNormalsTowardsViewpoint (const PointCloud<PointT>& cloud, PointCloud<NormalT>& normals,
                               const Eigen::Vector3f& viewpoint, std::size_t* flipped = nullptr)
{
  if (cloud.size () != normals.size ())
  {
    PCL_ERROR ("[pcl::orientNormalsTowardsViewpoint] %zu points but %zu normals\n", cloud.size (),
               normals.size ());
    return false;
  }
  std::size_t count = 0;
  for (std::size_t i = 0; i < cloud.size (); ++i)
  {
    auto n = normals[i].getNormalVector3fMap ();
    if (!isFinite (cloud[i]) || !n.allFinite ())
      continue;
    if (n.dot (viewpoint - cloud[i].getVector3fMap ()) < 0)
    {
      n = -n;
      ++count;
    }
  }
  if (flipped)
    *flipped = count;
  return true;
}

}  // namespace pcl
