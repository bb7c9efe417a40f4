#pragma once
// pcl::MortonCode: octree node identifiers in Morton order, see the class.
#include <Eigen/Core>

#include <cmath>
#include <cstdint>
#include <ostream>

namespace pcl {

/** \brief An octree node identifier in Morton (Z) order with a leading prefix bit (da Silva
  * 2018, §2.1.2, Fig. 2.2).
  *
  * The root is 1; child c of node x is (x << 3) | c, so a node at level l has 3 l + 1
  * significant bits and the level follows from the position of the prefix bit. Depth 21 uses
  * all 64 bits (63 interleaved bits + prefix). Child index c = (x_bit << 2) | (y_bit << 1) |
  * z_bit (PCL's octree convention). Codes at one level compare in Morton order as plain
  * integers; across levels compare span ().
  *
  * \note V. da Silva, 2018, "Concomitant Hierarchy Construction and Rendering of Large Point
  * Clouds" (OMiCroN), DSc thesis, UFRJ/COPPE.
  * \ingroup omicron
  */
class MortonCode
{
public:
  /** \brief The deepest level a 64-bit code holds.
    * \return the deepest level a 64-bit code holds */
  static constexpr int kMaxDepth = 21;

  /** \brief The invalid code (0). */
  constexpr MortonCode () = default;
  /** \brief A code from its bits.
    * \param[in] bits the prefix bit followed by 3 bits per level */
  constexpr explicit MortonCode (std::uint64_t bits) : bits_ (bits) {}

  /** \brief The root's code.
    * \return MortonCode (1) */
  static constexpr MortonCode root () { return MortonCode (1); }

  /** \brief The node of a grid cell.
    * \param[in] x cell coordinate, < 2^level
    * \param[in] y cell coordinate, < 2^level
    * \param[in] z cell coordinate, < 2^level
    * \param[in] level the grid's level (2^level cells per axis)
    * \return the code of cell (x, y, z)
    */
  static MortonCode
  fromCell (std::uint32_t x, std::uint32_t y, std::uint32_t z, int level)
  {
    return MortonCode ((std::uint64_t (1) << (3 * level)) | (spread (x) << 2) | (spread (y) << 1) | spread (z));
  }

  /** \brief The node of the 2^level grid over the cube [origin, origin + edge)^3 holding p.
    * Coordinates are clamped to the grid, so points on the max faces land in the last cell
    * (the cube made from a cloud's bounds touches its points there).
    * \param[in] p the point
    * \param[in] origin the cube's min corner
    * \param[in] edge the cube's edge
    * \param[in] level the grid's level
    * \return the code of the cell
    */
  static MortonCode
  fromPoint (const Eigen::Vector3f& p, const Eigen::Vector3d& origin, double edge, int level)
  {
    const double scale = static_cast<double> (std::uint64_t (1) << level) / edge;
    return fromCell (toCell (p.x (), origin.x (), scale, level), toCell (p.y (), origin.y (), scale, level),
                     toCell (p.z (), origin.z (), scale, level), level);
  }

  /** \brief Grid coordinate along one axis.
    * \param[in] v the coordinate
    * \param[in] origin the cube's min corner along the axis
    * \param[in] scale 2^level / edge
    * \param[in] level the grid's level
    * \return the cell index, clamped to [0, 2^level - 1]
    */
  static std::uint32_t
  toCell (float v, double origin, double scale, int level)
  {
    // Clamped first, then truncated: on [0, hi] truncation is the floor, and below 0 or above
    // hi the clamp gives what the floor would clamp to (no floor emulation on baseline x86-64).
    const double c = (static_cast<double> (v) - origin) * scale;
    const double hi = static_cast<double> ((std::uint64_t (1) << level) - 1);
    return static_cast<std::uint32_t> (c < 0.0 ? 0.0 : (c > hi ? hi : c));
  }

  /** \brief The raw bits.
    * \return the prefix bit followed by 3 bits per level */
  constexpr std::uint64_t bits () const { return bits_; }
  /** \brief Whether this is a node (not the default, invalid code).
    * \return bits () != 0 */
  constexpr bool valid () const { return bits_ != 0; }

  /** \brief The node's level (0 at the root).
    * \return the level */
  int
  level () const
  {
    return (63 - __builtin_clzll (bits_)) / 3;
  }

  /** \brief The parent's code.
    * \return the parent (invalid for the root) */
  MortonCode parent () const { return MortonCode (bits_ >> 3); }
  /** \brief A child's code.
    * \param[in] c the child index, 0..7
    * \return the child */
  MortonCode child (int c) const { return MortonCode ((bits_ << 3) | static_cast<std::uint64_t> (c)); }
  /** \brief This node's index among its siblings.
    * \return (x_bit << 2) | (y_bit << 1) | z_bit */
  int childIndex () const { return static_cast<int> (bits_ & 7u); }

