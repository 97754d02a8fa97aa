#!/usr/bin/python3
"""Writes the demo robot's meshes (binary STL, metres) next to this script.

  gripper.stl      palm and two fingers: a concave part whose convex hull the monitor checks
  wrist_shell.stl  an octagonal frustum shell of the hand link

Run again after changing the numbers below; the files are committed so the demo needs no build
step. Stdlib only.
"""
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))


def box(x0, x1, y0, y1, z0, z1):
    """Twelve outward triangles of an axis-aligned box."""
    c = [(x, y, z) for z in (z0, z1) for y in (y0, y1) for x in (x0, x1)]
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    tris = []
    for a, b, cc, d in quads:
        tris.append((c[a], c[b], c[cc]))
        tris.append((c[a], c[cc], c[d]))
    return tris


def frustum(n, r0, r1, z0, z1):
    """A closed n-gonal frustum along z: radius r0 at z0, r1 at z1 (outward triangles)."""
    bottom = [(r0 * math.cos(2 * math.pi * (i + 0.5) / n), r0 * math.sin(2 * math.pi * (i + 0.5) / n), z0)
              for i in range(n)]
    top = [(r1 * math.cos(2 * math.pi * (i + 0.5) / n), r1 * math.sin(2 * math.pi * (i + 0.5) / n), z1)
           for i in range(n)]
    tris = []
    for i in range(n):
        j = (i + 1) % n
        tris.append((bottom[i], bottom[j], top[j]))
        tris.append((bottom[i], top[j], top[i]))
        tris.append(((0.0, 0.0, z0), bottom[j], bottom[i]))
        tris.append(((0.0, 0.0, z1), top[i], top[j]))
    return tris


def write_stl(path, name, tris):
    with open(path, "wb") as f:
        header = ("collision_monitor demo mesh: " + name).encode()[:80]
        f.write(header.ljust(80, b" "))
        f.write(struct.pack("<I", len(tris)))
        for a, b, c in tris:
            u = [b[k] - a[k] for k in range(3)]
            v = [c[k] - a[k] for k in range(3)]
            n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]
            ln = math.sqrt(sum(x * x for x in n)) or 1.0
            f.write(struct.pack("<3f", *[x / ln for x in n]))
            for p in (a, b, c):
                f.write(struct.pack("<3f", *p))
            f.write(struct.pack("<H", 0))


def main():
    # Gripper, in the gripper link frame (z out of the flange): palm 40 x 110 x 20 mm, two fingers
    # 25 x 20 x 70 mm at the ends of the palm. Its convex hull tapers from palm to fingers.
    gripper = box(-0.02, 0.02, -0.055, 0.055, 0.0, 0.02)
    gripper += box(-0.0125, 0.0125, 0.035, 0.055, 0.02, 0.09)
    gripper += box(-0.0125, 0.0125, -0.055, -0.035, 0.02, 0.09)
    write_stl(os.path.join(HERE, "gripper.stl"), "gripper", gripper)
    # Hand shell: octagonal frustum, radius 36 mm at z = 50 mm tapering to 30 mm at z = 110 mm.
    write_stl(os.path.join(HERE, "wrist_shell.stl"), "wrist_shell", frustum(8, 0.036, 0.030, 0.05, 0.11))


if __name__ == "__main__":
    main()
