// bench_normals --wide / --speed / --quick. Rows (module normals):
//   sweep=wide;noise=<σ/diag>: ours (PlanarOctreeNormalEstimation defaults), pca_k<K> (PCL
//     NormalEstimationOMP), oracle_pca (the sweep's lowest RMS; params k=<K>), jet_k<K> and
//     jet_best (CGAL jet_estimate_normals, k grown until the error rises), vcm_R<a>_r<b> and
//     vcm_best (CGAL vcm_estimate_normals, offset / convolution radii a, b × the point spacing),
//     open3d_k18, open3d_hybrid (radius 4 spacings, max_nn 30); metrics rms, mean, min, max,
//     below5, below10 (unoriented angle error, degrees / shares). orient_mst_ours (and
//     orient_mst_pca_k18, the reference): MST flipped share on shapes with oriented truth (closed,
//     consistently oriented meshes).
//   sweep=speed;noise=<σ>: ours against pcl_omp_k18 at 100k / 300k / 1M clean points (best of
//     --speed-repeats, 2 by default), and at σ = 0.006 / 0.012 (100k) ours against pca_oracle
//     (params k=<the oracle's k>). Seconds are wall clock; the metrics end with cpu_seconds (the
//     process CPU time of the call, all threads, best of the repeats like the wall time: the
//     machines are shared, and CPU time moves less with the neighbours' load) and repeats.
// Every method of a (shape, σ) case runs on the same noisy cloud (one seed), on opt.threads threads.
#include "wide.h"

#include "normals_bench_util.h"
#ifdef PCLX_HAVE_OPEN3D
#include "open3d_peer.h"
#endif
#ifdef PCLX_HAVE_CGAL_PEER
#include "cgal_peer.h"
#endif

#include <pclx/normals/mst_normal_orientation.h>
#include <pclx/normals/normal_error.h>
#include <pclx/normals/planar_octree_normal_estimation.h>
#include <pclx/testing/degradation.h>
#include <pclx/testing/mesh_sampling.h>
#include <pclx/testing/shapes.h>

#include <pcl/common/common.h>
#include <pcl/common/io.h>
#include <pcl/features/normal_3d_omp.h>
#include <pcl/io/ply_io.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/search/kdtree.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <functional>
#include <iomanip>
#include <iostream>
#include <omp.h>
#include <random>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

