// hpr_viewer: hidden point removal on a PCD/PLY/XYZ file, on recorded frames (PCDGrabber,
// ImageGrabber, 7-Scenes depth PNGs) or live from an OpenNI2 device, shown in a VTK window.
//
// Every source (pclx::apps::FrameSource) feeds the same callback, onCloud(). Left viewport:
// what the observer at the viewpoint sees (visible points, optionally the partial
// mesh). Right viewport: the scene from the side, visible points coloured, hidden ones
// grey, the viewpoint as a red sphere. Move the camera of the left viewport with the
// mouse: HPR is recomputed from the new camera position when the mouse rests.
#include <pclx/apps/cloud_loader.h>
#include <pclx/apps/frame_source.h>
#include <pclx/apps/view.h>
#include <pclx/hpr/hpr_filter.h>

#include <pcl/common/centroid.h>
#include <pcl/common/common.h>
#include <pcl/io/pcd_io.h>

#include <vtkCamera.h>
#include <vtkRenderer.h>
#include <vtkRendererCollection.h>

#include <CLI/CLI.hpp>

#include <chrono>
#include <deque>
#include <mutex>
#include <thread>

using PointT = pcl::PointXYZRGBA;
using Cloud = pcl::PointCloud<PointT>;
using Filter = pcl::HPRFilter<PointT>;

namespace {

struct Options
{
  pclx::apps::SourceOptions source;
  std::string screenshot, output, method = "auto";
  bool mesh = false, show_hidden = true;
  int frames = 1, width = 1280, height = 640;
  double gamma = 0, radius = 0, occlusion = 0.05;
  std::size_t k = 0;
  int steps = 0;
  std::vector<float> viewpoint, view_dir, up;
};

Filter::Method
parseMethod (const std::string& m)
{
  static const std::map<std::string, Filter::Method> names{
      {"auto", Filter::Method::AUTO},         {"exact", Filter::Method::EXACT},
      {"grid", Filter::Method::ANGULAR_GRID}, {"candidate_hull", Filter::Method::CANDIDATE_HULL},
      {"bfp", Filter::Method::BENTLEY_FAUST_PREPARATA}, {"kavan", Filter::Method::KAVAN},
      {"hybrid", Filter::Method::HYBRID}};
  return names.at (m);
}

std::string
methodName (Filter::Method m)
{
  switch (m)
  {
  case Filter::Method::EXACT: return "exact";
  case Filter::Method::ANGULAR_GRID: return "grid";
  case Filter::Method::CANDIDATE_HULL: return "candidate_hull";
  case Filter::Method::BENTLEY_FAUST_PREPARATA: return "bfp";
  case Filter::Method::KAVAN: return "kavan";
  case Filter::Method::HYBRID: return "hybrid";
  default: return "auto";
  }
}

class HprViewer
{
public:
  explicit HprViewer (const Options& o) : opt_ (o) {}

  // The one callback every source calls (pcl::Grabber signature).
  void
  onCloud (const Cloud::ConstPtr& cloud)
  {
    std::lock_guard<std::mutex> lock (mutex_);
    pending_.push_back (cloud);
  }

