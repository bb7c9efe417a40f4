// bench_idc: IncrementalDualContouring (issue 10, seed 004) on posed depth sequences against
// Open3D's ScalableTSDFVolume + marching cubes at matching voxel sizes, and PCL's
// MarchingCubesHoppe / GreedyProjectionTriangulation on the fused cloud (object sequences).
// Inputs: frames rendered from meshes with Kinect-like noise (a torus around a sphere seen from
// an orbit, the Stanford bunny mesh scaled to 0.6 m when ../shared/data exists, a room for
// speed), the 50 7-Scenes frames (speed and looks; no truth) and the 10 bunny range scans
// (truth: bun_zipper.ply). Metrics: Chamfer / Hausdorff to the truth (area-uniform samples
// both ways, CGAL AABB distances), triangles, ms per frame (median, p95), memory. CSV rows on
// stdout (and --csv); --frames-csv gets the per-frame times for the frame-index chart.
#include "bench_rbf_metrics.h"
#include <bench_csv.h>
#include <pclx/apps/depth_frames.h>
#include <pclx/surface/incremental_dual_contouring.h>
#include <pclx/testing/depth_renderer.h>
#include <pclx/testing/mesh_sampling.h>
#include <pclx/testing/shapes.h>
#ifdef PCLX_HAVE_OPEN3D
#include "bench_idc_open3d.h"
#endif

#include <pcl/common/common.h>
#include <pcl/common/transforms.h>
#include <pcl/features/integral_image_normal.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/io/ply_io.h>
#include <pcl/search/kdtree.h>
#include <pcl/surface/gp3.h>
#include <pcl/surface/marching_cubes_hoppe.h>

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdlib>
#include <unistd.h>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace {

using pclx::testing::TriangleMesh;
using Clock = std::chrono::steady_clock;

double
msSince (Clock::time_point t0)
{
  return std::chrono::duration<double, std::milli> (Clock::now () - t0).count ();
}

double
rssMiB ()
{
  std::ifstream in ("/proc/self/statm");
  long pages = 0, resident = 0;
  in >> pages >> resident;
  return resident * 4096.0 / 1048576.0;
}

double
percentile (std::vector<double> v, double q)
{
  if (v.empty ())
    return 0;
  std::sort (v.begin (), v.end ());
  return v[std::min (v.size () - 1, static_cast<std::size_t> (q * (v.size () - 1) + 0.5))];
}

// A posed frame: 16-bit depth (pinhole) or an organized camera-frame cloud (range scans).
struct Frame
{
  int width = 0, height = 0;
  std::vector<std::uint16_t> mm;
  pcl::PointCloud<pcl::PointXYZ>::Ptr organized;
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity ();
};

struct Sequence
{
  std::string name;
  bool pinhole = true, has_truth = false, object = false;
  TriangleMesh truth;
  pclx::surface::DepthIntrinsics K;
  std::vector<Frame> frames;
  std::vector<double> leaves;  // detail levels (metres)
  double depth_trunc = 4.0;
};

Sequence
renderOrbit (const std::string& name, const TriangleMesh& mesh, int frames, double radius, int width, int height,
             std::vector<double> leaves)
{
  using namespace pclx::testing;
  Sequence s;
  s.name = name;
  s.truth = mesh;
  s.has_truth = s.object = true;
  s.leaves = std::move (leaves);
  s.depth_trunc = 3.0;
  const RayCaster caster (mesh);
  PinholeIntrinsics K;
  K.width = width; K.height = height;
  K.fx = K.fy = 525.f * width / 640.f;
  K.cx = (width - 1) / 2.f; K.cy = (height - 1) / 2.f;
  s.K = {K.fx, K.fy, K.cx, K.cy};
  const Eigen::Vector3f c = 0.5f * (mesh.bboxMin () + mesh.bboxMax ());
  for (int f = 0; f < frames; ++f)
  {
    // Around the object, alternately above and below, so that the views cover it.
    const float a = 2.f * float (M_PI) * f / frames;
    const float h = (f % 2 ? -0.55f : 0.75f) * float (radius);
    const Eigen::Vector3f eye = c + Eigen::Vector3f (float (radius) * std::cos (a), float (radius) * std::sin (a), h);
    const Eigen::Isometry3f pose = lookAt (eye, c);
    const DepthImage img = renderDepth (caster, K, pose, KinectNoise (), 1000 + f);
    Frame fr;
    fr.width = img.width; fr.height = img.height;
    fr.mm = img.depth_mm;
    fr.pose = pose.matrix ().cast<double> ();
    s.frames.push_back (std::move (fr));
  }
  return s;
}

