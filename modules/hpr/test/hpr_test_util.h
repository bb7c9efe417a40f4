#pragma once
#include <pclx/testing/mesh_sampling.h>
#include <pclx/testing/set_scores.h>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <algorithm>
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

// The points relative to the viewpoint C, formed in double as the filter forms them, and
// (optional) their centroid.
inline std::vector<Eigen::Vector3d>
relativeTo (const pcl::PointCloud<pcl::PointXYZ>& cloud, const Eigen::Vector3f& C, Eigen::Vector3d* centre = nullptr)
{
  std::vector<Eigen::Vector3d> rel;
  rel.reserve (cloud.size ());
  Eigen::Vector3d sum = Eigen::Vector3d::Zero ();
  for (const auto& p : cloud)
  {
    rel.push_back (p.getVector3fMap ().cast<double> () - C.cast<double> ());
    sum += rel.back ();
  }
  if (centre)
    *centre = sum / double (std::max<std::size_t> (rel.size (), 1));
  return rel;
}

}  // namespace hprtest
