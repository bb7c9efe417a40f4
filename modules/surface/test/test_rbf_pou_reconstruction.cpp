// RBFPOUReconstruction: accuracy and topology on closed shapes, the partition of unity,
// the off-surface constraints, threads, bad input.
#include <pclx/normals/planar_octree_normal_estimation.h>
#include <pclx/surface/rbf_pou_reconstruction.h>
#include <pclx/testing/degradation.h>
#include <pclx/testing/mesh_distance.h>
#include <pclx/testing/mesh_sampling.h>
#include <pclx/testing/shapes.h>

#include <pcl/common/io.h>
#include <pcl/conversions.h>
#include <pcl/features/normal_3d.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/search/kdtree.h>

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <thread>

namespace {

using Cloud = pcl::PointCloud<pcl::PointNormal>;
using Recon = pcl::RBFPOUReconstruction<pcl::PointNormal>;

struct MeshReport
{
  std::size_t vertices = 0, triangles = 0, boundary_edges = 0, nonmanifold_edges = 0;
  std::size_t misoriented_edges = 0;  // a directed edge used twice
  long euler = 0;
  double mean_dist = 0, max_dist = 0, signed_volume = 0;
};

MeshReport
inspect (const pcl::PolygonMesh& mesh, const pclx::testing::TriangleMesh* truth)
{
  MeshReport r;
  pcl::PointCloud<pcl::PointXYZ> v;
  pcl::fromPCLPointCloud2 (mesh.cloud, v);
  r.vertices = v.size ();
  r.triangles = mesh.polygons.size ();
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> undirected, directed;
  for (const auto& p : mesh.polygons)
  {
    for (int j = 0; j < 3; ++j)
    {
      const std::uint32_t a = p.vertices[j], b = p.vertices[(j + 1) % 3];
      ++undirected[{std::min (a, b), std::max (a, b)}];
      ++directed[{a, b}];
    }
    const Eigen::Vector3d a = v[p.vertices[0]].getVector3fMap ().cast<double> ();
    const Eigen::Vector3d b = v[p.vertices[1]].getVector3fMap ().cast<double> ();
    const Eigen::Vector3d c = v[p.vertices[2]].getVector3fMap ().cast<double> ();
    r.signed_volume += a.dot (b.cross (c)) / 6;
  }
  for (const auto& [e, n] : undirected)
  {
    r.boundary_edges += n == 1;
    r.nonmanifold_edges += n > 2;
  }
  for (const auto& [e, n] : directed)
    r.misoriented_edges += n > 1;
  r.euler = long (r.vertices) - long (undirected.size ()) + long (r.triangles);
  if (truth && r.vertices)
  {
    pclx::testing::MeshDistance md (*truth);
    for (const auto& p : v)
    {
      const double d = md.distance (p.getVector3fMap ());
      r.mean_dist += d;
      r.max_dist = std::max (r.max_dist, d);
    }
    r.mean_dist /= double (r.vertices);
  }
  return r;
}

double
meanSpacing (double area, std::size_t n)
{
  return std::sqrt (area / double (n));
}

void
expectClosed (const MeshReport& r, long euler, const char* what)
{
  EXPECT_GT (r.triangles, 100u) << what;
  EXPECT_EQ (r.boundary_edges, 0u) << what;
  EXPECT_EQ (r.nonmanifold_edges, 0u) << what;
  EXPECT_EQ (r.misoriented_edges, 0u) << what;
  EXPECT_EQ (r.euler, euler) << what;
  EXPECT_GT (r.signed_volume, 0) << what << ": triangles must face outwards";
}

pcl::PolygonMesh
run (Recon& rec, const Cloud::Ptr& cloud)
{
  rec.setInputCloud (cloud);
  pcl::PolygonMesh mesh;
  rec.reconstruct (mesh);
  return mesh;
}

const pclx::testing::TriangleMesh&
sphereMesh ()
{
  static const auto m = pclx::testing::makeSphere (1.f, 5);
  return m;
}

const pclx::testing::TriangleMesh&
torusMesh ()
{
  static const auto m = pclx::testing::makeTorus (1.f, 0.3f, 128, 48);
  return m;
}

Cloud::Ptr
sample (const pclx::testing::TriangleMesh& m, std::size_t n, std::uint32_t seed = 1)
{
  return Cloud::Ptr (new Cloud (pclx::testing::sampleUniform (m, n, seed).cloud));
}

}  // namespace

