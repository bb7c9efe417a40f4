#pragma once
// The planarity octree of seed 002 (Algorithm 1) plus the seed's ch. 7 fix:
// merging adjacent leaves whose planes agree into regions, each with one robust
// surface fit (plane, or a quadric height field: the seed's "polynomial fitting").
// Non-templated: it works on plain float positions, the PCL feature wraps it.
#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <vector>

namespace pclx {
namespace normals {

struct PlanarOctreeParams
{
  double s_alpha = 6.25;  // planar when λ2 > sα·λ3 ...
  double s_beta = 1.5;    // ... and sβ·λ2 > λ1 (seed §5.4.1)
  int max_depth = 10;
  int min_points = 10;    // a cell with fewer points is not split and cannot be planar
  int threads = 0;        // 0: OpenMP default
  // Not in the seed (0 = off): a planar cell is split anyway when a point lies farther
  // than this many RMS thicknesses from the cell's plane: a second surface (the other
  // side of an edge) hiding in the cell as a small minority.
  double max_residual_ratio = 0;
};

struct OctreeNode
{
  Eigen::Vector3f center = Eigen::Vector3f::Zero ();
  float half = 0;       // half edge of the cube
  int depth = 0;
  int begin = 0, end = 0;  // range in PlanarOctree::order ()
  int first_child = -1;    // 8 consecutive children, -1 for a leaf
  int parent = -1;
  bool planar = false;     // passed Algorithm 1's test
  bool degenerate = true;  // < 3 points, or collinear / coincident points
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero ();  // relative to PlanarOctree::origin ()
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero ();   // of the cell's points (divided by n)
  Eigen::Vector3d eigenvalues = Eigen::Vector3d::Zero ();  // λ1 ≥ λ2 ≥ λ3 of the covariance
  Eigen::Vector3f normal = Eigen::Vector3f::UnitZ ();  // eigenvector of λ3
  float curvature = 0;                                 // λ3 / (λ1 + λ2 + λ3)
  int region = -1;                                     // merged region (planar leaves only)
  int size () const { return end - begin; }
  bool isLeaf () const { return first_child < 0; }
};

// A set of merged coplanar leaves with its surface fit in a local frame
// (origin o, in-plane axes e1 e2, normal n): h = c0 x² + c1 xy + c2 y² + c3 x + c4 y + c5.
struct PlanarRegion
{
  int points = 0;
  int leaves = 0;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero ();     // moments, relative to origin ()
  Eigen::Matrix3d sum_sq = Eigen::Matrix3d::Zero ();
  double base_thickness = 0;  // largest RMS thickness of its leaves (the noise scale)
  Eigen::Vector3d o = Eigen::Vector3d::Zero ();
  Eigen::Matrix3d frame = Eigen::Matrix3d::Identity ();  // columns e1, e2, n
  double scale = 1;          // in-plane coordinates are divided by it for conditioning
  std::array<double, 6> c{}; // quadric coefficients (zero: plane)
  double rms = 0;            // RMS residual of the fit
  float curvature = 0;
};

class PlanarOctree
{
public:
  // Builds the octree over the given (finite) points. Returns false when the
  // points do not span a plane at all (fewer than 3, all equal or collinear).
  bool build (const std::vector<Eigen::Vector3f>& points, const PlanarOctreeParams& params);

  // Leaf containing p, or -1 outside the root cube.
  int locate (const Eigen::Vector3f& p) const;
  // Nearest ancestor (or the node itself) whose covariance spans a plane: the fallback
  // normal for points in degenerate cells (the root always qualifies after build()).
  int nonDegenerateAncestor (int node) const;
  // Distance from p to the cell's centre in the max norm, relative to the half edge (0 centre, 1 face).
  float relativeCentreDistance (int node, const Eigen::Vector3f& p) const;

  // Seed ch. 7: union of adjacent planar leaves whose normals differ by less than
  // max_angle_deg and whose union stays as thin as thickness_factor × the thickest part.
  void mergeCoplanarLeaves (double max_angle_deg, double thickness_factor);
  // Surface fit of every region (call after mergeCoplanarLeaves).
  void fitRegions (bool quadric);
  // Normal of region r's fitted surface at (the projection of) p, and p's distance to it.
  Eigen::Vector3f regionNormalAt (int r, const Eigen::Vector3f& p) const;
  double regionResidual (int r, const Eigen::Vector3f& p) const;

  const std::vector<OctreeNode>& nodes () const { return nodes_; }
  const std::vector<PlanarRegion>& regions () const { return regions_; }
  const std::vector<int>& order () const { return order_; }       // point indices by cell
  const std::vector<int>& leafOfPoint () const { return leaf_of_point_; }
  const Eigen::Vector3d& origin () const { return origin_; }
  int numLeaves () const;
  int numPlanarLeaves () const;

private:
  void analyseNode (OctreeNode& node, const PlanarOctreeParams& params) const;
  Eigen::Vector2d local (int r, const Eigen::Vector3f& p, double* h) const;

  const std::vector<Eigen::Vector3f>* points_ = nullptr;
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero ();
  std::vector<OctreeNode> nodes_;
  std::vector<PlanarRegion> regions_;
  std::vector<int> order_;
  std::vector<int> leaf_of_point_;
  int threads_ = 0;
};

}  // namespace normals
}  // namespace pclx
