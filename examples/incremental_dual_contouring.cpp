// Posed depth frames fused into an adaptive mesh that is updated frame by frame.
//   incremental_dual_contouring [frame.pcd ...]   organized clouds in the camera frame, the
//   camera-to-world pose in each file's sensor origin and orientation; without arguments:
//   three frames of a sphere of radius 0.3 rendered from a circle around it
#include <pclx/surface/incremental_dual_contouring.h>

#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>

#include <cmath>
#include <cstdio>

// A 160x120 depth frame of the sphere |p| = 0.3 seen from a camera at distance 1.2.
pcl::PointCloud<pcl::PointXYZ>
sphereFrame (const Eigen::Isometry3f& camera_to_world)
{
  pcl::PointCloud<pcl::PointXYZ> frame (160, 120, pcl::PointXYZ (NAN, NAN, NAN));
  frame.is_dense = false;
  const Eigen::Vector3f c = camera_to_world.inverse () * Eigen::Vector3f::Zero ();  // sphere centre
  for (int v = 0; v < 120; ++v)
    for (int u = 0; u < 160; ++u)
    {
      const Eigen::Vector3f d = Eigen::Vector3f ((u - 80) / 140.f, (v - 60) / 140.f, 1.f).normalized ();
      const float b = d.dot (c), disc = b * b - c.squaredNorm () + 0.09f;
      if (disc >= 0.f)
        frame.at (u, v).getVector3fMap () = (b - std::sqrt (disc)) * d;
    }
  return frame;
}

int
main (int argc, char** argv)
{
  pcl::IncrementalDualContouring<pcl::PointXYZ> idc;
  idc.setLeafSize (0.01);  // the finest detail, in metres
  for (int i = 0; i < (argc > 1 ? argc - 1 : 3); ++i)
  {
    pcl::PointCloud<pcl::PointXYZ> frame;
    Eigen::Isometry3f pose = Eigen::Isometry3f::Identity ();
    if (argc > 1 && pcl::io::loadPCDFile (argv[i + 1], frame) < 0)
      return 1;
    if (argc > 1)
      pose.fromPositionOrientationScale (frame.sensor_origin_.head<3> (), frame.sensor_orientation_,
                                         Eigen::Vector3f::Ones ());
    else  // cameras on a circle around the sphere, looking at its centre (x right, y down, z forward)
    {
      const float a = 0.6f * (i - 1);
      pose.linear () << std::cos (a), 0.f, -std::sin (a), 0.f, 1.f, 0.f, std::sin (a), 0.f, std::cos (a);
      pose.translation () = -1.2f * pose.linear ().col (2);
      frame = sphereFrame (pose);
    }
    if (!idc.addFrame (frame, pose.matrix ().cast<double> ()))
      return 1;
  }
  pcl::PolygonMesh mesh;
  idc.reconstruct (mesh);
  if (mesh.polygons.empty () || pcl::io::savePLYFileBinary ("mesh.ply", mesh) < 0)
    return 1;
  std::printf ("%zu triangles written to mesh.ply\n", mesh.polygons.size ());
  return 0;
}
