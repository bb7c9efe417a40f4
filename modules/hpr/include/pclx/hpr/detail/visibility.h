#pragma once
// The point-type independent core of pcl::HPRFilter: every method on a plain array of
// points given relative to the viewpoint. Internal: the public interface is HPRFilter.
#include <pclx/hpr/detail/angular_grid.h>

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

namespace pclx {
namespace hpr {
namespace detail {

// Largest grid the approximate methods accept (about 20 bytes per sector).
constexpr std::size_t kMaxSectors = std::size_t (1) << 24;

enum class VisibilityMethod { EXACT, ANGULAR_GRID, CANDIDATE_HULL, BENTLEY_FAUST_PREPARATA, KAVAN, HYBRID };

// What computeVisibility's first pass gathers: min and max |p|², and the sum of the points
// per block of kStatsBlock (the centroid adds them in block order, so it does not depend on
// the thread count). A caller that reads every point anyway (HPRFilter, copying them) can
// hand them over and the pass is skipped.
constexpr std::size_t kStatsBlock = 65536;
struct PointStats
{
  double min_rho2 = 0, max_rho2 = 0;
  std::vector<Eigen::Vector3d> block_sum;  // one per kStatsBlock points, in order
};

struct VisibilityOptions
{
  VisibilityMethod method = VisibilityMethod::ANGULAR_GRID;
  double radius = 0;          // R > max ρ; <= 0: calibrate (needs occlusion_depth)
  double occlusion_depth = 0.05;
  std::size_t sectors = 0;    // k; 0: calibrate
  double oversampling = 4.0;
  int view_pixels = 0;        // screen cap on k (0: none)
  double view_fov = 0;
  bool fixed_propagation = false;
  int steps = 0;              // ℓ (adaptive, 0: calibrate) or m (fixed)
  bool exact_prefilter = true;
  // Candidate hull: culling passes on the survivors after the first, on grids 2×, 4×, ...
  // finer at the same R (0: one pass; computeVisibility rejects < 0).
  int refinement = 2;
  bool triangles = false;
  float max_edge = 0.f;       // <= 0: 5 × median edge
  bool normals = false;
  // Size of the input's own coordinates (max |p| + |C| before p − C); the tolerance of the
  // flat-input test is a few float ulps of it. <= 0: max |p − C|.
  double coordinate_scale = 0;
  int threads = 0;  // OpenMP threads; 0: autoThreads()
  const PointStats* stats = nullptr;  // of exactly these points, or nullptr
};

struct VisibilityResult
{
  std::string error;                      // non-empty: the input was rejected, nothing computed
  std::string warning;                    // something was adjusted (e.g. k clamped)
  std::vector<std::uint8_t> visible;      // per input point
  std::vector<Eigen::Vector3i> triangles;  // point ids, facing the viewpoint
  std::vector<Eigen::Vector3f> normals;   // per point (NaN where hidden)
  std::vector<float> splat_radius;        // per point (0 where hidden)
  double radius = 0;
  std::size_t sectors = 0;
  int steps = 0;
  std::size_t prefilter_kept = 0;  // exact method: points left for Qhull
  int threads = 1;                 // OpenMP threads used
};

// Calibration (Machado e Silva et al. 2014, §6): R from the angular separation α of visible
// points, k from the sectors needed for one visible point per sector (times `oversampling`),
// ℓ from α.
struct HPRCalibration
{
  double alpha = 0;
  double grid_area = 0;  // angular area of the grid (sr, φθ rectangle)
  double visible_estimate = 0;
  double radius = 0;
  std::size_t sectors = 0;
  int steps = 0;
  double cloud_radius = 0;        // max |p − C_e|
  double reference_distance = 0;  // |C − C_e| (mean |p − C| when C is inside the cloud)
  double max_distance = 0;        // max |p − C|
};
HPRCalibration calibrateHPR (const std::vector<Eigen::Vector3d>& points, const VisibilityOptions& options);
// R at which two points α apart (seen from reference_distance) hide a point
// occlusion_depth × cloud_radius behind them (Fig. 9); always > max_distance.
double radiusForSeparation (const HPRCalibration& cal, double alpha, double occlusion_depth);
// Measured noise of the surface: the lower quartile, over ~`seeds` points spread through the
// cloud, of the thickness (√ of the smallest covariance eigenvalue) of a plane fit to each
// one's `k` nearest neighbours, found among the points of the 2×2×2 voxels around it (one
// pass over the cloud; voxel side from the seeds' extent and n). A clean, smooth surface
// reads its curvature over the neighbourhood. Walls thinner than the neighbourhood (both
// faces in it) read as noise where they are most of the cloud. 0 when the cloud is too small to tell. The candidate hull
// gathers the same neighbours in its first pass over the points (no pass of its own).
constexpr std::size_t kNoiseSeeds = 256;
constexpr int kNoiseNeighbours = 8;
double estimateSurfaceNoise (const std::vector<Eigen::Vector3d>& points, std::size_t seeds = kNoiseSeeds,
                             int k = kNoiseNeighbours);
// The candidate hull's occlusion depth (relative to the cloud radius, as occlusion_depth):
// 0.8 × occlusion_depth on a clean cloud, more where the measured noise needs it (see
// kNoiseDepths in visibility.cpp and docs/hpr.md).
double candidateHullDepth (double occlusion_depth, double cloud_radius, double noise);
// ℓ for a grid of k sectors: enough steps to cover the sectors between two visible points.
int propagationSteps (const HPRCalibration& cal, std::size_t k);

// True when every point lies in one plane through the viewpoint (or on one line), within
// `tolerance` (absolute, plus a few float ulps of each |p|). Such a cloud is a sheet seen
// exactly edge-on: every point lies on its silhouette, so HPR calls all of them visible.
// That is also the limit of the exact operator as C approaches the plane: the flip maps a
// plane not through C onto a closed surface of which every point is a hull vertex, so a
// flat cloud is entirely visible from any C off its plane. Qhull, given the degenerate flat
// case itself, would return a joggle-dependent answer.
bool isEdgeOn (const std::vector<Eigen::Vector3d>& points, double tolerance);

// Threads for one call on `points` points: at most omp_get_max_threads(), one per ~32k
// points, and no more than the cores nobody else is running on (the instantaneous runnable
// count of /proc/loadavg, this thread excluded). A thread that has to share its core stalls
// every barrier of the grid passes by a scheduler time slice. Not Linux: the first two rules.
int autoThreads (std::size_t points);

// Working memory that one call leaves for the next (HPRFilter keeps one): the buffers keep
// their capacity, so a filter run on every frame writes to pages it already has instead of
// faulting in fresh ones. Its size follows the largest cloud so far (docs/hpr.md);
// release () gives it back. Copies start empty (two filters never share one); not for
// concurrent calls.
struct VisibilityWorkspace
{
  VisibilityWorkspace () = default;
  VisibilityWorkspace (const VisibilityWorkspace&) {}
  VisibilityWorkspace& operator= (const VisibilityWorkspace&) { return *this; }
  void release ();

