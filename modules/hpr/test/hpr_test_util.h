#pragma once
#include <pclx/testing/mesh_sampling.h>
#include <pclx/testing/set_scores.h>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <vector>

namespace hprtest {

inline pcl::PointCloud<pcl::PointXYZ>::Ptr
xyz (const pclx::testing::SampledCloud& s)
{
  return pclx::testing::positions (s.cloud);
}

using Score = pclx::testing::SubsetScore;

inline Score
score (const pcl::Indices& visible, const std::vector<bool>& truth)
{
  return pclx::testing::scoreSubset (visible, truth);
}

inline double
jaccard (const pcl::Indices& a, const pcl::Indices& b)
{
  return pclx::testing::jaccard (a, b);
}

}  // namespace hprtest
