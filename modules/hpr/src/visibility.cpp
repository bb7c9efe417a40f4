#include <pclx/hpr/detail/angular_grid.h>
#include <pclx/hpr/detail/qhull_visibility.h>
#include <pclx/hpr/detail/visibility.h>

#include "stage_profile.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <fstream>
#include <string>
#include <unordered_map>

#ifdef _OPENMP
#include <omp.h>
#endif
#ifdef __linux__
#include <sys/syscall.h>  // SYS_gettid
#include <unistd.h>
#endif

namespace pclx {
namespace hpr {
namespace detail {

namespace {

Eigen::Vector3d
centroidOf (const std::vector<Eigen::Vector3d>& pts)
{
  Eigen::Vector3d c = Eigen::Vector3d::Zero ();
  for (const auto& p : pts)
    c += p;
  return c / double (std::max<std::size_t> (1, pts.size ()));
}

// Flipped cloud (Eq. 1) in double: R ≫ ρ leaves the depth differences in the low digits.
std::vector<Eigen::Vector3d>
flip (const std::vector<Eigen::Vector3d>& pts, const std::vector<int>& ids, double R, int threads)
{
  std::vector<Eigen::Vector3d> out (ids.size ());
  const std::ptrdiff_t m = std::ptrdiff_t (ids.size ());
#pragma omp parallel for num_threads(threads) schedule(dynamic, 8192)
  for (std::ptrdiff_t i = 0; i < m; ++i)
  {
    const Eigen::Vector3d& p = pts[ids[i]];
    const double rho = p.norm ();
    out[i] = p * (2.0 * R / rho - 1.0);
  }
  return out;
}

// Hull of the flipped `ids` (+ C); marks vertices visible, maps triangles back.
bool
hullVisibility (const std::vector<Eigen::Vector3d>& pts, const std::vector<int>& ids, double R, bool triangles,
                VisibilityResult& res, int threads)
{
  const std::vector<Eigen::Vector3d> flipped = flip (pts, ids, R, threads);
  HullResult hull = flippedHull (flipped, triangles);
  if (!hull.ok)
  {
    // Degenerate input (e.g. every point in one plane through C): joggle gives a defined answer.
    hull = flippedHull (flipped, triangles, true);
    if (!hull.ok)
    {
      res.error = "Qhull failed: " + hull.error;
      return false;
    }
    res.warning += "degenerate input for the convex hull (flat or collinear): Qhull joggled it (QJ); ";
  }
  for (int v : hull.vertices)
    res.visible[ids[v]] = 1;
  for (const auto& t : hull.triangles)
    res.triangles.emplace_back (ids[t[0]], ids[t[1]], ids[t[2]]);
  return true;
}

void
filterLongEdges (const std::vector<Eigen::Vector3d>& pts, float max_edge, std::vector<Eigen::Vector3i>& tris)
{
  if (tris.empty ())
    return;
  if (max_edge <= 0)
  {
    std::vector<float> e;
    e.reserve (tris.size ());
    for (const auto& t : tris)
      e.push_back ((pts[t[0]] - pts[t[1]]).norm ());
    std::nth_element (e.begin (), e.begin () + e.size () / 2, e.end ());
    max_edge = 5.f * e[e.size () / 2];
  }
  const float m2 = max_edge * max_edge;
  tris.erase (std::remove_if (tris.begin (), tris.end (),
                              [&] (const Eigen::Vector3i& t) {
                                return (pts[t[0]] - pts[t[1]]).squaredNorm () > m2 ||
                                       (pts[t[1]] - pts[t[2]]).squaredNorm () > m2 ||
                                       (pts[t[2]] - pts[t[0]]).squaredNorm () > m2;
                              }),
              tris.end ());
}

// Normals and splats from hull triangles: area-weighted, facing the viewpoint.
void
meshNormals (const std::vector<Eigen::Vector3d>& pts, const std::vector<Eigen::Vector3i>& tris,
             VisibilityResult& res)
{
  std::vector<Eigen::Vector3f> acc (pts.size (), Eigen::Vector3f::Zero ());
  res.splat_radius.assign (pts.size (), 0.f);
  for (const auto& t : tris)
  {
    const Eigen::Vector3f n = (pts[t[1]] - pts[t[0]]).cross (pts[t[2]] - pts[t[0]]).cast<float> ();
    for (int k = 0; k < 3; ++k)
    {
      acc[t[k]] += n;
      const float e = float ((pts[t[k]] - pts[t[(k + 1) % 3]]).norm () / 2);
      res.splat_radius[t[k]] = std::max (res.splat_radius[t[k]], e);
      res.splat_radius[t[(k + 1) % 3]] = std::max (res.splat_radius[t[(k + 1) % 3]], e);
    }
  }
  res.normals.assign (pts.size (), Eigen::Vector3f::Constant (std::numeric_limits<float>::quiet_NaN ()));
  for (std::size_t i = 0; i < pts.size (); ++i)
    if (res.visible[i])
    {
      const Eigen::Vector3f to_eye = (-pts[i]).cast<float> ();
      Eigen::Vector3f n = acc[i].norm () > 0 ? acc[i].normalized () : to_eye.normalized ();
      res.normals[i] = n.dot (to_eye) < 0 ? Eigen::Vector3f (-n) : n;
    }
}

// Exact duplicates share the visibility (and normal, splat) of their visible twin: the hull
// and the grid keep one copy.
void
shareWithDuplicates (const std::vector<Eigen::Vector3d>& pts, VisibilityResult& sub)
{
  std::vector<std::uint8_t>& visible = sub.visible;
  struct Hash
  {
    std::size_t operator() (const Eigen::Vector3d& p) const
    {
      std::uint64_t b[3];
      std::memcpy (b, p.data (), sizeof b);
      return (std::size_t (b[0]) * 73856093u) ^ (std::size_t (b[1]) * 19349663u) ^ (std::size_t (b[2]) * 83492791u);
    }
  };
  std::unordered_map<Eigen::Vector3d, int, Hash> seen;
  seen.reserve (pts.size () / 2);
  for (std::size_t i = 0; i < pts.size (); ++i)
    if (visible[i])
      seen.emplace (pts[i], int (i));
  for (std::size_t i = 0; i < pts.size (); ++i)
  {
    if (visible[i])
      continue;
    const auto twin = seen.find (pts[i]);
    if (twin == seen.end ())
      continue;
    visible[i] = 1;
    if (!sub.normals.empty ())
    {
      sub.normals[i] = sub.normals[twin->second];
      sub.splat_radius[i] = sub.splat_radius[twin->second];
    }
  }
}

// Points that are not provably interior to the hull of the flipped cloud: the angular
// grid's candidates after `steps` of propagation span local tetrahedra (C, a, b, c);
// points strictly inside one are hidden. The rest holds every hull vertex.
std::vector<std::uint8_t>
interiorMask (AngularGrid& grid, const std::vector<Eigen::Vector3d>& pts, const Eigen::Vector3d& centre, double R,
              std::size_t sectors, int steps)
{
  grid.build (pts, centre, R, sectors);
  grid.propagateAdaptive (steps);
  return grid.interiorPoints (pts);
}

std::vector<int>
cullInterior (AngularGrid& grid, const std::vector<Eigen::Vector3d>& pts, const Eigen::Vector3d& centre, double R,
              std::size_t sectors, int steps)
{
  const std::vector<std::uint8_t> interior = interiorMask (grid, pts, centre, R, sectors, steps);
  std::vector<int> keep;
  keep.reserve (pts.size () / 2);
  for (std::size_t i = 0; i < pts.size (); ++i)
    if (!interior[i])
      keep.push_back (int (i));
  return keep;
}

#if defined(__linux__) && defined(_OPENMP)
// OpenMP's worker threads spin for a while after a parallel region ends (libgomp's default
// wait policy), so right after one of ours, or any other OpenMP code run from the same thread
// (it reuses the same workers), /proc/loadavg counts them as runnable, and the rule below read them
// as another process on the cores: back-to-back calls on an idle machine would then run on
// one thread. The workers' ids are noted here; the ones found running are not counted. Any
// other busy thread, of this process or another, still is. Per calling thread: libgomp gives
// each thread that opens parallel regions its own pool of workers.
constexpr int kMaxNotedWorkers = 64;
thread_local std::array<pid_t, kMaxNotedWorkers> noted_workers{};

pid_t
threadId ()
{
  return static_cast<pid_t> (syscall (SYS_gettid));
}

void
noteWorkers (int threads)
{
  pid_t* slots = noted_workers.data ();  // the calling thread's list (workers have their own)
#pragma omp parallel num_threads(threads)
  {
    const int t = omp_get_thread_num ();
    if (t > 0 && t < kMaxNotedWorkers)
      slots[t] = threadId ();
  }
}

// Noted workers of the calling thread that are running now.
int
runningWorkers ()
{
  int running = 0;
  for (const pid_t tid : noted_workers)
  {
    if (tid <= 0)
      continue;
    std::ifstream stat ("/proc/self/task/" + std::to_string (tid) + "/stat");
    std::string line;
    if (!std::getline (stat, line))
      continue;
    // "tid (comm) S ...": the state follows the last parenthesis.
    const std::size_t close = line.rfind (')');
    running += close != std::string::npos && close + 2 < line.size () && line[close + 2] == 'R';
  }
  return running;
}
#endif

}  // namespace

int
autoThreads (std::size_t points)
{
#ifdef _OPENMP
  int threads = omp_get_max_threads ();
#else
  int threads = 1;
#endif
  // A parallel pass over fewer points than this costs more in wake-ups than it saves.
  constexpr std::size_t kPointsPerThread = 32768;
  threads = std::min<std::size_t> (threads, std::max<std::size_t> (1, points / kPointsPerThread));
  if (threads <= 1)
    return 1;
#if defined(__linux__) && defined(_OPENMP)
  // Field 4 of /proc/loadavg is "runnable/total" scheduling entities right now (this thread
  // included); the 1-minute averages would lag a pipeline by a minute. Our own spinning
  // OpenMP workers are not load (see noteWorkers).
  std::ifstream f ("/proc/loadavg");
  double l1, l5, l15;
  int runnable = 0;
  char slash;
  if (f >> l1 >> l5 >> l15 >> runnable >> slash)
  {
    const int free_cores = omp_get_num_procs () - std::max (0, runnable - 1 - runningWorkers ());
    threads = std::clamp (free_cores, 1, threads);
  }
  // Noted only when this call will wake them anyway: a region of its own on a busy machine
  // would wait for a worker the scheduler has not run yet.
  if (threads > 1)
    noteWorkers (threads);
#endif
  return threads;
}

bool
isEdgeOn (const std::vector<Eigen::Vector3d>& points, double tolerance)
{
  if (points.size () < 3)
    return true;
  const double ulps = 8.0 * std::numeric_limits<float>::epsilon ();
  // Quick rejection (the common case): three sample points that span a volume with C which
  // no flat cloud within the tolerance can span. If every point is within t of a plane
  // through C, |det (a, b, c)| ≤ t·(|a × b| + |b × c| + |c × a|) (each point's height times
  // the area of the opposite face, summed).
  {
    const std::size_t stride = std::max<std::size_t> (1, points.size () / 64);
    const Eigen::Vector3d& a = points[0];
    std::size_t jb = 0;
    double best = -1;
    for (std::size_t j = 0; j < points.size (); j += stride)
      if (const double c = a.cross (points[j]).squaredNorm (); c > best)
      {
        best = c;
        jb = j;
      }
    const Eigen::Vector3d& b = points[jb];
    for (std::size_t j = 0; j < points.size (); j += stride)
    {
      const Eigen::Vector3d& c = points[j];
      const double t = tolerance + ulps * std::max ({a.norm (), b.norm (), c.norm ()});
      if (std::abs (a.cross (b).dot (c)) > 2.0 * t * (a.cross (b).norm () + b.cross (c).norm () + c.cross (a).norm ()))
        return false;
    }
  }
  // The plane through C (the origin) that fits best: the smallest eigenvector of Σ p pᵀ.
  Eigen::Matrix3d m = Eigen::Matrix3d::Zero ();
  for (const auto& p : points)
  {
    const double r = p.norm ();
    if (r > 0)
      m.noalias () += (p / r) * (p / r).transpose ();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es (m);
  const Eigen::Vector3d normal = es.eigenvectors ().col (0);
  for (const auto& p : points)
    if (std::abs (normal.dot (p)) > tolerance + ulps * p.norm ())
      return false;
  return true;
}

namespace {
// estimateSurfaceNoise in parts, so that the candidate hull can gather the seeds' neighbours
// in the pass over the points it makes anyway (distancesOf) rather than reading the points
// again in a pass of its own. A kd-tree over the whole cloud
// would cost more than the rest of the call, and one over a subsample has neighbourhoods
// that span both faces of thin walls.
class NoiseProbe
{
public:
  NoiseProbe (const std::vector<Eigen::Vector3d>& points, std::size_t seeds, int k) : k_ (k)
  {
    const std::size_t n = points.size ();
    if (k < 4 || seeds == 0 || n < std::size_t (4 * k))
      return;
    const std::size_t stride = std::max<std::size_t> (1, n / seeds);
    for (std::size_t i = stride / 2; i < n; i += stride)
      seed_ids_.push_back (i);
    // Voxels of side h hold ~10 points of a surface of area ~2πr² (a closed object in a ball
    // of radius r, here from the seeds): the 2×2×2 voxels nearest a seed then hold its k
    // nearest neighbours with room to spare.
    Eigen::Vector3d mean = Eigen::Vector3d::Zero ();
    for (std::size_t i : seed_ids_)
      mean += points[i];
    mean /= double (seed_ids_.size ());
    double r = 0;
    for (std::size_t i : seed_ids_)
      r = std::max (r, (points[i] - mean).norm ());
    if (!(r > 0))
    {
      seed_ids_.clear ();
      return;
    }
    inv_h_ = 1.0 / (r * std::sqrt (64.0 / double (n)));
    bits_.assign ((std::size_t (1) << kBits) / 64, 0);
    for (std::size_t i : seed_ids_)
    {
      const Eigen::Vector3d v = points[i] * inv_h_;
      // The 2×2×2 block of voxels whose centre is nearest the seed.
      const std::int64_t x = floorInt (v.x () - 0.5), y = floorInt (v.y () - 0.5), z = floorInt (v.z () - 0.5);
      std::array<std::uint64_t, 8> vox;
      for (int c = 0; c < 8; ++c)
      {
        vox[c] = key (x + (c & 1), y + ((c >> 1) & 1), z + ((c >> 2) & 1));
        const std::size_t b = slot (vox[c]);
        bits_[b / 64] |= std::uint64_t (1) << (b % 64);
        buckets_.emplace (vox[c], std::vector<int> ());
      }
      seed_voxels_.push_back (vox);
    }
  }
  bool active () const { return !seed_ids_.empty (); }
  // A hashed bit set of the seeds' voxels rejects almost every point with one load; the few
  // that pass are bucketed by their exact voxel (hits: (voxel, index) for add () later, so that
  // threads can collect their own).
  void visit (const Eigen::Vector3d& p, int i, std::vector<std::pair<std::uint64_t, int>>* hits = nullptr)
  {
    const Eigen::Vector3d v = p * inv_h_;
    const std::uint64_t kk = key (floorInt (v.x ()), floorInt (v.y ()), floorInt (v.z ()));
    const std::size_t b = slot (kk);
    if (!(bits_[b / 64] >> (b % 64) & 1))
      return;
    if (hits)
      hits->emplace_back (kk, i);
    else
      add (kk, i);
  }
  void add (std::uint64_t kk, int i)
  {
    const auto it = buckets_.find (kk);
    if (it != buckets_.end ())
      it->second.push_back (i);
  }
  // The lower quartile of the seeds' plane-fit thickness (0: too few seeds with k neighbours).
  double finish (const std::vector<Eigen::Vector3d>& points)
  {
    std::vector<double> thickness;
    thickness.reserve (seed_ids_.size ());
    std::vector<std::pair<double, int>> near;
    for (std::size_t s = 0; s < seed_ids_.size (); ++s)
    {
      const Eigen::Vector3d& p = points[seed_ids_[s]];
      near.clear ();
      for (std::uint64_t kk : seed_voxels_[s])
        for (int j : buckets_[kk])
          near.emplace_back ((points[j] - p).squaredNorm (), j);
      if (near.size () < std::size_t (k_))
        continue;
      std::nth_element (near.begin (), near.begin () + (k_ - 1), near.end ());
      Eigen::Vector3d mean = Eigen::Vector3d::Zero ();
      for (int j = 0; j < k_; ++j)
        mean += points[near[j].second];
      mean /= double (k_);
      Eigen::Matrix3d cov = Eigen::Matrix3d::Zero ();
      for (int j = 0; j < k_; ++j)
      {
        const Eigen::Vector3d d = points[near[j].second] - mean;
        cov += d * d.transpose ();
      }
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
      es.computeDirect (cov / double (k_), Eigen::EigenvaluesOnly);
      thickness.push_back (std::sqrt (std::max (es.eigenvalues ()[0], 0.0)));
    }
    if (thickness.size () < 16)
      return 0;
    // The lower quartile, not the median: edges, corners and thin walls (both faces within
    // the neighbourhood) read thicker than the surface's noise; noise is everywhere.
    auto q = thickness.begin () + thickness.size () / 4;
    std::nth_element (thickness.begin (), q, thickness.end ());
    return *q;
  }

private:
  static constexpr int kBits = 18;
  static std::int64_t floorInt (double v)
  {
    const std::int64_t t = std::int64_t (v);
    return t - (double (t) > v);
  }
  static std::uint64_t key (std::int64_t x, std::int64_t y, std::int64_t z)
  {
    return (std::uint64_t (x & 0x1fffff) << 42) | (std::uint64_t (y & 0x1fffff) << 21) | std::uint64_t (z & 0x1fffff);
  }
  static std::size_t slot (std::uint64_t kk) { return std::size_t ((kk * 0x9E3779B97F4A7C15ull) >> (64 - kBits)); }
  int k_;
  double inv_h_ = 0;
  std::vector<std::size_t> seed_ids_;
  std::vector<std::array<std::uint64_t, 8>> seed_voxels_;
  std::vector<std::uint64_t> bits_;
  std::unordered_map<std::uint64_t, std::vector<int>> buckets_;
};

// The distances of a calibration (cloud radius, reference and largest distance from C);
// with `probe`, its pass over the points also gathers the probe's neighbours.
HPRCalibration
distancesOf (const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& centre, int threads,
             NoiseProbe* probe = nullptr)
{
  HPRCalibration cal;
  const std::size_t n = points.size ();
  // Sums per fixed block, added in block order: independent of the thread count.
  constexpr std::size_t kBlock = 65536;
  const std::size_t blocks = (n + kBlock - 1) / kBlock;
  std::vector<double> block_rho (blocks, 0.0);
  if (probe && !probe->active ())
    probe = nullptr;
  // Per block, the points the probe wants (added in block order: thread-count independent).
  std::vector<std::vector<std::pair<std::uint64_t, int>>> hits (probe && threads > 1 ? blocks : 0);
  double max_rho = 0, r = 0;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1) reduction(max : max_rho, r)
  for (std::ptrdiff_t b = 0; b < std::ptrdiff_t (blocks); ++b)
  {
    double sum = 0;
    for (std::size_t i = std::size_t (b) * kBlock, e = std::min (n, i + kBlock); i < e; ++i)
    {
      const Eigen::Vector3d& p = points[i];
      const double rho = p.norm ();
      max_rho = std::max (max_rho, rho);
      r = std::max<double> (r, (p - centre).squaredNorm ());
      sum += rho;
      if (probe)
        probe->visit (p, int (i), hits.empty () ? nullptr : &hits[b]);
    }
    block_rho[b] = sum;
  }
  for (const auto& block : hits)
    for (const auto& h : block)
      probe->add (h.first, h.second);
  double mean_rho = 0;
  for (double b : block_rho)
    mean_rho += b;
  r = std::sqrt (r);
  mean_rho /= double (std::max<std::size_t> (n, 1));
  cal.cloud_radius = r;
  // Typical distance of the surface from the viewer (inside the cloud: the mean).
  cal.reference_distance = centre.norm () > r ? double (centre.norm ()) : mean_rho;
  cal.max_distance = max_rho;
  return cal;
}
}  // namespace

HPRCalibration
calibrateHPR (const std::vector<Eigen::Vector3d>& points, const VisibilityOptions& options)
{
  const std::size_t n = points.size ();
  const Eigen::Vector3d centre = centroidOf (points);
  const int threads = options.threads > 0 ? options.threads : autoThreads (n);
  HPRCalibration cal = distancesOf (points, centre, threads);
  const double max_rho = cal.max_distance;

  // A coarse grid, ~16 points per sector, is the balls-in-bins sample.
  AngularGrid coarse;
  coarse.setThreads (threads);
  coarse.build (points, centre, 1e3 * max_rho + 1.0, std::clamp<std::size_t> (n / 16, 16, std::size_t (1) << 20));
  const AngularGrid::Calibration c = coarse.calibrate ();
  cal.alpha = c.alpha;
  cal.visible_estimate = c.visible_estimate;

  cal.radius = radiusForSeparation (cal, c.alpha, options.occlusion_depth);

  // k: `oversampling` sectors per visible-point cell of angular size α/2, capped by the screen.
  const double area = coarse.gridSolidAngle ();
  double k = options.oversampling * area / std::pow (c.alpha / 2, 2);
  if (options.view_pixels > 0 && options.view_fov > 0)
    k = std::min (k, area / std::pow (options.view_fov / options.view_pixels, 2));
  cal.sectors = std::size_t (std::clamp (k, 16.0, double (kMaxSectors)));
  cal.grid_area = area;
  cal.steps = propagationSteps (cal, cal.sectors);
  return cal;
}

double
radiusForSeparation (const HPRCalibration& cal, double alpha, double occlusion_depth)
{
  // Fig. 9: two points at unit distance, α apart, occlude a point d further away when
  // (2R − 1 − d) / (2R − 1) = cos(α/2); d is the occlusion depth relative to rho_ref.
  const double d = occlusion_depth * cal.cloud_radius / std::max (cal.reference_distance, 1e-30);
  const double one_minus_cos = std::max (1.0 - std::cos (alpha / 2), 1e-15);
  const double R = cal.reference_distance * (1.0 + d / one_minus_cos) / 2.0;
  return std::max (R, cal.max_distance * (1.0 + 1e-3));
}

double
estimateSurfaceNoise (const std::vector<Eigen::Vector3d>& points, std::size_t seeds, int k)
{
  NoiseProbe probe (points, seeds, k);
  if (probe.active ())
    for (std::size_t i = 0; i < points.size (); ++i)
      probe.visit (points[i], int (i));
  return probe.finish (points);
}

double
candidateHullDepth (double occlusion_depth, double cloud_radius, double noise)
{
  // CANDIDATE_HULL calibrates its R at 0.8 of the occlusion depth (R is linear in it). With
  // the outline candidates its culling gets close to the exact operator's at the same R, and
  // the smaller R culls the backs of thin parts seen face-on; both values were chosen on the
  // wide benchmark (docs/hpr.md).
  constexpr double kCandidateHullDepthScale = 0.8;
  // On noisy input the candidates are the front-most noisy points and a smaller R culls the
  // noisy front surface behind them: the depth grows to kNoiseDepths × the measured noise
  // (estimateSurfaceNoise) where that is deeper. Clean clouds measure far below the threshold
  // (the depth stays 0.8 × occlusion_depth).
  constexpr double kNoiseDepths = 60.0;
  return std::max (kCandidateHullDepthScale * occlusion_depth, kNoiseDepths * noise / std::max (cloud_radius, 1e-300));
}

int
propagationSteps (const HPRCalibration& cal, std::size_t k)
{
  if (!(cal.grid_area > 0) || !(cal.alpha > 0))
    return 1;
  const double fine_cell = std::sqrt (cal.grid_area / double (std::max<std::size_t> (k, 1)));
  return int (std::min (std::ceil (cal.alpha / fine_cell), 1e6)) + 1;
}

void
VisibilityWorkspace::release ()
{
  grid = AngularGrid ();
  fine = AngularGrid ();
  std::vector<int> ().swap (alive);
  std::vector<int> ().swap (next);
  std::vector<int> ().swap (settled);
  std::vector<Eigen::Vector3d> ().swap (alive_pts);
  std::vector<Eigen::Vector3d> ().swap (next_pts);
  std::vector<Eigen::Vector3d> ().swap (points);
  std::vector<int> ().swap (finite);
  std::vector<std::uint8_t> ().swap (state);
}

namespace {

// computeVisibility's first pass: min and max |p|² and the sum of the points, from the
// caller's statistics when it gathered them. The sums are per fixed block, added in block
// order: the centroid does not depend on the thread count.
struct PointSums
{
  double max_rho2 = 0, min_rho2 = std::numeric_limits<double>::infinity ();
  Eigen::Vector3d sum = Eigen::Vector3d::Zero ();
};

PointSums
sumPoints (const std::vector<Eigen::Vector3d>& points, const PointStats* stats, int threads)
{
  const std::size_t n = points.size ();
  const std::size_t blocks = (n + kStatsBlock - 1) / kStatsBlock;
  PointSums out;
  if (stats && stats->block_sum.size () == blocks)
  {
    out.max_rho2 = stats->max_rho2;
    out.min_rho2 = stats->min_rho2;
    for (const auto& b : stats->block_sum)
      out.sum += b;
    return out;
  }
  double max_rho2 = 0, min_rho2 = std::numeric_limits<double>::infinity ();
  std::vector<Eigen::Vector3d> block_sum (blocks, Eigen::Vector3d::Zero ());
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1) reduction(max : max_rho2) reduction(min : min_rho2)
  for (std::ptrdiff_t b = 0; b < std::ptrdiff_t (blocks); ++b)
  {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero ();
    for (std::size_t i = std::size_t (b) * kStatsBlock, e = std::min (n, i + kStatsBlock); i < e; ++i)
    {
      const Eigen::Vector3d& p = points[i];
      const double r2 = p.squaredNorm ();
      max_rho2 = std::max (max_rho2, r2);
      min_rho2 = std::min (min_rho2, r2);
      sum += p;
    }
    block_sum[b] = sum;
  }
  out.max_rho2 = max_rho2;
  out.min_rho2 = min_rho2;
  for (const auto& b : block_sum)
    out.sum += b;
  return out;
}

// What the method stages of computeVisibility share: the points (those at the viewpoint
// left out), the options, and R, k and ℓ as given or calibrated.
struct MethodInput
{
  const std::vector<Eigen::Vector3d>& pts;
  const VisibilityOptions& opt;
  VisibilityWorkspace* ws;  // buffers kept between calls, or nullptr
  int threads = 1;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero ();  // the centroid of pts
  double R = 0;                        // the candidate hull may calibrate its own
  std::size_t k = 0;                   // sectors of the grid-sampling methods
  std::size_t k_cull = 0;              // sectors of the candidate hull's culling grid
  std::size_t k_cull_default = 0;      // sectors of the exact pre-filter's culling grid
  int steps = 0;                       // ℓ (adaptive) or m (fixed)

