#include <pclx/surface/dual_contouring_octree.h>

#include <pcl/common/io.h>
#include <pcl/console/print.h>
#include <pcl/conversions.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <unordered_set>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace pcl {

namespace {

using Clock = std::chrono::steady_clock;
double
msSince (Clock::time_point t0)
{
  return std::chrono::duration<double, std::milli> (Clock::now () - t0).count ();
}

constexpr int kRootSide = 1 << DualContouringOctree::kRootLevels;  // 16 leaves per axis
constexpr int kRootCells = kRootSide * kRootSide * kRootSide;
constexpr int kLatticeLimit = (1 << 19) - 2 * kRootSide;  // |lattice coordinate| bound (key packing)
constexpr std::uint16_t kNone = 0xFFFF;
// QEF sums in fixed point: exact, so frame order does not change a bit.
constexpr double kFix = 4294967296.0;  // 2^32

// Round to nearest for the fixed-point sums (a truncating cast, no libm call; deterministic).
inline std::int64_t
fix (double x)
{
  x *= kFix;
  return static_cast<std::int64_t> (x + (x >= 0 ? 0.5 : -0.5));
}

// The signed-distance sums saturate (a vertex seen in very many frames keeps its sign).
inline void
addSaturated (std::int32_t& acc, std::int32_t d)
{
  const std::int64_t v = static_cast<std::int64_t> (acc) + d;
  acc = static_cast<std::int32_t> (std::max<std::int64_t> (std::min<std::int64_t> (v, INT32_MAX), INT32_MIN));
}

inline int
floorDiv (int a)
{
  return a >> DualContouringOctree::kRootLevels;  // arithmetic shift = floor for negatives
}
inline int
localIndex (int x, int y, int z)
{
  return ((z & (kRootSide - 1)) * kRootSide + (y & (kRootSide - 1))) * kRootSide + (x & (kRootSide - 1));
}
inline std::uint64_t
rootKey (int bx, int by, int bz)
{
  const std::uint64_t off = 1u << 15;
  return ((static_cast<std::uint64_t> (bx + off) & 0xFFFF) << 32) |
         ((static_cast<std::uint64_t> (by + off) & 0xFFFF) << 16) |
         (static_cast<std::uint64_t> (bz + off) & 0xFFFF);
}
inline std::uint64_t
edgeKey (int axis, int x, int y, int z)
{
  // Root-major so the edges of one root are contiguous after sorting.
  const std::uint64_t rk = rootKey (floorDiv (x), floorDiv (y), floorDiv (z));
  return (rk << 14) | (static_cast<std::uint64_t> (localIndex (x, y, z)) << 2) | static_cast<std::uint64_t> (axis);
}

// Leaf: QEF of the planes of its intersected edges in leaf-local lattice units, fixed point.
struct Leaf
{
  std::int64_t ata[6] = {0, 0, 0, 0, 0, 0};  // xx xy xz yy yz zz
  std::int64_t atb[3] = {0, 0, 0};
  std::int64_t btb = 0;
  std::int64_t mass[3] = {0, 0, 0};
  std::int32_t count = 0;
  std::uint16_t crossed = 0;  // 12 bits: edges with at least one intersection
  std::uint16_t cell = 0;     // local index in the root
};

// QEF in double, in a node-local frame (lattice units, origin at the node's min corner).
struct Qef
{
  Eigen::Matrix3d ata = Eigen::Matrix3d::Zero ();
  Eigen::Vector3d atb = Eigen::Vector3d::Zero ();
  double btb = 0;
  Eigen::Vector3d mass = Eigen::Vector3d::Zero ();
  double count = 0;

  static Qef
  fromLeaf (const Leaf& l)
  {
    Qef q;
    q.ata << l.ata[0], l.ata[1], l.ata[2], l.ata[1], l.ata[3], l.ata[4], l.ata[2], l.ata[4], l.ata[5];
    q.ata /= kFix;
    q.atb = Eigen::Vector3d (l.atb[0], l.atb[1], l.atb[2]) / kFix;
    q.btb = l.btb / kFix;
    q.mass = Eigen::Vector3d (l.mass[0], l.mass[1], l.mass[2]) / kFix;
    q.count = l.count;
    return q;
  }
  // Add a QEF whose frame origin is at `o` in this QEF's frame: n·(p − o) = d ⇒ n·p = d + n·o.
  void
  addShifted (const Qef& c, const Eigen::Vector3d& o)
  {
    ata += c.ata;
    atb += c.atb + c.ata * o;
    btb += c.btb + 2 * o.dot (c.atb) + o.dot (c.ata * o);
    mass += c.mass + c.count * o;
    count += c.count;
  }
  double
  error (const Eigen::Vector3d& x) const
  {
    return std::max (0.0, x.dot (ata * x) - 2 * x.dot (atb) + btb);
  }
  // Minimiser in the box [0, side]³: truncated eigen-decomposition of AᵀA (singular values below
  // 0.1 σ_max dropped, Ju et al. 2002), solved relative to the mass point so the dropped
  // directions stay at the mass point. Returns true when it had to be clamped.
  bool
  solve (double side, Eigen::Vector3d& x) const
  {
    if (count <= 0)
    {
      x = Eigen::Vector3d::Constant (0.5 * side);
      return false;
    }
    const Eigen::Vector3d m = mass / count;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
    es.computeDirect (ata);
    const Eigen::Vector3d lambda = es.eigenvalues ();
    const double lmax = lambda.cwiseAbs ().maxCoeff ();
    const Eigen::Vector3d r = atb - ata * m;
    x = m;
    if (lmax > 0)
      for (int i = 0; i < 3; ++i)
        if (lambda[i] > 0.01 * lmax)  // σ_i / σ_max > 0.1
        {
          const Eigen::Vector3d v = es.eigenvectors ().col (i);
          x += v * (v.dot (r) / lambda[i]);
        }
    const double tol = 1e-9 * side;
    const bool escaped = (x.array () < -tol).any () || (x.array () > side + tol).any ();
    x = x.cwiseMax (0.0).cwiseMin (side);
    return escaped;
  }
};

struct Crossing
{
  std::uint64_t key;
  float frac;  // position along the edge, [0, 1)
  std::uint32_t tri;
};

struct Vertex
{
  Eigen::Vector3f p;
  std::uint32_t node;  // level << 12 | local node index (diagnostics)
};

}  // namespace

