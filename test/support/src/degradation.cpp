#include <pclx/testing/degradation.h>

#include <pcl/common/common.h>
#include <pcl/kdtree/kdtree_flann.h>

#include <random>
#include <stdexcept>

namespace pclx {
namespace testing {

void
addGaussianNoise (SampledCloud& s, float sigma_fraction, std::uint32_t seed)
{
  if (sigma_fraction < 0.f)
    throw std::invalid_argument ("addGaussianNoise: sigma_fraction must be >= 0");
  if (s.cloud.empty () || sigma_fraction == 0.f)
    return;
  Eigen::Vector4f mn, mx;
  pcl::getMinMax3D (s.cloud, mn, mx);
  std::mt19937 rng (seed);
  std::normal_distribution<float> N (0.f, sigma_fraction * (mx - mn).head<3> ().norm ());
  for (auto& p : s.cloud)
  {
    p.x += N (rng);
    p.y += N (rng);
    p.z += N (rng);
  }
}

void
keepPoints (SampledCloud& s, const std::vector<int>& indices)
{
  SampledCloud out;
  out.cloud.reserve (indices.size ());
  out.face.reserve (indices.size ());
  for (int i : indices)
  {
    out.cloud.push_back (s.cloud[i]);
    out.face.push_back (s.face[i]);
  }
  s = std::move (out);
}

std::size_t
applyShadowHoles (SampledCloud& s, float fraction, std::uint32_t seed, float hole_fraction)
{
  if (!(fraction >= 0.f && fraction <= 1.f) || !(hole_fraction > 0.f))
    throw std::invalid_argument ("applyShadowHoles: fraction must be in [0,1], hole_fraction > 0");
  const std::size_t n = s.cloud.size ();
  const std::size_t target = static_cast<std::size_t> (std::lround (fraction * n));
  if (target == 0)
    return 0;
  const std::size_t hole_size = std::max<std::size_t> (1, static_cast<std::size_t> (hole_fraction * n));

  pcl::KdTreeFLANN<pcl::PointNormal> tree;
  tree.setInputCloud (s.cloud.makeShared ());
  std::vector<char> removed (n, 0);
  std::size_t count = 0;
  std::mt19937 rng (seed);
  std::uniform_int_distribution<std::size_t> pick (0, n - 1);
  std::vector<int> nn;
  std::vector<float> d2;
  while (count < target)
  {
    std::size_t c = pick (rng);
    if (removed[c])
      continue;
    // A hole is the ball of the nearest not-yet-removed samples around a random centre.
    const std::size_t want = std::min (hole_size, target - count);
    std::size_t k = want;
    for (;;)
    {
      tree.nearestKSearch (s.cloud[c], static_cast<int> (std::min (k, n)), nn, d2);
      std::size_t fresh = 0;
      for (int i : nn)
        fresh += !removed[i];
      if (fresh >= want || k >= n)
        break;
      k = std::min (n, k * 2);
    }
    std::size_t taken = 0;
    for (int i : nn)
    {
      if (taken == want)
        break;
      if (!removed[i])
      {
        removed[i] = 1;
        ++taken;
      }
    }
    count += taken;
  }
  std::vector<int> keep;
  keep.reserve (n - count);
  for (std::size_t i = 0; i < n; ++i)
    if (!removed[i])
      keep.push_back (static_cast<int> (i));
  keepPoints (s, keep);
  return count;
}

}  // namespace testing
}  // namespace pclx
