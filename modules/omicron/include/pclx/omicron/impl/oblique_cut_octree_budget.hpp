#pragma once
// The budgeted (out-of-core) build of pcl::ObliqueCutOctree: see oblique_cut_octree.h and
// budget_plan.h. Included by impl/oblique_cut_octree.hpp.
//
// runBudgeted () runs these stages on one shared state (Budgeted):
//   planSizes          fixed overheads, read block and count-grid sizes; refuses a budget
//                      below one chunk before anything is allocated
//   prepareOutput      the output folder (a temporary one by default) and the chunk file
//   readBounds         pass 1: the root cube from the input's bounds
//   countAndPlan       pass 2: points per cell of the count grid, then planChunks
//   scatterChunks      pass 3: whole spill-level cells into chunk regions of the chunk file
//   openPotreeOutput   the Potree writer and the spill sink the fix workers call
//   fixChunks          per chunk: load, sort, concatenate, close its last cell, fix (spills)
//   writeRetainedTree  the tree kept in memory, then hierarchy.bin and metadata.json
//   collectBudgetedStatistics  per-level counts of the spilled and the retained nodes
#include <pclx/omicron/detail/block_reader.h>
#include <pclx/omicron/detail/budget_plan.h>
#include <pclx/omicron/detail/huge_pages.h>
#include <pclx/omicron/impl/potree_writer.hpp>
#include <pclx/omicron/oblique_cut_octree.h>
#include <pclx/omicron/point_stream_reader.h>

#include <pcl/point_types.h>

#include <array>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#ifdef __GLIBC__
#include <malloc.h>
#endif
#include <filesystem>
#include <functional>
#include <limits>
#include <unistd.h>

namespace pclx {
namespace omicron {
namespace detail {

// The chunk file: one region per chunk at offsets known from the counts, written with pwrite
// and read back with pread (one descriptor however many chunks). Removed on destruction.
// Each call returns false with the reason in error () on failure.
class ChunkFile
{
public:
  ChunkFile () = default;
  ~ChunkFile ()
  {
    if (fd_ < 0)
      return;
    ::close (fd_);
    ::unlink (path_.c_str ());
  }
  ChunkFile (const ChunkFile&) = delete;
  ChunkFile& operator= (const ChunkFile&) = delete;

  bool
  create (const std::string& path)
  {
    path_ = path;
    fd_ = ::open (path.c_str (), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
    if (fd_ < 0)
      error_ = "cannot create the chunk file '" + path + "': " + std::strerror (errno);
    return fd_ >= 0;
  }
  bool
  write (const void* data, std::size_t bytes, std::uint64_t offset)
  {
    const char* p = static_cast<const char*> (data);
    while (bytes > 0)
    {
      const ssize_t w = ::pwrite (fd_, p, bytes, static_cast<off_t> (offset));
      if (w < 0 && errno == EINTR)
        continue;
      if (w <= 0)
      {
        error_ = "writing the chunk file '" + path_ + "' failed: " + std::strerror (errno);
        return false;
      }
      p += w;
      bytes -= static_cast<std::size_t> (w);
      offset += static_cast<std::uint64_t> (w);
    }
    return true;
  }
  bool
  read (void* data, std::size_t bytes, std::uint64_t offset)
  {
    char* p = static_cast<char*> (data);
    while (bytes > 0)
    {
      const ssize_t r = ::pread (fd_, p, bytes, static_cast<off_t> (offset));
      if (r < 0 && errno == EINTR)
        continue;
      if (r <= 0)
      {
        error_ = "reading the chunk file '" + path_ + "' failed" +
                 (r < 0 ? std::string (": ") + std::strerror (errno) : std::string (" (short)"));
        return false;
      }
      p += r;
      bytes -= static_cast<std::size_t> (r);
      offset += static_cast<std::uint64_t> (r);
    }
    return true;
  }
  const std::string& error () const { return error_; }

private:
  std::string path_, error_;
  int fd_ = -1;
};

// Hands the heap that freed buffers leave behind back to the system. glibc keeps freed blocks in
// the arena of the thread that allocated them, where the next stage's other threads cannot reuse
// them; without this the resident memory exceeds the live buffers the budget plans for.
inline void
releaseFreedHeap ()
{
#ifdef __GLIBC__
  ::malloc_trim (0);
#endif
}

}  // namespace detail
}  // namespace omicron
}  // namespace pclx

// The state one budgeted build shares between its stages.
template <typename PointT>
struct pcl::ObliqueCutOctree<PointT>::Budgeted
{
  using Ledger = pclx::omicron::detail::MemoryLedger;
  using BlockFunction = std::function<bool (const PointT*, std::size_t)>;
  // hierarchy.bin assembly (potree_format.cpp writeHierarchy): sorted index (4 B), child
  // mask (1 B), chunk members (4 B) per node, a little slack.
  static constexpr std::size_t kCloseRecordBytes = 12;
  // The smallest read block, in points.
  static constexpr std::size_t kMinBlock = 4096;