Sequence
renderRoom (int frames)
{
  using namespace pclx::testing;
  TriangleMesh scene = makeBox (Eigen::Vector3f (0.5f, 0.5f, 0.5f), 4);
  scene.append (makeSphere (0.3f, 5, Eigen::Vector3f (0.8f, 0.2f, 0.3f)));
  TriangleMesh torus = makeTorus (0.3f, 0.1f);
  torus.transform (Eigen::Affine3f (Eigen::Translation3f (-0.6f, 0.5f, 0.1f)));
  TriangleMesh floor = makeBox (Eigen::Vector3f (5.f, 5.f, 0.05f), 8);
  floor.transform (Eigen::Affine3f (Eigen::Translation3f (0, 0, -0.28f)));
  TriangleMesh wall = makeBox (Eigen::Vector3f (5.f, 0.05f, 3.f), 8);
  wall.transform (Eigen::Affine3f (Eigen::Translation3f (0, 1.6f, 1.2f)));
  scene.append (torus); scene.append (floor); scene.append (wall);
  Sequence s;
  s.name = "room";
  s.truth = scene;
  s.has_truth = true;  // accuracy only: most of the floor and wall is never seen
  s.leaves = {0.02, 0.01};  // 5 mm over a 4 m room: millions of triangles either way
  const RayCaster caster (scene);
  PinholeIntrinsics K;
  s.K = {K.fx, K.fy, K.cx, K.cy};
  for (int i = 0; i < frames; ++i)
  {
    const float a = -2.2f + 1.6f * i / std::max (1, frames - 1);
    const Eigen::Vector3f eye (2.2f * std::cos (a), 2.2f * std::sin (a) - 0.3f, 1.1f);
    const Eigen::Isometry3f pose = lookAt (eye, Eigen::Vector3f (0, 0.3f, 0));
    const DepthImage img = renderDepth (caster, K, pose, KinectNoise (), 7 + i);
    Frame fr;
    fr.width = img.width; fr.height = img.height;
    fr.mm = img.depth_mm;
    fr.pose = pose.matrix ().cast<double> ();
    s.frames.push_back (std::move (fr));
  }
  return s;
}

Sequence
sevenScenes (const std::string& dir, std::size_t max_frames)
{
  Sequence s;
  s.name = "7scenes-office";
  s.leaves = {0.02, 0.01, 0.005};
  pclx::apps::DepthFrameFolder folder (dir);
  const auto& k = folder.intrinsics ();
  s.K = {k.fx, k.fy, k.cx, k.cy};
  for (std::size_t i = 0; i < folder.size () && s.frames.size () < max_frames; ++i)
  {
    const auto img = pclx::apps::readDepthPng (folder.framePath (i));
    Frame fr;
    fr.width = img.width; fr.height = img.height;
    fr.mm = img.mm;
    for (auto& d : fr.mm)
      if (d == 65535) d = 0;
    Eigen::Matrix4f pose;
    if (!folder.pose (i, pose))
      continue;
    fr.pose = pose.cast<double> ();
    s.frames.push_back (std::move (fr));
  }
  return s;
}

