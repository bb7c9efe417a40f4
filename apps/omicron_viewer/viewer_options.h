#pragma once
// omicron_viewer's command-line options (see main () for their meaning and defaults).
#include <cstddef>
#include <string>
#include <vector>

namespace omicron_viewer {

/** \brief The command-line options. */
struct Options
{
  std::string input, output, screenshot, growth_prefix, color = "auto", draw = "rebuild";
  int depth = 7, threads = 0, width = 1280, height = 800, screenshot_every = 0;
  float ratio = 0.2f, threshold = 0.2f, leaf_radius = 0.f;
  std::vector<float> multipliers;
  bool collapse = true, no_render = false, orbit = false;
  std::size_t worklist = 32, chunks = 16;
  double orbit_seconds = 8, budget_mb = 0;
  std::vector<float> view_dir{1.f, -1.4f, 0.9f}, up{0.f, 0.f, 1.f};
};

}  // namespace omicron_viewer
