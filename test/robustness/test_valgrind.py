#!/usr/bin/python3
"""rostest: the node under valgrind memcheck (valgrind.test). Exercises the node's paths once --
URDF/SRDF robot posed by TF (moving joints), a YAML body, ~bodies (sphere, mesh hull from a
package:// STL, pose_topic body, replace, remove), ~body_poses (in the hand frame: a collision,
then clear), every service (valid and invalid requests, another frame), invalid and malformed
messages, ~markers -- then stops the node with SIGINT and reads valgrind's log: 0 errors, 0 bytes
definitely lost, 0 bytes indirectly lost, and the leak check must have run (a clean exit).
Figures go to stdout and to $CM_ARTIFACTS/valgrind.txt when set."""
import math
import os
import re
import signal
import subprocess
import sys
import threading
import time
import unittest

import rospy
import rostest
from collision_monitor.msg import Body, BodyPoses, CollisionEvent, Shape
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import JointState
from visualization_msgs.msg import MarkerArray

from robust_util import alive, body_bytes, node_pid, raw_class, save_figures, shape_bytes
from cm_test_util import Monitor, panda_joint_state, pose, shape, sphere_body, wait_for

E = CollisionEvent
FIGURES = []


def figure(line):
    FIGURES.append(line)
    print('[valgrind] ' + line, flush=True)


def joint_states():
    """Publishes the ready configuration with panda_joint1 swinging slowly (the links move: TF every cycle)."""
    pub = rospy.Publisher('/joint_states', JointState, queue_size=10)
    t0 = time.monotonic()
    while not rospy.is_shutdown():
        try:
            pub.publish(panda_joint_state(panda_joint1=0.3 * math.sin(time.monotonic() - t0)))
        except rospy.ROSException:
            return
        time.sleep(0.05)


def dump_threads(pid):
    """Where a hung node sits: each thread's state and kernel wait channel, then the guest stacks
    through valgrind's gdbserver (vgdb), for the CI log."""
    try:
        tasks = sorted(os.listdir('/proc/%d/task' % pid), key=int)
    except OSError:
        tasks = []
    for task in tasks:
        try:
            with open('/proc/%d/task/%s/stat' % (pid, task)) as f:
                stat = f.read().split()
            with open('/proc/%d/task/%s/wchan' % (pid, task)) as f:
                wchan = f.read()
            with open('/proc/%d/task/%s/syscall' % (pid, task)) as f:
                sc = f.read().strip()
        except OSError as e:
            stat, wchan, sc = ['?'] * 3, str(e), ''
        print('[valgrind] task %s %s state %s utime %s ticks, wchan %s, syscall %s'
              % (task, stat[1], stat[2], stat[13] if len(stat) > 13 else '?', wchan, sc),
              flush=True)
    try:
        with open('/proc/%d/cmdline' % pid, 'rb') as f:
            exe = [a.decode() for a in f.read().split(b'\0')
                   if a.endswith(b'collision_monitor_node')]
        out = subprocess.run(['gdb', '-batch', '-nx'] + exe[:1] +
                             ['-ex', 'target remote | vgdb --pid=%d' % pid, '-ex', 'info threads',
                              '-ex', 'thread apply all bt 30'],
                             capture_output=True, text=True, timeout=120)
        print(out.stdout[-30000:], out.stderr[-3000:], flush=True)
    except (OSError, subprocess.SubprocessError) as e:
        print('[valgrind] gdb/vgdb: %s' % e, flush=True)


def memcheck_summary(text):
    """Errors and definitely / indirectly lost bytes from a memcheck log; None where absent."""
    def number(pattern):
        m = re.search(pattern, text)
        return int(m.group(1).replace(',', '')) if m else None
    out = {'errors': number(r'ERROR SUMMARY: ([\d,]+) errors'),
           'definitely': number(r'definitely lost: ([\d,]+) bytes'),
           'indirectly': number(r'indirectly lost: ([\d,]+) bytes'),
           'suppressed': number(r'ERROR SUMMARY: [\d,]+ errors from [\d,]+ contexts '
                                r'\(suppressed: ([\d,]+) from')}
    if 'All heap blocks were freed -- no leaks are possible' in text:
        out['definitely'] = out['indirectly'] = 0
    out['leak_check_ran'] = 'LEAK SUMMARY' in text or 'All heap blocks were freed' in text
    return out


