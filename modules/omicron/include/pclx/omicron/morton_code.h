#pragma once
// pcl::MortonCode: octree node identifiers in Morton (Z) order with a leading prefix bit
// (OMiCroN §2.1.2, Fig. 2.2). The root is 1; child c of node x is (x << 3) | c, so a node at
// level l has 3·l + 1 significant bits and the level follows from the position of the prefix
// bit. Depth 21 uses all 64 bits (63 interleaved bits + prefix).
//
// Child index c = (x_bit << 2) | (y_bit << 1) | z_bit (PCL's octree convention). Codes at one
// level compare in Morton order as plain integers; across levels compare span().
#include <Eigen/Core>

#include <cmath>
#include <cstdint>
#include <ostream>

namespace pcl {

class MortonCode
{
public:
  static constexpr int kMaxDepth = 21;

  constexpr MortonCode () = default;
  constexpr explicit MortonCode (std::uint64_t bits) : bits_ (bits) {}

  static constexpr MortonCode root () { return MortonCode (1); }

  // Cell (x, y, z) of the 2^level grid; coordinates must be < 2^level.
  static MortonCode
  fromCell (std::uint32_t x, std::uint32_t y, std::uint32_t z, int level)
  {
    return MortonCode ((std::uint64_t (1) << (3 * level)) | (spread (x) << 2) | (spread (y) << 1) | spread (z));
  }

  // Cell of the 2^level grid over the cube [origin, origin + edge)^3 holding p. Coordinates
  // are clamped to the grid, so points on the max faces land in the last cell (the cube
  // made from a cloud's bounds touches its points there).
  static MortonCode
  fromPoint (const Eigen::Vector3f& p, const Eigen::Vector3d& origin, double edge, int level)
  {
    const double scale = static_cast<double> (std::uint64_t (1) << level) / edge;
    return fromCell (toCell (p.x (), origin.x (), scale, level), toCell (p.y (), origin.y (), scale, level),
                     toCell (p.z (), origin.z (), scale, level), level);
  }

  // Grid coordinate along one axis (clamped to [0, 2^level − 1]); scale = 2^level / edge.
  static std::uint32_t
  toCell (float v, double origin, double scale, int level)
  {
    const double c = std::floor ((static_cast<double> (v) - origin) * scale);
    const double hi = static_cast<double> ((std::uint64_t (1) << level) - 1);
    return static_cast<std::uint32_t> (c < 0.0 ? 0.0 : (c > hi ? hi : c));
  }

  constexpr std::uint64_t bits () const { return bits_; }
  constexpr bool valid () const { return bits_ != 0; }

  int
  level () const
  {
    return (63 - __builtin_clzll (bits_)) / 3;
  }

  MortonCode parent () const { return MortonCode (bits_ >> 3); }
  MortonCode child (int c) const { return MortonCode ((bits_ << 3) | static_cast<std::uint64_t> (c)); }
  int childIndex () const { return static_cast<int> (bits_ & 7u); }

  // Ancestor at `level` (<= this level).
  MortonCode
  ancestorAt (int level) const
  {
    return MortonCode (bits_ >> (3 * (this->level () - level)));
  }

  // Rightmost possible descendant at `level` (>= this level) in a full subtree: the code
  // followed by 111 per extra level. span (max_depth) is span(x) of §3.1; at an intermediate
  // level it is the placeholder P_{x,level} of §3.1.3.
  MortonCode
  span (int level) const
  {
    const int s = 3 * (level - this->level ());
    return MortonCode ((bits_ << s) | ((std::uint64_t (1) << s) - 1));
  }
  MortonCode placeholder (int level) const { return span (level); }

  // Leftmost possible descendant at `level`.
  MortonCode
  first (int level) const
  {
    return MortonCode (bits_ << (3 * (level - this->level ())));
  }

  // True when this node is `other` or one of its ancestors.
  bool
  isAncestorOf (MortonCode other) const
  {
    const int d = other.level () - level ();
    return d >= 0 && (other.bits_ >> (3 * d)) == bits_;
  }

  // Grid cell of this node at its own level.
  void
  cell (std::uint32_t& x, std::uint32_t& y, std::uint32_t& z) const
  {
    const std::uint64_t v = bits_ ^ (std::uint64_t (1) << (3 * level ()));
    x = compact (v >> 2);
    y = compact (v >> 1);
    z = compact (v);
  }

  // Axis-aligned box of the node inside the root cube.
  void
  box (const Eigen::Vector3d& origin, double edge, Eigen::Vector3f& min, Eigen::Vector3f& max) const
  {
    std::uint32_t x, y, z;
    cell (x, y, z);
    const double e = edge / static_cast<double> (std::uint64_t (1) << level ());
    const Eigen::Vector3d lo = origin + e * Eigen::Vector3d (x, y, z);
    min = lo.cast<float> ();
    max = (lo + Eigen::Vector3d::Constant (e)).cast<float> ();
  }

  friend constexpr bool operator== (MortonCode a, MortonCode b) { return a.bits_ == b.bits_; }
  friend constexpr bool operator!= (MortonCode a, MortonCode b) { return a.bits_ != b.bits_; }
  // Morton order; meaningful between codes of the same level.
  friend constexpr bool operator< (MortonCode a, MortonCode b) { return a.bits_ < b.bits_; }
  friend constexpr bool operator<= (MortonCode a, MortonCode b) { return a.bits_ <= b.bits_; }
  friend constexpr bool operator> (MortonCode a, MortonCode b) { return a.bits_ > b.bits_; }
  friend constexpr bool operator>= (MortonCode a, MortonCode b) { return a.bits_ >= b.bits_; }
  friend std::ostream& operator<< (std::ostream& os, MortonCode c) { return os << "0o" << std::oct << c.bits_ << std::dec; }

  // Spreads the low 21 bits of v to every third bit (magic-number bit interleaving).
  static std::uint64_t
  spread (std::uint32_t v)
  {
    std::uint64_t x = v & 0x1fffffu;
    x = (x | (x << 32)) & 0x1f00000000ffffULL;
    x = (x | (x << 16)) & 0x1f0000ff0000ffULL;
    x = (x | (x << 8)) & 0x100f00f00f00f00fULL;
    x = (x | (x << 4)) & 0x10c30c30c30c30c3ULL;
    x = (x | (x << 2)) & 0x1249249249249249ULL;
    return x;
  }
  static std::uint32_t
  compact (std::uint64_t x)
  {
    x &= 0x1249249249249249ULL;
    x = (x ^ (x >> 2)) & 0x10c30c30c30c30c3ULL;
    x = (x ^ (x >> 4)) & 0x100f00f00f00f00fULL;
    x = (x ^ (x >> 8)) & 0x1f0000ff0000ffULL;
    x = (x ^ (x >> 16)) & 0x1f00000000ffffULL;
    x = (x ^ (x >> 32)) & 0x1fffffULL;
    return static_cast<std::uint32_t> (x);
  }

private:
  std::uint64_t bits_ = 0;
};

}  // namespace pcl
