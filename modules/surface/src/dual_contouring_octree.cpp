#include <pclx/surface/dual_contouring_octree.h>
#include <pclx/surface/detail/bounded_edge_collapse.h>
#include <pclx/surface/detail/hole_filling.h>

#include <pcl/common/io.h>
#include <pcl/console/print.h>
#include <pcl/conversions.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Eigenvalues>

#include <boost/sort/spreadsort/integer_sort.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <future>
#include <memory_resource>
#include <mutex>
#include <new>
#include <system_error>
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

// std::lround's rounding (half away from zero) without its library call; |x| < 2^31.
inline std::int32_t
roundToInt (double x)
{
  const auto t = static_cast<std::int64_t> (x);  // toward zero
  const double r = x - static_cast<double> (t);  // exact
  return static_cast<std::int32_t> (t + (r >= 0.5) - (r <= -0.5));
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

// Per lattice edge: running weighted sums of the crossings every frame reported on it (position
// along the edge and unit normal), in fixed point so that the means do not depend on the order
// of the frames. The mean crossing and mean normal form the edge's Hermite sample.
struct EdgeData
{
  std::int64_t w = 0;                 // Σ weight
  std::int64_t wf = 0;                // Σ weight · position along the edge, [0, 1)
  std::int64_t wn[3] = {0, 0, 0};     // Σ weight · unit normal
  std::int32_t count = 0;             // observations

  bool
  hermite (double& frac, Eigen::Vector3d& n) const
  {
    if (w <= 0)
      return false;
    frac = static_cast<double> (wf) / static_cast<double> (w);
    n = Eigen::Vector3d (static_cast<double> (wn[0]), static_cast<double> (wn[1]), static_cast<double> (wn[2]));
    const double len = n.norm ();
    if (!(len > 0))
      return false;
    n /= len;
    return true;
  }
};

// A leaf: a lattice cell one of whose edges carries a crossing (stop criterion 1).
struct Leaf
{
  std::uint16_t crossed = 0;  // 12 bits: edges with at least one crossing
  std::uint16_t cell = 0;     // local index in the root
};

// Quadric error function of planes n·x = n·p in a node-local frame (leaf units), with the mass
// point of the node's edge crossings.
struct Qef
{
  Eigen::Matrix3d ata = Eigen::Matrix3d::Zero ();
  Eigen::Vector3d atb = Eigen::Vector3d::Zero ();
  double btb = 0;
  int planes = 0;
  Eigen::Vector3d mass = Eigen::Vector3d::Zero ();
  int points = 0;

  void
  addPlane (const Eigen::Vector3d& p, const Eigen::Vector3d& n)
  {
    const double d = n.dot (p);
    ata += n * n.transpose ();
    atb += n * d;
    btb += d * d;
    ++planes;
  }
  void
  addPoint (const Eigen::Vector3d& p)
  {
    mass += p;
    ++points;
  }
  // Adds a QEF whose frame origin lies at `o` in this QEF's frame: n·(p − o) = d ⇒ n·p = d + n·o.
  void
  addShifted (const Qef& c, const Eigen::Vector3d& o)
  {
    ata += c.ata;
    atb += c.atb + c.ata * o;
    btb += c.btb + 2 * o.dot (c.atb) + o.dot (c.ata * o);
    planes += c.planes;
    mass += c.mass + c.points * o;
    points += c.points;
  }
  double
  error (const Eigen::Vector3d& x) const
  {
    return std::max (0.0, x.dot (ata * x) - 2 * x.dot (atb) + btb);
  }
  // Minimiser by truncated eigen-decomposition of AᵀA (singular values below 0.1 σ_max dropped),
  // relative to the mass point so that the dropped directions stay at it (Ju et al. 2002). A
  // minimiser outside [lo, hi]³ is replaced by the mass point, which lies inside the node.
  // Returns true when that happened.
  bool
  solve (double lo, double hi, Eigen::Vector3d& x) const
  {
    const Eigen::Vector3d m = (points > 0 ? Eigen::Vector3d (mass / points) : Eigen::Vector3d::Constant (0.5 * (lo + hi)))
                                  .cwiseMax (lo)
                                  .cwiseMin (hi);
    x = m;
    if (planes == 0)
      return false;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
    es.computeDirect (ata);
    const Eigen::Vector3d lambda = es.eigenvalues ();
    const double lmax = lambda.cwiseAbs ().maxCoeff ();
    const Eigen::Vector3d r = atb - ata * m;
    if (lmax > 0)
      for (int i = 0; i < 3; ++i)
        if (lambda[i] > 0.01 * lmax)  // σ_i / σ_max > 0.1
        {
          const Eigen::Vector3d v = es.eigenvectors ().col (i);
          x += v * (v.dot (r) / lambda[i]);
        }
    if ((x.array () < lo).any () || (x.array () > hi).any ())
    {
      x = m;
      return true;
    }
    return false;
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
  std::uint32_t node;  // level << 12 | local node index (level > 0: a collapsed node)
};

// The topology of one cell: corner i at (i & 1, i >> 1 & 1, i >> 2 & 1); edge e = axis · 4 +
// du + 2 dw runs along `axis` at offsets (du, dw) on the axes (axis + 1) % 3, (axis + 2) % 3.
struct CellTables
{
  std::array<std::array<int, 2>, 12> edge_corners;
  // Face f = 2 · axis + side: its corners in cyclic order and edge k between corners k, k + 1.
  std::array<std::array<int, 4>, 6> face_corners, face_edges;

  CellTables ()
  {
    for (int e = 0; e < 12; ++e)
    {
      const int axis = e / 4, u = (axis + 1) % 3, w = (axis + 2) % 3;
      const int base = ((e & 1) << u) | (((e >> 1) & 1) << w);
      edge_corners[e] = {base, base | (1 << axis)};
    }
    for (int f = 0; f < 6; ++f)
    {
      const int axis = f / 2, side = f % 2, u = (axis + 1) % 3, w = (axis + 2) % 3;
      const int uw[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
      for (int k = 0; k < 4; ++k)
        face_corners[f][k] = (side << axis) | (uw[k][0] << u) | (uw[k][1] << w);
      for (int k = 0; k < 4; ++k)
        face_edges[f][k] = edgeBetween (face_corners[f][k], face_corners[f][(k + 1) % 4]);
    }
  }
  int
  edgeBetween (int a, int b) const
  {
    const int d = a ^ b;
    const int axis = d == 1 ? 0 : (d == 2 ? 1 : 2);
    const int lo = std::min (a, b), u = (axis + 1) % 3, w = (axis + 2) % 3;
    return axis * 4 + ((lo >> u) & 1) + 2 * ((lo >> w) & 1);
  }
};

const CellTables&
cellTables ()
{
  static const CellTables t;
  return t;
}

// Surface components inside one cell from its corners' inside bits, as the cycles of marching
// cubes' face segments: on a face with four crossed edges, bit f of `join` joins the interior
// corners, else each interior corner is cut off on its own. comp[e] is the component of edge
// e, or −1 when e is not crossed. Returns the number of components (≤ 4).
int
cellComponents (unsigned inside, unsigned join, std::array<int, 12>& comp)
{
  const CellTables& t = cellTables ();
  std::array<int, 12> parent;
  for (int e = 0; e < 12; ++e)
    parent[e] = e;
  auto find = [&] (int e) {
    while (parent[e] != e)
      e = parent[e] = parent[parent[e]];
    return e;
  };
  auto unite = [&] (int a, int b) { parent[find (a)] = find (b); };
  auto crossed = [&] (int e) { return ((inside >> t.edge_corners[e][0]) ^ (inside >> t.edge_corners[e][1])) & 1u; };
  for (int f = 0; f < 6; ++f)
  {
    int on[4], n = 0;
    for (int k = 0; k < 4; ++k)
      if (crossed (t.face_edges[f][k]))
        on[n++] = k;
    if (n == 2)
      unite (t.face_edges[f][on[0]], t.face_edges[f][on[1]]);
    else if (n == 4)
    {
      // Corner k lies between face edges k − 1 and k; pair the edges around the corners kept
      // apart (interior ones unless joined).
      const bool keep_inside = !((join >> f) & 1u);
      for (int k = 0; k < 4; ++k)
        if ((((inside >> t.face_corners[f][k]) & 1u) != 0) == keep_inside)
          unite (t.face_edges[f][(k + 3) % 4], t.face_edges[f][k]);
    }
  }
  int n = 0;
  std::array<int, 12> label;
  label.fill (-1);
  for (int e = 0; e < 12; ++e)
  {
    comp[e] = -1;
    if (!crossed (e))
      continue;
    const int r = find (e);
    if (label[r] < 0)
      label[r] = n++;
    comp[e] = label[r];
  }
  return n;
}

// Does face f hold four crossed edges?
bool
ambiguousFace (unsigned inside, int f)
{
  const CellTables& t = cellTables ();
  const int* c = t.face_corners[f].data ();
  const unsigned a = (inside >> c[0]) & 1u, b = (inside >> c[1]) & 1u, cc = (inside >> c[2]) & 1u, d = (inside >> c[3]) & 1u;
  return a == cc && b == d && a != b;
}

// With every ambiguous face cutting interior corners off, do the two segments of face f fall
// into one component? Then the dual edge across f would carry four quads.
bool
faceSegmentsJoined (unsigned inside, int f)
{
  std::array<int, 12> comp;
  cellComponents (inside, 0u, comp);
  const auto& fe = cellTables ().face_edges[f];
  return comp[fe[0]] == comp[fe[1]] && comp[fe[1]] == comp[fe[2]];
}

}  // namespace

// One frame's triangles that can be fused, with their unit normals (lattice frame), confidence
// weights and lattice crossings. Kept between frames, so that its buffers keep their capacity
// and pages instead of being allocated for every frame.
struct DualContouringOctree::FrameTriangles
{
  std::vector<Eigen::Vector3d> q;  // vertices in lattice units
  std::vector<char> finite;        // per vertex
  std::vector<std::uint32_t> used;
  std::vector<Eigen::Vector3d> normals;
  std::vector<double> weights;
  std::vector<Crossing> crossings;                 // sorted by edge, then fraction, then triangle
  std::vector<std::vector<Crossing>> thread_parts;  // each thread's crossings before the join
};

struct DualContouringOctree::Impl
{
  struct Root
  {
    Eigen::Vector3i origin;  // lattice coordinates of the min corner
    std::uint64_t key = 0;
    std::uint32_t id = 0;
    std::array<std::uint16_t, kRootCells> leaf_index;
    std::array<std::uint8_t, kRootCells> out_votes, in_votes;  // saturating
    std::array<std::int32_t, kRootCells> sdf;  // Σ weight · ± distance (2^-12 leaf)
    std::array<std::uint16_t, 3 * kRootCells> edge_index;  // 3 · vertex + axis → edges
    std::vector<Leaf> leaves;
    std::vector<EdgeData> edges;
    // Polygonisation cache: per fine cell the first of its vertices and, per edge, 2 bits of
    // the component whose vertex serves it (all cells of a collapsed node share one vertex).
    std::array<std::uint16_t, kRootCells> cell_vertex;
    std::array<std::uint32_t, kRootCells> cell_comp;
    std::vector<Vertex> vertices;
    // With ε > 0, the crossing planes each vertex stands for (world frame, n·x + d = 0): those
    // of vertex i start at plane_begin[i]; the mesh's edge collapse keeps vertices near them.
    std::vector<Eigen::Vector4f> planes;
    std::vector<std::uint32_t> plane_begin;
    std::vector<std::array<std::uint64_t, 3>> tris;  // vertex refs (see polygonise)
    // Polygons with a collapsed cell: the same one can come from several lattice edges along
    // a coarse edge; they are merged over the whole map at output (net orientation).
    struct Shared
    {
      std::array<std::uint64_t, 4> v;
      int n;
    };
    std::vector<Shared> shared;
    std::size_t escaped = 0, collapsed = 0, missing = 0, rim = 0;
    std::size_t stamp = 0;  // last frame that touched it
    bool dirty = true;

    Root ()
    {
      leaf_index.fill (kNone);
      out_votes.fill (0);
      in_votes.fill (0);
      sdf.fill (0);
      edge_index.fill (kNone);
      cell_vertex.fill (kNone);
      cell_comp.fill (0);
    }
  };

  // Destroys a root in place; its memory belongs to the arena.
  struct DestroyRoot
  {
    void
    operator() (Root* r) const
    {
      r->~Root ();
    }
  };
  using RootPtr = std::unique_ptr<Root, DestroyRoot>;

  // Memory for the roots: they are only freed all together, with the map, so a new root is a
  // bump in a monotonic buffer (cache-line aligned) instead of a heap allocation. Declared
  // before `roots`, so it outlives them.
  std::pmr::monotonic_buffer_resource arena{std::size_t (8) << 20};
  std::unordered_map<std::uint64_t, std::uint32_t> root_of;
  std::vector<RootPtr> roots;
  std::size_t leaves = 0, voted = 0, edges = 0;
  // Scratch of addFrameMesh, two frames' worth: one is merged while the next is prepared.
  FrameTriangles frames[2];
  int next_frame = 0;
  // The patches of the last reconstruct's holes: most survive a frame that changed other roots.
  pclx::surface::detail::HolePatchCache hole_patches;
  // The last output as positions and index triples, where the next reconstruct writes its own:
  // a reconstruct after every frame reuses these pages instead of faulting in fresh ones.
  std::vector<Eigen::Vector3f> mesh_points;
  std::vector<pclx::surface::detail::Triangle> mesh_triangles;

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
  // Gives the new roots from `first` on ids in key order, so that the ids do not depend on
  // which thread of the parallel merge created a root first.
  void
  numberRootsFrom (std::size_t first)
  {
    std::sort (roots.begin () + static_cast<std::ptrdiff_t> (first), roots.end (),
               [] (const RootPtr& a, const RootPtr& b) { return a->key < b->key; });
    for (std::size_t i = first; i < roots.size (); ++i)
    {
      roots[i]->id = static_cast<std::uint32_t> (i);
      root_of[roots[i]->key] = roots[i]->id;
    }
  }
  Root*
  get (int bx, int by, int bz)
  {
    const std::uint64_t k = rootKey (bx, by, bz);
    auto it = root_of.find (k);
    if (it != root_of.end ())
      return roots[it->second].get ();
    RootPtr r (new (arena.allocate (sizeof (Root), 64)) Root ());
    r->origin = Eigen::Vector3i (bx, by, bz) * kRootSide;
    r->key = k;
    r->id = static_cast<std::uint32_t> (roots.size ());
    root_of.emplace (k, r->id);
    roots.push_back (std::move (r));
    return roots.back ().get ();
  }
};

DualContouringOctree::DualContouringOctree () : impl_ (new Impl) {}

DualContouringOctree::~DualContouringOctree ()
{
  if (merging_.valid ())
    merging_.wait ();  // a merge's exception has nobody left to report to
}

void
DualContouringOctree::waitForMerge () const
{
  if (merging_.valid ())
    merging_.get ();  // rethrows what the merge threw (std::bad_alloc)
}

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
  waitForMerge ();
  if (!(h > 0) || !std::isfinite (h))
    return fail ("leaf size must be positive and finite");
  if (!impl_->roots.empty ())
    return fail ("the leaf size cannot change once frames are fused (clear () first)");
  h_ = h;
  error_.clear ();
  return true;
}

bool
DualContouringOctree::setSimplificationError (double eps)
{
  waitForMerge ();
  if (!(eps >= 0) || !std::isfinite (eps))
    return fail ("simplification error must be finite and >= 0");
  eps_ = eps;
  all_dirty_ = true;
  error_.clear ();
  return true;
}

bool
DualContouringOctree::setMaxHoleSize (double diameter)
{
  waitForMerge ();
  if (!(diameter >= 0) || !std::isfinite (diameter))
    return fail ("largest hole closed must be finite and >= 0");
  max_hole_ = diameter;
  hole_auto_ = false;
  error_.clear ();
  return true;
}

bool
DualContouringOctree::setVolume (const Eigen::Vector3d& min, const Eigen::Vector3d& max)
{
  waitForMerge ();
  if (!min.allFinite () || !max.allFinite () || !((max - min).array () > 0).all ())
    return fail ("volume must be finite with max > min on every axis");
  vol_min_ = min;
  vol_max_ = max;
  volume_set_ = true;
  error_.clear ();
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
  waitForMerge ();
  impl_.reset (new Impl);
  stats_ = Stats ();
  all_dirty_ = true;
  error_.clear ();
}

Eigen::Vector3i
DualContouringOctree::toLattice (const Eigen::Vector3d& p) const
{
  return (p / h_).array ().floor ().cast<int> ();
}

std::pair<int, int>
DualContouringOctree::gridVertexVotes (const Eigen::Vector3i& v) const
{
  waitForMerge ();
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
  // The Hermite data of the lattice edge from v along axis, or nullptr.
  const EdgeData*
  edgeAt (const Eigen::Vector3i& v, int axis) const
  {
    const Root* r = findCell (v.x (), v.y (), v.z ());
    if (!r)
      return nullptr;
    const std::uint16_t i = r->edge_index[3 * localIndex (v.x (), v.y (), v.z ()) + axis];
    return i == kNone ? nullptr : &r->edges[i];
  }
  std::int32_t
  sdfAt (const Eigen::Vector3i& v) const
  {
    const Root* r = findCell (v.x (), v.y (), v.z ());
    return r ? r->sdf[localIndex (v.x (), v.y (), v.z ())] : 0;
  }
};

// Resolved sign of grid vertices (§3.6), read-only on the map.
struct SignResolver
{
  using Root = DualContouringOctree::Impl::Root;
  const RootCache& map;
  DualContouringOctree::SignRule rule;

  // The WEIGHTED rule's vote of a vertex with weighted distance d: +1 exterior, −1 interior,
  // 2 ambiguous (votes that cancel), 0 no vote.
  static int
  weightedVote (std::int32_t d, bool any_vote)
  {
    return d > 0 ? 1 : (d < 0 ? -1 : (any_vote ? 2 : 0));
  }
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
      return weightedVote (r->sdf[i], o || n);
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
    // The weighted rule's field is defined only where crossings informed it: an uninformed
    // vertex stays unobserved and no polygon touches it (as a TSDF leaves unseen voxels).
    if (rule == DualContouringOctree::SignRule::WEIGHTED)
    {
      if (state)
        *state = 4;
      return 1;
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
          // The dissertation's rules propagate inside cells, through leaf edges without
          // intersection.
          if (!openEdge (start, axis))
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
  waitForMerge ();
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

namespace {

using FrameTriangles = DualContouringOctree::FrameTriangles;

// Confidence of a triangle's crossings: the cosine of its incidence angle times a falloff with
// range beyond 1 m (depth noise grows with range), 1 when the viewpoint is unknown.
double
crossingWeight (const Eigen::Vector3d& centroid_m, const Eigen::Vector3d& normal, const Eigen::Vector3f& viewpoint)
{
  if (!viewpoint.allFinite ())
    return 1.0;
  const Eigen::Vector3d ray = viewpoint.cast<double> () - centroid_m;
  const double range = ray.norm ();
  if (!(range > 0))
    return 1.0;
  const double cosine = std::max (0.05, std::abs (normal.dot (ray)) / range);
  return cosine * std::min (1.0, 1.0 / (range * range));
}

// Appends the crossings of triangle t with the lattice lines along the three axes; a top-left
// rule makes a line through a shared triangle edge hit once.
void
rasteriseTriangle (const Eigen::Vector3i& f, std::uint32_t t, const FrameTriangles& ft, std::vector<Crossing>& out)
{
  for (int a = 0; a < 3; ++a)
  {
    const int u = (a + 1) % 3, w = (a + 2) % 3;
    Eigen::Vector2d P[3];
    double D[3];
    for (int k = 0; k < 3; ++k)
    {
      P[k] = Eigen::Vector2d (ft.q[f[k]][u], ft.q[f[k]][w]);
      D[k] = ft.q[f[k]][a];
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
        out.push_back ({edgeKey (a, s.x (), s.y (), s.z ()), static_cast<float> (std::min (z - zf, 0.99999994)), t});
      }
  }
}

// Sorts crossings by edge, then by position along it, then by triangle: a total order, so the
// merge sees the same sequence whatever order the threads produced them in. A radix sort on
// the edge key; ties (an edge crossed more than once) are rare and short.
void
sortCrossings (std::vector<Crossing>& c)
{
  boost::sort::spreadsort::integer_sort (
      c.begin (), c.end (), [] (const Crossing& x, unsigned shift) { return x.key >> shift; },
      [] (const Crossing& x, const Crossing& y) { return x.key < y.key; });
  for (auto first = c.begin (); first != c.end ();)
  {
    auto last = first + 1;
    while (last != c.end () && last->key == first->key)
      ++last;
    if (last - first > 1)
      std::sort (first, last, [] (const Crossing& x, const Crossing& y) {
        return x.frac != y.frac ? x.frac < y.frac : x.tri < y.tri;
      });
    first = last;
  }
}

// The crossings of every used triangle into ft.crossings, sorted (sortCrossings).
void
intersectLattice (const pcl::FrameMesh& mesh, FrameTriangles& ft)
{
#ifdef _OPENMP
  const int threads = omp_get_max_threads ();
#else
  const int threads = 1;
#endif
  ft.thread_parts.resize (static_cast<std::size_t> (threads));
#pragma omp parallel num_threads (threads)
  {
#ifdef _OPENMP
    std::vector<Crossing>& local = ft.thread_parts[static_cast<std::size_t> (omp_get_thread_num ())];
#else
    std::vector<Crossing>& local = ft.thread_parts[0];
#endif
    local.clear ();
#pragma omp for schedule(dynamic, 256)
    for (std::ptrdiff_t ti = 0; ti < static_cast<std::ptrdiff_t> (ft.used.size ()); ++ti)
      rasteriseTriangle (mesh.triangles[ft.used[ti]], ft.used[ti], ft, local);
  }
  if (threads == 1)
    ft.crossings.swap (ft.thread_parts[0]);  // both buffers keep their capacity
  else
  {
    ft.crossings.clear ();
    for (const std::vector<Crossing>& part : ft.thread_parts)
      ft.crossings.insert (ft.crossings.end (), part.begin (), part.end ());
  }
  sortCrossings (ft.crossings);
}

Eigen::Vector3i
edgeStart (std::uint64_t key)
{
  const int li = static_cast<int> ((key >> 2) & (kRootCells - 1));
  const std::uint64_t rk = key >> 14;
  const Eigen::Vector3i b (static_cast<int> ((rk >> 32) & 0xFFFF) - (1 << 15),
                           static_cast<int> ((rk >> 16) & 0xFFFF) - (1 << 15),
                           static_cast<int> (rk & 0xFFFF) - (1 << 15));
  return b * kRootSide + Eigen::Vector3i (li % kRootSide, (li / kRootSide) % kRootSide, li / (kRootSide * kRootSide));
}

// Fuses sorted crossings into the map: per edge the weighted Hermite sums, the sign votes of
// the grid vertices and the leaves around the edge. Several mergers may run at once on
// crossings whose writes cannot meet (see mergeCrossings); they create roots under `create`.
class FrameMerger
{
public:
  using Root = DualContouringOctree::Impl::Root;

  // What a merger added to the map's and the frame's counters.
  struct Counts
  {
    std::size_t multi_intersection_edges = 0, touched_roots = 0, voted = 0, leaves = 0, edges = 0;

    Counts&
    operator+= (const Counts& o)
    {
      multi_intersection_edges += o.multi_intersection_edges;
      touched_roots += o.touched_roots;
      voted += o.voted;
      leaves += o.leaves;
      edges += o.edges;
      return *this;
    }
  };

  FrameMerger (DualContouringOctree::Impl& m, std::size_t frame_stamp, const FrameTriangles& ft, std::mutex& create)
    : m_ (m), stamp_ (frame_stamp), ft_ (ft), create_ (create)
  {}

  // Merges the crossings [first, last), sorted by edge.
  void
  mergeRange (const Crossing* first, const Crossing* last)
  {
    while (first != last)
    {
      const Crossing* e = first + 1;
      while (e != last && e->key == first->key)
        ++e;
      mergeEdge (first, e);
      first = e;
    }
  }

  const Counts&
  counts () const
  {
    return counts_;
  }

private:
  void
  mergeEdge (const Crossing* first, const Crossing* last)
  {
    const Crossing& c = *first;  // nearest to A (smallest fraction)
    const int axis = static_cast<int> (c.key & 3);
    const Eigen::Vector3i s = edgeStart (c.key);
    recentre (s);
    const std::size_t count = static_cast<std::size_t> (last - first);
    if (count > 1)
      ++counts_.multi_intersection_edges;
    const Eigen::Vector3d& n = ft_.normals[c.tri];
    // Eq. 3.1: S = (C − A)·N = frac · N_axis. With N pointing out, S > 0 means A lies behind
    // the surface, i.e. inside (the dissertation's text says exterior; its figure and the
    // geometry say interior). Odd count: B opposite; even: B as A, intersections disregarded
    // (§3.4.3).
    const bool a_ext = n[axis] < 0;
    const bool b_ext = (count % 2) ? !a_ext : a_ext;
    Eigen::Vector3i b = s;
    b[axis] += 1;
    const Crossing& back = *(last - 1);
    const Eigen::Vector3d& nb = ft_.normals[back.tri];
    vote (s, a_ext, a_ext, c.frac * std::abs (n[axis]), ft_.weights[c.tri]);
    vote (b, b_ext, nb[axis] > 0, (1.0 - back.frac) * std::abs (nb[axis]), ft_.weights[back.tri]);
    for (const Crossing* x = first; x != last; ++x)
      bandVote (s, axis, x->frac, ft_.normals[x->tri][axis], ft_.weights[x->tri]);
    addHermite (s, axis, first, last);
    markLeaves (s, axis);
  }

  Root*
  getRoot (int bx, int by, int bz)
  {
    std::lock_guard<std::mutex> lock (create_);
    return m_.get (bx, by, bz);
  }
  Root*
  rootOf (int x, int y, int z)
  {
    const int bx = floorDiv (x), by = floorDiv (y), bz = floorDiv (z);
    const int dx = bx - centre_.x () + 1, dy = by - centre_.y () + 1, dz = bz - centre_.z () + 1;
    Root** slot = nullptr;
    if (static_cast<unsigned> (dx) < 3u && static_cast<unsigned> (dy) < 3u && static_cast<unsigned> (dz) < 3u)
    {
      slot = &near_[dx + 3 * dy + 9 * dz];
      if (*slot)
        return *slot;
    }
    Root* r = getRoot (bx, by, bz);
    r->dirty = true;
    if (r->stamp != stamp_)
    {
      r->stamp = stamp_;
      ++counts_.touched_roots;
    }
    if (slot)
      *slot = r;
    return r;
  }
  void
  recentre (const Eigen::Vector3i& s)
  {
    const Eigen::Vector3i b (floorDiv (s.x ()), floorDiv (s.y ()), floorDiv (s.z ()));
    if (b != centre_)
    {
      centre_ = b;
      near_.fill (nullptr);
    }
  }
  // The cells around an informed vertex must have roots: their dual vertices are made by the
  // root that holds the cell. Such a root only has to exist (a new root starts dirty); its data
  // did not change, so it is not marked.
  void
  touchCellsAround (const Eigen::Vector3i& v)
  {
    const int lx = v.x () & (kRootSide - 1), ly = v.y () & (kRootSide - 1), lz = v.z () & (kRootSide - 1);
    if (lx && ly && lz)
      return;
    for (int mask = 1; mask < 8; ++mask)
      if ((!(mask & 1) || !lx) && (!(mask & 2) || !ly) && (!(mask & 4) || !lz))
      {
        const int x = v.x () - (mask & 1), y = v.y () - (mask >> 1 & 1), z = v.z () - (mask >> 2 & 1);
        const int dx = floorDiv (x) - centre_.x () + 1, dy = floorDiv (y) - centre_.y () + 1,
                  dz = floorDiv (z) - centre_.z () + 1;
        const bool cached = static_cast<unsigned> (dx) < 3u && static_cast<unsigned> (dy) < 3u &&
                            static_cast<unsigned> (dz) < 3u && near_[dx + 3 * dy + 9 * dz];
        if (!cached)
          getRoot (floorDiv (x), floorDiv (y), floorDiv (z));
      }
  }
  // `weighted_ext`: the vertex's own reading of its nearest crossing (for the WEIGHTED rule),
  // at `dist` leaf units along the edge.
  void
  vote (const Eigen::Vector3i& v, bool exterior, bool weighted_ext, double dist, double weight)
  {
    Root* r = rootOf (v.x (), v.y (), v.z ());
    const int i = localIndex (v.x (), v.y (), v.z ());
    std::uint8_t& c = exterior ? r->out_votes[i] : r->in_votes[i];
    if (r->out_votes[i] == 0 && r->in_votes[i] == 0)
      ++counts_.voted;
    if (c < 255)
      ++c;
    const std::int32_t d = roundToInt (weight * std::min (dist, 1.0) * 4096);
    addSaturated (r->sdf[i], weighted_ext ? d : -d);
    touchCellsAround (v);
  }
  // WEIGHTED rule: a crossing also informs the vertices in front of it along its lattice line,
  // up to kBand leaves away, with their distance to its plane (a truncated signed distance
  // sampled on the lattice lines; frames whose noise exceeds a leaf then average instead of
  // contradicting each other).
  void
  bandVote (const Eigen::Vector3i& s, int axis, double frac, double n_axis, double weight)
  {
    constexpr int kBand = 2;
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
      Root* r = rootOf (v.x (), v.y (), v.z ());
      const double d = std::max (-double (kBand), std::min (double (kBand), (k - frac) * n_axis));
      addSaturated (r->sdf[localIndex (v.x (), v.y (), v.z ())], roundToInt (weight * d * 4096));
      touchCellsAround (v);
    }
  }
  // The weighted running sums of the edge's crossings (position and normal).
  void
  addHermite (const Eigen::Vector3i& s, int axis, const Crossing* first, const Crossing* last)
  {
    Root* r = rootOf (s.x (), s.y (), s.z ());
    std::uint16_t& ei = r->edge_index[3 * localIndex (s.x (), s.y (), s.z ()) + axis];
    if (ei == kNone)
    {
      ei = static_cast<std::uint16_t> (r->edges.size ());
      r->edges.emplace_back ();
      ++counts_.edges;
    }
    EdgeData& e = r->edges[ei];
    for (const Crossing* x = first; x != last; ++x)
    {
      const double w = ft_.weights[x->tri];
      const Eigen::Vector3d& n = ft_.normals[x->tri];
      e.w += fix (w);
      e.wf += fix (w * x->frac);
      for (int k = 0; k < 3; ++k)
        e.wn[k] += fix (w * n[k]);
      ++e.count;
    }
  }
  void
  markLeaves (const Eigen::Vector3i& s, int axis)
  {
    const int u = (axis + 1) % 3, w = (axis + 2) % 3;
    for (int k = 0; k < 4; ++k)
    {
      const int du = k & 1, dw = k >> 1;
      Eigen::Vector3i cell = s;
      cell[u] -= du;
      cell[w] -= dw;
      Root* r = rootOf (cell.x (), cell.y (), cell.z ());
      const int ci = localIndex (cell.x (), cell.y (), cell.z ());
      std::uint16_t& li = r->leaf_index[ci];
      if (li == kNone)
      {
        li = static_cast<std::uint16_t> (r->leaves.size ());
        r->leaves.emplace_back ();
        r->leaves.back ().cell = static_cast<std::uint16_t> (ci);
        ++counts_.leaves;
      }
      r->leaves[li].crossed |= static_cast<std::uint16_t> (1u << (axis * 4 + du + 2 * dw));
    }
  }

  DualContouringOctree::Impl& m_;
  const std::size_t stamp_;
  const FrameTriangles& ft_;
  std::mutex& create_;
  Counts counts_;
  Eigen::Vector3i centre_ = Eigen::Vector3i::Constant (1 << 24);
  std::array<Root*, 27> near_{};
};

// The column of roots (bx, by) that an edge key's root lies in: the root key's two top fields.
inline std::uint64_t
columnOf (std::uint64_t edge_key)
{
  return edge_key >> 30;
}

// Merges the frame's sorted crossings (ft.crossings) in nine phases of root columns (bx mod 3,
// by mod 3). The edges of column (bx, by) write only to roots of columns bx − 1 … bx + 1,
// by − 1 … by + 1, so the columns of one phase run in parallel, and each record receives its
// writes in the same order for any number of threads. Columns, not slabs: a wall across x or y
// spreads over many. `parallel` false: on the calling thread alone.
void
mergeCrossings (DualContouringOctree::Impl& m, DualContouringOctree::Stats& st, const FrameTriangles& ft,
                bool parallel)
{
  const std::vector<Crossing>& crossings = ft.crossings;
  std::array<std::vector<std::pair<std::size_t, std::size_t>>, 9> phases;
  for (std::size_t g = 0; g < crossings.size ();)
  {
    const std::uint64_t column = columnOf (crossings[g].key);
    std::size_t e = g + 1;
    while (e < crossings.size () && columnOf (crossings[e].key) == column)
      ++e;
    phases[3 * ((column >> 16) % 3) + (column & 0xFFFF) % 3].emplace_back (g, e);
    g = e;
  }
  const std::size_t first_new_root = m.roots.size ();
  std::mutex create;
  FrameMerger::Counts total;
  for (const auto& slabs : phases)
  {
#pragma omp parallel if (parallel)
    {
      FrameMerger::Counts local;
#pragma omp for schedule(dynamic, 1) nowait
      for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t> (slabs.size ()); ++i)
      {
        FrameMerger merger (m, st.frames + 1, ft, create);
        merger.mergeRange (crossings.data () + slabs[i].first, crossings.data () + slabs[i].second);
        local += merger.counts ();
      }
#pragma omp critical
      total += local;
    }
  }
  m.numberRootsFrom (first_new_root);
  st.multi_intersection_edges += total.multi_intersection_edges;
  st.touched_roots += total.touched_roots;
  m.voted += total.voted;
  m.leaves += total.leaves;
  m.edges += total.edges;
}

}  // namespace

bool
DualContouringOctree::checkFrameTriangles (const pcl::FrameMesh& mesh, FrameTriangles& ft, Stats& st)
{
  const std::size_t nv = mesh.vertices.size ();
  ft.q.resize (nv);
  std::vector<char>& finite = ft.finite;
  finite.resize (nv);
  for (std::size_t i = 0; i < nv; ++i)
  {
    finite[i] = mesh.vertices[i].allFinite ();
    ft.q[i] = mesh.vertices[i].cast<double> () / h_;
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
  ft.used.clear ();
  ft.used.reserve (mesh.triangles.size ());
  ft.normals.assign (mesh.triangles.size (), Eigen::Vector3d::Zero ());
  ft.weights.assign (mesh.triangles.size (), 0.0);
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
      const Eigen::Vector3d& p = ft.q[f[k]];
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
    const Eigen::Vector3d n = (ft.q[f[1]] - ft.q[f[0]]).cross (ft.q[f[2]] - ft.q[f[0]]);
    const double len = n.norm ();
    if (!(len > 1e-12))
    {
      ++st.degenerate_triangles;
      continue;
    }
    ft.normals[t] = n / len;
    const Eigen::Vector3d centroid = (ft.q[f[0]] + ft.q[f[1]] + ft.q[f[2]]) * (h_ / 3.0);
    ft.weights[t] = crossingWeight (centroid, ft.normals[t], mesh.viewpoint);
    ft.used.push_back (static_cast<std::uint32_t> (t));
  }
  st.used_triangles = ft.used.size ();
  if (ft.used.empty ())
    return fail ("no usable triangle (" + std::to_string (st.nonfinite_triangles) + " non-finite, " +
                 std::to_string (st.degenerate_triangles) + " degenerate, " +
                 std::to_string (st.outside_triangles) + " outside the volume, " +
                 std::to_string (st.bad_index_triangles) + " bad indices)");
  if (st.outside_triangles)
    PCL_WARN ("[pcl::DualContouringOctree] %zu triangles outside the %s dropped\n", st.outside_triangles,
              grow_ ? "lattice range" : "volume (growth off)");
  return true;
}

// Checks and intersects the frame on the calling thread, then merges it: on a thread of its
// own when merges overlap (the previous frame's merge is joined first, so frames merge in
// order), else here.
bool
DualContouringOctree::addFrameMesh (const pcl::FrameMesh& mesh)
{
  const auto t0 = Clock::now ();
  Stats checked;  // this frame's input counts; stats_ may still be the running merge's
  checked.input_triangles = mesh.triangles.size ();
  FrameTriangles& ft = impl_->frames[impl_->next_frame];
  bool ok = !mesh.triangles.empty () && !mesh.vertices.empty ();
  if (!ok)
    fail ("empty mesh (no triangles)");
  else
    ok = checkFrameTriangles (mesh, ft, checked);
  if (ok)
  {
    intersectLattice (mesh, ft);
    checked.intersections = ft.crossings.size ();
    checked.t_intersect_ms = msSince (t0);
  }
  waitForMerge ();
  Stats& st = stats_;
  st.input_triangles = checked.input_triangles;
  st.used_triangles = checked.used_triangles;
  st.nonfinite_triangles = checked.nonfinite_triangles;
  st.degenerate_triangles = checked.degenerate_triangles;
  st.outside_triangles = checked.outside_triangles;
  st.bad_index_triangles = checked.bad_index_triangles;
  st.intersections = checked.intersections;
  st.multi_intersection_edges = st.touched_roots = 0;
  st.t_intersect_ms = checked.t_intersect_ms;
  if (!ok)
    return false;
  impl_->next_frame ^= 1;
#ifdef _OPENMP
  const bool overlap = overlap_ && omp_get_max_threads () > 1;
#else
  const bool overlap = false;
#endif
  const double t_intersect_ms = st.t_intersect_ms;
  bool merged_here = !overlap;
  if (overlap)
  {
    // One thread for the merge: the caller's next frame keeps the other core busy.
    try
    {
      merging_ = std::async (std::launch::async,
                             [this, &ft, t_intersect_ms] { mergeFrame (ft, t_intersect_ms, false); });
    }
    catch (const std::system_error&)
    {
      merged_here = true;  // no thread to be had: merge here
    }
  }
  if (merged_here)
    mergeFrame (ft, t_intersect_ms, true);
  error_.clear ();
  return true;
}

void
DualContouringOctree::mergeFrame (const FrameTriangles& ft, double t_intersect_ms, bool parallel)
{
  const auto t0 = Clock::now ();
  Stats& st = stats_;
  mergeCrossings (*impl_, st, ft, parallel);
  st.t_merge_ms = msSince (t0);
  ++st.frames;
  const Impl& m = *impl_;
  st.roots = m.roots.size ();
  st.leaves = m.leaves;
  st.grid_vertices = m.voted;
  st.memory_bytes = m.roots.size () * sizeof (Impl::Root) + m.leaves * sizeof (Leaf) + m.edges * sizeof (EdgeData) +
                    m.root_of.size () * 32;
  st.last_frame_ms = t_intersect_ms + st.t_merge_ms;
  st.total_intersect_ms += t_intersect_ms;
  st.total_merge_ms += st.t_merge_ms;
}

void
DualContouringOctree::reconstruct (pcl::PolygonMesh& mesh)
{
  waitForMerge ();
  polygonise (mesh, all_dirty_);
  error_.clear ();  // always succeeds: an earlier refusal is no longer the last call
}

void
DualContouringOctree::reconstructFromScratch (pcl::PolygonMesh& mesh)
{
  waitForMerge ();
  polygonise (mesh, true);
  error_.clear ();  // always succeeds: an earlier refusal is no longer the last call
}

namespace {

using Root = DualContouringOctree::Impl::Root;

// Offset of a dual vertex from its cell's faces, in leaf units: vertices of neighbouring cells
// never coincide.
constexpr double kFaceMargin = 1e-3;
// How far the topology signs of ε simplification extend observed signs into unobserved space
// (lattice steps): a band's back side that far behind the surface does not stop a merge.
constexpr int kFillDepth = 6;
static_assert (kRootSide + 3 + 2 * kFillDepth <= 32, "a sign block's rows along x are 32-bit masks");
// Resolved signs of the lattice vertices −1 … 17 of one root, plus `margin` more on each side
// (+1 exterior, −1 interior, 0 unobserved), their weighted signed distances, and the topology
// signs that decide a cell's components: unobserved vertices take the sign of the observed ones
// within `fill` lattice steps (exterior when those disagree or none is that close), so that the
// unobserved inside of a shape does not count as a surface behind its band. The margin equals
// the fill depth, so every root sees the same topology signs on the vertices it shares. One
// block serves root after root, keeping its arrays.
class SignBlock
{
public:
  explicit SignBlock (int fill) : margin_ (fill), side_ (kRootSide + 3 + 2 * fill) {}

  void
  compute (const Root& r, const RootCache& rc, DualContouringOctree::SignRule rule)
  {
    const std::size_t n = static_cast<std::size_t> (side_) * side_ * side_;
    sign_.assign (n, 0);
    topo_.assign (n, 1);
    sdf_.assign (n, 0);
    ambiguous_ = 0;
    if (rule == DualContouringOctree::SignRule::WEIGHTED && margin_ > 0)
      readWeighted<true> (r, rc);
    else if (rule == DualContouringOctree::SignRule::WEIGHTED)
      readWeighted<false> (r, rc);
    else
      resolveEach (r, rc, rule);
    if (margin_ > 0)
      fillUnobserved (margin_, rule == DualContouringOctree::SignRule::WEIGHTED);
  }

  int
  index (int x, int y, int z) const
  {
    const int o = 1 + margin_;
    return (x + o) + side_ * ((y + o) + side_ * (z + o));
  }
  // Observed sign (0: unobserved).
  int
  at (int x, int y, int z) const
  {
    return sign_[index (x, y, z)];
  }
  double
  sdf (int x, int y, int z) const
  {
    return sdf_[index (x, y, z)];
  }
  // Inside bits of the 8 corners of the node with min corner (x, y, z) and edge `side`.
  unsigned
  inside (int x, int y, int z, int side = 1) const
  {
    unsigned bits = 0;
    for (int c = 0; c < 8; ++c)
      bits |= unsigned (topo_[index (x + (c & 1) * side, y + (c >> 1 & 1) * side, z + (c >> 2) * side)] < 0) << c;
    return bits;
  }
  bool
  topologyInside (int x, int y, int z) const
  {
    return topo_[index (x, y, z)] < 0;
  }
  std::size_t
  ambiguous () const
  {
    return ambiguous_;
  }

private:
  // Every vertex through SignResolver::resolve (the rules whose unvoted vertices search their
  // neighbourhood).
  void
  resolveEach (const Root& r, const RootCache& rc, DualContouringOctree::SignRule rule)
  {
    const SignResolver sr{rc, rule};
    const int lo = -1 - margin_, hi = kRootSide + 1 + margin_;
    for (int z = lo; z <= hi; ++z)
      for (int y = lo; y <= hi; ++y)
        for (int x = lo; x <= hi; ++x)
        {
          const Eigen::Vector3i v = r.origin + Eigen::Vector3i (x, y, z);
          int state = 0;
          const int s = sr.resolve (v, &state);
          const int i = index (x, y, z);
          sign_[i] = static_cast<std::int8_t> (state == 4 ? 0 : s);
          topo_[i] = static_cast<std::int8_t> (sign_[i] < 0 ? -1 : 1);
          sdf_[i] = rc.sdfAt (v);
          ambiguous_ += state == 2 && x >= 0 && y >= 0 && z >= 0 && x < kRootSide && y < kRootSide && z < kRootSide;
        }
  }
  // The weighted rule's signs, as SignResolver::resolve gives them, read run by run along x from
  // the (at most three) roots a row of the block crosses instead of one lookup per vertex. With
  // `Masks` (a fill follows) it also builds the fill's row masks.
  template <bool Masks>
  void
  readWeighted (const Root& r, const RootCache& rc)
  {
    const int lo = -1 - margin_, hi = kRootSide + 1 + margin_;
    if constexpr (Masks)
      resizeRows ();
    for (int z = lo; z <= hi; ++z)
      for (int y = lo; y <= hi; ++y)
      {
        const int gy = r.origin.y () + y, gz = r.origin.z () + z;
        const bool own_row = y >= 0 && z >= 0 && y < kRootSide && z < kRootSide;
        [[maybe_unused]] std::uint32_t observed = 0, interior = 0;  // the row's masks for the fill
        for (int x = lo; x <= hi;)
        {
          const int gx = r.origin.x () + x;
          const int run = std::min (hi - x + 1, kRootSide - (gx & (kRootSide - 1)));
          const Root* src = rc.findCell (gx, gy, gz);
          if (src)
          {
            const int first = localIndex (gx, gy, gz), i0 = index (x, y, z);
            for (int k = 0; k < run; ++k)
            {
              const std::int32_t d = src->sdf[first + k];
              const int vote = SignResolver::weightedVote (d, src->out_votes[first + k] || src->in_votes[first + k]);
              // Ambiguous counts as exterior (SignResolver::resolve); no vote leaves it unobserved.
              const int s = vote == 2 ? 1 : vote;
              sign_[i0 + k] = static_cast<std::int8_t> (s);
              topo_[i0 + k] = static_cast<std::int8_t> (s < 0 ? -1 : 1);
              sdf_[i0 + k] = d;
              ambiguous_ += vote == 2 && own_row && x + k >= 0 && x + k < kRootSide;
              if constexpr (Masks)
              {
                observed |= static_cast<std::uint32_t> (s != 0) << (x + k - lo);
                interior |= static_cast<std::uint32_t> (s < 0) << (x + k - lo);
              }
            }
          }
          x += run;
        }
        if constexpr (Masks)
        {
          const std::size_t row = static_cast<std::size_t> (y - lo) + static_cast<std::size_t> (side_) * (z - lo);
          reached_[row] = observed;
          interior_[row] = interior;
        }
      }
  }
  // Sizes the fill's row masks for this block.
  void
  resizeRows ()
  {
    const std::size_t rows = static_cast<std::size_t> (side_) * side_;  // row y + n z
    for (auto* v : {&reached_, &interior_, &observed_in_, &front_in_, &front_out_, &vote_in_, &vote_out_})
      v->resize (rows);
  }
  // Breadth-first layers from the observed vertices, 6-connected, `depth` steps: a vertex first
  // reached in a layer takes the interior sign when only interior vertices of the layer before
  // reach it. The block's rows along x are bit masks (a block is at most 32 vertices wide), so a
  // layer is a few word operations per row. `masks_read`: readWeighted<true> built the observed
  // and interior rows already.
  void
  fillUnobserved (int depth, bool masks_read)
  {
    const int n = side_;
    const std::uint32_t full = n == 32 ? ~0u : (1u << n) - 1;
    const std::size_t rows = static_cast<std::size_t> (n) * n;  // row y + n z
    if (!masks_read)
    {
      resizeRows ();
      for (std::size_t row = 0; row < rows; ++row)
      {
        std::uint32_t r = 0, in = 0;
        for (int x = 0; x < n; ++x)
        {
          r |= static_cast<std::uint32_t> (sign_[row * n + x] != 0) << x;
          in |= static_cast<std::uint32_t> (topo_[row * n + x] < 0) << x;
        }
        reached_[row] = r;
        interior_[row] = in;
      }
    }
    for (std::size_t row = 0; row < rows; ++row)
    {
      observed_in_[row] = interior_[row];
      front_in_[row] = reached_[row] & interior_[row];
      front_out_[row] = reached_[row] & ~interior_[row];
    }
    // The vertices next to a mask's vertices in row (y, z).
    const auto spread = [&] (const std::vector<std::uint32_t>& m, int y, int z) {
      const std::size_t row = y + static_cast<std::size_t> (n) * z;
      std::uint32_t v = (m[row] << 1) | (m[row] >> 1);
      if (y > 0)
        v |= m[row - 1];
      if (y + 1 < n)
        v |= m[row + 1];
      if (z > 0)
        v |= m[row - n];
      if (z + 1 < n)
        v |= m[row + n];
      return v & full;
    };
    for (int d = 0; d < depth; ++d)
    {
      for (int z = 0; z < n; ++z)
        for (int y = 0; y < n; ++y)
        {
          const std::size_t row = y + static_cast<std::size_t> (n) * z;
          vote_in_[row] = spread (front_in_, y, z) & ~reached_[row];
          vote_out_[row] = spread (front_out_, y, z) & ~reached_[row];
        }
      bool any = false;
      for (std::size_t row = 0; row < rows; ++row)
      {
        const std::uint32_t now = vote_in_[row] | vote_out_[row];
        any |= now != 0;
        reached_[row] |= now;
        interior_[row] |= vote_in_[row] & ~vote_out_[row];
        front_in_[row] = vote_in_[row] & ~vote_out_[row];
        front_out_[row] = vote_out_[row];
      }
      if (!any)
        break;
    }
    // The fill only adds interior vertices: those turn from exterior to interior.
    for (std::size_t row = 0; row < rows; ++row)
      for (std::uint32_t added = interior_[row] & ~observed_in_[row]; added != 0; added &= added - 1)
        topo_[row * n + static_cast<std::size_t> (__builtin_ctz (added))] = -1;
  }

  int margin_, side_;
  std::vector<std::int8_t> sign_, topo_;
  std::vector<std::int32_t> sdf_;
  // The fill's rows: observed vertices, interior ones (observed, then filled), the observed
  // interior, each layer's fronts and votes.
  std::vector<std::uint32_t> reached_, interior_, observed_in_, front_in_, front_out_, vote_in_, vote_out_;
  std::size_t ambiguous_ = 0;
};

// Computes the dual vertices of one root: per cell one vertex per surface component (manifold
// dual contouring, Schaefer, Ju and Warren 2007), optionally merged into coarser nodes of the
// root's octree where that keeps the topology (Ju et al. 2002) and the error within ε.
class RootVertexBuilder
{
public:
  RootVertexBuilder (const RootCache& rc, DualContouringOctree::SignRule rule, double eps_leaf, double h)
    : rc_ (rc), rule_ (rule), eps_ (eps_leaf), h_ (h), block_ (eps_leaf > 0 ? kFillDepth : 0)
  {
    if (eps_ > 0)
      for (int l = 0; l <= DualContouringOctree::kRootLevels; ++l)
        level_qef_[l].resize (static_cast<std::size_t> (kRootCells) >> (3 * l));
  }

  // The vertices of root r (the cache centred on it); returns its ambiguous grid vertices.
  std::size_t
  build (Root& r)
  {
    r_ = &r;
    block_.compute (r, rc_, rule_);
    r_->vertices.clear ();
    r_->planes.clear ();
    r_->plane_begin.clear ();
    r_->cell_vertex.fill (kNone);
    r_->cell_comp.fill (0);
    r_->escaped = r_->collapsed = r_->rim = 0;
    cellPass ();
    int top = 0;
    if (eps_ > 0)
      top = collapseLevels ();
    emitCollapsed (top);
    emitCells ();
    if (eps_ > 0)
      r_->plane_begin.push_back (static_cast<std::uint32_t> (r_->planes.size ()));
    return block_.ambiguous ();
  }

private:
  struct Plane
  {
    Eigen::Vector3d p, n;  // leaf units, relative to the root's origin
    int comp;              // the cell component of its edge
  };
  // Per cell: 0 no seen surface, 1 one component off the rim (may merge), 2 fixed.
  enum : std::uint8_t { kEmpty = 0, kSimple = 1, kFixed = 2 };

  // Faces of the cell where the two segments of a four-crossing face are kept apart only if
  // cutting off the interior corners would join them on both sides of the face.
  unsigned
  joinedFaces (int x, int y, int z, unsigned inside) const
  {
    unsigned join = 0;
    for (int f = 0; f < 6; ++f)
    {
      if (!ambiguousFace (inside, f))
        continue;
      const int axis = f / 2, side = f % 2;
      Eigen::Vector3i nb (x, y, z);
      nb[axis] += side ? 1 : -1;
      const unsigned other = block_.inside (nb.x (), nb.y (), nb.z ());
      if (faceSegmentsJoined (inside, f) && faceSegmentsJoined (other, 2 * axis + (1 - side)))
        join |= 1u << f;
    }
    return join;
  }
  // The crossing of a cell edge in cell-local leaf units, and its plane when Hermite data exist.
  bool
  edgeCrossing (int x, int y, int z, int e, Eigen::Vector3d& p, Eigen::Vector3d& n) const
  {
    const auto& t = cellTables ();
    const int c0 = t.edge_corners[e][0], c1 = t.edge_corners[e][1];
    const int axis = e / 4;
    const Eigen::Vector3d corner (c0 & 1, c0 >> 1 & 1, c0 >> 2 & 1);
    const Eigen::Vector3i start = r_->origin + Eigen::Vector3i (x + (c0 & 1), y + (c0 >> 1 & 1), z + (c0 >> 2));
    double frac = 0.5;
    bool plane = false;
    const EdgeData* ed = rc_.edgeAt (start, axis);
    if (ed && ed->hermite (frac, n))
      plane = true;
    else if (rule_ == DualContouringOctree::SignRule::WEIGHTED)
    {
      const double d0 = block_.sdf (x + (c0 & 1), y + (c0 >> 1 & 1), z + (c0 >> 2));
      const double d1 = block_.sdf (x + (c1 & 1), y + (c1 >> 1 & 1), z + (c1 >> 2));
      if (d0 != d1)
        frac = std::min (1.0, std::max (0.0, d0 / (d0 - d1)));
    }
    p = corner;
    p[axis] += frac;
    return plane;
  }
  // Components of one cell whose vertices (nearly) coincide, as symmetric crossings can place
  // them, are moved apart towards the middle of their own first edge: no two output vertices
  // share a position.
  static void
  separateComponentVertices (const std::array<int, 12>& comp, int n, std::array<Eigen::Vector3d, 4>& v)
  {
    for (int b = 1; b < n; ++b)
      for (int a = 0; a < b; ++a)
      {
        if ((v[a] - v[b]).squaredNorm () > kFaceMargin * kFaceMargin)
          continue;
        const int e = static_cast<int> (std::find (comp.begin (), comp.end (), b) - comp.begin ());
        const auto& ec = cellTables ().edge_corners[e];
        const Eigen::Vector3d mid = 0.5 * (Eigen::Vector3d (ec[0] & 1, ec[0] >> 1 & 1, ec[0] >> 2) +
                                           Eigen::Vector3d (ec[1] & 1, ec[1] >> 1 & 1, ec[1] >> 2));
        v[b] = (v[b] + 0.1 * (mid - v[b])).cwiseMax (kFaceMargin).cwiseMin (1 - kFaceMargin);
      }
  }
  void
  cellPass ()
  {
    state_.fill (kEmpty);
    planes_.clear ();
    comp_pos_.clear ();
    for (int ci = 0; ci < kRootCells; ++ci)
    {
      const int x = ci % kRootSide, y = (ci / kRootSide) % kRootSide, z = ci / (kRootSide * kRootSide);
      plane_begin_[ci] = static_cast<std::uint32_t> (planes_.size ());
      first_comp_[ci] = static_cast<std::uint32_t> (comp_pos_.size ());
      ncomp_[ci] = 0;
      const unsigned inside = block_.inside (x, y, z);
      if (inside == 0 || inside == 0xFF)
      {
        plane_end_[ci] = plane_begin_[ci];
        continue;
      }
      std::array<int, 12> comp;
      const int n = cellComponents (inside, joinedFaces (x, y, z, inside), comp);
      // Crossed edges with an unobserved end give no polygon: a cell with only such edges is
      // outside what was seen (no merge cares about it), one with both kinds lies on a rim and
      // stays fine (merged across a rim, the polygons of a thin part's two sides can cancel).
      bool open = false, seen = false;
      std::array<Qef, 4> q;
      std::uint32_t bits = 0;
      for (int e = 0; e < 12; ++e)
      {
        if (comp[e] < 0)
          continue;
        const auto& ec = cellTables ().edge_corners[e];
        const bool unobserved = block_.at (x + (ec[0] & 1), y + (ec[0] >> 1 & 1), z + (ec[0] >> 2)) == 0 ||
                                block_.at (x + (ec[1] & 1), y + (ec[1] >> 1 & 1), z + (ec[1] >> 2)) == 0;
        open |= unobserved;
        seen |= !unobserved;
        bits |= static_cast<std::uint32_t> (comp[e]) << (2 * e);
        Eigen::Vector3d p, nn;
        const bool plane = edgeCrossing (x, y, z, e, p, nn);
        q[comp[e]].addPoint (p);
        if (plane)
        {
          q[comp[e]].addPlane (p, nn);
          planes_.push_back ({p + Eigen::Vector3d (x, y, z), nn, comp[e]});
        }
      }
      plane_end_[ci] = static_cast<std::uint32_t> (planes_.size ());
      const bool rim = open && seen;
      r_->rim += rim;
      comp_bits_[ci] = bits;
      ncomp_[ci] = static_cast<std::uint8_t> (n);
      std::array<Eigen::Vector3d, 4> v;
      for (int c = 0; c < n; ++c)
        r_->escaped += q[c].solve (kFaceMargin, 1 - kFaceMargin, v[c]);
      separateComponentVertices (comp, n, v);
      for (int c = 0; c < n; ++c)
        comp_pos_.push_back (v[c] + Eigen::Vector3d (x, y, z));
      state_[ci] = !seen ? kEmpty : ((n == 1 && !rim) ? kSimple : kFixed);
      if (eps_ > 0 && n == 1)
        level_qef_[0][ci] = q[0];  // read only where the state says kSimple
    }
  }
  // Ju et al. 2002's topology test of the node with min corner o (root-local) and side s: one
  // manifold component for its corners, and the signs at the middles of its edges, faces and
  // of the node agree with one of the corners they lie between.
  bool
  topologySafe (const Eigen::Vector3i& o, int s) const
  {
    const unsigned inside = block_.inside (o.x (), o.y (), o.z (), s);
    for (int f = 0; f < 6; ++f)
      if (ambiguousFace (inside, f))
        return false;
    std::array<int, 12> comp;
    if (cellComponents (inside, 0u, comp) != 1)
      return false;
    const int hs = s / 2;
    auto in = [&] (int dx, int dy, int dz) { return block_.topologyInside (o.x () + dx, o.y () + dy, o.z () + dz); };
    auto cornerIn = [&] (int c) { return ((inside >> c) & 1u) != 0; };
    for (int e = 0; e < 12; ++e)
    {
      const auto& ec = cellTables ().edge_corners[e];
      const int axis = e / 4;
      Eigen::Vector3i m ((ec[0] & 1) * s, (ec[0] >> 1 & 1) * s, (ec[0] >> 2) * s);
      m[axis] += hs;
      const bool mid = in (m.x (), m.y (), m.z ());
      if (mid != cornerIn (ec[0]) && mid != cornerIn (ec[1]))
        return false;
    }
    for (int f = 0; f < 6; ++f)
    {
      const int axis = f / 2, side = f % 2;
      Eigen::Vector3i m = Eigen::Vector3i::Constant (hs);
      m[axis] = side * s;
      const bool mid = in (m.x (), m.y (), m.z ());
      bool agrees = false;
      for (int k = 0; k < 4; ++k)
        agrees |= cornerIn (cellTables ().face_corners[f][k]) == mid;
      if (!agrees)
        return false;
    }
    const bool centre = in (hs, hs, hs);
    return centre ? inside != 0 : inside != 0xFF;
  }
  // The largest distance of the node's crossings to their planes through x (root-local).
  double
  maxPlaneDistance (const Eigen::Vector3i& o, int s, const Eigen::Vector3d& x) const
  {
    double worst = 0;
    for (int z = o.z (); z < o.z () + s; ++z)
      for (int y = o.y (); y < o.y () + s; ++y)
        for (int xx = o.x (); xx < o.x () + s; ++xx)
        {
          const int ci = (z * kRootSide + y) * kRootSide + xx;
          for (std::uint32_t k = plane_begin_[ci]; k < plane_end_[ci]; ++k)
            worst = std::max (worst, std::abs (planes_[k].n.dot (x - planes_[k].p)));
        }
    return worst;
  }
  // Merges sibling nodes bottom-up while topologySafe holds and the merged vertex stays within
  // ε of every crossing plane; returns the highest level that merged.
  int
  collapseLevels ()
  {
    level_state_[0].assign (state_.begin (), state_.end ());
    int top = 0;
    for (int l = 1; l <= DualContouringOctree::kRootLevels; ++l)
    {
      const int side = kRootSide >> l, cside = side * 2, s = 1 << l;
      level_state_[l].assign (static_cast<std::size_t> (side) * side * side, kEmpty);
      bool any = false;
      for (int ni = 0; ni < side * side * side; ++ni)
      {
        const int x = ni % side, y = (ni / side) % side, z = ni / (side * side);
        bool fixed = false, has = false;
        Qef acc;
        for (int c = 0; c < 8; ++c)
        {
          const int ci = ((2 * z + (c >> 2)) * cside + 2 * y + (c >> 1 & 1)) * cside + 2 * x + (c & 1);
          const std::uint8_t cs = level_state_[l - 1][ci];
          has |= cs != kEmpty;
          fixed |= cs == kFixed;
          if (cs == kSimple)
            acc.addShifted (level_qef_[l - 1][ci], Eigen::Vector3d (c & 1, c >> 1 & 1, c >> 2) * double (s / 2));
        }
        if (!has)
          continue;
        const Eigen::Vector3i o (x * s, y * s, z * s);
        bool ok = !fixed && acc.planes > 0 && topologySafe (o, s);
        Eigen::Vector3d v;
        if (ok)
        {
          acc.solve (kFaceMargin, s - kFaceMargin, v);
          ok = acc.error (v) / acc.planes < eps_ * eps_ && maxPlaneDistance (o, s, v + o.cast<double> ()) <= eps_;
        }
        level_state_[l][ni] = ok ? kSimple : kFixed;
        if (ok)
        {
          level_qef_[l][ni] = acc;
          any = true;
        }
      }
      if (!any)
        break;
      top = l;
    }
    return top;
  }
  std::uint16_t
  addVertex (const Eigen::Vector3d& root_local, std::uint32_t node)
  {
    const Eigen::Vector3d lat = root_local + r_->origin.cast<double> ();
    r_->vertices.push_back ({(lat * h_).cast<float> (), node});
    if (eps_ > 0)
      r_->plane_begin.push_back (static_cast<std::uint32_t> (r_->planes.size ()));
    return static_cast<std::uint16_t> (r_->vertices.size () - 1);
  }
  // With ε > 0: the crossing planes of cell ci (of its component `comp`, or all for −1) become
  // planes of the vertex added last, in the world frame.
  void
  addCellPlanes (int ci, int comp)
  {
    if (!(eps_ > 0))
      return;
    for (std::uint32_t k = plane_begin_[ci]; k < plane_end_[ci]; ++k)
    {
      const Plane& pl = planes_[k];
      const double len = pl.n.norm ();
      if ((comp >= 0 && pl.comp != comp) || !(len > 0))
        continue;
      const Eigen::Vector3d n = pl.n / len;
      const Eigen::Vector3d p = (pl.p + r_->origin.cast<double> ()) * h_;
      r_->planes.emplace_back (float (n.x ()), float (n.y ()), float (n.z ()), float (-n.dot (p)));
    }
  }
  // Nodes that merged and whose parent did not: one vertex for all their cells.
  void
  emitCollapsed (int top)
  {
    for (int l = top; l >= 1; --l)
    {
      const int side = kRootSide >> l, s = 1 << l;
      for (int ni = 0; ni < side * side * side; ++ni)
      {
        if (level_state_[l][ni] != kSimple)
          continue;
        const int x = ni % side, y = (ni / side) % side, z = ni / (side * side);
        if (l < top && level_state_[l + 1][((z / 2) * (side / 2) + y / 2) * (side / 2) + x / 2] == kSimple)
          continue;
        Eigen::Vector3d v;
        r_->escaped += level_qef_[l][ni].solve (kFaceMargin, s - kFaceMargin, v);
        const std::uint16_t vi = addVertex (v + Eigen::Vector3d (x * s, y * s, z * s), static_cast<std::uint32_t> (l << 12 | ni));
        for (int cz = z * s; cz < (z + 1) * s; ++cz)
          for (int cy = y * s; cy < (y + 1) * s; ++cy)
            for (int cx = x * s; cx < (x + 1) * s; ++cx)
            {
              const int ci = (cz * kRootSide + cy) * kRootSide + cx;
              r_->cell_vertex[ci] = vi;
              addCellPlanes (ci, -1);
            }
        ++r_->collapsed;
      }
    }
  }
  // Cells outside merged nodes: one vertex per component.
  void
  emitCells ()
  {
    for (int ci = 0; ci < kRootCells; ++ci)
    {
      if (!ncomp_[ci] || r_->cell_vertex[ci] != kNone)
        continue;
      r_->cell_vertex[ci] = static_cast<std::uint16_t> (r_->vertices.size ());
      r_->cell_comp[ci] = comp_bits_[ci];
      for (int c = 0; c < ncomp_[ci]; ++c)
      {
        addVertex (comp_pos_[first_comp_[ci] + c], static_cast<std::uint32_t> (ci));
        addCellPlanes (ci, c);
      }
    }
  }

  Root* r_ = nullptr;
  const RootCache& rc_;
  DualContouringOctree::SignRule rule_;
  double eps_, h_;
  SignBlock block_;
  std::array<std::uint8_t, kRootCells> state_, ncomp_;
  std::array<std::uint32_t, kRootCells> comp_bits_, first_comp_, plane_begin_, plane_end_;
  std::vector<Eigen::Vector3d> comp_pos_;
  std::vector<Plane> planes_;
  std::vector<std::uint8_t> level_state_[DualContouringOctree::kRootLevels + 1];
  // A node's QEF, read only where level_state_ says kSimple (kept, not cleared, between roots).
  std::vector<Qef> level_qef_[DualContouringOctree::kRootLevels + 1];
};

// A vertex reference: root id << 16 | vertex index.
Eigen::Vector3f
refPosition (const DualContouringOctree::Impl& m, std::uint64_t ref)
{
  return m.roots[ref >> 16]->vertices[ref & 0xFFFF].p;
}

// A polygon of 3 or 4 vertices as triangles; quads split along the shorter diagonal.
void
emitPolygon (const DualContouringOctree::Impl& m, std::vector<std::array<std::uint64_t, 3>>& out,
             const std::array<std::uint64_t, 4>& pv, int np)
{
  if (np == 3)
  {
    out.push_back ({pv[0], pv[1], pv[2]});
    return;
  }
  const float d02 = (refPosition (m, pv[0]) - refPosition (m, pv[2])).squaredNorm ();
  const float d13 = (refPosition (m, pv[1]) - refPosition (m, pv[3])).squaredNorm ();
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
}

// The polygons owned by one root: one per lattice edge that starts in the root and joins an
// exterior and an interior observed vertex, over the vertices of the four cells around it.
class RootPolygonBuilder
{
public:
  RootPolygonBuilder (const DualContouringOctree::Impl& m, const RootCache& rc, DualContouringOctree::SignRule rule,
                      bool collapsed_mode)
    : m_ (m), collapsed_mode_ (collapsed_mode), rc_ (rc), rule_ (rule), block_ (0)
  {}

  // The polygons of root r (the cache centred on it).
  void
  build (Root& r)
  {
    r_ = &r;
    block_.compute (r, rc_, rule_);
    r_->tris.clear ();
    r_->shared.clear ();
    r_->missing = 0;
    for (int vi = 0; vi < kRootCells; ++vi)
    {
      const Eigen::Vector3i l (vi % kRootSide, (vi / kRootSide) % kRootSide, vi / (kRootSide * kRootSide));
      const int sa = block_.at (l.x (), l.y (), l.z ());
      if (!sa)
        continue;
      for (int axis = 0; axis < 3; ++axis)
      {
        Eigen::Vector3i e = l;
        e[axis] += 1;
        const int sb = block_.at (e.x (), e.y (), e.z ());
        if (sb && sb != sa)
          edgePolygon (r_->origin + l, axis, sa);
      }
    }
  }

private:
  void
  edgePolygon (const Eigen::Vector3i& s, int axis, int start_sign)
  {
    static const int kU[4] = {-1, 0, 0, -1}, kW[4] = {-1, -1, 0, 0};
    const int u = (axis + 1) % 3, w = (axis + 2) % 3;
    // Incident cells in counter-clockwise order around +axis: (−,−), (0,−), (0,0), (−,0).
    std::array<std::uint64_t, 4> poly;
    for (int k = 0; k < 4; ++k)
    {
      Eigen::Vector3i cc = s;
      cc[u] += kU[k];
      cc[w] += kW[k];
      const Root* cr = rc_.findCell (cc.x (), cc.y (), cc.z ());
      const int li = localIndex (cc.x (), cc.y (), cc.z ());
      if (!cr || cr->cell_vertex[li] == kNone)
      {
        ++r_->missing;
        return;
      }
      const int e = axis * 4 + (-kU[k]) + 2 * (-kW[k]);
      const std::uint32_t comp = (cr->cell_comp[li] >> (2 * e)) & 3u;
      poly[k] = static_cast<std::uint64_t> (cr->id) << 16 | (cr->cell_vertex[li] + comp);
    }
    // Interior at the start ⇒ the surface faces +axis ⇒ keep the counter-clockwise order.
    if (start_sign > 0)
      std::swap (poly[1], poly[3]);
    // Drop repeated vertices (collapsed nodes) cyclically.
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
    if (collapsed_mode_)
      for (int k = 0; k < np; ++k)
        coarse |= (m_.roots[pv[k] >> 16]->vertices[pv[k] & 0xFFFF].node >> 12) > 0;
    if (coarse)
      r_->shared.push_back ({pv, np});  // may repeat along a coarse edge: merged at output
    else
      emitPolygon (m_, r_->tris, pv, np);
  }

  Root* r_ = nullptr;
  const DualContouringOctree::Impl& m_;
  bool collapsed_mode_;
  const RootCache& rc_;
  DualContouringOctree::SignRule rule_;
  SignBlock block_;
};

// Roots within `radius` roots of any root in `from`, each once.
std::vector<Root*>
dilateRoots (const DualContouringOctree::Impl& m, const std::vector<Root*>& from, int radius)
{
  std::vector<Root*> out;
  std::vector<char> mark (m.roots.size (), 0);
  for (Root* r : from)
  {
    const Eigen::Vector3i b = r->origin / kRootSide;
    for (int dz = -radius; dz <= radius; ++dz)
      for (int dy = -radius; dy <= radius; ++dy)
        for (int dx = -radius; dx <= radius; ++dx)
        {
          Root* n = m.find (b.x () + dx, b.y () + dy, b.z () + dz);
          if (n && !mark[n->id])
          {
            mark[n->id] = 1;
            out.push_back (n);
          }
        }
  }
  return out;
}

// The polygons of collapsed nodes, merged over the map: a canonical cycle (smallest first, then
// the smaller neighbour second) with its net orientation, emitted once when that is not zero.
std::vector<std::array<std::uint64_t, 3>>
mergeSharedPolygons (const DualContouringOctree::Impl& m, const std::vector<const Root*>& order)
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
  std::vector<std::pair<std::array<std::uint64_t, 4>, int>> entries;  // canonical cycle, net
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
  std::vector<std::array<std::uint64_t, 3>> merged;
  for (std::size_t i = 0; i < entries.size (); ++i)
  {
    if (entries[i].second == 0)
      continue;
    std::array<std::uint64_t, 4> v = entries[i].first;
    const int n = sizes[i];
    if (entries[i].second < 0)
      std::reverse (v.begin (), v.begin () + n);
    emitPolygon (m, merged, v, n);
  }
  return merged;
}

// Most crossing planes one output vertex may stand for after the edge collapses: bounds the
// cost of checking them.
constexpr std::size_t kMaxVertexPlanes = 1024;

// The octree's mesh (vertex i from root vertex refs[i]) simplified by edge collapses that keep
// every vertex within eps of the crossing planes it stands for; returns the number of collapses
// (the mesh is left as it was when the collapse refuses it).
std::size_t
collapseAcrossNodes (const DualContouringOctree::Impl& m, double eps, const std::vector<std::uint64_t>& refs,
                     std::vector<Eigen::Vector3f>& points, std::vector<pclx::surface::detail::Triangle>& tris)
{
  // Each vertex's planes copied from its root, placed by their counts first so that the copies
  // run in parallel.
  pclx::surface::detail::VertexPlanes vp;
  const std::ptrdiff_t n = static_cast<std::ptrdiff_t> (refs.size ());
  vp.begin.resize (n + 1);
  vp.begin[0] = 0;
  for (std::ptrdiff_t k = 0; k < n; ++k)
  {
    const auto& r = *m.roots[refs[k] >> 16];
    const std::size_t i = refs[k] & 0xFFFF;
    vp.begin[k + 1] = vp.begin[k] + (r.plane_begin[i + 1] - r.plane_begin[i]);
  }
  vp.planes.resize (vp.begin[n]);
#pragma omp parallel for schedule (static)
  for (std::ptrdiff_t k = 0; k < n; ++k)
  {
    const auto& r = *m.roots[refs[k] >> 16];
    const std::size_t i = refs[k] & 0xFFFF;
    std::copy (r.planes.begin () + r.plane_begin[i], r.planes.begin () + r.plane_begin[i + 1],
               vp.planes.begin () + vp.begin[k]);
  }
  pclx::surface::detail::EdgeCollapseStats cs;
  if (!pclx::surface::detail::collapseEdgesWithinDistance (points, tris, vp, eps, kMaxVertexPlanes, cs))
  {
    PCL_ERROR ("[pcl::DualContouringOctree::reconstruct] the mesh was left as the octree made it\n");
    return 0;
  }
  return cs.collapses;
}

}  // namespace

