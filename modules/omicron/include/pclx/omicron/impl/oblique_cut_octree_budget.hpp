#pragma once
// The budgeted (out-of-core) build of pcl::ObliqueCutOctree: see oblique_cut_octree.h and
// budget_plan.h. Included by impl/oblique_cut_octree.hpp.
#include <pclx/omicron/budget_plan.h>
#include <pclx/omicron/impl/potree_writer.hpp>
#include <pclx/omicron/oblique_cut_octree.h>
#include <pclx/omicron/point_stream_reader.h>

#include <pcl/point_types.h>

#include <array>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <functional>
#include <limits>
#include <unistd.h>

namespace pcl {
namespace omicron {

// The chunk file: one region per chunk at offsets known from the counts, written with pwrite
// and read back with pread (one descriptor however many chunks). Removed on destruction.
class ChunkFile
{
public:
  explicit ChunkFile (const std::string& path) : path_ (path)
  {
    fd_ = ::open (path.c_str (), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
    if (fd_ < 0)
      throw std::runtime_error ("cannot create the chunk file '" + path + "': " + std::strerror (errno));
  }
  ~ChunkFile ()
  {
    ::close (fd_);
    ::unlink (path_.c_str ());
  }
  ChunkFile (const ChunkFile&) = delete;
  ChunkFile& operator= (const ChunkFile&) = delete;

  void
  write (const void* data, std::size_t bytes, std::uint64_t offset)
  {
    const char* p = static_cast<const char*> (data);
    while (bytes > 0)
    {
      const ssize_t w = ::pwrite (fd_, p, bytes, static_cast<off_t> (offset));
      if (w < 0 && errno == EINTR)
        continue;
      if (w <= 0)
        throw std::runtime_error ("writing the chunk file '" + path_ + "' failed: " + std::strerror (errno));
      p += w;
      bytes -= static_cast<std::size_t> (w);
      offset += static_cast<std::uint64_t> (w);
    }
  }
  void
  read (void* data, std::size_t bytes, std::uint64_t offset) const
  {
    char* p = static_cast<char*> (data);
    while (bytes > 0)
    {
      const ssize_t r = ::pread (fd_, p, bytes, static_cast<off_t> (offset));
      if (r < 0 && errno == EINTR)
        continue;
      if (r <= 0)
        throw std::runtime_error ("reading the chunk file '" + path_ + "' failed" +
                                  (r < 0 ? std::string (": ") + std::strerror (errno) : std::string (" (short)")));
      p += r;
      bytes -= static_cast<std::size_t> (r);
      offset += static_cast<std::uint64_t> (r);
    }
  }

private:
  std::string path_;
  int fd_ = -1;
};

}  // namespace omicron
}  // namespace pcl

template <typename PointT> bool
pcl::ObliqueCutOctree<PointT>::runBudgeted (std::chrono::steady_clock::time_point t0)
{
  using Clock = std::chrono::steady_clock;
  using Ledger = omicron::MemoryLedger;
  const auto since = [&] { return std::chrono::duration<double> (Clock::now () - t0).count (); };
  Ledger ledger;
  const std::size_t budget = budget_;
  const int lmax = params_.max_depth;
  const int threads = params_.threads;
  const std::size_t pb = sizeof (PointT);
  stats_.memory_budget = budget;
  const auto failed = [&] (const std::string& why) {
    stats_.seconds_total = since ();
    stats_.accounted_peak_bytes = ledger.peak ();
    return fail (why);
  };
  const bool from_file = !input_file_.empty ();
  if (!from_file && !input_)
    return failed ("no input cloud or file");
  if (lmax - (params_.leaf_collapse ? 2 : 1) < 1)
    return failed ("a memory budget needs max depth >= 2 (>= 3 with leaf collapse): the tree needs a level to spill at");

  // Fixed overhead, checked before anything is allocated: a partly filled arena block per
  // worker (retained and scratch, nodes and points), a read block of at least 4096 points
  // (stream reader record + its PointXYZRGB copy + the block + the scatter copy + chunk id),
  // the coarsest count grid and small tables.
  const std::size_t slack = static_cast<std::size_t> (threads) * 2 * (1024 * sizeof (Node) + 8192 * pb);
  // MortonSorter::prepare's per-block bucket histograms (its bucket count as it chooses it).
  int bucket_bits = 12;
  while (bucket_bits < 16 && (std::size_t (1) << bucket_bits) < 64 * chunks_)
    ++bucket_bits;
  bucket_bits = std::min (3 * lmax, bucket_bits);
  const std::size_t sort_hist = (4 * static_cast<std::size_t> (threads) + 2) * (std::size_t (1) << bucket_bits) * 8;
  // + one hierarchy.bin chunk buffer at close: at most 1 + 8 + … + 8^4 records of 22 B.
  const std::size_t hierarchy_chunk = 4681 * omicron::potree::kRecordBytes;
  constexpr std::size_t kCloseRecordBytes = 12;
  const std::size_t tables = 64 * 1024 + sort_hist + hierarchy_chunk;
  const std::size_t read_point = 64 + sizeof (pcl::PointXYZRGB) + 2 * pb + 8;
  constexpr std::size_t kMinBlock = 4096;
  const std::size_t minimum = slack + tables + kMinBlock * read_point + omicron::planGridBytes (1);
  if (budget < minimum)
    return failed ("the memory budget of " + std::to_string (budget) + " bytes is below the fixed overhead of one " +
                   "chunk (" + std::to_string (minimum) + " bytes: arena blocks for " + std::to_string (threads) +
                   " threads, a read block of 4096 points, the count grid); nothing was allocated");
  const std::size_t R = std::max (kMinBlock, std::min<std::size_t> (std::size_t (1) << 20, budget / 8 / read_point));
  int G = 1;
  while (G < std::min (lmax, 8) && omicron::planGridBytes (G + 1) <= budget / 4)
    ++G;

  // Output folder (and the chunk file in it): unwritable is an error before any pass.
  std::string dir = output_dir_;
  if (dir.empty ())
  {
    std::string tmpl = (std::filesystem::temp_directory_path () / "pclx_omicron_XXXXXX").string ();
    if (!::mkdtemp (tmpl.data ()))
      return failed (std::string ("cannot create a temporary output folder: ") + std::strerror (errno));
    dir = temp_output_dir_ = tmpl;
  }
  {
    std::error_code ec;
    std::filesystem::create_directories (dir, ec);
    if (ec || !std::filesystem::is_directory (dir))
      return failed ("cannot create the output folder '" + dir + "'" + (ec ? ": " + ec.message () : std::string ()));
  }
  {
    std::lock_guard<std::mutex> g (cube_mutex_);
    used_output_dir_ = dir;
  }
  omicron::ChunkFile chunk_file (dir + "/.omicron_chunks.bin");

  // Blocks of the input in order: the file through the stream reader, or views of the cloud.
  std::unique_ptr<PointStreamReader> reader;
  if (from_file)
    reader.reset (new PointStreamReader (input_file_));
  PointCloud block;
  const auto forEachBlock = [&] (const std::function<void (const PointT*, std::size_t)>& fn) {
    if (reader)
    {
      reader->rewind ();
      while (reader->read (R, block))
      {
        ledger.set (Ledger::kReader, reader->bufferBytes () + block.points.capacity () * pb);
        fn (block.data (), block.size ());
      }
    }
    else
      for (std::size_t b = 0; b < input_->size (); b += R)
        fn (input_->data () + b, std::min (R, input_->size () - b));
  };
  const auto finite = [] (const PointT& p) {
    return std::isfinite (p.x) && std::isfinite (p.y) && std::isfinite (p.z);
  };

  // Pass 1: bounds, made cubic exactly as MortonSorter::prepare does (same codes).
  Eigen::Vector3d origin = origin_;
  double edge = edge_;
  if (!user_cube_)
  {
    Eigen::Array3f l = Eigen::Array3f::Constant (std::numeric_limits<float>::max ()), h = -l;
    forEachBlock ([&] (const PointT* p, std::size_t n) {
      for (std::size_t i = 0; i < n; ++i)
        if (finite (p[i]))
        {
          l = l.min (p[i].getArray3fMap ());
          h = h.max (p[i].getArray3fMap ());
        }
    });
    origin = l.cast<double> ().matrix ();
    const double extent = (h.cast<double> () - l.cast<double> ()).maxCoeff ();
    edge = extent > 0 && std::isfinite (extent) ? extent : 1.0;
    if (!(l <= h).all ())
      origin.setZero ();
  }
  {
    std::lock_guard<std::mutex> g (cube_mutex_);
    root_origin_ = origin;
    root_edge_ = edge;
  }
  const double scale = static_cast<double> (std::uint64_t (1) << lmax) / edge;
  const Eigen::Vector3d hi_corner = origin + Eigen::Vector3d::Constant (edge);
  // 0: keep, 1: NaN/Inf, 2: outside the user cube (as MortonSorter classifies).
  const auto classify = [&] (const PointT& p) -> int {
    if (!finite (p))
      return 1;
    if (user_cube_ && (p.x < origin.x () || p.y < origin.y () || p.z < origin.z () || p.x > hi_corner.x () ||
                       p.y > hi_corner.y () || p.z > hi_corner.z ()))
      return 2;
    return 0;
  };
  // The leaf-level key, shifted for coarser cells (never a code computed at a coarser scale,
  // which could round differently at cell borders).
  const auto key = [&] (const PointT& p) {
    return (MortonCode::spread (MortonCode::toCell (p.x, origin.x (), scale, lmax)) << 2) |
           (MortonCode::spread (MortonCode::toCell (p.y, origin.y (), scale, lmax)) << 1) |
           MortonCode::spread (MortonCode::toCell (p.z, origin.z (), scale, lmax));
  };

  // Pass 2: points per cell of the count grid.
  std::size_t kept = 0, invalid = 0, outside = 0;
  omicron::ChunkPlan plan;
  {
    ledger.set (Ledger::kCountGrid, omicron::planGridBytes (G));
    std::vector<std::uint32_t> counts (std::size_t (1) << (3 * G), 0);
    const int shift = 3 * (lmax - G);
    forEachBlock ([&] (const PointT* p, std::size_t n) {
      for (std::size_t i = 0; i < n; ++i)
      {
        const int c = classify (p[i]);
        if (c == 0)
        {
          ++counts[key (p[i]) >> shift];
          ++kept;
        }
        else
          ++(c == 1 ? invalid : outside);
      }
    });
    if (reader)
      invalid += reader->getDroppedInvalid ();
    stats_.input_points = kept + invalid + outside;
    stats_.kept_points = kept;
    stats_.dropped_invalid = invalid;
    stats_.dropped_outside = outside;
    if (kept >= std::numeric_limits<std::uint32_t>::max ())
      return failed ("more than 2^32 - 1 points (32-bit point counts per node)");
    if (kept == 0)
      return failed (std::string ("the input has no finite point") + (user_cube_ ? " inside the root cube" : "") +
                     " (" + std::to_string (stats_.input_points) + " points, " + std::to_string (invalid) +
                     " NaN/Inf, " + std::to_string (outside) + " outside the root cube); the hierarchy is empty");
    omicron::PlanParameters pp;
    pp.max_depth = lmax;
    pp.count_level = G;
    pp.ratio = params_.parent_ratio;
    pp.collapse = params_.leaf_collapse;
    pp.budget = budget;
    pp.point_bytes = pb;
    pp.encoded_bytes = pcl::traits::has_color_v<PointT> ? 18 : 12;
    pp.scratch_node_bytes = sizeof (Node) + 2 * sizeof (omicron::CutNode<PointT>);
    pp.retained_node_bytes = pp.scratch_node_bytes + 2 * sizeof (typename Front::Entry);
    pp.record_bytes = sizeof (omicron::potree::NodeRecord);
    // hierarchy.bin assembly (potree_format.cpp writeHierarchy): sorted index (4 B), child
    // mask (1 B), chunk members (4 B) per node, a little slack; one chunk's buffer is in tables.
    pp.close_record_bytes = kCloseRecordBytes;
    pp.fixed_bytes = slack + tables;
    plan = omicron::planChunks (counts, pp);
  }
  ledger.set (Ledger::kCountGrid, 0);
  stats_.count_level = G;
  if (plan.spill_level < 0)
    return failed (plan.error + "; raise the budget or lower the max depth");
  const int S = plan.spill_level;
  const std::size_t nchunks = plan.chunk_points.size ();
  stats_.spill_level = S;
  stats_.chunks = nchunks;
  stats_.planned_peak_bytes = plan.peak_bound;
  ledger.set (Ledger::kCountGrid, nchunks * 3 * sizeof (std::uint64_t));

  // Pass 3: whole spill-level cells into chunk regions, in input order (a stable counting
  // sort of each block by chunk), so each chunk's points keep the order the in-memory sort
  // sees and the result is the same.
  {
    std::vector<std::uint64_t> cursor (nchunks + 1, 0);
    for (std::size_t k = 0; k < nchunks; ++k)
      cursor[k + 1] = cursor[k] + plan.chunk_points[k] * pb;
    const std::vector<std::uint64_t> end (cursor.begin () + 1, cursor.end ());
    std::vector<std::uint32_t> ids (R);
    std::vector<std::size_t> count (nchunks + 1);
    typename PointCloud::VectorType scatter (R);
    ledger.set (Ledger::kScatter, R * (sizeof (std::uint32_t) + pb) + 2 * (nchunks + 1) * sizeof (std::uint64_t));
    const int shift = 3 * (lmax - S);
    constexpr std::uint32_t kDrop = std::numeric_limits<std::uint32_t>::max ();
    forEachBlock ([&] (const PointT* p, std::size_t n) {
      std::fill (count.begin (), count.end (), 0);
      for (std::size_t i = 0; i < n; ++i)
      {
        if (classify (p[i]) != 0)
        {
          ids[i] = kDrop;
          continue;
        }
        const std::uint64_t cell = key (p[i]) >> shift;
        ids[i] = static_cast<std::uint32_t> (
            std::upper_bound (plan.cell_begin.begin (), plan.cell_begin.end (), cell) - plan.cell_begin.begin () - 1);
        ++count[ids[i] + 1];
      }
      for (std::size_t k = 0; k < nchunks; ++k)
        count[k + 1] += count[k];
      std::vector<std::size_t> at (count.begin (), count.end () - 1);
      for (std::size_t i = 0; i < n; ++i)
        if (ids[i] != kDrop)
          scatter[at[ids[i]]++] = p[i];
      for (std::size_t k = 0; k < nchunks; ++k)
        if (count[k + 1] > count[k])
        {
          const std::size_t bytes = (count[k + 1] - count[k]) * pb;
          if (cursor[k] + bytes > end[k])
            throw std::runtime_error ("the input changed between passes (more points in a chunk than counted)");
          chunk_file.write (scatter.data () + count[k], bytes, cursor[k]);
          cursor[k] += bytes;
        }
    });
    for (std::size_t k = 0; k < nchunks; ++k)
      if (cursor[k] != end[k])
        return failed ("the input changed between passes (fewer points in a chunk than counted)");
  }
  reader.reset ();
  block = PointCloud ();
  ledger.set (Ledger::kReader, 0);
  ledger.set (Ledger::kScatter, 0);
  stats_.seconds_chunks = stats_.seconds_read = since ();

  // The Potree output; its records are reserved once (plan.node_bound) so they never move.
  PotreeWriter<PointT> writer;
  writer.setParentPointRatio (params_.parent_ratio);
  writer.open (dir, origin, edge);
  writer.reserveNodes (plan.node_bound);
  ledger.set (Ledger::kHierarchyRecords, plan.node_bound * sizeof (omicron::potree::NodeRecord));
  const std::size_t bpp = writer.getMetadata ().bytesPerPoint ();

  // The spill sink, called by the fix workers: writes a dropped subtree and counts it.
  std::mutex error_mutex;
  std::string sink_error;
  std::atomic<bool> sink_failed{false};
  std::array<std::atomic<std::size_t>, MortonCode::kMaxDepth + 1> sp_nodes{}, sp_points{}, sp_leaves{};
  std::atomic<std::size_t> write_now{0}, write_peak{0};
  // Encode buffers in flight: a call writes one record at a time, at most the larger of the
  // leaf point limit and its largest node.
  const auto accountWrite = [&] (std::size_t largest_node, std::size_t subtree_points) {
    const std::size_t wb = bpp * std::min<std::size_t> (subtree_points, std::max<std::size_t> (
                                                                           largest_node, writer.getLeafPointLimit ()));
    const std::size_t now = write_now.fetch_add (wb) + wb;
    std::size_t peak = write_peak.load ();
    while (now > peak && !write_peak.compare_exchange_weak (peak, now))
    {
    }
    return wb;
  };
  // The spill sink, called by the fix workers with a spill-level node and its children:
  // counts the subtrees and writes them.
  const auto sink = [&] (const Node& spilled) {
    if (sink_failed)
      return;
    try
    {
      std::size_t largest = spilled.num_points, points = spilled.num_points;
      std::vector<const Node*> stack;
      for (int c = spilled.num_children - 1; c >= 0; --c)
        stack.push_back (spilled.children + c);
      while (!stack.empty ())
      {
        const Node* n = stack.back ();
        stack.pop_back ();
        largest = std::max<std::size_t> (largest, n->num_points);
        points += n->num_points;
        sp_nodes[n->level].fetch_add (1, std::memory_order_relaxed);
        sp_points[n->level].fetch_add (n->num_points, std::memory_order_relaxed);
        if (n->isLeaf ())
          sp_leaves[n->level].fetch_add (1, std::memory_order_relaxed);
        for (int c = n->num_children - 1; c >= 0; --c)
          stack.push_back (n->children + c);
      }
      const std::size_t wb = accountWrite (largest, points);
      writer.appendSpilled (spilled);
      write_now.fetch_sub (wb);
    }
    catch (const std::exception& e)
    {
      std::lock_guard<std::mutex> g (error_mutex);
      if (!sink_failed)
        sink_error = e.what ();
      sink_failed = true;
    }
  };

  // Chunks in Morton order: load, sort, concatenate, close the chunk's last cell, fix
  // (which spills), free.
  MortonSorter<PointT> sorter;
  sorter.setMaxDepth (lmax);
  sorter.setChunks (chunks_);
  sorter.setThreads (threads);
  sorter.setRootCube (origin, edge);
  PointCloud chunk;
  typename PointCloud::VectorType sorted;
  std::vector<MortonCode> codes;
  std::uint64_t offset = 0;
  const std::size_t entry_bytes = 2 * sizeof (typename Front::Entry);
  for (std::size_t k = 0; k < nchunks; ++k)
  {
    const std::size_t n = plan.chunk_points[k];
    chunk.resize (n);
    ledger.set (Ledger::kChunkInput, chunk.points.capacity () * pb);
    chunk_file.read (chunk.data (), n * pb, offset);
    offset += n * pb;
    ledger.set (Ledger::kSortBuffers, sort_hist);
    if (sorter.prepare (chunk, sorted) != n)
      throw std::runtime_error ("chunk " + std::to_string (k) + " lost points on the way through the chunk file");
    ledger.set (Ledger::kSorted, sorted.capacity () * pb);
    typename PointCloud::VectorType ().swap (chunk.points);
    ledger.set (Ledger::kChunkInput, 0);
    stats_.sorted_bytes = std::max (stats_.sorted_bytes, sorted.capacity () * pb);
    std::size_t leaves = 0;
    for (std::size_t j = 0; j < sorter.numChunks (); ++j)
    {
      sorter.sortChunk (j, sorted, codes);
      ledger.set (Ledger::kSortBuffers, sorter.bufferBytes () + codes.capacity () * sizeof (MortonCode));
      if (!cut_)
      {
        // The first sorted piece fixes the automatic leaf splat radius; then the front and
        // the cut start.
        stats_.seconds_to_first_chunk = since ();
        startCut (codes, origin, edge);
        cut_->setSpill (S, sink);
        spill_level_ = S;
      }
      leaves += concatenateLeaves (codes, sorted.data () + sorter.chunkRange (j).first);
    }
    sorter.release ();
    std::vector<MortonCode> ().swap (codes);
    ledger.set (Ledger::kSortBuffers, 0);
    // Leaves in L_C and their parents on the way up (the segments and merged worklists).
    ledger.set (Ledger::kWorklists, 2 * leaves * sizeof (omicron::CutNode<PointT>));
    const std::uint64_t last = plan.cell_begin[k + 1] - 1;
    cut_->advanceBoundary (MortonCode ((std::uint64_t (1) << (3 * S)) | last).span (lmax));
    write_peak = 0;
    cut_->fix ();
    if (sink_failed)
      return failed ("writing the Potree output to '" + dir + "' failed: " + sink_error);
    // Checkpoint at the chunk's largest: scratch arenas at their end size, plus the largest
    // encode buffers seen in flight during the fix.
    const std::size_t scratch = cut_->scratchBytes ();
    ledger.set (Ledger::kScratchTree, scratch);
    ledger.set (Ledger::kRetainedTree, cut_->memoryBytes () - scratch);
    ledger.set (Ledger::kFront, front_.entryCount () * entry_bytes);
    ledger.set (Ledger::kWriteBuffers, write_peak.load ());
    ledger.set (Ledger::kWriteBuffers, 0);
    cut_->releaseScratch ();
    typename PointCloud::VectorType ().swap (sorted);
    ledger.set (Ledger::kScratchTree, 0);
    ledger.set (Ledger::kSorted, 0);
    ledger.set (Ledger::kWorklists, 0);
  }
  cut_->finishInput ();
  cut_->fix ();
  if (!cut_->isComplete () || !cut_->getRoot ())
    return failed ("internal error: the hierarchy did not complete");
  ledger.set (Ledger::kRetainedTree, cut_->memoryBytes ());
  ledger.set (Ledger::kFront, front_.entryCount () * entry_bytes);

  // The retained tree goes to the same folder (a spilled node stands for what the sink wrote
  // or kept aside), then hierarchy.bin and metadata.json.
  std::size_t largest = 0;
  std::vector<const Node*> stack{cut_->getRoot ()};
  while (!stack.empty ())
  {
    const Node* n = stack.back ();
    stack.pop_back ();
    largest = std::max<std::size_t> (largest, n->num_points);
    for (std::uint8_t j = 0; j < n->num_children; ++j)
      stack.push_back (n->children + j);
  }
  // A merged leaf may also hold points the sink kept aside, so the retained points do not
  // bound a record here: only the largest node and the leaf limit do.
  write_peak = 0;
  const std::size_t wb = accountWrite (largest, std::numeric_limits<std::size_t>::max ());
  writer.appendSubtree (*cut_->getRoot ());
  write_now.fetch_sub (wb);
  ledger.set (Ledger::kWriteBuffers, write_peak.load ());
  ledger.set (Ledger::kWriteBuffers, 0);
  ledger.set (Ledger::kHierarchyRecords, plan.node_bound * sizeof (omicron::potree::NodeRecord) +
                                             writer.nodesWritten () * kCloseRecordBytes + hierarchy_chunk);
  writer.close (kept);
  ledger.set (Ledger::kHierarchyRecords, 0);

  stats_.seconds_total = since ();
  stats_.seconds_to_first_front = front_.secondsToFirstLeaf () < 0 ? stats_.seconds_total
                                                                   : stats_.seconds_to_first_chunk + front_.secondsToFirstLeaf ();
  stats_.hierarchy_bytes = cut_->memoryBytes ();
  stats_.accounted_peak_bytes = ledger.peak ();
  stats_.nodes_per_level.assign (lmax + 1, 0);
  stats_.points_per_level.assign (lmax + 1, 0);
  stats_.leaves_per_level.assign (lmax + 1, 0);
  for (int l = 0; l <= lmax; ++l)
  {
    stats_.nodes_per_level[l] = sp_nodes[l];
    stats_.points_per_level[l] = sp_points[l];
    stats_.leaves_per_level[l] = sp_leaves[l];
    stats_.spilled_nodes += sp_nodes[l];
    stats_.spilled_points += sp_points[l];
  }
  stack.push_back (cut_->getRoot ());
  while (!stack.empty ())
  {
    const Node* n = stack.back ();
    stack.pop_back ();
    ++stats_.nodes_per_level[n->level];
    stats_.points_per_level[n->level] += n->num_points;
    stats_.leaves_per_level[n->level] += n->isLeaf () && !(n->flags & omicron::kSpilled) ? 1 : 0;
    for (std::uint8_t j = 0; j < n->num_children; ++j)
      stack.push_back (n->children + j);
  }
  return true;
}
