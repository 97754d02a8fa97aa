#!/usr/bin/python3
"""rostest: launch/collision_monitor.launch run by roslaunch (a real process) against a master
that still holds the parameters of an earlier launch, with boolean arguments given as 0 and
False."""
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

LAUNCH = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'launch',
                      'collision_monitor.launch')
NAME = '/cm_launched/'


class LaunchFile(unittest.TestCase):
    def test_relaunch_with_defaults_and_boolean_arguments(self):
        rospy.init_node('test_launch_file')
        # Left by an earlier launch with fixed_frame:=old_frame and a bodies_file. Bug: the
        # launch file sets neither when left at their defaults, so they stayed in force: the
        # monitor ran in old_frame (every robot link UNKNOWN) with the old bodies.
        rospy.set_param(NAME + 'fixed_frame', 'old_frame')
        rospy.set_param(NAME + 'bodies', [{'id': 'old_crate', 'frame_id': 'world',
                                           'parts': [{'type': 'box', 'dimensions': [1, 1, 1]}]}])
        # Bug: roslaunch passed 0 on as the integer 0 (the <param>s had no type="bool"); the
        # node refused it and kept its default (true). False was converted already.
        log = open(os.path.join(os.environ.get('ROS_HOME', '/tmp'), 'launch_file_roslaunch.log'),
                   'w+')
        launch = subprocess.Popen(
            ['roslaunch', LAUNCH, 'node_name:=cm_launched', 'publish_markers:=0',
             'check_on_tf:=False', 'exact_min_distance:=0', 'rate:=20'],
            stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        try:
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
        self.assertEqual(launch.returncode, 0)


if __name__ == '__main__':
    rostest.rosrun('collision_monitor', 'launch_file', LaunchFile, sys.argv)
