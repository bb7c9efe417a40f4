#pragma once
#include <pcl/PolygonMesh.h>

#include <pclx/surface/frame_mesh.h>

#include <Eigen/Core>

#include <cstdint>
#include <future>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

namespace pcl {

/** \brief The extrinsic representation of incremental dual contouring and its
  * polygonisation (da Paz 2017, §3.4–3.6; "the dissertation" below): the non-template core of
  * pcl::IncrementalDualContouring.
  *
  * Structure (a hashed octree):
  *   * a lattice of leaf cells of edge h anchored at the world origin, so the structure depends
  *     on the set of triangles only, not on the order of the frames (incremental = batch);
  *   * roots ("blocks") of 2^L leaves per axis (L = 4), kept in a hash map: the volume grows by
  *     adding roots wherever geometry arrives (§3.4.1, Fig. 3.6); optionally it is frozen to the
  *     volume of the first frame (setVolume / setGrowVolume (false)), geometry outside is dropped
  *     and counted;
  *   * inside a root, dense per-leaf indices and sparse leaf records (only leaves that an
  *     intersected lattice edge touches exist: stop criterion 1 of §3.4.2);
  *   * the inner levels of each root are rebuilt at polygonisation time for the ε collapse
  *     (Ju et al. 2002), never across roots, so a root is the unit of re-polygonisation.
  *
  * Departure from §3.4.2: every leaf is at maximum depth (the lattice); the dissertation's stop
  * criterion 2 (no interior triangle in a cell and its parent → coarse leaf) is not used, because
  * a coarse leaf's Hermite data lives on its long edges while finer neighbours' minimal edges lie
  * inside its faces, and its size would depend on how much the front end simplified. Coarse cells
  * come from the ε collapse instead (Ju et al.'s simplification), which measures geometry.
  *
  * Hermite data (§3.4.3), averaged over frames: every lattice edge crossed by a triangle keeps
  * running weighted sums of its crossings' positions along the edge and of their unit normals,
  * as a TSDF averages distances (the dissertation keeps one sample per edge and merges only
  * signs). The weight of a crossing is the cosine of its incidence angle times a falloff with
  * range beyond 1 m (1 without a viewpoint). The sums are 64-bit fixed point: exact and
  * commutative, so adding frames in any order gives bit-identical data (incremental = batch).
  * Per frame and edge: one crossing → S = (C − A)·N (Eq. 3.1) gives A's sign (with N pointing
  * out, S > 0: A interior; the dissertation's text has it the other way round), B the opposite;
  * several → parity. Not tried: the dissertation's unvalidated proposal of cell quadrics from
  * the front end's per-vertex quadrics (FrameMesh::quadrics is ignored).
  *
  * Signs live on the shared grid vertices of each root (dense): per vertex, counts of exterior
  * and interior votes and a weighted sum. SignRule::SEED (§3.5): same or unknown → adopt,
  * different → ambiguous → exterior. MAJORITY: more votes wins. WEIGHTED (default): Σ weight ·
  * ± distance to the plane; each crossing also informs the vertices in front of it along its
  * lattice line (and behind it on steep lines): a truncated signed distance sampled on the
  * lattice lines, so noisy frames average instead of contradicting each other. A vertex no
  * crossing informed is unobserved. SEED / MAJORITY resolve unknown vertices from the nearest
  * informed ones reached breadth first (≤ 3 leaf edges without intersection, §3.6; neighbours
  * that disagree, Fig. 3.11, leave it unobserved).
  *
  * Polygonisation: manifold dual contouring (Schaefer, Ju and Warren 2007) over minimal edges.
  * Every lattice edge between an exterior and an interior observed vertex gives a quad of the
  * cells around it; an edge with an unobserved end gives none (the rim of what was seen stays
  * open, as a TSDF's does). A cell holds one vertex per surface component of its corner signs,
  * the cycles of marching cubes' face segments; on a face with four crossings the interior
  * corners are cut off unless that would put both segments into one component on both sides
  * (then they are joined), so no dual edge carries more than two quads. A component's vertex
  * minimises the QEF of its edges' averaged planes (truncated eigen-decomposition, singular
  * values below 0.1 σ_max dropped, relative to the mass point of its crossings); a minimiser
  * outside the cell falls back to the mass point (counted as escaped). Quads split along the
  * shorter diagonal.
  * Simplification (ε > 0): inside a root, 8 sibling nodes of one component each merge into one
  * vertex while Ju et al.'s (2002) topology test holds (one manifold component for the node's
  * corners; the signs at the middles of its edges, faces and of the node agree with a corner
  * they lie between) and the merged vertex lies within ε of every averaged crossing plane of the
  * node: a merge neither opens a hole nor moves a crossing plane by more than ε. The test reads
  * the signs with unobserved vertices taking those of the observed ones a few steps away, so the
  * unseen inside of a wall does not count as a second surface; cells on the rim of what was seen
  * do not merge (the two sides of a thin part could cancel). The octree's merges stop where
  * noise makes the signs near a wall random, at rims and at root borders, so the mesh is then
  * simplified further by edge collapses (Garland and Heckbert 1997) with the same bound: every
  * vertex stays within ε of every crossing plane of the cells it stands for (Ronfard and
  * Rossignac 1996), and the link condition keeps the mesh's topology and its boundaries.
  * Incremental: a root whose data changed recomputes the vertices of the roots around it (a
  * cell's vertices read its neighbours' signs and edges); polygons are redone for the roots
  * within 2 of a changed one; all other roots keep their cached triangles.
  *
  * \note H. O. da Paz, 2017, "Reconstrução Adaptativa de Superfícies Implícitas a partir de
  * Imagens de Profundidade", MSc dissertation, IMPA; T. Ju, F. Losasso, S. Schaefer, J. Warren,
  * 2002, "Dual Contouring of Hermite Data", ACM SIGGRAPH; S. Schaefer, T. Ju, J. Warren, 2007,
  * "Manifold Dual Contouring", IEEE TVCG; M. Garland, P. S. Heckbert, 1997, "Surface
  * Simplification Using Quadric Error Metrics", SIGGRAPH; R. Ronfard, J. Rossignac, 1996,
  * "Full-range Approximation of Triangulated Polyhedra", Computer Graphics Forum 15(3).
  * \ingroup surface
  */
class DualContouringOctree
{
public:
  /** \brief How the conflicting votes of a grid vertex are resolved. */
  enum class SignRule
  {
    SEED,     ///< §3.5: different votes make the vertex ambiguous, taken as exterior
    MAJORITY, ///< more votes wins, ties are exterior
    WEIGHTED  ///< each vote weighted by the vertex's distance to its crossing (a truncated
              ///< signed distance along the edges), so noisy frames that disagree near the
              ///< surface average out
  };

