#pragma once
#include <pclx/omicron/impl/morton_sorter.hpp>
#include <pclx/omicron/impl/oblique_cut.hpp>
#include <pclx/omicron/impl/oblique_cut_front.hpp>
#include <pclx/omicron/oblique_cut_octree.h>
#include <pclx/omicron/point_stream_reader.h>

#include <pcl/console/print.h>

#include <pclx/omicron/detail/block_reader.h>
#include <pclx/omicron/detail/huge_pages.h>

#include <chrono>
#include <exception>
#include <filesystem>
#include <limits>
#include <stdexcept>
#include <string>

template <typename PointT>
pcl::ObliqueCutOctree<PointT>::~ObliqueCutOctree ()
{
  if (thread_.joinable ())
    thread_.join ();
  removeTempOutput ();
}

template <typename PointT> void
pcl::ObliqueCutOctree<PointT>::removeTempOutput ()
{
  if (temp_output_dir_.empty ())
    return;
  std::error_code ec;
  std::filesystem::remove_all (temp_output_dir_, ec);
  temp_output_dir_.clear ();
}

template <typename PointT> bool
pcl::ObliqueCutOctree<PointT>::fail (const std::string& why)
{
  PCL_ERROR ("[pcl::ObliqueCutOctree::build] %s\n", why.c_str ());
  std::lock_guard<std::mutex> g (cube_mutex_);
  last_error_ = why;
  return false;
}

template <typename PointT> bool
pcl::ObliqueCutOctree<PointT>::checkIdle (const char* method) const
{
  if (!running_)
    return true;
  PCL_ERROR ("[pcl::ObliqueCutOctree::%s] parameters cannot change while a build runs; the call is ignored\n", method);
  return false;
}

template <typename PointT> void
pcl::ObliqueCutOctree<PointT>::setMaxDepth (int depth)
{
  if (!checkIdle ("setMaxDepth"))
    return;
  if (depth < 1 || depth > MortonCode::kMaxDepth)
  {
    PCL_ERROR ("[pcl::ObliqueCutOctree::setMaxDepth] the max depth must be in [1, 21] (got %d); keeping %d\n", depth,
               params_.max_depth);
    return;
  }
  params_.max_depth = depth;
}

template <typename PointT> void
pcl::ObliqueCutOctree<PointT>::setParentPointRatio (float ratio)
{
  if (!checkIdle ("setParentPointRatio"))
    return;
  if (!(ratio > 0.f && ratio <= 1.f))
  {
    PCL_ERROR ("[pcl::ObliqueCutOctree::setParentPointRatio] the parent point ratio must be in (0, 1] (got %g); "
               "keeping %g\n", ratio, params_.parent_ratio);
    return;
  }
  params_.parent_ratio = ratio;
}

template <typename PointT> void
pcl::ObliqueCutOctree<PointT>::setWorklistSize (std::size_t nodes)
{
  if (!checkIdle ("setWorklistSize"))
    return;
  if (nodes < 1)
  {
    PCL_ERROR ("[pcl::ObliqueCutOctree::setWorklistSize] the worklist size must be >= 1; keeping %zu\n",
               params_.worklist_size);
    return;
  }
  params_.worklist_size = nodes;
}

template <typename PointT> void
pcl::ObliqueCutOctree<PointT>::setSortChunks (std::size_t chunks)
{
  if (!checkIdle ("setSortChunks"))
    return;
  if (chunks < 1)
  {
    PCL_ERROR ("[pcl::ObliqueCutOctree::setSortChunks] the sort chunk count must be >= 1; keeping %zu\n", chunks_);
    return;
  }
  chunks_ = chunks;
}

template <typename PointT> void
pcl::ObliqueCutOctree<PointT>::setThreads (int threads)
{
  if (!checkIdle ("setThreads"))
    return;
  if (threads < 1)
  {
    PCL_ERROR ("[pcl::ObliqueCutOctree::setThreads] the thread count must be >= 1 (got %d); keeping %d\n", threads,
               params_.threads);
    return;
  }
  params_.threads = threads;
}

