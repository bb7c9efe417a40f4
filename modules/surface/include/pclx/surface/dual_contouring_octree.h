#pragma once
// DualContouringOctree: the extrinsic representation of incremental dual contouring and its
// polygonisation (H. O. da Paz, "Reconstrução adaptativa de superfícies implícitas a partir de
// imagens de profundidade", MSc dissertation, IMPA, 2017, §3.4–3.6; "the dissertation" below).
// Non-template core of pcl::IncrementalDualContouring.
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
// Departure from §3.4.2: every leaf is at maximum depth (the lattice); the dissertation's stop
// criterion 2 (no interior triangle in a cell and its parent → coarse leaf) is not used, because
// a coarse leaf's Hermite data lives on its long edges while finer neighbours' minimal edges lie
// inside its faces, and its size would depend on how much the front end simplified. Coarse cells
// come from the ε collapse instead (Ju et al.'s simplification), which measures geometry.
//
// Hermite data (§3.4.3), averaged over frames: every lattice edge crossed by a triangle keeps
// running weighted sums of its crossings' positions along the edge and of their unit normals,
// as a TSDF averages distances (the dissertation keeps one sample per edge and merges only
// signs). The weight of a crossing is the cosine of its incidence angle times a falloff with
// range beyond 1 m (1 without a viewpoint). The sums are 64-bit fixed point: exact and
// commutative, so adding frames in any order gives bit-identical data (incremental = batch).
// Per frame and edge: one crossing → S = (C − A)·N (Eq. 3.1) gives A's sign (with N pointing
// out, S > 0: A interior; the dissertation's text has it the other way round), B the opposite;
// several → parity. Not tried: the dissertation's unvalidated proposal of cell quadrics from
// the front end's per-vertex quadrics (FrameMesh::quadrics is ignored).
//
// Signs live on the shared grid vertices of each root (dense): per vertex, counts of exterior
// and interior votes and a weighted sum. SignRule::SEED (§3.5): same or unknown → adopt,
// different → ambiguous → exterior. MAJORITY: more votes wins. WEIGHTED (default): Σ weight ·
// ± distance to the plane; each crossing also informs the vertices in front of it along its
// lattice line (and behind it on steep lines): a truncated signed distance sampled on the
// lattice lines, so noisy frames average instead of contradicting each other. A vertex no
// crossing informed is unobserved. SEED / MAJORITY resolve unknown vertices from the nearest
// informed ones reached breadth first (≤ 3 leaf edges without intersection, §3.6; neighbours
// that disagree, Fig. 3.11, leave it unobserved).
//
// Polygonisation: manifold dual contouring (Schaefer, Ju and Warren 2007) over minimal edges.
// Every lattice edge between an exterior and an interior observed vertex gives a quad of the
// cells around it; an edge with an unobserved end gives none (the rim of what was seen stays
// open, as a TSDF's does). A cell holds one vertex per surface component of its corner signs,
// the cycles of marching cubes' face segments; on a face with four crossings the interior
// corners are cut off unless that would put both segments into one component on both sides
// (then they are joined), so no dual edge carries more than two quads. A component's vertex
// minimises the QEF of its edges' averaged planes (truncated eigen-decomposition, singular
// values below 0.1 σ_max dropped, relative to the mass point of its crossings); a minimiser
// outside the cell falls back to the mass point (counted as escaped). Quads split along the
// shorter diagonal.
// Simplification (ε > 0): inside a root, 8 sibling nodes of one component each merge into one
// vertex while Ju et al.'s (2002) topology test holds (one manifold component for the node's
// corners; the signs at the middles of its edges, faces and of the node agree with a corner
// they lie between) and the merged vertex lies within ε of every averaged crossing plane of the
// node: a merge neither opens a hole nor moves a crossing plane by more than ε. The test reads
// the signs with unobserved vertices taking those of the observed ones a few steps away, so the
// unseen inside of a wall does not count as a second surface; cells on the rim of what was seen
// do not merge (the two sides of a thin part could cancel).
// Incremental: a root whose data changed recomputes the vertices of the roots around it (a
// cell's vertices read its neighbours' signs and edges); polygons are redone for the roots
// within 2 of a changed one; all other roots keep their cached triangles.
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
                collapsed_cells = 0;
    // Cells whose surface reaches an unobserved vertex (the open rim of what was seen), and
    // polygons left out for a cell without a vertex (0 unless the map is inconsistent).
    std::size_t rim_cells = 0, missing_vertices = 0;
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
  // ε of the octree simplification in metres (0 = off, default): sibling nodes merge while the
  // merge is topology-safe and the merged vertex lies within ε of every crossing plane of the
  // merged cells. False for ε < 0 or NaN.
  bool setSimplificationError (double eps);
  double getSimplificationError () const { return eps_; }
  // How votes become signs (default WEIGHTED, see above).
  void setSignRule (SignRule r) { rule_ = r; all_dirty_ = true; }
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

  struct Impl;            // defined in the .cpp
  struct FrameTriangles;  // defined in the .cpp

private:
  bool fail (const std::string& msg);
  bool checkFrameTriangles (const pclx::surface::FrameMesh& mesh, FrameTriangles& ft);
  void polygonise (pcl::PolygonMesh& mesh, bool all);
  void writeMesh (pcl::PolygonMesh& mesh);

  double h_ = 0.01, eps_ = 0, margin_ = 1.5;
  bool grow_ = true, volume_set_ = false, all_dirty_ = true;
  SignRule rule_ = SignRule::WEIGHTED;
  Eigen::Vector3d vol_min_ = Eigen::Vector3d::Zero (), vol_max_ = Eigen::Vector3d::Zero ();
  Stats stats_;
  std::string error_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pcl
