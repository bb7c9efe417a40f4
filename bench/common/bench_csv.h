#pragma once
// The CSV rows every pclx benchmark prints, one per (method, params, input):
//   module,method,params,input,points,seconds,metric,value[,metric2,value2...]
// Peers (Open3D, PCL) are just other `method`s in the same run, so ratios are
// measured on the same machine at the same time.
#include <pclx/testing/run_stats.h>

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

/** \brief A row's metrics: (name, value) pairs, printed in this order. */
using Metrics = std::vector<std::pair<std::string, double>>;

/** \brief Prints the CSV header and rows to stdout, and also to a file. */
class CsvWriter
{
public:
  /** \brief Prints the header.
    * \param[in] path a file that gets the same lines (none when empty)
    * \throw std::runtime_error when the file cannot be written
    */
  explicit CsvWriter (const std::string& path = "");

  /** \brief Prints one row: module,method,params,input,points,seconds,metric,value,...
    * \param[in] module the module benchmarked
    * \param[in] method ours or a peer's name
    * \param[in] params the method's parameters (key=value;...)
    * \param[in] input the input's name
    * \param[in] points the input's size
    * \param[in] seconds the time of the run
    * \param[in] metrics the measured values
    */
  void row (const std::string& module, const std::string& method, const std::string& params,
            const std::string& input, std::size_t points, double seconds, const Metrics& metrics);

private:
  std::ofstream file_;
};

/** \brief Wall-clock seconds of fn (), best of `repeats` runs (the machines are shared).
  * \param[in] fn the call to time
  * \param[in] repeats how many times to run it
  * \return the shortest time in seconds
  */
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

/** \brief CPU seconds of the whole process (every thread) so far: on a shared machine a
  * call's wall time grows with the other processes' load, its CPU time much less.
  * \return the seconds
  */
double processCpuSeconds ();

/** \brief Wall and process CPU seconds of fn (), each the best of `repeats` calls.
  * \param[in] fn the call to time
  * \param[in] repeats how many times to run it
  * \return (wall, CPU) seconds
  */
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

/** \brief Makes OpenMP's idle threads sleep rather than spin.
  *
  * libgomp spins in its barriers by default; on a shared 2-core machine that makes OpenMP code
  * with many short parallel regions (Open3D's Integrate and Poisson) many times slower than
  * its work. Sets OMP_WAIT_POLICY=PASSIVE and re-executes the program when it is unset
  * (libgomp reads it when it loads); returns only when the policy was already set.
  * \param[in] argv the program's arguments, passed on to the new image
  */
void passiveOpenMpWaits (char** argv);

/** \brief ../shared/data beside the checkout (or $PCLX_DATA_DIR); prints to stderr when
  * absent so the bench log says it fell back to generated scenes.
  * \return the folder, or nothing when there is none
  */
std::optional<std::string> sharedDataDir ();

/** \brief Turns the progress lines written through progress () on or off (off by default).
  * \param[in] on true: progress () is std::cerr; false: progress () discards what it gets
  */
void setVerbose (bool on);

/** \brief The stream for progress lines: std::cerr after setVerbose (true), otherwise a
  * stream that discards everything. Warnings a user must see go to std::cerr directly.
  * \return the progress stream
  */
std::ostream& progress ();

// ---- Running a measurement in a forked child (its own peak memory, limits, crash isolation).

// A key of /proc/self/status in kB (VmRSS, VmHWM, ...), 0 when absent, the nearest-rank
// percentile of a sample, and the reset of VmHWM before a child's measurement (test/support).
using pclx::testing::percentile;
using pclx::testing::procStatusKb;
using pclx::testing::resetPeakMemory;

/** \brief A row sent from a child through a pipe: "method\tparams\tseconds\tkey=value;key=value". */
struct ChildRow
{
  std::string method;  ///< the method
  std::string params;  ///< its parameters
  double seconds = 0;  ///< the time of the run
  Metrics metrics;     ///< the measured values
};

/** \brief One line for the pipe, without the newline.
  * \param[in] r the row
  * \return the line
  */
std::string encodeChildRow (const ChildRow& r);

/** \brief Reads a line written by encodeChildRow ().
  * \param[in] line the line
  * \param[out] r the row
  * \return false when the line lacks a field
  */
bool decodeChildRow (const std::string& line, ChildRow& r);

/** \brief Writes the whole text to a file descriptor (short writes retried).
  * \param[in] fd the descriptor
  * \param[in] text the bytes
  */
void writeAll (int fd, const std::string& text);

/** \brief Reads a file descriptor until EOF.
  * \param[in] fd the descriptor
  * \return the bytes read
  */
std::string readAll (int fd);

/** \brief Runs a measurement in a forked child and collects its rows.
  *
  * The child runs body (which appends its rows and returns its exit code; it sets its own
  * limits and catches its own exceptions), sends the rows back through a pipe and exits.
  * \param[in] body what the child runs
  * \param[in,out] rows the rows received are appended here
  * \return the child's waitpid status
  */
int runInChild (const std::function<int (std::vector<ChildRow>& rows)>& body, std::vector<ChildRow>& rows);

}  // namespace bench
}  // namespace pclx
