// pcl::ObliqueCutOctree (OMiCroN) benchmark, peers in the same run.
//
// Inputs are binary PCDs written once to a work folder (mesh samplings of the Stanford bunny and
// fertility when ../shared/data is present, a generated scene of pclx_testing shapes, a lattice
// of integer points, a cloud with 10 % distinct positions; on request the scene as a scan with
// intensity, and with colour and intensity). Per input and size, one process:
//   pcl_load        pcl::io::loadPCDFile into PointXYZ          fread   the file's bytes
//   omicron         our build (front off / on with an orbiting camera thread), sweeps of
//                   ratio × leaf collapse, worklist size, sort chunks, a memory budget (when the
//                   API has one), hierarchy completion over time (thesis Fig. 4.4)
//                   (also from the file: setInputFile without budget, read in blocks by the build;
//                   its front-off row writes the Potree folder and does not feed the front)
//   topdown_10k     a top-down octree split at 10,000 points with a ratio LOD sample per inner node
//   pcl_octree      pcl::octree::OctreePointCloudPointVector at the depth-7 leaf cell (no LOD)
//   pcl_outofcore   pcl_outofcore_process -depth 7 -gen_lod (subprocess, /usr/bin/time -v)
// Every build runs in a forked child of the process that loaded the cloud, which resets its
// VmHWM (clear_refs 5) after the fork: peaks are per row, deltas over the loaded cloud. The
// builds from the file run in children forked before the load: their peak is the whole process's.
// The scans with attributes get the file-to-Potree row (as pclx::PointXYZIPacked, or
// pclx::PointXYZRGBI with colour), PCL's load (PointXYZI, PointXYZRGBI) and outofcore only.
// Rows (bench/common/bench_csv.h):
//   omicron,<method>,sweep=..;ratio=..;collapse=..;worklist=..;chunks=..;front=..,<input>,<n>,<s>,metric,value,...
#include "bench_csv.h"

#include <pclx/omicron/camera.h>
#include <pclx/omicron/oblique_cut_octree.h>
#include <pclx/omicron/potree_reader.h>
#include <pclx/omicron/point_xyzi_packed.h>
#include <pclx/omicron/point_xyzrgbi.h>
#include <pclx/omicron/potree_writer.h>
#include <pclx/testing/shapes.h>
#include <pclx/testing/triangle_mesh.h>

#include <pcl/io/pcd_io.h>
#include <pcl/octree/octree_pointcloud_pointvector.h>
#include <pcl/point_types.h>

#include <CLI/CLI.hpp>

#include <fcntl.h>
#include <malloc.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <map>
#include <numeric>
#include <random>
#include <sstream>
#include <thread>
#include <type_traits>

namespace fs = std::filesystem;
using pclx::bench::CsvWriter;
using pclx::bench::Metrics;
using Cloud = pcl::PointCloud<pcl::PointXYZ>;
using Octree = pcl::ObliqueCutOctree<pcl::PointXYZ>;
using Clock = std::chrono::steady_clock;

