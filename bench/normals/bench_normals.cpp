// Normal estimation benchmark. Rows (module=normals):
//   estimation: ours_octree / ours_hybrid / ours_merged (default: with patches) / ours_merged_nopatch
//     (setPatchSize (0): every point off a used region goes to the adaptive kNN PCA),
//     pcl_omp_k18 / pcl_omp_k<K>, open3d_k18
//     metrics rms, mean, min, max (unoriented angle error, degrees), below5, below10 (shares)
//   orientation: orient_mst_<normals> (ours), orient_open3d (OrientNormalsConsistentTangentPlane)
//     metrics flipped (share against the outward truth of closed generated shapes)
// params: sweep=<main|noise|shadow|density|speed>;noise=<σ/diag>;shadow=<%>;min_ratio=<r>
// PCPNet ground truth is unoriented: it only gets estimation rows.
// --wide / --speed / --quick: the wide protocol instead (wide.cpp).
#include "bench_csv.h"
#include "normals_bench_util.h"
#include "wide.h"
#ifdef PCLX_HAVE_OPEN3D
#include "open3d_peer.h"
#endif

#include <pclx/normals/mst_normal_orientation.h>
#include <pclx/normals/normal_error.h>
#include <pclx/normals/planar_octree_normal_estimation.h>
#include <pclx/testing/degradation.h>
#include <pclx/testing/mesh_sampling.h>
#include <pclx/testing/shapes.h>

#include <pcl/common/io.h>
#include <pcl/features/normal_3d_omp.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <fstream>
#include <omp.h>
#include <sstream>

using namespace pclx::testing;
using pclx::bench::CsvWriter;
using pclx::bench::Metrics;
using pclx::bench::timeBest;
using pclx::bench::errorMetrics;
using pclx::bench::fmt;
using pclx::bench::loadPcpnet;
using Estimator = pcl::PlanarOctreeNormalEstimation<pcl::PointXYZ, pcl::Normal>;

namespace {

struct Options
{
  bool full = false;
  int threads = 0;
  int repeats = 1;
  int k_large = 50;
  std::size_t n_generated = 30000, n_speed = 200000, o3d_orient_max = 30000;
  bool open3d = true;
};

struct Case
{
  std::string input, params;
  SampledCloud s;
  bool oriented;  // truth normals are oriented (closed generated shapes)
};

void
run (const Case& c, const Options& opt, CsvWriter& out, bool orient)
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud (new pcl::PointCloud<pcl::PointXYZ>);
  pcl::copyPointCloud (c.s.cloud, *cloud);
  const std::size_t n = cloud->size ();
  const auto& truth = c.s.cloud;
  const int threads = opt.threads > 0 ? opt.threads : omp_get_max_threads ();