TEST (RBFPOUReconstruction, SphereClosedGenusZeroWithinBound)
{
  const std::size_t n = 8000;
  const auto cloud = sample (sphereMesh (), n);
  Recon rec;
  const auto r = inspect (run (rec, cloud), &sphereMesh ());
  const double s = meanSpacing (sphereMesh ().totalArea (), n);
  expectClosed (r, 2, "sphere");
  EXPECT_LT (r.mean_dist, 0.05 * s);
  EXPECT_LT (r.max_dist, 0.5 * s);
  EXPECT_EQ (rec.getStats ().noise, 0.0) << "clean samples are interpolated";
  EXPECT_EQ (rec.getStats ().smoothed_subdomains, 0u);
  std::printf ("sphere: %zu vertices, %zu triangles, mean %.2e max %.2e (spacing %.3f), %zu subdomains\n",
               r.vertices, r.triangles, r.mean_dist, r.max_dist, s, rec.getNumberOfSubdomains ());
}

TEST (RBFPOUReconstruction, TorusClosedGenusOneWithinBound)
{
  const std::size_t n = 12000;
  const auto cloud = sample (torusMesh (), n);
  Recon rec;
  const auto r = inspect (run (rec, cloud), &torusMesh ());
  const double s = meanSpacing (torusMesh ().totalArea (), n);
  expectClosed (r, 0, "torus");
  EXPECT_LT (r.mean_dist, 0.05 * s);
  EXPECT_LT (r.max_dist, 0.5 * s);
  std::printf ("torus: %zu vertices, mean %.2e max %.2e (spacing %.3f)\n", r.vertices, r.mean_dist,
               r.max_dist, s);
}

TEST (RBFPOUReconstruction, PartitionOfUnityCoversAndSumsToOne)
{
  const auto cloud = sample (torusMesh (), 6000);
  for (const auto decay : {Recon::Decay::LINEAR, Recon::Decay::CUBIC})
  {
    Recon rec;
    rec.setDecay (decay);
    ASSERT_GT (run (rec, cloud).polygons.size (), 0u);
    const double s = rec.getStats ().mean_spacing;
    std::mt19937 rng (5);
    std::uniform_real_distribution<float> u (-1.f, 1.f);
    std::uniform_int_distribution<std::size_t> pick (0, cloud->size () - 1);
    for (int i = 0; i < 2000; ++i)
    {
      // Within 3 spacings of a data point: the band the mesh is extracted from.
      const Eigen::Vector3f p = (*cloud)[pick (rng)].getVector3fMap () +
                                float (3 * s) * Eigen::Vector3f (u (rng), u (rng), u (rng));
      const auto w = rec.weightsAt (p);
      ASSERT_FALSE (w.empty ()) << "uncovered point near the data";
      double sum = 0;
      for (const double x : w)
      {
        EXPECT_GE (x, 0.0);
        sum += x;
      }
      EXPECT_NEAR (sum, 1.0, 1e-12);
      EXPECT_TRUE (std::isfinite (rec.evaluate (p)));
    }
    // Far from the data F is undefined rather than extrapolated.
    EXPECT_TRUE (std::isnan (rec.evaluate (Eigen::Vector3f (50.f, 50.f, 50.f))));
  }
}

TEST (RBFPOUReconstruction, OffSurfacePointsKeepTheirOriginNearest)
{
  // Two sheets 0.02 apart; ε = 0.05 forces halving for the points between the sheets.
  const auto sheets = pclx::testing::makeParallelSheets (1.f, 0.02f, 16);
  const auto cloud = sample (sheets, 6000, 3);
  Recon rec;
  rec.setOffSurfaceEpsilon (0.05);
  run (rec, cloud);
  const auto& pts = rec.getFilteredPoints ();
  const auto& off = rec.getOffSurfaceConstraints ();
  ASSERT_EQ (pts.size (), cloud->size ());
  EXPECT_GT (rec.getStats ().eps_halved, 0u);
  EXPECT_GT (off.size (), pts.size ());
  pcl::PointCloud<pcl::PointXYZ>::Ptr xyz (new pcl::PointCloud<pcl::PointXYZ>);
  for (const auto& p : pts)
  {
    pcl::PointXYZ q;
    q.getVector3fMap () = p;
    xyz->push_back (q);
  }
  pcl::KdTreeFLANN<pcl::PointXYZ> tree;
  tree.setInputCloud (xyz);
  std::size_t inner = 0;
  for (const auto& c : off)
  {
    pcl::PointXYZ q;
    q.getVector3fMap () = c.p;
    pcl::Indices k;
    std::vector<float> d;
    ASSERT_EQ (tree.nearestKSearch (q, 1, k, d), 1);
    const float to_origin = (c.p - pts[c.origin]).squaredNorm ();
    ASSERT_TRUE (k[0] == c.origin || d[0] >= to_origin) << "constraint of point " << c.origin;
    EXPECT_NEAR (std::abs (c.value), std::sqrt (to_origin), 1e-6f);
    inner += std::abs (c.p.z ()) < 0.01f;
  }
  EXPECT_GT (inner, 0u);  // halved points between the sheets exist
}

