#include <pclx/normals/grid_knn.h>

#include <algorithm>
#include <cmath>
#include <omp.h>
#include <parallel/algorithm>

namespace pclx {
namespace normals {

namespace {
constexpr std::int64_t kAxisCells = (std::int64_t (1) << 21) - 1;  // 21 bits per axis in a key
}

std::uint64_t
GridKnn::key (std::int64_t x, std::int64_t y, std::int64_t z) const
{
  return (static_cast<std::uint64_t> (x) << 42) | (static_cast<std::uint64_t> (y) << 21) | static_cast<std::uint64_t> (z);
}

void
GridKnn::build (const std::vector<Eigen::Vector3f>& points, int points_per_cell, int threads)
{
  const int n = static_cast<int> (points.size ());
  cell_keys_.clear ();
  cell_start_.clear ();
  ids_.clear ();
  points_.clear ();
  if (n == 0)
    return;
  if (threads <= 0)
    threads = omp_get_max_threads ();
  Eigen::Vector3d lo = points[0].cast<double> (), hi = lo;
  for (const auto& p : points)
  {
    lo = lo.cwiseMin (p.cast<double> ());
    hi = hi.cwiseMax (p.cast<double> ());
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
      sample.push_back (key (static_cast<std::int64_t> (c.x ()), static_cast<std::int64_t> (c.y ()),
                             static_cast<std::int64_t> (c.z ())) );
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

  std::vector<std::pair<std::uint64_t, int>> keyed (n);
#pragma omp parallel for num_threads(threads) schedule(static)
  for (int i = 0; i < n; ++i)
  {
    std::int64_t c[3];
    for (int a = 0; a < 3; ++a)
      c[a] = std::min<std::int64_t> (dims_[a] - 1, std::max<std::int64_t> (0, static_cast<std::int64_t> (
                                                                                 std::floor ((points[i][a] - lo[a]) / cell))));
    keyed[i] = {key (c[0], c[1], c[2]), i};
  }
  __gnu_parallel::sort (keyed.begin (), keyed.end (), __gnu_parallel::default_parallel_tag (threads));
  ids_.resize (n);
  points_.resize (n);
#pragma omp parallel for num_threads(threads) schedule(static)
  for (int i = 0; i < n; ++i)
  {
    ids_[i] = keyed[i].second;
    points_[i] = points[keyed[i].second];
  }
  for (int i = 0; i < n; ++i)
    if (i == 0 || keyed[i].first != keyed[i - 1].first)
    {
      cell_keys_.push_back (keyed[i].first);
      cell_start_.push_back (i);
    }
  cell_start_.push_back (n);
}

std::pair<int, int>
GridKnn::cellRange (std::int64_t x, std::int64_t y, std::int64_t z) const
{
  const auto it = std::lower_bound (cell_keys_.begin (), cell_keys_.end (), key (x, y, z));
  if (it == cell_keys_.end () || *it != key (x, y, z))
    return {0, 0};
  const auto c = it - cell_keys_.begin ();
  return {cell_start_[c], cell_start_[c + 1]};
}

int
GridKnn::nearestK (const Eigen::Vector3f& q, int k, std::vector<int>& indices, std::vector<float>& sqr_distances,
                   std::vector<std::pair<float, int>>& scratch) const
{
  indices.clear ();
  sqr_distances.clear ();
  scratch.clear ();
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
  auto scan = [&] (int begin, int end) {
    for (int i = begin; i < end; ++i)
      scratch.emplace_back ((points_[i] - q).squaredNorm (), ids_[i]);
  };
  // Keys of cells along z are consecutive: a z-run is one key range.
  auto scanRun = [&] (std::int64_t x, std::int64_t y, std::int64_t z0, std::int64_t z1) {
    z0 = std::max<std::int64_t> (z0, 0);
    z1 = std::min<std::int64_t> (z1, dims_[2] - 1);
    if (z0 > z1)
      return;
    if (z0 == z1)
    {
      const auto r = cellRange (x, y, z0);
      scan (r.first, r.second);
      return;
    }
    const auto b = std::lower_bound (cell_keys_.begin (), cell_keys_.end (), key (x, y, z0));
    const auto e = std::lower_bound (b, cell_keys_.end (), key (x, y, z1) + 1);
    if (b != e)
      scan (cell_start_[b - cell_keys_.begin ()], cell_start_[e - cell_keys_.begin ()]);
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
      const int m = std::min<int> (k, static_cast<int> (scratch.size ()));
      if (m > 0)
        std::nth_element (scratch.begin (), scratch.begin () + (m - 1), scratch.end ());
      const double covered = static_cast<double> (R) * cell_ + dmin;
      if (all || (m > 0 && scratch[m - 1].first <= covered * covered))
      {
        for (int i = 0; i < m; ++i)
        {
          indices.push_back (scratch[i].second);
          sqr_distances.push_back (scratch[i].first);
        }
        return m;
      }
    }
  }
}

}  // namespace normals
}  // namespace pclx
