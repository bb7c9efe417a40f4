// idc_scan: posed depth frames become an adaptive mesh, updated frame by frame, with
// IncrementalDualContouring (da Paz 2017). Sources: a live OpenNI2 device or .oni file
// (--device, fixed pose: --pose), recorded frames through pcl::PCDGrabber / ImageGrabber
// (--pcd-dir / --image-dir: the pose comes from each frame's VIEWPOINT, or --poses-dir, or
// --pose), a 7-Scenes folder (--depth-dir: 16-bit PNG depth, .pose.txt, intrinsics) and the
// Stanford bunny's raw range scans with bun.conf (--bunny). The window shows the mesh growing;
// --output writes it (PLY), --screenshot renders it off-screen to a PNG.
#include <pclx/apps/cloud_loader.h>
#include <pclx/apps/depth_frames.h>
#include <pclx/apps/frame_source.h>
#include <pclx/apps/mesh_stats.h>
#include <pclx/apps/view.h>
#include <pclx/surface/incremental_dual_contouring.h>

#include <pcl/common/transforms.h>
#include <pcl/io/ply_io.h>

#include <CLI/CLI.hpp>
#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <sstream>
#include <thread>

namespace fs = std::filesystem;
using PointT = pcl::PointXYZ;
using Cloud = pcl::PointCloud<PointT>;

namespace {

struct Failure : std::runtime_error
{
  using std::runtime_error::runtime_error;
};

Eigen::Matrix4d
readPoseFile (const std::string& path)
{
  std::ifstream in (path);
  if (!in)
    throw Failure ("cannot read pose file " + path);
  Eigen::Matrix4d T;
  for (int i = 0; i < 16; ++i)
    if (!(in >> T (i / 4, i % 4)))
      throw Failure (path + ": a pose file holds 16 numbers (4 x 4 camera-to-world, row by row)");
  return T;
}

// The frame's VIEWPOINT (PCD header) as camera-to-world; identity when absent.
Eigen::Matrix4d
viewpointPose (const Cloud& c)
{
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity ();
  T.topLeftCorner<3, 3> () = c.sensor_orientation_.cast<double> ().toRotationMatrix ();
  T.topRightCorner<3, 1> () = c.sensor_origin_.head<3> ().cast<double> ();
  return T;
}

// bun.conf: "bmesh <file> tx ty tz qi qj qk qr" places the scan in the common frame.
struct BunnyScan
{
  std::string file;
  Eigen::Matrix4d pose;
};

std::vector<BunnyScan>
readBunnyConf (const std::string& dir)
{
  const std::string conf = dir + "/bun.conf";
  std::ifstream in (conf);
  if (!in)
    throw Failure ("no bun.conf in " + dir);
  std::vector<BunnyScan> scans;
  std::string line;
  while (std::getline (in, line))
  {
    std::istringstream ls (line);
    std::string tag, file;
    double t[3], q[4];
    if (!(ls >> tag) || tag != "bmesh")
      continue;
    if (!(ls >> file >> t[0] >> t[1] >> t[2] >> q[0] >> q[1] >> q[2] >> q[3]))
      throw Failure (conf + ": malformed line: " + line);
    BunnyScan s;
    s.file = dir + "/" + file;
    s.pose.setIdentity ();
    // world = Rᵀ p + t with R from (qi qj qk qr): checked against bun_zipper.ply (mean
    // distance 0.5 mm for every scan; R p + t is off by 1–13 cm for all but bun000 / bun180).
    s.pose.topLeftCorner<3, 3> () =
        Eigen::Quaterniond (q[3], q[0], q[1], q[2]).normalized ().toRotationMatrix ().transpose ();
    s.pose.topRightCorner<3, 1> () = Eigen::Vector3d (t[0], t[1], t[2]);
    scans.push_back (s);
  }
  if (scans.empty ())
    throw Failure (conf + " lists no bmesh scan");
  return scans;
}

// The Cyberware scanner looks at the object along −z of the scan frame; IncrementalDualContouring
// wants the camera at the origin looking along +z: a virtual camera 1 m up the z axis, turned
// 180° about x. Returns the scan's points in that camera frame and its camera-to-world.
Cloud::Ptr
bunnyFrame (const BunnyScan& s, Eigen::Matrix4d& camera_to_world)
{
  Cloud::Ptr scan (new Cloud);
  if (!fs::exists (s.file) || pcl::io::loadPLYFile (s.file, *scan) < 0 || scan->empty ())
    throw Failure ("cannot read the range scan " + s.file);
  if (scan->height <= 1)
    throw Failure (s.file + " has no range_grid (not an organized scan)");
  Eigen::Matrix4d cam_in_scan = Eigen::Matrix4d::Identity ();
  cam_in_scan.topLeftCorner<3, 3> () = Eigen::Vector3d (1, -1, -1).asDiagonal ();
  cam_in_scan (2, 3) = 1.0;
  Cloud::Ptr cam (new Cloud);
  pcl::transformPointCloud (*scan, *cam, Eigen::Matrix4f (cam_in_scan.inverse ().cast<float> ()), true);
  cam->width = scan->width;
  cam->height = scan->height;
  cam->is_dense = false;
  camera_to_world = s.pose * cam_in_scan;
  return cam;
}

struct Options
{
  pclx::apps::SourceOptions source;
  std::string bunny, pose_file, poses_dir, output, screenshot;
  double leaf = 0.01, epsilon = 0, cell_size = -1, max_hole_size = -1;  // max_hole_size < 0: the class's
  int cell_pixels = 0, min_cell_pixels = pcl::CoupledSimplification ().getMinCellPixels ();
  int max_frames = 0, width = 1024, height = 768, update_every = 1;
  bool plane_removal = false, no_window = false;
};

class Scanner
{
public:
  explicit Scanner (const Options& o) : opt_ (o)
  {
    idc_.setLeafSize (o.leaf);
    idc_.setSimplificationError (o.epsilon);
    idc_.setPlaneRemoval (o.plane_removal);
    if (o.max_hole_size >= 0)
      idc_.setMaxHoleSize (o.max_hole_size);
    // Front-end cells in metres (default two leaves) unless --cell-pixels fixes the block.
    if (o.cell_pixels > 0)
      idc_.getSimplification ().setFrustumCellPixels (o.cell_pixels);
    else
      idc_.getSimplification ().setFrustumCellSize (o.cell_size > 0 ? o.cell_size : 2 * o.leaf);
    idc_.getSimplification ().setMinCellPixels (o.min_cell_pixels);
    if (!o.pose_file.empty ())
      fixed_pose_ = readPoseFile (o.pose_file);
  }

