// pclx_pipeline: the modules wired together on a stream of depth frames, as the design card
// asks. Each frame goes through
//   1. PCL's PassThrough (depth range, organized) and VoxelGrid,
//   2. HPRFilter from the camera (or from a second viewpoint beside it),
//   3. PlanarOctreeNormalEstimation with MST orientation,
//   4. IncrementalDualContouring across the posed frames, or RBFPOUReconstruction per keyframe,
//   5. ObliqueCutOctree over the accumulated visible points, drawn from its front,
// each switchable, with one VTK viewport per stage and per-stage timings per frame and at exit.
// Frames come from any pclx::apps::FrameSource (a file, PCD / image / 7-Scenes folders, an
// OpenNI2 device); a frame's pose is its sensor origin and orientation (PCD VIEWPOINT, 7-Scenes
// pose files), the identity when it has none.
#include <pclx/apps/frame_source.h>
#include <pclx/apps/view.h>
#include <pclx/hpr/hpr_filter.h>
#include <pclx/normals/mst_normal_orientation.h>
#include <pclx/normals/planar_octree_normal_estimation.h>
#include <pclx/omicron/camera.h>
#include <pclx/omicron/oblique_cut_octree.h>
#include <pclx/omicron/potree_writer.h>
#include <pclx/surface/incremental_dual_contouring.h>
#include <pclx/surface/rbf_pou_reconstruction.h>

#include <pcl/common/io.h>
#include <pcl/common/transforms.h>
#include <pcl/filters/passthrough.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>

#include <vtkCamera.h>
#include <vtkRenderer.h>
#include <vtkRendererCollection.h>

#include <CLI/CLI.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <thread>

using Point = pcl::PointXYZ;
using Cloud = pcl::PointCloud<Point>;
using Clock = std::chrono::steady_clock;

namespace {

enum Stage
{
  kFilter,
  kHpr,
  kNormals,
  kSurface,
  kOctree,
  kStages
};
const std::array<const char*, kStages> kStageNames{"filter", "hpr", "normals", "surface", "octree"};

struct Options
{
  pclx::apps::SourceOptions source;
  bool filter = true, hpr = true, normals = true, octree = true;
  std::string surface = "idc";  // idc, rbf or none
  float z_min = 0.1f, z_max = 6.f, voxel = 0.02f;
  std::vector<float> hpr_offset{0.f, 0.f, 0.f};  // a second viewpoint, in the camera frame
  double idc_leaf = 0.02;
  int keyframe = 0, octree_every = 5, frames = 0, width = 1500, height = 900;  // keyframe 0: IDC 1, RBF 10
  float map_voxel = 0.01f;
  std::string screenshot, output, timings;
};

double
msSince (Clock::time_point t0)
{
  return std::chrono::duration<double, std::milli> (Clock::now () - t0).count ();
}

// Camera-to-world of a frame: its sensor origin and orientation.
Eigen::Matrix4d
framePose (const Cloud& c)
{
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity ();
  pose.topLeftCorner<3, 3> () = c.sensor_orientation_.toRotationMatrix ().cast<double> ();
  pose.topRightCorner<3, 1> () = c.sensor_origin_.head<3> ().cast<double> ();
  return pose;
}

// What one frame produced, for display and --output.
struct FrameResult
{
  Cloud::Ptr input, filtered, visible, hidden;
  pcl::PointCloud<pcl::PointNormal>::Ptr oriented;
  pcl::PolygonMesh::Ptr mesh;
  Cloud::Ptr front;  // the octree front's points
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity ();
};

class Pipeline
{
public:
  explicit Pipeline (const Options& o) : opt_ (o)
  {
    idc_.setLeafSize (o.idc_leaf);
    idc_.setGrowVolume (true);
    idc_.setDepthRange (o.z_min, o.z_max);
  }

