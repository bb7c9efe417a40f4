// Our classes on a point type of the user's own: PCL_NO_PRECOMPILE makes each header include its
// implementation, as PCL's own headers do.
#define PCL_NO_PRECOMPILE
#include "consumer_checks.h"

#include <pclx/hpr/hpr_filter.h>
#include <pclx/omicron/oblique_cut_octree.h>
#include <pclx/surface/rbf_pou_reconstruction.h>

#include <pcl/point_types.h>
#include <pcl/register_point_struct.h>

// A scanner's point: position, normal and intensity, no curvature field.
struct EIGEN_ALIGN16 ScanPoint
{
  PCL_ADD_POINT4D;
  PCL_ADD_NORMAL4D;
  float intensity;
  PCL_MAKE_ALIGNED_OPERATOR_NEW
};
POINT_CLOUD_REGISTER_POINT_STRUCT (ScanPoint, (float, x, x) (float, y, y) (float, z, z) (float, normal_x, normal_x) (
                                                  float, normal_y, normal_y) (float, normal_z, normal_z) (float, intensity,
                                                                                                          intensity))

namespace consumer {

void
customPointType ()
{
  pcl::PointCloud<ScanPoint>::Ptr cloud (new pcl::PointCloud<ScanPoint>);
  const auto xyz = sphere (20000);
  for (const auto& p : *xyz)
  {
    ScanPoint q;
    q.getVector3fMap () = p.getVector3fMap ();
    q.getNormalVector3fMap () = p.getVector3fMap ().normalized ();
    q.intensity = 0.5f + 0.5f * p.z;
    cloud->push_back (q);
  }

  pcl::HPRFilter<ScanPoint> hpr;
  hpr.setInputCloud (cloud);
  hpr.setViewPoint (Eigen::Vector3f (0, 0, 4));
  pcl::PointCloud<ScanPoint> visible;
  hpr.filter (visible);
  bool near_side = !visible.empty ();
  for (const auto& p : visible)
    near_side = near_side && p.z > 0.f && p.intensity == 0.5f + 0.5f * p.z;
  check ("custom point type: HPRFilter keeps the near side with its fields", near_side,
         std::to_string (visible.size ()) + " visible");

  pcl::RBFPOUReconstruction<ScanPoint> rbf;
  rbf.setInputCloud (cloud);
  pcl::PointCloud<ScanPoint> vertices;
  std::vector<pcl::Vertices> triangles;
  rbf.reconstruct (vertices, triangles);
  double worst = 0, intensity_off = 0;
  for (const auto& v : vertices)
  {
    worst = std::max (worst, std::abs (double (v.getVector3fMap ().norm ()) - 1.0));
    intensity_off = std::max (intensity_off, std::abs (double (v.intensity) - (0.5 + 0.5 * v.z)));
  }
  check ("custom point type without curvature: RBFPOUReconstruction, fields from the nearest point",
         !triangles.empty () && worst < 0.01 && intensity_off < 0.03,
         std::to_string (triangles.size ()) + " triangles, farthest vertex " + fmt (worst) + " off");

  pcl::ObliqueCutOctree<ScanPoint> octree;
  octree.setInputCloud (cloud);
  octree.setMaxDepth (5);
  const bool built = octree.build ();
  const auto stats = octree.getStatistics ();
  check ("custom point type: ObliqueCutOctree builds", built && stats.kept_points == cloud->size (),
         std::to_string (stats.kept_points) + " points in the hierarchy");
}

}  // namespace consumer
