// omicron_viewer: opens a point cloud (PCD / PLY / XYZ), starts building the OMiCroN
// hierarchy (pcl::ObliqueCutOctree) at once and renders its front as splats while it grows.
//
// Every frame the render loop hands the current VTK camera (view-projection and viewport) to
// ObliqueCutOctree::evaluate (the front of da Silva 2018, OMiCroN), and draws the returned
// nodes' points as splats (pclx::apps::SplatRenderer): one disc per point, of the node level's
// splat radius (leaf radius times the per-level multipliers). The mouse moves the camera, and
// the front follows it on the next frame. A text line and the terminal report how much of the
// input is in the hierarchy.
//
// Off-screen (--screenshot, --screenshot-every; under `xvfb-run -a` without a display) the
// growth is recorded into numbered PNGs; --no-render builds headless and prints the timings,
// with --camera-orbit a simulated render thread measuring the front's frame cost.
#include "growth_run.h"
#include "viewer_input.h"
#include "viewer_options.h"

#include <pclx/apps/file_check.h>
#include <pclx/apps/process_stats.h>
#include <pclx/omicron/point_stream_reader.h>
#include <pclx/omicron/point_xyzi_packed.h>
#include <pclx/omicron/point_xyzrgbi.h>

#include <pcl/exceptions.h>
#include <pcl/point_types.h>

#include <CLI/CLI.hpp>

#include <algorithm>
#include <iostream>
#include <stdexcept>
#include <string>

