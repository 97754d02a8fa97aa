#!/usr/bin/python3
"""Scripted joint motion of the demo arm: publishes sensor_msgs/JointState on joint_states
(for robot_state_publisher) following demo_scene.joint_positions of ROS time.

Parameters: ~rate [50 Hz].
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import rospy  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402

import demo_scene  # noqa: E402


def main():
    rospy.init_node("demo_joint_motion")
    rate = rospy.Rate(rospy.get_param("~rate", 50.0))
    pub = rospy.Publisher("joint_states", JointState, queue_size=10)
    msg = JointState()
    msg.name = list(demo_scene.JOINTS)
    while not rospy.is_shutdown():
        now = rospy.Time.now()
        t = now.to_sec()
        msg.header.stamp = now
        msg.position = demo_scene.joint_positions(t)
        msg.velocity = demo_scene.joint_velocities(t)
        pub.publish(msg)
        try:
            rate.sleep()
        except rospy.ROSInterruptException:
            break


if __name__ == "__main__":
    main()
