#!/usr/bin/python3
"""rostest: a real robot's links against each other, at random joint configurations, against an
independent oracle (robot_oracle_pr2.test: the PR2's STL meshes, each one hull and, in a second
monitor, one hull per closed piece; robot_oracle_panda.test: the Panda's cylinders and spheres).

The robot comes from the parameter server (robot_description, robot_description_semantic) and
moves through robot_state_publisher: this test publishes joint_states, one configuration after
another (the zero one, then random ones in the joint limits, fixed seed; with ~candidates, each
the one of that many drawn in which the oracle, at the URDF's forward kinematics, finds the most
pairs in contact), each reached in a straight line in joint space over ~move_time seconds (0: at
once), and holds each still.
The oracle reads the URDF and SRDF with ElementTree (not urdfdom, not the node's SRDF reader),
reads the STL files and splits them into pieces itself, and takes each link's pose from TF (what
the monitor attaches the link to); its distances are sweep_oracle.py's (numpy + qhull: the
origin's signed distance to the hull of the difference of two parts' points, exact also when they
overlap; a cylinder bracketed between its inner and outer prisms of ~ngon sides, 512 by
default; a cylinder with spheres of its radius on its end caps, the Panda's, is exactly a capsule
with them, which the oracle has exactly too).

Checked at every configuration, for every pair of links with collision geometry:
  - a pair joined by a joint (links without geometry skipped over) or disabled by the SRDF is
    refused by ~get_distance as never checked, naming that reason;
  - every other pair's ~get_distance distance equals the oracle's (1e-7 m; a cylinder's within
    its bracket, and where its links are capsules and apart, within 1e-7 m of theirs), its
    witness points lie on their links and are that distance apart, its normal is a unit vector
    from point_a towards point_b;
  - ~check_collision with sphere probes near random links (every other one named after a link:
    that link moved there, its never-checked pairs left out) lists every link within the margin,
    sorted, at the oracle's distances, and in_collision when one is in contact;
  - ~state lists the pairs the thresholds put in WARNING or COLLISION, with those statuses (a
    pair within the hysteresis above a threshold may keep the status it had), lists no other
    pair and no pair that is never checked, and in_collision and min_distance agree.
With ~move_time, the events of each move: each is one the oracle's status machine (stepped over
every /tf stamp of the move, from the statuses ~state had before) gives on that pair, at that
stamp or at most a monitor's max_lag stamps later (MAX_LAG by default; 0 for a monitor that
checks slower than TF, whose catch-up goes over every stamp), at the oracle's distance there;
each of the oracle's transitions is sent (pairs of a link with a cylinder that is not a capsule's
left out).
With ~tf_prefix (robot_oracle_panda.test: the Panda as the left arm of a cell, its
robot_state_publisher's tf_prefix `left`), the links' TF frames are prefixed and each monitor's
fixed frame and ~list_bodies frames are held to the prefixed names, the ids to the link names.
A configuration counts only once ~state is stamped after the joint state that set it and no
link is stale. The share of pairs in COLLISION and WARNING is asserted, so the sample means
something.
"""
import math
import os
import random
import sys
import threading
import time
import unittest
import xml.etree.ElementTree as ET

import numpy as np
from scipy.spatial import QhullError

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import sweep_oracle  # noqa: E402
from event_oracle import (CONTACT, HYSTERESIS, MAX_LAG, WARNING, Timeline, key,  # noqa: E402
                          run)
from sweep_oracle import (BOX, CAPSULE, CYLINDER, MESH, SPHERE, ConvexHull, Tf,  # noqa: E402
                          body_distance, body_sdf, make_obody, read_stl)
from urdf_kinematics import Kinematics, floats, origin_tf  # noqa: E402

import rospkg  # noqa: E402
import rospy  # noqa: E402
import rostest  # noqa: E402
import tf2_ros  # noqa: E402
from collision_monitor.msg import PairState  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from tf2_msgs.msg import TFMessage  # noqa: E402

