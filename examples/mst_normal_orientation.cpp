// Consistent normal signs over a minimum spanning tree of the cloud's Riemannian graph.
//   mst_normal_orientation [cloud_with_normals.pcd]   without arguments: a unit sphere whose
//   normals have random signs
#include <pclx/normals/mst_normal_orientation.h>

#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <cmath>
#include <cstdio>
#include <random>

int
main (int argc, char** argv)
{
  pcl::PointCloud<pcl::PointNormal>::Ptr cloud (new pcl::PointCloud<pcl::PointNormal>);
  if (argc == 2)
  {
    if (pcl::io::loadPCDFile (argv[1], *cloud) < 0)
      return 1;
  }
  else
  {
    std::mt19937 rng (1);
    for (int i = 0; i < 30000; ++i)  // a golden-angle spiral on the unit sphere
    {
      const float z = 1.f - 2.f * (i + 0.5f) / 30000.f, r = std::sqrt (1.f - z * z), a = 2.39996323f * i;
      pcl::PointNormal p;
      p.getVector3fMap () = Eigen::Vector3f (r * std::cos (a), r * std::sin (a), z);
      p.getNormalVector3fMap () = (rng () % 2 ? 1.f : -1.f) * p.getVector3fMap ();  // unoriented
      cloud->push_back (p);
    }
  }

  pcl::MSTNormalOrientation<pcl::PointNormal, pcl::PointNormal> mst;
  mst.setInputCloud (cloud);
  if (!mst.orient (*cloud))  // flips the normals in place
    return 1;
  std::printf ("%zu normals oriented, %zu flipped, %zu graph component(s)\n", cloud->size (),
               mst.getNumberOfFlipped (), mst.getNumberOfComponents ());
  if (pcl::io::savePCDFileBinary ("oriented.pcd", *cloud) < 0)
    return 1;
  if (argc == 2)
    return 0;

  std::size_t outward = 0;
  for (const auto& p : *cloud)
    outward += p.getNormalVector3fMap ().dot (p.getVector3fMap ()) > 0.f;
  std::printf ("%zu of %zu normals face outwards\n", outward, cloud->size ());
  return outward == cloud->size () ? 0 : 1;
}
