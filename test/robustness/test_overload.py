#!/usr/bin/python3
"""rostest: /diagnostics WARNs "overloaded" while the mean check takes longer than the period of
~rate, and goes back to OK once it does not; it keeps coming while a long check runs, and says
so; SIGINT stops such a check (overload.test)."""
import os
import signal
import sys
import threading
import time
import unittest

import rospy
import rostest
from collision_monitor.msg import Body, BodyPoses, CollisionEvent, PairState, Shape
from collision_monitor.srv import GetDistance
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus

from robust_util import alive, node_pid  # (also puts test/ros on the path)
from cm_test_util import NS, Monitor, pose, shape, sphere_body, wait_for


class Overload(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_overload')
        cls.m = Monitor()

    def place(self, n):
        msg = BodyPoses(ids=['s%d' % i for i in range(n)],
                        poses=[pose(0.01 * i, 0, 0) for i in range(n)])
        msg.header.frame_id = 'world'
        msg.header.stamp = rospy.Time(0)  # static: never stale
        self.m.poses_pub.publish(msg)

    def report(self, level, text, timeout=10.0):
        """The first /diagnostics report from now on with `level`, whose message contains `text`."""
        self.m.diagnostics = None
        return wait_for(lambda: (lambda d: d if d is not None and d.level == level and
                                 text in d.message else None)(self.m.diagnostics), timeout, 0.05)

    def call_quietly(self, a, b):
        try:
            self.m.get_distance(a, b, '')
        except rospy.ServiceException:  # the node went away first
            pass

    def add_piles(self, x=None):
        """Bodies big_a, big_b, big_c of 1,000 overlapping boxes each; posed where they overlap
        each other (every check runs 3 x 1,000,000 box pairs) when `x` is given."""
        n = 1000
        for name in ('big_a', 'big_b', 'big_c'):
            b = Body(id=name, operation=Body.ADD, pose_from_topic=True)
            for i in range(n):
                p = shape(Shape.BOX, [0.2, 0.2, 0.2])
                p.pose = pose(0.001 * (i % 10), 0.001 * (i // 10 % 10), 0.001 * (i // 100))
                b.parts.append(p)
            self.m.add(b)
        self.assertTrue(wait_for(lambda: len(self.m.list_bodies().ids) == 5, 20.0))
        if x is not None:
            msg = BodyPoses(ids=['big_a', 'big_b', 'big_c'],
                            poses=[pose(x, 0, 0), pose(x + 0.05, 0, 0), pose(x, 0.05, 0)])
            msg.header.frame_id = 'world'
            msg.header.stamp = rospy.Time(0)
            self.m.poses_pub.publish(msg)

    def test_1_overloaded_then_not(self):
        n = 60
        for i in range(n):
            self.m.add(sphere_body('s%d' % i, 0.1))
        self.assertTrue(wait_for(lambda: len(self.m.list_bodies().ids) == n, 10.0))
        t_place = time.monotonic()
        self.place(n)
        # The first check with the poses turns over 1,100 pairs from UNKNOWN or CLEAR to COLLISION
        # or WARNING at once: one BEGIN each reaches ~events, none lost (a publisher queue of 100
        # let 101 to 202 through). The reference is the latest ~state: every pair it lists has
        # its BEGIN as its last event, and no other pair has one (pairs that were UNKNOWN
        # without poses and are apart now end with UNKNOWN_END).
        first = wait_for(lambda: (lambda s: s if s is not None and len(s.pairs) > 1000 else None)(
            self.m.state), 10.0)
        self.assertIsNotNone(first)
        begin = {PairState.COLLISION: CollisionEvent.COLLISION_BEGIN,
                 PairState.WARNING: CollisionEvent.WARNING_BEGIN}

        def expected():
            return {frozenset((p.body_a, p.body_b)): begin[p.status] for p in self.m.state.pairs}

        def last_events():  # each pair's last event since the poses were sent
            with self.m.lock:
                return {frozenset((e.pair.body_a, e.pair.body_b)): e.type
                        for t, e in self.m.events if t >= t_place}

        def begins(last):
            return {k: v for k, v in last.items() if v in begin.values()}

        def others(last):
            return set(last.values()) - set(begin.values())
        wait_for(lambda: (lambda last: begins(last) == expected() and
                          others(last) <= {CollisionEvent.UNKNOWN_END})(last_events()), 10.0)
        last, want = last_events(), expected()
        got = begins(last)
        self.assertTrue(others(last) <= {CollisionEvent.UNKNOWN_END}, others(last))
        print("burst: %d pairs in the first ~state, %d in the latest, %d with their BEGIN as "
              "last event" % (len(first.pairs), len(want),
                              sum(got.get(k) == v for k, v in want.items())))
        self.assertGreater(len(want), 1100)
        self.assertEqual(got, want)
        d = self.report(DiagnosticStatus.WARN, 'overloaded: a check takes')
        self.assertIsNotNone(d, self.m.diagnostics)
        self.assertIn('0.05 ms period of rate 20000 Hz', d.message)
        # The values of the report judged, not of a later one (load can change the mean).
        mean_ms = float(self.m.diag_value("mean cycle time (ms)", d))
        print("overloaded: %s" % d.message)
        self.assertGreater(mean_ms, 0.05)
        self.assertIsNotNone(self.m.diag_value('pairs checked (mean per check since last report)',
                                               d))
        for i in range(2, n):
            self.m.add(Body(id='s%d' % i, operation=Body.REMOVE))
        self.assertTrue(wait_for(lambda: len(self.m.list_bodies().ids) == 2, 10.0))
        d = self.report(DiagnosticStatus.OK, 'ok')
        self.assertIsNotNone(d, self.m.diagnostics)
        mean_ms = float(self.m.diag_value("mean cycle time (ms)", d))
        print("recovered: mean cycle time %s ms" % mean_ms)
        # OK means a mean of at most the period; the report rounds it to 1 us (0.0499 -> 0.050).
        self.assertLessEqual(mean_ms, 0.05)

    def test_2_long_check_reported_while_it_runs(self):
        """Three bodies of 1,000 overlapping boxes each, one of them moved by every pose message:
        every check runs 3 x 1,000,000 box pairs (several seconds). /diagnostics keeps coming
        every diagnostic_period (0.5 s) meanwhile and says that a check is running."""
        self.add_piles()
        reports = []  # (receive time, level, message)
        lock = threading.Lock()

        def on_diag(msg):
            for st in msg.status:
                if 'collision_monitor' in st.name:
                    with lock:
                        reports.append((time.monotonic(), st.level, st.message))

        sub = rospy.Subscriber('/diagnostics', DiagnosticArray, on_diag, queue_size=100)
        start = time.monotonic()
        k = 0
        while time.monotonic() - start < 8.0:
            msg = BodyPoses(ids=['big_a', 'big_b', 'big_c'],
                            poses=[pose(10.0, 0, 0), pose(10.05 + 1e-4 * k, 0, 0),
                                   pose(10.0, 0.05 + 1e-4 * k, 0)])
            msg.header.frame_id = 'world'
            msg.header.stamp = rospy.Time(0)
            self.m.poses_pub.publish(msg)
            k += 1
            time.sleep(0.2)
        sub.unregister()
        with lock:
            got = list(reports)
        running = [m for _, _, m in got if 'a check has been running for' in m]
        gaps = [b[0] - a[0] for a, b in zip(got, got[1:])]
        print('long checks: %d reports in 8 s, largest gap %.2f s, %d say a check is running '
              '(%s)' % (len(got), max(gaps, default=0.0), len(running), running[:1]), flush=True)
        self.assertTrue(running, 'no report said a check was running: %s' % got[:5])
        self.assertTrue(all(level == DiagnosticStatus.WARN for _, level, m in got
                            if 'a check has been running for' in m))
        self.assertGreater(len(got), 8)
        self.assertLess(max(gaps), 1.5, 'reports held back by the checks: %s' % gaps)
        for name in ('big_a', 'big_b', 'big_c'):
            self.m.add(Body(id=name, operation=Body.REMOVE))
        self.assertTrue(wait_for(lambda: len(self.m.list_bodies().ids) == 2, 30.0))
        d = self.report(DiagnosticStatus.OK, 'ok', timeout=20.0)
        self.assertIsNotNone(d, self.m.diagnostics)

    def test_2b_poses_during_a_long_check_wait_and_apply_in_order(self):
        """Pose messages that come while a check of seconds holds the world wait for it in the
        node (the callback returns at once: roscpp's other spinner threads spun on the
        subscription meanwhile) and apply in the order they came: s1 ends at the last pose sent,
        the unknown id in the middle is refused with its reason, /diagnostics counts them."""
        self.add_piles(10.0)
        d = self.report(DiagnosticStatus.WARN, 'a check has been running for', timeout=60.0)
        self.assertIsNotNone(d, self.m.diagnostics)
        deferred_before = int(self.m.diag_value('pose messages deferred during a check (total)', d))
        n = 25
        for k in range(n):
            ids = ['ghost'] if k == n // 2 else ['s1']
            msg = BodyPoses(ids=ids, poses=[pose(0.5 + 0.01 * k, 0, 0)])
            msg.header.frame_id = 'world'
            msg.header.stamp = rospy.Time(0)  # static: a later one always replaces an earlier one
            self.m.poses_pub.publish(msg)
            time.sleep(0.05)
        d = wait_for(lambda: (lambda d: d if d is not None and int(self.m.diag_value(
            'pose messages deferred during a check (total)', d)) > deferred_before else None)(
                self.m.diagnostics), 20.0, 0.05)
        self.assertIsNotNone(d, self.m.diagnostics)
        for name in ('big_a', 'big_b', 'big_c'):
            self.m.add(Body(id=name, operation=Body.REMOVE))
        self.assertTrue(wait_for(lambda: len(self.m.list_bodies().ids) == 2, 30.0))
        # s0 (radius 0.1) at the origin (test_1), s1 (radius 0.1) at the last x sent, 0.74.
        r = self.m.get_distance('s0', 's1', '')
        self.assertTrue(r.success, r.message)
        self.assertAlmostEqual(r.result.distance, 0.5 + 0.01 * (n - 1) - 0.2, places=9)
        d = self.report(DiagnosticStatus.OK, 'ok', timeout=20.0)
        self.assertIsNotNone(d, self.m.diagnostics)
        deferred = int(self.m.diag_value('pose messages deferred during a check (total)', d))
        dropped = int(self.m.diag_value('pose messages dropped while waiting for a check (total)',
                                        d))
        print('poses during long checks: %d of %d messages deferred, %d dropped' %
              (deferred - deferred_before, n, dropped), flush=True)
        self.assertEqual(dropped, 0)
        self.assertIn('~body_poses: poses ignored for unknown bodies: ghost',
                      self.m.diag_value('last rejection', d))

    def test_2c_services_waiting_for_a_check_leave_pose_input_flowing(self):
        """Eight ~get_distance calls wait for a check of seconds (the node has 2 to 8 threads for
        pose input) while 400 pose messages come: every one reaches the node ('~body_poses
        messages (total)'). When services shared pose input's threads, such calls took them all,
        and roscpp dropped the messages beyond its queue of 100."""
        pub = rospy.Publisher(NS + 'body_poses', BodyPoses, queue_size=1000)
        self.assertTrue(wait_for(lambda: pub.get_num_connections() > 0, 10.0))
        self.add_piles(10.0)
        d = self.report(DiagnosticStatus.WARN, 'a check has been running for', timeout=60.0)
        self.assertIsNotNone(d, self.m.diagnostics)
        received_before = int(self.m.diag_value('~body_poses messages (total)', d))

        def call():
            try:
                rospy.ServiceProxy(NS + 'get_distance', GetDistance)('s0', 'big_a', '')
            except rospy.ServiceException:
                pass
        callers = [threading.Thread(target=call, daemon=True) for _ in range(8)]
        for c in callers:
            c.start()
        time.sleep(0.2)
        n = 400
        t_sent = time.monotonic()
        for k in range(n):
            msg = BodyPoses(ids=['s1'], poses=[pose(0.5 + 0.001 * k, 0, 0)])
            msg.header.frame_id = 'world'
            msg.header.stamp = rospy.Time(0)
            pub.publish(msg)
            time.sleep(0.001)
        t_sent = time.monotonic() - t_sent
        answered = sum(not c.is_alive() for c in callers)
        received = wait_for(lambda: int(self.m.diag_value('~body_poses messages (total)') or 0) >=
                            received_before + n, 30.0, 0.05)
        got = int(self.m.diag_value('~body_poses messages (total)')) - received_before
        print('pose messages during waiting services: %d of %d received (%.2f s to send them; '
              '%d of 8 calls answered by then)' % (got, n, t_sent, answered), flush=True)
        self.assertTrue(received, '%d of %d pose messages received' % (got, n))
        self.assertEqual(got, n)
        for name in ('big_a', 'big_b', 'big_c'):
            self.m.add(Body(id=name, operation=Body.REMOVE))
        self.assertTrue(wait_for(lambda: len(self.m.list_bodies().ids) == 2, 30.0))
        for c in callers:
            c.join(30.0)
        r = self.m.get_distance('s0', 's1', '')
        self.assertTrue(r.success, r.message)
        self.assertAlmostEqual(r.result.distance, 0.5 + 0.001 * (n - 1) - 0.2, places=9)

    def test_3_sigint_during_a_long_check(self):
        """SIGINT while such a check runs: the node stops it and exits at once. It used to finish
        the check first (13.9 s on a loaded machine), and roslaunch turns SIGINT into SIGTERM
        after 15 s.
        Last: the node is gone afterwards (overload.test: not required)."""
        pid = node_pid()
        self.assertTrue(alive(pid))
        self.add_piles(10.0)
        # A check has run for at least a second (/diagnostics says so only then); such a check
        # takes several seconds (test_2).
        d = self.report(DiagnosticStatus.WARN, 'a check has been running for', timeout=60.0)
        self.assertIsNotNone(d, self.m.diagnostics)
        # Input keeps coming meanwhile, as from a robot: a pose message and a service call, each
        # waiting for the check on a callback thread at SIGINT. Bug: such a callback keeps the
        # nodelet alive (its callback queue holds it), so ~Monitor and its abandonChecks() came
        # only after the check ended.
        self.place(1)
        threading.Thread(target=lambda: self.call_quietly('s0', 'big_a'), daemon=True).start()
        time.sleep(0.3)
        with open('/proc/%d/status' % pid) as f:
            peak_memory = ' '.join(l.split(':')[1].strip() for l in f if l.startswith('VmHWM'))
        t0 = time.monotonic()
        os.kill(pid, signal.SIGINT)
        exited = wait_for(lambda: not alive(pid), 30.0, 0.05)
        t_exit = time.monotonic() - t0
        print('SIGINT during a check (%s): exit after %.2f s; peak memory %s' %
              (d.message, t_exit, peak_memory), flush=True)
        self.assertTrue(exited, 'the node did not exit within 30 s of SIGINT')
        # 0.26 to 0.35 s here, as a plain exit. It was up to 2.3 s (4 runs of 5 over 1.5 s)
        # while a pair's warm-start caches were all made before its first part query: 208 MB for
        # each pair of these bodies, allocated in 0.65 s, deaf to abandonChecks().
        self.assertLess(t_exit, 1.5)


if __name__ == '__main__':
    rostest.rosrun('collision_monitor', 'overload', Overload, sys.argv)
