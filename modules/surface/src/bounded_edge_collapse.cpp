#include <pclx/surface/detail/bounded_edge_collapse.h>
#include <pclx/surface/detail/plane_quadric.h>
#include <pclx/surface/detail/plane_set_bound.h>

#include <pcl/console/print.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace pclx {
namespace surface {
namespace detail {
namespace {

// No triangle may turn by more than this in one collapse (Garland–Heckbert's fold-over test).
constexpr double kMaxNormalTurnDeg = 60;
// Nor shrink below this share of its area: slivers of no area are the start of a fold.
constexpr double kMinAreaRatio = 1e-3;
// Eigenvalues of a quadric at most this share of the largest are dropped when placing a vertex,
// so that directions its planes do not constrain keep the edge's midpoint.
constexpr double kKeepEigen = 0.02;
// Below this many candidates their keys are computed in one thread.
constexpr std::ptrdiff_t kMinParallelEdges = 4096;
// The mesh is cut into this many slabs along its longest axis, which collapse in parallel while
// the vertices on the cuts are held; then the cuts collapse. The result does not depend on the
// number of threads.
constexpr int kSlabs = 4;
// The adjacency is built over ranges of this many vertices in parallel.
constexpr std::size_t kVerticesPerRange = 16384;

// A candidate collapse of the edge (a, b).
struct Candidate
{
  float key;             // root mean square distance to the planes of a and b
  std::int32_t a, b;
  std::uint32_t sa, sb;  // the vertices' stamps when queued: stale once either changes
};

// Candidates by key quantised to 1/4096 of the bound, first in first out within a share: pushes
// and pops take constant time, and keys that close are equally good.
class CandidateQueue
{
public:
  void
  reset (double bound)
  {
    scale_ = kBuckets / bound;
    buckets_.assign (kBuckets, {});
    heads_.assign (kBuckets, 0);
    lowest_ = kBuckets;
  }
  void
  push (const Candidate& c)
  {
    const int k = std::min (kBuckets - 1, static_cast<int> (c.key * scale_));
    buckets_[k].push_back (c);
    lowest_ = std::min (lowest_, k);
  }
  bool
  pop (Candidate& c)
  {
    while (lowest_ < kBuckets && heads_[lowest_] == buckets_[lowest_].size ())
    {
      buckets_[lowest_].clear ();
      heads_[lowest_] = 0;
      ++lowest_;
    }
    if (lowest_ == kBuckets)
      return false;
    c = buckets_[lowest_][heads_[lowest_]++];
    return true;
  }

private:
  static constexpr int kBuckets = 4096;
  double scale_ = 0;
  std::vector<std::vector<Candidate>> buckets_;
  std::vector<std::size_t> heads_;
  int lowest_ = kBuckets;
};

class BoundedCollapse
{
public:
  BoundedCollapse (const std::vector<Eigen::Vector3f>& vertices, std::vector<Triangle>& triangles, double eps,
                   std::size_t max_planes, EdgeCollapseStats& stats)
    : tris_ (triangles), eps_ (eps), max_planes_ (max_planes), stats_ (stats)
  {
    pos_.reserve (vertices.size ());
    for (const auto& v : vertices)
      pos_.push_back (v.cast<double> ());
  }

  void
  run (const VertexPlanes& planes)
  {
    buildAdjacency ();
    addPlanes (planes);
    const std::vector<std::int32_t> cut = holdCuts ();
    std::vector<Worker> workers (kSlabs);
    for (Worker& w : workers)
      w.mark.assign (pos_.size (), 0);
    collapseSlabs (workers);
    collapseCuts (cut, workers[0]);
    for (const Worker& w : workers)
    {
      stats_.collapses += w.stats.collapses;
      stats_.rejected_size += w.stats.rejected_size;
      stats_.rejected_topology += w.stats.rejected_topology;
      stats_.rejected_distance += w.stats.rejected_distance;
      stats_.rejected_foldover += w.stats.rejected_foldover;
      stats_.max_distance = std::max (stats_.max_distance, w.stats.max_distance);
    }
  }

