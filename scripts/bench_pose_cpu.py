#!/usr/bin/python3
"""CPU per thread of a running collision_monitor_node while checks of seconds run (three bodies of
1,000 overlapping boxes) and ~body_poses comes at 20 Hz (scripts/bench_pose_cpu.sh runs it).
With `bodies`, a ~bodies ADD (a small sphere, three ids in turn) comes with each pose message.
Usage: bench_pose_cpu.py <node pid> [seconds] [bodies]"""
import os
import sys
import time

import rospy
from collision_monitor.msg import Body, BodyPoses, Shape
from geometry_msgs.msg import Pose

TICK = os.sysconf('SC_CLK_TCK')


def pose(x, y=0.0):
    p = Pose()
    p.position.x, p.position.y = x, y
    p.orientation.w = 1.0
    return p


def cpu(pid):
    out = {}
    for tid in os.listdir('/proc/%d/task' % pid):
        try:
            with open('/proc/%d/task/%s/stat' % (pid, tid)) as f:
                fields = f.read().rsplit(')', 1)[1].split()
            out[int(tid)] = (int(fields[11]) + int(fields[12])) / TICK
        except OSError:
            pass
    return out


def main():
    pid, seconds = int(sys.argv[1]), float(sys.argv[2]) if len(sys.argv) > 2 else 20.0
    with_bodies = len(sys.argv) > 3 and sys.argv[3] == 'bodies'
    rospy.init_node('spin_cpu')
    bodies = rospy.Publisher('/collision_monitor/bodies', Body, queue_size=10, latch=True)
    poses = rospy.Publisher('/collision_monitor/body_poses', BodyPoses, queue_size=10)
    time.sleep(1.0)
    for name in ('big_a', 'big_b', 'big_c'):
        b = Body(id=name, operation=Body.ADD, pose_from_topic=True)
        for i in range(1000):
            s = Shape(type=Shape.BOX, dimensions=[0.2, 0.2, 0.2])
            s.pose = pose(0.001 * (i % 10), 0.001 * (i // 10 % 10))
            s.pose.position.z = 0.001 * (i // 100)
            b.parts.append(s)
        bodies.publish(b)
        time.sleep(0.5)
    k = 0
    t0 = time.monotonic()
    before = None
    t_before = 0.0
    while time.monotonic() - t0 < 5.0 + seconds:
        msg = BodyPoses(ids=['big_a', 'big_b', 'big_c'],
                        poses=[pose(10.0), pose(10.05 + 1e-4 * k), pose(10.0, 0.05 + 1e-4 * k)])
        msg.header.frame_id = 'world'
        poses.publish(msg)
        if with_bodies:
            probe = Body(id='probe%d' % (k % 3), operation=Body.ADD, pose_from_topic=True)
            probe.parts.append(Shape(type=Shape.SPHERE, dimensions=[0.1]))
            bodies.publish(probe)
        k += 1
        if before is None and time.monotonic() - t0 >= 5.0:
            before, t_before = cpu(pid), time.monotonic()
        time.sleep(0.05)
    after, t_after = cpu(pid), time.monotonic()
    dt = t_after - t_before
    use = sorted(((after[t] - before.get(t, 0.0)) / dt, t) for t in after)
    use.reverse()
    print('%d pose messages%s at 20 Hz; CPU per thread over %.1f s: %s; total %.2f' % (
        k, ' and ~bodies messages' if with_bodies else '', dt,
        ', '.join('%.2f' % u for u, _ in use[:5]), sum(u for u, _ in use)))


if __name__ == '__main__':
    main()