TEST (RBFPOUReconstruction, ParallelInstancesMatchSequentialRuns)
{
  const auto a = sample (sphereMesh (), 5000, 7);
  const auto b = sample (torusMesh (), 6000, 8);
  auto once = [] (const Cloud::Ptr& c) {
    Recon rec;
    return run (rec, c);
  };
  const auto seq_a = once (a), seq_b = once (b);
  pcl::PolygonMesh par_a, par_b;
  std::thread ta ([&] { par_a = once (a); });
  std::thread tb ([&] { par_b = once (b); });
  ta.join ();
  tb.join ();
  for (const auto& [s, p] : {std::make_pair (&seq_a, &par_a), std::make_pair (&seq_b, &par_b)})
  {
    ASSERT_GT (s->polygons.size (), 0u);
    EXPECT_EQ (s->cloud.data, p->cloud.data);
    ASSERT_EQ (s->polygons.size (), p->polygons.size ());
    for (std::size_t i = 0; i < s->polygons.size (); ++i)
      ASSERT_EQ (s->polygons[i].vertices, p->polygons[i].vertices);
  }
}

TEST (RBFPOUReconstruction, FlippedNormalsStillGiveAClosedSurface)
{
  const std::size_t n = 8000;
  const double s = meanSpacing (sphereMesh ().totalArea (), n);
  for (const double share : {0.01, 0.05})
  {
    auto cloud = sample (sphereMesh (), n, 11);
    std::mt19937 rng (13);
    std::uniform_real_distribution<double> u (0, 1);
    for (auto& p : *cloud)
      if (u (rng) < share)
        p.getNormalVector3fMap () *= -1.f;
    Recon rec;
    const auto r = inspect (run (rec, cloud), &sphereMesh ());
    const auto& st = rec.getStats ();
    std::size_t wrong = 0;
    for (std::size_t i = 0; i < rec.getFilteredPoints ().size (); ++i)
      wrong += rec.getFilteredNormals ()[i].dot (rec.getFilteredPoints ()[i]) < 0;
    EXPECT_EQ (wrong, 0u) << "inward normals left after the vote";
    std::printf ("%.0f %% flipped: voted %zu, mean %.2e max %.2e, t %.2f %.2f %.2f %.2f %.2f\n", 100 * share,
                 st.normals_voted, r.mean_dist, r.max_dist, st.t_prepare, st.t_off_surface, st.t_octree,
                 st.t_fits, st.t_extraction);
    expectClosed (r, 2, share < 0.02 ? "1 % flipped" : "5 % flipped");
    EXPECT_LT (r.mean_dist, 0.05 * s);
    EXPECT_LT (r.max_dist, 0.5 * s);
    EXPECT_GT (rec.getStats ().normals_voted, 0u);
  }
}

TEST (RBFPOUReconstruction, UnorientedNormalsWithMstOrientation)
{
  // PCL's PCA normals have an arbitrary sign; setOrientNormals (true) fixes them.
  const std::size_t n = 6000;
  const auto truth = sample (torusMesh (), n, 17);
  pcl::PointCloud<pcl::PointXYZ>::Ptr xyz (new pcl::PointCloud<pcl::PointXYZ>);
  pcl::copyPointCloud (*truth, *xyz);
  pcl::NormalEstimation<pcl::PointXYZ, pcl::Normal> ne;
  ne.setInputCloud (xyz);
  ne.setKSearch (12);
  pcl::PointCloud<pcl::Normal> normals;
  ne.compute (normals);
  Cloud::Ptr cloud (new Cloud);
  pcl::concatenateFields (*xyz, normals, *cloud);
  std::mt19937 rng (3);
  for (auto& p : *cloud)
    if (rng () & 1)
      p.getNormalVector3fMap () *= -1.f;
  Recon rec;
  rec.setOrientNormals (true);
  const auto r = inspect (run (rec, cloud), &torusMesh ());
  expectClosed (r, 0, "MST-oriented PCA normals");
  EXPECT_LT (r.mean_dist, 0.1 * meanSpacing (torusMesh ().totalArea (), n));
}