  // The vertices still used, in their order, and the live triangles renumbered.
  void
  write (std::vector<Eigen::Vector3f>& vertices, std::vector<Triangle>& triangles) const
  {
    std::vector<std::uint32_t> index (pos_.size (), kUnused);
    std::vector<Triangle> out;
    for (std::size_t f = 0; f < tris_.size (); ++f)
      if (face_alive_[f])
        for (std::uint32_t v : tris_[f])
          index[v] = 0;
    vertices.clear ();
    for (std::size_t v = 0; v < pos_.size (); ++v)
      if (index[v] != kUnused)
      {
        index[v] = static_cast<std::uint32_t> (vertices.size ());
        vertices.push_back (pos_[v].cast<float> ());
      }
    for (std::size_t f = 0; f < tris_.size (); ++f)
      if (face_alive_[f])
        out.push_back ({index[tris_[f][0]], index[tris_[f][1]], index[tris_[f][2]]});
    triangles.swap (out);
    stats_.triangles = triangles.size ();
  }

private:
  static constexpr std::uint32_t kUnused = std::numeric_limits<std::uint32_t>::max ();

  // A slab's queue, buffers and counts. `mark` holds, per vertex, the stamp of the last link
  // test that met it.
  struct Worker
  {
    CandidateQueue queue;
    std::vector<std::int32_t> na;
    std::vector<std::uint32_t> mark;
    std::uint32_t stamp = 0;
    EdgeCollapseStats stats;
  };

  // Each slab collapses its own edges in parallel with the others: with the vertices on the
  // cuts held, no two slabs touch the same vertex or triangle.
  void
  collapseSlabs (std::vector<Worker>& workers)
  {
    const std::vector<float> keys = edgeKeys ();
#pragma omp parallel for schedule (dynamic, 1)
    for (int s = 0; s < kSlabs; ++s)
    {
      Worker& w = workers[s];
      w.queue.reset (eps_);
      for (std::size_t i = 0; i < edges_.size (); ++i)
        if (keys[i] >= 0 && slab_[edges_[i].first] == s)
          w.queue.push ({keys[i], edges_[i].first, edges_[i].second, 0, 0});
      collapseAll (w);
    }
  }

  // Then the edges of the vertices on the cuts, released.
  void
  collapseCuts (const std::vector<std::int32_t>& cut, Worker& w)
  {
    held_.assign (pos_.size (), 0);
    w.queue.reset (eps_);
    for (std::int32_t c : cut)
    {
      neighbours (c, w.na);
      for (std::int32_t u : w.na)
        push (w, std::min (c, u), std::max (c, u));
    }
    collapseAll (w);
  }

  // Cuts the vertices into kSlabs slabs of equal counts along the longest axis of their box and
  // holds the vertices with a neighbour in another slab; returns those.
  std::vector<std::int32_t>
  holdCuts ()
  {
    const std::size_t n = pos_.size ();
    Eigen::Vector3d lo = Eigen::Vector3d::Constant (std::numeric_limits<double>::infinity ()), hi = -lo;
    for (const auto& p : pos_)
    {
      lo = lo.cwiseMin (p);
      hi = hi.cwiseMax (p);
    }
    int axis = 0;
    (hi - lo).maxCoeff (&axis);
    std::vector<double> coord (n);
    for (std::size_t v = 0; v < n; ++v)
      coord[v] = pos_[v][axis];
    std::vector<double> order = coord;
    double cuts[kSlabs];
    for (int s = 1; s < kSlabs; ++s)
    {
      std::nth_element (order.begin (), order.begin () + s * n / kSlabs, order.end ());
      cuts[s] = order[s * n / kSlabs];
    }
    slab_.assign (n, 0);
    for (std::size_t v = 0; v < n; ++v)
      for (int s = 1; s < kSlabs; ++s)
        slab_[v] += coord[v] >= cuts[s];
    held_.assign (n, 0);
    for (const auto& [a, b] : edges_)
      if (slab_[a] != slab_[b])
        held_[a] = held_[b] = 1;
    std::vector<std::int32_t> cut;
    for (std::size_t v = 0; v < n; ++v)
      if (held_[v])
        cut.push_back (static_cast<std::int32_t> (v));
    return cut;
  }

