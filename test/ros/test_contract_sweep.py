#!/usr/bin/python3
"""rostest: a randomized, fixed-seed contract sweep of collision_monitor, driven from outside
through a real roscore and compared with an independent oracle (sweep_oracle.py: exact signed
distances of sphere-swept polytopes via qhull).

Each round adds 7-10 random bodies (spheres, boxes, capsules, convex point sets, 1-3 parts with
random part poses, random padding and groups) attached to random static TF frames, posed by
~body_poses in random TF frames, or by a pose_topic; the robot of /robot_description (links on
static TF, robot_padding and robot_link_padding, robot_link_groups, adjacent links, SRDF) stays.
Every monitor listed in ~monitors (each with its own fixed_frame) is then asked: ~state,
~list_bodies, ~get_distance (random pairs and frame_ids, nearest body), ~check_collision (random
probes in random frames, margins, groups, tracked ids). Every answer is compared with the
oracle; all discrepancies are collected, written to ~report (JSON lines) and asserted empty at
the end of each round. Round kinds cycle: dense, sparse (2.5 m: min_distance beyond the broad
phase), far (bodies ~900 m from the origin), dense with BodyPoses twists (time_to_collision of
translating bodies, exact).
Also: test_zx_rotation (time_to_collision of a lever spinning about its body origin),
test_zy_edges (nearest-body ties, a timed pose going stale: UNKNOWN everywhere),
test_zz_dynamic (statuses with hysteresis step by step, the events and their distances, body
replacement keeping / dropping the pose).
Params: ~seed, ~monitors, ~report, ~perturb ('part_x': the oracle flips the x of the
first part's position of each round's first body; the sweep must then fail), ~keep_last.
Needs sweep_oracle.py next to this file (numpy, scipy).
"""
import faulthandler
import io
import json
import math
import pickle
import signal
import os
import random
import sys
import time
import unittest
import xml.etree.ElementTree as ET

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from sweep_oracle import (BOX, CAPSULE, CONE, CONVEX, CYLINDER, MESH, SPHERE, Tf, body_distance, body_sdf,  # noqa: E402
                          make_obody, read_stl, rpy_to_quat, time_to_collision)

import rospy  # noqa: E402
import rostest  # noqa: E402
import tf2_ros  # noqa: E402
from collision_monitor.msg import Body, BodyPoses, CollisionState, PairState, Shape  # noqa: E402
from collision_monitor.srv import CheckCollision, GetDistance, ListBodies  # noqa: E402
from geometry_msgs.msg import Point, Pose, PoseStamped, TransformStamped, Twist  # noqa: E402

TOL_D = 1e-6      # distances and witness points, metres
TOL_N = 1e-5      # normals
TREE = [('a', 'world'), ('b', 'a'), ('c', 'world'), ('d', 'b')]
ROBOT_TF = [('base_link', 'c'), ('arm_link', 'base_link'), ('tool_link', 'arm_link'),
            ('cam_link', 'base_link')]
STATUS = {0: 'CLEAR', 1: 'WARNING', 2: 'COLLISION', 3: 'UNKNOWN'}
ROUNDS = 4  # one of each kind: dense, sparse, far, dense with twists


def rand_quat(rng):
    v = [rng.gauss(0, 1) for _ in range(4)]
    n = math.sqrt(sum(x * x for x in v))
    return tuple(x / n for x in v)


def pose_msg(xyz, q):
    p = Pose()
    p.position.x, p.position.y, p.position.z = (float(v) for v in xyz)
    p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w = (float(v) for v in q)
    return p


def tf_of_pose(p):
    q = (p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w)
    return Tf.from_xyz_q((p.position.x, p.position.y, p.position.z), q)


def vec(p):
    return np.array([p.x, p.y, p.z], float)


def msg_repr(m):
    return str(m).replace('\n', '; ')


class Scene:
    """Everything generated from the seed: frames, bodies, probes; and the oracle's view."""

    def __init__(self, seed):
        self.rng = random.Random(seed)
        self.T = {'world': Tf()}   # frame -> T_world_frame
        self.tf_list = []          # TransformStamped of every static frame so far
        for child, parent in TREE:
            self.add_frame(child, parent, (self.rng.uniform(-0.4, 0.4) for _ in range(3)),
                           rand_quat(self.rng))
        for child, parent in ROBOT_TF:
            xyz = [self.rng.uniform(-0.15, 0.15) for _ in range(3)]
            if child == 'base_link':  # put the robot near the middle of the scene
                T_target = Tf.from_xyz_q([self.rng.uniform(-0.3, 0.3) for _ in range(3)],
                                         rand_quat(self.rng))
                local = self.T[parent].inv() * T_target
                self.add_frame(child, parent, local.t, local.quat())
            else:
                self.add_frame(child, parent, xyz, rand_quat(self.rng))

    def add_frame(self, child, parent, xyz, q):
        xyz = [float(v) for v in xyz]
        t = TransformStamped()
        t.header.stamp = rospy.Time(0)
        t.header.frame_id = parent
        t.child_frame_id = child
        t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = xyz
        (t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z,
         t.transform.rotation.w) = q
        self.tf_list.append(t)
        self.T[child] = self.T[parent] * Tf.from_xyz_q(xyz, q)


MESHES = {}


def mesh_verts(name):
    if name not in MESHES:
        import rospkg
        tri = read_stl(os.path.join(rospkg.RosPack().get_path('collision_monitor'), 'meshes',
                                    name))
        MESHES[name] = np.unique(tri.reshape(-1, 3), axis=0)
    return MESHES[name]


def random_scale(rng):
    r = rng.random()
    if r < 0.4:
        return None
    if r < 0.5:
        return (1.0, 1.0, 1.0)
    sc = [rng.choice([-1, 1]) * rng.uniform(0.5, 2.5) for _ in range(3)]
    if rng.random() < 0.15:
        sc[rng.randrange(3)] = 0.0   # flattens (docs: the hull of the scaled vertices)
    return tuple(sc)


def random_shape(rng, allow_flat=True, probe=False):
    """(Shape msg, (kind, dims, verts, T_part, scale) for the oracle)."""
    kinds = [SPHERE, BOX, CAPSULE, CONVEX, BOX, CONVEX, MESH]
    if probe:
        kinds += [CYLINDER, CONE]
    kind = rng.choice(kinds)
    s = Shape(type=kind)
    verts = None
    scale = None
    if kind in (CYLINDER, CONE):
        dims = [rng.uniform(0.02, 0.3), rng.uniform(0.02, 0.07)]
    elif kind == MESH:
        dims = []
        name = rng.choice(['gripper.stl', 'wrist_shell.stl'])
        s.resource = 'package://collision_monitor/meshes/' + name
        verts = mesh_verts(name)
        scale = random_scale(rng)
        if scale is not None:
            s.scale.x, s.scale.y, s.scale.z = scale
    elif kind == SPHERE:
        dims = [rng.uniform(0.03, 0.15)]
    elif kind == BOX:
        dims = [rng.uniform(0.03, 0.35) for _ in range(3)]
    elif kind == CAPSULE:
        dims = [rng.uniform(0.02, 0.35), rng.uniform(0.02, 0.1)]
    else:
        dims = []
        nv = rng.randint(2, 8) if allow_flat else rng.randint(4, 8)
        verts = [[rng.uniform(-0.12, 0.12) for _ in range(3)] for _ in range(nv)]
        if allow_flat and nv >= 3 and rng.random() < 0.25:  # flat (coplanar) convex part
            for v in verts:
                v[2] = 0.02
        s.vertices = [Point(*v) for v in verts]
        scale = random_scale(rng)
        if scale is not None:
            s.scale.x, s.scale.y, s.scale.z = scale
            if len({tuple(np.round(np.array(v) * scale, 15)) for v in verts}) < 2:
                scale = None
                s.scale.x = s.scale.y = s.scale.z = 0.0
    s.dimensions = dims
    xyz = [rng.uniform(-0.12, 0.12) for _ in range(3)]
    r = rng.random()
    if r < 0.15:
        q = (0.0, 0.0, 0.0, 0.0)            # zero quaternion: identity (Shape.msg)
        qo = (0.0, 0.0, 0.0, 1.0)
    elif r < 0.25:
        q0 = rand_quat(rng)
        q = tuple(v * 1.0004 for v in q0)   # |q| within 1e-3 of 1: normalised (docs)
        qo = q0
    else:
        q = qo = rand_quat(rng)
    s.pose = pose_msg(xyz, q)
    return s, (kind, dims, verts, Tf.from_xyz_q(xyz, qo), scale)


