#pragma once
// Progress of long stages on stderr: "estimating normals ... 40 %". Quiet for stages that
// end within `delay` seconds; at most one update a second (on a terminal the line is
// rewritten in place, otherwise one line per step of 10 %); a closing line with the time.
#include <chrono>
#include <cstddef>
#include <cstdio>
#include <string>

namespace pclx {
namespace apps {

class Progress
{
public:
  // total 0: a stage of unknown length (only the closing line, when it took > delay).
  explicit Progress (std::string stage, std::size_t total = 0, double delay = 2.0, std::FILE* out = stderr);
  ~Progress ();  // done () if not called
  Progress (const Progress&) = delete;
  Progress& operator= (const Progress&) = delete;

  void update (std::size_t done);
  void done ();
  double seconds () const;

private:
  std::string stage_;
  std::size_t total_;
  double delay_;
  std::FILE* out_;
  bool tty_, shown_ = false, finished_ = false;
  int last_percent_ = -1;
  std::chrono::steady_clock::time_point start_, last_print_;
};

}  // namespace apps
}  // namespace pclx