struct DualContouringOctree::Impl
{
  struct Root
  {
    Eigen::Vector3i origin;  // lattice coordinates of the min corner
    std::uint64_t key = 0;
    std::uint32_t id = 0;
    std::array<std::uint16_t, kRootCells> leaf_index;
    std::array<std::uint8_t, kRootCells> out_votes, in_votes;  // saturating
    std::array<std::int32_t, kRootCells> sdf;  // Σ ± distance to the nearest crossing (2^-12 leaf)
    std::vector<Leaf> leaves;
    // Polygonisation cache.
    std::array<std::uint16_t, kRootCells> cell_vertex;  // vertex of every fine cell (collapsed too)
    std::vector<Vertex> vertices;
    std::vector<std::array<std::uint64_t, 3>> tris;  // vertex refs (see polygonise)
    // Polygons with a collapsed cell: the same one can come from several lattice edges along
    // a coarse edge; they are merged over the whole map at output (net orientation).
    struct Shared
    {
      std::array<std::uint64_t, 4> v;
      int n;
    };
    std::vector<Shared> shared;
    std::size_t escaped = 0, collapsed = 0;
    std::size_t stamp = 0;  // last frame that touched it
    bool dirty = true;

    Root ()
    {
      leaf_index.fill (kNone);
      out_votes.fill (0);
      in_votes.fill (0);
      sdf.fill (0);
      cell_vertex.fill (kNone);
    }
  };

  std::unordered_map<std::uint64_t, std::uint32_t> root_of;
  std::vector<std::unique_ptr<Root>> roots;
  std::size_t leaves = 0, voted = 0;

  Root*
  find (int bx, int by, int bz) const
  {
    auto it = root_of.find (rootKey (bx, by, bz));
    return it == root_of.end () ? nullptr : roots[it->second].get ();
  }
  Root*
  findCell (int x, int y, int z) const
  {
    return find (floorDiv (x), floorDiv (y), floorDiv (z));
  }
  Root*
  get (int bx, int by, int bz)
  {
    const std::uint64_t k = rootKey (bx, by, bz);
    auto it = root_of.find (k);
    if (it != root_of.end ())
      return roots[it->second].get ();
    auto r = std::make_unique<Root> ();
    r->origin = Eigen::Vector3i (bx, by, bz) * kRootSide;
    r->key = k;
    r->id = static_cast<std::uint32_t> (roots.size ());
    root_of.emplace (k, r->id);
    roots.push_back (std::move (r));
    return roots.back ().get ();
  }
  const Leaf*
  leafAt (int x, int y, int z) const
  {
    const Root* r = findCell (x, y, z);
    if (!r)
      return nullptr;
    const std::uint16_t i = r->leaf_index[localIndex (x, y, z)];
    return i == kNone ? nullptr : &r->leaves[i];
  }
};

DualContouringOctree::DualContouringOctree () : impl_ (new Impl) {}
DualContouringOctree::~DualContouringOctree () = default;

bool
DualContouringOctree::fail (const std::string& msg)
{
  error_ = msg;
  PCL_ERROR ("[pcl::DualContouringOctree] %s\n", msg.c_str ());
  return false;
}

bool
DualContouringOctree::setLeafSize (double h)
{
  if (!(h > 0) || !std::isfinite (h))
    return fail ("leaf size must be positive and finite");
  if (!impl_->roots.empty ())
    return fail ("the leaf size cannot change once frames are fused (clear () first)");
  h_ = h;
  return true;
}

bool
DualContouringOctree::setSimplificationError (double eps)
{
  if (!(eps >= 0) || !std::isfinite (eps))
    return fail ("simplification error must be finite and >= 0");
  eps_ = eps;
  all_dirty_ = true;
  return true;
}

bool
DualContouringOctree::setVolume (const Eigen::Vector3d& min, const Eigen::Vector3d& max)
{
  if (!min.allFinite () || !max.allFinite () || !((max - min).array () > 0).all ())
    return fail ("volume must be finite with max > min on every axis");
  vol_min_ = min;
  vol_max_ = max;
  volume_set_ = true;
  return true;
}

bool
DualContouringOctree::getVolume (Eigen::Vector3d& min, Eigen::Vector3d& max) const
{
  min = vol_min_;
  max = vol_max_;
  return volume_set_;
}

void
DualContouringOctree::clear ()
{
  impl_.reset (new Impl);
  stats_ = Stats ();
  all_dirty_ = true;
}

Eigen::Vector3i
DualContouringOctree::toLattice (const Eigen::Vector3d& p) const
{
  return (p / h_).array ().floor ().cast<int> ();
}

std::pair<int, int>
DualContouringOctree::gridVertexVotes (const Eigen::Vector3i& v) const
{
  const auto* r = impl_->findCell (v.x (), v.y (), v.z ());
  if (!r)
    return {0, 0};
  const int i = localIndex (v.x (), v.y (), v.z ());
  return {r->out_votes[i], r->in_votes[i]};
}

namespace {

// Root lookups around one root without hashing (the 27 roots next to it), else the hash map.
struct RootCache
{
  using Root = DualContouringOctree::Impl::Root;
  const DualContouringOctree::Impl& map;
  // Until centreOn: far outside the root range (±2^15), so every lookup goes to the hash map.
  Eigen::Vector3i centre = Eigen::Vector3i::Constant (1 << 24);
  std::array<const Root*, 27> nb{};

  explicit RootCache (const DualContouringOctree::Impl& m) : map (m) {}
  void
  centreOn (const Eigen::Vector3i& block)
  {
    centre = block;
    for (int k = 0; k < 27; ++k)
      nb[k] = map.find (block.x () + k % 3 - 1, block.y () + (k / 3) % 3 - 1, block.z () + k / 9 - 1);
  }
  const Root*
  findCell (int x, int y, int z) const
  {
    const int dx = floorDiv (x) - centre.x () + 1, dy = floorDiv (y) - centre.y () + 1, dz = floorDiv (z) - centre.z () + 1;
    if (static_cast<unsigned> (dx) < 3u && static_cast<unsigned> (dy) < 3u && static_cast<unsigned> (dz) < 3u)
      return nb[dx + 3 * dy + 9 * dz];
    return map.findCell (x, y, z);
  }
  const Leaf*
  leafAt (int x, int y, int z) const
  {
    const Root* r = findCell (x, y, z);
    if (!r)
      return nullptr;
    const std::uint16_t i = r->leaf_index[localIndex (x, y, z)];
    return i == kNone ? nullptr : &r->leaves[i];
  }
};

// Resolved sign of grid vertices (§3.6), read-only on the map.
struct SignResolver
{
  using Root = DualContouringOctree::Impl::Root;
  const RootCache& map;
  DualContouringOctree::SignRule rule;

