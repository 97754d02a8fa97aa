#!/usr/bin/python3
"""rostest: Franka Panda from the URDF (one body per link with collision geometry, attached to
the link frames published by robot_state_publisher), adjacent-link and SRDF exclusion, a
topic-posed obstacle against the hand, robot links going stale when joint states stop, links'
own padding and groups (robot_link_padding, robot_link_groups), and the manager's ~get_loggers
(replaced by the nodelet: roscpp's crashes the process on Debian 12)."""
import sys
import threading
import time
import unittest
import xml.etree.ElementTree as ET
import xmlrpc.client

import rosgraph
import rosnode
import rospy
import rostest
import tf2_ros
from collision_monitor.msg import Body, CollisionEvent
from collision_monitor.srv import CheckCollision, GetDistance, ListBodies
from rosgraph_msgs.msg import Log
from roscpp.srv import GetLoggers
from sensor_msgs.msg import JointState
from tf2_msgs.msg import TFMessage

from cm_test_util import (Monitor, PoseStreamer, panda_joint_state, pose, sphere_body,
                          tf_transform, wait_for)

E = CollisionEvent
LINKS = ['panda_hand', 'panda_leftfinger', 'panda_link0', 'panda_link1', 'panda_link2',
         'panda_link3', 'panda_link4', 'panda_link5', 'panda_link6', 'panda_link7',
         'panda_rightfinger']


class JointStates:
    def __init__(self, rate=20.0):
        self.pub = rospy.Publisher('/joint_states', JointState, queue_size=10)
        self.running = True
        threading.Thread(target=self._run, args=(1.0 / rate,), daemon=True).start()

    def _run(self, period):
        while not rospy.is_shutdown():
            if self.running:
                try:
                    self.pub.publish(panda_joint_state())
                except rospy.ROSException:  # shutting down
                    return
            time.sleep(period)


