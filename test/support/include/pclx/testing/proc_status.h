#pragma once
// The one reader of /proc/self/status shared by the benchmarks and the apps (its own small
// library, pclx_proc_status, so that neither pulls in the other's dependencies).
#include <cstddef>

namespace pclx {
namespace testing {

/** \brief Reads one key of /proc/self/status that is given in kB (VmRSS, VmHWM, VmPeak, ...).
  * \param[in] key the key without its colon, e.g. "VmHWM"
  * \return the value in kB, or 0 when the key is absent or the file cannot be read
  */
std::size_t
procStatusKb (const char* key);

}  // namespace testing
}  // namespace pclx
