#!/usr/bin/python3
"""rostest (catch_up.test): catch-up in a world posed at one time, against an oracle.
A TF frame `dart` (a sphere of 0.1 m) swings along x at 100 Hz through three static targets
(spheres of 0.1 m on the fixed frame, at 0.12, 0.15 and 0.05 m off its line), beside 600 far
bodies on the fixed frame, in one group. The monitor checks at 5 Hz, not on TF: about 20 TF
stamps between two checks, within the 32 a frame it looks up. The oracle steps the statuses
(warning 0.05, contact 0, hysteresis 0.005) through the true distance at every stamp published;
the monitor's events of each (dart, target) pair must be the oracle's, type and stamp, each with
its distance to 1e-6 m.
- Before the thirty-eighth session the world kept no pose between two checks (one timed stamp
  at every check, the dart's): no event but at the checks.
- The first version of that change shared the 1,024 lookups a check by TF bodies, the 600 on
  the fixed frame too (which need none): one stamp a check, 139 of 147 events missing in the
  audit's run.
Then a TF frame new to TF: caught up from its first transform (test_c), but a body moved onto
it takes nothing of the frame's transforms stamped before it came (test_d)."""
import math
import sys
import time
import unittest

import rospy
import rostest
import tf2_ros
from collision_monitor.msg import Body, BodyPoses, CollisionEvent, PairState

from cm_test_util import Monitor, pose, sphere_body, tf_transform, wait_for
from event_oracle import run

E = CollisionEvent
TARGETS = [(0.0, 0.12), (0.5, -0.15), (-0.7, 0.05)]  # x, y: nearest -0.08, -0.05, -0.15 m
EXTRAS = 600
RUN = 6.0  # s


def dart_x(t):
    return 1.3 * math.sin(2.0 * math.pi * t / 2.7)


def fixed_body(body_id, radius, x, y, group=''):
    b = sphere_body(body_id, radius, frame='world', pose_from_topic=False, group=group)
    b.parts[0].pose = pose(x, y, 0.0)
    return b