void
DualContouringOctree::polygonise (pcl::PolygonMesh& mesh, bool all)
{
  const auto t0 = Clock::now ();
  Impl& m = *impl_;
  Stats& st = stats_;

  // Roots whose data changed (D); their vertices depend on the roots next to them (corner signs,
  // edges and the face rule), so vertices are redone for D dilated by one root, and polygons,
  // which reference the vertices of the roots around their edge, for D dilated by two.
  std::vector<Root*> dirty;
  for (auto& r : m.roots)
    if (all || r->dirty)
      dirty.push_back (r.get ());
  const std::vector<Root*> vertex_roots = dilateRoots (m, dirty, 1);
  const std::vector<Root*> redo = dilateRoots (m, dirty, 2);
  st.repolygonised_roots = redo.size ();

  const auto tv = Clock::now ();
  const double eps_leaf = eps_ / h_;
  std::size_t ambiguous = 0;
  // One cache and builder per thread, re-centred root by root: their arrays are reused.
#pragma omp parallel reduction(+ : ambiguous)
  {
    RootCache rc (m);
    RootVertexBuilder builder (rc, rule_, eps_leaf, h_);
#pragma omp for schedule(dynamic, 4)
    for (std::ptrdiff_t ri = 0; ri < static_cast<std::ptrdiff_t> (vertex_roots.size ()); ++ri)
    {
      Root& r = *vertex_roots[ri];
      rc.centreOn (r.origin / kRootSide);
      ambiguous += builder.build (r);
    }
  }
  for (Root* r : dirty)
    r->dirty = false;
  all_dirty_ = false;
  st.t_vertices_ms = msSince (tv);

  const auto tp = Clock::now ();
#pragma omp parallel
  {
    RootCache rc (m);
    RootPolygonBuilder builder (m, rc, rule_, eps_ > 0);
#pragma omp for schedule(dynamic, 4)
    for (std::ptrdiff_t ri = 0; ri < static_cast<std::ptrdiff_t> (redo.size ()); ++ri)
    {
      Root& r = *redo[ri];
      rc.centreOn (r.origin / kRootSide);
      builder.build (r);
    }
  }
  st.ambiguous_vertices = ambiguous;
  st.t_polygons_ms = msSince (tp);

  const auto to = Clock::now ();
  writeMesh (mesh);
  st.t_output_ms = msSince (to);
  st.last_reconstruct_ms = msSince (t0);
}