  // Throws pclx::apps::LoadError / SourceError (bad input, a device that stops).
  int
  run ()
  {
    pclx::apps::FrameSource<Point> source (opt_.source);
    std::printf ("%s\n", source.description ().c_str ());
    const bool offscreen = !opt_.screenshot.empty ();
    source.start ([this] (const Cloud::ConstPtr& c) {
      std::lock_guard<std::mutex> lock (mutex_);
      pending_.push_back (c);
    });
    makeWindow (offscreen);
    std::size_t processed = 0;
    while (opt_.frames <= 0 || processed < static_cast<std::size_t> (opt_.frames))
    {
      // Off-screen runs process every frame; a live window only the newest one.
      Cloud::ConstPtr frame;
      bool drained;
      {
        std::lock_guard<std::mutex> lock (mutex_);
        if (!pending_.empty () && !offscreen)
          pending_.erase (pending_.begin (), pending_.end () - 1);
        if (!pending_.empty ())
        {
          frame = pending_.front ();
          pending_.pop_front ();
        }
        drained = pending_.empty ();
      }
      if (frame)
        show (process (*frame, processed++));
      if (!frame && drained && source.finished ())
        break;
      source.check ();
      if (offscreen)
        std::this_thread::sleep_for (std::chrono::milliseconds (frame ? 0 : 5));
      else
      {
        if (viewer_->wasStopped ())
          break;
        viewer_->spinOnce (10);
      }
    }
    source.stop ();
    if (processed == 0)
      throw std::runtime_error ("no frame arrived");
    summary ();
    if (!opt_.output.empty ())
      writeOutputs ();
    if (offscreen)
    {
      pclx::apps::saveScreenshot (*viewer_, opt_.screenshot);
      std::printf ("wrote %s\n", opt_.screenshot.c_str ());
    }
    return 0;
  }

private:
  FrameResult
  process (const Cloud& frame, std::size_t index)
  {
    FrameResult r;
    std::array<double, kStages> ms{};
    r.pose = framePose (frame);
    r.input.reset (new Cloud (frame));
    r.input->sensor_origin_.setZero ();
    r.input->sensor_orientation_.setIdentity ();
    auto t = Clock::now ();
    r.filtered = filterStage (r.input, r.visible);
    ms[kFilter] = msSince (t);
    t = Clock::now ();
    hprStage (r);
    ms[kHpr] = opt_.hpr ? msSince (t) : 0;
    t = Clock::now ();
    if (opt_.normals)
    {
      r.oriented = normalsStage (*r.visible);
      ms[kNormals] = msSince (t);
    }
    t = Clock::now ();
    r.mesh = surfaceStage (r, index);
    ms[kSurface] = opt_.surface == "none" ? 0 : msSince (t);
    t = Clock::now ();
    if (opt_.octree)
    {
      r.front = octreeStage (r, index);
      ms[kOctree] = msSince (t);
    }
    double total = 0;
    std::printf ("frame %zu:", index);
    for (int s = 0; s < kStages; ++s)
    {
      total += ms[s];
      std::printf (" %s %.1f ms,", kStageNames[s], ms[s]);
    }
    const auto finite = [] (const Cloud& c) {
      return std::count_if (c.begin (), c.end (), [] (const Point& p) { return pcl::isFinite (p); });
    };
    std::printf (" total %.1f ms; %ld points, %ld after the depth range, %zu after the voxel grid and HPR, %zu mesh "
                 "triangles, %zu in the map\n",
                 total, finite (*r.input), finite (*r.filtered), r.visible->size (),
                 r.mesh ? r.mesh->polygons.size () : 0, map_ ? map_->size () : 0);
    times_.push_back (ms);
    last_ = r;
    return r;
  }

  // PassThrough on depth, organized (NaN where cut, for IDC), then VoxelGrid for the others.
  Cloud::Ptr
  filterStage (const Cloud::Ptr& input, Cloud::Ptr& sparse)
  {
    Cloud::Ptr organized (new Cloud);
    sparse.reset (new Cloud);
    if (!opt_.filter)
    {
      *organized = *input;
      pcl::Indices finite;
      for (std::size_t i = 0; i < input->size (); ++i)
        if (pcl::isFinite ((*input)[i]))
          finite.push_back (static_cast<pcl::index_t> (i));
      pcl::copyPointCloud (*input, finite, *sparse);
      return organized;
    }
    pcl::PassThrough<Point> pass (true);  // removed indices kept, as an organized result needs
    pass.setInputCloud (input);
    pass.setFilterFieldName ("z");
    pass.setFilterLimits (opt_.z_min, opt_.z_max);
    pass.setKeepOrganized (input->isOrganized ());
    pass.filter (*organized);
    pcl::VoxelGrid<Point> grid;
    grid.setInputCloud (organized);
    grid.setLeafSize (opt_.voxel, opt_.voxel, opt_.voxel);
    grid.filter (*sparse);
    return organized;
  }

