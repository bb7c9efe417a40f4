#pragma once
// The angular grid of Machado e Silva et al. 2014 (§3–4): sectors around the viewpoint C,
// one extreme candidate of the spherically flipped cloud per sector, the EMPTY map,
// candidate propagation, and what the grid gives for free: the partial view-dependent
// triangulation (§4.4), per-point normals (§5.3) and splat radii (§5.5). Points are given
// relative to C (C at the origin). Internal to pcl::HPRFilter.
#include <Eigen/Core>

#include <cstdint>
#include <functional>
#include <vector>

namespace pclx {
namespace hpr {
namespace detail {

class AngularGrid
{
public:
  // Sector frame: x axis through the cloud centre C_e. Narrow views are tiled in the
  // tangent plane (y/x, z/x); wide ones in the paper's φ = atan2(y, x), θ = acos(z / ρ).
  // `sectors` is k; cells are square (see build()).
  // `radius` is the flip radius R (> max ρ).
  void build (const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& centre, double radius,
              std::size_t sectors);
  // The same, with R chosen from the grid's solid angle (gridSolidAngle ()) once the grid is
  // laid out: the candidate hull calibrates R on its own grid, without a calibration grid.
  void build (const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& centre,
              const std::function<double (double grid_solid_angle)>& radius_for_area, std::size_t sectors);

  // Adaptive propagation (§4.3, scatter): only sectors changed in the previous step
  // pass their candidate on; stops when stable or after `max_steps` (0 = until stable).
  // Returns the number of steps done.
  int propagateAdaptive (int max_steps);
  // Fixed propagation (Machado e Silva 2012, §4.3.2, gather): one pass over an m×m
  // neighbourhood (m odd).
  void propagateFixed (int m);
  // Kavan et al.'s refinement (Machado e Silva 2012, §3.2): every candidate against all
  // others, O(k²).
  void refineGlobal ();

  // Visible = the distinct sector candidates (hull vertices of the approximation).
  std::vector<int> candidates () const;

  // §4.4: two triangles per 2×2 sector neighbourhood with distinct vertices, facing C;
  // triangles with an edge longer than max_edge (in point units, <= 0: no filter) dropped.
  std::vector<Eigen::Vector3i> triangulate (const std::vector<Eigen::Vector3d>& points, float max_edge) const;
  // §5.3: normals of the visible points from the triangle fans around each sector, facing C
  // (NaN for points that are not candidates); §5.5: splat radius covering the sectors a
  // point won.
  void normalsAndSplats (const std::vector<Eigen::Vector3d>& points, std::vector<Eigen::Vector3f>& normals,
                         std::vector<float>& splat_radius) const;

  // Exact-method pre-filter: marks points that lie strictly inside a tetrahedron
  // (C, a, b, c) of candidate points in flipped space. Such points are interior to
  // the hull of the flipped cloud, so they cannot be hull vertices: culling them
  // before Qhull changes no visible point. `points` are the ones given to build().
  // When `survivors` is given it receives the points that are not interior, in sector
  // order (indices into `points`; their positions in `survivor_points`): a finer pass over
  // them then reads memory nearly in order. The returned mask is then empty.
  // `survivor_in_band` (with `survivors`) flags, per survivor, whether its sector is within
  // one sector of a culled point or of a sector without candidate (silhouettes, the grid's
  // edge): the uncertain band where a finer pass can still cull something. With
  // `outside_band` (and `survivors`), the survivors outside the band go there, and
  // `survivors` (with `survivor_points`, `survivor_in_band`) holds the band only.
  std::vector<std::uint8_t> interiorPoints (const std::vector<Eigen::Vector3d>& points,
                                            std::vector<int>* survivors = nullptr,
                                            std::vector<Eigen::Vector3d>* survivor_points = nullptr,
                                            std::vector<std::uint8_t>* survivor_in_band = nullptr,
                                            std::vector<int>* outside_band = nullptr) const;

  // Balls-in-bins calibration (§6) on this grid used as the coarse grid.
  struct Calibration
  {
    double alpha = 0;            // estimated angular separation of visible points (rad)
    double visible_estimate = 0;  // estimated number of visible points
    double occupied_solid_angle = 0;
  };
  Calibration calibrate () const;

