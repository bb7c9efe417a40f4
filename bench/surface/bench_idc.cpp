// bench_idc: IncrementalDualContouring on posed depth sequences against Open3D's
// ScalableTSDFVolume + marching cubes over a sweep of voxel sizes, and PCL's MarchingCubesHoppe /
// GreedyProjectionTriangulation on the fused cloud (object sequences).
// Inputs: frames rendered from meshes with Kinect-like noise (a torus around a sphere seen from
// an orbit, the Stanford bunny mesh scaled to 0.6 m and the fertility statue at 0.4 m when
// ../shared/data exists, a furnished room
// and two furnished rooms joined by a door, both seen from inside), the 50 7-Scenes frames
// (speed and looks; no truth) and the 10 bunny range scans (truth: bun_zipper.ply).
// Metrics: accuracy (output samples to the truth), completion (the truth samples that some
// frame saw, to the output), their mean (Chamfer) and the larger directed maximum (Hausdorff),
// all with CGAL AABB distances; triangles, ms per frame (median, p95), memory. CSV rows on
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
#include <malloc.h>
#include <unistd.h>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <memory>
#include <sstream>

namespace {

using pclx::bench::percentile;
using pclx::testing::TriangleMesh;
using Clock = std::chrono::steady_clock;

double
msSince (Clock::time_point t0)
{
  return std::chrono::duration<double, std::milli> (Clock::now () - t0).count ();
}

// Resident set size of this process now, in MiB.
double
rssMiB ()
{
  return static_cast<double> (pclx::bench::procStatusKb ("VmRSS")) / 1024.0;
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
  pcl::DepthIntrinsics K;
  std::vector<Frame> frames;
  std::vector<double> leaves;       // IDC detail levels (metres)
  std::vector<double> tsdf_voxels;  // Open3D's voxel sweep (metres; pinhole sequences)
  double depth_trunc = 4.0;
};

// ---- Generated sequences

// The Kinect's 640 x 480 intrinsics scaled to another image size (same field of view).
pclx::testing::PinholeIntrinsics
scaledIntrinsics (int width, int height)
{
  pclx::testing::PinholeIntrinsics K;
  K.width = width;
  K.height = height;
  K.fx = K.fy = 525.f * width / 640.f;
  K.cx = (width - 1) / 2.f;
  K.cy = (height - 1) / 2.f;
  return K;
}

// Renders the sequence's truth from every pose with the default Kinect-like noise.
void
renderFrames (Sequence& s, const std::vector<Eigen::Isometry3f>& poses, int width, int height, std::uint32_t seed)
{
  using namespace pclx::testing;
  const RayCaster caster (s.truth);
  const PinholeIntrinsics K = scaledIntrinsics (width, height);
  s.K = {K.fx, K.fy, K.cx, K.cy};
  for (std::size_t i = 0; i < poses.size (); ++i)
  {
    const DepthImage img = renderDepth (caster, K, poses[i], KinectNoise (), seed + std::uint32_t (i));
    Frame fr;
    fr.width = img.width;
    fr.height = img.height;
    fr.mm = img.depth_mm;
    fr.pose = poses[i].matrix ().cast<double> ();
    s.frames.push_back (std::move (fr));
  }
}

// A camera at `eye` looking along `heading` (radians about z from +x), tilted up by `pitch`.
Eigen::Isometry3f
viewPose (const Eigen::Vector3f& eye, float heading, float pitch)
{
  const Eigen::Vector3f dir (std::cos (heading) * std::cos (pitch), std::sin (heading) * std::cos (pitch),
                             std::sin (pitch));
  return pclx::testing::lookAt (eye, eye + dir);
}

Sequence
renderOrbit (const std::string& name, const TriangleMesh& mesh, int frames, double radius, int width, int height,
             std::vector<double> leaves)
{
  Sequence s;
  s.name = name;
  s.truth = mesh;
  s.has_truth = s.object = true;
  s.leaves = std::move (leaves);
  s.depth_trunc = 3.0;
  const Eigen::Vector3f c = 0.5f * (mesh.bboxMin () + mesh.bboxMax ());
  std::vector<Eigen::Isometry3f> poses;
  for (int f = 0; f < frames; ++f)
  {
    // Around the object, alternately above and below, so that the views cover it.
    const float a = 2.f * float (M_PI) * f / frames;
    const float h = (f % 2 ? -0.55f : 0.75f) * float (radius);
    const Eigen::Vector3f eye = c + Eigen::Vector3f (float (radius) * std::cos (a), float (radius) * std::sin (a), h);
    poses.push_back (pclx::testing::lookAt (eye, c));
  }
  renderFrames (s, poses, width, height, 1000);
  return s;
}

// The room scenes: a room's interior, the thickness of its walls, the door between two rooms and
// the height of the camera.
const Eigen::Vector3f kRoomSize (4.f, 3.f, 2.5f);
const float kWall = 0.05f, kDoorWidth = 1.f, kDoorHeight = 2.f, kEyeHeight = 1.4f;

// An axis-aligned box between two corners.
TriangleMesh
boxBetween (const Eigen::Vector3f& lo, const Eigen::Vector3f& hi, int grid = 8)
{
  TriangleMesh b = pclx::testing::makeBox (hi - lo, grid);
  b.transform (Eigen::Affine3f (Eigen::Translation3f (0.5f * (lo + hi))));
  return b;
}

// A closed room around the interior [lo, hi]: floor, ceiling and four walls as boxes `t` thick
// outside it, so their inner faces bound the interior and face into it. The boxes overlap at the
// edges and corners, where every face they share lies inside another box or outside the room.
TriangleMesh
roomShell (const Eigen::Vector3f& lo, const Eigen::Vector3f& hi, float t)
{
  const Eigen::Vector3f olo = lo - Eigen::Vector3f::Constant (t), ohi = hi + Eigen::Vector3f::Constant (t);
  TriangleMesh m = boxBetween (olo, Eigen::Vector3f (ohi.x (), ohi.y (), lo.z ()));      // floor
  m.append (boxBetween (Eigen::Vector3f (olo.x (), olo.y (), hi.z ()), ohi));            // ceiling
  m.append (boxBetween (olo, Eigen::Vector3f (lo.x (), ohi.y (), ohi.z ())));            // -x wall
  m.append (boxBetween (Eigen::Vector3f (hi.x (), olo.y (), olo.z ()), ohi));            // +x wall
  m.append (boxBetween (olo, Eigen::Vector3f (ohi.x (), lo.y (), ohi.z ())));            // -y wall
  m.append (boxBetween (Eigen::Vector3f (olo.x (), hi.y (), olo.z ()), ohi));            // +y wall
  return m;
}

// Furniture on the floor z = 0: a table (a top on four legs) centred at `table` with a sphere and
// a torus on it, and a tall cabinet over the footprint [cabinet_lo, cabinet_hi]. Parts sink a
// little into what carries them, so no two faces touch flat.
TriangleMesh
furniture (const Eigen::Vector2f& table, const Eigen::Vector2f& cabinet_lo, const Eigen::Vector2f& cabinet_hi)
{
  const float top = 0.75f, thick = 0.04f, hx = 0.6f, hy = 0.35f, leg = 0.05f, inset = 0.08f, sink = 0.01f;
  const float ball = 0.1f, ring = 0.12f, tube = 0.04f, settle = 0.005f, cabinet_height = 1.8f;
  TriangleMesh m = boxBetween (Eigen::Vector3f (table.x () - hx, table.y () - hy, top - thick),
                               Eigen::Vector3f (table.x () + hx, table.y () + hy, top), 4);
  for (const float sx : {-1.f, 1.f})
    for (const float sy : {-1.f, 1.f})
    {
      const Eigen::Vector2f c = table + Eigen::Vector2f (sx * (hx - inset), sy * (hy - inset));
      m.append (boxBetween (Eigen::Vector3f (c.x () - leg / 2, c.y () - leg / 2, -sink),
                            Eigen::Vector3f (c.x () + leg / 2, c.y () + leg / 2, top - thick / 2), 2));
    }
  m.append (pclx::testing::makeSphere (ball, 4, Eigen::Vector3f (table.x () - 0.3f, table.y (), top + ball - settle)));
  TriangleMesh torus = pclx::testing::makeTorus (ring, tube, 64, 24);
  torus.transform (Eigen::Affine3f (Eigen::Translation3f (table.x () + 0.25f, table.y (), top + tube - settle)));
  m.append (torus);
  m.append (boxBetween (Eigen::Vector3f (cabinet_lo.x (), cabinet_lo.y (), -sink),
                        Eigen::Vector3f (cabinet_hi.x (), cabinet_hi.y (), cabinet_height), 4));
  return m;
}

// One furnished room, interior centred on the origin in x and y, floor at z = 0; the cabinet
// stands against the -x wall (sunk into it), the table near the +x, -y corner.
TriangleMesh
roomScene ()
{
  const Eigen::Vector3f lo (-kRoomSize.x () / 2, -kRoomSize.y () / 2, 0.f);
  const Eigen::Vector3f hi (kRoomSize.x () / 2, kRoomSize.y () / 2, kRoomSize.z ());
  TriangleMesh scene = roomShell (lo, hi, kWall);
  scene.append (furniture (Eigen::Vector2f (1.1f, -0.85f), Eigen::Vector2f (lo.x () - 0.02f, 0.5f),
                           Eigen::Vector2f (lo.x () + 0.5f, 1.3f)));
  return scene;
}

// A walk on a loop around the room's centre looking across the room, past the centre so the
// views sweep every wall, tilted down to the floor and furniture and up towards the ceiling in turn.
std::vector<Eigen::Isometry3f>
roomPath (int frames)
{
  std::vector<Eigen::Isometry3f> poses;
  for (int i = 0; i < frames; ++i)
  {
    const float a = 2.f * float (M_PI) * i / frames;
    const Eigen::Vector3f eye (0.8f * std::cos (a), 0.5f * std::sin (a), kEyeHeight);
    poses.push_back (viewPose (eye, a + float (M_PI) + 0.3f, -0.25f + 0.35f * std::sin (2.f * a)));
  }
  return poses;
}

Sequence
renderRoom (int frames, int width, int height, std::vector<double> leaves, std::string name = "room-generated")
{
  Sequence s;
  s.name = std::move (name);
  s.truth = roomScene ();
  s.has_truth = true;
  s.leaves = std::move (leaves);
  s.depth_trunc = 4.0;
  renderFrames (s, roomPath (frames), width, height, 7);
  return s;
}

// Two furnished rooms side by side along x (room 1 from the origin, room 2 beyond it), sharing
// the wall on room 1's +x side, which leaves a door in the middle of its length: two panels and a
// lintel.
TriangleMesh
twoRoomScene ()
{
  const float w = kRoomSize.x (), d = kRoomSize.y (), h = kRoomSize.z (), t = kWall;
  TriangleMesh scene = roomShell (Eigen::Vector3f::Zero (), Eigen::Vector3f (2 * w + t, d, h), t);
  const float door_lo = 0.5f * (d - kDoorWidth), door_hi = door_lo + kDoorWidth;
  // The panels reach into the outer walls, floor and ceiling by half the wall's thickness.
  scene.append (boxBetween (Eigen::Vector3f (w, -t / 2, -t / 2), Eigen::Vector3f (w + t, door_lo, h + t / 2)));
  scene.append (boxBetween (Eigen::Vector3f (w, door_hi, -t / 2), Eigen::Vector3f (w + t, d + t / 2, h + t / 2)));
  scene.append (boxBetween (Eigen::Vector3f (w, door_lo, kDoorHeight), Eigen::Vector3f (w + t, door_hi, h + t / 2)));
  scene.append (
      furniture (Eigen::Vector2f (1.f, 2.35f), Eigen::Vector2f (-0.02f, 0.3f), Eigen::Vector2f (0.48f, 1.1f)));
  const float x2 = w + t;  // room 2's -x side
  scene.append (furniture (Eigen::Vector2f (x2 + 2.85f, 0.75f), Eigen::Vector2f (x2 + 3.5f, 2.1f),
                           Eigen::Vector2f (x2 + w + 0.02f, 2.9f)));
  return scene;
}

// A look around room 1 on a loop (views across the room, as in roomPath) ending on its centre
// line facing the door, the walk along the centre line through the door, and a look around room 2.
std::vector<Eigen::Isometry3f>
twoRoomPath (int frames)
{
  const float w = kRoomSize.x (), d = kRoomSize.y ();
  const Eigen::Vector3f c1 (w / 2, d / 2, kEyeHeight), c2 (w + kWall + w / 2, d / 2, kEyeHeight);
  const Eigen::Vector3f loop (0.5f, 0.35f, 0.f);
  const int turn1 = 2 * frames / 5, walk = frames / 4, turn2 = frames - turn1 - walk;
  std::vector<Eigen::Isometry3f> poses;
  auto turn = [&poses, &loop] (const Eigen::Vector3f& c, float b) {
    const Eigen::Vector3f eye = c - loop.cwiseProduct (Eigen::Vector3f (std::cos (b), std::sin (b), 0.f));
    poses.push_back (viewPose (eye, b, -0.25f + 0.35f * std::sin (2.f * b)));
  };
  for (int i = 0; i < turn1; ++i)
    turn (c1, 2.f * float (M_PI) * (i + 1) / turn1);
  const float x0 = c1.x () - loop.x (), x1 = c2.x () - loop.x ();
  for (int i = 0; i < walk; ++i)
  {
    const float f = float (i + 1) / (walk + 1);
    const Eigen::Vector3f eye (x0 + f * (x1 - x0), d / 2, kEyeHeight);
    poses.push_back (viewPose (eye, 0.3f * std::sin (2.f * float (M_PI) * f), -0.15f));
  }
  for (int i = 0; i < turn2; ++i)
    turn (c2, 2.f * float (M_PI) * i / turn2);
  return poses;
}

Sequence
renderTwoRooms (int frames, int width, int height)
{
  Sequence s;
  s.name = "rooms-multi";
  s.truth = twoRoomScene ();
  s.has_truth = true;
  s.leaves = {0.02, 0.01};
  s.tsdf_voxels = {0.04, 0.02, 0.01};  // the finest voxel over two whole rooms takes minutes and gigabytes
  s.depth_trunc = 4.0;
  renderFrames (s, twoRoomPath (frames), width, height, 5000);
  return s;
}

// ---- Recorded sequences

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
cameraCloud (const Frame& f, const pcl::DepthIntrinsics& K)
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

// ---- Truth

// What a sequence's meshes are measured against: the truth surface (accuracy) and the samples
// of it that completion is measured from.
struct Truth
{
  std::unique_ptr<pclx::testing::MeshDistance> distance;
  std::vector<Eigen::Vector3f> samples;
  std::size_t all_samples = 0;
  double seenFraction () const { return all_samples ? double (samples.size ()) / double (all_samples) : 0.0; }
};

// The samples that some frame saw: every frame's view of the truth rendered without noise over
// the depth range a frame keeps, and a sample kept when its depth in the frame matches the
// rendered depth at its pixel (within a fixed tolerance or one proportional to the depth, the
// larger), so hidden, out-of-range and never-viewed parts of the truth do not count as missing
// from a mesh.
std::vector<Eigen::Vector3f>
seenSamples (const Sequence& s, const std::vector<Eigen::Vector3f>& samples)
{
  using namespace pclx::testing;
  const RayCaster caster (s.truth);
  KinectNoise exact;
  exact.enabled = false;
  exact.min_range = 0.4f;
  exact.max_range = float (s.depth_trunc);
  const float tol = 0.002f, tol_per_metre = 0.01f;
  std::vector<char> seen (samples.size (), 0);
  for (const auto& f : s.frames)
  {
    PinholeIntrinsics K;
    K.width = f.width;
    K.height = f.height;
    K.fx = s.K.fx; K.fy = s.K.fy; K.cx = s.K.cx; K.cy = s.K.cy;
    Eigen::Isometry3f pose;
    pose.matrix () = f.pose.cast<float> ();
    const DepthImage img = renderDepth (caster, K, pose, exact);
    const Eigen::Isometry3f to_camera = pose.inverse ();
    for (std::size_t i = 0; i < samples.size (); ++i)
    {
      if (seen[i])
        continue;
      const Eigen::Vector3f p = to_camera * samples[i];
      if (!(p.z () > 0.f))
        continue;
      const long u = std::lround (K.fx * p.x () / p.z () + K.cx), v = std::lround (K.fy * p.y () / p.z () + K.cy);
      if (u < 0 || v < 0 || u >= K.width || v >= K.height)
        continue;
      const float d = img.at (int (u), int (v)) * 0.001f;
      if (d < exact.min_range || d > exact.max_range)
        continue;
      seen[i] = std::abs (p.z () - d) <= std::max (tol, tol_per_metre * d);
    }
  }
  std::vector<Eigen::Vector3f> kept;
  for (std::size_t i = 0; i < samples.size (); ++i)
    if (seen[i])
      kept.push_back (samples[i]);
  return kept;
}

// Area-uniform samples of the truth; for rendered (pinhole) sequences only those a frame saw,
// for the range scans all of them.
std::unique_ptr<Truth>
makeTruth (const Sequence& s, std::size_t samples)
{
  if (!s.has_truth)
    return nullptr;
  auto t = std::make_unique<Truth> ();
  t->distance = std::make_unique<pclx::testing::MeshDistance> (s.truth);
  for (const auto& p : pclx::testing::sampleUniform (s.truth, samples, 3).cloud)
    t->samples.push_back (p.getVector3fMap ());
  t->all_samples = t->samples.size ();
  if (s.pinhole)
    t->samples = seenSamples (s, t->samples);
  return t;
}

// ---- Methods

struct Quality
{
  double chamfer = -1, hausdorff = -1, acc_mean = -1, comp_mean = -1, acc_max = -1, comp_max = -1, seen_fraction = -1;
  std::size_t triangles = 0, boundary = 0, nonmanifold = 0, duplicates = 0, zero_area = 0;
};

struct Bench
{
  pclx::bench::CsvWriter& out;
  std::ofstream* frames_csv;
  std::size_t samples;
  double cell_factor, collapse_ratio, collapse_error;
  int min_cell_pixels, narrowest_cell_pixels;
  double hole_leaves;    // largest hole closed, in leaves (< 0: the class's default)
  std::string mesh_dir;  // when set, every IDC and TSDF mesh is written there as PLY

