#pragma once
#include <pclx/omicron/detail/huge_pages.h>
#include <pclx/omicron/detail/morton_sorter.h>
#include <pclx/omicron/detail/worker_pool.h>

#include <pcl/console/print.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

template <typename PointT> void
pclx::omicron::detail::MortonSorter<PointT>::setMaxDepth (int depth)
{
  if (depth < 1 || depth > MortonCode::kMaxDepth)
  {
    PCL_ERROR ("[MortonSorter::setMaxDepth] the max depth must be in [1, 21] (got %d); keeping %d\n", depth, max_depth_);
    return;
  }
  max_depth_ = depth;
}

template <typename PointT> void
pclx::omicron::detail::MortonSorter<PointT>::setChunks (std::size_t chunks)
{
  if (chunks < 1)
  {
    PCL_ERROR ("[MortonSorter::setChunks] the chunk count must be >= 1; keeping %zu\n", chunks_);
    return;
  }
  chunks_ = chunks;
}

template <typename PointT> void
pclx::omicron::detail::MortonSorter<PointT>::setRootCube (const Eigen::Vector3d& origin, double edge)
{
  if (!origin.allFinite () || !(edge > 0) || !std::isfinite (edge))
  {
    PCL_ERROR ("[MortonSorter::setRootCube] the root cube needs a finite origin and a finite edge > 0\n");
    return;
  }
  origin_ = origin;
  edge_ = edge;
  user_cube_ = true;
}

template <typename PointT> void
pclx::omicron::detail::MortonSorter<PointT>::setCubeFromBounds (const Eigen::Array3f& l, const Eigen::Array3f& h)
{
  bounds_lo_ = l;
  bounds_hi_ = h;
  origin_ = l.cast<double> ().matrix ();
  const double extent = (h.cast<double> () - l.cast<double> ()).maxCoeff ();
  // All points identical (or none): any positive edge puts them in cell 0.
  edge_ = extent > 0 && std::isfinite (extent) ? extent : 1.0;
  if (!(l <= h).all ())
    origin_.setZero ();
}

template <typename PointT> void
pclx::omicron::detail::MortonSorter<PointT>::setKnownBounds (const Eigen::Array3f& lo, const Eigen::Array3f& hi)
{
  known_lo_ = lo;
  known_hi_ = hi;
  known_bounds_ = true;
}

template <typename PointT> inline int
pclx::omicron::detail::MortonSorter<PointT>::classify (const PointT& p) const
{
  if (!std::isfinite (p.x) || !std::isfinite (p.y) || !std::isfinite (p.z))
    return 1;
  if (user_cube_ && (p.x < origin_.x () || p.y < origin_.y () || p.z < origin_.z () || p.x > hi_corner_.x () ||
                     p.y > hi_corner_.y () || p.z > hi_corner_.z ()))
    return 2;
  return 0;
}

template <typename PointT> inline std::uint64_t
pclx::omicron::detail::MortonSorter<PointT>::leafKey (const PointT& p) const
{
  return (MortonCode::spread (MortonCode::toCell (p.x, origin_.x (), scale_, max_depth_)) << 2) |
         (MortonCode::spread (MortonCode::toCell (p.y, origin_.y (), scale_, max_depth_)) << 1) |
         MortonCode::spread (MortonCode::toCell (p.z, origin_.z (), scale_, max_depth_));
}

template <typename PointT> void
pclx::omicron::detail::MortonSorter<PointT>::fixCube (const PointT* points, std::size_t n, std::size_t blocks,
                                                      WorkerPool& pool)
{
  if (known_bounds_ && !user_cube_)
  {
    setCubeFromBounds (known_lo_, known_hi_);
    known_bounds_ = false;
  }
  else if (!user_cube_)
  {
    std::vector<Eigen::Array3f> lo (blocks, Eigen::Array3f::Constant (std::numeric_limits<float>::max ()));
    std::vector<Eigen::Array3f> hi (blocks, Eigen::Array3f::Constant (-std::numeric_limits<float>::max ()));
    pool.parallelFor (blocks, [&] (std::size_t b, int) {
      // Local accumulators: the vectors' elements would be stored back on every point.
      Eigen::Array3f l = lo[b], h = hi[b];
      for (std::size_t i = n * b / blocks, end = n * (b + 1) / blocks; i < end; ++i)
        if (std::isfinite (points[i].x) && std::isfinite (points[i].y) && std::isfinite (points[i].z))
        {
          l = l.min (points[i].getArray3fMap ());
          h = h.max (points[i].getArray3fMap ());
        }
      lo[b] = l;
      hi[b] = h;
    });
    Eigen::Array3f l = lo[0], h = hi[0];
    for (std::size_t b = 1; b < blocks; ++b)
    {
      l = l.min (lo[b]);
      h = h.max (hi[b]);
    }
    setCubeFromBounds (l, h);
  }
  // Top bits per bucket: enough buckets to cut `chunks_` balanced chunks, but small enough
  // that per-block histograms stay in cache.
  const int total_bits = 3 * max_depth_;
  int want = 12;
  while (want < 16 && (std::size_t (1) << want) < 64 * chunks_)
    ++want;
  bucket_bits_ = std::min (total_bits, want);
  shift_ = total_bits - bucket_bits_;
  scale_ = static_cast<double> (std::uint64_t (1) << max_depth_) / edge_;
  hi_corner_ = origin_ + Eigen::Vector3d::Constant (edge_);
}

