#!/usr/bin/python3
"""~markers bandwidth of a running monitor with a robot: sweeps every movable joint of the URDF
on robot_description (sensor_msgs/JointState on joint_states, 50 Hz, each joint a slow sine
within its limits) unless --still, and counts the serialized bytes of ~markers for --seconds
(no deserialisation). Prints arrays, rate, mean and max array size, MB/s.
Used by scripts/bench_markers.sh; see docs/node.md (~markers)."""
import argparse
import math
import threading
import time
import xml.etree.ElementTree as ET

import rospy
from sensor_msgs.msg import JointState


def movable_joints(urdf):
    joints = []
    for j in ET.fromstring(urdf).iter('joint'):
        if j.get('type') in ('revolute', 'prismatic', 'continuous'):
            lim = j.find('limit')
            lo = float(lim.get('lower', -1.0)) if lim is not None else -1.0
            hi = float(lim.get('upper', 1.0)) if lim is not None else 1.0
            if j.get('type') == 'continuous' or hi <= lo:
                lo, hi = -1.0, 1.0
            joints.append((j.get('name'), lo, hi))
    return joints


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--seconds', type=float, default=10.0)
    ap.add_argument('--warmup', type=float, default=3.0)
    ap.add_argument('--still', action='store_true')
    ap.add_argument('--topic', default='/collision_monitor/markers')
    a = ap.parse_args(rospy.myargv()[1:])
    rospy.init_node('marker_bandwidth', anonymous=True)
    joints = movable_joints(rospy.get_param('/robot_description'))
    pub = rospy.Publisher('joint_states', JointState, queue_size=10)

    def sweep():
        r = rospy.Rate(50.0)
        t0 = time.monotonic()
        while not rospy.is_shutdown():
            t = 0.0 if a.still else time.monotonic() - t0
            msg = JointState(name=[n for n, _, _ in joints])
            msg.header.stamp = rospy.Time.now()
            msg.position = [lo + (hi - lo) * (0.5 + 0.25 * math.sin(0.5 * t + i))
                            for i, (_, lo, hi) in enumerate(joints)]
            pub.publish(msg)
            r.sleep()

    threading.Thread(target=sweep, daemon=True).start()
    sizes, stamps, record = [], [], [False]

    def on_markers(m):
        if record[0]:
            stamps.append(time.monotonic())
            sizes.append(len(m._buff))

    rospy.Subscriber(a.topic, rospy.AnyMsg, on_markers, queue_size=100)
    time.sleep(a.warmup)  # the first array after subscribing carries every body
    record[0] = True
    time.sleep(a.seconds)
    record[0] = False
    if len(stamps) < 3:
        raise SystemExit('marker_bandwidth: %d arrays in %.0f s' % (len(stamps), a.seconds))
    span = stamps[-1] - stamps[0]
    print('%s %d joints: %d arrays, %.1f Hz, mean %.0f B, max %d B, %.2f MB/s'
          % ('still' if a.still else 'moving', len(joints), len(sizes), (len(sizes) - 1) / span,
             sum(sizes) / len(sizes), max(sizes), sum(sizes[1:]) / span / 1e6))


if __name__ == '__main__':
    main()
