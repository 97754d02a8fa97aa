#!/usr/bin/python3
"""rostest: launch/collision_monitor.launch run by roslaunch (a real process) against a master
that still holds the parameters of an earlier launch, with boolean arguments given as 0 and
False; and with the shipped config/example_bodies.yaml."""
import contextlib
import os
import signal
import subprocess
import sys
import unittest

import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticStatus
from visualization_msgs.msg import MarkerArray

from cm_test_util import Monitor, wait_for

PKG = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..')
LAUNCH = os.path.join(PKG, 'launch', 'collision_monitor.launch')
EXAMPLE = os.path.join(PKG, 'config', 'example_bodies.yaml')
NAME = '/cm_launched/'


@contextlib.contextmanager
def roslaunch(*args, launch_file=LAUNCH):
    """`launch_file` (collision_monitor.launch) with `args`, run by roslaunch until the block
    ends; it must exit 0 on SIGINT. Its output is printed at the end."""
    name = next((a.split(':=')[1] for a in args if a.startswith('node_name:=')),
                os.path.splitext(os.path.basename(launch_file))[0])
    log = open(os.path.join(os.environ.get('ROS_HOME', '/tmp'), name + '_roslaunch.log'), 'w+')
    launch = subprocess.Popen(['roslaunch', launch_file] + list(args), stdout=log,
                              stderr=subprocess.STDOUT, start_new_session=True)
    try:
        yield launch
    finally:
        os.killpg(launch.pid, signal.SIGINT)
        try:
            launch.wait(timeout=30.0)
        except subprocess.TimeoutExpired:
            os.killpg(launch.pid, signal.SIGKILL)
            launch.wait()
        log.seek(0)
        print(log.read()[-3000:], flush=True)
        log.close()
    if launch.returncode != 0:
        raise AssertionError('roslaunch exited %d' % launch.returncode)


