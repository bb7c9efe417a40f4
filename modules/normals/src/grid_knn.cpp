#include <pclx/normals/detail/grid_knn.h>

#include <algorithm>
#include <cmath>
#include <omp.h>
#include <parallel/algorithm>

namespace pclx {
namespace normals {
namespace detail {

namespace {
constexpr std::int64_t kAxisCells = (std::int64_t (1) << 21) - 1;  // 21 bits per axis in a key
}

std::uint64_t
GridKnn::key (std::int64_t x, std::int64_t y, std::int64_t z) const
{
  return (static_cast<std::uint64_t> (x) * static_cast<std::uint64_t> (dims_[1]) + static_cast<std::uint64_t> (y)) *
             static_cast<std::uint64_t> (dims_[2]) +
         static_cast<std::uint64_t> (z);
}

void
GridKnn::build (const std::vector<Eigen::Vector3f>& points, int points_per_cell, int threads)
{
  const int n = static_cast<int> (points.size ());
  cell_keys_.clear ();
  cell_start_.clear ();
  ids_.clear ();
  points_.clear ();
  column_start_.clear ();
  if (n == 0)
    return;
  if (threads <= 0)
    threads = omp_get_max_threads ();
  // Bounds, the keys' radix sort and the copy run in parallel: a serial stretch keeps the
  // other thread spinning in OpenMP's wait (CPU time) and, on a shared machine, off the core.
  Eigen::Vector3d lo = points[0].cast<double> (), hi = lo;
#pragma omp parallel num_threads(threads)
  {
    Eigen::Vector3d l = lo, h = hi;
#pragma omp for schedule(static) nowait
    for (int i = 0; i < n; ++i)
    {
      l = l.cwiseMin (points[i].cast<double> ());
      h = h.cwiseMax (points[i].cast<double> ());
    }
#pragma omp critical
    {
      lo = lo.cwiseMin (l);
      hi = hi.cwiseMax (h);
    }
  }
  origin_ = lo;
  const double extent = (hi - lo).maxCoeff ();
  const double diag = (hi - lo).norm ();
  // A surface's spacing is about diag / sqrt(n); the subsample (same cells at its own,
  // coarser spacing) measures how many points a cell really gets and rescales once.
  double cell = diag > 0 ? diag / std::sqrt (static_cast<double> (n)) * std::sqrt (static_cast<double> (points_per_cell)) : 1.0;
  const int step = std::max (1, n / 16384);
  if (diag > 0 && step > 1)
  {
    const double sub_cell = cell * std::sqrt (static_cast<double> (step));
    std::vector<std::uint64_t> sample;
    for (int i = 0; i < n; i += step)
    {
      const Eigen::Vector3d c = ((points[i].cast<double> () - lo) / sub_cell).array ().floor ();
      // Any injective key counts the occupied cells (the subsample's cells are not ours).
      sample.push_back ((static_cast<std::uint64_t> (c.x ()) << 42) | (static_cast<std::uint64_t> (c.y ()) << 21) |
                        static_cast<std::uint64_t> (c.z ()));
    }
    std::sort (sample.begin (), sample.end ());
    const double occupied = static_cast<double> (std::unique (sample.begin (), sample.end ()) - sample.begin ());
    const double per_cell = static_cast<double> (sample.size ()) / occupied;
    cell *= std::sqrt (points_per_cell / per_cell);
  }
  cell = std::max (cell, extent / static_cast<double> (kAxisCells - 1));
  if (!(cell > 0))
    cell = 1.0;
  cell_ = cell;
  for (int a = 0; a < 3; ++a)
    dims_[a] = std::min<std::int64_t> (kAxisCells, static_cast<std::int64_t> (std::floor ((hi[a] - lo[a]) / cell)) + 1);

  // Cell keys, then an LSD radix sort (11-bit digits, only as many as the keys use: 3 passes
  // for a million points on a surface) instead of a comparison sort, which would dominate
  // the build. Each pass counts and scatters by thread over contiguous chunks, the
  // threads' slots of a digit in chunk order: stable, so the order is the serial one.
  std::vector<std::uint64_t> keys (n), keys2 (n);
  std::vector<int> order (n), order2 (n);
#pragma omp parallel for num_threads(threads) schedule(static)
  for (int i = 0; i < n; ++i)
  {
    std::int64_t c[3];
    for (int a = 0; a < 3; ++a)
      c[a] = std::min<std::int64_t> (dims_[a] - 1, std::max<std::int64_t> (0, static_cast<std::int64_t> (
                                                                                 std::floor ((points[i][a] - lo[a]) / cell))));
    keys[i] = key (c[0], c[1], c[2]);
    order[i] = i;
  }
  const std::uint64_t max_key = key (dims_[0] - 1, dims_[1] - 1, dims_[2] - 1);
  constexpr int kDigit = 11;
  constexpr int kDigits = 1 << kDigit;
  std::vector<int> count (static_cast<std::size_t> (threads) * kDigits);
  for (int shift = 0; shift < 64 && (max_key >> shift) > 0; shift += kDigit)
  {
    const std::uint64_t mask = kDigits - 1;
#pragma omp parallel num_threads(threads)
    {
      const int t = omp_get_thread_num (), nt = omp_get_num_threads ();
      const int begin = static_cast<int> (static_cast<std::int64_t> (n) * t / nt);
      const int end = static_cast<int> (static_cast<std::int64_t> (n) * (t + 1) / nt);
      int* const mine = count.data () + static_cast<std::size_t> (t) * kDigits;
      std::fill (mine, mine + kDigits, 0);
      for (int i = begin; i < end; ++i)
        ++mine[(keys[i] >> shift) & mask];
#pragma omp barrier
#pragma omp single
      {
        int sum = 0;
        for (int d = 0; d < kDigits; ++d)
          for (int u = 0; u < nt; ++u)
          {
            int& c = count[static_cast<std::size_t> (u) * kDigits + d];
            const int here = c;
            c = sum;
            sum += here;
          }
      }
      for (int i = begin; i < end; ++i)
      {
        const int to = mine[(keys[i] >> shift) & mask]++;
        keys2[to] = keys[i];
        order2[to] = order[i];
      }
    }
    keys.swap (keys2);
    order.swap (order2);
  }
  ids_.swap (order);
  points_.resize (n);
#pragma omp parallel for num_threads(threads) schedule(static)
  for (int i = 0; i < n; ++i)
    points_[i] = points[ids_[i]];
  for (int i = 0; i < n; ++i)
    if (i == 0 || keys[i] != keys[i - 1])
    {
      cell_keys_.push_back (keys[i]);
      cell_start_.push_back (i);
    }
  cell_start_.push_back (n);
  const std::uint64_t columns = static_cast<std::uint64_t> (dims_[0]) * static_cast<std::uint64_t> (dims_[1]);
  if (columns <= std::max<std::uint64_t> (std::uint64_t (1) << 16, 4 * static_cast<std::uint64_t> (n)))
  {
    column_start_.assign (columns + 1, 0);
    for (const auto k : cell_keys_)
      ++column_start_[k / static_cast<std::uint64_t> (dims_[2]) + 1];
    for (std::size_t c = 1; c < column_start_.size (); ++c)
      column_start_[c] += column_start_[c - 1];
  }
}

std::pair<int, int>
GridKnn::runRange (std::int64_t x, std::int64_t y, std::int64_t z0, std::int64_t z1) const
{
  std::size_t b, e;
  if (!column_start_.empty ())
  {
    // A surface crosses a column in a few cells: walk them.
    const std::size_t col = static_cast<std::size_t> (x * dims_[1] + y);
    b = column_start_[col];
    e = column_start_[col + 1];
    const std::uint64_t k0 = key (x, y, z0), k1 = key (x, y, z1);
    while (b < e && cell_keys_[b] < k0)
      ++b;
    std::size_t last = b;
    while (last < e && cell_keys_[last] <= k1)
      ++last;
    e = last;
  }
  else
  {
    b = std::lower_bound (cell_keys_.begin (), cell_keys_.end (), key (x, y, z0)) - cell_keys_.begin ();
    e = std::upper_bound (cell_keys_.begin () + b, cell_keys_.end (), key (x, y, z1)) - cell_keys_.begin ();
  }
  if (b >= e)
    return {0, 0};
  return {cell_start_[b], cell_start_[e]};
}

int
GridKnn::nearestK (const Eigen::Vector3f& q, int k, std::vector<int>& indices, std::vector<float>& sqr_distances,
                   std::vector<std::uint64_t>& scratch, std::vector<Eigen::Vector3f>* positions,
                   float* radius_hint) const
{
  indices.clear ();
  sqr_distances.clear ();
  scratch.clear ();
  if (positions)
    positions->clear ();
  if (k <= 0 || ids_.empty () || !q.allFinite ())
    return 0;
  // The query's cell (may lie outside the grid) and its distance to that cell's faces:
  // the cube of rings 0..R covers the ball of radius R * cell + dmin around q.
  std::int64_t c[3];
  double dmin = cell_;
  std::int64_t r_first = 0, r_all = 0;  // rings before r_first are empty; r_all covers the grid
  for (int a = 0; a < 3; ++a)
  {
    const double u = (q[a] - origin_[a]) / cell_;
    const double f = std::floor (std::max (-1e12, std::min (1e12, u)));
    c[a] = static_cast<std::int64_t> (f);
    dmin = std::min (dmin, std::min (u - f, f + 1 - u) * cell_);
    r_first = std::max (r_first, std::max (-c[a], c[a] - (dims_[a] - 1)));
    r_all = std::max (r_all, std::max (c[a], dims_[a] - 1 - c[a]));
  }
  dmin = std::max (0.0, dmin);
  auto emit = [&] (int m) {
    for (int i = 0; i < m; ++i)
    {
      const auto slot = slotOfKey (scratch[i]);
      indices.push_back (ids_[slot]);
      sqr_distances.push_back (distanceOfKey (scratch[i]));
      if (positions)
        positions->push_back (points_[slot]);
    }
    return m;
  };
  // With a radius hint: only the cells that meet the ball of that radius, keeping the points
  // inside it. If k are inside, they hold the k nearest (every point outside is farther).
  // Consecutive queries of a caller are usually neighbours, so the last query's k-th distance
  // is a tight hint: this scans about half the points of the cube of rings below.
  if (radius_hint && *radius_hint > 0 && std::isfinite (*radius_hint))
  {
    const double r = *radius_hint;
    const float r2 = static_cast<float> (r * r);
    // Cells are enumerated for a slightly larger ball, so float rounding never drops a point.
    const double re = r * (1 + 1e-5) + 1e-6 * cell_;
    const double re2 = re * re;
    std::int64_t lo_c[3], hi_c[3];
    Eigen::Vector3d u;
    for (int a = 0; a < 3; ++a)
    {
      u[a] = (q[a] - origin_[a]) / cell_;
      lo_c[a] = static_cast<std::int64_t> (std::floor (std::max (-1e12, std::min (1e12, u[a] - re / cell_))));
      hi_c[a] = static_cast<std::int64_t> (std::floor (std::max (-1e12, std::min (1e12, u[a] + re / cell_))));
      lo_c[a] = std::max<std::int64_t> (lo_c[a], 0);
      hi_c[a] = std::min (hi_c[a], dims_[a] - 1);
    }
    // Distance (in cells) from u to the slab [c, c + 1] along one axis.
    auto gap = [] (double u, std::int64_t c) { return u < c ? c - u : (u > c + 1 ? u - (c + 1) : 0.0); };
    const double re2_cells = re2 / (cell_ * cell_);
    for (std::int64_t x = lo_c[0]; x <= hi_c[0]; ++x)
    {
      const double gx = gap (u[0], x);
      const double gx2 = gx * gx;
      if (gx2 > re2_cells)
        continue;
      for (std::int64_t y = lo_c[1]; y <= hi_c[1]; ++y)
      {
        const double gy = gap (u[1], y);
        const double gxy2 = gx2 + gy * gy;
        if (gxy2 > re2_cells)
          continue;
        const double rz = std::sqrt (re2_cells - gxy2);
        const std::int64_t z0 = std::max<std::int64_t> (lo_c[2], static_cast<std::int64_t> (std::floor (u[2] - rz)));
        const std::int64_t z1 = std::min<std::int64_t> (hi_c[2], static_cast<std::int64_t> (std::floor (u[2] + rz)));
        if (z0 > z1)
          continue;
        const auto range = runRange (x, y, z0, z1);
        for (int i = range.first; i < range.second; ++i)
        {
          const float d2 = (points_[i] - q).squaredNorm ();
          if (d2 <= r2)
            scratch.push_back (distanceSlotKey (d2, static_cast<std::uint32_t> (i)));
        }
      }
    }
    if (static_cast<int> (scratch.size ()) >= k)
    {
      std::nth_element (scratch.begin (), scratch.begin () + (k - 1), scratch.end ());
      // The next query's hint: this k-th distance with a margin for a sparser neighbourhood.
      *radius_hint = 1.15f * std::sqrt (distanceOfKey (scratch[k - 1]));
      return emit (k);
    }
    scratch.clear ();
  }
  // Candidates as distanceSlotKey integers (slot: the point's place in the grid's order).
  auto scan = [&] (int begin, int end) {
    for (int i = begin; i < end; ++i)
      scratch.push_back (distanceSlotKey ((points_[i] - q).squaredNorm (), static_cast<std::uint32_t> (i)));
  };
  // Keys of cells along z are consecutive: a z-run is one key range.
  auto scanRun = [&] (std::int64_t x, std::int64_t y, std::int64_t z0, std::int64_t z1) {
    z0 = std::max<std::int64_t> (z0, 0);
    z1 = std::min<std::int64_t> (z1, dims_[2] - 1);
    if (z0 > z1)
      return;
    const auto r = runRange (x, y, z0, z1);
    scan (r.first, r.second);
  };
  for (std::int64_t R = r_first;; ++R)
  {
    const std::int64_t x0 = std::max<std::int64_t> (0, c[0] - R), x1 = std::min (dims_[0] - 1, c[0] + R);
    const std::int64_t y0 = std::max<std::int64_t> (0, c[1] - R), y1 = std::min (dims_[1] - 1, c[1] + R);
    for (std::int64_t x = x0; x <= x1; ++x)
      for (std::int64_t y = y0; y <= y1; ++y)
      {
        if (std::abs (x - c[0]) == R || std::abs (y - c[1]) == R)
          scanRun (x, y, c[2] - R, c[2] + R);
        else
        {
          scanRun (x, y, c[2] - R, c[2] - R);
          if (R > 0)
            scanRun (x, y, c[2] + R, c[2] + R);
        }
      }
    const bool all = R >= r_all;
    if (static_cast<int> (scratch.size ()) >= k || all)
    {
      // Done when k points lie inside the covered ball: counted first, so the selection
      // runs once per query, not once per ring.
      const double covered = static_cast<double> (R) * cell_ + dmin;
      const double covered2 = covered * covered;
      int inside = 0;
      if (!all)
        for (const auto s : scratch)
          inside += distanceOfKey (s) <= covered2;
      if (all || inside >= k)
      {
        const int m = std::min<int> (k, static_cast<int> (scratch.size ()));
        // The k nearest are among the points inside: select among those only.
        const auto end = all ? scratch.end ()
                             : std::partition (scratch.begin (), scratch.end (),
                                               [&] (std::uint64_t s) { return distanceOfKey (s) <= covered2; });
        if (m > 0)
          std::nth_element (scratch.begin (), scratch.begin () + (m - 1), end);
        if (radius_hint && m == k)
          *radius_hint = 1.15f * std::sqrt (distanceOfKey (scratch[m - 1]));
        return emit (m);
      }
    }
  }
}

}  // namespace detail
}  // namespace normals
}  // namespace pclx
