"""Independent oracle for the collision_monitor contract sweep (numpy + scipy/qhull only).

A convex part is a "core" point set (sphere: its centre; capsule: 2 end points; box: 8 corners;
convex: its points) swept by a radius (sphere/capsule radius + padding). The signed distance of
two such parts is the signed distance of the origin to hull(core_a - core_b) minus the summed
radii (exact, also when penetrating). A body is a union of parts: its distance is the minimum over
part pairs (docs/node.md: "the smallest over its bodies' convex part pairs").
"""
import math
import struct

import numpy as np
from scipy.spatial import ConvexHull as _ConvexHull
from scipy.spatial import QhullError


def ConvexHull(pts):
    """qhull; on a precision error (many nearly coplanar points: the polygons of curved
    parts) again with wide facets allowed (Q12), then joggled (QJ, ~1e-11 relative)."""
    for opts in (None, 'Qt Q12', 'QJ'):
        try:
            return _ConvexHull(pts) if opts is None else _ConvexHull(pts, qhull_options=opts)
        except QhullError:
            if opts == 'QJ':
                raise

SPHERE, BOX, CYLINDER, CONE, CAPSULE, ELLIPSOID, CONVEX, MESH = 1, 2, 3, 4, 5, 6, 7, 8


def read_stl(path):
    """The triangles of an STL file (binary, or ASCII 'solid ... facet'), n x 3 x 3, as float32
    gives them."""
    with open(path, 'rb') as f:
        data = f.read()
    if data[:5] == b'solid' and b'facet' in data[:512]:
        pts = [[float(x) for x in line.split()[1:4]]
               for line in data.decode('ascii', 'replace').splitlines()
               if line.strip().startswith('vertex')]
        return np.array(pts, np.float32).astype(float).reshape(-1, 3, 3)
    n = struct.unpack_from('<I', data, 80)[0]
    rec = np.dtype([('n', '<f4', 3), ('v', '<f4', (3, 3)), ('a', '<u2')])
    return np.frombuffer(data, rec, count=n, offset=84)['v'].astype(float)


# ---------------------------------------------------------------- rigid transforms
def quat_to_mat(q):
    x, y, z, w = q
    n = math.sqrt(x * x + y * y + z * z + w * w)
    if n == 0.0:
        return np.eye(3)
    x, y, z, w = x / n, y / n, z / n, w / n
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def rpy_to_quat(r, p, y):
    """URDF rpy (fixed axes X, Y, Z: R = Rz(y) Ry(p) Rx(r)) as (x, y, z, w)."""
    cr, sr = math.cos(r / 2), math.sin(r / 2)
    cp, sp = math.cos(p / 2), math.sin(p / 2)
    cy, sy = math.cos(y / 2), math.sin(y / 2)
    return (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy)


