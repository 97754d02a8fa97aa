#!/usr/bin/python3
"""rostest: the node built with ThreadSanitizer (tsan.test). Drives every input thread of the node
at once -- TF (moving joints), ~body_poses, two pose topics that a body switches between as it is
replaced, ~bodies adding and removing bodies (a mesh among them), the three services from two
threads, ~markers subscribed and unsubscribed, dynamic_reconfigure -- for LOAD_SECONDS, then sends
SIGINT with all of it still running: TSan may have written no log (it writes one to report). Then
the same monitor as a nodelet in Debian's manager (libtsan preloaded), beside a second one under a
load of its own: unloaded under that load, loaded again, and the manager stopped by SIGINT under
load; no log of the manager either. Each stop comes during back-to-back reconfigure calls. Checks
first that the node and the libraries of ours it mapped are instrumented (a build without TSan
would pass vacuously), and afterwards that each kind of input was taken in.
Figures go to stdout and to $CM_ARTIFACTS/tsan.txt when set."""
import glob
import math
import os
import re
import signal
import subprocess
import sys
import threading
import time
import unittest

import roslib.packages
import rospy
import rosservice
import rostest
from collision_monitor.msg import Body, BodyPoses, CollisionEvent, Shape
from collision_monitor.srv import CheckCollision, GetDistance, ListBodies
from dynamic_reconfigure.client import Client
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import JointState
from visualization_msgs.msg import MarkerArray

from robust_util import alive, node_pid, save_figures
from cm_test_util import Monitor, panda_joint_state, pose, shape, sphere_body, wait_for

E = CollisionEvent
FIGURES = []
LOAD_SECONDS = 20.0
NODELET_LOAD_SECONDS = 8.0
TOPICS = ('/tsan/pose_a', '/tsan/pose_b')
BURST_THREADS = 4  # reconfigure calls back to back before each stop (Load.reconfigure_burst)


def figure(line):
    FIGURES.append(line)
    print('[tsan] ' + line, flush=True)


def instrumented(path):
    """Whether a binary calls into TSan (its code was compiled with -fsanitize=thread)."""
    with open(path, 'rb') as f:
        return b'__tsan_func_entry' in f.read()


def mapped_files(pid):
    """The files a process has mapped, from /proc/<pid>/maps."""
    with open('/proc/%d/maps' % pid) as f:
        return {line.split()[-1] for line in f if len(line.split()) >= 6}


def tsan_reports(text):
    """The kinds of the reports in a TSan log ('data race', 'lock-order-inversion ...')."""
    return [k.strip() for k in re.findall(r'^WARNING: ThreadSanitizer: ([^\n(]+)', text, re.M)]


