// rbf_reconstruct: a closed mesh from a point cloud (PCD / PLY / XYZ) with
// RBFPOUReconstruction (RBF partition of unity, Musmanno 2016 ch. 4). Points without normals get
// PlanarOctreeNormalEstimation + MST orientation first. Writes a binary PLY; --view shows it,
// --screenshot renders it off-screen to a PNG.
#include <pclx/apps/cloud_loader.h>
#include <pclx/apps/mesh_stats.h>
#include <pclx/apps/process_stats.h>
#include <pclx/apps/progress.h>
#include <pclx/apps/view.h>
#include <pclx/normals/mst_normal_orientation.h>
#include <pclx/normals/planar_octree_normal_estimation.h>
#include <pclx/surface/rbf_pou_reconstruction.h>
#include <pclx/testing/mesh_sampling.h>
#include <pclx/testing/shapes.h>

#include <pcl/common/io.h>
#include <pcl/io/ply_io.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>

using CloudN = pcl::PointCloud<pcl::PointNormal>;

using pclx::apps::secondsSince;

int
main (int argc, char** argv)
{
  CLI::App app ("Surface reconstruction with RBFPOUReconstruction (RBF partition of unity); PCD/PLY/XYZ in, PLY out");
  std::string input, output, demo, decay = "linear", screenshot;
  int points = 20000, t_max = 150, t_min = 50, band = 3, threads = 0;
  double overlap = 1.5, grid = 0, max_hole = -1;
  bool orient = false, view = false;
  auto* in_opt = app.add_option ("input,-i,--input", input, "PCD, PLY or XYZ (text) file; normals are used if present");
  app.add_option ("--demo", demo, "instead of a file: a sampled shape with exact normals")
      ->check (CLI::IsMember ({"sphere", "torus"}))
      ->excludes (in_opt);
  app.add_option ("--points", points, "--demo: number of points")->capture_default_str ();
  app.add_option ("-o,--output", output, "write the mesh as binary PLY");
  app.add_option ("--tmax", t_max, "max constraints per subdomain (3 per input point)")->capture_default_str ();
  app.add_option ("--tmin", t_min, "min constraints per subdomain (>= 10)")->capture_default_str ();
  app.add_option ("--overlap", overlap, "subdomain overlap factor d (> 1)")->capture_default_str ();
  app.add_option ("--grid", grid, "marching-cubes cell size (0: 1.5 x mean point spacing)")->capture_default_str ();
  app.add_option ("--band", band, "polygonised cells around the points (>= 1)")->capture_default_str ();
  app.add_option ("--max-hole", max_hole,
                  "close holes up to this size (0: none; default: scans only, up to 1/4 of the bounding-box diagonal)");
  app.add_option ("--decay", decay, "weight decay: linear (seed) or cubic (Tobor et al., smooth)")
      ->check (CLI::IsMember ({"linear", "cubic"}))
      ->capture_default_str ();
  app.add_flag ("--orient", orient, "orient the file's normals with MST first (for unoriented normals)");
  app.add_option ("--threads", threads, "0: OpenMP default");
  app.add_flag ("--view", view, "show the mesh (VTK)");
  app.add_option ("--screenshot", screenshot, "render the mesh off-screen to this PNG and exit (implies --view)");
  CLI11_PARSE (app, argc, argv);
  if (input.empty () && demo.empty ())
  {
    std::cerr << "rbf_reconstruct: give an input file or --demo (see --help)\n";
    return 2;
  }
  if (points <= 0)
  {
    std::cerr << "rbf_reconstruct: --points must be positive\n";
    return 2;
  }

  // Input: a sampled demo shape (true, outward normals) or a checked file.
  CloudN::Ptr cloud (new CloudN);
  bool has_normals = false;
  if (!demo.empty ())
  {
    using namespace pclx::testing;
    const TriangleMesh mesh = demo == "sphere" ? makeSphere (1.f, 6) : makeTorus (1.f, 0.3f, 256, 96);
    *cloud = sampleUniform (mesh, static_cast<std::size_t> (points), 1).cloud;
    has_normals = true;
    std::cout << "demo " << demo << ": " << cloud->size () << " points with true normals\n";
  }
  else
  {
    try
    {
      pclx::apps::CloudInfo info;
      cloud = pclx::apps::loadCloud<pcl::PointNormal> (input, &info);
      pclx::apps::requireFinitePoints (info);
      has_normals = info.fields.normals;
      std::cout << info.summary () << "\n";
    }
    catch (const pclx::apps::LoadError& e)
    {
      std::cerr << "rbf_reconstruct: " << e.what () << "\n";
      return 1;
    }
  }

  // No normals in the file: estimate and orient them here (the reconstruction needs
  // consistently oriented normals; MST's +z root makes closed shapes point outwards).
  if (!has_normals)
  {
    auto xyz = pclx::testing::positions (*cloud);
    pcl::PointCloud<pcl::Normal> normals;
    const auto t0 = std::chrono::steady_clock::now ();
    {
      pclx::apps::Progress estimating ("estimating normals");
      pcl::PlanarOctreeNormalEstimation<pcl::PointXYZ, pcl::Normal> ne;
      ne.setInputCloud (xyz);
      ne.setNumberOfThreads (static_cast<unsigned> (threads));
      ne.compute (normals);
    }
    if (normals.size () != xyz->size ())
    {
      std::cerr << "rbf_reconstruct: normal estimation failed\n";
      return 1;
    }
    const double t_est = secondsSince (t0);
    const auto t1 = std::chrono::steady_clock::now ();
    pcl::MSTNormalOrientation<pcl::PointXYZ, pcl::Normal> mst;
    {
      pclx::apps::Progress orienting ("orienting normals (MST)");
      mst.setInputCloud (xyz);
      mst.setNumberOfThreads (static_cast<unsigned> (threads));
      if (!mst.orient (normals))
      {
        std::cerr << "rbf_reconstruct: normal orientation failed\n";
        return 1;
      }
    }
    std::printf ("no normals in the input: estimated them (PlanarOctreeNormalEstimation, %.3f s) and oriented "
                 "them (MST, %.3f s, %zu components, %zu flipped)\n",
                 t_est, secondsSince (t1), mst.getNumberOfComponents (), mst.getNumberOfFlipped ());
    pcl::concatenateFields (*xyz, normals, *cloud);
    orient = false;  // already oriented
  }

  else if (demo.empty () && !orient)
  {
    // Consistently oriented normals are flipped by MST either nowhere or everywhere (its root
    // points to +z); anything between means the file's normals are unoriented.
    auto xyz = pclx::testing::positions (*cloud);
    pcl::PointCloud<pcl::Normal> normals;
    pcl::copyPointCloud (*cloud, normals);
    pcl::MSTNormalOrientation<pcl::PointXYZ, pcl::Normal> mst;
    mst.setInputCloud (xyz);
    mst.setNumberOfThreads (static_cast<unsigned> (threads));
    if (mst.orient (normals))
    {
      const std::size_t f = mst.getNumberOfFlipped ();
      const double share = double (std::min (f, cloud->size () - f)) / double (cloud->size ());
      std::printf ("file normals: %s (MST would flip %.1f %% against the majority)\n",
                   share > 0.02 ? "they look unoriented, pass --orient" : "they look oriented", 100 * share);
    }
  }

  pcl::RBFPOUReconstruction<pcl::PointNormal> rbf;
  rbf.setInputCloud (cloud);
  rbf.setMaxPointsPerSubdomain (t_max);
  rbf.setMinPointsPerSubdomain (t_min);
  rbf.setOverlap (overlap);
  if (grid > 0)
    rbf.setGridResolution (grid);
  rbf.setBandWidth (band);
  if (max_hole >= 0)
    rbf.setMaxHoleSize (max_hole);
  rbf.setDecay (decay == "cubic" ? pcl::RBFPOUReconstruction<pcl::PointNormal>::Decay::CUBIC
                                 : pcl::RBFPOUReconstruction<pcl::PointNormal>::Decay::LINEAR);
  rbf.setOrientNormals (orient);
  rbf.setNumberOfThreads (static_cast<unsigned> (threads));
  pcl::PolygonMesh mesh;
  const auto t0 = std::chrono::steady_clock::now ();
  {
    pclx::apps::Progress reconstructing ("reconstructing");
    rbf.reconstruct (mesh);
  }
  const double t_total = secondsSince (t0);
  if (mesh.polygons.empty ())
  {
    std::cerr << "rbf_reconstruct: "
              << (rbf.getLastError ().empty () ? std::string ("no surface extracted") : rbf.getLastError ()) << "\n";
    return 1;
  }

  const auto& s = rbf.getStats ();
  std::printf ("points: %zu in, %zu dropped, %zu zero normals; mean spacing %.4g, grid %.4g, epsilon %.4g\n",
               s.input_points, s.dropped_points, s.zero_normals, s.mean_spacing, s.grid_resolution, s.epsilon);
  if (orient)
    std::printf ("normals: %zu flipped by MST, %zu by the neighbour vote\n", s.normals_oriented, s.normals_voted);
  std::printf ("off-surface: %zu points, %zu epsilon halvings, %zu left out\n", s.off_surface_points, s.eps_halved,
               s.off_surface_dropped);
  std::printf ("subdomains: %zu (%zu grown, %zu over Tmax), %zu fit fallbacks\n", s.subdomains, s.grown, s.over_tmax,
               s.fit_fallbacks);
  std::printf ("grid: %zu active cells, %zu corners (%zu uncovered)\n", s.active_cells, s.corners,
               s.uncovered_corners);
  std::printf ("holes: density spread %.2f, %zu of %zu closed (up to %.4g across), %zu triangles added\n",
               s.density_spread, s.holes_filled, s.holes, s.max_hole_size, s.hole_triangles);
  std::size_t boundary = 0, non_manifold = 0;
  pclx::apps::countOpenEdges (mesh, boundary, non_manifold);
  std::printf ("mesh: %zu vertices, %zu triangles; %zu edges used once, %zu used > 2 times%s\n", s.vertices,
               s.triangles, boundary, non_manifold, boundary == 0 && non_manifold == 0 ? " (watertight)" : "");
  std::printf ("times (s): prepare %.3f, off-surface %.3f, octree %.3f, fits %.3f, extraction %.3f; total %.3f\n",
               s.t_prepare, s.t_off_surface, s.t_octree, s.t_fits, s.t_extraction, t_total);

  if (!output.empty ())
  {
    if (pcl::io::savePLYFileBinary (output, mesh) < 0)
    {
      std::cerr << "rbf_reconstruct: could not write " << output << "\n";
      return 1;
    }
    std::cout << "wrote " << output << "\n";
  }

  if (view || !screenshot.empty ())
  {
    const bool offscreen = !screenshot.empty ();
    const auto window = pclx::apps::makeVisualizer ("rbf_reconstruct", offscreen, 1024, 768);
    pcl::visualization::PCLVisualizer& viewer = *window;
    viewer.setBackgroundColor (0.1, 0.1, 0.12);
    viewer.addPolygonMesh (mesh, "mesh");
    // Uniform light grey (the mesh's normal fields are not colours): the lighting shows the shape.
    viewer.setPointCloudRenderingProperties (pcl::visualization::PCL_VISUALIZER_COLOR, 0.8, 0.8, 0.78, "mesh");
    char caption[160];
    std::snprintf (caption, sizeof (caption), "RBF partition of unity: %zu points, %zu subdomains, %zu triangles",
                   s.input_points, s.subdomains, s.triangles);
    viewer.addText (caption, 10, 10, 16, 1, 1, 1, "caption");
    pclx::apps::initCamera (viewer);
    // An oblique view from above; frameViewport centres the mesh and fits the distance.
    viewer.setCameraPosition (1.2, -1.0, 0.9, 0, 0, 0, 0, 0, 1);
    pclx::apps::frameViewport (viewer, 0, 0.12, {"mesh"});  // room for the caption
    if (offscreen)
    {
      try
      {
        pclx::apps::saveScreenshot (viewer, screenshot);
      }
      catch (const std::exception& e)
      {
        std::cerr << "rbf_reconstruct: " << e.what () << "\n";
        return 1;
      }
      std::cout << "wrote " << screenshot << "\n";
    }
    else
      viewer.spin ();
  }
  return 0;
}