template <typename PointT> std::vector<std::size_t>
pclx::omicron::detail::MortonSorter<PointT>::countPerBlock (const PointT* points, std::size_t n, std::size_t blocks,
                                                            WorkerPool& pool)
{
  const std::size_t nb = std::size_t (1) << bucket_bits_;
  std::vector<std::size_t> hist (blocks * nb, 0);
  std::vector<std::size_t> bad (blocks, 0), outside (blocks, 0);
  pclx::omicron::detail::reservePrefaulted (bucket_of_, n);
  bucket_of_.assign (n, 0);
  pool.parallelFor (blocks, [&] (std::size_t b, int) {
    std::size_t* h = hist.data () + b * nb;
    for (std::size_t i = n * b / blocks, end = n * (b + 1) / blocks; i < end; ++i)
    {
      const int c = classify (points[i]);
      if (c == 0)
      {
        bucket_of_[i] = static_cast<std::uint16_t> (leafKey (points[i]) >> shift_);
        ++h[bucket_of_[i]];
      }
      else
        ++(c == 1 ? bad[b] : outside[b]);
    }
  });
  for (std::size_t b = 0; b < blocks; ++b)
  {
    dropped_invalid_ += bad[b];
    dropped_outside_ += outside[b];
  }
  return hist;
}

template <typename PointT> void
pclx::omicron::detail::MortonSorter<PointT>::makeChunks (const std::vector<std::size_t>& bucket_start)
{
  // Chunks: whole buckets, boundaries at the bucket edge nearest each quantile j·n/k.
  const std::size_t sum = bucket_start.back ();
  chunk_begin_.assign (1, 0);
  if (sum == 0)
    return;
  for (std::size_t k = 1; k < chunks_; ++k)
  {
    const double target = static_cast<double> (sum) * static_cast<double> (k) / static_cast<double> (chunks_);
    const auto it = std::lower_bound (bucket_start.begin (), bucket_start.end (), target,
                                      [] (std::size_t v, double t) { return static_cast<double> (v) < t; });
    std::size_t pos = *it;
    if (it != bucket_start.begin () && target - static_cast<double> (*(it - 1)) < static_cast<double> (*it) - target)
      pos = *(it - 1);
    if (pos > chunk_begin_.back () && pos < sum)
      chunk_begin_.push_back (pos);
  }
  chunk_begin_.push_back (sum);
}

template <typename PointT> std::vector<std::size_t>
pclx::omicron::detail::MortonSorter<PointT>::startPass (const PointT* points, std::size_t n, WorkerPool& pool,
                                                        std::size_t& blocks, std::vector<std::size_t>& bucket_start)
{
  if (n >= std::numeric_limits<std::uint32_t>::max ())
    throw std::length_error ("MortonSorter: more than 2^32 - 1 points (32-bit point counts per node)");
  chunk_begin_.clear ();
  dropped_invalid_ = dropped_outside_ = 0;
  bucket_start_.clear ();
  streamed_ = false;
  scattered_ = 0;
  moved_points_ = false;
  // Contiguous blocks in input order: per-block histograms make the scatter stable.
  blocks = std::max<std::size_t> (1, std::min<std::size_t> (4 * threads_, n / 4096 + 1));
  fixCube (points, n, blocks, pool);
  std::vector<std::size_t> offsets = countPerBlock (points, n, blocks, pool);
  // Exclusive offsets, bucket-major then block: a scatter keeps input order per bucket.
  const std::size_t nb = std::size_t (1) << bucket_bits_;
  bucket_start.assign (nb + 1, 0);
  std::size_t sum = 0;
  for (std::size_t k = 0; k < nb; ++k)
  {
    bucket_start[k] = sum;
    for (std::size_t b = 0; b < blocks; ++b)
    {
      const std::size_t c = offsets[b * nb + k];
      offsets[b * nb + k] = sum;
      sum += c;
    }
  }
  bucket_start[nb] = sum;
  return offsets;
}

