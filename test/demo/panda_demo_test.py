#!/usr/bin/python3
"""rostest: the Panda demo (launch/panda_demo.launch) against an oracle of its own.

The oracle reads the URDF from the parameter server with ElementTree (not urdfdom), does the
forward kinematics of the joint positions that were published on joint_states (not TF), and
computes each obstacle's signed distance to each link in closed form: every obstacle of the
demo is a sphere and every Panda collision part a sphere or a cylinder, so the distance of the
obstacle's centre to a part is exact, and a pair's distance is the smallest over the link's parts
(the monitor's definition, also when they overlap). Its own status machine (thresholds and
hysteresis as docs/node.md gives them) runs over every stamp of the robot's TF.

Checked, for every pair with an obstacle:
  - each event's distance equals the oracle's at the event's stamp (1e-7 m), its witness point
    on the obstacle lies on the sphere, and the witness points are that distance apart;
  - each event is one the oracle's status machine gives on that pair, of the same type, at the
    same stamp of the robot's TF or at most MAX_LAG later (a check that came late passes over a
    TF stamp), and leaves the pair in the status the oracle has at its stamp; each event the
    oracle gives in the middle of the run is one the monitor sent;
  - the designed events happened: COLLISION_BEGIN and COLLISION_END on panda_hand / ball, a
    WARNING_BEGIN on panda_hand / lamp; no pair with the table has an event (disabled or far);
and no pair of two links has an event (the SRDF disables the adjacent ones; the motion keeps the
others apart).
"""
import os
import sys
import threading
import time
import unittest
import xml.etree.ElementTree as ET

import numpy as np
import rospy
import rostest

from collision_monitor.msg import CollisionEvent, PairState
from sensor_msgs.msg import JointState
from tf2_msgs.msg import TFMessage

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [os.path.join(HERE, "..", "..", "scripts"), os.path.join(HERE, "..", "ros")]
import panda_demo_scene as scene  # noqa: E402
from cm_test_util import EVENT_NAMES as NAMES  # noqa: E402
from cm_test_util import point  # noqa: E402
from event_oracle import MAX_LAG, Timeline, key, run  # noqa: E402
from urdf_kinematics import Kinematics, origin_tf  # noqa: E402

PKG = "collision_monitor"


class Urdf(object):
    """The collision parts of a URDF (spheres and cylinders only) and its kinematics."""

    def __init__(self, text):
        root = ET.fromstring(text)
        self.kinematics = Kinematics(root)
        self.parts = {}  # link -> [(kind, radius, length, Tf of the part in the link)]
        for link in root.findall("link"):
            parts = []
            for c in link.findall("collision"):
                g = c.find("geometry")[0]
                if g.tag == "sphere":
                    parts.append(("sphere", float(g.get("radius")), 0.0, origin_tf(c)))
                elif g.tag == "cylinder":
                    parts.append(("cylinder", float(g.get("radius")), float(g.get("length")),
                                  origin_tf(c)))
                else:
                    raise ValueError("the oracle has no closed form for a %s part" % g.tag)
            if parts:
                self.parts[link.get("name")] = parts


def point_part_signed_distance(c, part, link_pose):
    """Signed distance of point c to a solid sphere or cylinder (axis z) part of a link."""
    kind, radius, length, origin = part
    local = (link_pose * origin).inv().apply(np.asarray(c, float))
    if kind == "sphere":
        return float(np.linalg.norm(local)) - radius
    dr = float(np.hypot(local[0], local[1])) - radius
    dz = abs(float(local[2])) - 0.5 * length
    if dr <= 0.0 and dz <= 0.0:
        return max(dr, dz)
    return float(np.hypot(max(dr, 0.0), max(dz, 0.0)))


