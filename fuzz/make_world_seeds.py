#!/usr/bin/python3
"""Writes the seed corpus of the world model's fuzzer (fuzz/corpus/world/), deterministically.

Each seed is the settings byte (every combination of its five low bits in turn; seeds 192 to 255
with bodies that turn, bit 7; the 32 after them in frames mode with the clock going back, bit 5,
each with or without rates and turns; the 32 after those of capsules, bit 6, every combination of
the five low bits, half of them turning; the 64 after those with twists, bits 5 and 6, half of
them turning: 32 with align_poses off, one in eight of those with libccd, and 32 in frames
without rates; the 64 after those the same with boxes: their sixth byte, the second settings
byte of a case with twists, has bits 3 and 4; the 32 after those with boxes and hulls, bit 6 of
that byte too, half with align_poses off and half in frames without rates; bit 7 of that byte,
random, turns estimate_twists on in about half of the cases with twists; in every case of boxes
about half the boxes are cylinders, cones or ellipsoids, by a random bit of their turn's byte),
then random bytes: world_case.h decodes any bytes, so random ones are a fair
sample of its operations (poses, checks, replacements, removals, queries). Lengths from 40 to
1,200 bytes (600 at least with twists: times to collision are held to the reference only at
pairs near enough to be listed, at their events and at queries).
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
    for k in range(480):
        if k < 256:
            flags = k % 32 | (128 if k >= 192 else 0)
        elif k < 288:
            flags = 1 | 8 | 32 | (16 if k % 2 else 0) | (128 if k % 4 >= 2 else 0)
        elif k < 320:
            flags = k % 32 | 64 | (128 if k % 2 else 0)
        elif k < 352 or 384 <= k < 416:
            flags = (96 | (2 if k % 2 else 0) | (128 if k % 4 >= 2 else 0)
                     | (4 if k % 8 == 7 else 0) | (24 if k % 16 >= 8 else 0))
        elif k < 448:
            flags = 96 | 1 | 8 | (2 if k % 2 else 0) | (128 if k % 4 >= 2 else 0)
        else:
            flags = (96 | (2 if k % 2 else 0) | (128 if k % 4 >= 2 else 0)
                     | (9 if k % 8 >= 4 else 0))
        length = rng.choice([40, 120, 300, 600, 1200])
        if k >= 320:
            length = max(length, 600)
        data = bytearray([flags]) + bytes(rng.randrange(256) for _ in range(length - 1))
        if k >= 384:
            data[5] |= 0x18
        if k >= 448:
            data[5] |= 0x40
        with open(os.path.join(out, "seed_%03d_flags%d" % (k, flags)), "wb") as f:
            f.write(data)


if __name__ == "__main__":
    main()
