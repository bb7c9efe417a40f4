#include <pclx/omicron/detail/worker_pool.h>

pclx::omicron::detail::WorkerPool::WorkerPool (int threads)
{
  for (int w = 1; w < threads; ++w)
    threads_.emplace_back ([this, w] { loop (w); });
}

pclx::omicron::detail::WorkerPool::~WorkerPool ()
{
  {
    std::lock_guard<std::mutex> g (mutex_);
    stop_ = true;
  }
  wake_.notify_all ();
  for (std::thread& t : threads_)
    t.join ();
}

void
pclx::omicron::detail::WorkerPool::drain (const std::function<void (std::size_t, int)>& f, std::size_t n, int worker)
{
  for (std::size_t i = next_.fetch_add (1, std::memory_order_relaxed); i < n;
       i = next_.fetch_add (1, std::memory_order_relaxed))
    try
    {
      f (i, worker);
    }
    catch (...)
    {
      // The first error is kept for the caller; the indices not yet handed out are skipped.
      std::lock_guard<std::mutex> g (mutex_);
      if (!error_)
        error_ = std::current_exception ();
      next_.store (n, std::memory_order_relaxed);
    }
}

void
pclx::omicron::detail::WorkerPool::loop (int worker)
{
  std::size_t seen = 0;
  std::unique_lock<std::mutex> lk (mutex_);
  while (true)
  {
    wake_.wait (lk, [&] { return stop_ || (job_ && generation_ != seen); });
    if (stop_)
      return;
    // Joining happens under the lock while the loop is open (job_ set), so the caller waits
    // for exactly the helpers that may still touch its job.
    seen = generation_;
    ++busy_;
    const auto* job = job_;
    const std::size_t n = n_;
    lk.unlock ();
    drain (*job, n, worker);
    lk.lock ();
    if (--busy_ == 0)
      done_.notify_one ();
  }
}

void
pclx::omicron::detail::WorkerPool::parallelFor (std::size_t n, const std::function<void (std::size_t, int)>& f)
{
  if (n == 0)
    return;
  std::lock_guard<std::mutex> run (run_mutex_);
  if (threads_.empty () || n == 1)
  {
    for (std::size_t i = 0; i < n; ++i)
      f (i, 0);
    return;
  }
  {
    std::lock_guard<std::mutex> g (mutex_);
    job_ = &f;
    n_ = n;
    next_.store (0, std::memory_order_relaxed);
    ++generation_;
  }
  wake_.notify_all ();
  drain (f, n, 0);
  std::unique_lock<std::mutex> lk (mutex_);
  job_ = nullptr;  // closed: late helpers go back to sleep
  done_.wait (lk, [&] { return busy_ == 0; });
  if (error_)
  {
    std::exception_ptr error = nullptr;
    std::swap (error, error_);
    std::rethrow_exception (error);
  }
}
