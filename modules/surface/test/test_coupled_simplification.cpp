// CoupledSimplification (da Paz 2017, §3.2–3.3): the connected cloud, frustum clustering and the
// coupled edge collapse on generated depth frames; orientation, discontinuities, bad input.
#include <pclx/surface/coupled_simplification.h>
#include <pclx/testing/depth_renderer.h>
#include <pclx/testing/shapes.h>

#include <gtest/gtest.h>

#include <omp.h>

#include <cmath>
#include <limits>
#include <map>
#include <random>

namespace {

using pcl::DepthIntrinsics;
using pcl::FrameMesh;
using Simplifier = pcl::CoupledSimplification;

const DepthIntrinsics kK{525.f, 525.f, 319.5f, 239.5f};
constexpr int kW = 640, kH = 480;

// Depth of the plane n·x = d seen by the pinhole camera at the origin (0 = miss).
std::vector<float>
planeDepth (const Eigen::Vector3f& n, float d)
{
  std::vector<float> depth (static_cast<std::size_t> (kW) * kH, 0.f);
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < kW; ++u)
    {
      const Eigen::Vector3f ray ((u - kK.cx) / kK.fx, (v - kK.cy) / kK.fy, 1.f);
      const float z = d / n.dot (ray);
      if (z > 0)
        depth[static_cast<std::size_t> (v) * kW + u] = z;
    }
  return depth;
}

std::vector<float>
toMetres (const pclx::testing::DepthImage& img)
{
  std::vector<float> d (img.depth_mm.size ());
  for (std::size_t i = 0; i < d.size (); ++i)
    d[i] = img.depth_mm[i] * 0.001f;
  return d;
}

double
evalQuadric (const Simplifier::Quadric& q, const Eigen::Vector3d& x)
{
  Eigen::Matrix4d Q;
  Q << q[0], q[1], q[2], q[3], q[1], q[4], q[5], q[6], q[2], q[5], q[7], q[8], q[3], q[6], q[8], q[9];
  const Eigen::Vector4d h (x[0], x[1], x[2], 1);
  return h.dot (Q * h);
}

Eigen::Vector3f
faceNormal (const FrameMesh& m, std::size_t f)
{
  const auto& t = m.triangles[f];
  return (m.vertices[t[1]] - m.vertices[t[0]]).cross (m.vertices[t[2]] - m.vertices[t[0]]);
}

// Undirected edge → number of faces; > 2 is non-manifold.
std::map<std::pair<int, int>, int>
edgeUse (const FrameMesh& m)
{
  std::map<std::pair<int, int>, int> e;
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k)
      ++e[{std::min (t[k], t[(k + 1) % 3]), std::max (t[k], t[(k + 1) % 3])}];
  return e;
}

Eigen::Matrix4d
pose (const Eigen::Isometry3f& iso)
{
  return iso.matrix ().cast<double> ();
}

}  // namespace

TEST (CoupledSimplification, DenseConnectedCloudOfAFullPlaneIsTheGrid)
{
  const auto depth = planeDepth (Eigen::Vector3f (0, 0, 1), 1.5f);
  Simplifier s;
  FrameMesh dense;
  ASSERT_TRUE (s.computeConnectedCloud (depth.data (), kW, kH, kK, Eigen::Matrix4d::Identity (), dense));
  EXPECT_EQ (dense.vertices.size (), std::size_t (kW * kH));
  EXPECT_EQ (dense.triangles.size (), std::size_t (2 * (kW - 1) * (kH - 1)));
  ASSERT_EQ (dense.quadrics.size (), dense.vertices.size ());
  // Area-weighted quadrics: Σ trace / 3 = the dense area (each face counted at 3 corners).
  double w = 0, area = 0;
  for (const auto& q : dense.quadrics)
    w += q[0] + q[4] + q[7];
  for (std::size_t f = 0; f < dense.triangles.size (); ++f)
    area += 0.5 * faceNormal (dense, f).norm ();
  EXPECT_NEAR (w / 3, area, 1e-3 * area);
  EXPECT_TRUE (std::isfinite (dense.viewpoint[0]));
}

