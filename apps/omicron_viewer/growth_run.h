#pragma once
// omicron_viewer's run: the octree configured from the options, the build started, the front
// rendered (or evaluated headless) every frame while the hierarchy grows, then the statistics
// and the outputs.
#include "viewer_input.h"
#include "viewer_options.h"

#include <pclx/apps/bounds_camera.h>
#include <pclx/apps/process_stats.h>
#include <pclx/apps/progress.h>
#include <pclx/apps/splat_renderer.h>
#include <pclx/apps/view.h>
#include <pclx/omicron/oblique_cut_octree.h>
#include <pclx/omicron/potree_writer.h>

#include <pcl/console/print.h>

#include <vtkCamera.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace omicron_viewer {

using Clock = std::chrono::steady_clock;
using pclx::apps::formatMb;
using pclx::apps::secondsSince;
using pclx::apps::SplatColouring;

/** \brief The window (none with --no-render) and the camera the front is evaluated for. */
struct View
{
  pcl::visualization::PCLVisualizer::Ptr viewer;
  vtkRenderer* renderer = nullptr;
  vtkSmartPointer<vtkCamera> camera;
};

/** \brief The window and its camera, or (--no-render) a camera alone.
  * \param[in] opt the options (size, --no-render)
  * \param[in] offscreen render off-screen (screenshots) rather than in a window
  * \return the view
  */
inline View
makeView (const Options& opt, bool offscreen)
{
  View v;
  if (opt.no_render)
  {
    v.camera = vtkSmartPointer<vtkCamera>::New ();
    return v;
  }
  v.viewer = pclx::apps::makeVisualizer ("omicron_viewer", offscreen, opt.width, opt.height);
  v.viewer->setBackgroundColor (0.07, 0.07, 0.09);
  v.renderer = pclx::apps::viewportRenderer (*v.viewer, 0);
  v.camera = v.renderer->GetActiveCamera ();
  v.viewer->addText ("building: 0 % of points in the hierarchy, front 0 nodes", 12, 12, 16, 0.92, 0.92, 0.92,
                     "progress");
  return v;
}

/** \brief What the render loop measured. */
struct FrameLog
{
  std::vector<double> frame_ms, eval_ms;  // frames during the build, from the first with splats
  double first_items_s = -1, build_s = -1;
  int frame = 0, shots = 0, last_shot = -1;
};

/** \brief One run of the viewer: the octree configured from the options, the build started,
  * the front rendered (or evaluated headless) every frame until the build is done and the
  * front rests, then the statistics and the outputs.
  */
template <typename PointT>
class GrowthRun
{
public:
  using Octree = pcl::ObliqueCutOctree<PointT>;  ///< the hierarchy

  /** \brief A run of `opt` (which must outlive it) on `in`.
    * \param[in] opt the options
    * \param[in] in the input (a loaded cloud, or the file the octree reads itself)
    */
  GrowthRun (const Options& opt, Input<PointT> in)
    : opt_ (opt), in_ (std::move (in)), offscreen_ (!opt.screenshot.empty () || opt.screenshot_every > 0),
      frames_run_ (!opt.no_render || opt.orbit),
      threads_ (opt.threads > 0 ? opt.threads : std::max (1, int (std::thread::hardware_concurrency ()))),
      up_f_ (opt.up[0], opt.up[1], opt.up[2]),
      view_dir_ (Eigen::Vector3f (opt.view_dir[0], opt.view_dir[1], opt.view_dir[2]).cast<double> ()),
      up_ (up_f_.cast<double> ())
  {}

