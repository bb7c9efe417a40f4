#include <pclx/testing/mesh_sampling.h>

#include <pcl/common/io.h>

#include <algorithm>
#include <numeric>
#include <random>
#include <stdexcept>

namespace pclx {
namespace testing {

namespace {

pcl::PointNormal
makePoint (const Eigen::Vector3f& p, const Eigen::Vector3f& n)
{
  pcl::PointNormal q;
  q.getVector3fMap () = p;
  q.getNormalVector3fMap () = n;
  q.curvature = 0.f;
  return q;
}

// Draws one point uniformly on face f (Turk's square-root barycentric trick).
Eigen::Vector3f
samplePointOnFace (const TriangleMesh& mesh, std::size_t f, std::mt19937& rng)
{
  std::uniform_real_distribution<float> U (0.f, 1.f);
  const float r1 = std::sqrt (U (rng)), r2 = U (rng);
  const Eigen::Vector3i& t = mesh.faces[f];
  return (1 - r1) * mesh.vertices[t[0]] + r1 * (1 - r2) * mesh.vertices[t[1]] +
         r1 * r2 * mesh.vertices[t[2]];
}

}  // namespace

SampledCloud
sampleUniform (const TriangleMesh& mesh, std::size_t n, std::uint32_t seed)
{
  return sampleDensityGradient (mesh, n, 0, 1.f, seed);
}

SampledCloud
sampleDensityGradient (const TriangleMesh& mesh, std::size_t n, int axis, float min_ratio,
                       std::uint32_t seed)
{
  if (mesh.faces.empty ())
    throw std::invalid_argument ("sample: mesh has no faces");
  if (axis < 0 || axis > 2 || !(min_ratio > 0.f && min_ratio <= 1.f))
    throw std::invalid_argument ("sampleDensityGradient: axis must be 0..2 and 0 < min_ratio <= 1");
  std::vector<double> cdf (mesh.faces.size ());
  double acc = 0;
  for (std::size_t f = 0; f < mesh.faces.size (); ++f)
    cdf[f] = (acc += mesh.faceArea (f));
  const float lo = mesh.bboxMin ()[axis], hi = mesh.bboxMax ()[axis];
  const float extent = std::max (hi - lo, 1e-12f);

  std::mt19937 rng (seed);
  std::uniform_real_distribution<double> U (0.0, acc);
  std::uniform_real_distribution<float> U01 (0.f, 1.f);
  SampledCloud s;
  s.cloud.reserve (n);
  s.face.reserve (n);
  while (s.cloud.size () < n)
  {
    const std::size_t f = std::min<std::size_t> (
        std::lower_bound (cdf.begin (), cdf.end (), U (rng)) - cdf.begin (), cdf.size () - 1);
    const Eigen::Vector3f p = samplePointOnFace (mesh, f, rng);
    // Rejection sampling: acceptance falls linearly from 1 to min_ratio along the axis.
    const float density = 1.f - (1.f - min_ratio) * (p[axis] - lo) / extent;
    if (min_ratio < 1.f && U01 (rng) > density)
      continue;
    s.cloud.push_back (makePoint (p, mesh.faceNormal (f)));
    s.face.push_back (static_cast<int> (f));
  }
  return s;
}

pcl::PointCloud<pcl::PointXYZ>::Ptr
positions (const pcl::PointCloud<pcl::PointNormal>& cloud)
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr out (new pcl::PointCloud<pcl::PointXYZ>);
  pcl::copyPointCloud (cloud, *out);
  return out;
}

SampledCloud
meshVertices (const TriangleMesh& mesh)
{
  std::vector<Eigen::Vector3f> normals (mesh.vertices.size (), Eigen::Vector3f::Zero ());
  std::vector<int> face_of (mesh.vertices.size (), -1);
  for (std::size_t f = 0; f < mesh.faces.size (); ++f)
  {
    const Eigen::Vector3f an = mesh.faceNormal (f) * mesh.faceArea (f);
    for (int k = 0; k < 3; ++k)
    {
      normals[mesh.faces[f][k]] += an;
      face_of[mesh.faces[f][k]] = static_cast<int> (f);
    }
  }
  SampledCloud s;
  for (std::size_t i = 0; i < mesh.vertices.size (); ++i)
  {
    s.cloud.push_back (makePoint (mesh.vertices[i], normals[i].normalized ()));
    s.face.push_back (face_of[i]);
  }
  return s;
}

}  // namespace testing
}  // namespace pclx
