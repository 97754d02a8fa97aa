"""Helpers shared by the collision_monitor rostests (python test nodes, /usr/bin/python3)."""
import collections
import math
import threading
import time

import numpy as np
import rospy
from collision_monitor.msg import (Body, BodyPoses, CollisionEvent, CollisionState, Shape)
from collision_monitor.srv import CheckCollision, GetDistance, ListBodies
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Pose, TransformStamped
from sensor_msgs.msg import JointState

NS = '/collision_monitor/'
EVENT_NAMES = {v: k for k, v in vars(CollisionEvent).items()
               if k.isupper() and isinstance(v, int)}


def pose(x=0.0, y=0.0, z=0.0, qx=0.0, qy=0.0, qz=0.0, qw=1.0):
    p = Pose()
    p.position.x, p.position.y, p.position.z = x, y, z
    p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w = qx, qy, qz, qw
    return p


def shape(kind, dims=(), **kw):
    s = Shape(type=kind, dimensions=list(dims))
    s.pose.orientation.w = 1.0
    for k, v in kw.items():
        setattr(s, k, v)
    return s


def sphere_body(body_id, radius, frame='', pose_from_topic=True, group='', pose_topic=''):
    b = Body(id=body_id, operation=Body.ADD, group=group, pose_from_topic=pose_from_topic,
             pose_topic=pose_topic)
    b.header.frame_id = frame
    b.parts = [shape(Shape.SPHERE, [radius])]
    return b


def tf_transform(child, parent='world', stamp=None, xyz=(0.0, 0.0, 0.0), q=(0, 0, 0, 1)):
    """A TransformStamped of `child` in `parent`; stamp None: now."""
    t = TransformStamped()
    t.header.stamp = stamp if stamp is not None else rospy.Time.now()
    t.header.frame_id = parent
    t.child_frame_id = child
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = xyz
    (t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z,
     t.transform.rotation.w) = q
    return t


# The Panda's SRDF "default" (ready) configuration.
PANDA_READY = {'panda_joint1': 0.0, 'panda_joint2': -0.785398, 'panda_joint3': 0.0,
               'panda_joint4': -2.35619, 'panda_joint5': 0.0, 'panda_joint6': 1.5707,
               'panda_joint7': 0.785398, 'panda_finger_joint1': 0.02,
               'panda_finger_joint2': 0.02}


def panda_joint_state(**offsets):
    """A JointState of PANDA_READY stamped now, each joint named in `offsets` moved by its
    value (rad)."""
    js = JointState()
    js.header.stamp = rospy.Time.now()
    js.name = list(PANDA_READY)
    js.position = [PANDA_READY[n] + offsets.get(n, 0.0) for n in js.name]
    return js