// The bunny range scans: organized 512 × 400 clouds, a virtual camera 1 m up the scan's z axis
// (as apps/idc_scan does), bun.conf poses (world = Rᵀ p + t).
Sequence
bunnyScans (const std::string& dir, const TriangleMesh& zipper, std::size_t max_frames)
{
  Sequence s;
  s.name = "bunny-scans";
  s.pinhole = false;
  s.has_truth = s.object = true;
  s.truth = zipper;
  s.leaves = {0.004, 0.002, 0.001};
  std::ifstream in (dir + "/bun.conf");
  std::string line;
  while (std::getline (in, line) && s.frames.size () < max_frames)
  {
    std::istringstream ls (line);
    std::string tag, file;
    double t[3], q[4];
    if (!(ls >> tag) || tag != "bmesh" || !(ls >> file >> t[0] >> t[1] >> t[2] >> q[0] >> q[1] >> q[2] >> q[3]))
      continue;
    pcl::PointCloud<pcl::PointXYZ> scan;
    if (pcl::io::loadPLYFile (dir + "/" + file, scan) < 0 || scan.height <= 1)
      continue;
    Eigen::Matrix4d T = Eigen::Matrix4d::Identity ();
    T.topLeftCorner<3, 3> () = Eigen::Quaterniond (q[3], q[0], q[1], q[2]).normalized ().toRotationMatrix ().transpose ();
    T.topRightCorner<3, 1> () = Eigen::Vector3d (t[0], t[1], t[2]);
    Eigen::Matrix4d C = Eigen::Matrix4d::Identity ();
    C.topLeftCorner<3, 3> () = Eigen::Vector3d (1, -1, -1).asDiagonal ();
    C (2, 3) = 1.0;
    Frame fr;
    fr.organized.reset (new pcl::PointCloud<pcl::PointXYZ>);
    pcl::transformPointCloud (scan, *fr.organized, Eigen::Matrix4f (C.inverse ().cast<float> ()), true);
    fr.organized->width = scan.width;
    fr.organized->height = scan.height;
    fr.organized->is_dense = false;
    fr.width = scan.width; fr.height = scan.height;
    fr.pose = T * C;
    s.frames.push_back (std::move (fr));
  }
  return s;
}

pcl::PointCloud<pcl::PointXYZ>::Ptr
cameraCloud (const Frame& f, const pclx::surface::DepthIntrinsics& K)
{
  if (f.organized)
    return f.organized;
  pcl::PointCloud<pcl::PointXYZ>::Ptr c (new pcl::PointCloud<pcl::PointXYZ> (f.width, f.height));
  for (int v = 0; v < f.height; ++v)
    for (int u = 0; u < f.width; ++u)
    {
      const float z = f.mm[v * f.width + u] * 0.001f;
      auto& p = (*c) (u, v);
      if (z > 0)
        p.getVector3fMap () = Eigen::Vector3f ((u - K.cx) / K.fx * z, (v - K.cy) / K.fy * z, z);
      else
        p.x = p.y = p.z = std::numeric_limits<float>::quiet_NaN ();
    }
  c->is_dense = false;
  return c;
}

struct Quality
{
  double chamfer = -1, hausdorff = -1, acc_mean = -1;
  std::size_t triangles = 0, boundary = 0, nonmanifold = 0;
};

struct Bench
{
  pclx::bench::CsvWriter& out;
  std::ofstream* frames_csv;
  std::size_t samples;
  double cell_factor, collapse_ratio, collapse_error;

  Quality
  measure (const Sequence& s, const TriangleMesh& mesh, const pclx::testing::MeshDistance* truth,
           const std::vector<Eigen::Vector3f>& truth_samples)
  {
    Quality q;
    q.triangles = mesh.faces.size ();
    if (mesh.faces.empty ())
      return q;
    const auto topo = rbf_bench::topology (mesh);
    q.boundary = topo.boundary_edges;
    q.nonmanifold = topo.nonmanifold_edges;
    if (s.has_truth && truth)
    {
      const auto e = rbf_bench::meshError (mesh, *truth, truth_samples, samples);
      q.acc_mean = e.out_to_truth_mean;
      if (s.object)
      {
        q.chamfer = e.chamfer ();
        q.hausdorff = e.hausdorff ();
      }
    }
    return q;
  }

  void
  row (const Sequence& s, const std::string& method, const std::string& params, const Quality& q,
       const std::vector<double>& frame_ms, double extract_ms, double memory_mib, pclx::bench::Metrics extra = {})
  {
    pclx::bench::Metrics m{{"frame_ms_median", percentile (frame_ms, 0.5)},
                           {"frame_ms_p95", percentile (frame_ms, 0.95)},
                           {"extract_ms", extract_ms},
                           {"triangles", double (q.triangles)},
                           {"memory_mib", memory_mib},
                           {"boundary_edges", double (q.boundary)},
                           {"nonmanifold_edges", double (q.nonmanifold)}};
    if (q.chamfer >= 0)
    {
      m.emplace_back ("chamfer", q.chamfer);
      m.emplace_back ("hausdorff", q.hausdorff);
    }
    if (q.acc_mean >= 0)
      m.emplace_back ("accuracy_mean", q.acc_mean);
    m.insert (m.end (), extra.begin (), extra.end ());
    double total = extract_ms;
    for (double x : frame_ms) total += x;
    out.row ("surface", method, params, s.name, s.frames.size (), total / 1e3, m);
  }