namespace pclx {
namespace bench {

namespace {

using namespace pclx::testing;
using Estimator = pcl::PlanarOctreeNormalEstimation<pcl::PointXYZ, pcl::Normal>;
using Normals = pcl::PointCloud<pcl::Normal>;

const std::uint32_t kNoiseSeed = 13;  // one noisy cloud per (shape, σ), shared by every method

SampledCloud
withNoise (const SampledCloud& clean, float sigma)
{
  SampledCloud s = clean;
  if (sigma > 0)
    addGaussianNoise (s, sigma, kNoiseSeed);
  return s;
}

// A closed slab [-1,1]² × [-0.3, profile] whose top is a fine-detail profile along x, extruded
// along y: V-grooves, rectangular slots and thin ridges whose width and depth are a few point
// spacings at 100k points (spacing ≈ 0.0095), and a sinusoidal ripple. The profile's creases are
// mesh edges, so sampled face normals are the exact truth on both sides of every crease.
TriangleMesh
makeGroovedSlab ()
{
  const float s = 0.01f, bottom = -0.3f;
  std::vector<Eigen::Vector2f> p{{-1.f, 0.f}};  // (x, z)
  float x = -0.95f;
  p.emplace_back (x, 0.f);
  auto gap = [&] (float w) { x += w; p.emplace_back (x, 0.f); };
  auto vgroove = [&] (float w, float d) {
    p.emplace_back (x + w / 2, -d);
    x += w;
    p.emplace_back (x, 0.f);
  };
  auto slot = [&] (float w, float d) {
    p.emplace_back (x, -d);
    x += w;
    p.emplace_back (x, -d);
    p.emplace_back (x, 0.f);
  };
  auto ridge = [&] (float w, float h) {
    p.emplace_back (x + w / 2, h);
    x += w;
    p.emplace_back (x, 0.f);
  };
  for (float w : {2 * s, 4 * s, 6 * s})
  {
    vgroove (w, 4 * s);
    gap (10 * s);
  }
  for (float w : {3 * s, 5 * s})
  {
    slot (w, 4 * s);
    gap (10 * s);
  }
  for (float w : {2 * s, 3 * s, 5 * s})
  {
    ridge (w, 4 * s);
    gap (10 * s);
  }
  // Ripple: amplitude 1.5 s, wavelength 10 s, 4 periods.
  const float amp = 1.5f * s, wl = 10 * s;
  for (int i = 1; i <= 4 * 16; ++i)
    p.emplace_back (x + wl * i / 16.f, amp * std::sin (2 * float (M_PI) * i / 16.f));
  x += 4 * wl;
  gap (10 * s);
  // Deep narrow V-grooves next to each other (a comb).
  for (int i = 0; i < 4; ++i)
    vgroove (3 * s, 6 * s);
  if (x >= 1.f)
    throw std::logic_error ("makeGroovedSlab: the profile does not fit in [-1, 1]");
  p.emplace_back (1.f, 0.f);

  TriangleMesh m;
  for (std::size_t i = 0; i + 1 < p.size (); ++i)
  {
    const Eigen::Vector2f a = p[i], b = p[i + 1];
    // Top strip, outward (u × v with u along the profile, v along +y).
    m.addQuad ({a.x (), -1, a.y ()}, {b.x (), -1, b.y ()}, {b.x (), 1, b.y ()}, {a.x (), 1, a.y ()});
    if (b.x () > a.x ())
    {
      // Side walls under the strip: -y and +y.
      m.addQuad ({a.x (), -1, bottom}, {b.x (), -1, bottom}, {b.x (), -1, b.y ()}, {a.x (), -1, a.y ()});
      m.addQuad ({a.x (), 1, bottom}, {a.x (), 1, a.y ()}, {b.x (), 1, b.y ()}, {b.x (), 1, bottom});
    }
  }
  const float z0 = p.front ().y (), z1 = p.back ().y ();
  m.addQuad ({-1, -1, bottom}, {-1, -1, z0}, {-1, 1, z0}, {-1, 1, bottom});  // -x
  m.addQuad ({1, -1, bottom}, {1, 1, bottom}, {1, 1, z1}, {1, -1, z1});      // +x
  m.addQuad ({-1, -1, bottom}, {-1, 1, bottom}, {1, 1, bottom}, {1, -1, bottom});  // -z
  return m;
}

// Every directed edge once and its reverse once: closed and consistently oriented. Then
// `outward` tells the sign of the enclosed volume.
bool
consistentlyOriented (const TriangleMesh& m, bool& outward)
{
  std::unordered_map<std::uint64_t, int> edges;
  auto key = [] (int a, int b) { return (std::uint64_t (std::uint32_t (a)) << 32) | std::uint32_t (b); };
  double volume = 0;
  for (const auto& f : m.faces)
  {
    for (int e = 0; e < 3; ++e)
      if (++edges[key (f[e], f[(e + 1) % 3])] > 1)
        return false;
    volume += m.vertices[f[0]].cast<double> ().dot (
        m.vertices[f[1]].cast<double> ().cross (m.vertices[f[2]].cast<double> ()));
  }
  for (const auto& [k, count] : edges)
    if (!edges.count ((k << 32) | (k >> 32)))
      return false;
  outward = volume > 0;
  return true;
}

// Point spacing of a clean cloud: from the distance r to the 16th neighbour (median over a
// sample), the side of the square that holds one point: r·sqrt(π/16).
double
pointSpacing (const pcl::PointCloud<pcl::PointXYZ>::Ptr& cloud)
{
  pcl::search::KdTree<pcl::PointXYZ> tree;
  tree.setInputCloud (cloud);
  const std::size_t step = std::max<std::size_t> (1, cloud->size () / 2000);
  std::vector<double> r;
  pcl::Indices idx;
  std::vector<float> d2;
  for (std::size_t i = 0; i < cloud->size (); i += step)
    if (tree.nearestKSearch ((*cloud)[i], 17, idx, d2) == 17)
      r.push_back (std::sqrt (d2.back ()));
  if (r.empty ())
    return 0;
  std::nth_element (r.begin (), r.begin () + r.size () / 2, r.end ());
  return r[r.size () / 2] * std::sqrt (M_PI / 16);
}

// Orientation oracle (for the "< 1 % flipped" target): a reader that knows the true surface but,
// like any method, not which point of it a noisy sample came from. A sample q's origin then has
// the posterior exp(-|q - x|² / 2σ²) dA(x) over the surface (a dense uniform sample of the mesh
// within 3σ, weights summed per face). "position" points q's normal where the largest posterior
// weight of face normals agrees with it (candidates: the weighted mean, the heaviest faces'
// normals and the bisectors of their pairs); "lines" keeps each input normal's line and only picks
// its sign by that weight. Each gives the share of samples whose answer opposes their own origin's
// normal: what orientation from positions alone cannot go below (up to the candidate search).
struct OracleFlips
{
  double position = 0, lines = 0;
};

OracleFlips
orientationOracle (const TriangleMesh& mesh, const SampledCloud& noisy, double sigma_abs,
                   const pcl::PointCloud<pcl::Normal>& lines, int threads)
{
  OracleFlips out;
  const std::size_t n = noisy.cloud.size ();
  if (n == 0 || !(sigma_abs > 0))
    return out;
  // Dense enough that a 3σ ball holds ~200 samples of a flat surface.
  const double per_ball = 200.0 * mesh.totalArea () / (9.0 * M_PI * sigma_abs * sigma_abs);
  const std::size_t n_dense = std::size_t (std::clamp (per_ball, 4.0e5, 8.0e6));
  const SampledCloud dense = sampleUniform (mesh, n_dense, 29);
  pcl::PointCloud<pcl::PointXYZ>::Ptr dp (new pcl::PointCloud<pcl::PointXYZ>);
  dp->resize (dense.cloud.size ());
  for (std::size_t i = 0; i < dense.cloud.size (); ++i)
    (*dp)[i].getVector3fMap () = dense.cloud[i].getVector3fMap ();
  pcl::KdTreeFLANN<pcl::PointXYZ> tree;
  tree.setInputCloud (dp);
  const float r = float (3 * sigma_abs);
  const double inv2s2 = 1.0 / (2 * sigma_abs * sigma_abs);
  std::size_t wrong_pos = 0, wrong_lines = 0;
#pragma omp parallel num_threads (threads) reduction (+ : wrong_pos, wrong_lines)
  {
    pcl::Indices idx;
    std::vector<float> d2;
    std::vector<std::pair<int, double>> fw;  // (face, posterior weight)
#pragma omp for schedule (dynamic, 256)
    for (std::ptrdiff_t i = 0; i < std::ptrdiff_t (n); ++i)
    {
      pcl::PointXYZ q;
      q.getVector3fMap () = noisy.cloud[i].getVector3fMap ();
      const Eigen::Vector3d truth = noisy.cloud[i].getNormalVector3fMap ().cast<double> ();
      fw.clear ();
      if (tree.radiusSearch (q, r, idx, d2) > 0)
        for (std::size_t j = 0; j < idx.size (); ++j)
          fw.emplace_back (dense.face[idx[j]], std::exp (-d2[j] * inv2s2));
      if (fw.empty ())  // nothing within 3σ: the nearest face decides
      {
        tree.nearestKSearch (q, 1, idx, d2);
        fw.emplace_back (dense.face[idx[0]], 1.0);
      }
      std::sort (fw.begin (), fw.end ());
      std::size_t m = 0;
      for (std::size_t j = 0; j < fw.size (); ++j)
        if (m > 0 && fw[m - 1].first == fw[j].first)
          fw[m - 1].second += fw[j].second;
        else
          fw[m++] = fw[j];
      fw.resize (m);
      std::vector<std::pair<Eigen::Vector3d, double>> nw (m);
      Eigen::Vector3d mean = Eigen::Vector3d::Zero ();
      for (std::size_t j = 0; j < m; ++j)
      {
        nw[j] = {mesh.faceNormal (fw[j].first).cast<double> (), fw[j].second};
        mean += nw[j].second * nw[j].first;
      }
      auto agree = [&] (const Eigen::Vector3d& d) {
        double w = 0;
        for (const auto& [nf, wf] : nw)
          w += nf.dot (d) > 0 ? wf : 0.0;
        return w;
      };
      double total = 0;
      for (const auto& e : nw)
        total += e.second;
      Eigen::Vector3d best = mean;
      double best_w = agree (mean);
      if (best_w < total)  // some face disagrees with the mean: search the candidates
      {
        std::sort (nw.begin (), nw.end (), [] (const auto& a, const auto& b) { return a.second > b.second; });
        const std::size_t top = std::min<std::size_t> (nw.size (), 32), pairs = std::min<std::size_t> (nw.size (), 12);
        auto consider = [&] (const Eigen::Vector3d& d) {
          const double w = agree (d);
          if (w > best_w)
          {
            best_w = w;
            best = d;
          }
        };
        for (std::size_t a = 0; a < top; ++a)
          consider (nw[a].first);
        for (std::size_t a = 0; a < pairs; ++a)
          for (std::size_t b = a + 1; b < pairs; ++b)
            if ((nw[a].first + nw[b].first).squaredNorm () > 1e-12)
              consider ((nw[a].first + nw[b].first).normalized ());
      }
      wrong_pos += best.dot (truth) < 0;
      const Eigen::Vector3d l = lines[i].getNormalVector3fMap ().cast<double> ();
      if (l.allFinite ())
      {
        const double plus = agree (l), minus = agree (-l);
        wrong_lines += (plus >= minus ? l : Eigen::Vector3d (-l)).dot (truth) < 0;
      }
      else
        ++wrong_lines;
    }
  }
  out.position = double (wrong_pos) / n;
  out.lines = double (wrong_lines) / n;
  return out;
}

struct Shape
{
  std::string name;
  TriangleMesh mesh;           // empty for PCPNet clouds
  SampledCloud cloud;          // PCPNet: the cloud itself
  bool oriented = false;       // truth normals oriented outward (closed, consistent mesh)
};

SampledCloud
sampleShape (const Shape& s, std::size_t n, std::uint32_t seed)
{
  if (s.mesh.faces.empty ())
    return s.cloud;
  return sampleUniform (s.mesh, n, seed);
}

struct Result
{
  std::string method;
  double seconds, rms;
  Metrics m;
  double cpu_seconds = 0;  // process CPU time (all threads), best of the repeats
};

class WideRun
{
public:
  WideRun (const WideOptions& opt, CsvWriter& out) : opt_ (opt), out_ (out) {}

