#pragma once
#include <pcl/common/point_tests.h>
#include <pcl/point_cloud.h>

#include <Eigen/Core>
#include <cstddef>

namespace pcl {

/** \brief Orient normals towards a known capture position.
  *
  * Every normal is flipped so that ni · (vp − xi) > 0 (Musmanno 2016, §5.4.2). Invalid points
  * and non-finite normals are left untouched.
  * \param[in] cloud the points
  * \param[in,out] normals one normal per point, oriented in place
  * \param[in] viewpoint the capture position vp
  * \param[out] flipped optional: receives the number of flipped normals
  * \return false, with PCL_ERROR and the normals untouched, when the clouds differ in size
  *
  * \note R. M. Musmanno, 2016, "Estimação de Normais em Nuvens de Pontos para Reconstrução
  * de Superfícies 3D com Funções de Base Radial", MSc dissertation, UFF; and H. Hoppe,
  * T. DeRose, T. Duchamp, J. McDonald, W. Stuetzle, 1992, "Surface Reconstruction from
  * Unorganized Points", ACM SIGGRAPH.
  * \ingroup normals
  */
template <typename PointT, typename NormalT> bool
orientNormalsTowardsViewpoint (const PointCloud<PointT>& cloud, PointCloud<NormalT>& normals,
                               const Eigen::Vector3f& viewpoint, std::size_t* flipped = nullptr)
{
  if (cloud.size () != normals.size ())
  {
    PCL_ERROR ("[pcl::orientNormalsTowardsViewpoint] %zu points but %zu normals\n", cloud.size (),
               normals.size ());
    return false;
  }
  std::size_t count = 0;
  for (std::size_t i = 0; i < cloud.size (); ++i)
  {
    auto n = normals[i].getNormalVector3fMap ();
    if (!isFinite (cloud[i]) || !n.allFinite ())
      continue;
    if (n.dot (viewpoint - cloud[i].getVector3fMap ()) < 0)
    {
      n = -n;
      ++count;
    }
  }
  if (flipped)
    *flipped = count;
  return true;
}

}  // namespace pcl