class CatchUp(unittest.TestCase):
    def test_a_tf_dart_through_static_targets_matches_the_oracle(self):
        m = Monitor()
        for k in range(EXTRAS):  # far away, never in a pair with the dart or each other
            m.add(fixed_body('far%04d' % k, 0.05, 50.0 + k, 50.0, group='far'))
            if k % 50 == 49:
                time.sleep(0.05)
        for i, (x, y) in enumerate(TARGETS):
            m.add(fixed_body('t%d' % i, 0.1, x, y))
        br = tf2_ros.TransformBroadcaster()
        # The node's /tf subscriber connects to this new publisher first: on a loaded CI machine
        # it took longer than the run's first 0.3 s once, and the dart's WARNING_END of t1 there
        # was never seen (its poses before it were lost).
        self.assertTrue(wait_for(lambda: br.pub_tf.get_num_connections() > 0, 10.0),
                        'no /tf subscriber')
        br.sendTransform(tf_transform('dart', xyz=(0.0, 0.0, 0.0)))
        m.add(sphere_body('dart', 0.1, frame='dart', pose_from_topic=False))
        self.assertTrue(wait_for(lambda: len(m.list_bodies().ids) == EXTRAS + 4, 20.0),
                        len(m.list_bodies().ids))
        stamps = []  # (stamp, dart x) of every transform sent
        t0 = rospy.Time.now()
        start = time.monotonic()
        k = 0
        while time.monotonic() - start < RUN:
            now = rospy.Time.now()
            x = dart_x((now - t0).to_sec())
            br.sendTransform(tf_transform('dart', stamp=now, xyz=(x, 0.0, 0.0)))
            stamps.append((now, x))
            k += 1
            time.sleep(max(0.0, start + 0.01 * k - time.monotonic()))
        time.sleep(0.5)  # the checks after the last transform
        # From 0.3 s on (the dart's first check and the pairs' first statuses before), to the last
        # stamp (not reached by a check before the dart stops: its poses after that one are not).
        lo, hi = stamps[0][0] + rospy.Duration(0.3), stamps[-1][0]
        with m.lock:
            events = [e for _, e in m.events]
        x_at = dict((s.to_nsec(), x) for s, x in stamps)
        total = 0
        for i, (tx, ty) in enumerate(TARGETS):
            tid = 't%d' % i

            def gap(x):
                return math.hypot(x - tx, ty) - 0.2
            given, _ = run(tid, PairState.CLEAR, range(len(stamps)), lambda k: gap(stamps[k][1]))
            expected = [(t, stamps[k][0].to_nsec()) for k, _, t in given
                        if lo <= stamps[k][0] < hi]
            got = [e for e in events if {e.pair.body_a, e.pair.body_b} == {'dart', tid}
                   and e.type not in (E.UNKNOWN_BEGIN, E.UNKNOWN_END)
                   and lo <= e.header.stamp < hi]
            self.assertEqual([(e.type, e.header.stamp.to_nsec()) for e in got], expected, tid)
            for e in got:
                self.assertAlmostEqual(e.pair.distance, gap(x_at[e.header.stamp.to_nsec()]),
                                       delta=1e-6)
            total += len(got)
        self.assertGreaterEqual(total, 20)  # each target passed about four times, two events a pass

    def test_b_a_dart_back_from_a_spell_is_caught_up_from_its_first_pose(self):
        """A ~body_poses dart (a sphere of 0.1 m) comes back from a spell without a pose inside
        a target of 0.1 m on the fixed frame and leaves it at 10 m/s, posed at 100 Hz; no check
        follows a pose (check_on_pose false, checks at 5 Hz). The pair is known from the dart's
        first pose back: UNKNOWN_END and COLLISION_BEGIN at its stamp (-0.2 m), COLLISION_END at
        the stamp 0.1 m out. Before the forty-first session the pair started again at the first
        check: UNKNOWN_END at the dart's pose then, the collision lost (unless that check fell
        within the 10 ms before the second pose)."""
        m = Monitor()
        m.add(fixed_body('u', 0.1, 0.0, 20.0))
        m.add(sphere_body('v', 0.1, frame='world'))
        self.assertTrue(wait_for(lambda: {'u', 'v'} <= set(m.list_bodies().ids), 10.0))
        stream = BodyPosesAt(m.poses_pub)
        for _ in range(10):  # fresh at a few checks, 3 m off
            stream.send('v', -3.0, 20.0)
            time.sleep(0.05)
        spell = m.wait_event(E.UNKNOWN_BEGIN, 'u', 'v', timeout=5.0, since=time.monotonic())
        self.assertIsNotNone(spell)
        since = spell[0]
        sent = []  # (stamp, x)
        for k in range(61):  # out to 1 m, then held there
            x = 0.1 * min(k, 10)
            sent.append((stream.send('v', x, 20.0), x))
            time.sleep(0.01)
        pair = {frozenset(('u', 'v'))}
        self.assertTrue(wait_for(lambda: len(m.events_for(pair, since)) >= 4, 5.0),
                        m.events_for(pair, since))
        time.sleep(0.5)  # any event more
        got = m.events_for(pair, since)
        self.assertEqual(got[0].type, E.UNKNOWN_BEGIN)
        self.assert_out_from_first_pose(got[1:], sent)

    def assert_out_from_first_pose(self, got, sent):
        """`got`, the events of a sphere of 0.1 m posed at x of `sent` ((stamp, x), from inside)
        against one of 0.1 m at x = 0 after its UNKNOWN_BEGIN, are the oracle's from its first
        pose on: UNKNOWN_END, COLLISION_BEGIN and COLLISION_END, each at its stamp with its
        distance to 1e-6 m."""
        given, _ = run(None, PairState.CLEAR, range(len(sent)), lambda k: abs(sent[k][1]) - 0.2)
        expected = [(E.UNKNOWN_END, sent[0][0])] + [(t, sent[k][0]) for k, _, t in given]
        self.assertEqual([(e.type, e.header.stamp.to_nsec()) for e in got],
                         [(t, s.to_nsec()) for t, s in expected])
        self.assertEqual([e.type for e in got],
                         [E.UNKNOWN_END, E.COLLISION_BEGIN, E.COLLISION_END])
        x_at = dict((s.to_nsec(), x) for s, x in sent)
        for e in got:
            self.assertAlmostEqual(e.pair.distance, abs(x_at[e.header.stamp.to_nsec()]) - 0.2,
                                   delta=1e-6)

    def test_c_a_new_tf_frame_is_caught_up_from_its_first_transform(self):
        """A TF frame new to TF, `dart_c`, carries a sphere of 0.1 m added before the frame's
        first transform. The frame starts inside a target of 0.1 m on the fixed frame and leaves
        it at 10 m/s, sent at 100 Hz; checks at 5 Hz, not on TF. Its first lookup catches up over
        the last pose_timeout: UNKNOWN_END and COLLISION_BEGIN at the first stamp, COLLISION_END
        at the stamp 0.3 m out. Before the fifty-second session a frame's first lookup caught up
        nothing: the pair was first evaluated at the first check, the dart already out. (A pair
        first checked at the check that poses its body -- the body and its frame's first
        transforms came between the same two checks -- starts at that check's time.)"""
        m = Monitor()
        forget(m, 'dart', 'v')  # stale since the tests before: UNKNOWN pairs to list no more
        since = time.monotonic()
        m.add(fixed_body('g', 0.1, 0.0, 30.0))
        m.add(sphere_body('w', 0.1, frame='dart_c', pose_from_topic=False))
        # A check saw the body without a pose (a pair new at the check that poses it starts
        # there: see the docstring).
        self.assertIsNotNone(m.wait_event(E.UNKNOWN_BEGIN, 'g', 'w', timeout=5.0, since=since))
        sent = send_tf_dart('dart_c', 30.0, [0.1 * min(k, 10) for k in range(61)])
        pair = {frozenset(('g', 'w'))}

        def got():
            return [e for e in m.events_for(pair, since) if e.type != E.UNKNOWN_BEGIN]
        self.assertTrue(wait_for(lambda: len(got()) >= 3, 5.0), got())
        time.sleep(0.5)  # any event more
        self.assert_out_from_first_pose(got(), sent)

    def test_d_a_body_takes_nothing_of_its_frame_from_before_it_came(self):
        """A sphere of 0.1 m, static on the fixed frame 3 m off a target of 0.1 m, is moved
        onto a TF frame `dart_d` new to TF (an object attached to a gripper: replaced, its pair
        with the target kept) right after a check. Then the frame's transforms come late: the
        frame passing through the target (from inside, out to 2.8 m), stamped between that check
        and the replacement, then at 2.8 m stamped now, 100 Hz. The frame's first lookup catches
        up over the last pose_timeout (0.5 s), the passage included, but the body takes only
        the transforms stamped after it came: no event (but UNKNOWN ones, should a check come
        between the replacement and the transforms), the distance 2.8 m, then 2.6 m.
        (Taken, the passage gave a COLLISION_BEGIN and _END while the body was not there.)"""
        m = Monitor()
        forget(m, 'w')
        since = time.monotonic()
        m.add(fixed_body('h', 0.1, 0.0, 40.0))
        m.add(fixed_body('z', 0.1, 3.0, 40.0))
        self.assertTrue(wait_for(lambda: m.get_distance('z', 'h', '').success, 10.0))  # checked
        self.assertAlmostEqual(m.get_distance('z', 'h', '').result.distance, 2.8, delta=1e-6)
        checks = m.state_count
        self.assertTrue(wait_for(lambda: m.state_count > checks, 5.0))
        checked = m.state.header.stamp  # the check before the replacement, ~0.2 s before the next
        added = rospy.Time.now()
        m.add(sphere_body('z', 0.1, frame='dart_d', pose_from_topic=False))
        xs = [0.0, 0.1, 0.2, 0.5, 1.0, 1.5, 2.0, 2.5, 2.8, 2.8, 2.8]
        late = [(checked + (added - checked) * ((k + 1) / (len(xs) + 1.0)), x)
                for k, x in enumerate(xs)]
        sent = send_tf_dart('dart_d', 40.0, [2.8] * 60, late=late)
        time.sleep(0.3)  # the checks after the last transform
        r = m.get_distance('z', 'h', '')
        self.assertTrue(r.success, r.message)
        self.assertAlmostEqual(r.result.distance, 2.6, delta=1e-6)
        self.assertEqual([e for e in m.events_for({frozenset(('h', 'z'))}, since)
                          if e.type not in (E.UNKNOWN_BEGIN, E.UNKNOWN_END)], [])
        self.assertEqual(len(sent), 60)


