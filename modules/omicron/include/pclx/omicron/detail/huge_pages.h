#pragma once
// First touches of the build's large buffers (sorted array, bucket of each point, chunk sort
// buffers): their pages are mapped in one call before they are written (prefault ()), and on
// request in transparent huge pages.
//
// A page fault per 4 KiB page is a trap into the kernel, and on virtual machines that shadow
// the guest's page tables a trap into the host as well; mapping a whole range with
// MADV_POPULATE_WRITE takes one system call for it.
//
// The buffers stay std::vectors with their usual allocators (public types do not change):
// reserveHuge () reserves the capacity (large allocations are fresh mmaps, so nothing is
// touched yet), advises the 2 MiB-aligned part of it, and only then is it resized / written.
#include <cstddef>
#include <cstdint>
#include <cstdlib>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace pclx {
namespace omicron {
namespace detail {

// Off unless PCLX_OMICRON_THP=1 is in the environment. 2 MiB pages take a 512th of the page-table
// work of 4 KiB ones, but on virtual machines that hand freed memory back to their host they
// are carved from the returned blocks, so every huge page's first write waits for the host;
// 4 KiB pages mostly reuse memory the guest still holds (docs/omicron.md has the measurements).
inline bool
hugePagesEnabled ()
{
  static const bool on = [] {
    const char* v = std::getenv ("PCLX_OMICRON_THP");
    return v != nullptr && v[0] == '1';
  }();
  return on;
}

// Advises [p, p + bytes) (its 2 MiB-aligned interior) for huge pages when bytes >= 4 MiB.
inline void
adviseHugePages (void* p, std::size_t bytes)
{
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr std::uintptr_t kHuge = std::uintptr_t (2) << 20;
  if (p == nullptr || bytes < 2 * kHuge)
    return;
  if (!hugePagesEnabled ())
    return;
  const std::uintptr_t b = (reinterpret_cast<std::uintptr_t> (p) + kHuge - 1) & ~(kHuge - 1);
  const std::uintptr_t e = (reinterpret_cast<std::uintptr_t> (p) + bytes) & ~(kHuge - 1);
  if (e > b)
    madvise (reinterpret_cast<void*> (b), e - b, MADV_HUGEPAGE);  // advice only: failure is harmless
#else
  (void) p;
  (void) bytes;
#endif
}

// Maps the whole 4 KiB pages of [p, p + bytes) for writing in one system call, so writing
// them later takes no page fault. Ranges under 64 KiB are left alone (a few faults cost less
// than the call). Advice only: kernels before Linux 5.14 refuse it, and nothing changes.
inline void
prefault (void* p, std::size_t bytes)
{
#if defined(__linux__) && defined(MADV_POPULATE_WRITE)
  constexpr std::uintptr_t kPage = 4096;
  if (p == nullptr || bytes < 16 * kPage)
    return;
  const std::uintptr_t b = (reinterpret_cast<std::uintptr_t> (p) + kPage - 1) & ~(kPage - 1);
  const std::uintptr_t e = (reinterpret_cast<std::uintptr_t> (p) + bytes) & ~(kPage - 1);
  if (e > b)
    madvise (reinterpret_cast<void*> (b), e - b, MADV_POPULATE_WRITE);
#else
  (void) p;
  (void) bytes;
#endif
}

// v becomes an empty vector with capacity >= n whose storage is advised for huge pages
// (a buffer that already holds n elements is kept as it is).
template <typename Vector> void
reserveHuge (Vector& v, std::size_t n)
{
  if (v.capacity () >= n)
    return;
  Vector ().swap (v);
  v.reserve (n);
  adviseHugePages (v.data (), v.capacity () * sizeof (typename Vector::value_type));
}

// As reserveHuge (), and the first n elements' pages are mapped (prefault ()): for a buffer
// that is about to be filled up to n.
template <typename Vector> void
reservePrefaulted (Vector& v, std::size_t n)
{
  if (v.capacity () >= n)
    return;
  reserveHuge (v, n);
  prefault (v.data (), n * sizeof (typename Vector::value_type));
}

}  // namespace detail
}  // namespace omicron
}  // namespace pclx