  /** \brief Counts and wall times of the map, the last addFrameMesh () and the last
    * polygonisation. */
  struct Stats
  {
    std::size_t roots = 0;          ///< roots of the map
    std::size_t leaves = 0;         ///< leaves of the map
    std::size_t grid_vertices = 0;  ///< grid vertices with sign data
    std::size_t memory_bytes = 0;   ///< memory of the map, the cached polygons and the last output's working arrays
    std::size_t input_triangles = 0;       ///< last frame: triangles given
    std::size_t used_triangles = 0;        ///< last frame: triangles fused
    std::size_t nonfinite_triangles = 0;   ///< last frame: triangles with NaN / Inf corners
    std::size_t degenerate_triangles = 0;  ///< last frame: triangles of zero area
    std::size_t outside_triangles = 0;     ///< last frame: triangles outside a frozen volume
    std::size_t bad_index_triangles = 0;   ///< last frame: triangles with out-of-range indices
    std::size_t intersections = 0;             ///< last frame: lattice edge crossings
    std::size_t multi_intersection_edges = 0;  ///< last frame: edges crossed more than once (parity)
    std::size_t touched_roots = 0;             ///< last frame: roots whose data changed
    double t_intersect_ms = 0;  ///< last frame: intersecting the lattice (ms)
    double t_merge_ms = 0;      ///< last frame: merging into the map (ms)
    double last_frame_ms = 0;   ///< last frame: intersecting and merging (ms)
    double total_intersect_ms = 0;  ///< every frame: intersecting the lattice (ms)
    double total_merge_ms = 0;      ///< every frame: merging into the map (ms)
    std::size_t repolygonised_roots = 0;  ///< last polygonisation: roots redone
    std::size_t cells = 0;                ///< last polygonisation: leaves and collapsed cells with a vertex
    std::size_t vertices = 0;             ///< last polygonisation: output vertices
    std::size_t triangles = 0;            ///< last polygonisation: output triangles
    std::size_t escaped_vertices = 0;     ///< QEF minimisers outside their cell (mass point used)
    std::size_t ambiguous_vertices = 0;   ///< grid vertices whose votes cancel (taken as exterior)
    std::size_t collapsed_cells = 0;      ///< cells made by the ε collapse
    std::size_t rim_cells = 0;  ///< cells whose surface reaches an unobserved vertex (the open rim of what was seen)
    std::size_t missing_vertices = 0;  ///< polygons left out for a cell without a vertex (0 unless the map is inconsistent)
    double t_signs_ms = 0;           ///< last polygonisation: signs (ms)
    double t_vertices_ms = 0;        ///< last polygonisation: dual vertices (ms)
    double t_polygons_ms = 0;        ///< last polygonisation: polygons (ms)
    double t_output_ms = 0;          ///< last polygonisation: output mesh (ms), with the edge collapses
    std::size_t octree_triangles = 0;  ///< last polygonisation: triangles before the edge collapses
    std::size_t mesh_collapses = 0;    ///< last polygonisation: edges collapsed (ε > 0)
    double t_collapse_ms = 0;          ///< last polygonisation: the edge collapses (ms)
    std::size_t holes_filled = 0;      ///< last polygonisation: holes closed by patches
    std::size_t holes_open = 0;        ///< last polygonisation: loops left open (over the limit; 0 when off)
    std::size_t hole_triangles = 0;    ///< last polygonisation: triangles of the patches
    std::size_t hole_patches_reused = 0;  ///< last polygonisation: patches kept from the one before
    double t_holes_ms = 0;             ///< last polygonisation: closing the holes (ms)
    double last_reconstruct_ms = 0;  ///< last polygonisation: total (ms)
    std::size_t frames = 0;          ///< frames fused
  };