TEST (CoupledSimplification, PlaneCollapsesToFewTrianglesAtZeroError)
{
  // A tilted plane 1–2 m away filling the frame.
  const Eigen::Vector3f n = Eigen::Vector3f (0.3f, -0.2f, 1.f).normalized ();
  const float d = 1.4f;
  const auto depth = planeDepth (n, d);
  Simplifier s;
  s.setCollapseTargetRatio (0);
  s.setCollapseMaxError (1e-4);
  FrameMesh m;
  ASSERT_TRUE (s.compute (depth.data (), kW, kH, kK, Eigen::Matrix4d::Identity (), m));
  EXPECT_GT (s.getStats ().clustered_triangles, 5000u);
  EXPECT_LT (m.triangles.size (), 100u) << "clustered " << s.getStats ().clustered_triangles;
  for (const auto& v : m.vertices)
    EXPECT_NEAR (n.dot (v), d, 2e-4);
  // The quadrics carried to the output vanish on the plane.
  for (std::size_t i = 0; i < m.vertices.size (); ++i)
  {
    const double wq = m.quadrics[i][0] + m.quadrics[i][4] + m.quadrics[i][7];
    EXPECT_GT (wq, 0);
    EXPECT_LT (evalQuadric (m.quadrics[i], m.vertices[i].cast<double> ()) / wq, 1e-7);
  }
  // It still covers the frame: the area is close to the dense area.
  double area = 0;
  for (std::size_t f = 0; f < m.triangles.size (); ++f)
    area += 0.5 * faceNormal (m, f).norm ();
  FrameMesh dense;
  ASSERT_TRUE (s.computeConnectedCloud (depth.data (), kW, kH, kK, Eigen::Matrix4d::Identity (), dense));
  double dense_area = 0;
  for (std::size_t f = 0; f < dense.triangles.size (); ++f)
    dense_area += 0.5 * faceNormal (dense, f).norm ();
  // Clustering pulls the frame's border in by about half a cell (4 px of 640 × 480).
  EXPECT_NEAR (area, dense_area, 0.04 * dense_area);
}

TEST (CoupledSimplification, SphereStaysNearTheTruthAndFacesTheCamera)
{
  const Eigen::Vector3f c (0.2f, -0.1f, 0.3f);
  const float r = 0.5f;
  pclx::testing::RayCaster caster (pclx::testing::makeSphere (r, 5, c));
  const Eigen::Isometry3f cam = pclx::testing::lookAt (c + Eigen::Vector3f (1.2f, -1.0f, 0.6f), c);
  pclx::testing::PinholeIntrinsics PK;
  pclx::testing::KinectNoise noise;  // Kinect-like noise on
  const auto img = pclx::testing::renderDepth (caster, PK, cam, noise, 7);
  const auto depth = toMetres (img);
  Simplifier s;
  FrameMesh m;
  ASSERT_TRUE (s.compute (depth.data (), PK.width, PK.height, kK, pose (cam), m));
  ASSERT_GT (m.triangles.size (), 50u);
  // The full connected cloud has about two triangles per valid pixel.
  EXPECT_LT (m.triangles.size (), 2 * s.getStats ().valid_pixels / 50);
  double max_d = 0, sum = 0;
  for (const auto& v : m.vertices)
  {
    const double dist = std::abs ((v - c).norm () - r);
    max_d = std::max (max_d, dist);
    sum += dist;
  }
  // Noise σ ≈ 3 mm at 1.7 m; the icosphere's chords add < 1 mm.
  EXPECT_LT (sum / m.vertices.size (), 0.004);
  EXPECT_LT (max_d, 0.03);
  // Orientation: face normals point out of the sphere, towards the camera.
  std::size_t out = 0;
  for (std::size_t f = 0; f < m.triangles.size (); ++f)
  {
    const Eigen::Vector3f& a = m.vertices[m.triangles[f][0]];
    out += faceNormal (m, f).dot (a - c) > 0;
    EXPECT_GT (faceNormal (m, f).dot (m.viewpoint - a), -1e-9) << "face " << f;
  }
  // A few silhouette slivers (noisy grazing pixels) may tilt inwards; 6 of 2993 here.
  EXPECT_GE (out, 0.995 * m.triangles.size ());
  EXPECT_NEAR ((m.viewpoint - cam.translation ()).norm (), 0, 1e-5);
  // Vertex clustering joins sheets at a few silhouette edges (2 % here); the collapse adds none.
  std::size_t nonmanifold = 0;
  const auto use = edgeUse (m);
  for (const auto& e : use)
    nonmanifold += e.second > 2;
  EXPECT_LT (nonmanifold, use.size () / 20);
}

