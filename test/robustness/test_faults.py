#!/usr/bin/python3
"""rostest: faults through a real roscore.
  1. TF for a body's frame stops -> its pairs UNKNOWN within pose_timeout + one cycle; resumes ->
     they recover (UNKNOWN_END) with the right distance.
  4. A per-body pose_topic publisher stops -> that body's pairs UNKNOWN within pose_timeout + one
     cycle (and not before its last pose is pose_timeout old); resumes -> UNKNOWN_END.
  5. The same for a ~body_poses publisher of two bodies.
  2. A burst of 1,000 ~get_distance calls (8 threads) plus a slow client holding a connection:
     every answer exact, the periodic check must not stall beyond one cycle; the largest gap
     between consecutive ~state messages during the burst is measured. roscpp 1.15 itself drops
     a fresh connection now and then under such churn (ROSCPP_DROP below): such a call is
     counted, retried once, and must be rare.
  2b. ~check_collision calls that wait for TF (12 clients) leave ~get_distance and ~list_bodies
     answering without waiting behind them.
  6. Node restart (SIGKILL, respawned by roslaunch) while publishers keep running: the latched
     ~bodies and the TF stream bring the world back (same ids, same distance).
Figures go to stdout and to $CM_ARTIFACTS/faults.txt when set."""
import os
import signal
import socket
import sys
import threading
import time
import unittest

import rospy
import rosservice
import rostest
import tf2_ros
from collision_monitor.msg import Body, CollisionEvent, CollisionState, PairState, Shape
from collision_monitor.srv import CheckCollision, GetDistance, ListBodies
from geometry_msgs.msg import PoseStamped

from robust_util import alive, node_pid, save_figures
from cm_test_util import Monitor, PoseStreamer, pose, shape, tf_transform, wait_for

E = CollisionEvent
FIGURES = []
# What rospy reports when roscpp closes a service connection before answering. Debian's roscpp
# 1.15.15 does so when a stale EPOLLRDHUP of a just-closed connection reaches the next connection
# accepted on the same file descriptor (docs/reliability.md, "roscpp drops a fresh service
# connection"); a plain roscpp server without any of our code shows it too.
ROSCPP_DROP = 'unable to receive data from sender'


def figure(line):
    FIGURES.append(line)
    print('[faults] ' + line, flush=True)


class TfStreamer:
    """Broadcasts world -> moving_frame at `rate` Hz with fresh stamps while not paused."""

    def __init__(self, rate=50.0):
        self.br = tf2_ros.TransformBroadcaster()
        self.paused = False
        self.x = 1.0
        self.period = 1.0 / rate
        self.sent = []  # stamps published
        threading.Thread(target=self._run, daemon=True).start()

    def _run(self):
        while not rospy.is_shutdown():
            if not self.paused:
                t = tf_transform('moving_frame', xyz=(self.x, 0.0, 0.0))
                try:
                    self.br.sendTransform(t)
                except rospy.ROSException:
                    return
                self.sent.append(t.header.stamp)
            time.sleep(self.period)


class PoseStampedStreamer:
    """Publishes a PoseStamped (frame world, fresh stamps) on `topic` at `rate` Hz while not
    paused."""

    def __init__(self, topic, p, rate=20.0):
        self.pub = rospy.Publisher(topic, PoseStamped, queue_size=10, tcp_nodelay=True)
        self.pose = p
        self.paused = False
        self.period = 1.0 / rate
        self.sent = []  # stamps published
        threading.Thread(target=self._run, daemon=True).start()

    def _run(self):
        while not rospy.is_shutdown():
            if not self.paused:
                m = PoseStamped(pose=self.pose)
                m.header.frame_id = 'world'
                m.header.stamp = rospy.Time.now()
                try:
                    self.pub.publish(m)
                except rospy.ROSException:
                    return
                self.sent.append(m.header.stamp)
            time.sleep(self.period)