  // +1 exterior, −1 interior, 2 ambiguous, 0 no vote.
  int
  voted (int x, int y, int z) const
  {
    const Root* r = map.findCell (x, y, z);
    if (!r)
      return 0;
    const int i = localIndex (x, y, z);
    const int o = r->out_votes[i], n = r->in_votes[i];
    if (rule == DualContouringOctree::SignRule::WEIGHTED)
    {
      const std::int32_t d = r->sdf[i];
      return d > 0 ? 1 : (d < 0 ? -1 : ((o || n) ? 2 : 0));
    }
    if (o == 0 && n == 0)
      return 0;
    if (rule == DualContouringOctree::SignRule::SEED)
      return (o && n) ? 2 : (o ? 1 : -1);
    if (rule == DualContouringOctree::SignRule::MAJORITY)
      return o > n ? 1 : (n > o ? -1 : 2);
    const std::int32_t d = r->sdf[i];
    return d > 0 ? 1 : (d < 0 ? -1 : 2);
  }
  // Is the lattice edge (v, v + e_axis) an edge of a leaf without intersections?
  bool
  openEdge (const Eigen::Vector3i& v, int axis) const
  {
    const int u = (axis + 1) % 3, w = (axis + 2) % 3;
    for (int k = 0; k < 4; ++k)
    {
      Eigen::Vector3i c = v;
      const int du = (k & 1), dw = (k >> 1);
      c[u] -= du;
      c[w] -= dw;
      const Leaf* l = map.leafAt (c.x (), c.y (), c.z ());
      if (l)
      {
        const int e = axis * 4 + du + 2 * dw;
        return !(l->crossed >> e & 1);
      }
    }
    return false;
  }
  // Final sign (+1 exterior / −1 interior) and the state before defaults:
  // state 1/−1 voted, 2 ambiguous, 3 propagated, 4 unresolved.
  int
  resolve (const Eigen::Vector3i& v, int* state = nullptr) const
  {
    const int s = voted (v.x (), v.y (), v.z ());
    if (s == 1 || s == -1)
    {
      if (state)
        *state = s;
      return s;
    }
    if (s == 2)
    {
      if (state)
        *state = 2;
      return 1;  // ambiguous → exterior (§3.6)
    }
    // Breadth first through leaf edges without intersection, ≤ 3 edges.
    std::array<Eigen::Vector3i, 64> seen;
    int nseen = 1;
    seen[0] = v;
    std::array<Eigen::Vector3i, 64> front, next;
    int nfront = 1, nnext = 0;
    front[0] = v;
    for (int depth = 0; depth < 3; ++depth)
    {
      nnext = 0;
      int found = 0;
      for (int f = 0; f < nfront; ++f)
        for (int d = 0; d < 6; ++d)
        {
          const int axis = d >> 1;
          Eigen::Vector3i w = front[f];
          Eigen::Vector3i start = w;
          if (d & 1)
            w[axis] += 1;
          else
          {
            w[axis] -= 1;
            start = w;
          }
          if (std::find (seen.begin (), seen.begin () + nseen, w) != seen.begin () + nseen)
            continue;
          // WEIGHTED: the field is defined around the surface, any lattice edge carries it;
          // the seed's rules propagate inside cells, through leaf edges without intersection.
          if (rule != DualContouringOctree::SignRule::WEIGHTED && !openEdge (start, axis))
            continue;
          if (nseen < 64)
            seen[nseen++] = w;
          const int sw = voted (w.x (), w.y (), w.z ());
          if (sw == 1 || sw == -1)
            found |= (sw == 1 ? 1 : 2);
          else if (nnext < 64)
            next[nnext++] = w;
        }
      if (found)
      {
        if (found == 3)
          break;  // neighbours disagree (Fig. 3.11): unresolved
        if (state)
          *state = 3;
        return found == 1 ? 1 : -1;
      }
      std::swap (front, next);
      nfront = nnext;
      if (!nfront)
        break;
    }
    if (state)
      *state = 4;
    return 1;  // unresolved → exterior
  }
};

}  // namespace

int
DualContouringOctree::gridVertexState (const Eigen::Vector3i& v) const
{
  RootCache rc (*impl_);
  SignResolver sr{rc, rule_};
  int state = 0;
  const int s = sr.resolve (v, &state);
  if (state == 2)
    return 2;
  if (state == 4)
    return 0;
  return s;
}

