#pragma once
// The consumer's checks and scenes: what a user's own test code would hold, without pclx_testing
// (which is not installed).
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Geometry>

#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <string>

namespace consumer {

inline int&
failures ()
{
  static int n = 0;
  return n;
}

// Prints one line per check; a failed check counts towards the exit code.
inline void
check (const std::string& what, bool ok, const std::string& found)
{
  std::printf ("%s %s%s%s\n", ok ? "[ ok ]" : "[FAIL]", what.c_str (), found.empty () ? "" : ": ", found.c_str ());
  failures () += !ok;
}

inline int
summary ()
{
  std::printf (failures () ? "%d checks failed\n" : "all checks passed\n", failures ());
  return failures ();
}

inline std::string
fmt (double v)
{
  std::ostringstream s;
  s.precision (3);
  s << v;
  return s.str ();
}

// n points on a sphere of the given radius around the origin (Fibonacci lattice).
inline pcl::PointCloud<pcl::PointXYZ>::Ptr
sphere (std::size_t n, double radius = 1.0)
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud (new pcl::PointCloud<pcl::PointXYZ>);
  const double golden = M_PI * (3.0 - std::sqrt (5.0));
  for (std::size_t i = 0; i < n; ++i)
  {
    const double z = 1.0 - 2.0 * (double (i) + 0.5) / double (n), r = std::sqrt (1.0 - z * z);
    const double phi = golden * double (i);
    cloud->push_back (pcl::PointXYZ (float (radius * r * std::cos (phi)), float (radius * r * std::sin (phi)),
                                     float (radius * z)));
  }
  return cloud;
}

// Camera-to-world pose of a camera `distance` from the origin, at `angle` radians around y,
// looking at the origin (x right, y down, z forward, as depth cameras).
inline Eigen::Isometry3d
lookAtOrigin (double angle, double distance)
{
  const Eigen::Vector3d eye (distance * std::sin (angle), 0.0, -distance * std::cos (angle));
  const Eigen::Vector3d z = -eye.normalized (), y (0, 1, 0), x = y.cross (z).normalized ();
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity ();
  pose.linear ().col (0) = x;
  pose.linear ().col (1) = z.cross (x);
  pose.linear ().col (2) = z;
  pose.translation () = eye;
  return pose;
}

// An organized depth frame (camera frame, NaN background) of the sphere of `radius` around the
// world origin, seen from camera_to_world with a 60° horizontal field of view.
inline pcl::PointCloud<pcl::PointXYZ>::Ptr
sphereFrame (const Eigen::Isometry3d& camera_to_world, int width, int height, double radius = 1.0)
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr frame (new pcl::PointCloud<pcl::PointXYZ> (width, height));
  frame->is_dense = false;
  const double f = 0.5 * width / std::tan (M_PI / 6.0);
  const Eigen::Vector3d centre = camera_to_world.inverse () * Eigen::Vector3d::Zero ();
  const float nan = std::numeric_limits<float>::quiet_NaN ();
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u)
    {
      const Eigen::Vector3d ray = Eigen::Vector3d ((u + 0.5 - 0.5 * width) / f, (v + 0.5 - 0.5 * height) / f, 1.0);
      const Eigen::Vector3d d = ray.normalized ();
      const double b = d.dot (centre), c = centre.squaredNorm () - radius * radius, disc = b * b - c;
      auto& p = frame->at (u, v);
      if (disc < 0)
      {
        p.x = p.y = p.z = nan;
        continue;
      }
      p.getVector3fMap () = (d * (b - std::sqrt (disc))).cast<float> ();
    }
  return frame;
}

// Mean angle in degrees between the (unoriented) normals and a sphere's radial directions.
template <typename IndicesT> double
meanAngleDeg (const pcl::PointCloud<pcl::PointXYZ>& cloud, const IndicesT& indices,
              const pcl::PointCloud<pcl::Normal>& normals)
{
  double sum = 0;
  for (std::size_t i = 0; i < indices.size (); ++i)
  {
    const double c = std::abs (double (normals[i].getNormalVector3fMap ().dot (
        cloud[indices[i]].getVector3fMap ().normalized ())));
    sum += std::acos (std::min (1.0, c)) * 180.0 / M_PI;
  }
  return indices.empty () ? 0.0 : sum / double (indices.size ());
}

// custom_point.cpp: our classes on a point type of the user's own (PCL_NO_PRECOMPILE).
void
customPointType ();

}  // namespace consumer
