#include <pclx/testing/set_scores.h>

#include <algorithm>
#include <cstddef>
#include <iterator>

namespace pclx {
namespace testing {

template <typename Index> SubsetScore
scoreSubset (const std::vector<Index>& predicted, const std::vector<bool>& truth)
{
  std::vector<bool> p (truth.size (), false);
  for (Index i : predicted)
    p[static_cast<std::size_t> (i)] = true;
  double tp = 0, fp = 0, fn = 0;
  for (std::size_t i = 0; i < truth.size (); ++i)
  {
    tp += p[i] && truth[i];
    fp += p[i] && !truth[i];
    fn += !p[i] && truth[i];
  }
  SubsetScore s;
  s.predicted = predicted.size ();
  s.precision = tp / std::max (1.0, tp + fp);
  s.recall = tp / std::max (1.0, tp + fn);
  s.f1 = 2 * s.precision * s.recall / std::max (1e-12, s.precision + s.recall);
  return s;
}

template <typename Index> double
jaccard (std::vector<Index> a, std::vector<Index> b)
{
  std::sort (a.begin (), a.end ());
  std::sort (b.begin (), b.end ());
  std::vector<Index> both, either;
  std::set_intersection (a.begin (), a.end (), b.begin (), b.end (), std::back_inserter (both));
  std::set_union (a.begin (), a.end (), b.begin (), b.end (), std::back_inserter (either));
  return either.empty () ? 1.0 : double (both.size ()) / double (either.size ());
}

template SubsetScore scoreSubset (const std::vector<int>&, const std::vector<bool>&);
template double jaccard (std::vector<int>, std::vector<int>);

}  // namespace testing
}  // namespace pclx
