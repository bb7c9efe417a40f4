#include <pclx/testing/run_stats.h>

#include <malloc.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <string>

namespace pclx {
namespace testing {

std::size_t
procStatusKb (const char* key)
{
  std::ifstream status ("/proc/self/status");
  std::string line;
  const std::size_t len = std::strlen (key);
  while (std::getline (status, line))
    if (line.compare (0, len, key) == 0 && line.size () > len && line[len] == ':')
      return std::stoull (line.substr (len + 1));
  return 0;
}

std::size_t
resetPeakMemory ()
{
  malloc_trim (0);
  std::ofstream ("/proc/self/clear_refs") << "5";
  return procStatusKb ("VmRSS") * 1024;
}

double
percentile (std::vector<double> values, double q)
{
  if (values.empty ())
    return 0;
  std::sort (values.begin (), values.end ());
  return values[std::min (values.size () - 1, static_cast<std::size_t> (q * double (values.size () - 1) + 0.5))];
}

}  // namespace testing
}  // namespace pclx
