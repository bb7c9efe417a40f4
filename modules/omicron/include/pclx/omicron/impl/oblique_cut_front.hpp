#pragma once
#include <pclx/omicron/oblique_cut_front.h>

#include <pcl/console/print.h>

#include <limits>

template <typename PointT> void
pcl::ObliqueCutFront<PointT>::reset (int max_depth, const Eigen::Vector3d& origin, double edge,
                                     std::vector<float> splat_radius)
{
  std::lock_guard<std::mutex> g (front_mutex_);
  {
    std::lock_guard<std::mutex> p (placeholder_mutex_);
    placeholders_.clear ();
  }
  for (int l = 0; l < kLevels; ++l)
  {
    std::lock_guard<std::mutex> q (leaf_mutex_[l]);
    leaves_[l].clear ();
  }
  front_.clear ();
  max_depth_ = max_depth;
  origin_ = origin;
  edge_ = edge;
  radius_ = std::move (splat_radius);
  radius_.resize (kLevels, radius_.empty () ? 0.f : radius_.back ());
  start_ = std::chrono::steady_clock::now ();
  first_leaf_ = -1.0;
}

template <typename PointT> void
pcl::ObliqueCutFront<PointT>::setProjectionThreshold (float t)
{
  if (!(t > 0.f) || !std::isfinite (t))
  {
    PCL_ERROR ("[pcl::ObliqueCutFront::setProjectionThreshold] the threshold must be a finite number > 0 (got %g); "
               "keeping %g\n", t, getProjectionThreshold ());
    return;
  }
  std::lock_guard<std::mutex> g (front_mutex_);
  threshold_ = t;
}

template <typename PointT> void
pcl::ObliqueCutFront<PointT>::startFrom (const Node& node)
{
  std::lock_guard<std::mutex> g (front_mutex_);
  front_.assign (1, Slot::of (&node));
}

template <typename PointT> void
pcl::ObliqueCutFront<PointT>::insertPlaceholders (std::vector<MortonCode>&& placeholders)
{
  std::lock_guard<std::mutex> g (placeholder_mutex_);
  placeholders_.insert (placeholders_.end (), placeholders.begin (), placeholders.end ());
}

template <typename PointT> void
pcl::ObliqueCutFront<PointT>::insertLeaves (int level, std::vector<const Node*>&& leaves)
{
  if (first_leaf_.load () < 0.0 && !leaves.empty ())
    first_leaf_ = std::chrono::duration<double> (std::chrono::steady_clock::now () - start_).count ();
  std::lock_guard<std::mutex> g (leaf_mutex_[level]);
  leaves_[level].insert (leaves_[level].end (), leaves.begin (), leaves.end ());
}

template <typename PointT> double
pcl::ObliqueCutFront<PointT>::secondsToFirstLeaf () const
{
  return first_leaf_.load ();
}

template <typename PointT> std::size_t
pcl::ObliqueCutFront<PointT>::pendingLeaves () const
{
  std::size_t n = 0;
  for (int l = 0; l < kLevels; ++l)
  {
    std::lock_guard<std::mutex> g (leaf_mutex_[l]);
    n += leaves_[l].size ();
  }
  return n;
}

template <typename PointT> std::vector<typename pcl::ObliqueCutFront<PointT>::Entry>
pcl::ObliqueCutFront<PointT>::entries () const
{
  std::lock_guard<std::mutex> g (front_mutex_);
  std::vector<Entry> out;
  out.reserve (front_.size ());
  for (const Slot& s : front_)
    out.push_back (Entry{s.node (), s.code (max_depth_)});
  return out;
}

template <typename PointT> std::size_t
pcl::ObliqueCutFront<PointT>::entryCount () const
{
  std::size_t n = 0;
  {
    std::lock_guard<std::mutex> g (front_mutex_);
    n = front_.size ();
  }
  std::lock_guard<std::mutex> p (placeholder_mutex_);
  return n + placeholders_.size ();
}

template <typename PointT> float
pcl::ObliqueCutFront<PointT>::splatRadius (const Node& n) const
{
  // A collapsed leaf keeps its child's full density.
  const int l = (n.flags & pclx::omicron::detail::kCollapsed) ? max_depth_ : n.level;
  return radius_[l];
}

template <typename PointT> bool
pcl::ObliqueCutFront<PointT>::culled (const Node& n, const Camera& camera, float& ndc_diagonal) const
{
  Eigen::Vector3f lo, hi;
  n.code.box (origin_, edge_, lo, hi);
  // Outcodes: culled when all eight corners are outside one clip plane.
  unsigned all_out = 0x3f;
  bool behind = false;
  Eigen::Vector2f nmin = Eigen::Vector2f::Constant (std::numeric_limits<float>::max ());
  Eigen::Vector2f nmax = -nmin;
  for (int c = 0; c < 8; ++c)
  {
    const Eigen::Vector4f p ((c & 4) ? hi.x () : lo.x (), (c & 2) ? hi.y () : lo.y (), (c & 1) ? hi.z () : lo.z (), 1.f);
    const Eigen::Vector4f q = camera.view_projection * p;
    unsigned out = 0;
    out |= (q.x () < -q.w ()) ? 1u : 0u;
    out |= (q.x () > q.w ()) ? 2u : 0u;
    out |= (q.y () < -q.w ()) ? 4u : 0u;
    out |= (q.y () > q.w ()) ? 8u : 0u;
    out |= (q.z () < -q.w ()) ? 16u : 0u;
    out |= (q.z () > q.w ()) ? 32u : 0u;
    all_out &= out;
    if (q.w () <= 1e-6f)
      behind = true;
    else
    {
      const Eigen::Vector2f ndc = q.head<2> () / q.w ();
      nmin = nmin.cwiseMin (ndc);
      nmax = nmax.cwiseMax (ndc);
    }
  }
  // A box reaching behind the eye has no bounded projection: it counts as large.
  ndc_diagonal = behind ? std::numeric_limits<float>::infinity () : (nmax - nmin).norm ();
  return all_out != 0;
}

