#!/usr/bin/python3
"""rostest: the demo scene (launch/demo.launch) produces its designed events.

Within ~timeout seconds: WARNING_BEGIN on base_link/topic_sphere (posed by its PoseStamped
topic), COLLISION_BEGIN then COLLISION_END on gripper_link/tf_box (a mesh hull against a box
posed by TF); the warning pair never collides (its clearance stays >= 20 mm); ~state arrives; the
markers show a red body and a witness segment during a collision, and the crate's removal
deletes its markers (no ghosts).
"""
import math
import os
import sys
import threading
import time
import unittest

import rospy
import rostest

from collision_monitor.msg import CollisionEvent, CollisionState
from visualization_msgs.msg import Marker, MarkerArray

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..",
                                "scripts"))
import demo_scene  # noqa: E402

PKG = "collision_monitor"


def key(a, b):
    return tuple(sorted((a, b)))


class DemoEvents(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("demo_events_test")
        cls.lock = threading.Lock()
        cls.events = []  # (wall time, type, pair key, distance)
        cls.states = 0
        cls.red_bodies = 0
        cls.witness = 0
        cls.body_deletes = 0
        cls.timeout = rospy.get_param("~timeout", 40.0)
        rospy.Subscriber("/collision_monitor/events", CollisionEvent, cls.on_event,
                         queue_size=1000)
        rospy.Subscriber("/collision_monitor/state", CollisionState, cls.on_state,
                         queue_size=100)
        rospy.Subscriber("/collision_monitor/markers", MarkerArray, cls.on_markers,
                         queue_size=100)

    @classmethod
    def on_event(cls, ev):
        with cls.lock:
            cls.events.append((time.time(), ev.type, key(ev.pair.body_a, ev.pair.body_b),
                               ev.pair.distance, ev.header.frame_id))

    @classmethod
    def on_state(cls, st):
        with cls.lock:
            cls.states += 1

    @classmethod
    def on_markers(cls, msg):
        with cls.lock:
            for m in msg.markers:
                if m.ns == "bodies" and m.action == Marker.ADD and m.color.r > 0.8 and \
                        m.color.g < 0.2:
                    cls.red_bodies += 1
                if m.ns == "witness" and m.action == Marker.ADD:
                    cls.witness += 1
                if m.ns == "bodies" and m.action == Marker.DELETE:
                    cls.body_deletes += 1

    def wait_for(self, predicate, what):
        deadline = time.time() + self.timeout
        while time.time() < deadline and not rospy.is_shutdown():
            with self.lock:
                if predicate():
                    return
            time.sleep(0.1)
        with self.lock:
            seen = ["%s %s %.1f mm" % (t, p, 1000 * d) for (_, t, p, d, _) in self.events]
        self.fail("%s not seen within %.0f s; events: %s" % (what, self.timeout, seen[:40]))

    def has(self, etype, pair, after=0.0):
        return any(t == etype and p == key(*pair) and w >= after
                   for (w, t, p, _, _) in self.events)

    def test_1_state_arrives(self):
        self.wait_for(lambda: self.states > 10, "~state")

    def test_2_warning_begin(self):
        self.wait_for(lambda: self.has(CollisionEvent.WARNING_BEGIN, demo_scene.WARNING_PAIR),
                      "WARNING_BEGIN %s" % (demo_scene.WARNING_PAIR,))
        with self.lock:
            d = [d for (_, t, p, d, _) in self.events
                 if t == CollisionEvent.WARNING_BEGIN and p == key(*demo_scene.WARNING_PAIR)]
        self.assertTrue(all(0.0 < x < 0.05 for x in d), d)

    def test_3_collision_begin_and_end(self):
        pair = demo_scene.COLLISION_PAIR
        self.wait_for(lambda: self.has(CollisionEvent.COLLISION_BEGIN, pair),
                      "COLLISION_BEGIN %s" % (pair,))
        with self.lock:
            begin = min(w for (w, t, p, _, _) in self.events
                        if t == CollisionEvent.COLLISION_BEGIN and p == key(*pair))
            d = [d for (_, t, p, d, _) in self.events
                 if t == CollisionEvent.COLLISION_BEGIN and p == key(*pair)]
        self.assertTrue(all(x <= 0.0 for x in d), d)
        self.wait_for(lambda: self.has(CollisionEvent.COLLISION_END, pair, after=begin),
                      "COLLISION_END %s after its BEGIN" % (pair,))

    def test_4_events_are_sane(self):
        self.wait_for(lambda: self.has(CollisionEvent.COLLISION_END, demo_scene.COLLISION_PAIR),
                      "COLLISION_END")
        with self.lock:
            events = list(self.events)
        # The warning pair's clearance never drops below 20 mm.
        self.assertFalse(any(t == CollisionEvent.COLLISION_BEGIN and
                             p == key(*demo_scene.WARNING_PAIR) for (_, t, p, _, _) in events))
        for (_, t, p, d, frame) in events:
            self.assertEqual(frame, "world")
            self.assertFalse(math.isnan(d), p)

    def test_5_markers_follow(self):
        self.wait_for(lambda: self.red_bodies > 0 and self.witness > 0,
                      "a red body marker and a witness segment")
        # The crate is removed every period: its markers are deleted.
        self.wait_for(lambda: self.body_deletes > 0, "DELETE of a removed body's marker")


if __name__ == "__main__":
    rostest.rosrun(PKG, "demo_events", DemoEvents, sys.argv)