  std::chrono::steady_clock::time_point t0;
  Ledger ledger;
  std::size_t budget = 0;
  int lmax = 0, threads = 1;
  std::size_t pb = sizeof (PointT);  // bytes per point in memory
  // planSizes
  std::size_t slack = 0, sort_hist = 0, hierarchy_chunk = 0, tables = 0;
  std::size_t R = 0;  // points per read block
  int G = 1;          // level of the count grid
  // prepareOutput
  std::string dir;
  pclx::omicron::detail::ChunkFile chunk_file;
  std::unique_ptr<PointStreamReader> reader;  // the input file, or null for the cloud
  const PointCloud* cloud = nullptr;
  PointCloud blocks[2];  // the read blocks in flight
  // readBounds
  bool user_cube = false;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero (), hi_corner = Eigen::Vector3d::Zero ();
  double edge = 1.0, scale = 1.0;
  // countAndPlan
  std::size_t kept = 0;
  pclx::omicron::detail::ChunkPlan plan;
  int S = -1;  // spill level
  std::size_t nchunks = 0;
  // openPotreeOutput and the spill sink
  PotreeWriter<PointT> writer;
  std::size_t bpp = 0;  // Potree bytes per point
  std::mutex error_mutex;
  std::string sink_error;
  std::atomic<bool> sink_failed{false};
  std::array<std::atomic<std::size_t>, MortonCode::kMaxDepth + 1> sp_nodes{}, sp_points{}, sp_leaves{};
  std::atomic<std::size_t> write_now{0}, write_peak{0};

  double
  since () const
  {
    return std::chrono::duration<double> (std::chrono::steady_clock::now () - t0).count ();
  }
  static bool
  finite (const PointT& p)
  {
    return std::isfinite (p.x) && std::isfinite (p.y) && std::isfinite (p.z);
  }
  // 0: keep, 1: NaN/Inf, 2: outside the user cube (as MortonSorter classifies).
  int
  classify (const PointT& p) const
  {
    if (!finite (p))
      return 1;
    if (user_cube && (p.x < origin.x () || p.y < origin.y () || p.z < origin.z () || p.x > hi_corner.x () ||
                      p.y > hi_corner.y () || p.z > hi_corner.z ()))
      return 2;
    return 0;
  }
  // The leaf-level key, shifted for coarser cells (never a code computed at a coarser scale,
  // which could round differently at cell borders).
  std::uint64_t
  key (const PointT& p) const
  {
    return (MortonCode::spread (MortonCode::toCell (p.x, origin.x (), scale, lmax)) << 2) |
           (MortonCode::spread (MortonCode::toCell (p.y, origin.y (), scale, lmax)) << 1) |
           MortonCode::spread (MortonCode::toCell (p.z, origin.z (), scale, lmax));
  }
  // Blocks of the input in order: the file through the stream reader (the next block parsed on
  // a reader thread while fn works on this one), or views of the cloud. False when fn returns
  // false or the reader fails (its getLastError () says why).
  bool
  forEachBlock (const BlockFunction& fn)
  {
    if (reader)
    {
      if (!reader->rewind ())
        return false;
      return pclx::omicron::detail::readBlocksAhead (
          *reader, R, blocks, [&] (const PointCloud& block) { return fn (block.data (), block.size ()); },
          [&] {
            ledger.set (Ledger::kReader,
                        reader->bufferBytes () + (blocks[0].points.capacity () + blocks[1].points.capacity ()) * pb);
          });
    }
    for (std::size_t b = 0; b < cloud->size (); b += R)
      if (!fn (cloud->data () + b, std::min (R, cloud->size () - b)))
        return false;
    return true;
  }
  // Write buffers in flight: a call holds the level of each point it samples (one byte) and
  // writes one record at a time, in pieces of at most the larger of a leaf's points and the
  // writer's piece, or small records a piece per writer thread at a time, beside a piece read
  // back from the pending file.
  std::size_t
  accountWrite (std::size_t largest_node, std::size_t subtree_points, std::size_t sampled_points)
  {
    constexpr std::size_t kPiece = PotreeWriter<PointT>::kPiecePoints;
    const std::size_t wb =
        sampled_points + kPiece * (sizeof (PointT) + 1) +
        bpp * std::min<std::size_t> (subtree_points, std::max ({largest_node, kPiece, writer.getEncodeWindowPoints ()}));
    const std::size_t now = write_now.fetch_add (wb) + wb;
    std::size_t peak = write_peak.load ();
    while (now > peak && !write_peak.compare_exchange_weak (peak, now))
    {
    }
    return wb;
  }
  // The spill sink, called by the fix workers with a spill-level node and its children:
  // counts the subtrees and writes them. It must not throw; the first error is kept.
  void
  sink (const Node& spilled)
  {
    if (sink_failed)
      return;
    std::string error;
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
      const std::size_t wb = accountWrite (largest, points, points);
      if (!writer.appendSpilled (spilled))
        error = writer.getLastError ();
      write_now.fetch_sub (wb);
    }
    catch (const std::exception& e)
    {
      error = e.what ();
    }
    if (error.empty ())
      return;
    std::lock_guard<std::mutex> g (error_mutex);
    if (!sink_failed)
      sink_error = error;
    sink_failed = true;
  }
};

