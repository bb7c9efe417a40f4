#include "bench_rbf_metrics.h"

#include <pclx/testing/mesh_sampling.h>

#include <pcl/conversions.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <unordered_map>

namespace rbf_bench {

using pclx::testing::TriangleMesh;

namespace {

struct KeyHash
{
  std::size_t operator() (const Eigen::Vector3i& k) const
  {
    return std::size_t (k[0]) * 73856093u ^ std::size_t (k[1]) * 19349663u ^ std::size_t (k[2]) * 83492791u;
  }
};
struct KeyEq
{
  bool operator() (const Eigen::Vector3i& a, const Eigen::Vector3i& b) const { return a == b; }
};

int
findRoot (std::vector<int>& parent, int i)
{
  while (parent[i] != i)
  {
    parent[i] = parent[parent[i]];
    i = parent[i];
  }
  return i;
}

// Each edge (as a sorted vertex pair) and how many triangles use it.
std::vector<std::pair<std::uint64_t, int>>
edgeUses (const TriangleMesh& mesh)
{
  std::vector<std::uint64_t> edges;
  edges.reserve (3 * mesh.faces.size ());
  for (const auto& f : mesh.faces)
    for (int k = 0; k < 3; ++k)
    {
      const std::uint32_t a = std::uint32_t (f[k]), b = std::uint32_t (f[(k + 1) % 3]);
      edges.push_back ((std::uint64_t (std::min (a, b)) << 32) | std::max (a, b));
    }
  std::sort (edges.begin (), edges.end ());
  std::vector<std::pair<std::uint64_t, int>> uses;
  for (std::size_t i = 0; i < edges.size ();)
  {
    std::size_t j = i;
    while (j < edges.size () && edges[j] == edges[i])
      ++j;
    uses.emplace_back (edges[i], int (j - i));
    i = j;
  }
  return uses;
}

}  // namespace

TriangleMesh
weld (const std::vector<Eigen::Vector3f>& vertices, const std::vector<Eigen::Vector3i>& faces, float tol)
{
  // Quantised positions: vertices computed twice on the same grid edge land in one bucket
  // (a rounding boundary between two copies is rare and shows up as a boundary edge).
  std::unordered_map<Eigen::Vector3i, int, KeyHash, KeyEq> ids;
  std::vector<int> remap (vertices.size (), -1);
  TriangleMesh out;
  for (std::size_t i = 0; i < vertices.size (); ++i)
  {
    const Eigen::Vector3f& v = vertices[i];
    if (!v.allFinite ())
      continue;
    const Eigen::Vector3i key ((v / tol).array ().round ().cast<int> ());
    const auto it = ids.emplace (key, int (out.vertices.size ()));
    if (it.second)
      out.vertices.push_back (v);
    remap[i] = it.first->second;
  }
  out.faces.reserve (faces.size ());
  for (const auto& f : faces)
  {
    if (f.minCoeff () < 0 || std::size_t (f.maxCoeff ()) >= vertices.size ())
      continue;
    const Eigen::Vector3i g (remap[f[0]], remap[f[1]], remap[f[2]]);
    if (g.minCoeff () < 0 || g[0] == g[1] || g[1] == g[2] || g[0] == g[2])
      continue;
    out.faces.push_back (g);
  }
  return out;
}

TriangleMesh
weld (const pcl::PolygonMesh& mesh, float tol)
{
  pcl::PointCloud<pcl::PointXYZ> cloud;
  pcl::fromPCLPointCloud2 (mesh.cloud, cloud);
  std::vector<Eigen::Vector3f> v (cloud.size ());
  for (std::size_t i = 0; i < cloud.size (); ++i)
    v[i] = cloud[i].getVector3fMap ();
  std::vector<Eigen::Vector3i> f;
  f.reserve (mesh.polygons.size ());
  for (const auto& p : mesh.polygons)
    for (std::size_t k = 2; k < p.vertices.size (); ++k)  // fan-triangulate polygons
      f.emplace_back (int (p.vertices[0]), int (p.vertices[k - 1]), int (p.vertices[k]));
  return weld (v, f, tol);
}

Topology
topology (const TriangleMesh& mesh)
{
  Topology t;
  t.triangles = mesh.faces.size ();
  std::vector<char> used (mesh.vertices.size (), 0);
  std::vector<int> parent (mesh.vertices.size ());
  std::iota (parent.begin (), parent.end (), 0);
  for (const auto& f : mesh.faces)
    for (int k = 0; k < 3; ++k)
    {
      const int a = f[k], b = f[(k + 1) % 3];
      used[a] = 1;
      const int ra = findRoot (parent, a), rb = findRoot (parent, b);
      if (ra != rb)
        parent[ra] = rb;
    }
  const auto uses = edgeUses (mesh);
  for (const auto& [key, n] : uses)
    if (n == 1)
      ++t.boundary_edges;
    else if (n > 2)
      ++t.nonmanifold_edges;
  for (std::size_t v = 0; v < used.size (); ++v)
    if (used[v])
    {
      ++t.vertices;
      if (findRoot (parent, int (v)) == int (v))
        ++t.components;
    }
  t.euler = long (t.vertices) - long (uses.size ()) + long (t.triangles);
  return t;
}

std::vector<Eigen::Vector3f>
boundaryPoints (const TriangleMesh& mesh, double step)
{
  std::vector<Eigen::Vector3f> points;
  for (const auto& [key, n] : edgeUses (mesh))
    if (n == 1)
    {
      const Eigen::Vector3f& a = mesh.vertices[key >> 32];
      const Eigen::Vector3f& b = mesh.vertices[key & 0xFFFFFFFFu];
      const int pieces = std::max (1, int (std::ceil ((b - a).norm () / step)));
      for (int k = 0; k < pieces; ++k)
        points.push_back (a + (b - a) * ((float (k) + 0.5f) / float (pieces)));
    }
  return points;
}

OpenEdgesAtHoles
openEdgesAtHoles (const TriangleMesh& mesh, const std::vector<Eigen::Vector3f>& truth_boundary, double radius)
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr near (new pcl::PointCloud<pcl::PointXYZ>);
  for (const auto& p : truth_boundary)
    near->push_back (pcl::PointXYZ (p.x (), p.y (), p.z ()));
  pcl::KdTreeFLANN<pcl::PointXYZ> tree;
  if (!near->empty ())
    tree.setInputCloud (near);
  pcl::Indices idx (1);
  std::vector<float> d2 (1);
  OpenEdgesAtHoles r;
  for (const auto& [key, n] : edgeUses (mesh))
    if (n == 1)
    {
      const Eigen::Vector3f m = 0.5f * (mesh.vertices[key >> 32] + mesh.vertices[key & 0xFFFFFFFFu]);
      const double d = near->empty () || tree.nearestKSearch (pcl::PointXYZ (m.x (), m.y (), m.z ()), 1, idx, d2) != 1
                           ? HUGE_VAL
                           : std::sqrt (double (d2[0]));
      r.max_distance = std::max (r.max_distance, d);
      r.away += d > radius;
    }
  return r;
}

