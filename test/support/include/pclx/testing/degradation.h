#pragma once
// Degradations of a sampled cloud for stability sweeps.
#include <pclx/testing/mesh_sampling.h>

namespace pclx {
namespace testing {

// Adds isotropic Gaussian noise, sigma = sigma_fraction · bounding-box diagonal,
// to the positions (normals stay the ground truth of the clean surface).
void addGaussianNoise (SampledCloud& s, float sigma_fraction, std::uint32_t seed = 1);

// The "shadow" degradation of Musmanno 2016 §6.2.1: removes `fraction` (0..1) of the
// surface samples as compact holes (k-nearest-neighbour balls around random
// centres, each hole at most `hole_fraction` of the cloud). Returns the removed
// count; exactly round(fraction · n) points are removed.
std::size_t applyShadowHoles (SampledCloud& s, float fraction, std::uint32_t seed = 1,
                              float hole_fraction = 0.01f);

// Keeps only the points whose index is listed (in order).
void keepPoints (SampledCloud& s, const std::vector<int>& indices);

}  // namespace testing
}  // namespace pclx