TEST (RBFPOUReconstruction, PlanarOctreeNormalsWithMstOrientation)
{
  // pclx::normals' estimator (unoriented output) + the built-in MST orientation.
  const std::size_t n = 6000;
  const auto truth = sample (sphereMesh (), n, 37);
  pcl::PointCloud<pcl::PointXYZ>::Ptr xyz (new pcl::PointCloud<pcl::PointXYZ>);
  pcl::copyPointCloud (*truth, *xyz);
  pcl::PlanarOctreeNormalEstimation<pcl::PointXYZ, pcl::Normal> ne;
  ne.setInputCloud (xyz);
  pcl::PointCloud<pcl::Normal> normals;
  ne.compute (normals);
  Cloud::Ptr cloud (new Cloud);
  pcl::concatenateFields (*xyz, normals, *cloud);
  Recon rec;
  rec.setOrientNormals (true);
  const auto r = inspect (run (rec, cloud), &sphereMesh ());
  expectClosed (r, 2, "PlanarOctreeNormalEstimation + MST");
  EXPECT_LT (r.mean_dist, 0.1 * meanSpacing (sphereMesh ().totalArea (), n));
}

TEST (RBFPOUReconstruction, NonFiniteAndZeroNormalPointsAreDroppedAndCounted)
{
  auto cloud = sample (sphereMesh (), 6000, 19);
  const float nan = std::numeric_limits<float>::quiet_NaN ();
  const float inf = std::numeric_limits<float>::infinity ();
  for (int i = 0; i < 30; ++i)
  {
    (*cloud)[i * 7].x = i % 2 ? nan : inf;
    (*cloud)[i * 7 + 1].getNormalVector3fMap ().setZero ();
  }
  cloud->is_dense = false;
  Recon rec;
  const auto r = inspect (run (rec, cloud), &sphereMesh ());
  EXPECT_EQ (rec.getStats ().dropped_points, 30u);
  EXPECT_EQ (rec.getStats ().zero_normals, 30u);
  expectClosed (r, 2, "with NaN/Inf points");
  EXPECT_TRUE (rec.getLastError ().empty ());
}

TEST (RBFPOUReconstruction, BadInputGivesEmptyMeshAndError)
{
  const auto good = sample (sphereMesh (), 3000, 23);
  auto expectError = [] (Recon& rec, const Cloud::Ptr& c, const std::string& word) {
    const auto mesh = run (rec, c);
    EXPECT_TRUE (mesh.polygons.empty ()) << word;
    EXPECT_EQ (mesh.cloud.width * mesh.cloud.height, 0u) << word;
    EXPECT_NE (rec.getLastError ().find (word), std::string::npos) << rec.getLastError ();
  };
  {
    Cloud::Ptr c (new Cloud (*good));
    for (auto& p : *c)
      p.getNormalVector3fMap ().setZero ();
    Recon rec;
    expectError (rec, c, "normals");
  }
  {
    Cloud::Ptr c (new Cloud (*good));
    c->resize (12);
    Recon rec;
    expectError (rec, c, "Tmin");
  }
  {
    Recon rec;
    rec.setMinPointsPerSubdomain (200);
    rec.setMaxPointsPerSubdomain (100);
    expectError (rec, good, "Tmax");
  }
  for (const double d : {0.0, -1.0, 1.0})
  {
    Recon rec;
    rec.setOverlap (d);
    expectError (rec, good, "overlap");
  }
  for (const double h : {0.0, -0.1})
  {
    Recon rec;
    rec.setGridResolution (h);
    expectError (rec, good, "grid resolution");
  }
  {
    Recon rec;
    rec.setOffSurfaceEpsilon (0);
    expectError (rec, good, "epsilon");
  }
  {
    Recon rec;
    rec.setBandWidth (0);
    expectError (rec, good, "band");
  }
  for (const double sigma : {-0.01, std::numeric_limits<double>::quiet_NaN (), std::numeric_limits<double>::infinity ()})
  {
    Recon rec;
    rec.setNoiseLevel (sigma);
    expectError (rec, good, "noise");
  }
  {
    Recon rec;  // a good run after a failed one on the same instance works again
    rec.setOverlap (0.5);
    expectError (rec, good, "overlap");
    rec.setOverlap (1.5);
    EXPECT_GT (run (rec, good).polygons.size (), 0u);
    EXPECT_TRUE (rec.getLastError ().empty ());
  }
}

TEST (RBFPOUReconstruction, CoplanarPointsGiveAPlanePatch)
{
  // Documented behaviour: an open plane patch over the data (plus the band), not an error.
  Cloud::Ptr c (new Cloud);
  std::mt19937 rng (29);
  std::uniform_real_distribution<float> u (-0.5f, 0.5f);
  for (int i = 0; i < 3000; ++i)
  {
    pcl::PointNormal p;
    p.x = u (rng);
    p.y = u (rng);
    p.z = 0.f;
    p.normal_x = p.normal_y = 0.f;
    p.normal_z = 1.f;
    c->push_back (p);
  }
  Recon rec;
  const auto mesh = run (rec, c);
  const auto r = inspect (mesh, nullptr);
  EXPECT_GT (r.triangles, 100u);
  EXPECT_GT (r.boundary_edges, 0u);  // open
  EXPECT_EQ (r.nonmanifold_edges, 0u);
  EXPECT_EQ (r.euler, 1);            // a disc
  pcl::PointCloud<pcl::PointXYZ> v;
  pcl::fromPCLPointCloud2 (mesh.cloud, v);
  for (const auto& p : v)
    ASSERT_LT (std::abs (p.z), 1e-3f);
}