namespace {

double
since (Clock::time_point t0)
{
  return std::chrono::duration<double> (Clock::now () - t0).count ();
}

std::string
fmt (double v)
{
  std::ostringstream s;
  s << std::setprecision (4) << v;
  return s.str ();
}

std::string
sizeLabel (std::size_t n)
{
  if (n % 1000000 == 0)
    return std::to_string (n / 1000000) + "M";
  if (n % 1000 == 0)
    return std::to_string (n / 1000) + "k";
  return std::to_string (n);
}

// ---------------------------------------------------------------------------------------------
// Input files: binary PCD (x y z float, and for the scans with attributes an intensity float and
// a packed rgb), written in blocks so 100M points never sit in memory as PointNormal samples.

// What a record holds beside x y z: a laser scan's intensity, and a colourised scan's colour.
enum class Attributes
{
  kNone,
  kIntensity,
  kColourIntensity
};

std::size_t
recordFloats (Attributes a)
{
  return a == Attributes::kNone ? 3 : a == Attributes::kIntensity ? 4 : 5;
}

// The inputs named scene_intensity and scene_rgbi carry attributes; the others are x y z.
Attributes
attributesOf (const std::string& input)
{
  if (input == "scene_intensity")
    return Attributes::kIntensity;
  if (input == "scene_rgbi")
    return Attributes::kColourIntensity;
  return Attributes::kNone;
}

std::string
pcdHeader (std::size_t n, Attributes a)
{
  std::ostringstream h;
  h << "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n";
  switch (a)
  {
    case Attributes::kNone: h << "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"; break;
    case Attributes::kIntensity: h << "FIELDS x y z intensity\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\n"; break;
    case Attributes::kColourIntensity:
      h << "FIELDS x y z rgb intensity\nSIZE 4 4 4 4 4\nTYPE F F F U F\nCOUNT 1 1 1 1 1\n";
      break;
  }
  h << "WIDTH " << n << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << n << "\nDATA binary\n";
  return h.str ();
}

std::uintmax_t
expectedPcdBytes (std::size_t n, Attributes a)
{
  return pcdHeader (n, a).size () + 4 * recordFloats (a) * std::uintmax_t (n);
}

// A scanner-like intensity and colour from the position: smooth bands with a speckle, so the
// values vary within a node as a scan's do.
void
attributesAt (const float* p, std::size_t i, Attributes a, float* out)
{
  const float band = 0.5f + 0.4f * std::sin (0.7f * p[0]) * std::cos (0.9f * p[1]);
  const float speckle = float ((i * 2654435761u) % 1000u) * 1e-4f;
  const float intensity = band + speckle;
  if (a == Attributes::kColourIntensity)
  {
    const auto channel = [] (float v) { return std::uint32_t (std::clamp (v, 0.f, 1.f) * 255.f); };
    const std::uint32_t rgb = (channel (band) << 16) | (channel (0.5f + 0.05f * p[2]) << 8) | channel (1 - band);
    std::memcpy (out, &rgb, 4);
    out[1] = intensity;
  }
  else if (a == Attributes::kIntensity)
    out[0] = intensity;
}

// Writes n points produced by gen(i, float[3]) (called in order) to `path`, with the attributes
// `a` derived from each position.
void
writePcd (const std::string& path, std::size_t n, const std::function<void (std::size_t, float*)>& gen,
          Attributes a = Attributes::kNone)
{
  const std::string tmp = path + ".tmp";
  std::FILE* f = std::fopen (tmp.c_str (), "wb");
  if (!f)
    throw std::runtime_error ("cannot write " + tmp);
  const std::string h = pcdHeader (n, a);
  std::fwrite (h.data (), 1, h.size (), f);
  const std::size_t k = recordFloats (a);
  std::vector<float> block;
  const std::size_t kBlock = 1 << 20;
  for (std::size_t b = 0; b < n; b += kBlock)
  {
    const std::size_t m = std::min (kBlock, n - b);
    block.resize (k * m);
    for (std::size_t i = 0; i < m; ++i)
    {
      gen (b + i, block.data () + k * i);
      attributesAt (block.data () + k * i, b + i, a, block.data () + k * i + 3);
    }
    if (std::fwrite (block.data (), sizeof (float), block.size (), f) != block.size ())
      throw std::runtime_error ("short write to " + tmp);
  }
  std::fclose (f);
  fs::rename (tmp, path);
}

// Area-uniform sampler of a triangle mesh (streaming: one face table, no per-point storage).
class MeshSampler
{
public:
  MeshSampler (const pclx::testing::TriangleMesh& mesh, std::uint64_t seed) : mesh_ (mesh), rng_ (seed)
  {
    cdf_.resize (mesh.faces.size ());
    double acc = 0;
    for (std::size_t f = 0; f < mesh.faces.size (); ++f)
      cdf_[f] = acc += mesh.faceArea (f);
  }
  void
  sample (float* out)
  {
    std::uniform_real_distribution<double> u (0.0, 1.0);
    const double r = u (rng_) * cdf_.back ();
    const std::size_t f = std::min<std::size_t> (std::upper_bound (cdf_.begin (), cdf_.end (), r) - cdf_.begin (),
                                                 cdf_.size () - 1);
    double a = u (rng_), b = u (rng_);
    if (a + b > 1)
    {
      a = 1 - a;
      b = 1 - b;
    }
    const Eigen::Vector3i& t = mesh_.faces[f];
    const Eigen::Vector3f p = mesh_.vertices[t[0]] + float (a) * (mesh_.vertices[t[1]] - mesh_.vertices[t[0]]) +
                              float (b) * (mesh_.vertices[t[2]] - mesh_.vertices[t[0]]);
    out[0] = p.x ();
    out[1] = p.y ();
    out[2] = p.z ();
  }

private:
  const pclx::testing::TriangleMesh& mesh_;
  std::mt19937_64 rng_;
  std::vector<double> cdf_;
};

// A large scene: pclx_testing shapes spread over a 40 × 40 ground plate.
pclx::testing::TriangleMesh
makeScene ()
{
  using namespace pclx::testing;
  TriangleMesh scene = makeBox (Eigen::Vector3f (40.f, 40.f, 0.2f), 32);
  std::mt19937 rng (11);
  std::uniform_real_distribution<float> pos (-17.f, 17.f), size (0.6f, 2.5f);
  for (int i = 0; i < 24; ++i)
  {
    TriangleMesh m;
    const float s = size (rng);
    switch (i % 4)
    {
      case 0: m = makeSphere (s, 4); break;
      case 1: m = makeTorus (s, 0.3f * s, 96, 32); break;
      case 2: m = makeBox (Eigen::Vector3f (s, 1.5f * s, 2.f * s), 8); break;
      default: m = makeThinPlate (2.f * s, 0.05f * s, 8); break;
    }
    m.transform (Eigen::Affine3f (Eigen::Translation3f (pos (rng), pos (rng), s + 0.1f)));
    scene.append (m);
  }
  return scene;
}

struct Input
{
  std::string name;
  std::function<void (std::size_t, const std::string&)> generate;  // (n, path)
};

// Memory of this process, and rows from children (bench/common): one line each,
// "method\tparams\tseconds\tkey=value;key=value".
using pclx::bench::ChildRow;
using Row = ChildRow;
using pclx::bench::percentile;
using pclx::bench::procStatusKb;

// Runs fn in a forked child (peak memory of its own); fn returns the rows to print.
// Returns false when the child failed (crash, exception, non-zero exit).
bool
inChild (const std::function<std::vector<Row> (std::size_t rss0)>& fn, std::vector<Row>& rows)
{
  // Earlier rows' files are written back first, so no row's writes wait for another's.
  ::sync ();
  const int status = pclx::bench::runInChild (
      [&] (std::vector<Row>& out) {
        try
        {
          const std::size_t rss0 = pclx::bench::resetPeakMemory ();
          out = fn (rss0);
          return 0;
        }
        catch (const std::exception& e)
        {
          std::cerr << "[omicron] child failed: " << e.what () << "\n";
          return 2;
        }
      },
      rows);
  const bool ok = WIFEXITED (status) && WEXITSTATUS (status) == 0;
  if (!ok)
    std::cerr << "[omicron] child " << (WIFSIGNALED (status) ? "killed by signal " + std::to_string (WTERMSIG (status))
                                                             : "exited with " + std::to_string (WEXITSTATUS (status)))
              << "\n";
  return ok;
}

// ---------------------------------------------------------------------------------------------
// Our build.

// setMemoryBudget (bytes) when this version of the octree has it.
template <typename T>
auto
trySetBudget (T& octree, std::size_t bytes, int) -> decltype (octree.setMemoryBudget (bytes), bool ())
{
  octree.setMemoryBudget (bytes);
  return true;
}
template <typename T>
bool
trySetBudget (T&, std::size_t, long)
{
  return false;
}

bool
haveBudget ()
{
  Octree probe;
  return trySetBudget (probe, 0, 0);
}

struct Config
{
  std::string sweep = "main";
  float ratio = 0.2f;
  bool collapse = true;
  std::size_t worklist = 32, chunks = 16;
  int threads = 2, depth = 7;
  bool front = false;       // a thread evaluates the front with an orbiting camera during the build
  bool completion = false;  // sample the fraction of finished nodes over time (Fig. 4.4)
  std::size_t budget = 0;   // setMemoryBudget (bytes), 0 = none
  std::string curve;        // completion curve label
  std::string file, out_dir;  // budgeted builds read the PCD and write Potree output here
  bool from_file = false;     // in-memory build from the file path (setInputFile, no budget)
  std::string potree_dir;     // in-memory builds: also write the Potree folder here (file to Potree)
  bool feed_front = true;     // setFrontDuringBuild (off for an export nobody watches)