  // The neighbours of v over its live faces, sorted and unique.
  void
  neighbours (std::int32_t v, std::vector<std::int32_t>& out) const
  {
    out.clear ();
    for (std::int32_t f : vf_[v])
      if (face_alive_[f])
        for (std::uint32_t c : tris_[f])
          if (static_cast<std::int32_t> (c) != v)
            out.push_back (static_cast<std::int32_t> (c));
    std::sort (out.begin (), out.end ());
    out.erase (std::unique (out.begin (), out.end ()), out.end ());
  }

  // Faces per vertex, the unique edges, boundary vertices and vertices of non-manifold edges.
  void
  buildAdjacency ()
  {
    const std::size_t n = pos_.size ();
    listFaces ();
    face_alive_.assign (tris_.size (), 1);
    boundary_.assign (n, 0);
    locked_.assign (n, 0);
    stamp_.assign (n, 0);
    // Vertices in fixed ranges, each range's edges found in parallel and appended in order, so
    // the edges keep the order of their first vertex whatever the number of threads.
    const std::ptrdiff_t ranges = static_cast<std::ptrdiff_t> ((n + kVerticesPerRange - 1) / kVerticesPerRange);
    std::vector<RangeEdges> found (ranges);
#pragma omp parallel for schedule (dynamic, 1)
    for (std::ptrdiff_t r = 0; r < ranges; ++r)
      edgesFrom (r * kVerticesPerRange, std::min (n, (r + 1) * kVerticesPerRange), found[r]);
    for (const RangeEdges& f : found)
    {
      edges_.insert (edges_.end (), f.edges.begin (), f.edges.end ());
      boundary_edges_.insert (boundary_edges_.end (), f.boundary.begin (), f.boundary.end ());
      for (std::int32_t v : f.locked)
        locked_[v] = 1;
    }
    for (const auto& [a, b] : boundary_edges_)
      boundary_[a] = boundary_[b] = 1;
  }

  // One vertex range's edges, boundary edges and vertices of edges with more than two triangles.
  struct RangeEdges
  {
    std::vector<std::pair<std::int32_t, std::int32_t>> edges, boundary;
    std::vector<std::int32_t> locked;
  };

  // The edges (a, b), a < b, of the vertices a in [begin, end): each once, the boundary edges
  // (one triangle) and the ends of edges with more than two.
  void
  edgesFrom (std::size_t begin, std::size_t end, RangeEdges& out) const
  {
    std::vector<std::int32_t> ends;
    for (std::size_t v = begin; v < end; ++v)
    {
      const std::int32_t a = static_cast<std::int32_t> (v);
      ends.clear ();
      for (std::int32_t f : vf_[a])
        for (std::uint32_t c : tris_[f])
          if (static_cast<std::int32_t> (c) > a)
            ends.push_back (static_cast<std::int32_t> (c));
      std::sort (ends.begin (), ends.end ());
      for (std::size_t k = 0; k < ends.size ();)
      {
        std::size_t j = k;
        while (j < ends.size () && ends[j] == ends[k])
          ++j;
        const std::int32_t b = ends[k];
        if (j - k > 2)
        {
          out.locked.push_back (a);
          out.locked.push_back (b);
        }
        else if (j - k == 1)
          out.boundary.emplace_back (a, b);
        out.edges.emplace_back (a, b);
        k = j;
      }
    }
  }