class ContractSweep(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_contract_sweep')
        cls.seed = int(rospy.get_param('~seed', 4040))
        cls.rounds = ROUNDS
        cls.perturb = rospy.get_param('~perturb', '')
        cls.report_path = rospy.get_param('~report', '')
        cls.names = rospy.get_param('~monitors', ['collision_monitor'])
        cls.scene = Scene(cls.seed)
        cls.static_tf = tf2_ros.StaticTransformBroadcaster()
        cls.static_tf.sendTransform(cls.scene.tf_list)
        cls.mon = {}
        for name in cls.names:
            ns = '/' + name + '/'
            for s in ('get_distance', 'check_collision', 'list_bodies'):
                rospy.wait_for_service(ns + s, timeout=30.0)
            m = {
                'ns': ns,
                'gd': rospy.ServiceProxy(ns + 'get_distance', GetDistance, persistent=True),
                'cc': rospy.ServiceProxy(ns + 'check_collision', CheckCollision,
                                         persistent=True),
                'lb': rospy.ServiceProxy(ns + 'list_bodies', ListBodies, persistent=True),
                'bodies': rospy.Publisher(ns + 'bodies', Body, queue_size=1000),
                'poses': rospy.Publisher(ns + 'body_poses', BodyPoses, queue_size=100),
                'fixed': rospy.get_param(ns + 'fixed_frame', 'world').lstrip('/'),
                'W': float(rospy.get_param(ns + 'warning_distance', 0.05)),
                'C': float(rospy.get_param(ns + 'contact_distance', 0.0)),
                'H': float(rospy.get_param(ns + 'hysteresis', 0.005)),
                'robot_padding': float(rospy.get_param(ns + 'robot_padding', 0.0)),
                'link_padding': {k: float(v) for k, v in
                                 rospy.get_param(ns + 'robot_link_padding', {}).items()},
                'link_groups': {k: str(v) for k, v in
                                rospy.get_param(ns + 'robot_link_groups', {}).items()},
                'disabled': {frozenset(p) for p in rospy.get_param(ns + 'disabled_pairs', [])},
                'state': None, 'state_t': 0.0,
            }
            m['sub'] = rospy.Subscriber(ns + 'state', CollisionState, cls._on_state,
                                        callback_args=m, queue_size=5)
            cls.mon[name] = m
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline and not all(
                m['bodies'].get_num_connections() and m['poses'].get_num_connections()
                for m in cls.mon.values()):
            time.sleep(0.05)
        cls.load_robot()
        cls.load_yaml_bodies(cls.mon[cls.names[0]]['ns'])
        cls.pose_topic_pubs = []
        cls.all_problems = []
        cls.counts = {}

    @staticmethod
    def _on_state(msg, m):
        m['state'] = msg
        m['state_t'] = time.monotonic()

    # ------------------------------------------------------------ robot (parsed here, not by the node)
    @classmethod
    def load_robot(cls):
        cls.robot_links = {}   # id -> parts (kind, dims, verts, T_part)
        cls.robot_never = set()
        urdf = rospy.get_param('/robot_description', '')
        if not urdf:
            return
        root = ET.fromstring(urdf)
        for link in root.findall('link'):
            parts = []
            for col in link.findall('collision'):
                o = col.find('origin')
                xyz = [float(v) for v in (o.get('xyz', '0 0 0').split() if o is not None
                                          else '0 0 0'.split())]
                rpy = [float(v) for v in (o.get('rpy', '0 0 0').split() if o is not None
                                          else '0 0 0'.split())]
                T_part = Tf.from_xyz_q(xyz, rpy_to_quat(*rpy))
                g = col.find('geometry')[0]
                if g.tag == 'box':
                    parts.append((BOX, [float(v) for v in g.get('size').split()], None, T_part))
                elif g.tag == 'sphere':
                    parts.append((SPHERE, [float(g.get('radius'))], None, T_part))
                else:
                    raise AssertionError('robot geometry %s not handled by the oracle' % g.tag)
            if parts:
                cls.robot_links[link.get('name')] = parts
        for j in root.findall('joint'):
            p, c = j.find('parent').get('link'), j.find('child').get('link')
            if p in cls.robot_links and c in cls.robot_links:
                cls.robot_never.add(frozenset((p, c)))
        srdf = rospy.get_param('/robot_description_semantic', '')
        if srdf:
            for d in ET.fromstring(srdf).findall('disable_collisions'):
                cls.robot_never.add(frozenset((d.get('link1'), d.get('link2'))))

    @classmethod
    def load_yaml_bodies(cls, ns):
        """The ~bodies parameter, read and converted here (names, numbers, list and dict
        poses), as TF-attached bodies."""
        kinds = {'sphere': SPHERE, 'box': BOX, 'cylinder': CYLINDER, 'cone': CONE,
                 'capsule': CAPSULE, 'convex': CONVEX}
        cls.yaml_bodies = {}

        def xyz(v, keys='xyz', default=0.0):
            if isinstance(v, dict):
                return [float(v.get(k, default)) for k in keys]
            return [float(x) for x in v]
        for b in rospy.get_param(ns + 'bodies', []):
            parts = []
            for p in b['parts']:
                k = p['type']
                k = kinds[k.lower()] if isinstance(k, str) else int(k)
                pose = p.get('pose', {})
                pos = xyz(pose.get('position', [0, 0, 0]))
                q = pose.get('orientation', [0, 0, 0, 1])
                q = [float(q.get(c, 0.0)) for c in 'xyzw'] if isinstance(q, dict) else q
                verts = [xyz(v) for v in p.get('vertices', [])] or None
                scale = xyz(p['scale']) if 'scale' in p else None
                parts.append((k, [float(x) for x in p.get('dimensions', [])], verts,
                              Tf.from_xyz_q(pos, q), scale))
            frame = b.get('frame_id', b.get('header', {}).get('frame_id', '')).lstrip('/')
            cls.yaml_bodies[b['id']] = (frame, b.get('group', ''), float(b.get('padding', 0.0)),
                                        parts)

    # ------------------------------------------------------------ helpers
    def problem(self, kind, m, **details):
        rec = {'round': self.cur_round, 'monitor': m['ns'].strip('/'), 'kind': kind}
        rec.update(details)
        self.problems.append(rec)

    def count(self, key, n=1):
        self.counts[key] = self.counts.get(key, 0) + n

    def group_of(self, m, x):
        """x's group in monitor m: a robot link's from m's robot_link_groups, else the body's."""
        if x in self.robot_links:
            return m['link_groups'].get(x, '')
        return self.groups[x]

    def permitted(self, m, a, b):
        if a == b:
            return False
        ga, gb = self.group_of(m, a), self.group_of(m, b)
        if ga and ga == gb:
            return False
        if frozenset((a, b)) in m['disabled'] or frozenset((a, b)) in self.robot_never:
            return False
        return True

    def oracle_pair(self, a, b):
        key = (a, b)
        if key not in self.dcache:
            self.dcache[key] = body_distance(self.ob[a], self.ob[b])
        return self.dcache[key]

    def expected_status(self, m, d):
        if d <= m['C']:
            return 2
        if d < m['W']:
            return 1
        return 0

    def near_threshold(self, m, d):
        return (abs(d - m['C']) < 1e-6 or abs(d - m['W']) < 1e-6)

    def check_pair(self, m, ps, oa, ob, T_world_frame, ctx, check_status=True):
        """Compares a PairState with the oracle's answer for bodies oa, ob (OBody); points and
        normal expected in the frame T_world_frame."""
        self.count('pairs compared')
        d, n, gap, dlo = body_distance(oa, ob)
        approx = dlo != d
        info = dict(ctx, body_a=ps.body_a, body_b=ps.body_b, node_distance=ps.distance,
                    oracle_distance=d)
        if approx:
            info['oracle_lower_bound'] = dlo
            self.count('pairs compared with curved parts (bracketed)')
            gap = 0.0   # no normal check
            if not (dlo - TOL_D <= ps.distance <= d + TOL_D):
                self.problem('distance (outside the bracket)', m, **info)
                return
        elif not abs(ps.distance - d) <= TOL_D:
            self.problem('distance', m, **info)
            return
        if check_status and not self.near_threshold(m, d) and not (
                approx and min(dlo, d) - TOL_D <= m['C'] <= d + TOL_D or
                approx and dlo - TOL_D <= m['W'] <= d + TOL_D):
            st = self.expected_status(m, d)
            if ps.status != st:
                self.problem('status', m, node_status=STATUS.get(ps.status, ps.status),
                             oracle_status=STATUS[st], **info)
        nn = vec(ps.normal)
        n_f = T_world_frame.inv().rot(n)
        if not abs(np.linalg.norm(nn) - 1.0) <= TOL_N:
            self.problem('normal not unit', m, node_normal=nn.tolist(), **info)
        elif gap > 1e-6 and not np.linalg.norm(nn - n_f) <= TOL_N:
            self.problem('normal', m, node_normal=nn.tolist(), oracle_normal=n_f.tolist(), **info)
        if ctx.get('query') != 'check_collision' and not approx:
            va = self.twists.get(oa.id, np.zeros(3))
            vb = self.twists.get(ob.id, np.zeros(3))
            key = ('ttc', oa.id, ob.id)
            if key not in self.dcache:
                self.dcache[key] = time_to_collision(oa, ob, va, vb, m['C'])
            t = self.dcache[key]
            self.count('time_to_collision compared')
            tn = ps.time_to_collision
            if not ((math.isinf(t) and math.isinf(tn) and tn > 0) or
                    (not math.isinf(t) and abs(tn - t) <= 1e-6 * max(1.0, t))):
                self.problem('time_to_collision', m, node_ttc=tn, oracle_ttc=t,
                             v_a=va.tolist(), v_b=vb.tolist(), **info)
        pa_w = T_world_frame.apply(vec(ps.point_a))
        pb_w = T_world_frame.apply(vec(ps.point_b))
        sep = float(np.linalg.norm(pb_w - pa_w))
        if not abs(sep - abs(ps.distance if approx else d)) <= TOL_D:
            self.problem('|point_b - point_a| != |distance|', m, node_sep=sep, **info,
                         point_a=vec(ps.point_a).tolist(), point_b=vec(ps.point_b).tolist())
        for label, p_w, body in (('point_a', pa_w, oa), ('point_b', pb_w, ob)):
            smin, sabs, somin, vin, vout = body_sdf(body, p_w)
            if d > 0:
                on = somin <= TOL_D and smin >= -TOL_D
            else:
                on = any(o <= TOL_D and i >= -TOL_D for i, o in zip(vin, vout))
            if not on:
                self.problem(label + ' not on its body', m, sdf_union=smin, sdf_nearest_part=sabs,
                             node_point=getattr(ps, label).__repr__().replace('\n', ' '),
                             point_world=p_w.tolist(), **info)
        if gap > 1e-6 and abs(d) > 1e-9 and not approx:
            if not np.linalg.norm((pb_w - pa_w) - d * n) <= 10 * TOL_D:
                self.problem('point_b - point_a != distance * normal', m,
                             diff=((pb_w - pa_w) - d * n).tolist(), **info)

    # ------------------------------------------------------------ one round
    def build_round(self, r):
        rng = self.scene.rng
        self.cur_round = r
        nb = rng.randint(7, 10)
        mode = ['dense', 'sparse', 'far', 'dense_twist'][r % 4]
        self.mode = mode
        self.center = np.array([700.0, -400.0, 250.0]) if mode == 'far' else np.zeros(3)
        self.spread = 2.5 if mode == 'sparse' else 0.45
        self.twists = {}           # id -> linear velocity in world (angular 0)
        self.count('rounds ' + mode)
        self.round_bodies = []     # Body messages
        self.pose_msgs = []        # BodyPoses messages to (re)publish
        self.expect_frames = {}
        self.groups = {k: '' for k in self.robot_links}
        self.ob = {}
        by_frame = {}
        topic_pose = None
        tree_frames = [f for f, _ in TREE] + [f for f, _ in ROBOT_TF]
        new_frames = []
        for i in range(nb):
            bid = 'r%db%d' % (r, i)
            kind = ('pose_topic' if i == nb - 1 else
                    rng.choice(['tf_leaf', 'tf_leaf', 'tf_tree', 'poses', 'poses']))
            b = Body(id=bid, operation=Body.ADD)
            b.group = rng.choice(['', '', '', 'g1', 'g2'])
            b.padding = 0.0 if rng.random() < 0.4 else rng.uniform(0.0, 0.04)
            parts = [random_shape(rng) for _ in range(rng.randint(1, 3))]
            b.parts = [p[0] for p in parts]
            oparts = [p[1] for p in parts]
            if self.perturb == 'part_x' and i == 0:
                k, dims, verts, Tp, sc = oparts[0]
                Tp2 = Tf(Tp.R, Tp.t * np.array([-1.0, 1.0, 1.0]))
                oparts[0] = (k, dims, verts, Tp2, sc)
            desired = Tf.from_xyz_q(self.center + [rng.uniform(-self.spread, self.spread)
                                                   for _ in range(3)], rand_quat(rng))
            if mode == 'far' and kind == 'tf_tree':
                kind = 'tf_leaf'
            if kind == 'tf_leaf':
                parent = rng.choice(tree_frames + ['world'])
                frame = 'r%df%d' % (r, i)
                local = self.scene.T[parent].inv() * desired
                self.scene.add_frame(frame, parent, local.t, local.quat())
                new_frames.append(frame)
                b.header.frame_id = ('/' + frame) if rng.random() < 0.3 else frame
                self.expect_frames[bid] = frame
                T_wb = self.scene.T[frame]
            elif kind == 'tf_tree':
                frame = rng.choice(tree_frames[:4] + ['world'])
                b.header.frame_id = frame
                self.expect_frames[bid] = frame
                T_wb = self.scene.T[frame]
            else:
                b.pose_from_topic = True
                decl = rng.choice(['', 'declared_%d' % i, '/slash_%d' % i])
                b.header.frame_id = decl
                self.expect_frames[bid] = decl.lstrip('/')
                pf = rng.choice(tree_frames + ['world'])
                p = pose_msg((self.scene.T[pf].inv() * desired).t,
                             (self.scene.T[pf].inv() * desired).quat())
                T_wb = self.scene.T[pf] * tf_of_pose(p)
                if kind == 'poses':
                    tw = None
                    if mode == 'dense_twist' and rng.random() < 0.7:
                        tw = np.array([rng.uniform(-0.5, 0.5) for _ in range(3)])
                        self.twists[bid] = self.scene.T[pf].rot(tw)
                    by_frame.setdefault(pf, []).append((bid, p, tw))
                else:
                    b.pose_topic = 'cs_pose_r%d' % r
                    ps = PoseStamped()
                    ps.header.frame_id = pf
                    ps.header.stamp = rospy.Time(0)
                    ps.pose = p
                    topic_pose = ps
            self.round_bodies.append(b)
            self.groups[bid] = b.group
            self.ob[bid] = make_obody(bid, T_wb, oparts, b.padding, b.group)
            self.count('bodies')
            self.count('parts', len(parts))
            self.count('bodies ' + kind)
        for f, lst in sorted(by_frame.items()):
            msg = BodyPoses()
            msg.header.frame_id = f
            msg.header.stamp = rospy.Time(0)
            msg.ids = [x[0] for x in lst]
            msg.poses = [x[1] for x in lst]
            if any(x[2] is not None for x in lst):
                for x in lst:
                    t = Twist()
                    if x[2] is not None:
                        t.linear.x, t.linear.y, t.linear.z = (float(v) for v in x[2])
                    msg.twists.append(t)
            self.pose_msgs.append(msg)
        self.topic_pose = topic_pose
        self.new_frames = new_frames

    def oracle_robot(self, m):
        ob = {}
        for bid, (frame, group, pad, parts) in self.yaml_bodies.items():
            ob[bid] = make_obody(bid, self.scene.T[frame], parts, pad, group)
            self.groups[bid] = group
            self.expect_frames[bid] = frame
        for lid, parts in self.robot_links.items():
            pad = m['link_padding'].get(lid, m['robot_padding'])
            ob[lid] = make_obody(lid, self.scene.T[lid], parts, pad, '')
        return ob

    def run_round(self, r):
        self.problems = []
        self.build_round(r)
        self.static_tf.sendTransform(self.scene.tf_list)
        pub = None
        if self.topic_pose is not None:
            pub = rospy.Publisher('/cs_pose_r%d' % r, PoseStamped, queue_size=1, latch=True)
            pub.publish(self.topic_pose)
            self.pose_topic_pubs.append(pub)
        time.sleep(0.3)   # static TF first (BodyPoses in unknown frames are refused)
        for m in self.mon.values():
            for b in self.round_bodies:
                m['bodies'].publish(b)
        ids = [b.id for b in self.round_bodies]
        ready = {}
        deadline = time.monotonic() + 15.0
        while time.monotonic() < deadline and len(ready) < len(self.mon):
            for name, m in self.mon.items():
                for msg in self.pose_msgs:
                    m['poses'].publish(msg)
                if pub is not None:
                    pub.publish(self.topic_pose)
                lb = m['lb']()
                listed = dict(zip(lb.ids, lb.stale))
                if all(i in listed and not listed[i] for i in ids):
                    ready[name] = True
            time.sleep(0.2)
        for name, m in self.mon.items():
            if name not in ready:
                lb = m['lb']()
                self.problem('bodies not listed fresh within 15 s', m,
                             listed=list(lb.ids), stale=list(lb.stale))
        if len(ready) < len(self.mon):
            return
        t_ready = time.monotonic()
        time.sleep(0.4)
        for name, m in self.mon.items():
            self.dcache = {}
            self.ob.update(self.oracle_robot(m))
            self.query_monitor(m, t_ready)
        if self.problems and self.report_path:
            with open(self.report_path + '.round%d.txt' % r, 'w') as f:
                f.write('# static TF (parent -> child)\n')
                for tr in self.scene.tf_list:
                    f.write(msg_repr(tr) + '\n')
                f.write('# bodies\n')
                for b in self.round_bodies:
                    f.write(msg_repr(b) + '\n')
                f.write('# body_poses\n')
                for p in self.pose_msgs:
                    f.write(msg_repr(p) + '\n')
                f.write('# pose_topic\n' + msg_repr(self.topic_pose) + '\n')
            def ser(msg):
                b = io.BytesIO()
                msg.serialize(b)
                return b.getvalue()
            with open(self.report_path + '.round%d.pkl' % r, 'wb') as f:
                pickle.dump({'tf': [ser(x) for x in self.scene.tf_list],
                             'bodies': [ser(b) for b in self.round_bodies],
                             'poses': [ser(p) for p in self.pose_msgs],
                             'topic_pose': ser(self.topic_pose) if self.topic_pose else None,
                             'T': {k: (v.R, v.t) for k, v in self.scene.T.items()},
                             'ob': {k: (v.parts, getattr(v, 'outer', None), v.group)
                                    for k, v in self.ob.items()}}, f)

    # ------------------------------------------------------------ the queries
    def query_monitor(self, m, t_ready):
        rng = self.scene.rng
        T_fixed = self.scene.T[m['fixed']]
        all_ids = sorted(self.ob)
        round_ids = [b.id for b in self.round_bodies]
        # ---- ~list_bodies
        lb = m['lb']()
        self.count('list_bodies calls')
        if list(lb.ids) != all_ids:
            self.problem('list_bodies ids', m, node=list(lb.ids), oracle=all_ids)
        else:
            for i, bid in enumerate(lb.ids):
                ef = self.expect_frames.get(bid, bid)  # robot link: its own frame
                if lb.frames[i] != ef:
                    self.problem('list_bodies frame', m, id=bid, node=lb.frames[i], oracle=ef)
                if lb.groups[i] != self.group_of(m, bid):
                    self.problem('list_bodies group', m, id=bid, node=lb.groups[i],
                                 oracle=self.group_of(m, bid))
                if lb.stale[i]:
                    self.problem('list_bodies stale', m, id=bid)
        # ---- ~state
        deadline = time.monotonic() + 3.0
        while m['state_t'] < t_ready + 0.25 and time.monotonic() < deadline:
            time.sleep(0.02)
        st = m['state']
        self.count('state messages compared')
        perm = [(a, b) for i, a in enumerate(all_ids) for b in all_ids[i + 1:]
                if self.permitted(m, a, b)]
        dists = {frozenset(p): self.oracle_pair(*p)[0] for p in perm}
        if st.header.frame_id != m['fixed']:
            self.problem('state frame', m, node=st.header.frame_id, oracle=m['fixed'])
        if st.num_bodies != len(all_ids):
            self.problem('state num_bodies', m, node=st.num_bodies, oracle=len(all_ids))
        if list(st.stale_bodies):
            self.problem('state stale_bodies', m, node=list(st.stale_bodies))
        omin = min(dists.values()) if dists else float('inf')
        if not abs(st.min_distance - omin) <= TOL_D:
            argmin = min(dists, key=dists.get)
            self.problem('state min_distance', m, node=st.min_distance, oracle=omin,
                         oracle_pair=sorted(argmin))
        oin = any(d <= m['C'] for d in dists.values())
        if st.in_collision != oin:
            self.problem('state in_collision', m, node=st.in_collision, oracle=oin)
        listed = {}
        for ps in st.pairs:
            key = frozenset((ps.body_a, ps.body_b))
            listed[key] = ps
            if key not in dists:
                self.problem('state lists a pair never checked', m, pair=sorted(key),
                             status=ps.status, distance=ps.distance)
                continue
            self.check_pair(m, ps, self.ob[ps.body_a], self.ob[ps.body_b], T_fixed,
                            {'query': 'state'})
        for key, d in dists.items():
            if d < m['W'] and not self.near_threshold(m, d) and key not in listed:
                self.problem('state misses a pair', m, pair=sorted(key), oracle_distance=d,
                             oracle_status=STATUS[self.expected_status(m, d)])
        # ---- ~get_distance: random pairs in random frames
        frames = ['', '', m['fixed'], 'world', 'a', 'b', 'c', 'd', 'base_link', 'tool_link'] + \
            self.new_frames
        for k in range(14):
            a = rng.choice(round_ids if rng.random() < 0.8 else all_ids)
            b = rng.choice([x for x in all_ids if x != a])
            f = rng.choice(frames)
            self.gd_check(m, a, b, f)
        # forbidden pairs on purpose (same group / disabled) when there are any
        forb = [(a, b) for i, a in enumerate(all_ids) for b in all_ids[i + 1:]
                if not self.permitted(m, a, b)]
        for a, b in rng.sample(forb, min(4, len(forb))):
            self.gd_check(m, a, b, '')
        # nearest body
        for a in round_ids + rng.sample(list(self.robot_links), min(2, len(self.robot_links))):
            self.gd_nearest(m, a, rng.choice(frames))
        # a frame_id that TF does not know
        res = m['gd'](body_a=round_ids[0], body_b=round_ids[1], frame_id='no_such_frame')
        self.count('get_distance calls')
        if res.success:
            self.problem('get_distance unknown frame_id succeeded', m, result=msg_repr(res))
        # unknown id
        res = m['gd'](body_a='no_such_body', body_b=round_ids[0], frame_id='')
        self.count('get_distance calls')
        if res.success:
            self.problem('get_distance unknown id succeeded', m, result=msg_repr(res))
        # ---- ~check_collision
        for k in range(10):
            self.cc_check(m, k)

    def gd_check(self, m, a, b, f):
        res = m['gd'](body_a=a, body_b=b, frame_id=f)
        self.count('get_distance calls')
        ok = self.permitted(m, a, b)
        ctx = {'query': 'get_distance', 'request': {'body_a': a, 'body_b': b, 'frame_id': f}}
        if res.success != ok:
            self.problem('get_distance success', m, node=res.success, oracle=ok,
                         message=res.message, groups=[self.group_of(m, a), self.group_of(m, b)], **ctx)
            return
        if not ok:
            r = res.result
            if r.status != PairState.UNKNOWN or not math.isinf(r.distance):
                self.problem('get_distance refused pair result', m, result=msg_repr(r), **ctx)
            return
        if (res.result.body_a, res.result.body_b) != (a, b):
            self.problem('get_distance ids', m, node=[res.result.body_a, res.result.body_b],
                         **ctx)
            return
        T = self.scene.T[f or m['fixed']]
        self.check_pair(m, res.result, self.ob[a], self.ob[b], T, ctx)

    def gd_nearest(self, m, a, f):
        res = m['gd'](body_a=a, body_b='', frame_id=f)
        self.count('get_distance calls (nearest)')
        cands = {b: self.oracle_pair(a, b)[0] for b in self.ob if self.permitted(m, a, b)}
        ctx = {'query': 'get_distance nearest', 'request': {'body_a': a, 'body_b': '',
                                                             'frame_id': f}}
        if not cands:
            if res.success:
                self.problem('nearest with no candidate succeeded', m, result=msg_repr(res), **ctx)
            return
        dmin = min(cands.values())
        best = sorted(b for b, d in cands.items() if d <= dmin + 1e-7)
        if not res.success:
            self.problem('get_distance nearest failed', m, message=res.message, **ctx)
            return
        if res.result.body_b not in best:
            self.problem('nearest body', m, node=res.result.body_b,
                         node_distance=res.result.distance, oracle=best[0], oracle_distance=dmin,
                         **ctx)
            return
        T = self.scene.T[f or m['fixed']]
        self.check_pair(m, res.result, self.ob[a], self.ob[res.result.body_b], T, ctx)

    def cc_check(self, m, k):
        rng = self.scene.rng
        round_ids = [b.id for b in self.round_bodies]
        body = Body(operation=Body.ADD)
        r = rng.random()
        if r < 0.25:
            body.id = rng.choice(round_ids + list(self.robot_links))   # a tracked body, moved
        elif r < 0.5:
            body.id = ''
        else:
            body.id = 'probe%d' % k
        body.group = rng.choice(['', '', 'g1', 'g2'])
        body.padding = 0.0 if rng.random() < 0.5 else rng.uniform(0.0, 0.04)
        parts = [random_shape(rng, probe=True) for _ in range(rng.randint(1, 2))]
        body.parts = [p[0] for p in parts]
        frame = rng.choice(['', 'world', 'a', 'b', 'c', 'd', 'arm_link'] + self.new_frames)
        body.header.frame_id = frame
        desired = Tf.from_xyz_q(self.center + [rng.uniform(-self.spread, self.spread)
                                               for _ in range(3)], rand_quat(rng))
        Tf_frame = self.scene.T[frame or m['fixed']]
        local = Tf_frame.inv() * desired
        if rng.random() < 0.1:
            pose = pose_msg(local.t, (0.0, 0.0, 0.0, 0.0))   # zero quaternion: identity
            local = Tf(np.eye(3), local.t)
        else:
            pose = pose_msg(local.t, local.quat())
        margin = rng.choice([rng.uniform(0.0, 0.4), rng.uniform(0.0, 0.4), 0.0, -0.05])
        probe = make_obody(body.id or 'check_collision', Tf_frame * local,
                           [p[1] for p in parts], body.padding, body.group)
        try:
            res = m['cc'](body=body, pose=pose, margin=margin)
        except Exception as e:  # noqa: BLE001 (a transport error is a finding)
            self.problem('check_collision call raised', m, error=repr(e),
                         request=msg_repr(body) + '; pose: ' + msg_repr(pose) +
                         '; margin: %r' % margin)
            m['cc'] = rospy.ServiceProxy(m['ns'] + 'check_collision', CheckCollision,
                                         persistent=True)
            return
        self.count('check_collision calls')
        ctx = {'query': 'check_collision', 'request': {
            'id': body.id, 'group': body.group, 'frame_id': frame, 'margin': margin,
            'padding': body.padding, 'pose': msg_repr(pose),
            'parts': [msg_repr(s) for s in body.parts]}}
        if not res.success:
            self.problem('check_collision failed', m, message=res.message, **ctx)
            return
        tracked = body.id in self.ob
        exp, expl = {}, {}
        for b, ob in self.ob.items():
            if tracked and b == body.id:
                continue
            if body.group and body.group == self.group_of(m, b):
                continue
            if tracked:
                if not self.permitted(m, body.id, b):
                    continue
            d, _, _, dlo = body_distance(probe, ob)
            exp[b] = d
            expl[b] = dlo
        want = {b: d for b, d in exp.items() if d <= margin or d <= m['C']}
        got = [ps.body_b if ps.body_a == (body.id or 'check_collision') else ps.body_a
               for ps in res.pairs]
        amb = {b for b, d in exp.items()
               if any(expl[b] - 1e-6 <= x <= d + 1e-6 for x in (margin, m['C']))}
        if set(got) - amb != set(want) - amb:
            self.problem('check_collision pair set', m, node=sorted(got),
                         oracle=sorted(want),
                         missing={b: want[b] for b in set(want) - set(got)},
                         extra={b: exp.get(b) for b in set(got) - set(want)}, **ctx)
        oin = any(d <= m['C'] for d in exp.values())
        if res.in_collision != oin and not any(expl[b] - 1e-6 <= m['C'] <= exp[b] + 1e-6
                                               for b in exp):
            self.problem('check_collision in_collision', m, node=res.in_collision, oracle=oin,
                         **ctx)
        dl = [ps.distance for ps in res.pairs]
        if dl != sorted(dl):
            self.problem('check_collision not sorted', m, node=dl, **ctx)
        T_fixed = self.scene.T[m['fixed']]
        for ps in res.pairs:
            pid = body.id or 'check_collision'
            if ps.body_a == pid and ps.body_b in self.ob:
                self.check_pair(m, ps, probe, self.ob[ps.body_b], T_fixed, ctx)
            elif ps.body_b == pid and ps.body_a in self.ob:
                self.check_pair(m, ps, self.ob[ps.body_a], probe, T_fixed, ctx)
            else:
                self.problem('check_collision pair ids', m, pair=[ps.body_a, ps.body_b], **ctx)

    # ------------------------------------------------------------ tests
    def _round(self, r):
        t0 = time.monotonic()
        try:
            self.run_round(r)
        finally:  # the round's bodies go, also after a failure (the next round's oracle lacks them)
            if not (rospy.get_param('~keep_last', False) and r == self.rounds - 1):
                ids = {b.id for b in getattr(self, 'round_bodies', [])}
                for m in self.mon.values():
                    for i in ids:
                        m['bodies'].publish(Body(id=i, operation=Body.REMOVE))
                deadline = time.monotonic() + 10.0
                for m in self.mon.values():
                    while time.monotonic() < deadline and set(m['lb']().ids) & ids:
                        time.sleep(0.05)
        self.count('round seconds', time.monotonic() - t0)
        self.all_problems.extend(self.problems)
        if self.report_path:
            with open(self.report_path, 'a') as f:
                for p in self.problems:
                    f.write(json.dumps(p, default=str) + '\n')
                f.write(json.dumps({'round': r, 'counts': self.counts}) + '\n')
        # What was compared so far (cumulative), in the test's output (rosunit-contract_sweep.xml).
        print('contract sweep after round %d: %s' % (r, json.dumps(self.counts, sort_keys=True)),
              flush=True)
        self.assertEqual(self.problems, [], '%d discrepancies in round %d, first: %s' % (
            len(self.problems), r, json.dumps(self.problems[:3], default=str)))


    # ------------------------------------------------------------ time_to_collision, rotating body
    def test_zx_rotation(self):
        """A lever (box on a 1 m arm) spinning at 1 rad/s about its body origin's z axis towards
        a sphere: time_to_collision against the oracle (bisection on the exact distance of the
        lever turned about its origin; translating-only bodies are covered by the rounds)."""
        self.cur_round = 'rotation'
        self.problems = []
        lever = Body(id='rot_lever', operation=Body.ADD, pose_from_topic=True,
                     parts=[Shape(type=BOX, dimensions=[1.0, 0.05, 0.05])])
        lever.parts[0].pose.position.x = 0.5
        lever.parts[0].pose.orientation.w = 1.0
        target = Body(id='rot_target', operation=Body.ADD, pose_from_topic=True,
                      parts=[Shape(type=SPHERE, dimensions=[0.1])])
        target.parts[0].pose.orientation.w = 1.0
        origin = np.array([-40.0, 3.0, 0.0])
        msg = BodyPoses()
        msg.header.frame_id = 'world'
        msg.ids = ['rot_lever', 'rot_target']
        msg.poses = [pose_msg(origin, (0, 0, 0, 1)),
                     pose_msg(origin + [0.3, 0.7, 0.0], (0, 0, 0, 1))]
        tw = Twist()
        tw.angular.z = 1.0
        msg.twists = [tw, Twist()]
        for m in self.mon.values():
            m['bodies'].publish(lever)
            m['bodies'].publish(target)
        time.sleep(0.5)
        for n, m in self.mon.items():
            res = None
            for _ in range(40):
                m['poses'].publish(msg)
                time.sleep(0.05)
                res = m['gd'](body_a='rot_lever', body_b='rot_target', frame_id='')
                if res.success:
                    break

            def dist(theta):
                c, s_ = math.cos(theta), math.sin(theta)
                R = np.array([[c, -s_, 0], [s_, c, 0], [0, 0, 1.0]])
                a = make_obody('l', Tf(R, origin), [(BOX, [1.0, 0.05, 0.05], None,
                                                     Tf(np.eye(3), [0.5, 0, 0]))], 0.0)
                b = make_obody('t', Tf(np.eye(3), origin + [0.3, 0.7, 0.0]),
                               [(SPHERE, [0.1], None, Tf())], 0.0)
                return body_distance(a, b)[0]
            C = m['C']
            th = 0.0
            while dist(th + 0.01) > C:
                th += 0.01
            lo, hi = th, th + 0.01
            for _ in range(60):
                mid = (lo + hi) / 2
                if dist(mid) > C:
                    lo = mid
                else:
                    hi = mid
            self.count('rotation ttc compared')
            if not res.success or abs(res.result.time_to_collision - hi) > 1e-6:
                self.problem('time_to_collision (rotating about the body origin)', m,
                             node=res.result.time_to_collision if res else None, oracle=hi,
                             distance=res.result.distance if res else None,
                             oracle_distance=dist(0.0), request=msg_repr(msg))
        for m in self.mon.values():
            for b in ('rot_lever', 'rot_target'):
                m['bodies'].publish(Body(id=b, operation=Body.REMOVE))
        time.sleep(0.3)
        if self.report_path:
            with open(self.report_path, 'a') as f:
                for p in self.problems:
                    f.write(json.dumps(p, default=str) + '\n')
        self.assertEqual(self.problems, [], json.dumps(self.problems, default=str))

    # ------------------------------------------------------------ ties, stale poses, slashes
    def test_zy_edges(self):
        """Nearest-body ties (smallest id), a pose gone stale (UNKNOWN pairs everywhere, never
        clear), and what a leading '/' in request frames does (recorded, not asserted)."""
        self.cur_round = 'edges'
        self.problems = []
        self.observations = []
        self.twists = {}
        self.groups = {k: '' for k in self.robot_links}
        self.scene.add_frame('tie_frame', 'world', (-30.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
        self.scene.add_frame('stale_frame', 'world', (30.0, 0.5, 0.0), (0.0, 0.0, 0.0, 1.0))
        self.static_tf.sendTransform(self.scene.tf_list)
        time.sleep(0.3)

        def sph(bid, r, frame='', topic=False):
            b = Body(id=bid, operation=Body.ADD, pose_from_topic=topic,
                     parts=[Shape(type=SPHERE, dimensions=[r])])
            b.parts[0].pose.orientation.w = 1.0
            b.header.frame_id = frame
            return b
        bodies = [sph('tie_c', 0.1, 'tie_frame'), sph('tie_q', 0.1, topic=True),
                  sph('tie_p', 0.1, topic=True), sph('st_y', 0.1, 'stale_frame'),
                  sph('st_x', 0.1, topic=True)]
        ties = BodyPoses()
        ties.header.frame_id = 'tie_frame'
        ties.ids = ['tie_q', 'tie_p']
        ties.poses = [pose_msg((1.0, 0, 0), (0, 0, 0, 1)), pose_msg((-1.0, 0, 0), (0, 0, 0, 1))]
        for m in self.mon.values():
            for b in bodies:
                m['bodies'].publish(b)
        time.sleep(0.5)

        def stale_pose():
            msg = BodyPoses()
            msg.header.frame_id = 'world'
            msg.header.stamp = rospy.Time.now()
            msg.ids = ['st_x']
            msg.poses = [pose_msg((30.0, 0.0, 0.0), (0, 0, 0, 1))]
            return msg
        for n, m in self.mon.items():
            ok = False
            for _ in range(40):
                m['poses'].publish(ties)
                m['poses'].publish(stale_pose())
                time.sleep(0.05)
                r1 = m['gd'](body_a='tie_c', body_b='', frame_id='')
                r2 = m['gd'](body_a='st_y', body_b='st_x', frame_id='')
                if r1.success and r2.success:
                    ok = True
                    break
            if not ok:
                self.problem('edges: bodies not ready', m, r1=msg_repr(r1), r2=msg_repr(r2))
                continue
            # ties: tie_p and tie_q are both exactly 0.8 m from tie_c
            if r1.result.body_b != 'tie_p' or abs(r1.result.distance - 0.8) > 1e-9:
                self.problem('nearest body tie (smallest id)', m, node=r1.result.body_b,
                             node_distance=r1.result.distance, oracle='tie_p', oracle_distance=0.8)
            if abs(r2.result.distance - 0.3) > 1e-9:
                self.problem('edges: fresh timed pose distance', m, node=r2.result.distance,
                             oracle=0.3)
        # let st_x go stale (pose_timeout 0.5 s by default)
        time.sleep(1.5)
        for n, m in self.mon.items():
            lb = m['lb']()
            if 'st_x' not in lb.ids or not lb.stale[lb.ids.index('st_x')]:
                self.problem('stale: list_bodies stale flag', m, listed=list(zip(lb.ids, lb.stale)))
            t0 = time.monotonic()
            while m['state_t'] < t0 + 0.25 and time.monotonic() < t0 + 3:
                time.sleep(0.02)
            st = m['state']
            if list(st.stale_bodies) != ['st_x']:
                self.problem('stale: state.stale_bodies', m, node=list(st.stale_bodies),
                             oracle=['st_x'])
            others = sorted(list(self.robot_links) + list(self.yaml_bodies) +
                            ['tie_c', 'tie_p', 'tie_q', 'st_y'])
            unk = sorted((p.body_b if p.body_a == 'st_x' else p.body_a) for p in st.pairs
                         if 'st_x' in (p.body_a, p.body_b))
            if unk != others:
                self.problem('stale: state UNKNOWN pairs of st_x', m, node=unk, oracle=others)
            for p in st.pairs:
                if 'st_x' in (p.body_a, p.body_b) and (p.status != PairState.UNKNOWN or
                                                       not math.isinf(p.distance)):
                    self.problem('stale: state pair not UNKNOWN/+inf', m, pair=msg_repr(p))
            r = m['gd'](body_a='st_y', body_b='st_x', frame_id='')
            if r.success or r.result.status != PairState.UNKNOWN or \
                    not math.isinf(r.result.distance):
                self.problem('stale: get_distance', m, result=msg_repr(r))
            r = m['gd'](body_a='st_y', body_b='', frame_id='')
            if r.success:
                self.problem('stale: nearest body while a candidate is stale', m,
                             result=msg_repr(r))
            probe = sph('', 0.05)
            cres = m['cc'](body=probe, pose=pose_msg((30.0, 0.5, 0.2), (0, 0, 0, 1)), margin=0.3)
            names = [(p.body_b if p.body_a == 'check_collision' else p.body_a, p.status,
                      p.distance) for p in cres.pairs]
            T_fixed = self.scene.T[m['fixed']]
            loc = T_fixed.inv() * Tf(np.eye(3), (30.0, 0.5, 0.2))
            cres = m['cc'](body=probe, pose=pose_msg(loc.t, loc.quat()), margin=0.3)
            names = [(p.body_b if p.body_a == 'check_collision' else p.body_a, p.status,
                      p.distance) for p in cres.pairs]
            if not cres.success or [x[0] for x in names] != ['st_y', 'st_x'] or \
                    names[1][1] != PairState.UNKNOWN or not math.isinf(names[1][2]) or \
                    abs(names[0][2] - 0.05) > 1e-9 or not cres.message:
                self.problem('stale: check_collision UNKNOWN pair', m, node=names,
                             oracle=[('st_y', 1, 0.05), ('st_x', 3, 'inf')],
                             message=cres.message)
            # observations: leading '/' in request frames (the contract is silent)
            r = m['gd'](body_a='tie_c', body_b='tie_p', frame_id='/tie_frame')
            self.observations.append({'monitor': n, 'get_distance frame_id /tie_frame':
                                      [r.success, r.message, r.result.point_a.x]})
            pr = sph('slash_probe', 0.05)
            pr.header.frame_id = '/tie_frame'
            c2 = m['cc'](body=pr, pose=pose_msg((0.0, 0.5, 0), (0, 0, 0, 1)), margin=1.0)
            self.observations.append({'monitor': n, 'check_collision frame /tie_frame':
                                      [c2.success, c2.message, [(p.body_b, p.distance)
                                                                for p in c2.pairs]]})
        for m in self.mon.values():
            for b in bodies:
                m['bodies'].publish(Body(id=b.id, operation=Body.REMOVE))
        if self.report_path:
            with open(self.report_path, 'a') as f:
                for p in self.problems:
                    f.write(json.dumps(p, default=str) + '\n')
                for o in self.observations:
                    f.write(json.dumps({'observation': o}, default=str) + '\n')
        time.sleep(0.5)
        self.assertEqual(self.problems, [], json.dumps(self.problems, default=str))

    # ------------------------------------------------------------ hysteresis, events, replacement
    def test_zz_dynamic(self):
        """Two bodies moved step by step through the thresholds (statuses with hysteresis, the
        events), then replaced (pose kept from the same source, not from another)."""
        self.cur_round = 'dynamic'
        self.problems = []
        self.twists = {}
        self.groups = {k: '' for k in self.robot_links}
        self.groups.update({'dyn_a': '', 'dyn_b': ''})
        from collision_monitor.msg import CollisionEvent
        events = {n: [] for n in self.mon}
        subs = [rospy.Subscriber(m['ns'] + 'events', CollisionEvent,
                                 lambda e, n=n: events[n].append(e), queue_size=1000)
                for n, m in self.mon.items()]
        time.sleep(0.5)
        ra, rb = 0.1, 0.07
        T_c, T_b = self.scene.T['c'], self.scene.T['b']
        # dyn_a: sphere on frame c (TF). dyn_b: sphere posed in frame b, along a fixed direction.
        u = np.array([0.6, -0.48, 0.64])
        u = u / np.linalg.norm(u)
        far = np.array([50.0, 0.0, 0.0])   # keeps dyn_* away from the robot's links
        self.scene.add_frame('dyn_frame', 'c', (T_c.inv() * Tf(np.eye(3), far)).t,
                             (T_c.inv()).quat())
        self.static_tf.sendTransform(self.scene.tf_list)
        time.sleep(0.3)
        T_dyn = self.scene.T['dyn_frame']
        A = Body(id='dyn_a', operation=Body.ADD, parts=[Shape(type=SPHERE, dimensions=[ra])])
        A.header.frame_id = 'dyn_frame'
        A.parts[0].pose.orientation.w = 1.0
        B = Body(id='dyn_b', operation=Body.ADD, pose_from_topic=True,
                 parts=[Shape(type=SPHERE, dimensions=[rb])])
        B.parts[0].pose.orientation.w = 1.0
        for m in self.mon.values():
            m['bodies'].publish(A)
            m['bodies'].publish(B)
        time.sleep(0.5)

        def place_b(m, d):
            c_w = T_dyn.t + u * (ra + rb + d)
            loc = T_b.inv() * Tf(np.eye(3), c_w)
            msg = BodyPoses()
            msg.header.frame_id = 'b'
            msg.ids = ['dyn_b']
            msg.poses = [pose_msg(loc.t, loc.quat())]
            m['poses'].publish(msg)
            return msg

        def gd_wait(m, d, resend):
            deadline = time.monotonic() + 5.0
            res = None
            while time.monotonic() < deadline:
                res = m['gd'](body_a='dyn_a', body_b='dyn_b', frame_id='')
                if res.success and abs(res.result.distance - d) <= 1e-9:
                    return res
                if resend:
                    resend()
                time.sleep(0.05)
            return res

        seq = {}
        for n, m in self.mon.items():
            W, C, H = m['W'], m['C'], m['H']
            seq[n] = [(W + 0.05, 0), (W + H / 2, 0), (W - 0.01, 1), (W + H / 2, 1),
                      (W + 1.5 * H, 0), (C - 0.01, 2), (C + H / 2, 2), (C + 1.5 * H, 1),
                      (C - 0.01, 2), (W + 0.05, 0)]
        exp_events = {n: [] for n in self.mon}
        exp_dist = {n: [] for n in self.mon}
        prev = {n: 0 for n in self.mon}
        E = CollisionEvent
        end = {1: E.WARNING_END, 2: E.COLLISION_END}
        begin = {1: E.WARNING_BEGIN, 2: E.COLLISION_BEGIN}
        for step in range(10):
            for n, m in self.mon.items():
                d, st = seq[n][step]
                place_b(m, d)
            for n, m in self.mon.items():
                d, st = seq[n][step]
                res = gd_wait(m, d, lambda m=m, d=d: place_b(m, d))
                if res is None or not res.success or abs(res.result.distance - d) > 1e-9:
                    self.problem('dynamic: pose not taken', m, step=step, target=d,
                                 result=msg_repr(res))
                    continue
                t0 = time.monotonic()
                wait_t = t0 + 0.35
                while m['state_t'] < wait_t and time.monotonic() < t0 + 3:
                    time.sleep(0.02)
                stt = m['state']
                got = [p for p in stt.pairs if {p.body_a, p.body_b} == {'dyn_a', 'dyn_b'}]
                gst = got[0].status if got else 0
                if gst != st:
                    self.problem('dynamic: ~state status (hysteresis)', m, step=step,
                                 distance=d, W=m['W'], C=m['C'], H=m['H'],
                                 previous=STATUS[prev[n]], node=STATUS[gst], oracle=STATUS[st])
                res = m['gd'](body_a='dyn_a', body_b='dyn_b', frame_id='')
                if res.result.status != st:
                    self.problem('dynamic: get_distance status (hysteresis)', m, step=step,
                                 distance=d, previous=STATUS[prev[n]],
                                 node=STATUS[res.result.status], oracle=STATUS[st])
                if st != prev[n]:
                    if prev[n]:
                        exp_events[n].append(end[prev[n]])
                        exp_dist[n].append(d)
                    if st:
                        exp_events[n].append(begin[st])
                        exp_dist[n].append(d)
                prev[n] = st
        time.sleep(0.3)
        for n, m in self.mon.items():
            got = [e.type for e in events[n] if {e.pair.body_a, e.pair.body_b} ==
                   {'dyn_a', 'dyn_b'} and e.type not in (E.UNKNOWN_BEGIN, E.UNKNOWN_END)]
            if got != exp_events[n]:
                self.problem('dynamic: events', m, node=got, oracle=exp_events[n])
            else:
                evs = [e for e in events[n] if {e.pair.body_a, e.pair.body_b} ==
                       {'dyn_a', 'dyn_b'} and e.type not in (E.UNKNOWN_BEGIN, E.UNKNOWN_END)]
                for e, d in zip(evs, exp_dist[n]):
                    sep = np.linalg.norm(vec(e.pair.point_b) - vec(e.pair.point_a))
                    if abs(e.pair.distance - d) > 1e-9 or e.header.frame_id != m['fixed'] \
                            or abs(sep - abs(d)) > 1e-9:
                        self.problem('dynamic: event pair', m, event=msg_repr(e), oracle_distance=d)
        # ---- replacement
        for n, m in self.mon.items():
            last_d = seq[n][-1][0]
            # R1: dyn_b replaced by a box, same source (~body_poses): pose kept
            B2 = Body(id='dyn_b', operation=Body.ADD, pose_from_topic=True,
                      parts=[Shape(type=BOX, dimensions=[0.1, 0.2, 0.3])])
            B2.parts[0].pose.orientation.w = 1.0
            B2.header.frame_id = 'other_decl'
            m['bodies'].publish(B2)
            c_w = T_dyn.t + u * (ra + rb + last_d)
            ob_a = make_obody('dyn_a', T_dyn, [(SPHERE, [ra], None, Tf())], 0.0)
            ob_b = make_obody('dyn_b', Tf(np.eye(3), c_w) * Tf(), [(BOX, [0.1, 0.2, 0.3], None,
                                                                     Tf())], 0.0)
            # the pose of dyn_b in world: T_b * loc (identity rotation in world)
            dexp = body_distance(ob_a, ob_b)[0]
            res = gd_wait(m, dexp, None)
            if res is None or not res.success or abs(res.result.distance - dexp) > TOL_D:
                self.problem('replace: topic body re-shaped, pose should be kept', m,
                             oracle=dexp, result=msg_repr(res))
            # R3: dyn_b replaced by a TF body on frame d
            B3 = Body(id='dyn_b', operation=Body.ADD,
                      parts=[Shape(type=SPHERE, dimensions=[rb])])
            B3.parts[0].pose.orientation.w = 1.0
            B3.header.frame_id = 'd'
            m['bodies'].publish(B3)
            ob_b3 = make_obody('dyn_b', self.scene.T['d'], [(SPHERE, [rb], None, Tf())], 0.0)
            dexp = body_distance(ob_a, ob_b3)[0]
            res = gd_wait(m, dexp, None)
            if res is None or not res.success or abs(res.result.distance - dexp) > TOL_D:
                self.problem('replace: topic body -> TF body on d', m, oracle=dexp,
                             result=msg_repr(res))
            # R4: dyn_a replaced by a topic body: no pose until one comes
            A4 = Body(id='dyn_a', operation=Body.ADD, pose_from_topic=True,
                      parts=[Shape(type=SPHERE, dimensions=[ra])])
            A4.parts[0].pose.orientation.w = 1.0
            m['bodies'].publish(A4)
            ok = False
            deadline = time.monotonic() + 3.0
            while time.monotonic() < deadline:
                lb = m['lb']()
                if 'dyn_a' in lb.ids and lb.stale[lb.ids.index('dyn_a')] and \
                        lb.frames[lb.ids.index('dyn_a')] == '':
                    ok = True
                    break
                time.sleep(0.05)
            res = m['gd'](body_a='dyn_a', body_b='dyn_b', frame_id='')
            if not ok or res.success:
                lb = m['lb']()
                self.problem('replace: TF body -> topic body should have no pose', m,
                             listed=list(zip(lb.ids, lb.frames, lb.stale)), result=msg_repr(res))
            for bid in ('dyn_a', 'dyn_b'):
                m['bodies'].publish(Body(id=bid, operation=Body.REMOVE))
        for s_ in subs:
            s_.unregister()
        self.all_problems.extend(self.problems)
        if self.report_path:
            with open(self.report_path, 'a') as f:
                for p in self.problems:
                    f.write(json.dumps(p, default=str) + '\n')
        self.assertEqual(self.problems, [], json.dumps(self.problems, default=str))


for _r in range(ROUNDS):
    setattr(ContractSweep, 'test_round_%02d' % _r, lambda self, r=_r: self._round(r))


if __name__ == '__main__':
    faulthandler.register(signal.SIGUSR1)  # kill -USR1: where a stalled sweep waits
    rostest.rosrun('collision_monitor', 'contract_sweep', ContractSweep)
