#pragma once
// DualContouringOctree: the extrinsic representation of incremental dual contouring (seed 004
// §3.4–3.6) and its polygonisation. Non-template core of pcl::IncrementalDualContouring.
//
// Structure (a hashed octree):
//   * a lattice of leaf cells of edge h anchored at the world origin, so the structure depends
//     on the set of triangles only, not on the order of the frames (incremental = batch);
//   * roots ("blocks") of 2^L leaves per axis (L = 4), kept in a hash map: the volume grows by
//     adding roots wherever geometry arrives (§3.4.1, Fig. 3.6); optionally it is frozen to the
//     volume of the first frame (setVolume / setGrowVolume (false)), geometry outside is dropped
//     and counted;
//   * inside a root, dense per-leaf indices and sparse leaf records (only leaves that an
//     intersected lattice edge touches exist: stop criterion 1 of §3.4.2);
//   * the inner levels of each root are rebuilt at polygonisation time for the ε collapse
//     (Ju et al. 2002), never across roots, so a root is the unit of re-polygonisation.
//
// Departure from §3.4.2: every leaf is at maximum depth (the lattice); the seed's stop
// criterion 2 (no interior triangle in a cell and its parent → coarse leaf) is not used, because
// a coarse leaf's Hermite data lives on its long edges while finer neighbours' minimal edges lie
// inside its faces, and its size would depend on how much the front end simplified. Coarse cells
// come from the ε collapse instead (Ju et al.'s simplification), which measures geometry.
//
// Hermite data (§3.4.3): every lattice edge crossed by a triangle of a frame gets its
// intersection (exact segment–triangle point; top-left rule, so a point on a shared triangle
// edge counts once) and the unit face normal. Per frame and edge: one intersection → S =
// (C − A)·N (Eq. 3.1) gives A's sign (with N pointing out, S > 0: A interior; the seed's text
// has it the other way round), B the opposite; several → parity, with the intersection nearest
// to A (leaves are at maximum depth, so the "refine" branch is never taken). Every
// intersection's plane (C, N) goes into the QEFs of the four leaves around the edge (the seed
// kept only the nearest to A). QEFs are kept in 64-bit fixed point in leaf-local coordinates:
// sums are exact and commutative, so adding frames in any order gives bit-identical data.
// Not tried: the seed's unvalidated proposal of cell quadrics from the front end's per-vertex
// quadrics (FrameMesh::quadrics is ignored).
//
// Signs live in a hash table of shared grid vertices (per root, dense): per vertex, counts of
// exterior and interior votes and a weighted sum. SignRule::SEED (§3.5): same or unknown →
// adopt, different → ambiguous → exterior. MAJORITY: more votes wins. WEIGHTED (default):
// Σ ± distance to the plane; each crossing also informs the next vertex in front of it along
// its lattice line (and behind it on steep lines): a truncated signed distance sampled on the
// lattice lines, so noisy frames average instead of contradicting each other.
// Resolution before polygonisation (§3.6): an unknown vertex takes the sign of the nearest
// informed vertices reached breadth first (≤ 3 edges; SEED / MAJORITY only through leaf edges
// without intersection: the seed's repeated passes over a cell's 3 neighbours); when those
// disagree (Fig. 3.11) or none is reached it stays unresolved → exterior.
//
// Polygonisation: dual contouring over minimal edges. Every lattice edge whose resolved signs
// differ (SEED / MAJORITY: edges of leaves; WEIGHTED: edges at informed vertices) gives a quad
// of the (collapsed) leaves around it; the same polygon of collapsed cells from several
// lattice edges along a coarse edge is emitted once (net orientation), as Ju's cellProc /
// faceProc / edgeProc traversal would. Quads split along the shorter diagonal.
// Vertices: QEF minimiser by truncated eigen-decomposition of AᵀA (singular values below
// 0.1 σ_max dropped), biased to the mass point, clamped into the cell (counted as escaped).
// Incremental: a root whose data changed recomputes its vertices; polygons are redone for the
// roots within 2 of a changed one (a polygon depends on the ≤ 4 roots around its edge and on
// signs resolved ≤ 3 edges away); all other roots keep their cached triangles.
#include <pcl/PolygonMesh.h>

#include <pclx/surface/frame_mesh.h>

#include <Eigen/Core>

#include <cstdint>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

namespace pcl {

class DualContouringOctree
{
public:
  // How conflicting votes of a grid vertex are resolved.
  enum class SignRule
  {
    SEED,     // §3.5: different votes → ambiguous → exterior
    MAJORITY, // more votes wins, ties → exterior
    WEIGHTED  // each vote weighted by the vertex's distance to its crossing (a truncated signed
              // distance along the edges): noisy frames that disagree near the surface
  };

