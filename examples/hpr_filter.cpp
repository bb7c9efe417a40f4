// The points of a cloud that a viewer at a given position sees (hidden point removal).
//   hpr_filter [cloud.pcd x y z]     without arguments: a unit sphere seen from (0, 0, 3)
#include <pclx/hpr/hpr_filter.h>

#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>

int
main (int argc, char** argv)
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud (new pcl::PointCloud<pcl::PointXYZ>);
  Eigen::Vector3f viewpoint (0.f, 0.f, 3.f);
  if (argc == 5)
  {
    if (pcl::io::loadPCDFile (argv[1], *cloud) < 0)
      return 1;
    viewpoint = Eigen::Vector3f (std::atof (argv[2]), std::atof (argv[3]), std::atof (argv[4]));
  }
  else
  {
    for (int i = 0; i < 20000; ++i)  // a golden-angle spiral on the unit sphere
    {
      const float z = 1.f - 2.f * (i + 0.5f) / 20000.f, r = std::sqrt (1.f - z * z), a = 2.39996323f * i;
      cloud->push_back (pcl::PointXYZ (r * std::cos (a), r * std::sin (a), z));
    }
  }

  pcl::HPRFilter<pcl::PointXYZ> hpr (true);  // true: also keep the hidden (removed) indices
  hpr.setInputCloud (cloud);
  hpr.setViewPoint (viewpoint);
  pcl::PointCloud<pcl::PointXYZ> visible;
  hpr.filter (visible);
  std::printf ("%zu of %zu points visible, %zu hidden\n", visible.size (), cloud->size (),
               hpr.getRemovedIndices ()->size ());
  if (visible.empty () || pcl::io::savePCDFileBinary ("visible.pcd", visible) < 0)
    return 1;

  // From (0, 0, 3) a unit sphere shows the cap above z = 1/3.
  if (argc != 5)
    for (const auto& p : visible)
      if (p.z < 0.3f)
        return 1;
  return 0;
}