  /** \brief Runs the stages in order; prints to stdout, progress to stderr.
    * \return the exit code (0)
    * \throw std::exception when the build or an output fails
    */
  int
  run ()
  {
    if (in_.file.empty ())
      std::printf ("%s, read in %.2f s\n", in_.summary.c_str (), in_.seconds);
    else
      std::printf ("%s\n", in_.summary.c_str ());
    configureOctree ();
    mode_ = colourMode ();
    if (!(up_f_.norm () > 0) || !up_f_.allFinite ())
      throw std::invalid_argument ("--up must be a non-zero direction");
    setUpView ();
    // A build that reads the file itself meets the file's errors (e.g. no finite point): they
    // come back through getLastError () as the app's one error line, so PCL's own copy of
    // them is silenced while the build runs.
    const pcl::console::VERBOSITY_LEVEL verbosity = pcl::console::getVerbosityLevel ();
    if (!in_.file.empty ())
      pcl::console::setVerbosityLevel (pcl::console::L_ALWAYS);
    startBuild ();
    growLoop ();
    const bool built = octree_.wait ();
    pcl::console::setVerbosityLevel (verbosity);
    if (!built)
      throw std::runtime_error (octree_.getLastError ().empty () ? "the build failed" : octree_.getLastError ());
    if (log_.build_s < 0)
      log_.build_s = secondsSince (t0_);
    printStatistics ();
    writeOutputs ();
    return 0;
  }

private:
  // A memory budget: the octree builds out of core and writes the Potree folder itself.
  bool budgeted () const { return opt_.budget_mb > 0; }
  void configureOctree ();
  SplatColouring::Mode colourMode () const;
  void setUpView ();
  void frameCamera ();
  void startBuild ();
  void growLoop ();
  void trackBuild (bool building);
  void frameInputBounds ();
  bool renderFrame (bool building, Clock::time_point f0, double& eval_ms, bool& stopped);
  void updateLabel (bool building);
  void recordFrame (bool building, double f_ms, double e_ms);
  void printStatistics () const;
  void writeOutputs ();

  std::string
  shotName (int k) const
  {
    char b[24];
    std::snprintf (b, sizeof b, "_%04d.png", k);
    return opt_.growth_prefix + b;
  }

  const Options& opt_;
  Input<PointT> in_;
  const bool offscreen_, frames_run_;  // frames_run_: a render loop, real or simulated
  const int threads_;
  const Eigen::Vector3f up_f_;
  const Eigen::Vector3d view_dir_, up_;
  Octree octree_;
  SplatColouring::Mode mode_ = SplatColouring::Mode::HEIGHT;
  // Bounds: from the loaded cloud, or (file read by the octree) the root cube once it has read
  // the file; camera framing and height colours wait for them.
  Eigen::Vector3f lo_, hi_;
  bool framed_ = false;
  SplatColouring colour_{SplatColouring::Mode::HEIGHT, Eigen::Vector3f::UnitZ (), Eigen::Vector3f::Zero (),
                         Eigen::Vector3f::Zero ()};
  View view_;
  Eigen::Vector3d centre_, start_eye_;  // the framed camera: the orbit's centre and start
  std::unique_ptr<pclx::apps::SplatRenderer> splats_;
  std::vector<typename Octree::Item> items_;
  FrameLog log_;
  std::string label_;
  Clock::time_point t0_;
  std::unique_ptr<pclx::apps::Progress> progress_;
};

template <typename PointT>
void
GrowthRun<PointT>::configureOctree ()
{
  if (in_.file.empty ())
    octree_.setInputCloud (in_.cloud);
  else
  {
    // The octree reads the file in blocks. Out of core (a budget), subtrees below its spill
    // level go to the Potree folder as they are finished (the front stops at that level).
    octree_.setInputFile (in_.file);
    if (budgeted ())
    {
      octree_.setMemoryBudget (static_cast<std::size_t> (opt_.budget_mb * 1048576.0));
      if (!opt_.output.empty ())
        octree_.setOutputDirectory (opt_.output);
    }
  }
  octree_.setMaxDepth (opt_.depth);
  octree_.setParentPointRatio (opt_.ratio);
  octree_.setLeafCollapse (opt_.collapse);
  octree_.setWorklistSize (opt_.worklist);
  octree_.setSortChunks (opt_.chunks);
  octree_.setThreads (threads_);
  // Headless without an orbit nothing evaluates the front, so the build does not feed it.
  octree_.setFrontDuringBuild (frames_run_);
  octree_.setProjectionThreshold (opt_.threshold);
  octree_.setLeafSplatRadius (opt_.leaf_radius);
  // Default: one factor 1/sqrt(ratio) per level, the growth of the point spacing on a surface
  // when a parent keeps `ratio` of its children's points. The library's default factors
  // (da Silva 2018, Table 4.5) suit EWA splats; on opaque discs they mostly add overdraw.
  octree_.setSplatMultipliers (opt_.multipliers.empty () ? std::vector<float>{1.f / std::sqrt (opt_.ratio)}
                                                         : opt_.multipliers);
}

