#pragma once
// The planarity octree of Musmanno 2016 (Algorithm 1) plus Musmanno's ch. 7 fix:
// merging adjacent leaves whose planes agree into regions, each with one robust
// surface fit (plane, or a quadric height field: Musmanno's "polynomial fitting").
// Non-templated: it works on plain float positions, the PCL feature wraps it.
#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <utility>
#include <vector>

namespace pclx {
namespace normals {
namespace detail {

struct PlanarOctreeParams
{
  double s_alpha = 6.25;  // planar when λ2 > sα·λ3 ...
  double s_beta = 1.5;    // ... and sβ·λ2 > λ1 (Musmanno 2016, §5.4.1)
  int max_depth = 10;
  int min_points = 10;    // a cell with fewer points is not split and cannot be planar
  int threads = 0;        // 0: OpenMP default
  // Not in Musmanno 2016 (0 = off): a planar cell is split anyway when a point lies farther
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

// A least-squares surface, the fit of a patch (PlanarOctree::fitPatches) or of a merged
// region, kept small: there are about n / max_points patches. Height field
// h = c0 x² + c1 xy + c2 y² + c3 x + c4 y + c5 over the plane through o with normal n
// (in-plane axes n.unitOrthogonal () and n × that), x and y divided by scale.
struct SurfaceFit
{
  Eigen::Vector3f o = Eigen::Vector3f::Zero ();  // absolute position
  Eigen::Vector3f n = Eigen::Vector3f::UnitZ ();
  float scale = 1;
  std::array<float, 6> c{};
  float rms = 0;
  float curvature = 0;
  // Standard error of the fitted slope (radians): σ / (√N · smallest in-plane spread).
  float slope_sigma = 0;
  int support = 0;     // points in the support
  int leaf = -1;       // patches: the planar leaf of the cell
  bool valid = false;  // patches: slope_sigma within the limit
};

// A set of merged coplanar leaves with its surface fit (Musmanno 2016, ch. 7: one robust fit).
struct PlanarRegion
{
  int points = 0;
  int leaves = 0;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero ();     // moments, relative to origin ()
  Eigen::Matrix3d sum_sq = Eigen::Matrix3d::Zero ();
  double base_thickness = 0;  // largest RMS thickness of its leaves (the noise scale)
  SurfaceFit surface;         // rms: RMS residual; curvature: λ3 / Σλ of the region
};

// A cell of at most PlanarOctree::fitPatches' max_points points inside a planar leaf.
struct PatchCell
{
  Eigen::Vector3f center = Eigen::Vector3f::Zero ();
  float half = 0;
  int begin = 0, end = 0;  // range in PlanarOctree::order ()
  int leaf = -1;
  int first_child = -1;    // 8 consecutive sub-cells (in the leaf's tree); -1: a patch
  int fit = -1;            // its SurfaceFit (patches with points)
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

  // Musmanno 2016, ch. 7: union of adjacent planar leaves whose normals differ by less than
  // max_angle_deg and whose union stays as thin as thickness_factor × the thickest part.
  void mergeCoplanarLeaves (double max_angle_deg, double thickness_factor);
  // Surface fit of every region (call after mergeCoplanarLeaves).
  void fitRegions (bool quadric);
  // Normal of region r's fitted surface at (the projection of) p, and p's distance to it.
  Eigen::Vector3f regionNormalAt (int r, const Eigen::Vector3f& p) const;
  double regionResidual (int r, const Eigen::Vector3f& p) const;

