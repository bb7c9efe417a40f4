#include <pclx/apps/progress.h>

#include <unistd.h>

namespace pclx {
namespace apps {

Progress::Progress (std::string stage, std::size_t total, double delay, std::FILE* out)
  : stage_ (std::move (stage)), total_ (total), delay_ (delay), out_ (out), tty_ (isatty (fileno (out)) != 0),
    start_ (std::chrono::steady_clock::now ()), last_print_ (start_)
{}

Progress::~Progress ()
{
  done ();
}

double
Progress::seconds () const
{
  return std::chrono::duration<double> (std::chrono::steady_clock::now () - start_).count ();
}

void
Progress::update (std::size_t done)
{
  if (finished_ || total_ == 0)
    return;
  const auto now = std::chrono::steady_clock::now ();
  if (seconds () < delay_ || now - last_print_ < std::chrono::seconds (1))
    return;
  const int percent = static_cast<int> (100.0 * static_cast<double> (std::min (done, total_)) / static_cast<double> (total_));
  // Without a terminal, one line per 10 % step.
  if (!tty_ && percent / 10 == last_percent_ / 10)
    return;
  std::fprintf (out_, tty_ ? "\r%s ... %3d %%" : "%s ... %d %%\n", stage_.c_str (), percent);
  std::fflush (out_);
  last_percent_ = percent;
  last_print_ = now;
  shown_ = true;
}

void
Progress::done ()
{
  if (finished_)
    return;
  finished_ = true;
  const double s = seconds ();
  if (!shown_ && s < delay_)
    return;
  std::fprintf (out_, tty_ && shown_ ? "\r%s: done in %.1f s        \n" : "%s: done in %.1f s\n", stage_.c_str (), s);
  std::fflush (out_);
}

}  // namespace apps
}  // namespace pclx
