#pragma once
// The CSV rows every pclx benchmark prints, one per (method, params, input):
//   module,method,params,input,points,seconds,metric,value[,metric2,value2...]
// Peers (Open3D, PCL) are just other `method`s in the same run, so ratios are
// measured on the same machine at the same time.
#include <algorithm>
#include <chrono>
#include <fstream>
#include <functional>
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

// CPU seconds of the whole process (every thread) so far: on a shared machine a call's wall
// time grows with the other processes' load, its CPU time much less.
double processCpuSeconds ();

// Wall and process CPU seconds of fn (), each the best of `repeats` calls.
template <typename Fn> std::pair<double, double>
timeBestWallCpu (Fn&& fn, int repeats = 1)
{
  double wall = 1e300, cpu = 1e300;
  for (int r = 0; r < repeats; ++r)
  {
    const double c0 = processCpuSeconds ();
    const auto t0 = std::chrono::steady_clock::now ();
    fn ();
    wall = std::min (wall, std::chrono::duration<double> (std::chrono::steady_clock::now () - t0).count ());
    cpu = std::min (cpu, processCpuSeconds () - c0);
  }
  return {wall, cpu};
}

// libgomp spins in its barriers by default; on a shared 2-core machine that makes OpenMP code
// with many short parallel regions (Open3D's Integrate and Poisson) many times slower than its
// work. Sets OMP_WAIT_POLICY=PASSIVE and re-executes the program when it is unset (libgomp reads
// it when it loads); returns only when the policy was already set.
void passiveOpenMpWaits (char** argv);

// ../shared/data beside the checkout (or $PCLX_DATA_DIR); prints to stderr when absent
// so the bench log says it fell back to generated scenes.
std::optional<std::string> sharedDataDir ();

// Peak resident set size of this process so far, in MiB (from /proc/self/status).
double peakRssMiB ();

// ---- Running a measurement in a forked child (its own peak memory, limits, crash isolation).
// A key of /proc/self/status in kB (VmRSS, VmHWM, ...), 0 when absent.
std::size_t procStatusKb (const char* key);
// Returns freed heap to the system and resets VmHWM to the current RSS (clear_refs = 5,
// Linux >= 4.0); returns that RSS in bytes, the baseline of a child's peak.
std::size_t resetPeakMemory ();
// A row sent from a child through a pipe: "method\tparams\tseconds\tkey=value;key=value".
struct ChildRow
{
  std::string method, params;
  double seconds = 0;
  Metrics metrics;
};
std::string encodeChildRow (const ChildRow& r);  // one line, without the newline
bool decodeChildRow (const std::string& line, ChildRow& r);
// Whole-buffer pipe I/O (write retries short writes; read until EOF).
void writeAll (int fd, const std::string& text);
std::string readAll (int fd);
// Forks; the child runs body (which appends its rows and returns its exit code; it sets its
// own limits and catches its own exceptions), sends the rows back through a pipe and exits.
// The parent appends the rows it received and returns the child's waitpid status.
int runInChild (const std::function<int (std::vector<ChildRow>& rows)>& body, std::vector<ChildRow>& rows);

}  // namespace bench
}  // namespace pclx