  void
  frameRows (const Sequence& s, const std::string& method, double leaf, const std::vector<double>& ms)
  {
    if (!frames_csv)
      return;
    for (std::size_t i = 0; i < ms.size (); ++i)
      *frames_csv << s.name << "," << method << "," << leaf << "," << i << "," << ms[i] << "\n";
  }

  // IDC: every frame through addFrame; optionally reconstruct after each frame.
  void
  idc (const Sequence& s, double leaf, double eps, bool incremental, const pclx::testing::MeshDistance* truth,
       const std::vector<Eigen::Vector3f>& truth_samples, bool frame_rows)
  {
    pcl::IncrementalDualContouring<pcl::PointXYZ> idc;
    idc.setLeafSize (leaf);
    idc.setSimplificationError (eps);
    idc.getSimplification ().setFrustumCellSize (cell_factor * leaf);
    idc.getSimplification ().setCollapseTargetRatio (collapse_ratio);
    idc.getSimplification ().setCollapseMaxError (collapse_error);
    idc.setDepthRange (0.1f, float (s.depth_trunc));  // as Open3D's depth_trunc
    std::vector<double> ms, recon_ms, frontend_ms, octree_ms;
    std::size_t failed = 0;
    pcl::PolygonMesh mesh;
    for (const auto& f : s.frames)
    {
      const auto t0 = Clock::now ();
      const bool ok = s.pinhole ? idc.addFrame (f.mm.data (), f.width, f.height, s.K, f.pose, 0.001f)
                                : idc.addFrame (*f.organized, f.pose);
      double t = msSince (t0);
      failed += !ok;
      if (ok)
      {
        frontend_ms.push_back (idc.getStats ().last_frontend_ms);
        octree_ms.push_back (idc.getStats ().last_octree_ms);
      }
      if (incremental)
      {
        const auto t1 = Clock::now ();
        idc.reconstruct (mesh);
        recon_ms.push_back (msSince (t1));
        t += recon_ms.back ();
      }
      ms.push_back (t);
    }
    double extract = 0;
    if (!incremental)
    {
      const auto t1 = Clock::now ();
      idc.reconstruct (mesh);
      extract = msSince (t1);
    }
    const auto& st = idc.getStats ();
    const Quality q = measure (s, pclx::testing::fromPolygonMesh (mesh), truth, truth_samples);
    char params[96];
    std::snprintf (params, sizeof params, "leaf=%g;eps=%g;cell=%g;collapse=%g;collapse_err=%g", leaf, eps,
                   cell_factor * leaf, collapse_ratio, collapse_error);
    row (s, incremental ? "idc_incremental" : "idc", params, q, ms, extract, st.memory_bytes / 1048576.0,
         {{"leaves", double (st.leaves)}, {"escaped_vertices", double (st.escaped_vertices)},
          {"failed_frames", double (failed)},
          {"reconstruct_ms_median", percentile (recon_ms, 0.5)},
          {"frontend_ms_median", percentile (frontend_ms, 0.5)}, {"octree_ms_median", percentile (octree_ms, 0.5)}});
    if (frame_rows)
      frameRows (s, incremental ? "idc_incremental" : "idc", leaf, ms);
  }

#ifdef PCLX_HAVE_OPEN3D
  void
  open3d (const Sequence& s, double voxel, const pclx::testing::MeshDistance* truth,
          const std::vector<Eigen::Vector3f>& truth_samples, bool frame_rows)
  {
    const double rss0 = rssMiB ();
    std::vector<double> ms;
    std::vector<Eigen::Vector3f> v;
    std::vector<Eigen::Vector3i> f;
    double extract;
    std::size_t units;
    {
      idc_open3d::Tsdf tsdf (voxel, 4 * voxel, s.depth_trunc);
      for (const auto& fr : s.frames)
        ms.push_back (1e3 * tsdf.integrate (fr.mm.data (), fr.width, fr.height, s.K.fx, s.K.fy, s.K.cx, s.K.cy, fr.pose));
      extract = 1e3 * tsdf.extract (v, f);
      units = tsdf.volumeUnits ();
    }
    const double mem = std::max (0.0, rssMiB () - rss0);
    TriangleMesh m;
    m.vertices = std::move (v);
    m.faces = std::move (f);
    const Quality q = measure (s, m, truth, truth_samples);
    char params[96];
    std::snprintf (params, sizeof params, "voxel=%g;sdf_trunc=%g", voxel, 4 * voxel);
    row (s, "open3d_scalable_tsdf", params, q, ms, extract, mem, {{"volume_units", double (units)}});
    if (frame_rows)
      frameRows (s, "open3d_scalable_tsdf", voxel, ms);
  }
#endif