  std::string
  params () const
  {
    std::string p = "sweep=" + sweep + ";ratio=" + fmt (ratio) + ";collapse=" + (collapse ? "1" : "0") +
                    ";worklist=" + std::to_string (worklist) + ";chunks=" + std::to_string (chunks) +
                    ";threads=" + std::to_string (threads) + ";front=" + (front ? "1" : "0");
    if (budget)
      p += ";budget_mb=" + fmt (budget / 1048576.0);
    if (from_file)
      p += ";input=file";
    if (!feed_front)
      p += ";front_fed=0";
    if (!curve.empty ())
      p += ";curve=" + curve;
    return p;
  }
};

// An orbit around the root cube, one turn per 4 s, close enough that the front branches deep.
template <typename PointT>
typename pcl::ObliqueCutOctree<PointT>::Camera
orbitCamera (const pcl::ObliqueCutOctree<PointT>& octree, double t)
{
  const Eigen::Vector3f o = octree.getRootOrigin ().template cast<float> ();
  const float edge = float (octree.getRootEdge ());
  const Eigen::Vector3f c = o + Eigen::Vector3f::Constant (edge / 2);
  const float a = float (2 * M_PI * t / 4.0);
  const Eigen::Vector3f eye = c + edge * Eigen::Vector3f (0.8f * std::cos (a), 0.8f * std::sin (a),
                                                          0.3f + 0.2f * std::sin (0.7f * a));
  typename pcl::ObliqueCutOctree<PointT>::Camera cam;
  cam.width = 1920;
  cam.height = 1080;
  cam.view_projection = pcl::perspectiveLookAt (eye, c, float (M_PI) / 3.f, 16.f / 9.f, 0.01f * edge, 10.f * edge);
  return cam;
}

// Nodes that exist (cut roots and everything below them) in the current cut.
template <typename PointT>
std::size_t
finishedNodes (const pcl::ObliqueCut<PointT>& cut)
{
  const auto snap = cut.snapshot ();
  if (snap.complete)
    return std::size_t (-1);
  std::size_t count = 0;
  std::vector<const typename pcl::ObliqueCutOctree<PointT>::Node*> stack;
  for (const auto& list : snap.lists)
    for (const auto& r : list)
    {
      if (r.isPlaceholder ())
        continue;
      ++count;
      for (std::uint8_t j = 0; j < r.num_children; ++j)
        stack.push_back (r.children + j);
    }
  while (!stack.empty ())
  {
    const auto* n = stack.back ();
    stack.pop_back ();
    ++count;
    for (std::uint8_t j = 0; j < n->num_children; ++j)
      stack.push_back (n->children + j);
  }
  return count;
}

// One build of ours on the cloud, or from c.file when cloud is null (PointT: the type the file's
// fields are built as).
template <typename PointT>
std::vector<Row>
runOurs (const typename pcl::PointCloud<PointT>::ConstPtr& cloud, std::size_t n_points, const Config& c,
         std::size_t rss0)
{
  pcl::ObliqueCutOctree<PointT> octree;
  if (cloud)
    octree.setInputCloud (cloud);
  octree.setMaxDepth (c.depth);
  octree.setParentPointRatio (c.ratio);
  octree.setLeafCollapse (c.collapse);
  octree.setWorklistSize (c.worklist);
  octree.setSortChunks (c.chunks);
  octree.setThreads (c.threads);
  octree.setFrontDuringBuild (c.feed_front);
  if (c.budget)
  {
    // Out of core: the file is streamed (pcl::PointStreamReader), the cloud is not touched.
    if (!trySetBudget (octree, c.budget, 0))
      throw std::runtime_error ("no setMemoryBudget in this ObliqueCutOctree");
    octree.setInputFile (c.file);
    octree.setOutputDirectory (c.out_dir);
  }
  else if (c.from_file)
    octree.setInputFile (c.file);  // read in blocks by the build itself (file to tree)

  std::vector<double> frames;
  std::vector<std::pair<double, std::size_t>> samples;  // (s, finished nodes)
  double first_items = -1, front_items_mean = 0;
  std::size_t evaluations = 0, last_items = 0;
  const auto t0 = Clock::now ();
  if (!octree.startBuild ())
    throw std::runtime_error ("startBuild failed");
  std::thread sampler;
  if (c.completion)
    sampler = std::thread ([&] {
      // The cut exists once the first leaf reached the front; it is not replaced until the next build.
      while (!octree.isFinished () && octree.getFront ().secondsToFirstLeaf () < 0)
        std::this_thread::sleep_for (std::chrono::microseconds (500));
      double cost = 0;
      while (!octree.isFinished ())
      {
        // snapshot () cannot see the worklists the fix master has taken out to process (they are
        // between L_l and L_{l-1}), so one count is a lower bound: keep the largest of two
        // snapshots and of the earlier samples (the true count never decreases).
        const auto ts = Clock::now ();
        std::size_t k = finishedNodes (*octree.getCut ());
        if (k != std::size_t (-1))
          k = std::max (k, finishedNodes (*octree.getCut ()));
        cost = since (ts) / 2;
        if (k == std::size_t (-1))
          break;
        samples.emplace_back (since (t0), std::max (k, samples.empty () ? 0 : samples.back ().second));
        // Every 5 ms, or 4× the snapshot's own cost when that is larger (it takes the level locks).
        std::this_thread::sleep_for (std::chrono::duration<double> (std::max (0.005, 4 * cost)));
      }
    });
  if (c.front)
  {
    std::vector<typename pcl::ObliqueCutOctree<PointT>::Item> items;
    while (!octree.isFinished ())
    {
      const auto ts = Clock::now ();
      octree.evaluate (orbitCamera (octree, since (t0)), items);
      const double ms = 1e3 * since (ts);
      if (first_items < 0 && !items.empty ())
        first_items = since (t0);
      if (first_items < 0)
        continue;  // frame statistics from the first front that has something to draw
      frames.push_back (ms);
      ++evaluations;
      front_items_mean += double (items.size ());
      last_items = items.size ();
    }
  }
  const bool ok = octree.wait ();
  const double total = since (t0);
  if (sampler.joinable ())
    sampler.join ();
  if (!ok)
    throw std::runtime_error ("build failed: " + octree.getLastError ());
  const std::size_t hwm = procStatusKb ("VmHWM") * 1024;
  const auto st = octree.getStatistics ();
  std::size_t nodes = 0;
  for (std::size_t k : st.nodes_per_level)
    nodes += k;
  const double n = double (n_points);
  Metrics m{{"read_s", st.seconds_read},
            {"first_chunk_s", st.seconds_to_first_chunk},
            {"first_front_s", st.seconds_to_first_front},
            {"internal_total_s", st.seconds_total},
            {"phase_read_s", st.seconds_read},
            {"phase_sort1_s", st.seconds_to_first_chunk - st.seconds_read},
            {"phase_front_wait_s", std::max (0.0, st.seconds_to_first_front - st.seconds_to_first_chunk)},
            {"phase_rest_s", std::max (0.0, total - std::max (st.seconds_to_first_front, st.seconds_to_first_chunk))},
            {"points_per_s", n / total},
            {"peak_delta_bpp", double (hwm > rss0 ? hwm - rss0 : 0) / n},
            {"peak_total_bpp", double (hwm) / n},
            {"peak_delta_mb", double (hwm > rss0 ? hwm - rss0 : 0) / 1048576.0},
            {"structure_bpp", double (st.sorted_bytes + st.hierarchy_bytes) / n},
            {"hierarchy_bpp", double (st.hierarchy_bytes) / n},
            {"nodes", double (nodes)},
            {"chunks_used", double (st.chunks)},
            {"kept", double (st.kept_points)}};
  if (c.front)
  {
    m.insert (m.end (), {{"first_items_s", first_items},
                         {"evaluations", double (evaluations)},
                         {"frame_p50_ms", percentile (frames, 0.5)},
                         {"frame_p95_ms", percentile (frames, 0.95)},
                         {"frame_max_ms", frames.empty () ? 0 : *std::max_element (frames.begin (), frames.end ())},
                         {"front_items_mean", evaluations ? front_items_mean / evaluations : 0},
                         {"front_items_last", double (last_items)}});
  }
  const auto potreeMetrics = [&] (const std::string& dir) {
    // What a Potree loader gets: points stored (each input point once), nodes and their sizes.
    pcl::PotreeReader reader;
    if (!reader.open (dir))
      throw std::runtime_error (reader.getLastError ());
    std::vector<double> sizes;
    for (const auto& node : reader.getNodes ())
      sizes.push_back (node.num_points);
    m.insert (m.end (), {{"potree_stored", double (reader.getStoredPoints ())},
                         {"potree_stored_over_kept", double (reader.getStoredPoints ()) / double (st.kept_points)},
                         {"potree_nodes", double (sizes.size ())},
                         {"potree_node_points_p50", percentile (sizes, 0.5)},
                         {"potree_node_points_p95", percentile (sizes, 0.95)},
                         {"potree_spacing_over_edge", reader.getMetadata ().spacing / octree.getRootEdge ()}});
  };
  if (!c.potree_dir.empty ())
  {
    const auto tw = Clock::now ();
    pcl::PotreeWriter<PointT> writer;
    if (!writer.write (octree, c.potree_dir))
      throw std::runtime_error (writer.getLastError ());
    const double write_s = since (tw);
    m.insert (m.end (), {{"potree_write_s", write_s}, {"file_to_potree_s", total + write_s}});
    potreeMetrics (c.potree_dir);
    fs::remove_all (c.potree_dir);
  }
  if (c.budget)
  {
    potreeMetrics (c.out_dir);
    m.insert (m.end (), {{"budget_mb", c.budget / 1048576.0},
                         {"peak_over_budget", double (hwm > rss0 ? hwm - rss0 : 0) / double (c.budget)},
                         {"accounted_peak_mb", st.accounted_peak_bytes / 1048576.0},
                         {"planned_peak_mb", st.planned_peak_bytes / 1048576.0},
                         {"spill_level", double (st.spill_level)},
                         {"spilled_nodes", double (st.spilled_nodes)}});
    fs::remove_all (c.out_dir);
  }
  std::vector<Row> rows{{c.front ? "omicron_front" : "omicron", c.params (), total, m}};
  if (c.completion)
  {
    // At most ~150 points per curve, plus 0 and 1.
    Config cc = c;
    cc.sweep = "completion";
    const std::size_t stride = std::max<std::size_t> (1, samples.size () / 150);
    rows.push_back ({"omicron_front", cc.params (), 0.0, {{"completion", 0.0}}});
    // No node exists before the first chunk is sorted.
    rows.push_back ({"omicron_front", cc.params (), st.seconds_to_first_chunk, {{"completion", 0.0}}});
    for (std::size_t i = 0; i < samples.size (); i += stride)
      rows.push_back ({"omicron_front", cc.params (), samples[i].first,
                       {{"completion", nodes ? double (samples[i].second) / double (nodes) : 0.0}}});
    rows.push_back ({"omicron_front", cc.params (), total, {{"completion", 1.0}}});
  }
  return rows;
}

// ---------------------------------------------------------------------------------------------
// Peer: the thesis' top-down octree (split a node while it holds more than 10,000 points), with
// an LOD sample per inner node taken like ours: round(ratio · n) points of each child's points
// (leaf) or sample (inner), at equal strides.

class TopDownOctree
{
public:
  struct Node
  {
    std::size_t begin = 0, end = 0;  // leaf range of points_
    std::vector<pcl::PointXYZ> sample;
    std::array<std::unique_ptr<Node>, 8> children;
    bool leaf = true;
  };