template <typename PointT> void
pcl::ObliqueCutOctree<PointT>::setRootCube (const Eigen::Vector3d& origin, double edge)
{
  if (!checkIdle ("setRootCube"))
    return;
  if (!origin.allFinite () || !(edge > 0) || !std::isfinite (edge))
  {
    PCL_ERROR ("[pcl::ObliqueCutOctree::setRootCube] the root cube needs a finite origin and a finite edge > 0; "
               "keeping the previous setting\n");
    return;
  }
  origin_ = origin;
  edge_ = edge;
  user_cube_ = true;
}

template <typename PointT> void
pcl::ObliqueCutOctree<PointT>::clearRootCube ()
{
  if (checkIdle ("clearRootCube"))
    user_cube_ = false;
}

template <typename PointT> void
pcl::ObliqueCutOctree<PointT>::setSplatMultipliers (const std::vector<float>& m)
{
  if (!checkIdle ("setSplatMultipliers"))
    return;
  bool valid = !m.empty ();
  for (float v : m)
    valid = valid && v > 0.f && std::isfinite (v);
  if (!valid)
  {
    PCL_ERROR ("[pcl::ObliqueCutOctree::setSplatMultipliers] at least one multiplier is needed, each finite and > 0; "
               "keeping the previous ones\n");
    return;
  }
  multipliers_ = m;
}

template <typename PointT> bool
pcl::ObliqueCutOctree<PointT>::build ()
{
  if (!startBuild ())
    return false;
  return wait ();
}

template <typename PointT> bool
pcl::ObliqueCutOctree<PointT>::startBuild ()
{
  if (running_)
  {
    PCL_ERROR ("[pcl::ObliqueCutOctree::startBuild] a build is already running\n");
    return false;
  }
  if (thread_.joinable ())
    thread_.join ();
  running_ = true;
  finished_ = false;
  cut_.reset ();
  removeTempOutput ();
  spill_level_ = -1;
  {
    std::lock_guard<std::mutex> g (cube_mutex_);
    last_error_.clear ();
    used_output_dir_.clear ();
    input_bounds_ = false;
  }
  progress_points_ = 0;
  progress_total_ = 0;
  // The front is emptied here, so evaluate() right after startBuild () sees no stale nodes.
  front_.reset (params_.max_depth, Eigen::Vector3d::Zero (), 1.0, {});
  thread_ = std::thread ([this] {
    result_ = run ();
    // A front kept out of the build starts at the root once the hierarchy is whole.
    if (result_ && !front_during_build_ && cut_ && cut_->getRoot ())
      front_.startFrom (*cut_->getRoot ());
    running_ = false;
    finished_ = true;
  });
  return true;
}

template <typename PointT> bool
pcl::ObliqueCutOctree<PointT>::wait ()
{
  if (thread_.joinable ())
    thread_.join ();
  return result_;
}

template <typename PointT> void
pcl::ObliqueCutOctree<PointT>::setInputSummary (const Eigen::Array3f& lo, const Eigen::Array3f& hi, std::size_t kept)
{
  {
    std::lock_guard<std::mutex> g (cube_mutex_);
    input_lo_ = lo.matrix ();
    input_hi_ = hi.matrix ();
    input_bounds_ = !user_cube_ && (lo <= hi).all ();
  }
  progress_total_ = kept;
}

template <typename PointT> bool
pcl::ObliqueCutOctree<PointT>::getInputBounds (Eigen::Vector3f& lo, Eigen::Vector3f& hi) const
{
  std::lock_guard<std::mutex> g (cube_mutex_);
  lo = input_lo_;
  hi = input_hi_;
  return input_bounds_;
}

template <typename PointT> double
pcl::ObliqueCutOctree<PointT>::getProgress () const
{
  const std::size_t total = progress_total_;
  return total == 0 ? 0.0 : std::min (1.0, static_cast<double> (progress_points_) / static_cast<double> (total));
}