  int
  run ()
  {
    const bool offscreen = !opt_.screenshot.empty ();
    if (!offscreen && !opt_.no_window)
      viewer_ = pclx::apps::makeVisualizer ("idc_scan", false, opt_.width, opt_.height);
    if (!opt_.bunny.empty ())
      runBunny ();
    else if (!opt_.source.depth_dir.empty ())
      runDepthDir ();
    else
      runSource ();
    if (fused_ == 0)
      throw Failure ("no frame could be fused" + (last_error_.empty () ? std::string () : ": " + last_error_));
    pcl::PolygonMesh mesh;
    idc_.reconstruct (mesh);
    const auto& s = idc_.getStats ();
    std::size_t boundary = 0, non_manifold = 0;
    pclx::apps::countOpenEdges (mesh, boundary, non_manifold);
    const auto& os = idc_.getOctree ().getStats ();
    std::printf ("done: %zu frames fused (%zu skipped); mesh %zu vertices, %zu triangles; %zu edges used once, "
                 "%zu used > 2 times%s; %zu holes closed; %zu leaves, %.1f MB\n",
                 fused_, skipped_, s.vertices, s.triangles, boundary, non_manifold,
                 boundary == 0 && non_manifold == 0 ? " (watertight)" : "", os.holes_filled, s.leaves,
                 s.memory_bytes / 1048576.0);
    if (!opt_.output.empty ())
    {
      if (pcl::io::savePLYFileBinary (opt_.output, mesh) < 0)
        throw Failure ("could not write " + opt_.output);
      std::printf ("wrote %s\n", opt_.output.c_str ());
    }
    if (mesh.polygons.empty ())
      throw Failure ("the mesh is empty");
    if (offscreen)
    {
      viewer_ = pclx::apps::makeVisualizer ("idc_scan", true, opt_.width, opt_.height);
      show (mesh);
      pclx::apps::saveScreenshot (*viewer_, opt_.screenshot);
      std::printf ("wrote %s\n", opt_.screenshot.c_str ());
    }
    else if (viewer_)
    {
      show (mesh);
      while (!viewer_->wasStopped ())
        viewer_->spinOnce (50);
    }
    return 0;
  }

private:
  bool
  stopRequested ()
  {
    if (opt_.max_frames > 0 && frame_ >= static_cast<std::size_t> (opt_.max_frames))
      return true;
    return viewer_ && opt_.screenshot.empty () && viewer_->wasStopped ();
  }

