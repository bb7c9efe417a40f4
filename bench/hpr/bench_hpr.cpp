// HPRFilter benchmark: every method and Open3D's exact HPR in one run, against
// ray-cast visibility (Embree) on mesh samplings. Rows (bench/common/bench_csv.h):
//   hpr,<method>,sweep=<main|grid_k|noise|density>;R=..;k=..,<input>,<points>,<s>,visible,..,precision,..,recall,..,f1,..
#include "bench_csv.h"

#include <pclx/hpr/hpr_filter.h>
#include <pclx/testing/degradation.h>
#include <pclx/testing/ray_caster.h>
#include <pclx/testing/set_scores.h>
#include <pclx/testing/shapes.h>

#include <CLI/CLI.hpp>

#ifdef PCLX_HAVE_OPEN3D
#include <open3d/geometry/PointCloud.h>
#endif

#include <functional>
#include <iomanip>
#include <sstream>

using namespace pclx::testing;
using pclx::bench::CsvWriter;
using pclx::bench::Metrics;
using pclx::bench::timeBest;
using Filter = pcl::HPRFilter<pcl::PointXYZ>;

namespace {

struct Input
{
  std::string name;
  TriangleMesh mesh;
};

struct Case
{
  std::string input;
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud;
  std::vector<bool> truth;
  Eigen::Vector3f viewpoint;
  double diameter;
  int view;
};

std::string
fmt (double v)
{
  std::ostringstream s;
  s << std::setprecision (4) << v;
  return s.str ();
}

Metrics
accuracy (const std::vector<int>& visible, const std::vector<bool>& truth)
{
  const SubsetScore s = scoreSubset (visible, truth);
  return {{"visible", double (s.predicted)}, {"precision", s.precision}, {"recall", s.recall}, {"f1", s.f1}};
}


// Viewpoints at `distance` × diagonal from the centre, from several sides.
std::vector<Eigen::Vector3f>
viewpoints (const TriangleMesh& mesh, int count, float distance)
{
  const Eigen::Vector3f c = (mesh.bboxMin () + mesh.bboxMax ()) / 2;
  const std::vector<Eigen::Vector3f> dirs{{0.2f, 0.3f, 1.f}, {1.f, 0.4f, 0.3f}, {-0.6f, 0.8f, -0.5f},
                                          {0.1f, -1.f, 0.4f}};
  std::vector<Eigen::Vector3f> out;
  for (int i = 0; i < count && i < int (dirs.size ()); ++i)
    out.push_back (c + distance * mesh.diagonal () * dirs[i].normalized ());
  return out;
}

class Runner
{
public:
  Runner (CsvWriter& out, int repeats) : out_ (out), repeats_ (repeats) {}

  // One HPRFilter configuration on one case; returns the visible indices.
  // `more` adds metrics computed from the visible set (e.g. the overlap with a peer).
  std::vector<int>
  ours (const Case& c, const std::string& sweep, const std::string& method, Filter& f, const std::string& extra,
        const std::function<Metrics (const std::vector<int>&)>& more = {})
  {
    f.setInputCloud (c.cloud);
    f.setViewPoint (c.viewpoint);
    pcl::Indices vis;
    const double t = timeBest ([&] { f.filter (vis); }, repeats_);
    std::vector<int> v (vis.begin (), vis.end ());
    Metrics m = accuracy (v, c.truth);
    if (more)
    {
      const Metrics extra_metrics = more (v);
      m.insert (m.end (), extra_metrics.begin (), extra_metrics.end ());
    }
    m.emplace_back ("R_over_diameter", f.getRadiusUsed () / c.diameter);
    std::string params = "sweep=" + sweep + ";view=" + std::to_string (c.view) + ";R=" +
                         fmt (f.getRadiusUsed () / c.diameter) + "d";
    if (f.getSectorCountUsed ())
      params += ";k=" + std::to_string (f.getSectorCountUsed ()) + ";steps=" +
                std::to_string (f.getPropagationStepsUsed ());
    out_.row ("hpr", method, params + extra, c.input, c.cloud->size (), t, m);
    return v;
  }

#ifdef PCLX_HAVE_OPEN3D
  std::vector<int>
  open3d (const Case& c, const std::string& sweep, double R_over_d, const std::string& extra = "")
  {
    open3d::geometry::PointCloud pc;
    pc.points_.reserve (c.cloud->size ());
    for (const auto& p : *c.cloud)
      pc.points_.emplace_back (p.x, p.y, p.z);
    std::vector<size_t> vis;
    const double t = timeBest (
        [&] { vis = std::get<1> (pc.HiddenPointRemoval (c.viewpoint.cast<double> (), R_over_d * c.diameter)); },
        repeats_);
    std::vector<int> v (vis.begin (), vis.end ());
    out_.row ("hpr", "open3d_exact",
              "sweep=" + sweep + ";view=" + std::to_string (c.view) + ";R=" + fmt (R_over_d) + "d" + extra, c.input,
              c.cloud->size (), t, accuracy (v, c.truth));
    return v;
  }
#endif

private:
  CsvWriter& out_;
  int repeats_;
};

}  // namespace