  // The fused cloud: per-frame integral-image normals turned towards the camera, in world
  // coordinates, voxel-grid averaged at the leaf size.
  pcl::PointCloud<pcl::PointNormal>::Ptr
  fuse (const Sequence& s, double leaf, double& ms)
  {
    const auto t0 = Clock::now ();
    pcl::PointCloud<pcl::PointNormal>::Ptr all (new pcl::PointCloud<pcl::PointNormal>);
    for (const auto& f : s.frames)
    {
      const auto cam = cameraCloud (f, s.K);
      pcl::IntegralImageNormalEstimation<pcl::PointXYZ, pcl::Normal> ne;
      ne.setNormalEstimationMethod (ne.AVERAGE_3D_GRADIENT);
      ne.setMaxDepthChangeFactor (0.02f);
      ne.setNormalSmoothingSize (10.f);
      ne.setInputCloud (cam);
      pcl::PointCloud<pcl::Normal> n;
      ne.compute (n);
      pcl::PointCloud<pcl::PointNormal> pn;
      for (std::size_t i = 0; i < cam->size (); ++i)
      {
        const auto& p = (*cam)[i];
        Eigen::Vector3f nn = n[i].getNormalVector3fMap ();
        if (!std::isfinite (p.x) || !nn.allFinite ())
          continue;
        if (nn.dot (p.getVector3fMap ()) > 0)
          nn = -nn;
        pcl::PointNormal q;
        q.getVector3fMap () = p.getVector3fMap ();
        q.getNormalVector3fMap () = nn;
        pn.push_back (q);
      }
      pcl::PointCloud<pcl::PointNormal> w;
      pcl::transformPointCloudWithNormals (pn, w, Eigen::Matrix4f (f.pose.cast<float> ()));
      *all += w;
    }
    pcl::PointCloud<pcl::PointNormal>::Ptr down (new pcl::PointCloud<pcl::PointNormal>);
    pcl::VoxelGrid<pcl::PointNormal> vg;
    vg.setInputCloud (all);
    vg.setLeafSize (float (leaf), float (leaf), float (leaf));
    vg.filter (*down);
    for (auto& p : *down)
      p.getNormalVector3fMap ().normalize ();
    ms = msSince (t0);
    return down;
  }