def mat_to_quat(R):
    t = R[0, 0] + R[1, 1] + R[2, 2]
    if t > 0:
        s = math.sqrt(t + 1.0) * 2
        return ((R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s, 0.25 * s)
    i = int(np.argmax([R[0, 0], R[1, 1], R[2, 2]]))
    if i == 0:
        s = math.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2]) * 2
        return (0.25 * s, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s, (R[2, 1] - R[1, 2]) / s)
    if i == 1:
        s = math.sqrt(1.0 + R[1, 1] - R[0, 0] - R[2, 2]) * 2
        return ((R[0, 1] + R[1, 0]) / s, 0.25 * s, (R[1, 2] + R[2, 1]) / s, (R[0, 2] - R[2, 0]) / s)
    s = math.sqrt(1.0 + R[2, 2] - R[0, 0] - R[1, 1]) * 2
    return ((R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, 0.25 * s, (R[1, 0] - R[0, 1]) / s)


class Tf:
    """x_parent = R x_child + t."""

    def __init__(self, R=None, t=None):
        self.R = np.eye(3) if R is None else np.asarray(R, float)
        self.t = np.zeros(3) if t is None else np.asarray(t, float)

    @staticmethod
    def from_xyz_q(xyz, q):
        return Tf(quat_to_mat(q), xyz)

    def __mul__(self, o):
        return Tf(self.R @ o.R, self.R @ o.t + self.t)

    def inv(self):
        return Tf(self.R.T, -self.R.T @ self.t)

    def apply(self, pts):
        return np.asarray(pts, float) @ self.R.T + self.t

    def rot(self, v):
        return np.asarray(v, float) @ self.R.T

    def quat(self):
        return mat_to_quat(self.R)


# ---------------------------------------------------------------- parts
NGON = 512


def _scale(verts, scale):
    v = np.asarray(verts, float)
    if scale is None or all(x == 0.0 for x in scale):
        return v
    return v * np.asarray(scale, float)[None, :]


def part_core2(kind, dims, verts, scale=None):
    """(inner core, outer core, radius): the true part lies between the sphere-swept hulls of
    the inner and the outer core (the same array for the shapes that are exact here)."""
    if kind in (CYLINDER, CONE):
        h, r = dims
        ang = 2 * math.pi * (np.arange(NGON) + 0.5) / NGON
        ring = np.stack([np.cos(ang), np.sin(ang), np.zeros(NGON)], axis=1)
        out = []
        for rr in (r, r / math.cos(math.pi / NGON)):
            base = ring * rr + [0, 0, -h / 2]
            if kind == CYLINDER:
                top = ring * rr + [0, 0, h / 2]
                out.append(np.concatenate([base, top]))
            else:
                out.append(np.concatenate([base, [[0.0, 0.0, h / 2]]]))
        return out[0], out[1], 0.0
    if kind in (CONVEX, MESH):
        c = _scale(verts, scale)
        return c, c, 0.0
    c, r = part_core(kind, dims, verts)
    return c, c, r


def part_core(kind, dims, verts):
    """(core points in the part frame, radius) of one Shape, or None when not exact here."""
    if kind == SPHERE:
        return np.zeros((1, 3)), float(dims[0])
    if kind == BOX:
        hx, hy, hz = (d / 2.0 for d in dims)
        return np.array([[sx * hx, sy * hy, sz * hz] for sx in (-1, 1) for sy in (-1, 1)
                         for sz in (-1, 1)]), 0.0
    if kind == CAPSULE:
        h = dims[0] / 2.0
        return np.array([[0, 0, -h], [0, 0, h]], float), float(dims[1])
    if kind == CONVEX:
        return np.asarray(verts, float), 0.0
    return None


# ---------------------------------------------------------------- distance of the origin
def _seg_closest(a, b):
    """Closest points to the origin on segments a[i]-b[i] (arrays n x 3)."""
    d = b - a
    dd = np.einsum('ij,ij->i', d, d)
    t = np.where(dd > 0, -np.einsum('ij,ij->i', a, d) / np.where(dd > 0, dd, 1.0), 0.0)
    t = np.clip(t, 0.0, 1.0)
    return a + t[:, None] * d


def origin_to_hull(D):
    """Signed distance of the origin to hull(D) and the unit outward normal of the hull at the
    boundary point nearest the origin (for origin outside: -v/|v|, v the nearest point).
    Returns (signed, normal, nearest_point_or_None)."""
    D = np.asarray(D, float)
    c = D.mean(axis=0)
    X = D - c
    scale = max(1.0, float(np.abs(D).max()))
    _, s, Vt = np.linalg.svd(X, full_matrices=False)
    rank = int(np.sum(s > 1e-10 * scale))
    if rank == 0:
        v = D[0]
    elif rank == 1:
        u = Vt[0]
        tt = X @ u
        p0, p1 = c + tt.min() * u, c + tt.max() * u
        v = _seg_closest(p0[None], p1[None])[0]
    elif rank == 2:
        u1, u2 = Vt[0], Vt[1]
        P2 = np.stack([X @ u1, X @ u2], axis=1)
        o = -c
        o2 = np.array([o @ u1, o @ u2])
        hull = ConvexHull(P2)
        eq = hull.equations  # n.x + off <= 0 inside
        if np.all(eq[:, :2] @ o2 + eq[:, 2] <= 0):
            q2 = o2
        else:
            vs = P2[hull.simplices]
            a3 = np.concatenate([vs[:, 0] - o2, np.zeros((len(vs), 1))], axis=1)
            b3 = np.concatenate([vs[:, 1] - o2, np.zeros((len(vs), 1))], axis=1)
            cp = _seg_closest(a3, b3)
            i = int(np.argmin(np.einsum('ij,ij->i', cp, cp)))
            q2 = cp[i, :2] + o2
        v = c + q2[0] * u1 + q2[1] * u2
    else:
        hull = ConvexHull(D)
        eq = hull.equations
        vals = eq[:, 3]  # at the origin
        if np.all(vals <= 0):
            i = int(np.argmax(vals))  # the nearest facet plane
            return float(vals[i]), eq[i, :3].copy(), None
        tri = D[hull.simplices]  # m x 3 x 3
        n = eq[:, :3]
        proj = -vals[:, None] * n  # origin projected on each facet plane
        # barycentric test of proj in its triangle
        A, B, C = tri[:, 0], tri[:, 1], tri[:, 2]
        v0, v1, v2 = B - A, C - A, proj - A
        d00 = np.einsum('ij,ij->i', v0, v0)
        d01 = np.einsum('ij,ij->i', v0, v1)
        d11 = np.einsum('ij,ij->i', v1, v1)
        d20 = np.einsum('ij,ij->i', v2, v0)
        d21 = np.einsum('ij,ij->i', v2, v1)
        den = d00 * d11 - d01 * d01
        den = np.where(den == 0, 1.0, den)
        bv = (d11 * d20 - d01 * d21) / den
        bw = (d00 * d21 - d01 * d20) / den
        inside = (bv >= 0) & (bw >= 0) & (bv + bw <= 1)
        cands = [proj[inside]]
        for e0, e1 in ((A, B), (B, C), (C, A)):
            cands.append(_seg_closest(e0, e1))
        allc = np.concatenate(cands, axis=0)
        # qhull's triangulation (Qt) of coplanar facets has sliver triangles whose barycentric
        # test is meaningless: keep only candidates that lie on the hull (every plane <= tol)
        tol = 1e-9 * scale
        order = np.argsort(np.einsum('ij,ij->i', allc, allc))
        v = None
        for i in order:
            if np.max(eq[:, :3] @ allc[i] + eq[:, 3]) <= tol:
                v = allc[i]
                break
        assert v is not None
    nv = float(np.linalg.norm(v))
    return nv, (-v / nv if nv > 0 else np.zeros(3)), v


def part_pair(core_a, ra, core_b, rb):
    """(signed distance, unit normal from a towards b) of two sphere-swept cores (world)."""
    D = (core_a[:, None, :] - core_b[None, :, :]).reshape(-1, 3)
    sd, n, _ = origin_to_hull(D)
    return sd - ra - rb, n


def point_sdf(core, r, x):
    """Signed distance of point x to a sphere-swept core."""
    sd, _, _ = origin_to_hull(np.asarray(core, float) - np.asarray(x, float)[None, :])
    return sd - r


# ---------------------------------------------------------------- bodies
class OBody:
    """A body in world coordinates: list of (core_world, radius)."""

    def __init__(self, bid, parts_world, group=''):
        self.id = bid
        self.parts = parts_world
        self.group = group


def make_obody(bid, T_world_body, parts, padding, group=''):
    """parts: list of (kind, dims, verts, part Tf in body frame[, scale])."""
    out, outer, approx = [], [], False
    for p in parts:
        kind, dims, verts, T_part = p[:4]
        scale = p[4] if len(p) > 4 else None
        cin, cout, r = part_core2(kind, dims, verts, scale)
        T = T_world_body * T_part
        out.append((T.apply(cin), r + padding))
        outer.append((T.apply(cout), r + padding))
        approx = approx or cin is not cout
    b = OBody(bid, out, group)
    b.outer = outer
    b.approx = approx
    return b


def body_distance(a, b):
    """(signed distance, normal a->b, runner-up gap, lower bound) of two bodies: min over part
    pairs. With curved parts (cylinder, cone) the first is an upper bound (inner polygons) and the
    last a lower bound (outer polygons); otherwise both are the exact distance."""
    res = []
    for ca, ra in a.parts:
        for cb, rb in b.parts:
            res.append(part_pair(ca, ra, cb, rb))
    res.sort(key=lambda x: x[0])
    gap = res[1][0] - res[0][0] if len(res) > 1 else float('inf')
    lo = res[0][0]
    if getattr(a, 'approx', False) or getattr(b, 'approx', False):
        lo = min(part_pair(ca, ra, cb, rb)[0] for ca, ra in a.outer for cb, rb in b.outer)
    return res[0][0], res[0][1], gap, lo


def body_sdf(b, x):
    """min over parts of the part's signed distance at x, and min |.| (on some part); with
    curved parts the same for the outer cores (lower bounds), else the same values."""
    vals = [point_sdf(c, r, x) for c, r in b.parts]
    if not getattr(b, 'approx', False):
        return min(vals), min(abs(v) for v in vals), min(vals), vals, vals
    ovals = [point_sdf(c, r, x) for c, r in b.outer]
    return min(vals), min(abs(v) for v in vals), min(ovals), vals, ovals


def _golden_min(f, lo, hi, it=120):
    g = (math.sqrt(5) - 1) / 2
    a, b = lo, hi
    c, d = b - g * (b - a), a + g * (b - a)
    fc, fd = f(c), f(d)
    for _ in range(it):
        if fc < fd:
            b, d, fd = d, c, fc
            c = b - g * (b - a)
            fc = f(c)
        else:
            a, c, fc = c, d, fd
            d = a + g * (b - a)
            fd = f(d)
    t = (a + b) / 2
    return t, f(t)


def time_to_collision(a, b, va, vb, contact):
    """Translating bodies (linear velocities va, vb in world, no rotation): the first t >= 0 at
    which the body distance reaches `contact`; 0 when already at or below; inf when never.
    Each part pair's distance is convex in t (distance of the point w t to a fixed convex set)."""
    w = np.asarray(vb, float) - np.asarray(va, float)
    d0 = body_distance(a, b)[0]
    if d0 <= contact:
        return 0.0
    sw = float(np.linalg.norm(w))
    if sw == 0.0:
        return float('inf')
    best = float('inf')
    for ca, ra in a.parts:
        for cb, rb in b.parts:
            D0 = (ca[:, None, :] - cb[None, :, :]).reshape(-1, 3)
            R = ra + rb

            def f(t):
                return origin_to_hull(D0 - w * t)[0] - R
            tmax = (abs(contact) + R + float(np.abs(D0).max()) * 2 + 1.0) / sw
            tm, fm = _golden_min(f, 0.0, tmax)
            if fm > contact:
                continue
            lo, hi = 0.0, tm
            for _ in range(100):
                mid = (lo + hi) / 2
                if f(mid) <= contact:
                    hi = mid
                else:
                    lo = mid
            best = min(best, hi)
    return best