class Panda(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_panda')
        cls.joints = JointStates()
        cls.tf = tf2_ros.Buffer()
        cls.tf_listener = tf2_ros.TransformListener(cls.tf)
        cls.m = Monitor()
        srdf = ET.fromstring(rospy.get_param('/robot_description_semantic'))
        cls.disabled = {frozenset((e.get('link1'), e.get('link2')))
                        for e in srdf.iter('disable_collisions')}
        cls.adjacent = {frozenset((e.get('link1'), e.get('link2')))
                        for e in srdf.iter('disable_collisions') if e.get('reason') == 'Adjacent'}

    def wait_fresh(self, a, b, timeout=5.0):
        return wait_for(lambda: (lambda r: r if r.success else None)(
            self.m.get_distance(a, b, '')), timeout, 0.05)

    def test_01_links_with_collision_are_bodies(self):
        r = self.m.list_bodies()
        self.assertEqual(sorted(r.ids), LINKS)
        self.assertEqual(list(r.frames), list(r.ids))
        self.assertEqual(set(r.groups), {''})
        self.assertEqual(self.m.state.header.frame_id, 'panda_link0')  # root link of the URDF
        # fixed_frame is set empty (panda.test): reported, the default used.
        self.assertTrue(wait_for(lambda: self.m.diag_value('invalid parameter') is not None, 5.0))
        self.assertEqual(self.m.diag_value('invalid parameter'),
                         'fixed_frame is empty; using panda_link0')

    def test_02_disabled_pairs_are_refused_with_the_reason(self):
        r = self.m.get_distance('panda_link0', 'panda_link1', '')
        self.assertFalse(r.success)
        self.assertIn('adjacent links', r.message)
        r = self.m.get_distance('panda_link0', 'panda_link2', '')  # SRDF "Never"
        self.assertFalse(r.success)
        self.assertIn('SRDF', r.message)
        r = self.m.get_distance('panda_link7', 'panda_hand', '')  # adjacent through panda_link8
        self.assertFalse(r.success)
        self.assertIn('disabled', r.message)

    def test_02b_urdf_link_cannot_be_replaced_from_the_topic(self):
        self.m.add(sphere_body('panda_hand', 1.0, frame='elsewhere', pose_from_topic=False))
        time.sleep(0.3)
        r = self.m.list_bodies()
        self.assertEqual(sorted(r.ids), LINKS)
        self.assertEqual(r.frames[list(r.ids).index('panda_hand')], 'panda_hand')
        self.assertTrue(wait_for(lambda: 'panda_hand' in (self.m.diag_value('last rejection')
                                                          or ''), 3.0, 0.1))

    def test_03_enabled_pair_has_a_distance(self):
        r = self.wait_fresh('panda_link0', 'panda_hand')
        self.assertIsNotNone(r, self.m.get_distance('panda_link0', 'panda_hand', '').message)
        self.assertGreater(r.result.distance, 0.1)
        # The nearest body to the hand is one it may collide with.
        n = self.m.get_distance('panda_hand', '', '')
        self.assertTrue(n.success, n.message)
        self.assertNotIn(frozenset(('panda_hand', n.result.body_b)), self.disabled)

    def test_04_disabled_pairs_never_fire(self):
        self.assertIsNotNone(self.wait_fresh('panda_link0', 'panda_hand'))
        time.sleep(1.0)
        self.assertEqual(self.m.events_for(self.disabled), [])
        st = self.m.state
        for p in st.pairs:
            self.assertNotIn(frozenset((p.body_a, p.body_b)), self.disabled)
        self.assertFalse(st.in_collision, [(p.body_a, p.body_b, p.distance) for p in st.pairs])
        self.assertGreater(st.num_bodies, 10)

    def test_05_obstacle_at_the_hand(self):
        t = self.tf.lookup_transform('panda_link0', 'panda_hand', rospy.Time(0),
                                     rospy.Duration(5.0))
        c = t.transform.translation
        streamer = PoseStreamer(self.m.poses_pub, 'panda_link0', rate=20.0)
        self.m.add(sphere_body('obstacle', 0.05))
        self.assertTrue(self.m.wait_listed('obstacle'))
        t0 = time.monotonic()
        streamer.set('obstacle', pose(c.x, c.y, c.z))
        ev = self.m.wait_event(E.COLLISION_BEGIN, 'obstacle', 'panda_hand', 3.0, since=t0)
        self.assertIsNotNone(ev, 'no COLLISION_BEGIN between the obstacle and the hand')
        self.assertLess(ev[1].pair.distance, 0.0)
        t1 = time.monotonic()
        streamer.set('obstacle', pose(c.x, c.y, c.z + 1.0))
        self.assertIsNotNone(
            self.m.wait_event(E.COLLISION_END, 'obstacle', 'panda_hand', 3.0, since=t1))
        streamer.paused.add('obstacle')

    def test_06_robot_goes_stale_without_joint_states(self):
        self.assertIsNotNone(self.wait_fresh('panda_link0', 'panda_hand'))
        t0 = time.monotonic()
        self.joints.running = False
        # Whatever fails below, the joints run again for the later tests.
        self.addCleanup(setattr, self.joints, 'running', True)
        ev = self.m.wait_event(E.UNKNOWN_BEGIN, 'panda_link0', 'panda_hand', 3.0, since=t0)
        self.assertIsNotNone(ev, 'robot links did not turn UNKNOWN when TF stopped')
        r = self.m.get_distance('panda_link0', 'panda_hand', '')
        self.assertFalse(r.success)
        self.assertIn('panda_hand', r.message)
        # ~state and ~events are separate topics: the state of the cycle that raised the event may
        # arrive after it (it did once in CI, under load), so wait for it.
        state = wait_for(lambda: (lambda s: s if 'panda_hand' in s.stale_bodies else None)(
            self.m.state), 3.0)
        self.assertIsNotNone(state, 'no ~state lists panda_hand as stale')
        self.assertNotIn('panda_link0', state.stale_bodies)  # the fixed frame itself
        t1 = time.monotonic()
        self.joints.running = True
        self.assertIsNotNone(
            self.m.wait_event(E.UNKNOWN_END, 'panda_link0', 'panda_hand', 3.0, since=t1))
        self.assertEqual(self.m.events_for(self.adjacent), [])

    def test_07_tf_attached_obstacle_latency(self):
        # A body attached to a TF frame the test broadcasts. The heartbeat is 2 Hz here, so a
        # fast event shows that new TF data triggers a check.
        hand = self.tf.lookup_transform('panda_link0', 'panda_hand', rospy.Time(0),
                                        rospy.Duration(5.0)).transform.translation
        broadcaster = tf2_ros.TransformBroadcaster()
        where = {'z': hand.z + 1.0}

        def send():
            broadcaster.sendTransform(tf_transform('probe_frame', parent='panda_link0',
                                                   xyz=(hand.x, hand.y, where['z'])))
        stop = threading.Event()

        def run():
            while not stop.is_set() and not rospy.is_shutdown():
                try:
                    send()
                except rospy.ROSException:
                    return
                time.sleep(0.05)
        threading.Thread(target=run, daemon=True).start()
        try:
            self.m.add(sphere_body('tf_probe', 0.05, frame='probe_frame', pose_from_topic=False))
            self.assertTrue(self.m.wait_listed('tf_probe'))
            self.assertIsNotNone(self.wait_fresh('tf_probe', 'panda_hand'))
            latencies = []
            for _ in range(3):
                t0 = time.monotonic()
                where['z'] = hand.z
                send()
                ev = self.m.wait_event(E.COLLISION_BEGIN, 'tf_probe', 'panda_hand', 3.0, since=t0)
                self.assertIsNotNone(ev, 'no COLLISION_BEGIN for the TF-attached probe')
                latencies.append(ev[0] - t0)
                t1 = time.monotonic()
                where['z'] = hand.z + 1.0
                send()
                self.assertIsNotNone(
                    self.m.wait_event(E.COLLISION_END, 'tf_probe', 'panda_hand', 3.0, since=t1))
            latencies.sort()
            print('TF->event latency (ms): median %.2f max %.2f' %
                  (1e3 * latencies[1], 1e3 * latencies[-1]))
            self.assertLess(latencies[1], 0.1)
        finally:
            stop.set()

    def test_08_manager_get_loggers_does_not_crash_it(self):
        # roscpp's own ~get_loggers (rosconsole on log4cxx 1.0, Debian 12) killed the process at
        # the second call; here the process is a stock nodelet manager, and the monitor in it
        # died with it. The nodelet replaces the manager's service once per process.
        uri = rosnode.get_api_uri(rosgraph.Master('/test_panda'), '/manager', skip_cache=True)
        pid = xmlrpc.client.ServerProxy(uri).getPid('/test_panda')[2]
        get_loggers = rospy.ServiceProxy('/manager/get_loggers', GetLoggers)
        for _ in range(5):
            names = {l.name: l.level for l in get_loggers().loggers}
            self.assertEqual(names.get('ros.roscpp'), 'info', names)
            self.assertIn('ros.collision_monitor', names)
        self.assertEqual(xmlrpc.client.ServerProxy(uri).getPid('/test_panda')[2], pid)
        self.assertIsNotNone(self.wait_fresh('panda_link0', 'panda_hand'))


    def test_09_second_monitor_remapped_urdf_and_no_foreign_srdf(self):
        # Bugs: (1) the nodelet searched for robot_description past its remap and loaded the
        # demo arm of /robot2/robot_description; (2) the SRDF was searched on its own and the
        # global Panda SRDF disabled pairs of a robot that has none.
        ns = '/robot2/arm/arm_monitor/'
        for s in ('list_bodies', 'get_distance'):
            rospy.wait_for_service(ns + s, timeout=20.0)
        ids = sorted(rospy.ServiceProxy(ns + 'list_bodies', ListBodies)().ids)
        self.assertEqual(ids, LINKS)
        other = rospy.ServiceProxy(ns + 'get_distance', GetDistance)
        pair = ('panda_hand', 'panda_link3')  # SRDF "Never", not adjacent
        self.assertIn(frozenset(pair), self.disabled)
        main = self.m.get_distance(*pair, '')
        self.assertFalse(main.success)
        self.assertIn('SRDF', main.message)
        r = wait_for(lambda: (lambda r: r if r.success else None)(other(*pair, '')), 5.0, 0.05)
        self.assertIsNotNone(r, other(*pair, '').message)
        self.assertGreater(r.result.distance, 0.0)
        # Adjacent links stay excluded (from the URDF itself).
        adj = other('panda_link3', 'panda_link4', '')
        self.assertFalse(adj.success)
        self.assertIn('adjacent links', adj.message)
        # Its robot_link_padding pads the hand by 2 cm, and only the hand: at the same joint
        # states its distances from the hand are 2 cm shorter than the main monitor's, the others
        # equal.
        for a, b, pad in (('panda_link0', 'panda_hand', 0.02), ('panda_link0', 'panda_link5', 0.0)):
            mine = self.wait_fresh(a, b)
            theirs = wait_for(lambda: (lambda r: r if r.success else None)(other(a, b, '')), 5.0,
                              0.05)
            self.assertIsNotNone(mine, self.m.get_distance(a, b, '').message)
            self.assertIsNotNone(theirs, other(a, b, '').message)
            self.assertGreater(mine.result.distance, 0.05)
            self.assertAlmostEqual(theirs.result.distance, mine.result.distance - pad, places=9)

    def test_09b_robot_link_groups(self):
        # /robot2/arm/arm_monitor has the hand and fingers in group 'gripper': listed so, and an
        # object of that group held in the hand (a grasp) is checked against the arm but not
        # against them; without the group it collides with the fingers.
        ns = '/robot2/arm/arm_monitor/'
        rospy.wait_for_service(ns + 'check_collision', timeout=20.0)
        listed = rospy.ServiceProxy(ns + 'list_bodies', ListBodies)()
        self.assertEqual(dict(zip(listed.ids, listed.groups)),
                         {i: ('gripper' if i in ('panda_hand', 'panda_leftfinger',
                                                 'panda_rightfinger') else '') for i in LINKS})
        check = rospy.ServiceProxy(ns + 'check_collision', CheckCollision)
        held = sphere_body('held', 0.03, frame='panda_hand', pose_from_topic=False,
                           group='gripper')
        loose = sphere_body('held', 0.03, frame='panda_hand', pose_from_topic=False)
        at = pose(0, 0, 0.11)  # between the fingers (their joints at 2 cm)
        answers = [wait_for(lambda: (lambda r: r if r.success else None)(check(b, at, 0.5)),
                            5.0, 0.05) for b in (held, loose)]
        self.assertNotIn(None, answers)
        near = [{p.body_b if p.body_a == 'held' else p.body_a: p.distance for p in r.pairs}
                for r in answers]
        self.assertFalse(answers[0].in_collision, near[0])
        self.assertEqual(set(near[0]) & {'panda_hand', 'panda_leftfinger', 'panda_rightfinger'},
                         set(), near[0])
        self.assertIn('panda_link7', near[0])
        self.assertTrue(answers[1].in_collision, near[1])
        self.assertLess(near[1]['panda_leftfinger'], 0.0)
        self.assertLess(near[1]['panda_rightfinger'], 0.0)
        self.assertEqual(near[1]['panda_link7'], near[0]['panda_link7'])
        # The same object tracked (node.md, "Holding an object"): sent on ~bodies in the hand's
        # frame, it has its distance to panda_link7 and none to the hand or fingers.
        arm = Monitor(ns)
        held.parts[0].pose = at
        arm.add(held)
        try:
            self.assertTrue(arm.wait_listed('held'))
            r = wait_for(lambda: (lambda r: r if r.success else None)(
                arm.get_distance('held', 'panda_link7', '')), 5.0, 0.05)
            self.assertIsNotNone(r, arm.get_distance('held', 'panda_link7', '').message)
            self.assertAlmostEqual(r.result.distance, near[0]['panda_link7'], places=9)
            for link in ('panda_hand', 'panda_leftfinger', 'panda_rightfinger'):
                r = arm.get_distance('held', link, '')
                self.assertFalse(r.success)
                self.assertIn("both bodies are in group 'gripper'", r.message)
            # In ~state: WARNING with panda_link7 (3.7 cm), nothing with the gripper.
            def partners():
                return {p.body_b if p.body_a == 'held' else p.body_a for p in arm.state.pairs
                        if 'held' in (p.body_a, p.body_b)}
            self.assertTrue(wait_for(lambda: partners() == {'panda_link7'}, 5.0),
                            [(p.body_a, p.body_b, p.distance) for p in arm.state.pairs])
        finally:
            arm.add(Body(id='held', operation=Body.REMOVE))
            self.assertTrue(arm.wait_listed('held', present=False))

    def test_10_each_monitor_logs_its_own_tf_refusal(self):
        # Bug: the refusal's log line was throttled by ROS_WARN_STREAM_THROTTLE, whose last time
        # is one static for the whole process: of two monitors in this manager, the first to
        # refuse a transform silenced the other for 5 s (and their TF threads raced on the static,
        # ThreadSanitizer). Each monitor logs its own refusal now, its name first.
        lines = []
        sub = rospy.Subscriber('/rosout', Log, lambda m: lines.append(m.msg), queue_size=1000)
        time.sleep(0.5)
        pub = rospy.Publisher('/tf', TFMessage, queue_size=10)
        self.assertTrue(wait_for(lambda: pub.get_num_connections() >= 2, 10.0))
        pub.publish(TFMessage(transforms=[tf_transform('refused_by_both',
                                                       xyz=(float('nan'), 0.0, 0.0))]))

        def names():
            return sorted({m.split(': TF: refused')[0] for m in list(lines)
                           if ': TF: refused' in m and 'refused_by_both' in m})
        wait_for(lambda: len(names()) == 2, 5.0)
        sub.unregister()
        self.assertEqual(names(), ['/collision_monitor', '/robot2/arm/arm_monitor',
                                   '/robot3/default_off_monitor'])

    def test_11_srdf_default_collisions_and_enabled_pairs(self):
        # srdfdom 0.6's <disable_default_collisions> and <enable_collisions> were not read: the
        # hand was checked against everything (test/ros/panda_default_off.srdf).
        m = Monitor('/robot3/default_off_monitor/')

        def answered(a, b):
            r = wait_for(lambda: (lambda r: r if r.success else None)(
                m.get_distance(a, b, '')), 5.0, 0.05)
            self.assertIsNotNone(r, m.get_distance(a, b, '').message)
            return r.result
        self.assertGreater(answered('panda_hand', 'panda_link0').distance, 0.1)
        off = m.get_distance('panda_link3', 'panda_hand', '')
        self.assertFalse(off.success)
        self.assertIn("SRDF <disable_default_collisions> of 'panda_hand'", off.message)
        adj = m.get_distance('panda_hand', 'panda_link7', '')  # enabled, but adjacent
        self.assertFalse(adj.success)
        self.assertIn('adjacent links', adj.message)
        never = m.get_distance('panda_link0', 'panda_link2', '')
        self.assertFalse(never.success)
        self.assertIn('SRDF <disable_collisions>', never.message)
        # robot2's monitor (the same Panda, no SRDF) checks that pair.
        other = rospy.ServiceProxy('/robot2/arm/arm_monitor/get_distance', GetDistance)
        self.assertTrue(wait_for(lambda: other('panda_link3', 'panda_hand', '').success, 5.0))
        # Bodies added later, inside the hand: neither meets it, probe too (the SRDF's
        # enable_collisions of probe names no URDF link: left out, as srdfdom does).
        for body_id in ('probe', 'block'):
            m.add(sphere_body(body_id, 0.05, frame='panda_hand', pose_from_topic=False))
        self.assertLess(answered('probe', 'block').distance, 0.0)
        for body_id in ('probe', 'block'):
            off = m.get_distance('panda_hand', body_id, '')
            self.assertFalse(off.success)
            self.assertIn("of 'panda_hand'", off.message)

        def pairs():
            return {(p.body_a, p.body_b) for p in m.state.pairs}
        self.assertTrue(wait_for(lambda: ('block', 'probe') in pairs(), 5.0))
        self.assertNotIn(('panda_hand', 'probe'), pairs())
        self.assertNotIn(('block', 'panda_hand'), pairs())
        self.assertEqual(m.events_for({frozenset(('block', 'panda_hand')),
                                       frozenset(('panda_hand', 'probe'))}), [])


if __name__ == '__main__':
    rostest.rosrun('collision_monitor', 'panda', Panda, sys.argv)
