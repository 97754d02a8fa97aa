#!/usr/bin/python3
"""rostest: bodies from ~bodies, YAML and TF, posed by ~body_poses, pose_topic and TF, through a
real roscore. Exact distances, events with their latency, staleness, REMOVE, refused input, the
services. Run with backend:=gjk and backend:=libccd (same verdicts)."""
import io
import math
import re
import struct
import subprocess
import sys
import threading
import time
import unittest
from contextlib import contextmanager
from fractions import Fraction

import rospy
import rostest
import tf2_ros
from collision_monitor.msg import (Body, BodyPoses, CollisionEvent, CollisionState, PairState,
                                   Shape)
from collision_monitor.srv import CheckCollision, CheckCollisionRequest, CheckCollisionResponse
from diagnostic_msgs.msg import DiagnosticStatus
from dynamic_reconfigure.client import Client
from geometry_msgs.msg import Point, PoseStamped, Twist
from roscpp.srv import GetLoggers, SetLoggerLevel
from rosgraph_msgs.msg import Log
from visualization_msgs.msg import MarkerArray

from cm_test_util import (NS, Monitor, PoseStreamer, point_close, pose, shape, sphere_body,
                          tf_transform, wait_for)

E = CollisionEvent


def publish_stamped_now(pub, frame_id, pose_msg):
    """Publishes pose_msg as a PoseStamped in frame_id, stamped with the current ROS time."""
    p = PoseStamped()
    p.header.frame_id = frame_id
    p.header.stamp = rospy.Time.now()
    p.pose = pose_msg
    pub.publish(p)


def body_ids(arrays):
    """The ids of the body markers that `arrays` (MarkerArray messages) add."""
    return {m.id for a in arrays for m in a.markers if m.ns == 'bodies' and m.action == m.ADD}


# Run as its own ROS node: subscribes to argv[1] and prints the body marker ids of the first
# two MarkerArrays it receives, one per line.
_MARKERS_PROBE = """
import sys, time, rospy
from visualization_msgs.msg import MarkerArray
rospy.init_node('markers_probe', anonymous=True, disable_signals=True)
got = []
sub = rospy.Subscriber(sys.argv[1], MarkerArray, got.append)
deadline = time.time() + 10.0
while len(got) < 2 and time.time() < deadline:
    time.sleep(0.01)
sub.unregister()
if len(got) < 2:
    sys.exit('got %d arrays in 10 s' % len(got))
for i in sorted({m.id for a in got[:2] for m in a.markers
                 if m.ns == 'bodies' and m.action == m.ADD}):
    print(i)
"""


def first_body_marker_ids_in_new_process(topic):
    """body_ids() of the first two arrays on `topic` that a subscriber in a new process (a new
    connection to the publisher) receives."""
    out = subprocess.run([sys.executable, '-c', _MARKERS_PROBE, topic], capture_output=True,
                         text=True, timeout=30.0)
    if out.returncode != 0:
        raise AssertionError('markers probe failed: %s' % out.stderr.strip()[-500:])
    return {int(line) for line in out.stdout.split()}


def raw_request_class(request_class):
    """A request class of `request_class`'s type whose instances carry their serialized bytes
    (malformed on purpose): RawX(payload)."""
    def __init__(self, payload=b''):
        self.payload = payload

    def serialize(self, buff):
        buff.write(self.payload)

    return type('Raw' + request_class.__name__, (request_class,), {
        '__slots__': ['payload'], '__init__': __init__, 'serialize': serialize})


def raw_service(service_class, raw_request, response_class):
    """service_class for rospy.ServiceProxy whose requests are `raw_request` instances."""
    return type('Raw' + service_class.__name__, (object,), {
        '_type': service_class._type, '_md5sum': service_class._md5sum,
        '_request_class': raw_request, '_response_class': response_class})