template <typename PointT> std::size_t
pclx::omicron::detail::MortonSorter<PointT>::prepare (const PointCloud<PointT>& cloud, PointVector& sorted)
{
  const std::size_t n = cloud.size ();
  pclx::omicron::detail::WorkerPool pool (threads_);
  std::size_t blocks = 0;
  std::vector<std::size_t> bucket_start;
  std::vector<std::size_t> offsets = startPass (cloud.data (), n, pool, blocks, bucket_start);
  const std::size_t nb = bucket_start.size () - 1, sum = bucket_start.back ();
  // Fresh storage, mapped in one call (in huge pages when they are on) before resize () writes it.
  PointVector ().swap (sorted);
  pclx::omicron::detail::reservePrefaulted (sorted, sum);
  sorted.resize (sum);
  pool.parallelFor (blocks, [&] (std::size_t b, int) {
    std::size_t* h = offsets.data () + b * nb;
    for (std::size_t i = n * b / blocks, end = n * (b + 1) / blocks; i < end; ++i)
      if (classify (cloud[i]) == 0)
        sorted[h[bucket_of_[i]]++] = cloud[i];
  });
  std::vector<std::uint16_t> ().swap (bucket_of_);
  makeChunks (bucket_start);
  bucket_start_ = std::move (bucket_start);
  return sum;
}

template <typename PointT> std::size_t
pclx::omicron::detail::MortonSorter<PointT>::countBuckets (const PointT* points, std::size_t n)
{
  pclx::omicron::detail::WorkerPool pool (threads_);
  std::size_t blocks = 0;
  std::vector<std::size_t> bucket_start;
  startPass (points, n, pool, blocks, bucket_start);
  // scatter () advances next_ as the points arrive, so each bucket keeps their arrival order.
  const std::size_t sum = bucket_start.back ();
  next_.assign (bucket_start.begin (), bucket_start.end () - 1);
  end_.assign (bucket_start.begin () + 1, bucket_start.end ());
  makeChunks (bucket_start);
  bucket_start_ = std::move (bucket_start);
  streamed_ = true;
  return sum;
}

template <typename PointT> void
pclx::omicron::detail::MortonSorter<PointT>::scatter (const PointT* points, std::size_t n, PointVector& sorted)
{
  if (scattered_ + n > bucket_of_.size ())
    throw std::runtime_error ("MortonSorter: more points streamed than counted");
  const std::uint16_t* bucket = bucket_of_.data () + scattered_;
  for (std::size_t i = 0; i < n; ++i)
    if (classify (points[i]) == 0)
    {
      std::size_t& at = next_[bucket[i]];
      if (at >= end_[bucket[i]] || at >= sorted.size ())
        throw std::runtime_error ("MortonSorter: the streamed points differ from the counted ones");
      sorted[at++] = points[i];
    }
  scattered_ += n;
  if (scattered_ == bucket_of_.size ())
    std::vector<std::uint16_t> ().swap (bucket_of_);
}

template <typename PointT> void
pclx::omicron::detail::MortonSorter<PointT>::sortKeysBelowBucket (std::size_t m, SortScratch& s) const
{
  // No bits below the bucket bits: every key of the bucket is the same.
  if (shift_ == 0)
    return;
  // Small buckets: insertion sort (stable), cheaper than clearing the digit histograms.
  constexpr std::size_t kInsertion = 32;
  if (m <= kInsertion)
  {
    for (std::size_t i = 1; i < m; ++i)
    {
      const KeyIndex x = s.keys[i];
      std::size_t j = i;
      for (; j > 0 && s.keys[j - 1].key > x.key; --j)
        s.keys[j] = s.keys[j - 1];
      s.keys[j] = x;
    }
    return;
  }
  // Stable LSD radix sort (hand-written because Boost's spreadsort is not stable, and equal
  // codes must keep input order for a deterministic parent sampling). Only the shift_ bits
  // below the bucket bits can differ, in digits of at most 11 bits; digits where every key
  // agrees are skipped.
  constexpr int kMaxDigit = 11;
  const int passes = (shift_ + kMaxDigit - 1) / kMaxDigit;
  const int digit = (shift_ + passes - 1) / passes;
  const std::size_t bins = std::size_t (1) << digit;
  s.counts.assign (static_cast<std::size_t> (passes) * bins, 0);
  for (std::size_t i = 0; i < m; ++i)
    for (int d = 0; d < passes; ++d)
      ++s.counts[d * bins + ((s.keys[i].key >> (d * digit)) & (bins - 1))];
  for (int d = 0; d < passes; ++d)
  {
    std::uint32_t* c = s.counts.data () + d * bins;
    if (std::any_of (c, c + bins, [m] (std::uint32_t v) { return v == m; }))
      continue;
    std::uint32_t sum = 0;
    for (std::size_t v = 0; v < bins; ++v)
    {
      const std::uint32_t here = c[v];
      c[v] = sum;
      sum += here;
    }
    for (std::size_t i = 0; i < m; ++i)
      s.keys_tmp[c[(s.keys[i].key >> (d * digit)) & (bins - 1)]++] = s.keys[i];
    s.keys.swap (s.keys_tmp);
  }
}

