#pragma once
#include <pclx/normals/mst_normal_orientation.h>
#include <pclx/surface/rbf_pou_reconstruction.h>

#include <pcl/common/io.h>
#include <pcl/conversions.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/surface/marching_cubes.h>  // edgeTable / triTable

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace pcl {
namespace rbf_pou_detail {

using Clock = std::chrono::steady_clock;
inline double
seconds (Clock::time_point t0)
{
  return std::chrono::duration<double> (Clock::now () - t0).count ();
}

// Grid keys: 20 bits per axis, so that an edge key (corner key · 4 + axis) fits in 62 bits.
constexpr int kBits = 20;
constexpr std::int64_t kMaxIndex = (std::int64_t (1) << kBits) - 1;
inline std::uint64_t
pack (std::int64_t i, std::int64_t j, std::int64_t k)
{
  return std::uint64_t (i) | (std::uint64_t (j) << kBits) | (std::uint64_t (k) << (2 * kBits));
}
inline Eigen::Array3i
unpack (std::uint64_t key)
{
  const std::uint64_t m = std::uint64_t (kMaxIndex);
  return Eigen::Array3i (int (key & m), int ((key >> kBits) & m), int ((key >> (2 * kBits)) & m));
}

inline int
threadCount (unsigned int requested)
{
#ifdef _OPENMP
  return requested ? int (requested) : omp_get_max_threads ();
#else
  (void) requested;
  return 1;
#endif
}

inline void
sortUnique (std::vector<std::uint64_t>& v)
{
  std::sort (v.begin (), v.end ());
  v.erase (std::unique (v.begin (), v.end ()), v.end ());
}

// Union of `keys` shifted by o·stride for o in [lo, hi] (one axis). A shift keeps a sorted
// array sorted, so this is a chain of merges: peak memory ~3× the result, not (hi − lo + 1)×.
inline void
dilate (std::vector<std::uint64_t>& keys, int axis, int lo, int hi)
{
  const std::uint64_t stride = std::uint64_t (1) << (kBits * axis);
  std::vector<std::uint64_t> out, shifted (keys.size ()), merged;
  for (int o = lo; o <= hi; ++o)
  {
    for (std::size_t i = 0; i < keys.size (); ++i)
      shifted[i] = keys[i] + std::uint64_t (std::int64_t (o)) * stride;
    merged.clear ();
    merged.reserve (out.size () + shifted.size ());
    std::set_union (out.begin (), out.end (), shifted.begin (), shifted.end (), std::back_inserter (merged));
    out.swap (merged);
  }
  keys.swap (out);
}

// PCL's marching-cubes corner order (MarchingCubes::getNeighborList1D) and edge ends.
constexpr int kCorner[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 0, 1}, {0, 0, 1},
                               {0, 1, 0}, {1, 1, 0}, {1, 1, 1}, {0, 1, 1}};
constexpr int kEdge[12][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {4, 5}, {5, 6},
                              {6, 7}, {7, 4}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};

}  // namespace rbf_pou_detail

template <typename PointNT> bool
RBFPOUReconstruction<PointNT>::fail (const std::string& msg)
{
  error_ = msg;
  PCL_ERROR ("[pcl::%s] %s\n", getClassName ().c_str (), msg.c_str ());
  return false;
}

template <typename PointNT> double
RBFPOUReconstruction<PointNT>::weight (const Subdomain& s, const Eigen::Vector3d& p) const
{
  // Eq. 4.5: D = 1 − Π 4 (p − S)(T − p) / (T − S)², zero at the centre, one on the border.
  double prod = 1;
  for (int r = 0; r < 3; ++r)
  {
    const double a = p[r] - s.lo[r], b = s.hi[r] - p[r];
    if (a <= 0 || b <= 0)
      return 0;
    const double e = s.hi[r] - s.lo[r];
    prod *= 4 * a * b / (e * e);
  }
  const double d = 1 - prod;
  if (decay_ == Decay::LINEAR)
    return 1 - d;  // Eq. 4.6
  return 2 * d * d * d - 3 * d * d + 1;
}

