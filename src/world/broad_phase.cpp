#include "collision_monitor/world/broad_phase.h"

#include <algorithm>

namespace collision_monitor {
namespace world {

void SweepAndPrune::chooseAxis(const std::vector<int>& slots,
                               const std::vector<core::Aabb>& boxes) {
  // Variance of the box centres per axis; switch only on a clear win (20 %) so that a scene
  // spread evenly does not flip axes (and re-sort from scratch) every cycle.
  if (slots.empty()) return;
  core::Vec3 sum = core::Vec3::Zero();
  core::Vec3 sum2 = core::Vec3::Zero();
  for (int s : slots) {
    const core::Vec3 c = 0.5 * (boxes[s].min + boxes[s].max);
    sum += c;
    sum2 += c.cwiseProduct(c);
  }
  const double n = static_cast<double>(slots.size());
  const core::Vec3 var = sum2 / n - (sum / n).cwiseProduct(sum / n);
  int best = 0;
  for (int k = 1; k < 3; ++k) {
    if (var[k] > var[best]) best = k;
  }
  if (!initialized_ || (best != axis_ && var[best] > 1.2 * var[axis_])) {
    axis_ = best;
    a1_ = (best + 1) % 3;
    a2_ = (best + 2) % 3;
    resorted_ = true;
  }
}

void SweepAndPrune::update(const std::vector<int>& slots, const std::vector<core::Aabb>& boxes,
                           double margin) {
  resorted_ = !initialized_;
  chooseAxis(slots, boxes);
  initialized_ = true;

  // Keep the previous order of the slots that stay, append the new ones.
  if (member_.size() < boxes.size()) {
    member_.resize(boxes.size(), 0);
    present_.resize(boxes.size(), 0);
  }
  for (int s : slots)
    member_[s] = 1;
  std::size_t kept = 0;
  for (const Proxy& p : proxies_) {
    if (static_cast<std::size_t>(p.slot) < member_.size() && member_[p.slot] && !present_[p.slot]) {
      present_[p.slot] = 1;
      proxies_[kept++] = p;
    }
  }
  proxies_.resize(kept);
  for (int s : slots) {
    if (!present_[s]) {
      present_[s] = 1;
      proxies_.push_back(Proxy{0.0, 0.0, s});
    }
  }
  for (int s : slots) {
    member_[s] = 0;
    present_[s] = 0;
  }

  // Refresh the keys. Inflate by half the margin (plus a hair for rounding) on each side, so that
  // overlapping inflated boxes <=> gap <= margin on every axis.
  const double half = 0.5 * std::max(0.0, margin) * (1.0 + 1e-12) + 1e-12;
  for (Proxy& p : proxies_) {
    p.lo = boxes[p.slot].min[axis_] - half;
    p.hi = boxes[p.slot].max[axis_] + half;
  }

  // Insertion sort from the previous order, with a budget: beyond ~8 moves per element the
  // order is too shuffled and std::sort is cheaper.
  const auto by_lo = [](const Proxy& x, const Proxy& y) { return x.lo < y.lo; };
  if (!resorted_) {
    const std::size_t budget = 8 * proxies_.size() + 64;
    std::size_t moves = 0;
    for (std::size_t i = 1; i < proxies_.size() && moves <= budget; ++i) {
      const Proxy key = proxies_[i];
      std::size_t j = i;
      while (j > 0 && key.lo < proxies_[j - 1].lo) {
        proxies_[j] = proxies_[j - 1];
        --j;
        ++moves;
      }
      proxies_[j] = key;
    }
    if (moves > budget) resorted_ = true;
  }
  if (resorted_) std::sort(proxies_.begin(), proxies_.end(), by_lo);

  boxes_.resize(proxies_.size());
  max_width_ = 0.0;
  for (std::size_t i = 0; i < proxies_.size(); ++i) {
    boxes_[i] = boxes[proxies_[i].slot].inflated(half);
    max_width_ = std::max(max_width_, proxies_[i].hi - proxies_[i].lo);
  }
}

}  // namespace world
}  // namespace collision_monitor
