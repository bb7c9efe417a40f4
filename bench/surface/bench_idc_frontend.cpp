// bench_idc_frontend: the front end of incremental dual contouring (da Paz 2017 §3.2–3.3,
// pcl::CoupledSimplification) per 640 × 480 frame, stage by stage, against
// pcl::OrganizedFastMesh (PCL's connected cloud of an organized cloud) on the same frames:
// the 50 7-Scenes frames (when ../shared/data exists) and frames rendered from generated
// scenes with Kinect-like noise.
#include <bench_csv.h>
#include <pclx/surface/coupled_simplification.h>
#include <pclx/testing/depth_renderer.h>
#include <pclx/testing/shapes.h>

#include <pcl/surface/organized_fast_mesh.h>

#include <CLI/CLI.hpp>
#include <pclx/apps/depth_frames.h>

#include <algorithm>
#include <ctime>
#include <cstdlib>
#include <unistd.h>
#include <cstdio>
#include <filesystem>
#include <fstream>

namespace {

using pclx::bench::percentile;

// CPU time of this thread (ms): on a shared, loaded machine wall time mostly measures the
// other processes; with one thread the CPU time is what the stage costs.
double
threadCpuMs ()
{
  timespec ts;
  clock_gettime (CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

struct Frame
{
  std::string name;
  int width = 0, height = 0;
  std::vector<float> depth;  // metres
  pcl::DepthIntrinsics K;
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity ();
};

std::vector<Frame>
sevenScenes (const std::string& dir, std::size_t max_frames)
{
  std::vector<Frame> frames;
  try
  {
    // pclx_appkit's 7-Scenes reader (libpng, 16-bit grey checked).
    pclx::apps::DepthFrameFolder folder (dir);
    const auto& k = folder.intrinsics ();
    for (std::size_t i = 0; i < folder.size () && frames.size () < max_frames; ++i)
    {
      const pclx::apps::DepthImage16 img = pclx::apps::readDepthPng (folder.framePath (i));
      Frame f;
      f.name = std::filesystem::path (folder.framePath (i)).filename ().string ();
      f.width = img.width; f.height = img.height;
      f.K = {k.fx, k.fy, k.cx, k.cy};
      f.depth.resize (img.mm.size ());
      for (std::size_t p = 0; p < img.mm.size (); ++p)
        f.depth[p] = (img.mm[p] == 0 || img.mm[p] == 65535) ? 0.f : img.mm[p] * 0.001f;
      Eigen::Matrix4f pose;
      if (folder.pose (i, pose))
        f.pose = pose.cast<double> ();
      frames.push_back (std::move (f));
    }
  }
  catch (const std::exception& e)
  {
    std::cerr << "bench_idc_frontend: " << dir << ": " << e.what () << "\n";
  }
  return frames;
}

std::vector<Frame>
rendered (std::size_t count, int width, int height)
{
  using namespace pclx::testing;
  // A room corner with a box, a sphere and a torus: walls, edges and curved objects.
  TriangleMesh scene = makeBox (Eigen::Vector3f (0.5f, 0.5f, 0.5f), 4);
  TriangleMesh sphere = makeSphere (0.3f, 5, Eigen::Vector3f (0.8f, 0.2f, 0.3f));
  TriangleMesh torus = makeTorus (0.3f, 0.1f);
  torus.transform (Eigen::Affine3f (Eigen::Translation3f (-0.6f, 0.5f, 0.1f)));
  TriangleMesh floor = makeBox (Eigen::Vector3f (5.f, 5.f, 0.05f), 8);
  floor.transform (Eigen::Affine3f (Eigen::Translation3f (0, 0, -0.28f)));
  TriangleMesh wall = makeBox (Eigen::Vector3f (5.f, 0.05f, 3.f), 8);
  wall.transform (Eigen::Affine3f (Eigen::Translation3f (0, 1.6f, 1.2f)));
  scene.append (sphere); scene.append (torus); scene.append (floor); scene.append (wall);
  const RayCaster caster (scene);
  PinholeIntrinsics K;  // the Kinect's field of view at the requested size
  K.width = width;
  K.height = height;
  K.fx = K.fy = 525.f * width / 640.f;
  K.cx = (width - 1) / 2.f;
  K.cy = (height - 1) / 2.f;
  std::vector<Frame> frames;
  for (std::size_t i = 0; i < count; ++i)
  {
    const float a = -2.2f + 0.06f * i;
    const Eigen::Vector3f eye (2.2f * std::cos (a), 2.2f * std::sin (a) - 0.3f, 1.1f);
    const Eigen::Isometry3f pose = lookAt (eye, Eigen::Vector3f (0, 0.3f, 0));
    const DepthImage img = renderDepth (caster, K, pose, KinectNoise (), 7 + i);
    Frame f;
    f.name = "rendered-" + std::to_string (i);
    f.width = img.width; f.height = img.height;
    f.K = {K.fx, K.fy, K.cx, K.cy};
    f.pose = pose.matrix ().cast<double> ();
    f.depth.resize (img.depth_mm.size ());
    for (std::size_t p = 0; p < f.depth.size (); ++p)
      f.depth[p] = img.depth_mm[p] * 0.001f;
    frames.push_back (std::move (f));
  }
  return frames;
}

}  // namespace

int
main (int argc, char** argv)
{
  pclx::bench::passiveOpenMpWaits (argv);
  CLI::App app ("IDC front end (CoupledSimplification) per frame vs pcl::OrganizedFastMesh");
  std::string csv;
  bool quick = false;
  int cell = 0;
  double cell_size = 0.02;
  int min_cell_pixels = pcl::CoupledSimplification ().getMinCellPixels ();
  app.add_option ("--csv", csv, "also write the rows to this file");
  app.add_flag ("--quick", quick, "10 frames of each input");
  app.add_option ("--cell-pixels", cell, "fixed frustum cell side in pixels (0: from --cell-size)")->capture_default_str ();
  app.add_option ("--cell-size", cell_size, "frustum cell side in metres (2 x the 1 cm leaf)")->capture_default_str ();
  app.add_option ("--min-cell-pixels", min_cell_pixels,
                  "fewest pixels per cell side before 2 x 2 block averaging (0: full resolution)")
      ->capture_default_str ();
  CLI11_PARSE (app, argc, argv);
  pclx::bench::CsvWriter out (csv);
  std::vector<std::pair<std::string, std::vector<Frame>>> inputs;
  if (const auto data = pclx::bench::sharedDataDir ())
  {
    auto f = sevenScenes (*data + "/rgbd/7scenes-office", quick ? 10 : 50);
    if (!f.empty ())
      inputs.emplace_back ("7scenes-office", std::move (f));
  }
  inputs.emplace_back ("rendered-room", rendered (quick ? 10 : 30, 640, 480));
  inputs.emplace_back ("rendered-room-1200x680", rendered (quick ? 10 : 30, 1200, 680));

  for (const auto& [input, frames] : inputs)
  {
    pcl::CoupledSimplification cs;
    cs.setMinCellPixels (min_cell_pixels);
    if (cell > 0)
      cs.setFrustumCellPixels (cell);
    else
      cs.setFrustumCellSize (cell_size);
    std::vector<double> back, spac, conn, clus, coll, outp, total, dense_total, ofm, cpu, ofm_cpu;
    double tris_in = 0, tris_out = 0, clustered = 0, block = 0;
    for (const auto& f : frames)
    {
      pcl::FrameMesh m;
      const double c0 = threadCpuMs ();
      if (!cs.compute (f.depth.data (), f.width, f.height, f.K, f.pose, m))
        continue;
      cpu.push_back (threadCpuMs () - c0);
      const auto& s = cs.getStats ();
      back.push_back (s.t_backproject); spac.push_back (s.t_spacing); conn.push_back (s.t_connect);
      clus.push_back (s.t_cluster); coll.push_back (s.t_collapse); outp.push_back (s.t_output);
      total.push_back (s.t_total);
      block += s.cell_pixels;
      tris_in += s.dense_triangles; clustered += s.clustered_triangles; tris_out += s.triangles;
      // §3.2 alone (dense connected cloud with quadrics) and PCL's OrganizedFastMesh.
      pcl::CoupledSimplification dense;
      if (dense.computeConnectedCloud (f.depth.data (), f.width, f.height, f.K, f.pose, m))
        dense_total.push_back (dense.getStats ().t_total);
      pcl::PointCloud<pcl::PointXYZ>::Ptr cloud (new pcl::PointCloud<pcl::PointXYZ> (f.width, f.height));
      for (int v = 0; v < f.height; ++v)
        for (int u = 0; u < f.width; ++u)
        {
          const float z = f.depth[v * f.width + u];
          auto& p = (*cloud) (u, v);
          if (z > 0)
            p.getVector3fMap () = Eigen::Vector3f ((u - f.K.cx) / f.K.fx * z, (v - f.K.cy) / f.K.fy * z, z);
          else
            p.x = p.y = p.z = std::numeric_limits<float>::quiet_NaN ();
        }
      cloud->is_dense = false;
      pcl::OrganizedFastMesh<pcl::PointXYZ> fm;
      fm.setInputCloud (cloud);
      fm.setTriangulationType (pcl::OrganizedFastMesh<pcl::PointXYZ>::TRIANGLE_ADAPTIVE_CUT);
      fm.setMaxEdgeLength (0, 0, 0.03);  // depth-scaled, as our threshold
      std::vector<pcl::Vertices> polys;
      const double c1 = threadCpuMs ();
      ofm.push_back (1e3 * pclx::bench::timeBest ([&] { fm.reconstruct (polys); }));
      ofm_cpu.push_back (threadCpuMs () - c1);
    }
    const double n = std::max<std::size_t> (1, total.size ());
    auto row = [&] (const std::string& method, const std::vector<double>& v, const pclx::bench::Metrics& extra) {
      pclx::bench::Metrics m{{"ms_median", percentile (v, 0.5)}, {"ms_p95", percentile (v, 0.95)}};
      m.insert (m.end (), extra.begin (), extra.end ());
      const std::string params = (cell > 0 ? "cell_pixels=" + std::to_string (cell) : "cell_size=" + std::to_string (cell_size)) +
                               ";min_cell_pixels=" + std::to_string (min_cell_pixels);
      out.row ("surface", method, params, input, frames.empty () ? 0 : frames[0].depth.size (),
               percentile (v, 0.5) / 1e3, m);
    };
    row ("idc_frontend_total", total, {{"dense_triangles", tris_in / n}, {"clustered_triangles", clustered / n},
                                       {"triangles", tris_out / n}, {"cell_pixels", block / n}});
    row ("idc_frontend_total_cpu", cpu, {});
    row ("pcl_organized_fast_mesh_cpu", ofm_cpu, {});
    row ("idc_frontend_backproject", back, {});
    row ("idc_frontend_spacing_noise", spac, {});
    row ("idc_frontend_cluster", clus, {});
    row ("idc_frontend_connect_quadrics", conn, {});
    row ("idc_frontend_collapse", coll, {});
    row ("idc_frontend_output", outp, {});
    row ("idc_connected_cloud_dense", dense_total, {});
    row ("pcl_organized_fast_mesh", ofm, {});
  }
  return 0;
}
