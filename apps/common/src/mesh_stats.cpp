#include <pclx/apps/mesh_stats.h>

#include <cstdint>
#include <unordered_map>
#include <utility>

namespace pclx {
namespace apps {

void
countOpenEdges (const pcl::PolygonMesh& mesh, std::size_t& boundary, std::size_t& non_manifold)
{
  std::unordered_map<std::uint64_t, std::uint32_t> uses;
  uses.reserve (mesh.polygons.size () * 2);
  for (const auto& poly : mesh.polygons)
    for (std::size_t i = 0; i < poly.vertices.size (); ++i)
    {
      std::uint64_t a = poly.vertices[i], b = poly.vertices[(i + 1) % poly.vertices.size ()];
      if (a > b)
        std::swap (a, b);
      ++uses[(a << 32) | b];
    }
  boundary = non_manifold = 0;
  for (const auto& e : uses)
  {
    boundary += e.second == 1;
    non_manifold += e.second > 2;
  }
}

}  // namespace apps
}  // namespace pclx
