#pragma once
// The exact HPR core (Katz et al. 2007): convex hull of the spherically flipped
// cloud plus the viewpoint, with reentrant Qhull (libqhull_r).
#include <Eigen/Core>
#include <Eigen/Geometry>

#include <string>
#include <vector>

namespace pclx {
namespace hpr {
namespace detail {

struct HullResult
{
  bool ok = false;
  std::string error;                     // Qhull's message when !ok
  std::vector<int> vertices;             // ids (into the input) of hull vertices, the viewpoint excluded
  std::vector<Eigen::Vector3i> triangles;  // hull facets not touching the viewpoint (when requested)
};

// Convex hull of `points` (already flipped, viewpoint at the origin) ∪ {origin}.
// `triangulate` also returns facets (Katz's "quick and dirty" reconstruction).
// `joggle` retries degenerate (flat) inputs with Qhull's QJ option.
HullResult flippedHull (const std::vector<Eigen::Vector3d>& points, bool triangulate, bool joggle = false);

}  // namespace detail
}  // namespace hpr
}  // namespace pclx
