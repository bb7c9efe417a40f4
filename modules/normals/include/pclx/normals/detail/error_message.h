#pragma once
// printf-style formatting of the error messages that the public classes print with
// PCL_ERROR and keep for getLastError ().
#include <cstdarg>
#include <cstdio>
#include <string>

namespace pclx {
namespace normals {
namespace detail {

inline std::string
vformatMessage (const char* format, std::va_list args)
{
  std::va_list copy;
  va_copy (copy, args);
  const int size = std::vsnprintf (nullptr, 0, format, copy);
  va_end (copy);
  if (size <= 0)
    return std::string ();
  std::string out (static_cast<std::size_t> (size) + 1, '\0');
  std::vsnprintf (&out[0], out.size (), format, args);
  out.resize (static_cast<std::size_t> (size));
  return out;
}

}  // namespace detail
}  // namespace normals
}  // namespace pclx
