#pragma once
// Development-only stage timer (compile with -DPCLX_HPR_PROFILE): wall time per stage of the
// candidate hull, summed over calls and printed to stderr at exit. Compiles to nothing
// otherwise; the library never depends on it.
#ifdef PCLX_HPR_PROFILE
#include <ctime>
#include <cstdio>
#include <cstring>
#include <string>

namespace pclx {
namespace hpr {
namespace detail {
namespace profile {
struct Table
{
  static constexpr int kMax = 64;
  std::string name[kMax];
  double seconds[kMax] = {};
  long calls[kMax] = {};
  int used = 0;
  int pass = 0;  // culling pass the stages belong to (0: first)
  void add (const char* stage, double s)
  {
    const std::string key = "pass" + std::to_string (pass) + "." + stage;
    int i = 0;
    while (i < used && name[i] != key)
      ++i;
    if (i == used && used < kMax)
      name[used++] = key;
    if (i < kMax)
    {
      seconds[i] += s;
      ++calls[i];
    }
  }
  ~Table ()
  {
    for (int i = 0; i < used; ++i)
      std::fprintf (stderr, "hpr_profile,%s,%.6f,%ld\n", name[i].c_str (), seconds[i], calls[i]);
  }
};
inline Table table;
// CPU time of the calling thread: with one OpenMP thread (the profiled case) every stage
// runs on it, and other processes on a shared machine do not count.
inline double
threadSeconds ()
{
  timespec ts;
  clock_gettime (CLOCK_THREAD_CPUTIME_ID, &ts);
  return double (ts.tv_sec) + 1e-9 * double (ts.tv_nsec);
}
struct Laps
{
  double t = threadSeconds ();
  void lap (const char* stage)
  {
    const double now = threadSeconds ();
    table.add (stage, now - t);
    t = now;
  }
};
}  // namespace profile
}  // namespace detail
}  // namespace hpr
}  // namespace pclx
#define HPR_LAPS() ::pclx::hpr::detail::profile::Laps hpr_laps_
#define HPR_LAP(stage) hpr_laps_.lap (stage)
#define HPR_PASS(p) (::pclx::hpr::detail::profile::table.pass = (p))
#else
#define HPR_LAPS()
#define HPR_LAP(stage)
#define HPR_PASS(p)
#endif