  // Throws pclx::apps::LoadError / SourceError (bad input, a device that stops).
  int
  run ()
  {
    pclx::apps::FrameSource<PointT> source (opt_.source);
    std::cout << source.description () << std::endl;
    source.start ([this] (const Cloud::ConstPtr& c) { onCloud (c); });
    const bool offscreen = !opt_.screenshot.empty ();
    viewer_ = pclx::apps::makeVisualizer ("hpr_viewer", offscreen, opt_.width, opt_.height);
    viewer_->createViewPort (0.0, 0.0, 0.5, 1.0, left_);
    viewer_->createViewPort (0.5, 0.0, 1.0, 1.0, right_);
    // PCLVisualizer's viewports share one camera; the side view needs its own.
    {
      auto renderers = viewer_->getRendererCollection ();
      renderers->InitTraversal ();
      int index = 0;
      while (vtkRenderer* r = renderers->GetNextItem ())
        if (index++ > 0)
          r->SetActiveCamera (vtkSmartPointer<vtkCamera>::New ());
    }
    viewer_->setBackgroundColor (0.08, 0.08, 0.1, left_);
    viewer_->setBackgroundColor (0.12, 0.12, 0.14, right_);

    int processed = 0;
    auto last_move = std::chrono::steady_clock::now ();
    Eigen::Vector3f last_cam = Eigen::Vector3f::Constant (std::numeric_limits<float>::quiet_NaN ());
    while (true)
    {
      // Off-screen runs process every frame; a live window only the newest one.
      Cloud::ConstPtr frame;
      {
        std::lock_guard<std::mutex> lock (mutex_);
        if (!pending_.empty ())
        {
          if (!offscreen)
            pending_.erase (pending_.begin (), pending_.end () - 1);
          frame = pending_.front ();
          pending_.pop_front ();
        }
      }
      if (frame)
      {
        process (frame, processed++);
        if (offscreen && processed >= opt_.frames)
          break;
      }
      if (offscreen)
      {
        bool drained;
        {
          std::lock_guard<std::mutex> lock (mutex_);
          drained = pending_.empty ();
        }
        if (!frame && drained && source.finished ())
          break;
        source.check ();  // a stalled device or replay ends the run with its message
        std::this_thread::sleep_for (std::chrono::milliseconds (5));
        continue;
      }
      if (viewer_->wasStopped ())
        break;
      if (!source.finished ())
        source.check ();
      viewer_->spinOnce (30);
      // A moved camera (left viewport) becomes the new viewpoint once the mouse rests.
      if (current_)
      {
        const Eigen::Vector3f cam = leftCamera ();
        if (!(cam - last_cam).isZero (1e-6f))
        {
          last_cam = cam;
          last_move = std::chrono::steady_clock::now ();
        }
        else if ((cam - placed_camera_).norm () > 1e-3f * diag_ &&
                 std::chrono::steady_clock::now () - last_move > std::chrono::milliseconds (300))
        {
          viewpoint_ = cam;
          user_moved_ = true;
          process (current_, processed++);
        }
      }
    }
    source.stop ();
    if (processed == 0)
      throw std::runtime_error ("no frame arrived");
    if (offscreen)
    {
      pclx::apps::saveScreenshot (*viewer_, opt_.screenshot);
      std::cout << "wrote " << opt_.screenshot << std::endl;
    }
    return 0;
  }

private:
  Eigen::Vector3f
  leftCamera ()
  {
    double p[3];
    pclx::apps::viewportRenderer (*viewer_, left_)->GetActiveCamera ()->GetPosition (p);
    return Eigen::Vector3d (p[0], p[1], p[2]).cast<float> ();
  }

  void
  chooseViewpoint (const Cloud& cloud)
  {
    Eigen::Vector4f c, mn, mx;
    pcl::compute3DCentroid (cloud, c);
    pcl::getMinMax3D (cloud, mn, mx);
    centre_ = c.head<3> ();
    diag_ = (mx - mn).head<3> ().norm ();
    // Sensor frames (organized, camera looking along +z) are seen from the sensor's side.
    up_ = cloud.isOrganized () ? Eigen::Vector3f (0, -1, 0) : Eigen::Vector3f (0, 1, 0);
    if (opt_.up.size () == 3)
      up_ = Eigen::Vector3f (opt_.up[0], opt_.up[1], opt_.up[2]).normalized ();
    if (user_moved_)
      return;
    if (opt_.viewpoint.size () == 3)
      viewpoint_ = Eigen::Vector3f (opt_.viewpoint[0], opt_.viewpoint[1], opt_.viewpoint[2]);
    else if (opt_.view_dir.size () == 3)
      viewpoint_ = centre_ + 2.0f * diag_ * Eigen::Vector3f (opt_.view_dir[0], opt_.view_dir[1], opt_.view_dir[2]).normalized ();
    else if (cloud.isOrganized ())
      // A sensor frame is fully visible from the sensor: step aside so occlusions show.
      viewpoint_ = 0.3f * centre_.norm () * Eigen::Vector3f (1.f, -0.4f, 0.f);
    else
      viewpoint_ = centre_ + 2.0f * diag_ * Eigen::Vector3f (0.4f, 0.3f, 1.f).normalized ();
  }