  // Each vertex's faces in increasing order: counted, placed, then copied to their lists in parallel.
  void
  listFaces ()
  {
    const std::size_t n = pos_.size ();
    std::vector<std::uint32_t> start (n + 1, 0);
    for (const auto& t : tris_)
      for (std::uint32_t v : t)
        ++start[v + 1];
    for (std::size_t v = 0; v < n; ++v)
      start[v + 1] += start[v];
    std::vector<std::int32_t> faces (start[n]);
    std::vector<std::uint32_t> next (start.begin (), start.end () - 1);
    for (std::size_t f = 0; f < tris_.size (); ++f)
      for (std::uint32_t v : tris_[f])
        faces[next[v]++] = static_cast<std::int32_t> (f);
    vf_.assign (n, {});
#pragma omp parallel for schedule (static)
    for (std::ptrdiff_t v = 0; v < static_cast<std::ptrdiff_t> (n); ++v)
      vf_[v].assign (faces.begin () + start[v], faces.begin () + start[v + 1]);
  }

  // Each vertex's planes, contiguous, and their quadric: its own planes and, on the boundary,
  // the planes through its boundary edges perpendicular to their triangle.
  void
  addPlanes (const VertexPlanes& vp)
  {
    const std::size_t n = pos_.size ();
    std::vector<std::vector<Eigen::Vector4f>> extra (n);
    for (const auto& [a, b] : boundary_edges_)
    {
      const auto& t = tris_[sharedFace (a, b)];
      const Eigen::Vector3d fn = (pos_[t[1]] - pos_[t[0]]).cross (pos_[t[2]] - pos_[t[0]]);
      Eigen::Vector3d u;
      double d;
      if (!boundaryPlane (pos_[a], pos_[b], fn, u, d))
        continue;
      const Eigen::Vector4f plane = Eigen::Vector4d (u.x (), u.y (), u.z (), d).cast<float> ();
      extra[a].push_back (plane);
      extra[b].push_back (plane);
    }
    first_.assign (n + 1, 0);
    for (std::size_t v = 0; v < n; ++v)
      first_[v + 1] = first_[v] + (vp.begin[v + 1] - vp.begin[v]) + static_cast<std::uint32_t> (extra[v].size ());
    planes_.resize (first_[n]);
    q_.assign (n, PlaneQuadric::Zero ());
    count_.assign (n, 0);
    bound_.resize (n);
#pragma omp parallel for schedule (static)
    for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t> (n); ++i)
    {
      const auto v = static_cast<std::size_t> (i);
      locked_[v] |= vp.begin[v + 1] == vp.begin[v];
      const auto own = std::copy (vp.planes.begin () + vp.begin[v], vp.planes.begin () + vp.begin[v + 1],
                                  planes_.begin () + first_[v]);
      std::copy (extra[v].begin (), extra[v].end (), own);
      for (std::uint32_t k = first_[v]; k < first_[v + 1]; ++k)
        addPlane (q_[v], planes_[k].head<3> ().cast<double> (), planes_[k][3], 1.0);
      count_[v] = first_[v + 1] - first_[v];
      bound_[v] =
          PlaneSetBound::of (planes_.data () + first_[v], planes_.data () + first_[v + 1], pos_[v].cast<float> ());
    }
    // Every vertex starts as a cluster of itself.
    next_.assign (n, -1);
    last_.resize (n);
    for (std::size_t v = 0; v < n; ++v)
      last_[v] = static_cast<std::int32_t> (v);
  }

  std::int32_t
  sharedFace (std::int32_t a, std::int32_t b) const
  {
    for (std::int32_t f : vf_[a])
      if (face_alive_[f] && hasCorner (tris_[f], b))
        return f;
    return -1;
  }

  static bool
  hasCorner (const Triangle& t, std::int32_t v)
  {
    const auto u = static_cast<std::uint32_t> (v);
    return t[0] == u || t[1] == u || t[2] == u;
  }

