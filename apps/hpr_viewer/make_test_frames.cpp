// Writes organized depth frames of a generated scene as PCD files (sensor frame, y down),
// the way pcl::PCDGrabber replays recorded Kinect sequences. Used by the viewer test.
#include <pclx/testing/depth_renderer.h>
#include <pclx/testing/shapes.h>

#include <pcl/io/pcd_io.h>

#include <CLI/CLI.hpp>

#include <cstdio>

using namespace pclx::testing;

int
main (int argc, char** argv)
{
  CLI::App app ("Render organized test frames of a torus-and-sphere scene to PCD files");
  std::string dir = ".";
  int frames = 3, width = 320, height = 240;
  app.add_option ("--dir", dir, "output folder")->capture_default_str ();
  app.add_option ("--frames", frames, "number of frames")->capture_default_str ();
  app.add_option ("--width", width)->capture_default_str ();
  app.add_option ("--height", height)->capture_default_str ();
  CLI11_PARSE (app, argc, argv);

  TriangleMesh scene = makeTorus (0.3f, 0.1f, 128, 48);
  scene.append (makeSphere (0.12f, 4, Eigen::Vector3f (0, 0, 0.05f)));
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
  for (int f = 0; f < frames; ++f)
  {
    const float a = 0.15f * f;
    const Eigen::Vector3f eye (1.2f * std::sin (a), -1.2f * std::cos (a), 0.9f);
    const Eigen::Isometry3f pose = lookAt (eye, Eigen::Vector3f::Zero ());
    const DepthImage depth = renderDepth (caster, K, pose, KinectNoise (), 10 + f);
    const auto cloud = depthToCloud (depth, K);  // camera frame, as a sensor delivers it
    char name[64];
    std::snprintf (name, sizeof name, "/frame_%04d.pcd", f);
    if (pcl::io::savePCDFileBinary (dir + name, cloud) != 0)
      return 1;
  }
  std::printf ("wrote %d frames to %s\n", frames, dir.c_str ());
  return 0;
}