template <typename PointNT> double
RBFPOUReconstruction<PointNT>::local (const Subdomain& s, const Eigen::Vector3d& p) const
{
  const Eigen::Vector3d q = (p - s.centre) / s.scale;
  double f = s.poly[0] + s.poly.template tail<3> ().dot (q);
  const float* c = sub_q_.data () + 3 * std::size_t (s.first);
  const double* lambda = sub_lambda_.data () + s.first;
  for (std::uint32_t j = 0; j < s.count; ++j)
  {
    const double dx = q[0] - c[3 * j], dy = q[1] - c[3 * j + 1], dz = q[2] - c[3 * j + 2];
    const double r2 = dx * dx + dy * dy + dz * dz;
    f += lambda[j] * r2 * std::sqrt (r2);
  }
  return f;
}

template <typename PointNT> template <typename F> void
RBFPOUReconstruction<PointNT>::forCovering (const Eigen::Vector3d& p, F&& f) const
{
  if (subs_.empty ())
    return;
  const Eigen::Array3d b = ((p - bucket_origin_) / bucket_size_).array ().floor ();
  if ((b < 0).any () || (b > double (rbf_pou_detail::kMaxIndex)).any ())
    return;
  const std::uint64_t key = rbf_pou_detail::pack (std::int64_t (b[0]), std::int64_t (b[1]), std::int64_t (b[2]));
  auto it = std::lower_bound (buckets_.begin (), buckets_.end (), std::make_pair (key, std::uint32_t (0)));
  for (; it != buckets_.end () && it->first == key; ++it)
  {
    const Subdomain& s = subs_[it->second];
    if ((p.array () > s.lo.array ()).all () && (p.array () < s.hi.array ()).all ())
      f (s);
  }
}

template <typename PointNT> double
RBFPOUReconstruction<PointNT>::evaluate (const Eigen::Vector3f& pf, double* weight_sum) const
{
  const Eigen::Vector3d p = pf.cast<double> ();
  double sw = 0, swf = 0;
  forCovering (p, [&] (const Subdomain& s) {
    const double w = weight (s, p);
    if (w > 0)
    {
      sw += w;
      swf += w * local (s, p);
    }
  });
  if (weight_sum)
    *weight_sum = sw;
  return sw > 0 ? swf / sw : std::numeric_limits<double>::quiet_NaN ();  // Eq. 4.3–4.4
}

template <typename PointNT> std::vector<double>
RBFPOUReconstruction<PointNT>::weightsAt (const Eigen::Vector3f& pf) const
{
  const Eigen::Vector3d p = pf.cast<double> ();
  std::vector<double> w;
  forCovering (p, [&] (const Subdomain& s) {
    const double x = weight (s, p);
    if (x > 0)
      w.push_back (x);
  });
  const double sum = std::accumulate (w.begin (), w.end (), 0.0);
  for (double& x : w)
    x /= sum;  // Eq. 4.4
  return w;
}