  // The quadric's minimiser for the merged vertex, and the root mean square distance to its planes.
  Eigen::Vector3d
  place (std::int32_t a, std::int32_t b, double& rms) const
  {
    const PlaneQuadric q = q_[a] + q_[b];
    const Eigen::Vector3d m = 0.5 * (pos_[a] + pos_[b]);
    Eigen::Vector3d x = minimiseEdge (q);
    if (!x.allFinite () || (x - m).squaredNorm () > 0.25 * (pos_[a] - pos_[b]).squaredNorm ())
      x = minimise (q, m, kKeepEigen);
    rms = std::sqrt (std::max (0.0, evaluate (q, x)) / static_cast<double> (count_[a] + count_[b]));
    return x;
  }

  void
  push (Worker& w, std::int32_t a, std::int32_t b)
  {
    if (locked_[a] || locked_[b] || held_[a] || held_[b])
      return;
    double rms;
    place (a, b, rms);
    if (!(rms <= eps_))
      return;
    w.queue.push ({static_cast<float> (rms), a, b, stamp_[a], stamp_[b]});
  }

  // The key of every edge that may collapse (−1 for the others), computed in parallel.
  std::vector<float>
  edgeKeys () const
  {
    const std::ptrdiff_t n = static_cast<std::ptrdiff_t> (edges_.size ());
    std::vector<float> keys (n);
#pragma omp parallel for schedule (static) if (n > kMinParallelEdges)
    for (std::ptrdiff_t i = 0; i < n; ++i)
    {
      const auto [a, b] = edges_[i];
      double rms = std::numeric_limits<double>::infinity ();
      if (!locked_[a] && !locked_[b] && !held_[a] && !held_[b])
        place (a, b, rms);
      keys[i] = rms <= eps_ ? static_cast<float> (rms) : -1.f;
    }
    return keys;
  }

  // The link condition (common neighbours of a and b are exactly the corners opposite the edge),
  // with the boundary closed by a virtual vertex: two boundary vertices may only join along a
  // boundary edge.
  bool
  keepsTopology (std::int32_t a, std::int32_t b, Worker& w) const
  {
    int shared = 0;
    for (std::int32_t f : vf_[a])
      shared += face_alive_[f] && hasCorner (tris_[f], b);
    if (shared == 0 || (boundary_[a] && boundary_[b] && shared != 1))
      return false;
    // a's neighbours get the stamp, b's neighbours found with it count once (the stamp moves
    // on); neither a nor b counts, as each is only the other's neighbour.
    if (w.stamp >= std::numeric_limits<std::uint32_t>::max () - 2)
    {
      std::fill (w.mark.begin (), w.mark.end (), 0u);
      w.stamp = 0;
    }
    const std::uint32_t in_a = ++w.stamp, counted = ++w.stamp;
    for (std::int32_t f : vf_[a])
      if (face_alive_[f])
        for (std::uint32_t c : tris_[f])
          if (static_cast<std::int32_t> (c) != a)
            w.mark[c] = in_a;
    int common = 0;
    for (std::int32_t f : vf_[b])
      if (face_alive_[f])
        for (std::uint32_t c : tris_[f])
          if (static_cast<std::int32_t> (c) != b && w.mark[c] == in_a)
          {
            w.mark[c] = counted;
            ++common;
          }
    return common == shared;
  }

  // The largest distance of x to the planes c answers for, or the first one over `bound`.
  float
  clusterDistance (std::int32_t c, const Eigen::Vector3f& x, float bound) const
  {
    float worst = 0;
    for (std::int32_t v = c; v >= 0; v = next_[v])
      for (std::uint32_t k = first_[v]; k < first_[v + 1]; ++k)
      {
        worst = std::max (worst, std::abs (planes_[k].head<3> ().dot (x) + planes_[k][3]));
        if (worst > bound)
          return worst;
      }
    return worst;
  }