  void
  saveMesh (const Sequence& s, const std::string& method, const std::string& params, const pcl::PolygonMesh& mesh)
  {
    if (mesh_dir.empty ())
      return;
    std::string name = s.name + "_" + method + (params.empty () ? "" : "_" + params);
    for (char& c : name)
      if (c == ';' || c == '=')
        c = '_';
    pcl::io::savePLYFileBinary (mesh_dir + "/" + name + ".ply", mesh);
  }

  Quality
  measure (const TriangleMesh& mesh, const Truth* truth)
  {
    Quality q;
    q.triangles = mesh.faces.size ();
    if (mesh.faces.empty ())
      return q;
    const auto topo = rbf_bench::topology (mesh);
    q.boundary = topo.boundary_edges;
    q.nonmanifold = topo.nonmanifold_edges;
    std::vector<Eigen::Vector3f> sorted = mesh.vertices;
    std::sort (sorted.begin (), sorted.end (), [] (const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
      return std::lexicographical_compare (a.data (), a.data () + 3, b.data (), b.data () + 3);
    });
    q.duplicates = static_cast<std::size_t> (std::distance (
        std::unique (sorted.begin (), sorted.end ()), sorted.end ()));
    for (const auto& f : mesh.faces)
      q.zero_area += !((mesh.vertices[f[1]] - mesh.vertices[f[0]]).cross (mesh.vertices[f[2]] - mesh.vertices[f[0]]).squaredNorm () > 0);
    if (truth)
    {
      const auto e = rbf_bench::meshError (mesh, *truth->distance, truth->samples, samples);
      q.acc_mean = e.out_to_truth_mean;
      q.acc_max = e.out_to_truth_max;
      q.seen_fraction = truth->seenFraction ();
      if (!truth->samples.empty ())
      {
        q.comp_mean = e.truth_to_out_mean;
        q.comp_max = e.truth_to_out_max;
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
                           {"nonmanifold_edges", double (q.nonmanifold)},
                           {"duplicate_vertices", double (q.duplicates)},
                           {"zero_area_triangles", double (q.zero_area)}};
    if (q.chamfer >= 0)
    {
      m.emplace_back ("chamfer", q.chamfer);
      m.emplace_back ("hausdorff", q.hausdorff);
    }
    if (q.acc_mean >= 0)
      m.emplace_back ("accuracy_mean", q.acc_mean);
    if (q.comp_mean >= 0)
      m.emplace_back ("completion_mean", q.comp_mean);
    if (q.acc_max >= 0)
      m.emplace_back ("accuracy_max", q.acc_max);
    if (q.comp_max >= 0)
      m.emplace_back ("completion_max", q.comp_max);
    if (q.seen_fraction >= 0)
      m.emplace_back ("truth_seen_fraction", q.seen_fraction);
    m.insert (m.end (), extra.begin (), extra.end ());
    double total = extract_ms;
    for (double x : frame_ms) total += x;
    out.row ("surface", method, params, s.name, s.frames.size (), total / 1e3, m);
    if (total > 3e3)
      pclx::bench::progress () << "bench_idc:   " << method << " " << params << ": " << total / 1e3 << " s\n";
  }

  void
  frameRows (const Sequence& s, const std::string& method, double leaf, const std::vector<double>& ms)
  {
    if (!frames_csv)
      return;
    for (std::size_t i = 0; i < ms.size (); ++i)
      *frames_csv << s.name << "," << method << "," << leaf << "," << i << "," << ms[i] << "\n";
  }

  // Hands the memory freed by the runs before back to the kernel, so that every method starts
  // as in a fresh process: on these VMs first writes to new pages are a large part of a frame,
  // and a run that reuses another's freed pages (or cannot, when they sit in another thread's
  // malloc arena) would be timed with a head start (or a handicap).
  static void
  startCold ()
  {
    malloc_trim (0);
  }

  // IDC: every frame through addFrame; optionally reconstruct after each frame.
  void
  idc (const Sequence& s, double leaf, double eps, bool incremental, const Truth* truth, bool frame_rows)
  {
    startCold ();
    pcl::IncrementalDualContouring<pcl::PointXYZ> idc;
    idc.setLeafSize (leaf);
    idc.setSimplificationError (eps);
    if (cell_factor > 0)
      idc.getSimplification ().setFrustumCellSize (cell_factor * leaf);
    else
      idc.getSimplification ().setFrustumCellPixels (8);  // fixed 8 x 8 pixel blocks, for comparison
    idc.getSimplification ().setCollapseTargetRatio (collapse_ratio);
    idc.getSimplification ().setCollapseMaxError (collapse_error);
    idc.getSimplification ().setMinCellPixels (min_cell_pixels);
    idc.getSimplification ().setNarrowestCellPixels (narrowest_cell_pixels);
    idc.setDepthRange (0.1f, float (s.depth_trunc));  // as Open3D's depth_trunc
    if (hole_leaves >= 0)
      idc.setMaxHoleSize (hole_leaves * leaf);
    std::vector<double> ms, recon_ms;
    std::size_t failed = 0;
    pcl::PolygonMesh mesh;
    for (const auto& f : s.frames)
    {
      const auto t0 = Clock::now ();
      const bool ok = s.pinhole ? idc.addFrame (f.mm.data (), f.width, f.height, s.K, f.pose, 0.001f)
                                : idc.addFrame (*f.organized, f.pose);
      double t = msSince (t0);
      failed += !ok;
      // The stage times are read once at the end: reading them here would wait for each
      // frame's merge, which otherwise overlaps the next frame.
      if (incremental)
      {
        const auto t1 = Clock::now ();
        idc.reconstruct (mesh);
        recon_ms.push_back (msSince (t1));
        t += recon_ms.back ();
      }
      ms.push_back (t);
    }
    if (!ms.empty ())
    {
      // The last frame's merge may still run: it belongs to the last frame.
      const auto t1 = Clock::now ();
      idc.getOctree ().waitForMerge ();
      ms.back () += msSince (t1);
    }
    double extract = 0;
    if (!incremental)
    {
      const auto t1 = Clock::now ();
      idc.reconstruct (mesh);
      extract = msSince (t1);
    }
    const auto& st = idc.getStats ();
    const auto& os = idc.getOctree ().getStats ();
    const double fused = std::max<double> (1, double (st.frames));
    const Quality q = measure (pclx::testing::fromPolygonMesh (mesh), truth);
    char params[160];
    const int n =
        std::snprintf (params, sizeof params,
                       "leaf=%g;eps=%g;cell=%g;collapse=%g;collapse_err=%g;min_cell_px=%d;narrowest_cell_px=%d", leaf,
                       eps, cell_factor * leaf, collapse_ratio, collapse_error, min_cell_pixels, narrowest_cell_pixels);
    if (hole_leaves >= 0)
      std::snprintf (params + n, sizeof params - std::size_t (n), ";hole_leaves=%g", hole_leaves);
    if (!incremental)
      saveMesh (s, "idc", params, mesh);
    row (s, incremental ? "idc_incremental" : "idc", params, q, ms, extract, st.memory_bytes / 1048576.0,
         {{"leaves", double (st.leaves)}, {"escaped_vertices", double (st.escaped_vertices)},
          {"failed_frames", double (failed)},
          {"reconstruct_ms_median", percentile (recon_ms, 0.5)},
          {"frontend_ms_mean", st.total_frontend_ms / fused},
          {"octree_ms_mean", (os.total_intersect_ms + os.total_merge_ms) / fused},
          {"intersect_ms_mean", os.total_intersect_ms / fused}, {"merge_ms_mean", os.total_merge_ms / fused},
          {"holes_filled", double (os.holes_filled)}, {"holes_open", double (os.holes_open)},
          {"hole_triangles", double (os.hole_triangles)}, {"holes_ms", os.t_holes_ms},
          {"last_vertices_ms", os.t_vertices_ms}, {"last_polygons_ms", os.t_polygons_ms},
          {"last_output_ms", os.t_output_ms}, {"collapse_ms", os.t_collapse_ms},
          {"last_reconstruct_ms", os.last_reconstruct_ms}});
    if (frame_rows)
      frameRows (s, incremental ? "idc_incremental" : "idc", leaf, ms);
  }

#ifdef PCLX_HAVE_OPEN3D
  void
  open3d (const Sequence& s, double voxel, const Truth* truth, bool frame_rows)
  {
    startCold ();
    std::vector<double> ms;
    std::vector<Eigen::Vector3f> v;
    std::vector<Eigen::Vector3i> f;
    double extract, mem;
    std::size_t units;
    {
      idc_open3d::Tsdf tsdf (voxel, 4 * voxel, s.depth_trunc);
      for (const auto& fr : s.frames)
        ms.push_back (1e3 * tsdf.integrate (fr.mm.data (), fr.width, fr.height, s.K.fx, s.K.fy, s.K.cx, s.K.cy, fr.pose));
      mem = tsdf.voxelBytes () / 1048576.0;  // the volume after the last frame, as IDC counts its map
      extract = 1e3 * tsdf.extract (v, f);
      units = tsdf.volumeUnits ();
    }
    TriangleMesh m;
    m.vertices = std::move (v);
    m.faces = std::move (f);
    const Quality q = measure (m, truth);
    char params[96];
    std::snprintf (params, sizeof params, "voxel=%g;sdf_trunc=%g", voxel, 4 * voxel);
    if (!mesh_dir.empty ())
      saveMesh (s, "open3d_scalable_tsdf", params, pclx::testing::toPolygonMesh (m));
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
  pclPeers (const Sequence& s, double leaf, const Truth* truth)
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
      const Quality q = measure (rbf_bench::weld (mesh, float (1e-3 * leaf)), truth);
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
      const Quality q = measure (pclx::testing::fromPolygonMesh (mesh), truth);
      std::snprintf (params, sizeof params, "leaf=%g;radius=%g", leaf, 3 * leaf);
      row (s, "pcl_greedy_projection", params, q, {t / s.frames.size ()}, 0, std::max (0.0, rssMiB () - rss0),
           {{"fused_points", double (cloud->size ())}, {"total_ms", t}});
    }
  }
};

// ---- The run

struct Options
{
  bool quick = false;
  bool no_sweeps = false;           // IDC at ε = 0 and the TSDF only (profiling)
  std::vector<double> leaves;       // replaces every input's leaves and TSDF voxels when set
  std::vector<double> eps;          // replaces the ε sweep when set
  std::string only, preview;
};

// Every input the options ask for, the generated ones rendered; inputs whose data is missing
// are skipped with a line on stderr.
std::vector<Sequence>
loadSequences (const Options& opt)
{
  const bool quick = opt.quick;
  std::vector<Sequence> seqs;
  const auto data = pclx::bench::sharedDataDir ();
  auto want = [&] (const std::string& n) { return opt.only.empty () || n.find (opt.only) != std::string::npos; };
  if (want ("orbit-torus-sphere"))
  {
    TriangleMesh obj = pclx::testing::makeTorus (0.3f, 0.1f, 128, 48);
    obj.append (pclx::testing::makeSphere (0.15f, 4));
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
  if (!zipper.faces.empty () && !quick && want ("bunny-mesh-x4"))
  {
    // Scaled to 0.6 m: an object of the size a depth camera scans at 1 cm detail.
    TriangleMesh big = zipper;
    const Eigen::Vector3f c = 0.5f * (big.bboxMin () + big.bboxMax ());
    big.transform (Eigen::Affine3f (Eigen::Scaling (4.f) * Eigen::Translation3f (-c)));
    seqs.push_back (renderOrbit ("bunny-mesh-x4", big, 36, 1.3, 640, 480, {0.02, 0.01, 0.005}));
  }
  if (data && !quick && want ("fertility-mesh"))
  {
    // The held-back orbits' setup: an organic closed mesh (genus 4) at 0.4 m, 24 views.
    try
    {
      TriangleMesh statue = pclx::testing::loadPlyMesh (*data + "/meshes/fertility.ply");
      const Eigen::Vector3f c = 0.5f * (statue.bboxMin () + statue.bboxMax ());
      const float scale = 0.4f / (statue.bboxMax () - statue.bboxMin ()).maxCoeff ();
      // Its height runs along x: stand it up along z, the orbit's axis.
      statue.transform (Eigen::Affine3f (Eigen::AngleAxisf (-0.5f * float (M_PI), Eigen::Vector3f::UnitY ()) *
                                         Eigen::Scaling (scale) * Eigen::Translation3f (-c)));
      seqs.push_back (renderOrbit ("fertility-mesh", statue, 24, 0.9, 640, 480, {0.02, 0.01, 0.005}));
    }
    catch (const std::exception& e)
    {
      std::cerr << "bench_idc: " << e.what () << "\n";
    }
  }
  if (want ("room-generated"))
    seqs.push_back (quick ? renderRoom (8, 320, 240, {0.02}) : renderRoom (30, 640, 480, {0.02, 0.01}));
  // The same room at the frame size of a 1200 × 680 RGB-D sequence: the front end's share grows
  // with the pixels, the TSDF's with the voxels in view.
  if (!quick && want ("room-1200x680"))
    seqs.push_back (renderRoom (30, 1200, 680, {0.02, 0.01}, "room-1200x680"));
  if (!quick && want ("rooms-multi"))
    seqs.push_back (renderTwoRooms (40, 640, 480));
  if (data && want ("7scenes-office"))
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
  for (auto& s : seqs)
    if (!opt.leaves.empty ())
    {
      s.leaves = opt.leaves;
      s.tsdf_voxels = s.pinhole ? opt.leaves : std::vector<double>{};
    }
  for (auto& s : seqs)
    if (s.pinhole && s.tsdf_voxels.empty ())
      s.tsdf_voxels = quick ? std::vector<double>{0.02, 0.01} : std::vector<double>{0.04, 0.02, 0.01, 0.005};
  return seqs;
}

// Writes the depth of every sixth of a sequence as 16-bit PGM images (millimetres) and the truth
// samples the frames saw as an XYZ file, to look at what the camera path sees.
void
writePreview (const Sequence& s, const std::string& dir, std::size_t samples)
{
  if (const auto truth = makeTruth (s, samples))
  {
    std::cerr << "bench_idc: " << s.name << ": truth seen by the frames: " << 100.0 * truth->seenFraction ()
              << " % of " << truth->all_samples << " samples\n";
    std::ofstream xyz (dir + "/" + s.name + "_seen.xyz");
    for (const auto& p : truth->samples)
      xyz << p.x () << " " << p.y () << " " << p.z () << "\n";
  }
  const std::size_t n = s.frames.size ();
  for (std::size_t i = 0; i < n; i += std::max<std::size_t> (1, n / 6))
  {
    const Frame& f = s.frames[i];
    if (f.mm.empty ())
      continue;
    const std::string path = dir + "/" + s.name + "_" + std::to_string (i) + ".pgm";
    std::ofstream out (path, std::ios::binary);
    if (!out)
    {
      std::cerr << "bench_idc: cannot write " << path << "\n";
      return;
    }
    out << "P5\n" << f.width << " " << f.height << "\n65535\n";
    for (const std::uint16_t d : f.mm)
      out.put (char (d >> 8)).put (char (d & 0xff));  // PGM stores 16-bit values big-endian
    std::cerr << "bench_idc: wrote " << path << "\n";
  }
}

// Every method on one sequence: IDC at its leaves, Open3D's TSDF over its voxel sweep, IDC's ε
// sweep and the per-frame incremental mesh at the middle leaf, PCL's peers on objects.
void
runSequence (Bench& bench, const Sequence& s, const Options& opt)
{
  pclx::bench::progress () << "bench_idc: " << s.name << ", " << s.frames.size () << " frames\n";
  const std::unique_ptr<Truth> truth = makeTruth (s, bench.samples);
  if (truth)
    pclx::bench::progress () << "bench_idc:   truth seen by the frames: " << truth->samples.size () << " of "
                             << truth->all_samples << " samples (" << 100.0 * truth->seenFraction () << " %)\n";
  if (s.has_truth)
    bench.saveMesh (s, "truth", "", pclx::testing::toPolygonMesh (s.truth));
  // With --no-sweeps and --eps, IDC runs at the given ε only (profiling one setting).
  const std::vector<double> base_eps = opt.no_sweeps && !opt.eps.empty () ? opt.eps : std::vector<double>{0};
  for (double leaf : s.leaves)
    for (double eps : base_eps)
      bench.idc (s, leaf, eps, false, truth.get (), eps == 0);
#ifdef PCLX_HAVE_OPEN3D
  for (double voxel : s.tsdf_voxels)
    bench.open3d (s, voxel, truth.get (), true);
#endif
  if (opt.no_sweeps)
    return;
  // ε in metres: how far a merged vertex may lie from the crossing planes it replaces
  // (IncrementalDualContouring::setSimplificationError), swept at every leaf of inputs with truth
  // (at the middle leaf otherwise), so that the chart shows each leaf's error against triangles.
  const std::vector<double> eps_sweep = !opt.eps.empty () ? opt.eps
                                        : opt.quick       ? std::vector<double>{0.01}
                                                          : std::vector<double>{0.0003, 0.001, 0.003, 0.01, 0.03, 0.1};
  const double mid = s.leaves[s.leaves.size () > 2 ? 1 : s.leaves.size () - 1];
  for (double leaf : s.leaves)
    if (leaf == mid || (truth && !opt.quick))
      for (double eps : eps_sweep)
        bench.idc (s, leaf, eps, false, truth.get (), false);
  bench.idc (s, mid, 0, true, truth.get (), true);
  if (s.object && (!opt.quick || s.name.find ("orbit") != std::string::npos))
    bench.pclPeers (s, mid, truth.get ());
}

}  // namespace

int
main (int argc, char** argv)
{
  pclx::bench::passiveOpenMpWaits (argv);
  CLI::App app ("IncrementalDualContouring vs Open3D ScalableTSDFVolume and PCL MarchingCubesHoppe / GP3");
  std::string csv, frames_csv;
  Options opt;
  app.add_option ("--csv", csv, "also write the rows to this file");
  std::string mesh_dir;
  app.add_option ("--mesh-dir", mesh_dir, "write the truth and every IDC and TSDF mesh to this folder (PLY)");
  app.add_option ("--frames-csv", frames_csv, "per-frame times: input,method,leaf,frame,ms");
  app.add_option ("--only", opt.only, "run only the inputs whose name contains this");
  app.add_flag ("--quick", opt.quick, "small sequences, two detail levels (< 1 min)");
  app.add_option ("--leaves", opt.leaves, "IDC leaves and TSDF voxels (m) instead of each input's own");
  app.add_flag ("--no-sweeps", opt.no_sweeps, "only IDC at ε = 0 and the TSDF (no ε sweep, incremental run or PCL peers)");
  app.add_option ("--eps", opt.eps,
                  "IDC's ε sweep (m) instead of 0.3 mm to 10 cm; with --no-sweeps, IDC runs at these instead of ε = 0");
  app.add_option ("--preview", opt.preview,
                  "write a few depth frames of every input as 16-bit PGM and the seen truth samples as XYZ "
                  "into this folder, and exit");
  double cell_factor = 2, collapse_ratio = 0, collapse_error = 0;  // CoupledSimplification's defaults
  int min_cell_pixels = pcl::CoupledSimplification ().getMinCellPixels ();
  int narrowest_cell_pixels = pcl::CoupledSimplification ().getNarrowestCellPixels ();
  app.add_option ("--cell-factor", cell_factor, "front-end frustum cell = factor x leaf (0: 8 x 8 pixel blocks)")
      ->capture_default_str ();
  app.add_option ("--collapse-ratio", collapse_ratio, "front-end edge-collapse target ratio")->capture_default_str ();
  app.add_option ("--collapse-error", collapse_error, "front-end collapse error bound (m; 0 auto, < 0 none)")
      ->capture_default_str ();
  app.add_option ("--min-cell-pixels", min_cell_pixels,
                  "front end: fewest pixels per cell side before 2 x 2 block averaging (0: full resolution)")
      ->capture_default_str ();
  app.add_option ("--narrowest-cell-pixels", narrowest_cell_pixels,
                  "front end: narrowest frustum cell side in pixels when cells follow the leaf (1: no floor)")
      ->capture_default_str ();
  double hole_leaves = -1;
  app.add_option ("--hole-leaves", hole_leaves,
                  "largest hole IDC closes, in leaves (0: none; unset: the class's default)");
  bool verbose = false;
  app.add_flag ("--verbose", verbose, "progress lines on stderr");
  CLI11_PARSE (app, argc, argv);
  pclx::bench::setVerbose (verbose);
  const std::size_t samples = opt.quick ? 20000 : 100000;
  const std::vector<Sequence> seqs = loadSequences (opt);
  if (!opt.preview.empty ())
  {
    for (const auto& s : seqs)
      writePreview (s, opt.preview, samples);
    return 0;
  }
  pclx::bench::CsvWriter out (csv);
  std::ofstream fcsv;
  if (!frames_csv.empty ())
  {
    fcsv.open (frames_csv);
    fcsv << "input,method,leaf,frame,ms\n";
  }
  Bench bench{out, frames_csv.empty () ? nullptr : &fcsv, samples, cell_factor, collapse_ratio, collapse_error,
              min_cell_pixels, narrowest_cell_pixels, hole_leaves, mesh_dir};
  for (const auto& s : seqs)
    runSequence (bench, s, opt);
  return 0;
}
