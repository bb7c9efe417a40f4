#pragma once
// pclx::omicron::detail::MortonSorter: partial Morton sort of an unsorted cloud in chunks (OMiCroN §4.1,
// Algorithm 1's partial_sort), so that hierarchy creation starts after the first chunk.
//
//   prepare ()    bounds → root cube; one counting pass on the top Morton bits and one stable
//                 scatter of the finite points into buckets (MSD radix) of ONE output array;
//                 NaN/Inf points (and points outside a user root cube) are dropped and counted.
//   sortChunk (k) consecutive buckets form chunk k; each of its buckets is sorted in place
//                 with a stable LSD radix sort on the code bits below the bucket bits (the
//                 bucket stays in cache), the buckets shared among the threads, and the chunk
//                 is handed on; it never moves again.
//
// Equal codes keep input order (both passes are stable), so what is built from the sorted
// array does not depend on the thread or chunk count.
#include <pclx/omicron/detail/worker_pool.h>
#include <pclx/omicron/morton_code.h>

#include <pcl/point_cloud.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

namespace pclx {
namespace omicron {
namespace detail {

using pcl::MortonCode;
using pcl::PointCloud;

template <typename PointT>
class MortonSorter
{
public:
  using PointVector = typename PointCloud<PointT>::VectorType;

  // Leaf depth of the codes (1..21; otherwise PCL_ERROR and the value is kept).
  void setMaxDepth (int depth);
  int getMaxDepth () const { return max_depth_; }
  // At most this many chunks (>= 1). Chunks are made of whole buckets, so a cloud whose points
  // share few top-bit buckets (heavy duplicates) gets fewer.
  void setChunks (std::size_t chunks);
  std::size_t getChunks () const { return chunks_; }
  // Root cube [origin, origin + edge)^3; without it the cube is the cloud's bounds made cubic
  // (min corner, longest side). Points outside a given cube are dropped and counted.
  void setRootCube (const Eigen::Vector3d& origin, double edge);
  void clearRootCube () { user_cube_ = false; }
  void setThreads (int threads) { threads_ = threads < 1 ? 1 : threads; }
  // The finite points' bounds, when the caller already has them (e.g. gathered while reading
  // the file): the next prepare () skips its bounds pass and makes the same cube from them.
  // Ignored with a root cube; used by one prepare () only.
  void setKnownBounds (const Eigen::Array3f& lo, const Eigen::Array3f& hi);

  // Reads `cloud` into `sorted` (resized to the kept points, bucketed). Returns the kept count.
  // Throws std::length_error above 2^32 - 1 points (the octree's build thread catches it).
  std::size_t prepare (const PointCloud<PointT>& cloud, PointVector& sorted);

  // The same in two steps, for points streamed twice from a file (never held beside `sorted`):
  // countBuckets (points, n) fixes the cube (bounds as prepare () takes them), counts the
  // points per bucket and records each point's bucket; returns the kept count, the size
  // `sorted` must have. Then the same points, in the same order, are given to scatter () in
  // blocks of any size, which places each kept one in its recorded bucket, in arrival order
  // (the order prepare () keeps), without computing its code again. `points` may be `sorted`'s
  // own storage: countBuckets only reads it. scatter throws std::runtime_error when more
  // points arrive than were counted or a bucket overflows; a point that moved between the two
  // reads is found by sortChunk () (pointsDifferFromCounted ()).
  std::size_t countBuckets (const PointT* points, std::size_t n);
  void scatter (const PointT* points, std::size_t n, PointVector& sorted);
  // Whether a sorted chunk held a point whose code lies outside the chunk's buckets: the
  // scattered points were not the counted ones (a file that changed between its reads).
  bool pointsDifferFromCounted () const { return moved_points_; }

  std::size_t numChunks () const { return chunk_begin_.empty () ? 0 : chunk_begin_.size () - 1; }
  std::pair<std::size_t, std::size_t> chunkRange (std::size_t k) const { return {chunk_begin_[k], chunk_begin_[k + 1]}; }
  // Sorts chunk k of `sorted` (the array given to prepare) in place; `codes` receives the
  // depth-max_depth code of each of its points, in order.
  void sortChunk (std::size_t k, PointVector& sorted, std::vector<MortonCode>& codes);
  // Frees the chunk buffers (call after the last chunk).
  void release ();
  // Bytes of the sort buffers now allocated (keys, digit counts and the point scratch, each
  // sized for the largest bucket).
  std::size_t
  bufferBytes () const
  {
    std::size_t bytes = 0;
    for (const SortScratch& s : scratch_)
      bytes += (s.keys.capacity () + s.keys_tmp.capacity ()) * sizeof (KeyIndex) +
               s.counts.capacity () * sizeof (std::uint32_t) + s.points.capacity () * sizeof (PointT);
    return bytes;
  }

