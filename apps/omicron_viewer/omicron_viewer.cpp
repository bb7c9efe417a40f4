// omicron_viewer: opens a point cloud (PCD / PLY / XYZ), starts building the OMiCroN
// hierarchy (pcl::ObliqueCutOctree) at once and renders its front as splats while it grows.
//
// Every frame the render loop hands the current VTK camera (view-projection and viewport) to
// ObliqueCutOctree::evaluate (the front tracker of seed 001 §3.2), and draws the returned
// nodes' points with vtkPointGaussianMapper: one disc per point, of the node level's splat
// radius (leaf radius times the per-level multipliers of Table 4.5). The mouse moves the
// camera, and the front follows it on the next frame. A text line and the terminal report how
// much of the input is in the hierarchy.
//
// Off-screen (--screenshot, --screenshot-every; under `xvfb-run -a` without a display) the
// growth is recorded into numbered PNGs; --no-render builds headless and prints the timings,
// with --camera-orbit a simulated render thread measuring the front's frame cost.
#include <pclx/apps/cloud_loader.h>
#include <pclx/apps/progress.h>
#include <pclx/apps/view.h>
#include <pclx/omicron/oblique_cut_octree.h>
#include <pclx/omicron/point_stream_reader.h>
#include <pclx/omicron/potree_writer.h>

#include <pcl/common/common.h>
#include <pcl/exceptions.h>

#include <vtkActor.h>
#include <vtkCamera.h>
#include <vtkFloatArray.h>
#include <vtkMatrix4x4.h>
#include <vtkPointData.h>
#include <vtkPointGaussianMapper.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkProperty.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkUnsignedCharArray.h>

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <future>
#include <iostream>
#include <thread>
#include <unordered_map>