template <typename PointT> bool
pcl::ObliqueCutOctree<PointT>::failBudgeted (Budgeted& b, const std::string& why)
{
  stats_.seconds_total = b.since ();
  stats_.accounted_peak_bytes = b.ledger.peak ();
  return fail (why);
}

template <typename PointT> bool
pcl::ObliqueCutOctree<PointT>::runBudgeted (std::chrono::steady_clock::time_point t0)
{
  Budgeted b;
  b.t0 = t0;
  b.budget = budget_;
  b.lmax = params_.max_depth;
  b.threads = params_.threads;
  stats_.memory_budget = b.budget;
  if (input_file_.empty () && !input_)
    return failBudgeted (b, "no input cloud or file");
  if (b.lmax - (params_.leaf_collapse ? 2 : 1) < 1)
    return failBudgeted (
        b, "a memory budget needs max depth >= 2 (>= 3 with leaf collapse): the tree needs a level to spill at");
  if (!planSizes (b) || !prepareOutput (b) || !readBounds (b) || !countAndPlan (b) || !scatterChunks (b))
    return false;
  pclx::omicron::detail::releaseFreedHeap ();
  if (!openPotreeOutput (b) || !fixChunks (b) || !writeRetainedTree (b))
    return false;
  collectBudgetedStatistics (b);
  return true;
}