class Load:
    """The input threads, against the monitor `m` (its namespace `m.node`): each runs until
    `stop` is set and counts what it did."""

    def __init__(self, m):
        self.m = m
        self.ns = m.node + '/'
        self.stop = threading.Event()
        self.burst = threading.Event()  # set 1 s before the monitor is stopped
        self.sigint = threading.Event()  # set as the monitor is stopped: errors expected then
        self.counts = {}
        self.errors = []
        self.lock = threading.Lock()
        self.threads = []

    def count(self, key, n=1):
        with self.lock:
            self.counts[key] = self.counts.get(key, 0) + n

    def answered(self, service, r):
        """Counts a service's answer, and a refusal by its reason (ids and figures left out)."""
        self.count(service + ('_ok' if r.success else '_refused'))
        if not r.success:
            self.count('reason: ' + re.sub(r"'[^']*'|\b[0-9][0-9.e+-]*", '_', r.message)[:80])

    def start(self, *targets):
        for target in targets:
            t = threading.Thread(target=self._guard, args=(target,), daemon=True)
            t.start()
            self.threads.append(t)

    def _guard(self, target):
        try:
            target()
        except (rospy.ROSException, rospy.ServiceException) as e:
            if not self.sigint.is_set():
                self.errors.append('%s: %s' % (target.__name__, e))

    def join(self):
        self.stop.set()
        for t in self.threads:
            t.join(10.0)

    def joint_states(self):
        """The ready configuration with panda_joint1 and panda_joint4 swinging: TF moves every link, 50 Hz."""
        pub = rospy.Publisher('/joint_states', JointState, queue_size=10)
        t0 = time.monotonic()
        while not self.stop.is_set():
            s = time.monotonic() - t0
            pub.publish(panda_joint_state(panda_joint1=0.6 * math.sin(2.0 * s),
                                          panda_joint4=0.3 * math.sin(3.0 * s)))
            self.count('joint_states')
            time.sleep(0.02)

    def body_poses(self):
        """'post' in the hand frame, on the hand and 1 m off it in turn (a collision every
        second), and 'far' 1 m behind the hand: ~body_poses at 50 Hz."""
        k = 0
        while not self.stop.is_set():
            on_hand = (k // 25) % 2 == 0
            msg = BodyPoses(ids=['post', 'far'],
                            poses=[pose() if on_hand else pose(x=1.0), pose(x=-1.0)])
            msg.header.frame_id = 'panda_hand'
            msg.header.stamp = rospy.Time.now()
            self.m.poses_pub.publish(msg)
            self.count('body_poses')
            k += 1
            time.sleep(0.02)

    def pose_topics(self):
        """Both of the topics 'tracked' switches between, 100 Hz each."""
        pubs = [rospy.Publisher(t, PoseStamped, queue_size=10) for t in TOPICS]
        k = 0
        while not self.stop.is_set():
            for i, pub in enumerate(pubs):
                p = PoseStamped(pose=pose(x=0.4 + 0.01 * (k % 20), y=0.3 * i, z=0.5))
                p.header.frame_id = 'panda_link0'
                p.header.stamp = rospy.Time.now()
                pub.publish(p)
            self.count('pose_topic_messages', len(pubs))
            k += 1
            time.sleep(0.01)

    def bodies(self):
        """Every 0.1 s 'churn' added or removed (every fourth time a mesh hull), every 0.5 s
        'tracked' replaced on the other pose topic (an unsubscribe and a subscribe)."""
        k = 0
        while not self.stop.is_set():
            if k % 5 == 0:
                self.m.add(sphere_body('tracked', 0.05 + 0.01 * (k % 3),
                                       pose_topic=TOPICS[k // 5 % 2]))
                self.count('bodies_messages')
            if k % 2 == 0:
                churn = Body(id='churn', operation=Body.ADD, pose_from_topic=False)
                churn.header.frame_id = 'panda_link%d' % (k % 7)
                if k % 8 == 0:
                    churn.parts = [shape(Shape.MESH,
                                         resource='package://collision_monitor/meshes/gripper.stl')]
                else:
                    churn.parts = [shape(Shape.BOX, [0.05, 0.05, 0.05]),
                                   shape(Shape.SPHERE, [0.03], pose=pose(z=0.1))]
                self.m.add(churn)
            else:
                self.m.add(Body(id='churn', operation=Body.REMOVE))
            self.count('bodies_messages')
            k += 1
            time.sleep(0.1)

    # The service threads call over persistent connections: roscpp drops 1 in some thousands of
    # fresh ones when a call follows a call at once (docs/reliability.md, "roscpp drops a fresh
    # service connection"), more often under TSan.

    def distances(self):
        """~get_distance in a loop: a pair, the nearest body, the pose topics' body in another
        frame, an unknown id."""
        get_distance = rospy.ServiceProxy(self.ns + 'get_distance', GetDistance, persistent=True)
        asks = [('pair', 'panda_hand', 'table', ''), ('nearest', 'post', '', ''),
                ('pose_topic', 'panda_hand', 'tracked', 'panda_hand'),
                ('unknown', 'nobody', 'table', '')]
        k = 0
        while not self.stop.is_set():
            name, a, b, frame = asks[k % len(asks)]
            self.answered('get_distance_' + name, get_distance(a, b, frame))
            k += 1

    def probes(self):
        """~check_collision (a box in the hand frame) and ~list_bodies in a loop."""
        probe = Body(id='probe', operation=Body.ADD)
        probe.header.frame_id = 'panda_hand'
        probe.parts = [shape(Shape.BOX, [0.1, 0.1, 0.1])]
        check_collision = rospy.ServiceProxy(self.ns + 'check_collision', CheckCollision,
                                             persistent=True)
        list_bodies = rospy.ServiceProxy(self.ns + 'list_bodies', ListBodies, persistent=True)
        while not self.stop.is_set():
            self.answered('check_collision', check_collision(probe, pose(), 0.3))
            self.count('list_bodies_ok' if list_bodies().ids else 'list_bodies_empty')

    def markers(self):
        """~markers subscribed for 0.5 s, then not for 0.5 s (the node builds them only while
        subscribed)."""
        got = []
        while not self.stop.is_set():
            sub = rospy.Subscriber(self.ns + 'markers', MarkerArray, got.append,
                                   queue_size=10)
            self.stop.wait(0.5)
            sub.unregister()
            self.stop.wait(0.5)
            self.count('marker_arrays', len(got))
            got.clear()

    def reconfigure(self):
        """dynamic_reconfigure every 0.25 s: thresholds, align_poses, estimate_twists, the rate,
        the backend."""
        client = Client(self.m.node, timeout=30.0)
        k = 0
        while not self.stop.is_set():
            client.update_configuration({
                'warning_distance': 0.05 + 0.05 * (k % 2), 'align_poses': k % 3 != 0,
                'estimate_twists': k % 4 >= 2, 'rate': 20.0 + 10.0 * (k % 2),
                'backend': 'libccd' if k % 5 == 4 else 'gjk'})
            self.count('reconfigurations')
            k += 1
            self.stop.wait(0.25)

    def reconfigure_burst(self):
        """From `burst` on, dynamic_reconfigure calls back to back until the end: one is in
        progress as the monitor stops (~Monitor freed the server under such a call)."""
        client = Client(self.m.node, timeout=30.0)
        while not self.burst.wait(0.05):
            if self.stop.is_set():
                return
        k = 0
        while not self.stop.is_set():
            client.update_configuration({'warning_distance': 0.05 + 0.01 * (k % 3)})
            self.count('burst_reconfigurations')
            k += 1


class Tsan(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.t_start = time.monotonic()
        rospy.init_node('test_tsan')
        cls.m = Monitor()  # waits up to 30 s for the services
        cls.pid = node_pid()
        assert cls.pid, 'no pid for /collision_monitor'
        cls.log_prefix = os.path.join(rospy.get_param('/tsan_log_dir'), 'collision_monitor_tsan')
        figure('node up after %.1f s (pid %d, TSan log %s.%d)'
               % (time.monotonic() - cls.t_start, cls.pid, cls.log_prefix, cls.pid))

    def test_1_instrumented(self):
        files = mapped_files(self.pid)
        exe = os.readlink('/proc/%d/exe' % self.pid)
        ours = sorted(f for f in files if os.path.basename(f).startswith('libcollision_monitor'))
        self.assertTrue(any('libtsan' in f for f in files), 'TSan runtime not mapped')
        # The monitor itself lives in libcollision_monitor_ros, loaded as a nodelet at run time.
        self.assertTrue(any('libcollision_monitor_ros' in f for f in ours), ours)
        for f in [exe] + ours:
            self.assertTrue(instrumented(f), f + ' was not compiled with -fsanitize=thread')
        self.assert_logs_here(self.pid)
        figure('instrumented: %s' % ', '.join([exe] + ours))

    def start_load(self, m, joints=True):
        """The bodies Load.body_poses poses and the table (the node has it from YAML), then every
        input thread of Load against `m` (/joint_states only if `joints`: one load publishes them
        for every monitor)."""
        m.add(sphere_body('post', 0.03))
        m.add(sphere_body('far', 0.05))
        table = Body(id='table', operation=Body.ADD)
        table.header.frame_id = 'panda_link0'
        table.parts = [shape(Shape.BOX, [1.0, 1.0, 0.04], pose=pose(x=0.5, z=-0.05))]
        m.add(table)
        for b in ('post', 'far', 'table'):
            self.assertTrue(m.wait_listed(b, timeout=20.0), b)
        load = Load(m)
        load.t0 = time.monotonic()
        load.start(load.body_poses, load.pose_topics, load.bodies, load.distances, load.probes,
                   load.markers, load.reconfigure, *[load.reconfigure_burst] * BURST_THREADS)
        if joints:
            load.start(load.joint_states)
        return load

    def stop_process(self, pid, what, loads):
        """After 1 s of reconfigure bursts of `loads`, SIGINT to `pid` and its exit within 60 s;
        the seconds it took."""
        for load in loads:
            load.burst.set()
        time.sleep(1.0)
        for load in loads:
            load.sigint.set()
        t0 = time.monotonic()
        os.kill(pid, signal.SIGINT)
        exited = wait_for(lambda: not alive(pid), 60.0, 0.1)
        self.assertTrue(exited, what + ' did not exit within 60 s of SIGINT')
        return time.monotonic() - t0

    def check_load(self, load, label):
        """Every kind of input was taken in and answered, pose messages came during checks, and
        no call failed but at the end."""
        m = load.m
        with m.lock:
            collisions = sum(1 for t, e in m.events if t >= load.t0 and e.type == E.COLLISION_BEGIN
                             and {e.pair.body_a, e.pair.body_b} == {'panda_hand', 'post'})
        figure('%s: %s; hand-post COLLISION_BEGINs %d; last /diagnostics: %s'
               % (label, sorted(load.counts.items()), collisions,
                  m.diagnostics and m.diagnostics.message))
        self.assertEqual(load.errors, [])
        for key in ('get_distance_pair_ok', 'get_distance_nearest_ok', 'get_distance_pose_topic_ok',
                    'get_distance_unknown_refused', 'check_collision_ok', 'list_bodies_ok',
                    'reconfigurations', 'burst_reconfigurations', 'marker_arrays'):
            self.assertGreater(load.counts.get(key, 0), 0, key)
        self.assertGreater(collisions, 0, 'no collision of the hand with the post under load')
        deferred = m.diag_value('pose messages deferred during a check (total)')
        self.assertGreater(int(deferred or 0), 0, 'no pose message came during a check')

    def assert_logs_here(self, pid):
        """Process `pid` sends TSan's reports to the log check_no_log() reads (else to its
        stderr, unread)."""
        with open('/proc/%d/environ' % pid, 'rb') as f:
            env = dict(v.split(b'=', 1) for v in f.read().split(b'\0') if b'=' in v)
        options = env.get(b'TSAN_OPTIONS', b'').decode().split()
        self.assertIn('log_path=' + self.log_prefix, options)

    def check_no_log(self, pid):
        """TSan's log of process `pid`: none, since TSan writes one only to report (a race, a
        lock order inversion, a thread leak, an error of its own)."""
        logs = glob.glob('%s.%d' % (self.log_prefix, pid))
        reports = []
        for path in logs:
            with open(path, errors='replace') as f:
                text = f.read()
            reports += tsan_reports(text)
            print('[tsan] %s:\n%s' % (path, text[:40000]), flush=True)
        figure('TSan logs %s: %d reports %s' % (logs, len(reports), reports))
        self.assertEqual(logs, [])

    def test_2_load_then_sigint(self):
        load = self.start_load(self.m)
        time.sleep(LOAD_SECONDS)
        self.assertTrue(alive(self.pid), 'the node died under load')
        t_exit = self.stop_process(self.pid, 'the node', [load])  # every input still coming
        load.join()
        self.check_load(load, 'node: %.0f s of load, then SIGINT -> exit %.2f s'
                        % (LOAD_SECONDS, t_exit))
        self.check_no_log(self.pid)

    def test_3_nodelet_unloaded_and_loaded_again_under_load(self):
        """Two monitors as nodelets in Debian's manager (libtsan preloaded), each under a load of
        its own (/joint_states from cm_nodelet_b's): cm_nodelet unloaded while every input comes
        (~Monitor with the manager and cm_nodelet_b running on), loaded again, then the manager
        stopped by SIGINT under both loads. Two monitors in one process: state shared between
        them (a static) would race."""
        manager = node_pid('/tsan_manager')
        loader = node_pid('/cm_nodelet')
        self.assertTrue(manager and loader and node_pid('/cm_nodelet_b'),
                        'no pid for the manager or a nodelet loader')
        libs = [f for f in mapped_files(manager) if 'libcollision_monitor_ros' in f]
        self.assertTrue(any('libtsan' in f for f in mapped_files(manager)))
        self.assertTrue(libs and all(instrumented(f) for f in libs), libs)
        self.assert_logs_here(manager)
        load_b = self.start_load(Monitor('/cm_nodelet_b/'))
        load = self.start_load(Monitor('/cm_nodelet/'), joints=False)
        time.sleep(NODELET_LOAD_SECONDS)
        t_unload = self.stop_process(loader, 'nodelet load', [load])  # it unloads the nodelet
        self.assertTrue(wait_for(lambda: '/cm_nodelet/get_distance' not in
                                 rosservice.get_service_list(), 30.0, 0.1), 'not unloaded')
        time.sleep(1.0)  # the inputs keep coming to the manager with no monitor of theirs
        load.join()
        self.check_load(load, 'nodelet: %.0f s of load, then unloaded (loader exit %.2f s)'
                        % (NODELET_LOAD_SECONDS, t_unload))
        reloader = subprocess.Popen(roslib.packages.find_node('nodelet', 'nodelet')[:1] + [
            'load', 'collision_monitor/CollisionMonitorNodelet', 'tsan_manager',
            '__name:=cm_nodelet'], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            load = self.start_load(Monitor('/cm_nodelet/'), joints=False)
            time.sleep(NODELET_LOAD_SECONDS)
            self.assertTrue(alive(manager), 'the manager died under load')
            t_exit = self.stop_process(manager, 'the manager', [load, load_b])
            load.join()
            load_b.join()
            self.check_load(load, 'nodelet loaded again: %.0f s of load, then SIGINT to the '
                            'manager -> exit %.2f s' % (NODELET_LOAD_SECONDS, t_exit))
            self.check_load(load_b, 'second nodelet: under load throughout, then SIGINT to the '
                            'manager')
        finally:
            reloader.terminate()
            reloader.wait(30.0)
        self.check_no_log(manager)

    @classmethod
    def tearDownClass(cls):
        save_figures('tsan.txt', FIGURES)


if __name__ == '__main__':
    rostest.rosrun('collision_monitor', 'tsan', Tsan, sys.argv)