  // Visible and hidden points seen from the camera (plus --hpr-viewpoint); all visible when off.
  void
  hprStage (FrameResult& r)
  {
    r.hidden.reset (new Cloud);
    if (!opt_.hpr || r.visible->size () < 4)
      return;
    pcl::HPRFilter<Point> hpr (true);
    hpr.setInputCloud (r.visible);
    hpr.setViewPoint (Eigen::Vector3f (opt_.hpr_offset[0], opt_.hpr_offset[1], opt_.hpr_offset[2]));
    pcl::Indices visible;
    hpr.filter (visible);
    Cloud::Ptr seen (new Cloud);
    pcl::copyPointCloud (*r.visible, visible, *seen);
    pcl::copyPointCloud (*r.visible, *hpr.getRemovedIndices (), *r.hidden);
    r.visible = seen;
  }

  // Normals, MST-oriented, then turned towards the camera where most of them face away.
  pcl::PointCloud<pcl::PointNormal>::Ptr
  normalsStage (const Cloud& visible)
  {
    pcl::PointCloud<pcl::PointNormal>::Ptr out (new pcl::PointCloud<pcl::PointNormal>);
    if (visible.size () < 20)
      return out;
    Cloud::Ptr in (new Cloud (visible));
    pcl::PointCloud<pcl::Normal> normals;
    pcl::PlanarOctreeNormalEstimation<Point, pcl::Normal> ne;
    ne.setInputCloud (in);
    ne.compute (normals);
    pcl::MSTNormalOrientation<Point, pcl::Normal> mst;
    mst.setInputCloud (in);
    if (!mst.orient (normals))
      return out;
    std::size_t away = 0, valid = 0;
    for (std::size_t i = 0; i < normals.size (); ++i)
      if (std::isfinite (normals[i].normal_x))
      {
        ++valid;
        away += normals[i].getNormalVector3fMap ().dot (-in->points[i].getVector3fMap ()) < 0 ? 1 : 0;
      }
    const float sign = 2 * away > valid ? -1.f : 1.f;
    for (auto& n : normals)
      n.getNormalVector3fMap () *= sign;
    pcl::concatenateFields (*in, normals, *out);
    return out;
  }

  // On keyframes only (every frame for IDC by default, every 10th for RBF-POU): IDC fuses the
  // organized frame and remeshes, RBF-POU reconstructs the oriented visible points.
  pcl::PolygonMesh::Ptr
  surfaceStage (const FrameResult& r, std::size_t index)
  {
    const std::size_t every = opt_.keyframe > 0 ? opt_.keyframe : (opt_.surface == "rbf" ? 10 : 1);
    if (index % every != 0)
      return mesh_;
    if (opt_.surface == "idc" && r.filtered->isOrganized ())
    {
      if (!idc_.addFrame (*r.filtered, r.pose))
        std::printf ("  IDC refused the frame: %s\n", idc_.getLastError ().c_str ());
      mesh_.reset (new pcl::PolygonMesh);
      idc_.reconstruct (*mesh_);
    }
    else if (opt_.surface == "rbf" && r.oriented)
    {
      pcl::PointCloud<pcl::PointNormal>::Ptr world (new pcl::PointCloud<pcl::PointNormal>);
      pcl::transformPointCloudWithNormals (*r.oriented, *world, r.pose.cast<float> ());
      pcl::RBFPOUReconstruction<pcl::PointNormal> rbf;
      rbf.setInputCloud (world);
      mesh_.reset (new pcl::PolygonMesh);
      rbf.reconstruct (*mesh_);
    }
    return mesh_;
  }