double
medianEdgeLength (const TriangleMesh& mesh)
{
  std::vector<float> len;
  len.reserve (3 * mesh.faces.size ());
  for (const auto& f : mesh.faces)
    for (int k = 0; k < 3; ++k)
      len.push_back ((mesh.vertices[f[k]] - mesh.vertices[f[(k + 1) % 3]]).norm ());
  if (len.empty ())
    return 0;
  std::nth_element (len.begin (), len.begin () + len.size () / 2, len.end ());
  return len[len.size () / 2];
}

Error
meshError (const TriangleMesh& output, const pclx::testing::MeshDistance& truth,
           const std::vector<Eigen::Vector3f>& truth_samples, std::size_t samples, double far)
{
  Error e;
  const auto out_samples = pclx::testing::sampleUniform (output, samples, 7);
  double sum = 0;
  std::size_t far_count = 0;
  for (const auto& p : out_samples.cloud)
  {
    const double d = truth.distance (p.getVector3fMap ());
    sum += d;
    far_count += d > far;
    e.out_to_truth_max = std::max (e.out_to_truth_max, d);
  }
  e.out_to_truth_mean = sum / std::max<std::size_t> (1, out_samples.cloud.size ());
  e.far_share = double (far_count) / double (std::max<std::size_t> (1, out_samples.cloud.size ()));
  const pclx::testing::MeshDistance to_output (output);
  sum = 0;
  for (const auto& p : truth_samples)
  {
    const double d = to_output.distance (p);
    sum += d;
    e.truth_to_out_max = std::max (e.truth_to_out_max, d);
  }
  e.truth_to_out_mean = sum / std::max<std::size_t> (1, truth_samples.size ());
  return e;
}

void
trimLowDensity (std::vector<Eigen::Vector3f>& vertices, std::vector<Eigen::Vector3i>& faces,
                const std::vector<double>& density, double q)
{
  if (density.size () != vertices.size () || vertices.empty ())
    return;
  std::vector<double> sorted (density);
  const std::size_t k = std::min (sorted.size () - 1, std::size_t (q * double (sorted.size ())));
  std::nth_element (sorted.begin (), sorted.begin () + long (k), sorted.end ());
  const double cut = sorted[k];
  std::vector<int> remap (vertices.size (), -1);
  std::vector<Eigen::Vector3f> kept;
  for (std::size_t i = 0; i < vertices.size (); ++i)
    if (density[i] >= cut)
    {
      remap[i] = int (kept.size ());
      kept.push_back (vertices[i]);
    }
  std::vector<Eigen::Vector3i> kept_faces;
  for (const auto& f : faces)
  {
    const Eigen::Vector3i g (remap[f[0]], remap[f[1]], remap[f[2]]);
    if (g.minCoeff () >= 0)
      kept_faces.push_back (g);
  }
  vertices.swap (kept);
  faces.swap (kept_faces);
}

}  // namespace rbf_bench
