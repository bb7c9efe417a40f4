#include <pclx/omicron/detail/budget_plan.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace pclx {
namespace omicron {
namespace detail {

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

// Bounds per level of the count grid and above: points per cell (cnt; the grid level's are
// the counts themselves), a bound on a node's own points (P) and on the scratch bytes of its
// strict descendants (below), and a bound on the nodes of the whole hierarchy.
struct GridBounds
{
  std::vector<std::vector<std::uint32_t>> cnt;
  std::vector<std::vector<float>> P, below;
  double nodes = 0;
};

// The cells of the count grid, each bounding the levels under it from its count alone.
void
boundGridCells (const std::vector<std::uint32_t>& counts, const PlanParameters& p, GridBounds& g)
{
  const int G = p.count_level, lmax = p.max_depth;
  const double pb = static_cast<double> (p.point_bytes);
  const double snb = static_cast<double> (p.scratch_node_bytes);
  const double ratio = p.ratio;
  g.P[G].resize (counts.size ());
  g.below[G].resize (counts.size ());
  for (std::size_t i = 0; i < counts.size (); ++i)
  {
    const double m = counts[i];
    if (m == 0)
      continue;
    g.nodes += 1;
    if (G == lmax)
    {
      g.P[G][i] = static_cast<float> (m);
      continue;
    }
    // Levels under the grid: totals per level T_l <= min (m, ratio · T_{l+1} + N_{l+1}).
    double T = m, b = 0;
    for (int l = lmax; l > G; --l)
    {
      const double N = std::min (m, std::ldexp (1.0, 3 * (l - G)));
      b += N * snb + (l < lmax ? T * pb * kArenaSlack : 0.0);
      g.nodes += N;
      T = (p.collapse && l - 1 == lmax - 1) ? m : std::min (m, ratio * T + N);
    }
    g.P[G][i] = static_cast<float> (T);
    g.below[G][i] = static_cast<float> (b);
  }
}

// The levels above the count grid, each cell bounded from its eight children.
void
boundCoarserLevels (const std::vector<std::uint32_t>& counts, const PlanParameters& p, GridBounds& g)
{
  const int G = p.count_level, lmax = p.max_depth;
  const double pb = static_cast<double> (p.point_bytes);
  const double snb = static_cast<double> (p.scratch_node_bytes);
  const double ratio = p.ratio;
  for (int l = G - 1; l >= 0; --l)
  {
    const std::size_t n = std::size_t (1) << (3 * l);
    g.cnt[l].assign (n, 0);
    g.P[l].assign (n, 0.f);
    g.below[l].assign (n, 0.f);
    const auto& cc = l + 1 == G ? counts : g.cnt[l + 1];
    for (std::size_t i = 0; i < n; ++i)
    {
      double c = 0, sp = 0, sb = 0, k = 0;
      for (std::size_t j = 8 * i; j < 8 * i + 8; ++j)
        if (cc[j] > 0)
        {
          c += cc[j];
          k += 1;
          sp += g.P[l + 1][j];
          sb += g.below[l + 1][j] + snb + (l + 1 < lmax ? g.P[l + 1][j] * pb * kArenaSlack : 0.0);
        }
      g.cnt[l][i] = static_cast<std::uint32_t> (c);
      if (c == 0)
        continue;
      g.nodes += 1;
      g.P[l][i] = static_cast<float> ((p.collapse && l == lmax - 1) ? c : std::min (c, ratio * sp + k));
      g.below[l][i] = static_cast<float> (sb);
    }
  }
}

// Packs runs of whole cells of the spill level (counts cs, scratch bounds below) into chunks
// whose sort and fix phases each fit chunk_budget. Returns the largest chunk's bound.
double
packChunks (const std::vector<std::uint32_t>& cs, const std::vector<float>& below, const PlanParameters& p,
            double chunk_budget, double round, ChunkPlan& plan)
{
  const double pb = static_cast<double> (p.point_bytes);
  plan.cell_begin.push_back (0);
  plan.chunk_points.push_back (0);
  double a = 0, b = 0, worst = 0;
  for (std::size_t i = 0; i < cs.size (); ++i)
  {
    const double m = cs[i];
    if (m == 0)
      continue;
    const double da = (2 * pb + 40) * m * round;
    const double db = (pb * m + below[i] + static_cast<double> (p.encoded_bytes) * m) * round;
    if (plan.chunk_points.back () > 0 && std::max (a + da, b + db) > chunk_budget)
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
  return worst;
}

}  // namespace

ChunkPlan
planChunks (const std::vector<std::uint32_t>& counts, const PlanParameters& p)
{
  ChunkPlan plan;
  const int G = p.count_level, lmax = p.max_depth;
  const double pb = static_cast<double> (p.point_bytes);
  const double rnb = static_cast<double> (p.retained_node_bytes);
  GridBounds g;
  g.cnt.resize (G + 1);
  g.P.resize (G + 1);
  g.below.resize (G + 1);
  boundGridCells (counts, p, g);
  boundCoarserLevels (counts, p, g);
  // float sums round: 1 % margin on the bounds.
  constexpr double kRound = 1.01;
  plan.node_bound = static_cast<std::size_t> (g.nodes * kRound) + 1;
  const double fixed = static_cast<double> (p.fixed_bytes) + static_cast<double> (plan.node_bound * p.record_bytes);
  const double close = static_cast<double> (plan.node_bound * (p.record_bytes + p.close_record_bytes));
  const double budget = static_cast<double> (p.budget);
  const int top = std::min (G, lmax - (p.collapse ? 2 : 1));
  double retained = 0;
  std::string why;
  for (int S = 0; S <= top; ++S)
  {
    const auto& cs = S == G ? counts : g.cnt[S];
    for (std::size_t i = 0; i < cs.size (); ++i)
      if (cs[i] > 0)
        retained += rnb + g.P[S][i] * pb * kArenaSlack;
    if (S == 0)
      continue;
    double largest = 0;
    std::size_t at = 0;
    for (std::size_t i = 0; i < cs.size (); ++i)
    {
      const double m = cs[i];
      const double cost = std::max ((2 * pb + 40) * m, pb * m + g.below[S][i] + static_cast<double> (p.encoded_bytes) * m);
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
    plan.spill_level = S;
    plan.retained_bound = static_cast<std::size_t> (r);
    const double worst = packChunks (cs, g.below[S], p, budget - r - fixed, kRound, plan);
    plan.chunk_bound = static_cast<std::size_t> (worst);
    plan.peak_bound = static_cast<std::size_t> (std::max (r + fixed + worst, r + close));
    return plan;
  }
  plan.error = "no spill level fits the memory budget of " + mib (budget) + ": " + why +
               (top < 1 ? "max depth too small for a spill level" : "");
  return plan;
}

}  // namespace detail
}  // namespace omicron
}  // namespace pclx
