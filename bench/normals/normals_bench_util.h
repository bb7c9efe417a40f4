#pragma once
// Helpers shared by bench_normals' default sweeps and its --wide protocol.
#include "bench_csv.h"

#include <pclx/normals/normal_error.h>
#include <pclx/testing/mesh_sampling.h>

#include <fstream>
#include <sstream>
#include <string>

namespace pclx {
namespace bench {

inline Metrics
errorMetrics (const pcl::NormalErrorStats& e)
{
  return {{"rms", e.rms_deg}, {"mean", e.mean_deg}, {"min", e.min_deg}, {"max", e.max_deg},
          {"below5", e.below5}, {"below10", e.below10}};
}

inline std::string
fmt (double v)
{
  std::ostringstream s;
  s << v;
  return s.str ();
}

// PCPNet: .xyz positions and .normals (unoriented truth), one point per line.
inline bool
loadPcpnet (const std::string& stem, pclx::testing::SampledCloud& s)
{
  std::ifstream xyz (stem + ".xyz"), nrm (stem + ".normals");
  if (!xyz || !nrm)
    return false;
  pcl::PointNormal p;
  while (xyz >> p.x >> p.y >> p.z && nrm >> p.normal_x >> p.normal_y >> p.normal_z)
    s.cloud.push_back (p);
  s.face.assign (s.cloud.size (), 0);
  return !s.cloud.empty ();
}

}  // namespace bench
}  // namespace pclx