  // Visible points into the world map (VoxelGrid-thinned); the octree is rebuilt every
  // --octree-every frames and its front evaluated from the frame's camera.
  Cloud::Ptr
  octreeStage (const FrameResult& r, std::size_t index)
  {
    Cloud world;
    pcl::transformPointCloud (*r.visible, world, r.pose.cast<float> ());
    if (!map_)
      map_.reset (new Cloud);
    *map_ += world;
    if (index % static_cast<std::size_t> (opt_.octree_every) != 0 && front_)
      return front_;
    pcl::VoxelGrid<Point> grid;
    grid.setInputCloud (map_);
    grid.setLeafSize (opt_.map_voxel, opt_.map_voxel, opt_.map_voxel);
    Cloud::Ptr thinned (new Cloud);
    grid.filter (*thinned);
    map_ = thinned;
    octree_.reset (new pcl::ObliqueCutOctree<Point>);
    octree_->setInputCloud (map_);
    front_.reset (new Cloud);
    if (map_->empty () || !octree_->build ())
      return front_;
    const Eigen::Vector3f eye = r.pose.topRightCorner<3, 1> ().cast<float> ();
    const Eigen::Vector3f ahead = eye + r.pose.topLeftCorner<3, 3> ().col (2).cast<float> ();
    pcl::ObliqueCutOctree<Point>::Camera camera;
    camera.width = opt_.width / 3;
    camera.height = opt_.height / 2;
    camera.view_projection = pcl::perspectiveLookAt (eye, ahead, 1.0f, float (camera.width) / camera.height,
                                                              0.05f, 100.f);
    std::vector<pcl::ObliqueCutOctree<Point>::Item> items;
    octree_->evaluate (camera, items);
    for (const auto& item : items)
      front_->insert (front_->end (), item.points, item.points + item.num_points);
    return front_;
  }

  void
  makeWindow (bool offscreen)
  {
    offscreen_ = offscreen;
    viewer_ = pclx::apps::makeVisualizer ("pclx_pipeline", offscreen, opt_.width, opt_.height);
    for (int i = 0; i < 6; ++i)
    {
      const double x = (i % 3) / 3.0, y = i < 3 ? 0.5 : 0.0;
      viewer_->createViewPort (x, y, x + 1 / 3.0, y + 0.5, viewports_[i]);
      viewer_->setBackgroundColor (0.08 + 0.02 * (i % 2), 0.08, 0.1, viewports_[i]);
    }
    // PCLVisualizer's viewports share one camera; each stage needs its own.
    auto renderers = viewer_->getRendererCollection ();
    renderers->InitTraversal ();
    int index = 0;
    while (vtkRenderer* r = renderers->GetNextItem ())
      if (index++ > 0)
        r->SetActiveCamera (vtkSmartPointer<vtkCamera>::New ());
  }

  template <typename CloudPtr>
  void
  addPoints (const CloudPtr& cloud, const std::string& id, int vp, double r, double g, double b)
  {
    if (!cloud || cloud->empty ())
      return;
    using P = typename CloudPtr::element_type::PointType;
    pcl::visualization::PointCloudColorHandlerCustom<P> colour (cloud, r * 255, g * 255, b * 255);
    viewer_->addPointCloud<P> (cloud, colour, id, vp);
    viewer_->setPointCloudRenderingProperties (pcl::visualization::PCL_VISUALIZER_POINT_SIZE, 2, id);
  }

  // Each stage in its viewport; cameras placed once, from the first frame with content.
  void
  show (const FrameResult& r)
  {
    viewer_->removeAllPointClouds ();
    viewer_->removeAllShapes ();
    if (has_mesh_)
      viewer_->removePolygonMesh ("mesh");
    has_mesh_ = r.mesh && !r.mesh->polygons.empty ();
    addPoints (r.input, "input", viewports_[0], 0.6, 0.6, 0.65);
    addPoints (r.visible, "visible", viewports_[1], 1.0, 0.75, 0.35);
    addPoints (r.hidden, "hidden", viewports_[1], 0.35, 0.35, 0.4);
    if (r.oriented && !r.oriented->empty ())
    {
      viewer_->addPointCloud<pcl::PointNormal> (r.oriented, "oriented", viewports_[2]);
      viewer_->addPointCloudNormals<pcl::PointNormal> (r.oriented, 4, 2 * opt_.voxel, "normals", viewports_[2]);
    }
    if (has_mesh_)
      viewer_->addPolygonMesh (*r.mesh, "mesh", viewports_[3]);
    addPoints (r.front, "front", viewports_[4], 0.45, 0.8, 1.0);
    const std::string surface = opt_.surface == "rbf" ? "4 RBF-POU (keyframes)" : "4 incremental dual contouring";
    const std::array<std::string, 5> labels{
        "1 input frame", std::string ("2 depth range + voxel grid") + (opt_.hpr ? " + HPR: visible / hidden" : ""),
        opt_.normals ? "3 normals (MST-oriented)" : "3 normals (off)", opt_.surface == "none" ? "4 surface (off)" : surface,
        opt_.octree ? "5 OMiCroN front over the map" : "5 octree (off)"};
    for (int i = 0; i < 5; ++i)
      viewer_->addText (labels[i], 10, 10, 14, 1, 1, 1, "label" + std::to_string (i), viewports_[i]);
    viewer_->addText (timingText (), 10, 10, 14, 1, 1, 1, "timings", viewports_[5]);
    // Off-screen, every frame is framed; in a window only until the user has something to
    // look at (then the mouse owns the cameras).
    if (!cameras_placed_ || offscreen_)
      placeCameras (r);
    auto renderers = viewer_->getRendererCollection ();
    renderers->InitTraversal ();
    while (vtkRenderer* ren = renderers->GetNextItem ())
      ren->ResetCameraClippingRange ();
  }

