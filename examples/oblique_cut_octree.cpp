// A level-of-detail octree built in the background while a camera's front is drawn from the
// part already built (OMiCroN), then written as Potree 2.0 files a web viewer opens.
//   oblique_cut_octree [cloud.ply|cloud.pcd]   without arguments: 200k points on a unit sphere
#include <pclx/omicron/camera.h>
#include <pclx/omicron/oblique_cut_octree.h>
#include <pclx/omicron/potree_writer.h>

#include <pcl/point_types.h>

#include <cmath>
#include <cstdio>

int
main (int argc, char** argv)
{
  pcl::ObliqueCutOctree<pcl::PointXYZ> octree;
  if (argc == 2)
    octree.setInputFile (argv[1]);  // read in chunks: the cloud need not fit in memory
  else
  {
    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud (new pcl::PointCloud<pcl::PointXYZ>);
    for (int i = 0; i < 200000; ++i)  // a golden-angle spiral on the unit sphere
    {
      const float z = 1.f - 2.f * (i + 0.5f) / 200000.f, r = std::sqrt (1.f - z * z), a = 2.39996323f * i;
      cloud->push_back (pcl::PointXYZ (r * std::cos (a), r * std::sin (a), z));
    }
    octree.setInputCloud (cloud);
  }

  pcl::ObliqueCutOctree<pcl::PointXYZ>::Camera camera;
  camera.width = 640;
  camera.height = 480;
  camera.view_projection = pcl::perspectiveLookAt (Eigen::Vector3f (0.f, 0.f, 4.f), Eigen::Vector3f::Zero (),
                                                            float (M_PI) / 3.f, 640.f / 480.f, 0.1f, 100.f);
  if (!octree.startBuild ())
    return 1;
  std::vector<pcl::ObliqueCutOctree<pcl::PointXYZ>::Item> items;
  octree.evaluate (camera, items);  // a renderer calls this every frame, during the build too
  if (!octree.wait ())
    return 1;
  octree.evaluate (camera, items);
  std::size_t drawn = 0;
  for (const auto& item : items)
    drawn += item.num_points;  // item.points[0 .. num_points) with splats of item.splat_radius
  std::printf ("front: %zu nodes, %zu points to draw\n", items.size (), drawn);

  pcl::PotreeWriter<pcl::PointXYZ> writer;
  if (!writer.write (octree, "potree_out"))
    return 1;
  std::printf ("Potree 2.0 files in potree_out/ (metadata.json, hierarchy.bin, octree.bin)\n");
  return items.empty () ? 1 : 0;
}
