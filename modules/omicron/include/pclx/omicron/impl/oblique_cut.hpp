#pragma once
#include <pclx/omicron/oblique_cut.h>
#include <pclx/omicron/oblique_cut_front.h>

#include <pcl/console/print.h>

#include <stdexcept>
#include <string>

template <typename PointT>
pcl::ObliqueCut<PointT>::ObliqueCut (const Parameters& params) : params_ (params)
{
  // A parameter out of range is refused with PCL_ERROR and its default is used instead.
  const Parameters defaults;
  if (params.max_depth < 1 || params.max_depth > MortonCode::kMaxDepth)
  {
    PCL_ERROR ("[pcl::ObliqueCut] the max depth must be in [1, 21] (got %d); using %d\n", params.max_depth,
               defaults.max_depth);
    params_.max_depth = defaults.max_depth;
  }
  if (!(params.parent_ratio > 0.f && params.parent_ratio <= 1.f))
  {
    PCL_ERROR ("[pcl::ObliqueCut] the parent point ratio must be in (0, 1] (got %g); using %g\n", params.parent_ratio,
               defaults.parent_ratio);
    params_.parent_ratio = defaults.parent_ratio;
  }
  if (params.worklist_size < 1)
  {
    PCL_ERROR ("[pcl::ObliqueCut] the worklist size must be >= 1; using %zu\n", defaults.worklist_size);
    params_.worklist_size = defaults.worklist_size;
  }
  if (params.threads < 1)
  {
    PCL_ERROR ("[pcl::ObliqueCut] the thread count must be >= 1 (got %d); using %d\n", params.threads,
               defaults.threads);
    params_.threads = defaults.threads;
  }
  for (int i = 0; i < params_.threads; ++i)
    slots_.emplace_back (new Slot);
  if (params_.threads > 1)
    pool_.reset (new pclx::omicron::detail::WorkerPool (params_.threads));
}

template <typename PointT>
pcl::ObliqueCut<PointT>::~ObliqueCut () = default;

template <typename PointT> pcl::MortonCode
pcl::ObliqueCut<PointT>::getBoundary () const
{
  std::lock_guard<std::mutex> g (mutex_[params_.max_depth]);
  return boundary_[params_.max_depth];
}

template <typename PointT> bool
pcl::ObliqueCut<PointT>::setSpill (int level, SpillSink sink)
{
  const int top = params_.max_depth - (params_.leaf_collapse ? 2 : 1);
  if (level < 1 || level > top)
  {
    PCL_ERROR ("[pcl::ObliqueCut::setSpill] the spill level must be in [1, %d] (got %d)\n", top, level);
    return false;
  }
  if (!sink)
  {
    PCL_ERROR ("[pcl::ObliqueCut::setSpill] the spill needs a sink\n");
    return false;
  }
  std::lock_guard<std::mutex> g (mutex_[params_.max_depth]);
  if (boundary_[params_.max_depth].valid ())
  {
    PCL_ERROR ("[pcl::ObliqueCut::setSpill] called after the first concatenate\n");
    return false;
  }
  spill_level_ = level;
  sink_ = std::move (sink);
  return true;
}

template <typename PointT> void
pcl::ObliqueCut<PointT>::releaseScratch ()
{
  for (auto& s : slots_)
  {
    s->scratch_nodes.clear ();
    s->scratch_points.clear ();
  }
}

template <typename PointT> std::size_t
pcl::ObliqueCut<PointT>::scratchBytes () const
{
  std::size_t b = 0;
  for (const auto& s : slots_)
    b += s->scratch_nodes.bytes () + s->scratch_points.bytes ();
  return b;
}

template <typename PointT> bool
pcl::ObliqueCut<PointT>::advanceBoundary (MortonCode m)
{
  const int lmax = params_.max_depth;
  {
    std::lock_guard<std::mutex> g (mutex_[lmax]);
    if (input_finished_ || !m.valid () || m.level () != lmax ||
        (boundary_[lmax].valid () && m < boundary_[lmax]))
    {
      PCL_ERROR ("[pcl::ObliqueCut::advanceBoundary] the boundary must be a code at the max depth not before m_C, "
                 "before finishInput\n");
      return false;
    }
    boundary_[lmax] = m;
    dirty_[lmax] = true;
  }
  {
    std::lock_guard<std::mutex> g (signal_mutex_);
  }
  signal_.notify_all ();
  return true;
}