  // An upper bound of the largest distance of x to the planes a and b answer for, exact where
  // their PlaneSetBound cannot show it within the bound; over the bound exactly when that
  // distance is.
  double
  maxDistance (std::int32_t a, std::int32_t b, const Eigen::Vector3d& x) const
  {
    const Eigen::Vector3f xf = x.cast<float> ();
    const float bound = static_cast<float> (eps_);
    const float slack = PlaneSetBound::slackAt (xf);
    float worst = 0;
    for (std::int32_t c : {a, b})
    {
      const float quick = bound_[c].at (xf - pos_[c].cast<float> (), slack);
      worst = std::max (worst, quick <= bound ? quick : clusterDistance (c, xf, bound));
      if (worst > bound)
        return worst;
    }
    return worst;
  }

  // Whether moving a and b to x flips, turns too far or degenerates a triangle that stays.
  bool
  foldsOver (std::int32_t a, std::int32_t b, const Eigen::Vector3d& x, double cos_turn) const
  {
    for (std::int32_t v : {a, b})
      for (std::int32_t f : vf_[v])
      {
        const auto& t = tris_[f];
        if (!face_alive_[f] || (hasCorner (t, a) && hasCorner (t, b)))
          continue;
        Eigen::Vector3d p[3], q[3];
        for (int k = 0; k < 3; ++k)
        {
          p[k] = pos_[t[k]];
          q[k] = static_cast<std::int32_t> (t[k]) == v ? x : p[k];
        }
        const Eigen::Vector3d n0 = (p[1] - p[0]).cross (p[2] - p[0]);
        const Eigen::Vector3d n1 = (q[1] - q[0]).cross (q[2] - q[0]);
        const double l0 = n0.norm (), l1 = n1.norm ();
        if (!(l1 > kMinAreaRatio * l0) || n0.dot (n1) < cos_turn * l0 * l1)
          return true;
      }
    return false;
  }

  // Collapses b into a at x, within reach of their planes, and queues a's edges again.
  void
  collapse (Worker& w, std::int32_t a, std::int32_t b, const Eigen::Vector3d& x, double reach)
  {
    bound_[a] = PlaneSetBound::merge (bound_[a], static_cast<float> (count_[a]), bound_[b],
                                      static_cast<float> (count_[b]), static_cast<float> (reach));
    pos_[a] = x;
    q_[a] += q_[b];
    next_[last_[a]] = b;
    last_[a] = last_[b];
    count_[a] += count_[b];
    boundary_[a] |= boundary_[b];
    ++stamp_[a];
    ++stamp_[b];
    for (std::int32_t f : vf_[b])
    {
      if (!face_alive_[f])
        continue;
      auto& t = tris_[f];
      if (hasCorner (t, a))
      {
        face_alive_[f] = 0;
        continue;
      }
      for (auto& c : t)
        if (static_cast<std::int32_t> (c) == b)
          c = static_cast<std::uint32_t> (a);
      vf_[a].push_back (f);
    }
    vf_[b].clear ();
    auto& fa = vf_[a];
    fa.erase (std::remove_if (fa.begin (), fa.end (), [this] (std::int32_t f) { return !face_alive_[f]; }), fa.end ());
    neighbours (a, w.na);
    for (std::int32_t c : w.na)
      push (w, std::min (a, c), std::max (a, c));
  }

  void
  collapseAll (Worker& w)
  {
    const double cos_turn = std::cos (kMaxNormalTurnDeg * M_PI / 180.0);
    EdgeCollapseStats& st = w.stats;
    Candidate e;
    while (w.queue.pop (e))
    {
      const std::int32_t a = e.a, b = e.b;
      if (e.sa != stamp_[a] || e.sb != stamp_[b] || vf_[a].empty () || vf_[b].empty ())
        continue;
      if (count_[a] + count_[b] > max_planes_)
      {
        ++st.rejected_size;
        continue;
      }
      if (!keepsTopology (a, b, w))
      {
        ++st.rejected_topology;
        continue;
      }
      double rms;
      const Eigen::Vector3d x = place (a, b, rms);
      const double d = maxDistance (a, b, x);
      if (!(d <= eps_))
      {
        ++st.rejected_distance;
        continue;
      }
      if (foldsOver (a, b, x, cos_turn))
      {
        ++st.rejected_foldover;
        continue;
      }
      collapse (w, a, b, x, d);
      ++st.collapses;
      st.max_distance = std::max (st.max_distance, d);
    }
  }

