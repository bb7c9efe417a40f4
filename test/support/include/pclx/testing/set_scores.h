#pragma once
// Scores of a predicted subset (e.g. visible point indices) against per-point truth.
#include <vector>

namespace pclx {
namespace testing {

struct SubsetScore
{
  double precision = 0, recall = 0, f1 = 0;
  std::size_t predicted = 0;
};

// `predicted` are indices into `truth`.
template <typename Index> SubsetScore
scoreSubset (const std::vector<Index>& predicted, const std::vector<bool>& truth);

// |a ∩ b| / |a ∪ b| of two index sets (1 when both are empty).
template <typename Index> double
jaccard (std::vector<Index> a, std::vector<Index> b);

}  // namespace testing
}  // namespace pclx
