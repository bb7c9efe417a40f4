#include <pclx/normals/detail/planar_octree.h>
#include <pclx/normals/detail/plane_pca.h>

#include <Eigen/Dense>
#include <pcl/common/eigen.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <omp.h>

namespace pclx {
namespace normals {
namespace detail {

namespace {

int
threadCount (int requested)
{
  return requested > 0 ? requested : omp_get_max_threads ();
}

// Octant of p in a cell centred at c; build() and locate() must use the same rule.
inline int
octant (const Eigen::Vector3f& p, const Eigen::Vector3f& c)
{
  return (p.x () >= c.x () ? 1 : 0) | (p.y () >= c.y () ? 2 : 0) | (p.z () >= c.z () ? 4 : 0);
}

// Points that span no plane: coincident (λ1 = 0) or collinear (λ2 ≈ 0).
inline bool
spansNoPlane (const Eigen::Vector3d& lambda)
{
  return !(lambda (0) > 0) || lambda (1) <= 1e-12 * lambda (0);
}

struct UnionFind
{
  std::vector<int> parent;
  explicit UnionFind (int n) : parent (n) { std::iota (parent.begin (), parent.end (), 0); }
  int find (int a)
  {
    while (parent[a] != a)
      a = parent[a] = parent[parent[a]];
    return a;
  }
};

// The leaf-plane frame of a patch: its axes are derived from the normal alone (the
// quadric family is closed under in-plane rotation, so any axes do).
Eigen::Matrix3d
frameOfNormal (const Eigen::Vector3f& normal)
{
  Eigen::Matrix3d frame;
  frame.col (2) = normal.cast<double> ().normalized ();
  frame.col (0) = frame.col (2).unitOrthogonal ();
  frame.col (1) = frame.col (2).cross (frame.col (0));
  return frame;
}

// A surface fit (patch or region): the support's PCA plane (normal signed like
// `reference`), then the height field over it with in-plane coordinates relative to c
// over `scale`. The slope's standard error is σ / (√N · smallest in-plane spread), σ from
// the residual corrected for the fitted parameters.
bool
fitSurface (std::vector<Eigen::Vector3f>& pts, const Eigen::Vector3f& c, double scale,
            const Eigen::Vector3f& reference, bool quadric, SurfaceFit& R, bool trim = true)
{
  const int n = static_cast<int> (pts.size ());
  if (n < 3)
    return false;
  // One pass of sums shifted by c (the support's centre, so nothing cancels), as PCL's
  // computeMeanAndCovarianceMatrix does.
  Eigen::Vector3d s1 = Eigen::Vector3d::Zero ();
  Eigen::Matrix3d s2 = Eigen::Matrix3d::Zero ();
  for (const auto& q : pts)
  {
    const Eigen::Vector3d d = (q - c).cast<double> ();
    s1 += d;
    s2.noalias () += d * d.transpose ();
  }
  const Eigen::Vector3d mean = s1 / n;
  const PlanePca p = planePca (s2 / n - mean * mean.transpose ());
  if (spansNoPlane (p.lambda))
    return false;
  if (trim)
  {
    // A few points of another surface (across an edge, in a leaf that still passed the
    // planarity test) would bend a quadric into a fold: drop points far off the support's
    // plane compared with the median offset (noise or curvature stay within 4 robust
    // sigmas) and fit again.
    const Eigen::Vector3d nrm = p.normal;
    thread_local std::vector<float> off, sorted;  // one fit per patch: no allocation each time
    off.resize (n);
    for (int i = 0; i < n; ++i)
      off[i] = static_cast<float> (std::abs (((pts[i] - c).cast<double> () - mean).dot (nrm)));
    sorted = off;
    std::nth_element (sorted.begin (), sorted.begin () + n / 2, sorted.end ());
    const float limit = std::max (4.f * 1.4826f * sorted[n / 2], 1e-6f * static_cast<float> (scale));
    int kept = 0;
    for (int i = 0; i < n; ++i)
      if (off[i] <= limit)
        pts[kept++] = pts[i];
    if (kept < n)
    {
      pts.resize (kept);
      return fitSurface (pts, c, scale, reference, quadric, R, false);
    }
  }
  Eigen::Vector3f normal = p.normal.cast<float> ();
  if (normal.dot (reference) < 0)
    normal = -normal;
  const Eigen::Matrix3d frame = frameOfNormal (normal);
  R.support = n;
  R.o = c;
  R.n = frame.col (2).cast<float> ();
  R.scale = static_cast<float> (scale);
  R.curvature = static_cast<float> (p.lambda (2) / p.lambda.sum ());
  R.c.fill (0.f);
  const bool use_quadric = quadric && n >= 12;
  const int unknowns = use_quadric ? 6 : 3;
  double ss = 0;
  if (use_quadric)
  {
    // The normal equations hold only 15 distinct moments m[i][j] = Σ x^i y^j (i + j <= 4).
    double m[5][5] = {};
    Eigen::Matrix<double, 6, 1> ath = Eigen::Matrix<double, 6, 1>::Zero ();
    double hh = 0;
    const Eigen::Matrix3d ft = frame.transpose ();
    for (const auto& q : pts)
    {
      const Eigen::Vector3d l = ft * (q - c).cast<double> ();
      const double x = l.x () / scale, y = l.y () / scale, h = l.z ();
      const double x2 = x * x, y2 = y * y, xy = x * y;
      m[1][0] += x; m[0][1] += y;
      m[2][0] += x2; m[1][1] += xy; m[0][2] += y2;
      m[3][0] += x2 * x; m[2][1] += x2 * y; m[1][2] += x * y2; m[0][3] += y2 * y;
      m[4][0] += x2 * x2; m[3][1] += x2 * xy; m[2][2] += x2 * y2; m[1][3] += xy * y2; m[0][4] += y2 * y2;
      ath += Eigen::Matrix<double, 6, 1> (x2, xy, y2, x, y, 1.0) * h;
      hh += h * h;
    }
    m[0][0] = n;
    // Unknowns (x², xy, y², x, y, 1) have exponents (2,0) (1,1) (0,2) (1,0) (0,1) (0,0).
    static constexpr int ex[6] = {2, 1, 0, 1, 0, 0}, ey[6] = {0, 1, 2, 0, 1, 0};
    Eigen::Matrix<double, 6, 6> ata;
    for (int i = 0; i < 6; ++i)
      for (int j = 0; j < 6; ++j)
        ata (i, j) = m[ex[i] + ex[j]][ey[i] + ey[j]];
    Eigen::Matrix<double, 6, 6> reg = ata;
    for (int i = 0; i < 3; ++i)
      reg (i, i) += 1e-3 * n;  // a small ridge keeps strip-like supports from over-bending
    // The ridge makes reg positive definite unless the in-plane spread is degenerate:
    // Cholesky without LDLT's pivoting, LDLT only where Cholesky fails.
    Eigen::Matrix<double, 6, 1> cv;
    const Eigen::LLT<Eigen::Matrix<double, 6, 6>> llt (reg);
    if (llt.info () == Eigen::Success)
      cv = llt.solve (ath);
    else
      cv = reg.ldlt ().solve (ath);
    if (!cv.allFinite ())
      return false;
    for (int i = 0; i < 6; ++i)
      R.c[i] = static_cast<float> (cv (i));
    ss = hh - 2 * cv.dot (ath) + cv.dot (ata * cv);
  }
  else
  {
    // The PCA plane itself: through the mean, residual λ3.
    const Eigen::Vector3d m = frame.transpose () * mean;
    R.c[5] = static_cast<float> (m.z ());
    ss = n * p.lambda (2);
  }
  R.rms = static_cast<float> (std::sqrt (std::max (0.0, ss / n)));
  const int dof = std::max (1, n - unknowns);
  R.slope_sigma = static_cast<float> (R.rms * std::sqrt (static_cast<double> (n) / dof) /
                                      std::sqrt (n * std::max (p.lambda (1), 1e-300)));
  return true;
}

// In-plane coordinates (over scale) and height of p in a fit's frame.
Eigen::Vector3f
localOfFit (const SurfaceFit& P, const Eigen::Vector3f& p)
{
  const Eigen::Vector3f e1 = P.n.unitOrthogonal (), e2 = P.n.cross (e1);
  const Eigen::Vector3f d = p - P.o;
  return Eigen::Vector3f (d.dot (e1) / P.scale, d.dot (e2) / P.scale, d.dot (P.n));
}

// Normal of a fit's height field at (the projection of) p.
Eigen::Vector3f
normalAtFit (const SurfaceFit& P, const Eigen::Vector3f& p)
{
  const Eigen::Vector3f l = localOfFit (P, p);
  const auto& c = P.c;
  const float dx = (2 * c[0] * l.x () + c[1] * l.y () + c[3]) / P.scale;
  const float dy = (c[1] * l.x () + 2 * c[2] * l.y () + c[4]) / P.scale;
  const Eigen::Vector3f e1 = P.n.unitOrthogonal (), e2 = P.n.cross (e1);
  return (P.n - dx * e1 - dy * e2).normalized ();
}

// Distance of p from a fit's height field, along the fit's normal.
double
residualOfFit (const SurfaceFit& P, const Eigen::Vector3f& p)
{
  const Eigen::Vector3f l = localOfFit (P, p);
  const auto& c = P.c;
  const float x = l.x (), y = l.y ();
  return std::abs (l.z () - (c[0] * x * x + c[1] * x * y + c[2] * y * y + c[3] * x + c[4] * y + c[5]));
}

// Visits the leaves (first_child < 0) of a cell tree rooted at cells[0] whose cube
// (center ± half) overlaps the box [lo, hi]: octree nodes and patch cells alike.
template <typename Cell, typename Visit>
void
forLeavesInBox (const std::vector<Cell>& cells, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi, Visit visit)
{
  int stack[8 * 22];  // depth <= 21, 7 siblings left per level
  int top = 0;
  stack[top++] = 0;
  while (top > 0)
  {
    const int id = stack[--top];
    const Cell& C = cells[id];
    if (((C.center.array () - C.half) > hi.array ()).any () || ((C.center.array () + C.half) < lo.array ()).any ())
      continue;
    if (C.first_child < 0)
      visit (id);
    else
      for (int o = 0; o < 8; ++o)
        stack[top++] = C.first_child + o;
  }
}

}  // namespace

void
PlanarOctree::analyseNode (OctreeNode& node, const PlanarOctreeParams& params) const
{
  const int n = node.size ();
  node.planar = false;
  node.degenerate = true;
  if (n == 0)
    return;
  // Moments relative to the cell centre keep the covariance of tiny cells accurate.
  Eigen::Vector3d s1 = Eigen::Vector3d::Zero ();
  Eigen::Matrix3d s2 = Eigen::Matrix3d::Zero ();
  const Eigen::Vector3d c = node.center.cast<double> ();
  for (int i = node.begin; i < node.end; ++i)
  {
    const Eigen::Vector3d d = sorted_[i].cast<double> () - c;
    s1 += d;
    s2.noalias () += d * d.transpose ();
  }
  const Eigen::Vector3d mean = s1 / n;
  node.centroid = c + mean - origin_;
  node.covariance = s2 / n - mean * mean.transpose ();
  if (n < 3)
    return;
  const PlanePca p = planePca (node.covariance);
  node.eigenvalues = p.lambda;
  node.normal = p.normal.cast<float> ();
  const double trace = p.lambda.sum ();
  node.curvature = trace > 0 ? static_cast<float> (p.lambda (2) / trace) : 0.f;
  node.degenerate = spansNoPlane (p.lambda);
  if (node.degenerate)
    return;
  // Algorithm 1: a cell is an acceptable plane when λ2 > sα·λ3 and sβ·λ2 > λ1.
  node.planar = n >= std::max (3, params.min_points) && p.lambda (1) > params.s_alpha * p.lambda (2) &&
                params.s_beta * p.lambda (1) > p.lambda (0);
  if (node.planar && params.max_residual_ratio > 0)
  {
    const Eigen::Vector3d nrm = p.normal;
    const double limit = params.max_residual_ratio * std::sqrt (p.lambda (2)) + 1e-4 * node.half;
    for (int i = node.begin; i < node.end && node.planar; ++i)
      node.planar = std::abs ((sorted_[i].cast<double> () - c - mean).dot (nrm)) <= limit;
  }
}

void
PlanarOctree::partitionOctants (int begin, int end, const Eigen::Vector3f& c, std::array<int, 8>& cnt,
                                std::vector<int>& buffer, std::vector<unsigned char>& code)
{
  const int len = end - begin;
  code.resize (len);
  buffer.resize (len);
  thread_local std::vector<Eigen::Vector3f> moved;  // sorted_ moves along with order_
  moved.resize (len);
  cnt.fill (0);
  for (int i = 0; i < len; ++i)
    ++cnt[code[i] = static_cast<unsigned char> (octant (sorted_[begin + i], c))];
  std::array<int, 8> offset{};
  for (int o = 1; o < 8; ++o)
    offset[o] = offset[o - 1] + cnt[o - 1];
  for (int i = 0; i < len; ++i)
  {
    const int to = offset[code[i]]++;
    buffer[to] = order_[begin + i];
    moved[to] = sorted_[begin + i];
  }
  std::copy (buffer.begin (), buffer.begin () + len, order_.begin () + begin);
  std::copy (moved.begin (), moved.begin () + len, sorted_.begin () + begin);
}

bool
PlanarOctree::build (const std::vector<Eigen::Vector3f>& points, const PlanarOctreeParams& params)
{
  points_ = &points;
  threads_ = params.threads;
  nodes_.clear ();
  regions_.clear ();
  leaf_cells_.clear ();
  patches_.clear ();
  patch_of_point_.clear ();
  leaf_slot_.clear ();
  const int n = static_cast<int> (points.size ());
  order_.resize (n);
  sorted_.resize (n);
  leaf_of_point_.resize (n);
  if (n < 3)
  {
    std::iota (order_.begin (), order_.end (), 0);
    sorted_ = points;
    std::fill (leaf_of_point_.begin (), leaf_of_point_.end (), -1);
    return false;
  }

  // The copies and the bounds in parallel: a serial stretch keeps the other thread
  // spinning in OpenMP's wait (CPU time) and, on a shared machine, off the core.
  Eigen::Vector3f lo = points[0], hi = points[0];
#pragma omp parallel num_threads(threadCount (threads_))
  {
    Eigen::Vector3f l = lo, h = hi;
#pragma omp for schedule(static) nowait
    for (int i = 0; i < n; ++i)
    {
      order_[i] = i;
      sorted_[i] = points[i];
      leaf_of_point_[i] = -1;
      l = l.cwiseMin (points[i]);
      h = h.cwiseMax (points[i]);
    }
#pragma omp critical
    {
      lo = lo.cwiseMin (l);
      hi = hi.cwiseMax (h);
    }
  }
  origin_ = ((lo + hi) / 2).cast<double> ();
  OctreeNode root;
  root.center = (lo + hi) / 2;
  // Slightly larger than the bounding box so every point is strictly inside.
  root.half = 0.5f * (hi - lo).maxCoeff () * (1.f + 1e-4f) + 1e-30f;
  root.begin = 0;
  root.end = n;
  nodes_.push_back (root);

  // Level by level: every node of a level is analysed (and its range partitioned
  // into octants) in parallel; the ranges are disjoint, children are appended serially.
  std::vector<int> frontier{0};
  std::vector<std::array<int, 8>> counts;
  std::vector<char> split;
  while (!frontier.empty ())
  {
    const int m = static_cast<int> (frontier.size ());
    counts.assign (m, std::array<int, 8>{});
    split.assign (m, 0);
#pragma omp parallel num_threads(threadCount (threads_))
    {
      std::vector<int> buffer;
      std::vector<unsigned char> code;
#pragma omp for schedule(dynamic, 1)
      for (int f = 0; f < m; ++f)
      {
        OctreeNode& node = nodes_[frontier[f]];
        analyseNode (node, params);
        const bool coincident = node.size () == 0 || !(node.eigenvalues (0) > 0);
        if (node.planar || node.depth >= params.max_depth || node.size () <= params.min_points ||
            (coincident && node.size () >= 3))
          continue;
        split[f] = 1;
        partitionOctants (node.begin, node.end, node.center, counts[f], buffer, code);
      }
    }
    std::vector<int> next;
    for (int f = 0; f < m; ++f)
    {
      if (!split[f])
        continue;
      const int id = frontier[f];
      nodes_[id].first_child = static_cast<int> (nodes_.size ());
      int begin = nodes_[id].begin;
      for (int o = 0; o < 8; ++o)
      {
        OctreeNode child;
        const OctreeNode& parent = nodes_[id];
        const float q = parent.half / 2;
        child.half = q;
        child.center = parent.center + Eigen::Vector3f ((o & 1) ? q : -q, (o & 2) ? q : -q, (o & 4) ? q : -q);
        child.depth = parent.depth + 1;
        child.parent = id;
        child.begin = begin;
        child.end = begin + counts[f][o];
        begin = child.end;
        next.push_back (static_cast<int> (nodes_.size ()));
        nodes_.push_back (child);
      }
    }
    frontier.swap (next);
  }
  // Leaves own disjoint ranges: their (random) writes run in parallel.
  const int nn = static_cast<int> (nodes_.size ());
#pragma omp parallel for schedule(dynamic, 256) num_threads(threadCount (threads_))
  for (int id = 0; id < nn; ++id)
    if (nodes_[id].isLeaf ())
      for (int i = nodes_[id].begin; i < nodes_[id].end; ++i)
        leaf_of_point_[order_[i]] = id;
  return !nodes_[0].degenerate;
}

int
PlanarOctree::locate (const Eigen::Vector3f& p) const
{
  if (nodes_.empty () || !p.allFinite () ||
      (p - nodes_[0].center).cwiseAbs ().maxCoeff () > nodes_[0].half)
    return -1;
  int id = 0;
  while (!nodes_[id].isLeaf ())
    id = nodes_[id].first_child + octant (p, nodes_[id].center);
  return id;
}

int
PlanarOctree::nonDegenerateAncestor (int node) const
{
  while (node >= 0 && nodes_[node].degenerate)
    node = nodes_[node].parent;
  return node;
}

float
PlanarOctree::relativeCentreDistance (int node, const Eigen::Vector3f& p) const
{
  const OctreeNode& c = nodes_[node];
  return (p - c.center).cwiseAbs ().maxCoeff () / c.half;
}

int
PlanarOctree::numLeaves () const
{
  return static_cast<int> (std::count_if (nodes_.begin (), nodes_.end (), [] (const OctreeNode& n) { return n.isLeaf (); }));
}

int
PlanarOctree::numPlanarLeaves () const
{
  return static_cast<int> (
      std::count_if (nodes_.begin (), nodes_.end (), [] (const OctreeNode& n) { return n.isLeaf () && n.planar; }));
}

void
PlanarOctree::mergeCoplanarLeaves (double max_angle_deg, double thickness_factor)
{
  regions_.clear ();
  std::vector<int> leaves;
  for (int id = 0; id < static_cast<int> (nodes_.size ()); ++id)
    if (nodes_[id].isLeaf () && nodes_[id].planar)
      leaves.push_back (id);
  const int nl = static_cast<int> (leaves.size ());
  std::vector<int> slot (nodes_.size (), -1);
  for (int i = 0; i < nl; ++i)
    slot[leaves[i]] = i;

  // Region moments relative to origin_, one region per planar leaf to start with.
  std::vector<PlanarRegion> reg (nl);
  std::vector<Eigen::Vector3d> normal (nl);
  for (int i = 0; i < nl; ++i)
  {
    const OctreeNode& node = nodes_[leaves[i]];
    const double n = node.size ();
    reg[i].points = node.size ();
    reg[i].leaves = 1;
    reg[i].sum = n * node.centroid;
    reg[i].sum_sq = n * (node.covariance + node.centroid * node.centroid.transpose ());
    reg[i].base_thickness = std::sqrt (node.eigenvalues (2));
    normal[i] = node.normal.cast<double> ();
  }

  // Adjacent planar leaves: probe just outside each face at its centre and 4 quarter points.
  std::vector<std::pair<int, int>> edges;
#pragma omp parallel num_threads(threadCount (threads_))
  {
    std::vector<std::pair<int, int>> local_edges;
#pragma omp for schedule(dynamic, 64)
    for (int i = 0; i < nl; ++i)
    {
      const OctreeNode& node = nodes_[leaves[i]];
      const float h = node.half, eps = 1e-3f * node.half;
      for (int axis = 0; axis < 3; ++axis)
        for (int sign = -1; sign <= 1; sign += 2)
          for (int s = 0; s < 5; ++s)
          {
            Eigen::Vector3f q = node.center;
            q[axis] += sign * (h + eps);
            const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
            if (s > 0)
            {
              q[a1] += ((s & 1) ? 0.5f : -0.5f) * h;
              q[a2] += ((s & 2) ? 0.5f : -0.5f) * h;
            }
            const int other = locate (q);
            if (other >= 0 && slot[other] >= 0 && other != leaves[i])
              local_edges.emplace_back (std::min (i, slot[other]), std::max (i, slot[other]));
          }
    }
#pragma omp critical
    edges.insert (edges.end (), local_edges.begin (), local_edges.end ());
  }
  std::sort (edges.begin (), edges.end ());
  edges.erase (std::unique (edges.begin (), edges.end ()), edges.end ());
  // Most parallel pairs first, so regions grow from their flattest parts.
  std::vector<double> cost (edges.size ());
  for (std::size_t e = 0; e < edges.size (); ++e)
    cost[e] = 1.0 - std::abs (normal[edges[e].first].dot (normal[edges[e].second]));
  std::vector<std::size_t> by_cost (edges.size ());
  std::iota (by_cost.begin (), by_cost.end (), 0);
  std::sort (by_cost.begin (), by_cost.end (), [&] (std::size_t a, std::size_t b) { return cost[a] < cost[b]; });

  const double cos_max = std::cos (max_angle_deg * M_PI / 180.0);
  const double abs_eps = 1e-7 * nodes_[0].half;
  UnionFind uf (nl);
  for (std::size_t e : by_cost)
  {
    const int a = uf.find (edges[e].first), b = uf.find (edges[e].second);
    if (a == b || std::abs (normal[a].dot (normal[b])) < cos_max)
      continue;
    const double n = reg[a].points + reg[b].points;
    const Eigen::Vector3d mean = (reg[a].sum + reg[b].sum) / n;
    const Eigen::Matrix3d cov = (reg[a].sum_sq + reg[b].sum_sq) / n - mean * mean.transpose ();
    const PlanePca p = planePca (cov);
    const double base = std::max (reg[a].base_thickness, reg[b].base_thickness);
    if (std::sqrt (p.lambda (2)) > thickness_factor * base + abs_eps)
      continue;  // the union bends or steps: keep the leaves apart
    uf.parent[b] = a;
    reg[a].points += reg[b].points;
    reg[a].leaves += reg[b].leaves;
    reg[a].sum += reg[b].sum;
    reg[a].sum_sq += reg[b].sum_sq;
    reg[a].base_thickness = base;
    normal[a] = p.normal;
  }
  std::vector<int> region_of_root (nl, -1);
  for (int i = 0; i < nl; ++i)
  {
    const int r = uf.find (i);
    if (region_of_root[r] < 0)
    {
      region_of_root[r] = static_cast<int> (regions_.size ());
      regions_.push_back (reg[r]);
    }
    nodes_[leaves[i]].region = region_of_root[r];
  }
}

void
PlanarOctree::fitRegions (bool quadric)
{
  const int nr = static_cast<int> (regions_.size ());
  std::vector<std::vector<int>> leaves (nr);
  for (int id = 0; id < static_cast<int> (nodes_.size ()); ++id)
    if (nodes_[id].isLeaf () && nodes_[id].region >= 0)
      leaves[nodes_[id].region].push_back (id);
#pragma omp parallel num_threads(threadCount (threads_))
  {
    std::vector<Eigen::Vector3f> support;
#pragma omp for schedule(dynamic, 4)
    for (int r = 0; r < nr; ++r)
    {
      PlanarRegion& R = regions_[r];
      support.clear ();
      for (int leaf : leaves[r])
        for (int i = nodes_[leaf].begin; i < nodes_[leaf].end; ++i)
          support.push_back (sorted_[i]);
      // The same height-field fit as a patch, centred on the region (its moments are known).
      const Eigen::Vector3d mean = R.sum / R.points;
      const double spread = std::sqrt (std::max ((R.sum_sq / R.points - mean * mean.transpose ()).trace (), 1e-60));
      if (!fitSurface (support, (mean + origin_).cast<float> (), spread, nodes_[leaves[r][0]].normal, quadric,
                            R.surface, false))
        continue;  // cannot happen: a region's leaves span a plane
    }
  }
}

void
PlanarOctree::leavesInBox (const Eigen::Vector3f& lo, const Eigen::Vector3f& hi, std::vector<int>& out) const
{
  out.clear ();
  forLeavesInBox (nodes_, lo, hi, [&] (int id) { out.push_back (id); });
}

void
PlanarOctree::patchPointsInBox (int leaf, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi,
                                std::vector<Eigen::Vector3f>& out) const
{
  const auto& cells = leaf_cells_[leaf_slot_[leaf]];
  forLeavesInBox (cells, lo, hi, [&] (int c) {
    for (int i = cells[c].begin; i < cells[c].end; ++i)
    {
      const Eigen::Vector3f& q = sorted_[i];
      if ((q.array () >= lo.array ()).all () && (q.array () <= hi.array ()).all ())
        out.push_back (q);
    }
  });
}

// Per-thread scratch of fitPatches ().
struct PlanarOctree::PatchScratch
{
  std::vector<int> near, candidates, bucket_start, bucket_points, bucket_of;
  std::vector<Eigen::Vector3f> support, local;
};

// A planar leaf's setting for its patches' fits: the first ball radius, the leaf's plane
// (e1, e2) and the D × D bucket grid of edge g over it that holds the first scale's
// candidate points (PatchScratch::local, bucket_start, bucket_points).
struct PlanarOctree::PatchLeafFrame
{
  float half0 = 0;
  Eigen::Vector3f e1, e2;
  int D = 1;
  float span = 0, g = 1;
  int
  bucket (float t) const
  {
    return std::min (D - 1, std::max (0, static_cast<int> ((t + 0.5f * span) / g)));
  }
};

void
PlanarOctree::cutPatchCells (const std::vector<int>& leaves, int max_points, int threads)
{
  // Cut every planar leaf into a tree of cells of <= max_points (octants again; the
  // leaves' ranges are disjoint). Each leaf keeps its own tree; child ids are local to it.
  const int nl = static_cast<int> (leaves.size ());
  leaf_cells_.assign (nl, {});
  for (int l = 0; l < nl; ++l)
    leaf_slot_[leaves[l]] = l;
#pragma omp parallel num_threads(threads)
  {
    std::vector<int> buffer;
    std::vector<unsigned char> code;
#pragma omp for schedule(dynamic, 8)
    for (int l = 0; l < nl; ++l)
    {
      const OctreeNode& L = nodes_[leaves[l]];
      auto& tree = leaf_cells_[l];
      tree.reserve (1 + 16 * static_cast<std::size_t> (L.size ()) / max_points);
      tree.assign (1, PatchCell{L.center, L.half, L.begin, L.end, leaves[l], -1, -1});
      for (std::size_t t = 0; t < tree.size (); ++t)  // breadth first: the vector grows
      {
        const PatchCell c = tree[t];
        if (c.end - c.begin <= max_points || c.half < 1e-6f * nodes_[0].half)
          continue;
        std::array<int, 8> cnt;
        partitionOctants (c.begin, c.end, c.center, cnt, buffer, code);
        tree[t].first_child = static_cast<int> (tree.size ());
        int begin = c.begin;
        const float q = c.half / 2;
        for (int o = 0; o < 8; ++o)
        {
          const Eigen::Vector3f centre = c.center + Eigen::Vector3f ((o & 1) ? q : -q, (o & 2) ? q : -q, (o & 4) ? q : -q);
          tree.push_back (PatchCell{centre, q, begin, begin + cnt[o], c.leaf, -1, -1});
          begin += cnt[o];
        }
      }
    }
  }
}

void
PlanarOctree::numberPatches (int threads)
{
  // Patch ids in leaf order, each leaf's from a prefix sum, so the (random) writes of
  // every point's patch run in parallel.
  const int nl = static_cast<int> (leaf_cells_.size ());
  auto fitted = [] (const PatchCell& C) { return C.first_child < 0 && C.end > C.begin; };
  std::vector<int> first_fit (nl + 1, 0);
  for (int l = 0; l < nl; ++l)
    first_fit[l + 1] = first_fit[l] + static_cast<int> (std::count_if (leaf_cells_[l].begin (), leaf_cells_[l].end (), fitted));
  patches_.resize (first_fit[nl]);
#pragma omp parallel for schedule(dynamic, 64) num_threads(threads)
  for (int l = 0; l < nl; ++l)
  {
    int fit = first_fit[l];
    for (PatchCell& C : leaf_cells_[l])
    {
      if (!fitted (C))
        continue;
      C.fit = fit++;
      patches_[C.fit].leaf = C.leaf;
      for (int i = C.begin; i < C.end; ++i)
        patch_of_point_[order_[i]] = C.fit;
    }
  }
}

PlanarOctree::PatchLeafFrame
PlanarOctree::gatherLeafCandidates (int leaf, int scales, int support_points, PatchScratch& s) const
{
  const OctreeNode& L = nodes_[leaf];
  PatchLeafFrame f;
  // Area per point from the leaf's spread (a uniform rectangle has variance w² / 12).
  const double area = 12.0 * std::sqrt (L.eigenvalues (0) * L.eigenvalues (1));
  // Radius of the disc that holds support_points points (a kNN-like ball; the box
  // queries below only bound it).
  f.half0 = std::max (static_cast<float> (std::sqrt (support_points * area / (M_PI * L.size ()))),
                      1e-6f * nodes_[0].half);
  const float reach = f.half0 * static_cast<float> (1 << (scales - 1));
  const Eigen::Vector3f margin = Eigen::Vector3f::Constant (reach + L.half);
  leavesInBox (L.center - margin, L.center + margin, s.near);
  s.candidates.clear ();
  for (int other : s.near)
    if (leaf_slot_[other] >= 0 && (other == leaf || (L.region >= 0 && nodes_[other].region == L.region)))
      s.candidates.push_back (other);
  // The leaf's plane (it passed Algorithm 1) carries the bucket grid.
  const Eigen::Matrix3d frame = frameOfNormal (L.normal);
  f.e1 = frame.col (0).cast<float> ();
  f.e2 = frame.col (1).cast<float> ();

  // Scale-0 candidates on a D × D grid of bucket edge ≈ half0 over the plane.
  const Eigen::Vector3f box0 = Eigen::Vector3f::Constant (L.half + f.half0);
  s.local.clear ();
  for (int other : s.candidates)
    patchPointsInBox (other, L.center - box0, L.center + box0, s.local);
  f.span = 2.f * (L.half + f.half0) * std::sqrt (2.f);  // in-plane extent of the box, any tilt
  f.D = std::max (1, std::min (256, static_cast<int> (std::ceil (f.span / f.half0))));
  f.g = f.span / f.D;
  const int D = f.D;
  s.bucket_start.assign (D * D + 1, 0);
  s.bucket_of.resize (s.local.size ());
  for (std::size_t i = 0; i < s.local.size (); ++i)
  {
    const Eigen::Vector3f d = s.local[i] - L.center;
    s.bucket_of[i] = f.bucket (d.dot (f.e1)) * D + f.bucket (d.dot (f.e2));
    ++s.bucket_start[s.bucket_of[i] + 1];
  }
  std::partial_sum (s.bucket_start.begin (), s.bucket_start.end (), s.bucket_start.begin ());
  s.bucket_points.resize (s.local.size ());
  s.near.assign (s.bucket_start.begin (), s.bucket_start.end () - 1);  // fill positions
  for (std::size_t i = 0; i < s.local.size (); ++i)
    s.bucket_points[s.near[s.bucket_of[i]]++] = static_cast<int> (i);
  return f;
}

void
PlanarOctree::fitPatch (const PatchCell& C, const OctreeNode& L, const PatchLeafFrame& f, bool quadric,
                        double max_slope_sigma, int scales, PatchScratch& s)
{
  SurfaceFit& P = patches_[C.fit];
  Eigen::Vector3f centre = Eigen::Vector3f::Zero ();
  for (int i = C.begin; i < C.end; ++i)
    centre += sorted_[i];
  centre /= static_cast<float> (C.end - C.begin);
  Eigen::Vector3f previous = Eigen::Vector3f::Zero ();
  float previous_sigma = 0;
  for (int sc = 0; sc < scales && !P.valid; ++sc)
  {
    const float half = f.half0 * static_cast<float> (1 << sc);
    const Eigen::Vector3f lo = centre - Eigen::Vector3f::Constant (half),
                          hi = centre + Eigen::Vector3f::Constant (half);
    s.support.clear ();
    if (sc == 0)
    {
      const Eigen::Vector3f d = centre - L.center;
      const float u = d.dot (f.e1), v = d.dot (f.e2);
      // A point within `half` of the centre is within `half` of it along e1 and e2
      // (unit vectors), so these buckets hold the whole ball, in the same order.
      const int u0 = f.bucket (u - half), u1 = f.bucket (u + half);
      const int v0 = f.bucket (v - half), v1 = f.bucket (v + half);
      for (int bu = u0; bu <= u1; ++bu)
        for (int b = bu * f.D + v0; b <= bu * f.D + v1; ++b)
          for (int k = s.bucket_start[b]; k < s.bucket_start[b + 1]; ++k)
          {
            const Eigen::Vector3f& q = s.local[s.bucket_points[k]];
            if ((q - centre).squaredNorm () <= half * half)
              s.support.push_back (q);
          }
    }
    else
      for (int other : s.candidates)
      {
        const OctreeNode& O = nodes_[other];
        if (((O.center.array () - O.half) > hi.array ()).any () || ((O.center.array () + O.half) < lo.array ()).any ())
          continue;
        patchPointsInBox (other, lo, hi, s.support);
      }
    if (sc > 0)  // the ball inside the box
      s.support.erase (std::remove_if (s.support.begin (), s.support.end (),
                                       [&] (const Eigen::Vector3f& q) { return (q - centre).squaredNorm () > half * half; }),
                       s.support.end ());
    SurfaceFit trial = P;
    if (!fitSurface (s.support, centre, half, L.normal, quadric, trial))
      continue;
    // Lepski's rule: a larger support is only taken while its normal agrees with the
    // smaller one's within their uncertainties; otherwise the larger box sees other
    // shape (an edge, a fold), not less noise, and the patch stays unfitted.
    const Eigen::Vector3f normal = normalAtFit (trial, centre);
    if (sc > 0 && previous.squaredNorm () > 0 &&
        std::acos (std::min (1.f, std::abs (normal.dot (previous)))) > 2.f * (previous_sigma + trial.slope_sigma))
      break;
    P = trial;
    P.valid = P.slope_sigma <= max_slope_sigma;
    previous = normal;
    previous_sigma = P.slope_sigma;
  }
}

void
PlanarOctree::fitPatches (int max_points, bool quadric, double max_slope_sigma, int scales, int support_points)
{
  patches_.clear ();
  const int n = static_cast<int> (order_.size ());
  patch_of_point_.assign (n, -1);
  leaf_slot_.assign (nodes_.size (), -1);
  std::vector<int> leaves;
  for (int id = 0; id < static_cast<int> (nodes_.size ()); ++id)
    if (nodes_[id].isLeaf () && nodes_[id].planar)
      leaves.push_back (id);
  const int nl = static_cast<int> (leaves.size ());
  const int threads = threadCount (threads_);
  max_points = std::max (max_points, 1);
  cutPatchCells (leaves, max_points, threads);
  numberPatches (threads);

  // Fit each patch over a ball around its points' centroid that holds about support_points
  // points at the leaf's density (doubling while the slope is uncertain), taking the
  // points of the same leaf or of leaves merged into the same region. The ball is sized by
  // density, not by the cell: a cell that only grazes the surface can be large. Work goes
  // leaf by leaf: the candidate points of the first size are gathered once per leaf and
  // bucketed on a grid over the leaf's plane (a leaf is flat), so each patch reads only
  // the buckets under its ball; larger balls walk the cell trees (bounded by a box).
  scales = std::max (scales, 1);
  support_points = std::max (support_points, 3);
#pragma omp parallel num_threads(threads)
  {
    PatchScratch scratch;
#pragma omp for schedule(dynamic, 4)
    for (int l = 0; l < nl; ++l)
    {
      const PatchLeafFrame frame = gatherLeafCandidates (leaves[l], scales, support_points, scratch);
      for (const PatchCell& C : leaf_cells_[l])
        if (C.fit >= 0)
          fitPatch (C, nodes_[leaves[l]], frame, quadric, max_slope_sigma, scales, scratch);
    }
  }
}

int
PlanarOctree::locatePatch (const Eigen::Vector3f& p) const
{
  const int leaf = locate (p);
  if (leaf < 0 || leaf_slot_.empty () || leaf_slot_[leaf] < 0)
    return -1;
  const auto& cells = leaf_cells_[leaf_slot_[leaf]];
  int c = 0, parent = -1;
  while (cells[c].first_child >= 0)
  {
    parent = c;
    c = cells[c].first_child + octant (p, cells[c].center);
  }
  auto validFit = [&] (int cell) {
    const int f = cells[cell].fit;
    return f >= 0 && patches_[f].valid ? f : -1;
  };
  if (validFit (c) >= 0 || parent < 0)
    return validFit (c);
  // p fell into an empty (or unfitted) cell: the nearest fitted sibling.
  int best = -1;
  float best_d = std::numeric_limits<float>::max ();
  for (int s = cells[parent].first_child; s < cells[parent].first_child + 8; ++s)
    if (validFit (s) >= 0)
    {
      const float d = (p - cells[s].center).squaredNorm ();
      if (d < best_d)
      {
        best_d = d;
        best = validFit (s);
      }
    }
  return best;
}

Eigen::Vector3f
PlanarOctree::patchNormalAt (int fit, const Eigen::Vector3f& p) const
{
  return normalAtFit (patches_[fit], p);
}

Eigen::Vector3f
PlanarOctree::regionNormalAt (int r, const Eigen::Vector3f& p) const
{
  return normalAtFit (regions_[r].surface, p);
}

double
PlanarOctree::regionResidual (int r, const Eigen::Vector3f& p) const
{
  return residualOfFit (regions_[r].surface, p);
}

}  // namespace detail
}  // namespace normals
}  // namespace pclx