class Valgrind(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.t_start = time.monotonic()
        rospy.init_node('test_valgrind')
        threading.Thread(target=joint_states, daemon=True).start()
        cls.m = Monitor()  # waits up to 30 s for the services (valgrind starts slowly)
        cls.pid = node_pid()
        assert cls.pid, 'no pid for /collision_monitor'
        cls.log = os.path.join(rospy.get_param('/valgrind_log_dir'),
                               'collision_monitor_memcheck.%d.log' % cls.pid)
        figure('node up under valgrind after %.1f s (pid %d, log %s)'
               % (time.monotonic() - cls.t_start, cls.pid, cls.log))

    def wait_distance(self, a, b, timeout=20.0):
        return wait_for(lambda: (lambda r: r if r.success else None)(
            self.m.get_distance(a, b, '')), timeout, 0.1)

    def test_1_exercise(self):
        m = self.m
        self.assertTrue(os.path.exists(self.log), 'no valgrind log at ' + self.log)
        # The robot is posed by TF: its links answer.
        self.assertIsNotNone(self.wait_distance('panda_hand', 'table'), 'the robot never posed')
        # ~bodies: a TF-attached sphere, a mesh hull, a pose_topic body, a ~body_poses body.
        m.add(sphere_body('ball', 0.05, frame='panda_link0', pose_from_topic=False))
        mesh = Body(id='gripper_mesh', operation=Body.ADD, pose_from_topic=True)
        mesh.parts = [shape(Shape.MESH, resource='package://collision_monitor/meshes/gripper.stl')]
        m.add(mesh)
        m.add(sphere_body('tracked', 0.05, pose_topic='/valgrind/tracked_pose'))
        m.add(sphere_body('post', 0.03))
        for b in ('ball', 'gripper_mesh', 'tracked', 'post'):
            self.assertTrue(m.wait_listed(b, timeout=20.0), b)
        tracked = rospy.Publisher('/valgrind/tracked_pose', PoseStamped, queue_size=10)
        self.assertTrue(wait_for(lambda: tracked.get_num_connections() > 0, 20.0))
        # 'post' in the hand frame (resolved through TF): a collision with the hand, then away.
        t0 = time.monotonic()
        for k in range(40):
            msg = BodyPoses(ids=['post', 'gripper_mesh'], poses=[pose(), pose(x=-1.0)])
            msg.header.frame_id = 'panda_hand'
            msg.header.stamp = rospy.Time.now()
            m.poses_pub.publish(msg)
            p = PoseStamped(pose=pose(x=1.0, y=1.0))
            p.header.frame_id = 'panda_link0'
            p.header.stamp = rospy.Time.now()
            tracked.publish(p)
            if m.wait_event(E.COLLISION_BEGIN, 'panda_hand', 'post', timeout=0.25, since=t0):
                break
        ev = m.wait_event(E.COLLISION_BEGIN, 'panda_hand', 'post', timeout=10.0, since=t0)
        self.assertIsNotNone(ev, 'no collision of the hand with the post')
        figure('hand-post COLLISION_BEGIN %.1f s after the first pose' % (ev[0] - t0))
        t1 = time.monotonic()
        msg = BodyPoses(ids=['post'], poses=[pose(x=2.0)])
        msg.header.frame_id = 'panda_link0'
        msg.header.stamp = rospy.Time.now()
        m.poses_pub.publish(msg)
        self.assertIsNotNone(m.wait_event(E.COLLISION_END, 'panda_hand', 'post', timeout=20.0,
                                          since=t1))
        # Markers while subscribed.
        markers = []
        sub = rospy.Subscriber('/collision_monitor/markers', MarkerArray, markers.append,
                               queue_size=10)
        self.assertTrue(wait_for(lambda: markers, 20.0), 'no ~markers')
        sub.unregister()
        # Services: valid and invalid requests.
        self.assertTrue(m.get_distance('panda_hand', 'table', 'panda_hand').success)
        # The nearest body to the mesh: every body it may collide with must have a fresh pose
        # (pose_timeout 2 s; node.md, ~get_distance), and the waits above can take longer than
        # that under valgrind (a CI run: post and tracked stale, the query refused for 20 s).
        def mesh_posed_and_answered():
            msg = BodyPoses(ids=['gripper_mesh', 'post'], poses=[pose(x=-1.0), pose(x=2.0)])
            msg.header.frame_id = 'panda_link0'
            msg.header.stamp = rospy.Time.now()
            m.poses_pub.publish(msg)
            p = PoseStamped(pose=pose(x=1.0, y=1.0))
            p.header.frame_id = 'panda_link0'
            p.header.stamp = rospy.Time.now()
            tracked.publish(p)
            return m.get_distance('gripper_mesh', '', '').success
        self.assertTrue(wait_for(mesh_posed_and_answered, 20.0, 0.2))
        self.assertFalse(m.get_distance('nobody', 'table', '').success)
        self.assertFalse(m.get_distance('panda_link0', 'panda_link1', '').success)  # adjacent
        self.assertFalse(m.get_distance('panda_hand', 'table', 'no_such_frame').success)
        probe = Body(id='probe', operation=Body.ADD)
        probe.header.frame_id = 'panda_hand'
        probe.parts = [shape(Shape.BOX, [0.1, 0.1, 0.1])]
        r = m.check_collision(probe, pose(), 0.5)
        self.assertTrue(r.success, r.message)
        self.assertTrue(r.in_collision)
        probe.parts = [shape(Shape.SPHERE, [float('nan')])]
        self.assertFalse(m.check_collision(probe, pose(), 0.5).success)
        self.assertIn('gripper_mesh', m.list_bodies().ids)
        # Invalid and malformed input, a mesh outside mesh_roots.
        bad = sphere_body('bad', float('inf'))
        m.add(bad)
        outside = Body(id='outside', operation=Body.ADD, pose_from_topic=True)
        outside.parts = [shape(Shape.MESH, resource='file:///etc/passwd')]
        m.add(outside)
        raw = rospy.Publisher('/collision_monitor/bodies', raw_class(Body), queue_size=10)
        self.assertTrue(wait_for(lambda: raw.get_num_connections() > 0, 20.0))
        raw.publish(raw_class(Body)(body_bytes('raw', 'world', [
            shape_bytes(Shape.SPHERE, [0.1], claimed_dims=1 << 31)])))
        bad_poses = BodyPoses(ids=['post', 'post'], poses=[pose(), pose()])
        bad_poses.header.frame_id = 'panda_link0'
        m.poses_pub.publish(bad_poses)
        # Replace (another pose topic: unsubscribe + subscribe) and remove.
        m.add(sphere_body('tracked', 0.08, pose_topic='/valgrind/other_pose'))
        self.assertTrue(wait_for(lambda: tracked.get_num_connections() == 0, 20.0))
        m.add(Body(id='ball', operation=Body.REMOVE))
        self.assertTrue(m.wait_listed('ball', present=False, timeout=20.0))
        rejected = wait_for(lambda: int(m.diag_value('rejected inputs (total)') or 0) >= 4, 20.0)
        self.assertTrue(rejected, 'rejections not counted')
        figure('exercised in %.1f s; %s rejections counted'
               % (time.monotonic() - t0, m.diag_value('rejected inputs (total)')))

    def test_2_clean_exit_and_memcheck(self):
        self.assertTrue(alive(self.pid), 'the node died under valgrind')
        t0 = time.monotonic()
        os.kill(self.pid, signal.SIGINT)
        exited = wait_for(lambda: not alive(self.pid), 90.0, 0.2)
        t_exit = time.monotonic() - t0
        if not exited:
            dump_threads(self.pid)
        self.assertTrue(exited, 'the node did not exit within 90 s of SIGINT')
        with open(self.log, errors='replace') as f:
            text = f.read()
        s = memcheck_summary(text)
        figure('SIGINT -> exit %.1f s; whole run %.1f s; memcheck: %s errors (%s suppressed), '
               'definitely lost %s B, indirectly lost %s B, leak check ran: %s'
               % (t_exit, time.monotonic() - self.t_start, s['errors'], s['suppressed'],
                  s['definitely'], s['indirectly'], s['leak_check_ran']))
        if s['errors'] or s['definitely'] or s['indirectly']:
            print(text[-20000:], flush=True)  # the reports, for the CI log
        self.assertTrue(s['leak_check_ran'], 'no leak summary: the node did not exit cleanly')
        self.assertEqual(s['errors'], 0)
        self.assertEqual(s['definitely'], 0)
        self.assertEqual(s['indirectly'], 0)

    @classmethod
    def tearDownClass(cls):
        save_figures('valgrind.txt', FIGURES)


if __name__ == '__main__':
    rostest.rosrun('collision_monitor', 'valgrind', Valgrind, sys.argv)