from cm_test_util import EVENT_NAMES as NAMES  # noqa: E402
from cm_test_util import Monitor, point, pose, sphere_body, wait_for  # noqa: E402

TOL = 1e-7       # distance, exact parts (m)
SURFACE_TOL = 1e-6  # a witness point's distance to its link's surface (m)
CAP_TOL = 1e-12  # a sphere's centre off a cylinder's end cap's, and their radii's difference (m)
SEED = 20261202
PROBES = 6          # ~check_collision probes a configuration
PROBE_RADIUS = 0.05
PROBE_MARGIN = 0.1


def closed_pieces(tri):
    """docs/node.md, mesh_decomposition "pieces": triangles that share a vertex position are one
    piece; the mesh splits only when every piece is closed (each edge on an even number of its
    triangles). Returns each piece's points, or None (one hull)."""
    pos, idx = np.unique(tri.reshape(-1, 3), axis=0, return_inverse=True)
    idx = idx.reshape(-1, 3)
    up = list(range(len(pos)))

    def find(i):
        while up[i] != i:
            up[i] = up[up[i]]
            i = up[i]
        return i
    for a, b, c in idx:
        up[find(b)] = find(a)
        up[find(c)] = find(a)
    edges = {}
    for t in idx:
        for i, j in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
            e = (min(i, j), max(i, j))
            edges[e] = edges.get(e, 0) + 1
    if any(n % 2 for n in edges.values()):
        return None
    roots = np.array([find(i) for i in range(len(pos))])
    return [pos[roots == r] for r in np.unique(roots)]


def capsules(parts):
    """A link's parts with every cylinder merged with the spheres of its radius centred on its
    end caps (within CAP_TOL), as a capsule of its length and radius: their union is exactly that
    capsule, whose distances the oracle's sphere-swept cores give exactly. None when a cylinder is
    left (the Panda's hand: its cylinder is turned 1.57 rad, not pi/2, and its caps are 6e-5 m
    off its spheres' centres). Parts without a cylinder come back as they are (the same list)."""
    if not any(p[0] == CYLINDER for p in parts):
        return parts
    out, covered = [], set()
    for kind, dims, verts, T, *_ in parts:
        if kind != CYLINDER:
            continue
        h, r = dims[0] / 2.0, dims[1]
        for cap in T.apply([[0.0, 0.0, -h], [0.0, 0.0, h]]):
            j = next((j for j, p in enumerate(parts) if p[0] == SPHERE and
                      abs(p[1][0] - r) <= CAP_TOL and np.linalg.norm(p[3].t - cap) <= CAP_TOL),
                     None)
            if j is None:
                return None
            covered.add(j)
        out.append((CAPSULE, [2.0 * h, r], None, T))
    return out + [p for j, p in enumerate(parts) if p[0] != CYLINDER and j not in covered]


def hull_points(v):
    """The hull's vertices (all the points when they are flat: the oracle takes any set)."""
    try:
        return v[ConvexHull(v).vertices]
    except QhullError:  # a flat set: the set itself is exact
        return v


def resolve(uri):
    if uri.startswith('package://'):
        pkg, _, rest = uri[len('package://'):].partition('/')
        return os.path.join(rospkg.RosPack().get_path(pkg), rest)
    if uri.startswith('file://'):
        return uri[len('file://'):]
    raise ValueError('mesh URI neither package:// nor file://: ' + uri)


