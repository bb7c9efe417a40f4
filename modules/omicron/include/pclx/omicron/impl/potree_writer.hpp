#pragma once
#include <pclx/omicron/detail/worker_pool.h>
#include <pclx/omicron/oblique_cut_octree.h>
#include <pclx/omicron/potree_writer.h>

#include <pcl/console/print.h>
#include <pcl/point_types.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <exception>
#include <filesystem>
#include <limits>
#include <stdexcept>

template <typename PointT>
pcl::PotreeWriter<PointT>::PotreeWriter () : colors_ (pcl::traits::has_color_v<PointT>)
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
  meta_.spacing = edge / 128.0;  // PotreeConverter's root spacing, until close () measures ours
  meta_.rgb = colors_;
  lo_ = Eigen::Vector3d::Constant (std::numeric_limits<double>::max ());
  hi_ = -lo_;
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::setParentPointRatio (float ratio)
{
  if (!(ratio > 0.f && ratio <= 1.f))
  {
    PCL_ERROR ("[pcl::PotreeWriter::setParentPointRatio] the ratio must be in (0, 1] (got %g); keeping %g\n", ratio,
               parent_ratio_);
    return;
  }
  parent_ratio_ = ratio;
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::encode (const PointT* points, std::uint32_t n, std::uint32_t taken, Encoded& out) const
{
  const std::size_t bpp = meta_.bytesPerPoint ();
  const std::size_t first = out.bytes.size ();
  out.bytes.resize (first + bpp * (n - taken));
  out.points += n - taken;
  const double inv = 1.0 / meta_.scale.x ();
  std::uint8_t* dst = out.bytes.data () + first;
  // Bounds in float, widened once: the same values as a double min / max per point.
  Eigen::Array3f lo = Eigen::Array3f::Constant (std::numeric_limits<float>::max ()), hi = -lo;
  std::uint32_t t = 0;
  std::uint32_t next = taken > 0 ? pclx::omicron::detail::parentSampleIndex (0, taken, n) : n;
  for (std::uint32_t i = 0; i < n; ++i)
  {
    if (i == next)
    {
      ++t;
      next = t < taken ? pclx::omicron::detail::parentSampleIndex (t, taken, n) : n;
      continue;
    }
    const PointT& p = points[i];
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
        std::memcpy (dst + 12, c, 6);
      }
    dst += bpp;
  }
  if (n > taken)
  {
    out.lo = out.lo.cwiseMin (lo.cast<double> ().matrix ());
    out.hi = out.hi.cwiseMax (hi.cast<double> ().matrix ());
  }
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::record (MortonCode code, const Encoded& data)
{
  std::lock_guard<std::mutex> g (mutex_);
  if (!file_)
    throw std::runtime_error ("appendNode before open");
  if (!data.bytes.empty () && std::fwrite (data.bytes.data (), 1, data.bytes.size (), file_) != data.bytes.size ())
    throw std::runtime_error ("writing '" + directory_ + "/octree.bin' failed (disk full?)");
  records_.push_back ({code, static_cast<std::uint32_t> (data.points), offset_, data.bytes.size ()});
  offset_ += data.bytes.size ();
  lo_ = lo_.cwiseMin (data.lo);
  hi_ = hi_.cwiseMax (data.hi);
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::appendNodeImpl (MortonCode code, const PointT* points, std::uint32_t n)
{
  Encoded e;
  encode (points, n, 0, e);  // outside the lock: workers encode in parallel
  record (code, e);
}

template <typename PointT> std::uint32_t
pcl::PotreeWriter<PointT>::storedPoints (const Node& node) const
{
  return node.num_points - (node.level > 0 ? pclx::omicron::detail::parentSampleCount (node.num_points, parent_ratio_) : 0);
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::encodeNode (const Node& node, Encoded& out) const
{
  encode (node.points, node.num_points, node.num_points - storedPoints (node), out);
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::appendNodeImpl (const Node& node)
{
  Encoded e;
  encodeNode (node, e);
  record (node.code, e);
}

template <typename PointT> std::uint64_t
pcl::PotreeWriter<PointT>::subtreePoints (const Node& node) const
{
  if (node.flags & pclx::omicron::detail::kSpilled)
  {
    std::lock_guard<std::mutex> g (mutex_);
    const auto it = spilled_.find (node.code.bits ());
    if (it == spilled_.end ())
      throw std::runtime_error ("a spilled node that appendSpilled never received");
    return it->second.points;
  }
  std::uint64_t n = storedPoints (node);
  for (std::uint8_t c = 0; c < node.num_children; ++c)
    n += subtreePoints (node.children[c]);
  return n;
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::encodeSubtree (const Node& node, Encoded& out)
{
  if (!(node.flags & pclx::omicron::detail::kSpilled))
  {
    encodeNode (node, out);
    for (std::uint8_t c = 0; c < node.num_children; ++c)
      encodeSubtree (node.children[c], out);
    return;
  }
  // A subtree appendSpilled () kept aside: its bytes, already in depth-first order.
  std::lock_guard<std::mutex> g (mutex_);
  const auto it = spilled_.find (node.code.bits ());
  if (it != spilled_.end () && it->second.points == 0)
    return;
  if (it == spilled_.end () || !it->second.pending || !pending_)
    throw std::runtime_error ("a spilled subtree within the leaf limit was not kept aside");
  Spilled& sp = it->second;
  sp.written = true;
  const std::size_t first = out.bytes.size (), size = sp.points * meta_.bytesPerPoint ();
  out.bytes.resize (first + size);
  if (std::fflush (pending_) != 0 || fseeko (pending_, static_cast<off_t> (sp.offset), SEEK_SET) != 0 ||
      std::fread (out.bytes.data () + first, 1, size, pending_) != size || fseeko (pending_, 0, SEEK_END) != 0)
    throw std::runtime_error ("reading back '" + directory_ + "/octree.pending.bin' failed");
  out.points += sp.points;
  out.lo = out.lo.cwiseMin (sp.lo);
  out.hi = out.hi.cwiseMax (sp.hi);
}

template <typename PointT> template <typename F> void
pcl::PotreeWriter<PointT>::forEachRecord (const Node& node, F&& f)
{
  const std::uint64_t total = subtreePoints (node);
  if (total == 0)
    return;
  if (leaf_limit_ > 0 && total <= leaf_limit_)
  {
    f (WriteTask{&node, true, total});
    return;
  }
  f (WriteTask{&node, false, storedPoints (node)});
  for (std::uint8_t c = 0; c < node.num_children; ++c)
    forEachRecord (node.children[c], f);
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::encodeTask (const WriteTask& task, Encoded& out)
{
  if (task.subtree)
    encodeSubtree (*task.node, out);
  else
    encodeNode (*task.node, out);
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::appendSubtreeImpl (const Node& node)
{
  // One record encoded at a time (what a budgeted build accounts for).
  forEachRecord (node, [this] (const WriteTask& task) {
    Encoded e;
    encodeTask (task, e);
    record (task.node->code, e);
  });
}

template <typename PointT> void
pcl::PotreeWriter<PointT>::appendSpilledImpl (const Node& node)
{
  Spilled sp;
  sp.points = subtreePoints (node);
  if (leaf_limit_ == 0 || sp.points > leaf_limit_ || sp.points == 0)
  {
    {
      std::lock_guard<std::mutex> g (mutex_);
      spilled_[node.code.bits ()] = sp;
    }
    for (std::uint8_t c = 0; c < node.num_children; ++c)
      appendSubtreeImpl (node.children[c]);
    return;
  }
  Encoded e;
  encodeSubtree (node, e);
  std::lock_guard<std::mutex> g (mutex_);
  if (!file_)
    throw std::runtime_error ("appendSpilled before open");
  const std::string path = directory_ + "/octree.pending.bin";
  if (!pending_ && !(pending_ = std::fopen (path.c_str (), "w+b")))
    throw std::runtime_error ("cannot write '" + path + "': " + std::strerror (errno));
  if (!e.bytes.empty () && std::fwrite (e.bytes.data (), 1, e.bytes.size (), pending_) != e.bytes.size ())
    throw std::runtime_error ("writing '" + path + "' failed (disk full?)");
  sp.pending = true;
  sp.offset = pending_bytes_;
  sp.lo = e.lo;
  sp.hi = e.hi;
  pending_bytes_ += e.bytes.size ();
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
  for (const auto& sp : spilled_)
    if (sp.second.pending && !sp.second.written)
      throw std::runtime_error ("a subtree appendSpilled () kept aside was never written (close before "
                              "appendSubtree reached its node)");
  if (!flushed || !closed)
    throw std::runtime_error ("writing '" + directory_ + "/octree.bin' failed (disk full?)");
  meta_.points = points;
  meta_.spacing = pclx::omicron::detail::potree::spacingForNodes (records_, meta_.box_max.x () - meta_.box_min.x ());
  if (lo_.x () <= hi_.x ())
  {
    meta_.position_min = lo_;
    meta_.position_max = hi_;
  }
  pclx::omicron::detail::potree::writeHierarchy (directory_ + "/hierarchy.bin", records_, meta_);
  pclx::omicron::detail::potree::writeMetadata (directory_ + "/metadata.json", meta_);
}

template <typename PointT> bool
pcl::PotreeWriter<PointT>::open (const std::string& directory, const Eigen::Vector3d& origin, double edge)
{
  return guarded ("open", [&] { openImpl (directory, origin, edge); });
}

template <typename PointT> bool
pcl::PotreeWriter<PointT>::appendNode (const Node& node)
{
  return guarded ("appendNode", [&] { appendNodeImpl (node); });
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
pcl::PotreeWriter<PointT>::writeTasks (const std::vector<WriteTask>& tasks, int threads)
{
  // A window's encoded bytes are held until they are recorded: about 1M points keeps them a
  // small share of the points' own memory while each thread gets many nodes.
  constexpr std::uint64_t kWindowPoints = std::uint64_t (1) << 20;
  pclx::omicron::detail::WorkerPool pool (threads);
  std::vector<Encoded> encoded;
  for (std::size_t i = 0; i < tasks.size ();)
  {
    std::size_t j = i;
    std::uint64_t points = 0;
    while (j < tasks.size () && (j == i || points + tasks[j].points <= kWindowPoints))
      points += tasks[j++].points;
    encoded.assign (j - i, Encoded ());
    std::exception_ptr error;
    std::mutex error_mutex;
    pool.parallelFor (j - i, [&] (std::size_t k, int) {
      try
      {
        encodeTask (tasks[i + k], encoded[k]);
      }
      catch (...)
      {
        std::lock_guard<std::mutex> g (error_mutex);
        error = std::current_exception ();
      }
    });
    if (error)
      std::rethrow_exception (error);
    for (std::size_t k = i; k < j; ++k)
      record (tasks[k].node->code, encoded[k - i]);
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
  setParentPointRatio (octree.getParentPointRatio ());
  if (!open (directory, octree.getRootOrigin (), octree.getRootEdge ()))
    return false;
  if (guarded ("write", [&] {
        std::vector<WriteTask> tasks;
        forEachRecord (*root, [&tasks] (const WriteTask& task) { tasks.push_back (task); });
        writeTasks (tasks, octree.getThreads ());
        closeImpl (octree.getStatistics ().kept_points);
      }))
    return true;
  abandon ();
  return false;
}

#define PCL_INSTANTIATE_PotreeWriter(T) template class PCL_EXPORTS pcl::PotreeWriter<T>;
