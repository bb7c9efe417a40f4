// MSTNormalOrientation on scenes of several objects, where one object hides another's
// surface from some of the visibility votes' directions.
#include <pclx/normals/mst_normal_orientation.h>
#include <pclx/testing/mesh_sampling.h>
#include <pclx/testing/shapes.h>

#include <gtest/gtest.h>

#include <random>

TEST (MSTOrientationScenes, ObjectsAboveABasePlatePointOutward)
{
  // make_scene's cloud: a torus around a sphere, 8 cm above a base plate. The plate hides
  // the objects' undersides from every view from below, so there only the views from above
  // reach them, and only through the gaps between the samples of the surface in front.
  using pclx::testing::TriangleMesh;
  TriangleMesh scene = pclx::testing::makeTorus (0.3f, 0.1f, 128, 48);
  scene.append (pclx::testing::makeSphere (0.12f, 4, Eigen::Vector3f (0, 0, 0.05f)));
  TriangleMesh base = pclx::testing::makeBox (Eigen::Vector3f (1.f, 1.f, 0.04f), 8);
  base.transform (Eigen::Affine3f (Eigen::Translation3f (0, 0, -0.2f)));
  scene.append (base);
  const auto s = pclx::testing::sampleUniform (scene, 200000, 1);
  const auto cloud = pclx::testing::positions (s.cloud);

  // The exact normals, half of them flipped: only the orientation is under test.
  pcl::PointCloud<pcl::Normal> n (s.cloud.size (), 1);
  std::mt19937 rng (3);
  for (std::size_t i = 0; i < n.size (); ++i)
    n[i].getNormalVector3fMap () = s.cloud[i].getNormalVector3fMap () * ((rng () & 1) ? -1.f : 1.f);
  pcl::MSTNormalOrientation<pcl::PointXYZ, pcl::Normal> mst;
  mst.setInputCloud (cloud);
  ASSERT_TRUE (mst.orient (n));
  EXPECT_EQ (mst.getNumberOfComponents (), 3u);

  std::size_t objects = 0, objects_flipped = 0, plate_flipped = 0;
  for (std::size_t i = 0; i < n.size (); ++i)
  {
    const bool flipped = n[i].getNormalVector3fMap ().dot (s.cloud[i].getNormalVector3fMap ()) < 0;
    if (s.cloud[i].z > -0.15f)
    {
      ++objects;
      objects_flipped += flipped;
    }
    else
      plate_flipped += flipped;
  }
  ASSERT_GT (objects, 60000u);
  EXPECT_EQ (objects_flipped, 0u) << "of " << objects << " points on the torus and the sphere";
  EXPECT_LT (plate_flipped, 0.001 * (n.size () - objects)) << "on the plate";
}
