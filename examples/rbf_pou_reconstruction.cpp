// A mesh from oriented points: a partition of unity of local RBF fits, as any
// pcl::SurfaceReconstruction.
//   rbf_pou_reconstruction [cloud_with_normals.pcd]   without arguments: a unit sphere
#include <pclx/surface/rbf_pou_reconstruction.h>

#include <pcl/common/io.h>
#include <pcl/io/ply_io.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

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
    for (int i = 0; i < 20000; ++i)  // a golden-angle spiral on the unit sphere, normals outwards
    {
      const float z = 1.f - 2.f * (i + 0.5f) / 20000.f, r = std::sqrt (1.f - z * z), a = 2.39996323f * i;
      pcl::PointNormal p;
      p.getVector3fMap () = p.getNormalVector3fMap () = Eigen::Vector3f (r * std::cos (a), r * std::sin (a), z);
      cloud->push_back (p);
    }
  }

  pcl::RBFPOUReconstruction<pcl::PointNormal> rbf;
  rbf.setInputCloud (cloud);
  pcl::PolygonMesh mesh;
  rbf.reconstruct (mesh);
  if (mesh.polygons.empty () || pcl::io::savePLYFileBinary ("mesh.ply", mesh) < 0)
    return 1;
  std::printf ("%zu triangles written to mesh.ply\n", mesh.polygons.size ());
  if (argc == 2)
    return 0;

  pcl::PointCloud<pcl::PointXYZ> vertices;
  pcl::fromPCLPointCloud2 (mesh.cloud, vertices);
  double worst = 0;
  for (const auto& v : vertices)
    worst = std::max (worst, std::abs (double (v.getVector3fMap ().norm ()) - 1.0));
  std::printf ("farthest vertex from the sphere: %.5f\n", worst);
  return worst < 0.01 ? 0 : 1;
}