class Robot:
    """The URDF's links with collision geometry (their parts as sweep_oracle takes them), its
    joints, and the pairs never checked (adjacent or SRDF-disabled) with the reason. With
    `pieces`, a mesh is one part per closed piece (mesh_decomposition "pieces"). `exact` holds
    the links whose union of parts the oracle has exactly (no cylinder, or each one a capsule's
    with its end spheres: capsules()), as those parts."""

    def __init__(self, urdf, srdf, pieces=False):
        root = ET.fromstring(urdf)
        self.parts = {}
        hulls = {}
        for link in root.findall('link'):
            parts = []
            for col in link.findall('collision'):
                T = origin_tf(col)
                g = col.find('geometry')[0]
                if g.tag == 'box':
                    parts.append((BOX, floats(g.get('size'), ()), None, T))
                elif g.tag == 'sphere':
                    parts.append((SPHERE, [float(g.get('radius'))], None, T))
                elif g.tag == 'cylinder':
                    parts.append((CYLINDER, [float(g.get('length')), float(g.get('radius'))],
                                  None, T))
                elif g.tag == 'mesh':
                    path = resolve(g.get('filename'))
                    if path not in hulls:
                        tri = read_stl(path)
                        split = closed_pieces(tri) if pieces else None
                        hulls[path] = [hull_points(v) for v in split or [tri.reshape(-1, 3)]]
                    scale = floats(g.get('scale'), (1, 1, 1))
                    parts += [(MESH, (), v, T, scale) for v in hulls[path]]
                else:
                    raise ValueError('geometry the oracle does not know: ' + g.tag)
            if parts:
                self.parts[link.get('name')] = parts
        self.exact = {link: merged for link, merged in
                      ((link, capsules(parts)) for link, parts in self.parts.items())
                      if merged is not None}
        self.kinematics = Kinematics(root)
        self.never = {}
        # Joined by a joint, links without geometry skipped over: each link's nearest ancestor
        # with geometry.
        for link in self.parts:
            up = self.kinematics.parent.get(link)
            while up is not None and up not in self.parts:
                up = self.kinematics.parent.get(up)
            if up is not None:
                self.never.setdefault(key(link, up), 'adjacent links')
        sroot = ET.fromstring(srdf) if srdf else None
        if sroot is not None:
            assert sroot.find('disable_default_collisions') is None, 'not modelled here'
            for d in sroot.findall('disable_collisions'):
                a, b = d.get('link1').strip(), d.get('link2').strip()
                if a in self.parts and b in self.parts and a != b:
                    self.never.setdefault(key(a, b), 'SRDF <disable_collisions>')

    def contacts(self, q):
        """The pairs checked in contact and within WARNING at joint positions q, by the URDF's
        forward kinematics (in its root link's frame) and the oracle: (contacts, near)."""
        poses = self.kinematics.link_poses(q)
        bodies = {link: make_obody(link, poses[link], self.exact.get(link, parts), 0.0)
                  for link, parts in self.parts.items()}
        balls = {link: ball(b) for link, b in bodies.items()}
        links = sorted(self.parts)
        contacts = near = 0
        for i, a in enumerate(links):
            for b in links[i + 1:]:
                if (a, b) in self.never or ball_gap(balls[a], balls[b]) >= WARNING:
                    continue
                d = body_distance(bodies[a], bodies[b])[0]
                contacts += d <= CONTACT
                near += d < WARNING
        return contacts, near

    def configuration(self, rng, candidates=0):
        """Joint positions: zero clamped into the limits (rng None), random in the limits, or
        of `candidates` random ones the one with the most pairs in contact (then near)."""
        if rng is None or candidates <= 1:
            return self.kinematics.configuration(rng)
        drawn = [self.kinematics.configuration(rng) for _ in range(candidates)]
        scores = [self.contacts(q) for q in drawn]
        return drawn[scores.index(max(scores))]


def as_tf(t):
    r, p = t.transform.rotation, t.transform.translation
    return Tf.from_xyz_q((p.x, p.y, p.z), (r.x, r.y, r.z, r.w))


def ball(body):
    """(centre, radius) of a ball that holds the body."""
    pts = np.concatenate([core for core, _ in body.outer])
    centre = pts.mean(axis=0)
    return centre, max(float(np.linalg.norm(core - centre, axis=1).max()) + r
                       for core, r in body.outer)


def ball_gap(a, b):
    """The gap between two balls (centre, radius): a lower bound of their bodies' distance."""
    return float(np.linalg.norm(a[0] - b[0])) - a[1] - b[1]


def on_surface(body, x):
    """Whether x lies on the surface of one of the body's parts (between the inner and outer
    prisms of a cylinder)."""
    _, _, _, inner, outer = body_sdf(body, x)
    return any(o - SURFACE_TOL <= 0.0 <= i + SURFACE_TOL for i, o in zip(inner, outer))


