/// \file
/// Broad phases on axis-aligned boxes, by dense integer slot.
///
/// HashGrid (used by the world model): a uniform spatial hash grid with incremental updates;
/// each query costs O(1) per moved box in a scene of even density, whatever n. (It replaced a
/// one-axis sweep and prune, whose cost grows ~n^(5/3) in scenes spread in 3D: docs/benchmarks.md.)
///
/// Works on slots (dense integer body indices); boxes are in the fixed frame, metres.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "collision_monitor/core/math.h"

namespace collision_monitor {
namespace world {

/// Uniform hash grid (Teschner et al. 2003, "Optimized spatial hashing") over boxes inflated by
/// half the margin: a box is entered in every cell its inflated box touches, and a pair is
/// reported once, from its reference cell (the cell of the minimum corner of the intersection of
/// the two inflated boxes, which both of them touch). Incremental: set() re-enters a box only
/// when the range of cells it touches changed; boxes that would touch more than kMaxCells cells
/// (a floor, a huge body) are kept in a short "large" list tested against every query instead.
///
/// The cell size is chosen at rebuild() from the median inflated box (kCellFactor times its
/// largest side); rebuild() runs by itself in prepare() when the number of boxes grew or shrank
/// by 2x since the last choice. Reports exactly the pairs whose boxes are at most `margin` apart
/// on every axis, a superset of those within Euclidean distance `margin`.
class HashGrid {
 public:
  static constexpr int kMaxCells = 64;
  static constexpr double kCellFactor = 2.0;

  /// Pairs whose boxes are at most `margin` (m) apart on every axis are reported. Changing it
  /// re-enters every box at the next prepare().
  void setMargin(double margin);
  double margin() const { return margin_; }

  /// Enters or updates the box of `slot` (fixed frame, m). Boxes with non-finite coordinates
  /// go to the large list (they are compared box against box, which stays correct).
  void set(int slot, const core::Aabb& box);
  /// Takes `slot` out; no-op when absent.
  void remove(int slot);
  bool contains(int slot) const {
    return static_cast<std::size_t>(slot) < entries_.size() && entries_[slot].present;
  }
  /// Number of boxes held.
  std::size_t size() const { return members_.size(); }
  /// Boxes in the large list.
  std::size_t numLarge() const { return large_.size(); }
  /// Current cell size, m (0 before the first prepare()).
  double cellSize() const { return cell_; }

  /// Call after the set()/remove() calls of a cycle and before the queries: (re)builds the grid
  /// when needed (first call, margin changed, size changed by 2x).
  void prepare();
  /// Re-chooses the cell size and re-enters every box.
  void rebuild();

  /// Calls visit(slot_i, slot_j) once for each unordered pair of held boxes at most `margin`
  /// apart on every axis with at least one slot in `moved` (whose flags by slot, `is_moved`, must
  /// be set exactly for the slots of `moved`; slots beyond its end count as not moved). Cost
  /// O(sum over moved boxes of the boxes in the cells they touch + large list).
  template <class Visit>
  void forEachPairWith(const std::vector<int>& moved, const std::vector<char>& is_moved,
                       Visit&& visit) const {
    const auto flagged = [&](int slot) {
      return static_cast<std::size_t>(slot) < is_moved.size() && is_moved[slot] != 0;
    };
    for (int m : moved) {
      if (!contains(m)) continue;
      queryOne(m, flagged, visit);
    }
  }

  /// Calls visit(slot_i, slot_j) once for every pair of held boxes at most `margin` apart.
  template <class Visit>
  void forEachPair(Visit&& visit) const {
    const auto all = [](int) { return true; };
    for (int m : members_)
      queryOne(m, all, visit);
  }

 private:
  struct Entry {
    core::Aabb raw;           ///< as given
    std::array<int, 3> lo{};  ///< cell range touched (inclusive)
    std::array<int, 3> hi{};
    bool present = false;
    bool large = false;
    bool entered = false;   ///< in the buckets (lo/hi valid)
    int member_index = -1;  ///< in members_
    int large_index = -1;   ///< in large_
  };

  static bool overlap(const core::Aabb& a, const core::Aabb& b) {
    return a.min.x() <= b.max.x() && b.min.x() <= a.max.x() && a.min.y() <= b.max.y() &&
           b.min.y() <= a.max.y() && a.min.z() <= b.max.z() && b.min.z() <= a.max.z();
  }
  std::size_t bucketOf(int x, int y, int z) const {
    const std::uint32_t h = (static_cast<std::uint32_t>(x) * 73856093u) ^
                            (static_cast<std::uint32_t>(y) * 19349663u) ^
                            (static_cast<std::uint32_t>(z) * 83492791u);
    return static_cast<std::size_t>(h) & mask_;
  }
  int cellCoord(double v) const;
  /// Cell range of `box`; false when it is too large (or not finite) for the grid.
  bool cellRange(const core::Aabb& box, std::array<int, 3>* lo, std::array<int, 3>* hi) const;
  /// Puts an entry whose box changed where it belongs (buckets or large list).
  void place(int slot);
  void enter(int slot);
  void leave(int slot);
  void addLarge(int slot);
  void dropLarge(int slot);

  /// Reports the pairs of `m` with every held box, except pairs with a flagged slot below `m`
  /// (reported from that slot's own query).
  template <class Flagged, class Visit>
  void queryOne(int m, const Flagged& flagged, Visit& visit) const {
    const Entry& em = entries_[m];
    const core::Aabb& bm = boxes_[m];
    const auto skip = [&](int o) { return o == m || (o < m && flagged(o)); };
    if (em.large) {
      for (int o : members_) {
        if (!skip(o) && overlap(bm, boxes_[o])) visit(m, o);
      }
      return;
    }
    for (int o : large_) {
      if (!skip(o) && overlap(bm, boxes_[o])) visit(m, o);
    }
    for (int z = em.lo[2]; z <= em.hi[2]; ++z) {
      for (int y = em.lo[1]; y <= em.hi[1]; ++y) {
        for (int x = em.lo[0]; x <= em.hi[0]; ++x) {
          for (const Item& it : buckets_[bucketOf(x, y, z)]) {
            // Reference cell: the larger lower cell on each axis. Both touch it when the boxes
            // overlap, so each pair is seen there and only there.
            if (std::max(em.lo[0], it.lo[0]) != x || std::max(em.lo[1], it.lo[1]) != y ||
                std::max(em.lo[2], it.lo[2]) != z) {
              continue;
            }
            const int o = it.slot;
            if (skip(o)) continue;
            if (overlap(bm, boxes_[o])) visit(m, o);
          }
        }
      }
    }
  }

  std::vector<core::Aabb> boxes_;  ///< by slot: the box inflated by half the margin
  std::vector<Entry> entries_;     ///< by slot
  std::vector<int> members_;       ///< every held slot
  std::vector<int> large_;         ///< slots not in the buckets
  /// A box in a bucket, with its lower cell (for the reference-cell test without a lookup).
  struct Item {
    int slot;
    std::array<int, 3> lo;
  };
  std::vector<std::vector<Item>> buckets_;  ///< boxes per hashed cell (each slot once)
  std::size_t mask_ = 0;
  double margin_ = 0.0;
  double half_ = 1e-12;  ///< inflation per side
  double cell_ = 0.0;
  double inv_cell_ = 0.0;
  std::size_t sized_for_ = 0;  ///< members_.size() at the last rebuild
  bool built_ = false;
  std::vector<double> scratch_;
};

}  // namespace world
}  // namespace collision_monitor
