/// \file
/// Broad phase of the world model: sweep and prune ("box pruning", Terdiman 2002; Baraff 1992)
/// on the bounding boxes of the bodies, along the axis where the box centres spread most.
///
/// Incremental: the sorted order of the previous update is kept, so a scene that moved little
/// is re-sorted by insertion sort in ~O(n); a changed axis or a shuffled scene falls back to
/// std::sort (O(n log n)). The sweep then costs O(n + k_axis), k_axis = number of pairs whose
/// intervals overlap on the sweep axis. No heap allocation once the vectors have grown.
///
/// Works on slots (dense integer body indices); boxes are in the fixed frame, metres.
#pragma once

#include <cstddef>
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

}  // namespace world
}  // namespace collision_monitor