template <typename PointT> bool
pcl::ObliqueCutOctree<PointT>::planSizes (Budgeted& b)
{
  const std::size_t pb = b.pb;
  // Fixed overhead, checked before anything is allocated: a partly filled arena block per
  // worker (retained and scratch, nodes and points), a read block of at least 4096 points
  // (stream reader record + its PointXYZRGB copy and intensity + two blocks in flight + the
  // scatter copy + chunk id), the coarsest count grid and small tables.
  using Arena = pclx::omicron::detail::NodeArena<PointT>;
  b.slack = static_cast<std::size_t> (b.threads) * 2 * (1024 / 8 * Arena::groupBytes (8) + 8192 * pb);
  // MortonSorter::prepare's per-block bucket histograms (its bucket count as it chooses it).
  int bucket_bits = 12;
  while (bucket_bits < 16 && (std::size_t (1) << bucket_bits) < 64 * chunks_)
    ++bucket_bits;
  bucket_bits = std::min (3 * b.lmax, bucket_bits);
  b.sort_hist = (4 * static_cast<std::size_t> (b.threads) + 2) * (std::size_t (1) << bucket_bits) * 8;
  // + one hierarchy.bin chunk buffer at close: at most 1 + 8 + … + 8^4 records of 22 B.
  b.hierarchy_chunk = 4681 * pclx::omicron::detail::potree::kRecordBytes;
  b.tables = 64 * 1024 + b.sort_hist + b.hierarchy_chunk;
  const std::size_t read_point = 64 + sizeof (pcl::PointXYZRGB) + sizeof (float) + 3 * pb + 8;
  const std::size_t minimum = b.slack + b.tables + Budgeted::kMinBlock * read_point + pclx::omicron::detail::planGridBytes (1);
  if (b.budget < minimum)
    return failBudgeted (b, "the memory budget of " + std::to_string (b.budget) +
                                " bytes is below the fixed overhead of one chunk (" + std::to_string (minimum) +
                                " bytes: arena blocks for " + std::to_string (b.threads) +
                                " threads, a read block of 4096 points, the count grid); nothing was allocated");
  b.R = std::max (Budgeted::kMinBlock, std::min<std::size_t> (std::size_t (1) << 20, b.budget / 8 / read_point));
  b.G = 1;
  while (b.G < std::min (b.lmax, 8) && pclx::omicron::detail::planGridBytes (b.G + 1) <= b.budget / 4)
    ++b.G;
  return true;
}

template <typename PointT> bool
pcl::ObliqueCutOctree<PointT>::prepareOutput (Budgeted& b)
{
  // Output folder (and the chunk file in it): unwritable is an error before any pass.
  b.dir = output_dir_;
  if (b.dir.empty ())
  {
    std::string tmpl = (std::filesystem::temp_directory_path () / "pclx_omicron_XXXXXX").string ();
    if (!::mkdtemp (tmpl.data ()))
      return failBudgeted (b, std::string ("cannot create a temporary output folder: ") + std::strerror (errno));
    b.dir = temp_output_dir_ = tmpl;
  }
  {
    std::error_code ec;
    std::filesystem::create_directories (b.dir, ec);
    if (ec || !std::filesystem::is_directory (b.dir))
      return failBudgeted (b, "cannot create the output folder '" + b.dir + "'" +
                                  (ec ? ": " + ec.message () : std::string ()));
  }
  {
    std::lock_guard<std::mutex> g (cube_mutex_);
    used_output_dir_ = b.dir;
  }
  if (!b.chunk_file.create (b.dir + "/.omicron_chunks.bin"))
    return failBudgeted (b, b.chunk_file.error ());
  if (!input_file_.empty ())
  {
    b.reader.reset (new PointStreamReader);
    if (!b.reader->open (input_file_))
      return failBudgeted (b, b.reader->getLastError ());
  }
  else
    b.cloud = input_.get ();
  return true;
}

template <typename PointT> bool
pcl::ObliqueCutOctree<PointT>::readBounds (Budgeted& b)
{
  // Pass 1: bounds, made cubic exactly as MortonSorter::prepare does (same codes).
  Eigen::Vector3d origin = origin_;
  double edge = edge_;
  if (!user_cube_)
  {
    Eigen::Array3f l = Eigen::Array3f::Constant (std::numeric_limits<float>::max ()), h = -l;
    const bool read = b.forEachBlock ([&] (const PointT* p, std::size_t n) {
      for (std::size_t i = 0; i < n; ++i)
        if (Budgeted::finite (p[i]))
        {
          l = l.min (p[i].getArray3fMap ());
          h = h.max (p[i].getArray3fMap ());
        }
      return true;
    });
    if (!read)
      return failBudgeted (b, b.reader->getLastError ());
    origin = l.cast<double> ().matrix ();
    const double extent = (h.cast<double> () - l.cast<double> ()).maxCoeff ();
    edge = extent > 0 && std::isfinite (extent) ? extent : 1.0;
    if (!(l <= h).all ())
      origin.setZero ();
    setInputSummary (l, h, 0);
  }
  {
    std::lock_guard<std::mutex> g (cube_mutex_);
    root_origin_ = origin;
    root_edge_ = edge;
  }
  b.user_cube = user_cube_;
  b.origin = origin;
  b.edge = edge;
  b.scale = static_cast<double> (std::uint64_t (1) << b.lmax) / edge;
  b.hi_corner = origin + Eigen::Vector3d::Constant (edge);
  return true;
}

