#!/usr/bin/python3
"""rostest: the PR2 URDF with STL collision meshes loads (one body per link with collision)."""
import sys
import unittest

import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticStatus

from cm_test_util import Monitor, wait_for

PR2_LINKS_WITH_COLLISION = 32


class Pr2(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_pr2')
        cls.m = Monitor()

    def test_01_every_link_with_collision_is_a_body(self):
        r = self.m.list_bodies()
        self.assertEqual(len(r.ids), PR2_LINKS_WITH_COLLISION, r.ids)
        self.assertIn('base_link', r.ids)
        self.assertIn('r_gripper_l_finger_tip_link', r.ids)
        self.assertEqual(list(r.frames), list(r.ids))   # attached to the link frames
        self.assertTrue(all(r.stale))                   # no TF published in this test
        self.assertEqual(self.m.state.header.frame_id, 'base_footprint')  # URDF root link
        self.assertEqual(self.m.state.num_bodies, PR2_LINKS_WITH_COLLISION)

    def test_02_no_tf_means_unknown_not_clear(self):
        r = self.m.get_distance('base_link', 'head_tilt_link', '')
        self.assertFalse(r.success)
        self.assertTrue('base_link' in r.message or 'head_tilt_link' in r.message, r.message)
        self.assertFalse(self.m.state.in_collision)
        self.assertGreater(len(self.m.state.stale_bodies), 0)

    def test_03_meshes_loaded_without_rejections(self):
        self.assertTrue(wait_for(lambda: self.m.diag_value('rejected inputs (total)'), 5.0, 0.1))
        self.assertEqual(self.m.diag_value('rejected inputs (total)'), '0',
                         self.m.diag_value('last rejection'))

    def test_04_invalid_backend_falls_back_to_gjk(self):
        self.assertTrue(wait_for(lambda: self.m.diag_value('backend'), 5.0, 0.1))
        self.assertEqual(self.m.diag_value('backend'), 'gjk')
        self.assertEqual(self.m.diagnostics.level, DiagnosticStatus.ERROR)
        self.assertIn('backend', self.m.diagnostics.message)


if __name__ == '__main__':
    rostest.rosrun('collision_monitor', 'pr2', Pr2, sys.argv)
