#include <pclx/normals/planar_octree.h>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <omp.h>

namespace pclx {
namespace normals {

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

// Eigen decomposition sorted as the seed writes it: λ1 ≥ λ2 ≥ λ3, normal = v3.
struct Pca
{
  Eigen::Vector3d lambda;  // λ1, λ2, λ3
  Eigen::Matrix3d v;       // columns v1, v2, v3
};

Pca
pca (const Eigen::Matrix3d& cov)
{
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es (cov);
  Pca r;
  const Eigen::Vector3d ev = es.eigenvalues ().cwiseMax (0.0);  // ascending
  r.lambda = Eigen::Vector3d (ev (2), ev (1), ev (0));
  r.v.col (0) = es.eigenvectors ().col (2);
  r.v.col (1) = es.eigenvectors ().col (1);
  r.v.col (2) = es.eigenvectors ().col (0);
  return r;
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

}  // namespace

void
PlanarOctree::analyseNode (OctreeNode& node, const PlanarOctreeParams& params) const
{
  const auto& pts = *points_;
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
    const Eigen::Vector3d d = pts[order_[i]].cast<double> () - c;
    s1 += d;
    s2.noalias () += d * d.transpose ();
  }
  const Eigen::Vector3d mean = s1 / n;
  node.centroid = c + mean - origin_;
  node.covariance = s2 / n - mean * mean.transpose ();
  if (n < 3)
    return;
  const Pca p = pca (node.covariance);
  node.eigenvalues = p.lambda;
  node.normal = p.v.col (2).cast<float> ();
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
    const Eigen::Vector3d nrm = p.v.col (2);
    const double limit = params.max_residual_ratio * std::sqrt (p.lambda (2)) + 1e-4 * node.half;
    for (int i = node.begin; i < node.end && node.planar; ++i)
      node.planar = std::abs ((pts[order_[i]].cast<double> () - c - mean).dot (nrm)) <= limit;
  }
}

