#include <pclx/testing/ray_caster.h>

#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace pclx {
namespace testing {

struct RayCaster::Impl
{
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  std::vector<Eigen::Vector3f> normals;
  float diagonal = 0.f;
};

RayCaster::RayCaster (const TriangleMesh& mesh) : impl_ (new Impl)
{
  if (mesh.faces.empty ())
    throw std::invalid_argument ("RayCaster: mesh has no faces");
  impl_->device = rtcNewDevice (nullptr);
  if (!impl_->device)
    throw std::runtime_error ("RayCaster: rtcNewDevice failed (error " +
                              std::to_string (rtcGetDeviceError (nullptr)) + ")");
  impl_->scene = rtcNewScene (impl_->device);
  rtcSetSceneFlags (impl_->scene, RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality (impl_->scene, RTC_BUILD_QUALITY_HIGH);
  RTCGeometry geom = rtcNewGeometry (impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* v = static_cast<float*> (rtcSetNewGeometryBuffer (geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                         3 * sizeof (float), mesh.vertices.size ()));
  for (std::size_t i = 0; i < mesh.vertices.size (); ++i)
    for (int k = 0; k < 3; ++k)
      v[3 * i + k] = mesh.vertices[i][k];
  auto* idx = static_cast<unsigned*> (rtcSetNewGeometryBuffer (geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                              3 * sizeof (unsigned), mesh.faces.size ()));
  for (std::size_t f = 0; f < mesh.faces.size (); ++f)
    for (int k = 0; k < 3; ++k)
      idx[3 * f + k] = static_cast<unsigned> (mesh.faces[f][k]);
  rtcCommitGeometry (geom);
  rtcAttachGeometry (impl_->scene, geom);
  rtcReleaseGeometry (geom);
  rtcCommitScene (impl_->scene);
  impl_->diagonal = mesh.diagonal ();
  impl_->normals.reserve (mesh.faces.size ());
  for (std::size_t f = 0; f < mesh.faces.size (); ++f)
    impl_->normals.push_back (mesh.faceNormal (f));
}

const Eigen::Vector3f&
RayCaster::faceNormal (int face) const
{
  return impl_->normals.at (static_cast<std::size_t> (face));
}

RayCaster::~RayCaster ()
{
  if (impl_->scene)
    rtcReleaseScene (impl_->scene);
  if (impl_->device)
    rtcReleaseDevice (impl_->device);
}

float
RayCaster::cast (const Eigen::Vector3f& origin, const Eigen::Vector3f& dir, int* face) const
{
  RTCIntersectContext context;
  rtcInitIntersectContext (&context);
  RTCRayHit rh;
  rh.ray.org_x = origin.x ();
  rh.ray.org_y = origin.y ();
  rh.ray.org_z = origin.z ();
  rh.ray.dir_x = dir.x ();
  rh.ray.dir_y = dir.y ();
  rh.ray.dir_z = dir.z ();
  rh.ray.tnear = 0.f;
  rh.ray.tfar = std::numeric_limits<float>::infinity ();
  rh.ray.mask = static_cast<unsigned> (-1);
  rh.ray.flags = 0;
  rh.ray.time = 0.f;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1 (impl_->scene, &context, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID)
  {
    if (face)
      *face = -1;
    return std::numeric_limits<float>::infinity ();
  }
  if (face)
    *face = static_cast<int> (rh.hit.primID);
  return rh.ray.tfar;
}

bool
RayCaster::occluded (const Eigen::Vector3f& viewpoint, const Eigen::Vector3f& p, float abs_tol) const
{
  // The segment is cast back from near the point, not from the viewpoint: from a far
  // viewpoint (1000 x the diagonal) float hit distances along the whole ray are too coarse
  // for the tolerance, and every method scored ~0.07 F1 lower against that truth. Every
  // occluder lies within one diagonal of p (it is on the mesh), so the last 2 diagonals of
  // the segment decide the same; p - C is formed in double.
  const Eigen::Vector3d d = p.cast<double> () - viewpoint.cast<double> ();
  const double len = d.norm ();
  if (!(len > abs_tol))
    return false;
  const double L = std::min (len, 2.0 * double (impl_->diagonal));
  const Eigen::Vector3f origin =
      L < len ? Eigen::Vector3f ((p.cast<double> () - d * (L / len)).cast<float> ()) : viewpoint;
  const Eigen::Vector3f dir = p - origin;
  const float dir_len = dir.norm ();
  if (!(dir_len > abs_tol))
    return false;
  RTCIntersectContext context;
  rtcInitIntersectContext (&context);
  RTCRay ray;
  ray.org_x = origin.x ();
  ray.org_y = origin.y ();
  ray.org_z = origin.z ();
  ray.dir_x = dir.x ();
  ray.dir_y = dir.y ();
  ray.dir_z = dir.z ();
  ray.tnear = 0.f;
  ray.tfar = 1.f - abs_tol / dir_len;  // stop just before the point's own surface
  ray.mask = static_cast<unsigned> (-1);
  ray.flags = 0;
  ray.time = 0.f;
  rtcOccluded1 (impl_->scene, &context, &ray);
  return ray.tfar < 0.f;  // Embree sets tfar = -inf on a hit
}

template <typename PointT> std::vector<bool>
RayCaster::visibleFrom (const pcl::PointCloud<PointT>& cloud, const Eigen::Vector3f& viewpoint,
                        float tol) const
{
  const float abs_tol = tol * impl_->diagonal;
  std::vector<char> vis (cloud.size (), 0);
  const std::ptrdiff_t n = static_cast<std::ptrdiff_t> (cloud.size ());
#pragma omp parallel for schedule(dynamic, 4096)
  for (std::ptrdiff_t i = 0; i < n; ++i)
  {
    const Eigen::Vector3f p = cloud[i].getVector3fMap ();
    vis[i] = p.allFinite () && !occluded (viewpoint, p, abs_tol);
  }
  return std::vector<bool> (vis.begin (), vis.end ());
}

template std::vector<bool> RayCaster::visibleFrom (const pcl::PointCloud<pcl::PointXYZ>&,
                                                   const Eigen::Vector3f&, float) const;
template std::vector<bool> RayCaster::visibleFrom (const pcl::PointCloud<pcl::PointNormal>&,
                                                   const Eigen::Vector3f&, float) const;

}  // namespace testing
}  // namespace pclx
