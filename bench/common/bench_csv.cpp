#include "bench_csv.h"

#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <sstream>

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
peakRssMiB ()
{
  std::ifstream status ("/proc/self/status");
  std::string line;
  while (std::getline (status, line))
    if (line.rfind ("VmHWM:", 0) == 0)
      return std::stod (line.substr (6)) / 1024.0;  // kB
  return 0.0;
}

}  // namespace bench
}  // namespace pclx