bool
DualContouringOctree::addFrameMesh (const pclx::surface::FrameMesh& mesh)
{
  const auto t0 = Clock::now ();
  Stats& st = stats_;
  st.input_triangles = mesh.triangles.size ();
  st.used_triangles = st.nonfinite_triangles = st.degenerate_triangles = st.outside_triangles =
      st.bad_index_triangles = 0;
  st.intersections = st.multi_intersection_edges = st.touched_roots = 0;
  if (mesh.triangles.empty () || mesh.vertices.empty ())
    return fail ("empty mesh (no triangles)");

  // Lattice coordinates (units of h) in double: exact enough and the same for every frame order.
  const std::size_t nv = mesh.vertices.size ();
  std::vector<Eigen::Vector3d> q (nv);
  std::vector<char> finite (nv);
  for (std::size_t i = 0; i < nv; ++i)
  {
    finite[i] = mesh.vertices[i].allFinite ();
    q[i] = mesh.vertices[i].cast<double> () / h_;
  }

  // Volume of interest from the first frame (§3.4.1).
  if (!volume_set_)
  {
    Eigen::Vector3d lo = Eigen::Vector3d::Constant (std::numeric_limits<double>::max ());
    Eigen::Vector3d hi = -lo;
    for (std::size_t i = 0; i < nv; ++i)
      if (finite[i])
      {
        lo = lo.cwiseMin (mesh.vertices[i].cast<double> ());
        hi = hi.cwiseMax (mesh.vertices[i].cast<double> ());
      }
    if (!(lo.array () <= hi.array ()).all ())
      return fail ("no finite vertex in the mesh");
    const Eigen::Vector3d c = 0.5 * (lo + hi);
    const double half = 0.5 * margin_ * (hi - lo).maxCoeff () + h_;
    vol_min_ = c.array () - half;
    vol_max_ = c.array () + half;
    volume_set_ = true;
  }

  // Valid triangles: indices in range, finite corners, inside the lattice (and the volume when
  // it does not grow), non-zero area.
  std::vector<std::uint32_t> tris;
  tris.reserve (mesh.triangles.size ());
  std::vector<Eigen::Vector3d> normals (mesh.triangles.size (), Eigen::Vector3d::Zero ());
  for (std::size_t t = 0; t < mesh.triangles.size (); ++t)
  {
    const Eigen::Vector3i& f = mesh.triangles[t];
    if ((f.array () < 0).any () || (f.array () >= static_cast<int> (nv)).any ())
    {
      ++st.bad_index_triangles;
      continue;
    }
    if (!finite[f[0]] || !finite[f[1]] || !finite[f[2]])
    {
      ++st.nonfinite_triangles;
      continue;
    }
    bool outside = false;
    for (int k = 0; k < 3; ++k)
    {
      const Eigen::Vector3d& p = q[f[k]];
      if ((p.array ().abs () > kLatticeLimit).any ())
        outside = true;
      if (!grow_)
      {
        const Eigen::Vector3d w = p * h_;
        if ((w.array () < vol_min_.array ()).any () || (w.array () > vol_max_.array ()).any ())
          outside = true;
      }
    }
    if (outside)
    {
      ++st.outside_triangles;
      continue;
    }
    const Eigen::Vector3d n = (q[f[1]] - q[f[0]]).cross (q[f[2]] - q[f[0]]);
    const double len = n.norm ();
    if (!(len > 1e-12))
    {
      ++st.degenerate_triangles;
      continue;
    }
    normals[t] = n / len;
    tris.push_back (static_cast<std::uint32_t> (t));
  }
  st.used_triangles = tris.size ();
  if (tris.empty ())
    return fail ("no usable triangle (" + std::to_string (st.nonfinite_triangles) + " non-finite, " +
                 std::to_string (st.degenerate_triangles) + " degenerate, " +
                 std::to_string (st.outside_triangles) + " outside the volume, " +
                 std::to_string (st.bad_index_triangles) + " bad indices)");
  if (st.outside_triangles)
    PCL_WARN ("[pcl::DualContouringOctree] %zu triangles outside the %s dropped\n", st.outside_triangles,
              grow_ ? "lattice range" : "volume (growth off)");

  // Edge–triangle intersections: for each axis, the lattice lines through the triangle's
  // projection, with a top-left rule so a line through a shared triangle edge hits once.
  std::vector<Crossing> crossings;
#pragma omp parallel
  {
    std::vector<Crossing> local;
#pragma omp for schedule(dynamic, 256) nowait
    for (std::ptrdiff_t ti = 0; ti < static_cast<std::ptrdiff_t> (tris.size ()); ++ti)
    {
      const std::uint32_t t = tris[ti];
      const Eigen::Vector3i& f = mesh.triangles[t];
      for (int a = 0; a < 3; ++a)
      {
        const int u = (a + 1) % 3, w = (a + 2) % 3;
        Eigen::Vector2d P[3];
        double D[3];
        for (int k = 0; k < 3; ++k)
        {
          P[k] = Eigen::Vector2d (q[f[k]][u], q[f[k]][w]);
          D[k] = q[f[k]][a];
        }
        double area = (P[1] - P[0]).x () * (P[2] - P[0]).y () - (P[1] - P[0]).y () * (P[2] - P[0]).x ();
        if (area == 0)
          continue;  // parallel to the axis
        if (area < 0)
        {
          std::swap (P[1], P[2]);
          std::swap (D[1], D[2]);
          area = -area;
        }
        const int u0 = static_cast<int> (std::ceil (std::min ({P[0].x (), P[1].x (), P[2].x ()})));
        const int u1 = static_cast<int> (std::floor (std::max ({P[0].x (), P[1].x (), P[2].x ()})));
        const int w0 = static_cast<int> (std::ceil (std::min ({P[0].y (), P[1].y (), P[2].y ()})));
        const int w1 = static_cast<int> (std::floor (std::max ({P[0].y (), P[1].y (), P[2].y ()})));
        for (int iw = w0; iw <= w1; ++iw)
          for (int iu = u0; iu <= u1; ++iu)
          {
            const Eigen::Vector2d X (iu, iw);
            double e[3];
            bool in = true;
            for (int k = 0; k < 3 && in; ++k)
            {
              const Eigen::Vector2d& A = P[(k + 1) % 3];
              const Eigen::Vector2d& B = P[(k + 2) % 3];
              const Eigen::Vector2d d = B - A;
              e[k] = d.x () * (X.y () - A.y ()) - d.y () * (X.x () - A.x ());  // weight of vertex k
              if (e[k] < 0)
                in = false;
              else if (e[k] == 0)
                in = (d.y () < 0) || (d.y () == 0 && d.x () > 0);  // top-left edges own the line
            }
            if (!in)
              continue;
            // Clamped to the triangle's extent: a sliver's barycentrics can cancel badly.
            const double z = std::min (std::max ((e[0] * D[0] + e[1] * D[1] + e[2] * D[2]) / area,
                                                 std::min ({D[0], D[1], D[2]})),
                                       std::max ({D[0], D[1], D[2]}));
            const double zf = std::floor (z);
            Eigen::Vector3i s;
            s[a] = static_cast<int> (zf);
            s[u] = iu;
            s[w] = iw;
            local.push_back ({edgeKey (a, s.x (), s.y (), s.z ()),
                              static_cast<float> (std::min (z - zf, 0.99999994)), t});
          }
      }
    }
#pragma omp critical
    crossings.insert (crossings.end (), local.begin (), local.end ());
  }
  std::sort (crossings.begin (), crossings.end (), [&] (const Crossing& x, const Crossing& y) {
    if (x.key != y.key)
      return x.key < y.key;
    if (x.frac != y.frac)
      return x.frac < y.frac;
    return x.tri < y.tri;
  });
  st.intersections = crossings.size ();
  st.t_intersect_ms = msSince (t0);
  const auto t1 = Clock::now ();

  // Merge into the map (§3.4.3 / §3.5): votes on the two grid vertices, the plane into the QEFs
  // of the four leaves around the edge.
  Impl& m = *impl_;
  // Roots around the current crossing's root, resolved (and created) lazily: crossings come
  // sorted root by root, so the hash map is hardly touched.
  Eigen::Vector3i centre = Eigen::Vector3i::Constant (1 << 24);
  std::array<Impl::Root*, 27> near{};
  auto rootOf = [&] (int x, int y, int z) -> Impl::Root* {
    const int bx = floorDiv (x), by = floorDiv (y), bz = floorDiv (z);
    const int dx = bx - centre.x () + 1, dy = by - centre.y () + 1, dz = bz - centre.z () + 1;
    Impl::Root** slot = nullptr;
    if (static_cast<unsigned> (dx) < 3u && static_cast<unsigned> (dy) < 3u && static_cast<unsigned> (dz) < 3u)
    {
      slot = &near[dx + 3 * dy + 9 * dz];
      if (*slot)
        return *slot;
    }
    Impl::Root* r = m.get (bx, by, bz);
    r->dirty = true;
    if (r->stamp != st.frames + 1)
    {
      r->stamp = st.frames + 1;
      ++st.touched_roots;
    }
    if (slot)
      *slot = r;
    return r;
  };
  auto recentre = [&] (const Eigen::Vector3i& s) {
    const Eigen::Vector3i b (floorDiv (s.x ()), floorDiv (s.y ()), floorDiv (s.z ()));
    if (b != centre)
    {
      centre = b;
      near.fill (nullptr);
    }
  };
  // `weighted_ext`: the vertex's own reading of its nearest crossing (for the WEIGHTED rule),
  // at `dist` leaf units along the edge.
  auto vote = [&] (const Eigen::Vector3i& v, bool exterior, bool weighted_ext, double dist) {
    Impl::Root* r = rootOf (v.x (), v.y (), v.z ());
    const int i = localIndex (v.x (), v.y (), v.z ());
    std::uint8_t& c = exterior ? r->out_votes[i] : r->in_votes[i];
    if (r->out_votes[i] == 0 && r->in_votes[i] == 0)
      ++m.voted;
    if (c < 255)
      ++c;
    const std::int32_t w = static_cast<std::int32_t> (std::lround (std::min (dist, 1.0) * 4096));
    addSaturated (r->sdf[i], weighted_ext ? w : -w);
  };
  // WEIGHTED rule: a crossing also informs the vertices in front of it along its lattice line,
  // up to kBand leaves away, with their distance to its plane (a truncated signed distance
  // sampled on the lattice lines; frames whose noise exceeds a leaf then average instead of
  // contradicting each other).
  constexpr int kBand = 2;
  auto bandVote = [&] (const Eigen::Vector3i& s, int axis, double frac, double n_axis) {
    for (int k = -kBand + 1; k <= kBand; ++k)
    {
      if (k == 0 || k == 1)
        continue;  // the edge's own ends: vote ()
      // Behind the surface only where the line meets it steeply: along a grazing line the
      // surface may already have been left again (curved or thin parts).
      if ((k - frac) * n_axis < 0 && std::abs (n_axis) < 0.5)
        continue;
      Eigen::Vector3i v = s;
      v[axis] += k;
      Impl::Root* r = rootOf (v.x (), v.y (), v.z ());
      const double d = std::max (-double (kBand), std::min (double (kBand), (k - frac) * n_axis));
      addSaturated (r->sdf[localIndex (v.x (), v.y (), v.z ())], static_cast<std::int32_t> (std::lround (d * 4096)));
    }
  };
  for (std::size_t g = 0; g < crossings.size ();)
  {
    std::size_t e = g + 1;
    while (e < crossings.size () && crossings[e].key == crossings[g].key)
      ++e;
    const Crossing& c = crossings[g];  // nearest to A (smallest fraction)
    const int axis = static_cast<int> (c.key & 3);
    const int li = static_cast<int> ((c.key >> 2) & (kRootCells - 1));
    const std::uint64_t rk = c.key >> 14;
    Eigen::Vector3i s (static_cast<int> ((rk >> 32) & 0xFFFF) - (1 << 15),
                       static_cast<int> ((rk >> 16) & 0xFFFF) - (1 << 15),
                       static_cast<int> (rk & 0xFFFF) - (1 << 15));
    s = s * kRootSide + Eigen::Vector3i (li % kRootSide, (li / kRootSide) % kRootSide, li / (kRootSide * kRootSide));
    recentre (s);
    const std::size_t count = e - g;
    if (count > 1)
      ++st.multi_intersection_edges;
    const Eigen::Vector3d& n = normals[c.tri];
    // Eq. 3.1: S = (C − A)·N = frac · N_axis. With N pointing out, S > 0 means A lies behind
    // the surface, i.e. inside (the seed's text says exterior; its figure and the geometry say
    // interior). Odd count: B opposite; even: B as A, intersections disregarded (§3.4.3).
    const bool a_ext = n[axis] < 0;
    const bool b_ext = (count % 2) ? !a_ext : a_ext;
    Eigen::Vector3i b = s;
    b[axis] += 1;
    // Weighted: each end reads its nearest crossing, weighted by its distance to it (a truncated
    // signed distance along the edge; robust to noisy frames that disagree near the surface).
    const Crossing& last = crossings[e - 1];
    vote (s, a_ext, a_ext, c.frac * std::abs (n[axis]));
    vote (b, b_ext, normals[last.tri][axis] > 0, (1.0 - last.frac) * std::abs (normals[last.tri][axis]));
    for (std::size_t j = g; j < e; ++j)
        bandVote (s, axis, crossings[j].frac, normals[crossings[j].tri][axis]);
    // Every intersection's plane goes into the QEFs of the four leaves around the edge (the
    // seed kept only the nearest to A; with all of them a leaf's QEF is a function of the set
    // of triangles, whichever frames they came in).
    const int u = (axis + 1) % 3, w = (axis + 2) % 3;
    for (int k = 0; k < 4; ++k)
    {
      const int du = k & 1, dw = k >> 1;
      Eigen::Vector3i cell = s;
      cell[u] -= du;
      cell[w] -= dw;
      Impl::Root* r = rootOf (cell.x (), cell.y (), cell.z ());
      const int ci = localIndex (cell.x (), cell.y (), cell.z ());
      std::uint16_t& li2 = r->leaf_index[ci];
      if (li2 == kNone)
      {
        li2 = static_cast<std::uint16_t> (r->leaves.size ());
        r->leaves.emplace_back ();
        r->leaves.back ().cell = static_cast<std::uint16_t> (ci);
        ++m.leaves;
      }
      Leaf& leaf = r->leaves[li2];
      leaf.crossed |= static_cast<std::uint16_t> (1u << (axis * 4 + du + 2 * dw));
      for (std::size_t j = g; j < e; ++j)
      {
        const Eigen::Vector3d& nj = normals[crossings[j].tri];
        Eigen::Vector3d p = Eigen::Vector3d::Zero ();  // intersection in the leaf's frame
        p[axis] = crossings[j].frac;
        p[u] = du;
        p[w] = dw;
        const double d = nj.dot (p);
        const double nn[6] = {nj.x () * nj.x (), nj.x () * nj.y (), nj.x () * nj.z (),
                              nj.y () * nj.y (), nj.y () * nj.z (), nj.z () * nj.z ()};
        for (int q2 = 0; q2 < 6; ++q2)
          leaf.ata[q2] += fix (nn[q2]);
        for (int q2 = 0; q2 < 3; ++q2)
        {
          leaf.atb[q2] += fix (nj[q2] * d);
          leaf.mass[q2] += fix (p[q2]);
        }
        leaf.btb += fix (d * d);
        ++leaf.count;
      }
    }
    g = e;
  }
  st.t_merge_ms = msSince (t1);
  ++st.frames;
  st.roots = m.roots.size ();
  st.leaves = m.leaves;
  st.grid_vertices = m.voted;
  st.memory_bytes = m.roots.size () * sizeof (Impl::Root) + m.leaves * sizeof (Leaf) +
                    m.root_of.size () * 32;
  st.last_frame_ms = msSince (t0);
  return true;
}

