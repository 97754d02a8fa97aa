#!/usr/bin/python3
"""rostest: /diagnostics WARNs "overloaded" while the mean check takes longer than the period of
~rate, and goes back to OK once it does not (overload.test)."""
import sys
import unittest

import rospy
import rostest
from collision_monitor.msg import Body, BodyPoses
from diagnostic_msgs.msg import DiagnosticStatus

import robust_util  # noqa: F401 (puts test/ros on the path)
from cm_test_util import Monitor, pose, sphere_body, wait_for


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

    def test_1_overloaded_then_not(self):
        n = 60
        for i in range(n):
            self.m.add(sphere_body('s%d' % i, 0.1))
        self.assertTrue(wait_for(lambda: len(self.m.list_bodies().ids) == n, 10.0))
        self.place(n)
        d = self.report(DiagnosticStatus.WARN, 'overloaded: a check takes')
        self.assertIsNotNone(d, self.m.diagnostics)
        self.assertIn('0.05 ms period of rate 20000 Hz', d.message)
        mean_ms = float(self.m.diag_value("mean cycle time (ms)"))
        print("overloaded: %s" % d.message)
        self.assertGreater(mean_ms, 0.05)
        self.assertIsNotNone(self.m.diag_value('pairs checked (mean per check since last report)'))
        for i in range(2, n):
            self.m.add(Body(id='s%d' % i, operation=Body.REMOVE))
        self.assertTrue(wait_for(lambda: len(self.m.list_bodies().ids) == 2, 10.0))
        d = self.report(DiagnosticStatus.OK, 'ok')
        self.assertIsNotNone(d, self.m.diagnostics)
        print("recovered: mean cycle time %s ms" % self.m.diag_value("mean cycle time (ms)"))
        self.assertLess(float(self.m.diag_value("mean cycle time (ms)")), 0.05)


if __name__ == '__main__':
    rostest.rosrun('collision_monitor', 'overload', Overload, sys.argv)
