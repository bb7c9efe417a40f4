// Tests of the ground truth: Embree visibility and ray casting, depth rendering,
// CGAL point-to-mesh distance, PLY round trip through PCL.
#include <pclx/testing/depth_renderer.h>
#include <pclx/testing/mesh_distance.h>
#include <pclx/testing/mesh_sampling.h>
#include <pclx/testing/shapes.h>

#include <pcl/io/ply_io.h>

#include <gtest/gtest.h>

#include <cstdio>
#include <random>

using namespace pclx::testing;

TEST (RayCaster, RayHitsSphereAtAnalyticDistance)
{
  const RayCaster rc (makeSphere (1.f, 5));
  int face = -1;
  const float t = rc.cast (Eigen::Vector3f (0, 0, 5), Eigen::Vector3f (0, 0, -1), &face);
  EXPECT_NEAR (t, 4.f, 1e-3f);
  EXPECT_GE (face, 0);
  EXPECT_TRUE (std::isinf (rc.cast (Eigen::Vector3f (0, 0, 5), Eigen::Vector3f (0, 0, 1), &face)));
  EXPECT_EQ (face, -1);
  EXPECT_THROW (RayCaster{TriangleMesh{}}, std::invalid_argument);
}

TEST (RayCaster, AboutHalfOfAConvexShapeIsVisibleFromFarAway)
{
  const TriangleMesh m = makeSphere (1.f, 5);
  const RayCaster rc (m);
  const SampledCloud s = sampleUniform (m, 20000, 2);
  const Eigen::Vector3f C (0, 0, 1000);
  const std::vector<bool> vis = rc.visibleFrom (s.cloud, C);
  std::size_t n_vis = 0, wrong = 0;
  for (std::size_t i = 0; i < vis.size (); ++i)
  {
    n_vis += vis[i];
    // Exact answer for a sphere: visible iff (p − 0)·(C − p) > 0. Allow the facet sag band.
    const Eigen::Vector3f p = s.cloud[i].getVector3fMap ();
    const float facing = p.normalized ().dot ((C - p).normalized ());
    if (std::abs (facing) > 0.02f)
      wrong += (facing > 0) != vis[i];
  }
  EXPECT_NEAR (double (n_vis) / vis.size (), 0.5, 0.02);
  EXPECT_EQ (wrong, 0u);
  // From close by, a smaller cap is visible: 1 − 1/d of the half for a unit sphere at distance d.
  const std::vector<bool> near = rc.visibleFrom (s.cloud, Eigen::Vector3f (0, 0, 2));
  const double frac = std::count (near.begin (), near.end (), true) / double (near.size ());
  EXPECT_NEAR (frac, 0.5 * (1 - 1 / 2.0), 0.02);
}

TEST (RayCaster, OccluderHidesPointsBehindIt)
{
  TriangleMesh scene = makeBox (Eigen::Vector3f (2, 2, 0.1f), 2);  // a slab at z = 0
  TriangleMesh ball = makeSphere (0.2f, 3, Eigen::Vector3f (0, 0, 1));
  scene.append (ball);
  const RayCaster rc (scene);
  pcl::PointCloud<pcl::PointXYZ> pts;
  pts.push_back ({0.f, 0.f, 0.05f});   // slab top, directly under the ball: hidden
  pts.push_back ({0.8f, 0.f, 0.05f});  // slab top, clear line of sight: visible
  pts.push_back ({0.f, 0.f, 1.2f});    // ball top: visible
  pts.push_back ({0.f, 0.f, 0.8f});    // ball bottom, seen from above: hidden
  const auto vis = rc.visibleFrom (pts, Eigen::Vector3f (0, 0, 10));
  EXPECT_EQ (vis, (std::vector<bool>{false, true, true, false}));
}