TEST (RBFPOUReconstruction, OtherPointTypesKeepAttributes)
{
  const auto s = pclx::testing::sampleUniform (sphereMesh (), 4000, 31);
  pcl::PointCloud<pcl::PointXYZRGBNormal>::Ptr c (new pcl::PointCloud<pcl::PointXYZRGBNormal>);
  pcl::copyPointCloud (s.cloud, *c);
  for (auto& p : *c)
  {
    p.r = 200;
    p.g = 10;
    p.b = 20;
  }
  pcl::RBFPOUReconstruction<pcl::PointXYZRGBNormal> rec;
  rec.setInputCloud (c);
  pcl::PointCloud<pcl::PointXYZRGBNormal> points;
  std::vector<pcl::Vertices> polygons;
  rec.reconstruct (points, polygons);
  ASSERT_GT (polygons.size (), 100u);
  for (const auto& p : points)
  {
    ASSERT_EQ (p.r, 200);
    ASSERT_NEAR (p.getNormalVector3fMap ().norm (), 1.f, 1e-4f);
    // Outward normals on a sphere centred at the origin.
    ASSERT_GT (p.getNormalVector3fMap ().dot (p.getVector3fMap ().normalized ()), 0.5f);
  }
  pcl::RBFPOUReconstruction<pcl::PointXYZINormal> rec_i;  // instantiated too
  EXPECT_EQ (rec_i.getMaxPointsPerSubdomain (), 150);
}

TEST (RBFPOUReconstruction, SurfaceContinuationMatchesTheWholeBand)
{
  // Continuation evaluates F only near the zero set; on closed shapes the mesh is the one the
  // whole band gives, byte for byte, from fewer evaluated corners.
  for (const auto* shape : {&sphereMesh (), &torusMesh ()})
  {
    const auto cloud = sample (*shape, 6000, 41);
    Recon full, cont;
    full.setSurfaceContinuation (false);
    EXPECT_TRUE (cont.getSurfaceContinuation ());
    const auto a = run (full, cloud), b = run (cont, cloud);
    ASSERT_GT (a.polygons.size (), 100u);
    EXPECT_EQ (a.cloud.data, b.cloud.data);
    ASSERT_EQ (a.polygons.size (), b.polygons.size ());
    for (std::size_t i = 0; i < a.polygons.size (); ++i)
      ASSERT_EQ (a.polygons[i].vertices, b.polygons[i].vertices);
    const auto& sf = full.getStats ();
    const auto& sc = cont.getStats ();
    EXPECT_EQ (sf.active_cells, sf.band_cells);
    EXPECT_EQ (sf.waves, 1u);
    EXPECT_EQ (sc.band_cells, sf.band_cells);
    EXPECT_GT (sc.waves, 1u);
    EXPECT_LT (2 * sc.corners, sf.corners);  // measured ~2.7× fewer
    EXPECT_LT (sc.active_cells, sc.band_cells);
  }
}

TEST (RBFPOUReconstruction, PolygonMeshAndPointCloudOutputsAgree)
{
  // The PolygonMesh output writes PointNT records straight into the blob: it must read back
  // as the PointCloud output (positions, unit normals, zero curvature).
  const auto cloud = sample (sphereMesh (), 4000, 43);
  Recon a, b;
  const auto mesh = run (a, cloud);
  b.setInputCloud (cloud);
  Cloud points;
  std::vector<pcl::Vertices> polygons;
  b.reconstruct (points, polygons);
  Cloud back;
  pcl::fromPCLPointCloud2 (mesh.cloud, back);
  ASSERT_GT (points.size (), 100u);
  ASSERT_EQ (back.size (), points.size ());
  EXPECT_EQ (mesh.cloud.width, points.size ());
  EXPECT_EQ (mesh.cloud.height, 1u);
  for (std::size_t i = 0; i < points.size (); ++i)
  {
    ASSERT_EQ (back[i].getVector3fMap (), points[i].getVector3fMap ());
    ASSERT_EQ (back[i].getNormalVector3fMap (), points[i].getNormalVector3fMap ());
    ASSERT_NEAR (back[i].getNormalVector3fMap ().norm (), 1.f, 1e-5f);
    ASSERT_EQ (back[i].curvature, 0.f);
  }
  ASSERT_EQ (mesh.polygons.size (), polygons.size ());
  for (std::size_t i = 0; i < polygons.size (); ++i)
    ASSERT_EQ (mesh.polygons[i].vertices, polygons[i].vertices);
  EXPECT_GT (a.getStats ().t_output, 0.0);
}

