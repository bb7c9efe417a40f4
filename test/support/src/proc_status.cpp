#include <pclx/testing/proc_status.h>

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

}  // namespace testing
}  // namespace pclx