template <typename PointT> bool
pcl::ObliqueCut<PointT>::concatenate (Worklist w)
{
  const int lmax = params_.max_depth;
  if (w.empty ())
    return true;
  const auto reject = [] (const std::string& why) {
    PCL_ERROR ("[pcl::ObliqueCut::concatenate] %s; the worklist is rejected and the cut is unchanged\n", why.c_str ());
    return false;
  };
  // Leaves shallower than l_max enter as their placeholder P_{X,lmax} = span(X) (§3.1.3).
  MortonCode prev_span;
  for (std::size_t i = 0; i < w.size (); ++i)
  {
    CutNode& c = w[i];
    if (!c.code.valid () || c.code.level () != c.level || c.leaf_level != c.level || c.num_children != 0 ||
        c.level > lmax || c.level <= spill_level_)
      return reject ("node " + std::to_string (i) + " is not a leaf at a level <= max depth (code and level disagree, or it has children)");
    const MortonCode first = c.code.first (lmax);
    if (i > 0 && !(first > prev_span))
      return reject ("the worklist is not in strictly increasing Morton order (node " + std::to_string (i) + ")");
    prev_span = c.code.span (lmax);
    if (c.level < lmax)
    {
      c.code = prev_span;
      c.level = static_cast<std::uint8_t> (lmax);
    }
  }
  {
    std::lock_guard<std::mutex> g (mutex_[lmax]);
    if (input_finished_)
      return reject ("the input was declared finished");
    const MortonCode m = boundary_[lmax];
    const MortonCode first = w.front ().leaf_level < lmax
                                 ? MortonCode (w.front ().code.bits () >> (3 * (lmax - w.front ().leaf_level))).first (lmax)
                                 : w.front ().code;
    if (!(first > m))
      return reject ("its first node is not strictly after m_C in Morton order");
    boundary_[lmax] = w.back ().code;
    lists_[lmax].push_back (std::move (w));
    dirty_[lmax] = true;
  }
  {
    std::lock_guard<std::mutex> g (signal_mutex_);
  }
  signal_.notify_all ();
  return true;
}

template <typename PointT> void
pcl::ObliqueCut<PointT>::finishInput ()
{
  const int lmax = params_.max_depth;
  {
    std::lock_guard<std::mutex> g (mutex_[lmax]);
    input_finished_ = true;
    boundary_[lmax] = MortonCode::root ().span (lmax);
    dirty_[lmax] = true;
  }
  {
    std::lock_guard<std::mutex> g (signal_mutex_);
  }
  signal_.notify_all ();
}