  // Sensor-frame stages look along the camera (y down); world stages from the first pose.
  void
  placeCameras (const FrameResult& r)
  {
    if (r.input->empty ())
      return;
    for (int i = 0; i < 3; ++i)
    {
      viewer_->setCameraPosition (0, 0, -0.5, 0, 0, 1, 0, -1, 0, viewports_[i]);
      pclx::apps::frameViewport (*viewer_, viewports_[i]);
    }
    const Eigen::Vector3d eye = r.pose.topRightCorner<3, 1> ();
    const Eigen::Vector3d ahead = eye + r.pose.topLeftCorner<3, 3> ().col (2);
    const Eigen::Vector3d up = -r.pose.topLeftCorner<3, 3> ().col (1);
    for (int i = 3; i < 5; ++i)
    {
      viewer_->setCameraPosition (eye.x (), eye.y (), eye.z (), ahead.x (), ahead.y (), ahead.z (), up.x (), up.y (),
                                  up.z (), viewports_[i]);
      pclx::apps::frameViewport (*viewer_, viewports_[i]);
    }
    cameras_placed_ = r.mesh && !r.mesh->polygons.empty ();
  }

  // Mean ms per stage so far, and their sum.
  std::string
  timingText () const
  {
    std::string s = "per frame (mean of " + std::to_string (times_.size ()) + "):\n";
    double total = 0;
    for (int k = 0; k < kStages; ++k)
    {
      double sum = 0;
      for (const auto& t : times_)
        sum += t[k];
      const double mean = times_.empty () ? 0 : sum / times_.size ();
      total += mean;
      char line[96];
      std::snprintf (line, sizeof line, "  %-8s %7.1f ms\n", kStageNames[k], mean);
      s += line;
    }
    char line[96];
    std::snprintf (line, sizeof line, "  total    %7.1f ms", total);
    return s + line;
  }

  // Per-stage p50 / p95 / mean at exit, the slowest stage, and --timings as CSV.
  void
  summary () const
  {
    std::printf ("stage timings over %zu frames (ms): stage, mean, p50, p95\n", times_.size ());
    double slowest = -1, total = 0;
    int slow = 0;
    for (int k = 0; k < kStages; ++k)
    {
      std::vector<double> v;
      for (const auto& t : times_)
        v.push_back (t[k]);
      std::sort (v.begin (), v.end ());
      double mean = 0;
      for (double x : v)
        mean += x / v.size ();
      total += mean;
      std::printf ("  %-8s %8.1f %8.1f %8.1f\n", kStageNames[k], mean, v[v.size () / 2], v[v.size () * 95 / 100]);
      if (mean > slowest)
        slowest = mean, slow = k;
    }
    std::printf ("total %.1f ms per frame (%.1f fps); slowest stage: %s\n", total, total > 0 ? 1000 / total : 0.0,
                 kStageNames[slow]);
    if (opt_.timings.empty ())
      return;
    std::ofstream csv (opt_.timings);
    csv << "frame";
    for (const char* n : kStageNames)
      csv << ',' << n << "_ms";
    csv << '\n';
    for (std::size_t f = 0; f < times_.size (); ++f)
    {
      csv << f;
      for (double t : times_[f])
        csv << ',' << t;
      csv << '\n';
    }
  }