namespace {

using namespace omicron_viewer;

// The options and their help texts.
void
defineOptions (CLI::App& app, Options& opt)
{
  app.add_option ("input,-i,--input", opt.input, "PCD, PLY or XYZ (text) file")->required ();
  app.add_option ("--depth", opt.depth, "maximum octree depth (1..21)")->capture_default_str ();
  app.add_option ("--ratio", opt.ratio, "parent point ratio (0, 1]")->capture_default_str ();
  app.add_flag ("--collapse,!--no-collapse", opt.collapse, "leaf collapse (default on)");
  app.add_option ("--worklist", opt.worklist, "nodes per worklist")->capture_default_str ();
  app.add_option ("--chunks", opt.chunks, "Morton sort chunks")->capture_default_str ();
  app.add_option ("--threads", opt.threads, "build threads (0: all cores)")->capture_default_str ();
  app.add_option ("--threshold", opt.threshold, "front projection threshold (NDC diagonal)")->capture_default_str ();
  app.add_option ("--leaf-radius", opt.leaf_radius,
                  "leaf splat radius in world units (0: about the point spacing, from the first chunk)")
      ->capture_default_str ();
  app.add_option ("--splat-multipliers", opt.multipliers,
                  "splat radius factors going up from the leaves, the last one for every higher level (default: "
                  "1/sqrt(ratio) at every level; da Silva 2018, Table 4.5: 4.2 2.4 2.2 2.2 2.0)");
  app.add_option ("--color", opt.color, "auto (rgb when the cloud has it, else height), rgb, height or level")
      ->check (CLI::IsMember ({"auto", "rgb", "height", "level"}))
      ->capture_default_str ();
  app.add_option ("--draw", opt.draw,
                  "rebuild: one splat array refilled when the front changes; nodes: one actor per node")
      ->check (CLI::IsMember ({"rebuild", "nodes"}))
      ->capture_default_str ();
  auto* shot =
      app.add_option ("--screenshot", opt.screenshot, "render off-screen, save the final picture (PNG) and exit");
  auto* every = app.add_option ("--screenshot-every", opt.screenshot_every,
                                "render off-screen and save every N-th rendered frame (from the first with splats) as "
                                "<prefix>_NNNN.png, then the final front; exits after the build");
  app.add_option ("--growth-prefix", opt.growth_prefix,
                  "file prefix of --screenshot-every (default: --screenshot without .png, else omicron_growth)");
  app.add_option ("-o,--output", opt.output, "write the hierarchy as Potree 2.0 files to this folder after the build");
  app.add_option ("--memory-budget", opt.budget_mb,
                  "MB for the build's buffers: out-of-core build streaming the file (PCD/PLY/XYZ), subtrees below "
                  "the spill level written to --output as they finish (0: in memory)")
      ->capture_default_str ();
  auto* headless = app.add_flag ("--no-render", opt.no_render, "no window: build, print timings and statistics");
  headless->excludes (shot)->excludes (every);
  app.add_flag ("--camera-orbit", opt.orbit,
                "orbit the camera around the cloud during the build (with --no-render: a simulated render thread "
                "evaluating the front at up to 60 Hz)");
  app.add_option ("--orbit-seconds", opt.orbit_seconds, "seconds per orbit")->capture_default_str ();
  app.add_option ("--view-dir", opt.view_dir, "x y z: direction from the cloud's centre to the camera")->expected (3);
  app.add_option ("--up", opt.up, "x y z: the camera's up direction")->expected (3);
  app.add_option ("--width", opt.width, "window and screenshot width in pixels")->capture_default_str ();
  app.add_option ("--height", opt.height, "window and screenshot height in pixels")->capture_default_str ();
}

// --growth-prefix defaults to --screenshot without .png, else omicron_growth.
void
defaultGrowthPrefix (Options& o)
{
  if (!o.growth_prefix.empty ())
    return;
  o.growth_prefix = o.screenshot.empty () ? "omicron_growth" : o.screenshot;
  if (o.growth_prefix.size () > 4 && o.growth_prefix.compare (o.growth_prefix.size () - 4, 4, ".png") == 0)
    o.growth_prefix.resize (o.growth_prefix.size () - 4);
}

template <typename PointT>
int
run (const Options& opt, Input<PointT> in)
{
  GrowthRun<PointT> growth (opt, std::move (in));
  return growth.run ();
}

// Checks the input file and runs on it: XYZ text loaded here, PCD and PLY read by the octree.
int
runOnFile (const Options& o)
{
  if (o.width < 16 || o.height < 16)
    throw std::invalid_argument ("--width and --height must be >= 16");
  const pclx::apps::FileCheck check = pclx::apps::checkCloudFile (o.input);
  if (check.format == pclx::apps::CloudFormat::XYZ && o.budget_mb <= 0)
    return run (o, readXyzInput (o.input));
  // The octree reads the file itself (in memory, or out of core with a budget), so the points
  // are held once; framing and progress come from the octree.
  pcl::PointStreamReader reader (o.input);
  if (!reader.isOpen ())
    throw std::runtime_error (reader.getLastError ());
  const std::string how = o.budget_mb > 0
                              ? "memory budget " + formatMb (static_cast<std::size_t> (o.budget_mb * 1048576.0))
                              : "in memory";
  const auto summary = o.input + ": " + std::to_string (reader.getDeclaredPoints ()) + " points (xyz" +
                       (reader.hasColor () ? " rgb" : "") + (reader.hasIntensity () ? " intensity" : "") +
                       "), read by the octree (" + how + ")";
  // The point type holds what the file has, in as few bytes as it can: PointXYZ and
  // PointXYZIPacked take 16 per sorted point, the types with colour 32.
  const auto runAs = [&] (auto in) {
    in.file = o.input;
    in.summary = summary;
    in.color = reader.hasColor ();
    return run (o, std::move (in));
  };
  if (reader.hasColor ())
    return reader.hasIntensity () ? runAs (Input<pclx::PointXYZRGBI> ()) : runAs (Input<pcl::PointXYZRGB> ());
  return reader.hasIntensity () ? runAs (Input<pclx::PointXYZIPacked> ()) : runAs (Input<pcl::PointXYZ> ());
}

// pcl::IOException's what() starts with "<function> in <source file> @ <line> : ".
std::string
oneLine (const std::exception& e)
{
  std::string s = e.what ();
  if (dynamic_cast<const pcl::PCLException*> (&e))
  {
    const auto k = s.find (" : ");
    if (k != std::string::npos)
      s = s.substr (k + 3);
  }
  std::replace (s.begin (), s.end (), '\n', ' ');
  return s;
}

}  // namespace

int
main (int argc, char** argv)
{
  Options o;
  CLI::App app ("omicron_viewer: builds the OMiCroN hierarchy (pcl::ObliqueCutOctree) of a PCD/PLY/XYZ cloud and "
                "renders its front as splats while it grows");
  defineOptions (app, o);
  CLI11_PARSE (app, argc, argv);
  defaultGrowthPrefix (o);
  try
  {
    return runOnFile (o);
  }
  catch (const std::exception& e)
  {
    std::cerr << "omicron_viewer: " << oneLine (e) << "\n";
    return 1;
  }
}