  // Angular cell size for the next build() (radians; 0: from k). A refinement pass over a
  // subset of the points keeps the cell of the grid it refines instead of spreading k over
  // the subset's smaller extent; k then only caps the number of cells.
  void setCellSize (double cell) { fixed_cell_ = cell; }

  // Outline candidates for the culling tests (candidate hull): the grid gets one more sector
  // on every side, every sector without a point of its own that borders one with points
  // takes the point of its 3×3 neighbourhood that scores best towards it, and a quad whose
  // corners share a propagated candidate uses the corners' own best points. Without them, a
  // sector's tetrahedra reach only as far out as its neighbours' candidates, and a quad with
  // a repeated candidate has none: beside silhouettes, in the cloud's outline and where
  // propagation spread one candidate over several sectors, hidden points deep behind the
  // surface would never be tested. Any point is a valid tetrahedron vertex (the culling stays
  // inside the hull of all points, so it stays conservative). R is unchanged (the ring is
  // not counted in the grid's solid angle).
  void setOutlineCandidates (bool on) { outline_ = on; }
  // Only culls at most this far (ρ) behind the nearest candidate around them seed the
  // uncertain band of interiorPoints () (<= 0: every cull).
  void setBandDepth (double depth) { band_depth_ = depth; }

  // OpenMP threads for every pass (0: omp_get_max_threads ()).
  void setThreads (int threads) { threads_ = threads; }

  std::size_t sectorCount () const { return cand_.size (); }
  double radius () const { return radius_; }  // R the candidates were scored with
  // Per point given to build(): its sector (row-major, rows () × cols ()); per sector: its
  // candidate point or −1.
  const std::vector<std::uint32_t>& pointSectors () const { return sector_; }
  const std::vector<int>& sectorCandidates () const { return cand_; }
  int rows () const { return n_phi_; }
  int cols () const { return n_theta_; }
  double cellAngle () const { return cell_; }  // angular size of one sector (rad)
  int emptyFactor () const { return empty_factor_; }
  std::size_t occupiedSectors () const;
  // Points the last interiorPoints () culled by its depth cut, before the tetrahedron tests.
  std::size_t depthCulled () const { return depth_culled_; }
  bool wrapsPhi () const { return wrap_phi_; }
  bool gnomonic () const { return gnomonic_; }
  double cellSolidAngle (std::size_t sector) const;
  double gridSolidAngle () const;

private:
  struct Extent;
  struct Tetra;
  struct QuadSet;
  struct InteriorPass;

  // Both build ()s: R from radius_for_area when given, else `radius`. Its stages: the frame,
  // the points' directions (and the tiling), the sector layout and R, the candidates, the
  // EMPTY map.
  void buildGrid (const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& centre,
                  const std::function<double (double)>* radius_for_area, double radius, std::size_t sectors);
  void setFrame (const Eigen::Vector3d& centre);
  Extent pointDirections (const std::vector<Eigen::Vector3d>& points);
  Extent sphericalCoordinates ();
  void layoutSectors (Extent extent, const std::function<double (double)>* radius_for_area, double radius,
                      std::size_t sectors);
  void layoutCentres ();
  void assignCandidates ();
  void buildEmptyMap ();