template <typename PointT> bool
pcl::ObliqueCutFront<PointT>::trySubstitution (Slot& e, std::deque<const Node*>& subs) const
{
  // Algorithm 6: only the head of the substitution list can match (both are in Morton order).
  if (e.node () || subs.empty () || !subs.front ()->code.isAncestorOf (e.code (max_depth_)))
    return false;
  e = Slot::of (subs.front ());
  subs.pop_front ();
  return true;
}

template <typename PointT> void
pcl::ObliqueCutFront<PointT>::evaluate (const Camera& camera, std::vector<Item>& out)
{
  out.clear ();
  std::lock_guard<std::mutex> g (front_mutex_);
  // Substitution level: most pending leaves. Its list is taken before the placeholders, so
  // each of its leaves already has its placeholder in the front.
  int sl = 0;
  std::size_t most = 0;
  for (int l = 0; l < kLevels; ++l)
  {
    std::lock_guard<std::mutex> q (leaf_mutex_[l]);
    if (leaves_[l].size () > most)
    {
      most = leaves_[l].size ();
      sl = l;
    }
  }
  std::deque<const Node*> subs;
  if (most > 0)
  {
    std::lock_guard<std::mutex> q (leaf_mutex_[sl]);
    subs.swap (leaves_[sl]);
  }
  {
    std::lock_guard<std::mutex> p (placeholder_mutex_);
    front_.reserve (front_.size () + placeholders_.size ());
    for (const MortonCode& c : placeholders_)
      front_.push_back (Slot::placeholder (c, max_depth_));
    placeholders_.clear ();
  }

  const auto draw = [&] (const Node* n) {
    if (n->num_points > 0)
      out.push_back (Item{n, n->points, n->num_points, splatRadius (*n)});
  };
  // The walk rewrites the front in place: what it keeps of the entries read so far never
  // takes more slots than they did, except after a branch, which first moves the unread rest
  // aside and then appends to the front.
  std::vector<Slot> rest;
  Slot* in = front_.data ();
  std::size_t size = front_.size (), kept = 0;
  bool in_place = true;
  const auto keep = [&] (Slot s) {
    if (in_place)
      front_[kept++] = s;
    else
      front_.push_back (s);
  };
  for (std::size_t i = 0; i < size;)
  {
    Slot& e = in[i];
    trySubstitution (e, subs);
    const Node* n = e.node ();
    if (!n)
    {
      keep (e);  // placeholders are neither drawn nor pruned
      ++i;
      continue;
    }
    const Node* p = n->parent ();
    float ps = 0.f;
    if (p && n == p->children && (culled (*p, camera, ps) || ps < threshold_) && i + p->num_children <= size)
    {
      // Algorithm 7: the whole sibling group must be in the front (substituting it if needed).
      bool all = true;
      for (std::uint8_t j = 1; j < p->num_children && all; ++j)
      {
        Slot& s = in[i + j];
        trySubstitution (s, subs);
        all = s.node () == p->children + j;
      }
      if (all)
      {
        keep (Slot::of (p));
        if (!culled (*p, camera, ps))
          draw (p);
        i += p->num_children;
        continue;
      }
    }
    float ns = 0.f;
    const bool hidden = culled (*n, camera, ns);
    if (!hidden && ns >= threshold_ && !n->isLeaf ())
    {
      // Algorithm 8: branch one level per frame.
      ++i;
      if (in_place && kept + n->num_children > i)
      {
        rest.assign (in + i, in + size);
        front_.erase (front_.begin () + static_cast<std::ptrdiff_t> (kept), front_.end ());
        in = rest.data ();
        size = rest.size ();
        i = 0;
        in_place = false;
      }
      for (std::uint8_t j = 0; j < n->num_children; ++j)
      {
        const Node* c = n->children + j;
        keep (Slot::of (c));
        float cs;
        if (!culled (*c, camera, cs))
          draw (c);
      }
      continue;
    }
    keep (e);
    if (!hidden)
      draw (n);
    ++i;
  }
  if (in_place)
    front_.erase (front_.begin () + static_cast<std::ptrdiff_t> (kept), front_.end ());
  if (!subs.empty ())
  {
    std::lock_guard<std::mutex> q (leaf_mutex_[sl]);
    subs.insert (subs.end (), leaves_[sl].begin (), leaves_[sl].end ());
    leaves_[sl].swap (subs);
  }
}

#define PCL_INSTANTIATE_ObliqueCutFront(T) template class PCL_EXPORTS pcl::ObliqueCutFront<T>;