template <typename PointT>
SplatColouring::Mode
GrowthRun<PointT>::colourMode () const
{
  SplatColouring::Mode mode = SplatColouring::Mode::HEIGHT;
  if (opt_.color == "level")
    mode = SplatColouring::Mode::LEVEL;
  else if (opt_.color == "rgb" || (opt_.color == "auto" && in_.color))
    mode = SplatColouring::Mode::RGB;
  if (mode == SplatColouring::Mode::RGB && !in_.color)
  {
    std::cerr << "omicron_viewer: the cloud has no colour; colouring by height\n";
    mode = SplatColouring::Mode::HEIGHT;
  }
  return mode;
}

// The bounds, the colours, the window and the camera framed on the bounds, the splats.
template <typename PointT>
void
GrowthRun<PointT>::setUpView ()
{
  lo_ = in_.lo;
  hi_ = in_.hi;
  framed_ = (lo_.array () <= hi_.array ()).all ();
  if (!framed_)
    lo_ = hi_ = Eigen::Vector3f::Zero ();
  colour_ = SplatColouring (mode_, up_f_, lo_, hi_);
  view_ = makeView (opt_, offscreen_);
  if (framed_)
    frameCamera ();
  splats_ = std::make_unique<pclx::apps::SplatRenderer> (view_.renderer, opt_.draw == "nodes");
}

template <typename PointT>
void
GrowthRun<PointT>::frameCamera ()
{
  pclx::apps::frameBounds (*view_.camera, double (opt_.width) / opt_.height, lo_, hi_, view_dir_, up_);
  pclx::apps::clipToBounds (*view_.camera, lo_, hi_);
  view_.camera->GetFocalPoint (centre_.data ());
  view_.camera->GetPosition (start_eye_.data ());
}

template <typename PointT>
void
GrowthRun<PointT>::startBuild ()
{
  // The first render creates the GL context and compiles shaders (a noticeable pause with a
  // software renderer): done before the build so it is not the first frame of the growth.
  if (view_.viewer)
  {
    if (offscreen_)
      view_.viewer->getRenderWindow ()->Render ();
    else
      view_.viewer->spinOnce (1, true);
  }
  std::printf ("building: depth %d, parent ratio %.2f, leaf collapse %s, worklist %zu, sort chunks %zu, %d threads, "
               "projection threshold %.2f\n",
               opt_.depth, opt_.ratio, opt_.collapse ? "on" : "off", opt_.worklist, opt_.chunks, threads_,
               opt_.threshold);
  std::fflush (stdout);
  t0_ = Clock::now ();
  if (!octree_.startBuild ())
    throw std::runtime_error ("the build did not start");
  progress_ = std::make_unique<pclx::apps::Progress> ("building the hierarchy", 100);
}

// Frames until the build is done and the front rests (off-screen, headless) or the window is
// closed; without frames (--no-render alone) just the wait for the build.
template <typename PointT>
void
GrowthRun<PointT>::growLoop ()
{
  int stable = 0;
  while (true)
  {
    const bool building = !octree_.isFinished ();
    trackBuild (building);
    if (!frames_run_)
    {
      if (!building)
        break;
      std::this_thread::sleep_for (std::chrono::milliseconds (20));
      continue;
    }
    if (!framed_ && octree_.getFront ().secondsToFirstLeaf () >= 0)
      frameInputBounds ();
    const auto f0 = Clock::now ();
    double e_ms = 0;
    bool stopped = false;
    const bool changed = renderFrame (building, f0, e_ms, stopped);
    const double f_ms = 1e3 * secondsSince (f0);
    recordFrame (building, f_ms, e_ms);
    if (stopped)
      break;
    // After the build: the front still branches one level per evaluation; once it rests,
    // an off-screen or headless run ends, a window waits for the user.
    if (!building)
    {
      stable = changed ? 0 : stable + 1;
      if ((offscreen_ || opt_.no_render) && (stable >= 1 || log_.frame > 400))
        break;
      if (!offscreen_ && !opt_.no_render && !changed)
        std::this_thread::sleep_for (std::chrono::milliseconds (10));
    }
    else if (f_ms < 16.7)  // about a display's 60 Hz
      std::this_thread::sleep_for (std::chrono::duration<double, std::milli> (16.7 - f_ms));
  }
}

