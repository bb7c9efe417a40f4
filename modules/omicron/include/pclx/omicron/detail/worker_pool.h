#pragma once
// pclx::omicron::detail::WorkerPool: a fixed set of std::threads that run parallel loops for the fix
// workers and the sorter passes.
//
// Hand-written instead of TBB: Debian's libtbb is not built with ThreadSanitizer, so every
// TBB task handoff showed up as a data race and drowned the module's real races
// (scripts/tsan-omicron.sh). Only plain mutexes, condition variables and atomics are used, which
// TSan understands. The calling thread takes part as worker 0.
#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace pclx {
namespace omicron {
namespace detail {

class WorkerPool
{
public:
  // `threads` >= 1 workers in all, the caller included (threads − 1 threads are started).
  explicit WorkerPool (int threads);
  ~WorkerPool ();
  WorkerPool (const WorkerPool&) = delete;
  WorkerPool& operator= (const WorkerPool&) = delete;

  int size () const { return static_cast<int> (threads_.size ()) + 1; }

  // Calls f (i, worker) for every i in [0, n), worker in [0, size ()), and returns when all
  // calls have returned. Indices are handed out one at a time (the work per index varies).
  // One loop at a time: calls from several threads are serialized. When a call throws, the
  // indices not yet handed out are skipped, and the first exception is rethrown here once
  // every call that started has returned.
  void parallelFor (std::size_t n, const std::function<void (std::size_t, int)>& f);

private:
  void loop (int worker);
  void drain (const std::function<void (std::size_t, int)>& f, std::size_t n, int worker);

  std::vector<std::thread> threads_;
  std::mutex run_mutex_;  // one loop at a time
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  const std::function<void (std::size_t, int)>* job_ = nullptr;
  std::size_t n_ = 0;
  std::atomic<std::size_t> next_{0};
  std::size_t generation_ = 0;
  int busy_ = 0;  // helpers still inside the current loop
  std::exception_ptr error_;  // the current loop's first exception
  bool stop_ = false;
};

}  // namespace detail
}  // namespace omicron
}  // namespace pclx
