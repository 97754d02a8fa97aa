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
  int axis_ = 0;
  int a1_ = 1;
  int a2_ = 2;
  bool resorted_ = false;
  bool initialized_ = false;
};

}  // namespace world
}  // namespace collision_monitor