class Faults(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_faults')
        cls.static_tf = tf2_ros.StaticTransformBroadcaster()
        cls.static_tf.sendTransform([tf_transform('fixed_frame_a', stamp=rospy.Time())])
        cls.tf = TfStreamer()
        cls.m = Monitor()
        cls.rate = rospy.get_param('/collision_monitor/rate')
        cls.pose_timeout = rospy.get_param('/collision_monitor/pose_timeout')
        # 'fixed' comes from the ~bodies parameter (faults.test), 'mover' from a latched ~bodies
        # publisher: both survive a restart. A latched publisher keeps only its LAST message, so
        # one latched publisher (one node) can bring back one body (docs/reliability.md).
        cls.latched = rospy.Publisher('/collision_monitor/bodies', Body, queue_size=10, latch=True)
        b = Body(id='mover', operation=Body.ADD, pose_from_topic=False)
        b.header.frame_id = 'moving_frame'
        b.parts = [shape(Shape.SPHERE, [0.3])]
        cls.latched.publish(b)
        assert cls.m.wait_listed('fixed', timeout=10.0) and cls.m.wait_listed('mover', timeout=10.0)
        cls.state_times = []  # (receive time, the check's stamp (s)) of every ~state
        rospy.Subscriber('/collision_monitor/state', CollisionState,
                         lambda msg: cls.state_times.append((time.monotonic(),
                                                             msg.header.stamp.to_sec())),
                         queue_size=100)
        # Topic-posed bodies of faults.test (~bodies parameter), 'fixed' at the origin (r 0.2):
        # 'tracked' (r 0.1) on its pose_topic at y = 1, 'posed_a'/'posed_b' (r 0.1) on
        # ~body_poses at y = 2 / y = 3: every pair CLEAR while their publishers run.
        cls.tracked = PoseStampedStreamer('/tracked_pose', pose(y=1.0))
        cls.poses = PoseStreamer(cls.m.poses_pub, frame='world', rate=20.0)
        cls.poses.set('posed_a', pose(y=2.0))
        cls.poses.set('posed_b', pose(y=3.0))

    def distance(self):
        r = self.m.get_distance('fixed', 'mover', '')
        return r.result.distance if r.success else None

    def test_1_tf_stops_and_resumes(self):
        self.assertTrue(wait_for(lambda: self.distance() is not None, 5.0))
        self.assertAlmostEqual(self.distance(), 1.0 - 0.5, delta=1e-6)
        t0 = time.monotonic()
        self.tf.paused = True
        ev = self.m.wait_event(E.UNKNOWN_BEGIN, 'fixed', 'mover', timeout=5.0, since=t0)
        self.assertIsNotNone(ev, 'no UNKNOWN_BEGIN after the TF stream stopped')
        latency = ev[0] - t0
        # The last transform was up to one TF period old when the stream stopped.
        bound = self.pose_timeout + 1.0 / self.rate + 0.1
        figure('TF stopped: UNKNOWN_BEGIN after %.3f s (pose_timeout %.2f s, cycle %.3f s)'
               % (latency, self.pose_timeout, 1.0 / self.rate))
        self.assertLessEqual(latency, bound)
        self.assertEqual(ev[1].pair.status, PairState.UNKNOWN)
        t1 = time.monotonic()
        self.tf.paused = False
        ev = self.m.wait_event(E.UNKNOWN_END, 'fixed', 'mover', timeout=5.0, since=t1)
        self.assertIsNotNone(ev, 'no UNKNOWN_END after the TF stream resumed')
        figure('TF resumed: UNKNOWN_END after %.3f s' % (ev[0] - t1))
        self.assertTrue(wait_for(lambda: self.distance() is not None, 2.0))
        self.assertAlmostEqual(self.distance(), 0.5, delta=1e-6)

    def test_2_service_burst(self):
        # A slow client: connects to the service port and sends nothing.
        uri = rosservice.get_service_uri('/collision_monitor/get_distance')
        host, port = uri[len('rosrpc://'):].rstrip('/').rsplit(':', 1)
        slow = socket.create_connection((host, int(port)))
        slow.sendall(b'\x10\x00')  # 2 bytes of a 4-byte header length, then silence
        n, threads = 1000, 8
        del self.state_times[:]
        errors, drops = [], []

        def connect(k):
            return rospy.ServiceProxy('/collision_monitor/get_distance', GetDistance,
                                      persistent=(k % 2 == 0))

        def worker(k):
            proxy = connect(k)
            for _ in range(n // threads):
                for attempt in (1, 2):
                    try:
                        r = proxy('fixed', 'mover', '')
                    except rospy.ServiceException as e:
                        if attempt == 1 and ROSCPP_DROP in str(e):
                            drops.append(str(e))  # the retry must then succeed
                            proxy.close()
                            proxy = connect(k)
                            continue
                        errors.append(str(e))
                    except OSError as e:
                        errors.append(str(e))
                    else:
                        # Every answer the right one (spheres 0.2 and 0.3 with centres 1 m apart).
                        if not r.success or abs(r.result.distance - 0.5) > 1e-9:
                            errors.append('answer: %s %r' % (r.success, r.message or r.result))
                    break
            proxy.close()

        t0 = time.monotonic()
        ws = [threading.Thread(target=worker, args=(k,)) for k in range(threads)]
        for w in ws:
            w.start()
        for w in ws:
            w.join()
        dt = time.monotonic() - t0
        time.sleep(0.5)
        slow.close()
        # Gaps between the checks' own stamps: the node's loop, not this process's receiving
        # (its eight client threads hold the GIL).
        times = [stamp for t, stamp in self.state_times if t0 <= t <= t0 + dt]
        gaps = [b - a for a, b in zip(times, times[1:])]
        max_gap = max(gaps) if gaps else float('inf')
        figure('burst: %d ~get_distance calls from %d threads + 1 stalled client in %.2f s '
               '(%.0f calls/s), %d errors, %d connections dropped by roscpp and retried; '
               '~state during it: %d messages, max gap %.1f ms (cycle %.1f ms)'
               % (n, threads, dt, n / dt, len(errors), len(drops), len(times), 1e3 * max_gap,
                  1e3 / self.rate))
        self.assertEqual(errors, [])
        # Measured: 1 drop in 3,000 to 75,000 calls (ours), 1 in 6,000 (a plain roscpp server).
        self.assertLessEqual(len(drops), n // 200, drops)
        self.assertGreater(len(times), 2)
        self.assertLessEqual(max_gap, 2.0 / self.rate + 0.02,
                             'the periodic check stalled beyond one cycle during the burst')

    def test_2b_what_if_calls_waiting_for_tf_leave_the_other_services_answering(self):
        # ~check_collision bodies stamped ahead of TF in a moving frame: each call waits the
        # node's 50 ms for TF to catch up (and is refused: TF never gets 1 s ahead), from more
        # clients than the node has threads for them (at most 8). Meanwhile ~list_bodies and
        # ~get_distance are called one at a time: they must not queue behind the waits (on the
        # same threads, before the thirty-ninth session: 307 ms a call, as long as the what-ifs).
        stop = threading.Event()
        waits, errors = [], []

        def what_if():
            proxy = rospy.ServiceProxy('/collision_monitor/check_collision', CheckCollision,
                                       persistent=True)
            body = Body(id='probe', operation=Body.ADD, parts=[shape(Shape.SPHERE, [0.05])])
            body.header.frame_id = 'moving_frame'
            while not stop.is_set():
                body.header.stamp = rospy.Time.now() + rospy.Duration(1.0)
                t = time.monotonic()
                try:
                    r = proxy(body=body, pose=pose(), margin=0.0)
                except (rospy.ServiceException, OSError) as e:
                    errors.append(str(e))
                    break
                waits.append(time.monotonic() - t)
                if r.success or 'cannot resolve frame' not in r.message:
                    errors.append('what-if answer: %s %r' % (r.success, r.message))
            proxy.close()

        waits_before = int(self.m.diag_value('waits for TF (total)') or 0)
        clients = [threading.Thread(target=what_if) for _ in range(12)]
        for c in clients:
            c.start()
        others = []
        # Persistent: a fresh connection a call may meet roscpp's own drop (ROSCPP_DROP).
        get_distance = rospy.ServiceProxy('/collision_monitor/get_distance', GetDistance,
                                          persistent=True)
        list_bodies = rospy.ServiceProxy('/collision_monitor/list_bodies', ListBodies,
                                         persistent=True)
        try:
            self.assertTrue(wait_for(lambda: len(waits) >= 24, 10.0), 'the what-if calls stalled')
            for k in range(30):
                t = time.monotonic()
                if k % 2:
                    self.assertIn('fixed', list_bodies().ids)
                else:
                    r = get_distance('fixed', 'mover', '')
                    # The right answer, or a stale 'mover' should this process's TF thread
                    # have stalled among the 12 clients.
                    if r.success:
                        self.assertAlmostEqual(r.result.distance, 0.5, delta=1e-9)
                    else:
                        self.assertIn('stale', r.message)
                others.append(time.monotonic() - t)
        finally:
            stop.set()
            for c in clients:
                c.join()
            get_distance.close()
            list_bodies.close()
        self.assertEqual(errors, [])
        waits.sort()
        others.sort()
        wait_median, other_median = waits[len(waits) // 2], others[len(others) // 2]
        figure('%d what-if calls stamped ahead of TF from 12 clients: median %.1f ms; '
               '~list_bodies and ~get_distance meanwhile: median %.1f ms, max %.1f ms'
               % (len(waits), 1e3 * wait_median, 1e3 * other_median, 1e3 * others[-1]))
        # The what-ifs did wait for TF (50 ms each), and they were counted.
        self.assertGreaterEqual(wait_median, 0.045)
        self.assertTrue(wait_for(lambda: int(self.m.diag_value('waits for TF (total)') or 0) >=
                                 waits_before + len(waits) // 2, 5.0))
        # The other services did not wait behind them (on shared threads: at least one whole
        # wait each, as every thread was taken).
        self.assertLess(other_median, 0.4 * wait_median)

    def publisher_stops_and_resumes(self, what, pause, resume, body_ids, stamps):
        """Stops a pose publisher: every pair of `fixed` with `body_ids` must turn UNKNOWN within
        pose_timeout + one cycle of the stop, and not before the last pose published is more
        than pose_timeout old (judged by stamps, which load on this machine does not move:
        `stamps(b)` lists those the publisher sent for b); and recover (UNKNOWN_END, exact
        distance) within a cycle of the first pose after the resume."""
        pairs = [('fixed', b) for b in body_ids]
        expected = {b: self.distance_of('fixed', b) for b in body_ids}
        for b in body_ids:
            self.assertIsNotNone(expected[b], 'fixed-%s has no distance before the stop' % b)
        t0 = time.monotonic()
        pause()
        hi = self.pose_timeout + 1.0 / self.rate + 0.1
        latencies, ages, stopped_at = [], [], {}
        for a, b in pairs:
            ev = self.m.wait_event(E.UNKNOWN_BEGIN, a, b, timeout=5.0, since=t0)
            self.assertIsNotNone(ev, 'no UNKNOWN_BEGIN for %s-%s after the %s stopped' % (a, b, what))
            self.assertEqual(ev[1].pair.status, PairState.UNKNOWN)
            latencies.append(ev[0] - t0)
            stopped_at[b] = ev[1].header.stamp
            last = max(t for t in stamps(b) if t <= stopped_at[b])
            ages.append((stopped_at[b] - last).to_sec())
        figure('%s stopped: UNKNOWN_BEGIN after %s s, its last pose then %s s old '
               '(pose_timeout %.2f s, cycle %.3f s)'
               % (what, '/'.join('%.3f' % x for x in latencies),
                  '/'.join('%.3f' % x for x in ages), self.pose_timeout, 1.0 / self.rate))
        for x in latencies:
            self.assertLessEqual(x, hi)
        for age in ages:
            self.assertGreater(age, self.pose_timeout, 'UNKNOWN before the pose was stale')
        for b in body_ids:
            self.assertTrue(wait_for(lambda: b in self.m.state.stale_bodies, 1.0))
            r = self.m.get_distance('fixed', b, '')
            self.assertFalse(r.success)
            self.assertIn('stale', r.message)
        t1 = time.monotonic()
        resume()
        latencies, delays = [], []
        for a, b in pairs:
            ev = self.m.wait_event(E.UNKNOWN_END, a, b, timeout=5.0, since=t1)
            self.assertIsNotNone(ev, 'no UNKNOWN_END for %s-%s after the %s resumed' % (a, b, what))
            latencies.append(ev[0] - t1)
            # The publisher's thread records a stamp once publish() returned: maybe after the
            # node answered.
            first = wait_for(lambda: min((t for t in stamps(b) if t > stopped_at[b]),
                                         default=None), 2.0)
            self.assertIsNotNone(first, 'no pose recorded after the resume')
            delays.append((ev[1].header.stamp - first).to_sec())
        figure('%s resumed: UNKNOWN_END after %s s, %s s after the first pose\'s stamp'
               % (what, '/'.join('%.3f' % x for x in latencies),
                  '/'.join('%.3f' % x for x in delays)))
        for x in delays:
            self.assertGreaterEqual(x, 0.0)
            self.assertLessEqual(x, 1.0 / self.rate + 0.1)
        for b in body_ids:
            self.assertAlmostEqual(self.distance_of('fixed', b), expected[b], delta=1e-9)
            self.assertTrue(wait_for(lambda: b not in self.m.state.stale_bodies, 1.0))

    def distance_of(self, a, b):
        r = wait_for(lambda: (lambda x: x if x.success else None)(self.m.get_distance(a, b, '')),
                     5.0)
        return r.result.distance if r else None

    def test_4_pose_topic_stops_and_resumes(self):
        self.assertAlmostEqual(self.distance_of('fixed', 'tracked'), 1.0 - 0.3, delta=1e-9)

        def pause():
            self.tracked.paused = True

        def resume():
            self.tracked.paused = False
        self.publisher_stops_and_resumes('pose_topic publisher', pause, resume, ['tracked'],
                                         lambda b: list(self.tracked.sent))

    def test_5_body_poses_stop_and_resume(self):
        self.assertAlmostEqual(self.distance_of('fixed', 'posed_a'), 2.0 - 0.3, delta=1e-9)
        self.assertAlmostEqual(self.distance_of('fixed', 'posed_b'), 3.0 - 0.3, delta=1e-9)

        def pause():
            with self.poses.lock:
                self.poses.paused.update(('posed_a', 'posed_b'))

        def resume():
            with self.poses.lock:
                self.poses.paused.clear()
        self.publisher_stops_and_resumes('~body_poses publisher', pause, resume,
                                         ['posed_a', 'posed_b'], self.poses.stamps)

    def test_6_restart(self):
        pid = node_pid()
        self.assertTrue(alive(pid))
        self.assertAlmostEqual(self.distance(), 0.5, delta=1e-9)  # spheres 0.2, 0.3, 1 m apart
        os.kill(pid, signal.SIGKILL)
        t0 = time.monotonic()
        new_pid = wait_for(lambda: (lambda p: p if p and p != pid else None)(node_pid()), 30.0, 0.2)
        self.assertIsNotNone(new_pid, 'the node was not respawned')
        back = wait_for(lambda: self._answers(), 30.0, 0.1)
        figure('restart: SIGKILL -> respawned (pid %s) -> world back (latched ~bodies, TF) in %.2f s'
               % (new_pid, time.monotonic() - t0))
        self.assertTrue(back, 'the world did not come back after the restart')
        self.assertAlmostEqual(self.distance(), 0.5, delta=1e-9)

    def _answers(self):
        try:
            rospy.wait_for_service('/collision_monitor/get_distance', timeout=0.5)
            ids = rospy.ServiceProxy('/collision_monitor/list_bodies',
                                     self.m.list_bodies.service_class)().ids
            if 'fixed' not in ids or 'mover' not in ids:
                return False
            self.m.get_distance = rospy.ServiceProxy('/collision_monitor/get_distance', GetDistance)
            return self.distance() is not None
        except (rospy.ROSException, rospy.ServiceException, OSError):
            return False

    @classmethod
    def tearDownClass(cls):
        save_figures('faults.txt', FIGURES)


if __name__ == '__main__':
    rostest.rosrun('collision_monitor', 'faults', Faults, sys.argv)