TEST (DepthRenderer, DepthEqualsRayCastAndAnalyticDepth)
{
  // A wall facing the camera at z = 2 and a sphere in front of it.
  TriangleMesh scene;
  Eigen::Vector3f size (10, 10, 0.01f);
  TriangleMesh wall = makeBox (size, 2);
  wall.transform (Eigen::Affine3f (Eigen::Translation3f (0, 0, 2.005f)));
  scene.append (wall);
  scene.append (makeSphere (0.3f, 5, Eigen::Vector3f (0, 0, 1.f)));
  const RayCaster rc (scene);
  PinholeIntrinsics K;
  K.width = 64;
  K.height = 48;
  K.fx = K.fy = 50.f;
  K.cx = 31.5f;
  K.cy = 23.5f;
  KinectNoise exact;
  exact.enabled = false;
  const DepthImage img = renderDepth (rc, K, Eigen::Isometry3f::Identity (), exact);
  ASSERT_EQ (img.depth_mm.size (), 64u * 48u);
  EXPECT_EQ (img.at (0, 0), 2000);  // wall corner
  // Centre pixels see the sphere front at z = 0.7.
  EXPECT_NEAR (img.at (31, 23), 700, 2);
  for (int v = 0; v < K.height; v += 5)
    for (int u = 0; u < K.width; u += 5)
    {
      const Eigen::Vector3f d ((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.f);
      EXPECT_NEAR (img.at (u, v), std::round (1000 * rc.cast (Eigen::Vector3f::Zero (), d)), 1);
    }
  // Back-projection lands on the surface: every pixel's point is on the wall or the sphere.
  const auto cloud = depthToCloud (img, K);
  EXPECT_TRUE (cloud.isOrganized ());
  const MeshDistance dist (scene);
  for (const auto& p : cloud)
    EXPECT_LT (dist.distance (p.getVector3fMap ()), 2e-3);

  // Kinect noise: sigma at 2 m is 0.0012 + 0.0019·1.6² ≈ 6.1 mm.
  KinectNoise kinect;
  kinect.dropout = 0.1f;
  const DepthImage noisy = renderDepth (rc, K, Eigen::Isometry3f::Identity (), kinect, 5);
  double sum2 = 0;
  int n = 0, dropped = 0;
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u)
      if (img.at (u, v) == 2000)
      {
        if (noisy.at (u, v) == 0)
          ++dropped;
        else
        {
          sum2 += std::pow (noisy.at (u, v) - 2000.0, 2);
          ++n;
        }
      }
  EXPECT_NEAR (std::sqrt (sum2 / n), 6.1, 1.2);
  EXPECT_NEAR (double (dropped) / (n + dropped), 0.1, 0.04);
}

TEST (DepthRenderer, PosedCameraAndGrazingDropout)
{
  const TriangleMesh sphere = makeSphere (0.5f, 5);
  const RayCaster rc (sphere);
  PinholeIntrinsics K;
  K.width = 80;
  K.height = 60;
  K.fx = K.fy = 60.f;
  K.cx = 39.5f;
  K.cy = 29.5f;
  const Eigen::Isometry3f pose = lookAt (Eigen::Vector3f (3, 0, 0), Eigen::Vector3f::Zero ());
  KinectNoise exact;
  exact.enabled = false;
  const DepthImage img = renderDepth (rc, K, pose, exact);
  // The principal ray hits the sphere at distance 2.5.
  EXPECT_NEAR (img.at (40, 30), 2500, 5);
  const auto world = depthToCloud (img, K, pose);
  for (const auto& p : world)
    if (std::isfinite (p.x))
      EXPECT_NEAR (p.getVector3fMap ().norm (), 0.5f, 3e-3f);
  // Grazing dropout only removes silhouette pixels.
  KinectNoise grazing;
  grazing.dropout = 0.f;
  grazing.a = grazing.b = 0.f;
  grazing.grazing_deg = 60.f;
  const DepthImage g = renderDepth (rc, K, pose, grazing);
  int lost = 0, kept = 0;
  for (std::size_t i = 0; i < g.depth_mm.size (); ++i)
    if (img.depth_mm[i])
      (g.depth_mm[i] ? kept : lost)++;
  EXPECT_GT (lost, 0);
  EXPECT_GT (kept, lost);
  EXPECT_NE (g.at (40, 30), 0);
  EXPECT_THROW (renderDepth (rc, PinholeIntrinsics{0, 0, 1, 1, 0, 0}, pose), std::invalid_argument);
}

TEST (MeshDistance, PointToMeshDistanceMatchesAnalytic)
{
  const MeshDistance d (makeBox (Eigen::Vector3f (2, 2, 2), 2));
  EXPECT_NEAR (d.distance (Eigen::Vector3f (0, 0, 3)), 2.0, 1e-6);
  EXPECT_NEAR (d.distance (Eigen::Vector3f (0, 0, 0)), 1.0, 1e-6);
  EXPECT_NEAR (d.distance (Eigen::Vector3f (2, 2, 2)), std::sqrt (3.0), 1e-6);
  EXPECT_TRUE (d.closestPoint (Eigen::Vector3f (0.2f, 0.3f, 5)).isApprox (Eigen::Vector3f (0.2f, 0.3f, 1)));
  EXPECT_THROW (MeshDistance{TriangleMesh{}}, std::invalid_argument);
}

TEST (MeshIO, PlyRoundTripThroughPcl)
{
  const TriangleMesh m = makeTorus (1.f, 0.3f, 16, 8);
  const std::string path = ::testing::TempDir () + "pclx_torus.ply";
  ASSERT_EQ (pcl::io::savePLYFileBinary (path, toPolygonMesh (m)), 0);
  const TriangleMesh back = loadPlyMesh (path);
  ASSERT_EQ (back.vertices.size (), m.vertices.size ());
  ASSERT_EQ (back.faces.size (), m.faces.size ());
  EXPECT_EQ (back.faces[5], m.faces[5]);
  EXPECT_TRUE (back.vertices[7].isApprox (m.vertices[7]));
  std::remove (path.c_str ());
  EXPECT_THROW (loadPlyMesh (::testing::TempDir () + "does_not_exist.ply"), std::runtime_error);
}
