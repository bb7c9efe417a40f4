#pragma once
// Exact k-nearest-neighbour queries over a uniform grid (sorted cell keys). Built in a
// fraction of a kd-tree's time and in parallel: PlanarOctreeNormalEstimation needs kNN at
// only a few percent of a clean cloud's points (the rest get patch or region normals), so
// FLANN's serial build over every point would be its largest single cost.
// Queries visit cube rings of cells around the query until the k-th distance lies inside
// the visited block, so results are the exact k nearest (ties in any order).
#include <Eigen/Core>

#include <cstdint>
#include <cstring>
#include <utility>
#include <vector>

namespace pclx {
namespace normals {
namespace detail {

// A (squared distance, slot) pair as one integer: a non-negative float's bits order like
// its value, so sorting or selecting these orders them as the pairs would (ties by slot)
// with one integer compare each.
inline std::uint64_t
distanceSlotKey (float squared_distance, std::uint32_t slot)
{
  std::uint32_t bits;
  std::memcpy (&bits, &squared_distance, sizeof bits);
  return (static_cast<std::uint64_t> (bits) << 32) | slot;
}
inline std::uint32_t
slotOfKey (std::uint64_t key)
{
  return static_cast<std::uint32_t> (key);
}
inline float
distanceOfKey (std::uint64_t key)
{
  const auto bits = static_cast<std::uint32_t> (key >> 32);
  float d;
  std::memcpy (&d, &bits, sizeof d);
  return d;
}

class GridKnn
{
public:
  // Cells hold about points_per_cell points on a surface (estimated from a subsample).
  void build (const std::vector<Eigen::Vector3f>& points, int points_per_cell = 16, int threads = 0);
  // The k nearest points of q (indices into the build points, unsorted) and their squared
  // distances; fewer when the cloud has fewer. scratch: reusable per thread. positions,
  // if given, gets the points themselves (from the grid's own cell-ordered copy).
  // radius_hint (optional, per thread, in and out): a guess of the k-th distance; the
  // search first scans only the ball of that radius, and writes the next guess. The
  // result is the same with or without it.
  int nearestK (const Eigen::Vector3f& q, int k, std::vector<int>& indices, std::vector<float>& sqr_distances,
                std::vector<std::uint64_t>& scratch, std::vector<Eigen::Vector3f>* positions = nullptr,
                float* radius_hint = nullptr) const;
  double cellSize () const { return cell_; }
  bool empty () const { return ids_.empty (); }

private:
  // (x * dims_y + y) * dims_z + z: z-runs of cells are key ranges (fits 63 bits: 21 per axis).
  std::uint64_t key (std::int64_t x, std::int64_t y, std::int64_t z) const;
  // Points of the cells (x, y, z0..z1): one range [first, second) of ids_ (empty if none).
  std::pair<int, int> runRange (std::int64_t x, std::int64_t y, std::int64_t z0, std::int64_t z1) const;

  double cell_ = 1.0;
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero ();
  std::int64_t dims_[3] = {1, 1, 1};
  std::vector<std::uint64_t> cell_keys_;  // sorted, unique
  std::vector<int> cell_start_;           // cell_keys_.size () + 1 offsets into ids_
  // Per (x, y) column, its first cell in cell_keys_ (dims_x * dims_y + 1 entries): a query
  // finds its cells without binary searches (which would dominate a query). Empty
  // when the table would be much larger than the cloud: lookups then search cell_keys_.
  std::vector<int> column_start_;
  std::vector<int> ids_;                  // point indices by cell
  std::vector<Eigen::Vector3f> points_;   // points by cell (cache-friendly scans)
};

}  // namespace detail
}  // namespace normals
}  // namespace pclx