template <typename PointT> void
pcl::ObliqueCut<PointT>::createParent (const CutNode* group, std::size_t k, Slot& slot, Segment& out) const
{
  const int lmax = params_.max_depth;
  const int l = group[0].level;
  // A placeholder is a degenerate subtree: it climbs one level per fix and becomes the leaf
  // X itself at X's level.
  if (k == 1 && group[0].isPlaceholder ())
  {
    CutNode up = group[0];
    up.level = static_cast<std::uint8_t> (l - 1);
    up.code = up.code.parent ();
    if (l == lmax && spill_level_ < 0)
      out.placeholders.push_back (group[0].code);
    out.parents.push_back (up);
    return;
  }
  // Budgeted build: the group and the parent's sample below the spill level go to scratch.
  const bool spill = spill_level_ >= 0;
  pclx::omicron::detail::NodeArena<PointT>& node_arena = spill && l > spill_level_ ? slot.scratch_nodes : slot.nodes;
  pclx::omicron::detail::BlockArena<PointT>& point_arena = spill && l - 1 > spill_level_ ? slot.scratch_points : slot.points;
  CutNode pa;
  pa.code = group[0].code.parent ();
  pa.level = pa.leaf_level = static_cast<std::uint8_t> (l - 1);
  // Every node processed at l_max gets its place in the front (Algorithm 4); with a spill,
  // every node created at the spill level.
  if (l == lmax && !spill)
    for (std::size_t i = 0; i < k; ++i)
      out.placeholders.push_back (group[i].code);
  if (params_.leaf_collapse && k == 1 && l == lmax)
  {
    // Leaf collapse: the only child is dropped and the parent becomes the leaf. It keeps all
    // of the child's points (a range of the sorted array, so keeping them costs nothing).
    pa.points = group[0].points;
    pa.num_points = group[0].num_points;
    pa.flags = pclx::omicron::detail::kCollapsed;
    out.parents.push_back (pa);
    return;
  }
  Node* block = node_arena.allocate (k);
  std::uint32_t total = 0;
  for (std::size_t i = 0; i < k; ++i)
    total += pclx::omicron::detail::parentSampleCount (group[i].num_points, params_.parent_ratio);
  PointT* dst = total > 0 ? point_arena.allocate (total) : nullptr;
  pa.points = dst;
  pa.num_points = total;
  pa.children = block;
  pa.num_children = static_cast<std::uint8_t> (k);
  for (std::size_t i = 0; i < k; ++i)
  {
    const CutNode& c = group[i];
    Node& n = block[i];
    pclx::omicron::detail::assignNode (n, c);
    const std::uint32_t m = pclx::omicron::detail::parentSampleCount (c.num_points, params_.parent_ratio);
    for (std::uint32_t t = 0; t < m; ++t)
      *dst++ = c.points[pclx::omicron::detail::parentSampleIndex (t, m, c.num_points)];
    // The grandchildren now have a parent that is no root of L_C: link them, and the leaves
    // among them may enter the front (invariant 2.2).
    // (Nothing below the spill level enters the front: it is dropped after the spill.)
    const bool front_level = !spill || l + 1 <= spill_level_;
    n.linkChildren ();
    if (front_level)
      for (std::uint8_t j = 0; j < n.num_children; ++j)
        if (n.children[j].isLeaf ())
          out.leaves.push_back (&n.children[j]);
  }
  if (spill && l - 1 == spill_level_)
  {
    // The subtree of pa is complete: the sink receives pa with its children, which are cut off.
    // pa keeps its sample (retained arena) and is drawn as a leaf.
    Node view;
    pclx::omicron::detail::assignNode (view, pa);
    sink_ (view);
    pa.children = nullptr;
    pa.num_children = 0;
    pa.flags |= pclx::omicron::detail::kSpilled;
    out.placeholders.push_back (pa.code.span (lmax));
  }
  out.parents.push_back (pa);
}

// One step of Algorithm 3 at level l, in stages: take L_{C,l}; find where each worklist's own
// sibling groups start; hold back the group still waiting at the boundary; create the
// parents in parallel; merge them into L_{C,l-1} and hand placeholders and leaves to the front.
template <typename PointT> bool
pcl::ObliqueCut<PointT>::fixLevel (int l)
{
  const int lmax = params_.max_depth;
  if (l < 1 || l > lmax)
    return false;
  std::deque<Worklist> in;
  FixPass f;
  MortonCode up_bnd;
  {
    std::lock_guard<std::mutex> g (mutex_[l]);
    in.swap (lists_[l]);
    f.bnd = boundary_[l];
    dirty_[l] = false;
  }
  {
    std::lock_guard<std::mutex> g (mutex_[l - 1]);
    up_bnd = boundary_[l - 1];
  }
  if (in.empty () && up_bnd == f.bnd)
    return false;

  for (Worklist& w : in)
    if (!w.empty ())
      f.ws.push_back (&w);
  const MortonCode last_parent = findGroupStarts (f);
  holdWaitingGroup (f, last_parent);
  createParents (f);
  publishParents (l, f);
  if (l == 1 && f.bnd == MortonCode::root ().span (lmax))
    finalize ();
  return true;
}

// Master: sibling groups split across worklists belong to the worklist where they begin
// (start[i] skips the continuation). The thesis merges the duplicate parents afterwards;
// resolving first creates each parent once, so no permanent node or parent link is ever
// rewritten while the front may read it. Returns the parent code of the last group.
template <typename PointT> pcl::MortonCode
pcl::ObliqueCut<PointT>::findGroupStarts (FixPass& f) const
{
  const std::vector<Worklist*>& ws = f.ws;
  f.start.assign (ws.size (), 0);
  MortonCode prev;
  for (std::size_t i = 0; i < ws.size (); ++i)
  {
    const Worklist& w = *ws[i];
    std::size_t j = 0;
    while (prev.valid () && j < w.size () && w[j].code.parent () == prev)
      ++j;
    f.start[i] = j;
    prev = w.back ().code.parent ();
  }
  return prev;
}

