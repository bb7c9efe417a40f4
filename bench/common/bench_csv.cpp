#include "bench_csv.h"

#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include <sys/wait.h>
#include <unistd.h>

namespace pclx {
namespace bench {

CsvWriter::CsvWriter (const std::string& path)
{
  const char* header = "module,method,params,input,points,seconds,metric,value,...";
  std::cout << header << '\n';
  if (!path.empty ())
  {
    file_.open (path);
    if (!file_)
      throw std::runtime_error ("CsvWriter: cannot write " + path);
    file_ << header << '\n';
  }
}

void
CsvWriter::row (const std::string& module, const std::string& method, const std::string& params,
                const std::string& input, std::size_t points, double seconds, const Metrics& metrics)
{
  std::ostringstream s;
  s << module << ',' << method << ',' << params << ',' << input << ',' << points << ','
    << std::setprecision (6) << seconds;
  for (const auto& m : metrics)
    s << ',' << m.first << ',' << std::setprecision (6) << m.second;
  std::cout << s.str () << std::endl;
  if (file_.is_open ())
    file_ << s.str () << std::endl;
}

void
passiveOpenMpWaits (char** argv)
{
  if (std::getenv ("OMP_WAIT_POLICY"))
    return;
  setenv ("OMP_WAIT_POLICY", "PASSIVE", 1);
  execv ("/proc/self/exe", argv);
}

std::optional<std::string>
sharedDataDir ()
{
  namespace fs = std::filesystem;
  std::vector<fs::path> candidates;
  if (const char* env = std::getenv ("PCLX_DATA_DIR"))
    candidates.emplace_back (env);
  candidates.emplace_back (fs::path (PCLX_SOURCE_DIR) / ".." / "shared" / "data");
  for (const auto& c : candidates)
    if (fs::is_directory (c))
      return fs::canonical (c).string ();
  std::cerr << "[bench] ../shared/data not found (set PCLX_DATA_DIR): using generated scenes only\n";
  return std::nullopt;
}

double
processCpuSeconds ()
{
  timespec ts{};
  clock_gettime (CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double (ts.tv_sec) + 1e-9 * double (ts.tv_nsec);
}

namespace {
bool verbose = false;
}  // namespace

void
setVerbose (bool on)
{
  verbose = on;
}

std::ostream&
progress ()
{
  static std::ostream discard (nullptr);
  return verbose ? std::cerr : discard;
}

std::string
encodeChildRow (const ChildRow& r)
{
  std::ostringstream s;
  s << r.method << '\t' << r.params << '\t' << std::setprecision (9) << r.seconds << '\t';
  for (std::size_t i = 0; i < r.metrics.size (); ++i)
    s << (i ? ";" : "") << r.metrics[i].first << '=' << std::setprecision (9) << r.metrics[i].second;
  return s.str ();
}

bool
decodeChildRow (const std::string& line, ChildRow& r)
{
  std::istringstream s (line);
  std::string secs, metrics;
  if (!std::getline (s, r.method, '\t') || !std::getline (s, r.params, '\t') || !std::getline (s, secs, '\t'))
    return false;
  std::getline (s, metrics);
  r.seconds = std::stod (secs);
  r.metrics.clear ();
  std::istringstream m (metrics);
  std::string kv;
  while (std::getline (m, kv, ';'))
  {
    const auto eq = kv.find ('=');
    if (eq != std::string::npos)
      r.metrics.emplace_back (kv.substr (0, eq), std::stod (kv.substr (eq + 1)));
  }
  return true;
}

void
writeAll (int fd, const std::string& text)
{
  std::size_t off = 0;
  while (off < text.size ())
  {
    const ssize_t w = write (fd, text.data () + off, text.size () - off);
    if (w <= 0)
      break;
    off += std::size_t (w);
  }
}

std::string
readAll (int fd)
{
  std::string text;
  char buf[65536];
  ssize_t n;
  while ((n = read (fd, buf, sizeof (buf))) > 0)
    text.append (buf, std::size_t (n));
  return text;
}

int
runInChild (const std::function<int (std::vector<ChildRow>& rows)>& body, std::vector<ChildRow>& rows)
{
  int fd[2];
  if (pipe (fd) != 0)
    throw std::runtime_error ("pipe failed");
  std::cout.flush ();
  std::cerr.flush ();
  const pid_t pid = fork ();
  if (pid < 0)
    throw std::runtime_error ("fork failed");
  if (pid == 0)
  {
    close (fd[0]);
    std::vector<ChildRow> mine;
    const int code = body (mine);
    std::string out;
    for (const ChildRow& r : mine)
      out += encodeChildRow (r) + "\n";
    writeAll (fd[1], out);
    close (fd[1]);
    _exit (code);
  }
  close (fd[1]);
  const std::string text = readAll (fd[0]);
  close (fd[0]);
  int status = 0;
  waitpid (pid, &status, 0);
  std::istringstream lines (text);
  std::string line;
  while (std::getline (lines, line))
  {
    ChildRow row;
    if (decodeChildRow (line, row))
      rows.push_back (row);
  }
  return status;
}

}  // namespace bench
}  // namespace pclx
