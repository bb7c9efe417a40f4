// normals_tool: normals for a point cloud file (PCD / PLY / XYZ) with
// PlanarOctreeNormalEstimation (octree / hybrid / merged) or PCL's PCA, optional
// orientation (MST or viewpoint), an error table against ground truth, and a VTK view
// coloured by angle error or by planar region (off-screen PNG with --screenshot).
#include <pclx/apps/cloud_loader.h>
#include <pclx/apps/progress.h>
#include <pclx/apps/view.h>
#include <pclx/normals/mst_normal_orientation.h>
#include <pclx/normals/normal_error.h>
#include <pclx/normals/planar_octree_normal_estimation.h>
#include <pclx/normals/viewpoint_normal_orientation.h>
#include <pclx/testing/degradation.h>
#include <pclx/testing/mesh_sampling.h>
#include <pclx/testing/shapes.h>

#include <pcl/common/common.h>
#include <pcl/common/io.h>
#include <pcl/features/normal_3d_omp.h>
#include <pcl/io/pcd_io.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <fstream>
#include <iostream>
#include <sstream>

using Cloud = pcl::PointCloud<pcl::PointXYZ>;
using Normals = pcl::PointCloud<pcl::Normal>;
using Estimator = pcl::PlanarOctreeNormalEstimation<pcl::PointXYZ, pcl::Normal>;

namespace {

bool
endsWith (const std::string& s, const std::string& suffix)
{
  return s.size () >= suffix.size () && s.compare (s.size () - suffix.size (), suffix.size (), suffix) == 0;
}

// Plain text, three numbers per line (the first three columns are used).
bool
loadColumns (const std::string& path, std::vector<Eigen::Vector3f>& rows)
{
  std::ifstream in (path);
  if (!in)
    return false;
  std::string line;
  while (std::getline (in, line))
  {
    std::istringstream s (line);
    Eigen::Vector3f v;
    if (s >> v.x () >> v.y () >> v.z ())
      rows.push_back (v);
  }
  return true;
}

// PCD / PLY / XYZ through the app kit (checked first; normals when the file has them).
void
loadCloud (const std::string& path, pcl::PointCloud<pcl::PointNormal>& out, bool& has_normals)
{
  pclx::apps::CloudInfo info;
  out = *pclx::apps::loadCloud<pcl::PointNormal> (path, &info);
  pclx::apps::requireFinitePoints (info);
  has_normals = info.fields.normals;
  std::cout << info.summary () << "\n";
}

Eigen::Vector3f
errorColour (double deg)
{
  // 0° green, 22.5° yellow, >= 45° red (unoriented error is at most 90°).
  const float t = static_cast<float> (std::min (deg / 45.0, 1.0));
  return t < 0.5f ? Eigen::Vector3f (2 * t, 1, 0) : Eigen::Vector3f (1, 2 - 2 * t, 0);
}

Eigen::Vector3f
regionColour (int id)
{
  if (id < 0)
    return Eigen::Vector3f (0.5f, 0.5f, 0.5f);
  std::uint32_t h = static_cast<std::uint32_t> (id) * 2654435761u;
  return Eigen::Vector3f (0.25f + 0.75f * ((h >> 8) & 255) / 255.f, 0.25f + 0.75f * ((h >> 16) & 255) / 255.f,
                          0.25f + 0.75f * ((h >> 24) & 255) / 255.f);
}

void
printTable (const pcl::NormalErrorStats& e, const char* what)
{
  std::printf ("%-22s %8zu %8.3f %8.3f %8.3f %8.3f %8.2f%% %8.2f%%", what, e.count, e.rms_deg, e.mean_deg, e.min_deg,
               e.max_deg, 100 * e.below5, 100 * e.below10);
}

}  // namespace

