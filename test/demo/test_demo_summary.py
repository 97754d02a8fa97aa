#!/usr/bin/python3
"""rostest (demo_summary.test): scripts/demo_summary.py, run as a process of its own against a
fake monitor's ~events and ~state published by this test, prints each event live except an
UNKNOWN_END whose UNKNOWN_BEGIN it did not see (the robot's pairs, known from its first poses
before it connected: 49 of the 71 lines of a 12 s Panda demo before); its table has a row for
each pair with another event or near in ~state, and one line for the rest. After its duration it
ends the roslaunch that started it as Ctrl-C would (the demo, launched here)."""
import os
import re
import signal
import socket
import subprocess
import sys
import unittest

import rospy
import rostest
from collision_monitor.msg import CollisionEvent, CollisionState, PairState

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'scripts',
                      'demo_summary.py')
FAKE = '/fake_monitor'
E = CollisionEvent
C, W, X, U = PairState.CLEAR, PairState.WARNING, PairState.COLLISION, PairState.UNKNOWN  # statuses


def event(etype, a, b, status, distance):
    ev = CollisionEvent(type=etype)
    ev.header.stamp = rospy.Time.now()
    ev.pair = PairState(body_a=a, body_b=b, status=status, distance=distance)
    return ev


class DemoSummary(unittest.TestCase):
    def test_prints_the_events_that_tell_something(self):
        rospy.init_node('test_demo_summary')
        events = rospy.Publisher(FAKE + '/events', CollisionEvent, queue_size=100)
        state = rospy.Publisher(FAKE + '/state', CollisionState, queue_size=100)
        proc = subprocess.Popen([sys.executable, SCRIPT, '__name:=summary_under_test',
                                 '_monitor:=' + FAKE, '_duration:=6'],
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        try:
            deadline = rospy.Time.now() + rospy.Duration(20.0)
            while (events.get_num_connections() == 0 or state.get_num_connections() == 0) and \
                    rospy.Time.now() < deadline:
                rospy.sleep(0.05)
            self.assertGreater(events.get_num_connections(), 0)
            sent = [
                # Known from their first poses: their UNKNOWN_BEGINs came before.
                event(E.UNKNOWN_END, 'arm', 'ball', C, 0.5),
                event(E.UNKNOWN_END, 'arm', 'cube', C, 0.25),
                event(E.UNKNOWN_END, 'arm', 'lamp', W, 0.04),
                event(E.WARNING_BEGIN, 'arm', 'lamp', W, 0.04),
                event(E.UNKNOWN_END, 'ball', 'hand', X, -0.01),
                event(E.COLLISION_BEGIN, 'ball', 'hand', X, -0.01),
                # A spell without poses while the summary watches: both ends printed.
                event(E.UNKNOWN_BEGIN, 'cube', 'hand', U, float('inf')),
                event(E.UNKNOWN_END, 'cube', 'hand', C, 0.2),
                event(E.COLLISION_END, 'ball', 'hand', C, 0.07),
                event(E.WARNING_END, 'arm', 'lamp', C, 0.06),
            ]
            for ev in sent:
                events.publish(ev)
                rospy.sleep(0.02)
            for k in range(5):
                st = CollisionState(num_bodies=5, num_pairs_checked=3, compute_time=0.001)
                st.header.stamp = rospy.Time.now()
                if k == 0:  # near from before, with no event seen: listed
                    st.pairs = [PairState(body_a='desk', body_b='hand', status=W, distance=0.03)]
                state.publish(st)
                rospy.sleep(0.1)
            out, _ = proc.communicate(timeout=30.0)
        finally:
            if proc.poll() is None:
                proc.kill()
        print(out)
        live = re.findall(r'^\[ *[0-9.]+ s\] (\w+) +(\S+) <-> (\S+)', out, re.M)
        self.assertEqual(live, [('WARNING_BEGIN', 'arm', 'lamp'),
                                ('COLLISION_BEGIN', 'ball', 'hand'),
                                ('UNKNOWN_BEGIN', 'cube', 'hand'),
                                ('UNKNOWN_END', 'cube', 'hand'),
                                ('COLLISION_END', 'ball', 'hand'),
                                ('WARNING_END', 'arm', 'lamp')])
        rows = re.findall(r'^(\S+) <-> (\S+) +(\S+) +((?:\d+ *){6})$', out, re.M)
        self.assertEqual([(a, b, d, counts.split()) for a, b, d, counts in rows], [
            ('arm', 'lamp', '40.0', ['0', '0', '1', '1', '0', '1']),
            ('ball', 'hand', '-10.0', ['1', '1', '0', '0', '0', '1']),
            ('cube', 'hand', '200.0', ['0', '0', '0', '0', '1', '1']),
            ('desk', 'hand', '30.0', ['0', '0', '0', '0', '0', '0'])])
        self.assertIn('+ 2 pairs known from the first poses (an UNKNOWN_END only), not listed; '
                      'nearest arm <-> cube at 250.0 mm', out)
        self.assertIn('events: COLLISION_BEGIN 1, COLLISION_END 1, WARNING_BEGIN 1, '
                      'WARNING_END 1, UNKNOWN_BEGIN 1, UNKNOWN_END 5', out)
        self.assertIn('(UNKNOWN_END without their BEGINs: those came before this summary '
                      'connected; such UNKNOWN_ENDs are not printed above)', out)
        self.assertRegex(out, r'(?m)^cycles: 5 at [0-9.]+ Hz, 5 bodies, 3\.0 narrow-phase')
        self.assertEqual(proc.returncode, 0)

    def test_ends_the_demo_as_ctrl_c_would(self):
        """The demo launched by roslaunch (on a master of its own) ends after `duration`: the
        summary prints its table and sends roslaunch SIGINT, so roslaunch shuts every node down
        as on Ctrl-C (the summary too) and exits 0, without the red "REQUIRED process ... has
        died" of a required node that exits first."""
        sock = socket.socket()
        sock.bind(('', 0))
        port = sock.getsockname()[1]
        sock.close()
        env = dict(os.environ, ROS_MASTER_URI='http://localhost:%d' % port)
        proc = subprocess.Popen(['roslaunch', '-p', str(port), 'collision_monitor', 'demo.launch',
                                 'duration:=3', 'monitor_output:=log'], env=env,
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        try:
            out, _ = proc.communicate(timeout=90.0)
        finally:
            if proc.poll() is None:
                proc.send_signal(signal.SIGINT)
                proc.communicate(timeout=30.0)
        print(out)
        self.assertIn('=== collision_monitor demo summary', out)
        self.assertRegex(out, r'(?m)^cycles: [1-9]\d* at ')
        self.assertNotIn('REQUIRED process', out)
        self.assertIn('shutting down processing monitor complete', out)
        self.assertEqual(proc.returncode, 0)


if __name__ == '__main__':
    rostest.rosrun('collision_monitor', 'demo_summary', DemoSummary)