def forget(m, *ids):
    """Removes bodies `ids` and waits until none is listed."""
    for body_id in ids:
        m.add(Body(id=body_id, operation=Body.REMOVE))
    assert wait_for(lambda: not set(ids) & set(m.list_bodies().ids), 10.0), ids


def send_tf_dart(frame, y, xs, late=()):
    """Frame `frame` at (x, y, 0) in the fixed frame: first at once for each (stamp, x) of
    `late`, then for each x of `xs` at 100 Hz, stamped now. Returns (stamp, x) of the latter."""
    br = tf2_ros.TransformBroadcaster()
    # The monitor connected: /tf sent before is lost.
    assert wait_for(lambda: br.pub_tf.get_num_connections() > 0, 10.0), 'no /tf subscriber'
    for stamp, x in late:
        br.sendTransform(tf_transform(frame, stamp=stamp, xyz=(x, y, 0.0)))
    sent = []
    start = time.monotonic()
    for k, x in enumerate(xs):
        now = rospy.Time.now()
        br.sendTransform(tf_transform(frame, stamp=now, xyz=(x, y, 0.0)))
        sent.append((now, x))
        time.sleep(max(0.0, start + 0.01 * (k + 1) - time.monotonic()))
    return sent


class BodyPosesAt:
    """~body_poses of one body at a time, in the fixed frame, stamped now."""

    def __init__(self, pub):
        self.pub = pub

    def send(self, body_id, x, y):
        msg = BodyPoses()
        msg.header.frame_id = 'world'
        msg.header.stamp = rospy.Time.now()
        msg.ids.append(body_id)
        msg.poses.append(pose(x, y, 0.0))
        self.pub.publish(msg)
        return msg.header.stamp


if __name__ == '__main__':
    rospy.init_node('test_catch_up')
    rostest.rosrun('collision_monitor', 'catch_up', CatchUp, sys.argv)