  void
  process (const Cloud::ConstPtr& cloud, int index)
  {
    current_ = cloud;
    chooseViewpoint (*cloud);
    Filter hpr (true);
    hpr.setInputCloud (cloud);
    hpr.setViewPoint (viewpoint_);
    hpr.setMethod (parseMethod (opt_.method));
    if (opt_.radius > 0)
      hpr.setRadius (opt_.radius);
    else if (opt_.gamma > 0)
      hpr.setGamma (opt_.gamma);
    else
      hpr.setAutoRadius (opt_.occlusion);
    hpr.setSectorCount (opt_.k);
    if (opt_.steps > 0)
      hpr.setPropagation (Filter::Propagation::ADAPTIVE, opt_.steps);
    hpr.setReconstructMesh (opt_.mesh);
    pcl::Indices visible;
    const auto t0 = std::chrono::steady_clock::now ();
    hpr.filter (visible);
    const double ms = std::chrono::duration<double, std::milli> (std::chrono::steady_clock::now () - t0).count ();
    std::size_t finite = 0;
    for (const auto& p : *cloud)
      finite += pcl::isFinite (p);
    std::cout << "frame " << index << ": " << finite << " points, " << visible.size () << " visible ("
              << (finite ? 100.0 * visible.size () / finite : 0.0) << " %), method " << methodName (hpr.getMethodUsed ())
              << ", R " << hpr.getRadiusUsed () << ", k " << hpr.getSectorCountUsed () << ", " << ms << " ms"
              << ", viewpoint " << viewpoint_.transpose () << ", centre " << centre_.transpose () << std::endl;

    Cloud::Ptr vis (new Cloud), hidden (new Cloud);
    pcl::copyPointCloud (*cloud, visible, *vis);
    pcl::copyPointCloud (*cloud, *hpr.getRemovedIndices (), *hidden);
    // HPR works in the cloud's own coordinates; PCLVisualizer would apply the PCD
    // VIEWPOINT (sensor pose) on top, e.g. PCL's Kinect frames carry a 180° turn.
    for (Cloud* c : {vis.get (), hidden.get ()})
    {
      c->sensor_origin_.setZero ();
      c->sensor_orientation_.setIdentity ();
    }
    if (!opt_.output.empty () && !vis->empty ())
      pcl::io::savePCDFileBinary (opt_.output, *vis);

    viewer_->removeAllPointClouds ();
    viewer_->removeAllShapes ();
    pcl::visualization::PointCloudColorHandlerCustom<PointT> warm (vis, 255, 190, 90), grey (hidden, 90, 90, 95);
    // The observer's view in the cloud's own colours when it has any.
    const bool coloured = std::any_of (vis->begin (), vis->end (), [] (const PointT& p) { return p.rgba & 0xffffff; });
    if (coloured)
      viewer_->addPointCloud<PointT> (vis, pcl::visualization::PointCloudColorHandlerRGBField<PointT> (vis),
                                      "visible_left", left_);
    else
      viewer_->addPointCloud<PointT> (vis, warm, "visible_left", left_);
    viewer_->addPointCloud<PointT> (vis, warm, "visible_right", right_);
    if (opt_.show_hidden)
      viewer_->addPointCloud<PointT> (hidden, grey, "hidden_right", right_);
    for (const char* id : {"visible_left", "visible_right", "hidden_right"})
      viewer_->setPointCloudRenderingProperties (pcl::visualization::PCL_VISUALIZER_POINT_SIZE, 2, id);
    if (opt_.mesh && !hpr.getMesh ().polygons.empty ())
      viewer_->addPolygonMesh (hpr.getMesh (), "mesh", left_);
    const float size = std::max (0.01f * diag_, 1e-6f);
    const pcl::PointXYZ vp (viewpoint_.x (), viewpoint_.y (), viewpoint_.z ());
    viewer_->addSphere (vp, size, 1.0, 0.2, 0.2, "viewpoint", right_);
    viewer_->addLine (pcl::PointXYZ (centre_.x (), centre_.y (), centre_.z ()), vp, 1.0, 0.2, 0.2, "to_viewpoint", right_);
    viewer_->addText ("seen from the viewpoint: " + std::to_string (visible.size ()) + " visible points", 10, 10,
                      14, 1, 1, 1, "label_left", left_);
    viewer_->addText ("from the side: visible (orange), hidden (grey), red: towards the viewpoint", 10, 10, 14, 1, 1, 1,
                      "label_right", right_);
    if (!user_moved_)
    {
      viewer_->setCameraPosition (viewpoint_.x (), viewpoint_.y (), viewpoint_.z (), centre_.x (), centre_.y (),
                                  centre_.z (), up_.x (), up_.y (), up_.z (), left_);
      // The side view: 90° around the up axis from the viewpoint, farther out.
      const Eigen::Vector3f to_vp = viewpoint_ - centre_;
      const Eigen::Vector3f side =
          centre_ + Eigen::AngleAxisf (float (M_PI / 3), up_) * to_vp * 1.3f;
      viewer_->setCameraFieldOfView (0.9, left_);  // ~52°, about a depth camera's field of view
      viewer_->setCameraPosition (side.x (), side.y (), side.z (), centre_.x (), centre_.y (), centre_.z (),
                                  up_.x (), up_.y (), up_.z (), right_);
      // Both views keep their direction and move in until the points fill them; the
      // viewpoint may lie outside the side view, a red line points to it.
      pclx::apps::frameViewport (*viewer_, left_);
      pclx::apps::frameViewport (*viewer_, right_, 0.05, {"visible_right", "hidden_right"});
      placed_camera_ = leftCamera ();
    }
    // setCameraPosition keeps the old near/far planes: fit them to the new scene.
    auto renderers = viewer_->getRendererCollection ();
    renderers->InitTraversal ();
    while (vtkRenderer* r = renderers->GetNextItem ())
      r->ResetCameraClippingRange ();
  }

