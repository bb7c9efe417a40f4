#pragma once
// Memory budget of pcl::ObliqueCutOctree (out-of-core build): the ledger that accounts the
// large buffers, and the chunk planner that picks the spill level and the chunks from the
// point counts per cell.
//
// The planner bounds, per cell of the count grid, what its points will cost once loaded:
//   sort phase  (2 · sizeof(PointT) + 40) · n          chunk cloud + sorted copy, or sorted +
//                                                       radix keys (2 × 16 B) + point scratch
//                                                       + codes (8 B)
//   fix phase   sizeof(PointT) · n + below + bpp · n   sorted points, the nodes and samples
//                                                       below the spill level, write buffers
//                                                       and each point's Potree level (bpp
//                                                       counts that byte)
// with `below` an upper bound from the counts alone: a node holds at most the points of its
// subtree and at most ratio · (its children's points) + (its children) (parentSampleCount
// (n) <= ratio · n + 1); under the count grid a level has at most min (n, 8^depth) nodes. The
// retained tree (levels <= spill) is bounded the same way. The spill level is the smallest
// one whose largest cell fits beside the retained tree; chunks are runs of whole cells at
// that level packed up to the chunk budget.
#include <array>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <string>
#include <vector>

namespace pclx {
namespace omicron {
namespace detail {

// Current and peak sum of the accounted buffers (one value per item; thread-safe).
class MemoryLedger
{
public:
  enum Item
  {
    kReader,            // stream reader buffers and the read block
    kCountGrid,         // counts per cell and the planner's bounds
    kScatter,           // chunk ids and the scatter copy of a read block
    kChunkInput,        // a chunk as loaded from the chunk file
    kSorted,            // a chunk's sorted points (the leaves' storage)
    kSortBuffers,       // MortonSorter keys and scratch
    kScratchTree,       // nodes and samples below the spill level (freed per chunk)
    kRetainedTree,      // nodes and samples at or above the spill level
    kWorklists,         // cut nodes in L_C
    kFront,             // front entries
    kWriteBuffers,      // Potree encode buffers in flight
    kHierarchyRecords,  // Potree node records (and hierarchy.bin assembly at close)
    kItems
  };
  void set (Item item, std::size_t bytes);
  void add (Item item, std::size_t bytes);
  void sub (Item item, std::size_t bytes);
  std::size_t current () const;
  std::size_t peak () const;
  std::size_t get (Item item) const;
  void reset ();

private:
  mutable std::mutex mutex_;
  std::array<std::size_t, kItems> value_{};
  std::size_t total_ = 0, peak_ = 0;
};

struct PlanParameters
{
  int max_depth = 7;
  int count_level = 6;         // level of the count grid (<= max_depth)
  float ratio = 0.2f;
  bool collapse = false;
  std::size_t budget = 0;      // bytes
  std::size_t point_bytes = 16;          // sizeof (PointT)
  std::size_t encoded_bytes = 13;        // Potree bytes per point, and its level of detail
  std::size_t scratch_node_bytes = 104;  // a node below the spill level: Node + 2 cut nodes
  std::size_t retained_node_bytes = 136; // a retained node: Node + 2 cut nodes + 2 front entries
  std::size_t record_bytes = 32;         // Potree record while building
  std::size_t close_record_bytes = 64;   // … and while hierarchy.bin is assembled
  std::size_t fixed_bytes = 0;           // arena block slack, tables
};

struct ChunkPlan
{
  int spill_level = -1;
  // Chunk k = the spill-level cells [cell_begin[k], cell_begin[k + 1]) (cell index without
  // the prefix bit, Morton order), holding chunk_points[k] points.
  std::vector<std::uint64_t> cell_begin;
  std::vector<std::uint64_t> chunk_points;
  std::size_t retained_bound = 0;  // retained tree at the spill level
  std::size_t chunk_bound = 0;     // largest chunk (sort or fix phase)
  std::size_t node_bound = 0;      // nodes of the whole hierarchy
  std::size_t peak_bound = 0;      // planned peak of the chunk and close phases
  std::string error;               // why no plan fits (spill_level < 0)
};

// Bytes of the counts at `level` plus the planner's work arrays.
std::size_t planGridBytes (int level);
// `counts`: points per cell of the count grid (8^count_level values, Morton order).
ChunkPlan planChunks (const std::vector<std::uint32_t>& counts, const PlanParameters& p);

}  // namespace detail
}  // namespace omicron
}  // namespace pclx
