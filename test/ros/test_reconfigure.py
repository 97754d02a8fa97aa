#!/usr/bin/python3
"""rostest: the parameters that may change while the node runs, changed through
dynamic_reconfigure as rqt_reconfigure and `dynparam set` do.

Two spheres 0.2 m apart with static poses (stamp 0: nothing moves, nothing triggers a check but
the heartbeat and the change itself). Raising warning_distance must make the pair WARNING
although neither body moved (the broad phase is swept again at its new reach); contact_distance
makes it COLLISION; an invalid change is refused, counted on /diagnostics, and the server answers
with the values in force; rate, backend, publish_markers and pose_timeout take effect."""
import sys
import time
import unittest

import rospy
import rostest
from collision_monitor.msg import BodyPoses, CollisionEvent, PairState
from collision_monitor.srv import CheckCollisionRequest
from dynamic_reconfigure.client import Client
from visualization_msgs.msg import Marker, MarkerArray

from cm_test_util import Monitor, point_close, pose, sphere_body, wait_for, NS

NODE = NS.rstrip('/')


class Reconfigure(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_reconfigure')
        cls.m = Monitor()
        cls.client = Client(NODE, timeout=30.0)
        for body_id in ('a', 'b', 'c'):
            cls.m.add(sphere_body(body_id, 0.5))
            assert cls.m.wait_listed(body_id)
        msg = BodyPoses()
        msg.header.frame_id = 'world'  # stamp 0: static poses, never stale
        msg.ids = ['a', 'b']
        msg.poses = [pose(0, 0, 0), pose(1.2, 0, 0)]
        cls.m.poses_pub.publish(msg)
        assert wait_for(lambda: cls.m.state is not None and cls.m.state.min_distance < 1.0, 10.0)

    def update(self, **values):
        return self.client.update_configuration(values)

    def pair_ab(self):
        st = self.m.state
        return next((p for p in st.pairs if {p.body_a, p.body_b} == {'a', 'b'}), None)

    def test_01_start_values_are_the_checked_ones(self):
        c = self.client.get_configuration(timeout=10.0)
        self.assertEqual(c['rate'], 2.0)
        self.assertEqual(c['warning_distance'], 0.05)
        self.assertEqual(c['hysteresis'], 0.005)  # -1.0 was given: the default is in force
        self.assertEqual(c['backend'], 'gjk')
        self.assertEqual(rospy.get_param(NS + 'hysteresis'), 0.005)
        self.assertIsNone(self.pair_ab())  # 0.2 m apart: CLEAR
        # The start-up errors: these two, nothing else.
        self.assertTrue(wait_for(lambda: self.m.diagnostics is not None, 10.0))
        errors = [kv.value for kv in self.m.diagnostics.values if kv.key == 'invalid parameter']
        self.assertEqual(errors, [
            'hysteresis = -1.000000 (must be >= 0); using 0.005000',
            "fixed_frame '/' is empty without its leading '/'; using world"])
        self.assertEqual(self.m.state.header.frame_id, 'world')

    def test_02_thresholds_while_nothing_moves(self):
        since = time.monotonic()
        r = self.update(warning_distance=0.3)
        self.assertEqual(r['warning_distance'], 0.3)
        self.assertTrue(self.m.wait_event(CollisionEvent.WARNING_BEGIN, 'a', 'b', 3.0, since),
                        'no WARNING_BEGIN after warning_distance 0.3 (pair 0.2 m apart)')
        p = wait_for(self.pair_ab, 3.0)
        self.assertEqual(p.status, PairState.WARNING)
        self.assertAlmostEqual(p.distance, 0.2, delta=1e-9)
        self.assertEqual(rospy.get_param(NS + 'warning_distance'), 0.3)

        since = time.monotonic()
        r = self.update(contact_distance=0.25)
        self.assertEqual((r['warning_distance'], r['contact_distance']), (0.3, 0.25))
        self.assertTrue(self.m.wait_event(CollisionEvent.WARNING_END, 'a', 'b', 3.0, since))
        self.assertTrue(self.m.wait_event(CollisionEvent.COLLISION_BEGIN, 'a', 'b', 3.0, since))
        self.assertTrue(wait_for(lambda: self.m.state.in_collision, 3.0))

        # A hypothetical body is judged by the contact distance in force too.
        req = CheckCollisionRequest()
        req.body = sphere_body('', 0.5)
        req.body.header.frame_id = 'world'
        req.pose = pose(0, 1.24, 0)  # 0.24 m from a: within contact_distance 0.25
        res = self.m.check_collision(req)
        self.assertTrue(res.success, res.message)
        self.assertTrue(res.in_collision)

    def test_03_invalid_changes_are_refused(self):
        rejected0 = int(self.m.diag_value('rejected inputs (total)') or 0)
        r = self.update(hysteresis=-1.0)
        self.assertEqual(r['hysteresis'], 0.005)  # the value in force
        # Below the contact distance in force (0.25): the warning distance in force stays.
        r = self.update(warning_distance=0.1)
        self.assertEqual(r['warning_distance'], 0.3)
        r = self.update(backend='bullet', rate=-3.0)
        self.assertEqual((r['backend'], r['rate']), ('gjk', 2.0))
        self.assertTrue(wait_for(lambda: int(self.m.diag_value('rejected inputs (total)') or 0)
                                 >= rejected0 + 3, 5.0))
        last = self.m.diag_value('last rejection')
        self.assertIn("dynamic_reconfigure refused rate = -3.000000 (must be > 0); using "
                      "2.000000; backend = 'bullet' (must be gjk or libccd); using gjk", last)
        self.assertEqual(rospy.get_param(NS + 'hysteresis'), 0.005)
        self.assertEqual(self.pair_ab().status, PairState.COLLISION)  # nothing changed
        # /diagnostics shows the values in force, not the refused ones (it showed none of them:
        # a start-up ERROR naming values since reconfigured was all an operator had).
        in_force = ('warning_distance', 'contact_distance', 'hysteresis', 'rate', 'backend')
        self.assertTrue(wait_for(lambda: tuple(self.m.diag_value(k) for k in in_force)
                                 == ('0.3', '0.25', '0.005', '2', 'gjk'), 5.0),
                        [self.m.diag_value(k) for k in in_force])

        # contact_distance alone past the warning distance in force: the warning distance
        # follows it, nothing refused (dynparam sends every value: it was refused as an ERROR
        # about the warning_distance 0.3 it carried).
        rejected1 = int(self.m.diag_value('rejected inputs (total)'))
        r = self.update(contact_distance=0.35)
        self.assertEqual((r['warning_distance'], r['contact_distance']), (0.35, 0.35))
        self.assertTrue(wait_for(lambda: self.m.diag_value('warning_distance') == '0.35', 5.0))
        rospy.sleep(1.5)  # a report more: a refusal would be counted in it
        self.assertEqual(int(self.m.diag_value('rejected inputs (total)')), rejected1)

        since = time.monotonic()
        self.update(warning_distance=0.05, contact_distance=0.0)
        self.assertTrue(self.m.wait_event(CollisionEvent.COLLISION_END, 'a', 'b', 3.0, since))
        self.assertTrue(wait_for(lambda: self.pair_ab() is None, 3.0))

    def count_states(self, seconds):
        n0 = self.m.state_count
        time.sleep(seconds)
        return self.m.state_count - n0

    def test_04_rate(self):
        slow = self.count_states(2.0)
        self.update(rate=25.0)
        fast = self.count_states(2.0)
        self.update(rate=2.0)
        # 2 Hz: about 4 states in 2 s; 25 Hz: about 50.
        self.assertLessEqual(slow, 8)
        self.assertGreaterEqual(fast, 30)
        self.assertTrue(wait_for(lambda: self.m.diag_value('target rate (Hz)') == '2.0', 5.0))

    def test_05_backend(self):
        self.update(backend='libccd')
        self.assertTrue(wait_for(lambda: self.m.diag_value('backend') == 'libccd', 5.0))
        r = self.m.get_distance('a', 'b', '')
        self.assertTrue(r.success, r.message)
        self.assertAlmostEqual(r.result.distance, 0.2, delta=1e-6)
        self.update(backend='gjk')
        self.assertTrue(wait_for(lambda: self.m.diag_value('backend') == 'gjk', 5.0))

    def test_06_markers_off_clears_them(self):
        arrays = []
        sub = rospy.Subscriber(NS + 'markers', MarkerArray, arrays.append, queue_size=100)
        try:
            self.assertTrue(wait_for(lambda: any(m.ns.startswith('bod') for a in arrays
                                                 for m in a.markers), 10.0), 'no body markers')
            self.update(publish_markers=False)
            self.assertTrue(wait_for(lambda: arrays and
                                     [m.action for m in arrays[-1].markers] == [Marker.DELETEALL],
                                     5.0), 'no DELETEALL when markers were turned off')
            n = len(arrays)
            time.sleep(1.5)
            self.assertEqual(len(arrays), n)  # nothing more while off
            self.update(publish_markers=True)
            self.assertTrue(wait_for(lambda: len(arrays) > n, 5.0))
            self.assertEqual(arrays[n].markers[0].action, Marker.DELETEALL)  # starts afresh
            self.assertTrue(any(m.ns.startswith('bod') for m in arrays[n].markers))
        finally:
            sub.unregister()

    def test_07_pose_timeout(self):
        msg = BodyPoses()
        msg.header.frame_id = 'world'
        msg.header.stamp = rospy.Time.now()  # timed: stale after pose_timeout
        msg.ids = ['c']
        msg.poses = [pose(0, 5, 0)]
        self.m.poses_pub.publish(msg)
        self.assertTrue(wait_for(lambda: 'c' in self.m.state.stale_bodies, 5.0))
        self.update(pose_timeout=600.0)
        self.assertTrue(wait_for(lambda: 'c' not in self.m.state.stale_bodies, 3.0),
                        "c's pose is a few seconds old: fresh under pose_timeout 600 s")
        self.update(pose_timeout=0.5)
        self.assertTrue(wait_for(lambda: 'c' in self.m.state.stale_bodies, 3.0))

    def test_08_extreme_valid_rates(self):
        # rate 1e-12 Hz is valid (> 0): no heartbeat for ages, but pose input is still checked.
        # Its marker lifetime (3e12 s) made ros::Duration throw in every check with a ~markers
        # subscriber, and its period overflowed the steady clock's nanoseconds.
        arrays = []
        sub = rospy.Subscriber(NS + 'markers', MarkerArray, arrays.append, queue_size=100)
        try:
            self.assertTrue(wait_for(lambda: arrays, 10.0))
            self.update(rate=1e-12, min_check_interval=1e-3)
            time.sleep(0.5)
            n0, a0 = self.m.state_count, len(arrays)
            msg = BodyPoses()
            msg.header.frame_id = 'world'
            msg.header.stamp = rospy.Time.now()
            msg.ids = ['c']
            msg.poses = [pose(0, 4, 0)]
            self.m.poses_pub.publish(msg)
            self.assertTrue(wait_for(lambda: self.m.state_count > n0, 3.0),
                            'no ~state after pose input at rate 1e-12 Hz')
            self.assertTrue(wait_for(lambda: len(arrays) > a0, 3.0))
            self.assertTrue(wait_for(lambda: self.m.diag_value('target rate (Hz)') == '0.0', 3.0))
        finally:
            sub.unregister()
            self.update(rate=2.0, min_check_interval=0.002)

    def test_09_a_long_min_check_interval_put_right(self):
        # Bug (audit): the wait for min_check_interval ended only at its deadline: 20 s typed for
        # 20 ms and put right at once still stopped every check for 20 s.
        self.update(rate=20.0)
        self.update(min_check_interval=20.0)
        # No check for more than a second (two periods of rate): /diagnostics says so.
        self.assertTrue(wait_for(lambda: 'no check for' in self.m.diagnostics.message, 5.0),
                        self.m.diagnostics.message)
        self.update(min_check_interval=0.002)
        n0 = self.m.state_count
        self.assertTrue(wait_for(lambda: self.m.state_count >= n0 + 5, 2.0),
                        'checks did not resume after min_check_interval 20 s -> 0.002 s')
        self.update(rate=2.0)

    def test_10_thresholds_at_or_below_zero_keep_the_checks_going(self):
        # Bug (audit, twenty-fifth session): with no reach left (every threshold <= 0), once a
        # shallow overlap had narrowed min_distance's far grid to margin 0, a check with no
        # boxes touching grew that margin 4 x 0 = 0 for ever: no ~state, no service answer,
        # and no exit on SIGINT.
        self.update(contact_distance=-0.05, warning_distance=-0.05, hysteresis=0.0)
        msg = BodyPoses()
        msg.header.frame_id = 'world'  # static poses
        msg.ids = ['a', 'b']
        msg.poses = [pose(0, 0, 0), pose(0.99, 0, 0)]  # 0.01 m deep: CLEAR below -0.05
        self.m.poses_pub.publish(msg)
        self.assertTrue(wait_for(lambda: abs(self.m.state.min_distance + 0.01) < 1e-9, 5.0),
                        self.m.state.min_distance)
        self.assertIsNone(self.pair_ab())
        self.assertFalse(self.m.state.in_collision)
        msg.poses = [pose(0, 0, 0), pose(3.0, 0, 0)]  # 2 m apart: no boxes touch
        self.m.poses_pub.publish(msg)
        self.assertTrue(wait_for(lambda: abs(self.m.state.min_distance - 2.0) < 1e-9, 5.0),
                        'no ~state with min_distance 2.0 m after the pair moved apart')
        n0 = self.m.state_count
        self.assertTrue(wait_for(lambda: self.m.state_count >= n0 + 2, 3.0),
                        'the heartbeat stopped')
        self.update(warning_distance=0.05, contact_distance=0.0, hysteresis=0.005)
        msg.poses = [pose(0, 0, 0), pose(1.2, 0, 0)]
        self.m.poses_pub.publish(msg)
        self.assertTrue(wait_for(lambda: abs(self.m.state.min_distance - 0.2) < 1e-9, 5.0))

    def test_11_check_on_pose_off_leaves_pose_input_to_the_heartbeat(self):
        # check_on_pose false (node.md, Check loop): pose input sets no flag; the next check is
        # the heartbeat's, 10 s after the change's own check at rate 0.1 Hz.
        self.update(rate=0.1, check_on_pose=False)
        time.sleep(0.5)  # the check the change itself makes
        n0 = self.m.state_count
        msg = BodyPoses()
        msg.header.frame_id = 'world'
        msg.ids = ['c']
        msg.poses = [pose(0, 6, 0)]
        self.m.poses_pub.publish(msg)
        time.sleep(1.5)
        n1 = self.m.state_count
        self.update(check_on_pose=True, rate=2.0)
        self.assertEqual(n1, n0, 'a check after pose input with check_on_pose false')
        # On again: pose input is checked at once (no heartbeat within 3 s at 0.1 Hz either).
        self.update(rate=0.1)
        time.sleep(0.5)
        n0 = self.m.state_count
        msg.poses = [pose(0, 7, 0)]
        self.m.poses_pub.publish(msg)
        self.assertTrue(wait_for(lambda: self.m.state_count > n0, 3.0),
                        'no check after pose input with check_on_pose true')
        self.update(rate=2.0)

    def test_12_fixed_frame_spelled_with_a_leading_slash(self):
        # '/world' is the fixed frame 'world' (tf2 names have no leading '/'), and no TF is
        # published here: ~body_poses in '/world' and ~get_distance in '/world' need none. a at
        # the origin, c at y = 3, both of radius 0.5: 2 m apart, witnesses at y = 0.5 and 2.5.
        msg = BodyPoses()
        msg.header.frame_id = '/world'
        msg.ids = ['c']
        msg.poses = [pose(0, 3, 0)]
        self.m.poses_pub.publish(msg)
        r = wait_for(lambda: (lambda r: r if r.success and abs(r.result.distance - 2.0) < 1e-9
                              else None)(self.m.get_distance('a', 'c', '')), 5.0)
        self.assertTrue(r, self.m.get_distance('a', 'c', ''))
        r = self.m.get_distance('a', 'c', '/world')
        self.assertTrue(r.success, r.message)
        self.assertAlmostEqual(r.result.distance, 2.0, delta=1e-9)
        self.assertTrue(point_close(r.result.point_a, (0.0, 0.5, 0.0), 1e-9), r.result.point_a)
        self.assertTrue(point_close(r.result.point_b, (0.0, 2.5, 0.0), 1e-9), r.result.point_b)


if __name__ == '__main__':
    rostest.rosrun('collision_monitor', 'reconfigure', Reconfigure, sys.argv)
