#!/usr/bin/env python3
"""Ratio table and target check for collision_monitor_bench_core's JSON output.

Usage:
  collision_monitor_bench_core --benchmark_out=core.json --benchmark_out_format=json \\
      --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
  python3 bench/compare.py core.json [--markdown] [--strict]

Reads Google Benchmark JSON (python3 standard library only). With repetitions it uses the median
aggregate of each benchmark; without, the single run. Times are per query (real time, ns).

Prints, per query (Distance, DistanceWarm, Intersect, Penetration), a table of cases x libraries
with the time and the ratio library/ours (> 1: ours is faster), then checks the targets of the
issue "The convex geometry core" (Speed):
  * BM_Distance on hulls: ours >= 5x faster than fcl and than bullet, at every hull size;
  * BM_Intersect on hulls: ours >= 1.5x faster than libccd_gjk and than libccd_mpr, every size;
  * BM_DistanceWarm/ours on hulls >= 3x faster than BM_Distance/ours (cold), every size.
--strict: exit status 1 when a target is missed or the correctness check failed.

The same script reads collision_monitor_bench_world's JSON (BM_Cycle / BM_CycleAll, cases n10 ..
n10000; times per cycle): a table per variant with ours, fcl, fcl/ours, time / (n log2 n) and the
growth exponent between consecutive n, then the targets of the issue "The monitor node" (Speed):
  * BM_Cycle[All]/ours/n1000 (7-link arm + 1,000 obstacles) under 1 ms per cycle;
  * ours >= 5x faster than the FCL pipeline on the same scene, at every n;
  * growth no worse than ~n log n: exponent of ours from n1000 to n10000 <= 1.25 (n log n gives
    1.12 there).
"""

import argparse
import json
import math
import re
import sys

NAME_RE = re.compile(r"^BM_(?P<query>[A-Za-z]+)/(?P<lib>[a-z_]+)/(?P<case>[a-z0-9_]+?)"
                     r"(?:_(?P<agg>mean|median|stddev|cv))?$")
QUERIES = ["Distance", "DistanceWarm", "Intersect", "Penetration"]
LIB_ORDER = ["ours", "libccd_gjk", "libccd_mpr", "fcl", "bullet"]
CASE_ORDER = ["hull12", "hull32", "hull100", "hull500",
              "box_box", "capsule_capsule", "sphere_box", "cylinder_cone"]
HULLS = ["hull12", "hull32", "hull100", "hull500"]
TO_NS = {"ns": 1.0, "us": 1e3, "ms": 1e6, "s": 1e9}

WORLD_QUERIES = ["Cycle", "CycleAll"]
WORLD_VARIANT = {"Cycle": "arm + 10 % of the obstacles move per cycle",
                 "CycleAll": "arm + every obstacle moves every cycle"}
WORLD_CYCLE_TARGET_US = 1000.0  # ours at n1000
WORLD_RATIO_TARGET = 5.0        # fcl / ours, every n
WORLD_GROWTH_TARGET = 1.25      # exponent of ours from n1000 to n10000

# (description, query of the reference, library, query of ours, minimum ratio reference/ours)
TARGETS = [
    ("distance vs FCL (libccd GJK) >= 5x", "Distance", "fcl", "Distance", 5.0),
    ("distance vs Bullet >= 5x", "Distance", "bullet", "Distance", 5.0),
    ("intersect vs libccd GJK >= 1.5x", "Intersect", "libccd_gjk", "Intersect", 1.5),
    ("intersect vs libccd MPR >= 1.5x", "Intersect", "libccd_mpr", "Intersect", 1.5),
    ("warm distance vs cold >= 3x", "Distance", "ours", "DistanceWarm", 3.0),
]