template <typename PointNT> bool
RBFPOUReconstruction<PointNT>::build ()
{
  using namespace rbf_pou_detail;
  stats_ = Stats ();
  error_.clear ();
  pts_.clear (); nrm_.clear (); src_.clear (); off_.clear (); subs_.clear ();
  sub_q_.clear (); sub_lambda_.clear (); buckets_.clear ();

  if (t_min_ < 10)
    return fail ("Tmin must be >= 10 (got " + std::to_string (t_min_) + ")");
  if (t_min_ > t_max_)
    return fail ("Tmin (" + std::to_string (t_min_) + ") > Tmax (" + std::to_string (t_max_) + ")");
  if (!(overlap_ > 1) || !std::isfinite (overlap_))
    return fail ("overlap factor d must be a finite value > 1 (got " + std::to_string (overlap_) + ")");
  if (!grid_auto_ && !(grid_resolution_ > 0 && std::isfinite (grid_resolution_)))
    return fail ("grid resolution must be > 0 (got " + std::to_string (grid_resolution_) + ")");
  if (band_ < 1)
    return fail ("band width must be >= 1 cell (got " + std::to_string (band_) + ")");
  if (!epsilon_auto_ && !(epsilon_ > 0 && std::isfinite (epsilon_)))
    return fail ("off-surface epsilon must be > 0 (got " + std::to_string (epsilon_) + ")");
  if (!std::isfinite (iso_))
    return fail ("iso level must be finite");
  const int nt = threadCount (threads_);

  // --- valid points -------------------------------------------------------------------
  auto t0 = Clock::now ();
  stats_.input_points = indices_->size ();
  for (const auto idx : *indices_)
  {
    const PointNT& q = (*input_)[idx];
    const Eigen::Vector3f p = q.getVector3fMap ();
    const Eigen::Vector3f n = q.getNormalVector3fMap ();
    if (!p.allFinite ())
    {
      ++stats_.dropped_points;
      continue;
    }
    const float len = n.norm ();
    if (!n.allFinite () || !(len > 1e-6f))
    {
      ++stats_.zero_normals;
      continue;
    }
    pts_.push_back (p);
    nrm_.push_back (n / len);
    src_.push_back (idx);
  }
  if (pts_.empty ())
    return fail (stats_.zero_normals ? "no usable normals: all " + std::to_string (stats_.zero_normals) +
                                           " finite points have zero or non-finite normals"
                                     : "no finite input points");
  const std::size_t n = pts_.size ();
  if (3 * n < std::size_t (t_min_))
    return fail ("too few points: " + std::to_string (n) + " valid points give " + std::to_string (3 * n) +
                 " constraints, fewer than Tmin = " + std::to_string (t_min_));
  if (stats_.dropped_points || stats_.zero_normals)
    PCL_WARN ("[pcl::%s] dropped %zu non-finite points and %zu zero / non-finite normals\n",
              getClassName ().c_str (), stats_.dropped_points, stats_.zero_normals);

  pcl::PointCloud<pcl::PointXYZ>::Ptr xyz (new pcl::PointCloud<pcl::PointXYZ>);
  xyz->resize (n);
  for (std::size_t i = 0; i < n; ++i)
    (*xyz)[i].getVector3fMap () = pts_[i];
  pcl::KdTreeFLANN<pcl::PointXYZ> tree (false);
  tree.setInputCloud (xyz);

  double spacing_sum = 0;
#pragma omp parallel for num_threads(nt) reduction(+ : spacing_sum) schedule(static)
  for (std::ptrdiff_t i = 0; i < std::ptrdiff_t (n); ++i)
  {
    pcl::Indices k (2);
    std::vector<float> d (2);
    if (tree.nearestKSearch ((*xyz)[i], 2, k, d) == 2)
      spacing_sum += std::sqrt (d[1]);
  }
  stats_.mean_spacing = spacing_sum / double (n);
  if (!(stats_.mean_spacing > 0))
    return fail ("all valid points coincide (mean spacing 0)");
  stats_.grid_resolution = grid_auto_ ? 1.5 * stats_.mean_spacing : grid_resolution_;
  stats_.epsilon = epsilon_auto_ ? stats_.mean_spacing : epsilon_;

  // --- normals: optional MST orientation, then the neighbour vote ----------------------
  if (orient_normals_)
  {
    pcl::PointCloud<pcl::PointNormal> nc;
    nc.resize (n);
    for (std::size_t i = 0; i < n; ++i)
    {
      nc[i].getVector3fMap () = pts_[i];
      nc[i].getNormalVector3fMap () = nrm_[i];
    }
    pcl::MSTNormalOrientation<pcl::PointXYZ, pcl::PointNormal> mst;
    mst.setInputCloud (xyz);
    mst.setNumberOfThreads (threads_);
    if (!mst.orient (nc))
      return fail ("MST normal orientation failed");
    for (std::size_t i = 0; i < n; ++i)
      nrm_[i] = nc[i].getNormalVector3fMap ();
    stats_.normals_oriented = mst.getNumberOfFlipped ();
  }
  if (normal_vote_ && n > 8)
  {
    // Neighbour lists once; a few Jacobi passes so that small clusters of flips also turn.
    std::vector<int> nn (8 * n, -1);
#pragma omp parallel for num_threads(nt) schedule(static)
    for (std::ptrdiff_t i = 0; i < std::ptrdiff_t (n); ++i)
    {
      pcl::Indices k (9);
      std::vector<float> d (9);
      const int found = tree.nearestKSearch ((*xyz)[i], 9, k, d);
      for (int j = 0, o = 0; j < found && o < 8; ++j)
        if (k[j] != int (i))
          nn[8 * i + o++] = k[j];
    }
    std::vector<char> flip (n, 0);
    for (int pass = 0; pass < 4; ++pass)
    {
      std::size_t changed = 0;
#pragma omp parallel for num_threads(nt) reduction(+ : changed) schedule(static)
      for (std::ptrdiff_t i = 0; i < std::ptrdiff_t (n); ++i)
      {
        int against = 0;
        for (int j = 0; j < 8; ++j)
          against += nn[8 * i + j] >= 0 && nrm_[i].dot (nrm_[nn[8 * i + j]]) < 0;
        flip[i] = nn[8 * i + 7] >= 0 && against >= 6;
        changed += flip[i];
      }
      if (!changed)
        break;
      for (std::size_t i = 0; i < n; ++i)
        if (flip[i])
          nrm_[i] = -nrm_[i];
      stats_.normals_voted += changed;
    }
    if (stats_.normals_voted > n / 10)
      PCL_WARN ("[pcl::%s] %zu of %zu normals disagreed with their neighbours: are the normals oriented? "
                "(setOrientNormals (true) orients them with an MST)\n",
                getClassName ().c_str (), stats_.normals_voted, n);
  }
  stats_.t_prepare = seconds (t0);

  // --- off-surface constraints (Carr et al.: halve ε until the origin is the nearest) ---
  t0 = Clock::now ();
  const float eps0 = float (stats_.epsilon);
  std::vector<float> eps (2 * n, 0.f);
  std::size_t halved = 0;
#pragma omp parallel for num_threads(nt) reduction(+ : halved) schedule(static)
  for (std::ptrdiff_t i = 0; i < std::ptrdiff_t (n); ++i)
  {
    pcl::Indices k (1);
    std::vector<float> d (1);
    for (int side = 0; side < 2; ++side)
    {
      const float sign = side == 0 ? 1.f : -1.f;
      float e = eps0;
      for (int it = 0; it < 12; ++it, e *= 0.5f, ++halved)
      {
        pcl::PointXYZ q;
        q.getVector3fMap () = pts_[i] + sign * e * nrm_[i];
        // Ties (another point exactly as near) count as failures.
        if (tree.nearestKSearch (q, 1, k, d) == 1 &&
            (k[0] == int (i) || d[0] > (q.getVector3fMap () - pts_[i]).squaredNorm () * (1.f + 1e-5f)))
        {
          eps[2 * i + side] = sign * e;
          break;
        }
      }
    }
  }
  off_.reserve (2 * n);
  for (std::size_t i = 0; i < 2 * n; ++i)
  {
    const float e = eps[i];
    if (e == 0.f)
    {
      ++stats_.off_surface_dropped;
      continue;
    }
    off_.push_back ({pts_[i / 2] + e * nrm_[i / 2], e, int (i / 2)});
  }
  stats_.eps_halved = halved - stats_.off_surface_dropped * 12;
  stats_.off_surface_points = off_.size ();
  stats_.t_off_surface = seconds (t0);

  // --- octree partition of unity (§4.3.2) ----------------------------------------------
  t0 = Clock::now ();
  const std::size_t nc = n + off_.size ();
  auto centre_of = [&] (std::uint32_t c) -> const Eigen::Vector3f& { return c < n ? pts_[c] : off_[c - n].p; };
  Eigen::Vector3f bmin = pts_[0], bmax = pts_[0];
  for (std::uint32_t c = 0; c < nc; ++c)
  {
    bmin = bmin.cwiseMin (centre_of (c));
    bmax = bmax.cwiseMax (centre_of (c));
  }
  struct Node
  {
    Eigen::Vector3d c;
    double half;  // of the octree cell
    int depth;
    std::vector<std::uint32_t> ids;  // constraints in the enlarged cell
  };
  struct Leaf
  {
    Eigen::Vector3d c;
    double half;  // of the enlarged box
    std::vector<std::uint32_t> ids;
  };
  std::vector<Leaf> leaves;
  {
    std::vector<Node> stack;
    Node root;
    root.c = 0.5 * (bmin + bmax).cast<double> ();
    root.half = 0.5 * double ((bmax - bmin).maxCoeff ()) * 1.001 + 1e-9;
    root.depth = 0;
    root.ids.resize (nc);
    std::iota (root.ids.begin (), root.ids.end (), 0u);
    stack.push_back (std::move (root));
    while (!stack.empty ())
    {
      Node node = std::move (stack.back ());
      stack.pop_back ();
      if (int (node.ids.size ()) <= t_max_ || node.depth >= 20)
      {
        stats_.over_tmax += int (node.ids.size ()) > t_max_;
        leaves.push_back ({node.c, overlap_ * node.half, std::move (node.ids)});
        continue;
      }
      // Children enlarged by d stay inside the parent's enlarged box (d ≥ 1): filter its list.
      for (int o = 0; o < 8; ++o)
      {
        Node child;
        child.half = node.half / 2;
        child.depth = node.depth + 1;
        child.c = node.c + child.half * Eigen::Vector3d (o & 1 ? 1 : -1, o & 2 ? 1 : -1, o & 4 ? 1 : -1);
        const double r = overlap_ * child.half;
        for (const auto id : node.ids)
          if (((centre_of (id).template cast<double> () - child.c).array ().abs () < r).all ())
            child.ids.push_back (id);
        if (!child.ids.empty ())
          stack.push_back (std::move (child));
      }
    }
  }

  // Grow leaves below Tmin (factor 1.25 per step, at most 4×), shrinking back by bisection
  // when a step overshoots Tmax; leaves that cannot reach Tmin are dropped.
  pcl::PointCloud<pcl::PointXYZ>::Ptr cxyz (new pcl::PointCloud<pcl::PointXYZ>);
  cxyz->resize (nc);
  for (std::uint32_t c = 0; c < nc; ++c)
    (*cxyz)[c].getVector3fMap () = centre_of (c);
  pcl::KdTreeFLANN<pcl::PointXYZ> ctree (false);
  ctree.setInputCloud (cxyz);
  std::vector<char> keep (leaves.size (), 1);
  std::vector<std::uint32_t> sub_centres;  // constraint ids of every subdomain, until fitted
  std::vector<double> scale (leaves.size (), 1.0);
  std::size_t grown = 0;
#pragma omp parallel for num_threads(nt) reduction(+ : grown) schedule(dynamic, 16)
  for (std::ptrdiff_t l = 0; l < std::ptrdiff_t (leaves.size ()); ++l)
  {
    Leaf& leaf = leaves[l];
    if (int (leaf.ids.size ()) >= t_min_)
      continue;
    ++grown;
    pcl::PointXYZ q;
    q.getVector3fMap () = leaf.c.template cast<float> ();
    pcl::Indices k;
    std::vector<float> d;
    auto inBox = [&] (double f, std::vector<std::uint32_t>* out) {
      const double h = leaf.half * f;
      ctree.radiusSearch (q, float (h * std::sqrt (3.0) * 1.0001), k, d);
      int count = 0;
      for (const auto id : k)
        if (((centre_of (id).template cast<double> () - leaf.c).array ().abs () < h).all ())
        {
          ++count;
          if (out)
            out->push_back (std::uint32_t (id));
        }
      return count;
    };
    double lo = 1, f = 1;
    int count = int (leaf.ids.size ());
    while (count < t_min_ && f < 4)
    {
      lo = f;
      f *= 1.25;
      count = inBox (f, nullptr);
    }
    if (count < t_min_)
    {
      keep[l] = 0;
      continue;
    }
    double hi = f;
    for (int it = 0; it < 10 && count > t_max_; ++it)
    {
      const double mid = 0.5 * (lo + hi);
      const int c = inBox (mid, nullptr);
      if (c < t_min_)
        lo = mid;
      else
      {
        hi = mid;
        count = c;
      }
    }
    scale[l] = hi;
    leaf.ids.clear ();
    inBox (hi, &leaf.ids);
    std::sort (leaf.ids.begin (), leaf.ids.end ());
  }
  stats_.grown = grown;
  for (std::size_t l = 0; l < leaves.size (); ++l)
  {
    if (!keep[l])
      continue;
    Subdomain s;
    const double h = leaves[l].half * scale[l];
    s.centre = leaves[l].c;
    s.lo = s.centre.array () - h;
    s.hi = s.centre.array () + h;
    s.scale = h;
    s.poly.setZero ();
    s.first = std::uint32_t (sub_centres.size ());
    s.count = std::uint32_t (leaves[l].ids.size ());
    stats_.over_tmax += leaves[l].ids.size () > std::size_t (t_max_) && scale[l] > 1;
    sub_centres.insert (sub_centres.end (), leaves[l].ids.begin (), leaves[l].ids.end ());
    subs_.push_back (s);
  }
  leaves.clear ();
  leaves.shrink_to_fit ();
  stats_.subdomains = subs_.size ();
  if (subs_.empty ())
    return fail ("no subdomain reached Tmin = " + std::to_string (t_min_) + " constraints");

  // Lookup buckets of the median subdomain size.
  {
    std::vector<double> sizes (subs_.size ());
    Eigen::Vector3d o = subs_[0].lo;
    for (std::size_t i = 0; i < subs_.size (); ++i)
    {
      sizes[i] = 2 * subs_[i].scale;
      o = o.cwiseMin (subs_[i].lo);
    }
    std::nth_element (sizes.begin (), sizes.begin () + sizes.size () / 2, sizes.end ());
    bucket_size_ = sizes[sizes.size () / 2];
    bucket_origin_ = o.array () - bucket_size_;
    for (std::uint32_t i = 0; i < subs_.size (); ++i)
    {
      const Eigen::Array3i a = ((subs_[i].lo - bucket_origin_) / bucket_size_).array ().floor ().template cast<int> ();
      const Eigen::Array3i b = ((subs_[i].hi - bucket_origin_) / bucket_size_).array ().floor ().template cast<int> ();
      for (int z = a[2]; z <= b[2]; ++z)
        for (int y = a[1]; y <= b[1]; ++y)
          for (int x = a[0]; x <= b[0]; ++x)
            buckets_.emplace_back (pack (x, y, z), i);
    }
    std::sort (buckets_.begin (), buckets_.end ());
  }
  stats_.t_octree = seconds (t0);

  // --- local fits: [A P; Pᵀ 0] [λ; c] = [h; 0], A_jk = |q_j − q_k|³ -------------------
  t0 = Clock::now ();
  sub_lambda_.assign (sub_centres.size (), 0.0);
  sub_q_.assign (3 * sub_centres.size (), 0.f);
  std::size_t fallbacks = 0;
#pragma omp parallel for num_threads(nt) reduction(+ : fallbacks) schedule(dynamic, 4)
  for (std::ptrdiff_t si = 0; si < std::ptrdiff_t (subs_.size ()); ++si)
  {
    Subdomain& s = subs_[si];
    const int m = int (s.count);
    Eigen::MatrixXd q (3, m);
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero (m + 4);
    for (int j = 0; j < m; ++j)
    {
      const std::uint32_t c = sub_centres[s.first + j];
      q.col (j) = (centre_of (c).template cast<double> () - s.centre) / s.scale;  // conditioning
      for (int r = 0; r < 3; ++r)
        sub_q_[3 * (std::size_t (s.first) + j) + r] = float (q (r, j));
      q.col (j) = Eigen::Vector3f (&sub_q_[3 * (std::size_t (s.first) + j)]).template cast<double> ();
      rhs[j] = c < n ? 0.0 : double (off_[c - n].value);
    }
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero (m + 4, m + 4);
    for (int j = 0; j < m; ++j)
    {
      for (int k = 0; k < j; ++k)
      {
        const double r = (q.col (j) - q.col (k)).norm ();
        a (j, k) = a (k, j) = r * r * r;
      }
      a (j, m) = a (m, j) = 1;
      for (int r = 0; r < 3; ++r)
        a (j, m + 1 + r) = a (m + 1 + r, j) = q (r, j);
    }
    Eigen::VectorXd x = a.partialPivLu ().solve (rhs);
    // Duplicated centres or too few distinct ones make the system singular: least squares.
    if (!x.allFinite () || (a * x - rhs).norm () > 1e-6 * rhs.norm () + 1e-12)
    {
      x = a.completeOrthogonalDecomposition ().solve (rhs);
      ++fallbacks;
    }
    for (int j = 0; j < m; ++j)
      sub_lambda_[s.first + j] = x[j];
    s.poly = x.tail<4> ();
  }
  stats_.fit_fallbacks = fallbacks;
  stats_.t_fits = seconds (t0);
  return true;
}

