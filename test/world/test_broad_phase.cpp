// The hash-grid broad phase against brute force on boxes: fixed-seed random scenes over many
// incremental cycles (small motions, teleports, bodies coming and going), boundary cases.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include "collision_monitor/world/broad_phase.h"

namespace collision_monitor {
namespace world {
namespace {

using core::Aabb;
using core::Vec3;
using PairSet = std::set<std::pair<int, int>>;

/// Uniform in [lo, hi) from the raw mt19937 output (whose sequence the standard fixes).
double uniform(std::mt19937& g, double lo, double hi) {
  return lo + (hi - lo) * (static_cast<double>(g()) / 4294967296.0);
}

Aabb randomBox(std::mt19937& g, const Vec3& extent) {
  const Vec3 c(uniform(g, 0, extent.x()), uniform(g, 0, extent.y()), uniform(g, 0, extent.z()));
  const Vec3 h(uniform(g, 0.01, 0.3), uniform(g, 0.01, 0.3), uniform(g, 0.01, 0.3));
  return Aabb{c - h, c + h};
}

PairSet bruteForce(const std::vector<int>& slots, const std::vector<Aabb>& boxes, double margin) {
  PairSet out;
  for (std::size_t i = 0; i < slots.size(); ++i) {
    for (std::size_t j = i + 1; j < slots.size(); ++j) {
      const Aabb& a = boxes[slots[i]];
      const Aabb& b = boxes[slots[j]];
      const Vec3 gap = (b.min - a.max).cwiseMax(a.min - b.max);
      if (gap.maxCoeff() <= margin) {
        out.emplace(std::min(slots[i], slots[j]), std::max(slots[i], slots[j]));
      }
    }
  }
  return out;
}

PairSet gridAll(const HashGrid& grid) {
  PairSet out;
  grid.forEachPair([&](int i, int j) {
    const bool inserted = out.emplace(std::min(i, j), std::max(i, j)).second;
    EXPECT_TRUE(inserted) << "pair reported twice: " << i << ", " << j;
  });
  return out;
}

TEST(HashGrid, IncrementalCandidatesMatchBruteForceOverManyCycles) {
  // The world model's use: every cycle some boxes move (small steps, occasional teleports and
  // size changes), some leave and come back; pairs of unmoved boxes are kept from the previous
  // cycle and only the moved ones are queried. The union must equal brute force every cycle,
  // each pair reported once; includes a few huge boxes (large list) and mixed sizes.
  std::mt19937 g(20261122);
  const int n = 700;
  const double margin = 0.055;
  const Vec3 extent(4, 3, 2.5);
  std::vector<Aabb> boxes(n);
  for (Aabb& b : boxes)
    b = randomBox(g, extent);
  boxes[5] = Aabb{Vec3(-1, -1, -0.1), Vec3(5, 4, 0.0)};   // a floor: large list
  boxes[77] = Aabb{Vec3(1, 1, 1), Vec3(1.6, 1.1, 1.05)};  // arm-link-like, wide
  boxes[123] = Aabb{Vec3(2, 2, 2), Vec3(2, 2, 2)};        // a point
  std::vector<char> in(n, 1);
  HashGrid grid;
  grid.setMargin(margin);
  std::vector<int> moved;
  std::vector<char> flag(n, 0);
  for (int i = 0; i < n; ++i) {
    grid.set(i, boxes[i]);
    moved.push_back(i);
    flag[i] = 1;
  }
  PairSet kept;
  std::size_t total = 0;
  std::size_t max_large = 0;
  for (int cycle = 0; cycle < 200; ++cycle) {
    if (cycle > 0) {
      moved.clear();
      std::fill(flag.begin(), flag.end(), 0);
      const auto touch = [&](int i) {
        if (!flag[i]) {
          flag[i] = 1;
          moved.push_back(i);
        }
      };
      const int step = cycle % 10 == 0 ? 1 : 7;  // every 10th cycle: everything moves
      for (int i = cycle % step; i < n; i += step) {
        if (!in[i]) continue;
        const Vec3 d(uniform(g, -0.03, 0.03), uniform(g, -0.03, 0.03), uniform(g, -0.03, 0.03));
        boxes[i].min += d;
        boxes[i].max += d;
        if (g() % 50 == 0) boxes[i] = randomBox(g, extent);       // teleport
        if (g() % 200 == 0) boxes[i].max += Vec3::Constant(0.4);  // grows
        grid.set(i, boxes[i]);
        touch(i);
      }
      for (int k = 0; k < 5; ++k) {  // leave / come back
        const int i = static_cast<int>(g() % n);
        if (in[i]) {
          in[i] = 0;
          grid.remove(i);
          flag[i] = 0;
          moved.erase(std::remove(moved.begin(), moved.end(), i), moved.end());
        } else {
          in[i] = 1;
          grid.set(i, boxes[i]);
          touch(i);
        }
      }
      if (cycle == 100) {  // the scene grows 3x: prepare() rebuilds with another cell size
        for (Aabb& b : boxes) {
          b.min *= 3.0;
          b.max *= 3.0;
        }
        for (int i = 0; i < n; ++i) {
          if (in[i]) {
            grid.set(i, boxes[i]);
            touch(i);
          }
        }
        grid.rebuild();
      }
    }
    grid.prepare();
    max_large = std::max(max_large, grid.numLarge());
    // Kept pairs: both still in, neither moved (the world model's cache).
    PairSet got;
    for (const auto& p : kept) {
      if (in[p.first] && in[p.second] && !flag[p.first] && !flag[p.second]) got.insert(p);
    }
    grid.forEachPairWith(moved, flag, [&](int i, int j) {
      EXPECT_TRUE(flag[i] || flag[j]);
      const bool inserted = got.emplace(std::min(i, j), std::max(i, j)).second;
      EXPECT_TRUE(inserted) << "pair reported twice or kept and reported: " << i << ", " << j;
    });
    std::vector<int> slots;
    for (int i = 0; i < n; ++i) {
      if (in[i]) slots.push_back(i);
    }
    const PairSet expected = bruteForce(slots, boxes, margin);
    ASSERT_EQ(got, expected) << "cycle " << cycle;
    if (cycle % 50 == 0) {
      EXPECT_EQ(gridAll(grid), expected) << "cycle " << cycle;
    }
    EXPECT_EQ(grid.size(), slots.size());
    kept = got;
    total += expected.size();
  }
  EXPECT_GT(total / 200, 300u);  // meaningful: hundreds of pairs per cycle
  EXPECT_GE(max_large, 1u);      // the floor went to the large list
}

TEST(HashGrid, TouchingAndMarginBoundariesAndFarAway) {
  std::vector<Aabb> boxes = {Aabb{Vec3(0, 0, 0), Vec3(1, 1, 1)}, Aabb{Vec3(1, 0, 0), Vec3(2, 1, 1)},
                             Aabb{Vec3(2.25, 0, 0), Vec3(3.25, 1, 1)},
                             Aabb{Vec3(3.75, 0, 0), Vec3(4.75, 1, 1)},
                             // far from the origin (coordinates clamp) and touching each other
                             Aabb{Vec3(1e9, 1e9, 1e9), Vec3(1e9 + 1, 1e9 + 1, 1e9 + 1)},
                             Aabb{Vec3(1e9 + 1, 1e9, 1e9), Vec3(1e9 + 2, 1e9 + 1, 1e9 + 1)}};
  for (double margin : {0.25, 0.5}) {
    HashGrid grid;
    grid.setMargin(margin);
    for (int i = 0; i < static_cast<int>(boxes.size()); ++i)
      grid.set(i, boxes[i]);
    grid.prepare();
    std::vector<int> all = {0, 1, 2, 3, 4, 5};
    EXPECT_EQ(gridAll(grid), bruteForce(all, boxes, margin)) << margin;
    EXPECT_EQ(gridAll(grid).count({4, 5}), 1u);
  }
  HashGrid empty;
  empty.prepare();
  EXPECT_EQ(gridAll(empty), PairSet{});
}

TEST(HashGrid, BoxesReachingPastTheClampedCellCoordinatesMeetTheirNeighbours) {
  // Cells of 2.5 m (the median box, 1 m inflated by 1/8 m a side, twice): cell coordinates clamp
  // at +-2^20 cells (+-2.6e6 m) and an int holds +-2^31 (+-5.4e9 m). A box from -3e6 to -1e6 m
  // overlaps the unit box at -2e6 m, one from 1e9 to 1e10 m the unit box at 8e9 m; the boxes
  // near the origin meet nothing (4 m and more apart).
  const std::vector<Aabb> boxes = {
      Aabb{Vec3(0, 0, 0), Vec3(1, 1, 1)},       Aabb{Vec3(5, 0, 0), Vec3(6, 1, 1)},
      Aabb{Vec3(-3e6, 0, 0), Vec3(-1e6, 1, 1)}, Aabb{Vec3(-2e6, 0, 0), Vec3(-2e6 + 1, 1, 1)},
      Aabb{Vec3(1e9, 0, 0), Vec3(1e10, 1, 1)},  Aabb{Vec3(8e9, 0, 0), Vec3(8e9 + 1, 1, 1)},
      Aabb{Vec3(10, 0, 0), Vec3(11, 1, 1)}};
  HashGrid grid;
  grid.setMargin(0.25);
  for (int i = 0; i < static_cast<int>(boxes.size()); ++i)
    grid.set(i, boxes[i]);
  grid.prepare();
  EXPECT_NEAR(grid.cellSize(), 2.5, 1e-9);
  EXPECT_EQ(gridAll(grid), (PairSet{{2, 3}, {4, 5}}));
  // Each box queried as moved finds the same.
  PairSet moved;
  for (int i = 0; i < static_cast<int>(boxes.size()); ++i) {
    std::vector<char> flag(boxes.size(), 0);
    flag[i] = 1;
    grid.forEachPairWith({i}, flag,
                         [&](int a, int b) { moved.emplace(std::min(a, b), std::max(a, b)); });
  }
  EXPECT_EQ(moved, (PairSet{{2, 3}, {4, 5}}));
}

}  // namespace
}  // namespace world
}  // namespace collision_monitor
