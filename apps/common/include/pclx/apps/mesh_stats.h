#pragma once
// What the mesh-writing apps report about their output: edges used by one triangle only
// (holes, rims) and by more than two (non-manifold). Both 0: watertight.
#include <pcl/PolygonMesh.h>

#include <cstddef>

namespace pclx {
namespace apps {

void countOpenEdges (const pcl::PolygonMesh& mesh, std::size_t& boundary, std::size_t& non_manifold);

}  // namespace apps
}  // namespace pclx
