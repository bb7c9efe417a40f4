#pragma once
#include <pclx/testing/mesh_sampling.h>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <vector>

namespace hprtest {

inline pcl::PointCloud<pcl::PointXYZ>::Ptr
xyz (const pclx::testing::SampledCloud& s)
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr c (new pcl::PointCloud<pcl::PointXYZ>);
  for (const auto& p : s.cloud)
    c->push_back (pcl::PointXYZ (p.x, p.y, p.z));
  return c;
}

struct Score
{
  double precision = 0, recall = 0, f1 = 0;
};

inline Score
score (const pcl::Indices& visible, const std::vector<bool>& truth)
{
  std::vector<bool> v (truth.size (), false);
  for (auto i : visible)
    v[i] = true;
  double tp = 0, fp = 0, fn = 0;
  for (std::size_t i = 0; i < truth.size (); ++i)
  {
    tp += v[i] && truth[i];
    fp += v[i] && !truth[i];
    fn += !v[i] && truth[i];
  }
  Score s;
  s.precision = tp / std::max (1.0, tp + fp);
  s.recall = tp / std::max (1.0, tp + fn);
  s.f1 = 2 * s.precision * s.recall / std::max (1e-12, s.precision + s.recall);
  return s;
}

inline double
jaccard (pcl::Indices a, pcl::Indices b)
{
  std::sort (a.begin (), a.end ());
  std::sort (b.begin (), b.end ());
  pcl::Indices i, u;
  std::set_intersection (a.begin (), a.end (), b.begin (), b.end (), std::back_inserter (i));
  std::set_union (a.begin (), a.end (), b.begin (), b.end (), std::back_inserter (u));
  return u.empty () ? 1.0 : double (i.size ()) / double (u.size ());
}

}  // namespace hprtest