template <typename PointT> bool
pcl::ObliqueCutOctree<PointT>::countAndPlan (Budgeted& b)
{
  using Ledger = typename Budgeted::Ledger;
  // Pass 2: points per cell of the count grid.
  const int G = b.G, lmax = b.lmax;
  std::size_t kept = 0, invalid = 0, outside = 0;
  {
    b.ledger.set (Ledger::kCountGrid, pclx::omicron::detail::planGridBytes (G));
    std::vector<std::uint32_t> counts (std::size_t (1) << (3 * G), 0);
    const int shift = 3 * (lmax - G);
    const bool read = b.forEachBlock ([&] (const PointT* p, std::size_t n) {
      for (std::size_t i = 0; i < n; ++i)
      {
        const int c = b.classify (p[i]);
        if (c == 0)
        {
          ++counts[b.key (p[i]) >> shift];
          ++kept;
        }
        else
          ++(c == 1 ? invalid : outside);
      }
      return true;
    });
    if (!read)
      return failBudgeted (b, b.reader->getLastError ());
    if (b.reader)
      invalid += b.reader->getDroppedInvalid ();
    stats_.input_points = kept + invalid + outside;
    stats_.kept_points = kept;
    stats_.dropped_invalid = invalid;
    stats_.dropped_outside = outside;
    if (kept >= std::numeric_limits<std::uint32_t>::max ())
      return failBudgeted (b, "more than 2^32 - 1 points (32-bit point counts per node)");
    if (kept == 0)
      return failBudgeted (b, std::string ("the input has no finite point") +
                                  (user_cube_ ? " inside the root cube" : "") + " (" +
                                  std::to_string (stats_.input_points) + " points, " + std::to_string (invalid) +
                                  " NaN/Inf, " + std::to_string (outside) +
                                  " outside the root cube); the hierarchy is empty");
    pclx::omicron::detail::PlanParameters pp;
    pp.max_depth = lmax;
    pp.count_level = G;
    pp.ratio = params_.parent_ratio;
    pp.collapse = params_.leaf_collapse;
    pp.budget = b.budget;
    pp.point_bytes = b.pb;
    pp.encoded_bytes = (pcl::traits::has_color_v<PointT> ? 18 : 12) + 1;  // and its level of detail
    // A node with a group header of its own (a group of one), the most a node can take.
    pp.scratch_node_bytes = pclx::omicron::detail::NodeArena<PointT>::groupBytes (1) +
                            2 * sizeof (pclx::omicron::detail::CutNode<PointT>);
    pp.retained_node_bytes = pp.scratch_node_bytes + Front::bytesPerEntry ();
    pp.record_bytes = sizeof (pclx::omicron::detail::potree::NodeRecord);
    // One hierarchy.bin chunk buffer is in the tables.
    pp.close_record_bytes = Budgeted::kCloseRecordBytes;
    pp.fixed_bytes = b.slack + b.tables;
    b.plan = pclx::omicron::detail::planChunks (counts, pp);
  }
  b.kept = kept;
  progress_total_ = kept;
  b.ledger.set (Ledger::kCountGrid, 0);
  stats_.count_level = G;
  if (b.plan.spill_level < 0)
    return failBudgeted (b, b.plan.error + "; raise the budget or lower the max depth");
  b.S = b.plan.spill_level;
  b.nchunks = b.plan.chunk_points.size ();
  stats_.spill_level = b.S;
  stats_.chunks = b.nchunks;
  stats_.planned_peak_bytes = b.plan.peak_bound;
  b.ledger.set (Ledger::kCountGrid, b.nchunks * 3 * sizeof (std::uint64_t));
  return true;
}