namespace {

using Clock = std::chrono::steady_clock;

double
secondsSince (Clock::time_point t)
{
  return std::chrono::duration<double> (Clock::now () - t).count ();
}

struct Options
{
  std::string input, output, screenshot, growth_prefix, color = "auto", draw = "rebuild";
  int depth = 7, threads = 0, width = 1280, height = 800, screenshot_every = 0;
  float ratio = 0.2f, threshold = 0.2f, leaf_radius = 0.f;
  std::vector<float> multipliers;
  bool collapse = true, no_render = false, orbit = false;
  std::size_t worklist = 32, chunks = 16;
  double orbit_seconds = 8, budget_mb = 0;
  std::vector<float> view_dir{1.f, -1.4f, 0.9f}, up{0.f, 0.f, 1.f};
};

// The input and its axis-aligned bounds.
template <typename PointT>
struct Input
{
  typename pcl::PointCloud<PointT>::Ptr cloud{new pcl::PointCloud<PointT>};
  Eigen::Vector3f lo = Eigen::Vector3f::Constant (std::numeric_limits<float>::max ()), hi = -lo;
  bool color = false;
  std::string file;  // memory budget: the octree streams this file itself (cloud left empty)
  std::string summary;
  double seconds = 0;
};

// PCD and PLY: the kit's header check, then pcl::PointStreamReader in chunks straight into
// the cloud (no PCLPointCloud2 copy: half the peak memory of the kit's loader on big binary
// files). XYZ: the kit's loader (its column rules: x y z [nx ny nz]).
template <typename PointT>
Input<PointT>
readInput (const std::string& path, const pclx::apps::FileCheck& check)
{
  Input<PointT> in;
  const auto t0 = Clock::now ();
  if (check.format == pclx::apps::CloudFormat::XYZ)
  {
    pclx::apps::CloudInfo info;
    in.cloud = pclx::apps::loadCloud<PointT> (path, &info);
    pclx::apps::requireFinitePoints (info);
    in.summary = info.summary ();
  }
  else
  {
    pcl::PointStreamReader reader (path);
    in.color = reader.hasColor ();
    pclx::apps::Progress progress ("reading " + path, reader.getDeclaredPoints ());
    in.cloud->reserve (reader.getDeclaredPoints ());
    pcl::PointCloud<PointT> chunk;
    while (reader.read (1 << 20, chunk))
    {
      in.cloud->insert (in.cloud->end (), chunk.begin (), chunk.end ());
      progress.update (reader.getPointsRead () + reader.getDroppedInvalid ());
    }
    progress.done ();
    if (in.cloud->empty ())
      throw pclx::apps::LoadError (path + ": no finite point (" + std::to_string (reader.getDroppedInvalid ()) +
                                   " NaN/Inf)");
    in.summary = path + ": " + std::to_string (in.cloud->size ()) + " points (xyz" + (in.color ? " rgb" : "") + ")";
    if (reader.getDroppedInvalid ())
      in.summary += ", " + std::to_string (reader.getDroppedInvalid ()) + " NaN/Inf dropped";
  }
  for (const auto& p : *in.cloud)
    if (std::isfinite (p.x) && std::isfinite (p.y) && std::isfinite (p.z))
    {
      in.lo = in.lo.cwiseMin (p.getVector3fMap ());
      in.hi = in.hi.cwiseMax (p.getVector3fMap ());
    }
  in.seconds = secondsSince (t0);
  return in;
}

std::size_t
statusKb (const char* key)
{
  std::ifstream f ("/proc/self/status");
  std::string line;
  const std::string k = std::string (key) + ":";
  while (std::getline (f, line))
    if (line.rfind (k, 0) == 0)
      return std::stoul (line.substr (k.size ()));
  return 0;
}

struct Percentiles
{
  std::size_t n = 0;
  double p50 = 0, p95 = 0, max = 0;
};

Percentiles
percentiles (std::vector<double> v)
{
  Percentiles p;
  if (v.empty ())
    return p;
  std::sort (v.begin (), v.end ());
  const auto at = [&] (double q) { return v[std::min (v.size () - 1, std::size_t (q * double (v.size () - 1) + 0.5))]; };
  p.n = v.size ();
  p.p50 = at (0.5);
  p.p95 = at (0.95);
  p.max = v.back ();
  return p;
}

// Points the camera at the bounds' centre from `dir` and moves it back until the eight corners
// fit the view with `margin` (share of the half-width) to spare. apps::frameViewport does
// this for the props on screen; here the subject is the data bounds, known before anything is
// drawn (and the camera may have no renderer: --no-render).
void
frameBounds (vtkCamera* cam, double aspect, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi,
             const Eigen::Vector3d& dir_in, const Eigen::Vector3d& up_in, double margin = 0.06)
{
  const Eigen::Vector3d dir = -dir_in.normalized ();  // view direction: towards the data
  Eigen::Vector3d right = dir.cross (up_in);
  if (right.norm () < 1e-6)
    right = dir.unitOrthogonal ();
  right.normalize ();
  const Eigen::Vector3d up = right.cross (dir);
  const double tan_v = std::tan (cam->GetViewAngle () * M_PI / 360.0) * (1 - margin);
  const double tan_h = tan_v * aspect;
  const Eigen::Vector3d c = ((lo + hi) / 2).cast<double> ();
  double distance = 0;
  for (int i = 0; i < 8; ++i)
  {
    const Eigen::Vector3d p (i & 1 ? hi.x () : lo.x (), i & 2 ? hi.y () : lo.y (), i & 4 ? hi.z () : lo.z ());
    const Eigen::Vector3d q = p - c;
    distance = std::max (distance, std::max (std::abs (q.dot (right)) / tan_h, std::abs (q.dot (up)) / tan_v) - q.dot (dir));
  }
  distance = std::max (distance, 1e-3 * (hi - lo).cast<double> ().norm () + 1e-9);
  const Eigen::Vector3d eye = c - distance * dir;
  cam->SetFocalPoint (c.data ());
  cam->SetPosition (eye.data ());
  cam->SetViewUp (up.data ());
}

// Near and far planes around the bounds (the front culls against them too).
void
clipToBounds (vtkCamera* cam, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi)
{
  double pos[3], dop[3];
  cam->GetPosition (pos);
  cam->GetDirectionOfProjection (dop);
  double near = std::numeric_limits<double>::max (), far = 0;
  for (int i = 0; i < 8; ++i)
  {
    const Eigen::Vector3d p (i & 1 ? hi.x () : lo.x (), i & 2 ? hi.y () : lo.y (), i & 4 ? hi.z () : lo.z ());
    const double d = (p - Eigen::Vector3d (pos[0], pos[1], pos[2])).dot (Eigen::Vector3d (dop[0], dop[1], dop[2]));
    near = std::min (near, d);
    far = std::max (far, d);
  }
  far = std::max (far * 1.05, 1e-6);
  near = std::max (near * 0.95, far * 1e-4);
  cam->SetClippingRange (near, far);
}

// An orbit around the bounds' centre at the framing distance: one turn per `period` seconds.
void
orbit (vtkCamera* cam, const Eigen::Vector3d& centre, const Eigen::Vector3d& start_eye, const Eigen::Vector3d& up,
       double t, double period)
{
  const Eigen::Vector3d eye = centre + Eigen::AngleAxisd (2 * M_PI * t / period, up.normalized ()) * (start_eye - centre);
  cam->SetFocalPoint (centre.data ());
  cam->SetPosition (eye.data ());
  cam->SetViewUp (up.data ());
  cam->OrthogonalizeViewUp ();
}

template <typename Camera>
Camera
frontCamera (vtkCamera* cam, int width, int height)
{
  Camera c;
  c.width = width;
  c.height = height;
  vtkMatrix4x4* m = cam->GetCompositeProjectionTransformMatrix (double (width) / height, -1, 1);
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      c.view_projection (i, j) = static_cast<float> (m->GetElement (i, j));
  return c;
}

// Share of the input points whose leaves are in the hierarchy: the cut's boundary m_C (the
// last leaf concatenated) located among a Morton-sorted sample of the input (<= 2^18 points,
// taken once the root cube is known, off the render thread).
template <typename PointT>
class Completion
{
public:
  Completion (pcl::ObliqueCutOctree<PointT>& octree, const pcl::PointCloud<PointT>& cloud)
    : octree_ (octree), cloud_ (cloud)
  {}

