/// \file
/// Core narrow-phase benchmark: our GJK (query.h) against libccd (GJK and MPR), FCL 0.7's
/// libccd-based solver and Bullet 3 (double), on the same pools of shape pairs (pools.h).
///
/// Benchmarks are named BM_<Query>/<library>/<case>:
///   BM_Distance       separation distance (no depth on overlap)   ours, fcl, bullet
///   BM_DistanceWarm   the same with each library's warm start      ours (PairCache), bullet (axis)
///   BM_Intersect      boolean overlap                              ours, libccd_gjk, libccd_mpr,
///                                                                  fcl (MPR), bullet (GJK verdict)
///   BM_Penetration    signed distance on overlapping pairs only    ours (GJK+EPA), libccd_gjk
///                     (GJK+EPA), libccd_mpr (MPR estimate), fcl (GJK+EPA), bullet (GJK+EPA)
/// Cases: hull12, hull32, hull100, hull500, box_box, capsule_capsule, sphere_box, cylinder_cone.
///
/// Before timing, every pool is checked outside the timed loops: all libraries must agree on
/// the overlap verdict for every (pair, step) whose |signed distance| is outside a tolerance band
/// (kBand), our warm-started distance must equal the cold one, and the distance differences
/// against FCL are printed. A failed check prints CORRECTNESS FAILED, is recorded in the JSON
/// context ("correctness"), and makes the program exit with status 1 after the benchmarks run.
///
/// Extra flags (before Google Benchmark's own):
///   --cm_pools=hull12,box_box   build and benchmark only these pools
///   --cm_no_check               skip the correctness checks
///
/// Reproduce: scripts/bench.sh (docs/benchmarks.md).

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "bench_loop.h"
#include "ccd_adapter.h"
#include "collision_monitor/core/query.h"
#include "pools.h"
#ifdef CM_BENCH_HAVE_FCL
#include "fcl_adapter.h"
#endif
#ifdef CM_BENCH_HAVE_BULLET
#include "bullet_adapter.h"
#endif