  pcl::PointCloud<pcl::Normal> merged;
  for (auto [name, method] : {std::pair{"ours_octree", Estimator::Method::OCTREE},
                              std::pair{"ours_hybrid", Estimator::Method::HYBRID},
                              std::pair{"ours_merged", Estimator::Method::MERGED},
                              std::pair{"ours_merged_nopatch", Estimator::Method::MERGED}})
  {
    Estimator ne;
    ne.setInputCloud (cloud);
    ne.setMethod (method);
    ne.setNumberOfThreads (threads);
    if (std::string (name) == "ours_merged_nopatch")
    {
      ne.setPatchSize (0);
      ne.setRegionValidationRatio (0.5);  // the kNN-thickness validation's own default
    }
    pcl::PointCloud<pcl::Normal> normals;
    const double t = timeBest ([&] { ne.compute (normals); }, opt.repeats);
    Metrics m = errorMetrics (pcl::compareNormals (normals, truth));
    m.emplace_back ("planar_leaves", ne.getOctree ().numPlanarLeaves ());
    m.emplace_back ("regions", ne.getOctree ().regions ().size ());
    // Share of points whose normal needed no kNN search (patch or region surface).
    const auto& st = ne.getPointStatus ();
    m.emplace_back ("no_knn", st.empty () ? 0.0
                                          : double (std::count_if (st.begin (), st.end (), [] (std::uint8_t v) {
                                              return v == Estimator::PATCH_FIT || v == Estimator::REGION_FIT ||
                                                     v == Estimator::LEAF_PLANE;
                                            })) / st.size ());
    out.row ("normals", name, c.params, c.input, n, t, m);
    if (std::string (name) == "ours_merged")
      merged = normals;
  }
  pcl::PointCloud<pcl::Normal> pca18;
  for (int k : {18, opt.k_large})
  {
    pcl::NormalEstimationOMP<pcl::PointXYZ, pcl::Normal> ne (threads);
    ne.setInputCloud (cloud);
    ne.setKSearch (k);
    pcl::PointCloud<pcl::Normal> normals;
    const double t = timeBest ([&] { ne.compute (normals); }, opt.repeats);
    out.row ("normals", "pcl_omp_k" + std::to_string (k), c.params, c.input, n, t,
             errorMetrics (pcl::compareNormals (normals, truth)));
    if (k == 18)
      pca18 = normals;
  }
#ifdef PCLX_HAVE_OPEN3D
  std::vector<Eigen::Vector3d> o3d_points (n), o3d_normals;
  for (std::size_t i = 0; i < n; ++i)
    o3d_points[i] = (*cloud)[i].getVector3fMap ().cast<double> ();
  if (opt.open3d)
  {
    double t = 1e300;
    for (int r = 0; r < opt.repeats; ++r)
      t = std::min (t, open3d_peer::estimateNormals (o3d_points, 18, o3d_normals));
    pcl::PointCloud<pcl::Normal> normals (n, 1);
    for (std::size_t i = 0; i < n; ++i)
      normals[i].getNormalVector3fMap () = o3d_normals[i].cast<float> ();
    out.row ("normals", "open3d_k18", c.params, c.input, n, t,
             errorMetrics (pcl::compareNormals (normals, truth)));
  }
#endif
  if (!orient || !c.oriented)
    return;
  // Orientation, judged against the outward truth of closed shapes.
  for (auto& [name, normals] : {std::pair{std::string ("orient_mst_ours_merged"), merged},
                                std::pair{std::string ("orient_mst_pcl_k18"), pca18}})
  {
    pcl::PointCloud<pcl::Normal> oriented;
    pcl::MSTNormalOrientation<pcl::PointXYZ, pcl::Normal> mst;
    mst.setInputCloud (cloud);
    mst.setKSearch (10);
    mst.setNumberOfThreads (threads);
    const double t = timeBest ([&] { oriented = normals; mst.orient (oriented); }, opt.repeats);
    const auto e = pcl::compareNormals (oriented, truth, true);
    out.row ("normals", name, c.params + ";k=10", c.input, n, t,
             {{"flipped", e.flipped}, {"rms_oriented", e.rms_deg}, {"components", double (mst.getNumberOfComponents ())}});
  }
#ifdef PCLX_HAVE_OPEN3D
  if (opt.open3d && n <= opt.o3d_orient_max)
  {
    const double t = open3d_peer::orientConsistent (o3d_points, o3d_normals, 10);
    pcl::PointCloud<pcl::Normal> normals (n, 1);
    for (std::size_t i = 0; i < n; ++i)
      normals[i].getNormalVector3fMap () = o3d_normals[i].cast<float> ();
    const auto e = pcl::compareNormals (normals, truth, true);
    out.row ("normals", "orient_open3d", c.params + ";k=10", c.input, n, t,
             {{"flipped", e.flipped}, {"rms_oriented", e.rms_deg}});
  }
#endif
}

}  // namespace