  void
  pclPeers (const Sequence& s, double leaf, const pclx::testing::MeshDistance* truth,
            const std::vector<Eigen::Vector3f>& truth_samples)
  {
    double fuse_ms = 0;
    const auto cloud = fuse (s, leaf, fuse_ms);
    char params[96];
    {
      const double rss0 = rssMiB ();
      pcl::MarchingCubesHoppe<pcl::PointNormal> mc;
      pcl::search::KdTree<pcl::PointNormal>::Ptr tree (new pcl::search::KdTree<pcl::PointNormal>);
      mc.setSearchMethod (tree);
      mc.setInputCloud (cloud);
      Eigen::Vector4f lo, hi;
      pcl::getMinMax3D (*cloud, lo, hi);
      const Eigen::Vector3f ext = (hi - lo).head<3> ();
      const int rx = std::min (400, int (ext[0] / leaf) + 2), ry = std::min (400, int (ext[1] / leaf) + 2),
                rz = std::min (400, int (ext[2] / leaf) + 2);
      mc.setGridResolution (rx, ry, rz);
      mc.setIsoLevel (0.f);
      mc.setPercentageExtendGrid (0.05f);
      mc.setDistanceIgnore (float (3 * leaf));
      pcl::PolygonMesh mesh;
      const auto t0 = Clock::now ();
      mc.reconstruct (mesh);
      const double t = msSince (t0) + fuse_ms;
      const Quality q = measure (s, rbf_bench::weld (mesh, float (1e-3 * leaf)), truth, truth_samples);
      std::snprintf (params, sizeof params, "leaf=%g;grid=%dx%dx%d", leaf, rx, ry, rz);
      row (s, "pcl_marching_cubes_hoppe", params, q, {t / s.frames.size ()}, 0, std::max (0.0, rssMiB () - rss0),
           {{"fused_points", double (cloud->size ())}, {"total_ms", t}});
    }
    {
      const double rss0 = rssMiB ();
      pcl::GreedyProjectionTriangulation<pcl::PointNormal> gp3;
      pcl::search::KdTree<pcl::PointNormal>::Ptr tree (new pcl::search::KdTree<pcl::PointNormal>);
      gp3.setSearchMethod (tree);
      gp3.setInputCloud (cloud);
      gp3.setSearchRadius (3 * leaf);
      gp3.setMu (2.5);
      gp3.setMaximumNearestNeighbors (100);
      gp3.setMaximumSurfaceAngle (M_PI / 4);
      gp3.setMinimumAngle (M_PI / 18);
      gp3.setMaximumAngle (2 * M_PI / 3);
      gp3.setNormalConsistency (true);
      pcl::PolygonMesh mesh;
      const auto t0 = Clock::now ();
      gp3.reconstruct (mesh);
      const double t = msSince (t0) + fuse_ms;
      const Quality q = measure (s, pclx::testing::fromPolygonMesh (mesh), truth, truth_samples);
      std::snprintf (params, sizeof params, "leaf=%g;radius=%g", leaf, 3 * leaf);
      row (s, "pcl_greedy_projection", params, q, {t / s.frames.size ()}, 0, std::max (0.0, rssMiB () - rss0),
           {{"fused_points", double (cloud->size ())}, {"total_ms", t}});
    }
  }
};

}  // namespace