// Correct, oriented normals are never turned by the vote: on a clean torus the mesh is the one
// without the vote, and on a plate thinner than the sample spacing the other side's opposite
// normals (off the point's tangent plane) do not outvote a point.
TEST (RBFPOUReconstruction, VoteNeverTurnsCorrectNormals)
{
  const auto torus = sample (torusMesh (), 8000, 31);
  Recon with, without;
  without.setNormalVote (false);
  const pcl::PolygonMesh a = run (with, torus), b = run (without, torus);
  EXPECT_EQ (with.getStats ().normals_voted, 0u);
  ASSERT_GT (a.polygons.size (), 0u);
  EXPECT_EQ (a.cloud.data, b.cloud.data);
  ASSERT_EQ (a.polygons.size (), b.polygons.size ());
  for (std::size_t i = 0; i < a.polygons.size (); ++i)
    ASSERT_EQ (a.polygons[i].vertices, b.polygons[i].vertices);

  const std::size_t n = 20000;
  const double spacing = std::sqrt (2.0 / n);  // two faces of a unit plate
  const auto plate = pclx::testing::makeThinPlate (1.f, static_cast<float> (0.7 * spacing), 16);
  Recon thin;
  thin.setInputCloud (sample (plate, n, 37));
  pcl::PolygonMesh m;
  thin.reconstruct (m);
  EXPECT_EQ (thin.getStats ().normals_voted, 0u);
}

// reconstruct () without an input cloud is refused (PCL's base class would dereference it),
// also through a base-class pointer.
TEST (RBFPOUReconstruction, NoInputIsRefused)
{
  Recon rec;
  pcl::PolygonMesh mesh;
  mesh.polygons.resize (3);
  ::testing::internal::CaptureStderr ();
  rec.reconstruct (mesh);
  const std::string log = ::testing::internal::GetCapturedStderr ();
  EXPECT_EQ (log.find ("[pcl::"), log.rfind ("[pcl::")) << log;  // one PCL_ERROR line
  EXPECT_NE (log.find ("[pcl::"), std::string::npos) << log;
  EXPECT_TRUE (mesh.polygons.empty ());
  EXPECT_EQ (mesh.cloud.width * mesh.cloud.height, 0u);
  EXPECT_NE (rec.getLastError ().find ("input"), std::string::npos) << rec.getLastError ();

  pcl::PCLSurfaceBase<pcl::PointNormal>::Ptr base (new Recon);
  pcl::PolygonMesh other;
  base->reconstruct (other);
  EXPECT_TRUE (other.polygons.empty ());

  Cloud points;
  points.resize (5);
  std::vector<pcl::Vertices> polygons (2);
  rec.reconstruct (points, polygons);
  EXPECT_TRUE (points.empty ());
  EXPECT_TRUE (polygons.empty ());
}

// Noisy samples are approximated, not interpolated: the noise is measured, every fit smooths,
// and the sphere comes out as one closed surface within 2σ; interpolating the same points
// (setNoiseLevel (0)) wraps every noisy point and lands farther from the sphere.
TEST (RBFPOUReconstruction, NoisySphereIsOneClosedSurfaceWithinTwoSigma)
{
  const std::size_t n = 20000;
  auto s = pclx::testing::sampleUniform (sphereMesh (), n, 41);
  const double sigma = 0.0025 * sphereMesh ().diagonal ();
  pclx::testing::addGaussianNoise (s, 0.0025f, 43);
  const Cloud::Ptr cloud (new Cloud (s.cloud));

  Recon smooth;
  const auto r = inspect (run (smooth, cloud), &sphereMesh ());
  expectClosed (r, 2, "noisy sphere");
  EXPECT_LT (r.max_dist, 2 * sigma);
  EXPECT_NEAR (smooth.getStats ().noise, sigma, 0.3 * sigma);
  EXPECT_EQ (smooth.getStats ().smoothed_subdomains, smooth.getNumberOfSubdomains ());
  EXPECT_EQ (smooth.getStats ().normals_voted, 0u);

  Recon interpolating;
  interpolating.setNoiseLevel (0);
  const auto ri = inspect (run (interpolating, cloud), &sphereMesh ());
  EXPECT_EQ (interpolating.getStats ().smoothed_subdomains, 0u);
  EXPECT_GT (ri.mean_dist, 2 * r.mean_dist);
  std::printf ("noisy sphere (sigma %.4f): mean %.2e max %.2e; interpolated mean %.2e max %.2e\n", sigma,
               r.mean_dist, r.max_dist, ri.mean_dist, ri.max_dist);
}