class TopicBodies(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_topic_bodies')
        cls.backend = rospy.get_param('~backend', 'gjk')
        # shelf_frame: 5 m along y in world, static (stamp 0 chain: never stale).
        cls.static_tf = tf2_ros.StaticTransformBroadcaster()
        # turned_frame: world turned +90 degrees about x (its y is world z, its z is world -y).
        cls.statics = [
            tf_transform('shelf_frame', stamp=rospy.Time(), xyz=(0.0, 5.0, 0.0)),
            tf_transform('turned_frame', stamp=rospy.Time(),
                         q=(math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5))),
            # far_frame: 1e308 m along x (a finite frame in which a finite pose overflows).
            tf_transform('far_frame', stamp=rospy.Time(), xyz=(1e308, 0.0, 0.0))]
        cls.static_tf.sendTransform(cls.statics)
        cls.m = Monitor()
        cls.poses = PoseStreamer(cls.m.poses_pub, 'world', rate=20.0)
        # Two unit spheres 3 m apart.
        cls.m.add(sphere_body('s1', 1.0))
        cls.m.add(sphere_body('s2', 1.0))
        assert cls.m.wait_listed('s1') and cls.m.wait_listed('s2')
        cls.poses.set('s1', pose(0, 0, 0))
        cls.poses.set('s2', pose(3, 0, 0))

    def setUp(self):
        # Every test starts from the same scene, whatever the previous one left behind.
        self.poses.paused.clear()
        self.poses.set('s1', pose(0, 0, 0))
        self.poses.set('s2', pose(3, 0, 0))
        # Penetration depth: our EPA is exact to rounding; libccd's MPR stops at ~1e-6.
        self.depth_tol = 1e-5 if self.backend == 'libccd' else 1e-9

    def distance(self, a, b, frame=''):
        return self.m.get_distance(a, b, frame)

    def wait_distance(self, a, b, expected, tol=1e-9, timeout=3.0):
        return wait_for(lambda: (lambda r: r if r.success and abs(r.result.distance - expected)
                                 <= tol else None)(self.distance(a, b)), timeout, 0.01)

    def add_pose_topic_body(self, body_id, radius, topic):
        """Adds a sphere posed by PoseStamped on `topic`; returns a publisher the monitor is
        connected to."""
        pub = rospy.Publisher(topic, PoseStamped, queue_size=10)
        self.m.add(sphere_body(body_id, radius, pose_topic=topic))
        self.assertTrue(self.m.wait_listed(body_id))
        self.assertTrue(wait_for(lambda: pub.get_num_connections() > 0, 5.0))
        return pub

    def rejected_now(self):
        """'rejected inputs (total)' of the first /diagnostics report after this call."""
        self.m.diagnostics = None
        self.assertTrue(wait_for(lambda: self.m.diagnostics is not None, 5.0))
        return int(self.m.diag_value('rejected inputs (total)'))

    def wait_one_more_rejected(self, counted, why):
        """The last rejection of the first report counting more than `counted` rejected inputs,
        which must count exactly one more."""
        d = wait_for(lambda: (lambda d: d if d is not None and int(
            self.m.diag_value('rejected inputs (total)', d)) > counted else None)(
                self.m.diagnostics), 5.0, 0.05)
        self.assertIsNotNone(d, why)
        self.assertEqual(int(self.m.diag_value('rejected inputs (total)', d)), counted + 1)
        return self.m.diag_value('last rejection', d)

    def test_01_two_unit_spheres_exact(self):
        r = self.wait_distance('s1', 's2', 1.0)
        self.assertIsNotNone(r, self.distance('s1', 's2'))
        self.assertAlmostEqual(r.result.distance, 1.0, places=9)
        self.assertTrue(point_close(r.result.point_a, (1, 0, 0)), r.result.point_a)
        self.assertTrue(point_close(r.result.point_b, (2, 0, 0)), r.result.point_b)
        self.assertTrue(point_close(r.result.normal, (1, 0, 0)), r.result.normal)
        self.assertEqual(r.result.status, PairState.CLEAR)
        self.assertEqual({r.result.body_a, r.result.body_b}, {'s1', 's2'})
        # Nearest body to s1 is s2 (the shelf is 3.5 m away).
        n = self.distance('s1', '')
        self.assertTrue(n.success, n.message)
        self.assertEqual(n.result.body_b, 's2')
        self.assertAlmostEqual(n.result.distance, 1.0, places=9)
        # State heartbeat in the fixed frame (default "world": no URDF).
        self.assertTrue(wait_for(lambda: self.m.state.num_bodies >= 3, 3.0))
        st = self.m.state
        self.assertEqual(st.header.frame_id, 'world')
        self.assertFalse(st.in_collision)

    def test_02_events_and_latency(self):
        self.assertIsNotNone(self.wait_distance('s1', 's2', 1.0))
        # Warning: 3 cm apart (< warning_distance 5 cm). The check loop runs at 2 Hz here, so
        # only the pose-triggered check can deliver the event quickly.
        latencies = []
        for k in range(5):
            t0 = time.monotonic()
            self.poses.set('s2', pose(2.03, 0, 0))
            ev = self.m.wait_event(E.WARNING_BEGIN, 's1', 's2', timeout=3.0, since=t0)
            self.assertIsNotNone(ev, 'no WARNING_BEGIN')
            latencies.append(ev[0] - t0)
            self.assertAlmostEqual(ev[1].pair.distance, 0.03, places=9)
            self.assertEqual(ev[1].header.frame_id, 'world')
            self.assertEqual(ev[1].pair.status, PairState.WARNING)
            t1 = time.monotonic()
            self.poses.set('s2', pose(3, 0, 0))
            self.assertIsNotNone(self.m.wait_event(E.WARNING_END, 's1', 's2', 3.0, since=t1))
        latencies.sort()
        rospy.loginfo('pose -> WARNING_BEGIN latency: median %.1f ms, max %.1f ms',
                      1e3 * latencies[len(latencies) // 2], 1e3 * latencies[-1])
        print('pose->event latency (ms): median %.2f max %.2f' %
              (1e3 * latencies[len(latencies) // 2], 1e3 * latencies[-1]))
        self.assertLess(latencies[len(latencies) // 2], 0.1)

        # Collision: 10 cm penetration.
        t2 = time.monotonic()
        self.poses.set('s2', pose(1.9, 0, 0))
        ev = self.m.wait_event(E.COLLISION_BEGIN, 's1', 's2', 3.0, since=t2)
        self.assertIsNotNone(ev, 'no COLLISION_BEGIN')
        self.assertAlmostEqual(ev[1].pair.distance, -0.1, delta=self.depth_tol)
        self.assertTrue(wait_for(lambda: self.m.state.in_collision, 2.0))
        t3 = time.monotonic()
        self.poses.set('s2', pose(3, 0, 0))
        self.assertIsNotNone(self.m.wait_event(E.COLLISION_END, 's1', 's2', 3.0, since=t3))
        self.assertTrue(wait_for(lambda: not self.m.state.in_collision, 2.0))

    def test_03_stale_pose_unknown_and_recovery(self):
        self.assertIsNotNone(self.wait_distance('s1', 's2', 1.0))
        t0 = time.monotonic()
        self.poses.paused.add('s1')
        ev = self.m.wait_event(E.UNKNOWN_BEGIN, 's1', 's2', timeout=3.0, since=t0)
        self.assertIsNotNone(ev, 'no UNKNOWN_BEGIN after pose_timeout')
        # Not before s1's last pose is pose_timeout (0.5 s) old, by the stamps.
        last = max(t for t in self.poses.stamps('s1') if t <= ev[1].header.stamp)
        self.assertGreater((ev[1].header.stamp - last).to_sec(), 0.5)
        self.assertEqual(ev[1].pair.status, PairState.UNKNOWN)
        r = self.distance('s1', 's2')
        self.assertFalse(r.success)
        self.assertIn('s1', r.message)
        listed = self.m.list_bodies()
        self.assertTrue(listed.stale[listed.ids.index('s1')])
        # ~state comes on its own connection: it may not have caught up with ~events yet.
        self.assertTrue(wait_for(lambda: 's1' in self.m.state.stale_bodies, 3.0))
        t1 = time.monotonic()
        self.poses.paused.discard('s1')
        self.poses.publish_now()
        self.assertIsNotNone(self.m.wait_event(E.UNKNOWN_END, 's1', 's2', 3.0, since=t1))
        self.assertIsNotNone(self.wait_distance('s1', 's2', 1.0))

    def test_04_tf_attached_yaml_body(self):
        # "shelf" (YAML ~bodies): unit cube attached to shelf_frame = world + (0, 5, 0).
        self.assertIn('shelf', self.m.ids())
        r = wait_for(lambda: (lambda x: x if x.success else None)(self.distance('s1', 'shelf')),
                     5.0)
        self.assertIsNotNone(r, self.distance('s1', 'shelf').message)
        self.assertAlmostEqual(r.result.distance, 3.5, places=9)
        self.assertTrue(point_close(r.result.point_a, (0, 1, 0)), r.result.point_a)
        self.assertTrue(point_close(r.result.point_b, (0, 4.5, 0)), r.result.point_b)
        # The same answer expressed in shelf_frame.
        r2 = self.distance('s1', 'shelf', 'shelf_frame')
        self.assertTrue(r2.success, r2.message)
        self.assertTrue(point_close(r2.result.point_b, (0, -0.5, 0)), r2.result.point_b)
        self.assertTrue(point_close(r2.result.normal, (0, 1, 0)), r2.result.normal)
        # A static TF chain never goes stale.
        listed = self.m.list_bodies()
        self.assertFalse(listed.stale[listed.ids.index('shelf')])
        # Given as '/shelf_frame': listed (and drawn) as tf2 names it.
        self.assertEqual(listed.frames[listed.ids.index('shelf')], 'shelf_frame')
        # Unknown frame in the request: refused with the reason.
        r3 = self.distance('s1', 'shelf', 'no_such_frame')
        self.assertFalse(r3.success)
        self.assertIn('no_such_frame', r3.message)

    def test_05_body_poses_in_another_frame(self):
        # s3 posed in shelf_frame at (0, -5, 2): world (0, 0, 2).
        self.m.add(sphere_body('s3', 0.5))
        self.assertTrue(self.m.wait_listed('s3'))
        msg = BodyPoses()
        msg.header.frame_id = 'shelf_frame'
        msg.header.stamp = rospy.Time(0)  # stamp 0: a static pose, never stale
        msg.ids = ['s3']
        msg.poses = [pose(0, -5, 2.0)]
        self.m.poses_pub.publish(msg)
        r = self.wait_distance('s1', 's3', 0.5)
        self.assertIsNotNone(r, self.distance('s1', 's3'))
        self.assertTrue(point_close(r.result.point_b, (0, 0, 1.5)), r.result.point_b)
        self.m.add(Body(id='s3', operation=Body.REMOVE))
        self.assertTrue(self.m.wait_listed('s3', present=False))

    def test_06_pose_topic(self):
        pub = self.add_pose_topic_body('tracked', 0.5, '/tracker/pose')

        def publish(x):
            publish_stamped_now(pub, 'world', pose(x, 0, 0))
        publish(10.0)
        r = wait_for(lambda: (lambda x: x if x.success and abs(x.result.distance - 5.5) < 1e-9
                              else None)(self.distance('tracked', 's2')), 3.0)
        self.assertIsNotNone(r, self.distance('tracked', 's2'))
        # REMOVE: gone from the list, its pose topic unsubscribed, queries name it unknown.
        self.m.add(Body(id='tracked', operation=Body.REMOVE))
        self.assertTrue(self.m.wait_listed('tracked', present=False))
        self.assertTrue(wait_for(lambda: pub.get_num_connections() == 0, 5.0),
                        'pose_topic still subscribed after REMOVE')
        r = self.distance('tracked', 's2')
        self.assertFalse(r.success)
        self.assertIn("unknown body 'tracked'", r.message)

    def test_07_bad_input_refused_node_keeps_answering(self):
        before = self.m.ids()
        rejected0 = int(self.m.diag_value('rejected inputs (total)') or 0)
        bad = []
        b = sphere_body('bad_nan_pose', 1.0)
        b.parts[0].pose.position.x = float('nan')
        bad.append(b)
        bad.append(sphere_body('bad_negative_radius', -1.0))
        b = sphere_body('bad_type', 1.0)
        b.parts[0].type = 42
        bad.append(b)
        b = sphere_body('bad_dims', 1.0)
        b.parts[0].dimensions = [1.0, 2.0]
        bad.append(b)
        b = Body(id='bad_mesh_passwd', operation=Body.ADD, pose_from_topic=True)
        b.parts = [shape(Shape.MESH, resource='file:///etc/passwd')]
        bad.append(b)
        b = Body(id='bad_mesh_escape', operation=Body.ADD, pose_from_topic=True)
        b.parts = [shape(Shape.MESH, resource='package://collision_monitor/../../../etc/passwd')]
        bad.append(b)
        b = Body(id='bad_no_parts', operation=Body.ADD, pose_from_topic=True)
        bad.append(b)
        b = Body(id='bad_too_many_vertices', operation=Body.ADD, pose_from_topic=True)
        b.parts = [shape(Shape.CONVEX, vertices=[Point(math.cos(k), math.sin(k), 0.01 * k)
                                                 for k in range(101)])]  # max 100
        bad.append(b)
        b = sphere_body('bad_quaternion', 1.0)
        b.parts[0].pose.orientation.w = 2.0
        bad.append(b)
        # Replacing a YAML body from the topic is refused; the shelf stays as it is.
        bad.append(sphere_body('shelf', 0.1))
        for b in bad:
            self.m.add(b)
        # s1 pose with NaN: refused, s1 keeps its pose.
        msg = BodyPoses()
        msg.header.frame_id = 'world'
        msg.header.stamp = rospy.Time.now()
        msg.ids = ['s1']
        msg.poses = [pose(float('nan'), 0, 0)]
        self.m.poses_pub.publish(msg)
        msg2 = BodyPoses()
        msg2.header = msg.header
        msg2.ids = ['s1', 's2']
        msg2.poses = [pose(0, 0, 0)]  # mismatched lengths
        self.m.poses_pub.publish(msg2)
        time.sleep(0.5)
        self.assertEqual(self.m.ids(), before)
        r = self.wait_distance('s1', 's2', 1.0)
        self.assertIsNotNone(r, 'the node stopped answering or s1/s2 changed')
        r = self.distance('s1', 'shelf')
        self.assertTrue(r.success, r.message)
        self.assertAlmostEqual(r.result.distance, 3.5, places=9)
        # Every refusal is counted on /diagnostics with the last reason.
        ok = wait_for(lambda: int(self.m.diag_value('rejected inputs (total)') or 0)
                      >= rejected0 + len(bad) + 2, 5.0, 0.1)
        self.assertTrue(ok, 'rejections not counted: %s' % self.m.diag_value(
            'rejected inputs (total)'))
        self.assertTrue(self.m.diag_value('last rejection'))
        # REMOVE of an id the monitor does not track: nothing to do, not a rejection (a second
        # REMOVE, a latched one replayed). REMOVE of the YAML shelf is one; it comes after, on
        # the same connection, so once it is counted the first one has been handled.
        counted = int(self.m.diag_value('rejected inputs (total)'))
        self.m.add(Body(id='never_added', operation=Body.REMOVE))
        self.m.add(Body(id='shelf', operation=Body.REMOVE))
        d = wait_for(lambda: (lambda d: d if d is not None and "cannot remove 'shelf'" in
                              (self.m.diag_value('last rejection', d) or '') else None)(
                                  self.m.diagnostics), 5.0, 0.05)
        self.assertIsNotNone(d, self.m.diag_value('last rejection'))
        self.assertIn("cannot remove 'shelf': declared by the parameter",
                      self.m.diag_value('last rejection', d))
        self.assertEqual(int(self.m.diag_value('rejected inputs (total)', d)), counted + 1)
        self.assertIn('shelf', self.m.ids())

    def test_08_check_collision(self):
        self.assertIsNotNone(self.wait_distance('s1', 's2', 1.0))
        probe = sphere_body('probe', 0.5, frame='world', pose_from_topic=False)
        r = self.m.check_collision(probe, pose(0, 0, 1.2), 10.0)
        self.assertTrue(r.success, r.message)
        self.assertTrue(r.in_collision)
        names = [p.body_b if p.body_a == 'probe' else p.body_a for p in r.pairs]
        self.assertEqual(names[0], 's1')
        self.assertAlmostEqual(r.pairs[0].distance, -0.3, delta=self.depth_tol)
        self.assertEqual(r.pairs, sorted(r.pairs, key=lambda p: p.distance))
        self.assertIn('s2', names)
        # Far away, small margin: nothing near.
        r = self.m.check_collision(probe, pose(0, -20, 0), 0.1)
        self.assertTrue(r.success, r.message)
        self.assertFalse(r.in_collision)
        self.assertEqual(len(r.pairs), 0)
        # Placed through TF: in shelf_frame at the shelf's centre -> collides with the shelf.
        probe.header.frame_id = 'shelf_frame'
        r = self.m.check_collision(probe, pose(0, 0, 0), 0.0)
        self.assertTrue(r.success, r.message)
        self.assertTrue(r.in_collision)
        self.assertIn('shelf', [p.body_b if p.body_a == 'probe' else p.body_a for p in r.pairs])
        # Invalid body: refused with the reason.
        bad = sphere_body('probe', -1.0, frame='world', pose_from_topic=False)
        r = self.m.check_collision(bad, pose(0, 0, 0), 0.1)
        self.assertFalse(r.success)
        self.assertIn('negative', r.message)
        self.assertNotIn('probe', self.m.ids())
        # Bug: an id of white space only passes the message checks but not the world's; the world
        # answered nothing and the service said success, not in collision (a false "clear"), for a
        # probe deep in the shelf.
        for blank in (' ', ' \t'):
            ws = sphere_body(blank, 0.5, frame='shelf_frame', pose_from_topic=False)
            r = self.m.check_collision(ws, pose(0, 0, 0), 10.0)
            self.assertFalse(r.success, blank)
            self.assertFalse(r.in_collision)
            self.assertEqual(r.pairs, [])
            self.assertEqual(r.message, "body '%s' refused: the id is only white space"
                             % blank.replace('\t', '\\x09'))  # escaped, as every rejection
        # So was a placement that overflows in the fixed frame: x = 1e308 in far_frame is 2e308 =
        # inf in world.
        far = sphere_body('probe', 0.5, frame='far_frame', pose_from_topic=False)
        r = self.m.check_collision(far, pose(1e308, 0, 0), 10.0)
        self.assertFalse(r.success)
        self.assertEqual(r.message, "the pose in the fixed frame is not finite (or not rigid)")
        # Malformed request (a 2^31 dimensions claim in ~100 bytes): refused before deserialization
        # (no 16 GB allocation), with the reason; the service keeps answering.
        req = CheckCollisionRequest(body=sphere_body('probe', 0.5, frame='world',
                                                     pose_from_topic=False), pose=pose(), margin=0.1)
        buff = io.BytesIO()
        req.serialize(buff)
        raw = bytearray(buff.getvalue())
        b = req.body
        dims = 12 + 4 + len(b.header.frame_id) + 4 + len(b.id) + 1 + 4 + len(b.group) + 4 + 1
        self.assertEqual(struct.unpack_from('<I', raw, dims)[0], 1)
        struct.pack_into('<I', raw, dims, 0x80000000)
        raw_request = raw_request_class(CheckCollisionRequest)
        raw_check = rospy.ServiceProxy('/collision_monitor/check_collision', raw_service(
            CheckCollision, raw_request, CheckCollisionResponse))
        r = raw_check(raw_request(bytes(raw)))
        self.assertFalse(r.success)
        self.assertIn('malformed message', r.message)
        self.assertIn('body.parts[0].dimensions claims 2147483648', r.message)
        r = self.m.check_collision(probe, pose(0, -20, 0), 0.1)
        self.assertTrue(r.success, r.message)

        # Bug: an empty id became 'check_collision', and a tracked body of that id was left out as
        # "itself": a probe overlapping it by 0.6 m was not in collision. Empty is only a label.
        self.m.add(sphere_body('check_collision', 0.5))
        self.poses.set('check_collision', pose(0, -20, 0))
        try:
            self.assertIsNotNone(self.wait_distance('check_collision', 's1', 20.0 - 1.5))
            anon = sphere_body('', 0.1, frame='world', pose_from_topic=False)
            r = self.m.check_collision(anon, pose(0, -20, 0), 0.1)
            self.assertTrue(r.success, r.message)
            self.assertTrue(r.in_collision)
            self.assertEqual([(p.body_a, p.body_b) for p in r.pairs],
                             [('check_collision', 'check_collision')])
            self.assertAlmostEqual(r.pairs[0].distance, -0.6, delta=self.depth_tol)
            # The tracked body's own id: that body moved there, not checked against itself.
            own = sphere_body('check_collision', 0.1, frame='world', pose_from_topic=False)
            r = self.m.check_collision(own, pose(0, -20, 0), 0.1)
            self.assertEqual((r.success, r.in_collision, r.pairs), (True, False, []))
        finally:
            with self.poses.lock:
                self.poses.poses.pop('check_collision')
            self.m.add(Body(id='check_collision', operation=Body.REMOVE))
        self.assertTrue(self.m.wait_listed('check_collision', present=False))

    def test_09_markers_while_subscribed(self):
        arrays = []
        sub = rospy.Subscriber('/collision_monitor/markers', MarkerArray, arrays.append)
        try:
            self.assertTrue(wait_for(lambda: any(a.markers for a in arrays), 5.0),
                            'no ~markers while subscribed')
            # A new subscriber gets every body in the next array (unchanged bodies otherwise
            # only come again as their refreshes fall due): within the first two arrays.
            self.assertTrue(wait_for(lambda: len(arrays) >= 2, 5.0))
            frames = {(m.header.frame_id, m.frame_locked) for a in arrays[:2] for m in a.markers
                      if m.action != m.DELETE and m.action != m.DELETEALL}
            # The shelf hangs on shelf_frame: drawn there, moved by rviz with TF. Bodies posed
            # by topics are drawn in the fixed frame.
            self.assertEqual(frames, {('world', False), ('shelf_frame', True)})
            shelf = [m for a in arrays for m in a.markers if m.header.frame_id == 'shelf_frame']
            self.assertTrue(all(m.ns == 'bodies' and m.type == m.CUBE and
                                (m.pose.position.x, m.pose.position.y, m.pose.position.z) ==
                                (0.0, 0.0, 0.0) for m in shelf), shelf[:1])
            # A second subscriber, while the first stays: every body in its first two arrays
            # too (test_markers UnchangedBodiesAreNotSent checks the resend itself). It must be
            # another process: rospy shares one connection among a process's subscribers to a
            # topic, so a second rospy.Subscriber here would open none and the node would
            # resend nothing (its first arrays held only the bodies whose refresh fell due).
            time.sleep(1.0)
            second = first_body_marker_ids_in_new_process('/collision_monitor/markers')
            self.assertEqual(second, body_ids(arrays[:2]))
            self.assertGreaterEqual(len(second), 3)
        finally:
            sub.unregister()

    def test_10_diagnostics(self):
        self.assertTrue(wait_for(lambda: self.m.diag_value('backend'), 5.0, 0.1))
        self.assertEqual(self.m.diag_value('backend'), self.backend)
        self.assertEqual(self.m.diagnostics.name, 'collision_monitor: inputs')
        self.assertEqual(self.m.diagnostics.hardware_id, '/collision_monitor')  # was "none"

    def test_11_max_bodies(self):
        present = self.m.ids()
        room = 8 - len(present)   # max_bodies = 8
        self.assertGreater(room, 0, present)
        # The one refused has a newline in its id: logged and reported on one line (escaped).
        fills = ['fill_%d' % k for k in range(room)] + ['fill\n[ERROR] injected']
        for k, f in enumerate(fills):
            self.m.add(sphere_body(f, 0.1))
            if k < room:
                self.assertTrue(self.m.wait_listed(f), f)
        time.sleep(0.3)
        ids = self.m.ids()
        self.assertEqual(len(ids), 8)
        self.assertNotIn(fills[-1], ids)
        # /diagnostics reports once a second.
        self.assertTrue(wait_for(lambda: 'max_bodies' in (self.m.diag_value('last rejection')
                                                          or ''), 3.0, 0.1),
                        self.m.diag_value('last rejection'))
        last = self.m.diag_value('last rejection')
        self.assertIn("body 'fill\\x0a[ERROR] injected' refused", last)
        self.assertNotIn('\n', last)
        for f in fills:
            self.m.add(Body(id=f, operation=Body.REMOVE))
        self.assertTrue(wait_for(lambda: self.m.ids() == present, 3.0, 0.05))

    def test_12_convex_bodies_in_far_coordinates(self):
        # CONVEX vertices written 1e5 m out (map coordinates, identity pose): 1 cm cubes 2.5 mm
        # apart along x. The monitor keeps them about their centres (ConvexShape::offset()), so
        # distance and witness points are those of the given doubles: the gap is the difference of
        # two faces' x coordinates (exact in floating point, Sterbenz), the witness points lie on
        # those faces, in world coordinates.
        c = (1e5, -2e4, 3.0)

        def cube(body_id, dx):
            b = Body(id=body_id, operation=Body.ADD, pose_from_topic=False)
            b.header.frame_id = 'world'
            b.parts = [shape(Shape.CONVEX, vertices=[
                Point(c[0] + dx + sx * 0.005, c[1] + sy * 0.005, c[2] + sz * 0.005)
                for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])]
            return b

        self.m.add(cube('far_a', 0.0))
        self.m.add(cube('far_b', 0.0125))
        self.assertTrue(self.m.wait_listed('far_a') and self.m.wait_listed('far_b'))
        a_max = c[0] + 0.005
        b_min = c[0] + 0.0125 - 0.005
        r = wait_for(lambda: (lambda r: r if r.success else None)(self.distance('far_a', 'far_b')),
                     3.0, 0.05)
        self.assertIsNotNone(r, self.distance('far_a', 'far_b'))
        self.assertAlmostEqual(r.result.distance, b_min - a_max, delta=1e-12)
        self.assertEqual(r.result.point_a.x, a_max)
        self.assertEqual(r.result.point_b.x, b_min)
        for p in (r.result.point_a, r.result.point_b):
            self.assertLessEqual(abs(p.y - c[1]), 0.005 + 1e-11)
            self.assertLessEqual(abs(p.z - c[2]), 0.005 + 1e-11)
        self.assertTrue(point_close(r.result.normal, (1, 0, 0), 1e-9), r.result.normal)
        self.assertEqual(r.result.status, PairState.WARNING)
        for f in ('far_a', 'far_b'):
            self.m.add(Body(id=f, operation=Body.REMOVE))
            self.assertTrue(self.m.wait_listed(f, present=False))


    def test_13_unknown_bodies_are_never_clear_in_services(self):
        # Bug: ~check_collision and ~get_distance's nearest body left out bodies without a fresh
        # pose, as if clear: a probe next to a stale body was "not in collision".
        self.assertIsNotNone(self.wait_distance('s1', 's2', 1.0))
        t_add = time.monotonic()
        self.m.add(sphere_body('ghost', 0.5))  # topic-posed, never posed
        self.assertTrue(self.m.wait_listed('ghost'))
        # Never posed, yet UNKNOWN on ~events too (it was silent: an events consumer took it for
        # clear), with the pair as in ~state: distance +inf.
        ev = self.m.wait_event(CollisionEvent.UNKNOWN_BEGIN, 'ghost', 's1', since=t_add)
        self.assertIsNotNone(ev)
        self.assertEqual(ev[1].pair.status, PairState.UNKNOWN)
        self.assertEqual(ev[1].pair.distance, float('inf'))
        try:
            probe = sphere_body('probe', 0.5, frame='world', pose_from_topic=False)
            r = self.m.check_collision(probe, pose(0, -20, 0), 0.1)
            self.assertTrue(r.success, r.message)
            self.assertFalse(r.in_collision)
            self.assertEqual([(p.body_a, p.body_b, p.status) for p in r.pairs],
                             [('probe', 'ghost', PairState.UNKNOWN)])
            self.assertIn('UNKNOWN', r.message)
            n = self.distance('s1', '')
            self.assertFalse(n.success)
            self.assertIn("the nearest body to 's1' is unknown: body 'ghost' has no pose yet",
                          n.message)
        finally:
            t_remove = time.monotonic()
            self.m.add(Body(id='ghost', operation=Body.REMOVE))
        self.assertTrue(self.m.wait_listed('ghost', present=False))
        self.assertIsNotNone(self.m.wait_event(CollisionEvent.UNKNOWN_END, 'ghost', 's1',
                                               since=t_remove))
        n = self.distance('s1', '')
        self.assertTrue(n.success, n.message)
        self.assertEqual((n.result.body_b, n.result.distance), ('s2', 1.0))
        r = self.m.check_collision(probe, pose(0, -20, 0), 0.1)
        self.assertEqual((r.success, r.pairs, r.message), (True, [], ''))

    def test_14_invalid_pose_topic_changes_nothing(self):
        # Bug: a pose_topic that is no ROS name replaced the body and dropped its working
        # subscription before roscpp's subscribe() threw; the body stayed UNKNOWN for good.
        pub = self.add_pose_topic_body('tracked2', 0.5, '/tracker2/pose')

        def publish():
            publish_stamped_now(pub, 'world', pose(10.0, 0, 0))
        try:
            publish()
            self.assertIsNotNone(wait_for(lambda: publish() or (lambda x: x if x.success and abs(
                x.result.distance - 5.5) < 1e-9 else None)(self.distance('tracked2', 's2')), 3.0))
            self.m.add(sphere_body('tracked2', 2.0, pose_topic='/tracker2/pose-1'))
            self.assertTrue(wait_for(lambda: 'is not a valid ROS name' in (
                self.m.diag_value('last rejection') or ''), 3.0, 0.1),
                self.m.diag_value('last rejection'))
            self.assertIn("pose_topic '/tracker2/pose-1' is not a valid ROS name: Character [-]",
                          self.m.diag_value('last rejection'))
            # Still the 0.5 m sphere on its old topic: fresh well past pose_timeout (0.5 s).
            t0 = time.monotonic()
            while time.monotonic() - t0 < 1.5:
                publish()
                time.sleep(0.05)
            r = self.distance('tracked2', 's2')
            self.assertTrue(r.success, r.message)
            self.assertAlmostEqual(r.result.distance, 5.5, delta=1e-9)
            self.assertEqual(pub.get_num_connections(), 1)

            # Bug: `~name` (valid, node.md) passed validation, then roscpp's subscribe() threw
            # after the body was replaced: stale for good. It is the private namespace's name.
            private = rospy.Publisher(NS + 'tracker2_pose', PoseStamped, queue_size=10)
            self.m.add(sphere_body('tracked2', 1.0, pose_topic='~tracker2_pose'))
            self.assertTrue(wait_for(lambda: private.get_num_connections() > 0, 5.0))
            self.assertTrue(wait_for(lambda: pub.get_num_connections() == 0, 5.0))
            self.assertIsNotNone(wait_for(
                lambda: publish_stamped_now(private, 'world', pose(20.0, 0, 0)) or (
                    lambda x: x if x.success and abs(x.result.distance - 15.0) < 1e-9 else None)(
                        self.distance('tracked2', 's2')), 3.0))
        finally:
            self.m.add(Body(id='tracked2', operation=Body.REMOVE))
        self.assertTrue(self.m.wait_listed('tracked2', present=False))


    def test_15_get_loggers_does_not_crash_the_node(self):
        # Bug: roscpp's own ~get_loggers (rosconsole on log4cxx 1.0, Debian 12) freed log4cxx's
        # logger repository: the second call, as rqt_logger_level makes, killed the node (SIGSEGV).
        get_loggers = rospy.ServiceProxy(NS + 'get_loggers', GetLoggers)
        set_level = rospy.ServiceProxy(NS + 'set_logger_level', SetLoggerLevel)
        for _ in range(5):
            names = {l.name: l.level for l in get_loggers().loggers}
            self.assertEqual(names.get('ros.collision_monitor'), 'info', names)
            self.assertEqual(names.get('ros.roscpp'), 'info', names)
        try:
            set_level('ros.collision_monitor', 'debug')
            names = {l.name: l.level for l in get_loggers().loggers}
            self.assertEqual(names['ros.collision_monitor'], 'debug')
            self.assertEqual(names['ros.roscpp'], 'info')
        finally:
            set_level('ros.collision_monitor', 'info')
        answer = get_loggers().loggers  # one answer, sorted by name
        self.assertEqual(answer, sorted(answer, key=lambda l: l.name))
        self.assertIsNotNone(self.wait_distance('s1', 's2', 1.0))  # alive and answering

    def test_16_exact_stamps_and_min_distance(self):
        # min_distance is the nearest checked pair's distance, also beyond warning_distance
        # (it was +inf unless a pair was within 5.5 cm). Oracle: the nearest body of every body
        # with a fresh pose, from ~get_distance.
        self.assertIsNotNone(self.wait_distance('s1', 's2', 1.0))

        def nearest_overall():
            ds = [r.result.distance for r in (self.distance(b, '') for b in self.m.ids())
                  if r.success]
            return min(ds) if ds else None
        for x in (3.0, 2.5):
            self.poses.set('s2', pose(x, 0, 0))
            self.assertIsNotNone(self.wait_distance('s1', 's2', x - 2.0))
            expected = nearest_overall()
            self.assertGreater(expected, 0.1)
            self.assertTrue(wait_for(lambda: abs(self.m.state.min_distance - expected) < 1e-9,
                                     3.0), (self.m.state.min_distance, expected))

        # Stamps to the nanosecond: a stamp that seconds in a double do not hold (they are 238 ns
        # apart at 1.7e9 s) comes back exactly in the WARNING_BEGIN it causes and in ~state.
        self.poses.paused.update({'s1', 's2'})
        time.sleep(0.1)  # no streamed pose newer than ours in flight
        stamp = rospy.Time.now() - rospy.Duration(0, 20000000)
        while abs(Fraction(stamp.to_sec()) - Fraction(stamp.to_nsec(), 10**9)) <= \
                Fraction(1, 2 * 10**9):
            stamp += rospy.Duration(0, 1)
        msg = BodyPoses()
        msg.header.frame_id = 'world'
        msg.header.stamp = stamp
        msg.ids = ['s1', 's2']
        msg.poses = [pose(0, 0, 0), pose(2.03, 0, 0)]
        t0 = time.monotonic()
        self.m.poses_pub.publish(msg)
        ev = self.m.wait_event(E.WARNING_BEGIN, 's1', 's2', timeout=3.0, since=t0)
        self.assertIsNotNone(ev, 'no WARNING_BEGIN')
        self.assertEqual(ev[1].header.stamp, stamp)
        self.assertTrue(wait_for(lambda: any(st.header.stamp == stamp
                                             for st in list(self.m.states)), 3.0),
                        [st.header.stamp for st in list(self.m.states)[-5:]])

    def test_17_poses_in_a_frame_whose_tf_stopped(self):
        # Bug: every pose message in a frame whose TF had stopped waited 50 ms for TF on a worker
        # thread: 10 pose topics at 50 Hz delayed services by 4 s. One wait per frame now, until
        # its TF moves again (the count is on /diagnostics, 'waits for TF (total)').
        br = tf2_ros.TransformBroadcaster()

        def send_tf():
            br.sendTransform(tf_transform('stopped_frame', xyz=(10.0, 0.0, 0.0)))
        self.m.add(sphere_body('in_stopped', 0.5))
        self.assertTrue(self.m.wait_listed('in_stopped'))
        msg = BodyPoses(ids=['in_stopped'], poses=[pose(0, 0, 0)])
        msg.header.frame_id = 'stopped_frame'

        def publish_pose():
            msg.header.stamp = rospy.Time.now()
            self.m.poses_pub.publish(msg)
        try:
            # While TF runs: posed in stopped_frame, 10 m from the origin.
            self.assertIsNotNone(wait_for(lambda: send_tf() or publish_pose() or (
                lambda r: r if r.success and abs(r.result.distance - 8.5) < 1e-9 else None)(
                    self.distance('s1', 'in_stopped')), 5.0))
            # TF stops; poses stamped after its last transform go on. The last pose above waited
            # for TF newer than its stamp: one more transform, so that the next wait is this
            # test's (a frame whose TF has not moved since its last failed wait is not waited
            # for), and the counts from a report that comes after that wait.
            send_tf()
            time.sleep(0.2)
            self.m.diagnostics = None
            self.assertTrue(wait_for(lambda: self.m.diagnostics is not None, 5.0))
            n0 = int(self.m.diag_value('~body_poses messages (total)'))
            w0 = int(self.m.diag_value('waits for TF (total)'))
            for _ in range(60):
                publish_pose()
                time.sleep(0.01)
            self.assertTrue(wait_for(lambda: int(self.m.diag_value(
                '~body_poses messages (total)')) >= n0 + 60, 5.0, 0.1))
            waits = int(self.m.diag_value('waits for TF (total)')) - w0
            self.assertIn("cannot resolve frame 'stopped_frame'",
                          self.m.diag_value('last rejection'))
            # The first message, and those that began waiting before its wait failed (one per
            # 10 ms over its 50 ms, on as many worker threads); it was one per message (60).
            self.assertLessEqual(waits, 6)
            self.assertGreaterEqual(waits, 1)
            # TF moves again: waits resume, the body is posed again.
            self.assertIsNotNone(wait_for(lambda: send_tf() or publish_pose() or (
                lambda r: r if r.success and abs(r.result.distance - 8.5) < 1e-9 else None)(
                    self.distance('s1', 'in_stopped')), 5.0))
        finally:
            self.m.add(Body(id='in_stopped', operation=Body.REMOVE))
        self.assertTrue(self.m.wait_listed('in_stopped', present=False))

    def test_18_time_to_collision_from_twists_in_another_frame(self):
        # An arm: a 0.5 m sphere on a 2 m lever, its body spinning about world z at 1 rad/s, the
        # twist given in turned_frame (where world z is y); a 0.5 m sphere b at world (0, 2, 10),
        # the arm's origin at world (0, 0, 10). Oracle: the sphere centres are 1 m apart when
        # |(2 cos t, 2 sin t) - (0, 2)| = 1, sin t = 7/8; spinning the other way, sin(-t) = 7/8.
        arm = Body(id='arm', operation=Body.ADD, pose_from_topic=True)
        arm.parts = [shape(Shape.SPHERE, [0.5], pose=pose(2, 0, 0))]
        self.m.add(arm)
        self.m.add(sphere_body('b', 0.5))
        self.assertTrue(self.m.wait_listed('arm') and self.m.wait_listed('b'))

        def spin(rate):
            msg = BodyPoses(ids=['arm', 'b'], poses=[pose(0, 10, 0), pose(0, 10, -2)])
            msg.header.frame_id = 'turned_frame'
            msg.header.stamp = rospy.Time(0)  # static poses: never stale
            msg.twists = [Twist(), Twist()]
            msg.twists[0].angular.y = rate
            self.m.poses_pub.publish(msg)
        try:
            for rate, expected in ((1.0, math.asin(0.875)), (-1.0, math.pi + math.asin(0.875))):
                spin(rate)
                r = wait_for(lambda: (lambda r: r if r.success and abs(
                    r.result.time_to_collision - expected) < 1e-6 else None)(
                        self.distance('arm', 'b')), 5.0)
                self.assertIsNotNone(r, (rate, self.distance('arm', 'b')))
                self.assertAlmostEqual(r.result.distance, math.sqrt(8) - 1, places=9)
                self.assertTrue(point_close(r.result.point_b, (
                    0.5 * math.sqrt(0.5), 2 - 0.5 * math.sqrt(0.5), 10)), r.result.point_b)
            spin(0.0)  # at rest: never
            self.assertIsNotNone(wait_for(lambda: (lambda r: r if r.success and math.isinf(
                r.result.time_to_collision) else None)(self.distance('arm', 'b')), 5.0))
        finally:
            self.m.add(Body(id='arm', operation=Body.REMOVE))
            self.m.add(Body(id='b', operation=Body.REMOVE))
        self.assertTrue(self.m.wait_listed('arm', present=False))
        self.assertTrue(self.m.wait_listed('b', present=False))

    def test_19_pose_topic_spelled_otherwise_or_remapped(self):
        # A tracker that sends one static pose, latched. Bug: replacing the body with the same
        # pose_topic spelled another way ('~tool_pose', then its full name) dropped its pose
        # (the spellings were compared, not the topics), and the latched pose does not come
        # again: UNKNOWN for good.
        latched = rospy.Publisher(NS + 'tool_pose', PoseStamped, queue_size=1, latch=True)
        p = PoseStamped()
        p.header.frame_id = 'world'  # stamp 0: static, never stale
        p.pose = pose(0, 3, 0)
        latched.publish(p)
        # Bug: the node is started with swap_a:=swap_b swap_b:=swap_a (topic_bodies.test), and
        # a pose_topic was remapped twice (swap_a -> swap_b -> swap_a): the body read swap_a.
        swapped = rospy.Publisher('/swap_b', PoseStamped, queue_size=1, latch=True)
        q = PoseStamped()
        q.header.frame_id = 'world'
        q.pose = pose(0, -4, 0)
        swapped.publish(q)
        try:
            self.m.add(sphere_body('tool', 0.5, pose_topic='~tool_pose'))
            self.m.add(sphere_body('swapped', 0.5, pose_topic='swap_a'))
            self.assertIsNotNone(self.wait_distance('tool', 's1', 1.5), self.distance('tool', 's1'))
            self.assertIsNotNone(self.wait_distance('swapped', 's1', 2.5),
                                 self.distance('swapped', 's1'))
            self.m.add(sphere_body('tool', 0.25, pose_topic=NS + 'tool_pose'))
            self.assertIsNotNone(self.wait_distance('tool', 's1', 1.75),
                                 self.distance('tool', 's1'))
            # Still posed well past pose_timeout (0.5 s): nothing else will come.
            time.sleep(1.0)
            r = self.distance('tool', 's1')
            self.assertTrue(r.success, r.message)
            self.assertAlmostEqual(r.result.distance, 1.75, places=9)
            self.assertEqual(latched.get_num_connections(), 1)
        finally:
            self.m.add(Body(id='tool', operation=Body.REMOVE))
            self.m.add(Body(id='swapped', operation=Body.REMOVE))
        self.assertTrue(self.m.wait_listed('tool', present=False))
        self.assertTrue(self.m.wait_listed('swapped', present=False))

    def test_20_a_replaced_body_takes_no_pose_from_its_old_topic(self):
        # Bug: a body replaced while its pose_topic streamed could take a pose from the old
        # subscription (a callback in flight while the replacement shut it down): stamped 0, that
        # pose never aged, and a body with no source of poses was checked where nobody put it
        # (7 of 100 replacements). Four bodies follow a 500 Hz stream, then become ~body_poses
        # bodies that nobody poses, 60 times: each must stay without a pose.
        fast = rospy.Publisher('/race/pose', PoseStamped, queue_size=100)
        running = threading.Event()
        running.set()

        def stream():
            p = PoseStamped()
            p.header.frame_id = 'world'  # stamp 0: a static pose
            p.pose = pose(0, 6, 0)
            while running.is_set():
                fast.publish(p)
                time.sleep(0.002)
        streamer = threading.Thread(target=stream, daemon=True)
        streamer.start()
        ids = ['race%d' % k for k in range(4)]

        def listed(group):
            # The bodies of `group` (each round's replacements have their own) that hold a pose.
            r = self.m.list_bodies()
            present = [i for i in ids if i in r.ids and r.groups[r.ids.index(i)] == group]
            return present, [i for i in present if not r.stale[r.ids.index(i)]]
        posed_after = []
        try:
            for round_ in range(60):
                for i in ids:
                    self.m.add(sphere_body(i, 0.1, pose_topic='/race/pose'))
                self.assertTrue(wait_for(lambda: listed('')[1] == ids, 5.0), round_)
                group = 'replaced%d' % round_  # ~body_poses now: no pose until one comes
                for i in ids:
                    self.m.add(sphere_body(i, 0.1, group=group))
                self.assertTrue(wait_for(lambda: listed(group)[0] == ids, 5.0), round_)
                time.sleep(0.1)  # a pose in flight on the old subscription has landed by now
                posed_after += [(round_, i) for i in listed(group)[1]]
        finally:
            running.clear()
            streamer.join()
            for i in ids:
                self.m.add(Body(id=i, operation=Body.REMOVE))
        self.assertTrue(wait_for(lambda: not set(ids) & set(self.m.ids()), 5.0))
        self.assertEqual(posed_after, [])

    def test_21_rejections_over_the_log_budget_are_counted_in_the_log(self):
        # Bug: rejections over the log budget (20 lines/s) were counted only in the next line
        # logged: after a burst with nothing after it, in none (906 rejections, 20 lines).
        lines = []
        sub = rospy.Subscriber('/rosout', Log, lambda m: lines.append(m.msg), queue_size=1000)
        time.sleep(1.5)  # connected, and the budget's second is a new one
        for k in range(30):
            self.m.add(Body(id='flood%02d' % k, operation=Body.ADD))  # no parts: refused
        summary = wait_for(lambda: [m for m in lines if 'rejections not logged' in m], 5.0)
        time.sleep(0.5)
        sub.unregister()
        self.assertIsNotNone(summary)
        # Every refusal is in the log: a line of its own, or counted in a line (the burst may
        # straddle the budget's second: then a later line says "and N other").
        logged = [m for m in lines if "body 'flood" in m and 'rejections not logged' not in m]
        counted = sum(int(n) for m in lines
                      for n in re.findall(r'(\d+) (?:other )?rejections not logged', m))
        self.assertEqual(len(logged) + counted, 30, lines)
        self.assertIn("(the last: ~bodies: body 'flood29' refused", summary[-1])

    def test_22_sources_of_different_rates_are_checked_at_one_time(self):
        # Two spheres (r 0.1) moving together at 1 m/s, 0.03 m apart: 'tfball' on TF at 100 Hz,
        # 'posedball' on ~body_poses at 10 Hz. Each was checked at its latest pose: TF up to
        # 0.1 s ahead, 0.03 m reported as -0.07 to 0.03 m, COLLISION flapping every 100 ms. Now
        # the TF sphere is taken back to the other's stamp: 0.03 m in every verdict once the
        # posed sphere has moved (its second pose), WARNING throughout.
        pair = frozenset(('tfball', 'posedball'))
        states = []

        def on_state(msg):
            states.extend((msg.header.stamp, p.distance, p.status) for p in msg.pairs
                          if frozenset((p.body_a, p.body_b)) == pair)
        sub = rospy.Subscriber(NS + 'state', CollisionState, on_state, queue_size=1000)
        br = tf2_ros.TransformBroadcaster()
        t0 = rospy.Time.now()

        def x_of(stamp):  # tfball's centre; posedball's is 0.23 m ahead
            return -1.0 + (stamp - t0).to_sec()
        br.sendTransform(tf_transform('ball_frame', stamp=t0, xyz=(x_of(t0), 20.0, 0.0)))
        self.m.add(sphere_body('tfball', 0.1, frame='ball_frame', pose_from_topic=False))
        self.m.add(sphere_body('posedball', 0.1))
        self.assertTrue(self.m.wait_listed('tfball') and self.m.wait_listed('posedball'))
        start = time.monotonic()
        try:
            for k in range(200):  # 2 s
                now = rospy.Time.now()
                br.sendTransform(tf_transform('ball_frame', stamp=now, xyz=(x_of(now), 20.0, 0.0)))
                if k % 10 == 0 or k == 1:  # moving from its second pose on
                    msg = BodyPoses()
                    msg.header.frame_id = 'world'
                    msg.header.stamp = now
                    msg.ids = ['posedball']
                    msg.poses = [pose(x_of(now) + 0.23, 20.0, 0.0)]
                    self.m.poses_pub.publish(msg)
                    if k == 1:
                        second = now
                time.sleep(max(0.0, start + (k + 1) * 0.01 - time.monotonic()))
            time.sleep(0.3)
        finally:
            sub.unregister()
            for i in pair:
                self.m.add(Body(id=i, operation=Body.REMOVE))
        checked = [(st, d, status) for st, d, status in states if st >= second]
        self.assertGreater(len(checked), 100, len(checked))
        worst = max(abs(d - 0.03) for _, d, _ in checked)
        self.assertLess(worst, 1e-6, sorted(checked, key=lambda c: -abs(c[1] - 0.03))[:3])
        self.assertEqual({status for _, _, status in checked}, {PairState.WARNING})
        # No flapping: at most the first WARNING_BEGIN, and the removal's WARNING_END.
        self.assertIsNotNone(self.m.wait_event(E.WARNING_END, 'tfball', 'posedball', 3.0))
        kinds = [e.type for e in self.m.events_for({pair}) if e.header.stamp >= second]
        self.assertIn(kinds, ([E.WARNING_END], [E.WARNING_BEGIN, E.WARNING_END]), kinds)

    def test_23_a_pass_between_two_poses_of_a_slower_body_is_caught_up(self):
        # A dart on TF at 100 Hz (5 m/s) flies through a target posed on ~body_poses about every
        # 0.2 s, between two of the target's poses (the dart 0.7 m off at both: the target is
        # posed as the dart passes fixed places, which a late loop on a loaded machine moves by
        # no more than the loop is late; posed every 20th loop from a time taken before the
        # bodies were listed, the dart was 0.38 m off once in CI). The pair's time moves
        # from one of the target's stamps to the next; in between it is checked at the dart's
        # poses, the target interpolated: COLLISION_BEGIN and COLLISION_END come, stamped between
        # the two poses, each with the distance at its stamp. Checked only at the target's
        # stamps, the pass was not seen.
        self._dart_through_target()

    def test_23b_a_pass_between_checks_that_tf_outran_is_caught_up(self):
        # The same with no check in the pass: check_on_tf off, a heartbeat every 5 s and the pose
        # stream of the other bodies paused, so the monitor checks only at the target's poses
        # (stamped 5 ms behind the dart's TF, so that every check sees the stamps apart). It looks
        # the dart's frame up at the TF stamps between two checks (node.md, Catch-up): the same
        # two events, at the dart's stamps, with their distances. Before, a TF body kept only
        # the transforms its checks saw, all 0.7 m or more off the target: no event.
        with self._no_check_but_at_poses():
            self._dart_through_target(lag=0.005)

    @contextmanager
    def _no_check_but_at_poses(self):
        """check_on_tf off, a heartbeat every 5 s and the pose stream of the other bodies paused:
        the monitor checks only at the poses the test sends."""
        client = Client(NS.rstrip('/'), timeout=10.0)
        client.update_configuration({'check_on_tf': False, 'rate': 0.2})
        with self.poses.lock:
            paused = set(self.poses.poses) - self.poses.paused
            self.poses.paused |= paused
        try:
            yield
        finally:
            with self.poses.lock:
                self.poses.paused -= paused
            client.update_configuration({'check_on_tf': True, 'rate': 2.0})

    def test_23c_a_world_posed_at_one_time_is_caught_up_between_checks(self):
        # A TF dart at 100 Hz (5 m/s) flies through a static target (a ~body_poses pose stamped
        # 0), with no check in the pass: check_on_tf off, a heartbeat every 5 s and the pose
        # stream of the other bodies paused. Every check sees one timed stamp, the dart's. From
        # the dart's second TF stamp since a check, the monitor keeps its poses and checks the
        # pair at them (node.md, Catch-up): COLLISION_BEGIN and COLLISION_END at the dart's
        # stamps, with their distances. Before, a world posed at one time kept no pose between
        # two checks: no event.
        pair = frozenset(('dart2', 'target2'))
        since = time.monotonic()
        br = tf2_ros.TransformBroadcaster()
        t0 = rospy.Time.now()

        def dart_x(stamp):  # at 0 at t0 + 0.4 s
            return -2.0 + 5.0 * (stamp - t0).to_sec()

        def gap(stamp):  # the target 0.05 m off the dart's line
            return math.hypot(dart_x(stamp), 0.05) - 0.2

        def pose_target():
            msg = BodyPoses()
            msg.header.frame_id = 'world'  # stamp 0: static
            msg.ids = ['target2']
            msg.poses = [pose(0.0, -29.95, 0.0)]
            self.m.poses_pub.publish(msg)
        with self._no_check_but_at_poses():
            try:
                br.sendTransform(tf_transform('dart2_frame', stamp=t0, xyz=(-2.0, -30.0, 0.0)))
                self.m.add(sphere_body('dart2', 0.1, frame='dart2_frame', pose_from_topic=False))
                self.m.add(sphere_body('target2', 0.1))
                self.assertTrue(self.m.wait_listed('dart2') and self.m.wait_listed('target2'))
                pose_target()  # a check, both bodies posed: the pair known CLEAR before the pass
                self.assertTrue(self.wait_distance('dart2', 'target2', math.hypot(2.0, 0.05) - 0.2))
                t0 = rospy.Time.now()
                start = time.monotonic()
                for k in range(80):  # 0.8 s
                    now = rospy.Time.now()
                    br.sendTransform(
                        tf_transform('dart2_frame', stamp=now, xyz=(dart_x(now), -30.0, 0.0)))
                    time.sleep(max(0.0, start + (k + 1) * 0.01 - time.monotonic()))
                end = rospy.Time.now()
                pose_target()  # the same place again: a check (check_on_pose)
                self.assertIsNotNone(
                    self.m.wait_event(E.COLLISION_END, 'dart2', 'target2', 3.0, since=since))
            finally:
                for i in pair:
                    self.m.add(Body(id=i, operation=Body.REMOVE))
        self._assert_one_pass(pair, since, t0, end, gap)

    def _assert_one_pass(self, pair, since, lo, hi, gap):
        """The pair's events since `since`: COLLISION_BEGIN and COLLISION_END stamped between `lo`
        and `hi`, each with the distance gap(stamp) there."""
        hits = [e for e in self.m.events_for({pair}, since)
                if e.type in (E.COLLISION_BEGIN, E.COLLISION_END)]
        self.assertEqual([e.type for e in hits], [E.COLLISION_BEGIN, E.COLLISION_END], hits)
        for e in hits:
            stamp = e.header.stamp
            self.assertTrue(lo < stamp < hi, (lo, stamp, hi))
            self.assertAlmostEqual(e.pair.distance, gap(stamp), delta=1e-6)
        self.assertLessEqual(hits[0].pair.distance, 0.0)
        self.assertGreater(hits[1].pair.distance, 0.0)

    def _dart_through_target(self, lag=0.0):
        # lag: the target's poses are stamped this many seconds before the dart's TF of the time.
        pair = frozenset(('dart', 'target'))
        since = time.monotonic()  # test_23b's run after test_23's
        br = tf2_ros.TransformBroadcaster()
        t0 = rospy.Time.now()

        def dart_x(stamp):  # at 0 at t0 + 1.1 s, between the target's poses at -0.7 and +0.7
            return -5.5 + 5.0 * (stamp - t0).to_sec()

        def target_y(stamp):  # moving slowly across the dart's line
            return 30.0 + 0.05 * (stamp - t0).to_sec()

        def gap(stamp):
            return math.hypot(dart_x(stamp), target_y(stamp) - 30.0) - 0.2
        br.sendTransform(tf_transform('dart_frame', stamp=t0, xyz=(dart_x(t0), 30.0, 0.0)))
        self.m.add(sphere_body('dart', 0.1, frame='dart_frame', pose_from_topic=False))
        self.m.add(sphere_body('target', 0.1))
        self.assertTrue(self.m.wait_listed('dart') and self.m.wait_listed('target'))
        t0 = rospy.Time.now()  # the pass 1.1 s from here, whatever the wait took
        places = [-4.5, -3.5, -2.5, -1.5, -0.7, 0.7, 1.5]  # where the target is posed, in dart_x
        start = time.monotonic()
        posed = []
        try:
            for k in range(160):  # 1.6 s
                now = rospy.Time.now()
                br.sendTransform(tf_transform('dart_frame', stamp=now, xyz=(dart_x(now), 30.0, 0.0)))
                if len(posed) < len(places) and dart_x(now) >= places[len(posed)]:
                    msg = BodyPoses()
                    msg.header.frame_id = 'world'
                    msg.header.stamp = now - rospy.Duration(lag)
                    msg.ids = ['target']
                    msg.poses = [pose(0.0, target_y(msg.header.stamp), 0.0)]
                    self.m.poses_pub.publish(msg)
                    posed.append(msg.header.stamp)
                time.sleep(max(0.0, start + (k + 1) * 0.01 - time.monotonic()))
            self.assertIsNotNone(
                self.m.wait_event(E.COLLISION_END, 'dart', 'target', 3.0, since=since))
        finally:
            for i in pair:
                self.m.add(Body(id=i, operation=Body.REMOVE))
        # The target's two poses around the pass, with the dart 0.7 m off at both.
        before = max(p for p in posed if dart_x(p) < 0.0)
        after = min(p for p in posed if dart_x(p) > 0.0)
        self.assertGreater(gap(before), 0.2)
        self.assertGreater(gap(after), 0.2)
        self.assertGreaterEqual(len(posed), 6)  # the target moving before the pass
        self._assert_one_pass(pair, since, before, after, gap)

    def test_24_same_group_is_never_checked_by_get_distance(self):
        # Bodies sharing a non-empty group are never checked against each other (INTERFACE.md,
        # Body.group): ~get_distance refuses the pair with the reason (node.md, Services); bodies
        # of different groups are checked as any other pair. g1 and g2 in group 'team' 0.5 m
        # apart, g3 in group 'other' 0.5 m from g1: spheres of 0.5 m, far from the others.
        self.m.add(sphere_body('g1', 0.5, group='team'))
        self.m.add(sphere_body('g2', 0.5, group='team'))
        self.m.add(sphere_body('g3', 0.5, group='other'))
        try:
            self.assertTrue(self.m.wait_listed('g1') and self.m.wait_listed('g2') and
                            self.m.wait_listed('g3'))
            self.poses.set('g1', pose(0, 40, 0))
            self.poses.set('g2', pose(1.5, 40, 0))
            self.poses.set('g3', pose(0, 41.5, 0))
            r = self.wait_distance('g1', 'g3', 0.5)
            self.assertIsNotNone(r, self.distance('g1', 'g3'))
            self.assertEqual(r.result.status, PairState.CLEAR)
            r = self.distance('g1', 'g2')
            self.assertFalse(r.success)
            self.assertIn("'g1' and 'g2' are never checked", r.message)
            self.assertIn("group 'team'", r.message)
            self.assertEqual(r.result.status, PairState.UNKNOWN)
        finally:
            with self.poses.lock:
                for i in ('g1', 'g2', 'g3'):
                    self.poses.poses.pop(i, None)
            for i in ('g1', 'g2', 'g3'):
                self.m.add(Body(id=i, operation=Body.REMOVE))
        for i in ('g1', 'g2', 'g3'):
            self.assertTrue(self.m.wait_listed(i, present=False))

    def test_25_body_poses_for_a_tf_body_are_dropped_and_counted(self):
        # ~body_poses only poses bodies with pose_from_topic: entries for TF-attached ids are
        # dropped and counted (node.md, Poses). The shelf hangs on shelf_frame (static TF).
        self.assertIsNotNone(self.wait_distance('s1', 'shelf', 3.5))
        counted = self.rejected_now()
        msg = BodyPoses(ids=['shelf'], poses=[pose(0, 0, 0)])
        msg.header.frame_id = 'world'
        msg.header.stamp = rospy.Time.now()
        self.m.poses_pub.publish(msg)
        last = self.wait_one_more_rejected(
            counted, 'poses for a TF-attached body not counted as rejected')
        self.assertIn('~body_poses', last)
        self.assertIn('shelf', last)
        self.assertIn('attached to TF', last)
        r = self.distance('s1', 'shelf')
        self.assertTrue(r.success, r.message)
        self.assertAlmostEqual(r.result.distance, 3.5, places=9)

    def test_26_zero_quaternion_on_a_pose_topic_is_refused(self):
        # A zero quaternion means identity only in Shape.pose and ~check_collision's pose; it is
        # refused in BodyPoses and PoseStamped (node.md, Input validation). 'zq' (0.5 m) on its
        # pose topic at x = 10 (5.5 m from s2), then zero-quaternion poses at x = 20: refused,
        # so the body is never 15.5 m from s2, and its last good pose goes stale.
        pub = rospy.Publisher('/zq/pose', PoseStamped, queue_size=10)
        self.m.add(sphere_body('zq', 0.5, pose_topic='/zq/pose'))
        try:
            self.assertTrue(self.m.wait_listed('zq'))
            self.assertTrue(wait_for(lambda: pub.get_num_connections() > 0, 5.0))

            def publish(x, w):
                publish_stamped_now(pub, 'world', pose(x, 0, 0, qw=w))
            self.assertIsNotNone(wait_for(lambda: publish(10.0, 1.0) or (
                lambda r: r if r.success and abs(r.result.distance - 5.5) < 1e-9 else None)(
                    self.distance('zq', 's2')), 3.0), self.distance('zq', 's2'))
            answers = []
            t0 = time.monotonic()
            while time.monotonic() - t0 < 1.5:  # 3 pose_timeouts
                publish(20.0, 0.0)
                answers.append(self.distance('zq', 's2'))
                time.sleep(0.05)
            self.assertEqual([a.result.distance for a in answers
                              if a.success and abs(a.result.distance - 15.5) < 1e-6], [])
            self.assertFalse(answers[-1].success, answers[-1].result)
            self.assertTrue(wait_for(lambda: "'zq'" in (self.m.diag_value('last rejection') or '')
                                     and 'refused' in self.m.diag_value('last rejection'),
                                     3.0, 0.1), self.m.diag_value('last rejection'))
        finally:
            self.m.add(Body(id='zq', operation=Body.REMOVE))
        self.assertTrue(self.m.wait_listed('zq', present=False))

    def test_27_check_collision_empty_frame_is_the_fixed_frame(self):
        # body.header.frame_id empty: placed in fixed_frame (node.md, ~check_collision). A 0.5 m
        # probe at (0, 0, 1.2) overlaps s1 (1 m at the origin) by 0.3 m.
        self.assertIsNotNone(self.wait_distance('s1', 's2', 1.0))
        probe = sphere_body('probe', 0.5, frame='', pose_from_topic=False)
        r = self.m.check_collision(probe, pose(0, 0, 1.2), 0.0)
        self.assertTrue(r.success, r.message)
        self.assertTrue(r.in_collision)
        self.assertEqual([(p.body_a, p.body_b) for p in r.pairs], [('probe', 's1')])
        self.assertAlmostEqual(r.pairs[0].distance, -0.3, delta=self.depth_tol)
        self.assertNotIn('probe', self.m.ids())

    def test_28_check_collision_margin_must_be_finite(self):
        # margin is a distance in metres: NaN or infinite is refused with the reason, nothing
        # is checked (node.md: every number must be finite; invalid input: success false).
        probe = sphere_body('probe', 0.5, frame='world', pose_from_topic=False)
        for margin in (float('nan'), float('inf'), float('-inf')):
            r = self.m.check_collision(probe, pose(0, 0, 1.2), margin)
            self.assertFalse(r.success, margin)
            self.assertFalse(r.in_collision, margin)
            self.assertEqual(r.pairs, [], margin)
            self.assertIn('margin', r.message, margin)

    def test_29_diagnostics_level_warn_for_stale_bodies_and_rejections(self):
        # Level: WARN when inputs were rejected since the last report or bodies are stale, else
        # OK (node.md, Diagnostics). 'lonely' is never posed: stale.
        self.m.add(sphere_body('lonely', 0.1))
        try:
            self.assertTrue(self.m.wait_listed('lonely'))
            d = wait_for(lambda: (lambda d: d if d is not None and 'stale' in d.message and
                                  'rejected' not in d.message else None)(self.m.diagnostics),
                         5.0, 0.05)
            self.assertIsNotNone(d, self.m.diagnostics)
            self.assertEqual(d.level, DiagnosticStatus.WARN, d.message)
            self.assertIn('lonely', d.message)
            # A rejected input: REMOVE of the YAML shelf.
            self.m.diagnostics = None
            self.m.add(Body(id='shelf', operation=Body.REMOVE))
            d = wait_for(lambda: (lambda d: d if d is not None and 'rejected' in d.message
                                  else None)(self.m.diagnostics), 5.0, 0.05)
            self.assertIsNotNone(d, self.m.diagnostics)
            self.assertEqual(d.level, DiagnosticStatus.WARN, d.message)
            self.assertIn("cannot remove 'shelf'", d.message)
        finally:
            self.m.add(Body(id='lonely', operation=Body.REMOVE))
        self.assertTrue(self.m.wait_listed('lonely', present=False))
        # Nothing stale, nothing rejected: OK.
        d = wait_for(lambda: (lambda d: d if d is not None and d.level == DiagnosticStatus.OK
                              else None)(self.m.diagnostics), 5.0, 0.05)
        self.assertIsNotNone(d, self.m.diagnostics)

    def test_30_body_poses_for_unknown_ids_are_dropped_and_counted(self):
        # Entries of ~body_poses for ids the monitor does not track are dropped and counted as
        # rejected inputs (node.md, Poses); the other entries of the message apply. s2 moves to
        # x = 3.5 (1.5 m from s1) in the same message.
        self.assertIsNotNone(self.wait_distance('s1', 's2', 1.0))
        self.poses.paused.add('s2')
        time.sleep(0.1)  # no streamed pose of s2 in flight
        counted = self.rejected_now()
        msg = BodyPoses(ids=['nobody_here', 's2'], poses=[pose(0, 0, 0), pose(3.5, 0, 0)])
        msg.header.frame_id = 'world'
        msg.header.stamp = rospy.Time.now()
        self.m.poses_pub.publish(msg)
        # (within pose_timeout, 0.5 s: s2 is not streamed any more)
        r = self.wait_distance('s1', 's2', 1.5, timeout=0.4)
        self.assertIsNotNone(r, self.distance('s1', 's2'))
        last = self.wait_one_more_rejected(counted,
                                           'a pose for an unknown id not counted as rejected')
        self.assertIn('~body_poses', last)
        self.assertIn('nobody_here', last)
        self.assertIn('unknown', last)
        self.assertNotIn('nobody_here', self.m.ids())

    def test_30b_a_shared_pose_stream_with_ignore_unknown_pose_ids(self):
        # capped_monitor (topic_bodies.test) sets ignore_unknown_pose_ids: a ~body_poses stream
        # that also carries other monitors' ids poses its own bodies, and the other ids are
        # dropped without an error (counted apart); a TF-attached id is still refused. Bug: a
        # shared motion-capture stream logged an ERROR a second and held /diagnostics at WARN.
        capped = Monitor('/capped_monitor/')
        ids = ['w1', 'w2', 'w_tf']
        capped.add(sphere_body('w1', 0.5))
        capped.add(sphere_body('w2', 0.5))
        capped.add(sphere_body('w_tf', 0.1, frame='world', pose_from_topic=False))
        try:
            self.assertTrue(wait_for(lambda: set(ids) <= set(capped.ids()), 5.0), capped.ids())

            def report():
                capped.diagnostics = None
                self.assertTrue(wait_for(lambda: capped.diagnostics is not None, 5.0))
                return (int(capped.diag_value('rejected inputs (total)')),
                        int(capped.diag_value('~body_poses entries for unknown ids ignored '
                                              '(total)')))

            rejected0, ignored0 = report()
            msg = BodyPoses(ids=['other_a', 'w1', 'other_b', 'w2'],
                            poses=[pose(0, 0, 0), pose(0, 0, 0), pose(0, 0, 0), pose(1.7, 0, 0)])
            msg.header.frame_id = 'world'
            for _ in range(3):
                msg.header.stamp = rospy.Time.now()
                capped.poses_pub.publish(msg)
                rospy.sleep(0.1)
            r = capped.get_distance('w1', 'w2', '')
            self.assertTrue(r.success, r.message)
            self.assertAlmostEqual(r.result.distance, 0.7, places=9)
            self.assertEqual(report(), (rejected0, ignored0 + 6))
            msg = BodyPoses(ids=['w_tf'], poses=[pose(0, 0, 0)])
            msg.header.frame_id = 'world'
            msg.header.stamp = rospy.Time.now()
            capped.poses_pub.publish(msg)
            self.assertTrue(wait_for(lambda: report() == (rejected0 + 1, ignored0 + 6), 5.0))
            self.assertIn('bodies attached to TF', capped.diag_value('last rejection'))
        finally:  # test_31 counts this monitor's bodies without a pose
            for i in ids:
                capped.add(Body(id=i, operation=Body.REMOVE))
            self.assertTrue(wait_for(lambda: not set(ids) & set(capped.ids()), 5.0))

    def test_31_unknown_pairs_beyond_max_unknown_pairs_are_counted(self):
        # ~check_collision reports every body without a fresh pose as an UNKNOWN pair, at most
        # max_unknown_pairs of them, and its message says how many there are in all and how
        # many are listed (node.md, ~check_collision). capped_monitor (topic_bodies.test):
        # max_unknown_pairs 1, three bodies never posed.
        capped = Monitor('/capped_monitor/')
        ids = ['u1', 'u2', 'u3']
        for i in ids:
            capped.add(sphere_body(i, 0.1))
        self.assertTrue(wait_for(lambda: capped.ids() == ids, 5.0), capped.ids())
        probe = sphere_body('probe', 0.5, frame='world', pose_from_topic=False)
        r = capped.check_collision(probe, pose(0, 0, 0), 0.1)
        self.assertTrue(r.success, r.message)
        self.assertFalse(r.in_collision)
        self.assertEqual(len(r.pairs), 1, r.pairs)
        self.assertEqual(r.pairs[0].status, PairState.UNKNOWN)
        self.assertIn(r.pairs[0].body_b, ids)
        self.assertEqual(r.pairs[0].distance, float('inf'))
        self.assertIn('3 bodies without a fresh pose', r.message)
        self.assertIn('(1 listed, max_unknown_pairs)', r.message)

    def test_32_get_distance_frame_with_a_leading_slash(self):
        # frame_id '/shelf_frame' is tf2's shelf_frame (as the YAML body's frame_id of
        # topic_bodies.test): s1 at the origin (radius 1), the unit cube shelf at (0, 5, 0) in
        # world, so at (0, 0, 0) in shelf_frame; its witness point (0, 4.5, 0) in world.
        r = wait_for(lambda: (lambda x: x if x.success else None)(self.distance('s1', 'shelf')),
                     5.0)
        self.assertIsNotNone(r, self.distance('s1', 'shelf').message)
        r = self.distance('s1', 'shelf', '/shelf_frame')
        self.assertTrue(r.success, r.message)
        self.assertAlmostEqual(r.result.distance, 3.5, places=9)
        self.assertTrue(point_close(r.result.point_a, (0, -4, 0)), r.result.point_a)
        self.assertTrue(point_close(r.result.point_b, (0, -0.5, 0)), r.result.point_b)

    def test_33_pose_topic_stamped_0_in_a_moving_frame_ages_with_it(self):
        # A PoseStamped stamped 0 in a frame that TF moves takes the time of that frame's
        # transform (node.md): stale pose_timeout (0.5 s) after the frame's TF stops.
        br = tf2_ros.TransformBroadcaster()
        pub = self.add_pose_topic_body('on_mover', 0.5, '/mover/pose')
        p = PoseStamped()
        p.header.frame_id = 'mover_frame'  # stamp 0
        p.pose = pose(0, 0, 0)
        try:
            # mover_frame at (10, 0, 0): 8.5 m from s1 (radius 1).
            self.assertIsNotNone(wait_for(lambda: br.sendTransform(tf_transform(
                'mover_frame', xyz=(10.0, 0.0, 0.0))) or pub.publish(p) or (
                lambda r: r if r.success and abs(r.result.distance - 8.5) < 1e-9 else None)(
                    self.distance('s1', 'on_mover')), 5.0))
            stopped = time.monotonic()
            self.assertTrue(wait_for(lambda: self.m.is_stale('on_mover'), 3.0),
                            'fresh after its frame stopped moving')
            self.assertGreater(time.monotonic() - stopped, 0.3)
        finally:
            self.m.add(Body(id='on_mover', operation=Body.REMOVE))
        self.assertTrue(self.m.wait_listed('on_mover', present=False))

    def test_34_a_static_frame_that_stops_resolving_is_unknown_at_once(self):
        # A failed lookup marks a TF-attached body unresolved: its pairs turn UNKNOWN at once
        # (node.md), also on a static frame (stamp 0, never stale), here re-parented to a frame
        # with no path to world. static_frame at (0, -5, 0): 3.5 m from s1 (radius 1).
        self.m.add(sphere_body('on_static', 0.5, frame='static_frame', pose_from_topic=False))
        self.assertTrue(self.m.wait_listed('on_static'))
        try:
            self.static_tf.sendTransform(self.statics + [tf_transform(
                'static_frame', stamp=rospy.Time(), xyz=(0.0, -5.0, 0.0))])
            self.assertIsNotNone(self.wait_distance('s1', 'on_static', 3.5, timeout=5.0),
                                 self.distance('s1', 'on_static'))
            self.static_tf.sendTransform(self.statics + [tf_transform(
                'static_frame', parent='island', stamp=rospy.Time())])
            r = wait_for(lambda: (lambda x: x if not x.success else None)(
                self.distance('s1', 'on_static')), 3.0)
            self.assertIsNotNone(r, 'still posed after its frame lost its path to world')
            self.assertEqual(r.result.status, PairState.UNKNOWN)
            # With TF's reason (it said "has an unresolved pose", nothing of the frame).
            self.assertTrue(r.message.startswith(
                "body 'on_static' has an unresolved pose: its frame 'static_frame' cannot be "
                "looked up in 'world': "), r.message)
            self.assertIn('not part of the same tree', r.message)  # tf2's own words
        finally:
            self.static_tf.sendTransform(self.statics)
            self.m.add(Body(id='on_static', operation=Body.REMOVE))
        self.assertTrue(self.m.wait_listed('on_static', present=False))

    def test_34b_a_frame_never_in_tf_is_named_with_tf_reason(self):
        # A typo in a frame name: the body never has a pose, and the queries say why (they said
        # "has no pose yet", nothing of the frame).
        self.m.add(sphere_body('on_typo', 0.5, frame='shelf_farme', pose_from_topic=False))
        self.assertTrue(self.m.wait_listed('on_typo'))
        try:
            expected = ("body 'on_typo' has no pose yet: its frame 'shelf_farme' cannot be "
                        "looked up in 'world': ")
            r = wait_for(lambda: (lambda x: x if expected in x.message else None)(
                self.distance('s1', 'on_typo')), 3.0)
            self.assertIsNotNone(r, self.distance('s1', 'on_typo').message)
            self.assertFalse(r.success)
            self.assertTrue(r.message.startswith(expected), r.message)
            self.assertIn('shelf_farme', r.message[len(expected):])  # tf2's own words
            # /diagnostics names the frame too (a stale body's frame said nothing there).
            self.assertTrue(wait_for(lambda: "'shelf_farme': " in (
                self.m.diag_value('unresolved TF frames') or ''), 5.0),
                self.m.diag_value('unresolved TF frames'))
        finally:
            self.m.add(Body(id='on_typo', operation=Body.REMOVE))
        self.assertTrue(self.m.wait_listed('on_typo', present=False))

    def test_35_pose_topic_in_a_turned_frame(self):
        # turned_frame is world turned +90 degrees about x (its y is world z): a PoseStamped at
        # (0, 2, 0) there is at (0, 0, 2) in world, 0.5 m from s1 (radius 1), witness points
        # (0, 0, 1) and (0, 0, 1.5).
        pub = self.add_pose_topic_body('turned', 0.5, '/turned/pose')
        try:
            r = wait_for(lambda: publish_stamped_now(pub, 'turned_frame', pose(0, 2, 0)) or (
                lambda x: x if x.success else None)(self.distance('s1', 'turned')), 3.0)
            self.assertIsNotNone(r, self.distance('s1', 'turned'))
            self.assertAlmostEqual(r.result.distance, 0.5, places=9)
            self.assertTrue(point_close(r.result.point_a, (0, 0, 1)), r.result.point_a)
            self.assertTrue(point_close(r.result.point_b, (0, 0, 1.5)), r.result.point_b)
        finally:
            self.m.add(Body(id='turned', operation=Body.REMOVE))
        self.assertTrue(self.m.wait_listed('turned', present=False))

    def test_36_a_pose_stamped_ahead_ages_from_its_arrival(self):
        # A pose stamped 0.8 s ahead of ROS time (a publisher's clock ahead, within the 1 s
        # tolerance) ages from its arrival (node.md, "Nothing from the future"): stale
        # pose_timeout (0.5 s) after it came, not 0.8 s later. At (0, -3, 0): 1.5 m from s1.
        self.m.add(sphere_body('ahead', 0.5))
        self.assertTrue(self.m.wait_listed('ahead'))
        msg = BodyPoses(ids=['ahead'], poses=[pose(0, -3, 0)])
        msg.header.frame_id = 'world'
        try:
            msg.header.stamp = rospy.Time.now() + rospy.Duration(0.8)
            sent = time.monotonic()
            self.m.poses_pub.publish(msg)
            self.assertIsNotNone(self.wait_distance('s1', 'ahead', 1.5, timeout=0.4),
                                 self.distance('s1', 'ahead'))
            self.assertTrue(wait_for(lambda: self.m.is_stale('ahead'), 3.0), 'never stale')
            self.assertLess(time.monotonic() - sent, 1.0, 'aged from its stamp, not its arrival')
        finally:
            self.m.add(Body(id='ahead', operation=Body.REMOVE))
        self.assertTrue(self.m.wait_listed('ahead', present=False))

    def test_37_time_to_collision_estimated_from_tf_and_pose_topic(self):
        # estimate_twists (dynamic_reconfigure): 'tfmover' (0.25 m) on a TF frame coming at 1 m/s
        # along x towards 'wall' (0.25 m, on ~body_poses, still), 'ptmover' (0.25 m) on its
        # pose_topic at 0.5 m/s along y towards it. Neither source has a twist: each pair's time
        # to collision is its distance over the speed the last two poses give (the frame's
        # stamps 20 ms apart). Off: +inf, as for every body without a twist.
        client = Client(NS.rstrip('/'), timeout=10.0)
        br = tf2_ros.TransformBroadcaster()
        t0 = rospy.Time.now()

        def send(stamp):
            dt = (stamp - t0).to_sec()
            br.sendTransform(tf_transform('mover_frame', stamp=stamp, xyz=(-8.0 + dt, 0.0, 30.0)))
            p = PoseStamped()
            p.header.frame_id = 'world'
            p.header.stamp = stamp
            p.pose = pose(0.0, -6.0 + 0.5 * dt, 30.0)
            pt.publish(p)
        pt = self.add_pose_topic_body('ptmover', 0.25, '/ptmover/pose')
        send(t0)
        self.m.add(sphere_body('tfmover', 0.25, frame='mover_frame', pose_from_topic=False))
        self.m.add(sphere_body('wall', 0.25))
        self.assertTrue(self.m.wait_listed('tfmover') and self.m.wait_listed('wall'))
        self.poses.set('wall', pose(0.0, 0.0, 30.0))
        samples = {'tfmover': [], 'ptmover': []}
        try:
            for estimate in (True, False):
                client.update_configuration({'estimate_twists': estimate})
                start = time.monotonic()
                for k in range(100):  # 2 s at 50 Hz
                    send(rospy.Time.now())
                    if k >= 50 and k % 5 == 0:
                        for mover, speed in (('tfmover', 1.0), ('ptmover', 0.5)):
                            r = self.distance(mover, 'wall')
                            self.assertTrue(r.success, r.message)
                            samples[mover].append((estimate, r.result.distance, speed,
                                                   r.result.time_to_collision))
                    time.sleep(max(0.0, start + (k + 1) * 0.02 - time.monotonic()))
        finally:
            client.update_configuration({'estimate_twists': False})
            for i in ('tfmover', 'ptmover', 'wall'):
                self.m.add(Body(id=i, operation=Body.REMOVE))
            with self.poses.lock:
                self.poses.poses.pop('wall', None)
        for mover, got in samples.items():
            self.assertEqual(len(got), 20, got)
            for estimate, d, speed, ttc in got:
                self.assertGreater(d, 0.5, (mover, got))  # still coming
                if estimate:
                    self.assertAlmostEqual(ttc, d / speed, delta=1e-6, msg=(mover, d, ttc))
                else:
                    self.assertTrue(math.isinf(ttc) and ttc > 0, (mover, d, ttc))
        for i in ('tfmover', 'ptmover', 'wall'):
            self.assertTrue(self.m.wait_listed(i, present=False), i)


if __name__ == '__main__':
    rostest.rosrun('collision_monitor', 'topic_bodies', TopicBodies, sys.argv)