int
main (int argc, char** argv)
{
  CLI::App app ("HPRFilter benchmark: methods and Open3D against ray-cast visibility");
  std::string csv;
  std::vector<std::size_t> sizes{100000, 1000000, 3000000};
  int views = 3, repeats = 1;
  bool quick = false, no_sweeps = false, sweeps_only = false;
  float distance = 3.f;
  app.add_option ("--csv", csv, "also write rows to this file");
  app.add_option ("--sizes", sizes, "point counts of the main sweep")->capture_default_str ();
  app.add_option ("--views", views, "viewpoints per input (1-4)")->capture_default_str ();
  app.add_option ("--distance", distance, "viewpoint distance in bounding-box diagonals")->capture_default_str ();
  app.add_option ("--repeats", repeats, "best of N timings")->capture_default_str ();
  app.add_flag ("--quick", quick, "demo size: 100k points, one view, no 3M");
  app.add_flag ("--no-sweeps", no_sweeps, "only the main time-vs-accuracy sweep");
  app.add_flag ("--sweeps-only", sweeps_only, "only the noise and density sweeps");
  CLI11_PARSE (app, argc, argv);
  if (quick)
  {
    sizes = {100000};
    views = 1;
  }

  std::vector<Input> inputs;
  if (auto data = pclx::bench::sharedDataDir ())
    inputs.push_back ({"bunny", loadPlyMesh (*data + "/bunny/reconstruction/bun_zipper.ply")});
  {
    // A generated scene with concavities and occluders: a torus around a sphere on a slab.
    TriangleMesh scene = makeTorus (1.f, 0.3f, 256, 96);
    scene.append (makeSphere (0.45f, 5, Eigen::Vector3f (0, 0, 0.1f)));
    TriangleMesh slab = makeBox (Eigen::Vector3f (3.f, 3.f, 0.1f), 16);
    slab.transform (Eigen::Affine3f (Eigen::Translation3f (0, 0, -0.5f)));
    scene.append (slab);
    inputs.push_back ({"torus_scene", scene});
  }

  CsvWriter out (csv);
  Runner run (out, repeats);
  const std::vector<double> radii{1e2, 1e3, 1e4};  // R / diameter, as in Open3D's examples

  for (const auto& in : inputs)
  {
    const RayCaster caster (in.mesh);
    const double diameter = in.mesh.diagonal ();
    const auto vps = viewpoints (in.mesh, views, distance);
    for (std::size_t n : sweeps_only ? std::vector<std::size_t>{} : sizes)
    {
      const SampledCloud s = sampleUniform (in.mesh, n, 7);
      for (int v = 0; v < int (vps.size ()); ++v)
      {
        const Case c{in.name, positions (s.cloud), caster.visibleFrom (s.cloud, vps[v]), vps[v], diameter, v};
        // Main sweep: time against F1 for every method.
        for (double r : radii)
        {
          std::vector<int> o3d;
#ifdef PCLX_HAVE_OPEN3D
          o3d = run.open3d (c, "main", r);
#endif
          Filter exact;
          exact.setMethod (Filter::Method::EXACT);
          exact.setRadius (r * diameter);
          // The exact result should equal Open3D's at equal R: report the overlap.
          run.ours (c, "main", "pclx_exact", exact, "", [&] (const std::vector<int>& vis) {
            return o3d.empty () ? Metrics{} : Metrics{{"jaccard_vs_open3d", pclx::testing::jaccard (vis, o3d)}};
          });
        }
        {
          Filter f;  // everything calibrated
          f.setMethod (Filter::Method::EXACT);
          run.ours (c, "main", "pclx_exact_autoR", f, "");
        }
        {
          Filter f;
          f.setMethod (Filter::Method::CANDIDATE_HULL);
          run.ours (c, "main", "pclx_candidate_hull_autoR", f, "");
          Filter f4;
          f4.setMethod (Filter::Method::CANDIDATE_HULL);
          f4.setRadius (1e4 * diameter);
          run.ours (c, "main", "pclx_candidate_hull", f4, "");
        }
        for (double over : {1.0, 4.0})
        {
          Filter f;
          f.setMethod (Filter::Method::ANGULAR_GRID);
          f.setGridOversampling (over);
          run.ours (c, "main", "pclx_grid_auto", f, ";oversampling=" + fmt (over));
          Filter fixed;
          fixed.setMethod (Filter::Method::ANGULAR_GRID);
          fixed.setGridOversampling (over);
          fixed.setPropagation (Filter::Propagation::FIXED, 3);
          run.ours (c, "main", "pclx_grid_fixed3", fixed, ";oversampling=" + fmt (over));
        }
        for (std::size_t k : {n / 4, n})
        {
          Filter bfp;
          bfp.setMethod (Filter::Method::BENTLEY_FAUST_PREPARATA);
          bfp.setSectorCount (k);
          run.ours (c, "main", "bfp", bfp, ";k=" + std::to_string (k));
          Filter hybrid;
          hybrid.setMethod (Filter::Method::HYBRID);
          hybrid.setSectorCount (k);
          run.ours (c, "main", "hybrid", hybrid, "");
        }
        if (n <= 1000000)
          for (std::size_t k : {std::size_t (2000), std::size_t (8000)})
          {
            Filter kavan;  // O(k²) refinement: only small k is affordable
            kavan.setMethod (Filter::Method::KAVAN);
            kavan.setSectorCount (k);
            run.ours (c, "main", "kavan", kavan, "");
          }
        // F1 against k for the grid (R calibrated).
        if (!no_sweeps && v == 0)
          for (double ratio : {1.0 / 16, 1.0 / 4, 1.0, 4.0, 16.0})
          {
            Filter f;
            f.setMethod (Filter::Method::ANGULAR_GRID);
            f.setSectorCount (std::size_t (ratio * n));
            run.ours (c, "grid_k", "pclx_grid_adaptive", f, "");
            Filter fixed;
            fixed.setMethod (Filter::Method::ANGULAR_GRID);
            fixed.setSectorCount (std::size_t (ratio * n));
            fixed.setPropagation (Filter::Propagation::FIXED, 3);
            run.ours (c, "grid_k", "pclx_grid_fixed3", fixed, "");
          }
      }
    }

    if (no_sweeps)
      continue;
    // Stability: noise and density gradient at 100k points, first viewpoint; ground truth
    // is the visibility of the clean samples. Exact with a calibrated R and with the fixed
    // R = 10⁴·diameter (Open3D's best above, also run), the grid, the candidate hull.
    const std::size_t n = 100000;
    const Eigen::Vector3f vp = vps[0];
    auto stability = [&] (const Case& c, const std::string& sweep, const std::string& tag) {
#ifdef PCLX_HAVE_OPEN3D
      run.open3d (c, sweep, 1e4, tag);
#endif
      Filter exact;
      exact.setMethod (Filter::Method::EXACT);
      run.ours (c, sweep, "pclx_exact_autoR", exact, tag);
      Filter exact_fixed;
      exact_fixed.setMethod (Filter::Method::EXACT);
      exact_fixed.setRadius (1e4 * diameter);
      run.ours (c, sweep, "pclx_exact", exact_fixed, tag);
      Filter grid;
      grid.setMethod (Filter::Method::ANGULAR_GRID);
      run.ours (c, sweep, "pclx_grid_auto", grid, tag);
      Filter ch;
      ch.setMethod (Filter::Method::CANDIDATE_HULL);
      run.ours (c, sweep, "pclx_candidate_hull_autoR", ch, tag);
    };
    for (double sigma : {0.0, 0.0025, 0.005, 0.01, 0.02})
    {
      SampledCloud s = sampleUniform (in.mesh, n, 7);
      const std::vector<bool> truth = caster.visibleFrom (s.cloud, vp);
      addGaussianNoise (s, float (sigma), 3);
      stability (Case{in.name, positions (s.cloud), truth, vp, diameter, 0}, "noise", ";noise=" + fmt (sigma));
    }
    for (double ratio : {1.0, 0.3, 0.1, 0.03})
    {
      const SampledCloud s = sampleDensityGradient (in.mesh, n, 0, float (ratio), 5);
      stability (Case{in.name, positions (s.cloud), caster.visibleFrom (s.cloud, vp), vp, diameter, 0}, "density",
                 ";min_ratio=" + fmt (ratio));
    }
  }
  return 0;
}