void
DualContouringOctree::reconstruct (pcl::PolygonMesh& mesh)
{
  polygonise (mesh, all_dirty_);
}

void
DualContouringOctree::reconstructFromScratch (pcl::PolygonMesh& mesh)
{
  polygonise (mesh, true);
}

void
DualContouringOctree::polygonise (pcl::PolygonMesh& mesh, bool all)
{
  const auto t0 = Clock::now ();
  Impl& m = *impl_;
  Stats& st = stats_;
  using Root = Impl::Root;

  // Dirty roots D (data changed); owners to redo P = D dilated by 2 roots: a quad depends on the
  // leaves of the ≤ 4 roots around its edge and on signs resolved ≤ 3 edges away.
  std::vector<Root*> dirty, redo;
  for (auto& r : m.roots)
    if (all || r->dirty)
      dirty.push_back (r.get ());
  {
    std::vector<char> mark (m.roots.size (), 0);
    for (Root* r : dirty)
    {
      const Eigen::Vector3i b = r->origin / kRootSide;
      for (int dz = -2; dz <= 2; ++dz)
        for (int dy = -2; dy <= 2; ++dy)
          for (int dx = -2; dx <= 2; ++dx)
          {
            Root* n = m.find (b.x () + dx, b.y () + dy, b.z () + dz);
            if (n && !mark[n->id])
            {
              mark[n->id] = 1;
              redo.push_back (n);
            }
          }
    }
  }
  st.repolygonised_roots = redo.size ();

  // Vertices of the dirty roots: ε collapse inside the root (Ju et al.), then QEF minimisers.
  const auto tv = Clock::now ();
  const double eps2 = (eps_ / h_) * (eps_ / h_);  // RMS distance bound in leaf units, squared
#pragma omp parallel for schedule(dynamic, 4)
  for (std::ptrdiff_t ri = 0; ri < static_cast<std::ptrdiff_t> (dirty.size ()); ++ri)
  {
    Root& r = *dirty[ri];
    r.vertices.clear ();
    r.cell_vertex.fill (kNone);
    r.escaped = r.collapsed = 0;
    // Nodes per level: QEF (level-local frame), state 0 empty, 1 collapsible, 2 fixed.
    std::vector<Qef> qef[kRootLevels + 1];
    std::vector<std::uint8_t> state[kRootLevels + 1];
    int top = 0;  // highest level that may hold collapsed nodes
    if (eps_ > 0)
    {
      for (int l = 0; l <= kRootLevels; ++l)
      {
        const int side = kRootSide >> l;
        qef[l].assign (static_cast<std::size_t> (side) * side * side, Qef ());
        state[l].assign (static_cast<std::size_t> (side) * side * side, 0);
      }
      for (const Leaf& lf : r.leaves)
      {
        qef[0][lf.cell] = Qef::fromLeaf (lf);
        state[0][lf.cell] = 1;
      }
      for (int l = 1; l <= kRootLevels; ++l)
      {
        const int side = kRootSide >> l, cside = side * 2;
        bool any = false;
        for (int z = 0; z < side; ++z)
          for (int y = 0; y < side; ++y)
            for (int x = 0; x < side; ++x)
            {
              const int ni = (z * side + y) * side + x;
              bool ok = true, has = false;
              Qef acc;
              for (int c = 0; c < 8; ++c)
              {
                const int cx = 2 * x + (c & 1), cy = 2 * y + (c >> 1 & 1), cz = 2 * z + (c >> 2);
                const int ci = (cz * cside + cy) * cside + cx;
                if (state[l - 1][ci] == 0)
                  continue;
                has = true;
                if (state[l - 1][ci] == 2)
                {
                  ok = false;
                  continue;
                }
                // All node QEFs are in leaf units, origin at the node's min corner.
                acc.addShifted (qef[l - 1][ci], Eigen::Vector3d (c & 1, c >> 1 & 1, c >> 2) * double (1 << (l - 1)));
              }
              if (!has)
                continue;
              if (ok)
              {
                Eigen::Vector3d x0;
                acc.solve (double (1 << l), x0);
                ok = acc.count > 0 && acc.error (x0) / acc.count < eps2;  // mean squared distance
              }
              state[l][ni] = ok ? 1 : 2;
              if (ok)
              {
                qef[l][ni] = acc;
                any = true;
              }
            }
        if (!any)
          break;
        top = l;
      }
    }
    // Assign vertices top-down: a collapsible node whose parent is not collapsible is final.
    auto emitVertex = [&] (int level, int nx, int ny, int nz, const Qef& qq) {
      Eigen::Vector3d x;  // leaf units from the node's min corner
      if (qq.solve (double (1 << level), x))
        ++r.escaped;
      const Eigen::Vector3d lat = Eigen::Vector3d (nx, ny, nz) * double (1 << level) + x + r.origin.cast<double> ();
      const std::uint16_t vi = static_cast<std::uint16_t> (r.vertices.size ());
      r.vertices.push_back ({(lat * h_).cast<float> (), static_cast<std::uint32_t> (level << 12 | ((nz * (kRootSide >> level) + ny) * (kRootSide >> level) + nx))});
      const int s = 1 << level;
      for (int z = nz * s; z < (nz + 1) * s; ++z)
        for (int y = ny * s; y < (ny + 1) * s; ++y)
          for (int x2 = nx * s; x2 < (nx + 1) * s; ++x2)
            r.cell_vertex[(z * kRootSide + y) * kRootSide + x2] = vi;
    };
    for (int l = top; l >= 1; --l)
    {
      const int side = kRootSide >> l;
      for (int z = 0; z < side; ++z)
        for (int y = 0; y < side; ++y)
          for (int x = 0; x < side; ++x)
          {
            const int ni = (z * side + y) * side + x;
            if (state[l][ni] != 1)
              continue;
            bool parent_final = false;
            if (l < top)
            {
              const int ps = side / 2;
              parent_final = state[l + 1][((z / 2) * ps + y / 2) * ps + x / 2] == 1;
            }
            if (parent_final)
              continue;
            emitVertex (l, x, y, z, qef[l][ni]);
            ++r.collapsed;
          }
    }
    for (int ci = 0; ci < kRootCells; ++ci)
    {
      if (r.leaf_index[ci] == kNone || r.cell_vertex[ci] != kNone)
        continue;
      const Leaf& lf = r.leaves[r.leaf_index[ci]];
      const int x = lf.cell % kRootSide, y = (lf.cell / kRootSide) % kRootSide, z = lf.cell / (kRootSide * kRootSide);
      emitVertex (0, x, y, z, Qef::fromLeaf (lf));
    }
    r.dirty = false;
  }
  all_dirty_ = false;
  st.t_vertices_ms = msSince (tv);

  // Polygons (dual contouring over minimal edges) for the owner roots to redo.
  const auto tp = Clock::now ();
  // A vertex reference: root id << 16 | vertex index; phantom (no leaf): bit 63 + cell coords.
  auto phantomRef = [] (const Eigen::Vector3i& c) -> std::uint64_t {
    const std::uint64_t off = 1u << 20;
    return (1ull << 63) | ((static_cast<std::uint64_t> (c.x () + off) & 0x1FFFFF) << 42) |
           ((static_cast<std::uint64_t> (c.y () + off) & 0x1FFFFF) << 21) |
           (static_cast<std::uint64_t> (c.z () + off) & 0x1FFFFF);
  };
  auto repOf = [&] (const RootCache& rc, const Eigen::Vector3i& c, bool& exists) -> std::uint64_t {
    const Root* r = rc.findCell (c.x (), c.y (), c.z ());
    if (r)
    {
      const std::uint16_t v = r->cell_vertex[localIndex (c.x (), c.y (), c.z ())];
      if (v != kNone)
      {
        exists = true;
        return static_cast<std::uint64_t> (r->id) << 16 | v;
      }
    }
    exists = false;
    return phantomRef (c);
  };
  auto position = [&] (std::uint64_t ref) -> Eigen::Vector3f {
    if (ref >> 63)
    {
      const std::int64_t off = 1 << 20;
      const Eigen::Vector3d c (static_cast<double> (static_cast<std::int64_t> ((ref >> 42) & 0x1FFFFF) - off),
                               static_cast<double> (static_cast<std::int64_t> ((ref >> 21) & 0x1FFFFF) - off),
                               static_cast<double> (static_cast<std::int64_t> (ref & 0x1FFFFF) - off));
      return ((c.array () + 0.5) * h_).matrix ().cast<float> ();
    }
    return m.roots[ref >> 16]->vertices[ref & 0xFFFF].p;
  };
  // A polygon of 3 or 4 vertices as triangles; quads split along the shorter diagonal.
  auto emitPolygon = [&] (std::vector<std::array<std::uint64_t, 3>>& out, const std::array<std::uint64_t, 4>& pv, int np) {
    if (np == 3)
    {
      out.push_back ({pv[0], pv[1], pv[2]});
      return;
    }
    const float d02 = (position (pv[0]) - position (pv[2])).squaredNorm ();
    const float d13 = (position (pv[1]) - position (pv[3])).squaredNorm ();
    if (d02 <= d13)
    {
      out.push_back ({pv[0], pv[1], pv[2]});
      out.push_back ({pv[0], pv[2], pv[3]});
    }
    else
    {
      out.push_back ({pv[0], pv[1], pv[3]});
      out.push_back ({pv[1], pv[2], pv[3]});
    }
  };
  std::size_t ambiguous = 0, unresolved = 0, phantoms = 0;
  const bool collapsed_mode = eps_ > 0;
#pragma omp parallel for schedule(dynamic, 4) reduction(+ : ambiguous, unresolved, phantoms)
  for (std::ptrdiff_t ri = 0; ri < static_cast<std::ptrdiff_t> (redo.size ()); ++ri)
  {
    Root& r = *redo[ri];
    r.tris.clear ();
    r.shared.clear ();
    RootCache rc (m);
    rc.centreOn (r.origin / kRootSide);
    SignResolver sr{rc, rule_};
    // Cells in index order, so the output does not depend on the order leaves were created.
    std::vector<int> cells;
    for (int i = 0; i < kRootCells; ++i)
      if (r.leaf_index[i] != kNone)
        cells.push_back (i);
    static const int kU[4] = {-1, 0, 0, -1}, kW[4] = {-1, -1, 0, 0};
    // One lattice edge: if its resolved signs differ, the polygon of the (collapsed) cells
    // around it.
    auto processEdge = [&] (const Eigen::Vector3i& s, int axis) {
      const int u = (axis + 1) % 3, w = (axis + 2) % 3;
      Eigen::Vector3i end = s;
      end[axis] += 1;
      int sa = 0, sb = 0;
      const int ga = sr.resolve (s, &sa);
      const int gb = sr.resolve (end, &sb);
      if (ga == gb)
        return;
      ambiguous += (sa == 2) + (sb == 2);
      unresolved += (sa == 4) + (sb == 4);
      // Incident cells in counter-clockwise order around +axis: (−,−), (0,−), (0,0), (−,0).
      std::array<std::uint64_t, 4> poly;
      bool missing = false;
      for (int k = 0; k < 4; ++k)
      {
        Eigen::Vector3i cc = s;
        cc[u] += kU[k];
        cc[w] += kW[k];
        bool exk;
        poly[k] = repOf (rc, cc, exk);
        if (!exk)
        {
          ++phantoms;
          missing = true;
        }
      }
      if (missing && !phantom_polygons_)
        return;
      // Interior at the start ⇒ the surface faces +axis ⇒ keep the counter-clockwise order.
      if (ga > 0)
        std::swap (poly[1], poly[3]);
      // Drop repeated cells (collapsed nodes) cyclically.
      std::array<std::uint64_t, 4> pv;
      int np = 0;
      for (int k = 0; k < 4; ++k)
        if (np == 0 || poly[k] != pv[np - 1])
          pv[np++] = poly[k];
      if (np > 1 && pv[np - 1] == pv[0])
        --np;
      if (np < 3)
        return;
      bool coarse = false;
      if (collapsed_mode)
        for (int k = 0; k < np; ++k)
          coarse |= !(pv[k] >> 63) && (m.roots[pv[k] >> 16]->vertices[pv[k] & 0xFFFF].node >> 12) > 0;
      if (coarse)
        r.shared.push_back ({pv, np});  // may repeat along a coarse edge: merged at output
      else
        emitPolygon (r.tris, pv, np);
    };
    // First leaf (fixed order) among the 4 cells around an edge, or the 8 around a vertex.
    auto firstLeafAroundEdge = [&] (const Eigen::Vector3i& s, int axis, Eigen::Vector3i& out) {
      const int u = (axis + 1) % 3, w = (axis + 2) % 3;
      for (int k = 0; k < 4; ++k)
      {
        Eigen::Vector3i cc = s;
        cc[u] += kU[k];
        cc[w] += kW[k];
        if (rc.leafAt (cc.x (), cc.y (), cc.z ()))
        {
          out = cc;
          return true;
        }
      }
      return false;
    };
    if (rule_ == SignRule::WEIGHTED)
    {
      // The sign field is defined on every vertex a crossing informed (band included), so
      // every edge with such an end is examined: all sign changes get their polygon and the
      // mesh closes. An edge between two informed vertices is done from its start.
      for (int vi = 0; vi < kRootCells; ++vi)
      {
        if (!r.out_votes[vi] && !r.in_votes[vi] && !r.sdf[vi])
          continue;
        const Eigen::Vector3i v = r.origin + Eigen::Vector3i (vi % kRootSide, (vi / kRootSide) % kRootSide, vi / (kRootSide * kRootSide));
        for (int axis = 0; axis < 3; ++axis)
        {
          processEdge (v, axis);
          Eigen::Vector3i prev = v;
          prev[axis] -= 1;
          if (!sr.voted (prev.x (), prev.y (), prev.z ()))
            processEdge (prev, axis);
        }
      }
      continue;
    }
    for (int ci : cells)
    {
      const Eigen::Vector3i c = r.origin + Eigen::Vector3i (ci % kRootSide, (ci / kRootSide) % kRootSide, ci / (kRootSide * kRootSide));
      // The leaf's 12 edges, each done by the first leaf around it.
      for (int e = 0; e < 12; ++e)
      {
        const int axis = e / 4, u = (axis + 1) % 3, w = (axis + 2) % 3;
        Eigen::Vector3i s = c;  // edge start vertex
        s[u] += e & 1;
        s[w] += (e >> 1) & 1;
        Eigen::Vector3i owner;
        if (firstLeafAroundEdge (s, axis, owner) && owner == c)
          processEdge (s, axis);
      }
    }
  }
  st.ambiguous_vertices = ambiguous;
  st.unresolved_vertices = unresolved;
  st.phantom_vertices = phantoms;
  st.t_polygons_ms = msSince (tp);

  // Output: every root's cached triangles; vertices numbered per root, unused ones dropped.
  const auto to = Clock::now ();
  std::vector<std::size_t> base (m.roots.size () + 1, 0);
  for (std::size_t i = 0; i < m.roots.size (); ++i)
    base[i + 1] = base[i] + m.roots[i]->vertices.size ();
  std::vector<std::int32_t> index (base.back (), -1);
  std::unordered_map<std::uint64_t, std::int32_t> phantom_index;
  pcl::PointCloud<pcl::PointXYZ> cloud;
  std::size_t ntris = 0, escaped = 0, collapsed = 0;
  for (const auto& r : m.roots)
  {
    ntris += r->tris.size ();
    escaped += r->escaped;
    collapsed += r->collapsed;
  }
  auto outIndex = [&] (std::uint64_t ref) -> int {
    if (ref >> 63)
    {
      auto it = phantom_index.find (ref);
      if (it != phantom_index.end ())
        return it->second;
      const Eigen::Vector3f p = position (ref);
      phantom_index.emplace (ref, static_cast<std::int32_t> (cloud.size ()));
      cloud.push_back (pcl::PointXYZ (p.x (), p.y (), p.z ()));
      return static_cast<int> (cloud.size () - 1);
    }
    std::int32_t& idx = index[base[ref >> 16] + (ref & 0xFFFF)];
    if (idx < 0)
    {
      const Eigen::Vector3f& p = m.roots[ref >> 16]->vertices[ref & 0xFFFF].p;
      idx = static_cast<std::int32_t> (cloud.size ());
      cloud.push_back (pcl::PointXYZ (p.x (), p.y (), p.z ()));
    }
    return idx;
  };
  std::vector<const Root*> order;
  order.reserve (m.roots.size ());
  for (const auto& r : m.roots)
    order.push_back (r.get ());
  std::sort (order.begin (), order.end (), [] (const Root* a, const Root* b) { return a->key < b->key; });
  // Merge the polygons of collapsed cells: canonical cycle (smallest first, then the smaller
  // neighbour second) → net orientation; emitted once when it is not zero.
  std::vector<std::array<std::uint64_t, 3>> merged;
  {
    struct KeyHash
    {
      std::size_t
      operator() (const std::array<std::uint64_t, 4>& k) const
      {
        std::size_t h = 0;
        for (auto x : k)
          h = h * 0x9E3779B97F4A7C15ull + (x ^ (x >> 29));
        return h;
      }
    };
    std::unordered_map<std::array<std::uint64_t, 4>, std::size_t, KeyHash> slot;
    std::vector<std::pair<std::array<std::uint64_t, 4>, int>> entries;  // canonical cycle (+n), net
    std::vector<int> sizes;
    for (const Root* r : order)
      for (const auto& sh : r->shared)
      {
        const int n = sh.n;
        int lo = 0;
        for (int k = 1; k < n; ++k)
          if (sh.v[k] < sh.v[lo])
            lo = k;
        std::array<std::uint64_t, 4> c{~0ull, ~0ull, ~0ull, ~0ull};
        const bool fwd = sh.v[(lo + 1) % n] < sh.v[(lo + n - 1) % n];
        for (int k = 0; k < n; ++k)
          c[k] = sh.v[(lo + (fwd ? k : n - k)) % n];
        auto it = slot.find (c);
        if (it == slot.end ())
        {
          slot.emplace (c, entries.size ());
          entries.push_back ({c, fwd ? 1 : -1});
          sizes.push_back (n);
        }
        else
          entries[it->second].second += fwd ? 1 : -1;
      }
    for (std::size_t i = 0; i < entries.size (); ++i)
    {
      if (entries[i].second == 0)
        continue;
      std::array<std::uint64_t, 4> v = entries[i].first;
      const int n = sizes[i];
      if (entries[i].second < 0)
        std::reverse (v.begin (), v.begin () + n);
      emitPolygon (merged, v, n);
    }
  }
  auto allTris = [&] (auto&& f) {
    for (const Root* r : order)
      for (const auto& t : r->tris)
        f (t);
    for (const auto& t : merged)
      f (t);
  };
  // Fill the caller's polygons in place: a mesh passed again (every frame) reuses its storage
  // instead of one allocation per triangle.
  ntris += merged.size ();
  mesh.polygons.resize (ntris);
  std::size_t ti = 0;
  allTris ([&] (const std::array<std::uint64_t, 3>& t) {
    auto& v = mesh.polygons[ti++].vertices;
    v.resize (3);
    v[0] = outIndex (t[0]);
    v[1] = outIndex (t[1]);
    v[2] = outIndex (t[2]);
  });
  pcl::toPCLPointCloud2 (cloud, mesh.cloud);
  st.vertices = cloud.size ();
  st.triangles = mesh.polygons.size ();
  st.escaped_vertices = escaped;
  st.collapsed_cells = collapsed;
  st.cells = base.back ();
  std::size_t cache_bytes = 0;
  for (const auto& r : m.roots)
    cache_bytes += r->vertices.capacity () * sizeof (Vertex) + r->tris.capacity () * sizeof (r->tris[0]) +
                   r->leaves.capacity () * sizeof (Leaf);
  st.memory_bytes = m.roots.size () * sizeof (Root) + cache_bytes + m.root_of.size () * 32;
  st.t_output_ms = msSince (to);
  st.last_reconstruct_ms = msSince (t0);
}

}  // namespace pcl