  double
  percent ()
  {
    if (octree_.isFinished ())
      return 100;
    if (cloud_.empty ())
      return -1;
    // The cut exists once the first leaf reached the front (it is not replaced meanwhile).
    if (octree_.getFront ().secondsToFirstLeaf () < 0)
      return -1;
    if (!sample_.valid ())
      sample_ = std::async (std::launch::async, [this] { return sortedSample (); });
    // The first time, wait a little: a fresh front should not be labelled 0 %.
    if (sample_.wait_for (std::chrono::milliseconds (codes_.empty () ? 50 : 0)) != std::future_status::ready)
      return last_;
    if (codes_.empty ())
      codes_ = sample_.get ();
    const pcl::MortonCode b = octree_.getCut ()->getBoundary ();
    const int lmax = octree_.getMaxDepth ();
    if (!b.valid () || codes_.empty ())
      return last_;
    const std::uint64_t bound = (b.level () < lmax ? b.span (lmax) : b).bits ();
    const auto k = std::upper_bound (codes_.begin (), codes_.end (), bound) - codes_.begin ();
    last_ = std::max (last_, 100.0 * double (k) / double (codes_.size ()));
    return last_;
  }

private:
  std::vector<std::uint64_t>
  sortedSample () const
  {
    const Eigen::Vector3d origin = octree_.getRootOrigin ();
    const double edge = octree_.getRootEdge ();
    const int lmax = octree_.getMaxDepth ();
    const std::size_t stride = std::max<std::size_t> (1, cloud_.size () >> 18);
    std::vector<std::uint64_t> codes;
    codes.reserve (cloud_.size () / stride + 1);
    for (std::size_t i = 0; i < cloud_.size (); i += stride)
    {
      const auto& p = cloud_[i];
      if (std::isfinite (p.x) && std::isfinite (p.y) && std::isfinite (p.z))
        codes.push_back (pcl::MortonCode::fromPoint (p.getVector3fMap (), origin, edge, lmax).bits ());
    }
    std::sort (codes.begin (), codes.end ());
    return codes;
  }

  pcl::ObliqueCutOctree<PointT>& octree_;
  const pcl::PointCloud<PointT>& cloud_;
  std::future<std::vector<std::uint64_t>> sample_;
  std::vector<std::uint64_t> codes_;
  double last_ = -1;  // < 0: not known yet
};

// Colour of a splat: the cloud's rgb, the node's level, or the height (along the camera's up
// direction) over the bounds.
struct Colouring
{
  enum Mode { RGB, LEVEL, HEIGHT } mode = HEIGHT;
  Eigen::Vector3f up = Eigen::Vector3f::UnitZ ();
  float z0 = 0, inv_dz = 1;
  std::array<std::array<std::uint8_t, 3>, 256> ramp{};
  std::array<std::array<std::uint8_t, 3>, 22> level{};

  Colouring (Mode m, const Eigen::Vector3f& up_dir, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi)
    : mode (m), up (up_dir.normalized ())
  {
    float zlo = std::numeric_limits<float>::max (), zhi = -zlo;
    for (int i = 0; i < 8; ++i)
    {
      const float z = up.dot (Eigen::Vector3f (i & 1 ? hi.x () : lo.x (), i & 2 ? hi.y () : lo.y (), i & 4 ? hi.z () : lo.z ()));
      zlo = std::min (zlo, z);
      zhi = std::max (zhi, z);
    }
    z0 = zlo;
    inv_dz = zhi > zlo ? 255.f / (zhi - zlo) : 0.f;
    // Height: deep blue -> teal -> sand -> white (readable on the dark background).
    const Eigen::Vector3f stops[4] = {{0.18f, 0.30f, 0.75f}, {0.15f, 0.70f, 0.65f}, {0.92f, 0.80f, 0.45f}, {1.f, 0.97f, 0.92f}};
    for (int i = 0; i < 256; ++i)
    {
      const float t = 3.f * i / 255.f;
      const int k = std::min (2, int (t));
      const Eigen::Vector3f c = stops[k] + (t - k) * (stops[k + 1] - stops[k]);
      for (int j = 0; j < 3; ++j)
        ramp[i][j] = static_cast<std::uint8_t> (255.f * c[j]);
    }
    for (int l = 0; l < 22; ++l)
    {
      std::uint32_t h = std::uint32_t (l + 3) * 2654435761u;
      for (int j = 0; j < 3; ++j)
        level[l][j] = static_cast<std::uint8_t> (70 + (h >> (8 * j + 8)) % 186);
    }
  }