  Options opt_;
  std::mutex mutex_;
  std::deque<Cloud::ConstPtr> pending_;
  Cloud::ConstPtr current_;
  pcl::visualization::PCLVisualizer::Ptr viewer_;
  int left_ = 0, right_ = 0;
  // placed_camera_: where process() put the left camera; the user moved it when it differs.
  Eigen::Vector3f placed_camera_ = Eigen::Vector3f::Zero ();
  Eigen::Vector3f viewpoint_ = Eigen::Vector3f::Zero (), centre_ = Eigen::Vector3f::Zero (), up_ = Eigen::Vector3f::UnitY ();
  float diag_ = 1.f;
  bool user_moved_ = false;
};

}  // namespace

int
main (int argc, char** argv)
{
  Options o;
  CLI::App app ("hpr_viewer: hidden point removal (pcl::HPRFilter) on files, recorded frames or an OpenNI2 device");
  pclx::apps::addSourceOptions (app, o.source);
  app.add_option ("--frames", o.frames, "with --screenshot: frames to process before saving")->capture_default_str ();
  app.add_option ("-m,--method", o.method, "auto, exact, grid, candidate_hull, bfp, kavan, hybrid")
      ->check (CLI::IsMember ({"auto", "exact", "grid", "candidate_hull", "bfp", "kavan", "hybrid"}))
      ->capture_default_str ();
  app.add_option ("--gamma", o.gamma, "R = max|p - C| * 10^gamma (default: calibrated R)");
  app.add_option ("--radius", o.radius, "absolute flip radius R");
  app.add_option ("--occlusion", o.occlusion, "calibrated R: occlusion depth / cloud radius")->capture_default_str ();
  app.add_option ("-k,--sectors", o.k, "angular grid size k (0: calibrated)")->capture_default_str ();
  app.add_option ("--steps", o.steps, "adaptive propagation steps (0: calibrated)")->capture_default_str ();
  app.add_option ("--viewpoint", o.viewpoint, "x y z (default: 2 diagonals from the centre)")->expected (3);
  app.add_option ("--view-dir", o.view_dir, "x y z: direction from the centre to the default viewpoint")->expected (3);
  app.add_option ("--up", o.up, "x y z: the cameras' up direction (default: +y, -y for sensor frames)")->expected (3);
  app.add_flag ("--mesh", o.mesh, "also show the partial view-dependent triangulation");
  app.add_option ("--screenshot", o.screenshot, "render off-screen, save this PNG and exit");
  app.add_option ("--width", o.width, "window and screenshot width in pixels")->capture_default_str ();
  app.add_option ("--height", o.height, "window and screenshot height in pixels")->capture_default_str ();
  app.add_option ("-o,--output", o.output, "save the visible points of the last frame (.pcd)");
  CLI11_PARSE (app, argc, argv);
  pclx::apps::finishSourceOptions (app, o.source);
  try
  {
    HprViewer viewer (o);
    return viewer.run ();
  }
  catch (const std::exception& e)
  {
    std::cerr << "hpr_viewer: " << e.what () << "\n";
    return 1;
  }
}