template <typename PointT> bool
pclx::omicron::detail::MortonSorter<PointT>::sortBucket (std::size_t q, PointT* points, std::size_t m,
                                                         MortonCode* codes, SortScratch& s) const
{
  bool moved = false;
  for (std::size_t i = 0; i < m; ++i)
  {
    s.keys[i].key = leafKey (points[i]);
    s.keys[i].index = static_cast<std::uint32_t> (i);
    moved = moved || (s.keys[i].key >> shift_) != q;
  }
  sortKeysBelowBucket (m, s);
  const std::uint64_t prefix = std::uint64_t (1) << (3 * max_depth_);
  for (std::size_t i = 0; i < m; ++i)
  {
    s.points[i] = points[s.keys[i].index];
    codes[i] = MortonCode (prefix | s.keys[i].key);
  }
  std::copy (s.points.begin (), s.points.begin () + m, points);
  return moved;
}

template <typename PointT> void
pclx::omicron::detail::MortonSorter<PointT>::sortChunk (std::size_t k, PointVector& sorted, std::vector<MortonCode>& codes)
{
  const std::size_t b = chunk_begin_[k], e = chunk_begin_[k + 1], n = e - b;
  const std::size_t nb = bucket_start_.size () - 1;
  if (!sort_pool_)
    sort_pool_.reset (new WorkerPool (threads_));
  std::size_t largest_bucket = 0, largest_chunk = 0;
  for (std::size_t q = 0; q < nb; ++q)
    largest_bucket = std::max (largest_bucket, bucket_start_[q + 1] - bucket_start_[q]);
  for (std::size_t j = 0; j + 1 < chunk_begin_.size (); ++j)
    largest_chunk = std::max (largest_chunk, chunk_begin_[j + 1] - chunk_begin_[j]);
  // One scratch per thread, but never more scratch than one largest chunk's worth (the bound
  // a memory budget plans with): buckets of more than half a chunk (heavy duplicates) are
  // sorted on one thread.
  const std::size_t scratches = std::max<std::size_t> (
      1, std::min<std::size_t> (sort_pool_->size (), largest_bucket > 0 ? largest_chunk / largest_bucket : 1));
  scratch_.resize (scratches);
  for (SortScratch& s : scratch_)
    if (s.keys.size () < largest_bucket)
    {
      s.keys.resize (largest_bucket);
      s.keys_tmp.resize (largest_bucket);
      s.points.resize (largest_bucket);
    }
  if (codes.capacity () < n)
    pclx::omicron::detail::reservePrefaulted (codes, largest_chunk);
  codes.resize (n);
  // Chunk boundaries are bucket starts, so the chunk is its buckets in order.
  const std::size_t first =
      std::lower_bound (bucket_start_.begin (), bucket_start_.end (), b) - bucket_start_.begin ();
  std::size_t last = first;
  while (last < nb && bucket_start_[last] < e)
    ++last;
  std::vector<char> moved (scratch_.size (), 0);
  const auto sortOne = [&] (std::size_t i, int worker) {
    const std::size_t q = first + i, s = bucket_start_[q], t = bucket_start_[q + 1];
    if (t > s && sortBucket (q, sorted.data () + s, t - s, codes.data () + (s - b), scratch_[worker]))
      moved[worker] = 1;
  };
  if (scratch_.size () == static_cast<std::size_t> (sort_pool_->size ()))
    sort_pool_->parallelFor (last - first, sortOne);
  else
    for (std::size_t i = first; i < last; ++i)
      sortOne (i - first, 0);
  // After a streaming scatter, every point must lie in its own bucket.
  for (char m : moved)
    moved_points_ = moved_points_ || (streamed_ && m != 0);
}

template <typename PointT> void
pclx::omicron::detail::MortonSorter<PointT>::release ()
{
  scratch_ = {};
  sort_pool_.reset ();
  next_ = {};
  end_ = {};
  bucket_of_ = {};
  bucket_start_ = {};
}

#define PCL_INSTANTIATE_MortonSorter(T) template class PCL_EXPORTS pclx::omicron::detail::MortonSorter<T>;