  int run ();

private:
  std::vector<Shape> shapes ();
  std::vector<int> pcaKs () const
  {
    return opt_.quick ? std::vector<int>{12, 18, 50} : std::vector<int>{12, 18, 30, 50, 100, 200};
  }
  Result ours (const pcl::PointCloud<pcl::PointXYZ>::Ptr& cloud, const SampledCloud& truth, Normals* out = nullptr,
               int repeats = 1);
  Result pca (const pcl::PointCloud<pcl::PointXYZ>::Ptr& cloud, const SampledCloud& truth, int k, int repeats = 1,
              Normals* out = nullptr);
  void wideCase (const Shape& shape, const SampledCloud& clean, float sigma);
  void speed (const std::vector<Shape>& shapes);
  void orientCase (const Shape& shape, const SampledCloud& clean, float sigma);
  std::string orientRows (const pcl::PointCloud<pcl::PointXYZ>::Ptr& cloud, const SampledCloud& s,
                          const std::string& params, const std::string& input,
                          const std::vector<std::pair<std::string, const Normals*>>& inputs, bool open3d);
  void emit (const Result& r, const std::string& params, const std::string& input, std::size_t n)
  {
    out_.row ("normals", r.method, params, input, n, r.seconds, r.m);
  }
  // Speed rows: the metrics end with cpu_seconds and repeats (after the columns the scripts read).
  void emitSpeed (Result r, const std::string& params, const std::string& input, std::size_t n)
  {
    r.m.emplace_back ("cpu_seconds", r.cpu_seconds);
    r.m.emplace_back ("repeats", opt_.speed_repeats);
    emit (r, params, input, n);
  }
  // The lowest-RMS row of a sweep, renamed (oracle_pca, jet_best, vcm_best).
  void emitBest (const std::vector<Result>& sweep, const std::string& name, const std::string& params,
                 const std::string& input, std::size_t n, const std::function<std::string (const Result&)>& choice)
  {
    if (sweep.empty ())
      return;
    const Result best = *std::min_element (sweep.begin (), sweep.end (),
                                           [] (const Result& a, const Result& b) { return a.rms < b.rms; });
    Result r = best;
    r.method = name;
    emit (r, params + ";" + choice (best), input, n);
  }