  TopDownOctree (std::size_t split, float ratio, int max_depth, int threads)
    : split_ (split), ratio_ (ratio), max_depth_ (max_depth), threads_ (threads)
  {}

  void
  build (const Cloud& cloud)
  {
    Eigen::Vector3f lo = Eigen::Vector3f::Constant (std::numeric_limits<float>::max ()), hi = -lo;
    points_.clear ();
    points_.reserve (cloud.size ());
    for (const auto& p : cloud)
      if (std::isfinite (p.x) && std::isfinite (p.y) && std::isfinite (p.z))
      {
        points_.push_back (p);
        lo = lo.cwiseMin (p.getVector3fMap ());
        hi = hi.cwiseMax (p.getVector3fMap ());
      }
    const float edge = (hi - lo).maxCoeff () * (1 + 1e-6f) + 1e-30f;
    root_ = std::make_unique<Node> ();
    root_->begin = 0;
    root_->end = points_.size ();
    // The root's children are built in parallel (one subtree per task); below, sequential.
    std::vector<std::tuple<Node*, Eigen::Vector3f, float>> tasks;
    split (*root_, lo, edge, 0, &tasks);
    std::atomic<std::size_t> next{0};
    std::vector<std::thread> pool;
    for (int t = 0; t < threads_; ++t)
      pool.emplace_back ([&] {
        for (std::size_t k; (k = next++) < tasks.size ();)
          split (*std::get<0> (tasks[k]), std::get<1> (tasks[k]), std::get<2> (tasks[k]), 1, nullptr);
      });
    for (auto& th : pool)
      th.join ();
    if (!root_->leaf)
      sampleFromChildren (*root_);
  }