TEST (CoupledSimplification, DepthDiscontinuitiesAreNotBridged)
{
  // A plate 1 m away in front of the left half of a wall 2 m away.
  auto depth = planeDepth (Eigen::Vector3f::UnitZ (), 2.f);
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < kW / 2; ++u)
      depth[static_cast<std::size_t> (v) * kW + u] = 1.f;
  Simplifier s;
  for (bool dense_only : {true, false})
  {
    FrameMesh m;
    ASSERT_TRUE (dense_only ? s.computeConnectedCloud (depth.data (), kW, kH, kK, Eigen::Matrix4d::Identity (), m)
                            : s.compute (depth.data (), kW, kH, kK, Eigen::Matrix4d::Identity (), m));
    ASSERT_GT (m.triangles.size (), 0u);
    for (const auto& t : m.triangles)
    {
      const float z0 = m.vertices[t[0]].z (), z1 = m.vertices[t[1]].z (), z2 = m.vertices[t[2]].z ();
      EXPECT_LT (std::max ({z0, z1, z2}) - std::min ({z0, z1, z2}), 0.1f) << (dense_only ? "dense" : "simplified");
    }
  }
  // An absolute threshold above the 1 m jump bridges it: the test above can fail.
  s.setEdgeThreshold (1.5);
  FrameMesh bridged;
  ASSERT_TRUE (s.computeConnectedCloud (depth.data (), kW, kH, kK, Eigen::Matrix4d::Identity (), bridged));
  bool any = false;
  for (const auto& t : bridged.triangles)
    any |= std::abs (bridged.vertices[t[0]].z () - bridged.vertices[t[1]].z ()) > 0.5f;
  EXPECT_TRUE (any);
}

TEST (CoupledSimplification, PosedFrameIsInWorldCoordinates)
{
  const auto depth = planeDepth (Eigen::Vector3f::UnitZ (), 1.f);
  Eigen::Isometry3f T = Eigen::Isometry3f::Identity ();
  T.rotate (Eigen::AngleAxisf (0.7f, Eigen::Vector3f (1, 2, 3).normalized ()));
  T.pretranslate (Eigen::Vector3f (3, -2, 1));
  Simplifier s;
  FrameMesh cam, world;
  ASSERT_TRUE (s.compute (depth.data (), kW, kH, kK, Eigen::Matrix4d::Identity (), cam));
  ASSERT_TRUE (s.compute (depth.data (), kW, kH, kK, pose (T), world));
  ASSERT_EQ (cam.vertices.size (), world.vertices.size ());
  for (std::size_t i = 0; i < cam.vertices.size (); ++i)
  {
    EXPECT_LT ((T * cam.vertices[i] - world.vertices[i]).norm (), 1e-4);
    // The world quadric evaluated at the world vertex equals the camera one at the camera vertex.
    const double wq = world.quadrics[i][0] + world.quadrics[i][4] + world.quadrics[i][7];
    EXPECT_NEAR (evalQuadric (world.quadrics[i], world.vertices[i].cast<double> ()) / wq, 0, 1e-7);
  }
  EXPECT_LT ((world.viewpoint - T.translation ()).norm (), 1e-6);
}