namespace {

// Closes the mesh's holes up to `diameter` (metres) with patches appended to it.
void
closeSmallHoles (double diameter, pclx::surface::detail::HolePatchCache& cache, std::vector<Eigen::Vector3f>& points,
                 std::vector<pclx::surface::detail::Triangle>& tris, DualContouringOctree::Stats& st)
{
  st.holes_filled = st.holes_open = st.hole_triangles = st.hole_patches_reused = 0;
  if (!(diameter > 0))
    return;
  pclx::surface::detail::HoleFillingStats hs;
  // Lattice loops are often coplanar: only the search free of geometric predicates.
  using pclx::surface::detail::kCubicSearchEdges;
  if (!pclx::surface::detail::fillSmallHoles (points, tris, diameter, hs, kCubicSearchEdges, &cache))
    return;
  st.holes_filled = hs.filled;
  st.holes_open = hs.too_large + hs.failed;
  st.hole_triangles = hs.added_triangles;
  st.hole_patches_reused = cache.hits;
}

// Writes positions and index triples into a PCL mesh, in the storage a mesh passed again after
// every frame already has (its polygons' allocations, its cloud's bytes). Each polygon owns an
// allocation, so the polygons are written in parallel.
void
toPolygonMesh (const std::vector<Eigen::Vector3f>& points, const std::vector<pclx::surface::detail::Triangle>& tris,
               pcl::PolygonMesh& mesh)
{
  mesh.polygons.resize (tris.size ());
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t> (tris.size ()); ++i)
    mesh.polygons[std::size_t (i)].vertices.assign (tris[std::size_t (i)].begin (), tris[std::size_t (i)].end ());
  pcl::toPCLPointCloud2 (pcl::PointCloud<pcl::PointXYZ> (), mesh.cloud);  // the fields of pcl::PointXYZ
  pcl::PCLPointCloud2& c = mesh.cloud;
  c.width = static_cast<std::uint32_t> (points.size ());
  c.height = 1;
  c.row_step = c.point_step * c.width;
  c.data.resize (c.row_step);
  for (std::size_t i = 0; i < points.size (); ++i)
    std::memcpy (c.data.data () + i * c.point_step, points[i].data (), 3 * sizeof (float));
}

}  // namespace