  std::size_t
  nodes () const
  {
    std::size_t k = 0;
    std::vector<const Node*> stack{root_.get ()};
    while (!stack.empty ())
    {
      const Node* n = stack.back ();
      stack.pop_back ();
      ++k;
      for (const auto& c : n->children)
        if (c)
          stack.push_back (c.get ());
    }
    return k;
  }

private:
  void
  split (Node& node, const Eigen::Vector3f& lo, float edge, int depth,
         std::vector<std::tuple<Node*, Eigen::Vector3f, float>>* defer)
  {
    if (node.end - node.begin <= split_ || depth >= max_depth_)
      return;
    node.leaf = false;
    const float h = edge / 2;
    const Eigen::Vector3f mid = lo + Eigen::Vector3f::Constant (h);
    // Three nested partitions: x, then y, then z; child index (x << 2) | (y << 1) | z.
    std::array<std::size_t, 9> cut;
    cut[0] = node.begin;
    cut[8] = node.end;
    auto part = [&] (std::size_t b, std::size_t e, int axis) {
      return std::size_t (std::partition (points_.begin () + b, points_.begin () + e,
                                          [&] (const pcl::PointXYZ& p) { return p.data[axis] < mid[axis]; }) -
                          points_.begin ());
    };
    cut[4] = part (cut[0], cut[8], 0);
    cut[2] = part (cut[0], cut[4], 1);
    cut[6] = part (cut[4], cut[8], 1);
    cut[1] = part (cut[0], cut[2], 2);
    cut[3] = part (cut[2], cut[4], 2);
    cut[5] = part (cut[4], cut[6], 2);
    cut[7] = part (cut[6], cut[8], 2);
    for (int c = 0; c < 8; ++c)
    {
      if (cut[c] == cut[c + 1])
        continue;
      auto child = std::make_unique<Node> ();
      child->begin = cut[c];
      child->end = cut[c + 1];
      const Eigen::Vector3f clo = lo + h * Eigen::Vector3f ((c >> 2) & 1, (c >> 1) & 1, c & 1);
      if (defer)
        defer->emplace_back (child.get (), clo, h);
      else
        split (*child, clo, h, depth + 1, nullptr);
      node.children[c] = std::move (child);
    }
    if (!defer)
      sampleFromChildren (node);
  }

  void
  sampleFromChildren (Node& node)
  {
    for (const auto& c : node.children)
    {
      if (!c)
        continue;
      const pcl::PointXYZ* src = c->leaf ? points_.data () + c->begin : c->sample.data ();
      const std::uint32_t n = std::uint32_t (c->leaf ? c->end - c->begin : c->sample.size ());
      const std::uint32_t m = pclx::omicron::detail::parentSampleCount (n, ratio_);
      for (std::uint32_t t = 0; t < m; ++t)
        node.sample.push_back (src[pclx::omicron::detail::parentSampleIndex (t, m, n)]);
    }
  }

  std::size_t split_;
  float ratio_;
  int max_depth_, threads_;
  std::vector<pcl::PointXYZ> points_;
  std::unique_ptr<Node> root_;
};

// Our builds from the file (the build reads it in blocks), each in a forked child: the export
// (front off, not fed, writing the Potree folder to potree_dir) and, when `watched`, the build
// with an orbiting front. PointT: the type the file's fields are built as.
template <typename PointT>
std::vector<Row>
fileRows (const std::string& file, std::size_t n, Config c, const std::string& potree_dir, bool watched)
{
  std::vector<Row> all;
  c.from_file = true;
  c.file = file;
  for (bool front : {false, true})
  {
    if (front && !watched)
      break;
    Config ff = c;
    ff.front = front;
    if (!front)
    {
      ff.potree_dir = potree_dir;
      ff.feed_front = false;
    }
    std::vector<Row> rows;
    if (!inChild ([&] (std::size_t rss0) { return runOurs<PointT> (nullptr, n, ff, rss0); }, rows))
      std::cerr << "[omicron] " << file << ": FAILED " << ff.params () << "\n";
    all.insert (all.end (), rows.begin (), rows.end ());
  }
  return all;
}

// Seconds of pcl::io::loadPCDFile of the file into a cloud of PointT, which is then dropped.
template <typename PointT>
double
pclLoadSeconds (const std::string& file, std::size_t n)
{
  pcl::PointCloud<PointT> cloud;
  const auto t0 = Clock::now ();
  if (pcl::io::loadPCDFile<PointT> (file, cloud) < 0 || cloud.size () != n)
    throw std::runtime_error ("cannot load " + file);
  return since (t0);
}

// Root cube of a cloud as our octree makes it: min corner, longest side.
void
rootCube (const Cloud& cloud, Eigen::Vector3f& lo, float& edge)
{
  lo = Eigen::Vector3f::Constant (std::numeric_limits<float>::max ());
  Eigen::Vector3f hi = -lo;
  for (const auto& p : cloud)
  {
    lo = lo.cwiseMin (p.getVector3fMap ());
    hi = hi.cwiseMax (p.getVector3fMap ());
  }
  edge = (hi - lo).maxCoeff ();
}

// pcl_outofcore_process as a subprocess: wall time and peak RSS (/usr/bin/time -v, else wait4).
bool
runOutofcore (const std::string& pcd, const std::string& out_dir, int depth, double& seconds, double& peak_bytes,
              std::string& why)
{
  const std::string tool = "/usr/bin/pcl_outofcore_process";
  if (!fs::exists (tool))
  {
    why = "pcl_outofcore_process not installed (package pcl-tools)";
    return false;
  }
  fs::remove_all (out_dir);
  ::sync ();  // as before our rows: nothing of an earlier row left to write back
  const bool gnu_time = fs::exists ("/usr/bin/time");
  const std::string time_log = out_dir + ".time";
  std::vector<std::string> args;
  if (gnu_time)
    args = {"/usr/bin/time", "-v", "-o", time_log};
  const std::string d = std::to_string (depth);
  args.insert (args.end (), {tool, "-depth", d, "-gen_lod", pcd, out_dir});
  std::vector<char*> argv;
  for (auto& a : args)
    argv.push_back (a.data ());
  argv.push_back (nullptr);
  std::cout.flush ();
  const auto t0 = Clock::now ();
  const pid_t pid = fork ();
  if (pid == 0)
  {
    const int null = open ("/dev/null", O_WRONLY);
    dup2 (null, 1);
    dup2 (null, 2);
    execv (argv[0], argv.data ());
    _exit (127);
  }
  int status = 0;
  struct rusage ru;
  wait4 (pid, &status, 0, &ru);
  seconds = since (t0);
  peak_bytes = double (ru.ru_maxrss) * 1024.0;  // the largest descendant (time itself is tiny)
  if (gnu_time)
  {
    std::ifstream log (time_log);
    std::string line;
    const std::string key = "Maximum resident set size (kbytes):";
    while (std::getline (log, line))
      if (line.find (key) != std::string::npos)
        peak_bytes = std::stod (line.substr (line.find (key) + key.size ())) * 1024.0;
    fs::remove (time_log);
  }
  std::uintmax_t bytes = 0;
  if (fs::exists (out_dir))
    for (const auto& e : fs::recursive_directory_iterator (out_dir))
      if (e.is_regular_file ())
        bytes += e.file_size ();
  fs::remove_all (out_dir);
  if (!WIFEXITED (status) || WEXITSTATUS (status) != 0)
  {
    why = "pcl_outofcore_process failed (status " + std::to_string (status) + ")";
    return false;
  }
  why = std::to_string (bytes);  // output size, reported as a metric
  return true;
}

}  // namespace