  /** \brief Empty map with the default settings. */
  DualContouringOctree ();
  /** \brief Destructor (waits for a merge still running). */
  ~DualContouringOctree ();
  /** \brief Not copyable (the map can be large). */
  DualContouringOctree (const DualContouringOctree&) = delete;
  /** \brief Not copyable (the map can be large).
    * \return none (deleted)
    */
  DualContouringOctree& operator= (const DualContouringOctree&) = delete;

  /** \brief Set the leaf edge h; only before the first frame.
    * \param[in] h the edge in metres (> 0, finite; default 0.01)
    * \return false (with a PCL_ERROR, the old value kept) for a bad value or after the first frame
    */
  bool setLeafSize (double h);
  /** \brief Get the leaf edge.
    * \return h in metres
    */
  double getLeafSize () const { return h_; }
  /** \brief Levels per root (fixed): a root spans 2^kRootLevels leaves per axis; the ε collapse
    * stops at a whole root. */
  static constexpr int kRootLevels = 4;
  /** \brief Set the initial volume. Unset, it is the first frame's bounding box enlarged by the
    * volume margin (§3.4.1). With growth on (default) it only reports; geometry outside adds
    * roots. With growth off, triangles not inside the volume are dropped and counted
    * (Stats::outside_triangles).
    * \param[in] min the lower corner (metres)
    * \param[in] max the upper corner (metres)
    * \return false (with a PCL_ERROR, the old volume kept) when the volume is empty or not finite
    */
  bool setVolume (const Eigen::Vector3d& min, const Eigen::Vector3d& max);
  /** \brief Set the factor by which the first frame's bounding box is enlarged when no volume
    * is set.
    * \param[in] m the factor (default 1.5)
    */
  void setVolumeMargin (double m) { margin_ = m; }
  /** \brief Let the volume grow with the geometry (default) or freeze it.
    * \param[in] on true: geometry outside the volume adds roots; false: it is dropped and counted
    */
  void setGrowVolume (bool on) { waitForMerge (); grow_ = on; }
  /** \brief Get the volume.
    * \param[out] min the lower corner (metres)
    * \param[out] max the upper corner (metres)
    * \return false while no volume is set (before setVolume () or the first frame)
    */
  bool getVolume (Eigen::Vector3d& min, Eigen::Vector3d& max) const;
  /** \brief Set ε of the simplification: sibling nodes merge while the merge is topology-safe
    * and the merged vertex lies within ε of every crossing plane of the merged cells; then the
    * mesh's edges collapse under the same bound, keeping its topology.
    * \param[in] eps ε in metres (≥ 0, finite; 0 = off, default)
    * \return false (with a PCL_ERROR, the old value kept) for ε < 0 or not finite
    */
  bool setSimplificationError (double eps);
  /** \brief Get ε of the octree simplification.
    * \return ε in metres
    */
  double getSimplificationError () const { return eps_; }
  /** \brief Set the largest hole closed in the output. The views leave small holes where no
    * frame's surface crossed the lattice (crevices, parts seen only at grazing angles or between
    * a frame's depth jumps); each hole whose boundary fits in a box of this diagonal becomes a
    * patch triangulated, refined and faired to meet the surface around it. Larger openings, such
    * as the rim of what was seen, stay open, and so do holes of more than
    * pclx::surface::detail::kCubicSearchEdges edges.
    * \param[in] diameter the box diagonal in metres (≥ 0, finite; 0 leaves every hole open);
    * until set, kAutoHoleLeaves leaves
    * \return false (with a PCL_ERROR, the old value kept) for a negative or non-finite diameter
    * \note P. Liepa, 2003, "Filling Holes in Meshes", Eurographics Symposium on Geometry
    * Processing, as CGAL implements it.
    */
  bool setMaxHoleSize (double diameter);
  /** \brief Get the largest hole closed in the output.
    * \return the box diagonal in metres (kAutoHoleLeaves leaves until set)
    */
  double getMaxHoleSize () const { return hole_auto_ ? kAutoHoleLeaves * h_ : max_hole_; }
  /** \brief The largest hole closed until setMaxHoleSize (), in leaves: the crevices that orbits
    * of depth frames leave open on organic objects measure up to about ten leaves. */
  static constexpr double kAutoHoleLeaves = 10;
  /** \brief Set how votes become signs.
    * \param[in] r the rule (default SignRule::WEIGHTED)
    */
  void setSignRule (SignRule r) { waitForMerge (); rule_ = r; all_dirty_ = true; }
  /** \brief Get how votes become signs.
    * \return the rule
    */
  SignRule getSignRule () const { return rule_; }

