// make_idc_frames: posed depth frames of a generated object (a torus around a sphere) from an
// orbit around it, with Kinect-like noise: PCD frames whose VIEWPOINT is the camera pose (for
// PCDGrabber) and / or the 7-Scenes layout (16-bit PNG depth in mm, .pose.txt, intrinsics).
#include <pclx/apps/depth_frames.h>
#include <pclx/testing/depth_renderer.h>
#include <pclx/testing/shapes.h>

#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>

#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>

int
main (int argc, char** argv)
{
  using namespace pclx::testing;
  CLI::App app ("Posed depth frames of a torus around a sphere, seen from an orbit around it");
  std::string pcd_dir, png_dir, mesh_file;
  int frames = 8, width = 320, height = 240;
  app.add_option ("--pcd-dir", pcd_dir, "write frames as PCD (camera frame; VIEWPOINT = camera-to-world)");
  app.add_option ("--depth-png-dir", png_dir, "write frames in the 7-Scenes layout");
  app.add_option ("--mesh", mesh_file, "write the ground-truth mesh (PLY)");
  app.add_option ("--frames", frames, "number of frames (>= 1)")->capture_default_str ();
  app.add_option ("--width", width, "depth frame width in pixels")->capture_default_str ();
  app.add_option ("--height", height, "depth frame height in pixels")->capture_default_str ();
  CLI11_PARSE (app, argc, argv);
  if (frames < 1 || width < 8 || height < 8)
  {
    std::fprintf (stderr, "make_idc_frames: --frames >= 1, --width and --height >= 8\n");
    return 2;
  }
  TriangleMesh object = makeTorus (0.3f, 0.1f, 128, 48);
  object.append (makeSphere (0.15f, 4));
  if (!mesh_file.empty () && pcl::io::savePLYFileBinary (mesh_file, toPolygonMesh (object)) < 0)
    return 1;
  const RayCaster caster (object);
  PinholeIntrinsics K;
  K.width = width;
  K.height = height;
  K.fx = K.fy = 525.f * width / 640.f;
  K.cx = (width - 1) / 2.f;
  K.cy = (height - 1) / 2.f;
  for (const auto& d : {pcd_dir, png_dir})
    if (!d.empty ())
      std::filesystem::create_directories (d);
  if (!png_dir.empty ())
    pclx::apps::writeIntrinsics (png_dir + "/camera-intrinsics.txt", pclx::apps::DepthIntrinsics{K.fx, K.fy, K.cx, K.cy});
  for (int f = 0; f < frames; ++f)
  {
    // Around the object, alternately above and below it, so the views cover it.
    const float a = 2.f * float (M_PI) * f / frames;
    const float h = (f % 2 ? -0.7f : 0.9f);
    const Eigen::Vector3f eye (1.1f * std::cos (a), 1.1f * std::sin (a), h);
    const Eigen::Isometry3f pose = lookAt (eye, Eigen::Vector3f::Zero ());
    const DepthImage depth = renderDepth (caster, K, pose, KinectNoise (), 100 + f);
    char name[64];
    if (!pcd_dir.empty ())
    {
      auto cloud = depthToCloud (depth, K);  // camera frame, as a sensor delivers it
      cloud.sensor_origin_ = Eigen::Vector4f (eye[0], eye[1], eye[2], 0.f);
      cloud.sensor_orientation_ = Eigen::Quaternionf (pose.rotation ());
      std::snprintf (name, sizeof name, "/frame_%04d.pcd", f);
      if (pcl::io::savePCDFileBinary (pcd_dir + name, cloud) != 0)
        return 1;
    }
    if (!png_dir.empty ())
    {
      std::snprintf (name, sizeof name, "/frame-%06d", f);
      pclx::apps::writeDepthPng (png_dir + name + ".depth.png",
                                 pclx::apps::DepthImage16{depth.width, depth.height, depth.depth_mm});
      pclx::apps::writePose (png_dir + name + ".pose.txt", pose.matrix ());
    }
  }
  std::printf ("wrote %d frames\n", frames);
  return 0;
}