def load(path):
    """{(query, lib, case): ns per query}, context dict."""
    with open(path, encoding="utf-8") as f:
        data = json.load(f)
    singles, medians = {}, {}
    for b in data.get("benchmarks", []):
        m = NAME_RE.match(b.get("name", ""))
        if not m:
            continue
        key = (m.group("query"), m.group("lib"), m.group("case"))
        ns = float(b["real_time"]) * TO_NS.get(b.get("time_unit", "ns"), 1.0)
        if b.get("run_type") == "aggregate":
            if b.get("aggregate_name") == "median":
                medians[key] = ns
        elif m.group("agg") is None:
            singles.setdefault(key, []).append(ns)
    times = {}
    for key, values in singles.items():
        values.sort()
        times[key] = values[len(values) // 2]
    times.update(medians)  # medians win when there are repetitions
    return times, data.get("context", {})


def ordered(items, order):
    return sorted(items, key=lambda x: (order.index(x) if x in order else len(order), x))


def fmt_ns(ns):
    return f"{ns:,.0f}" if ns >= 100 else f"{ns:.1f}"


def tables(times, markdown):
    out = []
    for query in QUERIES:
        cases = ordered({c for (q, _, c) in times if q == query}, CASE_ORDER)
        libs = ordered({l for (q, l, _) in times if q == query}, LIB_ORDER)
        if not cases:
            continue
        others = [l for l in libs if l != "ours"]
        header = ["case"] + [f"{l} ns" for l in libs] + [f"{l}/ours" for l in others]
        rows = []
        for c in cases:
            ours = times.get((query, "ours", c))
            row = [c]
            for l in libs:
                t = times.get((query, l, c))
                row.append(fmt_ns(t) if t is not None else "-")
            for l in others:
                t = times.get((query, l, c))
                row.append(f"{t / ours:.2f}x" if t is not None and ours else "-")
            rows.append(row)
        out.append(f"\nBM_{query} (median time per query, ns; ratio > 1: ours faster)")
        out.extend(render(header, rows, markdown))
    # Warm vs cold, ours (and bullet's own warm start).
    rows = []
    for c in ordered({c for (q, _, c) in times if q == "DistanceWarm"}, CASE_ORDER):
        row = [c]
        for lib in ("ours", "bullet"):
            cold, warm = times.get(("Distance", lib, c)), times.get(("DistanceWarm", lib, c))
            row += [fmt_ns(cold) if cold else "-", fmt_ns(warm) if warm else "-",
                    f"{cold / warm:.2f}x" if cold and warm else "-"]
        rows.append(row)
    if rows:
        out.append("\nWarm start (1 mm / 1 degree per step): cold / warm")
        out.extend(render(["case", "ours cold", "ours warm", "ours cold/warm",
                           "bullet cold", "bullet warm", "bullet cold/warm"], rows, markdown))
    return out


def render(header, rows, markdown):
    if markdown:
        lines = ["", "| " + " | ".join(header) + " |",
                 "|" + "|".join("---" if i == 0 else "---:" for i in range(len(header))) + "|"]
        lines += ["| " + " | ".join(r) + " |" for r in rows]
        return lines
    widths = [max(len(str(x)) for x in col) for col in zip(header, *rows)]
    lines = ["  ".join(h.rjust(w) if i else h.ljust(w) for i, (h, w) in enumerate(zip(header, widths)))]
    for r in rows:
        lines.append("  ".join(x.rjust(w) if i else x.ljust(w)
                               for i, (x, w) in enumerate(zip(r, widths))))
    return lines


def check_targets(times, markdown):
    out, missed, rows = [], 0, []
    for desc, ref_q, ref_lib, ours_q, minimum in TARGETS:
        for c in HULLS:
            ref, ours = times.get((ref_q, ref_lib, c)), times.get((ours_q, "ours", c))
            if ref is None or ours is None:
                rows.append([desc, c, "-", "not measured"])
                continue
            ratio = ref / ours
            ok = ratio >= minimum
            missed += 0 if ok else 1
            rows.append([desc, c, f"{ratio:.2f}x", "met" if ok else "MISSED"])
    out.append("\nTargets (hulls, every size)")
    out.extend(render(["target", "case", "ratio", "verdict"], rows, markdown))
    return out, missed


def case_n(case):
    m = re.match(r"^n(\d+)$", case)
    return int(m.group(1)) if m else None


def fit_exponent(points):
    """Least-squares slope of log t over log n."""
    if len(points) < 2:
        return None
    xs = [math.log(n) for n, _ in points]
    ys = [math.log(t) for _, t in points]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    sxx = sum((x - mx) ** 2 for x in xs)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sxx if sxx else None


def world_tables(times, markdown):
    out = []
    for query in WORLD_QUERIES:
        ns = sorted({case_n(c) for (q, _, c) in times if q == query and case_n(c)})
        if not ns:
            continue
        rows = []
        prev = {}
        series = {"ours": [], "fcl": []}
        for n in ns:
            row = [f"{n:,}"]
            for lib in ("ours", "fcl"):
                t = times.get((query, lib, f"n{n}"))
                row.append(f"{t / 1e3:,.1f}" if t is not None else "-")
                if t is not None:
                    series[lib].append((n, t))
            ours, fcl = times.get((query, "ours", f"n{n}")), times.get((query, "fcl", f"n{n}"))
            row.append(f"{fcl / ours:.2f}x" if ours and fcl else "-")
            row.append(f"{ours / (n * math.log2(n)):.2f}" if ours else "-")
            for lib, t in (("ours", ours), ("fcl", fcl)):
                if t is not None and lib in prev:
                    pn, pt = prev[lib]
                    row.append(f"{math.log(t / pt) / math.log(n / pn):.2f}")
                else:
                    row.append("-")
                if t is not None:
                    prev[lib] = (n, t)
            rows.append(row)
        out.append(f"\nBM_{query}: {WORLD_VARIANT[query]} (median time per cycle, us; "
                   "ratio > 1: ours faster)")
        out.extend(render(["n obstacles", "ours us", "fcl us", "fcl/ours", "ours ns/(n log2 n)",
                           "ours exponent", "fcl exponent"], rows, markdown))
        fits = []
        for lib in ("ours", "fcl"):
            pts = [(n, t) for n, t in series[lib] if n >= 100]
            e = fit_exponent(pts)
            if e is not None:
                fits.append(f"{lib} t ~ n^{e:.2f}")
        if fits:
            out.append("fitted over n >= 100: " + ", ".join(fits))
    return out


def check_world_targets(times, markdown):
    rows, missed = [], 0
    for query in WORLD_QUERIES:
        ns = sorted({case_n(c) for (q, _, c) in times if q == query and case_n(c)})
        if not ns:
            continue
        ours = times.get((query, "ours", "n1000"))
        if ours is None:
            rows.append([f"{query}: arm + 1,000 obstacles < 1 ms", "n1000", "-", "not measured"])
        else:
            ok = ours / 1e3 < WORLD_CYCLE_TARGET_US
            missed += 0 if ok else 1
            rows.append([f"{query}: arm + 1,000 obstacles < 1 ms", "n1000",
                         f"{ours / 1e3:,.0f} us", "met" if ok else "MISSED"])
        for n in ns:
            o, f = times.get((query, "ours", f"n{n}")), times.get((query, "fcl", f"n{n}"))
            if o is None or f is None:
                rows.append([f"{query}: vs FCL pipeline >= 5x", f"n{n}", "-", "not measured"])
                continue
            ok = f / o >= WORLD_RATIO_TARGET
            missed += 0 if ok else 1
            rows.append([f"{query}: vs FCL pipeline >= 5x", f"n{n}", f"{f / o:.2f}x",
                         "met" if ok else "MISSED"])
        a, b = times.get((query, "ours", "n1000")), times.get((query, "ours", "n10000"))
        if a and b:
            e = math.log(b / a) / math.log(10.0)
            ok = e <= WORLD_GROWTH_TARGET
            missed += 0 if ok else 1
            rows.append([f"{query}: growth <= ~n log n (exponent <= {WORLD_GROWTH_TARGET})",
                         "n1000-n10000", f"{e:.2f}", "met" if ok else "MISSED"])
    out = ["\nTargets (monitor node cycle)"]
    out.extend(render(["target", "case", "value", "verdict"], rows, markdown))
    return out, missed


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("json", help="Google Benchmark JSON output of collision_monitor_bench_core "
                    "or collision_monitor_bench_world")
    ap.add_argument("--markdown", action="store_true", help="markdown tables (docs/benchmarks.md)")
    ap.add_argument("--strict", action="store_true",
                    help="exit 1 when a target is missed or correctness failed")
    args = ap.parse_args()
    times, context = load(args.json)
    if not times:
        print(f"compare.py: no BM_<Query>/<library>/<case> benchmarks in {args.json}")
        return 2
    lines = []
    for k in ("date", "host_name", "num_cpus", "mhz_per_cpu", "library_build_type", "load_avg",
              "cm_libraries", "cm_correctness"):
        if k in context:
            lines.append(f"{k}: {context[k]}")
    is_core = any(q in QUERIES for (q, _, _) in times)
    is_world = any(q in WORLD_QUERIES for (q, _, _) in times)
    missed = 0
    if is_core:
        lines += tables(times, args.markdown)
        target_lines, missed = check_targets(times, args.markdown)
        lines += target_lines
    if is_world:
        lines += [f"{k}: {v}" for k, v in sorted(context.items()) if k.startswith("cm_check_")]
        lines += world_tables(times, args.markdown)
        target_lines, world_missed = check_world_targets(times, args.markdown)
        lines += target_lines
        missed += world_missed
    correctness = context.get("cm_correctness", "unknown")
    lines.append(f"\n{missed} target(s) missed; correctness check: {correctness}")
    print("\n".join(lines))
    if args.strict and (missed or correctness not in ("OK",)):
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