int
main (int argc, char** argv)
{
  CLI::App app ("pcl::ObliqueCutOctree (OMiCroN) benchmark with PCL peers in the same run");
  std::string csv, work = "/tmp/pclx_omicron_bench";
  std::vector<std::size_t> sizes{2000000, 5000000, 10000000};
  std::vector<std::size_t> other_sizes;
  std::vector<std::string> inputs{"scene", "bunny", "fertility", "lattice", "duplicates"};
  bool quick = false, full = false, no_outofcore = false, no_sweeps = false, budget_only = false;
  int threads = int (std::max (1u, std::thread::hardware_concurrency ())), depth = 7;
  std::size_t sweep_max = 0;
  std::string outofcore_dir = fs::is_directory ("/dev/shm") ? "/dev/shm/pclx_omicron_outofcore" : "";
  std::vector<std::string> outofcore_inputs;
  bool outofcore_disk = false;
  std::size_t outofcore_tmpfs_max = 20000000;
  app.add_option ("--csv", csv, "also write rows to this file");
  app.add_option ("--sizes", sizes, "point counts of the size sweep (scene input)")->capture_default_str ();
  app.add_option ("--other-sizes", other_sizes,
                  "point counts for the other inputs (default: the smallest of --sizes)");
  app.add_option ("--inputs", inputs,
                  "scene bunny fertility lattice duplicates; also scene_intensity, scene_rgbi (the scene as a "
                  "scan with intensity, and with colour and intensity: file to Potree, PCL's load, outofcore)")
      ->capture_default_str ();
  app.add_option ("--work-dir", work, "where the input PCDs are written (reused when the size matches)")
      ->capture_default_str ();
  app.add_option ("--threads", threads, "build threads for ours and the top-down peer")->capture_default_str ();
  app.add_option ("--depth", depth, "octree depth (ours, the PCL octree cell, outofcore)")->capture_default_str ();
  app.add_option ("--sweep-max", sweep_max, "run the parameter sweeps only up to this size (0: all sizes)");
  app.add_flag ("--quick", quick, "demo size: 1M and 2M points (< 60 s on 2 cores)");
  app.add_flag ("--full", full, "20M, 50M, 100M points");
  app.add_flag ("--no-outofcore", no_outofcore, "skip pcl_outofcore_process");
  app.add_option ("--outofcore-dir", outofcore_dir,
                  "where pcl_outofcore_process writes its tree (default tmpfs: this VM's disk creates files "
                  "slowly; empty = the work dir)")
      ->capture_default_str ();
  app.add_option ("--outofcore-inputs", outofcore_inputs, "inputs pcl_outofcore_process runs on (default all; "
                                                          "--quick: scene)");
  app.add_option ("--outofcore-tmpfs-max", outofcore_tmpfs_max,
                  "above this many points pcl_outofcore_process writes to the work dir instead (its tree is "
                  "~130 B/point)")
      ->capture_default_str ();
  app.add_flag ("--outofcore-disk", outofcore_disk,
                "also run pcl_outofcore_process into the work dir (disk) on the scene at the smallest size");
  app.add_flag ("--no-sweeps", no_sweeps, "only the main rows (ours default, front, peers)");
  app.add_flag ("--budget-only", budget_only,
                "only the reads and the memory-budget rows (budget = 1/4 of the cloud, and in memory)");
  bool verbose = false;
  app.add_flag ("--verbose", verbose, "progress lines on stderr");
  CLI11_PARSE (app, argc, argv);
  pclx::bench::setVerbose (verbose);
  if (quick)
  {
    sizes = {1000000, 2000000};
    if (outofcore_inputs.empty ())
      outofcore_inputs = {"scene"};
  }
  else if (full)
    sizes = {20000000, 50000000, 100000000};
  std::sort (sizes.begin (), sizes.end ());
  if (other_sizes.empty ())
    other_sizes = {sizes.front ()};
  fs::create_directories (work);
  if (outofcore_inputs.empty ())
    outofcore_inputs = inputs;
  if (outofcore_dir.empty ())
    outofcore_dir = work;
  fs::create_directories (outofcore_dir);

  // Inputs.
  const auto data = pclx::bench::sharedDataDir ();
  std::map<std::string, std::function<void (std::size_t, const std::string&)>> gens;
  auto meshGen = [] (std::function<pclx::testing::TriangleMesh ()> make, std::uint64_t seed,
                     Attributes a = Attributes::kNone) {
    return [make, seed, a] (std::size_t n, const std::string& path) {
      const pclx::testing::TriangleMesh mesh = make ();
      MeshSampler s (mesh, seed + n);
      writePcd (path, n, [&] (std::size_t, float* p) { s.sample (p); }, a);
    };
  };
  gens["scene"] = meshGen (makeScene, 1);
  // The scene's points (same seed) as a laser scan with intensity, and as a colourised one.
  gens["scene_intensity"] = meshGen (makeScene, 1, Attributes::kIntensity);
  gens["scene_rgbi"] = meshGen (makeScene, 1, Attributes::kColourIntensity);
  if (data)
  {
    const std::string d = *data;
    gens["bunny"] =
        meshGen ([d] { return pclx::testing::loadPlyMesh (d + "/bunny/reconstruction/bun_zipper.ply"); }, 2);
    gens["fertility"] = meshGen ([d] { return pclx::testing::loadPlyMesh (d + "/meshes/fertility.ply"); }, 3);
  }
  // Integer lattice (a cube, raster order): PotreeConverter's sampler crashes on it (issue #550).
  gens["lattice"] = [] (std::size_t n, const std::string& path) {
    const std::size_t k = std::size_t (std::ceil (std::cbrt (double (n))));
    writePcd (path, n, [k] (std::size_t i, float* p) {
      p[0] = float (i % k);
      p[1] = float ((i / k) % k);
      p[2] = float (i / (k * k));
    });
  };
  // 10 % distinct positions (scene samples), each repeated ten times in scattered order.
  gens["duplicates"] = [] (std::size_t n, const std::string& path) {
    const pclx::testing::TriangleMesh mesh = makeScene ();
    const std::size_t m = std::max<std::size_t> (1, n / 10);
    std::vector<float> distinct (3 * m);
    MeshSampler s (mesh, 4 + n);
    for (std::size_t j = 0; j < m; ++j)
      s.sample (distinct.data () + 3 * j);
    std::size_t step = 1000003;
    while (std::gcd (step, m) != 1)
      step += 2;
    writePcd (path, n, [&] (std::size_t i, float* p) {
      const std::size_t j = std::size_t ((unsigned __int128) (i) * step % m);
      std::copy (distinct.begin () + 3 * j, distinct.begin () + 3 * j + 3, p);
    });
  };

  CsvWriter out (csv);
  const bool budget_api = haveBudget ();
  pclx::bench::progress () << "[omicron] " << threads << " threads; setMemoryBudget "
                           << (budget_api ? "present" : "absent") << "; pcl_outofcore_process "
                           << (no_outofcore ? "skipped" : "on") << "; work dir " << work << "\n";
  const auto t_start = Clock::now ();

  for (const std::string& name : inputs)
  {
    if (!gens.count (name))
    {
      std::cerr << "[omicron] input '" << name << "' skipped"
                << (name == "bunny" || name == "fertility" ? " (no ../shared/data)" : " (unknown)") << "\n";
      continue;
    }
    // The scene and the scans made from it run the size sweep.
    for (std::size_t n : name.rfind ("scene", 0) == 0 ? sizes : other_sizes)
    {
      const std::string label = sizeLabel (n);
      const std::string path = work + "/" + name + "_" + label + ".pcd";
      if (!fs::exists (path) || fs::file_size (path) != expectedPcdBytes (n, attributesOf (name)))
      {
        pclx::bench::progress () << "[omicron] writing " << path << " ..." << std::flush;
        const auto tg = Clock::now ();
        gens[name](n, path);
        pclx::bench::progress () << " " << fmt (since (tg)) << " s\n";
      }
      const double file_mb = double (fs::file_size (path)) / 1048576.0;
      auto emit = [&] (const Row& r) { out.row ("omicron", r.method, r.params, name, n, r.seconds, r.metrics); };
      auto log = [&] (const std::string& what, double s) {
        pclx::bench::progress () << "[omicron] " << name << " " << label << ": " << what << " " << fmt (s)
                                 << " s  (elapsed " << fmt (since (t_start)) << " s)\n";
      };
      // A row of ours built from the file, beside PCL's load of the same file.
      auto emitAgainstLoad = [&] (Row r, double load_s) {
        r.metrics.emplace_back ("load_s", load_s);
        r.metrics.emplace_back ("build_over_load", r.seconds / load_s);
        emit (r);
        log (r.method + " " + r.params, r.seconds);
      };
      // pcl_outofcore_process on the same file: tmpfs up to --outofcore-tmpfs-max, the work dir above.
      auto outofcorePeer = [&] (double load_s) {
        const bool oc_here =
            std::find (outofcore_inputs.begin (), outofcore_inputs.end (), name) != outofcore_inputs.end ();
        std::vector<std::pair<std::string, std::string>> oc_runs;  // (dir, label)
        const std::string oc_dir = n > outofcore_tmpfs_max ? work : outofcore_dir;
        if (!no_outofcore && oc_here)
          oc_runs.emplace_back (oc_dir, oc_dir.rfind ("/dev/shm", 0) == 0 ? "tmpfs" : "disk");
        if (!no_outofcore && outofcore_disk && name == "scene" && n == sizes.front () && oc_dir != work)
          oc_runs.emplace_back (work, "disk");
        for (const auto& [dir, where] : oc_runs)
        {
          double s = 0, peak = 0;
          std::string info;
          if (runOutofcore (path, dir + "/outofcore_" + name + "_" + label, depth, s, peak, info))
          {
            emit ({"pcl_outofcore" + std::string (where == "disk" && oc_runs.size () > 1 ? "_disk" : ""),
                   "sweep=main;depth=" + std::to_string (depth) + ";gen_lod=1;out=" + where, s,
                   {{"points_per_s", n / s},
                    {"peak_total_bpp", peak / n},
                    {"peak_mb", peak / 1048576.0},
                    {"output_mb", std::stod (info) / 1048576.0},
                    {"load_s", load_s}}});
            log ("pcl_outofcore_process (" + where + ")", s);
          }
          else
            std::cerr << "[omicron] " << name << " " << label << ": " << info << "\n";
        }
      };

      // Reads (warm page cache: the file was just written or read).
      double fread_s = 0;
      {
        std::vector<char> bytes (fs::file_size (path));
        const auto t0 = Clock::now ();
        std::FILE* f = std::fopen (path.c_str (), "rb");
        const std::size_t got = std::fread (bytes.data (), 1, bytes.size (), f);
        std::fclose (f);
        fread_s = since (t0);
        if (got != bytes.size ())
          throw std::runtime_error ("short read of " + path);
      }
      emit ({"fread", "sweep=main", fread_s, {{"points_per_s", n / fread_s}, {"file_mb", file_mb}}});
      // From the file: file to tree (and to a Potree folder), in children forked before this
      // process loads the cloud, so their peaks are the whole process's. Emitted after the load,
      // against pcl_load.
      Config file_config;
      file_config.threads = threads;
      file_config.depth = depth;
      const std::string potree_dir = work + "/potree_" + name + "_" + label;
      const Attributes attributes = attributesOf (name);
      if (attributes != Attributes::kNone)
      {
        if (budget_only)
          continue;
        // A scan with attributes: its export as the point type omicron_viewer builds it as, beside
        // PCL's load into the PCL type that holds the fields and outofcore's tree of the same file.
        const bool intensity_only = attributes == Attributes::kIntensity;
        const std::string ours_as = intensity_only ? "PointXYZIPacked" : "PointXYZRGBI";
        const std::string pcl_as = intensity_only ? "PointXYZI" : "PointXYZRGBI";
        const std::vector<Row> rows =
            intensity_only ? fileRows<pclx::PointXYZIPacked> (path, n, file_config, potree_dir, false)
                           : fileRows<pclx::PointXYZRGBI> (path, n, file_config, potree_dir, false);
        const double load_s = intensity_only ? pclLoadSeconds<pcl::PointXYZI> (path, n)
                                             : pclLoadSeconds<pclx::PointXYZRGBI> (path, n);
        malloc_trim (0);
        emit ({"pcl_load", "sweep=main;point=" + pcl_as, load_s, {{"points_per_s", n / load_s}, {"file_mb", file_mb}}});
        log ("pcl load", load_s);
        for (Row r : rows)
        {
          r.params += ";point=" + ours_as;
          emitAgainstLoad (r, load_s);
        }
        outofcorePeer (load_s);
        continue;
      }
      // With --budget-only, only the unwatched file → Potree row: the budgeted build's reference.
      const std::vector<Row> file_rows = fileRows<pcl::PointXYZ> (path, n, file_config, potree_dir, !budget_only);
      Cloud::Ptr cloud (new Cloud);
      const auto tl = Clock::now ();
      if (pcl::io::loadPCDFile<pcl::PointXYZ> (path, *cloud) < 0 || cloud->size () != n)
        throw std::runtime_error ("cannot load " + path);
      const double load_s = since (tl);
      malloc_trim (0);
      emit ({"pcl_load", "sweep=main", load_s, {{"points_per_s", n / load_s}, {"file_mb", file_mb}}});
      log ("pcl load", load_s);

      // The in-memory file → Potree folder of this input and size (0 when it failed).
      double file_to_potree_s = 0;
      for (const Row& r : file_rows)
        for (const auto& [key, value] : r.metrics)
          if (key == "file_to_potree_s")
            file_to_potree_s = value;
      auto ours = [&] (Config c) {
        c.threads = threads;
        c.depth = depth;
        std::vector<Row> rows;
        if (!inChild ([&] (std::size_t rss0) { return runOurs<pcl::PointXYZ> (cloud, n, c, rss0); }, rows))
          std::cerr << "[omicron] " << name << " " << label << ": FAILED " << c.params () << "\n";
        for (Row& r : rows)
        {
          if (r.params.rfind ("sweep=completion", 0) != 0)
          {
            r.metrics.emplace_back ("load_s", load_s);
            r.metrics.emplace_back ("build_over_load", r.seconds / load_s);
          }
          // A budgeted build writes the Potree folder from the file: its in-memory counterpart.
          if (c.budget && file_to_potree_s > 0)
          {
            r.metrics.emplace_back ("in_memory_file_to_potree_s", file_to_potree_s);
            r.metrics.emplace_back ("over_in_memory_file_to_potree", r.seconds / file_to_potree_s);
          }
          emit (r);
        }
        if (!rows.empty ())
          log (rows[0].method + " " + c.params (), rows[0].seconds);
        return rows.empty () ? Row{} : rows[0];
      };

      Config base;
      // A budget of a quarter of the cloud (PointXYZ, 16 B/pt), input streamed from the file;
      // the in-memory reference is load + build (front off) of the same run.
      auto budgetRows = [&] {
        Config c = base;
        c.sweep = "budget";
        c.budget = n * sizeof (pcl::PointXYZ) / 4;
        c.file = path;
        c.out_dir = work + "/budget_" + name + "_" + label;
        ours (c);
        Config m = base;
        m.sweep = "budget";
        ours (m);
      };
      if (budget_only)
      {
        for (const Row& r : file_rows)
          emitAgainstLoad (r, load_s);
        if (budget_api)
          budgetRows ();
        continue;
      }
      // Main rows: ours with the defaults (ratio 0.2, collapse), front off and on; completion curves.
      ours (base);
      Config fr = base;
      fr.front = true;
      ours (fr);
      for (const Row& r : file_rows)
        emitAgainstLoad (r, load_s);
      for (bool collapse : {false, true})
      {
        if (name != "scene" && !collapse)
          continue;
        Config cc = base;
        cc.sweep = "curve";
        cc.front = true;
        cc.completion = true;
        cc.collapse = collapse;
        cc.curve = (name == "scene" ? label : name + "_" + label) + (collapse ? "_collapse" : "_nocollapse");
        ours (cc);
      }

      // Peers.
      {
        std::vector<Row> rows;
        inChild (
            [&] (std::size_t rss0) {
              TopDownOctree td (10000, 0.2f, 21, threads);
              const auto t0 = Clock::now ();
              td.build (*cloud);
              const double s = since (t0);
              const double hwm = double (procStatusKb ("VmHWM") * 1024);
              return std::vector<Row>{{"topdown_10k",
                                       "sweep=main;ratio=0.2;split=10000;threads=" + std::to_string (threads), s,
                                       {{"points_per_s", n / s},
                                        {"peak_delta_bpp", (hwm - double (rss0)) / n},
                                        {"peak_total_bpp", hwm / n},
                                        {"nodes", double (td.nodes ())},
                                        {"load_s", load_s}}}};
            },
            rows);
        for (const Row& r : rows)
        {
          emit (r);
          log (r.method, r.seconds);
        }
        rows.clear ();
        inChild (
            [&] (std::size_t rss0) {
              Eigen::Vector3f lo;
              float edge;
              rootCube (*cloud, lo, edge);
              // Every point strictly inside, box and cell in double: the depth stays `depth`.
              const double e = double (edge) * (1 + 1e-5) + 1e-30;
              const double res = e / double (1 << depth);
              pcl::octree::OctreePointCloudPointVector<pcl::PointXYZ> oct (res);
              const auto t0 = Clock::now ();
              oct.setInputCloud (cloud);
              oct.defineBoundingBox (lo.x (), lo.y (), lo.z (), lo.x () + e, lo.y () + e, lo.z () + e);
              oct.addPointsFromInputCloud ();
              const double s = since (t0);
              const double hwm = double (procStatusKb ("VmHWM") * 1024);
              return std::vector<Row>{{"pcl_octree", "sweep=main;depth=" + std::to_string (oct.getTreeDepth ()), s,
                                       {{"points_per_s", n / s},
                                        {"peak_delta_bpp", (hwm - double (rss0)) / n},
                                        {"peak_total_bpp", hwm / n},
                                        {"leaves", double (oct.getLeafCount ())},
                                        {"load_s", load_s}}}};
            },
            rows);
        for (const Row& r : rows)
        {
          emit (r);
          log (r.method, r.seconds);
        }
      }
      outofcorePeer (load_s);

      // Parameter sweeps on the scene.
      if (name != "scene" || no_sweeps || (sweep_max && n > sweep_max))
        continue;
      for (float ratio : {0.2f, 0.25f})
        for (bool collapse : {true, false})
        {
          Config c = base;
          c.sweep = "ratio";
          c.ratio = ratio;
          c.collapse = collapse;
          ours (c);
        }
      for (std::size_t wl : {8, 32, 128})
      {
        Config c = base;
        c.sweep = "worklist";
        c.worklist = wl;
        c.front = true;
        ours (c);
      }
      for (std::size_t ch : {1, 4, 16, 64})
      {
        Config c = base;
        c.sweep = "chunks";
        c.chunks = ch;
        c.front = true;
        ours (c);
      }
      // Below ~10M points a quarter of the cloud cannot hold the budgeted build's fixed overheads.
      if (budget_api && n >= 10000000)
        budgetRows ();
    }
  }
  pclx::bench::progress () << "[omicron] done in " << fmt (since (t_start)) << " s\n";
  return 0;
}