  std::vector<Triangle>& tris_;
  const double eps_;
  const std::size_t max_planes_;
  EdgeCollapseStats& stats_;
  std::vector<Eigen::Vector3d> pos_;
  std::vector<PlaneQuadric> q_;
  std::vector<std::vector<std::int32_t>> vf_;
  std::vector<std::uint8_t> face_alive_, boundary_, locked_, held_;
  std::vector<int> slab_;
  std::vector<std::uint32_t> stamp_;
  std::vector<std::pair<std::int32_t, std::int32_t>> edges_, boundary_edges_;
  // Input vertex v's planes are planes_[first_[v]] … planes_[first_[v + 1] − 1]; a live vertex
  // answers for the planes of the input vertices in its cluster, a list from itself to last_
  // linked by next_, count_ planes in all.
  std::vector<Eigen::Vector4f> planes_;
  std::vector<std::uint32_t> first_;
  std::vector<std::int32_t> next_, last_;
  std::vector<std::size_t> count_;
  // Per live vertex, a bound on its distance to the planes it answers for, made at pos_.
  std::vector<PlaneSetBound> bound_;

};

bool
fail (const char* what)
{
  PCL_ERROR ("[pclx::surface::detail::collapseEdgesWithinDistance] %s; the mesh is unchanged\n", what);
  return false;
}

}  // namespace

bool
collapseEdgesWithinDistance (std::vector<Eigen::Vector3f>& vertices, std::vector<Triangle>& triangles,
                             const VertexPlanes& planes, double max_distance, std::size_t max_planes,
                             EdgeCollapseStats& stats)
{
  stats = EdgeCollapseStats ();
  stats.input_triangles = stats.triangles = triangles.size ();
  if (!(max_distance > 0) || !std::isfinite (max_distance))
    return fail ("the distance bound must be positive and finite");
  if (max_planes == 0)
    return fail ("a vertex must be allowed at least one plane");
  if (vertices.size () >= static_cast<std::size_t> (std::numeric_limits<std::int32_t>::max ()) ||
      triangles.size () >= static_cast<std::size_t> (std::numeric_limits<std::int32_t>::max ()))
    return fail ("the mesh has more than 2^31 vertices or triangles");
  for (const auto& t : triangles)
    if (t[0] >= vertices.size () || t[1] >= vertices.size () || t[2] >= vertices.size () || t[0] == t[1] ||
        t[1] == t[2] || t[2] == t[0])
      return fail ("a triangle has an index out of range or a repeated corner");
  if (planes.begin.size () != vertices.size () + 1 || planes.begin.front () != 0 ||
      planes.begin.back () != planes.planes.size () || !std::is_sorted (planes.begin.begin (), planes.begin.end ()))
    return fail ("the planes do not match the vertices");
  for (const auto& p : planes.planes)
    if (!p.allFinite () || std::abs (p.head<3> ().norm () - 1.f) > 1e-3f)
      return fail ("a plane is not finite or its normal is not a unit vector");
  for (const auto& v : vertices)
    if (!v.allFinite ())
      return fail ("a vertex is not finite");
  if (triangles.empty ())
    return true;
  std::vector<Triangle> work = triangles;
  BoundedCollapse c (vertices, work, max_distance, max_planes, stats);
  c.run (planes);
  c.write (vertices, triangles);
  return true;
}

}  // namespace detail
}  // namespace surface
}  // namespace pclx
