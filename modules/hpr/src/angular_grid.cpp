#include <pclx/hpr/detail/angular_grid.h>

#include "stage_profile.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cstring>
#include <cmath>
#include <limits>
#include <stdexcept>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace pclx {
namespace hpr {
namespace detail {

namespace {
constexpr double kPi = 3.14159265358979323846;

// Packs (score, point) so that an atomic integer min picks the smallest score,
// ties going to the lowest point index (deterministic for any thread count).
inline std::uint64_t
packKey (float score, std::uint32_t point)
{
  std::uint32_t bits;
  static_assert (sizeof (bits) == sizeof (score), "float is 32 bits");
  std::memcpy (&bits, &score, sizeof bits);  // score > 0: bit order = numeric order
  return (std::uint64_t (bits) << 32) | point;
}

inline void
atomicMin (std::uint64_t& target, std::uint64_t value)
{
  std::uint64_t cur = __atomic_load_n (&target, __ATOMIC_RELAXED);
  while (value < cur &&
         !__atomic_compare_exchange_n (&target, &cur, value, true, __ATOMIC_RELAXED, __ATOMIC_RELAXED))
  {
  }
}
// The smallest packed key per slot, over points scored in parallel. Each thread keeps its
// own row of slots while the rows take at most 64 MB (merged by best ()): with one shared
// array, the threads' loads and compare-exchanges on the same cache lines take away most of
// the parallel gain. Above that, one shared row with atomic minima.
class BestKeys
{
public:
  BestKeys (std::vector<std::uint64_t>& storage, std::size_t slots, int threads)
    : keys_ (storage), slots_ (slots),
      rows_ (threads > 1 && slots * std::size_t (threads) * sizeof (std::uint64_t) <= (std::size_t (64) << 20)
                 ? std::size_t (threads)
                 : 1),
      shared_ (threads > 1 && rows_ == 1)
  {
    keys_.assign (slots_ * rows_, kNone);
  }
  // The calling thread's row (inside the parallel region).
  std::uint64_t* row () const
  {
#ifdef _OPENMP
    return keys_.data () + (rows_ > 1 ? slots_ * std::size_t (omp_get_thread_num ()) : 0);
#else
    return keys_.data ();
#endif
  }
  void offer (std::uint64_t* row, std::size_t slot, std::uint64_t key) const
  {
    if (shared_)
      atomicMin (row[slot], key);
    else
      row[slot] = std::min (row[slot], key);
  }
  std::uint64_t best (std::size_t slot) const
  {
    std::uint64_t key = keys_[slot];
    for (std::size_t r = 1; r < rows_; ++r)
      key = std::min (key, keys_[r * slots_ + slot]);
    return key;
  }
  static constexpr std::uint64_t kNone = std::numeric_limits<std::uint64_t>::max ();

private:
  std::vector<std::uint64_t>& keys_;
  std::size_t slots_, rows_;
  bool shared_;
};
}  // namespace

void
AngularGrid::build (const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& centre, double radius,
                    std::size_t sectors)
{
  buildGrid (points, centre, nullptr, radius, sectors);
}

void
AngularGrid::build (const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& centre,
                    const std::function<double (double)>& radius_for_area, std::size_t sectors)
{
  buildGrid (points, centre, &radius_for_area, 0.0, sectors);
}

// The extent of the points' sector coordinates: (y/x, z/x) on gnomonic grids, (φ, θ) on
// wide ones.
struct AngularGrid::Extent
{
  float a_min, a_max, b_min, b_max;
};

void
AngularGrid::buildGrid (const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& centre,
                        const std::function<double (double)>* radius_for_area, double radius, std::size_t sectors)
{
  HPR_LAPS ();
  const std::ptrdiff_t n = static_cast<std::ptrdiff_t> (points.size ());
  if (n == 0 || sectors == 0)
    throw std::invalid_argument ("AngularGrid: needs points and k > 0");
  if (n >= std::numeric_limits<std::int32_t>::max ())
    throw std::invalid_argument ("AngularGrid: too many points");
  setFrame (centre);
  Extent extent = pointDirections (points);
  HPR_LAP ("build.unit_rho");
  if (!gnomonic_)
    extent = sphericalCoordinates ();
  HPR_LAP ("build.sector_coords");
  layoutSectors (extent, radius_for_area, radius, sectors);
  HPR_LAP ("build.layout");
  assignCandidates ();
  HPR_LAP ("build.assign_score");
  buildEmptyMap ();
  HPR_LAP ("build.candidates_empty");
}

void
AngularGrid::setFrame (const Eigen::Vector3d& centre)
{
  // Frame (Machado e Silva et al. 2014, §4.1): x through the cloud centre; z from the world
  // axis least aligned with x.
  Eigen::Vector3d x = centre;
  x = x.norm () > 0 ? x.normalized () : Eigen::Vector3d::UnitX ();
  Eigen::Vector3d e = Eigen::Vector3d::UnitZ ();
  if (std::abs (x.z ()) > 0.9)
    e = Eigen::Vector3d::UnitY ();
  const Eigen::Vector3d z = (e - e.dot (x) * x).normalized ();
  const Eigen::Vector3d y = z.cross (x);
  frame_.row (0) = x;
  frame_.row (1) = y;
  frame_.row (2) = z;
}

AngularGrid::Extent
AngularGrid::pointDirections (const std::vector<Eigen::Vector3d>& points)
{
  // Directions in frame coordinates (all later tests are rotation invariant), and the extent
  // of the gnomonic sector coordinates in the same pass: they are what almost every view
  // uses, and this saves a second pass over the directions.
  const std::ptrdiff_t n = static_cast<std::ptrdiff_t> (points.size ());
  unit_.resize (n);
  rho_.resize (n);
  sector_.resize (n);
  float min_x = 1.f;
  double rho0 = std::numeric_limits<double>::infinity ();
  float a_min = std::numeric_limits<float>::max (), a_max = std::numeric_limits<float>::lowest ();
  float b_min = a_min, b_max = a_max;
#pragma omp parallel for num_threads(nt ()) schedule(dynamic, 8192) reduction(min : min_x, rho0, a_min, b_min) \
    reduction(max : a_max, b_max)
  for (std::ptrdiff_t i = 0; i < n; ++i)
  {
    const double r = points[i].norm ();
    const Eigen::Vector3f u = r > 0 ? Eigen::Vector3f ((frame_ * points[i] / r).cast<float> ()) : Eigen::Vector3f::UnitX ();
    unit_[i] = u;
    rho_[i] = r;
    min_x = std::min (min_x, u.x ());
    rho0 = std::min (rho0, r);
    // Meaningless when u.x () <= 0.5 somewhere: then the wide tiling recomputes them.
    const float ga = u.y () / u.x (), gb = u.z () / u.x ();
    a_min = std::min (a_min, ga);
    a_max = std::max (a_max, ga);
    b_min = std::min (b_min, gb);
    b_max = std::max (b_max, gb);
  }
  rho0_ = rho0;
  // Narrow views (every point within 60° of the axis) use the gnomonic tiling
  // (a, b) = (y/x, z/x): sectors are pyramids bounded by planes through C, like a cube face
  // projected on the sphere (one of the tilings of Machado e Silva et al. 2014, §3), and cost
  // two divisions per point. Wide views (C inside or beside the cloud) use the paper's
  // spherical angles (φ, θ), with φ wrapping around the viewer.
  gnomonic_ = min_x > 0.5f;
  return {a_min, a_max, b_min, b_max};
}

AngularGrid::Extent
AngularGrid::sphericalCoordinates ()
{
  // Wide views only: (φ, θ) per point (atan2 and acos are worth storing; the gnomonic
  // coordinates are two divisions, recomputed where needed rather than written and read back).
  const std::ptrdiff_t n = static_cast<std::ptrdiff_t> (unit_.size ());
  std::vector<float>& ca = scratch_.ca;
  std::vector<float>& cb = scratch_.cb;
  ca.resize (n);
  cb.resize (n);
  float a_min, a_max, b_min, b_max;
  a_min = b_min = std::numeric_limits<float>::max ();
  a_max = b_max = std::numeric_limits<float>::lowest ();
#pragma omp parallel for num_threads(nt ()) schedule(dynamic, 8192) reduction(min : a_min, b_min) reduction(max : a_max, b_max)
  for (std::ptrdiff_t i = 0; i < n; ++i)
  {
    const Eigen::Vector3f& u = unit_[i];
    ca[i] = std::atan2 (u.y (), u.x ());
    cb[i] = std::acos (std::clamp (u.z (), -1.f, 1.f));
    a_min = std::min (a_min, ca[i]);
    a_max = std::max (a_max, ca[i]);
    b_min = std::min (b_min, cb[i]);
    b_max = std::max (b_max, cb[i]);
  }
  return {a_min, a_max, b_min, b_max};
}

void
AngularGrid::layoutCentres ()
{
  // Sector centres and their angles for the current n_phi_, n_theta_, phi0_, theta0_.
  cell_ = std::sqrt (cell_phi_ * cell_theta_);
  centre_a_.resize (n_phi_);
  for (int i = 0; i < n_phi_; ++i)
    centre_a_[i] = phi0_ + (i + 0.5) * cell_phi_;
  centre_b_.resize (n_theta_);
  for (int j = 0; j < n_theta_; ++j)
    centre_b_[j] = theta0_ + (j + 0.5) * cell_theta_;
  cos_phi_.resize (n_phi_);
  sin_phi_.resize (n_phi_);
  for (int i = 0; i < n_phi_; ++i)
  {
    cos_phi_[i] = std::cos (centre_a_[i]);
    sin_phi_[i] = std::sin (centre_a_[i]);
  }
  cos_theta_.resize (n_theta_);
  sin_theta_.resize (n_theta_);
  for (int j = 0; j < n_theta_; ++j)
  {
    cos_theta_[j] = std::cos (centre_b_[j]);
    sin_theta_[j] = std::sin (centre_b_[j]);
  }
}

void
AngularGrid::layoutSectors (Extent e, const std::function<double (double)>* radius_for_area, double radius,
                            std::size_t sectors)
{
  // The grid covers the cloud's extent (tighter than the enclosing-sphere frustum of
  // Eq. 2–3; the same for round clouds), with square cells.
  wrap_phi_ = !gnomonic_ && (e.a_max - e.a_min) > kPi;
  if (wrap_phi_)
  {
    e.a_min = float (-kPi);
    e.a_max = float (kPi);
  }
  const double pad = 1e-6;
  const double range_a = std::max (double (e.a_max) - e.a_min, 0.0) + 2 * pad;
  const double range_b = std::max (double (e.b_max) - e.b_min, 0.0) + 2 * pad;
  // A cell size set by setCellSize () wins unless it would need more than `sectors` cells.
  const double cell = std::max (fixed_cell_, std::sqrt (range_a * range_b / double (sectors)));
  n_phi_ = std::max (1, int (std::ceil (range_a / cell - 1e-9)));
  n_theta_ = std::max (1, int (std::ceil (range_b / cell - 1e-9)));
  phi0_ = wrap_phi_ ? -kPi : e.a_min - pad;
  cell_phi_ = wrap_phi_ ? 2 * kPi / n_phi_ : cell;
  theta0_ = e.b_min - pad;
  cell_theta_ = cell;
  // Angular size of a cell (gnomonic cells shrink as 1/(1 + a² + b²) away from the axis;
  // the axis value is what calibration and splats use).
  layoutCentres ();
  // R from the cloud's own extent (the outline ring below adds no solid angle of the cloud).
  // The grid's solid angle (a sum over every sector) only where R depends on it.
  radius_ = radius_for_area ? (*radius_for_area) (gridSolidAngle ()) : radius;
  if (outline_)
  {
    // One more sector on every side (not across the φ wrap): the outline candidates of
    // fillEmptySectors () go there.
    if (!wrap_phi_)
    {
      n_phi_ += 2;
      phi0_ -= cell_phi_;
    }
    n_theta_ += 2;
    theta0_ -= cell_theta_;
    layoutCentres ();
  }
}

void
AngularGrid::assignCandidates ()
{
  // Machado e Silva et al. 2014, §4.2: sector of every point and the extreme (best scored)
  // point per sector.
  const std::ptrdiff_t n = static_cast<std::ptrdiff_t> (unit_.size ());
  const std::size_t k = std::size_t (n_phi_) * n_theta_;
  const std::vector<float>& ca = scratch_.ca;
  const std::vector<float>& cb = scratch_.cb;
  const int threads = nt ();
  const BestKeys keys (scratch_.keys, k, threads);
  const float inv_a = float (1.0 / cell_phi_), inv_b = float (1.0 / cell_theta_);
  const float a0 = float (phi0_), b0 = float (theta0_);
  const double inv_2r = 1.0 / (2.0 * radius_);
#pragma omp parallel num_threads(threads)
  {
    std::uint64_t* best_key = keys.row ();
#pragma omp for schedule(dynamic, 8192)
    for (std::ptrdiff_t i = 0; i < n; ++i)
    {
      const Eigen::Vector3f& u = unit_[i];
      const float pa = gnomonic_ ? u.y () / u.x () : ca[i], pb = gnomonic_ ? u.z () / u.x () : cb[i];
      const int a = std::clamp (int ((pa - a0) * inv_a), 0, n_phi_ - 1);
      const int b = std::clamp (int ((pb - b0) * inv_b), 0, n_theta_ - 1);
      const std::size_t s = std::size_t (a) * n_theta_ + b;
      sector_[i] = static_cast<std::uint32_t> (s);
      Eigen::Vector3f d;
      if (gnomonic_)
      {
        const float da = float (centre_a_[a]), db = float (centre_b_[b]);
        d = Eigen::Vector3f (1.f, da, db) / std::sqrt (1.f + da * da + db * db);
      }
      else
        d = direction (s).cast<float> ();
      const float one_minus_cos = 0.5f * (unit_[i] - d).squaredNorm ();
      // See score(): the depth enters as (ρ − ρ_min)/2R, exact in float at any distance.
      const float g = one_minus_cos * float (1.0 - rho_[i] * inv_2r) + float ((rho_[i] - rho0_) * inv_2r);
      keys.offer (best_key, s, packKey (g, std::uint32_t (i)));
    }
  }
  cand_.assign (k, -1);
  best_.assign (k, std::numeric_limits<double>::infinity ());
#pragma omp parallel for num_threads(threads) schedule(dynamic, 8192)
  for (std::ptrdiff_t s = 0; s < std::ptrdiff_t (k); ++s)
  {
    const std::uint64_t key = keys.best (std::size_t (s));
    if (key != BestKeys::kNone)
    {
      cand_[s] = int (key & 0xffffffffu);
      best_[s] = score (cand_[s], std::size_t (s));
    }
  }
}

void
AngularGrid::buildEmptyMap ()
{
  // Machado e Silva et al. 2014, §4.3, the EMPTY map: when k/n > 25 % it is kept on a coarser
  // grid, so sectors inside the object's projection that merely received no sample are still
  // visited.
  const std::size_t n = unit_.size (), k = cand_.size ();
  empty_factor_ = 1;
  if (double (k) / double (n) > 0.25)
    empty_factor_ = int (std::ceil (std::sqrt (double (k) / double (n) / 0.25)));
  coarse_theta_ = (n_theta_ + empty_factor_ - 1) / empty_factor_;
  const int coarse_phi = (n_phi_ + empty_factor_ - 1) / empty_factor_;
  occupied_coarse_.assign (std::size_t (coarse_phi) * coarse_theta_, 0);
  for (std::size_t s = 0; s < k; ++s)
    if (cand_[s] >= 0)
    {
      const int a = int (s / n_theta_), b = int (s % n_theta_);
      occupied_coarse_[std::size_t (a / empty_factor_) * coarse_theta_ + b / empty_factor_] = 1;
    }
  if (outline_)
  {
    fillEmptySectors ();
    own_ = cand_;
  }
  else
    own_.clear ();
}

void
AngularGrid::fillEmptySectors ()
{
  const std::size_t k = cand_.size (), n = sector_.size ();
  const int rows = n_phi_, cols = n_theta_;
  const Shape grid = shape ();
  // Point-less sectors next to one with points ("hollow", numbered), their directions, and
  // the sectors next to them (whose points are scored towards them).
  // border[s]: 1 + where s's point-less neighbours start in border_hollow (a list ended by
  // −1), or 0: the points' pass below then reads one list instead of testing 9 neighbours.
  std::vector<std::uint32_t> border (k, 0);
  std::vector<std::int32_t> hollow_of (k, -1);
  std::vector<std::size_t> hollow;
  std::vector<Eigen::Vector3f> hollow_dir;
  std::vector<std::int32_t> border_hollow;
  // From the occupied sectors (on the finer grids most sectors are empty).
  for (int a = 0; a < rows; ++a)
    for (int b = 0; b < cols; ++b)
    {
      const std::size_t s = std::size_t (a) * cols + b;
      if (cand_[s] < 0)
        continue;
      const std::size_t first = border_hollow.size ();
      for (int da = -1; da <= 1; ++da)
        for (int db = -1; db <= 1; ++db)
        {
          const std::ptrdiff_t t = grid.neighbour (a, b, da, db);
          if (t < 0 || cand_[std::size_t (t)] >= 0)
            continue;
          if (hollow_of[std::size_t (t)] < 0)
          {
            hollow_of[std::size_t (t)] = std::int32_t (hollow.size ());
            hollow.push_back (std::size_t (t));
            hollow_dir.push_back (direction (std::size_t (t)).cast<float> ());
          }
          border_hollow.push_back (hollow_of[std::size_t (t)]);
        }
      if (border_hollow.size () > first)
      {
        border[s] = std::uint32_t (first + 1);
        border_hollow.push_back (-1);
      }
    }
  if (hollow.empty ())
    return;
  // The score of build()'s assignment pass (float, depth term relative to ρ_min).
  const std::size_t m = hollow.size ();
  const int threads = nt ();
  std::vector<std::uint64_t> storage;
  const BestKeys keys (storage, m, threads);
  const double inv_2r = 1.0 / (2.0 * radius_);
#pragma omp parallel num_threads(threads)
  {
    std::uint64_t* best_key = keys.row ();
#pragma omp for schedule(dynamic, 8192)
    for (std::ptrdiff_t i = 0; i < std::ptrdiff_t (n); ++i)
    {
      const std::uint32_t first = border[sector_[i]];
      if (!first)
        continue;
      const float depth = float ((rho_[i] - rho0_) * inv_2r), near = float (1.0 - rho_[i] * inv_2r);
      for (const std::int32_t* h = border_hollow.data () + (first - 1); *h >= 0; ++h)
      {
        const float g = 0.5f * (unit_[i] - hollow_dir[std::size_t (*h)]).squaredNorm () * near + depth;
        keys.offer (best_key, std::size_t (*h), packKey (g, std::uint32_t (i)));
      }
    }
  }
  for (std::size_t h = 0; h < m; ++h)
  {
    const std::uint64_t key = keys.best (h);
    if (key != BestKeys::kNone)
    {
      cand_[hollow[h]] = int (key & 0xffffffffu);
      best_[hollow[h]] = score (cand_[hollow[h]], hollow[h]);
    }
  }
}

int
AngularGrid::nt () const
{
#ifdef _OPENMP
  return threads_ > 0 ? threads_ : omp_get_max_threads ();
#else
  return 1;
#endif
}

Eigen::Vector3d
AngularGrid::direction (std::size_t s) const
{
  const int a = int (s / n_theta_), b = int (s % n_theta_);
  if (gnomonic_)
    return Eigen::Vector3d (1.0, centre_a_[a], centre_b_[b]).normalized ();
  return Eigen::Vector3d (sin_theta_[b] * cos_phi_[a], sin_theta_[b] * sin_phi_[a], cos_theta_[b]);
}

double
AngularGrid::score (int point, std::size_t sector) const
{
  return scoreDir (point, direction (sector));
}

double
AngularGrid::scoreDir (int point, const Eigen::Vector3d& d) const
{
  const double one_minus_cos = 0.5 * (unit_[point].cast<double> () - d).squaredNorm ();
  // g − ρ_min/2R: the same ranking, and the depth term keeps its digits when C is far
  // (ρ ≈ distance, depth differences ≪ ρ).
  return one_minus_cos * (1.0 - rho_[point] / (2.0 * radius_)) + (rho_[point] - rho0_) / (2.0 * radius_);
}

double
AngularGrid::cellSolidAngle (std::size_t s) const
{
  const int a = int (s / n_theta_), b = int (s % n_theta_);
  if (gnomonic_)
    return cell_phi_ * cell_theta_ /
           std::pow (1.0 + centre_a_[a] * centre_a_[a] + centre_b_[b] * centre_b_[b], 1.5);
  return cell_phi_ * cell_theta_ * sin_theta_[b];
}

double
AngularGrid::gridSolidAngle () const
{
  double total = 0;
  for (std::size_t s = 0; s < std::size_t (n_phi_) * n_theta_; ++s)
    total += cellSolidAngle (s);
  return total;
}

bool
AngularGrid::isEmpty (std::size_t s) const
{
  const int a = int (s / n_theta_), b = int (s % n_theta_);
  return !occupied_coarse_[std::size_t (a / empty_factor_) * coarse_theta_ + b / empty_factor_];
}

void
AngularGrid::neighbours (std::size_t s, int radius, std::vector<std::size_t>& out) const
{
  out.clear ();
  const Shape grid = shape ();
  const int a = int (s / n_theta_), b = int (s % n_theta_);
  for (int da = -radius; da <= radius; ++da)
    for (int db = -radius; db <= radius; ++db)
    {
      const std::ptrdiff_t t = da == 0 && db == 0 ? -1 : grid.neighbour (a, b, da, db);
      if (t >= 0)
        out.push_back (std::size_t (t));
    }
}

int
AngularGrid::propagateAdaptive (int max_steps)
{
  const std::size_t k = cand_.size ();
  std::vector<std::size_t> changed;
  for (std::size_t s = 0; s < k; ++s)
    if (cand_[s] >= 0)
      changed.push_back (s);
  // Each step is a Jacobi step: candidates move at most one sector per step.
  const int cap = max_steps > 0 ? max_steps : 4 * (n_phi_ + n_theta_);
  std::vector<int>& prop_cand = scratch_.prop_cand;
  std::vector<double>& prop_best = scratch_.prop_best;
  std::vector<std::uint32_t>& stamp = scratch_.stamp;
  prop_cand.assign (k, -1);
  prop_best.resize (k);
  stamp.assign (k, 0);
  std::vector<std::size_t> nb, touched;
  int steps = 0;
  while (!changed.empty () && steps < cap)
  {
    ++steps;
    touched.clear ();
    if (changed.size () > k / 8)
    {
      // Many sectors changed (the first steps): a parallel gather over all sectors.
      // The 3×3 neighbourhood inline (neighbours () fills a vector), and the sector's direction
      // only once a neighbour has a candidate to score: the refinement grids are mostly empty.
      const Shape grid = shape ();
#pragma omp parallel for num_threads(nt ()) schedule(dynamic, 256) firstprivate(grid)
      for (std::ptrdiff_t t = 0; t < std::ptrdiff_t (k); ++t)
      {
        if (isEmpty (std::size_t (t)))
          continue;
        const int a = int (t / grid.cols), b = int (t % grid.cols);
        Eigen::Vector3d d;
        bool have_d = false;
        double best = best_[t];
        int who = -1;
        for (int da = -1; da <= 1; ++da)
          for (int db = -1; db <= 1; ++db)
          {
            // The sector itself is skipped by c == cand_[t].
            const std::ptrdiff_t u = grid.neighbour (a, b, da, db);
            const int c = u < 0 ? -1 : cand_[std::size_t (u)];
            if (c < 0 || c == cand_[t])
              continue;
            if (!have_d)
            {
              d = direction (std::size_t (t));
              have_d = true;
            }
            const double g = scoreDir (c, d);
            if (g < best || (g == best && who >= 0 && c < who))
            {
              best = g;
              who = c;
            }
          }
        if (who >= 0)
        {
          prop_cand[t] = who;
          prop_best[t] = best;
        }
        else
          prop_cand[t] = -1;
      }
      for (std::size_t t = 0; t < k; ++t)
        if (prop_cand[t] >= 0)
          touched.push_back (t);
    }
    else
    {
      // Few changes: scatter from the changed sectors only (the CPU variant of Machado e
      // Silva 2012, §4.3.3).
      for (std::size_t s : changed)
      {
        const int c = cand_[s];
        neighbours (s, 1, nb);
        for (std::size_t t : nb)
        {
          if (isEmpty (t) || cand_[t] == c)
            continue;
          const double g = score (c, t);
          const bool fresh = stamp[t] != std::uint32_t (steps) + (1u << 31);
          const double cur = fresh ? best_[t] : prop_best[t];
          if (g < cur)
          {
            if (fresh)
            {
              stamp[t] = std::uint32_t (steps) + (1u << 31);
              touched.push_back (t);
            }
            prop_cand[t] = c;
            prop_best[t] = g;
          }
        }
      }
    }
    changed.clear ();
    for (std::size_t t : touched)
    {
      if (prop_cand[t] < 0)
        continue;
      cand_[t] = prop_cand[t];
      best_[t] = prop_best[t];
      prop_cand[t] = -1;
      changed.push_back (t);
    }
  }
  return steps;
}

void
AngularGrid::propagateFixed (int m)
{
  const int radius = std::max (0, m / 2);
  if (radius == 0)
    return;
  const std::vector<int> old = cand_;
  const std::ptrdiff_t k = std::ptrdiff_t (cand_.size ());
  std::vector<std::size_t> nb;
#pragma omp parallel for num_threads(nt ()) schedule(dynamic, 256) private(nb)
  for (std::ptrdiff_t t = 0; t < k; ++t)
  {
    if (isEmpty (std::size_t (t)))
      continue;
    neighbours (std::size_t (t), radius, nb);
    const Eigen::Vector3d d = direction (std::size_t (t));
    for (std::size_t s : nb)
    {
      const int c = old[s];
      if (c < 0 || c == cand_[t])
        continue;
      const double g = scoreDir (c, d);
      if (g < best_[t])
      {
        best_[t] = g;
        cand_[t] = c;
      }
    }
  }
}

void
AngularGrid::refineGlobal ()
{
  const std::vector<int> pool = candidates ();
  const std::ptrdiff_t k = std::ptrdiff_t (cand_.size ());
#pragma omp parallel for num_threads(nt ()) schedule(dynamic, 64)
  for (std::ptrdiff_t t = 0; t < k; ++t)
  {
    if (cand_[t] < 0)
      continue;
    const Eigen::Vector3d d = direction (std::size_t (t));
    for (int c : pool)
    {
      const double g = scoreDir (c, d);
      if (g < best_[t])
      {
        best_[t] = g;
        cand_[t] = c;
      }
    }
  }
}

std::vector<int>
AngularGrid::candidates () const
{
  std::vector<int> out;
  for (int c : cand_)
    if (c >= 0)
      out.push_back (c);
  std::sort (out.begin (), out.end ());
  out.erase (std::unique (out.begin (), out.end ()), out.end ());
  return out;
}

std::size_t
AngularGrid::occupiedSectors () const
{
  return std::size_t (std::count_if (cand_.begin (), cand_.end (), [] (int c) { return c >= 0; }));
}

std::vector<Eigen::Vector3i>
AngularGrid::triangulate (const std::vector<Eigen::Vector3d>& points, float max_edge) const
{
  std::vector<Eigen::Vector3i> tris;
  const int rows = wrap_phi_ ? n_phi_ : n_phi_ - 1;
  const float max2 = max_edge > 0 ? max_edge * max_edge : std::numeric_limits<float>::infinity ();
  auto add = [&] (int a, int b, int c) {
    if (a < 0 || b < 0 || c < 0 || a == b || b == c || a == c)
      return;
    const Eigen::Vector3d &pa = points[a], &pb = points[b], &pc = points[c];
    if ((pa - pb).squaredNorm () > max2 || (pb - pc).squaredNorm () > max2 || (pc - pa).squaredNorm () > max2)
      return;
    if ((pb - pa).cross (pc - pa).dot (-pa) < 0)  // face the viewpoint (origin)
      std::swap (b, c);
    // Canonical rotation (smallest index first) so duplicates can be removed.
    if (b < a && b < c)
      tris.emplace_back (b, c, a);
    else if (c < a && c < b)
      tris.emplace_back (c, a, b);
    else
      tris.emplace_back (a, b, c);
  };
  for (int i = 0; i < rows; ++i)
  {
    const int i1 = (i + 1) % n_phi_;
    for (int j = 0; j + 1 < n_theta_; ++j)
    {
      const int a = cand_[std::size_t (i) * n_theta_ + j], b = cand_[std::size_t (i) * n_theta_ + j + 1];
      const int c = cand_[std::size_t (i1) * n_theta_ + j], d = cand_[std::size_t (i1) * n_theta_ + j + 1];
      add (a, b, d);
      add (a, d, c);
    }
  }
  std::sort (tris.begin (), tris.end (), [] (const Eigen::Vector3i& l, const Eigen::Vector3i& r) {
    return std::lexicographical_compare (l.data (), l.data () + 3, r.data (), r.data () + 3);
  });
  tris.erase (std::unique (tris.begin (), tris.end ()), tris.end ());
  return tris;
}

void
AngularGrid::normalsAndSplats (const std::vector<Eigen::Vector3d>& points, std::vector<Eigen::Vector3f>& normals,
                               std::vector<float>& splat_radius) const
{
  const std::size_t k = cand_.size ();
  std::vector<Eigen::Vector3f> sector_normal (k, Eigen::Vector3f::Zero ());
  std::vector<float> sector_splat (k, 0.f);
  // Circulation order around a sector (Machado e Silva et al. 2014, §5.3, Fig. 8a).
  static const int ring[8][2] = {{-1, -1}, {-1, 0}, {-1, 1}, {0, 1}, {1, 1}, {1, 0}, {1, -1}, {0, -1}};
  const float half_diag = static_cast<float> (cell_ * std::sqrt (2.0) / 2);
#pragma omp parallel for num_threads(nt ()) schedule(dynamic, 256)
  for (std::ptrdiff_t s = 0; s < std::ptrdiff_t (k); ++s)
  {
    const Shape grid = shape ();
    const int c0 = cand_[s];
    if (c0 < 0)
      continue;
    const int a = int (s / n_theta_), b = int (s % n_theta_);
    int fan[8], m = 0;
    for (const auto& o : ring)
    {
      const std::ptrdiff_t t = grid.neighbour (a, b, o[0], o[1]);
      if (t < 0)
        continue;
      const int c = cand_[std::size_t (t)];
      if (c >= 0 && c != c0 && (m == 0 || fan[m - 1] != c))
        fan[m++] = c;
    }
    Eigen::Vector3f sum = Eigen::Vector3f::Zero ();
    const Eigen::Vector3d& p0 = points[c0];
    for (int t = 0; t + 1 < m + (m > 2 ? 1 : 0); ++t)
    {
      const int c1 = fan[t], c2 = fan[(t + 1) % m];
      if (c1 == c2)
        continue;
      Eigen::Vector3f nrm = (points[c2] - p0).cross (points[c1] - p0).cast<float> ();
      if (nrm.dot ((-p0).cast<float> ()) < 0)
        nrm = -nrm;
      sum += nrm;
    }
    sector_normal[s] = sum;
    // §5.5: the splat must cover the footprint of every sector this point won.
    const double r = rho_[c0];
    sector_splat[s] = r * ((unit_[c0].cast<double> () - direction (std::size_t (s))).norm () + half_diag);
  }
  normals.assign (points.size (), Eigen::Vector3f::Constant (std::numeric_limits<float>::quiet_NaN ()));
  splat_radius.assign (points.size (), 0.f);
  std::vector<Eigen::Vector3f> acc (points.size (), Eigen::Vector3f::Zero ());
  for (std::size_t s = 0; s < k; ++s)
    if (cand_[s] >= 0)
    {
      acc[cand_[s]] += sector_normal[s];
      splat_radius[cand_[s]] = std::max (splat_radius[cand_[s]], sector_splat[s]);
    }
  for (int c : candidates ())
  {
    if (acc[c].norm () > 0)
      normals[c] = acc[c].normalized ();
    else  // isolated candidate: facing the viewer is the only estimate
      normals[c] = (-points[c]).normalized ().cast<float> ();
  }
}

namespace {
// The four triangles of a 2×2 quad of corner sectors 0…3 (both diagonals), and the edge
// (ab, bc, ca) of each that lies on a diagonal (the other two bound the quad).
constexpr int kQuadTriangles[4][3] = {{0, 1, 2}, {0, 2, 3}, {0, 1, 3}, {1, 2, 3}};
constexpr int kQuadTriangleDiagonal[4] = {2, 0, 1, 2};
}  // namespace

// Tetrahedron (C, a, b, c) in flipped space: q is strictly inside when it is strictly
// inside the cone of the three directions and strictly on C's side of plane(a, b, c).
struct AngularGrid::Tetra
{
  Eigen::Vector3d edge[3];  // cone side normals, pointing inwards
  double cone_eps;
  Eigen::Vector3d w;        // plane normal, C's side positive
  Eigen::Vector3d f;        // a point of the plane (flipped a)
  double h;                 // inside when w·(q − f) > h (h > 0: the margin)
  int diagonal;             // the edge on the quad's diagonal (the other two bound the quad)
};

// The tetrahedra of one 2×2 quad of sectors, the smallest ρ of their candidates, and the
// quad row they were set up for (see runTetrahedronTests ()).
struct AngularGrid::QuadSet
{
  Tetra t[4];
  int count;
  double min_rho;
  int qa = std::numeric_limits<int>::min ();
};

// What the stages of interiorPoints () share: its arguments, the sizes, and the per-point
// mask it returns when no survivor list is asked for.
struct AngularGrid::InteriorPass
{
  const std::vector<Eigen::Vector3d>& points;
  std::vector<int>* survivors = nullptr;
  std::vector<Eigen::Vector3d>* survivor_points = nullptr;
  std::vector<std::uint8_t>* survivor_in_band = nullptr;
  std::vector<int>* outside_band = nullptr;
  std::size_t n = 0, k = 0;  // points, sectors
  double R2 = 0;             // 2R
  bool with_own = false;     // quads may use a sector's own point in place of a repeated candidate
  bool want_band = false;    // the caller asked for the uncertain band
  bool with_cut = false;     // the depth cut runs (gnomonic grids with many points per sector)
  int threads = 1;
  std::vector<std::uint8_t> interior;

