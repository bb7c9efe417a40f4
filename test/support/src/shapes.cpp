#include <pclx/testing/shapes.h>

#include <cmath>
#include <map>

namespace pclx {
namespace testing {

namespace {

// A grid of (n+1)² vertices over the parallelogram origin + s·u + t·v, s,t ∈ [0,1],
// with faces oriented along u × v.
TriangleMesh
gridPatch (const Eigen::Vector3f& origin, const Eigen::Vector3f& u, const Eigen::Vector3f& v, int n)
{
  TriangleMesh m;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i)
      m.vertices.push_back (origin + u * (float (i) / n) + v * (float (j) / n));
  auto id = [n] (int i, int j) { return j * (n + 1) + i; };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
    {
      m.faces.emplace_back (id (i, j), id (i + 1, j), id (i + 1, j + 1));
      m.faces.emplace_back (id (i, j), id (i + 1, j + 1), id (i, j + 1));
    }
  return m;
}

TriangleMesh
boxMesh (const Eigen::Vector3f& size, int grid)
{
  const Eigen::Vector3f h = size / 2;
  const Eigen::Vector3f X (size.x (), 0, 0), Y (0, size.y (), 0), Z (0, 0, size.z ());
  TriangleMesh m;
  // Each face: origin corner and two edges ordered so that u × v points outward.
  m.append (gridPatch (Eigen::Vector3f (-h.x (), -h.y (), -h.z ()), Y, X, grid));  // -z
  m.append (gridPatch (Eigen::Vector3f (-h.x (), -h.y (), h.z ()), X, Y, grid));   // +z
  m.append (gridPatch (Eigen::Vector3f (-h.x (), -h.y (), -h.z ()), X, Z, grid));  // -y
  m.append (gridPatch (Eigen::Vector3f (-h.x (), h.y (), -h.z ()), Z, X, grid));   // +y
  m.append (gridPatch (Eigen::Vector3f (-h.x (), -h.y (), -h.z ()), Z, Y, grid));  // -x
  m.append (gridPatch (Eigen::Vector3f (h.x (), -h.y (), -h.z ()), Y, Z, grid));   // +x
  return m;
}

}  // namespace

TriangleMesh
makeSphere (float radius, int subdivisions, const Eigen::Vector3f& center)
{
  const float t = (1.f + std::sqrt (5.f)) / 2.f;
  TriangleMesh m;
  m.vertices = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (auto& v : m.vertices)
    v.normalize ();
  m.faces = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
             {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
             {3, 8, 9},  {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int s = 0; s < subdivisions; ++s)
  {
    std::map<std::pair<int, int>, int> midpoint;
    auto mid = [&] (int a, int b) {
      const auto key = std::minmax (a, b);
      auto it = midpoint.find (key);
      if (it != midpoint.end ())
        return it->second;
      m.vertices.push_back ((m.vertices[a] + m.vertices[b]).normalized ());
      const int id = static_cast<int> (m.vertices.size ()) - 1;
      midpoint.emplace (key, id);
      return id;
    };
    std::vector<Eigen::Vector3i> faces;
    faces.reserve (m.faces.size () * 4);
    for (const auto& f : m.faces)
    {
      const int a = mid (f[0], f[1]), b = mid (f[1], f[2]), c = mid (f[2], f[0]);
      faces.emplace_back (f[0], a, c);
      faces.emplace_back (f[1], b, a);
      faces.emplace_back (f[2], c, b);
      faces.emplace_back (a, b, c);
    }
    m.faces.swap (faces);
  }
  for (auto& v : m.vertices)
    v = center + radius * v;
  return m;
}

TriangleMesh
makeTorus (float R, float r, int nu, int nv)
{
  TriangleMesh m;
  const float two_pi = 2.f * static_cast<float> (M_PI);
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j)
    {
      const float u = two_pi * i / nu, v = two_pi * j / nv;
      m.vertices.emplace_back ((R + r * std::cos (v)) * std::cos (u), (R + r * std::cos (v)) * std::sin (u),
                               r * std::sin (v));
    }
  auto id = [nu, nv] (int i, int j) { return (i % nu) * nv + (j % nv); };
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j)
    {
      m.faces.emplace_back (id (i, j), id (i + 1, j), id (i + 1, j + 1));
      m.faces.emplace_back (id (i, j), id (i + 1, j + 1), id (i, j + 1));
    }
  return m;
}

TriangleMesh
makeBox (const Eigen::Vector3f& size, int grid)
{
  return boxMesh (size, grid);
}

TriangleMesh
makeParallelSheets (float size, float gap, int grid)
{
  const Eigen::Vector3f X (size, 0, 0), Y (0, size, 0);
  TriangleMesh m = gridPatch (Eigen::Vector3f (-size / 2, -size / 2, gap / 2), X, Y, grid);  // +z
  m.append (gridPatch (Eigen::Vector3f (-size / 2, -size / 2, -gap / 2), Y, X, grid));        // -z
  return m;
}

TriangleMesh
makeThinPlate (float size, float thickness, int grid)
{
  return boxMesh (Eigen::Vector3f (size, size, thickness), grid);
}

TriangleMesh
makeFinsScene (int slab_grid, int part_grid)
{
  TriangleMesh scene = makeBox (Eigen::Vector3f (2.4f, 2.f, 0.2f), slab_grid);
  scene.transform (Eigen::Affine3f (Eigen::Translation3f (0, 0, -0.1f)));
  auto add = [&scene, part_grid] (const Eigen::Vector3f& size, const Eigen::Vector3f& at) {
    TriangleMesh b = makeBox (size, part_grid);
    b.transform (Eigen::Affine3f (Eigen::Translation3f (at)));
    scene.append (b);
  };
  for (int i = 0; i < 5; ++i)  // fins 0.04 thick, slots 0.2 wide and 1.0 deep
    add (Eigen::Vector3f (0.04f, 1.8f, 1.05f), Eigen::Vector3f (-1.05f + 0.24f * i, 0.f, 0.475f));
  const float wall = 0.04f, side = 0.7f, height = 0.9f, cx = 0.65f;  // the cup
  add (Eigen::Vector3f (side, wall, height), Eigen::Vector3f (cx, -side / 2, 0.4f));
  add (Eigen::Vector3f (side, wall, height), Eigen::Vector3f (cx, side / 2, 0.4f));
  add (Eigen::Vector3f (wall, side, height), Eigen::Vector3f (cx - side / 2, 0.f, 0.4f));
  add (Eigen::Vector3f (wall, side, height), Eigen::Vector3f (cx + side / 2, 0.f, 0.4f));
  return scene;
}

}  // namespace testing
}  // namespace pclx