namespace cm_bench {
namespace {

/// Pairs with |signed distance| below this (m) by any library are "in the tolerance band":
/// libraries may legitimately disagree on them (libccd's EPA/MPR tolerance is 1e-4 m).
constexpr double kBand = 1e-4;
/// Distance differences above this (m) are counted per pool (FCL's GJK stops at 1e-6 progress).
constexpr double kReportDiff = 1e-5;

/// One pool with every library's prepared data.
struct Bench {
  Pool pool;
  ccd_t ccd = makeCcd();
  std::vector<PairStep> overlapping;  ///< (pair, step)s all libraries see overlapping
#ifdef CM_BENCH_HAVE_FCL
  std::unique_ptr<FclBench> fcl;
#endif
#ifdef CM_BENCH_HAVE_BULLET
  std::unique_ptr<BulletBench> bullet;
#endif
};

// ---- ours -------------------------------------------------------------------------------------

void oursDistance(benchmark::State& state, const Bench* b) {
  const Pool& pool = b->pool;
  runPool(state, pool, [&pool](int pair, int step) {
    return core::distance(*pool.a(pair).ours, pool.poseA(pair), *pool.b(pair).ours,
                          pool.poseB(pair, step))
        .distance;
  });
}

void oursDistanceWarm(benchmark::State& state, const Bench* b) {
  const Pool& pool = b->pool;
  std::vector<core::PairCache> caches(pool.size());
  // One untimed pass: every pair's cache holds its previous step (what a monitor cycle sees).
  Cursor c(pool.size());
  for (int i = 0; i < pool.size(); ++i, c.next()) {
    core::distance(*pool.a(c.pair).ours, pool.poseA(c.pair), *pool.b(c.pair).ours,
                   pool.poseB(c.pair, c.step()), &caches[c.pair]);
  }
  runPool(state, pool, [&pool, &caches](int pair, int step) {
    return core::distance(*pool.a(pair).ours, pool.poseA(pair), *pool.b(pair).ours,
                          pool.poseB(pair, step), &caches[pair])
        .distance;
  });
}

void oursIntersect(benchmark::State& state, const Bench* b) {
  const Pool& pool = b->pool;
  runPool(state, pool, [&pool](int pair, int step) {
    return core::intersect(*pool.a(pair).ours, pool.poseA(pair), *pool.b(pair).ours,
                           pool.poseB(pair, step));
  });
}

void oursPenetration(benchmark::State& state, const Bench* b) {
  const Pool& pool = b->pool;
  runList(state, b->overlapping, [&pool](int pair, int step) {
    return core::signedDistance(*pool.a(pair).ours, pool.poseA(pair), *pool.b(pair).ours,
                                pool.poseB(pair, step))
        .distance;
  });
}

// ---- libccd -----------------------------------------------------------------------------------

void ccdGjkIntersectBench(benchmark::State& state, const Bench* b) {
  const Pool& pool = b->pool;
  const ccd_t& ccd = b->ccd;
  runPool(state, pool, [&pool, &ccd](int pair, int step) {
    return ccdGjkIntersect(ccd, pool.a(pair), pool.poseA(pair), pool.b(pair),
                           pool.poseB(pair, step));
  });
}

void ccdMprIntersectBench(benchmark::State& state, const Bench* b) {
  const Pool& pool = b->pool;
  const ccd_t& ccd = b->ccd;
  runPool(state, pool, [&pool, &ccd](int pair, int step) {
    return ccdMprIntersect(ccd, pool.a(pair), pool.poseA(pair), pool.b(pair),
                           pool.poseB(pair, step));
  });
}

void ccdGjkPenetrationBench(benchmark::State& state, const Bench* b) {
  const Pool& pool = b->pool;
  const ccd_t& ccd = b->ccd;
  runList(state, b->overlapping, [&pool, &ccd](int pair, int step) {
    return ccdGjkDepth(ccd, pool.a(pair), pool.poseA(pair), pool.b(pair), pool.poseB(pair, step));
  });
}

void ccdMprPenetrationBench(benchmark::State& state, const Bench* b) {
  const Pool& pool = b->pool;
  const ccd_t& ccd = b->ccd;
  runList(state, b->overlapping, [&pool, &ccd](int pair, int step) {
    return ccdMprDepth(ccd, pool.a(pair), pool.poseA(pair), pool.b(pair), pool.poseB(pair, step));
  });
}

// ---- correctness, outside the timed loops -------------------------------------------------------

struct Verdicts {
  std::vector<std::string> names;
  std::vector<bool> overlap;
  void add(const char* name, bool v) {
    names.push_back(name);
    overlap.push_back(v);
  }
};

std::string describe(int pair, int step, double ours, double fcl) {
  char buf[160];
  std::snprintf(buf, sizeof(buf), " (pair %d step %d: ours=%.9g fcl=%.9g)", pair, step, ours, fcl);
  return buf;
}

/// Checks one pool; prints a summary line per pool and the first disagreements. Returns false on
/// a failure (a disagreement outside the band, a warm/cold mismatch, a non-finite answer).
bool checkPool(Bench& bench, std::string* summary) {
  const Pool& pool = bench.pool;
  const int n = pool.size();
  const int steps = Pool::kSteps;
  std::map<std::string, int> overlap_count;
  int in_band = 0, disagreements = 0, failed_to_converge = 0;
  double max_diff_ours_fcl = 0.0, max_diff_bullet_fcl = 0.0, max_diff_warm_cold = 0.0;
  double max_depth_ours_ccd = 0.0, max_depth_ours_fcl = 0.0, max_depth_ours_bullet = 0.0;
  int fcl_throws = 0;
  std::string worst_depth_fcl;
  std::string worst_ours_fcl, worst_bullet_fcl,
      worst_ours_bullet;  // where the largest differences occur
  double max_diff_ours_bullet = 0.0;
  int over_ours_fcl = 0, over_ours_bullet = 0;  // pairs differing by more than kReportDiff
  bool ok = true;
  std::vector<double> cold_distance(static_cast<size_t>(n) * steps, 0.0);
  bench.overlapping.clear();

  for (int p = 0; p < n; ++p) {
    for (int k = 0; k < steps; ++k) {
      const ShapeSpec& a = pool.a(p);
      const ShapeSpec& b = pool.b(p);
      const Transform3& pa = pool.poseA(p);
      const Transform3& pb = pool.poseB(p, k);
      Verdicts v;
      bool near = false;
      const auto nearZero = [&near](double x) {
        if (std::abs(x) < kBand) near = true;
      };

      const bool ours_int = core::intersect(*a.ours, pa, *b.ours, pb);
      const core::ContactResult ours_d = core::distance(*a.ours, pa, *b.ours, pb);
      const core::ContactResult ours_sd = core::signedDistance(*a.ours, pa, *b.ours, pb);
      if (ours_d.status == core::Status::FailedToConverge ||
          ours_sd.status == core::Status::FailedToConverge)
        ++failed_to_converge;
      if (!std::isfinite(ours_d.distance) || !std::isfinite(ours_sd.distance)) {
        std::fprintf(stderr, "  %s pair %d step %d: non-finite distance from ours\n",
                     pool.name.c_str(), p, k);
        ok = false;
      }
      v.add("ours_intersect", ours_int);
      v.add("ours_distance", ours_d.status != core::Status::Separated);
      v.add("ours_signed", ours_sd.distance <= 0.0);
      if (ours_d.status == core::Status::Separated) nearZero(ours_d.distance);
      nearZero(ours_sd.distance);
      cold_distance[static_cast<size_t>(p) * steps + k] = ours_d.distance;

      v.add("libccd_gjk", ccdGjkIntersect(bench.ccd, a, pa, b, pb));
      v.add("libccd_mpr", ccdMprIntersect(bench.ccd, a, pa, b, pb));
      // libccd's GJK+EPA depth is informational only: libccd 2.x's EPA returns depths far too
      // small on these pools (see docs/benchmarks.md), so it takes no part in the band.
      const double ccd_depth = ccdGjkDepth(bench.ccd, a, pa, b, pb);
      if (ccd_depth >= 0.0 && ours_sd.distance < 0.0)
        max_depth_ours_ccd = std::max(max_depth_ours_ccd, std::abs(-ours_sd.distance - ccd_depth));
      if (ours_sd.distance < 0.0) {
#ifdef CM_BENCH_HAVE_FCL
        try {
          const double f = bench.fcl->signedDistance(p, k);
          nearZero(f);
          if (std::abs(f - ours_sd.distance) > max_depth_ours_fcl) {
            max_depth_ours_fcl = std::abs(f - ours_sd.distance);
            worst_depth_fcl = describe(p, k, ours_sd.distance, f);
          }
        } catch (const std::exception& e) {
          ++fcl_throws;
        }
#endif
#ifdef CM_BENCH_HAVE_BULLET
        const BulletResult bt_sd = bench.bullet->query(p, k, true);
        if (bt_sd.has_result) {
          nearZero(bt_sd.distance);
          max_depth_ours_bullet =
              std::max(max_depth_ours_bullet, std::abs(bt_sd.distance - ours_sd.distance));
        }
#endif
      }
#ifdef CM_BENCH_HAVE_FCL
      v.add("fcl_intersect", bench.fcl->intersect(p, k));
      // FCL's closed forms (capsule/capsule, sphere/box) report a negative distance and
      // "separated" = true on overlap; its GJK path reports false and -1.
      auto fcl_d = bench.fcl->distance(p, k);
      if (fcl_d.second <= 0.0) fcl_d.first = false;
      v.add("fcl_distance", !fcl_d.first);
      if (fcl_d.first) {
        nearZero(fcl_d.second);
        if (ours_d.status == core::Status::Separated &&
            std::abs(ours_d.distance - fcl_d.second) > kReportDiff)
          ++over_ours_fcl;
        if (ours_d.status == core::Status::Separated &&
            std::abs(ours_d.distance - fcl_d.second) > max_diff_ours_fcl) {
          max_diff_ours_fcl = std::abs(ours_d.distance - fcl_d.second);
          worst_ours_fcl = describe(p, k, ours_d.distance, fcl_d.second);
        }
      }
#endif
#ifdef CM_BENCH_HAVE_BULLET
      const BulletResult bt = bench.bullet->query(p, k, false);
      v.add("bullet", bt.overlapping());
      if (bt.has_result) nearZero(bt.distance);
      if (bt.has_result && bt.distance > 0.0 && ours_d.status == core::Status::Separated) {
        const double diff = std::abs(bt.distance - ours_d.distance);
        if (diff > max_diff_ours_bullet) {
          max_diff_ours_bullet = diff;
          worst_ours_bullet =
              describe(p, k, ours_d.distance, -1.0) + " bullet=" + std::to_string(bt.distance);
        }
        if (diff > kReportDiff) ++over_ours_bullet;
      }
#ifdef CM_BENCH_HAVE_FCL
      if (bt.has_result && fcl_d.first && bt.distance > 0.0 &&
          std::abs(bt.distance - fcl_d.second) > max_diff_bullet_fcl) {
        max_diff_bullet_fcl = std::abs(bt.distance - fcl_d.second);
        worst_bullet_fcl = describe(p, k, ours_d.distance, fcl_d.second) +
                           " bullet=" + std::to_string(bt.distance);
      }
#endif
#endif
      for (size_t i = 0; i < v.names.size(); ++i)
        overlap_count[v.names[i]] += v.overlap[i] ? 1 : 0;
      const bool all_same = std::all_of(v.overlap.begin(), v.overlap.end(),
                                        [&v](bool x) { return x == v.overlap[0]; });
      if (near) {
        ++in_band;
        continue;
      }
      if (!all_same) {
        ++disagreements;
        ok = false;
        if (disagreements <= 5) {
          std::ostringstream os;
          for (size_t i = 0; i < v.names.size(); ++i)
            os << " " << v.names[i] << "=" << (v.overlap[i] ? "overlap" : "apart");
          std::fprintf(stderr, "  %s pair %d step %d: disagreement (ours d=%.9g sd=%.9g):%s\n",
                       pool.name.c_str(), p, k, ours_d.distance, ours_sd.distance,
                       os.str().c_str());
        }
      } else if (v.overlap[0]) {
        bench.overlapping.push_back(PairStep{p, k});
      }
    }
  }

  // Warm start along the benchmark's own walk must give the cold answers.
  {
    std::vector<core::PairCache> caches(n);
    Cursor c(n);
    for (int i = 0; i < n * (2 * steps - 2) * 2; ++i, c.next()) {
      const core::ContactResult r =
          core::distance(*pool.a(c.pair).ours, pool.poseA(c.pair), *pool.b(c.pair).ours,
                         pool.poseB(c.pair, c.step()), &caches[c.pair]);
      const double cold = cold_distance[static_cast<size_t>(c.pair) * steps + c.step()];
      max_diff_warm_cold = std::max(max_diff_warm_cold, std::abs(r.distance - cold));
    }
    if (!(max_diff_warm_cold <= 1e-9)) ok = false;
  }

  const double total = static_cast<double>(n) * steps;
  std::ostringstream os;
  os.precision(3);
  os << pool.name;
  if (pool.kind_a == Kind::Hull) os << " (mean " << pool.mean_vertices << " hull vertices)";
  os << ": " << (ok ? "OK" : "FAILED") << "; overlapping share:";
  for (const auto& kv : overlap_count)
    os << " " << kv.first << "=" << 100.0 * kv.second / total << "%";
  os << "; in tolerance band " << in_band << "/" << static_cast<int>(total)
     << "; disagreements outside band " << disagreements << "; ours FailedToConverge "
     << failed_to_converge << "\n    distance: max |ours-fcl| " << max_diff_ours_fcl << " m"
     << worst_ours_fcl << "; max |ours-bullet| " << max_diff_ours_bullet << " m"
     << worst_ours_bullet << "; max |bullet-fcl| " << max_diff_bullet_fcl << " m"
     << worst_bullet_fcl << "\n    distance: pairs with |ours-fcl| > " << kReportDiff
     << " m: " << over_ours_fcl << ", with |ours-bullet| > " << kReportDiff
     << " m: " << over_ours_bullet << "; max |warm-cold| ours " << max_diff_warm_cold
     << " m\n    signed distance on overlap: max |ours-fcl| " << max_depth_ours_fcl << " m"
     << worst_depth_fcl << " (fcl threw " << fcl_throws << "x); max |ours-bullet EPA| "
     << max_depth_ours_bullet << " m; max |ours-libccd GJK+EPA depth| " << max_depth_ours_ccd
     << " m";
  *summary = os.str();
  std::fprintf(stderr, "check %s\n", summary->c_str());
  if (bench.overlapping.empty()) {
    std::fprintf(stderr, "  %s: no overlapping pairs for BM_Penetration\n", pool.name.c_str());
    bench.overlapping.push_back(PairStep{0, 0});
  }
  return ok;
}

/// Without the check, the penetration list comes from libccd GJK alone.
void overlapListFromLibccd(Bench& bench) {
  const Pool& pool = bench.pool;
  bench.overlapping.clear();
  for (int p = 0; p < pool.size(); ++p)
    for (int k = 0; k < Pool::kSteps; ++k)
      if (ccdGjkIntersect(bench.ccd, pool.a(p), pool.poseA(p), pool.b(p), pool.poseB(p, k)))
        bench.overlapping.push_back(PairStep{p, k});
  if (bench.overlapping.empty()) bench.overlapping.push_back(PairStep{0, 0});
}

// ---- registration -----------------------------------------------------------------------------

template <class Fn>
void reg(const std::string& query, const std::string& lib, const Bench* b, Fn fn) {
  const std::string name = "BM_" + query + "/" + lib + "/" + b->pool.name;
  benchmark::RegisterBenchmark(name.c_str(), [fn, b](benchmark::State& s) {
    fn(s, b);
  })->Unit(benchmark::kNanosecond);
}

void registerAll(const std::vector<std::unique_ptr<Bench>>& benches) {
  for (const auto& bp : benches) {
    const Bench* b = bp.get();
    reg("Distance", "ours", b, oursDistance);
#ifdef CM_BENCH_HAVE_FCL
    reg("Distance", "fcl", b,
        [](benchmark::State& s, const Bench* x) { x->fcl->benchDistance(s); });
#endif
#ifdef CM_BENCH_HAVE_BULLET
    reg("Distance", "bullet", b,
        [](benchmark::State& s, const Bench* x) { x->bullet->benchDistance(s); });
#endif
    reg("DistanceWarm", "ours", b, oursDistanceWarm);
#ifdef CM_BENCH_HAVE_BULLET
    reg("DistanceWarm", "bullet", b,
        [](benchmark::State& s, const Bench* x) { x->bullet->benchDistanceWarm(s); });
#endif
    reg("Intersect", "ours", b, oursIntersect);
    reg("Intersect", "libccd_gjk", b, ccdGjkIntersectBench);
    reg("Intersect", "libccd_mpr", b, ccdMprIntersectBench);
#ifdef CM_BENCH_HAVE_FCL
    reg("Intersect", "fcl", b,
        [](benchmark::State& s, const Bench* x) { x->fcl->benchIntersect(s); });
#endif
#ifdef CM_BENCH_HAVE_BULLET
    reg("Intersect", "bullet", b,
        [](benchmark::State& s, const Bench* x) { x->bullet->benchIntersect(s); });
#endif
    reg("Penetration", "ours", b, oursPenetration);
    reg("Penetration", "libccd_gjk", b, ccdGjkPenetrationBench);
    reg("Penetration", "libccd_mpr", b, ccdMprPenetrationBench);
#ifdef CM_BENCH_HAVE_FCL
    reg("Penetration", "fcl", b,
        [](benchmark::State& s, const Bench* x) { x->fcl->benchPenetration(s, x->overlapping); });
#endif
#ifdef CM_BENCH_HAVE_BULLET
    reg("Penetration", "bullet", b, [](benchmark::State& s, const Bench* x) {
      x->bullet->benchPenetration(s, x->overlapping);
    });
#endif
  }
}

std::vector<std::string> splitComma(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

}  // namespace
}  // namespace cm_bench

int main(int argc, char** argv) {
  using namespace cm_bench;
  std::vector<std::string> pool_names = poolNames();
  bool check = true;
  // Our own flags first; Google Benchmark gets the rest.
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i) {
    if (std::strncmp(argv[i], "--cm_pools=", 11) == 0) {
      pool_names = splitComma(argv[i] + 11);
    } else if (std::strcmp(argv[i], "--cm_no_check") == 0) {
      check = false;
    } else {
      rest.push_back(argv[i]);
    }
  }
  int rest_argc = static_cast<int>(rest.size());
  benchmark::Initialize(&rest_argc, rest.data());
  if (benchmark::ReportUnrecognizedArguments(rest_argc, rest.data())) return 2;