  // interiorPoints ()'s stages: the candidates' directions and flips, the depth cut, the
  // points bucketed by sector row, the tetrahedron tests, the uncertain band, the output.
  void prepareCandidates (InteriorPass& pass) const;
  void quadTetras (const InteriorPass& pass, int qa, int qb, Tetra* out, int& count, double& min_rho) const;
  void computeDepthCut (const InteriorPass& pass) const;
  void bucketByRow (InteriorPass& pass) const;
  void runTetrahedronTests (InteriorPass& pass) const;
  static bool insideQuads (const QuadSet* const* quad, int first, const Eigen::Vector3d& p, const Eigen::Vector3d& q,
                           double rho);
  void markUncertainBand (const InteriorPass& pass) const;
  void writeInteriorOutput (InteriorPass& pass) const;
  bool seedsBand (double rho, double near) const;
  // g = 1 − cos α + cos α·ρ/(2R) is the paper's DIST = (2R − ρ)·cos α rescaled so that
  // smaller is better and the tiny differences survive in floating point (R ≫ ρ).
  double score (int point, std::size_t sector) const;
  double scoreDir (int point, const Eigen::Vector3d& sector_direction) const;  // the same, direction given
  Eigen::Vector3d direction (std::size_t sector) const;
  bool isEmpty (std::size_t sector) const;  // EMPTY map: outside the object's projection
  void fillEmptySectors ();                  // see setOutlineCandidates ()
  void neighbours (std::size_t s, int radius, std::vector<std::size_t>& out) const;
  // Rows (φ) × columns (θ) of sectors; φ wraps around the viewer on wide grids. Loops take a
  // local copy: the members would be reloaded after every store to a vector.
  struct Shape
  {
    int rows, cols;
    bool wrap;
    // Sector (a + da, b + db), or −1 off the grid.
    std::ptrdiff_t neighbour (int a, int b, int da, int db) const
    {
      int aa = a + da;
      const int bb = b + db;
      if (wrap)
        aa = (aa % rows + rows) % rows;
      if (aa < 0 || aa >= rows || bb < 0 || bb >= cols)
        return -1;
      return std::ptrdiff_t (aa) * cols + bb;
    }
  };
  Shape shape () const { return {n_phi_, n_theta_, wrap_phi_}; }

  std::vector<Eigen::Vector3f> unit_;  // per point: direction from C, in frame coordinates
  std::vector<double> rho_;            // per point: distance from C
  double rho0_ = 0;                    // min rho_: scores rank by ρ − ρ0 (see score())
  std::vector<std::uint32_t> sector_;  // per point: its sector
  double radius_ = 0;
  Eigen::Matrix3d frame_ = Eigen::Matrix3d::Identity ();  // rows: frame axes
  double phi0_ = 0, theta0_ = 0, cell_phi_ = 1, cell_theta_ = 1, cell_ = 1;
  int n_phi_ = 0, n_theta_ = 0;
  bool wrap_phi_ = false;
  bool gnomonic_ = false;                    // tangent-plane tiling (narrow views)
  std::vector<double> centre_a_, centre_b_;  // sector centre coordinates
  std::vector<double> cos_phi_, sin_phi_, cos_theta_, sin_theta_;  // sector centre angles
  std::vector<int> cand_;      // per sector: candidate point or −1 (the paper's MAX array)
  std::vector<double> best_;   // per sector: score of the candidate
  int threads_ = 0;
  double fixed_cell_ = 0;
  bool outline_ = false;
  double band_depth_ = 0;
  mutable std::size_t depth_culled_ = 0;
  std::vector<int> own_;       // with outline_: per sector its own best point, before propagation
  int nt () const;
  int empty_factor_ = 1;       // EMPTY is kept on a grid coarser by this factor per axis
  int coarse_theta_ = 0;
  std::vector<std::uint8_t> occupied_coarse_;
  // Per-call buffers of build (), propagateAdaptive () and interiorPoints (), kept with their
  // capacity: a grid used again (HPRFilter on every frame) then writes to pages it already
  // has instead of faulting in fresh ones.
  struct Scratch
  {
    std::vector<float> ca, cb;
    std::vector<std::uint64_t> keys;
    std::vector<std::uint8_t> is_cand, inside, cand_sorted, seed, band;
    std::vector<std::uint32_t> start, order, col, slot, kept, kept_end;
    std::vector<Eigen::Vector3d> sorted, cand_dir, cand_flip, split;
    std::vector<Eigen::Vector2d> cand_g;
    std::vector<double> cut, cut_near, quad_d, quad_near;
    std::vector<double> cand_rho, prop_best;
    std::vector<int> prop_cand;
    std::vector<std::uint32_t> stamp;
  };
  mutable Scratch scratch_;  // contents meaningless between calls
};

}  // namespace detail
}  // namespace hpr
}  // namespace pclx