class LaunchFile(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_launch_file')

    def test_relaunch_with_defaults_and_boolean_arguments(self):
        # Left by an earlier launch with fixed_frame:=old_frame and a bodies_file. Bug: the
        # launch file sets neither when left at their defaults, so they stayed in force: the
        # monitor ran in old_frame (every robot link UNKNOWN) with the old bodies.
        rospy.set_param(NAME + 'fixed_frame', 'old_frame')
        rospy.set_param(NAME + 'bodies', [{'id': 'old_crate', 'frame_id': 'world',
                                           'parts': [{'type': 'box', 'dimensions': [1, 1, 1]}]}])
        # Bug: roslaunch passed 0 on as the integer 0 (the <param>s had no type="bool"); the
        # node refused it and kept its default (true). False was converted already.
        with roslaunch('node_name:=cm_launched', 'publish_markers:=0', 'check_on_tf:=False',
                       'exact_min_distance:=0', 'rate:=20'):
            m = Monitor(NAME)
            self.assertEqual(m.state.header.frame_id, 'world')  # no URDF here: world
            self.assertEqual(m.ids(), [])
            self.assertIs(rospy.get_param(NAME + 'publish_markers'), False)
            self.assertIs(rospy.get_param(NAME + 'check_on_tf'), False)
            self.assertIs(rospy.get_param(NAME + 'exact_min_distance'), False)
            self.assertIs(rospy.get_param(NAME + 'check_on_pose'), True)
            self.assertTrue(wait_for(lambda: m.diagnostics is not None, 10.0))
            d = m.diagnostics
            self.assertNotEqual(d.level, DiagnosticStatus.ERROR, d.message)
            self.assertEqual([kv.value for kv in d.values if kv.key == 'invalid parameter'], [])
            # publish_markers false: no arrays, although someone listens.
            got = []
            sub = rospy.Subscriber(NAME + 'markers', MarkerArray, got.append)
            try:
                self.assertTrue(wait_for(lambda: sub.get_num_connections() > 0, 5.0))
                rospy.sleep(1.0)
                self.assertEqual(got, [])
            finally:
                sub.unregister()

    def test_contact_distance_alone_raises_the_warning_distance(self):
        # Bug: the launch file always set warning_distance (0.05), so contact_distance:=0.1
        # alone was an invalid warning_distance, /diagnostics ERROR for the whole run, where the
        # node started without the launch file raises it without an error (docs/node.md).
        for args, warning in ((['contact_distance:=0.1'], 0.1),
                              (['contact_distance:=0.1', 'warning_distance:=0.2'], 0.2)):
            with roslaunch('node_name:=cm_contact', *args):
                m = Monitor('/cm_contact/')
                self.assertTrue(wait_for(lambda: m.diagnostics is not None, 10.0))
                d = m.diagnostics
                self.assertEqual([kv.value for kv in d.values if kv.key == 'invalid parameter'],
                                 [], args)
                self.assertEqual(d.level, DiagnosticStatus.OK, d.message)
                # The values in force, as dynamic_reconfigure writes them back.
                self.assertEqual(rospy.get_param('/cm_contact/warning_distance'), warning, args)
                self.assertEqual(m.diag_value('warning_distance'), str(warning), args)

    def test_shipped_example_bodies_file(self):
        # config/example_bodies.yaml, as README and the launch file point users to it: every
        # body, pair and parameter in it is valid.
        with roslaunch('node_name:=cm_example', 'bodies_file:=' + EXAMPLE):
            m = Monitor('/cm_example/')
            self.assertTrue(wait_for(lambda: m.diagnostics is not None, 10.0))
            d = m.diagnostics
            self.assertEqual([kv.value for kv in d.values if kv.key in (
                'invalid parameter', 'parameter body left out')], [])
            self.assertEqual(m.ids(), ['crate', 'table', 'table_leg', 'wand'])
            r = m.get_distance('table', 'table_leg', '')
            self.assertFalse(r.success)
            self.assertIn('the pair is disabled (disabled_pairs parameter)', r.message)

    def test_demo_after_the_panda_demo_on_one_master(self):
        # What launch/panda_demo.launch leaves on a master that stays up: demo_joint_motion's
        # ~scene and the Panda's SRDF. Bug: demo.launch set neither, so its demo_joint_motion
        # moved the Panda's joints (robot_state_publisher: "not found in URDF"), the demo arm's
        # moving links had no TF (UNKNOWN for the whole run) and its monitor read the Panda's
        # SRDF as the demo arm's.
        srdf = os.path.join(os.environ.get('CM_ROBOT_DATA') or os.path.join(PKG, '../shared/data'),
                            'example-robot-data/robots/panda_description/srdf/panda.srdf')
        rospy.set_param('/demo_joint_motion/scene', 'panda_demo_scene')
        with open(srdf) as f:
            rospy.set_param('/robot_description_semantic', f.read())
        arm = {'turret_link', 'upper_arm_link', 'forearm_link', 'wrist_link', 'hand_link',
               'gripper_link'}
        try:
            with roslaunch('duration:=0', 'monitor_output:=log',
                           launch_file=os.path.join(PKG, 'launch', 'demo.launch')):
                m = Monitor('/collision_monitor/')
                self.assertTrue(arm <= set(m.ids()), m.ids())
                self.assertTrue(wait_for(lambda: not arm & set(m.state.stale_bodies), 15.0),
                                m.state.stale_bodies)
                self.assertFalse(rospy.has_param('/demo_joint_motion/scene'))
                self.assertEqual(rospy.get_param('/robot_description_semantic'), '')
        finally:  # the other tests' monitors have no robot
            for p in ('/robot_description', '/robot_description_semantic'):
                if rospy.has_param(p):
                    rospy.delete_param(p)

    def test_every_shipped_launch_file_documents_its_arguments(self):
        # roslaunch --ros-args lists an argument whose default is empty as required; none of the
        # shipped launch files needs one, so such an argument's doc says it is optional. Every
        # argument has a doc.
        files = sorted(os.listdir(os.path.join(PKG, 'launch')))
        self.assertIn('collision_monitor.launch', files)
        for name in files:
            out = subprocess.run(['roslaunch', '--ros-args', os.path.join(PKG, 'launch', name)],
                                 stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                 timeout=60, check=True).stdout
            self.assertNotIn('undocumented', out, name)
            section = None
            for line in out.splitlines():
                if line.endswith('Arguments:'):
                    section = line
                elif section == 'Required Arguments:' and line.startswith('  '):
                    doc = line.strip().partition(': ')[2]
                    self.assertTrue(doc.startswith('optional'), '%s: %s' % (name, line))
            self.assertIsNotNone(section, name + ': no arguments listed\n' + out)


if __name__ == '__main__':
    rostest.rosrun('collision_monitor', 'launch_file', LaunchFile, sys.argv)