class RobotOracle(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_robot_oracle')
        cls.configs = rospy.get_param('~configs', 4)
        # Each random configuration is the one of ~candidates drawn with the most pairs in
        # contact (0: the first drawn).
        cls.candidates = rospy.get_param('~candidates', 0)
        # Sides of a cylinder's bracketing prisms: 512 by default; fewer where the robot has
        # many cylinders (the hull of the difference of two has 4 ngon^2 points).
        sweep_oracle.NGON = rospy.get_param('~ngon', sweep_oracle.NGON)
        urdf = rospy.get_param('robot_description')
        srdf = rospy.get_param('robot_description_semantic', '')
        # The monitors: {namespace: {mesh_decomposition: hull or pieces, max_lag: /tf stamps by
        # which a move's event may come late (MAX_LAG by default), ns: the namespace, where it
        # is not the key}}.
        cls.monitors = []
        robots = {}  # one a mesh_decomposition: monitors of the same geometry share its oracle
        default = {'collision_monitor': {'mesh_decomposition': 'hull'}}
        for name, cfg in sorted(rospy.get_param('~monitors', default).items()):
            ns = cfg.get('ns', name)  # a name with '/' would nest the parameter
            m = Monitor('/%s/' % ns)
            m.max_lag = cfg.get('max_lag', MAX_LAG)
            pieces = cfg.get('mesh_decomposition', 'hull') == 'pieces'
            if pieces not in robots:
                robots[pieces] = Robot(urdf, srdf, pieces)
            cls.monitors.append((ns, m, robots[pieces]))
        cls.memo = {}  # the oracle's answers this configuration: (id(robot), when, what) -> value
        cls.robot = cls.monitors[0][2]
        # The links' TF frames: robot_state_publisher's tf_prefix, if it has one, then '/'.
        prefix = rospy.get_param('~tf_prefix', '')

        def frame(link):
            return prefix + '/' + link if prefix else link
        cls.frame = {link: frame(link) for link in cls.robot.parts}
        [root] = cls.robot.kinematics.roots
        cls.fixed = frame(root)
        cls.tf = tf2_ros.Buffer(rospy.Duration(60.0))  # a move's poses are read after it
        cls.listener = tf2_ros.TransformListener(cls.tf)
        # Seconds a move from one configuration to the next takes (0: a jump).
        cls.move_time = rospy.get_param('~move_time', 0.0)
        cls.q_from = cls.q_to = cls.robot.configuration(None)
        cls.t0 = rospy.Time.now()
        cls.lock = threading.Lock()
        cls.tf_stamps = set()  # ns: the stamps of robot_state_publisher's /tf messages
        rospy.Subscriber('/tf', TFMessage, cls.on_tf, queue_size=1000)
        cls.pub = rospy.Publisher('joint_states', JointState, queue_size=10)
        cls.stop = False
        cls.thread = threading.Thread(target=cls.publish_joints, daemon=True)
        cls.thread.start()

    @classmethod
    def tearDownClass(cls):
        cls.stop = True
        cls.thread.join()

    @classmethod
    def on_tf(cls, msg):
        with cls.lock:
            cls.tf_stamps.update(t.header.stamp.to_nsec() for t in msg.transforms)

    @classmethod
    def joints_at(cls, now):
        """The joint positions at `now`: on the straight line from q_from to q_to."""
        f = (now - cls.t0).to_sec() / cls.move_time if cls.move_time > 0 else 1.0
        f = min(1.0, max(0.0, f))
        return {n: a + f * (cls.q_to[n] - a) for n, a in cls.q_from.items()}

    @classmethod
    def publish_joints(cls):
        while not cls.stop and not rospy.is_shutdown():
            with cls.lock:
                now = rospy.Time.now()
                q = cls.joints_at(now)
                msg = JointState(name=list(q), position=list(q.values()))
                msg.header.stamp = now
                cls.pub.publish(msg)
            time.sleep(0.03)

    def hold(self, q):
        """Moves the robot to q (in move_time) and holds it there until every monitor's ~state
        is stamped after it with no link stale; returns the links' poses in the fixed frame, from
        TF, and the move's start and end (ns)."""
        with self.lock:
            now = rospy.Time.now()
            cls = type(self)
            cls.q_from, cls.q_to, cls.t0 = cls.joints_at(now), q, now
            start = now
        since = start + rospy.Duration(self.move_time)
        wait_for(lambda: rospy.Time.now() > since, self.move_time + 5.0)
        for ns, m, _ in self.monitors:
            ok = wait_for(lambda: m.state.header.stamp > since + rospy.Duration(0.05)
                          and not m.state.stale_bodies, 10.0)
            self.assertTrue(ok, '%s did not take the configuration: stale %s' %
                            (ns, list(m.state.stale_bodies)))
        poses = {}
        for link in self.robot.parts:
            # This test's TF buffer, too, at or after the configuration (stamp 0: only fixed
            # joints between the link and the fixed frame).
            def lookup():
                t = self.tf.lookup_transform(self.fixed, self.frame[link], rospy.Time(0),
                                             rospy.Duration(2.0))
                return t if t.header.stamp.is_zero() or t.header.stamp >= since else None
            self.assertTrue(wait_for(lambda: lookup() is not None, 5.0), link)
            poses[link] = as_tf(lookup())
        return poses, (start.to_nsec(), since.to_nsec())

    def test_links_against_the_oracle(self):
        # Each monitor attaches each link to its TF frame, the id being the link's name, and
        # answers in the root link's frame.
        for ns, m, _ in self.monitors:
            self.assertEqual(m.state.header.frame_id, self.fixed, ns)
            r = m.list_bodies()
            self.assertEqual(dict(zip(r.ids, r.frames)), self.frame, ns)
        rng = random.Random(SEED)
        links = sorted(self.robot.parts)
        pairs = [(a, b) for i, a in enumerate(links) for b in links[i + 1:]]
        counts = {ns: {'checked': 0, 'never': 0, 'collision': 0, 'warning': 0, 'curved': 0,
                       'curved, exact': 0, 'configs in contact': 0, 'move events': 0,
                       'move stamps': 0, 'late': []}
                  for ns, _, _ in self.monitors}
        worst = 0.0
        contacts = set()  # 'configuration: pair distance', all monitors'
        statuses = {}  # ns -> {pair: status} at the last configuration
        for c in range(self.configs):
            self.memo.clear()
            poses, move = self.hold(self.robot.configuration(rng if c else None,
                                                             self.candidates))
            for ns, m, robot in self.monitors:
                if c and self.move_time > 0:
                    self.check_move(c, move, pairs, ns, m, robot, statuses[ns], counts[ns])
                worst = max(worst, self.check(c, poses, pairs, ns, m, robot, counts[ns],
                                              contacts))
                statuses[ns] = {key(p.body_a, p.body_b): p.status for p in m.state.pairs}
        rospy.loginfo('robot oracle: %d configurations, %s, largest error on exact parts %.3g m; '
                      'in contact: %s', self.configs, counts, worst, ', '.join(sorted(contacts)))
        # A meaningful sample: pairs checked and pairs refused, some in contact (with
        # ~candidates, in every random configuration) and some near.
        for n in counts.values():
            self.assertGreater(n['checked'], 10, counts)
            self.assertGreater(n['never'], 10, counts)
            self.assertGreaterEqual(n['configs in contact'],
                                    self.configs - 1 if self.candidates > 1 else 1, counts)
            self.assertGreater(n['warning'], 0, counts)
            self.assertGreater(n['probe pairs'], 4 * self.configs, counts)
            self.assertGreater(n['probes in collision'], self.configs // 2, counts)
            if self.move_time > 0:
                self.assertGreater(n['move events'], self.configs, counts)

    def oracle(self, robot, when, what, compute):
        """compute(), once for the monitors that share `robot`'s geometry."""
        k = (id(robot), when, what)
        if k not in self.memo:
            self.memo[k] = compute()
        return self.memo[k]

    def check(self, c, poses, pairs, ns, m, robot, counts, contacts):
        """Every pair of monitor `m` at configuration `c` against the oracle (see the module's
        docstring); returns the largest error on exact parts."""
        worst = 0.0
        bodies = self.oracle(robot, ('config', c), 'bodies', lambda: {
            link: make_obody(link, poses[link], parts, 0.0) for link, parts in robot.parts.items()})
        exact = self.oracle(robot, ('config', c), 'exact bodies', lambda: {
            link: make_obody(link, poses[link], parts, 0.0) for link, parts in robot.exact.items()})
        state = m.state
        listed = {key(p.body_a, p.body_b): p for p in state.pairs}
        min_distance = math.inf
        for a, b in pairs:
            where = '%s, configuration %d, %s / %s' % (ns, c, a, b)
            r = m.get_distance(a, b, '')
            never = robot.never.get((a, b))
            if never is not None:
                counts['never'] += 1
                self.assertFalse(r.success, where)
                self.assertIn('are never checked: the pair is disabled (%s)' % never,
                              r.message, where)
                self.assertNotIn((a, b), listed, where)
                continue
            counts['checked'] += 1
            self.assertTrue(r.success, where + ': ' + r.message)
            hi, _, _, lo = self.oracle(robot, ('config', c), (a, b),
                                       lambda: body_distance(bodies[a], bodies[b]))
            d = r.result.distance
            if bodies[a].approx or bodies[b].approx:
                counts['curved'] += 1
                self.assertTrue(lo - TOL <= d <= hi + TOL, '%s: %.9f not in [%.9f, %.9f]' %
                                (where, d, lo, hi))
                if a in exact and b in exact:
                    # Capsules: their distance is the links' when apart; when they overlap, the
                    # links' (the deepest of their parts' overlaps) is at most theirs.
                    x = self.oracle(robot, ('config', c), ('exact', a, b),
                                    lambda: body_distance(exact[a], exact[b])[0])
                    counts['curved, exact'] += 1
                    if x > CONTACT:
                        self.assertAlmostEqual(d, x, delta=TOL, msg=where + ' (capsules)')
                        worst = max(worst, abs(d - x))
                    else:
                        self.assertTrue(x - TOL <= d <= CONTACT + TOL, '%s: %.9f not in '
                                        '[%.9f, 0] (capsules)' % (where, d, x))
            else:
                self.assertAlmostEqual(d, hi, delta=TOL, msg=where)
                worst = max(worst, abs(d - hi))
            min_distance = min(min_distance, d)
            pa, pb = point(r.result.point_a), point(r.result.point_b)
            n = point(r.result.normal)
            self.assertTrue(on_surface(bodies[a], pa), where + ': point_a off link a')
            self.assertTrue(on_surface(bodies[b], pb), where + ': point_b off link b')
            self.assertAlmostEqual(np.linalg.norm(pb - pa), abs(d), delta=1e-9, msg=where)
            self.assertAlmostEqual(np.linalg.norm(n), 1.0, delta=1e-9, msg=where)
            if abs(d) > 1e-6:
                self.assertAlmostEqual(float(n @ (pb - pa)), d, delta=1e-9, msg=where)
            # ~state at the same poses (the robot holds still).
            p = listed.get((a, b))
            status = p.status if p is not None else PairState.CLEAR
            if d <= CONTACT:
                counts['collision'] += 1
                contacts.add('%d: %s / %s %.4f' % (c, a, b, d))
                self.assertEqual(status, PairState.COLLISION, where)
            elif d < WARNING:
                counts['warning'] += 1
                allowed = {PairState.WARNING}
                if d <= CONTACT + HYSTERESIS:
                    allowed.add(PairState.COLLISION)
                self.assertIn(status, allowed, '%s at %.6f m' % (where, d))
            else:
                allowed = {PairState.CLEAR}
                if d <= WARNING + HYSTERESIS:
                    allowed.add(PairState.WARNING)
                self.assertIn(status, allowed, '%s at %.6f m' % (where, d))
            if p is not None:
                self.assertAlmostEqual(p.distance, d, delta=1e-9, msg=where)
        self.assertEqual(state.in_collision,
                         any(p.status == PairState.COLLISION for p in state.pairs), ns)
        self.assertAlmostEqual(state.min_distance, min_distance, delta=1e-9, msg=ns)
        counts['configs in contact'] += min_distance <= CONTACT
        self.probe(c, poses, ns, m, robot, bodies, counts)
        return worst

    def check_move(self, c, move, pairs, ns, m, robot, before, counts):
        """The events of monitor `m` during the move to configuration `c` against the oracle's
        status machine stepped over every /tf stamp of the move, from the statuses the monitor
        had before it (~state): each event is one the oracle gives on that pair, at the same stamp
        or at most max_lag stamps later (a check that comes late may pass over a stamp), at the
        oracle's distance there, leaving the pair in the oracle's status; and each of the
        oracle's transitions is sent. Pairs of links the oracle has exactly (robot.exact: meshes,
        boxes, spheres, cylinders as capsules with their end spheres) are checked; a link with a
        cylinder of its own is left out. Every threshold is at or above 0, where the capsules'
        distance is the links'; an overlap's depth is the links' parts' deepest, bracketed."""
        start, end = move
        with self.lock:
            timeline = Timeline(t for t in self.tf_stamps if start < t <= end + int(0.2e9))
        stamps = timeline.stamps
        links = sorted(robot.exact)

        def poses(t):
            return self.oracle(robot, ('stamp', t), 'poses', lambda: {
                link: as_tf(self.tf.lookup_transform(self.fixed, self.frame[link],
                                                     rospy.Time(0, t)))
                for link in links})

        bodies = {t: self.oracle(robot, ('stamp', t), 'bodies', lambda: {
            link: make_obody(link, poses(t)[link], robot.exact[link], 0.0) for link in links})
            for t in stamps}
        # A ball about each link (its parts' points and radii) for a cheap lower bound.
        balls = {t: {link: ball(b) for link, b in by_link.items()} for t, by_link in bodies.items()}

        def distance(pair, t):
            return self.oracle(robot, ('stamp', t), pair, lambda: body_distance(
                bodies[t][pair[0]], bodies[t][pair[1]]))[0]

        def near_distance(pair, t):
            """distance(), or inf when the balls are far past every threshold."""
            far = ball_gap(balls[t][pair[0]], balls[t][pair[1]]) > WARNING + HYSTERESIS + 1e-3
            return math.inf if far else distance(pair, t)

        def overlap(pair, t):
            """[lower, upper] bound of the links' distance where their exact forms overlap."""
            x = distance(pair, t)
            if all(robot.exact[link] is robot.parts[link] for link in pair):
                return x, x
            hi, _, _, lo = self.oracle(robot, ('stamp', t), ('parts', pair), lambda: body_distance(
                *(make_obody(link, poses(t)[link], robot.parts[link], 0.0) for link in pair)))
            return max(x, lo), min(hi, CONTACT)

        predicted, status_at = [], {}
        for pair in pairs:
            if pair in robot.never or not set(pair) <= robot.exact.keys():
                continue
            given, at = run(pair, before.get(pair, PairState.CLEAR), stamps,
                            lambda t: near_distance(pair, t))
            predicted += given
            status_at.update(((pair, t), status) for t, status in at.items())
        with m.lock:
            events = [e for _, e in m.events if start < e.header.stamp.to_nsec() <= stamps[-1]]
        actual = [(e.header.stamp.to_nsec(), key(e.pair.body_a, e.pair.body_b), e.type, e)
                  for e in events if set((e.pair.body_a, e.pair.body_b)) <= robot.exact.keys()]
        for t, pair, etype, e in actual:
            where = '%s, move to configuration %d: %s on %s at %.3f' % (
                ns, c, NAMES[etype], pair, t * 1e-9)
            self.assertIn(t, timeline.index, where + ', a stamp /tf did not have')
            n = timeline.lag((t, pair, etype), predicted)
            self.assertTrue(n is not None and n <= m.max_lag, where + ', which the oracle does not '
                            'give (lag %s)' % n)
            if n:  # the oracle's transition n stamps before, at that stamp's distance
                t0 = stamps[timeline.index[t] - n]
                counts['late'].append('%s %s at %.3f: %d late (%.6f m there, %.6f m at %.3f)' % (
                    NAMES[etype], '/'.join(pair), t * 1e-9, n, distance(pair, t0),
                    distance(pair, t), t0 * 1e-9))
            if distance(pair, t) > CONTACT:
                self.assertAlmostEqual(e.pair.distance, distance(pair, t), delta=TOL, msg=where)
            else:
                lo, hi = overlap(pair, t)
                self.assertTrue(lo - TOL <= e.pair.distance <= hi + TOL, '%s: %.9f not in '
                                '[%.9f, %.9f]' % (where, e.pair.distance, lo, hi))
            self.assertEqual(e.pair.status, status_at[(pair, t)], where)
        for p in predicted:
            self.assertTrue(timeline.sent(p, actual, m.max_lag),
                            '%s, move to configuration %d: the oracle gives %s on %s at %.3f, the '
                            'monitor did not send it' % (ns, c, NAMES[p[2]], p[1], p[0] * 1e-9))
        counts['move events'] += len(actual)
        counts['move stamps'] += len(stamps)
        counts['move pairs'] = counts.get('move pairs', 0) + len(
            {p for p in pairs if p not in robot.never and set(p) <= robot.exact.keys()})

    def probe(self, c, poses, ns, m, robot, bodies, counts):
        """~check_collision: spheres near random links, every other one named after a link
        (that link moved there: its never-checked pairs apply), against the oracle."""
        rng = random.Random(SEED + c)
        links = sorted(robot.parts)
        for k in range(PROBES):
            near = rng.choice(links)
            centre = poses[near].t + np.array([rng.uniform(-0.2, 0.2) for _ in range(3)])
            pid = near if k % 2 else ''
            where = '%s, configuration %d, probe %d (%r at %s)' % (ns, c, k, pid, centre)
            body = sphere_body(pid, PROBE_RADIUS, frame=self.fixed, pose_from_topic=False)
            r = m.check_collision(body, pose(*centre), PROBE_MARGIN)
            self.assertTrue(r.success, where + ': ' + r.message)
            sphere = make_obody('probe', Tf(t=centre), [(SPHERE, [PROBE_RADIUS], None, Tf())], 0.0)
            want = {}
            for link in links:
                if link == pid or (pid and key(pid, link) in robot.never):
                    continue
                hi, _, _, lo = self.oracle(robot, ('probe', c, k), link,
                                           lambda: body_distance(sphere, bodies[link]))
                if lo - TOL <= PROBE_MARGIN:
                    want[link] = (lo, hi)
            got = [(p.body_b, p.distance) for p in r.pairs]
            self.assertEqual([d for _, d in got], sorted(d for _, d in got), where)
            for link, d in got:
                self.assertIn(link, want, '%s: %s at %.9f m' % (where, link, d))
                lo, hi = want[link]
                self.assertTrue(lo - TOL <= d <= hi + TOL, '%s: %s at %.9f not in [%.9f, %.9f]' %
                                (where, link, d, lo, hi))
            for link, (lo, hi) in want.items():
                if hi + TOL < PROBE_MARGIN:  # surely within the margin
                    self.assertIn(link, [x for x, _ in got], where)
            self.assertEqual(r.in_collision, any(d <= CONTACT for _, d in got), where)
            counts['probe pairs'] = counts.get('probe pairs', 0) + len(got)
            counts['probes in collision'] = counts.get('probes in collision', 0) + r.in_collision


if __name__ == '__main__':
    rostest.rosrun('collision_monitor', 'robot_oracle', RobotOracle)