TEST (CoupledSimplification, MonotoneInTheErrorBound)
{
  pclx::testing::RayCaster caster (pclx::testing::makeTorus (0.5f, 0.2f));
  const Eigen::Isometry3f cam = pclx::testing::lookAt (Eigen::Vector3f (1.2f, 0.6f, 1.0f), Eigen::Vector3f::Zero ());
  pclx::testing::PinholeIntrinsics PK;
  pclx::testing::KinectNoise noise;
  noise.enabled = false;
  const auto depth = toMetres (pclx::testing::renderDepth (caster, PK, cam, noise));
  std::size_t prev = std::numeric_limits<std::size_t>::max ();
  for (double e : {0.0005, 0.002, 0.008})
  {
    Simplifier s;
    s.setCollapseTargetRatio (0);
    s.setCollapseMaxError (e);
    FrameMesh m;
    ASSERT_TRUE (s.compute (depth.data (), PK.width, PK.height, kK, pose (cam), m));
    EXPECT_LT (m.triangles.size (), prev) << "error bound " << e;
    prev = m.triangles.size ();
    EXPECT_LE (s.getStats ().max_error, e);
  }
}

// The connected cloud is built in row bands, one per thread, and the representatives and the
// first collapse candidates are computed in parallel: one and two threads give the same frame
// mesh, vertex for vertex (the cluster quadrics are summed in the same order, and the collapse
// queue's order is total).
TEST (CoupledSimplification, SameFrameMeshForAnyThreadCount)
{
  pclx::testing::RayCaster caster (pclx::testing::makeTorus (0.5f, 0.2f));
  const Eigen::Isometry3f cam = pclx::testing::lookAt (Eigen::Vector3f (1.2f, 0.6f, 1.0f), Eigen::Vector3f::Zero ());
  pclx::testing::PinholeIntrinsics PK;
  pclx::testing::KinectNoise noise;
  const auto depth = toMetres (pclx::testing::renderDepth (caster, PK, cam, noise, 3));
  const auto run = [&] (int threads) {
    const int saved = omp_get_max_threads ();
    omp_set_num_threads (threads);
    Simplifier s;
    s.setFrustumCellPixels (4);
    FrameMesh m;
    EXPECT_TRUE (s.compute (depth.data (), PK.width, PK.height, kK, pose (cam), m));
    omp_set_num_threads (saved);
    return m;
  };
  const FrameMesh one = run (1), two = run (2);
  ASSERT_GT (one.vertices.size (), 4096u) << "too few clusters for the parallel stages to run (kMinParallelItems)";
  ASSERT_EQ (one.vertices.size (), two.vertices.size ());
  ASSERT_EQ (one.triangles.size (), two.triangles.size ());
  for (std::size_t i = 0; i < one.vertices.size (); ++i)
    ASSERT_EQ (one.vertices[i], two.vertices[i]) << "vertex " << i;
  for (std::size_t i = 0; i < one.triangles.size (); ++i)
    ASSERT_EQ (one.triangles[i], two.triangles[i]) << "triangle " << i;
  for (std::size_t i = 0; i < one.quadrics.size (); ++i)
    ASSERT_EQ (one.quadrics[i], two.quadrics[i]) << "quadric " << i;
}