template <typename PointT> bool
pcl::ObliqueCutOctree<PointT>::scatterChunks (Budgeted& b)
{
  using Ledger = typename Budgeted::Ledger;
  // Pass 3: whole spill-level cells into chunk regions, in input order (a stable counting
  // sort of each block by chunk), so each chunk's points keep the order the in-memory sort
  // sees and the result is the same.
  const std::size_t nchunks = b.nchunks, pb = b.pb, R = b.R;
  const pclx::omicron::detail::ChunkPlan& plan = b.plan;
  {
    std::vector<std::uint64_t> cursor (nchunks + 1, 0);
    for (std::size_t k = 0; k < nchunks; ++k)
      cursor[k + 1] = cursor[k] + plan.chunk_points[k] * pb;
    const std::vector<std::uint64_t> end (cursor.begin () + 1, cursor.end ());
    std::vector<std::uint32_t> ids (R);
    std::vector<std::size_t> count (nchunks + 1);
    typename PointCloud::VectorType scatter (R);
    // The chunk of each spill-level cell as a table when the cells are few (up to level 4:
    // 8 KiB of the small tables the plan reserves), else a binary search per point.
    constexpr std::size_t kMaxTableCells = std::size_t (1) << 12;
    const std::size_t cells = std::size_t (1) << (3 * b.S);
    std::vector<std::uint16_t> chunk_of;
    if (cells <= kMaxTableCells && nchunks <= std::numeric_limits<std::uint16_t>::max ())
    {
      chunk_of.resize (cells);
      for (std::size_t k = 0; k < nchunks; ++k)
        std::fill (chunk_of.begin () + plan.cell_begin[k], chunk_of.begin () + plan.cell_begin[k + 1],
                   static_cast<std::uint16_t> (k));
    }
    b.ledger.set (Ledger::kScatter, R * (sizeof (std::uint32_t) + pb) + 2 * (nchunks + 1) * sizeof (std::uint64_t) +
                                        chunk_of.capacity () * sizeof (std::uint16_t));
    const int shift = 3 * (b.lmax - b.S);
    constexpr std::uint32_t kDrop = std::numeric_limits<std::uint32_t>::max ();
    const auto chunkOf = [&] (std::uint64_t cell) {
      if (!chunk_of.empty ())
        return static_cast<std::uint32_t> (chunk_of[cell]);
      return static_cast<std::uint32_t> (
          std::upper_bound (plan.cell_begin.begin (), plan.cell_begin.end (), cell) - plan.cell_begin.begin () - 1);
    };
    std::string error;
    const bool read = b.forEachBlock ([&] (const PointT* p, std::size_t n) {
      std::fill (count.begin (), count.end (), 0);
      for (std::size_t i = 0; i < n; ++i)
      {
        if (b.classify (p[i]) != 0)
        {
          ids[i] = kDrop;
          continue;
        }
        ids[i] = chunkOf (b.key (p[i]) >> shift);
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
          {
            error = "the input changed between passes (more points in a chunk than counted)";
            return false;
          }
          if (!b.chunk_file.write (scatter.data () + count[k], bytes, cursor[k]))
          {
            error = b.chunk_file.error ();
            return false;
          }
          cursor[k] += bytes;
        }
      return true;
    });
    if (!read)
      return failBudgeted (b, error.empty () ? b.reader->getLastError () : error);
    for (std::size_t k = 0; k < nchunks; ++k)
      if (cursor[k] != end[k])
        return failBudgeted (b, "the input changed between passes (fewer points in a chunk than counted)");
  }
  b.reader.reset ();
  b.blocks[0] = PointCloud ();
  b.blocks[1] = PointCloud ();
  b.ledger.set (Ledger::kReader, 0);
  b.ledger.set (Ledger::kScatter, 0);
  stats_.seconds_chunks = stats_.seconds_read = b.since ();
  return true;
}

template <typename PointT> bool
pcl::ObliqueCutOctree<PointT>::openPotreeOutput (Budgeted& b)
{
  // The Potree output; its records are reserved once (plan.node_bound) so they never move.
  b.writer.setThreads (b.threads);
  if (!b.writer.open (b.dir, b.origin, b.edge))
    return failBudgeted (b, b.writer.getLastError ());
  b.writer.reserveNodes (b.plan.node_bound);
  b.ledger.set (Budgeted::Ledger::kHierarchyRecords, b.plan.node_bound * sizeof (pclx::omicron::detail::potree::NodeRecord));
  b.bpp = b.writer.getMetadata ().bytesPerPoint ();
  return true;
}