// The last group waits when its parent's subtree reaches past the boundary (S): it is
// copied to f.tail, and (f.ti, f.tj) marks where it starts.
template <typename PointT> void
pcl::ObliqueCut<PointT>::holdWaitingGroup (FixPass& f, MortonCode prev) const
{
  const std::vector<Worklist*>& ws = f.ws;
  f.ti = ws.size ();
  f.tj = 0;
  if (!ws.empty () && prev.span (params_.max_depth) > f.bnd)
  {
    std::size_t ti = ws.size () - 1, tj = ws[ti]->size ();
    while (true)
    {
      if (tj > 0 && (*ws[ti])[tj - 1].code.parent () == prev)
        --tj;
      else if (tj == 0 && ti > 0 && ws[ti - 1]->back ().code.parent () == prev)
        tj = ws[--ti]->size ();
      else
        break;
    }
    for (std::size_t i = ti, j = tj; i < ws.size (); ++i, j = 0)
      f.tail.insert (f.tail.end (), ws[i]->begin () + j, ws[i]->end ());
    f.ti = ti;
    f.tj = tj;
  }
}

// Workers: the parents of each worklist's complete groups (Algorithm 4) into its segment.
template <typename PointT> void
pcl::ObliqueCut<PointT>::createParents (FixPass& f)
{
  const std::vector<Worklist*>& ws = f.ws;
  const std::size_t ti = f.ti, tj = f.tj;
  f.segs.resize (ws.size ());
  const auto work = [&] (std::size_t i, Slot& s) {
    const Worklist& w = *ws[i];
    CutNode group[8];
    std::size_t j = f.start[i];
    while (j < w.size () && !(i == ti && j >= tj) && i <= ti)
    {
      const MortonCode pc = w[j].code.parent ();
      std::size_t k = 0, wi = i, jj = j;
      while (wi < ws.size ())
      {
        const Worklist& cw = *ws[wi];
        while (jj < cw.size () && k < 8 && cw[jj].code.parent () == pc)
          group[k++] = cw[jj++];
        if (jj < cw.size () || k == 8)
          break;
        ++wi;
        jj = 0;
      }
      createParent (group, k, s, f.segs[i]);
      if (wi != i)
        break;  // the group ran into the next worklists, which skip it
      j = jj;
    }
  };
  if (pool_ && ws.size () > 1)
    pool_->parallelFor (ws.size (), [&] (std::size_t i, int worker) { work (i, *slots_[worker]); });
  else
    for (std::size_t i = 0; i < ws.size (); ++i)
      work (i, *slots_[0]);
}

// Master: merge the segments into worklists of the configured size for level l - 1, put the
// waiting group back at the front of L_{C,l}, and hand the front its placeholders and leaves.
template <typename PointT> void
pcl::ObliqueCut<PointT>::publishParents (int l, FixPass& f)
{
  std::vector<Worklist> up;
  Worklist cur;
  for (Segment& s : f.segs)
    for (CutNode& c : s.parents)
    {
      cur.push_back (c);
      if (cur.size () >= params_.worklist_size)
      {
        up.push_back (std::move (cur));
        cur = Worklist ();
      }
    }
  if (!cur.empty ())
    up.push_back (std::move (cur));
  {
    std::lock_guard<std::mutex> g (mutex_[l - 1]);
    for (Worklist& w : up)
      lists_[l - 1].push_back (std::move (w));
    boundary_[l - 1] = f.bnd;
    if (l - 1 >= 1)
      dirty_[l - 1] = true;
  }
  if (!f.tail.empty ())
  {
    std::lock_guard<std::mutex> g (mutex_[l]);
    lists_[l].push_front (std::move (f.tail));
  }
  if (front_)
  {
    std::vector<MortonCode> ph;
    std::vector<const Node*> leaves;
    for (Segment& s : f.segs)
    {
      ph.insert (ph.end (), s.placeholders.begin (), s.placeholders.end ());
      leaves.insert (leaves.end (), s.leaves.begin (), s.leaves.end ());
    }
    // Placeholders before leaves: the front takes a leaf list before the placeholders, so
    // every leaf it sees already has its placeholder (Algorithm 3 sends them in this order).
    if (!ph.empty ())
      front_->insertPlaceholders (std::move (ph));
    if (!leaves.empty ())
      front_->insertLeaves (l + 1, std::move (leaves));
  }
}