bool
PlanarOctree::build (const std::vector<Eigen::Vector3f>& points, const PlanarOctreeParams& params)
{
  points_ = &points;
  threads_ = params.threads;
  nodes_.clear ();
  regions_.clear ();
  const int n = static_cast<int> (points.size ());
  order_.resize (n);
  std::iota (order_.begin (), order_.end (), 0);
  leaf_of_point_.assign (n, -1);
  if (n < 3)
    return false;

  Eigen::Vector3f lo = points[0], hi = points[0];
  for (const auto& p : points)
  {
    lo = lo.cwiseMin (p);
    hi = hi.cwiseMax (p);
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
        const int len = node.size ();
        code.resize (len);
        buffer.resize (len);
        auto& cnt = counts[f];
        for (int i = 0; i < len; ++i)
          ++cnt[code[i] = static_cast<unsigned char> (octant (points[order_[node.begin + i]], node.center))];
        std::array<int, 8> offset{};
        for (int o = 1; o < 8; ++o)
          offset[o] = offset[o - 1] + cnt[o - 1];
        for (int i = 0; i < len; ++i)
          buffer[offset[code[i]]++] = order_[node.begin + i];
        std::copy (buffer.begin (), buffer.begin () + len, order_.begin () + node.begin);
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
  for (int id = 0; id < static_cast<int> (nodes_.size ()); ++id)
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
    const Pca p = pca (cov);
    const double base = std::max (reg[a].base_thickness, reg[b].base_thickness);
    if (std::sqrt (p.lambda (2)) > thickness_factor * base + abs_eps)
      continue;  // the union bends or steps: keep the leaves apart
    uf.parent[b] = a;
    reg[a].points += reg[b].points;
    reg[a].leaves += reg[b].leaves;
    reg[a].sum += reg[b].sum;
    reg[a].sum_sq += reg[b].sum_sq;
    reg[a].base_thickness = base;
    normal[a] = p.v.col (2);
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
  const auto& pts = *points_;
#pragma omp parallel for schedule(dynamic, 4) num_threads(threadCount (threads_))
  for (int r = 0; r < nr; ++r)
  {
    PlanarRegion& R = regions_[r];
    R.o = R.sum / R.points;
    const Pca p = pca (R.sum_sq / R.points - R.o * R.o.transpose ());
    R.frame = p.v;
    if (R.frame.determinant () < 0)
      R.frame.col (1) = -R.frame.col (1);
    R.scale = std::max (std::sqrt (p.lambda (0)), 1e-30);
    const double trace = p.lambda.sum ();
    R.curvature = trace > 0 ? static_cast<float> (p.lambda (2) / trace) : 0.f;
    R.c.fill (0.0);
    R.rms = std::sqrt (p.lambda (2));
    if (!quadric || R.points < 12)
      continue;
    // Least-squares height field over the region's plane (seed ch. 7: polynomial fit).
    Eigen::Matrix<double, 6, 6> ata = Eigen::Matrix<double, 6, 6>::Zero ();
    Eigen::Matrix<double, 6, 1> ath = Eigen::Matrix<double, 6, 1>::Zero ();
    double hh = 0;
    for (int leaf : leaves[r])
      for (int i = nodes_[leaf].begin; i < nodes_[leaf].end; ++i)
      {
        const Eigen::Vector3d d = pts[order_[i]].cast<double> () - origin_ - R.o;
        const double x = d.dot (R.frame.col (0)) / R.scale, y = d.dot (R.frame.col (1)) / R.scale,
                     h = d.dot (R.frame.col (2));
        Eigen::Matrix<double, 6, 1> a;
        a << x * x, x * y, y * y, x, y, 1.0;
        ata.noalias () += a * a.transpose ();
        ath += a * h;
        hh += h * h;
      }
    // A small ridge on the curvature terms keeps strip-like regions from over-bending.
    Eigen::Matrix<double, 6, 6> reg = ata;
    for (int k = 0; k < 3; ++k)
      reg (k, k) += 1e-3 * R.points;
    const Eigen::Matrix<double, 6, 1> c = reg.ldlt ().solve (ath);
    if (!c.allFinite ())
      continue;
    for (int k = 0; k < 6; ++k)
      R.c[k] = c (k);
    const double ss = hh - 2 * c.dot (ath) + c.dot (ata * c);
    R.rms = std::sqrt (std::max (0.0, ss / R.points));
  }
}

Eigen::Vector2d
PlanarOctree::local (int r, const Eigen::Vector3f& p, double* h) const
{
  const PlanarRegion& R = regions_[r];
  const Eigen::Vector3d d = p.cast<double> () - origin_ - R.o;
  *h = d.dot (R.frame.col (2));
  return Eigen::Vector2d (d.dot (R.frame.col (0)) / R.scale, d.dot (R.frame.col (1)) / R.scale);
}

Eigen::Vector3f
PlanarOctree::regionNormalAt (int r, const Eigen::Vector3f& p) const
{
  const PlanarRegion& R = regions_[r];
  double h;
  const Eigen::Vector2d xy = local (r, p, &h);
  const auto& c = R.c;
  const double dx = (2 * c[0] * xy.x () + c[1] * xy.y () + c[3]) / R.scale;
  const double dy = (c[1] * xy.x () + 2 * c[2] * xy.y () + c[4]) / R.scale;
  return (R.frame.col (2) - dx * R.frame.col (0) - dy * R.frame.col (1)).normalized ().cast<float> ();
}

double
PlanarOctree::regionResidual (int r, const Eigen::Vector3f& p) const
{
  const auto& c = regions_[r].c;
  double h;
  const Eigen::Vector2d v = local (r, p, &h);
  const double x = v.x (), y = v.y ();
  return std::abs (h - (c[0] * x * x + c[1] * x * y + c[2] * y * y + c[3] * x + c[4] * y + c[5]));
}

}  // namespace normals
}  // namespace pclx