int
main (int argc, char** argv)
{
  // OpenMP threads that spin while waiting (libgomp's default) cost Open3D's Integrate 30×
  // on a shared, loaded machine (765 vs 21 ms per 7-Scenes frame at 2 cm, measured here);
  // libgomp reads the policy at load time, so set it and start again.
  if (!std::getenv ("OMP_WAIT_POLICY"))
  {
    setenv ("OMP_WAIT_POLICY", "PASSIVE", 1);
    execv ("/proc/self/exe", argv);
  }
  CLI::App app ("IncrementalDualContouring vs Open3D ScalableTSDFVolume and PCL MarchingCubesHoppe / GP3");
  std::string csv, frames_csv, only;
  bool quick = false;
  app.add_option ("--csv", csv, "also write the rows to this file");
  app.add_option ("--frames-csv", frames_csv, "per-frame times: input,method,leaf,frame,ms");
  app.add_option ("--only", only, "run only the input whose name contains this");
  app.add_flag ("--quick", quick, "small sequences, two detail levels (< 1 min)");
  double cell_factor = 2, collapse_ratio = 0, collapse_error = 0;  // CoupledSimplification's defaults
  app.add_option ("--cell-factor", cell_factor, "front-end frustum cell = factor x leaf")->capture_default_str ();
  app.add_option ("--collapse-ratio", collapse_ratio, "front-end edge-collapse target ratio")->capture_default_str ();
  app.add_option ("--collapse-error", collapse_error, "front-end collapse error bound (m; 0 auto, < 0 none)")
      ->capture_default_str ();
  CLI11_PARSE (app, argc, argv);
  pclx::bench::CsvWriter out (csv);
  std::ofstream fcsv;
  if (!frames_csv.empty ())
  {
    fcsv.open (frames_csv);
    fcsv << "input,method,leaf,frame,ms\n";
  }
  Bench bench{out, frames_csv.empty () ? nullptr : &fcsv, quick ? std::size_t (20000) : std::size_t (100000),
              cell_factor, collapse_ratio, collapse_error};

  std::vector<Sequence> seqs;
  const auto data = pclx::bench::sharedDataDir ();
  auto want = [&] (const std::string& n) { return only.empty () || n.find (only) != std::string::npos; };
  {
    TriangleMesh obj = pclx::testing::makeTorus (0.3f, 0.1f, 128, 48);
    obj.append (pclx::testing::makeSphere (0.15f, 4));
    if (want ("orbit"))
      seqs.push_back (quick ? renderOrbit ("orbit-torus-sphere", obj, 8, 1.2, 320, 240, {0.02, 0.01})
                            : renderOrbit ("orbit-torus-sphere", obj, 36, 1.2, 640, 480, {0.02, 0.01, 0.005}));
  }
  TriangleMesh zipper;
  if (data)
  {
    try
    {
      zipper = pclx::testing::loadPlyMesh (*data + "/bunny/reconstruction/bun_zipper.ply");
    }
    catch (const std::exception& e)
    {
      std::cerr << "bench_idc: " << e.what () << "\n";
    }
  }
  if (!zipper.faces.empty () && !quick && want ("bunny-mesh"))
  {
    // Scaled to 0.6 m: an object of the size a depth camera scans at 1 cm detail.
    TriangleMesh big = zipper;
    const Eigen::Vector3f c = 0.5f * (big.bboxMin () + big.bboxMax ());
    big.transform (Eigen::Affine3f (Eigen::Scaling (4.f) * Eigen::Translation3f (-c)));
    seqs.push_back (renderOrbit ("bunny-mesh-x4", big, 36, 1.3, 640, 480, {0.02, 0.01, 0.005}));
  }
  if (want ("room") && !quick)
    seqs.push_back (renderRoom (30));
  if (data && want ("7scenes"))
  {
    try
    {
      seqs.push_back (sevenScenes (*data + "/rgbd/7scenes-office", quick ? 6 : 50));
      if (quick)
        seqs.back ().leaves = {0.02};
    }
    catch (const std::exception& e)
    {
      std::cerr << "bench_idc: 7-Scenes: " << e.what () << "\n";
    }
  }
  if (data && !zipper.faces.empty () && want ("bunny-scans"))
  {
    seqs.push_back (bunnyScans (*data + "/bunny/scans", zipper, quick ? 4 : 10));
    if (quick)
      seqs.back ().leaves = {0.004};
  }

  // ε in metres: the RMS plane distance a merged cell may have (IncrementalDualContouring::setSimplificationError).
  const std::vector<double> eps_sweep =
      quick ? std::vector<double>{0.01} : std::vector<double>{0.0003, 0.001, 0.003, 0.01, 0.03, 0.1};
  for (const auto& s : seqs)
  {
    std::cerr << "bench_idc: " << s.name << ", " << s.frames.size () << " frames\n";
    std::unique_ptr<pclx::testing::MeshDistance> truth;
    std::vector<Eigen::Vector3f> truth_samples;
    if (s.has_truth)
    {
      truth = std::make_unique<pclx::testing::MeshDistance> (s.truth);
      for (const auto& p : pclx::testing::sampleUniform (s.truth, bench.samples, 3).cloud)
        truth_samples.push_back (p.getVector3fMap ());
    }
    const double mid = s.leaves[s.leaves.size () > 2 ? 1 : s.leaves.size () - 1];
    for (double leaf : s.leaves)
    {
      bench.idc (s, leaf, 0, false, truth.get (), truth_samples, true);
#ifdef PCLX_HAVE_OPEN3D
      if (s.pinhole)
        bench.open3d (s, leaf, truth.get (), truth_samples, true);
#endif
    }
    // The adaptive part: ε at the middle detail, and the per-frame incremental mesh.
    for (double eps : eps_sweep)
      bench.idc (s, mid, eps, false, truth.get (), truth_samples, false);
    bench.idc (s, mid, 0, true, truth.get (), truth_samples, true);
    if (s.object && (!quick || s.name.find ("orbit") != std::string::npos))
      bench.pclPeers (s, mid, truth.get (), truth_samples);
  }
  return 0;
}
