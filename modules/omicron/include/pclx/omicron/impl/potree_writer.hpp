#pragma once
#include <pclx/omicron/detail/level_sampler.h>
#include <pclx/omicron/detail/worker_pool.h>
#include <pclx/omicron/oblique_cut_octree.h>
#include <pclx/omicron/potree_writer.h>

#include <pcl/console/print.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <exception>
#include <filesystem>
#include <limits>
#include <memory>
#include <stdexcept>
#include <unordered_map>

template <typename PointT>
pcl::PotreeWriter<PointT>::PotreeWriter ()
  : pool_ (new pclx::omicron::detail::WorkerPool (1)), colors_ (pcl::traits::has_color_v<PointT>),
    intensity_ (pcl::traits::has_intensity_v<PointT>)
{
}

template <typename PointT>
pcl::PotreeWriter<PointT>::~PotreeWriter ()
{
  abandon ();
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::setHierarchyStepSize (int step)
{
  if (step < 1 || step > MortonCode::kMaxDepth)
  {
    PCL_ERROR ("[pcl::PotreeWriter::setHierarchyStepSize] the step size must be in [1, 21] (got %d); keeping %d\n",
               step, meta_.step_size);
    return;
  }
  meta_.step_size = step;
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::setThreads (int threads)
{
  if (threads < 1)
  {
    PCL_ERROR ("[pcl::PotreeWriter::setThreads] the thread count must be >= 1 (got %d); keeping %d\n", threads,
               getThreads ());
    return;
  }
  if (isOpen ())
  {
    PCL_ERROR ("[pcl::PotreeWriter::setThreads] a write is open; keeping %d threads\n", getThreads ());
    return;
  }
  pool_.reset (new pclx::omicron::detail::WorkerPool (threads));
}

template <typename PointT> int
pcl::PotreeWriter<PointT>::getThreads () const
{
  return pool_->size ();
}

template <typename PointT> std::size_t
pcl::PotreeWriter<PointT>::getEncodeWindowPoints () const
{
  return static_cast<std::size_t> (getThreads ()) * kPiecePoints;
}

template <typename PointT> bool
pcl::PotreeWriter<PointT>::fail (const char* method, const std::string& why)
{
  PCL_ERROR ("[pcl::PotreeWriter::%s] %s\n", method, why.c_str ());
  std::lock_guard<std::mutex> g (error_mutex_);
  last_error_ = why;
  return false;
}

template <typename PointT> std::string
pcl::PotreeWriter<PointT>::getLastError () const
{
  std::lock_guard<std::mutex> g (error_mutex_);
  return last_error_;
}

template <typename PointT> template <typename F> bool
pcl::PotreeWriter<PointT>::guarded (const char* method, F&& f)
{
  try
  {
    f ();
    return true;
  }
  catch (const std::exception& e)
  {
    return fail (method, e.what ());
  }
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::openImpl (const std::string& directory, const Eigen::Vector3d& origin, double edge)
{
  if (file_)
    throw std::runtime_error ("already open");
  if (!origin.allFinite () || !(edge > 0) || !std::isfinite (edge))
    throw std::runtime_error ("the root cube needs a finite origin and edge > 0");
  std::error_code ec;
  std::filesystem::create_directories (directory, ec);
  const std::string path = directory + "/octree.bin";
  if (ec)
    throw std::runtime_error ("cannot create the output folder '" + directory + "': " + ec.message ());
  file_ = std::fopen (path.c_str (), "wb");
  if (!file_)
    throw std::runtime_error ("cannot write '" + path + "': " + std::strerror (errno));
  directory_ = directory;
  offset_ = 0;
  records_.clear ();
  spilled_.clear ();
  pending_bytes_ = 0;
  double scale = scale_;
  if (!(scale > 0))
    scale = std::pow (10.0, std::ceil (std::log10 (edge / 1073741824.0)));
  if (edge / scale > 2147483000.0)
  {
    abandon ();
    throw std::runtime_error ("the scale is too fine for the root cube (int32 positions)");
  }
  meta_.scale = Eigen::Vector3d::Constant (scale);
  meta_.offset = origin;
  meta_.box_min = origin;
  meta_.box_max = origin + Eigen::Vector3d::Constant (edge);
  // The root's grid (LevelSampler): PotreeConverter's root spacing.
  meta_.spacing = edge / double (1 << pclx::omicron::detail::kSampleGridDepth);
  meta_.setWrittenAttributes (colors_ && pcl::traits::has_color_v<PointT>,
                              intensity_ && pcl::traits::has_intensity_v<PointT>);
  lo_ = Eigen::Vector3d::Constant (std::numeric_limits<double>::max ());
  hi_ = -lo_;
  intensity_lo_ = std::numeric_limits<float>::max ();
  intensity_hi_ = -intensity_lo_;
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::encodeRun (const WriteTask& task, const Run& run, Encoded& out) const
{
  // A node alone keeps the points its level samples; a subtree as one leaf keeps every point
  // no coarser record took (pclx::omicron::detail::kNoSampleLevel included). The counts are
  // plain loops over the level bytes (vectorised): an inner node scans its whole subtree.
  const auto level = static_cast<std::uint8_t> (task.node->level);
  const std::uint8_t* lv = run.levels;
  const auto keep = [&] (std::size_t i) { return !lv || (task.subtree ? lv[i] >= level : lv[i] == level); };
  std::size_t kept = run.n;
  if (lv)
  {
    kept = 0;
    if (task.subtree)
      for (std::size_t i = 0; i < run.n; ++i)
        kept += lv[i] >= level;
    else
      for (std::size_t i = 0; i < run.n; ++i)
        kept += lv[i] == level;
  }
  if (kept == 0)
    return;
  const std::size_t bpp = meta_.bytesPerPoint ();
  const std::size_t first = out.bytes.size ();
  out.bytes.resize (first + bpp * kept);
  out.points += kept;
  const double inv = 1.0 / meta_.scale.x ();
  std::uint8_t* dst = out.bytes.data () + first;
  // Bounds in float, widened once: the same values as a double min / max per point.
  Eigen::Array3f lo = Eigen::Array3f::Constant (std::numeric_limits<float>::max ()), hi = -lo;
  for (std::size_t i = 0, done = 0; done < kept; ++i)
  {
    if (!keep (i))
      continue;
    ++done;
    const PointT& p = run.points[i];
    const Eigen::Array3f v = p.getArray3fMap ();
    lo = lo.min (v);
    hi = hi.max (v);
    std::int32_t q[3];
    for (int a = 0; a < 3; ++a)
      q[a] = static_cast<std::int32_t> (
          pclx::omicron::detail::potree::roundHalfAway ((static_cast<double> (v[a]) - meta_.offset[a]) * inv));
    std::memcpy (dst, q, 12);
    if constexpr (pcl::traits::has_color_v<PointT>)
      if (meta_.rgb)
      {
        const std::uint16_t c[3] = {static_cast<std::uint16_t> (p.r * 257u), static_cast<std::uint16_t> (p.g * 257u),
                                    static_cast<std::uint16_t> (p.b * 257u)};
        std::memcpy (dst + meta_.rgb_offset, c, 6);
      }
    if constexpr (pcl::traits::has_intensity_v<PointT>)
      if (meta_.intensity)
      {
        std::memcpy (dst + meta_.intensity_offset, &p.intensity, 4);
        // NaN and Inf are stored as they are, but the metadata range (JSON) holds finite values.
        if (std::isfinite (p.intensity))
        {
          out.intensity_lo = std::min (out.intensity_lo, p.intensity);
          out.intensity_hi = std::max (out.intensity_hi, p.intensity);
        }
      }
    dst += bpp;
  }
  out.lo = out.lo.cwiseMin (lo.cast<double> ().matrix ());
  out.hi = out.hi.cwiseMax (hi.cast<double> ().matrix ());
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::addRange (const Encoded& data)
{
  lo_ = lo_.cwiseMin (data.lo);
  hi_ = hi_.cwiseMax (data.hi);
  intensity_lo_ = std::min (intensity_lo_, data.intensity_lo);
  intensity_hi_ = std::max (intensity_hi_, data.intensity_hi);
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::record (MortonCode code, const Encoded& data)
{
  std::lock_guard<std::mutex> whole (record_mutex_);
  std::lock_guard<std::mutex> g (mutex_);
  if (!file_)
    throw std::runtime_error ("appendNode before open");
  if (!data.bytes.empty () && std::fwrite (data.bytes.data (), 1, data.bytes.size (), file_) != data.bytes.size ())
    throw std::runtime_error ("writing '" + directory_ + "/octree.bin' failed (disk full?)");
  records_.push_back ({code, static_cast<std::uint32_t> (data.points), offset_, data.bytes.size ()});
  offset_ += data.bytes.size ();
  addRange (data);
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::appendNodeImpl (MortonCode code, const PointT* points, std::uint32_t n)
{
  Node node;
  node.code = code;
  Encoded e;
  encodeRun (WriteTask{&node, true, n, 0}, Run{points, nullptr, n}, e);  // outside the lock: workers encode in parallel
  record (code, e);
}

template <typename PointT> typename pcl::PotreeWriter<PointT>::PointCounts
pcl::PotreeWriter<PointT>::countPoints (const Node& node) const
{
  if (node.flags & pclx::omicron::detail::kSpilled)
  {
    std::lock_guard<std::mutex> g (mutex_);
    const auto it = spilled_.find (node.code.bits ());
    if (it == spilled_.end ())
      throw std::runtime_error ("a spilled node that appendSpilled never received");
    return {it->second.points, 0};
  }
  if (node.isLeaf ())
    return {node.num_points, node.num_points};
  PointCounts n;
  for (std::uint8_t c = 0; c < node.num_children; ++c)
  {
    const PointCounts k = countPoints (node.children[c]);
    n.total += k.total;
    n.in_memory += k.in_memory;
  }
  return n;
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::addRecords (const Node& node, std::uint64_t& first, std::vector<WriteTask>& tasks) const
{
  const PointCounts n = countPoints (node);
  bool written_out = false;
  if (node.flags & pclx::omicron::detail::kSpilled)
  {
    std::lock_guard<std::mutex> g (mutex_);
    written_out = !spilled_.at (node.code.bits ()).whole;
  }
  if (n.total == 0 || written_out)
  {
    first += n.in_memory;
    return;
  }
  if (node.isLeaf () || (leaf_limit_ > 0 && n.total <= leaf_limit_))
  {
    tasks.push_back (WriteTask{&node, true, n.total, first});
    first += n.in_memory;
    return;
  }
  tasks.push_back (WriteTask{&node, false, n.total, first});
  for (std::uint8_t c = 0; c < node.num_children; ++c)
    addRecords (node.children[c], first, tasks);
}

template <typename PointT> std::vector<typename pcl::PotreeWriter<PointT>::WriteTask>
pcl::PotreeWriter<PointT>::records (const Node& node) const
{
  std::vector<WriteTask> tasks;
  std::uint64_t first = 0;
  addRecords (node, first, tasks);
  return tasks;
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::computeLevels (const Node& root, const std::vector<WriteTask>& tasks, int cap,
                                          pclx::omicron::detail::WorkerPool& pool,
                                          std::vector<std::uint8_t>& levels) const
{
  using pclx::omicron::detail::kSampleGridDepth;
  levels.resize (countPoints (root).in_memory);
  // Jobs that hold whole sampling units (octree cells at kSampleGridDepth, or coarser
  // leaves): the records that are whole subtrees down to that depth, and the nodes at that
  // depth still split into records. Without records (a subtree kept aside whole), or below
  // that depth, the subtree is one job. A point's levels are capped at its record's: the
  // levels below belong to that record whole, and must not take cells from another record's
  // points.
  struct Job
  {
    const Node* node;
    std::uint64_t first;
  };
  std::vector<Job> jobs;
  std::unordered_map<const Node*, int> caps;
  for (const WriteTask& t : tasks)
  {
    if (t.subtree)
      caps.emplace (t.node, t.node->level);
    if ((t.subtree && t.node->level <= kSampleGridDepth) || (!t.subtree && t.node->level == kSampleGridDepth))
      jobs.push_back ({t.node, t.first});
  }
  if (tasks.empty () || root.level > kSampleGridDepth)
    jobs.assign (1, Job{&root, 0});
  const auto sample = [&] (const Job& job, pclx::omicron::detail::LevelSampler& sampler) {
    std::uint64_t at = job.first;
    sampler.reset (job.node->level);
    const auto walk = [&] (const Node& n, int cap, auto&& self) -> void {
      if (n.flags & pclx::omicron::detail::kSpilled)
        return;
      if (n.level == kSampleGridDepth || (n.isLeaf () && n.level < kSampleGridDepth))
        sampler.reset (n.level);  // a new unit
      if (const auto it = caps.find (&n); it != caps.end ())
        cap = it->second;
      if (n.isLeaf ())
      {
        for (std::uint32_t i = 0; i < n.num_points; ++i)
          levels[at++] = sampler.take (n.points[i].getVector3fMap (), cap);
        return;
      }
      for (std::uint8_t c = 0; c < n.num_children; ++c)
        self (n.children[c], cap, self);
    };
    walk (*job.node, tasks.empty () ? cap : MortonCode::kMaxDepth, walk);
  };
  const Eigen::Vector3d origin = meta_.box_min;
  const double edge = meta_.box_max.x () - meta_.box_min.x ();
  if (pool.size () <= 1 || jobs.size () < 2)
  {
    pclx::omicron::detail::LevelSampler sampler (origin, edge);
    for (const Job& job : jobs)
      sample (job, sampler);
    return;
  }
  std::vector<std::unique_ptr<pclx::omicron::detail::LevelSampler>> samplers;
  for (int t = 0; t < pool.size (); ++t)
    samplers.emplace_back (new pclx::omicron::detail::LevelSampler (origin, edge));
  pool.parallelFor (jobs.size (), [&] (std::size_t k, int thread) { sample (jobs[k], *samplers[thread]); });
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::readPending (std::uint64_t offset, std::size_t size, std::size_t n, void* out)
{
  std::lock_guard<std::mutex> g (mutex_);
  if (!pending_ || std::fflush (pending_) != 0 || fseeko (pending_, static_cast<off_t> (offset), SEEK_SET) != 0 ||
      std::fread (out, size, n, pending_) != n || fseeko (pending_, 0, SEEK_END) != 0)
    throw std::runtime_error ("reading back '" + directory_ + "/octree.pending.bin' failed");
}

template <typename PointT> template <typename F> void
pcl::PotreeWriter<PointT>::forEachRun (const WriteTask& task, const std::vector<std::uint8_t>& levels, F&& f)
{
  std::uint64_t at = task.first;
  std::vector<PointT> buffer;
  std::vector<std::uint8_t> buffer_levels;
  const auto walk = [&] (const Node& n, auto&& self) -> void {
    if (n.flags & pclx::omicron::detail::kSpilled)
    {
      Spilled sp;
      {
        std::lock_guard<std::mutex> g (mutex_);
        sp = spilled_.at (n.code.bits ());
      }
      if (sp.points == 0)
        return;
      if (!sp.whole && (task.subtree || task.node->level >= n.level))
        throw std::runtime_error ("a spilled subtree larger than a leaf inside a record of its own level or below");
      // Kept aside whole: its points, then their levels. Else the points of this level alone.
      std::uint64_t offset = sp.offset, count = sp.points;
      if (!sp.whole)
      {
        for (int l = 0; l < task.node->level; ++l)
          offset += sp.level_points[l] * sizeof (PointT);
        count = sp.level_points[task.node->level];
      }
      for (std::uint64_t done = 0; done < count;)
      {
        const std::size_t k = static_cast<std::size_t> (std::min<std::uint64_t> (kPiecePoints, count - done));
        buffer.resize (k);
        readPending (offset + done * sizeof (PointT), sizeof (PointT), k, buffer.data ());
        if (sp.whole)
        {
          buffer_levels.resize (k);
          readPending (sp.offset + sp.points * sizeof (PointT) + done, 1, k, buffer_levels.data ());
        }
        f (Run{buffer.data (), sp.whole ? buffer_levels.data () : nullptr, k});
        done += k;
      }
      std::lock_guard<std::mutex> g (mutex_);
      spilled_.at (n.code.bits ()).written = true;
      return;
    }
    if (n.isLeaf ())
    {
      f (Run{n.points, levels.data () + at, n.num_points});
      at += n.num_points;
      return;
    }
    for (std::uint8_t c = 0; c < n.num_children; ++c)
      self (n.children[c], self);
  };
  walk (*task.node, walk);
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::encodeTask (const WriteTask& task, const std::vector<std::uint8_t>& levels, Encoded& out)
{
  forEachRun (task, levels, [&] (const Run& run) { encodeRun (task, run, out); });
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::encodeAndRecord (const std::vector<WriteTask>& tasks, std::size_t first, std::size_t last,
                                            const std::vector<std::uint8_t>& levels,
                                            pclx::omicron::detail::WorkerPool& pool, std::vector<Encoded>& encoded)
{
  encoded.assign (last - first, Encoded ());
  pool.parallelFor (last - first, [&] (std::size_t k, int) { encodeTask (tasks[first + k], levels, encoded[k]); });
  for (std::size_t k = first; k < last; ++k)
    record (tasks[k].node->code, encoded[k - first]);
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::writeTaskStreamed (const WriteTask& task, const std::vector<std::uint8_t>& levels)
{
  // Encoded run by run (a spilled subtree's runs are pieces of the pending file) and appended
  // piece by piece: the buffers stay at a piece, whatever the record. Records appended from
  // other threads wait: a record's bytes are contiguous.
  std::lock_guard<std::mutex> whole (record_mutex_);
  Encoded total, e;
  std::uint64_t start = 0;
  const auto flush = [&] {
    std::lock_guard<std::mutex> g (mutex_);
    if (!file_)
      throw std::runtime_error ("appendSubtree before open");
    if (!e.bytes.empty () && std::fwrite (e.bytes.data (), 1, e.bytes.size (), file_) != e.bytes.size ())
      throw std::runtime_error ("writing '" + directory_ + "/octree.bin' failed (disk full?)");
    total.points += e.points;
    total.lo = total.lo.cwiseMin (e.lo);
    total.hi = total.hi.cwiseMax (e.hi);
    total.intensity_lo = std::min (total.intensity_lo, e.intensity_lo);
    total.intensity_hi = std::max (total.intensity_hi, e.intensity_hi);
    offset_ += e.bytes.size ();
    e = Encoded ();
  };
  {
    std::lock_guard<std::mutex> g (mutex_);
    start = offset_;
  }
  forEachRun (task, levels, [&] (const Run& run) {
    encodeRun (task, run, e);
    if (e.points >= kPiecePoints)
      flush ();
  });
  flush ();
  std::lock_guard<std::mutex> g (mutex_);
  records_.push_back ({task.node->code, static_cast<std::uint32_t> (total.points), start, offset_ - start});
  addRange (total);
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::writeTasksStreamed (const std::vector<WriteTask>& tasks,
                                               const std::vector<std::uint8_t>& levels)
{
  // Runs of whole subtrees of at most a piece each are encoded on the pool's threads, up to a
  // piece per thread at a time, and recorded in order; the other records (larger ones, and
  // inner nodes, whose share of their subtree is known only once encoded) are streamed.
  const std::uint64_t window = getEncodeWindowPoints ();
  const auto small = [&] (const WriteTask& t) { return t.subtree && t.points <= kPiecePoints; };
  std::vector<Encoded> encoded;
  for (std::size_t i = 0; i < tasks.size ();)
  {
    std::size_t j = i;
    std::uint64_t points = 0;
    while (pool_->size () > 1 && j < tasks.size () && small (tasks[j]) && points + tasks[j].points <= window)
      points += tasks[j++].points;
    if (j - i < 2)
    {
      writeTaskStreamed (tasks[i++], levels);
      continue;
    }
    encodeAndRecord (tasks, i, j, levels, *pool_, encoded);
    i = j;
  }
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::appendSubtreeImpl (const Node& node)
{
  const std::vector<WriteTask> tasks = records (node);
  std::vector<std::uint8_t> levels;
  computeLevels (node, tasks, node.level, *pool_, levels);
  writeTasksStreamed (tasks, levels);
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::keepAside (const Node& node, const std::vector<std::uint8_t>& levels, bool whole,
                                      Spilled& sp)
{
  // Whole: every point, then every level. Else, level by level above the node, the points
  // that level samples, in depth-first order.
  std::vector<PointT> piece;
  piece.reserve (kPiecePoints);
  std::lock_guard<std::mutex> g (mutex_);
  const std::string path = directory_ + "/octree.pending.bin";
  if (!file_)
    throw std::runtime_error ("appendSpilled before open");
  if (!pending_ && !(pending_ = std::fopen (path.c_str (), "w+b")))
    throw std::runtime_error ("cannot write '" + path + "': " + std::strerror (errno));
  sp.offset = pending_bytes_;
  const auto put = [&] (const void* data, std::size_t bytes) {
    if (bytes > 0 && std::fwrite (data, 1, bytes, pending_) != bytes)
      throw std::runtime_error ("writing '" + path + "' failed (disk full?)");
    pending_bytes_ += bytes;
  };
  const auto flush = [&] {
    put (piece.data (), piece.size () * sizeof (PointT));
    piece.clear ();
  };
  const auto collect = [&] (int level) {
    std::uint64_t at = 0, count = 0;
    const auto walk = [&] (const Node& n, auto&& self) -> void {
      if (!n.isLeaf ())
      {
        for (std::uint8_t c = 0; c < n.num_children; ++c)
          self (n.children[c], self);
        return;
      }
      for (std::uint32_t i = 0; i < n.num_points; ++i, ++at)
        if (level < 0 || levels[at] == level)
        {
          piece.push_back (n.points[i]);
          ++count;
          if (piece.size () == kPiecePoints)
            flush ();
        }
    };
    walk (node, walk);
    flush ();
    return count;
  };
  if (whole)
  {
    collect (-1);
    put (levels.data (), levels.size ());
    return;
  }
  for (int l = 0; l < node.level; ++l)
    sp.level_points[l] = collect (l);
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::appendSpilledImpl (const Node& node)
{
  Spilled sp;
  sp.points = countPoints (node).total;
  sp.whole = leaf_limit_ > 0 && sp.points <= leaf_limit_ && sp.points > 0;
  if (sp.points > 0)
  {
    // At kSampleGridDepth or above the subtree holds whole sampling units, so the levels are
    // those of the in-memory build. A subtree kept aside whole ends in a record at the node's
    // level or above, which caps its levels.
    const std::vector<WriteTask> tasks = sp.whole ? std::vector<WriteTask> () : records (node);
    std::vector<std::uint8_t> levels;
    computeLevels (node, tasks, node.level, *pool_, levels);
    if (!sp.whole)
      writeTasksStreamed (tasks, levels);
    keepAside (node, levels, sp.whole, sp);
  }
  std::lock_guard<std::mutex> g (mutex_);
  spilled_[node.code.bits ()] = sp;
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::reserveNodes (std::size_t nodes)
{
  std::lock_guard<std::mutex> g (mutex_);
  records_.reserve (nodes);
}

template <typename PointT> std::uint64_t
pcl::PotreeWriter<PointT>::bytesWritten () const
{
  std::lock_guard<std::mutex> g (mutex_);
  return offset_;
}

template <typename PointT> std::size_t
pcl::PotreeWriter<PointT>::nodesWritten () const
{
  std::lock_guard<std::mutex> g (mutex_);
  return records_.size ();
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::closePending ()
{
  if (!pending_)
    return;
  std::fclose (pending_);
  pending_ = nullptr;
  std::error_code ec;
  std::filesystem::remove (directory_ + "/octree.pending.bin", ec);
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::abandon ()
{
  if (file_)
    std::fclose (file_);
  file_ = nullptr;
  closePending ();
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::closeImpl (std::uint64_t points)
{
  std::lock_guard<std::mutex> g (mutex_);
  if (!file_)
    throw std::runtime_error ("close before open");
  const bool flushed = std::fflush (file_) == 0 && !std::ferror (file_);
  const bool closed = std::fclose (file_) == 0;
  file_ = nullptr;
  closePending ();
  for (const auto& [code, sp] : spilled_)
    if (!sp.written && (sp.whole || std::any_of (sp.level_points.begin (), sp.level_points.end (),
                                                 [] (std::uint64_t n) { return n > 0; })))
      throw std::runtime_error ("a subtree appendSpilled () kept aside was never written (close before "
                              "appendSubtree reached its node)");
  if (!flushed || !closed)
    throw std::runtime_error ("writing '" + directory_ + "/octree.bin' failed (disk full?)");
  meta_.points = points;
  if (lo_.x () <= hi_.x ())
  {
    meta_.position_min = lo_;
    meta_.position_max = hi_;
  }
  if (intensity_lo_ <= intensity_hi_)
  {
    meta_.intensity_min = intensity_lo_;
    meta_.intensity_max = intensity_hi_;
  }
  else
    meta_.intensity_min = meta_.intensity_max = 0;
  pclx::omicron::detail::potree::writeHierarchy (directory_ + "/hierarchy.bin", records_, meta_);
  pclx::omicron::detail::potree::writeMetadata (directory_ + "/metadata.json", meta_);
}

template <typename PointT> bool
pcl::PotreeWriter<PointT>::open (const std::string& directory, const Eigen::Vector3d& origin, double edge)
{
  return guarded ("open", [&] { openImpl (directory, origin, edge); });
}

template <typename PointT> bool
pcl::PotreeWriter<PointT>::appendNode (MortonCode code, const PointT* points, std::uint32_t n)
{
  return guarded ("appendNode", [&] { appendNodeImpl (code, points, n); });
}

template <typename PointT> bool
pcl::PotreeWriter<PointT>::appendSubtree (const Node& node)
{
  return guarded ("appendSubtree", [&] { appendSubtreeImpl (node); });
}

template <typename PointT> bool
pcl::PotreeWriter<PointT>::appendSpilled (const Node& node)
{
  return guarded ("appendSpilled", [&] { appendSpilledImpl (node); });
}

template <typename PointT> bool
pcl::PotreeWriter<PointT>::close (std::uint64_t points)
{
  return guarded ("close", [&] { closeImpl (points); });
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::writeTasks (const std::vector<WriteTask>& tasks, const std::vector<std::uint8_t>& levels,
                                       pclx::omicron::detail::WorkerPool& pool)
{
  // A window's encoded bytes are held until they are recorded: about 1M points keeps them a
  // small share of the points' own memory while each thread gets many nodes. A node alone
  // stores a sample of its subtree; only whole subtrees count towards the window.
  constexpr std::uint64_t kWindowPoints = std::uint64_t (1) << 20;
  std::vector<Encoded> encoded;
  for (std::size_t i = 0; i < tasks.size ();)
  {
    std::size_t j = i;
    std::uint64_t points = 0;
    while (j < tasks.size () && (j == i || points + (tasks[j].subtree ? tasks[j].points : 0) <= kWindowPoints))
      points += tasks[j].subtree ? tasks[j++].points : (++j, 0);
    encodeAndRecord (tasks, i, j, levels, pool, encoded);
    i = j;
  }
}

template <typename PointT> bool
pcl::PotreeWriter<PointT>::write (const ObliqueCutOctree<PointT>& octree, const std::string& directory)
{
  const Node* root = octree.getRoot ();
  if (!root)
    return fail ("write", "the octree is not built (or empty)");
  if (octree.getSpillLevel () >= 0)
    return fail ("write", "a budgeted build keeps only its upper tree; it already wrote the whole hierarchy to "
                          "getOutputDirectory ()");
  if (!open (directory, octree.getRootOrigin (), octree.getRootEdge ()))
    return false;
  if (guarded ("write", [&] {
        const std::vector<WriteTask> tasks = records (*root);
        std::vector<std::uint8_t> levels;
        pclx::omicron::detail::WorkerPool pool (octree.getThreads ());
        computeLevels (*root, tasks, 0, pool, levels);
        writeTasks (tasks, levels, pool);
        closeImpl (octree.getStatistics ().kept_points);
      }))
    return true;
  abandon ();
  return false;
}

#define PCL_INSTANTIATE_PotreeWriter(T) template class PCL_EXPORTS pcl::PotreeWriter<T>;