  InteriorPass (const std::vector<Eigen::Vector3d>& pts, std::vector<int>* surv,
                std::vector<Eigen::Vector3d>* surv_pts, std::vector<std::uint8_t>* surv_in_band,
                std::vector<int>* outside)
    : points (pts), survivors (surv), survivor_points (surv_pts), survivor_in_band (surv_in_band), outside_band (outside)
  {
  }
};

std::vector<std::uint8_t>
AngularGrid::interiorPoints (const std::vector<Eigen::Vector3d>& points, std::vector<int>* survivors,
                             std::vector<Eigen::Vector3d>* survivor_points,
                             std::vector<std::uint8_t>* survivor_in_band, std::vector<int>* outside_band) const
{
  HPR_LAPS ();
  InteriorPass pass (points, survivors, survivor_points, survivor_in_band, outside_band);
  pass.n = unit_.size ();
  pass.k = cand_.size ();
  // Exactly the flip the hull sees (double, from the input points): a culled point must
  // be interior to the very hull Qhull computes.
  pass.R2 = 2.0 * radius_;
  pass.with_own = own_.size () == pass.k;
  pass.want_band = survivors && (survivor_in_band || outside_band);
  // The depth cut only where sectors hold many points (the first pass): the refinement
  // passes' grids hold the band, which lies near the surface, and have more sectors than points.
  pass.with_cut = gnomonic_ && n_phi_ >= 3 && n_theta_ >= 3 && pass.n >= 8 * pass.k;
  pass.threads = nt ();
  pass.interior.assign (survivors ? 0 : pass.n, 0);

  prepareCandidates (pass);
  HPR_LAP ("interior.cand_flip");
  // With a band asked for, culls within band_depth_ mark its seed sectors.
  if (pass.want_band)
    scratch_.seed.assign (pass.k, 0);
  if (pass.with_cut)
    computeDepthCut (pass);
  HPR_LAP ("interior.cut");
  bucketByRow (pass);
  HPR_LAP ("interior.scatter");
  runTetrahedronTests (pass);
  HPR_LAP ("interior.tests");
  markUncertainBand (pass);
  HPR_LAP ("interior.band");
  writeInteriorOutput (pass);
  HPR_LAP ("interior.output");
  return std::move (pass.interior);
}

void
AngularGrid::prepareCandidates (InteriorPass& pass) const
{
  const std::size_t n = pass.n, k = pass.k;
  const double R2 = pass.R2;
  std::vector<std::uint8_t>& is_cand = scratch_.is_cand;
  is_cand.assign (n, 0);
  for (int c : cand_)
    if (c >= 0)
      is_cand[c] = 1;
  // Direction and flipped position of each sector's candidate, once per sector (each is
  // used by the 16 tetrahedra of up to 9 sectors).
  // Slot s: the candidate of sector s; slot k + s: its own best point when propagation
  // replaced it by a neighbour's (a quad whose corners share a candidate has no tetrahedron;
  // its own point, any point of the cloud, still spans one).
  std::vector<Eigen::Vector3d>& cand_dir = scratch_.cand_dir;
  std::vector<Eigen::Vector3d>& cand_flip = scratch_.cand_flip;
  std::vector<double>& cand_rho = scratch_.cand_rho;
  cand_dir.resize (2 * k);
  cand_flip.resize (2 * k);
  cand_rho.resize (2 * k);
  const bool with_own = pass.with_own;
  const std::vector<Eigen::Vector3d>& points = pass.points;
#pragma omp parallel for num_threads(nt ()) schedule(dynamic, 1024)
  for (std::ptrdiff_t s = 0; s < std::ptrdiff_t (k); ++s)
    for (int slot = 0; slot < 2; ++slot)
    {
      const int c = slot == 0 ? cand_[s] : with_own && own_[s] != cand_[s] ? own_[s] : -1;
      const std::size_t v = std::size_t (s) + (slot ? k : 0);
      if (c < 0)
      {
        cand_rho[v] = std::numeric_limits<double>::infinity ();
        continue;
      }
      const Eigen::Vector3d& p = points[c];
      cand_rho[v] = p.norm ();
      cand_dir[v] = p / cand_rho[v];
      cand_flip[v] = p * (R2 / cand_rho[v] - 1.0);
    }
  // Gnomonic views: the planes through C and each sector's candidate along the two grid
  // axes (split[2s], split[2s + 1]; normals n with n·p ≥ 0 on the side of larger a or b). The
  // four quads around a sector meet at its candidate, so the side of these planes a point
  // lies on names the quad most likely to hold it.
  std::vector<Eigen::Vector3d>& split = scratch_.split;
  std::vector<Eigen::Vector2d>& cand_g = scratch_.cand_g;  // the candidates' (a, b) (depth cut)
  if (gnomonic_)
  {
    split.resize (2 * k);
    cand_g.resize (k);
    const Eigen::Vector3d ex = frame_.row (0), ey = frame_.row (1), ez = frame_.row (2);
#pragma omp parallel for num_threads(nt ()) schedule(dynamic, 1024)
    for (std::ptrdiff_t s = 0; s < std::ptrdiff_t (k); ++s)
    {
      // A sector without candidate has no point either, and no quad of the depth cut uses it.
      if (cand_[s] < 0)
        continue;
      const Eigen::Vector3d u = frame_ * cand_dir[s];
      const double ga = u.y () / u.x (), gb = u.z () / u.x ();
      cand_g[s] = Eigen::Vector2d (ga, gb);
      split[2 * s] = ey - ga * ex;
      split[2 * s + 1] = ez - gb * ex;
    }
  }
}

void
AngularGrid::quadTetras (const InteriorPass& pass, int qa, int qb, Tetra* out, int& count, double& min_rho) const
{
  // The tetrahedra of the 2×2 quad whose corner sectors are (qa, qb) … (qa + 1, qb + 1),
  // both diagonals; min ρ of their candidates.
  const std::size_t k = pass.k;
  const double R2 = pass.R2;
  const std::vector<Eigen::Vector3d>& cand_dir = scratch_.cand_dir;
  const std::vector<Eigen::Vector3d>& cand_flip = scratch_.cand_flip;
  const std::vector<double>& cand_rho = scratch_.cand_rho;
  count = 0;
  min_rho = std::numeric_limits<double>::infinity ();
  int a0 = qa, a1 = qa + 1;
  const int b0 = qb, b1 = qb + 1;
  if (wrap_phi_)
  {
    a0 = (a0 + n_phi_) % n_phi_;
    a1 = a1 % n_phi_;
  }
  if (a0 < 0 || a1 >= n_phi_ || b0 < 0 || b1 >= n_theta_)
    return;
  std::size_t sc[4] = {std::size_t (a0) * n_theta_ + b0, std::size_t (a0) * n_theta_ + b1,
                       std::size_t (a1) * n_theta_ + b1, std::size_t (a1) * n_theta_ + b0};
  int id[4] = {cand_[sc[0]], cand_[sc[1]], cand_[sc[2]], cand_[sc[3]]};
  // A corner that repeats another's candidate takes its sector's own point (slot k + s).
  if (pass.with_own)
    for (int i = 1; i < 4; ++i)
      for (int j = 0; j < i; ++j)
        if (id[i] >= 0 && id[i] == id[j])
        {
          // sc[m] < k: not replaced yet; own_ differs from cand_ only where propagation moved it.
          auto swappable = [&] (int m) { return sc[m] < k && own_[sc[m]] >= 0 && own_[sc[m]] != cand_[sc[m]]; };
          const int m = swappable (i) ? i : swappable (j) ? j : -1;
          if (m >= 0)
          {
            id[m] = own_[sc[m]];
            sc[m] += k;
          }
        }
  for (int ti = 0; ti < 4; ++ti)
  {
    const int* t = kQuadTriangles[ti];
    const std::size_t sa = sc[t[0]], sb = sc[t[1]], sc2 = sc[t[2]];
    const int ia = id[t[0]], ib = id[t[1]], ic = id[t[2]];
    if (ia < 0 || ib < 0 || ic < 0 || ia == ib || ib == ic || ia == ic)
      continue;
    const Eigen::Vector3d &ua = cand_dir[sa], &ub = cand_dir[sb], &uc = cand_dir[sc2];
    const double o = ua.cross (ub).dot (uc);
    if (std::abs (o) < 1e-18)
      continue;
    min_rho = std::min ({min_rho, cand_rho[sa], cand_rho[sb], cand_rho[sc2]});
    const double sgn = o > 0 ? 1.0 : -1.0;
    Tetra& T = out[count];
    T.edge[0] = sgn * ua.cross (ub);
    T.edge[1] = sgn * ub.cross (uc);
    T.edge[2] = sgn * uc.cross (ua);
    T.cone_eps = 1e-9 * std::abs (o);
    const Eigen::Vector3d &fa = cand_flip[sa], &fb = cand_flip[sb], &fc = cand_flip[sc2];
    Eigen::Vector3d nrm = (fb - fa).cross (fc - fa);
    if (nrm.dot (fa) > 0)  // make C (the origin) the positive side
      nrm = -nrm;
    T.w = nrm;
    // Strict, with a margin of ~10² double roundoffs of coordinates of size 2R (|q| < 2R:
    // w·(q − f) is off by ~1.5e-15·2R·|w|; Qhull's own fuzz is of the same order). It must
    // not grow faster than that: R grows as distance² (Fig. 9 at a fixed angular spacing),
    // so a margin relative to w·a would swallow every depth difference of a far view.
    T.f = fa;
    T.h = 1e-13 * R2 * nrm.norm ();
    T.diagonal = kQuadTriangleDiagonal[ti];
    ++count;
  }
}

bool
AngularGrid::seedsBand (double rho, double near) const
{
  // A cull at ρ seeds the band unless deeper than band_depth_ behind the nearest candidate around it.
  return !(band_depth_ > 0 && rho - near > band_depth_);
}

void
AngularGrid::computeDepthCut (const InteriorPass& pass) const
{
  // Depth cut (gnomonic views): a point of sector s deeper than cut[s] is strictly inside one
  // of the tetrahedra its tests would try, so it is culled before the bucket sort and never
  // tested (on a closed object, the far side: about half the points). Why it holds: when
  // each of the 8 neighbours' candidates lies beyond the side (edge neighbours) or the two sides
  // (diagonal ones) of s that it faces, the outer edges of the 4 quads around s form a loop
  // that winds once around s (in gnomonic coordinates cones through C are polygons), so the
  // fan triangles (s's candidate, two consecutive ring candidates), each a triangle of one quad,
  // cover every direction of s. A point whose flipped distance from C, 2R − ρ, is below the
  // distance from C of every one of these tetrahedra's planes (less the margin h) is on C's
  // side of them all, hence strictly inside the one whose cone holds it.
  const std::size_t k = pass.k;
  const double R2 = pass.R2;
  std::vector<double>& cut = scratch_.cut;
  std::vector<double>& cut_near = scratch_.cut_near;  // min ρ of those candidates (band seeds)
  const std::vector<Eigen::Vector2d>& cand_g = scratch_.cand_g;
  const int qcols = n_theta_ - 1;
  const std::ptrdiff_t quads = std::ptrdiff_t (n_phi_ - 1) * qcols;
  std::vector<double>& quad_d = scratch_.quad_d;
  std::vector<double>& quad_near = scratch_.quad_near;
  quad_d.resize (std::size_t (quads));
  quad_near.resize (std::size_t (quads));
#pragma omp parallel for num_threads(nt ()) schedule(dynamic, 1024)
  for (std::ptrdiff_t q = 0; q < quads; ++q)
  {
    const int qa = int (q / qcols), qb = int (q % qcols);
    const std::size_t s0 = std::size_t (qa) * n_theta_ + std::size_t (qb);
    const int id[4] = {cand_[s0], cand_[s0 + 1], cand_[s0 + n_theta_ + 1], cand_[s0 + n_theta_]};
    quad_d[q] = -std::numeric_limits<double>::infinity ();  // no cut next to this quad
    if (id[0] < 0 || id[1] < 0 || id[2] < 0 || id[3] < 0 || id[0] == id[1] || id[0] == id[2] ||
        id[0] == id[3] || id[1] == id[2] || id[1] == id[3] || id[2] == id[3])
      continue;
    Tetra t[4];
    int count;
    quadTetras (pass, qa, qb, t, count, quad_near[q]);
    if (count < 4)
      continue;
    double d = std::numeric_limits<double>::infinity ();
    for (const Tetra& T : t)
      d = std::min (d, (-T.w.dot (T.f) - T.h) / T.w.norm ());
    quad_d[q] = d;
  }
  cut.assign (k, std::numeric_limits<double>::infinity ());
  cut_near.resize (k);
  // 1 % of a cell: the points' sectors come from float coordinates.
  const double eps_a = 0.01 * cell_phi_ + 1e-6, eps_b = 0.01 * cell_theta_ + 1e-6;
#pragma omp parallel for num_threads(nt ()) schedule(dynamic, 16)
  for (int a = 1; a < n_phi_ - 1; ++a)
  {
    const double lo_a = phi0_ + a * cell_phi_ - eps_a, hi_a = phi0_ + (a + 1) * cell_phi_ + eps_a;
    for (int b = 1; b < n_theta_ - 1; ++b)
    {
      const std::size_t q0 = std::size_t (a - 1) * qcols + std::size_t (b - 1), q1 = q0 + std::size_t (qcols);
      const double d = std::min ({quad_d[q0], quad_d[q0 + 1], quad_d[q1], quad_d[q1 + 1]});
      if (!(d > 0))
        continue;
      const double lo_b = theta0_ + b * cell_theta_ - eps_b, hi_b = theta0_ + (b + 1) * cell_theta_ + eps_b;
      const std::size_t s = std::size_t (a) * n_theta_ + std::size_t (b);
      bool around = true;
      for (int da = -1; da <= 1 && around; ++da)
        for (int db = -1; db <= 1 && around; ++db)
        {
          const Eigen::Vector2d& g = cand_g[std::size_t (std::ptrdiff_t (s) + da * n_theta_ + db)];
          around = (da == 0 || (da < 0 ? g.x () < lo_a : g.x () > hi_a)) &&
                   (db == 0 || (db < 0 ? g.y () < lo_b : g.y () > hi_b));
        }
      if (!around)
        continue;
      cut[s] = R2 - d + 1e-13 * R2;
      cut_near[s] = std::min ({quad_near[q0], quad_near[q0 + 1], quad_near[q1], quad_near[q1 + 1]});
    }
  }
}

void
AngularGrid::bucketByRow (InteriorPass& pass) const
{
  // Points bucketed by sector row (counting sort over the n_phi rows): the tests set up the
  // tetrahedra of two rows of quads once, and read the points in order. Bucketing by sector
  // (k buckets) would cost more than the tests: k interleaved write streams miss the cache
  // on every point; n_phi ≈ √k streams stay in it.
  const std::size_t n = pass.n;
  const bool with_cut = pass.with_cut, want_band = pass.want_band;
  const std::vector<int>* survivors = pass.survivors;
  const std::vector<Eigen::Vector3d>& points = pass.points;
  std::vector<std::uint8_t>& interior = pass.interior;
  std::vector<std::uint8_t>& is_cand = scratch_.is_cand;
  std::vector<std::uint8_t>& seed = scratch_.seed;
  const std::vector<double>& cut = scratch_.cut;
  const std::vector<double>& cut_near = scratch_.cut_near;
  const int cols = n_theta_;
  const double inv_cols = 1.0 / cols;
  // Exact: s + 0.5 keeps the product off the integers for every s < 2^31.
  auto rowOf = [inv_cols] (std::uint32_t s) { return std::uint32_t ((double (s) + 0.5) * inv_cols); };
  std::vector<std::uint32_t>& start = scratch_.start;
  std::vector<std::uint32_t>& order = scratch_.order;
  start.assign (std::size_t (n_phi_) + 1, 0);
  order.resize (n);
  // The points in row order, scattered once while sorting: the tests then read memory in
  // order rather than through order[]. Candidates are never interior.
  std::vector<Eigen::Vector3d>& sorted = scratch_.sorted;
  std::vector<std::uint8_t>& inside_sorted = scratch_.inside;
  std::vector<std::uint8_t>& cand_sorted = scratch_.cand_sorted;
  std::vector<std::uint32_t>& col_sorted = scratch_.col;
  sorted.resize (n);
  if (!survivors)  // the per-point mask; with survivors the tests list them per row instead
    inside_sorted.assign (n, 0);
  cand_sorted.resize (n);
  col_sorted.resize (n);
  // Counting sort in parallel: each thread counts its own contiguous slice per row, the
  // slices' offsets are laid out row by row in thread order, and each thread scatters its
  // slice. Thread t's points of a row follow thread t − 1's, so the order is the serial one
  // for any thread count.
  const int threads = pass.threads;
  std::vector<std::uint32_t>& slot = scratch_.slot;
  slot.assign (std::size_t (threads) * n_phi_, 0);
  // Points beyond the depth cut are marked 2 in is_cand by the counting loop (candidates are
  // kept whatever their depth, as the tests do) and skipped by the scatter.
  constexpr std::uint8_t kDeep = 2;
#pragma omp parallel num_threads(threads)
  {
#ifdef _OPENMP
    const int t = omp_get_thread_num (), nth = omp_get_num_threads ();
#else
    const int t = 0, nth = 1;
#endif
    const std::size_t lo = n * std::size_t (t) / nth, hi = n * std::size_t (t + 1) / nth;
    std::uint32_t* fill = slot.data () + std::size_t (t) * n_phi_;
    for (std::size_t i = lo; i < hi; ++i)
    {
      const std::uint32_t s = sector_[i];
      if (with_cut && rho_[i] > cut[s] && !is_cand[i])
        is_cand[i] = kDeep;
      else
        ++fill[rowOf (s)];
    }
#pragma omp barrier
#pragma omp single
    {
      std::uint32_t at = 0;
      for (int row = 0; row < n_phi_; ++row)
      {
        start[row] = at;
        for (int u = 0; u < nth; ++u)
        {
          std::uint32_t& c = slot[std::size_t (u) * n_phi_ + row];
          const std::uint32_t count = c;
          c = at;
          at += count;
        }
      }
      start[n_phi_] = at;
      depth_culled_ = n - at;
    }
    for (std::size_t i = lo; i < hi; ++i)
    {
      const std::uint32_t s = sector_[i];
      if (is_cand[i] == kDeep)
      {
        if (!survivors)
          interior[i] = 1;
        else if (want_band && seedsBand (rho_[i], cut_near[s]))
          __atomic_store_n (&seed[s], std::uint8_t (1), __ATOMIC_RELAXED);
        continue;
      }
      const std::uint32_t row = rowOf (s);
      const std::uint32_t r = fill[row]++;
      order[r] = std::uint32_t (i);
      sorted[r] = points[i];
      cand_sorted[r] = is_cand[i];
      col_sorted[r] = s - row * std::uint32_t (cols);
    }
  }
}

bool
AngularGrid::insideQuads (const QuadSet* const* quad, int first, const Eigen::Vector3d& p, const Eigen::Vector3d& q,
                          double rho)
{
  // Once the point is inside the cone of a tetrahedron of one quad and above the planes of
  // that quad's tetrahedra, the other quads are not tried: they would have to overlap this
  // one to contain it (stopping only keeps points), and a visible point would otherwise pay
  // for all 16 tetrahedra.
  bool inside = false, in_cone = false;
  for (int kq = 0; kq < 4 && !inside && !in_cone; ++kq)
  {
    const QuadSet& Q = *quad[(first + kq) % 4];
    for (int t = 0; t < Q.count; ++t)
    {
      const Tetra& T = Q.t[t];
      int outside = -1;
      for (int e = 0; e < 3 && outside < 0; ++e)
        if (T.edge[e].dot (p) <= T.cone_eps * rho)
          outside = e;
      if (outside >= 0)
      {
        // Beyond an edge that bounds the quad: the point is outside the quad's cone (when the
        // quad is convex), so its other tetrahedra are skipped (skipping only keeps points).
        if (outside != T.diagonal)
          break;
        continue;
      }
      in_cone = true;
      if (T.w.dot (q - T.f) > T.h)
      {
        inside = true;
        break;
      }
    }
  }
  return inside;
}

void
AngularGrid::runTetrahedronTests (InteriorPass& pass) const
{
  // Survivors of each row, recorded by the tests (row r's from kept[start[row]] to
  // kept_end[row], in row order), so that the band and the output read the survivors only
  // instead of scanning all n twice. A row's seed sectors are its own, so rows in parallel
  // write disjoint seeds.
  const std::size_t n = pass.n;
  const double R2 = pass.R2;
  const bool want_band = pass.want_band;
  const std::vector<int>* survivors = pass.survivors;
  const int cols = n_theta_;
  const std::vector<std::uint32_t>& start = scratch_.start;
  const std::vector<Eigen::Vector3d>& sorted = scratch_.sorted;
  const std::vector<std::uint8_t>& cand_sorted = scratch_.cand_sorted;
  const std::vector<std::uint32_t>& col_sorted = scratch_.col;
  const std::vector<Eigen::Vector3d>& split = scratch_.split;
  std::vector<std::uint8_t>& inside_sorted = scratch_.inside;
  std::vector<std::uint8_t>& seed = scratch_.seed;
  std::vector<std::uint32_t>& kept = scratch_.kept;
  std::vector<std::uint32_t>& kept_end = scratch_.kept_end;
  if (survivors)
  {
    kept.resize (n);
    kept_end.assign (start.begin (), start.begin () + n_phi_);  // rows without points keep none
  }
#pragma omp parallel num_threads(nt ())
  {
    // The quads of the rows above (qa = a − 1) and below (qa = a) the sector row a, indexed by
    // qb + 1 (qb = −1 … cols − 1): a point of sector (a, b) tests the quads (a − 1, b − 1),
    // (a − 1, b), (a, b − 1), (a, b), numbered q = 2·(da + 1) + (db + 1). Each is set up when a
    // point first needs it (stamped with its qa): the refinement grids have more sectors than
    // points. A thread that takes row a + 1 next reuses row a's quads as its upper row.
    std::vector<QuadSet> upper (std::size_t (cols) + 1), lower (std::size_t (cols) + 1);
    int lower_row = -2;
    auto quadAt = [&] (std::vector<QuadSet>& quads, int qa, int qb) -> const QuadSet* {
      QuadSet& Q = quads[std::size_t (qb + 1)];
      if (Q.qa != qa)
      {
        quadTetras (pass, qa, qb, Q.t, Q.count, Q.min_rho);
        Q.qa = qa;
      }
      return &Q;
    };
#pragma omp for schedule(dynamic, 2)
    for (std::ptrdiff_t row = 0; row < std::ptrdiff_t (n_phi_); ++row)
    {
      if (start[row] == start[row + 1])
        continue;
      const int a = int (row);
      if (lower_row == a - 1)
        upper.swap (lower);
      lower_row = a;
      std::uint32_t* keep = survivors ? kept.data () + start[row] : nullptr;
      auto survive = [&keep] (std::uint32_t r) {
        if (keep)
          *keep++ = r;
      };
      for (std::uint32_t r = start[row]; r < start[row + 1]; ++r)
      {
        if (cand_sorted[r])
        {
          survive (r);
          continue;
        }
        const int b = int (col_sorted[r]);
        const QuadSet* quad[4] = {quadAt (upper, a - 1, b - 1), quadAt (upper, a - 1, b), quadAt (lower, a, b - 1),
                                  quadAt (lower, a, b)};
        if (quad[0]->count + quad[1]->count + quad[2]->count + quad[3]->count == 0)
        {
          survive (r);
          continue;
        }
        // A point inside (C, a, b, c) is deeper than the nearest of a, b, c (|q| = 2R − ρ is
        // below the plane's largest |x| over the triangle, 2R − min ρ): points no deeper than
        // every candidate of the 3×3 neighbourhood skip the tests.
        const double min_rho = std::min ({quad[0]->min_rho, quad[1]->min_rho, quad[2]->min_rho, quad[3]->min_rho});
        const Eigen::Vector3d& p = sorted[r];
        const double rho = p.norm ();
        if (rho <= min_rho)
        {
          survive (r);
          continue;
        }
        // The cone tests take p itself, their margin scaled by ρ (no division per point;
        // the margin, 1e-9 of the cone's size, dwarfs the rounding either way).
        const Eigen::Vector3d q = p * (R2 / rho - 1.0);  // the flip of prepareCandidates ()
        // Try first the quad on the point's side of its sector's candidate (the one most likely
        // to contain it), then the other three.
        int first = 0;
        if (gnomonic_)
        {
          const std::size_t s = std::size_t (a) * cols + std::size_t (b);
          first = 2 * (split[2 * s].dot (p) >= 0) + (split[2 * s + 1].dot (p) >= 0);
        }
        const bool inside = insideQuads (quad, first, p, q, rho);
        // A cull within band_depth_ of the nearest candidate around it seeds the band.
        if (!inside)
          survive (r);
        else if (!survivors)
          inside_sorted[r] = 1;
        else if (want_band && seedsBand (rho, min_rho))
          seed[std::size_t (a) * cols + std::size_t (b)] = 1;
      }
      if (keep)
        kept_end[row] = std::uint32_t (keep - kept.data ());
    }
  }
}

void
AngularGrid::markUncertainBand (const InteriorPass& pass) const
{
  // The uncertain band: sectors whose 3×3 neighbourhood holds a culled point or a sector
  // without candidate (a silhouette, the grid's edge). Elsewhere every point had only
  // front-surface points around it, and a finer pass culls (nearly) nothing there.
  const std::size_t k = pass.k;
  std::vector<std::uint8_t>& seed = scratch_.seed;
  std::vector<std::uint8_t>& band = scratch_.band;
  band.clear ();
  if (!pass.want_band)
    return;
  for (std::size_t s = 0; s < k; ++s)
    if (cand_[s] < 0)
      seed[s] = 1;
  band.assign (k, 0);
  const Shape grid = shape ();
  for (int a = 0; a < grid.rows; ++a)
    for (int b = 0; b < grid.cols; ++b)
    {
      std::uint8_t any = 0;
      for (int da = -1; da <= 1 && !any; ++da)
        for (int db = -1; db <= 1 && !any; ++db)
        {
          // Outside the grid counts as empty: the cloud's outline.
          const std::ptrdiff_t t = grid.neighbour (a, b, da, db);
          any = t < 0 ? 1 : seed[std::size_t (t)];
        }
      band[std::size_t (a) * n_theta_ + b] = any;
    }
}

void
AngularGrid::writeInteriorOutput (InteriorPass& pass) const
{
  const std::size_t n = pass.n;
  const int threads = pass.threads;
  const std::vector<std::uint32_t>& order = scratch_.order;
  if (!pass.survivors)
  {
    const std::vector<std::uint8_t>& inside_sorted = scratch_.inside;
    std::vector<std::uint8_t>& interior = pass.interior;
#pragma omp parallel for num_threads(threads) schedule(static)
    for (std::ptrdiff_t r = 0; r < std::ptrdiff_t (n); ++r)
      interior[order[r]] = inside_sorted[r] != 0;
    return;
  }
  // The caller reads the survivors; the per-point mask (a random scatter) is left empty.
  // With `outside_band`, survivors outside the band go there and the others (the band) to
  // `survivors`: the caller marks the first visible and refines the second, without a
  // second pass that splits them. Rows are counted, then written, in parallel (each row at
  // its prefix offset: the serial order), and the outputs are sized exactly first.
  std::vector<int>* survivors = pass.survivors;
  std::vector<Eigen::Vector3d>* survivor_points = pass.survivor_points;
  std::vector<std::uint8_t>* survivor_in_band = pass.survivor_in_band;
  std::vector<int>* outside_band = pass.outside_band;
  pass.interior.clear ();
  const int cols = n_theta_;
  const std::vector<std::uint32_t>& start = scratch_.start;
  const std::vector<std::uint32_t>& kept = scratch_.kept;
  const std::vector<std::uint32_t>& kept_end = scratch_.kept_end;
  const std::vector<std::uint32_t>& col_sorted = scratch_.col;
  const std::vector<Eigen::Vector3d>& sorted = scratch_.sorted;
  const std::vector<std::uint8_t>& band = scratch_.band;
  // Sector of the r-th point in row order, without a random read of sector_.
  auto sectorSorted = [&] (int row, std::uint32_t r) { return std::size_t (row) * cols + col_sorted[r]; };
  std::vector<std::uint32_t> n_kept (std::size_t (n_phi_) + 1, 0), kept_band (std::size_t (n_phi_) + 1, 0);
#pragma omp parallel for num_threads(threads) schedule(dynamic, 4)
  for (std::ptrdiff_t row = 0; row < std::ptrdiff_t (n_phi_); ++row)
  {
    std::uint32_t in_band = 0;
    if (outside_band)
      for (std::uint32_t j = start[row]; j < kept_end[row]; ++j)
        in_band += band[sectorSorted (int (row), kept[j])];
    n_kept[row + 1] = kept_end[row] - start[row];
    kept_band[row + 1] = in_band;
  }
  for (int row = 0; row < n_phi_; ++row)
  {
    n_kept[row + 1] += n_kept[row];
    kept_band[row + 1] += kept_band[row];
  }
  const std::size_t to_survivors = outside_band ? kept_band[n_phi_] : n_kept[n_phi_];
  survivors->resize (to_survivors);
  if (survivor_points)
    survivor_points->resize (to_survivors);
  if (survivor_in_band)
    survivor_in_band->resize (to_survivors);
  if (outside_band)
    outside_band->resize (n_kept[n_phi_] - kept_band[n_phi_]);
#pragma omp parallel for num_threads(threads) schedule(dynamic, 4)
  for (std::ptrdiff_t row = 0; row < std::ptrdiff_t (n_phi_); ++row)
  {
    std::size_t j = outside_band ? kept_band[row] : n_kept[row], o = n_kept[row] - kept_band[row];
    for (std::uint32_t i = start[row]; i < kept_end[row]; ++i)
    {
      const std::uint32_t r = kept[i];
      const bool in_band = !band.empty () && band[sectorSorted (int (row), r)];
      if (outside_band && !in_band)
      {
        (*outside_band)[o++] = int (order[r]);
        continue;
      }
      (*survivors)[j] = int (order[r]);
      if (survivor_points)
        (*survivor_points)[j] = sorted[r];
      if (survivor_in_band)
        (*survivor_in_band)[j] = in_band;
      ++j;
    }
  }
}

AngularGrid::Calibration
AngularGrid::calibrate () const
{
  const std::size_t k = cand_.size ();
  const std::ptrdiff_t n = std::ptrdiff_t (unit_.size ());
  std::vector<double> min_rho (k, std::numeric_limits<double>::infinity ());
  for (std::ptrdiff_t i = 0; i < n; ++i)
    min_rho[sector_[i]] = std::min (min_rho[sector_[i]], rho_[i]);
  // Visible-count estimate (Machado e Silva et al. 2014, §6): per sector, points roughly as near as the nearest one,
  // "roughly" being one sector footprint at that depth.
  double visible = 0;
  for (std::ptrdiff_t i = 0; i < n; ++i)
  {
    const double m = min_rho[sector_[i]];
    visible += rho_[i] <= m * (1.0 + 2.0 * cell_);
  }
  Calibration c;
  for (std::size_t s = 0; s < k; ++s)
    if (cand_[s] >= 0)
      c.occupied_solid_angle += cellSolidAngle (s);
  c.visible_estimate = std::max (1.0, visible);
  // Eq. 5 with a = 0.5: the number of bins in which visible_estimate balls occupy half.
  const double a = 0.5;
  const double bins = -1.0 / (std::pow (1.0 - a, 1.0 / c.visible_estimate) - 1.0);
  c.alpha = 2.0 * std::sqrt (c.occupied_solid_angle / bins);
  return c;
}

}  // namespace detail
}  // namespace hpr
}  // namespace pclx