  template <typename PointT>
  void
  operator() (const PointT& p, int node_level, std::uint8_t* out) const
  {
    if constexpr (pcl::traits::has_color_v<PointT>)
      if (mode == RGB)
      {
        out[0] = p.r;
        out[1] = p.g;
        out[2] = p.b;
        return;
      }
    const std::uint8_t* c = mode == LEVEL ? level[node_level].data ()
                                          : ramp[static_cast<int> (std::clamp ((up.dot (p.getVector3fMap ()) - z0) * inv_dz, 0.f, 255.f))].data ();
    out[0] = c[0];
    out[1] = c[1];
    out[2] = c[2];
  }
};

// Splats as opaque, depth-tested discs of radius `scale` (VTK's default is an additive
// Gaussian, which sums overlapping splats to white); a slight darkening at the rim.
vtkSmartPointer<vtkActor>
splatActor (vtkPolyData* data)
{
  vtkNew<vtkPointGaussianMapper> mapper;
  mapper->SetInputData (data);
  mapper->SetScaleArray ("scale");
  mapper->SetScaleFactor (1.0);
  mapper->EmissiveOff ();
  mapper->SetTriangleScale (1.0f);
  mapper->SetSplatShaderCode ("//VTK::Color::Impl\n"
                              "float dist2 = dot(offsetVCVSOutput.xy, offsetVCVSOutput.xy);\n"
                              "if (dist2 > 1.0) { discard; }\n"
                              "float rim = 1.0 - 0.3 * dist2;\n"
                              "ambientColor *= rim;\n"
                              "diffuseColor *= rim;\n");
  mapper->SetScalarModeToUsePointData ();
  mapper->SetColorModeToDirectScalars ();
  mapper->ScalarVisibilityOn ();
  vtkSmartPointer<vtkActor> actor = vtkSmartPointer<vtkActor>::New ();
  actor->SetMapper (mapper);
  actor->GetProperty ()->SetAmbient (0.35);
  actor->GetProperty ()->SetDiffuse (0.65);
  return actor;
}

// Fills points, colours and per-point scales of `items` into a poly data (arrays reused).
template <typename Item>
void
fillPolyData (const std::vector<Item>& items, const Colouring& colour, vtkPolyData* data)
{
  std::size_t n = 0;
  for (const auto& it : items)
    n += it.num_points;
  vtkPoints* pts = data->GetPoints ();
  auto* xyz = vtkFloatArray::SafeDownCast (pts->GetData ());
  auto* rgb = vtkUnsignedCharArray::SafeDownCast (data->GetPointData ()->GetScalars ());
  auto* scale = vtkFloatArray::SafeDownCast (data->GetPointData ()->GetArray ("scale"));
  xyz->SetNumberOfTuples (static_cast<vtkIdType> (n));
  rgb->SetNumberOfTuples (static_cast<vtkIdType> (n));
  scale->SetNumberOfTuples (static_cast<vtkIdType> (n));
  float* p = xyz->GetPointer (0);
  std::uint8_t* c = rgb->GetPointer (0);
  float* s = scale->GetPointer (0);
  for (const auto& it : items)
  {
    const int level = it.node ? it.node->level : 0;
    for (std::uint32_t i = 0; i < it.num_points; ++i, p += 3, c += 3, ++s)
    {
      const auto& q = it.points[i];
      p[0] = q.x;
      p[1] = q.y;
      p[2] = q.z;
      colour (q, level, c);
      *s = it.splat_radius;
    }
  }
  xyz->Modified ();
  rgb->Modified ();
  scale->Modified ();
  pts->Modified ();
  data->Modified ();
}

vtkSmartPointer<vtkPolyData>
emptySplatData ()
{
  vtkSmartPointer<vtkPolyData> data = vtkSmartPointer<vtkPolyData>::New ();
  vtkNew<vtkPoints> pts;
  pts->SetDataTypeToFloat ();
  data->SetPoints (pts);
  vtkNew<vtkUnsignedCharArray> rgb;
  rgb->SetNumberOfComponents (3);
  rgb->SetName ("rgb");
  data->GetPointData ()->SetScalars (rgb);
  vtkNew<vtkFloatArray> scale;
  scale->SetName ("scale");
  data->GetPointData ()->AddArray (scale);
  return data;
}

// Draws the front: `rebuild` keeps one poly data refilled when the front changes; `nodes`
// keeps one actor per node (cached by node pointer) and switches visibility.
template <typename PointT>
class SplatRenderer
{
public:
  using Item = typename pcl::ObliqueCutOctree<PointT>::Item;
  using Node = typename pcl::ObliqueCutOctree<PointT>::Node;

  SplatRenderer (vtkRenderer* renderer, const Colouring& colour, bool per_node)
    : renderer_ (renderer), colour_ (colour), per_node_ (per_node)
  {
    if (!per_node_)
    {
      data_ = emptySplatData ();
      actor_ = splatActor (data_);
      if (renderer_)
        renderer_->AddActor (actor_);
    }
  }