  // Patches (not in Musmanno 2016): every planar leaf is cut into cells of at most max_points
  // points; each cell gets a quadric fitted over a box around its points that holds about
  // support_points points at the leaf's density, restricted to the same leaf or merged
  // region (the same sheet of surface). When the fit's slope is more uncertain than
  // max_slope_sigma (radians: noise), the box doubles, up to `scales` sizes, so a patch
  // spends no more support than the noise needs; a cell that never gets there is marked
  // invalid. A point's normal is the gradient of its cell's fit: a kNN-sized support
  // without a kNN search, and no leaf border inside it (the error Musmanno found in
  // Algorithm 2). Call after mergeCoplanarLeaves.
  void fitPatches (int max_points, bool quadric, double max_slope_sigma, int scales, int support_points);
  // The patch cells of a planar leaf (node id), as a tree: cell 0 is the leaf itself.
  const std::vector<PatchCell>& patchCellsOfLeaf (int node) const
  {
    static const std::vector<PatchCell> none;
    return node >= 0 && node < static_cast<int> (leaf_slot_.size ()) && leaf_slot_[node] >= 0
               ? leaf_cells_[leaf_slot_[node]] : none;
  }
  const std::vector<SurfaceFit>& patches () const { return patches_; }
  const std::vector<int>& patchOfPoint () const { return patch_of_point_; }  // SurfaceFit id, -1: none
  // Valid SurfaceFit of the patch containing p (or of its nearest sibling), -1 if none.
  int locatePatch (const Eigen::Vector3f& p) const;
  Eigen::Vector3f patchNormalAt (int fit, const Eigen::Vector3f& p) const;

  const std::vector<OctreeNode>& nodes () const { return nodes_; }
  const std::vector<PlanarRegion>& regions () const { return regions_; }
  const std::vector<int>& order () const { return order_; }       // point indices by cell
  const std::vector<int>& leafOfPoint () const { return leaf_of_point_; }
  const Eigen::Vector3d& origin () const { return origin_; }
  int numLeaves () const;
  int numPlanarLeaves () const;

private:
  void analyseNode (OctreeNode& node, const PlanarOctreeParams& params) const;
  // Stable split of order_[begin, end) into the 8 octants around c; counts per octant.
  void partitionOctants (int begin, int end, const Eigen::Vector3f& c, std::array<int, 8>& counts,
                         std::vector<int>& buffer, std::vector<unsigned char>& code);
  // Leaves whose cube overlaps the box [lo, hi].
  void leavesInBox (const Eigen::Vector3f& lo, const Eigen::Vector3f& hi, std::vector<int>& out) const;
  // Appends the points of planar leaf `leaf` (node id) that lie in [lo, hi].
  void patchPointsInBox (int leaf, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi,
                         std::vector<Eigen::Vector3f>& out) const;

  // fitPatches ()'s stages.
  struct PatchScratch;
  struct PatchLeafFrame;
  // Cuts every planar leaf (node ids) into its tree of patch cells.
  void cutPatchCells (const std::vector<int>& leaves, int max_points, int threads);
  // Gives every non-empty patch cell its SurfaceFit slot and every point its patch.
  void numberPatches (int threads);
  // The candidate points of a leaf's patches, bucketed over its plane.
  PatchLeafFrame gatherLeafCandidates (int leaf, int scales, int support_points, PatchScratch& scratch) const;
  // The fit of one patch cell C of leaf L, growing its ball up to `scales` sizes.
  void fitPatch (const PatchCell& C, const OctreeNode& L, const PatchLeafFrame& frame, bool quadric,
                 double max_slope_sigma, int scales, PatchScratch& scratch);

  const std::vector<Eigen::Vector3f>* points_ = nullptr;
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero ();
  std::vector<OctreeNode> nodes_;
  std::vector<PlanarRegion> regions_;
  std::vector<int> order_;
  // The points in order_'s order: cells read their points as one run, not by gathers
  // through order_ (the octree, patch and region stages all read cells' points).
  std::vector<Eigen::Vector3f> sorted_;
  std::vector<int> leaf_of_point_;
  std::vector<std::vector<PatchCell>> leaf_cells_;  // per planar leaf: its tree of patch cells
  std::vector<SurfaceFit> patches_;
  std::vector<int> patch_of_point_;
  std::vector<int> leaf_slot_;  // per node: its index in leaf_cells_, -1 if none
  int threads_ = 0;
};

}  // namespace detail
}  // namespace normals
}  // namespace pclx