template <typename PointT> void
pcl::ObliqueCut<PointT>::finalize ()
{
  Worklist roots;
  {
    std::lock_guard<std::mutex> g (mutex_[0]);
    for (Worklist& w : lists_[0])
      roots.insert (roots.end (), w.begin (), w.end ());
    lists_[0].clear ();
  }
  std::vector<const Node*> leaves1;
  if (!roots.empty ())
  {
    // Only the null node is left in S: one root (§3.1.4).
    const CutNode& c = roots.front ();
    Node* r = slots_[0]->nodes.allocate (1);
    r->code = c.code;
    r->points = c.points;
    r->num_points = c.num_points;
    r->level = c.level;
    r->num_children = c.num_children;
    r->flags = c.flags;
    r->children = c.children;
    r->linkChildren ();
    for (std::uint8_t j = 0; j < r->num_children; ++j)
      if (r->children[j].isLeaf ())
        leaves1.push_back (&r->children[j]);
    root_ = r;
  }
  if (front_)
  {
    if (!leaves1.empty ())
      front_->insertLeaves (1, std::move (leaves1));
    if (root_ && root_->isLeaf ())
      front_->insertLeaves (0, std::vector<const Node*>{root_});
  }
  complete_ = true;
  {
    std::lock_guard<std::mutex> g (signal_mutex_);
  }
  signal_.notify_all ();
}

template <typename PointT> void
pcl::ObliqueCut<PointT>::fix ()
{
  for (int l = params_.max_depth; l >= 1; --l)
    fixLevel (l);
}

template <typename PointT> bool
pcl::ObliqueCut<PointT>::dirty (int level) const
{
  std::lock_guard<std::mutex> g (mutex_[level]);
  return dirty_[level];
}

template <typename PointT> std::size_t
pcl::ObliqueCut<PointT>::worklists (int level) const
{
  std::lock_guard<std::mutex> g (mutex_[level]);
  return lists_[level].size ();
}

template <typename PointT> void
pcl::ObliqueCut<PointT>::runMaster ()
{
  const int lmax = params_.max_depth;
  int l = lmax;
  while (!complete_)
  {
    if (dirty (l))
    {
      fixLevel (l);
      // Algorithm 3: climb while the next level has more work than the leaf level.
      l = (l > 1 && worklists (l - 1) > worklists (lmax)) ? l - 1 : lmax;
      continue;
    }
    int d = 0;
    for (int k = lmax; k >= 1 && d == 0; --k)
      if (dirty (k))
        d = k;
    if (d > 0)
    {
      l = d;
      continue;
    }
    std::unique_lock<std::mutex> lk (signal_mutex_);
    signal_.wait (lk, [&] {
      if (complete_)
        return true;
      for (int k = lmax; k >= 1; --k)
        if (dirty (k))
          return true;
      return false;
    });
  }
}

template <typename PointT> bool
pcl::ObliqueCut<PointT>::isComplete () const
{
  return complete_;
}

template <typename PointT> typename pcl::ObliqueCut<PointT>::Snapshot
pcl::ObliqueCut<PointT>::snapshot () const
{
  Snapshot s;
  std::vector<std::unique_lock<std::mutex>> locks;
  for (int l = 0; l <= params_.max_depth; ++l)
    locks.emplace_back (mutex_[l]);
  s.boundary = boundary_[params_.max_depth];
  s.lists.resize (params_.max_depth + 1);
  for (int l = 0; l <= params_.max_depth; ++l)
    for (const Worklist& w : lists_[l])
      s.lists[l].insert (s.lists[l].end (), w.begin (), w.end ());
  s.root = root_;
  s.complete = complete_;
  return s;
}

template <typename PointT> std::size_t
pcl::ObliqueCut<PointT>::memoryBytes () const
{
  std::size_t b = 0;
  for (const auto& s : slots_)
    b += s->nodes.bytes () + s->points.bytes () + s->scratch_nodes.bytes () + s->scratch_points.bytes ();
  return b;
}

#define PCL_INSTANTIATE_ObliqueCut(T) template class PCL_EXPORTS pcl::ObliqueCut<T>;
