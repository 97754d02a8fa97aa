// Sweep and prune against brute force on boxes: fixed-seed random scenes, small motions
// (incremental insertion sort), big shuffles (re-sort), bodies coming and going.
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

PairSet sweep(const SweepAndPrune& sap) {
  PairSet out;
  sap.forEachPair([&](int i, int j) {
    const bool inserted = out.emplace(std::min(i, j), std::max(i, j)).second;
    EXPECT_TRUE(inserted) << "pair reported twice: " << i << ", " << j;
  });
  return out;
}

TEST(SweepAndPrune, MatchesBruteForceAcrossUpdates) {
  std::mt19937 g(42);
  const Vec3 extent(8, 3, 2);  // spread along x: x is the sweep axis
  const int n = 600;
  std::vector<Aabb> boxes(n);
  for (Aabb& b : boxes)
    b = randomBox(g, extent);
  std::vector<int> slots;
  for (int i = 0; i < n; ++i)
    slots.push_back(i);
  const double margin = 0.05;

  SweepAndPrune sap;
  std::size_t total_pairs = 0;
  int resorts = 0;
  for (int round = 0; round < 30; ++round) {
    if (round > 0) {
      // Small motion of a third of the boxes: the incremental path.
      for (int i = round % 3; i < n; i += 3) {
        const Vec3 dx(uniform(g, -0.05, 0.05), uniform(g, -0.05, 0.05), uniform(g, -0.05, 0.05));
        boxes[i].min += dx;
        boxes[i].max += dx;
      }
    }
    if (round == 10) {
      // Everything teleports: too shuffled for insertion sort.
      for (Aabb& b : boxes)
        b = randomBox(g, extent);
    }
    if (round == 20) {
      // Bodies leave and others join (slots not in order).
      slots.erase(std::remove_if(slots.begin(), slots.end(), [](int s) { return s % 5 == 0; }),
                  slots.end());
      std::shuffle(slots.begin(), slots.end(), g);
    }
    if (round == 25) {
      for (int s = 0; s < n; s += 5)
        slots.push_back(s);
    }
    sap.update(slots, boxes, margin);
    resorts += sap.lastUpdateResorted();
    EXPECT_EQ(sap.size(), slots.size());
    EXPECT_EQ(sap.axis(), 0);
    const PairSet expected = bruteForce(slots, boxes, margin);
    EXPECT_EQ(sweep(sap), expected) << "round " << round;
    total_pairs += expected.size();
  }
  // The sample was meaningful: some but not most pairs overlap, and most updates were
  // incremental.
  EXPECT_GT(total_pairs / 30, 100u);
  EXPECT_LT(total_pairs / 30, 5000u);
  EXPECT_LE(resorts, 4);
  EXPECT_GE(resorts, 2);  // first update and the teleport
}

TEST(SweepAndPrune, PairsWithMovedBoxesMatchBruteForce) {
  // forEachPairWith(moved) reports exactly the pairs of forEachPair() that involve a moved box,
  // each once; with one wide box (a "floor") that reaches far back on the sweep axis.
  std::mt19937 g(3);
  std::vector<Aabb> boxes(400);
  for (Aabb& b : boxes)
    b = randomBox(g, Vec3(8, 3, 2));
  boxes[17] = Aabb{Vec3(-1, -1, -0.1), Vec3(9, 4, 0.0)};
  std::vector<int> slots;
  for (int i = 0; i < 400; ++i)
    slots.push_back(i);
  SweepAndPrune sap;
  sap.update(slots, boxes, 0.05);
  const PairSet all = sweep(sap);
  for (int trial = 0; trial < 5; ++trial) {
    std::vector<char> moved(trial == 4 ? 20 : 400, 0);  // a short vector: the rest unmoved
    for (int k = 0; k < 25; ++k)
      moved[g() % moved.size()] = 1;
    if (trial == 0) moved[17] = 1;
    const auto is_moved = [&](int slot) {
      return static_cast<std::size_t>(slot) < moved.size() && moved[slot] != 0;
    };
    PairSet expected;
    for (const auto& p : all) {
      if (is_moved(p.first) || is_moved(p.second)) expected.insert(p);
    }
    PairSet got;
    sap.forEachPairWith(moved, [&](int i, int j) {
      const bool inserted = got.emplace(std::min(i, j), std::max(i, j)).second;
      EXPECT_TRUE(inserted) << "pair reported twice: " << i << ", " << j;
    });
    EXPECT_EQ(got, expected) << "trial " << trial;
    EXPECT_GT(expected.size(), 10u);
  }
}

TEST(SweepAndPrune, PicksTheAxisOfLargestSpreadAndStaysCorrect) {
  std::mt19937 g(7);
  std::vector<Aabb> boxes(300);
  for (Aabb& b : boxes)
    b = randomBox(g, Vec3(1, 1, 12));
  std::vector<int> slots;
  for (int i = 0; i < 300; ++i)
    slots.push_back(i);
  SweepAndPrune sap;
  sap.update(slots, boxes, 0.0);
  EXPECT_EQ(sap.axis(), 2);
  EXPECT_EQ(sweep(sap), bruteForce(slots, boxes, 0.0));
  // The scene turns: now spread along y.
  for (Aabb& b : boxes) {
    std::swap(b.min.y(), b.min.z());
    std::swap(b.max.y(), b.max.z());
  }
  sap.update(slots, boxes, 0.0);
  EXPECT_EQ(sap.axis(), 1);
  EXPECT_TRUE(sap.lastUpdateResorted());
  EXPECT_EQ(sweep(sap), bruteForce(slots, boxes, 0.0));
}

TEST(SweepAndPrune, TouchingAndMarginBoundaries) {
  // Unit boxes with gaps 0 (touching) and exactly the margin 0.25 on x; 0.5 is too far.
  std::vector<Aabb> boxes = {Aabb{Vec3(0, 0, 0), Vec3(1, 1, 1)}, Aabb{Vec3(1, 0, 0), Vec3(2, 1, 1)},
                             Aabb{Vec3(2.25, 0, 0), Vec3(3.25, 1, 1)},
                             Aabb{Vec3(3.75, 0, 0), Vec3(4.75, 1, 1)}};
  SweepAndPrune sap;
  sap.update({0, 1, 2, 3}, boxes, 0.25);
  EXPECT_EQ(sweep(sap), (PairSet{{0, 1}, {1, 2}}));
  sap.update({0, 1, 2, 3}, boxes, 0.5);
  EXPECT_EQ(sweep(sap), (PairSet{{0, 1}, {1, 2}, {2, 3}}));
  sap.update({}, boxes, 0.5);
  EXPECT_EQ(sweep(sap), PairSet{});
}

}  // namespace
}  // namespace world
}  // namespace collision_monitor
