#pragma once
// What a run measures about itself, shared by the benchmarks and the apps: the process's
// memory from /proc/self/status and percentiles of per-frame times. Its own small library,
// pclx_run_stats, so that neither pulls in the other's dependencies.
#include <cstddef>
#include <vector>

namespace pclx {
namespace testing {

/** \brief Reads one key of /proc/self/status that is given in kB (VmRSS, VmHWM, VmPeak, ...).
  * \param[in] key the key without its colon, e.g. "VmHWM"
  * \return the value in kB, or 0 when the key is absent or the file cannot be read
  */
std::size_t
procStatusKb (const char* key);

/** \brief Returns freed heap to the system and resets VmHWM to the current RSS
  * (clear_refs = 5, Linux >= 4.0), so that VmHWM then measures the peak of what follows.
  * \return that RSS in bytes, the baseline of the peak
  */
std::size_t
resetPeakMemory ();

/** \brief A percentile by nearest rank: the value at round (q (n - 1)) in sorted order.
  * \param[in] values the sample (copied: it is sorted)
  * \param[in] q the quantile in [0, 1]
  * \return the percentile, 0 for an empty sample
  */
double
percentile (std::vector<double> values, double q);

}  // namespace testing
}  // namespace pclx