TEST (CoupledSimplification, CellSizeInMetresSetsThePixelBlock)
{
  // A wall 2 m away: 4 cm cells are 4 cm · 525 / 2 m ≈ 10.5 pixels (median range ≈ 2.1 m).
  const auto depth = planeDepth (Eigen::Vector3f::UnitZ (), 2.f);
  Simplifier s;
  s.setCollapseTargetRatio (1);  // clustering only
  FrameMesh fine, coarse;
  s.setFrustumCellSize (0.01);
  ASSERT_TRUE (s.compute (depth.data (), kW, kH, kK, Eigen::Matrix4d::Identity (), fine));
  const int b_fine = s.getStats ().cell_pixels;
  s.setFrustumCellSize (0.04);
  ASSERT_TRUE (s.compute (depth.data (), kW, kH, kK, Eigen::Matrix4d::Identity (), coarse));
  const int b_coarse = s.getStats ().cell_pixels;
  EXPECT_NEAR (b_coarse, 0.04 * 525 / s.getStats ().median_range, 1.0);
  EXPECT_GT (s.getStats ().median_range, 2.0);
  EXPECT_GT (b_coarse, 3 * b_fine);
  EXPECT_GT (fine.triangles.size (), 9 * coarse.triangles.size ());
  // Organized input (no intrinsics): the pixel angle comes from the neighbour spacing.
  std::vector<Eigen::Vector3f> pts (depth.size ());
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < kW; ++u)
      pts[v * kW + u] = Eigen::Vector3f ((u - kK.cx) / kK.fx * 2.f, (v - kK.cy) / kK.fy * 2.f, 2.f);
  ASSERT_TRUE (s.compute (pts.data (), kW, kH, Eigen::Matrix4d::Identity (), coarse));
  EXPECT_NEAR (s.getStats ().cell_pixels, b_coarse, 1);
  // A size under a pixel: a noisy frame's cells stop at 3 pixels (1 when lowered), a noise-free
  // frame's do not.
  auto noisy = depth;
  std::mt19937 rng (5);
  std::normal_distribution<float> noise (0.f, 0.004f);
  for (float& z : noisy)
    z += noise (rng);
  Simplifier t;
  t.setCollapseTargetRatio (1);
  t.setMinCellPixels (0);  // no block averaging
  t.setFrustumCellSize (0.002);
  ASSERT_TRUE (t.compute (noisy.data (), kW, kH, kK, Eigen::Matrix4d::Identity (), fine));
  EXPECT_EQ (t.getStats ().cell_pixels, 3);
  ASSERT_TRUE (t.compute (depth.data (), kW, kH, kK, Eigen::Matrix4d::Identity (), fine));
  EXPECT_EQ (t.getStats ().cell_pixels, 1);
  t.setNarrowestCellPixels (1);
  ASSERT_TRUE (t.compute (noisy.data (), kW, kH, kK, Eigen::Matrix4d::Identity (), fine));
  EXPECT_EQ (t.getStats ().cell_pixels, 1);
}

TEST (CoupledSimplification, CellsBetweenWholePixelsKeepTheirSizeOnAverage)
{
  // A noise-free wall filling the frame: one cluster per pixel block.
  const auto depth = planeDepth (Eigen::Vector3f::UnitZ (), 2.f);
  Simplifier s;
  s.setCollapseTargetRatio (1);  // clustering only
  FrameMesh m;
  ASSERT_TRUE (s.compute (depth.data (), kW, kH, kK, Eigen::Matrix4d::Identity (), m));
  const double metres_per_pixel = s.getStats ().median_range / kK.fx;
  const auto clustersAt = [&] (double pixels) {
    s.setFrustumCellSize (pixels * metres_per_pixel);
    EXPECT_TRUE (s.compute (depth.data (), kW, kH, kK, Eigen::Matrix4d::Identity (), m));
    return static_cast<double> (s.getStats ().clusters);
  };
  EXPECT_EQ (clustersAt (4.0), (kW / 4) * (kH / 4));
  // Rounded to whole pixels, 2.45 and 2.55 would give blocks of 2 and 3 pixels: 2.25 times as
  // many clusters for 4 % less width. Blocks of 2 and 3 pixels alternate instead.
  const double narrower = clustersAt (2.45), wider = clustersAt (2.55);
  EXPECT_NEAR (narrower / wider, (2.55 * 2.55) / (2.45 * 2.45), 0.03);
  EXPECT_NEAR (wider, (kW / 2.55) * (kH / 2.55), 0.01 * wider);
}