  // Each stage's result of the last frame: PCD, PLY and a Potree folder.
  void
  writeOutputs () const
  {
    namespace fs = std::filesystem;
    fs::create_directories (opt_.output);
    const auto pcd = [&] (const auto& cloud, const std::string& name) {
      if (cloud && !cloud->empty ())
        pcl::io::savePCDFileBinary (opt_.output + "/" + name, *cloud);
    };
    pcd (last_.filtered, "filtered.pcd");
    pcd (last_.visible, "visible.pcd");
    pcd (last_.oriented, "normals.pcd");
    pcd (map_, "map.pcd");
    if (last_.mesh && !last_.mesh->polygons.empty ())
      pcl::io::savePLYFileBinary (opt_.output + "/surface.ply", *last_.mesh);
    if (octree_ && octree_->getRoot ())
    {
      pcl::PotreeWriter<Point> writer;
      if (!writer.write (*octree_, opt_.output + "/potree"))
        throw std::runtime_error (writer.getLastError ());
    }
    std::printf ("wrote the last frame's stages to %s\n", opt_.output.c_str ());
  }

  Options opt_;
  std::mutex mutex_;
  std::deque<Cloud::ConstPtr> pending_;
  pcl::visualization::PCLVisualizer::Ptr viewer_;
  std::array<int, 6> viewports_{};
  bool offscreen_ = false, cameras_placed_ = false, has_mesh_ = false;
  pcl::IncrementalDualContouring<Point> idc_;
  pcl::PolygonMesh::Ptr mesh_;
  Cloud::Ptr map_, front_;
  std::unique_ptr<pcl::ObliqueCutOctree<Point>> octree_;
  std::vector<std::array<double, kStages>> times_;
  FrameResult last_;
};

}  // namespace

int
main (int argc, char** argv)
{
  Options o;
  CLI::App app ("pclx_pipeline: depth frames through PassThrough / VoxelGrid, HPR, normals, a surface and an "
                "OMiCroN octree, one viewport per stage");
  pclx::apps::addSourceOptions (app, o.source);
  app.add_flag ("--filter,!--no-filter", o.filter, "PassThrough on depth and VoxelGrid (default on)");
  app.add_flag ("--hpr,!--no-hpr", o.hpr, "hidden point removal from the camera (default on)");
  app.add_flag ("--normals,!--no-normals", o.normals, "normals with MST orientation (default on)");
  app.add_flag ("--octree,!--no-octree", o.octree, "OMiCroN octree over the map (default on)");
  app.add_option ("--surface", o.surface, "idc (every frame), rbf (keyframes) or none")
      ->check (CLI::IsMember ({"idc", "rbf", "none"}))
      ->capture_default_str ();
  app.add_option ("--z-min", o.z_min, "PassThrough: nearest depth kept (m)")->capture_default_str ();
  app.add_option ("--z-max", o.z_max, "PassThrough: farthest depth kept (m)")->capture_default_str ();
  app.add_option ("--voxel", o.voxel, "VoxelGrid leaf before HPR and normals (m)")->capture_default_str ();
  app.add_option ("--hpr-viewpoint", o.hpr_offset, "HPR viewpoint in the camera frame (x y z)")->expected (3);
  app.add_option ("--idc-leaf", o.idc_leaf, "IDC leaf size (m)")->capture_default_str ();
  app.add_option ("--keyframe", o.keyframe, "the surface stage on every N-th frame (0: IDC every frame, RBF-POU every 10th)")
      ->check (CLI::NonNegativeNumber)
      ->capture_default_str ();
  app.add_option ("--octree-every", o.octree_every, "rebuild the octree every N frames")
      ->check (CLI::PositiveNumber)
      ->capture_default_str ();
  app.add_option ("--map-voxel", o.map_voxel, "VoxelGrid leaf of the accumulated map (m)")->capture_default_str ();
  app.add_option ("--frames", o.frames, "stop after N frames (0: all)")->capture_default_str ();
  app.add_option ("--screenshot", o.screenshot, "render off-screen, save this PNG after the last frame and exit");
  app.add_option ("--width", o.width, "window and screenshot width")->capture_default_str ();
  app.add_option ("--height", o.height, "window and screenshot height")->capture_default_str ();
  app.add_option ("-o,--output", o.output, "write each stage's result of the last frame (PCD, PLY, Potree) here");
  app.add_option ("--timings", o.timings, "write the per-frame stage times (CSV)");
  CLI11_PARSE (app, argc, argv);
  pclx::apps::finishSourceOptions (app, o.source);
  try
  {
    Pipeline pipeline (o);
    return pipeline.run ();
  }
  catch (const std::exception& e)
  {
    std::fprintf (stderr, "pclx_pipeline: %s\n", e.what ());
    return 1;
  }
}