  // prepare() + every chunk in order; on_chunk (begin, end, codes) is called as each is sorted.
  template <typename F> std::size_t
  sort (const PointCloud<PointT>& cloud, PointVector& sorted, F&& on_chunk)
  {
    const std::size_t n = prepare (cloud, sorted);
    std::vector<MortonCode> codes;
    for (std::size_t k = 0; k < numChunks (); ++k)
    {
      sortChunk (k, sorted, codes);
      on_chunk (chunk_begin_[k], chunk_begin_[k + 1], codes);
    }
    release ();
    return n;
  }

  // The finite points' bounds the last pass made its cube from; false with a root cube.
  bool
  getBounds (Eigen::Array3f& lo, Eigen::Array3f& hi) const
  {
    lo = bounds_lo_;
    hi = bounds_hi_;
    return !user_cube_;
  }
  const Eigen::Vector3d& getOrigin () const { return origin_; }
  double getEdge () const { return edge_; }
  std::size_t getDroppedInvalid () const { return dropped_invalid_; }
  std::size_t getDroppedOutside () const { return dropped_outside_; }
  int getBucketBits () const { return bucket_bits_; }

private:
  struct KeyIndex
  {
    std::uint64_t key;  // interleaved bits without the prefix
    std::uint32_t index;
  };
  // One sort thread's buffers, each sized for the largest bucket.
  struct SortScratch
  {
    std::vector<KeyIndex> keys, keys_tmp;
    std::vector<std::uint32_t> counts;  // per-digit histograms
    PointVector points;
  };
  // Sorts bucket q (its m points at `points`) by leaf code, stably, and writes the codes.
  // Returns whether a point's code lies outside the bucket.
  bool sortBucket (std::size_t q, PointT* points, std::size_t m, MortonCode* codes, SortScratch& s) const;
  // Stable sort of s.keys[0, m) on the key bits below the bucket bits.
  void sortKeysBelowBucket (std::size_t m, SortScratch& s) const;
  void setCubeFromBounds (const Eigen::Array3f& lo, const Eigen::Array3f& hi);
  // The stages prepare () and countBuckets () share, so both make the same buckets and chunks:
  // the root cube (user cube, known bounds or a bounds pass) and the bucket bits; per-block
  // bucket counts of the kept points (drops counted); chunk boundaries from bucket starts.
  void fixCube (const PointT* points, std::size_t n, std::size_t blocks, WorkerPool& pool);
  std::vector<std::size_t> countPerBlock (const PointT* points, std::size_t n, std::size_t blocks, WorkerPool& pool);
  void makeChunks (const std::vector<std::size_t>& bucket_start);
  // The start of both passes: the count checked, chunks, drop counts and the streaming
  // scatter's state reset, the cube fixed, the points counted per bucket in `blocks`
  // contiguous blocks in input order. Returns each block's first slot per bucket
  // (block-major); bucket_start gets the bucket starts and the total at the end.
  std::vector<std::size_t> startPass (const PointT* points, std::size_t n, WorkerPool& pool, std::size_t& blocks,
                                      std::vector<std::size_t>& bucket_start);
  // 0: keep, 1: NaN/Inf, 2: outside the user cube.
  int classify (const PointT& p) const;
  // The leaf-level interleaved bits of p's cell (no prefix bit) in the current cube.
  std::uint64_t leafKey (const PointT& p) const;

  int max_depth_ = 7;
  std::size_t chunks_ = 16;
  int threads_ = 1;
  bool user_cube_ = false;
  bool known_bounds_ = false;
  Eigen::Array3f known_lo_ = Eigen::Array3f::Zero (), known_hi_ = Eigen::Array3f::Zero ();
  Eigen::Array3f bounds_lo_ = Eigen::Array3f::Zero (), bounds_hi_ = Eigen::Array3f::Zero ();
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero ();
  double edge_ = 1.0;
  double scale_ = 1.0;  // leaf cells per unit length
  Eigen::Vector3d hi_corner_ = Eigen::Vector3d::Ones ();
  int bucket_bits_ = 0, shift_ = 0;
  std::size_t dropped_invalid_ = 0, dropped_outside_ = 0;
  std::vector<std::size_t> chunk_begin_;  // numChunks () + 1 offsets into the sorted array
  std::vector<std::size_t> next_, end_;  // streaming scatter: next free slot and end per bucket
  // Bucket of each counted point in input order, from the count to the scatter (bucket bits
  // are at most 16), and how many points the streaming scatter has been given so far.
  std::vector<std::uint16_t> bucket_of_;
  std::size_t scattered_ = 0;
  std::vector<std::size_t> bucket_start_;  // first slot of each bucket, and the total at the end
  bool streamed_ = false;  // the points came through scatter (): sortChunk checks their buckets
  bool moved_points_ = false;
  std::vector<SortScratch> scratch_;  // one per sort thread
  std::unique_ptr<WorkerPool> sort_pool_;
};

}  // namespace detail
}  // namespace omicron
}  // namespace pclx