TEST (CoupledSimplification, BlockAveragingKeepsCoarseCellsAsAccurate)
{
  // A wall 2 m away with 4 mm depth noise: 6 cm cells are about 16 pixels wide, so the frame is
  // block-averaged before clustering; the representatives must stay as close to the wall.
  auto depth = planeDepth (Eigen::Vector3f::UnitZ (), 2.f);
  std::mt19937 rng (11);
  std::normal_distribution<float> noise (0.f, 0.004f);
  for (float& z : depth)
    z += noise (rng);
  auto rmsToWall = [] (const FrameMesh& m) {
    double s = 0;
    for (const auto& v : m.vertices)
      s += (v.z () - 2.0) * (v.z () - 2.0);
    return std::sqrt (s / static_cast<double> (m.vertices.size ()));
  };
  Simplifier s;
  s.setFrustumCellSize (0.06);
  s.setCollapseTargetRatio (1);  // clustering only
  FrameMesh full, reduced;
  s.setMinCellPixels (0);
  ASSERT_TRUE (s.compute (depth.data (), kW, kH, kK, Eigen::Matrix4d::Identity (), full));
  EXPECT_FALSE (s.getStats ().block_averaged);
  const std::size_t dense_full = s.getStats ().dense_triangles;
  s.setMinCellPixels (2);
  ASSERT_TRUE (s.compute (depth.data (), kW, kH, kK, Eigen::Matrix4d::Identity (), reduced));
  EXPECT_TRUE (s.getStats ().block_averaged);
  EXPECT_NEAR (s.getStats ().cell_pixels, 0.06 * 525 / s.getStats ().median_range, 2.0);
  EXPECT_LT (s.getStats ().dense_triangles, dense_full / 3);
  EXPECT_NEAR (static_cast<double> (reduced.triangles.size ()), static_cast<double> (full.triangles.size ()),
               0.3 * full.triangles.size ());
  // Each representative averages ~250 pixels of σ = 4 mm either way; a quarter as many averaged
  // pixels, each half as noisy, keep the representatives at least as close to the wall.
  const double rms_full = rmsToWall (full), rms_reduced = rmsToWall (reduced);
  EXPECT_LT (rms_full, 1.5e-3);
  EXPECT_LT (rms_reduced, rms_full);
  EXPECT_GT (s.getStats ().range_noise, 1.0);
  // Cells narrower than twice the limit keep the full resolution.
  s.setMinCellPixels (9);
  ASSERT_TRUE (s.compute (depth.data (), kW, kH, kK, Eigen::Matrix4d::Identity (), reduced));
  EXPECT_FALSE (s.getStats ().block_averaged);
  EXPECT_EQ (s.getStats ().dense_triangles, dense_full);
  // So does a frame without noise (a laser range scan): averaging would only blur it.
  const auto clean = planeDepth (Eigen::Vector3f::UnitZ (), 2.f);
  s.setMinCellPixels (2);
  ASSERT_TRUE (s.compute (clean.data (), kW, kH, kK, Eigen::Matrix4d::Identity (), reduced));
  EXPECT_LT (s.getStats ().range_noise, 0.1);
  EXPECT_FALSE (s.getStats ().block_averaged);
}

TEST (CoupledSimplification, OrganizedCloudInputMatchesDepthInput)
{
  const auto depth = planeDepth (Eigen::Vector3f (0.1f, 0.2f, 1.f).normalized (), 1.2f);
  std::vector<Eigen::Vector3f> pts (depth.size ());
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < kW; ++u)
    {
      const float z = depth[v * kW + u];
      pts[v * kW + u] = Eigen::Vector3f ((u - kK.cx) / kK.fx * z, (v - kK.cy) / kK.fy * z, z);
    }
  Simplifier s;
  FrameMesh a, b;
  ASSERT_TRUE (s.computeConnectedCloud (depth.data (), kW, kH, kK, Eigen::Matrix4d::Identity (), a));
  ASSERT_TRUE (s.computeConnectedCloud (pts.data (), kW, kH, Eigen::Matrix4d::Identity (), b));
  EXPECT_EQ (a.triangles.size (), b.triangles.size ());
  // A grid stored bottom-up (rows flipped) still gives faces towards the camera.
  std::vector<Eigen::Vector3f> flipped (pts.size ());
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < kW; ++u)
      flipped[(kH - 1 - v) * kW + u] = pts[v * kW + u];
  FrameMesh c;
  ASSERT_TRUE (s.compute (flipped.data (), kW, kH, Eigen::Matrix4d::Identity (), c));
  for (std::size_t f = 0; f < c.triangles.size (); ++f)
    EXPECT_LT (faceNormal (c, f).z (), 0.f);
}