// The terminal's progress line while building; the build time once it is done.
template <typename PointT>
void
GrowthRun<PointT>::trackBuild (bool building)
{
  if (building)
    progress_->update (static_cast<std::size_t> (100.0 * octree_.getProgress ()));
  else if (log_.build_s < 0)
  {
    log_.build_s = octree_.getStatistics ().seconds_total;
    progress_->done ();
  }
}

// The octree read the file: its bounds of the input points (the root cube when a cube was
// given), known once it has read the file.
template <typename PointT>
void
GrowthRun<PointT>::frameInputBounds ()
{
  if (!octree_.getInputBounds (lo_, hi_))
  {
    lo_ = octree_.getRootOrigin ().template cast<float> ();
    hi_ = lo_ + Eigen::Vector3f::Constant (static_cast<float> (octree_.getRootEdge ()));
  }
  colour_ = SplatColouring (mode_, up_f_, lo_, hi_);
  frameCamera ();
  framed_ = true;
}

// One frame: camera -> front -> splats -> picture. Returns whether the splats changed.
template <typename PointT>
bool
GrowthRun<PointT>::renderFrame (bool building, Clock::time_point f0, double& eval_ms, bool& stopped)
{
  if (opt_.orbit && building)  // then the front settles for the final picture
    pclx::apps::orbitCamera (*view_.camera, centre_, start_eye_, up_, secondsSince (t0_), opt_.orbit_seconds);
  pclx::apps::clipToBounds (*view_.camera, lo_, hi_);
  typename Octree::Camera camera;
  camera.width = opt_.width;
  camera.height = opt_.height;
  camera.view_projection = pclx::apps::viewProjection (*view_.camera, opt_.width, opt_.height);
  octree_.evaluate (camera, items_);
  eval_ms = 1e3 * secondsSince (f0);
  const bool changed = splats_->update (items_, colour_);
  if (view_.viewer)
  {
    updateLabel (building);
    if (offscreen_)
      view_.viewer->getRenderWindow ()->Render ();
    else
    {
      view_.viewer->spinOnce (1, true);
      stopped = view_.viewer->wasStopped ();
    }
  }
  return changed;
}

template <typename PointT>
void
GrowthRun<PointT>::updateLabel (bool building)
{
  char text[160];
  if (building)
    std::snprintf (text, sizeof text, "building%s: %.0f %% of points in the hierarchy, front %zu nodes",
                   budgeted () ? " out of core" : "", 100.0 * octree_.getProgress (), items_.size ());
  else
    std::snprintf (text, sizeof text, "built: %zu points in %.2f s, front %zu nodes",
                   octree_.getStatistics ().kept_points, log_.build_s, items_.size ());
  if (label_ != text)
  {
    label_ = text;
    view_.viewer->updateText (label_, 12, 12, 16, 0.92, 0.92, 0.92, "progress");
  }
}

// Frame times (during the build, from the first frame with splats) and growth pictures.
template <typename PointT>
void
GrowthRun<PointT>::recordFrame (bool building, double f_ms, double e_ms)
{
  if (!items_.empty () && log_.first_items_s < 0)
    log_.first_items_s = secondsSince (t0_);
  if (building && log_.first_items_s >= 0)
  {
    log_.frame_ms.push_back (f_ms);
    log_.eval_ms.push_back (e_ms);
  }
  if (log_.first_items_s >= 0)
    ++log_.frame;
  if (view_.viewer && opt_.screenshot_every > 0 && log_.first_items_s >= 0 &&
      (log_.frame - 1) % opt_.screenshot_every == 0)
  {
    pclx::apps::saveScreenshot (*view_.viewer, shotName (log_.shots++));
    log_.last_shot = log_.frame;
  }
}