  MethodInput (const std::vector<Eigen::Vector3d>& points, const VisibilityOptions& options, VisibilityWorkspace* w)
    : pts (points), opt (options), ws (w)
  {
  }
};

// R, k and ℓ of `in`: as given, or calibrated where the method uses them (the grid-sampling
// methods' k and ℓ; the candidate hull calibrates R on its own culling grid).
void
planMethod (MethodInput& in, VisibilityResult& res)
{
  const VisibilityOptions& opt = in.opt;
  const std::size_t n = in.pts.size ();
  const bool grid_sampled = opt.method == VisibilityMethod::ANGULAR_GRID || opt.method == VisibilityMethod::KAVAN ||
                            opt.method == VisibilityMethod::HYBRID ||
                            opt.method == VisibilityMethod::BENTLEY_FAUST_PREPARATA;
  const bool ch_only = opt.method == VisibilityMethod::CANDIDATE_HULL;
  const bool need_cal = (opt.radius <= 0 && !ch_only) || (grid_sampled && opt.sectors == 0) ||
                        (opt.method == VisibilityMethod::ANGULAR_GRID && opt.steps == 0 && !opt.fixed_propagation);
  HPRCalibration cal;
  res.threads = in.threads;
  if (need_cal)
  {
    VisibilityOptions copt = opt;
    copt.threads = in.threads;
    cal = calibrateHPR (in.pts, copt);
  }
  // The culling grid of CANDIDATE_HULL and of the exact pre-filter, k = 2·n^0.7 (chosen on
  // the benchmark, see docs/hpr.md): finer grids make smaller triangles that cover fewer
  // points, coarser ones sag. Its triangles span a cell diagonal, not the spacing of visible
  // points, so CANDIDATE_HULL's own R makes such a triangle hide a point one occlusion depth
  // behind it.
  in.k_cull_default = std::size_t (std::max (64.0, 2.0 * std::pow (double (n), 0.7)));
  in.k_cull = opt.sectors > 0 ? std::min ({opt.sectors, kMaxSectors, 64 * n}) : in.k_cull_default;
  in.R = opt.radius > 0 ? opt.radius : cal.radius;
  std::size_t k = opt.sectors > 0 ? opt.sectors : cal.sectors;
  // More than 64 sectors per point only adds empty sectors (the visible count saturates
  // near a few sectors per point, Machado e Silva et al. 2014, §7.2).
  const std::size_t k_cap = std::min (kMaxSectors, 64 * n);
  if (k > k_cap)
  {
    res.warning += "k = " + std::to_string (k) + " clamped to " + std::to_string (k_cap) + "; ";
    k = k_cap;
  }
  in.k = k;
  in.steps = opt.steps > 0 ? opt.steps : (need_cal ? propagationSteps (cal, k) : 0);
  res.radius = in.R;
}

std::vector<int>
everyPoint (std::size_t n)
{
  std::vector<int> all (n);
  for (std::size_t i = 0; i < n; ++i)
    all[i] = int (i);
  return all;
}

// CANDIDATE_HULL's refinement: the survivors in `alive` (positions in `alive_pts`) again, on
// grids 2×, 4×, ... finer, at the same R. A finer triangle sags less below the surface (the
// depth band it leaves ∝ R·(triangle size)²), so hidden points just behind the surface
// (silhouettes, thin parts) are culled, and a point inside a tetrahedron of survivors is
// inside the hull of all points: the test stays conservative (every hull vertex survives),
// whichever survivors span it. Only the uncertain band goes on (survivors within one sector
// of a culled point or of a silhouette, see interiorPoints): elsewhere the previous pass saw
// front-surface points only; the rest are marked visible in `sub` as they settle. The band's
// finer grid keeps the cell it would have had over all survivors (`cell0` halved per pass in
// area). Survivors come in the previous grid's sector order, nearly the finer one's.
void
refineSurvivors (const MethodInput& in, double band_depth, double cell0, std::vector<int>& alive,
                 std::vector<Eigen::Vector3d>& alive_pts, std::vector<int>& settled, VisibilityResult& sub)
{
  HPR_LAPS ();
  const VisibilityOptions& opt = in.opt;
  const bool reuse = in.ws && opt.method == VisibilityMethod::CANDIDATE_HULL;
  AngularGrid local_fine;
  std::vector<int> local_next;
  std::vector<Eigen::Vector3d> local_next_pts;
  std::vector<int>& next = reuse ? in.ws->next : local_next;
  std::vector<Eigen::Vector3d>& next_pts = reuse ? in.ws->next_pts : local_next_pts;
  for (int pass = 1; pass <= opt.refinement && alive.size () >= 4; ++pass)
  {
    HPR_PASS (pass);
    const std::size_t kp = std::min ({in.k_cull << pass, kMaxSectors, 64 * alive.size ()});
    AngularGrid& fine = reuse ? in.ws->fine : local_fine;
    fine.setThreads (in.threads);
    fine.setOutlineCandidates (true);
    fine.setBandDepth (band_depth);
    fine.setCellSize (cell0 / std::pow (std::sqrt (2.0), pass));
    fine.build (alive_pts, in.centre, in.R, kp);
    HPR_LAP ("build");
    // No propagation in the first refinement pass: its sectors' own points span smaller
    // triangles than candidates carried over from neighbours, and cull more hidden points
    // just behind the surface. Later passes take one step (see docs/hpr.md).
    if (pass > 1)
      fine.propagateAdaptive (1);
    HPR_LAP ("propagate");
    fine.interiorPoints (alive_pts, &next, &next_pts, nullptr, pass < opt.refinement ? &settled : nullptr);
    HPR_LAP ("interior");
    for (int& j : next)
      j = alive[j];
    if (pass < opt.refinement)
      for (int j : settled)
        sub.visible[alive[j]] = 1;
    alive.swap (next);
    alive_pts.swap (next_pts);
    HPR_LAP ("remap");
  }
}

// CANDIDATE_HULL: every point not strictly inside a tetrahedron (C, a, b, c) of neighbouring
// candidates of the culling grid, refined by refineSurvivors ().
void
runCandidateHull (MethodInput& in, AngularGrid& grid, VisibilityResult& sub, VisibilityResult& res)
{
  HPR_LAPS ();
  const VisibilityOptions& opt = in.opt;
  const std::vector<Eigen::Vector3d>& pts = in.pts;
  const bool reuse = in.ws != nullptr;
  const int cull_steps = opt.steps > 0 ? in.steps : 4;
  grid.setOutlineCandidates (true);
  grid.setCellSize (0);
  // R from the culling grid's own solid angle: no calibration grid is needed here.
  // The occlusion depth of this cloud: 0.8 × the option when clean, more when noisy.
  NoiseProbe probe (pts, opt.radius > 0 ? 0 : kNoiseSeeds, kNoiseNeighbours);
  const HPRCalibration dist = distancesOf (pts, in.centre, in.threads, &probe);
  HPR_LAP ("distances");
  const double noise = probe.active () ? probe.finish (pts) : 0.0;
  const double ch_depth = candidateHullDepth (opt.occlusion_depth, dist.cloud_radius, noise);
  HPR_LAP ("noise");
  const std::size_t k_cull = in.k_cull;
  if (opt.radius > 0)
    grid.build (pts, in.centre, in.R, k_cull);
  else
  {
    grid.build (pts, in.centre,
                [&] (double area) {
                  HPRCalibration c = dist;
                  c.grid_area = area;
                  return radiusForSeparation (c, std::sqrt (2.0 * area / double (k_cull)), ch_depth);
                },
                k_cull);
    in.R = grid.radius ();
    res.radius = in.R;
  }
  HPR_LAP ("build");
  // The uncertain band is seeded only by culls less than kBandDepths occlusion depths behind
  // the nearest candidate around them: on a closed object every sector has a culled far-side
  // point, and the band would be (nearly) every survivor (see docs/hpr.md).
  constexpr double kBandDepths = 4.0;
  const double band_depth = kBandDepths * ch_depth * dist.cloud_radius;
  grid.setBandDepth (band_depth);
  grid.propagateAdaptive (cull_steps);
  HPR_LAP ("propagate");
  std::vector<int> local_alive, local_settled;
  std::vector<Eigen::Vector3d> local_alive_pts;
  std::vector<int>& alive = reuse ? in.ws->alive : local_alive;
  std::vector<Eigen::Vector3d>& alive_pts = reuse ? in.ws->alive_pts : local_alive_pts;
  std::vector<int>& settled = reuse ? in.ws->settled : local_settled;  // survivors outside the band: visible
  settled.clear ();
  grid.interiorPoints (pts, &alive, &alive_pts, nullptr, opt.refinement > 0 ? &settled : nullptr);
  for (int i : settled)
    sub.visible[i] = 1;
  HPR_LAP ("interior");
  res.sectors = grid.sectorCount ();
  res.steps = cull_steps;
  refineSurvivors (in, band_depth, grid.cellAngle (), alive, alive_pts, settled, sub);
  HPR_PASS (9);
  for (int i : alive)
    sub.visible[i] = 1;
  HPR_LAP ("mark_visible");
  // The grid's triangulation spans the candidates; other visible points get normals
  // facing the viewer (meshNormals' fallback). Triangles with a vertex a refinement pass
  // culled are dropped.
  if (opt.triangles || opt.normals)
  {
    sub.triangles = grid.triangulate (pts, -1.f);
    sub.triangles.erase (std::remove_if (sub.triangles.begin (), sub.triangles.end (),
                                         [&] (const Eigen::Vector3i& t) {
                                           return !sub.visible[t[0]] || !sub.visible[t[1]] || !sub.visible[t[2]];
                                         }),
                         sub.triangles.end ());
  }
}

// ANGULAR_GRID, KAVAN and HYBRID: the grid's sector candidates after propagation (angular
// grid) or global refinement (Kavan), visible as they are or through their exact hull (hybrid).
bool
runGridSampling (const MethodInput& in, AngularGrid& grid, VisibilityResult& sub, VisibilityResult& res)
{
  const VisibilityOptions& opt = in.opt;
  const std::vector<Eigen::Vector3d>& pts = in.pts;
  grid.build (pts, in.centre, in.R, in.k);
  if (opt.method == VisibilityMethod::KAVAN)
    grid.refineGlobal ();
  else if (opt.method == VisibilityMethod::ANGULAR_GRID)
  {
    if (opt.fixed_propagation)
    {
      grid.propagateFixed (in.steps);
      res.steps = in.steps;
    }
    else
      res.steps = grid.propagateAdaptive (in.steps);
  }
  const std::vector<int> cands = grid.candidates ();
  if (opt.method == VisibilityMethod::HYBRID)
  {
    if (!hullVisibility (pts, cands, in.R, opt.triangles || opt.normals, sub, in.threads))
      return false;
  }
  else
  {
    for (int c : cands)
      sub.visible[c] = 1;
    if (opt.triangles)
      sub.triangles = grid.triangulate (pts, -1.f);
    if (opt.normals)
      grid.normalsAndSplats (pts, sub.normals, sub.splat_radius);
  }
  res.sectors = grid.sectorCount ();
  return true;
}

// BENTLEY_FAUST_PREPARATA (Machado e Silva 2012, §3.1): the extremes along the viewing axis x
// in a g × g grid over the (y, z) plane of the flipped cloud, then their exact hull.
bool
runBentleyFaustPreparata (const MethodInput& in, VisibilityResult& sub, VisibilityResult& res)
{
  const VisibilityOptions& opt = in.opt;
  const std::vector<Eigen::Vector3d>& pts = in.pts;
  const std::vector<Eigen::Vector3d> f = flip (pts, everyPoint (pts.size ()), in.R, in.threads);
  const Eigen::Vector3d x = in.centre.cast<double> ().normalized ();
  const Eigen::Vector3d e = std::abs (x.z ()) > 0.9 ? Eigen::Vector3d::UnitY () : Eigen::Vector3d::UnitZ ();
  const Eigen::Vector3d z = (e - e.dot (x) * x).normalized (), y = z.cross (x);
  const int g = std::max (1, int (std::lround (std::sqrt (double (in.k)))));
  double y0 = 1e300, y1 = -1e300, z0 = 1e300, z1 = -1e300;
  for (const auto& q : f)
  {
    y0 = std::min (y0, q.dot (y));
    y1 = std::max (y1, q.dot (y));
    z0 = std::min (z0, q.dot (z));
    z1 = std::max (z1, q.dot (z));
  }
  const double sy = g / std::max (y1 - y0, 1e-300), sz = g / std::max (z1 - z0, 1e-300);
  std::vector<int> lo (std::size_t (g) * g, -1), hi (std::size_t (g) * g, -1);
  for (std::size_t i = 0; i < f.size (); ++i)
  {
    const int a = std::clamp (int ((f[i].dot (y) - y0) * sy), 0, g - 1);
    const int b = std::clamp (int ((f[i].dot (z) - z0) * sz), 0, g - 1);
    const std::size_t c = std::size_t (a) * g + b;
    const double v = f[i].dot (x);
    if (lo[c] < 0 || v < f[lo[c]].dot (x))
      lo[c] = int (i);
    if (hi[c] < 0 || v > f[hi[c]].dot (x))
      hi[c] = int (i);
  }
  std::vector<int> sel;
  for (std::size_t c = 0; c < lo.size (); ++c)
  {
    if (lo[c] >= 0)
      sel.push_back (lo[c]);
    if (hi[c] >= 0 && hi[c] != lo[c])
      sel.push_back (hi[c]);
  }
  if (!hullVisibility (pts, sel, in.R, opt.triangles || opt.normals, sub, in.threads))
    return false;
  res.sectors = std::size_t (g) * g;
  return true;
}

// The method's answer on the compacted points (`sub`) back on the input points of `res`:
// long edges dropped, normals from the triangles where the method gave none, duplicates
// of visible points made visible. id (i) is the input index of compacted point i.
template <typename IdOf>
void
writeResult (const std::vector<Eigen::Vector3d>& pts, const VisibilityOptions& opt, std::size_t n, IdOf id,
             VisibilityResult& sub, VisibilityResult& res)
{
  res.warning += sub.warning;
  if (opt.triangles)
    filterLongEdges (pts, opt.max_edge, sub.triangles);
  if (opt.normals && sub.normals.empty ())
    meshNormals (pts, sub.triangles, sub);
  // Exact duplicates pass the candidate-hull test together; the other methods pick one
  // point per hull vertex or sector.
  if (opt.method != VisibilityMethod::CANDIDATE_HULL)
    shareWithDuplicates (pts, sub);
  for (std::size_t i = 0; i < pts.size (); ++i)
    res.visible[id (i)] = sub.visible[i];
  for (const auto& t : sub.triangles)
    res.triangles.emplace_back (id (t[0]), id (t[1]), id (t[2]));
  if (opt.normals)
  {
    res.normals.assign (n, Eigen::Vector3f::Constant (std::numeric_limits<float>::quiet_NaN ()));
    res.splat_radius.assign (n, 0.f);
    for (std::size_t i = 0; i < pts.size (); ++i)
      if (res.visible[id (i)])
      {
        res.normals[id (i)] = sub.normals[i];
        res.splat_radius[id (i)] = sub.splat_radius[i];
      }
  }
}

}  // namespace

VisibilityResult
computeVisibility (const std::vector<Eigen::Vector3d>& points, const VisibilityOptions& opt, VisibilityWorkspace* ws)
{
  HPR_PASS (0);
  HPR_LAPS ();
  VisibilityResult res;
  const std::size_t n = points.size ();
  res.visible.assign (n, 0);
  if (n == 0)
    return res;
  const int threads = opt.threads > 0 ? opt.threads : autoThreads (n);
  const PointSums sums = sumPoints (points, opt.stats, threads);
  const double max_rho = std::sqrt (sums.max_rho2);
  HPR_LAP ("min_max_rho");

  // A point at the viewpoint is seen (and cannot be flipped): keep it out of the hull.
  const double eye_eps = 1e-9 * std::max (max_rho, 1e-30);
  std::size_t at_eye = 0;
  if (std::sqrt (sums.min_rho2) <= eye_eps)  // rare: a second pass only then
    for (std::size_t i = 0; i < n; ++i)
      if (points[i].norm () <= eye_eps)
      {
        res.visible[i] = 1;
        ++at_eye;
      }
  if (n - at_eye < 4)
  {
    // With C, at most 4 points: each is a vertex of their hull unless degenerate; call all visible.
    res.visible.assign (n, 1);
    res.radius = opt.radius;
    return res;
  }
  // Work on the input itself unless points at the viewpoint had to be left out; id(i) maps
  // back to the input.
  std::vector<int> ids;
  std::vector<Eigen::Vector3d> compact;
  if (at_eye > 0)
  {
    for (std::size_t i = 0; i < n; ++i)
      if (!res.visible[i])
      {
        ids.push_back (int (i));
        compact.push_back (points[i]);
      }
  }
  const std::vector<Eigen::Vector3d>& pts = at_eye > 0 ? compact : points;
  auto id = [&ids] (std::size_t i) { return ids.empty () ? int (i) : ids[i]; };

  if (opt.refinement < 0)
  {
    res.error = "the number of refinement passes must be >= 0";
    return res;
  }
  if (opt.radius > 0 && opt.radius <= max_rho)
  {
    res.error = "R = " + std::to_string (opt.radius) + " must exceed the distance from the viewpoint to the "
                "farthest point (" + std::to_string (max_rho) + ")";
    return res;
  }
  // A sheet seen edge-on: every point is on the silhouette (see isEdgeOn). One answer for
  // every method, decided before any of them meets the degenerate geometry.
  const double scale = opt.coordinate_scale > 0 ? opt.coordinate_scale : max_rho;
  const bool edge_on = isEdgeOn (pts, 8.0 * std::numeric_limits<float>::epsilon () * scale);
  HPR_LAP ("edge_on_test");
  if (edge_on)
  {
    res.visible.assign (n, 1);
    res.radius = opt.radius > 0 ? opt.radius : 0;
    if (opt.normals)
    {
      res.normals.assign (n, Eigen::Vector3f::Constant (std::numeric_limits<float>::quiet_NaN ()));
      res.splat_radius.assign (n, 0.f);
    }
    return res;
  }
  MethodInput in (pts, opt, ws);
  in.threads = threads;
  planMethod (in, res);
  VisibilityResult sub;
  sub.visible.assign (pts.size (), 0);
  in.centre = at_eye > 0 ? centroidOf (pts) : Eigen::Vector3d (sums.sum / double (n));
  HPR_LAP ("centroid");
  // The candidate hull reuses the workspace's grids (every setting is made again).
  AngularGrid local_grid;
  const bool reuse = ws && opt.method == VisibilityMethod::CANDIDATE_HULL;
  AngularGrid& grid = reuse ? ws->grid : local_grid;
  grid.setThreads (threads);
  if (!reuse)
    in.ws = nullptr;

  bool ok = true;
  switch (opt.method)
  {
  case VisibilityMethod::CANDIDATE_HULL: runCandidateHull (in, grid, sub, res); break;
  case VisibilityMethod::EXACT:
  {
    const std::vector<int> keep = opt.exact_prefilter && pts.size () >= 2000
                                      ? cullInterior (grid, pts, in.centre, in.R, in.k_cull_default, 4)
                                      : everyPoint (pts.size ());
    res.prefilter_kept = keep.size ();
    ok = hullVisibility (pts, keep, in.R, opt.triangles || opt.normals, sub, threads);
    break;
  }
  case VisibilityMethod::ANGULAR_GRID:
  case VisibilityMethod::KAVAN:
  case VisibilityMethod::HYBRID: ok = runGridSampling (in, grid, sub, res); break;
  case VisibilityMethod::BENTLEY_FAUST_PREPARATA: ok = runBentleyFaustPreparata (in, sub, res); break;
  }
  if (!ok)
  {
    res.error = sub.error;
    return res;
  }
  writeResult (pts, opt, n, id, sub, res);
  HPR_LAP ("output");
  return res;
}

}  // namespace detail
}  // namespace hpr
}  // namespace pclx