template <typename PointT> bool
pcl::ObliqueCutOctree<PointT>::fixChunks (Budgeted& b)
{
  using Ledger = typename Budgeted::Ledger;
  // Chunks in Morton order: load, sort, concatenate, close the chunk's last cell, fix
  // (which spills), free.
  const std::size_t pb = b.pb;
  const int lmax = b.lmax, S = b.S;
  pclx::omicron::detail::MortonSorter<PointT> sorter;
  sorter.setMaxDepth (lmax);
  sorter.setChunks (chunks_);
  sorter.setThreads (b.threads);
  sorter.setRootCube (b.origin, b.edge);
  PointCloud chunk;
  typename PointCloud::VectorType sorted;
  std::vector<MortonCode> codes;
  std::uint64_t offset = 0;
  const std::size_t entry_bytes = Front::bytesPerEntry ();
  for (std::size_t k = 0; k < b.nchunks; ++k)
  {
    const std::size_t n = b.plan.chunk_points[k];
    pclx::omicron::detail::reservePrefaulted (chunk.points, n);
    chunk.resize (n);
    b.ledger.set (Ledger::kChunkInput, chunk.points.capacity () * pb);
    if (!b.chunk_file.read (chunk.data (), n * pb, offset))
      return failBudgeted (b, b.chunk_file.error ());
    offset += n * pb;
    b.ledger.set (Ledger::kSortBuffers, b.sort_hist);
    if (sorter.prepare (chunk, sorted) != n)
      return failBudgeted (b, "chunk " + std::to_string (k) + " lost points on the way through the chunk file");
    b.ledger.set (Ledger::kSorted, sorted.capacity () * pb);
    typename PointCloud::VectorType ().swap (chunk.points);
    b.ledger.set (Ledger::kChunkInput, 0);
    stats_.sorted_bytes = std::max (stats_.sorted_bytes, sorted.capacity () * pb);
    std::size_t leaves = 0;
    for (std::size_t j = 0; j < sorter.numChunks (); ++j)
    {
      sorter.sortChunk (j, sorted, codes);
      b.ledger.set (Ledger::kSortBuffers, sorter.bufferBytes () + codes.capacity () * sizeof (MortonCode));
      if (!cut_)
      {
        // The first sorted piece fixes the automatic leaf splat radius; then the front and
        // the cut start.
        stats_.seconds_to_first_chunk = b.since ();
        startCut (codes, b.origin, b.edge);
        if (!cut_->setSpill (S, [&b] (const Node& spilled) { b.sink (spilled); }))
          return failBudgeted (b, "internal error: the spill level " + std::to_string (S) + " was refused");
        spill_level_ = S;
      }
      leaves += concatenateLeaves (codes, sorted.data () + sorter.chunkRange (j).first);
    }
    sorter.release ();
    std::vector<MortonCode> ().swap (codes);
    b.ledger.set (Ledger::kSortBuffers, 0);
    // Leaves in L_C and their parents on the way up (the segments and merged worklists).
    b.ledger.set (Ledger::kWorklists, 2 * leaves * sizeof (pclx::omicron::detail::CutNode<PointT>));
    const std::uint64_t last = b.plan.cell_begin[k + 1] - 1;
    cut_->advanceBoundary (MortonCode ((std::uint64_t (1) << (3 * S)) | last).span (lmax));
    b.write_peak = 0;
    cut_->fix ();
    if (b.sink_failed)
      return failBudgeted (b, "writing the Potree output to '" + b.dir + "' failed: " + b.sink_error);
    // Checkpoint at the chunk's largest: scratch arenas at their end size, plus the largest
    // encode buffers seen in flight during the fix.
    const std::size_t scratch = cut_->scratchBytes ();
    b.ledger.set (Ledger::kScratchTree, scratch);
    b.ledger.set (Ledger::kRetainedTree, cut_->memoryBytes () - scratch);
    b.ledger.set (Ledger::kFront, front_.entryCount () * entry_bytes);
    b.ledger.set (Ledger::kWriteBuffers, b.write_peak.load ());
    b.ledger.set (Ledger::kWriteBuffers, 0);
    cut_->releaseScratch ();
    typename PointCloud::VectorType ().swap (sorted);
    b.ledger.set (Ledger::kScratchTree, 0);
    b.ledger.set (Ledger::kSorted, 0);
    b.ledger.set (Ledger::kWorklists, 0);
    pclx::omicron::detail::releaseFreedHeap ();
  }
  cut_->finishInput ();
  cut_->fix ();
  if (!cut_->isComplete () || !cut_->getRoot ())
    return failBudgeted (b, "internal error: the hierarchy did not complete");
  b.ledger.set (Ledger::kRetainedTree, cut_->memoryBytes ());
  b.ledger.set (Ledger::kFront, front_.entryCount () * entry_bytes);
  return true;
}

