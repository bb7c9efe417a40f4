#include <pclx/surface/detail/pose_convention_check.h>

#include <cmath>
#include <cstdint>
#include <unordered_set>

namespace pclx {
namespace surface {
namespace detail {

namespace {

// Enough samples to measure an overlap share to a few per cent, few enough to cost well under a
// millisecond per frame.
constexpr std::size_t kKept = 4096, kProbes = 512;
// A frame is suspect when the inverse poses make most of it (4 in 5) overlap the previous frame
// and a quarter of it more than the given poses do: noise and static cameras move both alike.
constexpr double kMinOverlap = 0.8, kMinMargin = 0.25;

std::uint64_t
voxelKey (const Eigen::Vector3d& p, double radius)
{
  auto cell = [radius] (double x) {
    return static_cast<std::uint64_t> (static_cast<std::int64_t> (std::floor (x / radius)) + (1 << 20)) & 0x1FFFFF;
  };
  return cell (p.x ()) << 42 | cell (p.y ()) << 21 | cell (p.z ());
}

std::unordered_set<std::uint64_t>
voxels (const std::vector<Eigen::Vector3f>& camera_points, const Eigen::Isometry3d& pose, double radius)
{
  std::unordered_set<std::uint64_t> set;
  set.reserve (camera_points.size ());
  for (const auto& p : camera_points)
    set.insert (voxelKey (pose * p.cast<double> (), radius));
  return set;
}

// Share of the probes whose voxel or one of its 26 neighbours holds a vertex of the set.
double
overlap (const std::unordered_set<std::uint64_t>& set, const std::vector<Eigen::Vector3f>& probes,
         const Eigen::Isometry3d& pose, double radius)
{
  if (probes.empty ())
    return 0;
  std::size_t hits = 0;
  for (const auto& p : probes)
  {
    const Eigen::Vector3d w = pose * p.cast<double> ();
    bool hit = false;
    for (int dz = -1; dz <= 1 && !hit; ++dz)
      for (int dy = -1; dy <= 1 && !hit; ++dy)
        for (int dx = -1; dx <= 1 && !hit; ++dx)
          hit = set.count (voxelKey (w + radius * Eigen::Vector3d (dx, dy, dz), radius)) > 0;
    hits += hit;
  }
  return static_cast<double> (hits) / static_cast<double> (probes.size ());
}

}  // namespace

bool
PoseConventionCheck::add (const std::vector<Eigen::Vector3f>& world_vertices, const Eigen::Matrix4d& camera_to_world,
                          double radius)
{
  Eigen::Isometry3d pose;
  pose.matrix () = camera_to_world;
  const Eigen::Isometry3d inverse = pose.inverse ();
  std::vector<Eigen::Vector3f> camera;
  const std::size_t stride = std::max<std::size_t> (1, world_vertices.size () / kKept);
  for (std::size_t i = 0; i < world_vertices.size (); i += stride)
    camera.push_back ((inverse * world_vertices[i].cast<double> ()).cast<float> ());
  bool suspect = false;
  given_ = inverse_ = 0;
  if (!previous_.empty () && !camera.empty () && radius > 0)
  {
    std::vector<Eigen::Vector3f> probes;
    const std::size_t step = std::max<std::size_t> (1, camera.size () / kProbes);
    for (std::size_t i = 0; i < camera.size (); i += step)
      probes.push_back (camera[i]);
    given_ = overlap (voxels (previous_, previous_pose_, radius), probes, pose, radius);
    inverse_ = overlap (voxels (previous_, previous_pose_.inverse (), radius), probes, inverse, radius);
    suspect = inverse_ >= kMinOverlap && inverse_ - given_ >= kMinMargin;
  }
  // Symmetric objects (a sphere seen from around it) can line up once by chance; a scan with
  // inverted poses does so frame after frame.
  streak_ = suspect ? streak_ + 1 : 0;
  previous_.swap (camera);
  previous_pose_ = pose;
  return streak_ >= 2;
}

}  // namespace detail
}  // namespace surface
}  // namespace pclx