  // Returns true when the drawn set changed.
  bool
  update (const std::vector<Item>& items)
  {
    bool same = items.size () == shown_.size ();
    for (std::size_t i = 0; same && i < items.size (); ++i)
      same = items[i].node == shown_[i] && (items[i].node || items[i].num_points == 0);
    if (same)
      return false;
    shown_.clear ();
    for (const auto& it : items)
      shown_.push_back (it.node);
    ++generation_;
    if (!per_node_)
    {
      fillPolyData (items, colour_, data_);
      return true;
    }
    for (const auto& it : items)
    {
      auto& e = cache_[it.node];
      if (!e.actor)
      {
        e.data = emptySplatData ();
        fillPolyData (std::vector<Item>{it}, colour_, e.data);
        e.actor = splatActor (e.data);
        if (renderer_)
          renderer_->AddActor (e.actor);
      }
      e.actor->SetVisibility (true);
      e.generation = generation_;
    }
    // Hide what left the front; forget actors unused for a while.
    for (auto i = cache_.begin (); i != cache_.end ();)
    {
      if (i->second.generation != generation_)
        i->second.actor->SetVisibility (false);
      if (generation_ - i->second.generation > 64)
      {
        if (renderer_)
          renderer_->RemoveActor (i->second.actor);
        i = cache_.erase (i);
      }
      else
        ++i;
    }
    return true;
  }

private:
  struct Cached
  {
    vtkSmartPointer<vtkPolyData> data;
    vtkSmartPointer<vtkActor> actor;
    std::size_t generation = 0;
  };
  vtkRenderer* renderer_;
  const Colouring& colour_;
  bool per_node_;
  vtkSmartPointer<vtkPolyData> data_;
  vtkSmartPointer<vtkActor> actor_;
  std::vector<const Node*> shown_;
  std::unordered_map<const Node*, Cached> cache_;
  std::size_t generation_ = 0;
};

std::string
fmtMb (std::size_t bytes)
{
  char b[32];
  std::snprintf (b, sizeof b, "%.1f MB", double (bytes) / 1048576.0);
  return b;
}

template <typename PointT>
int
run (const Options& opt, Input<PointT> in)
{
  using Octree = pcl::ObliqueCutOctree<PointT>;
  if (in.file.empty ())
    std::printf ("%s, read in %.2f s\n", in.summary.c_str (), in.seconds);
  else
    std::printf ("%s\n", in.summary.c_str ());
  const bool offscreen = !opt.screenshot.empty () || opt.screenshot_every > 0;
  const int threads = opt.threads > 0 ? opt.threads : std::max (1, int (std::thread::hardware_concurrency ()));

  Octree octree;
  if (in.file.empty ())
    octree.setInputCloud (in.cloud);
  else
  {
    // Out of core: the octree reads the file in blocks, subtrees below its spill level go to
    // the Potree folder as they are finished (the front stops at that level).
    octree.setInputFile (in.file);
    octree.setMemoryBudget (static_cast<std::size_t> (opt.budget_mb * 1048576.0));
    if (!opt.output.empty ())
      octree.setOutputDirectory (opt.output);
  }
  octree.setMaxDepth (opt.depth);
  octree.setParentPointRatio (opt.ratio);
  octree.setLeafCollapse (opt.collapse);
  octree.setWorklistSize (opt.worklist);
  octree.setSortChunks (opt.chunks);
  octree.setThreads (threads);
  octree.setProjectionThreshold (opt.threshold);
  octree.setLeafSplatRadius (opt.leaf_radius);
  // Default: one factor 1/sqrt(ratio) per level, the growth of the point spacing on a surface
  // when a parent keeps `ratio` of its children's points. Table 4.5's factors (the library's
  // default, 4.2 at the first step) were tuned for EWA splats; on opaque discs they give
  // about 4x the overdraw with no visible gain.
  octree.setSplatMultipliers (opt.multipliers.empty () ? std::vector<float>{1.f / std::sqrt (opt.ratio)}
                                                       : opt.multipliers);

  Colouring::Mode mode = Colouring::HEIGHT;
  if (opt.color == "level")
    mode = Colouring::LEVEL;
  else if (opt.color == "rgb" || (opt.color == "auto" && in.color))
    mode = Colouring::RGB;
  if (mode == Colouring::RGB && !in.color)
  {
    std::cerr << "omicron_viewer: the cloud has no colour; colouring by height\n";
    mode = Colouring::HEIGHT;
  }
  const Eigen::Vector3f up_f (opt.up[0], opt.up[1], opt.up[2]);
  if (!(up_f.norm () > 0) || !up_f.allFinite ())
    throw std::invalid_argument ("--up must be a non-zero direction");
  // Bounds: from the loaded cloud, or (budgeted build) the root cube once the octree has read
  // the file; camera framing and height colours wait for them.
  Eigen::Vector3f lo = in.lo, hi = in.hi;
  bool framed = (lo.array () <= hi.array ()).all ();
  if (!framed)
    lo = hi = Eigen::Vector3f::Zero ();
  Colouring colour (mode, up_f, lo, hi);

  // The window (or none) and the camera, framed on the data bounds.
  pcl::visualization::PCLVisualizer::Ptr viewer;
  vtkRenderer* renderer = nullptr;
  vtkSmartPointer<vtkCamera> camera;
  if (!opt.no_render)
  {
    viewer = pclx::apps::makeVisualizer ("omicron_viewer", offscreen, opt.width, opt.height);
    viewer->setBackgroundColor (0.07, 0.07, 0.09);
    renderer = pclx::apps::viewportRenderer (*viewer, 0);
    camera = renderer->GetActiveCamera ();
    viewer->addText ("building: 0 % of points in the hierarchy, front 0 nodes", 12, 12, 16, 0.92, 0.92, 0.92, "progress");
  }
  else
    camera = vtkSmartPointer<vtkCamera>::New ();
  const Eigen::Vector3d view_dir = Eigen::Vector3f (opt.view_dir[0], opt.view_dir[1], opt.view_dir[2]).cast<double> ();
  const Eigen::Vector3d up = Eigen::Vector3f (opt.up[0], opt.up[1], opt.up[2]).cast<double> ();
  Eigen::Vector3d centre, start_eye;
  const auto frame_camera = [&] {
    frameBounds (camera, double (opt.width) / opt.height, lo, hi, view_dir, up);
    clipToBounds (camera, lo, hi);
    camera->GetFocalPoint (centre.data ());
    camera->GetPosition (start_eye.data ());
  };
  if (framed)
    frame_camera ();

  SplatRenderer<PointT> splats (renderer, colour, opt.draw == "nodes");
  const bool frames_run = !opt.no_render || opt.orbit;  // a render loop, real or simulated
  std::vector<typename Octree::Item> items;
  std::vector<double> frame_ms, eval_ms;
  double first_items_s = -1, build_s = -1;
  int frame = 0, shots = 0, last_shot = -1;
  std::string label;
  const auto shot = [&] (const std::string& png) {
    pclx::apps::saveScreenshot (*viewer, png);
  };
  const auto shotName = [&] (int k) {
    char b[16];
    std::snprintf (b, sizeof b, "_%04d.png", k);
    return opt.growth_prefix + b;
  };

  // The first render creates the GL context and compiles shaders (~0.5 s with Mesa's
  // llvmpipe): done before the build so it is not the first frame of the growth.
  if (viewer)
  {
    if (offscreen)
      viewer->getRenderWindow ()->Render ();
    else
      viewer->spinOnce (1, true);
  }
  std::printf ("building: depth %d, parent ratio %.2f, leaf collapse %s, worklist %zu, sort chunks %zu, %d threads, "
               "projection threshold %.2f\n",
               opt.depth, opt.ratio, opt.collapse ? "on" : "off", opt.worklist, opt.chunks, threads, opt.threshold);
  std::fflush (stdout);
  const auto t0 = Clock::now ();
  if (!octree.startBuild ())
    throw std::runtime_error ("the build did not start");
  Completion<PointT> completion (octree, *in.cloud);
  pclx::apps::Progress progress ("building the hierarchy", 100);
  int stable = 0;
  bool stopped = false;
  while (true)
  {
    const bool building = !octree.isFinished ();
    if (building)
      progress.update (static_cast<std::size_t> (std::max (0.0, completion.percent ())));
    else if (build_s < 0)
    {
      build_s = octree.getStatistics ().seconds_total;
      progress.done ();
    }
    if (!frames_run)
    {
      if (!building)
        break;
      std::this_thread::sleep_for (std::chrono::milliseconds (20));
      continue;
    }
    if (!framed && octree.getFront ().secondsToFirstLeaf () >= 0)
    {
      const Eigen::Vector3d o = octree.getRootOrigin ();
      lo = o.cast<float> ();
      hi = lo + Eigen::Vector3f::Constant (static_cast<float> (octree.getRootEdge ()));
      colour = Colouring (mode, up_f, lo, hi);
      frame_camera ();
      framed = true;
    }
    // One frame: camera -> front -> splats -> picture.
    const auto f0 = Clock::now ();
    if (opt.orbit && building)  // then the front settles for the final picture
      orbit (camera, centre, start_eye, up, secondsSince (t0), opt.orbit_seconds);
    clipToBounds (camera, lo, hi);
    octree.evaluate (frontCamera<typename Octree::Camera> (camera, opt.width, opt.height), items);
    const double e_ms = 1e3 * secondsSince (f0);
    const bool changed = splats.update (items);
    if (viewer)
    {
      const double pct = building ? completion.percent () : 100.0;
      char text[160];
      if (building && !in.file.empty ())
        std::snprintf (text, sizeof text, "building out of core: front %zu nodes", items.size ());
      else if (building && pct < 0)
        std::snprintf (text, sizeof text, "building: front %zu nodes", items.size ());
      else if (building)
        std::snprintf (text, sizeof text, "building: %.0f %% of points in the hierarchy, front %zu nodes", pct, items.size ());
      else
        std::snprintf (text, sizeof text, "built: %zu points in %.2f s, front %zu nodes",
                     octree.getStatistics ().kept_points, build_s, items.size ());
      if (label != text)
      {
        label = text;
        viewer->updateText (label, 12, 12, 16, 0.92, 0.92, 0.92, "progress");
      }
      if (offscreen)
        viewer->getRenderWindow ()->Render ();
      else
      {
        viewer->spinOnce (1, true);
        stopped = viewer->wasStopped ();
      }
    }
    const double f_ms = 1e3 * secondsSince (f0);
    if (!items.empty () && first_items_s < 0)
      first_items_s = secondsSince (t0);
    if (building && first_items_s >= 0)
    {
      frame_ms.push_back (f_ms);
      eval_ms.push_back (e_ms);
    }
    if (first_items_s >= 0)
      ++frame;
    if (viewer && opt.screenshot_every > 0 && first_items_s >= 0 && (frame - 1) % opt.screenshot_every == 0)
    {
      shot (shotName (shots++));
      last_shot = frame;
    }
    if (stopped)
      break;
    // After the build: the front still branches one level per evaluation; once it rests,
    // an off-screen or headless run ends, a window waits for the user.
    if (!building)
    {
      stable = changed ? 0 : stable + 1;
      if ((offscreen || opt.no_render) && (stable >= 1 || frame > 400))
        break;
      if (!offscreen && !opt.no_render && !changed)
        std::this_thread::sleep_for (std::chrono::milliseconds (10));
    }
    else if (f_ms < 16.7)  // about a display's 60 Hz
      std::this_thread::sleep_for (std::chrono::duration<double, std::milli> (16.7 - f_ms));
  }
  if (!octree.wait ())
    throw std::runtime_error (octree.getLastError ().empty () ? "the build failed" : octree.getLastError ());
  if (build_s < 0)
    build_s = secondsSince (t0);

  // What the build did.
  const auto st = octree.getStatistics ();
  if (in.file.empty ())
    std::printf ("read: file %.2f s, ", in.seconds);
  else
    std::printf ("read (streamed by the octree): ");
  std::printf ("octree bounds and bucket passes %.3f s; first chunk sorted in %.3f s (%zu chunks)\n", st.seconds_read,
               st.seconds_to_first_chunk - st.seconds_read, st.chunks);
  std::printf ("first renderable front: %.3f s after the build started", st.seconds_to_first_front);
  if (first_items_s >= 0 && frames_run)
    std::printf (" (first splats drawn at %.3f s)", first_items_s);
  std::printf ("; hierarchy complete: %.3f s\n", st.seconds_total);
  const std::vector<float> radii = octree.getSplatRadii ();
  std::printf ("%6s %10s %12s %10s %12s\n", "level", "nodes", "points", "leaves", "splat radius");
  std::size_t nodes = 0, pts = 0;
  for (std::size_t l = 0; l < st.nodes_per_level.size (); ++l)
  {
    std::printf ("%6zu %10zu %12zu %10zu %12.4g\n", l, st.nodes_per_level[l], st.points_per_level[l],
                 st.leaves_per_level[l], l < radii.size () ? radii[l] : 0.f);
    nodes += st.nodes_per_level[l];
    pts += st.points_per_level[l];
  }
  std::printf ("%6s %10zu %12zu   (%zu input points kept, %zu NaN/Inf dropped)\n", "all", nodes, pts, st.kept_points,
               st.dropped_invalid);
  std::printf ("memory: sorted points %s, hierarchy %s; peak resident (VmHWM) %s\n", fmtMb (st.sorted_bytes).c_str (),
               fmtMb (st.hierarchy_bytes).c_str (), fmtMb (statusKb ("VmHWM") * 1024).c_str ());
  if (st.memory_budget)
    std::printf ("memory budget %s: accounted peak %s (planned %s); spill level %d, %zu nodes / %zu points written out "
                 "and dropped; chunk file pass %.2f s\n",
                 fmtMb (st.memory_budget).c_str (), fmtMb (st.accounted_peak_bytes).c_str (),
                 fmtMb (st.planned_peak_bytes).c_str (), st.spill_level, st.spilled_nodes, st.spilled_points,
                 st.seconds_chunks);
  if (frames_run)
  {
    const Percentiles f = percentiles (frame_ms), e = percentiles (eval_ms);
    std::printf ("%s frames during the build: %zu, frame time p50 %.1f ms, p95 %.1f ms, max %.1f ms (front "
                 "evaluation p50 %.2f ms, p95 %.2f ms); front now %zu nodes\n",
                 opt.no_render ? "simulated (evaluate + splat arrays)" : "rendered", f.n, f.p50, f.p95, f.max, e.p50,
                 e.p95, items.size ());
  }
  if (viewer && !opt.screenshot.empty ())
  {
    shot (opt.screenshot);
    std::printf ("wrote %s\n", opt.screenshot.c_str ());
  }
  if (shots > 0)
  {
    if (last_shot != frame)  // the final front as the last picture of the series
      shot (shotName (shots++));
    std::printf ("wrote %d growth pictures %s ... %s\n", shots, shotName (0).c_str (), shotName (shots - 1).c_str ());
  }
  if (!in.file.empty ())
    std::printf ("Potree 2.0 files written by the build to %s%s\n", octree.getOutputDirectory ().c_str (),
                 opt.output.empty () ? " (temporary: removed on exit; give --output to keep them)" : "");
  else if (!opt.output.empty ())
  {
    const auto w0 = Clock::now ();
    pcl::PotreeWriter<PointT> writer;
    writer.write (octree, opt.output);
    std::printf ("wrote Potree 2.0 files to %s (metadata.json, hierarchy.bin, octree.bin) in %.2f s\n",
                 opt.output.c_str (), secondsSince (w0));
  }
  return 0;
}

// pcl::IOException's what() starts with "<function> in <source file> @ <line> : ".
std::string
oneLine (const std::exception& e)
{
  std::string s = e.what ();
  if (dynamic_cast<const pcl::PCLException*> (&e))
  {
    const auto k = s.find (" : ");
    if (k != std::string::npos)
      s = s.substr (k + 3);
  }
  std::replace (s.begin (), s.end (), '\n', ' ');
  return s;
}

}  // namespace

