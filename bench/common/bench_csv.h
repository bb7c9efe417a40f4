#pragma once
// The CSV rows every pclx benchmark prints, one per (method, params, input):
//   module,method,params,input,points,seconds,metric,value[,metric2,value2...]
// Peers (Open3D, PCL) are just other `method`s in the same run, so ratios are
// measured on the same machine at the same time.
#include <chrono>
#include <fstream>
#include <iostream>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace pclx {
namespace bench {

using Metrics = std::vector<std::pair<std::string, double>>;

class CsvWriter
{
public:
  // Writes to stdout, and also to `path` when it is not empty.
  explicit CsvWriter (const std::string& path = "");
  void row (const std::string& module, const std::string& method, const std::string& params,
            const std::string& input, std::size_t points, double seconds, const Metrics& metrics);

private:
  std::ofstream file_;
};

// Wall-clock seconds of fn(), best of `repeats` runs (the machines are shared).
template <typename Fn> double
timeBest (Fn&& fn, int repeats = 1)
{
  double best = 1e300;
  for (int r = 0; r < repeats; ++r)
  {
    const auto t0 = std::chrono::steady_clock::now ();
    fn ();
    best = std::min (best, std::chrono::duration<double> (std::chrono::steady_clock::now () - t0).count ());
  }
  return best;
}

// ../shared/data beside the checkout (or $PCLX_DATA_DIR); prints to stderr when absent
// so the bench log says it fell back to generated scenes.
std::optional<std::string> sharedDataDir ();

// Peak resident set size of this process so far, in MiB (from /proc/self/status).
double peakRssMiB ();

}  // namespace bench
}  // namespace pclx
