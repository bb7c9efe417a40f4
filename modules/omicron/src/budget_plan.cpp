#include <pclx/omicron/budget_plan.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace pcl {
namespace omicron {

void
MemoryLedger::set (Item item, std::size_t bytes)
{
  std::lock_guard<std::mutex> g (mutex_);
  total_ = total_ - value_[item] + bytes;
  value_[item] = bytes;
  peak_ = std::max (peak_, total_);
}

void
MemoryLedger::add (Item item, std::size_t bytes)
{
  std::lock_guard<std::mutex> g (mutex_);
  value_[item] += bytes;
  total_ += bytes;
  peak_ = std::max (peak_, total_);
}

void
MemoryLedger::sub (Item item, std::size_t bytes)
{
  std::lock_guard<std::mutex> g (mutex_);
  bytes = std::min (bytes, value_[item]);
  value_[item] -= bytes;
  total_ -= bytes;
}

std::size_t
MemoryLedger::current () const
{
  std::lock_guard<std::mutex> g (mutex_);
  return total_;
}

std::size_t
MemoryLedger::peak () const
{
  std::lock_guard<std::mutex> g (mutex_);
  return peak_;
}

std::size_t
MemoryLedger::get (Item item) const
{
  std::lock_guard<std::mutex> g (mutex_);
  return value_[item];
}

void
MemoryLedger::reset ()
{
  std::lock_guard<std::mutex> g (mutex_);
  value_.fill (0);
  total_ = peak_ = 0;
}

std::size_t
planGridBytes (int level)
{
  const std::size_t cells = std::size_t (1) << (3 * level);
  // counts (4 B) + P and below (4 B each) at the grid level, all three for the coarser levels.
  return cells * 12 + (cells / 7 + 1) * 12;
}

namespace {

// Arena blocks hold samples with at most 1/16 slack (BlockArena gives large requests their
// own block); the bound covers it.
constexpr double kArenaSlack = 17.0 / 16.0;

std::string
mib (double bytes)
{
  char b[32];
  std::snprintf (b, sizeof (b), "%.1f MiB", bytes / 1048576.0);
  return b;
}

}  // namespace

ChunkPlan
planChunks (const std::vector<std::uint32_t>& counts, const PlanParameters& p)
{
  ChunkPlan plan;
  const int G = p.count_level, lmax = p.max_depth;
  const double pb = static_cast<double> (p.point_bytes);
  const double snb = static_cast<double> (p.scratch_node_bytes);
  const double rnb = static_cast<double> (p.retained_node_bytes);
  const double ratio = p.ratio;
  // Per level: points, bound on a node's own points (P), bound on the scratch bytes of its
  // strict descendants (below).
  std::vector<std::vector<std::uint32_t>> cnt (G + 1);
  std::vector<std::vector<float>> P (G + 1), below (G + 1);
  P[G].resize (counts.size ());
  below[G].resize (counts.size ());
  double nodes = 0;
  for (std::size_t i = 0; i < counts.size (); ++i)
  {
    const double m = counts[i];
    if (m == 0)
      continue;
    nodes += 1;
    if (G == lmax)
    {
      P[G][i] = static_cast<float> (m);
      continue;
    }
    // Levels under the grid: totals per level T_l <= min (m, ratio · T_{l+1} + N_{l+1}).
    double T = m, b = 0;
    for (int l = lmax; l > G; --l)
    {
      const double N = std::min (m, std::ldexp (1.0, 3 * (l - G)));
      b += N * snb + (l < lmax ? T * pb * kArenaSlack : 0.0);
      nodes += N;
      T = (p.collapse && l - 1 == lmax - 1) ? m : std::min (m, ratio * T + N);
    }
    P[G][i] = static_cast<float> (T);
    below[G][i] = static_cast<float> (b);
  }
  for (int l = G - 1; l >= 0; --l)
  {
    const std::size_t n = std::size_t (1) << (3 * l);
    cnt[l].assign (n, 0);
    P[l].assign (n, 0.f);
    below[l].assign (n, 0.f);
    const auto& cc = l + 1 == G ? counts : cnt[l + 1];
    for (std::size_t i = 0; i < n; ++i)
    {
      double c = 0, sp = 0, sb = 0, k = 0;
      for (std::size_t j = 8 * i; j < 8 * i + 8; ++j)
        if (cc[j] > 0)
        {
          c += cc[j];
          k += 1;
          sp += P[l + 1][j];
          sb += below[l + 1][j] + snb + (l + 1 < lmax ? P[l + 1][j] * pb * kArenaSlack : 0.0);
        }
      cnt[l][i] = static_cast<std::uint32_t> (c);
      if (c == 0)
        continue;
      nodes += 1;
      P[l][i] = static_cast<float> ((p.collapse && l == lmax - 1) ? c : std::min (c, ratio * sp + k));
      below[l][i] = static_cast<float> (sb);
    }
  }
  // float sums round: 1 % margin on the bounds.
  constexpr double kRound = 1.01;
  plan.node_bound = static_cast<std::size_t> (nodes * kRound) + 1;
  const double fixed = static_cast<double> (p.fixed_bytes) + static_cast<double> (plan.node_bound * p.record_bytes);
  const double close = static_cast<double> (plan.node_bound * (p.record_bytes + p.close_record_bytes));
  const double budget = static_cast<double> (p.budget);
  const int top = std::min (G, lmax - (p.collapse ? 2 : 1));
  double retained = 0;
  std::string why;
  for (int S = 0; S <= top; ++S)
  {
    const auto& cs = S == G ? counts : cnt[S];
    for (std::size_t i = 0; i < cs.size (); ++i)
      if (cs[i] > 0)
        retained += rnb + P[S][i] * pb * kArenaSlack;
    if (S == 0)
      continue;
    double largest = 0;
    std::size_t at = 0;
    for (std::size_t i = 0; i < cs.size (); ++i)
    {
      const double m = cs[i];
      const double cost = std::max ((2 * pb + 40) * m, pb * m + below[S][i] + static_cast<double> (p.encoded_bytes) * m);
      if (cost > largest)
      {
        largest = cost;
        at = i;
      }
    }
    largest *= kRound;
    const double r = retained * kRound;
    if (r + fixed + largest > budget || r + close > budget)
    {
      why = "at level " + std::to_string (S) + " the largest cell holds " + std::to_string (cs[at]) + " points (" +
            mib (largest) + " while loaded), beside the retained tree (" + mib (r) + "), the node records (" +
            mib (static_cast<double> (plan.node_bound * p.record_bytes)) + ", " + mib (close) +
            " while hierarchy.bin is written) and the fixed overhead (" + mib (static_cast<double> (p.fixed_bytes)) + ")";
      continue;
    }
    // Fits: pack runs of whole cells up to the chunk budget.
    const double cb = budget - r - fixed;
    plan.spill_level = S;
    plan.retained_bound = static_cast<std::size_t> (r);
    plan.cell_begin.push_back (0);
    plan.chunk_points.push_back (0);
    double a = 0, b = 0, worst = 0;
    for (std::size_t i = 0; i < cs.size (); ++i)
    {
      const double m = cs[i];
      if (m == 0)
        continue;
      const double da = (2 * pb + 40) * m * kRound;
      const double db = (pb * m + below[S][i] + static_cast<double> (p.encoded_bytes) * m) * kRound;
      if (plan.chunk_points.back () > 0 && std::max (a + da, b + db) > cb)
      {
        worst = std::max (worst, std::max (a, b));
        plan.cell_begin.push_back (i);
        plan.chunk_points.push_back (0);
        a = b = 0;
      }
      a += da;
      b += db;
      plan.chunk_points.back () += cs[i];
    }
    worst = std::max (worst, std::max (a, b));
    plan.cell_begin.push_back (cs.size ());
    plan.chunk_bound = static_cast<std::size_t> (worst);
    plan.peak_bound = static_cast<std::size_t> (std::max (r + fixed + worst, r + close));
    return plan;
  }
  plan.error = "no spill level fits the memory budget of " + mib (budget) + ": " + why +
               (top < 1 ? "max depth too small for a spill level" : "");
  return plan;
}

}  // namespace omicron
}  // namespace pcl
