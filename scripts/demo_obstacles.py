#!/usr/bin/python3
"""Moving obstacles of the demo scene, one per way a body can be posed:

  tf_box        attached to the TF frame demo_tf_obstacle, which this node broadcasts (tf2)
  topic_sphere  pose_from_topic with its own geometry_msgs/PoseStamped topic (demo/sphere_pose, in the demo's namespace)
  pillar        pose_from_topic, posed through <monitor>/body_poses (BodyPoses, with twists)
  crate         attached to the world frame; added and removed every half period (REMOVE)

Bodies go to <monitor>/bodies on a latched publisher. A latched topic keeps only its last
message, so the full set is (re)sent whenever a new subscriber connects (e.g. the monitor
restarts); the latched message itself (possibly the crate's REMOVE) is harmless. Motion
follows demo_scene of ROS time.

Parameters: ~monitor [/collision_monitor] namespace of the monitor, ~rate [50 Hz],
~frame [world] the fixed frame poses are given in.
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import rospy  # noqa: E402
import tf2_ros  # noqa: E402
from geometry_msgs.msg import Point, PoseStamped, TransformStamped, Twist, Pose  # noqa: E402

from collision_monitor.msg import Body, BodyPoses, Shape  # noqa: E402

import demo_scene as scene  # noqa: E402


def shape(kind, dims, xyz=(0.0, 0.0, 0.0)):
    s = Shape()
    s.type = kind
    s.dimensions = list(dims)
    s.pose.position = Point(*xyz)
    s.pose.orientation.w = 1.0
    return s


def body(body_id, frame, parts, pose_from_topic=False, pose_topic="", padding=0.0):
    b = Body()
    b.header.frame_id = frame
    b.id = body_id
    b.operation = Body.ADD
    b.group = "obstacles"  # obstacles are never checked against each other
    b.parts = parts
    b.padding = padding
    b.pose_from_topic = pose_from_topic
    b.pose_topic = pose_topic
    return b


class Obstacles(object):
    def __init__(self):
        self.monitor = rospy.get_param("~monitor", "/collision_monitor").rstrip("/")
        self.frame = rospy.get_param("~frame", "world")
        self.rate = rospy.get_param("~rate", 50.0)
        self.bodies_pub = rospy.Publisher(self.monitor + "/bodies", Body, queue_size=100,
                                          latch=True)
        self.poses_pub = rospy.Publisher(self.monitor + "/body_poses", BodyPoses, queue_size=10)
        self.sphere_pub = rospy.Publisher(scene.SPHERE_POSE_TOPIC, PoseStamped, queue_size=10)
        self.tf = tf2_ros.TransformBroadcaster()
        self.bodies = {
            "tf_box": body("tf_box", scene.TF_OBSTACLE_FRAME,
                           [shape(Shape.BOX, scene.TF_BOX_SIZE)]),
            "topic_sphere": body("topic_sphere", self.frame,
                                 [shape(Shape.SPHERE, (scene.SPHERE_RADIUS,))],
                                 pose_from_topic=True, pose_topic=scene.SPHERE_POSE_TOPIC),
            # A capsule with 10 mm padding: drawn with a translucent shell.
            "pillar": body("pillar", self.frame,
                           [shape(Shape.CAPSULE, (scene.PILLAR_LENGTH, scene.PILLAR_RADIUS))],
                           pose_from_topic=True, padding=0.01),
        }
        c = scene.CRATE_SIZE
        self.crate = body("crate", self.frame,
                          [shape(Shape.BOX, (c, c, c), scene.CRATE_POSITION)])
        self.crate_shown = False
        self.connections = 0
        self.poses_from = None  # time the first bodies went out; poses start a little later

    def send_all(self):
        for b in self.bodies.values():
            b.header.stamp = rospy.Time.now()
            self.bodies_pub.publish(b)
        if self.crate_shown:
            self.bodies_pub.publish(self.crate)

    def step(self, now):
        t = now.to_sec()
        n = self.bodies_pub.get_num_connections()
        if n > self.connections:
            self.send_all()
            if self.poses_from is None:
                self.poses_from = t + 0.5
        self.connections = n

        want_crate = scene.crate_present(t)
        if want_crate != self.crate_shown:
            self.crate_shown = want_crate
            msg = Body()
            msg.header.stamp = now
            msg.header.frame_id = self.frame
            msg.id = "crate"
            if want_crate:
                msg = self.crate
                msg.header.stamp = now
            else:
                msg.operation = Body.REMOVE
            self.bodies_pub.publish(msg)

        tf = TransformStamped()
        tf.header.stamp = now
        tf.header.frame_id = self.frame
        tf.child_frame_id = scene.TF_OBSTACLE_FRAME
        x, y, z = scene.tf_box_position(t)
        tf.transform.translation.x, tf.transform.translation.y, tf.transform.translation.z = x, y, z
        tf.transform.rotation.w = 1.0
        self.tf.sendTransform(tf)

        # Poses of bodies the monitor does not know yet would be rejected (and logged): the
        # bodies and the poses travel on different connections, so give the bodies a head start.
        if self.poses_from is None or t < self.poses_from:
            return

        sp = PoseStamped()
        sp.header.stamp = now
        sp.header.frame_id = self.frame
        sp.pose.position = Point(*scene.sphere_position(t))
        sp.pose.orientation.w = 1.0
        self.sphere_pub.publish(sp)

        (px, py, pz), (vx, vy, vz) = scene.pillar_state(t)
        bp = BodyPoses()
        bp.header.stamp = now
        bp.header.frame_id = self.frame
        bp.ids = ["pillar"]
        pose = Pose()
        pose.position = Point(px, py, pz)
        pose.orientation.w = 1.0
        bp.poses = [pose]
        tw = Twist()
        tw.linear.x, tw.linear.y, tw.linear.z = vx, vy, vz
        bp.twists = [tw]
        self.poses_pub.publish(bp)

    def run(self):
        rate = rospy.Rate(self.rate)
        while not rospy.is_shutdown():
            self.step(rospy.Time.now())
            try:
                rate.sleep()
            except rospy.ROSInterruptException:
                break


def main():
    rospy.init_node("demo_obstacles")
    Obstacles().run()


if __name__ == "__main__":
    main()
