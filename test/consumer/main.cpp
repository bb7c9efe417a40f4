// A user project: ordinary PCL code with the pclx classes in it, built against the install.
// Each check prints its name and what it found; the exit code is the number that failed.
#include "consumer_checks.h"

#include <pclx/hpr/hpr_filter.h>
#include <pclx/normals/mst_normal_orientation.h>
#include <pclx/normals/planar_octree_normal_estimation.h>
#include <pclx/omicron/camera.h>
#include <pclx/omicron/oblique_cut_octree.h>
#include <pclx/surface/incremental_dual_contouring.h>
#include <pclx/surface/rbf_pou_reconstruction.h>

#include <pcl/common/io.h>
#include <pcl/features/normal_3d.h>
#include <pcl/filters/filter_indices.h>
#include <pcl/filters/passthrough.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iterator>
#include <thread>

using consumer::check;
using Cloud = pcl::PointCloud<pcl::PointXYZ>;

namespace {

// Visible indices of the unit sphere seen from (0, 0, 4).
pcl::Indices
visibleFromAbove (const Cloud::ConstPtr& cloud, const pcl::IndicesConstPtr& indices = nullptr)
{
  pcl::HPRFilter<pcl::PointXYZ> hpr;
  hpr.setInputCloud (cloud);
  if (indices)
    hpr.setIndices (indices);
  hpr.setViewPoint (Eigen::Vector3f (0, 0, 4));
  pcl::Indices visible;
  hpr.filter (visible);
  return visible;
}

void
filterIndicesChain ()
{
  const auto cloud = consumer::sphere (20000);
  pcl::PassThrough<pcl::PointXYZ> pass;
  pass.setInputCloud (cloud);
  pass.setFilterFieldName ("x");
  pass.setFilterLimits (0.f, 1.f);
  pcl::IndicesPtr half (new pcl::Indices);
  pass.filter (*half);

  pcl::HPRFilter<pcl::PointXYZ> hpr;
  hpr.setInputCloud (cloud);
  hpr.setIndices (half);
  hpr.setViewPoint (Eigen::Vector3f (0, 0, 4));
  pcl::Indices visible, hidden;
  hpr.filter (visible);
  hpr.setNegative (true);
  hpr.filter (hidden);
  pcl::Indices both = visible;
  both.insert (both.end (), hidden.begin (), hidden.end ());
  std::sort (both.begin (), both.end ());
  check ("PassThrough -> HPRFilter::setIndices: visible and hidden split the indices",
         both == *half && !visible.empty () && !hidden.empty (),
         std::to_string (visible.size ()) + " + " + std::to_string (hidden.size ()) + " of " +
             std::to_string (half->size ()));
}

void
basePointers ()
{
  const auto cloud = consumer::sphere (5000);
  auto make = [] {
    auto hpr = std::make_shared<pcl::HPRFilter<pcl::PointXYZ>> ();
    hpr->setViewPoint (Eigen::Vector3f (0, 0, 4));
    return hpr;
  };
  pcl::Filter<pcl::PointXYZ>::Ptr filter = make ();
  filter->setInputCloud (cloud);
  Cloud out;
  filter->filter (out);
  pcl::FilterIndices<pcl::PointXYZ>::Ptr filter_indices = make ();
  filter_indices->setInputCloud (cloud);
  pcl::Indices idx;
  filter_indices->filter (idx);
  check ("Filter::Ptr and FilterIndices::Ptr call HPRFilter", out.size () == idx.size () && !idx.empty (),
         std::to_string (out.size ()) + " points, " + std::to_string (idx.size ()) + " indices");
}

void
keepOrganized ()
{
  // A camera 3 units from the unit sphere: a frame whose background is NaN.
  const Eigen::Isometry3d pose = consumer::lookAtOrigin (0.0, 3.0);
  const auto frame = consumer::sphereFrame (pose, 80, 60, 1.0);
  pcl::HPRFilter<pcl::PointXYZ> hpr;
  hpr.setInputCloud (frame);
  hpr.setKeepOrganized (true);
  Cloud out;
  hpr.filter (out);
  std::size_t finite_in = 0, kept = 0, moved = 0;
  for (std::size_t i = 0; i < frame->size () && i < out.size (); ++i)
  {
    finite_in += pcl::isFinite ((*frame)[i]);
    if (pcl::isFinite (out[i]))
    {
      ++kept;
      moved += out[i].getVector3fMap () != (*frame)[i].getVector3fMap ();
    }
  }
  check ("setKeepOrganized on an organized frame with NaN keeps its shape and its points",
         out.width == frame->width && out.height == frame->height && moved == 0 && kept >= finite_in * 95 / 100 &&
             kept <= finite_in,
         std::to_string (out.width) + "x" + std::to_string (out.height) + ", " + std::to_string (kept) + " of " +
             std::to_string (finite_in) + " valid points visible");
}

void
featureWithSurfaceAndIndices ()
{
  const auto cloud = consumer::sphere (20000);
  pcl::IndicesPtr some (new pcl::Indices);
  for (int i = 0; i < int (cloud->size ()); i += 7)
    some->push_back (i);
  const auto sparse = consumer::sphere (3000, 0.37);
  pcl::PlanarOctreeNormalEstimation<pcl::PointXYZ, pcl::Normal> ours;
  pcl::NormalEstimation<pcl::PointXYZ, pcl::Normal> pcl_ne;
  pcl::Feature<pcl::PointXYZ, pcl::Normal>* features[] = {&ours, &pcl_ne};
  pcl::PointCloud<pcl::Normal> out[2];
  for (int f = 0; f < 2; ++f)
  {
    features[f]->setInputCloud (cloud);
    features[f]->setIndices (some);
    features[f]->setSearchSurface (cloud);
    features[f]->setKSearch (18);
    features[f]->compute (out[f]);
  }
  const double ours_deg = consumer::meanAngleDeg (*cloud, *some, out[0]);
  const double pcl_deg = consumer::meanAngleDeg (*cloud, *some, out[1]);
  check ("pcl::Feature: setSearchSurface + setIndices, as pcl::NormalEstimation",
         out[0].size () == some->size () && out[1].size () == some->size () && ours_deg <= pcl_deg + 0.5,
         "mean error " + consumer::fmt (ours_deg) + " deg, NormalEstimation " + consumer::fmt (pcl_deg) + " deg");

  // A radius alone, as PCL users set it.
  pcl::PlanarOctreeNormalEstimation<pcl::PointXYZ, pcl::Normal> by_radius;
  by_radius.setInputCloud (sparse);
  by_radius.setRadiusSearch (0.15);
  pcl::PointCloud<pcl::Normal> radius_out;
  by_radius.compute (radius_out);
  check ("PlanarOctreeNormalEstimation with setRadiusSearch alone", radius_out.size () == sparse->size (),
         std::to_string (radius_out.size ()) + " normals");

  // Invalid points: NaN normals, which PCL's NaN filters drop.
  auto holes = consumer::sphere (3000);
  (*holes)[5].x = std::numeric_limits<float>::quiet_NaN ();
  holes->is_dense = false;
  pcl::PlanarOctreeNormalEstimation<pcl::PointXYZ, pcl::Normal> nan_ne;
  nan_ne.setInputCloud (holes);
  pcl::PointCloud<pcl::Normal> nan_out;
  nan_ne.compute (nan_out);
  pcl::Indices finite;
  pcl::removeNaNNormalsFromPointCloud (nan_out, nan_out, finite);
  check ("invalid points get NaN normals (removeNaNNormalsFromPointCloud drops them)",
         nan_out.size () == holes->size () - 1, std::to_string (nan_out.size ()) + " finite normals");
}

// Points and oriented normals of the unit sphere through concatenateFields.
pcl::PointCloud<pcl::PointNormal>::Ptr
orientedSphere (std::size_t n)
{
  const auto xyz = consumer::sphere (n);
  pcl::PointCloud<pcl::Normal> normals;
  for (const auto& p : *xyz)
  {
    pcl::Normal q;
    q.getNormalVector3fMap () = p.getVector3fMap ().normalized ();
    normals.push_back (q);
  }
  pcl::PointCloud<pcl::PointNormal>::Ptr out (new pcl::PointCloud<pcl::PointNormal>);
  pcl::concatenateFields (*xyz, normals, *out);
  return out;
}

void
surfaceBaseAndPly ()
{
  const auto cloud = orientedSphere (20000);
  check ("concatenateFields: points + normals", cloud->size () == 20000 && (*cloud)[3].normal_z == (*cloud)[3].z,
         std::to_string (cloud->size ()) + " PointNormal");
  pcl::SurfaceReconstruction<pcl::PointNormal>::Ptr surface (new pcl::RBFPOUReconstruction<pcl::PointNormal>);
  surface->setInputCloud (cloud);
  pcl::PolygonMesh mesh;
  surface->reconstruct (mesh);
  Cloud vertices;
  pcl::fromPCLPointCloud2 (mesh.cloud, vertices);
  double worst = 0;
  for (const auto& v : vertices)
    worst = std::max (worst, std::abs (double (v.getVector3fMap ().norm ()) - 1.0));
  check ("SurfaceReconstruction::Ptr -> reconstruct (): a sphere", !mesh.polygons.empty () && worst < 0.01,
         std::to_string (mesh.polygons.size ()) + " triangles, farthest vertex " + consumer::fmt (worst) + " off");

  const auto path = (std::filesystem::temp_directory_path () / "pclx_consumer_sphere.ply").string ();
  pcl::io::savePLYFileBinary (path, mesh);
  pcl::PolygonMesh back;
  pcl::io::loadPLYFile (path, back);
  std::filesystem::remove (path);
  check ("PLY save / load round trip", back.polygons.size () == mesh.polygons.size () &&
                                           back.cloud.width * back.cloud.height == vertices.size (),
         std::to_string (back.polygons.size ()) + " triangles back");
}

void
dualContouringFromFrames ()
{
  pcl::IncrementalDualContouring<pcl::PointXYZ> idc;
  bool added = true;
  for (double angle : {0.0, 0.6, -0.6})
  {
    // Cameras on a circle of radius 1.2 around the sphere at the origin, looking at it.
    const Eigen::Isometry3d pose = consumer::lookAtOrigin (angle, 1.2);
    added = idc.addFrame (*consumer::sphereFrame (pose, 160, 120, 0.3), pose.matrix ()) && added;
  }
  pcl::PolygonMesh mesh;
  idc.reconstruct (mesh);
  Cloud vertices;
  pcl::fromPCLPointCloud2 (mesh.cloud, vertices);
  double worst = 0;
  for (const auto& v : vertices)
    worst = std::max (worst, std::abs (double (v.getVector3fMap ().norm ()) - 0.3));
  check ("IncrementalDualContouring from organized clouds with poses",
         added && !mesh.polygons.empty () && worst < 0.01 && idc.getStats ().suspect_pose_frames == 0,
         std::to_string (mesh.polygons.size ()) + " triangles, farthest vertex " + consumer::fmt (worst) + " m off");
}

void
dualContouringFlagsInvertedPoses ()
{
  // Eight frames on a slow arc whose poses are given as world-to-camera by mistake.
  pcl::IncrementalDualContouring<pcl::PointXYZ> idc;
  bool added = true;
  for (int k = 0; k < 8; ++k)
  {
    const Eigen::Isometry3d pose = consumer::lookAtOrigin (0.0873 * k, 1.2);
    added = idc.addFrame (*consumer::sphereFrame (pose, 160, 120, 0.3), pose.inverse ().matrix ()) && added;
  }
  check ("IncrementalDualContouring flags world-to-camera poses", added && idc.getStats ().suspect_pose_frames > 0,
         std::to_string (idc.getStats ().suspect_pose_frames) + " of 8 frames flagged");
}

void
obliqueCutFront ()
{
  const auto cloud = consumer::sphere (50000);
  pcl::ObliqueCutOctree<pcl::PointXYZ> octree;
  octree.setInputCloud (cloud);
  octree.setMaxDepth (6);
  const bool built = octree.build ();
  pcl::ObliqueCutOctree<pcl::PointXYZ>::Camera camera;
  camera.view_projection = pcl::perspectiveLookAt (Eigen::Vector3f (0, 0, 4), Eigen::Vector3f::Zero (),
                                                            float (M_PI) / 3.f, 640.f / 480.f, 0.1f, 100.f);
  camera.width = 640;
  camera.height = 480;
  std::vector<pcl::ObliqueCutOctree<pcl::PointXYZ>::Item> items;
  octree.evaluate (camera, items);
  std::size_t drawn = 0;
  for (const auto& item : items)
    drawn += item.num_points;
  check ("ObliqueCutOctree from a cloud in memory, a front for a camera",
         built && !items.empty () && drawn > 0 && drawn <= cloud->size (),
         std::to_string (items.size ()) + " nodes, " + std::to_string (drawn) + " points to draw");
}

void
reuseAndThreads ()
{
  const auto big = consumer::sphere (20000), small = consumer::sphere (3000, 0.5);
  pcl::HPRFilter<pcl::PointXYZ> hpr;
  hpr.setViewPoint (Eigen::Vector3f (0, 0, 4));
  pcl::Indices first, second, again;
  hpr.setInputCloud (big);
  hpr.filter (first);
  hpr.setInputCloud (small);
  hpr.filter (second);
  hpr.setInputCloud (big);
  hpr.filter (again);
  check ("one HPRFilter reused across clouds of different sizes",
         first == again && second == visibleFromAbove (small) && first == visibleFromAbove (big),
         std::to_string (first.size ()) + " / " + std::to_string (second.size ()) + " visible");

  pcl::Indices a, b;
  std::thread ta ([&] { a = visibleFromAbove (big); });
  std::thread tb ([&] { b = visibleFromAbove (small); });
  ta.join ();
  tb.join ();
  check ("two filters in two std::threads give the single-thread answer", a == first && b == second, "");
}

// HPRFilter::filter on every XYZ point type the library instantiates.
template <typename PointT> std::size_t
visibleCount (const Cloud& xyz)
{
  typename pcl::PointCloud<PointT>::Ptr cloud (new pcl::PointCloud<PointT>);
  pcl::copyPointCloud (xyz, *cloud);
  pcl::HPRFilter<PointT> hpr;
  hpr.setInputCloud (cloud);
  hpr.setViewPoint (Eigen::Vector3f (0, 0, 4));
  pcl::Indices visible;
  hpr.filter (visible);
  return visible.size ();
}

void
pointTypes ()
{
  const auto cloud = consumer::sphere (4000);
  const std::size_t n[] = {visibleCount<pcl::PointXYZ> (*cloud), visibleCount<pcl::PointXYZI> (*cloud),
                           visibleCount<pcl::PointXYZRGB> (*cloud), visibleCount<pcl::PointXYZRGBA> (*cloud),
                           visibleCount<pcl::PointNormal> (*cloud), visibleCount<pcl::PointXYZRGBNormal> (*cloud)};
  check ("HPRFilter on six point types: one answer", std::all_of (std::begin (n), std::end (n),
                                                                  [&] (std::size_t v) { return v == n[0]; }),
         std::to_string (n[0]) + " visible");
}

void
givenRadiusAboveTheExactLimit ()
{
  const auto cloud = consumer::sphere (30000);
  pcl::HPRFilter<pcl::PointXYZ> hpr;
  hpr.setInputCloud (cloud);
  hpr.setViewPoint (Eigen::Vector3f (0, 0, 4));
  hpr.setRadius (500.0);
  pcl::Indices visible;
  hpr.filter (visible);
  std::size_t far_side = 0;
  for (const int i : visible)
    far_side += (*cloud)[i].z < -0.1f;
  check ("HPRFilter::setRadius is honoured above 20k points", far_side == 0 && visible.size () < cloud->size () / 2,
         std::to_string (visible.size ()) + " visible, " + std::to_string (far_side) + " on the far side");
}

}  // namespace

int
main ()
{
  filterIndicesChain ();
  basePointers ();
  keepOrganized ();
  featureWithSurfaceAndIndices ();
  surfaceBaseAndPly ();
  dualContouringFromFrames ();
  dualContouringFlagsInvertedPoses ();
  obliqueCutFront ();
  reuseAndThreads ();
  pointTypes ();
  givenRadiusAboveTheExactLimit ();
  consumer::customPointType ();
  return consumer::summary ();
}
