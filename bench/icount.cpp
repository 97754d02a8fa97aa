// Instruction-count driver: one query type over a benchmark pool's walk (bench/pools.h: 1000
// pairs, 8 poses each, the same sequence as bench_core's timed loops), for
//   valgrind --tool=callgrind --toggle-collect='run_queries()' <binary> <pool> <query>
// (scripts/icount.sh). Counting instructions is deterministic, so small changes can be compared
// on a busy machine where timings cannot. Not a benchmark: no timing, no competitors but MPR.
//   <pool>  a bench pool name (hull12, hull32, hull100, hull500, box_box, capsule_capsule,
//           sphere_box, cylinder_cone)
//   <query> distance | warm | intersect | signed | mpr
// warm runs the walk twice (the first pass fills the caches), so the count covers 16,000 queries.
#include <cstdio>
#include <string>
#include <vector>

#include "ccd_adapter.h"
#include "collision_monitor/core/query.h"
#include "pools.h"

namespace {

namespace cc = collision_monitor::core;
using cm_bench::Cursor;
using cm_bench::Pool;

constexpr int kQueries = 8000;

enum class Query { Distance, Warm, Intersect, Signed, Mpr };

// The function callgrind counts (--toggle-collect); noinline so that its name survives.
__attribute__((noinline)) double run_queries(const Pool& pool, Query q, const ccd_t& ccd,
                                             std::vector<cc::PairCache>& caches) {
  double acc = 0.0;
  Cursor c(pool.size());
  for (int i = 0; i < kQueries; ++i, c.next()) {
    const auto& a = pool.a(c.pair);
    const auto& b = pool.b(c.pair);
    const auto& pa = pool.poseA(c.pair);
    const auto& pb = pool.poseB(c.pair, c.step());
    switch (q) {
      case Query::Distance:
        acc += cc::distance(*a.ours, pa, *b.ours, pb).distance;
        break;
      case Query::Warm:
        acc += cc::distance(*a.ours, pa, *b.ours, pb, &caches[c.pair]).distance;
        break;
      case Query::Intersect:
        acc += cc::intersect(*a.ours, pa, *b.ours, pb) ? 1.0 : 0.0;
        break;
      case Query::Signed:
        acc += cc::signedDistance(*a.ours, pa, *b.ours, pb).distance;
        break;
      case Query::Mpr:
        acc += cm_bench::ccdMprIntersect(ccd, a, pa, b, pb) ? 1.0 : 0.0;
        break;
    }
  }
  return acc;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s <pool> distance|warm|intersect|signed|mpr\n", argv[0]);
    return 2;
  }
  const std::string name = argv[2];
  Query q;
  if (name == "distance") {
    q = Query::Distance;
  } else if (name == "warm") {
    q = Query::Warm;
  } else if (name == "intersect") {
    q = Query::Intersect;
  } else if (name == "signed") {
    q = Query::Signed;
  } else if (name == "mpr") {
    q = Query::Mpr;
  } else {
    std::fprintf(stderr, "unknown query '%s'\n", argv[2]);
    return 2;
  }
  const Pool pool = cm_bench::makePool(argv[1]);
  const ccd_t ccd = cm_bench::makeCcd();
  std::vector<cc::PairCache> caches(pool.size());
  double acc = 0.0;
  if (q == Query::Warm) acc += run_queries(pool, q, ccd, caches);
  acc += run_queries(pool, q, ccd, caches);
  // The sum of the answers: equal sums to 17 digits are a quick check that a change kept them.
  std::printf("%s %s: sum of answers %.17g\n", argv[1], argv[2], acc);
  return 0;
}