// What the build did: stage times, nodes and points per level, memory, frame times.
template <typename PointT>
void
GrowthRun<PointT>::printStatistics () const
{
  const auto st = octree_.getStatistics ();
  if (in_.file.empty ())
    std::printf ("read: file %.2f s, ", in_.seconds);
  else
    std::printf ("read (streamed by the octree): ");
  std::printf ("octree bounds and bucket passes %.3f s; first chunk sorted in %.3f s (%zu chunks)\n", st.seconds_read,
               st.seconds_to_first_chunk - st.seconds_read, st.chunks);
  std::printf ("first renderable front: %.3f s after the build started", st.seconds_to_first_front);
  if (log_.first_items_s >= 0 && frames_run_)
    std::printf (" (first splats drawn at %.3f s)", log_.first_items_s);
  std::printf ("; hierarchy complete: %.3f s\n", st.seconds_total);
  const std::vector<float> radii = octree_.getSplatRadii ();
  std::printf ("%6s %10s %12s %10s %12s\n", "level", "nodes", "points", "leaves", "splat radius");
  std::size_t nodes = 0, pts = 0;
  for (std::size_t l = 0; l < st.nodes_per_level.size (); ++l)
  {
    std::printf ("%6zu %10zu %12zu %10zu %12.4g\n", l, st.nodes_per_level[l], st.points_per_level[l],
                 st.leaves_per_level[l], l < radii.size () ? radii[l] : 0.f);
    nodes += st.nodes_per_level[l];
    pts += st.points_per_level[l];
  }
  std::printf ("%6s %10zu %12zu   (%zu input points kept, %zu NaN/Inf dropped)\n", "all", nodes, pts, st.kept_points,
               st.dropped_invalid);
  std::printf ("memory: sorted points %s, hierarchy %s; peak resident (VmHWM) %s\n",
               formatMb (st.sorted_bytes).c_str (), formatMb (st.hierarchy_bytes).c_str (),
               formatMb (pclx::apps::peakResidentBytes ()).c_str ());
  if (st.memory_budget)
    std::printf ("memory budget %s: accounted peak %s (planned %s); spill level %d, %zu nodes / %zu points written out "
                 "and dropped; chunk file pass %.2f s\n",
                 formatMb (st.memory_budget).c_str (), formatMb (st.accounted_peak_bytes).c_str (),
                 formatMb (st.planned_peak_bytes).c_str (), st.spill_level, st.spilled_nodes, st.spilled_points,
                 st.seconds_chunks);
  if (frames_run_)
  {
    const pclx::apps::Percentiles f = pclx::apps::percentiles (log_.frame_ms),
                                  e = pclx::apps::percentiles (log_.eval_ms);
    std::printf ("%s frames during the build: %zu, frame time p50 %.1f ms, p95 %.1f ms, max %.1f ms (front "
                 "evaluation p50 %.2f ms, p95 %.2f ms); front now %zu nodes\n",
                 opt_.no_render ? "simulated (evaluate + splat arrays)" : "rendered", f.n, f.p50, f.p95, f.max, e.p50,
                 e.p95, items_.size ());
  }
}

// The final picture, the last growth picture, the Potree files.
template <typename PointT>
void
GrowthRun<PointT>::writeOutputs ()
{
  if (view_.viewer && !opt_.screenshot.empty ())
  {
    pclx::apps::saveScreenshot (*view_.viewer, opt_.screenshot);
    std::printf ("wrote %s\n", opt_.screenshot.c_str ());
  }
  if (log_.shots > 0)
  {
    if (log_.last_shot != log_.frame)  // the final front as the last picture of the series
      pclx::apps::saveScreenshot (*view_.viewer, shotName (log_.shots++));
    std::printf ("wrote %d growth pictures %s ... %s\n", log_.shots, shotName (0).c_str (),
                 shotName (log_.shots - 1).c_str ());
  }
  if (budgeted ())
    std::printf ("Potree 2.0 files written by the build to %s%s\n", octree_.getOutputDirectory ().c_str (),
                 opt_.output.empty () ? " (temporary: removed on exit; give --output to keep them)" : "");
  else if (!opt_.output.empty ())
  {
    const auto w0 = Clock::now ();
    pcl::PotreeWriter<PointT> writer;
    if (!writer.write (octree_, opt_.output))
      throw std::runtime_error (writer.getLastError ());
    std::printf ("wrote Potree 2.0 files to %s (metadata.json, hierarchy.bin, octree.bin) in %.2f s\n",
                 opt_.output.c_str (), secondsSince (w0));
  }
}

}  // namespace omicron_viewer