// A plate about four spacings thick: supports that hold both of its sides would read the
// thickness as noise, smooth the clean samples with large quadrics and leave the rim open. The
// estimate skips neighbours facing the other way, so clean samples are interpolated (closed,
// near the plate) and noisy ones give their own σ.
TEST (RBFPOUReconstruction, ThinPlateSidesAreNotReadAsNoise)
{
  const auto plate = pclx::testing::makeThinPlate (1.f, 0.02f, 16);
  const std::size_t n = 20000;
  Recon clean;
  const auto r = inspect (run (clean, sample (plate, n, 47)), &plate);
  EXPECT_EQ (clean.getStats ().noise, 0.0);
  EXPECT_LT (clean.getStats ().noise_ratio, 0.1);
  expectClosed (r, 2, "clean thin plate");
  EXPECT_LT (r.mean_dist, 0.1 * clean.getStats ().mean_spacing);

  auto s = pclx::testing::sampleUniform (plate, n, 47);
  const double sigma = 0.0025 * plate.diagonal ();
  pclx::testing::addGaussianNoise (s, 0.0025f, 53);
  Recon noisy;
  const auto rn = inspect (run (noisy, Cloud::Ptr (new Cloud (s.cloud))), &plate);
  EXPECT_NEAR (noisy.getStats ().noise, sigma, 0.2 * sigma);
  expectClosed (rn, 2, "noisy thin plate");
  std::printf ("thin plate: clean mean %.2e (spacing %.2e), noise %.2e for sigma %.2e\n", r.mean_dist,
               clean.getStats ().mean_spacing, noisy.getStats ().noise, sigma);
}

// Under noise one quadric over both sides of a plate reads the noise as thickness (its
// quadratic term along the normal fits E[z²] = t²/4 + σ²), so the sides move apart; a fit per
// side keeps them where they are. Smooth and closed shapes hold no opposed sides and are fitted
// as before.
TEST (RBFPOUReconstruction, NoisyThinPlateSidesStayWhereTheyAre)
{
  const auto plate = pclx::testing::makeThinPlate (1.f, 0.02f, 16);
  auto s = pclx::testing::sampleUniform (plate, 20000, 47);
  const double sigma = 0.0025 * plate.diagonal ();
  pclx::testing::addGaussianNoise (s, 0.0025f, 53);
  Recon rec;
  const pcl::PolygonMesh mesh = run (rec, Cloud::Ptr (new Cloud (s.cloud)));
  EXPECT_GT (rec.getStats ().two_sheet_subdomains, rec.getNumberOfSubdomains () / 2);
  expectClosed (inspect (mesh, &plate), 2, "noisy thin plate");
  pcl::PointCloud<pcl::PointXYZ> v;
  pcl::fromPCLPointCloud2 (mesh.cloud, v);
  double offset = 0;  // mean |z| − half the thickness away from the rim
  std::size_t count = 0;
  for (const auto& p : v)
    if (std::abs (p.x) < 0.4f && std::abs (p.y) < 0.4f)
    {
      offset += std::abs (p.z) - 0.01;
      ++count;
    }
  ASSERT_GT (count, 1000u);
  offset /= double (count);
  EXPECT_LT (std::abs (offset), 0.05 * sigma);
  std::printf ("noisy thin plate: sides off by %.2e on average (sigma %.2e), %zu of %zu fits split\n", offset, sigma,
               rec.getStats ().two_sheet_subdomains, rec.getNumberOfSubdomains ());

  auto sphere = pclx::testing::sampleUniform (sphereMesh (), 20000, 41);
  pclx::testing::addGaussianNoise (sphere, 0.0025f, 43);
  Recon round;
  run (round, Cloud::Ptr (new Cloud (sphere.cloud)));
  EXPECT_EQ (round.getStats ().two_sheet_subdomains, 0u);

  // One surface whose normals disagree (a cap flipped, the vote off) is not two sides: their
  // fits lie on each other, so no fit is split.
  for (auto& p : sphere.cloud)
    if (p.z > 0.8f)
      p.getNormalVector3fMap () *= -1.f;
  Recon flipped;
  flipped.setNormalVote (false);
  run (flipped, Cloud::Ptr (new Cloud (sphere.cloud)));
  EXPECT_EQ (flipped.getStats ().two_sheet_subdomains, 0u);
}

