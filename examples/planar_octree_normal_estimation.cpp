// Normals of a cloud from an octree split on PCA planarity, as any pcl::Feature.
//   planar_octree_normal_estimation [cloud.pcd]   without arguments: a noisy unit sphere
#include <pclx/normals/planar_octree_normal_estimation.h>

#include <pcl/common/io.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

int
main (int argc, char** argv)
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud (new pcl::PointCloud<pcl::PointXYZ>);
  if (argc == 2)
  {
    if (pcl::io::loadPCDFile (argv[1], *cloud) < 0)
      return 1;
  }
  else
  {
    std::mt19937 rng (1);
    std::normal_distribution<float> noise (0.f, 0.002f);
    for (int i = 0; i < 50000; ++i)  // a golden-angle spiral on the unit sphere, with noise
    {
      const float z = 1.f - 2.f * (i + 0.5f) / 50000.f, r = std::sqrt (1.f - z * z), a = 2.39996323f * i;
      const float s = 1.f + noise (rng);
      cloud->push_back (pcl::PointXYZ (s * r * std::cos (a), s * r * std::sin (a), s * z));
    }
  }

  pcl::PlanarOctreeNormalEstimation<pcl::PointXYZ, pcl::Normal> ne;  // scales chosen from the data
  ne.setInputCloud (cloud);
  pcl::PointCloud<pcl::Normal> normals;
  ne.compute (normals);
  if (normals.size () != cloud->size ())
    return 1;

  pcl::PointCloud<pcl::PointNormal> out;
  pcl::concatenateFields (*cloud, normals, out);
  if (pcl::io::savePCDFileBinary ("normals.pcd", out) < 0)
    return 1;

  std::printf ("%zu normals written to normals.pcd\n", out.size ());
  if (argc == 2)
    return 0;

  // On the sphere the true normal is the position; the sign is left to an orientation step.
  double sum_deg = 0;
  for (const auto& p : out)
  {
    const float c = std::abs (p.getNormalVector3fMap ().dot (p.getVector3fMap ().normalized ()));
    sum_deg += std::acos (std::min (1.f, c)) * 180.0 / M_PI;
  }
  std::printf ("mean angle to the true normals: %.2f deg\n", sum_deg / out.size ());
  return sum_deg / out.size () < 5.0 ? 0 : 1;
}
