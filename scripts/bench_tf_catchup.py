#!/usr/bin/python3
"""Load for scripts/bench_tf_catchup.sh: with `joints`, publishes sensor_msgs/JointState for every
movable joint of the URDF on /robot_description (sinusoids) at ~rate Hz; with `ball`, adds a
sphere 'ball' on the monitor's ~bodies, poses it on ~body_poses at 10 Hz near the robot's base
(`static`: once, stamped 0 in the fixed frame) for `seconds` and prints, at each /diagnostics
report of the monitor, its mean cycle time, check rate, pair checks caught up and pairs checked a
check.
Usage: bench_tf_catchup.py joints | bench_tf_catchup.py ball [seconds [moving|static]]"""
import math
import sys
import xml.etree.ElementTree as ET

import rospy
from collision_monitor.msg import Body, BodyPoses, Shape
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Pose
from sensor_msgs.msg import JointState

KEYS = ('mean cycle time (ms)', 'check rate (Hz)', 'pair checks caught up (since last report)',
        'pairs checked (mean per check since last report)')


def joints():
    rospy.init_node('bench_tf_catchup_joints')
    root = ET.fromstring(rospy.get_param('/robot_description'))
    names = [j.get('name') for j in root.findall('joint')
             if j.get('type') not in ('fixed', 'floating', 'planar')]
    pub = rospy.Publisher('joint_states', JointState, queue_size=10)
    rate = rospy.Rate(rospy.get_param('~rate', 100.0))
    while not rospy.is_shutdown():
        msg = JointState()
        msg.header.stamp = rospy.Time.now()
        msg.name = names
        t = msg.header.stamp.to_sec()
        msg.position = [0.3 * math.sin(0.5 * t + i) for i in range(len(names))]
        pub.publish(msg)
        rate.sleep()


def ball(seconds, static):
    rospy.init_node('bench_tf_catchup_ball')
    ns = '/collision_monitor/'
    bodies = rospy.Publisher(ns + 'bodies', Body, queue_size=10, latch=True)
    poses = rospy.Publisher(ns + 'body_poses', BodyPoses, queue_size=10)

    def on_diagnostics(msg):
        for s in msg.status:
            if s.hardware_id == '/collision_monitor':
                values = {kv.key: kv.value for kv in s.values}
                print('  '.join('%s: %s' % (k, values.get(k, '?')) for k in KEYS), flush=True)
    rospy.Subscriber('/diagnostics', DiagnosticArray, on_diagnostics)
    rospy.sleep(1.0)
    sphere = Shape(type=Shape.SPHERE, dimensions=[0.1])
    sphere.pose.orientation.w = 1.0
    bodies.publish(Body(id='ball', operation=Body.ADD, parts=[sphere], pose_from_topic=True))
    end = rospy.Time.now() + rospy.Duration(seconds)
    rate = rospy.Rate(10.0)
    posed = False
    while not rospy.is_shutdown() and rospy.Time.now() < end:
        msg = BodyPoses(ids=['ball'])
        p = Pose()
        p.position.x, p.position.y, p.position.z = 0.6, -0.2, 0.8
        p.orientation.w = 1.0
        if static:  # in the monitor's fixed frame, the URDF's root link
            root = ET.fromstring(rospy.get_param('/robot_description'))
            children = {j.find('child').get('link') for j in root.findall('joint')}
            msg.header.frame_id = next(link.get('name') for link in root.findall('link')
                                       if link.get('name') not in children)
        else:
            msg.header.stamp = rospy.Time.now()
            msg.header.frame_id = 'base_link'
            p.position.x += 0.1 * math.sin(rospy.get_time())
        msg.poses = [p]
        if not (static and posed):
            poses.publish(msg)
            posed = True
        rate.sleep()


if __name__ == '__main__':
    if sys.argv[1:2] == ['joints']:
        joints()
    elif sys.argv[1:2] == ['ball']:
        ball(float(sys.argv[2]) if len(sys.argv) > 2 else 25.0, sys.argv[3:4] == ['static'])
    else:
        sys.exit(__doc__)