void
DualContouringOctree::writeMesh (pcl::PolygonMesh& mesh)
{
  const Impl& m = *impl_;
  Stats& st = stats_;
  // Every root's cached triangles; vertices numbered per root, unused ones dropped.
  std::vector<std::size_t> base (m.roots.size () + 1, 0);
  for (std::size_t i = 0; i < m.roots.size (); ++i)
    base[i + 1] = base[i] + m.roots[i]->vertices.size ();
  std::vector<std::int32_t> index (base.back (), -1);
  std::vector<Eigen::Vector3f>& points = impl_->mesh_points;
  std::vector<pclx::surface::detail::Triangle>& tris = impl_->mesh_triangles;
  points.clear ();
  tris.clear ();
  // Room for the holes' patches (about 1 % more), and a quarter more for a map that grows frame
  // by frame once it has been written.
  const auto fit = [] (auto& v, std::size_t n) {
    if (v.capacity () < n + n / 64)
      v.reserve (v.capacity () == 0 ? n + n / 64 : n + n / 4);
  };
  fit (points, base.back ());
  std::vector<std::uint64_t> refs;  // per output vertex, for the edge collapses (ε > 0)
  std::size_t ntris = 0, escaped = 0, collapsed = 0, missing = 0, rim = 0;
  for (const auto& r : m.roots)
  {
    ntris += r->tris.size ();
    escaped += r->escaped;
    collapsed += r->collapsed;
    missing += r->missing;
    rim += r->rim;
  }
  auto outIndex = [&] (std::uint64_t ref) -> std::uint32_t {
    std::int32_t& idx = index[base[ref >> 16] + (ref & 0xFFFF)];
    if (idx < 0)
    {
      idx = static_cast<std::int32_t> (points.size ());
      points.push_back (refPosition (m, ref));
      if (eps_ > 0)
        refs.push_back (ref);
    }
    return static_cast<std::uint32_t> (idx);
  };
  std::vector<const Root*> order;
  order.reserve (m.roots.size ());
  for (const auto& r : m.roots)
    order.push_back (r.get ());
  std::sort (order.begin (), order.end (), [] (const Root* a, const Root* b) { return a->key < b->key; });
  const std::vector<std::array<std::uint64_t, 3>> merged = mergeSharedPolygons (m, order);
  ntris += merged.size ();
  fit (tris, ntris);
  auto put = [&] (const std::array<std::uint64_t, 3>& t) {
    tris.push_back ({outIndex (t[0]), outIndex (t[1]), outIndex (t[2])});
  };
  for (const Root* r : order)
    for (const auto& t : r->tris)
      put (t);
  for (const auto& t : merged)
    put (t);
  st.octree_triangles = ntris;
  st.mesh_collapses = 0;
  st.t_collapse_ms = 0;
  if (eps_ > 0)
  {
    const auto tc = Clock::now ();
    st.mesh_collapses = collapseAcrossNodes (m, eps_, refs, points, tris);
    st.t_collapse_ms = msSince (tc);
  }
  const auto th = Clock::now ();
  closeSmallHoles (getMaxHoleSize (), impl_->hole_patches, points, tris, st);
  st.t_holes_ms = msSince (th);
  toPolygonMesh (points, tris, mesh);
  st.vertices = points.size ();
  st.triangles = tris.size ();
  st.escaped_vertices = escaped;
  st.collapsed_cells = collapsed;
  st.missing_vertices = missing;
  st.rim_cells = rim;
  st.cells = base.back ();
  std::size_t cache_bytes = 0;
  for (const auto& r : m.roots)
    cache_bytes += r->vertices.capacity () * sizeof (Vertex) + r->tris.capacity () * sizeof (r->tris[0]) +
                   r->leaves.capacity () * sizeof (Leaf) + r->edges.capacity () * sizeof (EdgeData) +
                   r->planes.capacity () * sizeof (r->planes[0]) + r->plane_begin.capacity () * sizeof (std::uint32_t);
  cache_bytes += m.hole_patches.scratchBytes () + m.mesh_points.capacity () * sizeof (Eigen::Vector3f) +
                 m.mesh_triangles.capacity () * sizeof (pclx::surface::detail::Triangle);
  st.memory_bytes = m.roots.size () * sizeof (Root) + cache_bytes + m.root_of.size () * 32;
}


}  // namespace pcl