template <typename PointT> template <typename F> bool
pcl::ObliqueCutOctree<PointT>::readFileBlocks (PointStreamReader& reader, F&& on_block)
{
  // 2^18 points: the reader's buffers and the two blocks stay a small share of the memory
  // beside the points held once, while a block still amortises the hand-over.
  constexpr std::size_t kBlock = std::size_t (1) << 18;
  PointCloud blocks[2];
  return pclx::omicron::detail::readBlocksAhead (
      reader, kBlock, blocks,
      [&] (const PointCloud& block) {
        on_block (block);
        return true;
      },
      [] {});
}

// The first sorted chunk fixes the automatic leaf splat radius (leaf cell edge over the
// square root of the mean points per occupied leaf: about the point spacing on a surface);
// then the per-level radii, the front and the cut start.
template <typename PointT> void
pcl::ObliqueCutOctree<PointT>::startCut (const std::vector<MortonCode>& first_chunk_codes,
                                         const Eigen::Vector3d& origin, double edge)
{
  const int lmax = params_.max_depth;
  float leaf_radius = leaf_radius_;
  const double cell = edge / static_cast<double> (std::uint64_t (1) << lmax);
  if (!(leaf_radius > 0.f))
  {
    const auto& codes = first_chunk_codes;
    std::size_t occupied = 0;
    for (std::size_t i = 0; i < codes.size (); ++i)
      occupied += (i == 0 || codes[i] != codes[i - 1]) ? 1 : 0;
    leaf_radius = static_cast<float> (cell / std::sqrt (static_cast<double> (codes.size ()) / occupied));
  }
  radii_.assign (lmax + 1, leaf_radius);
  for (int l = lmax - 1; l >= 0; --l)
    radii_[l] = radii_[l + 1] * multipliers_[std::min<std::size_t> (lmax - 1 - l, multipliers_.size () - 1)];
  front_.reset (lmax, origin, edge, radii_);
  cut_.reset (new ObliqueCut<PointT> (params_));
  cut_->setFront (front_during_build_ ? &front_ : nullptr);
}

// Algorithm 1's inner loop: one leaf per run of equal codes in a sorted chunk (its points
// start at `first`), concatenated in worklists of the configured size. Returns the leaves.
template <typename PointT> std::size_t
pcl::ObliqueCutOctree<PointT>::concatenateLeaves (const std::vector<MortonCode>& codes, PointT* first)
{
  using Worklist = typename ObliqueCut<PointT>::Worklist;
  std::size_t leaves = 0;
  Worklist w;
  w.reserve (params_.worklist_size);
  for (std::size_t i = 0; i < codes.size ();)
  {
    std::size_t j = i + 1;
    while (j < codes.size () && codes[j] == codes[i])
      ++j;
    w.push_back (pclx::omicron::detail::CutNode<PointT>::leaf (codes[i], first + i, static_cast<std::uint32_t> (j - i)));
    ++leaves;
    if (w.size () >= params_.worklist_size)
    {
      progress_points_ += (first + j) - w.front ().points;
      cut_->concatenate (std::move (w));
      w = Worklist ();
      w.reserve (params_.worklist_size);
    }
    i = j;
  }
  if (!w.empty ())
  {
    progress_points_ += (first + codes.size ()) - w.front ().points;
    cut_->concatenate (std::move (w));
  }
  return leaves;
}