  /** \brief Fuse a world-space mesh into the map (§3.4–3.5).
    * \param[in] world_mesh the mesh, counter-clockwise seen from outside
    * \return false (with a PCL_ERROR and getLastError ()) on bad input; the map is then unchanged
    * \note With overlapped merges (setOverlapMerges ()) the call returns once the mesh is
    * checked and intersected with the lattice, while its merge runs on.
    */
  bool addFrameMesh (const pcl::FrameMesh& world_mesh);
  /** \brief Merge each frame into the map on a thread of its own, so that the caller prepares
    * the next frame (its front end, its lattice crossings) meanwhile. Every other call first
    * waits for that merge, and the merges run in frame order: the map is the same either way.
    * \param[in] on default true; merges overlap only while OpenMP has more than one thread
    */
  void setOverlapMerges (bool on) { waitForMerge (); overlap_ = on; }
  /** \brief Whether frames' merges may overlap the next frame's preparation.
    * \return whether they may */
  bool getOverlapMerges () const { return overlap_; }
  /** \brief Wait for the merge of the last frame, when it still runs (setOverlapMerges ()). */
  void waitForMerge () const;
  /** \brief Polygonise the map (§3.6). Only roots touched since the last call are
    * re-polygonised (with their neighbours whose quads share them); the other roots keep their
    * cached triangles.
    * Clears getLastError ().
    * \param[out] mesh the mesh (x, y, z vertices; triangles counter-clockwise seen from outside)
    */
  void reconstruct (pcl::PolygonMesh& mesh);
  /** \brief Same as reconstruct (), but re-polygonises every root (for tests: must give the
    * same mesh).
    * \param[out] mesh the mesh
    */
  void reconstructFromScratch (pcl::PolygonMesh& mesh);
  /** \brief Forget every fused frame; the settings are kept. */
  void clear ();