int
main (int argc, char** argv)
{
  CLI::App app ("pclx normal estimation benchmark (ours vs PCL NormalEstimationOMP vs Open3D)");
  Options opt;
  std::string csv;
  app.add_option ("--csv", csv, "also write the CSV rows to this file");
  app.add_flag ("--full", opt.full, "full run: all sweeps, 100k generated points, 1M speed rows (minutes)");
  app.add_option ("--threads", opt.threads, "threads for every method (0: OpenMP default)");
  app.add_option ("--k-large", opt.k_large, "the larger k of the PCL peer")->capture_default_str ();
  app.add_flag ("!--no-open3d", opt.open3d, "skip the Open3D peer");
  pclx::bench::WideOptions wide;
  app.add_flag ("--wide", wide.wide,
                "the wide protocol: 7 shapes x 4 noise levels, ours vs PCA k sweep (+oracle), CGAL jet/VCM, "
                "Open3D, MST orientation; then the speed sweep (tens of minutes)");
  app.add_flag ("--speed", wide.speed, "the speed sweep only: ours vs PCL k=18 at 100k/300k/1M, noisy vs oracle-k PCA");
  app.add_flag ("--quick", wide.quick, "the wide protocol and speed sweep on small generated shapes (seconds; CTest)");
  app.add_flag ("--orient", wide.orient,
                "orientation only, on the wide set's shapes with oriented truth (fertility, cube, grooved slab) at 4 "
                "noise levels: MST on our, PCA k=18 and exact normals, Open3D's orientation of ours (minutes)");
  std::string data;
  app.add_option ("--data", data, "shared data folder for --wide/--speed (default: ../shared/data beside the checkout)");
  app.add_option ("--shapes", wide.shapes,
                  "--wide/--speed: only these shapes (fertility bunny_mesh bunny100k fandisk100k 151A_100k_0 cube "
                  "grooved_slab)");
  app.add_option ("--peers", wide.peers, "--wide: all, or pca (ours and the PCA sweep only)")
      ->check (CLI::IsMember ({"all", "pca"}))
      ->capture_default_str ();
  app.add_flag ("!--no-cgal", wide.cgal, "--wide: skip the CGAL jet / VCM peers");
  bool no_speed = false;
  app.add_flag ("--no-speed", no_speed, "--wide: skip the speed sweep");
  app.add_option ("--speed-repeats", wide.speed_repeats, "speed sweep: best of this many calls (wall and CPU time)")
      ->check (CLI::PositiveNumber)
      ->capture_default_str ();
  app.add_option ("--speed-sizes", wide.speed_sizes, "speed sweep: only these clean sizes (default 100000 300000 1000000)")
      ->check (CLI::PositiveNumber);
  bool no_speed_noisy = false;
  app.add_flag ("--no-speed-noisy", no_speed_noisy, "speed sweep: skip the noisy rows against oracle-k PCA");
  app.add_option ("--dump", wide.dump, "--wide: write each shape's clean sample as <dir>/<shape>.ply (to look at)");
  bool verbose = false;
  app.add_flag ("--verbose", verbose, "progress lines on stderr");
  CLI11_PARSE (app, argc, argv);
  pclx::bench::setVerbose (verbose);
  if (wide.wide || wide.speed || wide.quick || wide.orient)
  {
    // --wide includes the speed sweep (unless --no-speed); --speed alone runs only that.
    if (wide.quick || wide.wide)
    {
      wide.wide = true;
      wide.speed = !no_speed;
    }
    wide.threads = opt.threads > 0 ? opt.threads : 2;
    wide.speed_noisy = !no_speed_noisy;
    wide.open3d = opt.open3d;
    if (!wide.quick)
    {
      if (data.empty ())
      {
        if (auto d = pclx::bench::sharedDataDir ())
          data = *d;
      }
      wide.data = data;
    }
    CsvWriter out (csv);
    return pclx::bench::runWide (wide, out);
  }
  if (opt.full)
  {
    opt.n_generated = 100000;
    opt.n_speed = 1000000;
    opt.o3d_orient_max = 100000;
    opt.repeats = 2;
  }
#ifndef PCLX_HAVE_OPEN3D
  std::cerr << "[bench_normals] built without Open3D: no Open3D rows\n";
#endif
  CsvWriter out (csv);

  // Closed generated shapes (oriented truth) and PCPNet shapes (unoriented truth).
  std::vector<std::pair<std::string, TriangleMesh>> meshes{
      {"sphere", makeSphere (1.f, 6)},
      {"torus", makeTorus (1.f, 0.3f, 256, 96)},
      {"box", makeBox (Eigen::Vector3f (1.f, 0.6f, 0.4f), 16)},
      {"thin_plate", makeThinPlate (1.f, 0.02f, 32)}};
  std::vector<std::pair<std::string, SampledCloud>> pcpnet;
  if (auto data = pclx::bench::sharedDataDir ())
    for (const char* name : {"bunny100k", "fandisk100k"})
    {
      SampledCloud s;
      if (loadPcpnet (*data + "/pcpnet/" + name, s))
        pcpnet.emplace_back (name, std::move (s));
    }

  // main: every input, clean.
  for (const auto& [name, mesh] : meshes)
    run ({name, "sweep=main;noise=0;shadow=0", sampleUniform (mesh, opt.n_generated, 1), true}, opt, out, true);
  for (const auto& [name, s] : pcpnet)
    run ({name, "sweep=main;noise=0;shadow=0", s, false}, opt, out, false);

  // noise: σ as a fraction of the bounding-box diagonal.
  const std::vector<float> sigmas{0.f, 0.0012f, 0.006f, 0.012f};
  std::vector<std::pair<std::string, SampledCloud>> noise_inputs;
  if (!pcpnet.empty ())
    noise_inputs.push_back (pcpnet.front ());
  if (opt.full || pcpnet.empty ())
    noise_inputs.emplace_back ("torus", sampleUniform (meshes[1].second, opt.n_generated, 2));
  if (opt.full && pcpnet.size () > 1)
    noise_inputs.push_back (pcpnet[1]);
  for (const auto& [name, clean] : noise_inputs)
    for (float sigma : sigmas)
    {
      SampledCloud s = clean;
      if (sigma > 0)
        addGaussianNoise (s, sigma, 5);
      run ({name, "sweep=noise;noise=" + fmt (sigma) + ";shadow=0", s, name == "torus"}, opt, out, name == "torus");
    }

  // shadow (Musmanno 2016 §6.2.1): holes removing a share of the surface.
  const std::vector<int> shadows = opt.full ? std::vector<int>{0, 1, 2, 5, 10, 20, 25, 30, 50, 75}
                                            : std::vector<int>{0, 30};
  std::vector<std::pair<std::string, SampledCloud>> shadow_inputs;
  if (!pcpnet.empty ())
    shadow_inputs.push_back (pcpnet.front ());
  if (opt.full || pcpnet.empty ())
    shadow_inputs.emplace_back ("sphere", sampleUniform (meshes[0].second, opt.n_generated, 3));
  for (const auto& [name, clean] : shadow_inputs)
    for (int pct : shadows)
    {
      SampledCloud s = clean;
      if (pct > 0)
        applyShadowHoles (s, pct / 100.f, 7);
      run ({name, "sweep=shadow;noise=0;shadow=" + std::to_string (pct), s, name == "sphere"}, opt, out, false);
    }

  // density gradient along x: min/max density ratio.
  const std::vector<float> ratios = opt.full ? std::vector<float>{1.f, 0.3f, 0.1f, 0.03f} : std::vector<float>{0.1f};
  for (float r : ratios)
    run ({"torus", "sweep=density;min_ratio=" + fmt (r), sampleDensityGradient (meshes[1].second, opt.n_generated, 0, r, 4),
          true},
         opt, out, false);

  // speed: many points (1M in the full run), a smooth and a sharp-edged shape; Open3D's
  // orientation is left out there (it takes minutes).
  for (int m : {1, 2})
    run ({meshes[m].first, "sweep=speed;noise=0;shadow=0", sampleUniform (meshes[m].second, opt.n_speed, 6), true}, opt,
         out, true);
  return 0;
}
