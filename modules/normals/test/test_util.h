#pragma once
// Shared generators for the normals tests: analytic shapes with exact normals.
#include <pcl/common/io.h>
#include <pcl/features/normal_3d.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cmath>
#include <random>

namespace normals_test {

// Points exactly on a sphere (uniform directions); truth = outward radial normals.
inline pcl::PointCloud<pcl::PointNormal>
analyticSphere (std::size_t n, float radius, const Eigen::Vector3f& c, std::uint32_t seed = 7)
{
  std::mt19937 rng (seed);
  std::normal_distribution<float> g;
  pcl::PointCloud<pcl::PointNormal> out;
  while (out.size () < n)
  {
    Eigen::Vector3f d (g (rng), g (rng), g (rng));
    if (d.norm () < 1e-3f)
      continue;
    d.normalize ();
    pcl::PointNormal p;
    p.getVector3fMap () = c + radius * d;
    p.getNormalVector3fMap () = d;
    out.push_back (p);
  }
  return out;
}

// Points uniformly on a (tilted) square patch of a plane; truth = the plane normal.
inline pcl::PointCloud<pcl::PointNormal>
analyticPlane (std::size_t n, const Eigen::Vector3f& normal, float size, std::uint32_t seed = 3)
{
  std::mt19937 rng (seed);
  std::uniform_real_distribution<float> u (-size / 2, size / 2);
  const Eigen::Vector3f nz = normal.normalized ();
  const Eigen::Vector3f e1 = nz.unitOrthogonal (), e2 = nz.cross (e1);
  pcl::PointCloud<pcl::PointNormal> out;
  for (std::size_t i = 0; i < n; ++i)
  {
    pcl::PointNormal p;
    p.getVector3fMap () = Eigen::Vector3f (0.3f, -0.2f, 1.5f) + u (rng) * e1 + u (rng) * e2;
    p.getNormalVector3fMap () = nz;
    out.push_back (p);
  }
  return out;
}

// Hoppe / PCL PCA normals, the reference every comparison is made against.
template <typename PointT> pcl::PointCloud<pcl::Normal>
pcaNormals (const typename pcl::PointCloud<PointT>::ConstPtr& cloud, int k)
{
  pcl::NormalEstimation<PointT, pcl::Normal> ne;
  ne.setInputCloud (cloud);
  ne.setKSearch (k);
  pcl::PointCloud<pcl::Normal> out;
  ne.compute (out);
  return out;
}

}  // namespace normals_test