template <typename PointT> bool
pcl::ObliqueCutOctree<PointT>::writeRetainedTree (Budgeted& b)
{
  using Ledger = typename Budgeted::Ledger;
  // The retained tree goes to the same folder (a spilled node stands for what the sink wrote
  // or kept aside), then hierarchy.bin and metadata.json.
  std::size_t largest = 0, retained_points = 0;
  std::vector<const Node*> stack{cut_->getRoot ()};
  while (!stack.empty ())
  {
    const Node* n = stack.back ();
    stack.pop_back ();
    largest = std::max<std::size_t> (largest, n->num_points);
    if (n->isLeaf () && !(n->flags & pclx::omicron::detail::kSpilled))
      retained_points += n->num_points;
    for (std::uint8_t j = 0; j < n->num_children; ++j)
      stack.push_back (n->children + j);
  }
  // A record may also hold points the sink kept aside, so the retained points do not bound
  // it: its pieces do. The levels are those of the retained leaves.
  b.write_peak = 0;
  const std::size_t wb = b.accountWrite (largest, std::numeric_limits<std::size_t>::max (), retained_points);
  if (!b.writer.appendSubtree (*cut_->getRoot ()))
    return failBudgeted (b, b.writer.getLastError ());
  b.write_now.fetch_sub (wb);
  b.ledger.set (Ledger::kWriteBuffers, b.write_peak.load ());
  b.ledger.set (Ledger::kWriteBuffers, 0);
  b.ledger.set (Ledger::kHierarchyRecords, b.plan.node_bound * sizeof (pclx::omicron::detail::potree::NodeRecord) +
                                               b.writer.nodesWritten () * Budgeted::kCloseRecordBytes +
                                               b.hierarchy_chunk);
  if (!b.writer.close (b.kept))
    return failBudgeted (b, b.writer.getLastError ());
  b.ledger.set (Ledger::kHierarchyRecords, 0);
  return true;
}

template <typename PointT> void
pcl::ObliqueCutOctree<PointT>::collectBudgetedStatistics (Budgeted& b)
{
  const int lmax = b.lmax;
  stats_.seconds_total = b.since ();
  stats_.seconds_to_first_front = front_.secondsToFirstLeaf () < 0 ? stats_.seconds_total
                                                                   : stats_.seconds_to_first_chunk + front_.secondsToFirstLeaf ();
  stats_.hierarchy_bytes = cut_->memoryBytes ();
  stats_.accounted_peak_bytes = b.ledger.peak ();
  stats_.nodes_per_level.assign (lmax + 1, 0);
  stats_.points_per_level.assign (lmax + 1, 0);
  stats_.leaves_per_level.assign (lmax + 1, 0);
  for (int l = 0; l <= lmax; ++l)
  {
    stats_.nodes_per_level[l] = b.sp_nodes[l];
    stats_.points_per_level[l] = b.sp_points[l];
    stats_.leaves_per_level[l] = b.sp_leaves[l];
    stats_.spilled_nodes += b.sp_nodes[l];
    stats_.spilled_points += b.sp_points[l];
  }
  std::vector<const Node*> stack{cut_->getRoot ()};
  while (!stack.empty ())
  {
    const Node* n = stack.back ();
    stack.pop_back ();
    ++stats_.nodes_per_level[n->level];
    stats_.points_per_level[n->level] += n->num_points;
    stats_.leaves_per_level[n->level] += n->isLeaf () && !(n->flags & pclx::omicron::detail::kSpilled) ? 1 : 0;
    for (std::uint8_t j = 0; j < n->num_children; ++j)
      stack.push_back (n->children + j);
  }
}