class PandaDemo(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("panda_demo_test")
        cls.lock = threading.Lock()
        cls.events = []
        cls.joint_states = {}  # stamp (ns) -> {joint: position}
        cls.poses = {}  # stamp (ns) -> {link: pose}, the forward kinematics of its joint state
        cls.timeout = rospy.get_param("~timeout", 40.0)
        cls.urdf = Urdf(rospy.get_param("/robot_description"))
        cls.obstacles = {}  # id -> (centre in the root frame, radius)
        for body in rospy.get_param("/collision_monitor/bodies"):
            (part,) = body["parts"]
            assert part["type"] == "sphere" or body["id"] == "table", body
            if part["type"] == "sphere":
                cls.obstacles[body["id"]] = ([float(x) for x in part["pose"]["position"]],
                                             float(part["dimensions"][0]))
        rospy.Subscriber("/collision_monitor/events", CollisionEvent, cls.on_event,
                         queue_size=1000)
        rospy.Subscriber("/joint_states", JointState, cls.on_joints, queue_size=1000)
        cls.tf_stamps = set()  # stamps (ns) of the robot's moving transforms
        rospy.Subscriber("/tf", TFMessage, cls.on_tf, queue_size=1000)

    @classmethod
    def on_event(cls, ev):
        with cls.lock:
            cls.events.append(ev)

    @classmethod
    def on_tf(cls, msg):
        with cls.lock:
            for t in msg.transforms:
                if t.child_frame_id == "panda_link1":
                    cls.tf_stamps.add(t.header.stamp.to_nsec())

    @classmethod
    def on_joints(cls, msg):
        with cls.lock:
            cls.joint_states[msg.header.stamp.to_nsec()] = dict(zip(msg.name, msg.position))

    def distance(self, link, obstacle, stamp):
        """The pair's distance at the joint state stamped `stamp` (ns)."""
        if stamp not in self.poses:
            with self.lock:
                q = self.joint_states[stamp]
            self.poses[stamp] = self.urdf.kinematics.link_poses(q)
        centre, radius = self.obstacles[obstacle]
        return min(point_part_signed_distance(centre, p, self.poses[stamp][link])
                   for p in self.urdf.parts[link]) - radius

    def designed_events_seen(self):
        seen = set((key(e.pair.body_a, e.pair.body_b), e.type) for e in self.events)
        return (key(*scene.COLLISION_PAIR), CollisionEvent.COLLISION_BEGIN) in seen and \
            (key(*scene.COLLISION_PAIR), CollisionEvent.COLLISION_END) in seen and \
            (key(*scene.WARNING_PAIR), CollisionEvent.WARNING_BEGIN) in seen and \
            (key(*scene.WARNING_PAIR), CollisionEvent.WARNING_END) in seen

    def test_events_against_the_oracle(self):
        deadline = time.time() + self.timeout
        while time.time() < deadline and not rospy.is_shutdown():
            with self.lock:
                # A whole period and more after the robot's first poses.
                since = [e.header.stamp.to_nsec() for e in self.events
                         if e.type == CollisionEvent.UNKNOWN_END] + list(self.joint_states)[:1]
                if self.designed_events_seen() and since and \
                        (max(self.joint_states) - max(since)) * 1e-9 > scene.PERIOD + 3.0:
                    break
            time.sleep(0.1)
        with self.lock:
            events = list(self.events)
            states = dict(self.joint_states)
        self.assertTrue(self.designed_events_seen(),
                        "designed events missing; got %s" % sorted(set(
                            (key(e.pair.body_a, e.pair.body_b), NAMES[e.type]) for e in events)))
        links = set(self.urdf.parts)
        checked = 0
        worst = 0.0
        for e in events:
            pair = key(e.pair.body_a, e.pair.body_b)
            if e.type in (CollisionEvent.UNKNOWN_BEGIN, CollisionEvent.UNKNOWN_END):
                continue  # before the robot's first TF (checked below)
            self.assertFalse(pair[0] in links and pair[1] in links,
                             "an event on two links: %s %s" % (NAMES[e.type], pair))
            self.assertNotIn("table", pair, "an event with the table: %s" % NAMES[e.type])
            obstacle = pair[0] if pair[0] in self.obstacles else pair[1]
            link = pair[1] if obstacle == pair[0] else pair[0]
            stamp = e.header.stamp.to_nsec()
            self.assertIn(stamp, states, "%s on %s at a stamp no joint_states had" %
                          (NAMES[e.type], pair))
            d = self.distance(link, obstacle, stamp)
            worst = max(worst, abs(e.pair.distance - d))
            self.assertAlmostEqual(e.pair.distance, d, delta=1e-7, msg="%s %s at %.3f" % (
                NAMES[e.type], pair, e.header.stamp.to_sec()))
            # Witness points: the obstacle's on its sphere, the two |distance| apart.
            centre, radius = self.obstacles[obstacle]
            on_obstacle = e.pair.point_a if e.pair.body_a == obstacle else e.pair.point_b
            gap = point(e.pair.point_a) - point(e.pair.point_b)
            self.assertAlmostEqual(np.linalg.norm(point(on_obstacle) - centre), radius,
                                   delta=1e-7)
            self.assertAlmostEqual(np.linalg.norm(gap), abs(d), delta=1e-7)
            checked += 1
        # The oracle's own events over the stamps the robot's TF had (those the monitor's checks
        # can see; robot_state_publisher passes on some of the joint_states), pair by pair.
        timeline = Timeline(t for t in self.tf_stamps if t in states)
        tf_stamps = timeline.stamps
        predicted = []  # (stamp ns, pair, type)
        oracle_status = {}  # (pair, stamp ns) -> status
        for obstacle in self.obstacles:
            for link in links:
                pair = key(link, obstacle)
                given, at = run(pair, PairState.CLEAR, tf_stamps,
                                 lambda t: self.distance(link, obstacle, t))
                predicted += given
                oracle_status.update(((pair, t), status) for t, status in at.items())
        actual = [(e.header.stamp.to_nsec(), key(e.pair.body_a, e.pair.body_b), e.type,
                   e.pair.status)
                  for e in events
                  if e.type not in (CollisionEvent.UNKNOWN_BEGIN, CollisionEvent.UNKNOWN_END)]
        # Compared from a second after the robot's first pose (its pairs' UNKNOWN_END; the oracle
        # starts CLEAR at the first TF) to half a second before the last TF.
        unknown_ends = [e.header.stamp.to_nsec() for e in events
                        if e.type == CollisionEvent.UNKNOWN_END]
        start = max([tf_stamps[0]] + unknown_ends) + int(1e9)
        end = tf_stamps[-1] - int(0.5e9)
        late_unknown = [e for e in events if e.type == CollisionEvent.UNKNOWN_BEGIN and
                        e.header.stamp.to_nsec() > start - int(1e9)]
        self.assertFalse(late_unknown, "poses went stale during the run: %s" % [
            (key(e.pair.body_a, e.pair.body_b), e.header.stamp.to_sec()) for e in late_unknown])
        lags = []
        for a in actual:
            if start <= a[0] <= end:
                n = timeline.lag(a, predicted)
                self.assertTrue(n is not None and n <= MAX_LAG, "the monitor sent %s on %s at "
                                "%.3f (phase %.2f s), which the oracle does not give (lag %s)" % (
                                    NAMES[a[2]], a[1], a[0] * 1e-9, scene.phase(a[0] * 1e-9), n))
                lags.append(n)
                self.assertEqual(a[3], oracle_status[(a[1], a[0])],
                                 "%s on %s at %.3f leaves the pair in status %d, the oracle's "
                                 "is %d" % (NAMES[a[2]], a[1], a[0] * 1e-9, a[3],
                                            oracle_status[(a[1], a[0])]))
        middle = [p for p in predicted if start <= p[0] <= end]
        for p in middle:
            self.assertTrue(timeline.sent(p, actual, MAX_LAG),
                            "the oracle gives %s on %s at %.3f (phase %.2f s), the monitor did "
                            "not send it" % (NAMES[p[2]], p[1], p[0] * 1e-9,
                                             scene.phase(p[0] * 1e-9)))
        self.assertGreaterEqual(len(middle), 6)
        rospy.loginfo("panda demo: %d events checked against the oracle (largest distance error "
                      "%.3g m); %d of the oracle's events matched, %d of them at the same stamp "
                      "(the others %s TF stamps later)", checked, worst, len(middle),
                      lags.count(0), sorted(n for n in lags if n))


if __name__ == "__main__":
    rostest.rosrun(PKG, "panda_demo", PandaDemo)