  // After every fused frame: a progress line and, on screen, the grown mesh.
  void
  after (bool ok, std::size_t total)
  {
    ++frame_;
    const auto& s = idc_.getStats ();
    if (ok)
    {
      ++fused_;
      std::printf ("frame %zu%s: %.1f ms (front end %.1f, octree %.1f), %zu frame triangles, %zu leaves, %.1f MB\n",
                   frame_ - 1, total ? ("/" + std::to_string (total)).c_str () : "", s.last_frame_ms,
                   s.last_frontend_ms, s.last_octree_ms, s.frame_triangles, s.leaves, s.memory_bytes / 1048576.0);
    }
    else
    {
      ++skipped_;
      last_error_ = idc_.getLastError ();
      std::printf ("frame %zu skipped: %s\n", frame_ - 1, last_error_.c_str ());
    }
    std::fflush (stdout);
    if (viewer_ && opt_.screenshot.empty () && ok && fused_ % std::max (1, opt_.update_every) == 0)
    {
      pcl::PolygonMesh mesh;
      idc_.reconstruct (mesh);
      show (mesh);
      viewer_->spinOnce (1);
    }
  }

  void
  show (const pcl::PolygonMesh& mesh)
  {
    pcl::visualization::PCLVisualizer& v = *viewer_;
    if (!shown_)
    {
      v.setBackgroundColor (0.1, 0.1, 0.12);
      v.addPolygonMesh (mesh, "mesh");
      pclx::apps::initCamera (v);
      // Look from the first camera (or the scan's side), slightly above it.
      const Eigen::Vector3d eye = first_pose_.topRightCorner<3, 1> ();
      const Eigen::Vector3d fwd = first_pose_.topLeftCorner<3, 3> ().col (2);
      const Eigen::Vector3d up = -first_pose_.topLeftCorner<3, 3> ().col (1);
      const Eigen::Vector3d at = eye + fwd;
      v.setCameraPosition (eye[0], eye[1], eye[2], at[0], at[1], at[2], up[0], up[1], up[2]);
      shown_ = true;
    }
    else
      v.updatePolygonMesh (mesh, "mesh");
    v.setPointCloudRenderingProperties (pcl::visualization::PCL_VISUALIZER_COLOR, 0.82, 0.8, 0.76, "mesh");
    pclx::apps::frameViewport (v, 0, 0.05, {"mesh"});
  }

  bool
  fuseCloud (const Cloud& cloud, const Eigen::Matrix4d& pose)
  {
    if (frame_ == 0)
      first_pose_ = pose;
    return idc_.addFrame (cloud, pose);
  }

  void
  runBunny ()
  {
    const auto scans = readBunnyConf (opt_.bunny);
    std::printf ("%s: %zu range scans (bun.conf poses)\n", opt_.bunny.c_str (), scans.size ());
    for (const auto& s : scans)
    {
      if (stopRequested ())
        break;
      Eigen::Matrix4d pose;
      const Cloud::Ptr cam = bunnyFrame (s, pose);
      after (fuseCloud (*cam, pose), scans.size ());
    }
  }

  void
  runDepthDir ()
  {
    pclx::apps::DepthFrameFolder folder (opt_.source.depth_dir);
    const auto& k = folder.intrinsics ();
    const pcl::DepthIntrinsics K{k.fx, k.fy, k.cx, k.cy};
    std::printf ("%s: %zu depth frames, fx %.1f fy %.1f cx %.1f cy %.1f\n", opt_.source.depth_dir.c_str (),
                 folder.size (), K.fx, K.fy, K.cx, K.cy);
    for (std::size_t i = 0; i < folder.size () && !stopRequested (); ++i)
    {
      Eigen::Matrix4f pf;
      Eigen::Matrix4d pose = fixed_pose_;
      if (folder.pose (i, pf))
        pose = pf.cast<double> ();
      else if (opt_.pose_file.empty ())
        throw Failure (folder.framePath (i) + " has no .pose.txt (give --pose for a fixed camera)");
      const pclx::apps::DepthImage16 d = pclx::apps::readDepthPng (folder.framePath (i));
      if (frame_ == 0)
        first_pose_ = pose;
      after (idc_.addFrame (d.mm.data (), d.width, d.height, K, pose, 0.001f), folder.size ());
    }
  }

  // Files, PCDGrabber, ImageGrabber and OpenNI2: one pcl::Grabber callback path.
  void
  runSource ()
  {
    pclx::apps::FrameSource<PointT> source (opt_.source);
    std::printf ("%s\n", source.description ().c_str ());
    source.start ([this] (const Cloud::ConstPtr& c) {
      std::lock_guard<std::mutex> lock (mutex_);
      pending_.push_back (c);
    });
    const bool offscreen = !opt_.screenshot.empty ();
    std::size_t index = 0;
    while (!stopRequested ())
    {
      Cloud::ConstPtr frame;
      bool drained;
      {
        std::lock_guard<std::mutex> lock (mutex_);
        if (!pending_.empty ())
        {
          // A live window keeps up with the device: only the newest frame.
          if (source.live () && !offscreen)
            pending_.erase (pending_.begin (), pending_.end () - 1);
          frame = pending_.front ();
          pending_.pop_front ();
        }
        drained = pending_.empty ();
      }
      if (frame)
      {
        after (fuseCloud (*frame, poseOf (*frame, index++)), source.expected ());
        continue;
      }
      if (drained && source.finished ())
        break;
      source.check ();
      if (viewer_ && !offscreen)
        viewer_->spinOnce (10);
      else
        std::this_thread::sleep_for (std::chrono::milliseconds (5));
    }
    source.stop ();
  }