  const WideOptions& opt_;
  CsvWriter& out_;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now ();
};

std::string
elapsed (std::chrono::steady_clock::time_point t0)
{
  std::ostringstream s;
  s << std::fixed << std::setprecision (0)
    << std::chrono::duration<double> (std::chrono::steady_clock::now () - t0).count () << " s";
  return s.str ();
}

std::vector<Shape>
WideRun::shapes ()
{
  std::vector<Shape> all;
  auto wanted = [&] (const std::string& name) {
    return opt_.shapes.empty () || std::find (opt_.shapes.begin (), opt_.shapes.end (), name) != opt_.shapes.end ();
  };
  namespace fs = std::filesystem;
  const bool have_data = !opt_.quick && !opt_.data.empty () && fs::is_directory (opt_.data);
  if (!opt_.quick && !have_data)
    std::cerr << "[bench_normals] shared data folder '" << opt_.data
              << "' not found (--data): generated shapes only\n";
  if (have_data)
  {
    for (const auto& [name, rel] : {std::pair<std::string, std::string> ("fertility", "meshes/fertility.ply"),
                                    std::pair<std::string, std::string> ("bunny_mesh", "bunny/reconstruction/bun_zipper.ply")})
    {
      if (!wanted (name))
        continue;
      const fs::path p = fs::path (opt_.data) / rel;
      if (!fs::exists (p))
      {
        std::cerr << "[bench_normals] " << p << " missing: " << name << " skipped\n";
        continue;
      }
      Shape s{name, loadPlyMesh (p.string ()), {}, false};
      bool outward = false;
      s.oriented = consistentlyOriented (s.mesh, outward);
      if (s.oriented && !outward)
        for (auto& f : s.mesh.faces)
          std::swap (f[1], f[2]);
      pclx::bench::progress () << "[bench_normals] " << name << ": " << s.mesh.faces.size () << " faces, "
                               << (s.oriented
                                       ? (std::string ("closed and consistently oriented") +
                                          (outward ? "" : " (flipped to outward)"))
                                       : std::string ("not closed or not consistently oriented: no orientation rows"))
                               << "\n";
      all.push_back (std::move (s));
    }
    for (const char* name : {"bunny100k", "fandisk100k", "151A_100k_0"})
    {
      if (!wanted (name))
        continue;
      Shape s{name, {}, {}, false};
      if (loadPcpnet (opt_.data + "/pcpnet/" + name, s.cloud))
        all.push_back (std::move (s));
      else
        std::cerr << "[bench_normals] PCPNet " << name << " missing: skipped\n";
    }
  }
  if (wanted ("cube"))
    all.push_back ({"cube", makeBox (Eigen::Vector3f::Ones (), 16), {}, true});
  if (wanted ("grooved_slab"))
    all.push_back ({"grooved_slab", makeGroovedSlab (), {}, true});
  return all;
}

Result
WideRun::ours (const pcl::PointCloud<pcl::PointXYZ>::Ptr& cloud, const SampledCloud& truth, Normals* out, int repeats)
{
  Estimator ne;
  ne.setInputCloud (cloud);
  ne.setNumberOfThreads (opt_.threads);
  Normals normals;
  const auto [t, cpu] = timeBestWallCpu ([&] { ne.compute (normals); }, repeats);
  const auto e = pcl::compareNormals (normals, truth.cloud);
  Metrics m = errorMetrics (e);
  const auto& st = ne.getPointStatus ();
  m.emplace_back ("knn_share", st.empty () ? 0.0
                                           : double (std::count (st.begin (), st.end (), std::uint8_t (Estimator::KNN_PCA))) /
                                                 st.size ());
  if (out)
    *out = std::move (normals);
  return {"ours", t, e.rms_deg, m, cpu};
}

Result
WideRun::pca (const pcl::PointCloud<pcl::PointXYZ>::Ptr& cloud, const SampledCloud& truth, int k, int repeats,
              Normals* out)
{
  pcl::NormalEstimationOMP<pcl::PointXYZ, pcl::Normal> ne (opt_.threads);
  ne.setInputCloud (cloud);
  ne.setKSearch (k);
  Normals normals;
  const auto [t, cpu] = timeBestWallCpu ([&] { ne.compute (normals); }, repeats);
  const auto e = pcl::compareNormals (normals, truth.cloud);
  if (out)
    *out = std::move (normals);
  return {"pca_k" + std::to_string (k), t, e.rms_deg, errorMetrics (e), cpu};
}

Normals
toPcl (const std::vector<Eigen::Vector3f>& n)
{
  Normals out (n.size (), 1);
  for (std::size_t i = 0; i < n.size (); ++i)
    out[i].getNormalVector3fMap () = n[i];
  return out;
}

void
WideRun::wideCase (const Shape& shape, const SampledCloud& clean, float sigma)
{
  const auto t0 = std::chrono::steady_clock::now ();
  const SampledCloud s = withNoise (clean, sigma);
  const auto cloud = positions (s.cloud);
  const std::size_t n = cloud->size ();
  const std::string params = "sweep=wide;noise=" + fmt (sigma);
  const std::string& input = shape.name;

  Normals our_normals;
  const Result o = ours (cloud, s, &our_normals);
  emit (o, params, input, n);

  std::vector<Result> pcas;
  Normals pca18;
  for (int k : pcaKs ())
  {
    pcas.push_back (pca (cloud, s, k, 1, k == 18 ? &pca18 : nullptr));
    emit (pcas.back (), params, input, n);
  }
  emitBest (pcas, "oracle_pca", params, input, n, [] (const Result& r) { return "k=" + r.method.substr (5); });
  const Result oracle = *std::min_element (pcas.begin (), pcas.end (),
                                           [] (const Result& a, const Result& b) { return a.rms < b.rms; });
  std::string extra;
  if (opt_.peers == "all")
  {
    std::vector<Eigen::Vector3f> pts (n), nrm;
    for (std::size_t i = 0; i < n; ++i)
      pts[i] = (*cloud)[i].getVector3fMap ();
#ifdef PCLX_HAVE_CGAL_PEER
    if (opt_.cgal)
    {
      // Jet over growing k, stopped at the first k that is worse than the one before (the
      // error is unimodal in k here; it saves the k = 200 run on clean and mildly noisy clouds).
      std::vector<Result> jets;
      for (int k : opt_.quick ? std::vector<int>{18} : std::vector<int>{18, 50, 100, 200})
      {
        const double t = cgal_peer::jetNormals (pts, k, opt_.threads, nrm);
        const auto e = pcl::compareNormals (toPcl (nrm), s.cloud);
        jets.push_back ({"jet_k" + std::to_string (k), t, e.rms_deg, errorMetrics (e)});
        emit (jets.back (), params, input, n);
        if (jets.size () > 1 && jets.back ().rms > jets[jets.size () - 2].rms)
          break;
      }
      emitBest (jets, "jet_best", params, input, n, [] (const Result& r) { return "k=" + r.method.substr (5); });
      // VCM radii in point spacings h: the offset radius R follows the feature size, the
      // convolution radius r the noise (CGAL's documentation). R ∈ {2, 5} h (10 h was worse than
      // 5 h on the cube at σ = 0.006, and each offset step costs 15-40 s at 100k points here);
      // r ∈ {2, 5, 10} h, all convolved from one offset step.
      const double h = pointSpacing (positions (clean.cloud));
      const std::vector<int> conv = opt_.quick ? std::vector<int>{2} : std::vector<int>{2, 5, 10};
      std::vector<double> conv_h;
      for (int b : conv)
        conv_h.push_back (b * h);
      std::vector<Result> vcms;
      for (int a : opt_.quick ? std::vector<int>{2} : std::vector<int>{2, 5})
      {
        std::vector<std::vector<Eigen::Vector3f>> nrms;
        std::vector<double> secs;
        cgal_peer::vcmNormalsSweep (pts, a * h, conv_h, nrms, secs);
        for (std::size_t j = 0; j < conv.size (); ++j)
        {
          const auto e = pcl::compareNormals (toPcl (nrms[j]), s.cloud);
          Metrics m = errorMetrics (e);
          m.emplace_back ("offset_radius", a * h);
          m.emplace_back ("convolution_radius", conv_h[j]);
          vcms.push_back ({"vcm_R" + std::to_string (a) + "_r" + std::to_string (conv[j]), secs[j], e.rms_deg, m});
          emit (vcms.back (), params, input, n);
        }
      }
      emitBest (vcms, "vcm_best", params, input, n, [] (const Result& r) {
        const auto u = r.method.find ("_r");
        return "R=" + r.method.substr (5, u - 5) + ";r=" + r.method.substr (u + 2);
      });
      const auto bj = std::min_element (jets.begin (), jets.end (), [] (auto& a, auto& b) { return a.rms < b.rms; });
      const auto bv = std::min_element (vcms.begin (), vcms.end (), [] (auto& a, auto& b) { return a.rms < b.rms; });
      std::ostringstream x;
      x << std::fixed << std::setprecision (2) << ", jet " << bj->rms << "° (" << bj->method << "), vcm " << bv->rms
        << "° (" << bv->method << ")";
      extra += x.str ();
    }
#endif
#ifdef PCLX_HAVE_OPEN3D
    if (opt_.open3d)
    {
      std::vector<Eigen::Vector3d> p3 (n), n3;
      for (std::size_t i = 0; i < n; ++i)
        p3[i] = pts[i].cast<double> ();
      auto row = [&] (const std::string& name, double t, const Metrics& extra_m) {
        std::vector<Eigen::Vector3f> nf (n);
        for (std::size_t i = 0; i < n; ++i)
          nf[i] = n3[i].cast<float> ();
        const auto e = pcl::compareNormals (toPcl (nf), s.cloud);
        Metrics m = errorMetrics (e);
        m.insert (m.end (), extra_m.begin (), extra_m.end ());
        emit ({name, t, e.rms_deg, m}, params, input, n);
      };
      row ("open3d_k18", open3d_peer::estimateNormals (p3, 18, n3), {});
      // Hybrid search as Open3D's tutorials use it: a radius of a few spacings, at most 30.
      const double radius = 4 * pointSpacing (positions (clean.cloud));
      row ("open3d_hybrid", open3d_peer::estimateNormalsHybrid (p3, radius, 30, n3),
           {{"radius", radius}, {"max_nn", 30}});
    }
#endif
    if (shape.oriented)
      extra += orientRows (cloud, s, params, input, {{"orient_mst_ours", &our_normals}, {"orient_mst_pca_k18", &pca18}},
                           false);
  }
  pclx::bench::progress () << std::fixed << std::setprecision (2) << "[bench_normals] wide " << input
                           << " σ=" << fmt (sigma) << ": ours " << o.rms << "° " << o.seconds << " s, oracle PCA "
                           << oracle.rms << "° (" << oracle.method << ", " << oracle.seconds << " s)" << extra << "  ["
                           << elapsed (t0) << ", total " << elapsed (start_) << "]\n"
                           << std::defaultfloat;
}

// MST (k = 10) on each set of normals: flipped share against the oriented truth, overall and
// among the points whose unoriented error is < 60° (a normal further off has no meaningful
// sign). With open3d, Open3D's OrientNormalsConsistentTangentPlane (k = 10) on the first set
// too, for the time ratio. Returns the progress text.
std::string
WideRun::orientRows (const pcl::PointCloud<pcl::PointXYZ>::Ptr& cloud, const SampledCloud& s, const std::string& params,
                     const std::string& input, const std::vector<std::pair<std::string, const Normals*>>& inputs,
                     bool open3d)
{
  const std::size_t n = cloud->size ();
  auto metrics = [&] (const Normals& oriented, const Normals& unoriented) {
    const auto e = pcl::compareNormals (oriented, s.cloud, true);
    const auto un = pcl::angleErrorsDeg (unoriented, s.cloud);
    const auto ori = pcl::angleErrorsDeg (oriented, s.cloud, true);
    std::size_t good = 0, good_flipped = 0;
    for (std::size_t i = 0; i < n; ++i)
      if (!std::isnan (un[i]) && un[i] < 60.0)
      {
        ++good;
        good_flipped += ori[i] > 90.0;
      }
    return Metrics{{"flipped", e.flipped},
                   {"flipped_lt60", good ? double (good_flipped) / good : 0.0},
                   {"share_lt60", n ? double (good) / n : 0.0},
                   {"rms_oriented", e.rms_deg}};
  };
  std::ostringstream x;
  x << std::setprecision (3);
  for (const auto& [name, normals] : inputs)
  {
    pcl::MSTNormalOrientation<pcl::PointXYZ, pcl::Normal> mst;
    mst.setInputCloud (cloud);
    mst.setKSearch (10);
    mst.setNumberOfThreads (opt_.threads);
    Normals oriented;
    const double t = timeBest ([&] { oriented = *normals; mst.orient (oriented); }, 1);
    Metrics m = metrics (oriented, *normals);
    m.emplace_back ("components", double (mst.getNumberOfComponents ()));
    out_.row ("normals", name, params + ";k=10", input, n, t, m);
    x << ", " << name.substr (7) << " " << 100 * m[0].second << " % (<60°: " << 100 * m[1].second << " %) " << t
      << " s";
  }
#ifdef PCLX_HAVE_OPEN3D
  if (open3d && opt_.open3d && !inputs.empty ())
  {
    std::vector<Eigen::Vector3d> p3 (n), n3 (n);
    for (std::size_t i = 0; i < n; ++i)
    {
      p3[i] = (*cloud)[i].getVector3fMap ().cast<double> ();
      n3[i] = (*inputs.front ().second)[i].getNormalVector3fMap ().cast<double> ();
    }
    const double t = open3d_peer::orientConsistent (p3, n3, 10);
    Normals oriented = toPcl ([&] {
      std::vector<Eigen::Vector3f> nf (n);
      for (std::size_t i = 0; i < n; ++i)
        nf[i] = n3[i].cast<float> ();
      return nf;
    }());
    const std::string name = "orient_open3d_" + inputs.front ().first.substr (11);
    out_.row ("normals", name, params + ";k=10", input, n, t, metrics (oriented, *inputs.front ().second));
    x << ", Open3D " << 100 * metrics (oriented, *inputs.front ().second)[0].second << " % " << t << " s";
  }
#else
  (void) open3d;
#endif
  return x.str ();
}

// --orient: the orientation rows alone, with our, PCA k = 18 and exact (truth) normals as input,
// and Open3D's orientation of our normals in the same run.
void
WideRun::orientCase (const Shape& shape, const SampledCloud& clean, float sigma)
{
  const auto t0 = std::chrono::steady_clock::now ();
  const SampledCloud s = withNoise (clean, sigma);
  const auto cloud = positions (s.cloud);
  Normals our_normals, pca18, exact (s.cloud.size (), 1);
  ours (cloud, s, &our_normals);
  pca (cloud, s, 18, 1, &pca18);
  // Exact normals with random signs (the orientation must not read the truth's).
  std::mt19937 rng (5);
  for (std::size_t i = 0; i < exact.size (); ++i)
    exact[i].getNormalVector3fMap () = s.cloud[i].getNormalVector3fMap () * ((rng () & 1) ? 1.f : -1.f);
  // Open3D's orientation builds a Delaunay tetrahedralization (qhull) first, which ran for
  // minutes on the clean cube's coplanar faces: generated shapes get it on noisy clouds only.
  const bool open3d = sigma > 0 || !shape.cloud.cloud.empty () || shape.name == "fertility";
  const std::string text = orientRows (cloud, s, "sweep=orient;noise=" + fmt (sigma), shape.name,
                                       {{"orient_mst_ours", &our_normals},
                                        {"orient_mst_pca_k18", &pca18},
                                        {"orient_mst_exact", &exact}},
                                       open3d);
  std::string oracle;
  if (sigma > 0 && !shape.mesh.faces.empty ())
  {
    const auto to = std::chrono::steady_clock::now ();
    Eigen::Vector4f lo, hi;  // addGaussianNoise's σ is relative to the clean cloud's diagonal
    pcl::getMinMax3D (clean.cloud, lo, hi);
    const double sigma_abs = double (sigma) * (hi - lo).head<3> ().norm ();
    const OracleFlips f = orientationOracle (shape.mesh, s, sigma_abs, our_normals, opt_.threads);
    const double t = std::chrono::duration<double> (std::chrono::steady_clock::now () - to).count ();
    const std::string params = "sweep=orient;noise=" + fmt (sigma);
    out_.row ("normals", "orient_oracle_position", params, shape.name, s.cloud.size (), t, {{"flipped", f.position}});
    out_.row ("normals", "orient_oracle_ours_lines", params, shape.name, s.cloud.size (), t, {{"flipped", f.lines}});
    std::ostringstream x;
    x << std::setprecision (3) << ", oracle from positions " << 100 * f.position << " %, with our lines "
      << 100 * f.lines << " %";
    oracle = x.str ();
  }
  pclx::bench::progress () << "[bench_normals] orient " << shape.name << " σ=" << fmt (sigma) << text << oracle << "  ["
                           << elapsed (t0) << "]\n";
}

void
WideRun::speed (const std::vector<Shape>& shapes)
{
  const std::vector<std::size_t> sizes = !opt_.speed_sizes.empty () ? opt_.speed_sizes
                                        : opt_.quick ? std::vector<std::size_t>{3000, 6000}
                                                     : std::vector<std::size_t>{100000, 300000, 1000000};
  const int repeats = opt_.speed_repeats;
  for (const auto& shape : shapes)
  {
    if (shape.mesh.faces.empty ())
      continue;
    for (std::size_t n : sizes)
    {
      const auto t0 = std::chrono::steady_clock::now ();
      const SampledCloud s = sampleUniform (shape.mesh, n, 21);
      const auto cloud = positions (s.cloud);
      const Result o = ours (cloud, s, nullptr, repeats);
      Result p = pca (cloud, s, 18, repeats);
      p.method = "pcl_omp_k18";
      emitSpeed (o, "sweep=speed;noise=0", shape.name, n);
      emitSpeed (p, "sweep=speed;noise=0", shape.name, n);
      pclx::bench::progress () << std::fixed << std::setprecision (2) << "[bench_normals] speed " << shape.name << " "
                               << n << ": ours " << o.seconds << " s (CPU " << o.cpu_seconds << " s) " << o.rms
                               << "°, PCL k=18 " << p.seconds << " s (CPU " << p.cpu_seconds << " s) " << p.rms << "° ("
                               << p.seconds / o.seconds << "x wall, " << p.cpu_seconds / o.cpu_seconds << "x CPU)  ["
                               << elapsed (t0) << "]\n"
                               << std::defaultfloat;
    }
    // Noisy: ours against PCA at the k the oracle picks for this shape and σ.
    for (float sigma : opt_.speed_noisy ? std::vector<float>{0.006f, 0.012f} : std::vector<float>{})
    {
      const auto t0 = std::chrono::steady_clock::now ();
      SampledCloud s = sampleUniform (shape.mesh, opt_.quick ? sizes.front () : opt_.points, 21);
      addGaussianNoise (s, sigma, kNoiseSeed);
      const auto cloud = positions (s.cloud);
      Result best{"", 0, 1e300, {}};
      int best_k = 0;
      for (int k : pcaKs ())
      {
        const Result r = pca (cloud, s, k);
        if (r.rms < best.rms)
          best = r, best_k = k;
      }
      const std::string params = "sweep=speed;noise=" + fmt (sigma) + ";k=" + std::to_string (best_k);
      const Result o = ours (cloud, s, nullptr, repeats);
      Result p = pca (cloud, s, best_k, repeats);
      p.method = "pca_oracle";
      emitSpeed (o, params, shape.name, cloud->size ());
      emitSpeed (p, params, shape.name, cloud->size ());
      pclx::bench::progress () << std::fixed << std::setprecision (2) << "[bench_normals] speed " << shape.name
                               << " σ=" << fmt (sigma) << ": ours " << o.seconds << " s (CPU " << o.cpu_seconds
                               << " s) " << o.rms << "°, PCA oracle k=" << best_k << " " << p.seconds << " s (CPU "
                               << p.cpu_seconds << " s) " << p.rms << "°  [" << elapsed (t0) << "]\n"
                               << std::defaultfloat;
    }
  }
}

int
WideRun::run ()
{
  omp_set_num_threads (opt_.threads);  // Open3D's OpenMP loops too
#ifdef PCLX_HAVE_CGAL_PEER
  if (opt_.cgal && opt_.peers == "all")
    pclx::bench::progress () << "[bench_normals] CGAL jet_estimate_normals: " << cgal_peer::jetConcurrency ()
                             << "; vcm_estimate_normals: sequential\n";
#else
  std::cerr << "[bench_normals] built without the CGAL peer: no jet / VCM rows\n";
#endif
#ifndef PCLX_HAVE_OPEN3D
  std::cerr << "[bench_normals] built without Open3D: no Open3D rows\n";
#endif
  const std::vector<Shape> all = shapes ();
  if (all.empty ())
  {
    std::cerr << "[bench_normals] no shape left (--shapes)\n";
    return 2;
  }
  const std::size_t n = opt_.quick ? 4000 : opt_.points;
  if (opt_.orient)
  {
    for (const auto& shape : all)
      if (shape.oriented)
      {
        const SampledCloud clean = sampleShape (shape, n, 17);
        for (float sigma : opt_.quick ? std::vector<float>{0.f, 0.006f} : std::vector<float>{0.f, 0.0012f, 0.006f, 0.012f})
          orientCase (shape, clean, sigma);
      }
  }
  if (opt_.wide)
  {
    const std::vector<float> sigmas =
        opt_.quick ? std::vector<float>{0.f, 0.006f} : std::vector<float>{0.f, 0.0012f, 0.006f, 0.012f};
    for (const auto& shape : all)
    {
      const SampledCloud clean = sampleShape (shape, n, 17);
      if (!opt_.dump.empty ())
        pcl::io::savePLYFileBinary (opt_.dump + "/" + shape.name + ".ply", clean.cloud);
      for (float sigma : sigmas)
        wideCase (shape, clean, sigma);
    }
  }
  if (opt_.speed)
  {
    // Detailed organic meshes (generated shapes when the data folder is missing).
    std::vector<Shape> meshes;
    for (const auto& s : all)
      if (s.name == "fertility" || s.name == "bunny_mesh")
        meshes.push_back (s);
    if (meshes.empty ())
      for (const auto& s : all)
        if (!s.mesh.faces.empty ())
          meshes.push_back (s);
    speed (meshes);
  }
  pclx::bench::progress () << "[bench_normals] done in " << elapsed (start_) << "\n";
  return 0;
}

}  // namespace

int
runWide (const WideOptions& opt, CsvWriter& out)
{
  WideRun run (opt, out);
  return run.run ();
}

}  // namespace bench
}  // namespace pclx
