#pragma once
// detail::LevelSampler: the level of detail at which a Potree output stores each point.
#include <pclx/omicron/morton_code.h>

#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace pclx {
namespace omicron {
namespace detail {

/** \brief Depth below a node of the grid it samples: 2^7 = 128 cells per edge, the root
  * spacing edge / 128 of PotreeConverter 2. */
constexpr int kSampleGridDepth = 7;
/** \brief The level of a point that no level below the cap took. */
constexpr std::uint8_t kNoSampleLevel = 255;

/** \brief Assigns points to the levels of an additive (Potree) level of detail.
  *
  * A node at level l keeps one point per cell of its grid (the octree cells at depth
  * l + kSampleGridDepth, capped at the deepest level): the first point, in the order given,
  * whose cell no earlier point took at that level and which no coarser level took. Every
  * level's nodes then cover the cloud at their spacing, as PotreeConverter 2's indexer
  * subsamples inner nodes, and each point is stored once.
  *
  * Cells lie inside the octree cell at depth kSampleGridDepth that holds them, so the points
  * can be given unit by unit (an octree cell at that depth, or a coarser leaf), with reset ()
  * in between; the levels do not depend on it. Within a unit a level's cells are a bitmap while
  * they are few (up to 4096), else a hash set.
  */
class LevelSampler
{
public:
  /** \brief A sampler for points in a root cube.
    * \param[in] origin the cube's min corner
    * \param[in] edge the cube's edge
    */
  LevelSampler (const Eigen::Vector3d& origin, double edge);

  /** \brief Forget the taken cells: the next points are a unit that shares no cell with the
    * earlier ones.
    * \param[in] unit_depth the octree depth of the unit's cell (its points lie in one cell of it)
    */
  void reset (int unit_depth);

  /** \brief The level that takes the next point.
    * \param[in] p the point
    * \param[in] cap levels at and below it are not sampled (its node holds every point left)
    * \return the first level l < cap whose cell at p is still free, or kNoSampleLevel
    */
  std::uint8_t take (const Eigen::Vector3f& p, int cap);

private:
  // Open-addressing set of cell codes (0 is never a code), cleared through its used slots.
  class CellSet
  {
  public:
    bool insert (std::uint64_t key);
    bool contains (std::uint64_t key) const;
    void clear ();

  private:
    void grow ();
    std::vector<std::uint64_t> slots_;
    std::vector<std::uint32_t> used_;
    int bits_ = 0;
  };

  static constexpr int kBitmapBits = 12;  // cells per level within a unit kept as a bitmap: 2^12

  Eigen::Vector3d origin_;
  double scale_;         // deepest cells per unit length
  int used_levels_ = 0;  // levels touched since the last reset
  // Per level: the shift from a deepest grid coordinate to the level's; for levels with few
  // cells in the unit, the first word of the level's bitmap in words_ (else -1: the level's
  // cells go to taken_), its bits per axis, and the shift from the finest such level's index.
  std::vector<int> shift_;
  std::vector<std::ptrdiff_t> word_;
  std::vector<int> axis_bits_;
  std::vector<int> index_shift_;
  int finest_ = -1;  // the finest level with a bitmap
  std::vector<std::uint64_t> words_;
  std::vector<CellSet> taken_;                     // per level with many cells: taken cell codes
};

}  // namespace detail
}  // namespace omicron
}  // namespace pclx