  struct Stats
  {
    // Map
    std::size_t roots = 0, leaves = 0, grid_vertices = 0, memory_bytes = 0;
    // Last addFrameMesh
    std::size_t input_triangles = 0, used_triangles = 0, nonfinite_triangles = 0,
                degenerate_triangles = 0, outside_triangles = 0, bad_index_triangles = 0;
    std::size_t intersections = 0, multi_intersection_edges = 0, touched_roots = 0;
    double t_intersect_ms = 0, t_merge_ms = 0, last_frame_ms = 0;
    // Last polygonisation
    std::size_t repolygonised_roots = 0, cells = 0;  // cells: leaves + collapsed cells with a vertex
    std::size_t vertices = 0, triangles = 0, escaped_vertices = 0, ambiguous_vertices = 0,
                unresolved_vertices = 0, phantom_vertices = 0, collapsed_cells = 0;
    double t_signs_ms = 0, t_vertices_ms = 0, t_polygons_ms = 0, t_output_ms = 0,
           last_reconstruct_ms = 0;
    std::size_t frames = 0;
  };

  DualContouringOctree ();
  ~DualContouringOctree ();
  DualContouringOctree (const DualContouringOctree&) = delete;
  DualContouringOctree& operator= (const DualContouringOctree&) = delete;

  // Leaf edge h in metres (> 0, default 0.01). Only before the first frame (else false).
  bool setLeafSize (double h);
  double getLeafSize () const { return h_; }
  // Levels per root (fixed): a root spans 2^kRootLevels leaves per axis; the ε collapse stops
  // at a whole root.
  static constexpr int kRootLevels = 4;
  // Initial volume. Unset: the first frame's bounding box enlarged by `margin` (default 1.5×,
  // §3.4.1). With growth on (default) it only reports; geometry outside adds roots. With growth
  // off, triangles not inside the volume are dropped and counted (outside_triangles).
  bool setVolume (const Eigen::Vector3d& min, const Eigen::Vector3d& max);  // false if empty / NaN
  void setVolumeMargin (double m) { margin_ = m; }
  void setGrowVolume (bool on) { grow_ = on; }
  bool getVolume (Eigen::Vector3d& min, Eigen::Vector3d& max) const;
  // ε of the octree simplification in metres (0 = off, default): 8 sibling cells (collapsed
  // or leaves) of a root merge while the RMS distance of all their planes to the merged QEF's
  // minimiser stays below ε (Ju et al. 2002, topology-unsafe). False for ε < 0 or NaN.
  bool setSimplificationError (double eps);
  double getSimplificationError () const { return eps_; }
  // Default WEIGHTED: on 14 noisy (Kinect model) views of a sphere the seed's rule left 10.8k
  // ambiguous vertex readings (→ exterior), 50 boundary and 57 non-manifold edges; WEIGHTED 0,
  // 6 and 180... see the module README for the comparison.
  void setSignRule (SignRule r) { rule_ = r; all_dirty_ = true; }
  // A sign change on an edge whose cells are not all leaves (no Hermite data: the rim of a
  // partly seen surface, conflicting signs) has no proper dual vertices. Default (on): use the
  // centres of the missing cells ("phantom" vertices): the mesh stays closed, rims get
  // artefacts up to a leaf off the surface. Off: drop such polygons (holes at rims; 14 noisy
  // views of a sphere: 12 boundary edges instead of 0).
  void setPhantomPolygons (bool on) { phantom_polygons_ = on; all_dirty_ = true; }
  bool getPhantomPolygons () const { return phantom_polygons_; }
  SignRule getSignRule () const { return rule_; }

  // The common entry (§3.4–3.5). False + getLastError () on bad input; nothing fused is lost.
  bool addFrameMesh (const pclx::surface::FrameMesh& world_mesh);
  // Only roots touched since the last call are re-polygonised (and their neighbours whose
  // quads share them); the other roots keep their cached triangles.
  void reconstruct (pcl::PolygonMesh& mesh);
  // Same as reconstruct, but re-polygonises everything (for tests: must equal reconstruct).
  void reconstructFromScratch (pcl::PolygonMesh& mesh);
  // Forget everything (keeps the settings).
  void clear ();

  // Diagnostics: resolved sign of a grid vertex (lattice coordinates): +1 exterior,
  // −1 interior, 0 unknown (before the exterior default), 2 ambiguous.
  int gridVertexState (const Eigen::Vector3i& v) const;
  // Vote counts of a grid vertex (exterior, interior).
  std::pair<int, int> gridVertexVotes (const Eigen::Vector3i& v) const;
  Eigen::Vector3i toLattice (const Eigen::Vector3d& p) const;

  const Stats& getStats () const { return stats_; }
  const std::string& getLastError () const { return error_; }

  struct Impl;  // defined in the .cpp

private:
  bool fail (const std::string& msg);
  void polygonise (pcl::PolygonMesh& mesh, bool all);

  double h_ = 0.01, eps_ = 0, margin_ = 1.5;
  bool grow_ = true, volume_set_ = false, all_dirty_ = true, phantom_polygons_ = true;
  SignRule rule_ = SignRule::WEIGHTED;
  Eigen::Vector3d vol_min_ = Eigen::Vector3d::Zero (), vol_max_ = Eigen::Vector3d::Zero ();
  Stats stats_;
  std::string error_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pcl
