#include "collision_monitor/world/broad_phase.h"

#include <algorithm>
#include <cmath>

namespace collision_monitor {
namespace world {

// ---- HashGrid ------------------------------------------------------------------------------

namespace {
constexpr int kCoordLimit = 1 << 20;  ///< cell coordinates are clamped to +-this (monotone)
}  // namespace

void HashGrid::setMargin(double margin) {
  margin = std::max(0.0, margin);
  if (built_ && margin == margin_) return;
  margin_ = margin;
  half_ = 0.5 * margin * (1.0 + 1e-12) + 1e-12;
  for (int s : members_)
    boxes_[s] = entries_[s].raw.inflated(half_);
  built_ = false;  // re-enter everything at the next prepare()
}

int HashGrid::cellCoord(double v) const {
  const double q = std::floor(v * inv_cell_);
  if (q < -kCoordLimit) return -kCoordLimit;
  if (q > kCoordLimit) return kCoordLimit;
  return static_cast<int>(q);
}

bool HashGrid::cellRange(const core::Aabb& box, std::array<int, 3>* lo,
                         std::array<int, 3>* hi) const {
  long long cells = 1;
  for (int k = 0; k < 3; ++k) {
    if (!std::isfinite(box.min[k]) || !std::isfinite(box.max[k]) || box.min[k] > box.max[k]) {
      return false;
    }
    (*lo)[k] = cellCoord(box.min[k]);
    (*hi)[k] = cellCoord(box.max[k]);
    cells *= static_cast<long long>((*hi)[k]) - (*lo)[k] + 1;
    if (cells > kMaxCells) return false;
  }
  return true;
}

void HashGrid::enter(int slot) {
  Entry& e = entries_[slot];
  for (int z = e.lo[2]; z <= e.hi[2]; ++z) {
    for (int y = e.lo[1]; y <= e.hi[1]; ++y) {
      for (int x = e.lo[0]; x <= e.hi[0]; ++x) {
        std::vector<Item>& b = buckets_[bucketOf(x, y, z)];
        // Two cells of one box may hash to the same bucket: keep each slot once per bucket.
        const auto same = [slot](const Item& i) { return i.slot == slot; };
        if (std::find_if(b.begin(), b.end(), same) == b.end()) b.push_back(Item{slot, e.lo});
      }
    }
  }
  e.entered = true;
}

void HashGrid::leave(int slot) {
  Entry& e = entries_[slot];
  for (int z = e.lo[2]; z <= e.hi[2]; ++z) {
    for (int y = e.lo[1]; y <= e.hi[1]; ++y) {
      for (int x = e.lo[0]; x <= e.hi[0]; ++x) {
        std::vector<Item>& b = buckets_[bucketOf(x, y, z)];
        const auto same = [slot](const Item& i) { return i.slot == slot; };
        auto it = std::find_if(b.begin(), b.end(), same);
        if (it != b.end()) {
          *it = b.back();
          b.pop_back();
        }
      }
    }
  }
  e.entered = false;
}

void HashGrid::addLarge(int slot) {
  Entry& e = entries_[slot];
  e.large = true;
  e.large_index = static_cast<int>(large_.size());
  large_.push_back(slot);
}

void HashGrid::dropLarge(int slot) {
  Entry& e = entries_[slot];
  const int last = large_.back();
  large_[e.large_index] = last;
  entries_[last].large_index = e.large_index;
  large_.pop_back();
  e.large = false;
  e.large_index = -1;
}

void HashGrid::place(int slot) {
  Entry& e = entries_[slot];
  std::array<int, 3> lo;
  std::array<int, 3> hi;
  if (!cellRange(boxes_[slot], &lo, &hi)) {
    if (e.entered) leave(slot);
    if (!e.large) addLarge(slot);
    return;
  }
  if (e.large) dropLarge(slot);
  if (e.entered) {
    if (lo == e.lo && hi == e.hi) return;  // same cells: nothing to re-enter
    leave(slot);
  }
  e.lo = lo;
  e.hi = hi;
  enter(slot);
}

void HashGrid::set(int slot, const core::Aabb& box) {
  if (slot < 0) return;
  if (static_cast<std::size_t>(slot) >= entries_.size()) {
    entries_.resize(slot + 1);
    boxes_.resize(slot + 1);
  }
  Entry& e = entries_[slot];
  if (!e.present) {
    e.present = true;
    e.member_index = static_cast<int>(members_.size());
    members_.push_back(slot);
  }
  e.raw = box;
  boxes_[slot] = box.inflated(half_);
  if (built_) place(slot);
}

void HashGrid::remove(int slot) {
  if (!contains(slot)) return;
  Entry& e = entries_[slot];
  if (e.entered) leave(slot);
  if (e.large) dropLarge(slot);
  const int last = members_.back();
  members_[e.member_index] = last;
  entries_[last].member_index = e.member_index;
  members_.pop_back();
  e = Entry();
}

void HashGrid::prepare() {
  const std::size_t n = members_.size();
  if (!built_ || n > 2 * sized_for_ + 16 || 2 * n + 16 < sized_for_) rebuild();
}

void HashGrid::rebuild() {
  // Cell size from the median largest side of the (finite) inflated boxes.
  scratch_.clear();
  for (int s : members_) {
    const core::Aabb& b = boxes_[s];
    const double side = (b.max - b.min).maxCoeff();
    if (std::isfinite(side) && side >= 0.0) scratch_.push_back(side);
  }
  double median = 0.0;
  if (!scratch_.empty()) {
    auto mid = scratch_.begin() + static_cast<std::ptrdiff_t>(scratch_.size() / 2);
    std::nth_element(scratch_.begin(), mid, scratch_.end());
    median = *mid;
  }
  cell_ = std::max(kCellFactor * median, 1e-3);
  inv_cell_ = 1.0 / cell_;

  std::size_t table = 64;
  while (table < 2 * members_.size())
    table *= 2;
  for (std::vector<Item>& b : buckets_)
    b.clear();
  buckets_.resize(table);
  mask_ = table - 1;
  large_.clear();
  for (int s : members_) {
    Entry& e = entries_[s];
    e.entered = false;
    e.large = false;
    e.large_index = -1;
  }
  for (int s : members_)
    place(s);
  sized_for_ = members_.size();
  built_ = true;
}

}  // namespace world
}  // namespace collision_monitor