def wait_for(predicate, timeout, period=0.01):
    """Polls predicate until it returns a truthy value; returns it (or None on timeout)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and not rospy.is_shutdown():
        v = predicate()
        if v:
            return v
        time.sleep(period)
    return None


class Monitor:
    """Publishers, subscribers and service proxies of one monitor, the node `ns` names (by
    default /collision_monitor); its diagnostics are told apart by their hardware_id."""

    def __init__(self, ns=NS):
        self.node = ns.rstrip('/')
        for s in ('get_distance', 'check_collision', 'list_bodies'):
            rospy.wait_for_service(ns + s, timeout=30.0)
        self.get_distance = rospy.ServiceProxy(ns + 'get_distance', GetDistance)
        self.check_collision = rospy.ServiceProxy(ns + 'check_collision', CheckCollision)
        self.list_bodies = rospy.ServiceProxy(ns + 'list_bodies', ListBodies)
        self.bodies_pub = rospy.Publisher(ns + 'bodies', Body, queue_size=100)
        self.poses_pub = rospy.Publisher(ns + 'body_poses', BodyPoses, queue_size=100,
                                         tcp_nodelay=True)
        self.lock = threading.Lock()
        self.events = []        # (receive wall time, CollisionEvent)
        self.state = None
        self.states = collections.deque(maxlen=200)  # the latest ~state messages
        self.state_count = 0
        self.diagnostics = None
        rospy.Subscriber(ns + 'events', CollisionEvent, self._on_event, queue_size=100000,
                         tcp_nodelay=True)
        rospy.Subscriber(ns + 'state', CollisionState, self._on_state, queue_size=10)
        rospy.Subscriber('/diagnostics', DiagnosticArray, self._on_diag, queue_size=10)
        assert wait_for(lambda: self.bodies_pub.get_num_connections() > 0
                        and self.poses_pub.get_num_connections() > 0, 10.0), \
            'the monitor did not subscribe to ~bodies / ~body_poses'
        assert wait_for(lambda: self.state is not None, 10.0), 'no ~state heartbeat'

    def _on_event(self, msg):
        with self.lock:
            self.events.append((time.monotonic(), msg))

    def _on_state(self, msg):
        self.states.append(msg)
        self.state_count += 1
        self.state = msg

    def _on_diag(self, msg):
        for st in msg.status:
            if st.hardware_id == self.node:
                self.diagnostics = st

    def wait_event(self, etype, a, b, timeout=5.0, since=0.0):
        """The first event of this type for pair {a, b} received after `since` (monotonic)."""
        def find():
            with self.lock:
                for t, e in self.events:
                    if t >= since and e.type == etype and {e.pair.body_a, e.pair.body_b} == {a, b}:
                        return (t, e)
            return None
        return wait_for(find, timeout, period=0.001)

    def events_for(self, pairs, since=0.0):
        """Every event received after `since` (monotonic) whose pair is one of `pairs` (a set
        of frozensets)."""
        with self.lock:
            return [e for t, e in self.events
                    if t >= since and frozenset((e.pair.body_a, e.pair.body_b)) in pairs]

    def ids(self):
        return sorted(self.list_bodies().ids)

    def is_stale(self, body_id):
        """~list_bodies' stale flag of a listed body."""
        listed = self.list_bodies()
        return listed.stale[listed.ids.index(body_id)]

    def add(self, body):
        self.bodies_pub.publish(body)

    def wait_listed(self, body_id, present=True, timeout=5.0):
        return wait_for(lambda: (body_id in self.list_bodies().ids) == present, timeout, 0.02)

    def diag_value(self, key, status=None):
        """The value of `key` in `status`, by default the latest report."""
        status = self.diagnostics if status is None else status
        if status is None:
            return None
        for kv in status.values:
            if kv.key == key:
                return kv.value
        return None


class PoseStreamer:
    """Publishes BodyPoses for a dict of id -> Pose at `rate` Hz (fresh stamps), in `frame`."""

    def __init__(self, pub, frame='world', rate=20.0):
        self.pub = pub
        self.frame = frame
        self.poses = {}
        self.paused = set()
        self.lock = threading.Lock()
        self.period = 1.0 / rate
        self.sent = {}  # id -> stamps of the messages that carried it, in order
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def set(self, body_id, p, publish_now=True):
        with self.lock:
            self.poses[body_id] = p
        if publish_now:
            self.publish_now()

    def publish_now(self):
        msg = BodyPoses()
        msg.header.frame_id = self.frame
        msg.header.stamp = rospy.Time.now()
        with self.lock:
            for k, v in self.poses.items():
                if k not in self.paused:
                    msg.ids.append(k)
                    msg.poses.append(v)
        if msg.ids:
            self.pub.publish(msg)
            with self.lock:
                for k in msg.ids:
                    self.sent.setdefault(k, []).append(msg.header.stamp)
        return msg.header.stamp

    def stamps(self, body_id):
        """The stamps of the messages published so far that carried `body_id`."""
        with self.lock:
            return list(self.sent.get(body_id, ()))

    def _run(self):
        while not rospy.is_shutdown():
            try:
                self.publish_now()
            except rospy.ROSException:  # shutting down
                return
            time.sleep(self.period)


def point(p):
    """A message's x, y, z (Point, Vector3) as an array."""
    return np.array([p.x, p.y, p.z])


def point_close(p, xyz, tol=1e-6):
    return math.dist((p.x, p.y, p.z), xyz) <= tol