template <typename PointT> bool
pcl::ObliqueCutOctree<PointT>::readFileSorted (pclx::omicron::detail::MortonSorter<PointT>& sorter, std::size_t& kept)
{
  PointStreamReader reader;
  if (!reader.open (input_file_))
    return fail (reader.getLastError ());
  // Pass 1: the points in file order into sorted_ (storage for the declared count, in huge
  // pages when they are on; each block's destination is mapped before it is copied in), their
  // bounds folded in as the blocks arrive.
  Eigen::Array3f lo = Eigen::Array3f::Constant (std::numeric_limits<float>::max ());
  Eigen::Array3f hi = Eigen::Array3f::Constant (-std::numeric_limits<float>::max ());
  typename PointCloud::VectorType ().swap (sorted_);
  pclx::omicron::detail::reserveHuge (sorted_, static_cast<std::size_t> (reader.getDeclaredPoints ()));
  const bool read = readFileBlocks (reader, [&] (const PointCloud& block) {
    // Local accumulators, so the bounds stay in registers over the block.
    Eigen::Array3f l = lo, h = hi;
    for (const PointT& p : block)
    {
      l = l.min (p.getArray3fMap ());
      h = h.max (p.getArray3fMap ());
    }
    lo = l;
    hi = h;
    if (sorted_.size () + block.size () <= sorted_.capacity ())
      pclx::omicron::detail::prefault (sorted_.data () + sorted_.size (), block.size () * sizeof (PointT));
    sorted_.insert (sorted_.end (), block.begin (), block.end ());
  });
  if (!read)
    return fail (reader.getLastError ());
  const std::size_t n = sorted_.size ();
  stats_.input_points = n + reader.getDroppedInvalid ();
  // The reader drops NaN/Inf rows, so every point here is finite and the bounds are exact.
  if (!user_cube_)
    sorter.setKnownBounds (lo, hi);
  kept = sorter.countBuckets (sorted_.data (), n);
  stats_.dropped_invalid = reader.getDroppedInvalid () + sorter.getDroppedInvalid ();
  // Pass 2: the same points from the file again, each into its bucket of the same array
  // (kept <= n: shrinking keeps the storage). The file-order copy is overwritten as it goes,
  // and nothing reads it any more.
  sorted_.resize (kept);
  if (!reader.rewind ())
    return fail (reader.getLastError ());
  std::size_t again = 0;
  const bool reread = readFileBlocks (reader, [&] (const PointCloud& block) {
    again += block.size ();
    if (again > n)
      throw std::runtime_error ("the file changed between its two reads (more points the second time)");
    sorter.scatter (block.data (), block.size (), sorted_);
  });
  if (!reread)
    return fail (reader.getLastError ());
  if (again != n)
    return fail ("the file changed between its two reads (" + std::to_string (n) + " then " + std::to_string (again) +
                 " points)");
  return true;
}

// The build thread's body: no exception leaves it (an I/O error deep in the budgeted build,
// or a failed allocation, becomes false + getLastError ()).
template <typename PointT> bool
pcl::ObliqueCutOctree<PointT>::run ()
{
  const auto t0 = std::chrono::steady_clock::now ();
  stats_ = Statistics ();
  try
  {
    return budget_ > 0 ? runBudgeted (t0) : runInMemory (t0);
  }
  catch (const std::exception& e)
  {
    stats_.seconds_total = std::chrono::duration<double> (std::chrono::steady_clock::now () - t0).count ();
    return fail (e.what ());
  }
}

