#pragma once
// What the apps report about a run: wall-clock seconds, percentiles of per-frame times, memory
// sizes in MB and the process's peak resident memory.
#include <chrono>
#include <cstddef>
#include <string>
#include <vector>

namespace pclx {
namespace apps {

/** \brief Seconds of wall-clock time since `t` (steady clock).
  * \param[in] t the start
  * \return the seconds elapsed
  */
double
secondsSince (std::chrono::steady_clock::time_point t);

/** \brief The median, 95th percentile and maximum of a sample (all 0 when it is empty). */
struct Percentiles
{
  std::size_t n = 0;  ///< the sample size
  double p50 = 0;     ///< the median
  double p95 = 0;     ///< the 95th percentile
  double max = 0;     ///< the largest value
};

/** \brief Percentiles of a sample, nearest rank (the value at round (q (n - 1)) in sorted order).
  * \param[in] values the sample (copied: it is sorted)
  * \return the percentiles
  */
Percentiles
percentiles (std::vector<double> values);

/** \brief A byte count in MB (MiB) with one decimal, e.g. "61.0 MB".
  * \param[in] bytes the bytes
  * \return the text
  */
std::string
formatMb (std::size_t bytes);

/** \brief The process's peak resident set size so far (VmHWM).
  * \return the bytes, 0 when /proc/self/status cannot tell
  */
std::size_t
peakResidentBytes ();

}  // namespace apps
}  // namespace pclx