  // --poses-dir (frame-NNNNNN.pose.txt by arrival index), else the frame's VIEWPOINT when it
  // is not the identity, else --pose (or the identity).
  Eigen::Matrix4d
  poseOf (const Cloud& c, std::size_t index) const
  {
    if (!opt_.poses_dir.empty ())
    {
      char name[64];
      std::snprintf (name, sizeof name, "/frame-%06zu.pose.txt", index);
      return readPoseFile (opt_.poses_dir + name);
    }
    const Eigen::Matrix4d vp = viewpointPose (c);
    if (!vp.isIdentity (1e-9))
      return vp;
    return fixed_pose_;
  }

  Options opt_;
  pcl::IncrementalDualContouring<PointT> idc_;
  pcl::visualization::PCLVisualizer::Ptr viewer_;
  Eigen::Matrix4d fixed_pose_ = Eigen::Matrix4d::Identity (), first_pose_ = Eigen::Matrix4d::Identity ();
  std::mutex mutex_;
  std::deque<Cloud::ConstPtr> pending_;
  std::size_t frame_ = 0, fused_ = 0, skipped_ = 0;
  std::string last_error_;
  bool shown_ = false;
};

}  // namespace

int
main (int argc, char** argv)
{
  CLI::App app ("Incremental dual contouring: posed depth frames become an adaptive mesh, frame by frame");
  Options o;
  pclx::apps::addSourceOptions (app, o.source);
  app.get_option_group ("source")
      ->add_option ("--bunny", o.bunny, "the Stanford bunny's raw range scans: a folder with bun.conf and the .ply scans");
  app.add_option ("--pose", o.pose_file, "fixed camera-to-world (4 x 4 text) for a live device or frames without a pose");
  app.add_option ("--poses-dir", o.poses_dir, "grabber frames: frame-NNNNNN.pose.txt per frame, by arrival order");
  app.add_option ("--leaf", o.leaf, "detail: octree leaf size in metres")->capture_default_str ();
  app.add_option ("--epsilon", o.epsilon, "octree simplification error (0: off)")->capture_default_str ();
  app.add_option ("--cell-size", o.cell_size, "front end: frustum cell side in metres at the median range (default 2 x leaf)");
  app.add_option ("--cell-pixels", o.cell_pixels, "front end: fixed frustum cell side in pixels (0: from --cell-size)")
      ->capture_default_str ();
  app.add_option ("--min-cell-pixels", o.min_cell_pixels,
                  "front end: fewest pixels per cell side before 2 x 2 block averaging (0: every pixel)")
      ->capture_default_str ();
  app.add_option ("--max-hole-size", o.max_hole_size,
                  "close holes up to this box diagonal in metres (0: none; default 10 leaves)");
  app.add_flag ("--remove-plane", o.plane_removal, "cut away the dominant plane (RANSAC) to isolate an object");
  app.add_option ("--frames", o.max_frames, "stop after this many frames (0: all)")->capture_default_str ();
  app.add_option ("--update-every", o.update_every, "on screen: re-polygonise every N frames")->capture_default_str ();
  app.add_option ("-o,--output", o.output, "write the final mesh as binary PLY");
  app.add_option ("--screenshot", o.screenshot, "render the final mesh off-screen to this PNG (no window)");
  app.add_flag ("--no-window", o.no_window, "no VTK window: fuse, report and write --output");
  app.add_option ("--width", o.width, "window and screenshot width in pixels")->capture_default_str ();
  app.add_option ("--height", o.height, "window and screenshot height in pixels")->capture_default_str ();
  CLI11_PARSE (app, argc, argv);
  pclx::apps::finishSourceOptions (app, o.source);
  const bool hole_size_set = app.count ("--max-hole-size") > 0;
  if (!(o.leaf > 0) || o.epsilon < 0 || o.cell_pixels < 0 || o.min_cell_pixels < 0 ||
      (hole_size_set && !(o.max_hole_size >= 0 && std::isfinite (o.max_hole_size))))
  {
    std::cerr << "idc_scan: --leaf must be > 0, --epsilon, --cell-pixels, --min-cell-pixels and --max-hole-size >= 0\n";
    return 2;
  }
  try
  {
    Scanner scanner (o);
    return scanner.run ();
  }
  catch (const std::exception& e)  // LoadError, SourceError, Failure: one line, exit 1
  {
    std::string msg = e.what ();
    std::replace (msg.begin (), msg.end (), '\n', ' ');
    std::cerr << "idc_scan: " << msg << "\n";
    return 1;
  }
}
