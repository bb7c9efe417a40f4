// make_omicron_cloud: large test clouds for omicron_viewer. Samples a triangle mesh (a PLY
// such as ../shared/data/meshes/fertility.ply, or the generated torus-sphere-plate scene of
// make_scene) uniformly, optionally coloured by the surface normal and/or given an intensity
// (the normal's incidence on a light from above, as a scanner's return falls with the angle),
// and writes binary PCD or binary PLY.
#include <pclx/apps/progress.h>
#include <pclx/omicron/point_xyzrgbi.h>
#include <pclx/testing/mesh_sampling.h>
#include <pclx/testing/shapes.h>
#include <pclx/testing/triangle_mesh.h>

#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>

#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <type_traits>

using namespace pclx::testing;

namespace {

bool
endsWith (const std::string& s, const std::string& suffix)
{
  return s.size () >= suffix.size () && s.compare (s.size () - suffix.size (), suffix.size (), suffix) == 0;
}

template <typename PointT>
int
write (const std::string& path, const pcl::PointCloud<PointT>& cloud)
{
  return endsWith (path, ".ply") ? pcl::PLYWriter ().write (path, cloud, true, false)
                                 : pcl::io::savePCDFileBinary (path, cloud);
}

int
run (int argc, char** argv)
{
  CLI::App app ("Test clouds for omicron_viewer: a sampled mesh (PLY) or the generated scene, binary PCD/PLY out");
  std::string mesh_path, out;
  std::size_t points = 1000000;
  bool color = false, intensity = false;
  std::uint32_t seed = 1;
  app.add_option ("--mesh", mesh_path, "triangle mesh to sample (PLY); default: torus, sphere and base plate");
  app.add_option ("--points", points, "points to sample")->capture_default_str ();
  app.add_flag ("--color", color, "colour the points by their surface normal (rgb field)");
  app.add_flag ("--intensity", intensity,
                "an intensity field: |normal.z| x 1000 (a return that falls with the incidence)");
  app.add_option ("--seed", seed)->capture_default_str ();
  app.add_option ("-o,--out", out, "output cloud (.pcd or .ply, binary)")->required ();
  CLI11_PARSE (app, argc, argv);
  if (!endsWith (out, ".pcd") && !endsWith (out, ".ply"))
    throw std::runtime_error ("--out must end in .pcd or .ply");

  TriangleMesh mesh;
  if (!mesh_path.empty ())
    mesh = loadPlyMesh (mesh_path);
  else
  {
    mesh = makeTorus (0.3f, 0.1f, 128, 48);
    mesh.append (makeSphere (0.12f, 4, Eigen::Vector3f (0, 0, 0.05f)));
    TriangleMesh base = makeBox (Eigen::Vector3f (1.f, 1.f, 0.04f), 8);
    base.transform (Eigen::Affine3f (Eigen::Translation3f (0, 0, -0.2f)));
    mesh.append (base);
  }
  pclx::apps::Progress sampling ("sampling " + std::to_string (points) + " points");
  const SampledCloud s = sampleUniform (mesh, points, seed);
  sampling.done ();
  // The normal's colour and its incidence from above, as the chosen fields.
  const auto fill = [&] (auto& q, const pcl::PointNormal& p) {
    q.x = p.x;
    q.y = p.y;
    q.z = p.z;
    if constexpr (pcl::traits::has_color_v<std::decay_t<decltype (q)>>)
    {
      q.r = static_cast<std::uint8_t> (127.5f + 127.f * p.normal_x);
      q.g = static_cast<std::uint8_t> (127.5f + 127.f * p.normal_y);
      q.b = static_cast<std::uint8_t> (127.5f + 127.f * p.normal_z);
    }
    if constexpr (pcl::traits::has_intensity_v<std::decay_t<decltype (q)>>)
      q.intensity = 1000.f * std::abs (p.normal_z);
  };
  const auto convert = [&] (auto cloud) {
    cloud.resize (s.cloud.size ());
    for (std::size_t i = 0; i < cloud.size (); ++i)
      fill (cloud[i], s.cloud[i]);
    return write (out, cloud);
  };
  int rc;
  if (color && intensity)
    rc = convert (pcl::PointCloud<pclx::PointXYZRGBI> ());
  else if (color)
    rc = convert (pcl::PointCloud<pcl::PointXYZRGB> ());
  else if (intensity)
    rc = convert (pcl::PointCloud<pcl::PointXYZI> ());
  else
    rc = write (out, *positions (s.cloud));
  if (rc != 0)
    throw std::runtime_error ("could not write " + out);
  std::printf ("wrote %zu points%s%s to %s\n", s.cloud.size (), color ? " (rgb)" : "", intensity ? " (intensity)" : "",
               out.c_str ());
  return 0;
}

}  // namespace

int
main (int argc, char** argv)
{
  try
  {
    return run (argc, argv);
  }
  catch (const std::exception& e)
  {
    std::fprintf (stderr, "make_omicron_cloud: %s\n", e.what ());
    return 1;
  }
}
