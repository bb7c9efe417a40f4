#pragma once
// Per-point scale selection for kNN PCA normals (not in Musmanno 2016): a ladder of
// supports (12, 18, 30, 50, 100, 200, ... nearest neighbours) read as prefixes of one
// sorted neighbour list, and Lepski's rule: take the largest support whose normal agrees
// with every smaller one within τ standard errors of their difference. The standard error
// of a PCA normal comes from the eigenvector perturbation formula (Anderson 1963) with the
// noise variance of the whole cloud (sampleNoise), not the support's own λ3: a small
// support under heavy noise has λ2 ≈ noise, its normal is meaningless and it constrains
// nothing. Nested prefixes share their errors, so the difference of two rungs' normals has
// variance err_small² − err_large² (much tighter than the sum of the errors, which
// over-smoothed where the bias grows slowly).
#include <Eigen/Core>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace pclx {
namespace normals {
namespace detail {

struct NoiseEstimate
{
  double sigma = 0;    // noise along the normal (robust, median over samples)
  double spacing = 0;  // typical point spacing (median √(π d50² / 50))
  int samples = 0;
  // Noise that matters next to the sampling: above about 0.15 spacing, small quadric
  // patches are worse than a PCA plane over a larger support (docs/normals.md).
  double ratio () const { return spacing > 0 ? sigma / spacing : 0; }
};

// Noise of one sample from its neighbours sorted by distance (the point first, >= 50 of
// them): robust RMS residual (corrected for 6 unknowns) of a quadric height field over the
// first 24, 50, 100 or 200 neighbours, the smallest support whose plane is well defined
// (λ2 > 9 residual²): small supports keep shape out of the estimate on clean data, large
// ones are needed once the noise is as wide as a small support. A second sheet in the
// support (a thin plate a few spacings thick) is left out by a least-trimmed-squares start
// (Rousseeuw and Van Driessen 2006) rather than read as noise. Returns false when the
// neighbours span no plane. spacing2: π d50² / 50.
bool sampleNoise (const std::vector<Eigen::Vector3f>& sorted, double& residual2, double& spacing2);

// Median of the samples' values (the estimate of the whole cloud).
NoiseEstimate combineNoiseSamples (std::vector<double> residual2, std::vector<double> spacing2);

// The noise of a cloud of n points from about `samples` of them, evenly spread:
// neighbours (i, sorted, scratch) fills point i's neighbour positions sorted by distance
// (the point first; sampleNoise skips fewer than 50), scratch being one Scratch per thread.
// The estimator and the MST orientation share it.
template <typename Scratch, typename Neighbours>
NoiseEstimate
estimateCloudNoise (std::size_t n, std::size_t samples, int threads, Neighbours&& neighbours)
{
  const std::size_t step = std::max<std::size_t> (1, n / samples), count = (n + step - 1) / step;
  std::vector<double> residual2 (count, -1.0), spacing2 (count, -1.0);
#pragma omp parallel num_threads(threads)
  {
    Scratch scratch;
    std::vector<Eigen::Vector3f> sorted;
#pragma omp for schedule(dynamic, 8)
    for (std::ptrdiff_t s = 0; s < static_cast<std::ptrdiff_t> (count); ++s)
    {
      sorted.clear ();
      neighbours (static_cast<std::size_t> (s) * step, sorted, scratch);
      double r2 = 0, sp2 = 0;
      if (sampleNoise (sorted, r2, sp2))
      {
        residual2[s] = r2;
        spacing2[s] = sp2;
      }
    }
  }
  residual2.erase (std::remove (residual2.begin (), residual2.end (), -1.0), residual2.end ());
  spacing2.erase (std::remove (spacing2.begin (), spacing2.end (), -1.0), spacing2.end ());
  return combineNoiseSamples (residual2, spacing2);
}

// Support sizes of the ladder: 12, 18, 30, 50, 100, 200, 400, ... from min(first, 12) up
// to max_k (max_k itself is the last rung).
std::vector<int> ladderRungs (int first, int max_k);

struct ScaleChoice
{
  Eigen::Vector3f normal = Eigen::Vector3f::UnitZ ();
  float curvature = 0;
  int support = 0;  // neighbours of the chosen rung
  bool ok = false;  // false: no rung spans a plane
  bool exhausted = false;  // growth ran out of rungs or points (was not refused)
};

// Lepski's rule over the rungs for the point x, whose neighbours (positions) are sorted
// by distance from x: the largest rung that agrees with every smaller rung whose error is
// below 0.2 rad (noisier rungs say nothing about bias). Growth also stops
// - at a one-sided rung (centroid off x by > 0.3 of its radius plus 3 noise sigmas in the
//   plane: a rim or a border, where more points bring another sheet);
// - where detail comes in: the residual variance of a quadric height field (in the frame of
//   the largest rung) grows from one rung of >= 30 points to the next by more than 2 of its
//   relative sampling errors √(2/dof). A quadric takes the curvature, which does not bias
//   a support centred on x (a plane's residual stopped a noisy sphere at 50 points).
// tau: agreement in standard errors of the difference (2.5).
ScaleChoice selectScale (const Eigen::Vector3f& x, const std::vector<Eigen::Vector3f>& sorted,
                         const std::vector<int>& rungs, double noise2, double tau);

// selectScale's rules for one step of the ladder, for a point x whose k nearest
// neighbours are the slots (distanceSlotKey) of the first k keys in positions (any order):
// out = their plane (out.ok false: none); returns whether the rule keeps it over the k1
// nearest (k1 < k): false when it is one-sided, disagrees with the smaller one (when that
// is well defined) or its quadric residual grows past the smaller one's (when that is
// readable). The smaller rung is fitted only when its error, predicted from the larger
// one's spread, is below twice the comparison limit; then the first k keys are reordered
// (the k1 nearest first). Where the estimator shares the ladder's choice over a cell
// (noise wider than a spacing), each member checks the shared rung this way on its own
// neighbours and climbs its own ladder when refused.
bool keepsLargerRung (const Eigen::Vector3f& x, std::uint64_t* keys, const std::vector<Eigen::Vector3f>& positions,
                      int k1, int k, double noise2, double tau, ScaleChoice& out);

// Sums over the positions of the first count keys' slots (distanceSlotKey), shifted by x
// (close to all of them, so the sums keep their digits): s[0..2] = Σ d, s[3..8] = Σ dx², dx dy,
// dx dz, dy², dy dz, dz² (d = p − x). Adds to s; returns the largest |d|².
double shiftedSums (const Eigen::Vector3f& x, const std::uint64_t* keys, int count,
                    const std::vector<Eigen::Vector3f>& positions, double* s);

}  // namespace detail
}  // namespace normals
}  // namespace pclx
