#!/usr/bin/python3
"""roscore restarting under a running collision_monitor_node (MasterWatch, src/nodes/
master_watch.h). Not a rostest: the test starts, stops and restarts masters itself, and each
client step is a process of its own (rospy does not register again with a new master either).
  1. Before: a client adds a ball (posed on ~body_poses, static) and a post (static TF), and reads
     their distance, 0.8 m.
  2. roscore stops; for 3 s the port takes connections and never answers (a master host gone
     without a reset: the watch's call hangs, 2 s at most), then a new roscore starts on it. A new
     client finds the node known to the new master, its world kept (both bodies, 0.8 m), its ~state heard and its
     ~bodies, ~body_poses and /tf subscriptions connected to publishers that started since: a dart
     added and posed by TF, the ball moved; distances exact.
  3. A second node of the same name starts: the first one exits (the name is the new one's), the
     second one answers with its own, empty world.
Without the watch, step 2 found no node: the new master knew none of its topics or services.
Without a deadline on the watch's calls, the hung call held the watch for good: no node in step 2
either, and the first node never exited in step 3.
Usage: test_master_restart.py NODE_EXECUTABLE [--gtest_output=xml:FILE]"""
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
NODE = sys.argv[1] if len(sys.argv) > 1 and not sys.argv[1].startswith('-') else None


def free_port():
    s = socket.socket()
    s.bind(('127.0.0.1', 0))
    port = s.getsockname()[1]
    s.close()
    return port


def client(step):
    """One client step, in a process of its own; raises (exit status 1) when a check fails."""
    sys.path.insert(0, os.path.join(HERE, '..', 'ros'))
    import rospy
    import tf2_ros
    from collision_monitor.msg import BodyPoses
    from cm_test_util import Monitor, pose, sphere_body, tf_transform, wait_for

    rospy.init_node('master_restart_client', anonymous=True)
    m = Monitor()  # the services, ~state and both subscriptions of the node (else it asserts)

    def put_ball(x):
        msg = BodyPoses(ids=['ball'], poses=[pose(x, 0.0, 0.0)])
        msg.header.frame_id = 'world'  # stamp 0: static
        m.poses_pub.publish(msg)

    def distance(a, b):
        r = m.get_distance(a, b, '')
        return r.result.distance if r.success else None

    def wait_distance(a, b, expected):
        got = wait_for(lambda: (lambda d: d is not None and abs(d - expected) <= 1e-9)(
            distance(a, b)), 5.0)
        assert got, '%s-%s: %s, expected %s' % (a, b, distance(a, b), expected)

    if step == 'before':
        static = tf2_ros.StaticTransformBroadcaster()
        static.sendTransform(tf_transform('post_frame', stamp=rospy.Time(0), xyz=(1.0, 0.0, 0.0)))
        m.add(sphere_body('ball', 0.1))
        m.add(sphere_body('post', 0.1, frame='post_frame', pose_from_topic=False))
        assert m.wait_listed('ball') and m.wait_listed('post'), m.ids()
        put_ball(0.0)
        wait_distance('ball', 'post', 0.8)
    elif step == 'after':
        assert m.ids() == ['ball', 'post'], m.ids()  # the world kept
        wait_distance('ball', 'post', 0.8)
        put_ball(0.5)  # ~body_poses from a publisher of the new master's time
        wait_distance('ball', 'post', 0.3)
        br = tf2_ros.TransformBroadcaster()
        m.add(sphere_body('dart', 0.1, frame='dart_frame', pose_from_topic=False))
        assert m.wait_listed('dart'), m.ids()
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline:  # /tf likewise
            br.sendTransform(tf_transform('dart_frame', xyz=(0.5, 2.0, 0.0)))
            d = distance('ball', 'dart')
            if d is not None and abs(d - 1.8) <= 1e-9:
                break
            time.sleep(0.05)
        assert d is not None and abs(d - 1.8) <= 1e-9, d
    elif step == 'second':
        assert m.ids() == [], m.ids()  # the new node's own world
    else:
        raise ValueError(step)


class MasterRestart(unittest.TestCase):
    def setUp(self):
        self.port = free_port()
        self.home = tempfile.mkdtemp(prefix='cm_master_restart_')
        self.env = dict(os.environ, ROS_MASTER_URI='http://127.0.0.1:%d' % self.port,
                        ROS_HOSTNAME='127.0.0.1', ROS_HOME=self.home)
        self.env.pop('ROS_IP', None)
        self.procs = []
        self.held = []  # connections taken by hold_port(), never answered

    def tearDown(self):
        for p in reversed(self.procs):
            if p.poll() is None:
                p.send_signal(2)
                try:
                    p.wait(10.0)
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait()
        for c in self.held:
            c.close()
        shutil.rmtree(self.home, ignore_errors=True)

    def start(self, args, log):
        p = subprocess.Popen(args, env=self.env, stdout=open(os.path.join(self.home, log), 'w'),
                             stderr=subprocess.STDOUT)
        self.procs.append(p)
        return p

    def start_master(self, log):
        master = self.start(['roscore', '-p', str(self.port)], log)
        deadline = time.monotonic() + 20.0
        while time.monotonic() < deadline:
            if subprocess.run(['rosnode', 'list'], env=self.env, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL).returncode == 0:
                return master
            time.sleep(0.2)
        self.fail('roscore did not start')

    def hold_port(self, seconds):
        """Takes connections on the port for `seconds` and answers none; they stay open."""
        listener = socket.socket()
        listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        listener.bind(('127.0.0.1', self.port))
        listener.listen(16)
        listener.settimeout(0.1)
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            try:
                self.held.append(listener.accept()[0])
            except socket.timeout:
                pass
        listener.close()

    def stop(self, p):
        p.send_signal(2)
        p.wait(20.0)

    def run_client(self, step, timeout=60.0):
        r = subprocess.run([sys.executable, __file__, '--client', step], env=self.env,
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=timeout)
        self.assertEqual(r.returncode, 0, '%s: %s' % (step, r.stdout.decode()[-3000:]))

    def log(self, name):
        with open(os.path.join(self.home, name)) as f:
            return f.read()

    def test_node_registers_again_with_a_new_master(self):
        self.assertIsNotNone(NODE, 'no node executable given')
        master = self.start_master('roscore1.log')
        node = self.start([NODE, '_fixed_frame:=world'], 'node.log')
        self.run_client('before')
        self.stop(master)
        self.hold_port(3.0)
        self.assertGreater(len(self.held), 0, 'the watch did not call while the port was held')
        self.start_master('roscore2.log')
        self.run_client('after')
        self.assertIsNone(node.poll(), self.log('node.log'))
        self.assertIn('did not know this node', self.log('node.log'))

        second = self.start([NODE, '_fixed_frame:=world'], 'node2.log')
        try:
            node.wait(10.0)
        except subprocess.TimeoutExpired:
            self.fail('the first node runs on beside the second: ' + self.log('node.log'))
        self.assertEqual(node.returncode, 0, self.log('node.log'))
        self.run_client('second')
        self.assertIsNone(second.poll(), self.log('node2.log'))


if __name__ == '__main__':
    if sys.argv[1:2] == ['--client']:
        client(sys.argv[2])
    else:
        import rosunit
        sys.argv = [sys.argv[0]] + sys.argv[2:]
        rosunit.unitrun('collision_monitor', 'master_restart', MasterRestart, sysargs=sys.argv)
