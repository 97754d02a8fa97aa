#!/usr/bin/python3
"""rostest: two monitors in one nodelet manager of one worker thread (manager.test)."""
import sys
import threading
import time
import unittest

import rospy
import rostest
from collision_monitor.msg import Body, BodyPoses, Shape
from collision_monitor.srv import ListBodies

from cm_test_util import Monitor, pose, shape, wait_for


def heavy_body(body_id):
    """1,000 boxes of 0.2 m, 1 mm apart: two such bodies 5 cm apart overlap in every part pair,
    and a check of three queries them all (about a million EPA queries)."""
    b = Body(id=body_id, operation=Body.ADD, pose_from_topic=True)
    for i in range(1000):
        s = shape(Shape.BOX, (0.2, 0.2, 0.2))
        s.pose = pose(0.001 * (i % 10), 0.001 * (i // 10 % 10), 0.001 * (i // 100))
        b.parts.append(s)
    return b


class Manager(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_manager')
        cls.heavy = Monitor('/heavy/')
        rospy.wait_for_service('/light/list_bodies', timeout=30.0)
        cls.light_list = rospy.ServiceProxy('/light/list_bodies', ListBodies)

    def light_ids(self):
        return sorted(self.light_list().ids)

    def test_1_remapped_bodies_topic_keeps_its_parameter(self):
        self.assertEqual(self.light_ids(), ['yaml_box'])  # not the decoy at /obstacles
        pub = rospy.Publisher('/obstacles', Body, queue_size=10, latch=True)
        b = Body(id='from_topic', operation=Body.ADD, pose_from_topic=True)
        b.parts = [shape(Shape.SPHERE, (0.5,))]
        pub.publish(b)
        self.assertTrue(wait_for(lambda: self.light_ids() == ['from_topic', 'yaml_box'], 10.0),
                        self.light_ids())

    def test_2_a_monitor_in_long_checks_holds_no_worker_of_the_manager(self):
        ids = ['h%d' % i for i in range(3)]
        for i in ids:
            self.heavy.add(heavy_body(i))
        self.assertTrue(wait_for(lambda: self.heavy.ids() == ids, 30.0), self.heavy.ids())
        stop = threading.Event()

        def stream():  # a robot's pose feed: every message waits for the check in progress
            k = 0
            while not stop.is_set() and not rospy.is_shutdown():
                x = 1e-4 * (k % 7)
                msg = BodyPoses(ids=ids, poses=[pose(x, 0, 0), pose(x + 0.05, 0, 0),
                                                pose(x, 0.05, 0)])
                msg.header.frame_id = 'world'
                msg.header.stamp = rospy.Time.now()
                self.heavy.poses_pub.publish(msg)
                k += 1
                time.sleep(0.05)

        feeder = threading.Thread(target=stream)
        feeder.start()
        try:
            # Checks of a second or more, else this test shows nothing.
            slow = wait_for(lambda: self.heavy.state is not None and
                            self.heavy.state.num_bodies == 3 and
                            self.heavy.state.compute_time >= 0.5, 60.0)
            self.assertTrue(slow, 'heavy checks take %s s' % (
                self.heavy.state.compute_time if self.heavy.state else None))
            latencies = []
            start = time.monotonic()
            while time.monotonic() - start < 6.0:
                t0 = time.monotonic()
                self.light_list()
                latencies.append(time.monotonic() - t0)
                time.sleep(0.05)
            check = self.heavy.state.compute_time
        finally:
            stop.set()
            feeder.join()
        print('manager: heavy checks %.2f s; light list_bodies: %d calls, max %.3f s' % (
            check, len(latencies), max(latencies)), flush=True)
        # It waited for heavy's checks (the manager's one worker held by heavy's pose callback).
        self.assertLess(max(latencies), 0.5)
        for i in ids:
            self.heavy.add(Body(id=i, operation=Body.REMOVE))


if __name__ == '__main__':
    rostest.rosrun('collision_monitor', 'manager_test', Manager, sys.argv)
