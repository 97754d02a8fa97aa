#!/usr/bin/python3
"""Writes the seed corpus of the world model's fuzzer (fuzz/corpus/world/), deterministically.

Each seed is the settings byte (every combination of its five low bits in turn; the last 64 seeds
with bodies that turn, bit 7), then random bytes: world_case.h decodes any bytes, so random ones
are a fair sample of its operations (poses, checks, replacements, removals, queries). Lengths from
40 to 1,200 bytes.
Usage: fuzz/make_world_seeds.py [out_dir]
"""
import os
import random
import sys


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(
        os.path.dirname(os.path.abspath(__file__)), "corpus", "world")
    os.makedirs(out, exist_ok=True)
    rng = random.Random(20261130)
    for k in range(256):
        flags = k % 32 | (128 if k >= 192 else 0)
        length = rng.choice([40, 120, 300, 600, 1200])
        data = bytes([flags]) + bytes(rng.randrange(256) for _ in range(length - 1))
        with open(os.path.join(out, "seed_%03d_flags%d" % (k, flags)), "wb") as f:
            f.write(data)


if __name__ == "__main__":
    main()