// Where a quadric cannot follow the surface within the noise (a box's edges under little noise)
// the fit is Carr et al.'s smoothing spline with ρ between interpolation and the polynomial.
TEST (RBFPOUReconstruction, SmoothingSplineWhereAQuadricMissesTheShape)
{
  const auto box = pclx::testing::makeBox ();
  auto s = pclx::testing::sampleUniform (box, 60000, 47);
  pclx::testing::addGaussianNoise (s, 0.0007f, 53);
  const double sigma = 0.0007 * box.diagonal ();
  Recon rec;
  const auto r = inspect (run (rec, Cloud::Ptr (new Cloud (s.cloud))), &box);
  const auto& st = rec.getStats ();
  EXPECT_GT (st.noise, 0.0);
  EXPECT_GT (st.smoothed_subdomains, st.polynomial_subdomains) << "some fits keep r³ terms";
  EXPECT_GT (st.polynomial_subdomains, 0u);
  expectClosed (r, 2, "noisy box");
  EXPECT_LT (r.mean_dist, sigma);
  std::printf ("noisy box: %zu of %zu fits are splines, mean %.2e (sigma %.2e)\n",
               st.smoothed_subdomains - st.polynomial_subdomains, rec.getNumberOfSubdomains (), r.mean_dist, sigma);
}

// Near a box's corners the enlarged octree cells can leave band corners that no subdomain
// covers; they take the nearest subdomain's fit, so the mesh has no hole there.
TEST (RBFPOUReconstruction, UncoveredBandCornersStillClose)
{
  const auto box = pclx::testing::makeBox ();
  Recon rec;
  const auto r = inspect (run (rec, sample (box, 30000, 1)), &box);
  EXPECT_GT (rec.getStats ().uncovered_corners, 0u) << "the case this test is about did not arise";
  expectClosed (r, 2, "box");
  EXPECT_TRUE (std::isnan (rec.evaluate (Eigen::Vector3f (5.f, 5.f, 5.f)))) << "F stays undefined far away";
}

// A gap in the samples wider than two grid cells (random sampling leaves such gaps at 1M
// points) is bridged by the default band of three cells.
TEST (RBFPOUReconstruction, SamplingGapWithinTheBandCloses)
{
  const std::size_t n = 8000;
  auto cloud = sample (sphereMesh (), n, 59);
  Recon probe;
  run (probe, cloud);
  const double h = probe.getStats ().grid_resolution;
  const Cloud::Ptr holed (new Cloud);
  for (const auto& p : *cloud)
    if ((p.getVector3fMap () - Eigen::Vector3f::UnitZ ()).norm () > 3.4 * h)
      holed->push_back (p);
  Recon narrow, standard;
  narrow.setBandWidth (2);
  narrow.setGridResolution (h);
  standard.setGridResolution (h);
  const auto open = inspect (run (narrow, holed), nullptr);
  const auto closed = inspect (run (standard, holed), &sphereMesh ());
  EXPECT_GT (open.boundary_edges, 0u) << "a band of 2 cells should not reach across this gap";
  expectClosed (closed, 2, "sphere with a gap");
}

// A search object counting its queries, as a user's own search method would be.
class CountingKdTree : public pcl::search::KdTree<pcl::PointNormal>
{
public:
  int
  nearestKSearch (const pcl::PointNormal& p, int k, pcl::Indices& indices, std::vector<float>& d2) const override
  {
    ++queries;
    return pcl::search::KdTree<pcl::PointNormal>::nearestKSearch (p, k, indices, d2);
  }
  mutable std::atomic<std::size_t> queries{0};
};

// setSearchMethod () is honoured: the point searches go to the given search, and a kd-tree gives
// the mesh of the class's own, also with invalid points and a subset of indices.
TEST (RBFPOUReconstruction, SetSearchMethodIsUsed)
{
  auto cloud = sample (sphereMesh (), 6000);
  (*cloud)[7].x = std::numeric_limits<float>::quiet_NaN ();
  (*cloud)[9].getNormalVector3fMap ().setZero ();
  cloud->is_dense = false;
  pcl::IndicesPtr subset (new pcl::Indices);
  for (int i = 0; i < int (cloud->size ()); ++i)
    if (i % 10 != 3)
      subset->push_back (i);
  Recon own, given;
  own.setIndices (subset);
  given.setIndices (subset);
  auto search = std::make_shared<CountingKdTree> ();
  given.setSearchMethod (search);
  const pcl::PolygonMesh a = run (own, cloud), b = run (given, cloud);
  EXPECT_GT (search->queries.load (), subset->size ());
  ASSERT_FALSE (a.polygons.empty ());
  ASSERT_EQ (a.polygons.size (), b.polygons.size ());
  EXPECT_EQ (a.cloud.data, b.cloud.data);
  EXPECT_DOUBLE_EQ (own.getStats ().mean_spacing, given.getStats ().mean_spacing);
}