  /** \brief Diagnostics: the resolved sign of a grid vertex.
    * \param[in] v the vertex in lattice coordinates
    * \return +1 exterior, −1 interior, 0 unknown (before the exterior default), 2 ambiguous
    */
  int gridVertexState (const Eigen::Vector3i& v) const;
  /** \brief Diagnostics: the vote counts of a grid vertex.
    * \param[in] v the vertex in lattice coordinates
    * \return (exterior votes, interior votes)
    */
  std::pair<int, int> gridVertexVotes (const Eigen::Vector3i& v) const;
  /** \brief The lattice vertex nearest below a point.
    * \param[in] p a point in world coordinates (metres)
    * \return its lattice coordinates
    */
  Eigen::Vector3i toLattice (const Eigen::Vector3d& p) const;

  /** \brief Get the counts and timings.
    * \return the statistics
    */
  const Stats& getStats () const { waitForMerge (); return stats_; }
  /** \brief Get the reason of the last refused call.
    * \return the message, empty after a call that succeeded
    */
  const std::string& getLastError () const { return error_; }

  /** \brief Internal: the map's storage (defined in the .cpp, public for its helpers there). */
  struct Impl;
  /** \brief Internal: the checked triangles of one frame (defined in the .cpp). */
  struct FrameTriangles;

private:
  bool fail (const std::string& msg);
  bool checkFrameTriangles (const pcl::FrameMesh& mesh, FrameTriangles& ft, Stats& st);
  void mergeFrame (const FrameTriangles& ft, double t_intersect_ms, bool parallel);
  void polygonise (pcl::PolygonMesh& mesh, bool all);
  void writeMesh (pcl::PolygonMesh& mesh);

  double h_ = 0.01, eps_ = 0, margin_ = 1.5, max_hole_ = 0;
  bool hole_auto_ = true;
  bool grow_ = true, volume_set_ = false, all_dirty_ = true, overlap_ = true;
  SignRule rule_ = SignRule::WEIGHTED;
  Eigen::Vector3d vol_min_ = Eigen::Vector3d::Zero (), vol_max_ = Eigen::Vector3d::Zero ();
  Stats stats_;  // written by a running merge until waitForMerge ()
  std::string error_;
  std::unique_ptr<Impl> impl_;
  mutable std::future<void> merging_;  // the running merge, if any (declared last: joined first)
};

}  // namespace pcl