int
main (int argc, char** argv)
{
  CLI::App app ("Normals with PlanarOctreeNormalEstimation (Musmanno 2016) or PCA; PCD/PLY/XYZ in, PCD out");
  std::string input, output, truth_path, demo, method = "merged", orient = "none", color = "error", screenshot;
  // The library's defaults, so that the app and a PCL user's code give the same normals.
  const Estimator defaults;
  int k = Estimator::kDefaultNeighbours, max_depth = defaults.getMaxDepth (),
      min_points = defaults.getMinPointsPerCell (), orient_k = 10, points = 50000, threads = 0;
  double across_penalty = 0.5;
  double s_alpha = 0, s_beta = defaults.getSBeta (), border = defaults.getBorderRatio (),
         merge_angle = defaults.getMergeAngle (), noise = 0, shadow = 0, scale = 0;
  double validation = defaults.getRegionValidationRatio (), patch_slope = defaults.getMaxPatchSlopeError ();
  int adaptive_max = defaults.getMaxAdaptiveNeighbours (), patch_size = defaults.getPatchSize (),
      patch_support = defaults.getPatchSupport ();
  std::vector<float> viewpoint{0, 0, 0};
  bool view = false;
  auto* in_opt = app.add_option ("input,-i,--input", input, "PCD, PLY or XYZ (text) file");
  app.add_option ("--demo", demo, "instead of a file: a generated shape with exact normals")
      ->check (CLI::IsMember ({"sphere", "torus", "box", "thin_plate"}))
      ->excludes (in_opt);
  app.add_option ("--points", points, "--demo: number of points")->capture_default_str ();
  app.add_option ("--noise", noise, "--demo: Gaussian noise sigma / bounding-box diagonal")->capture_default_str ();
  app.add_option ("--shadow", shadow, "--demo: share of the surface removed as holes (0..1)")->capture_default_str ();
  app.add_option ("-o,--out,--output", output, "write a PCD with points and normals");
  app.add_option ("-m,--method", method, "octree (Musmanno 2016), hybrid (his §5.4.3), merged (his ch. 7), pca (PCL)")
      ->check (CLI::IsMember ({"octree", "hybrid", "merged", "pca"}))
      ->capture_default_str ();
  app.add_option ("-k,--k", k, "kNN size for PCA, borders and fallbacks")->capture_default_str ();
  app.add_option ("--s-alpha", s_alpha, "planarity: lambda2 > s_alpha * lambda3 (0: method default, 6.25 or 20)");
  app.add_option ("--s-beta", s_beta, "planarity: s_beta * lambda2 > lambda1")->capture_default_str ();
  app.add_option ("--max-depth", max_depth, "octree depth limit")->capture_default_str ();
  app.add_option ("--min-points", min_points, "minimum points of a planar cell")->capture_default_str ();
  app.add_option ("--border", border, "hybrid: border band, share of the half edge")->capture_default_str ();
  app.add_option ("--merge-angle", merge_angle, "merged: max angle between merged leaves (deg)")->capture_default_str ();
  app.add_option ("--region-validation", validation,
                  "merged: use a region if its fit RMS <= this x its patches' median RMS (0: always; with "
                  "--patch-size 0: x local kNN thickness, use 0.5)")
      ->capture_default_str ();
  app.add_option ("--patch-size", patch_size, "merged: max points per patch cell (0: no patches, kNN instead)")
      ->capture_default_str ();
  app.add_option ("--patch-support", patch_support, "merged: points in a patch's fitting disc")->capture_default_str ();
  app.add_option ("--patch-slope", patch_slope, "merged: max standard error of a patch's slope (deg)")
      ->capture_default_str ();
  app.add_option ("--adaptive-max", adaptive_max, "merged: largest grown kNN set (<= k: plain PCA)")
      ->capture_default_str ();
  app.add_option ("--orient", orient, "none, mst (Hoppe: root at max z points +z) or viewpoint")
      ->check (CLI::IsMember ({"none", "mst", "viewpoint"}))
      ->capture_default_str ();
  app.add_option ("--orient-k", orient_k, "mst: neighbours in the Riemannian graph")->capture_default_str ();
  app.add_option ("--across-penalty", across_penalty,
                  "mst: extra cost of edges along the normals (through thin parts); 0 = Hoppe")
      ->capture_default_str ();
  app.add_option ("--viewpoint", viewpoint, "viewpoint x y z")->expected (3);
  app.add_option ("--truth", truth_path,
                  "ground-truth normals: a .normals text file (PCPNet) or a PCD/PLY with normal_x.. fields");
  app.add_option ("--threads", threads, "0: OpenMP default");
  app.add_flag ("--view", view, "show the cloud and normals (VTK)");
  app.add_option ("--color", color, "colour by angle error (needs truth) or planar region")
      ->check (CLI::IsMember ({"error", "region"}))
      ->capture_default_str ();
  app.add_option ("--normal-scale", scale, "length of the drawn normals (0: 1% of the diagonal)");
  app.add_option ("--screenshot", screenshot, "with --view: render off-screen to this PNG and exit");
  CLI11_PARSE (app, argc, argv);
  if (input.empty () && demo.empty ())
  {
    std::cerr << "normals_tool: give an input file or --demo (see --help)\n";
    return 2;
  }

  // Input and ground truth.
  pcl::PointCloud<pcl::PointNormal> loaded;
  bool has_normals = false;
  if (!demo.empty ())
  {
    using namespace pclx::testing;
    const TriangleMesh mesh = demo == "sphere" ? makeSphere (1.f, 6)
                              : demo == "torus" ? makeTorus (1.f, 0.3f, 256, 96)
                              : demo == "box"   ? makeBox (Eigen::Vector3f (1.f, 0.6f, 0.4f), 16)
                                                : makeThinPlate (1.f, 0.02f, 32);
    SampledCloud s = sampleUniform (mesh, static_cast<std::size_t> (points), 1);
    if (shadow > 0)
      applyShadowHoles (s, static_cast<float> (shadow), 2);
    if (noise > 0)
      addGaussianNoise (s, static_cast<float> (noise), 3);
    loaded = s.cloud;
    has_normals = true;
  }
  else
  {
    try
    {
      loadCloud (input, loaded, has_normals);
    }
    catch (const pclx::apps::LoadError& e)
    {
      std::cerr << "normals_tool: " << e.what () << "\n";
      return 1;
    }
  }
  Cloud::Ptr cloud (new Cloud);
  pcl::copyPointCloud (loaded, *cloud);
  pcl::PointCloud<pcl::PointNormal> truth;
  bool have_truth = false;
  if (!truth_path.empty ())
  {
    std::vector<Eigen::Vector3f> rows;
    bool truth_has_normals = false;
    bool read = false;
    try
    {
      read = endsWith (truth_path, ".normals") ? loadColumns (truth_path, rows)
                                               : (loadCloud (truth_path, truth, truth_has_normals), truth_has_normals);
    }
    catch (const pclx::apps::LoadError& e)
    {
      std::cerr << "normals_tool: " << e.what () << "\n";
      return 1;
    }
    if (read)
    {
      if (!rows.empty ())
      {
        truth.resize (rows.size ());
        for (std::size_t i = 0; i < rows.size (); ++i)
          truth[i].getNormalVector3fMap () = rows[i];
      }
      have_truth = truth.size () == cloud->size ();
    }
    if (!have_truth)
    {
      std::cerr << "normals_tool: " << truth_path << " has no normals for the " << cloud->size () << " points\n";
      return 1;
    }
  }
  else if (!demo.empty ())
  {
    truth = loaded;
    have_truth = true;
  }
  std::cout << "points: " << cloud->size () << (have_truth ? " (with ground truth)" : "") << "\n";

  // Normals.
  Normals normals;
  std::vector<int> region_ids (cloud->size (), -1);
  const auto t0 = std::chrono::steady_clock::now ();
  pclx::apps::Progress estimating ("estimating normals (" + method + ")");
  if (method == "pca")
  {
    pcl::NormalEstimationOMP<pcl::PointXYZ, pcl::Normal> ne (threads);
    ne.setInputCloud (cloud);
    ne.setKSearch (k);
    ne.compute (normals);
  }
  else
  {
    Estimator ne;
    ne.setInputCloud (cloud);
    ne.setMethod (method == "octree" ? Estimator::Method::OCTREE
                  : method == "hybrid" ? Estimator::Method::HYBRID
                                       : Estimator::Method::MERGED);
    ne.setKSearch (k);
    if (s_alpha > 0 || s_beta != 1.5)
      ne.setPlanarityThresholds (s_alpha > 0 ? s_alpha : ne.getSAlpha (), s_beta);
    ne.setMaxDepth (max_depth);
    ne.setMinPointsPerCell (min_points);
    ne.setBorderRatio (border);
    ne.setMergeAngle (merge_angle);
    ne.setRegionValidationRatio (validation);
    ne.setMaxAdaptiveNeighbours (adaptive_max);
    ne.setPatchSize (patch_size);
    ne.setPatchSupport (patch_support);
    ne.setMaxPatchSlopeError (patch_slope);
    ne.setNumberOfThreads (static_cast<unsigned> (threads));
    ne.compute (normals);
    if (normals.empty ())
    {
      std::cerr << "normals_tool: estimation failed (see the error above)\n";
      return 1;
    }
    region_ids = ne.getRegionIds ();
    std::size_t count[Estimator::PATCH_FIT + 1] = {};
    for (auto s : ne.getPointStatus ())
      ++count[s];
    std::printf ("octree: %d leaves, %d planar, %zu regions, %zu patches; points: %zu leaf plane, %zu region fit, "
                 "%zu patch fit, %zu adopted, %zu kNN PCA, %zu fallback, %zu invalid\n",
                 ne.getOctree ().numLeaves (), ne.getOctree ().numPlanarLeaves (), ne.getOctree ().regions ().size (),
                 ne.getOctree ().patches ().size (), count[Estimator::LEAF_PLANE], count[Estimator::REGION_FIT],
                 count[Estimator::PATCH_FIT], count[Estimator::ADOPTED_REGION], count[Estimator::KNN_PCA],
                 count[Estimator::NEIGHBOUR_FALLBACK], count[Estimator::INVALID_POINT]);
  }
  estimating.done ();
  const double t_est = std::chrono::duration<double> (std::chrono::steady_clock::now () - t0).count ();
  std::printf ("estimation (%s): %.3f s\n", method.c_str (), t_est);

  if (orient == "mst")
  {
    const auto t1 = std::chrono::steady_clock::now ();
    pclx::apps::Progress orienting ("orienting normals (MST)");
    pcl::MSTNormalOrientation<pcl::PointXYZ, pcl::Normal> mst;
    mst.setInputCloud (cloud);
    mst.setKSearch (orient_k);
    mst.setNumberOfThreads (static_cast<unsigned> (threads));
    mst.setAcrossSurfacePenalty (across_penalty);
    if (!mst.orient (normals))
      return 1;
    orienting.done ();
    std::printf ("orientation (MST, k=%d): %.3f s, %zu components, %zu flipped\n", orient_k,
                 std::chrono::duration<double> (std::chrono::steady_clock::now () - t1).count (),
                 mst.getNumberOfComponents (), mst.getNumberOfFlipped ());
  }
  else if (orient == "viewpoint")
  {
    std::size_t flipped = 0;
    pcl::orientNormalsTowardsViewpoint (*cloud, normals, Eigen::Vector3f (viewpoint[0], viewpoint[1], viewpoint[2]),
                                        &flipped);
    std::printf ("orientation (viewpoint): %zu flipped\n", flipped);
  }

  std::vector<double> errors;
  if (have_truth)
  {
    std::printf ("\n%-22s %8s %8s %8s %8s %8s %9s %9s\n", "error (degrees)", "points", "rms", "mean", "min", "max",
                 "<5deg", "<10deg");
    printTable (pcl::compareNormals (normals, truth), "unoriented");
    std::printf ("\n");
    if (orient != "none")
    {
      const auto e = pcl::compareNormals (normals, truth, true);
      printTable (e, "oriented");
      std::printf ("   flipped %.3f%%%s\n", 100 * e.flipped,
                   demo.empty () ? " (meaningful only if the truth is oriented)" : "");
    }
    errors = pcl::angleErrorsDeg (normals, truth);
  }

  if (!output.empty ())
  {
    pcl::PointCloud<pcl::PointNormal> out;
    pcl::concatenateFields (*cloud, normals, out);
    if (pcl::io::savePCDFileBinary (output, out) < 0)
      return 1;
    std::cout << "wrote " << output << "\n";
  }

  if (view)
  {
    if (color == "error" && !have_truth)
    {
      std::cerr << "normals_tool: --color error needs ground truth (--truth or --demo); using regions\n";
      color = "region";
    }
    pcl::PointCloud<pcl::PointXYZRGB>::Ptr coloured (new pcl::PointCloud<pcl::PointXYZRGB>);
    pcl::copyPointCloud (*cloud, *coloured);
    for (std::size_t i = 0; i < coloured->size (); ++i)
    {
      const Eigen::Vector3f c = color == "error" ? errorColour (std::isnan (errors[i]) ? 0 : errors[i])
                                                 : regionColour (region_ids[i]);
      (*coloured)[i].r = static_cast<std::uint8_t> (255 * c.x ());
      (*coloured)[i].g = static_cast<std::uint8_t> (255 * c.y ());
      (*coloured)[i].b = static_cast<std::uint8_t> (255 * c.z ());
    }
    Eigen::Vector4f lo, hi;
    pcl::getMinMax3D (*cloud, lo, hi);
    const float diag = (hi - lo).head<3> ().norm ();
    const bool offscreen = !screenshot.empty ();
    const auto window = pclx::apps::makeVisualizer ("normals_tool", offscreen, 1024, 768);
    pcl::visualization::PCLVisualizer& viewer = *window;
    viewer.setBackgroundColor (0.1, 0.1, 0.12);
    viewer.addPointCloud<pcl::PointXYZRGB> (coloured, pcl::visualization::PointCloudColorHandlerRGBField<pcl::PointXYZRGB> (coloured), "cloud");
    viewer.setPointCloudRenderingProperties (pcl::visualization::PCL_VISUALIZER_POINT_SIZE, 3, "cloud");
    const int level = std::max<int> (1, static_cast<int> (cloud->size () / 4000));
    viewer.addPointCloudNormals<pcl::PointXYZRGB, pcl::Normal> (coloured, normals.makeShared (), level,
                                                                 scale > 0 ? scale : 0.02 * diag, "normals");
    viewer.setPointCloudRenderingProperties (pcl::visualization::PCL_VISUALIZER_COLOR, 0.8, 0.8, 0.9, "normals");
    viewer.addText (method + (color == "error" ? ": angle error, green 0 -> red 45+ deg" : ": planar regions (grey: none)"),
                    10, 10, 16, 1, 1, 1, "label");
    pclx::apps::initCamera (viewer);
    const Eigen::Vector3f c = ((lo + hi) / 2).head<3> ();
    viewer.setCameraPosition (c.x () + 1.2 * diag, c.y () - 1.0 * diag, c.z () + 0.9 * diag, c.x (), c.y (), c.z (), 0, 0, 1);
    // The cloud fills the window from that direction.
    pclx::apps::frameViewport (viewer, 0, 0.05, {"cloud"});
    if (offscreen)
    {
      try
      {
        pclx::apps::saveScreenshot (viewer, screenshot);
      }
      catch (const std::exception& e)
      {
        std::cerr << "normals_tool: " << e.what () << "\n";
        return 1;
      }
      std::cout << "wrote " << screenshot << "\n";
    }
    else
      viewer.spin ();
  }
  return 0;
}