template <typename PointT> bool
pcl::ObliqueCutOctree<PointT>::runInMemory (std::chrono::steady_clock::time_point t0)
{
  using Clock = std::chrono::steady_clock;
  const auto since = [&] { return std::chrono::duration<double> (Clock::now () - t0).count (); };
  // The input: the cloud, bucketed by the sorter into sorted_, or the file, read twice in
  // blocks into sorted_ (readFileSorted).
  if (input_file_.empty () && !input_)
    return fail ("no input cloud");
  const int lmax = params_.max_depth;
  pclx::omicron::detail::MortonSorter<PointT> sorter;
  sorter.setMaxDepth (lmax);
  sorter.setChunks (chunks_);
  sorter.setThreads (params_.threads);
  if (user_cube_)
    sorter.setRootCube (origin_, edge_);
  std::size_t kept = 0;
  if (!input_file_.empty ())
  {
    if (!readFileSorted (sorter, kept))
      return false;
  }
  else
  {
    stats_.input_points = input_->size ();
    kept = sorter.prepare (*input_, sorted_);
    stats_.dropped_invalid = sorter.getDroppedInvalid ();
  }
  stats_.seconds_read = since ();
  stats_.kept_points = kept;
  {
    Eigen::Array3f lo, hi;
    sorter.getBounds (lo, hi);
    setInputSummary (lo, hi, kept);
  }
  stats_.dropped_outside = sorter.getDroppedOutside ();
  stats_.chunks = sorter.numChunks ();
  stats_.sorted_bytes = sorted_.capacity () * sizeof (PointT);
  const Eigen::Vector3d origin = sorter.getOrigin ();
  const double edge = sorter.getEdge ();
  {
    std::lock_guard<std::mutex> g (cube_mutex_);
    root_origin_ = origin;
    root_edge_ = edge;
  }
  if (kept == 0)
  {
    stats_.seconds_total = since ();
    return fail (std::string ("the cloud has no finite point") + (user_cube_ ? " inside the root cube" : "") + " (" +
                 std::to_string (stats_.input_points) + " points, " + std::to_string (stats_.dropped_invalid) +
                 " NaN/Inf, " + std::to_string (stats_.dropped_outside) +
                 " outside the root cube); the hierarchy is empty");
  }

  // The first chunk is sorted here: it fixes the automatic leaf splat radius.
  std::vector<MortonCode> codes;
  sorter.sortChunk (0, sorted_, codes);
  // The first chunk sort allocates the buffers for the largest chunk.
  const std::size_t sort_buffer_bytes = sorter.bufferBytes () + codes.capacity () * sizeof (MortonCode);
  stats_.seconds_to_first_chunk = since ();
  startCut (codes, origin, edge);

  // Sorter thread (Algorithm 1): leaves of each sorted chunk, in worklists, concatenated.
  std::thread sorter_thread ([&] {
    std::vector<MortonCode> chunk_codes = std::move (codes);
    for (std::size_t k = 0; k < sorter.numChunks (); ++k)
    {
      if (k > 0)
        sorter.sortChunk (k, sorted_, chunk_codes);
      concatenateLeaves (chunk_codes, sorted_.data () + sorter.chunkRange (k).first);
    }
    sorter.release ();
    cut_->finishInput ();
  });
  cut_->runMaster ();  // this thread is the fix master
  sorter_thread.join ();
  if (sorter.pointsDifferFromCounted ())
    return fail ("the file changed between its two reads (points moved between Morton buckets)");

  stats_.seconds_total = since ();
  stats_.seconds_to_first_front = front_.secondsToFirstLeaf () < 0 ? stats_.seconds_total
                                                                   : stats_.seconds_to_first_chunk + front_.secondsToFirstLeaf ();
  stats_.hierarchy_bytes = cut_->memoryBytes ();
  stats_.accounted_peak_bytes = stats_.sorted_bytes + sort_buffer_bytes + stats_.hierarchy_bytes;
  stats_.nodes_per_level.assign (lmax + 1, 0);
  stats_.points_per_level.assign (lmax + 1, 0);
  stats_.leaves_per_level.assign (lmax + 1, 0);
  std::vector<const Node*> stack;
  if (cut_->getRoot ())
    stack.push_back (cut_->getRoot ());
  while (!stack.empty ())
  {
    const Node* n = stack.back ();
    stack.pop_back ();
    ++stats_.nodes_per_level[n->level];
    stats_.points_per_level[n->level] += n->num_points;
    stats_.leaves_per_level[n->level] += n->isLeaf () ? 1 : 0;
    for (std::uint8_t j = 0; j < n->num_children; ++j)
      stack.push_back (n->children + j);
  }
  return true;
}

template <typename PointT> typename pcl::ObliqueCutOctree<PointT>::Statistics
pcl::ObliqueCutOctree<PointT>::getStatistics () const
{
  if (running_)
  {
    PCL_ERROR ("[pcl::ObliqueCutOctree::getStatistics] statistics are available after the build\n");
    return Statistics ();
  }
  return stats_;
}

#include <pclx/omicron/impl/oblique_cut_octree_budget.hpp>

#define PCL_INSTANTIATE_ObliqueCutOctree(T) template class PCL_EXPORTS pcl::ObliqueCutOctree<T>;
