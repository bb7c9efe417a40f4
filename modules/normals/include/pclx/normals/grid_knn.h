#pragma once
// Exact k-nearest-neighbour queries over a uniform grid (sorted cell keys). Built in a
// fraction of a kd-tree's time and in parallel: PlanarOctreeNormalEstimation needs kNN at
// only a few percent of a clean cloud's points (the rest get patch or region normals), so
// FLANN's serial build over every point was its largest single cost (0.41 of 1.53 s at 1M).
// Queries visit cube rings of cells around the query until the k-th distance lies inside
// the visited block, so results are the exact k nearest (ties in any order).
#include <Eigen/Core>

#include <cstdint>
#include <utility>
#include <vector>

namespace pclx {
namespace normals {

class GridKnn
{
public:
  // Cells hold about points_per_cell points on a surface (estimated from a subsample).
  void build (const std::vector<Eigen::Vector3f>& points, int points_per_cell = 16, int threads = 0);
  // The k nearest points of q (indices into the build points, unsorted) and their squared
  // distances; fewer when the cloud has fewer. scratch: reusable per thread.
  int nearestK (const Eigen::Vector3f& q, int k, std::vector<int>& indices, std::vector<float>& sqr_distances,
                std::vector<std::pair<float, int>>& scratch) const;
  double cellSize () const { return cell_; }
  bool empty () const { return ids_.empty (); }

private:
  std::uint64_t key (std::int64_t x, std::int64_t y, std::int64_t z) const;
  // Range [first, second) of cell (x, y, z) in ids_, empty if no point.
  std::pair<int, int> cellRange (std::int64_t x, std::int64_t y, std::int64_t z) const;

  double cell_ = 1.0;
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero ();
  std::int64_t dims_[3] = {1, 1, 1};
  std::vector<std::uint64_t> cell_keys_;  // sorted, unique
  std::vector<int> cell_start_;           // cell_keys_.size () + 1 offsets into ids_
  std::vector<int> ids_;                  // point indices by cell
  std::vector<Eigen::Vector3f> points_;   // points by cell (cache-friendly scans)
};

}  // namespace normals
}  // namespace pclx
