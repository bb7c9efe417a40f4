#pragma once
// pclx::omicron::detail::readBlocksAhead: a file read in blocks on a thread of its own, two blocks
// in flight, so the parsing of the next block overlaps the work on the current one.
#include <pclx/omicron/point_stream_reader.h>

#include <pcl/point_cloud.h>

#include <condition_variable>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>

namespace pclx {
namespace omicron {
namespace detail {

/** \brief Reads `reader` from its current position to its end in blocks of `block_points`.
  *
  * A reader thread fills `blocks[0]` and `blocks[1]` in turn; `on_block (const
  * pcl::PointCloud<PointT>&)` runs on the calling thread on each block in file order, while
  * the other one is being read, and returns false to stop the read. `after_read ()` runs on the
  * reader thread after each block is read (it may read both blocks' capacities, nothing else).
  * \return false when on_block stopped the read or the reader failed (its getLastError ());
  * what either thread throws is rethrown here, after the reader thread has ended
  */
template <typename PointT, typename OnBlock, typename AfterRead> bool
readBlocksAhead (pcl::PointStreamReader& reader, std::size_t block_points, pcl::PointCloud<PointT> (&blocks)[2],
                 OnBlock&& on_block, AfterRead&& after_read)
{
  bool full[2] = {false, false}, done = false, stop = false, stopped = false;
  std::exception_ptr error;
  std::mutex m;
  std::condition_variable cv;
  std::thread producer ([&] {
    try
    {
      for (int k = 0;; k ^= 1)
      {
        {
          std::unique_lock<std::mutex> lock (m);
          cv.wait (lock, [&] { return !full[k] || stop; });
          if (stop)
            break;
        }
        const bool more = reader.read (block_points, blocks[k]);
        after_read ();
        std::lock_guard<std::mutex> lock (m);
        if (!more)
          break;
        full[k] = true;
        cv.notify_all ();
      }
    }
    catch (...)
    {
      std::lock_guard<std::mutex> lock (m);
      error = std::current_exception ();
    }
    std::lock_guard<std::mutex> lock (m);
    done = true;
    cv.notify_all ();
  });
  const auto halt = [&] {
    {
      std::lock_guard<std::mutex> lock (m);
      stop = true;
      cv.notify_all ();
    }
    producer.join ();
  };
  try
  {
    for (int k = 0;; k ^= 1)
    {
      {
        std::unique_lock<std::mutex> lock (m);
        cv.wait (lock, [&] { return full[k] || done; });
        if (!full[k])
          break;
      }
      if (!on_block (static_cast<const pcl::PointCloud<PointT>&> (blocks[k])))
      {
        stopped = true;
        break;
      }
      std::lock_guard<std::mutex> lock (m);
      full[k] = false;
      cv.notify_all ();
    }
  }
  catch (...)
  {
    halt ();
    throw;
  }
  halt ();
  if (error)
    std::rethrow_exception (error);
  return !stopped && reader.getLastError ().empty ();
}

}  // namespace detail
}  // namespace omicron
}  // namespace pclx