int
main (int argc, char** argv)
{
  Options o;
  CLI::App app ("omicron_viewer: builds the OMiCroN hierarchy (pcl::ObliqueCutOctree) of a PCD/PLY/XYZ cloud and "
                "renders its front as splats while it grows");
  app.add_option ("input,-i,--input", o.input, "PCD, PLY or XYZ (text) file")->required ();
  app.add_option ("--depth", o.depth, "maximum octree depth (1..21)")->capture_default_str ();
  app.add_option ("--ratio", o.ratio, "parent point ratio (0, 1]")->capture_default_str ();
  app.add_flag ("--collapse,!--no-collapse", o.collapse, "leaf collapse (default on)");
  app.add_option ("--worklist", o.worklist, "nodes per worklist")->capture_default_str ();
  app.add_option ("--chunks", o.chunks, "Morton sort chunks")->capture_default_str ();
  app.add_option ("--threads", o.threads, "build threads (0: all cores)")->capture_default_str ();
  app.add_option ("--threshold", o.threshold, "front projection threshold (NDC diagonal)")->capture_default_str ();
  app.add_option ("--leaf-radius", o.leaf_radius,
                  "leaf splat radius in world units (0: about the point spacing, from the first chunk)")
      ->capture_default_str ();
  app.add_option ("--splat-multipliers", o.multipliers,
                  "splat radius factors going up from the leaves, the last one for every higher level (default: "
                  "1/sqrt(ratio) at every level; the seed's Table 4.5: 4.2 2.4 2.2 2.2 2.0)");
  app.add_option ("--color", o.color, "auto (rgb when the cloud has it, else height), rgb, height or level")
      ->check (CLI::IsMember ({"auto", "rgb", "height", "level"}))
      ->capture_default_str ();
  app.add_option ("--draw", o.draw, "rebuild: one splat array refilled when the front changes; nodes: one actor per node")
      ->check (CLI::IsMember ({"rebuild", "nodes"}))
      ->capture_default_str ();
  auto* shot = app.add_option ("--screenshot", o.screenshot, "render off-screen, save the final picture (PNG) and exit");
  auto* every = app.add_option ("--screenshot-every", o.screenshot_every,
                                "render off-screen and save every N-th rendered frame (from the first with splats) as "
                                "<prefix>_NNNN.png, then the final front; exits after the build");
  app.add_option ("--growth-prefix", o.growth_prefix,
                  "file prefix of --screenshot-every (default: --screenshot without .png, else omicron_growth)");
  app.add_option ("-o,--output", o.output, "write the hierarchy as Potree 2.0 files to this folder after the build");
  app.add_option ("--memory-budget", o.budget_mb,
                  "MB for the build's buffers: out-of-core build streaming the file (PCD/PLY/XYZ), subtrees below "
                  "the spill level written to --output as they finish (0: in memory)")
      ->capture_default_str ();
  auto* headless = app.add_flag ("--no-render", o.no_render, "no window: build, print timings and statistics");
  headless->excludes (shot)->excludes (every);
  app.add_flag ("--camera-orbit", o.orbit,
                "orbit the camera around the cloud during the build (with --no-render: a simulated render thread "
                "evaluating the front at up to 60 Hz)");
  app.add_option ("--orbit-seconds", o.orbit_seconds, "seconds per orbit")->capture_default_str ();
  app.add_option ("--view-dir", o.view_dir, "x y z: direction from the cloud's centre to the camera")->expected (3);
  app.add_option ("--up", o.up, "x y z: the camera's up direction")->expected (3);
  app.add_option ("--width", o.width, "window and screenshot width in pixels")->capture_default_str ();
  app.add_option ("--height", o.height, "window and screenshot height in pixels")->capture_default_str ();
  CLI11_PARSE (app, argc, argv);
  if (o.growth_prefix.empty ())
  {
    o.growth_prefix = o.screenshot.empty () ? "omicron_growth" : o.screenshot;
    if (o.growth_prefix.size () > 4 && o.growth_prefix.compare (o.growth_prefix.size () - 4, 4, ".png") == 0)
      o.growth_prefix.resize (o.growth_prefix.size () - 4);
  }
  try
  {
    if (o.width < 16 || o.height < 16)
      throw std::invalid_argument ("--width and --height must be >= 16");
    const pclx::apps::FileCheck check = pclx::apps::checkCloudFile (o.input);
    bool color = false;
    if (check.format != pclx::apps::CloudFormat::XYZ)
      color = pcl::PointStreamReader (o.input).hasColor ();
    if (o.budget_mb > 0)
    {
      // The octree streams the file; nothing is loaded here.
      pcl::PointStreamReader reader (o.input);
      const auto summary = o.input + ": " + std::to_string (reader.getDeclaredPoints ()) + " points declared (xyz" +
                           (reader.hasColor () ? " rgb" : "") + "), streamed by the octree (memory budget " +
                           fmtMb (static_cast<std::size_t> (o.budget_mb * 1048576.0)) + ")";
      Input<pcl::PointXYZRGB> rgb;
      Input<pcl::PointXYZ> xyz;
      rgb.file = xyz.file = o.input;
      rgb.summary = xyz.summary = summary;
      rgb.color = true;
      return reader.hasColor () ? run (o, rgb) : run (o, xyz);
    }
    // Colour only when the file has it: PointXYZ halves the input and sorted-array memory.
    return color ? run (o, readInput<pcl::PointXYZRGB> (o.input, check))
                 : run (o, readInput<pcl::PointXYZ> (o.input, check));
  }
  catch (const std::exception& e)
  {
    std::cerr << "omicron_viewer: " << oneLine (e) << "\n";
    return 1;
  }
}
