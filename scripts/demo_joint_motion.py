#!/usr/bin/python3
"""Scripted joint motion of a demo robot: publishes sensor_msgs/JointState on joint_states
(for robot_state_publisher) following the scene module's joint_positions of ROS time.

Parameters: ~rate [50 Hz]; ~scene [demo_scene]: the module beside this script that holds JOINTS,
joint_positions(t) and joint_velocities(t) (demo_scene: the demo arm; panda_demo_scene: the
Franka Panda).
"""
import importlib
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import rospy  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402

SCENES = ("demo_scene", "panda_demo_scene")


def main():
    rospy.init_node("demo_joint_motion")
    name = rospy.get_param("~scene", "demo_scene")
    if name not in SCENES:
        rospy.logfatal("~scene must be one of %s, not %r", ", ".join(SCENES), name)
        sys.exit(1)
    scene = importlib.import_module(name)
    rate = rospy.Rate(rospy.get_param("~rate", 50.0))
    pub = rospy.Publisher("joint_states", JointState, queue_size=10)
    msg = JointState()
    msg.name = list(scene.JOINTS)
    while not rospy.is_shutdown():
        now = rospy.Time.now()
        t = now.to_sec()
        msg.header.stamp = now
        msg.position = scene.joint_positions(t)
        msg.velocity = scene.joint_velocities(t)
        pub.publish(msg)
        try:
            rate.sleep()
        except rospy.ROSInterruptException:
            break


if __name__ == "__main__":
    main()
