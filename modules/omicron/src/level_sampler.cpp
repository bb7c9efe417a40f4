#include <pclx/omicron/detail/level_sampler.h>

#include <algorithm>
#include <array>

namespace pclx {
namespace omicron {
namespace detail {

using pcl::MortonCode;

namespace {

// MortonCode::spread () of every 4-bit value: a bitmap level has at most 4 bits per axis.
constexpr std::array<std::uint16_t, 16> kSpread4 = {0x000, 0x001, 0x008, 0x009, 0x040, 0x041, 0x048, 0x049,
                                                    0x200, 0x201, 0x208, 0x209, 0x240, 0x241, 0x248, 0x249};

}  // namespace

LevelSampler::LevelSampler (const Eigen::Vector3d& origin, double edge)
  : origin_ (origin), scale_ (static_cast<double> (std::uint64_t (1) << MortonCode::kMaxDepth) / edge),
    shift_ (MortonCode::kMaxDepth + 1), word_ (MortonCode::kMaxDepth + 1, -1), axis_bits_ (MortonCode::kMaxDepth + 1, 0),
    index_shift_ (MortonCode::kMaxDepth + 1, 0), taken_ (MortonCode::kMaxDepth + 1)
{
  for (int l = 0; l <= MortonCode::kMaxDepth; ++l)
    shift_[l] = MortonCode::kMaxDepth - std::min (l + kSampleGridDepth, MortonCode::kMaxDepth);
  reset (0);
}

void
LevelSampler::reset (int unit_depth)
{
  std::fill (words_.begin (), words_.end (), 0);
  for (int l = 0; l < used_levels_; ++l)
    if (word_[l] < 0)
      taken_[l].clear ();
  used_levels_ = 0;
  // Levels with few cells in the unit (coarse to fine) get a bitmap, indexed by the Morton
  // index of the cell within the unit: a prefix of the finest such level's index.
  std::size_t words = 0;
  finest_ = -1;
  for (int l = 0; l <= MortonCode::kMaxDepth; ++l)
  {
    const int depth = std::min (l + kSampleGridDepth, MortonCode::kMaxDepth);
    const int bits = std::max (0, depth - unit_depth);  // per axis
    word_[l] = -1;
    if (3 * bits <= kBitmapBits)
    {
      axis_bits_[l] = bits;
      word_[l] = static_cast<std::ptrdiff_t> (words);
      words += std::max<std::size_t> (1, (std::size_t (1) << (3 * bits)) / 64);
      finest_ = l;
    }
  }
  for (int l = 0; l <= finest_; ++l)
    index_shift_[l] = 3 * (axis_bits_[finest_] - axis_bits_[l]);
  words_.resize (words);
}

std::uint8_t
LevelSampler::take (const Eigen::Vector3f& p, int cap)
{
  constexpr int kDeepest = MortonCode::kMaxDepth;
  const std::uint64_t x = MortonCode::toCell (p.x (), origin_.x (), scale_, kDeepest),
                      y = MortonCode::toCell (p.y (), origin_.y (), scale_, kDeepest),
                      z = MortonCode::toCell (p.z (), origin_.z (), scale_, kDeepest);
  static_assert (kBitmapBits <= 3 * 4, "kSpread4 spreads 4 bits per axis");
  std::uint64_t index = 0;  // the cell's Morton index within the unit at the finest bitmap level
  if (finest_ >= 0)
  {
    const int s = shift_[finest_];
    const std::uint64_t m = (std::uint64_t (1) << axis_bits_[finest_]) - 1;
    index = (std::uint64_t (kSpread4[(x >> s) & m]) << 2) | (std::uint64_t (kSpread4[(y >> s) & m]) << 1) |
            kSpread4[(z >> s) & m];
  }
  const auto key = [&] (int l) {
    const int s = shift_[l];
    return ((x >> s) << 42) | ((y >> s) << 21) | (z >> s) | (std::uint64_t (1) << 63);  // never 0
  };
  const auto taken = [&] (int l) {
    if (word_[l] < 0)
      return taken_[l].contains (key (l));
    const std::uint64_t i = index >> index_shift_[l];
    return ((words_[static_cast<std::size_t> (word_[l]) + (i >> 6)] >> (i & 63)) & 1) != 0;
  };
  cap = std::min (cap, kDeepest + 1);
  if (cap <= 0)
    return kNoSampleLevel;
  used_levels_ = std::max (used_levels_, cap);
  // The taken cells along a point's levels are a prefix (whoever took a cell found every
  // coarser cell around it taken): when the finest is taken, so are all.
  if (taken (cap - 1))
    return kNoSampleLevel;
  int l = 0;
  while (l < cap - 1 && taken (l))
    ++l;
  if (word_[l] < 0)
    taken_[l].insert (key (l));
  else
  {
    const std::uint64_t i = index >> index_shift_[l];
    words_[static_cast<std::size_t> (word_[l]) + (i >> 6)] |= std::uint64_t (1) << (i & 63);
  }
  return static_cast<std::uint8_t> (l);
}

bool
LevelSampler::CellSet::contains (std::uint64_t key) const
{
  if (slots_.empty ())
    return false;
  const std::size_t mask = slots_.size () - 1;
  for (std::size_t i = static_cast<std::size_t> ((key * 0x9E3779B97F4A7C15ULL) >> (64 - bits_)); slots_[i] != 0;
       i = (i + 1) & mask)
    if (slots_[i] == key)
      return true;
  return false;
}

bool
LevelSampler::CellSet::insert (std::uint64_t key)
{
  if (2 * (used_.size () + 1) > slots_.size ())
    grow ();
  const std::size_t mask = slots_.size () - 1;
  std::size_t i = static_cast<std::size_t> ((key * 0x9E3779B97F4A7C15ULL) >> (64 - bits_));
  while (slots_[i] != 0)
  {
    if (slots_[i] == key)
      return false;
    i = (i + 1) & mask;
  }
  slots_[i] = key;
  used_.push_back (static_cast<std::uint32_t> (i));
  return true;
}

void
LevelSampler::CellSet::clear ()
{
  for (std::uint32_t i : used_)
    slots_[i] = 0;
  used_.clear ();
}

void
LevelSampler::CellSet::grow ()
{
  std::vector<std::uint64_t> old;
  old.swap (slots_);
  bits_ = std::max (bits_ + 1, 6);
  slots_.assign (std::size_t (1) << bits_, 0);
  used_.clear ();
  for (std::uint64_t key : old)
    if (key != 0)
      insert (key);
}

}  // namespace detail
}  // namespace omicron
}  // namespace pclx