TEST (CoupledSimplification, BadInputFailsAndLeavesTheOutputAlone)
{
  const auto good = planeDepth (Eigen::Vector3f::UnitZ (), 1.f);
  FrameMesh out;
  out.vertices.emplace_back (1, 2, 3);
  auto untouched = [&] { return out.vertices.size () == 1 && out.triangles.empty (); };
  Simplifier s;
  const Eigen::Matrix4d I = Eigen::Matrix4d::Identity ();

  std::vector<float> none (good.size (), 0.f);
  EXPECT_FALSE (s.compute (none.data (), kW, kH, kK, I, out));
  EXPECT_NE (s.getLastError ().find ("no valid pixel"), std::string::npos) << s.getLastError ();
  EXPECT_TRUE (untouched ());

  std::vector<float> nan (good.size (), std::numeric_limits<float>::quiet_NaN ());
  nan[5] = std::numeric_limits<float>::infinity ();
  EXPECT_FALSE (s.compute (nan.data (), kW, kH, kK, I, out));
  EXPECT_TRUE (untouched ());

  std::vector<float> far (good.size (), 50.f);
  EXPECT_FALSE (s.compute (far.data (), kW, kH, kK, I, out));
  EXPECT_EQ (s.getStats ().out_of_range_pixels, far.size ());
  EXPECT_TRUE (untouched ());

  DepthIntrinsics zero;
  EXPECT_FALSE (s.compute (good.data (), kW, kH, zero, I, out));
  EXPECT_NE (s.getLastError ().find ("fx"), std::string::npos);
  DepthIntrinsics inf = kK;
  inf.cx = std::numeric_limits<float>::infinity ();
  EXPECT_FALSE (s.compute (good.data (), kW, kH, inf, I, out));
  EXPECT_TRUE (untouched ());

  EXPECT_FALSE (s.compute (good.data (), kW, kH, kK, Eigen::Matrix4d::Zero (), out));
  Eigen::Matrix4d scaled = I;
  scaled.topLeftCorner<3, 3> () *= 2;
  EXPECT_FALSE (s.compute (good.data (), kW, kH, kK, scaled, out));
  EXPECT_NE (s.getLastError ().find ("singular"), std::string::npos);
  Eigen::Matrix4d nanpose = I;
  nanpose (0, 3) = std::numeric_limits<double>::quiet_NaN ();
  EXPECT_FALSE (s.compute (good.data (), kW, kH, kK, nanpose, out));
  EXPECT_TRUE (untouched ());

  EXPECT_FALSE (s.compute (static_cast<const float*> (nullptr), kW, kH, kK, I, out));
  EXPECT_FALSE (s.compute (good.data (), 0, kH, kK, I, out));
  EXPECT_FALSE (s.compute (static_cast<const Eigen::Vector3f*> (nullptr), kW, kH, I, out));
  std::vector<Eigen::Vector3f> nanpts (good.size (), Eigen::Vector3f::Constant (std::numeric_limits<float>::quiet_NaN ()));
  EXPECT_FALSE (s.compute (nanpts.data (), kW, kH, I, out));
  EXPECT_TRUE (untouched ());

  Simplifier bad;
  bad.setFrustumCellPixels (0);
  EXPECT_FALSE (bad.compute (good.data (), kW, kH, kK, I, out));
  EXPECT_TRUE (untouched ());
  Simplifier negative;
  negative.setMinCellPixels (-1);
  EXPECT_FALSE (negative.compute (good.data (), kW, kH, kK, I, out));
  EXPECT_NE (negative.getLastError ().find ("fewest pixels"), std::string::npos) << negative.getLastError ();
  EXPECT_TRUE (untouched ());
  Simplifier narrow;
  narrow.setFrustumCellSize (0.02);
  narrow.setNarrowestCellPixels (0);
  EXPECT_FALSE (narrow.compute (good.data (), kW, kH, kK, I, out));
  EXPECT_NE (narrow.getLastError ().find ("narrowest"), std::string::npos) << narrow.getLastError ();
  EXPECT_TRUE (untouched ());

  // Partly bad frames are fine: the bad pixels are skipped and counted.
  auto mixed = good;
  for (std::size_t i = 0; i < mixed.size (); i += 7)
    mixed[i] = (i % 2) ? std::numeric_limits<float>::quiet_NaN () : 100.f;
  ASSERT_TRUE (s.compute (mixed.data (), kW, kH, kK, I, out));
  EXPECT_GT (s.getStats ().nonfinite_pixels, 0u);
  EXPECT_GT (s.getStats ().out_of_range_pixels, 0u);
  EXPECT_GT (out.triangles.size (), 0u);
}