  std::string competitors = "ours libccd_gjk libccd_mpr";
#ifdef CM_BENCH_HAVE_FCL
  competitors += " fcl";
#else
  std::fprintf(stderr, "bench: built without FCL, no fcl rows\n");
#endif
#ifdef CM_BENCH_HAVE_BULLET
  competitors += " bullet";
#else
  std::fprintf(stderr, "bench: built without Bullet, no bullet rows\n");
#endif
  benchmark::AddCustomContext("cm_libraries", competitors);

  std::vector<std::unique_ptr<Bench>> benches;
  bool all_ok = true;
  for (const std::string& name : pool_names) {
    auto b = std::make_unique<Bench>();
    try {
      b->pool = makePool(name);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "bench: cannot build pool '%s': %s\n", name.c_str(), e.what());
      return 2;
    }
#ifdef CM_BENCH_HAVE_FCL
    b->fcl = makeFclBench(b->pool);
#endif
#ifdef CM_BENCH_HAVE_BULLET
    b->bullet = std::make_unique<BulletBench>(b->pool);
#endif
    if (check) {
      std::string summary;
      const bool ok = checkPool(*b, &summary);
      all_ok = all_ok && ok;
      benchmark::AddCustomContext("cm_check_" + name, summary);
    } else {
      overlapListFromLibccd(*b);
    }
    benches.push_back(std::move(b));
  }
  benchmark::AddCustomContext("cm_correctness", check ? (all_ok ? "OK" : "FAILED") : "not checked");
  if (!all_ok) std::fprintf(stderr, "CORRECTNESS FAILED (see the check lines above)\n");

  registerAll(benches);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return all_ok ? 0 : 1;
}