  AngularGrid grid, fine;  // candidate hull: the culling grid, the refinement passes' grid
  std::vector<int> alive, next, settled;
  std::vector<Eigen::Vector3d> alive_pts, next_pts;
  // HPRFilter's own: the finite requested points relative to the viewpoint, their input
  // indices, and per requested index its state.
  std::vector<Eigen::Vector3d> points;
  std::vector<int> finite;
  std::vector<std::uint8_t> state;
};

// What HPRFilter gathers while copying the requested points (its applyFilter's stages share
// it): the thread count, the number of requested indices, per block of kStatsBlock indices
// the number of finite points before it, the point statistics, max |p − C| and max |p|.
struct GatheredPoints
{
  int threads = 1;
  std::size_t requested = 0, blocks = 0;
  std::vector<std::size_t> block_start;
  PointStats stats;
  double max_rho = 0, max_coord = 0;
};

// `points` are p − C for finite p; points at the viewpoint itself are visible.
// Flat input seen edge-on (every point, to float precision, in one plane through C) is all
// visible, whatever the method: see isEdgeOn().
// `workspace` (optional): buffers kept from an earlier call, see VisibilityWorkspace.
VisibilityResult computeVisibility (const std::vector<Eigen::Vector3d>& points, const VisibilityOptions& options,
                                    VisibilityWorkspace* workspace = nullptr);

}  // namespace detail
}  // namespace hpr
}  // namespace pclx
