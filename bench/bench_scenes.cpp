// Ground-truth throughput: how long scenes and ground truth take at bench sizes.
// Rows: module=scenes; methods sample / embree_visibility / cgal_distance / depth_render.
#include "bench_csv.h"

#include <pclx/testing/depth_renderer.h>
#include <pclx/testing/mesh_distance.h>
#include <pclx/testing/mesh_sampling.h>
#include <pclx/testing/shapes.h>

#include <CLI/CLI.hpp>

using namespace pclx::testing;
using pclx::bench::CsvWriter;
using pclx::bench::timeBest;

int
main (int argc, char** argv)
{
  CLI::App app ("pclx scene / ground-truth throughput benchmark");
  std::string csv;
  std::vector<std::size_t> sizes{10000, 100000, 1000000};
  app.add_option ("--csv", csv, "also write the CSV rows to this file");
  app.add_option ("--sizes", sizes, "point counts")->capture_default_str ();
  bool verbose = false;
  app.add_flag ("--verbose", verbose, "progress lines on stderr");
  CLI11_PARSE (app, argc, argv);
  pclx::bench::setVerbose (verbose);

  CsvWriter out (csv);
  std::vector<std::pair<std::string, TriangleMesh>> inputs{{"sphere", makeSphere (1.f, 6)},
                                                            {"torus", makeTorus (1.f, 0.3f, 512, 128)}};
  if (auto data = pclx::bench::sharedDataDir ())
    inputs.emplace_back ("bunny", loadPlyMesh (*data + "/bunny/reconstruction/bun_zipper.ply"));

  for (const auto& [name, mesh] : inputs)
  {
    const RayCaster caster (mesh);
    const MeshDistance distance (mesh);
    const Eigen::Vector3f center = (mesh.bboxMin () + mesh.bboxMax ()) / 2;
    const Eigen::Vector3f viewpoint = center + Eigen::Vector3f (0, 0, 3 * mesh.diagonal ());
    for (std::size_t n : sizes)
    {
      SampledCloud s;
      const double t_sample = timeBest ([&] { s = sampleUniform (mesh, n, 1); });
      out.row ("scenes", "sample_uniform", "", name, n, t_sample, {{"faces", double (mesh.faces.size ())}});

      std::vector<bool> vis;
      const double t_vis = timeBest ([&] { vis = caster.visibleFrom (s.cloud, viewpoint); });
      out.row ("scenes", "embree_visibility", "", name, n, t_vis,
               {{"visible_fraction", std::count (vis.begin (), vis.end (), true) / double (n)}});

      const std::size_t m = std::min<std::size_t> (n, 20000);
      double max_d = 0;
      const double t_dist = timeBest ([&] {
        for (std::size_t i = 0; i < m; ++i)
          max_d = std::max (max_d, distance.distance (s.cloud[i].getVector3fMap ()));
      });
      out.row ("scenes", "cgal_distance", "", name, m, t_dist, {{"max_distance", max_d}});
    }
    PinholeIntrinsics K;
    const Eigen::Isometry3f pose = lookAt (center + Eigen::Vector3f (0, -std::max (1.5f * mesh.diagonal (), 0.8f), 0), center);
    DepthImage img;
    const double t_depth = timeBest ([&] { img = renderDepth (caster, K, pose); });
    const double valid =
        std::count_if (img.depth_mm.begin (), img.depth_mm.end (), [] (auto d) { return d != 0; });
    out.row ("scenes", "depth_render", "640x480;kinect_noise", name, img.depth_mm.size (), t_depth,
             {{"valid_pixels", valid}});
  }
  return 0;
}
