/// \file
/// Broad phases on axis-aligned boxes, by dense integer slot.
///
/// HashGrid (used by the world model): a uniform spatial hash grid with incremental updates;
/// each query costs O(1) per moved box in a scene of even density, whatever n.
///
/// SweepAndPrune (kept as a reference and for scenes spread along one axis): sweep and prune ("box
/// pruning", Terdiman 2002; Baraff 1992) on the bounding boxes of the bodies, along the axis where
/// the box centres spread most.
///
/// Incremental: the sorted order of the previous update is kept, so a scene that moved little
/// is re-sorted by insertion sort in ~O(n); a changed axis or a shuffled scene falls back to
/// std::sort (O(n log n)). The sweep then costs O(n + k_axis), k_axis = number of pairs whose
/// intervals overlap on the sweep axis. No heap allocation once the vectors have grown.
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

class SweepAndPrune {
 public:
  /// Takes the boxes of `slots` (boxes are looked up as boxes[slot]) for the next sweep. Pairs
  /// whose boxes are at most `margin` (m) apart on every axis will be reported.
  void update(const std::vector<int>& slots, const std::vector<core::Aabb>& boxes, double margin);

  /// Calls visit(slot_i, slot_j) once for each unordered pair of the last update whose boxes are
  /// at most `margin` apart along every axis (a superset of the pairs within Euclidean distance
  /// `margin`, which the caller refines). Order of i and j is unspecified.
  template <class Visit>
  void forEachPair(Visit&& visit) const {
    const std::size_t n = proxies_.size();
    for (std::size_t i = 0; i < n; ++i) {
      const Proxy& p = proxies_[i];
      const core::Aabb& bi = boxes_[i];
      for (std::size_t j = i + 1; j < n && proxies_[j].lo <= p.hi; ++j) {
        const core::Aabb& bj = boxes_[j];
        if (bi.min[a1_] <= bj.max[a1_] && bj.min[a1_] <= bi.max[a1_] &&
            bi.min[a2_] <= bj.max[a2_] && bj.min[a2_] <= bi.max[a2_]) {
          visit(p.slot, proxies_[j].slot);
        }
      }
    }
  }

  /// Like forEachPair(), but only the pairs with at least one slot flagged in `moved` (indexed by
  /// slot; slots beyond its end count as not moved). Cost O(n + sum over moved boxes of the
  /// boxes near them on the sweep axis): the caller keeps the pairs between unmoved boxes from
  /// the previous cycle, so a scene where few bodies move costs ~O(n) for the re-sort plus a
  /// little per moved body.
  template <class Visit>
  void forEachPairWith(const std::vector<char>& moved, Visit&& visit) const {
    const std::size_t n = proxies_.size();
    const auto is_moved = [&](int slot) {
      return static_cast<std::size_t>(slot) < moved.size() && moved[slot] != 0;
    };
    for (std::size_t p = 0; p < n; ++p) {
      const Proxy& m = proxies_[p];
      if (!is_moved(m.slot)) continue;
      const core::Aabb& bm = boxes_[p];
      const auto others_overlap = [&](const core::Aabb& b) {
        return bm.min[a1_] <= b.max[a1_] && b.min[a1_] <= bm.max[a1_] &&
               bm.min[a2_] <= b.max[a2_] && b.min[a2_] <= bm.max[a2_];
      };
      // Forward: every box starting inside m's interval (moved or not; each pair once, from
      // the earlier of the two).
      for (std::size_t j = p + 1; j < n && proxies_[j].lo <= m.hi; ++j) {
        if (others_overlap(boxes_[j])) visit(m.slot, proxies_[j].slot);
      }
      // Backward: boxes starting before m that reach into it; a box cannot reach further than
      // the widest one. Moved ones report the pair from their own forward scan.
      for (std::size_t i = p; i-- > 0;) {
        const Proxy& q = proxies_[i];
        if (q.lo < m.lo - max_width_) break;
        if (q.hi >= m.lo && !is_moved(q.slot) && others_overlap(boxes_[i])) visit(q.slot, m.slot);
      }
    }
  }

  /// The sweep axis (0 = x, 1 = y, 2 = z).
  int axis() const { return axis_; }
  /// Number of boxes in the last update.
  std::size_t size() const { return proxies_.size(); }
  /// True when the last update had to sort from scratch (axis change, first call, big shuffle).
  bool lastUpdateResorted() const { return resorted_; }

 private:
  struct Proxy {
    double lo;  ///< inflated box min on the sweep axis
    double hi;  ///< inflated box max on the sweep axis
    int slot;
  };
  void chooseAxis(const std::vector<int>& slots, const std::vector<core::Aabb>& boxes);

  std::vector<Proxy> proxies_;     ///< sorted by lo
  std::vector<core::Aabb> boxes_;  ///< inflated boxes, parallel to proxies_
  std::vector<char> member_;       ///< by slot: part of the current update
  std::vector<char> present_;      ///< by slot: already in proxies_ (scratch)
  double max_width_ = 0.0;         ///< widest inflated interval on the sweep axis, m
  int axis_ = 0;
  int a1_ = 1;
  int a2_ = 2;
  bool resorted_ = false;
  bool initialized_ = false;
};

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
/// on every axis (like SweepAndPrune), a superset of those within Euclidean distance `margin`.
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
