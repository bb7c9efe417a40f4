#include <pclx/apps/process_stats.h>
#include <pclx/testing/run_stats.h>

#include <algorithm>
#include <cstdio>

namespace pclx {
namespace apps {

double
secondsSince (std::chrono::steady_clock::time_point t)
{
  return std::chrono::duration<double> (std::chrono::steady_clock::now () - t).count ();
}

Percentiles
percentiles (std::vector<double> v)
{
  Percentiles p;
  if (v.empty ())
    return p;
  p.n = v.size ();
  p.p50 = pclx::testing::percentile (v, 0.5);
  p.p95 = pclx::testing::percentile (v, 0.95);
  p.max = *std::max_element (v.begin (), v.end ());
  return p;
}

std::string
formatMb (std::size_t bytes)
{
  char b[32];
  std::snprintf (b, sizeof b, "%.1f MB", double (bytes) / 1048576.0);
  return b;
}

std::size_t
peakResidentBytes ()
{
  return pclx::testing::procStatusKb ("VmHWM") * 1024;
}

}  // namespace apps
}  // namespace pclx
