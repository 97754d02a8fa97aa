#!/usr/bin/python3
"""Writes the seed corpus of the geometry-core fuzzer (fuzz/corpus/core/), deterministically.

Every pair of shape kinds (9 x 9) in a few layouts: near contact (factor 1 with the relative
placement), overlapping, apart, tiny/huge/zero sizes, far from the origin, degenerate hulls and
invalid values. The byte layout is core_case.h's decoder; libFuzzer mutates from here.
Usage: fuzz/make_seeds.py [out_dir]
"""
import os
import random
import sys

KINDS = 9  # sphere box capsule cylinder cone ellipsoid point segment hull
# magnitude selectors (core_case.h magnitude()): 0 zero, 1 denormal, 2 1e-9, 3 1e-6, 4 1e-3,
# 5 0.1, 6 1, 7 10, 8 1e3, 9 1e6, 10 negative, 11 NaN, 12 Inf, 13 -0.0, 14 raw
ZERO, DENORM, NANO, MICRO, MILLI, DECI, ONE, TEN, KILO, MEGA, NEG, NAN, INF, NEGZERO = range(14)


def mag(sel, m=0):
    return [sel, m]


def coord(sel, m=0, neg=False):
    return [1 if neg else 0, sel, m]


def shape(rng, kind, scale, padded=False, layout=None, npts=None):
    out = [kind | (0x80 if padded else 0)]
    if kind == 0:
        out += mag(scale, rng.randrange(256))
    elif kind in (1, 5):
        for _ in range(3):
            out += mag(scale, rng.randrange(256))
    elif kind in (2, 3, 4):
        out += mag(scale, rng.randrange(256)) + mag(scale, rng.randrange(256))
    elif kind == 6:
        for _ in range(3):
            out += coord(scale, rng.randrange(256), rng.random() < 0.5)
    elif kind == 7:
        for _ in range(6):
            out += coord(scale, rng.randrange(256), rng.random() < 0.5)
    else:
        n = npts if npts is not None else rng.randrange(4, 65)
        lay = layout if layout is not None else 0
        out += [n, lay] + mag(scale, rng.randrange(256))
        out += coord(ZERO) * 3  # centre
        out += [rng.randrange(256) for _ in range(3)]  # collinear direction
        per_point = {1: 2, 2: 1, 3: 0}.get(lay, 3)  # bytes per point of each layout
        for _ in range(n):
            if lay == 5:
                for _ in range(3):
                    out += coord(ONE if rng.random() < 0.9 else scale, rng.randrange(256),
                                 rng.random() < 0.5)
            else:
                out += [rng.randrange(256) for _ in range(per_point)]
    if padded:
        out += mag(scale, rng.randrange(256))
    return out


def pose(rng, mode):
    out = [mode]
    if mode in (1, 2):
        out += [rng.randrange(256) for _ in range(4)]
    elif mode == 3:
        out += [rng.randrange(3), rng.randrange(4)]
    elif mode == 4:
        out += [rng.randrange(256) for _ in range(4)]
    return out


def case(rng, ka, kb, scale_a, scale_b, factor, far=None, pad=False, layout=None, npts=None):
    relative = factor is not None
    flags = (1 if relative else 0) | (2 if factor == 1.0 else 0)
    data = [flags]
    data += shape(rng, ka, scale_a, pad, layout, npts)
    data += shape(rng, kb, scale_b, pad, layout, npts)
    data += pose(rng, rng.choice([0, 1, 2, 3, 4]))
    data += pose(rng, rng.choice([0, 1, 2, 3]))
    if far is None:
        data += coord(ZERO) * 3
    else:
        data += coord(far, rng.randrange(256)) + coord(far, 0, True) + coord(ZERO)
    data += [rng.randrange(256) for _ in range(3)]  # direction
    if flags & 2 == 0:
        data += [int(min(255, (factor or 0.0) * 128))]
    data += coord(scale_b, rng.randrange(256)) * 3  # absolute B (used when not relative)
    return bytes(data)


def main():
    out_dir = sys.argv[1] if len(sys.argv) > 1 else os.path.join(
        os.path.dirname(os.path.abspath(__file__)), "corpus", "core")
    os.makedirs(out_dir, exist_ok=True)
    rng = random.Random(0xF022)
    seeds = {}
    for ka in range(KINDS):
        for kb in range(KINDS):
            seeds["k%d%d_contact" % (ka, kb)] = case(rng, ka, kb, ONE, DECI, 1.0)
            seeds["k%d%d_overlap" % (ka, kb)] = case(rng, ka, kb, ONE, ONE, 0.5, pad=True)
            seeds["k%d%d_apart" % (ka, kb)] = case(rng, ka, kb, ONE, TEN, 1.5)
    for ka in range(KINDS):
        seeds["k%d_tiny_vs_huge" % ka] = case(rng, ka, 1, NANO, MEGA, 0.9)
        seeds["k%d_far" % ka] = case(rng, ka, 8, MILLI, MILLI, 0.99, far=MEGA)
        seeds["k%d_zero" % ka] = case(rng, ka, 0, ZERO, ONE, 1.0)
        seeds["k%d_denormal" % ka] = case(rng, ka, 1, DENORM, MICRO, 0.5)
        seeds["k%d_negative" % ka] = case(rng, ka, 1, NEG, ONE, 0.5)
        seeds["k%d_nan" % ka] = case(rng, ka, 1, NAN, ONE, 0.5)
        seeds["k%d_inf" % ka] = case(rng, ka, 1, INF, ONE, 0.5)
        seeds["k%d_negzero" % ka] = case(rng, ka, 2, NEGZERO, ONE, 1.0)
        seeds["k%d_absolute" % ka] = case(rng, ka, 3, ONE, ONE, None)
    for layout in range(8):
        for npts in (0, 1, 2, 3, 4, 8, 64):
            seeds["hull_l%d_n%d" % (layout, npts)] = case(rng, 8, 8, ONE, ONE, 0.8, layout=layout,
                                                         npts=npts)
    for name, data in sorted(seeds.items()):
        with open(os.path.join(out_dir, name), "wb") as f:
            f.write(data)
    print("%d seeds in %s" % (len(seeds), out_dir))


if __name__ == "__main__":
    main()
