/// \file
/// The timed loop shared by every benchmark: one query per iteration, walking a pool with a
/// Cursor (pair by pair, then one trajectory step further), so no two consecutive queries hit
/// the same pair and branch predictors cannot learn one pair's path.
#pragma once

#include <benchmark/benchmark.h>

#include <vector>

#include "pools.h"

namespace cm_bench {

/// A (pair, trajectory step) of a pool.
struct PairStep {
  int pair = 0;
  int step = 0;
};

/// Runs `query(pair, step)` once per benchmark iteration over the pool's walk. `query` returns
/// something the optimiser must not drop (its result goes through DoNotOptimize).
template <class Query>
void runPool(benchmark::State& state, const Pool& pool, Query&& query) {
  Cursor c(pool.size());
  for (auto _ : state) {
    auto r = query(c.pair, c.step());
    benchmark::DoNotOptimize(r);
    c.next();
  }
  state.SetItemsProcessed(state.iterations());
}

/// Runs `query(pair, step)` cycling over a fixed list (e.g. the overlapping (pair, step)s).
template <class Query>
void runList(benchmark::State& state, const std::vector<PairStep>& list, Query&& query) {
  size_t i = 0;
  for (auto _ : state) {
    const PairStep& ps = list[i];
    auto r = query(ps.pair, ps.step);
    benchmark::DoNotOptimize(r);
    if (++i == list.size()) i = 0;
  }
  state.SetItemsProcessed(state.iterations());
}

}  // namespace cm_bench