template <typename PointNT> void
RBFPOUReconstruction<PointNT>::extract (PointCloud<PointNT>& points, std::vector<Vertices>& polygons)
{
  using namespace rbf_pou_detail;
  const auto t0 = Clock::now ();
  const int nt = threadCount (threads_);
  const double h = stats_.grid_resolution;
  Eigen::Vector3f bmin = pts_[0], bmax = pts_[0];
  for (const auto& p : pts_)
  {
    bmin = bmin.cwiseMin (p);
    bmax = bmax.cwiseMax (p);
  }
  const Eigen::Vector3d origin = bmin.cast<double> ().array () - (band_ + 2) * h;
  const Eigen::Vector3d extent = (bmax.cast<double> () - origin).array () / h + band_ + 3;
  if (extent.maxCoeff () >= double (kMaxIndex))
  {
    fail ("grid resolution " + std::to_string (h) + " too fine for the extent (more than 2^20 cells per axis)");
    return;
  }

  // Active cells: cells holding a point, dilated by the band (one axis at a time).
  std::vector<std::uint64_t> cells (pts_.size ());
  for (std::size_t i = 0; i < pts_.size (); ++i)
  {
    const Eigen::Array3d c = ((pts_[i].cast<double> () - origin) / h).array ().floor ();
    cells[i] = pack (std::int64_t (c[0]), std::int64_t (c[1]), std::int64_t (c[2]));
  }
  sortUnique (cells);
  for (int axis = 0; axis < 3; ++axis)
    dilate (cells, axis, -band_, band_);
  stats_.active_cells = cells.size ();

  std::vector<std::uint64_t> corners = cells;  // corners: cells dilated by {0, 1}³
  for (int axis = 0; axis < 3; ++axis)
    dilate (corners, axis, 0, 1);
  stats_.corners = corners.size ();
  auto position = [&] (std::uint64_t key) {
    return Eigen::Vector3d (origin + unpack (key).cast<double> ().matrix () * h);
  };
  std::vector<double> value (corners.size ());
  std::size_t uncovered = 0;
#pragma omp parallel for num_threads(nt) reduction(+ : uncovered) schedule(dynamic, 256)
  for (std::ptrdiff_t i = 0; i < std::ptrdiff_t (corners.size ()); ++i)
  {
    value[i] = evaluate (position (corners[i]).template cast<float> ()) - iso_;
    uncovered += std::isnan (value[i]);
  }
  stats_.uncovered_corners = uncovered;
  auto cornerIndex = [&] (std::uint64_t key) {
    return std::size_t (std::lower_bound (corners.begin (), corners.end (), key) - corners.begin ());
  };

  // Marching cubes with PCL's tables; a vertex is named by its grid edge, so cells that
  // share an edge share the vertex.
  std::vector<std::uint8_t> cube (cells.size (), 0);
  std::vector<std::size_t> tri_count (cells.size () + 1, 0);
#pragma omp parallel for num_threads(nt) schedule(static)
  for (std::ptrdiff_t ci = 0; ci < std::ptrdiff_t (cells.size ()); ++ci)
  {
    const Eigen::Array3i c = unpack (cells[ci]);
    int index = 0;
    bool defined = true;
    for (int v = 0; v < 8; ++v)
    {
      const std::uint64_t key = pack (c[0] + kCorner[v][0], c[1] + kCorner[v][1], c[2] + kCorner[v][2]);
      const double x = value[cornerIndex (key)];
      defined = defined && !std::isnan (x);
      if (x < 0)
        index |= 1 << v;
    }
    if (!defined || edgeTable[index] == 0)
      continue;
    cube[ci] = std::uint8_t (index);
    int t = 0;
    while (triTable[index][3 * t] != -1)
      ++t;
    tri_count[ci + 1] = t;
  }
  std::partial_sum (tri_count.begin (), tri_count.end (), tri_count.begin ());
  std::vector<std::uint64_t> tri_edges (3 * tri_count.back ());
#pragma omp parallel for num_threads(nt) schedule(static)
  for (std::ptrdiff_t ci = 0; ci < std::ptrdiff_t (cells.size ()); ++ci)
  {
    if (tri_count[ci + 1] == tri_count[ci])
      continue;
    const Eigen::Array3i c = unpack (cells[ci]);
    const int index = cube[ci];
    std::size_t out = 3 * tri_count[ci];
    for (int i = 0; triTable[index][i] != -1; ++i)
    {
      const int* a = kCorner[kEdge[triTable[index][i]][0]];
      const int* b = kCorner[kEdge[triTable[index][i]][1]];
      int axis = 0;
      while (a[axis] == b[axis])
        ++axis;
      const int* low = a[axis] < b[axis] ? a : b;
      tri_edges[out++] = 4 * pack (c[0] + low[0], c[1] + low[1], c[2] + low[2]) + std::uint64_t (axis);
    }
  }
  std::vector<std::uint64_t> edges = tri_edges;
  sortUnique (edges);

  // Vertices: linear interpolation on the edge; attributes from the nearest input point.
  points.clear ();
  points.resize (edges.size ());
  points.width = std::uint32_t (edges.size ());
  points.height = 1;
  points.is_dense = true;
  pcl::PointCloud<pcl::PointXYZ>::Ptr xyz (new pcl::PointCloud<pcl::PointXYZ>);
  xyz->resize (pts_.size ());
  for (std::size_t i = 0; i < pts_.size (); ++i)
    (*xyz)[i].getVector3fMap () = pts_[i];
  pcl::KdTreeFLANN<pcl::PointXYZ> tree (false);
  tree.setInputCloud (xyz);
#pragma omp parallel for num_threads(nt) schedule(static)
  for (std::ptrdiff_t i = 0; i < std::ptrdiff_t (edges.size ()); ++i)
  {
    const std::uint64_t k0 = edges[i] >> 2;
    const int axis = int (edges[i] & 3);
    Eigen::Array3i c1 = unpack (k0);
    c1[axis] += 1;
    const std::uint64_t k1 = pack (c1[0], c1[1], c1[2]);
    const double v0 = value[cornerIndex (k0)], v1 = value[cornerIndex (k1)];
    const double t = v0 == v1 ? 0.5 : std::clamp (v0 / (v0 - v1), 0.0, 1.0);
    const Eigen::Vector3d p = (1 - t) * position (k0) + t * position (k1);
    pcl::PointXYZ q;
    q.getVector3fMap () = p.cast<float> ();
    pcl::Indices nn (1);
    std::vector<float> d (1);
    PointNT out;
    if (tree.nearestKSearch (q, 1, nn, d) == 1)
      out = (*input_)[src_[nn[0]]];
    out.getVector3fMap () = q.getVector3fMap ();
    out.getNormalVector3fMap ().setZero ();
    out.curvature = 0;
    points[i] = out;
  }
  // The grid is no longer needed: free it before the polygons are allocated (peak memory).
  const std::size_t n_tri = tri_count.back ();
  std::vector<std::uint64_t> ().swap (cells);
  std::vector<std::uint64_t> ().swap (corners);
  std::vector<double> ().swap (value);
  std::vector<std::uint8_t> ().swap (cube);
  std::vector<std::size_t> ().swap (tri_count);
  polygons.resize (n_tri);
#pragma omp parallel for num_threads(nt) schedule(static)
  for (std::ptrdiff_t t = 0; t < std::ptrdiff_t (polygons.size ()); ++t)
  {
    polygons[t].vertices.resize (3);
    for (int j = 0; j < 3; ++j)
      polygons[t].vertices[j] = std::uint32_t (
          std::lower_bound (edges.begin (), edges.end (), tri_edges[3 * t + j]) - edges.begin ());
  }
  // Vertex normals: area-weighted face normals.
  for (const auto& poly : polygons)
  {
    const Eigen::Vector3f a = points[poly.vertices[0]].getVector3fMap ();
    const Eigen::Vector3f fn = (points[poly.vertices[1]].getVector3fMap () - a)
                                   .cross (points[poly.vertices[2]].getVector3fMap () - a);
    for (const auto v : poly.vertices)
      points[v].getNormalVector3fMap () += fn;
  }
  for (auto& p : points)
  {
    const float len = p.getNormalVector3fMap ().norm ();
    if (len > 0)
      p.getNormalVector3fMap () /= len;
  }
  stats_.vertices = points.size ();
  stats_.triangles = polygons.size ();
  stats_.t_extraction = seconds (t0);
}

template <typename PointNT> void
RBFPOUReconstruction<PointNT>::performReconstruction (PointCloud<PointNT>& points, std::vector<Vertices>& polygons)
{
  points.clear ();
  polygons.clear ();
  if (!build ())
    return;
  extract (points, polygons);
  if (!error_.empty ())
  {
    points.clear ();
    polygons.clear ();
  }
}

template <typename PointNT> void
RBFPOUReconstruction<PointNT>::performReconstruction (PolygonMesh& output)
{
  PointCloud<PointNT> points;
  performReconstruction (points, output.polygons);
  pcl::toPCLPointCloud2 (points, output.cloud);
}

}  // namespace pcl