  /** \brief The ancestor at a level.
    * \param[in] level a level <= this node's
    * \return the ancestor (this node at its own level) */
  MortonCode
  ancestorAt (int level) const
  {
    return MortonCode (bits_ >> (3 * (this->level () - level)));
  }

  /** \brief The rightmost possible descendant in a full subtree: the code followed by 111
    * per extra level. span (max_depth) is span (x) of the thesis' §3.1; at an intermediate
    * level it is the placeholder P_{x,level} of §3.1.3.
    * \param[in] level a level >= this node's
    * \return the descendant's code
    */
  MortonCode
  span (int level) const
  {
    const int s = 3 * (level - this->level ());
    return MortonCode ((bits_ << s) | ((std::uint64_t (1) << s) - 1));
  }
  /** \brief The placeholder P_{x,level} (da Silva 2018, §3.1.3): span (level).
    * \param[in] level a level >= this node's
    * \return the placeholder's code */
  MortonCode placeholder (int level) const { return span (level); }

  /** \brief The leftmost possible descendant.
    * \param[in] level a level >= this node's
    * \return the descendant's code */
  MortonCode
  first (int level) const
  {
    return MortonCode (bits_ << (3 * (level - this->level ())));
  }

  /** \brief Whether this node is `other` or one of its ancestors.
    * \param[in] other a node
    * \return true for `other` itself and its ancestors */
  bool
  isAncestorOf (MortonCode other) const
  {
    const int d = other.level () - level ();
    return d >= 0 && (other.bits_ >> (3 * d)) == bits_;
  }

  /** \brief Grid cell of this node at its own level.
    * \param[out] x cell coordinate
    * \param[out] y cell coordinate
    * \param[out] z cell coordinate */
  void
  cell (std::uint32_t& x, std::uint32_t& y, std::uint32_t& z) const
  {
    const std::uint64_t v = bits_ ^ (std::uint64_t (1) << (3 * level ()));
    x = compact (v >> 2);
    y = compact (v >> 1);
    z = compact (v);
  }

  /** \brief Axis-aligned box of the node inside the root cube.
    * \param[in] origin the root cube's min corner
    * \param[in] edge the root cube's edge
    * \param[out] min the box's min corner
    * \param[out] max the box's max corner */
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

  /** \brief Same node.
    * \param[in] a a code
    * \param[in] b a code
    * \return a.bits () == b.bits () */
  friend constexpr bool operator== (MortonCode a, MortonCode b) { return a.bits_ == b.bits_; }
  /** \brief Different nodes.
    * \param[in] a a code
    * \param[in] b a code
    * \return a.bits () != b.bits () */
  friend constexpr bool operator!= (MortonCode a, MortonCode b) { return a.bits_ != b.bits_; }
  /** \brief Morton order; meaningful between codes of the same level.
    * \param[in] a a code
    * \param[in] b a code
    * \return a.bits () < b.bits () */
  friend constexpr bool operator< (MortonCode a, MortonCode b) { return a.bits_ < b.bits_; }
  /** \brief Morton order (see operator<).
    * \param[in] a a code
    * \param[in] b a code
    * \return a.bits () <= b.bits () */
  friend constexpr bool operator<= (MortonCode a, MortonCode b) { return a.bits_ <= b.bits_; }
  /** \brief Morton order (see operator<).
    * \param[in] a a code
    * \param[in] b a code
    * \return a.bits () > b.bits () */
  friend constexpr bool operator> (MortonCode a, MortonCode b) { return a.bits_ > b.bits_; }
  /** \brief Morton order (see operator<).
    * \param[in] a a code
    * \param[in] b a code
    * \return a.bits () >= b.bits () */
  friend constexpr bool operator>= (MortonCode a, MortonCode b) { return a.bits_ >= b.bits_; }
  /** \brief Print the bits in octal (one digit per level after the prefix).
    * \param[in] os the stream
    * \param[in] c the code
    * \return os */
  friend std::ostream& operator<< (std::ostream& os, MortonCode c) { return os << "0o" << std::oct << c.bits_ << std::dec; }

  /** \brief Spread the low 21 bits of v to every third bit (bit interleaving).
    * \param[in] v the bits
    * \return the spread bits */
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
  /** \brief The inverse of spread (): every third bit gathered into the low 21 bits.
    * \param[in] x the spread bits
    * \return the gathered bits */
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
