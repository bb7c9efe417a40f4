// make_scene: a generated torus-and-sphere scene, as organized depth frames in PCD files
// (sensor frame, y down, Kinect-like noise) the way pcl::PCDGrabber replays recorded
// sequences, as the same frames in the 7-Scenes layout (16-bit depth PNGs in mm,
// camera-intrinsics.txt, camera-to-world poses) for --depth-dir and virtual cameras,
// and/or as a uniformly sampled cloud (PLY). Used by the viewer test and the demo.
#include <pclx/apps/depth_frames.h>
#include <pclx/apps/progress.h>
#include <pclx/testing/depth_renderer.h>
#include <pclx/testing/mesh_sampling.h>
#include <pclx/testing/shapes.h>

#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>

#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>

using namespace pclx::testing;

namespace {
int run (int argc, char** argv);
}

int
main (int argc, char** argv)
{
  try
  {
    return run (argc, argv);
  }
  catch (const std::exception& e)
  {
    std::fprintf (stderr, "make_scene: %s\n", e.what ());
    return 1;
  }
}

namespace {
int
run (int argc, char** argv)
{
  CLI::App app ("Generated torus-and-sphere scene: depth frames (PCD) and/or a sampled cloud (PLY)");
  std::string dir, png_dir, cloud_file;
  int frames = 3, width = 320, height = 240;
  std::size_t points = 200000;
  app.add_option ("--dir", dir, "write depth frames (PCD) to this folder");
  app.add_option ("--depth-png-dir", png_dir,
                  "write the frames in the 7-Scenes layout (frame-NNNNNN.depth.png in mm, camera-intrinsics.txt, "
                  "frame-NNNNNN.pose.txt camera-to-world)");
  app.add_option ("--cloud", cloud_file, "write a uniformly sampled cloud of the scene (PLY)");
  app.add_option ("--points", points, "points of --cloud")->capture_default_str ();
  app.add_option ("--frames", frames, "number of frames")->capture_default_str ();
  app.add_option ("--width", width, "rendered frame width in pixels")->capture_default_str ();
  app.add_option ("--height", height, "rendered frame height in pixels")->capture_default_str ();
  CLI11_PARSE (app, argc, argv);

  // A torus around a sphere: self-occlusion and occlusion of one object by another.
  TriangleMesh object = makeTorus (0.3f, 0.1f, 128, 48);
  object.append (makeSphere (0.12f, 4, Eigen::Vector3f (0, 0, 0.05f)));
  if (!cloud_file.empty ())
  {
    // The cloud: the object on a small base plate.
    TriangleMesh scene = object;
    TriangleMesh base = makeBox (Eigen::Vector3f (1.f, 1.f, 0.04f), 8);
    base.transform (Eigen::Affine3f (Eigen::Translation3f (0, 0, -0.2f)));
    scene.append (base);
    const SampledCloud s = sampleUniform (scene, points, 1);
    pcl::PointCloud<pcl::PointXYZ> xyz;
    for (const auto& p : s.cloud)
      xyz.push_back (pcl::PointXYZ (p.x, p.y, p.z));
    // No `camera` element: PCL's reader would warn about each of its properties.
    if (pcl::PLYWriter ().write (cloud_file, xyz, true, false) != 0)
      return 1;
    std::printf ("wrote %zu points to %s\n", xyz.size (), cloud_file.c_str ());
  }
  if (dir.empty () && png_dir.empty ())
    return 0;
  // The frames: the object in front of a wide wall, as a depth camera sees a room.
  TriangleMesh scene = object;
  TriangleMesh wall = makeBox (Eigen::Vector3f (3.f, 3.f, 0.05f), 4);
  wall.transform (Eigen::Affine3f (Eigen::Translation3f (0, 0, -0.4f)));
  scene.append (wall);
  const RayCaster caster (scene);
  PinholeIntrinsics K;
  K.width = width;
  K.height = height;
  K.fx = K.fy = 525.f * width / 640.f;
  K.cx = (width - 1) / 2.f;
  K.cy = (height - 1) / 2.f;
  if (!png_dir.empty ())
    std::filesystem::create_directories (png_dir);
  if (!png_dir.empty ())
    pclx::apps::writeIntrinsics (png_dir + "/camera-intrinsics.txt", pclx::apps::DepthIntrinsics{K.fx, K.fy, K.cx, K.cy});
  pclx::apps::Progress progress ("rendering depth frames", static_cast<std::size_t> (frames));
  for (int f = 0; f < frames; ++f)
  {
    const float a = 0.15f * f;
    const Eigen::Vector3f eye (1.2f * std::sin (a), -1.2f * std::cos (a), 0.9f);
    const Eigen::Isometry3f pose = lookAt (eye, Eigen::Vector3f::Zero ());
    const DepthImage depth = renderDepth (caster, K, pose, KinectNoise (), 10 + f);
    char name[64];
    if (!dir.empty ())
    {
      const auto cloud = depthToCloud (depth, K);  // camera frame, as a sensor delivers it
      std::snprintf (name, sizeof name, "/frame_%04d.pcd", f);
      if (pcl::io::savePCDFileBinary (dir + name, cloud) != 0)
        return 1;
    }
    if (!png_dir.empty ())
    {
      std::snprintf (name, sizeof name, "/frame-%06d", f);
      pclx::apps::writeDepthPng (png_dir + name + ".depth.png", pclx::apps::DepthImage16{depth.width, depth.height, depth.depth_mm});
      pclx::apps::writePose (png_dir + name + ".pose.txt", pose.matrix ());
    }
    progress.update (static_cast<std::size_t> (f + 1));
  }
  progress.done ();
  for (const std::string& d : {dir, png_dir})
    if (!d.empty ())
      std::printf ("wrote %d frames to %s\n", frames, d.c_str ());
  return 0;
}
}  // namespace
