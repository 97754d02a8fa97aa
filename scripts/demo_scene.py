"""The demo scene's choreography, shared by the demo nodes and the demo tests (stdlib only).

Everything repeats with PERIOD seconds and is a function of ROS time modulo PERIOD, so the
joint motion, the obstacle motion and the tests agree on the phase no matter when each started.
Designed events per period (with warning_distance 0.05 m, contact_distance 0, hysteresis 0.005):
  gripper_link / tf_box         COLLISION_BEGIN around t = 1.4 s, COLLISION_END around t = 2.9 s
                                (the gripper runs into the post and lingers at the end of its
                                swing)
  base_link / topic_sphere      WARNING_BEGIN around t = 2 s, WARNING_END around t = 6 s (min
                                clearance 20 mm: never a collision)
  pillar (~body_poses, twists)  passes near the forearm and wrist on the other side of the swing
  crate                         added for half of each period (WARNING with base_link at 30 mm),
                                then removed (its markers are deleted, its warning ends)
"""
import math

PERIOD = 8.0  # s
OMEGA = 2.0 * math.pi / PERIOD

JOINTS = ["joint1", "joint2", "joint3", "joint4", "joint5", "joint6"]

# Pairs the tests expect (order-independent).
COLLISION_PAIR = ("gripper_link", "tf_box")
WARNING_PAIR = ("base_link", "topic_sphere")

TF_OBSTACLE_FRAME = "demo_tf_obstacle"
# Relative: the publisher (demo_obstacles.py) and the monitor resolve it in their namespace, so
# two demos in two namespaces do not share it.
SPHERE_POSE_TOPIC = "demo/sphere_pose"

BASE_RADIUS = 0.10  # base_link cylinder (urdf/demo_arm.urdf)
SPHERE_RADIUS = 0.04
TF_BOX_SIZE = (0.12, 0.12, 0.24)  # a post the gripper runs into while its z rises
PILLAR_LENGTH = 0.5
PILLAR_RADIUS = 0.03
CRATE_SIZE = 0.1


def phase(t):
    """Seconds into the current period."""
    return math.fmod(t, PERIOD)


SWING = 0.9  # rad, base yaw amplitude
DWELL = 2.0  # sharpness of the pause at both ends of the swing


def swing(t):
    """Base yaw: a sine flattened at its ends (tanh), so the arm lingers ~1.5 s at each side."""
    return SWING * math.tanh(DWELL * math.sin(OMEGA * t)) / math.tanh(DWELL)


def joint_positions(t):
    """Arm joint angles (rad) at time t: a yaw swing of +-0.9 rad that pauses at both ends, with
    gentle shoulder, elbow and wrist motion, all periodic in PERIOD."""
    return [
        swing(t),
        0.7 + 0.1 * math.cos(OMEGA * t),
        1.0 + 0.2 * math.sin(2.0 * OMEGA * t),
        0.5 * math.sin(OMEGA * t),
        0.5 + 0.25 * math.sin(2.0 * OMEGA * t),
        1.2 * math.sin(4.0 * OMEGA * t),
    ]


def joint_velocities(t):
    th = math.tanh(DWELL * math.sin(OMEGA * t))
    return [
        SWING / math.tanh(DWELL) * (1.0 - th * th) * DWELL * OMEGA * math.cos(OMEGA * t),
        -0.1 * OMEGA * math.sin(OMEGA * t),
        0.4 * OMEGA * math.cos(2.0 * OMEGA * t),
        0.5 * OMEGA * math.cos(OMEGA * t),
        0.5 * OMEGA * math.cos(2.0 * OMEGA * t),
        4.8 * OMEGA * math.cos(4.0 * OMEGA * t),
    ]


def tf_box_position(t):
    """Origin of the TF obstacle frame (world): where the gripper pauses at the end of its +y
    swing, bobbing +-15 mm in z."""
    return (0.37, 0.60, 0.42 + 0.015 * math.sin(OMEGA * t))


def sphere_position(t):
    """Centre of the pose-topic sphere: beside the base (-y, under the arm's reach), clearance
    80 mm -> 20 mm -> 80 mm."""
    gap = 0.02 + 0.06 * 0.5 * (1.0 + math.cos(OMEGA * t))
    return (0.0, -(BASE_RADIUS + SPHERE_RADIUS + gap), 0.05)


def pillar_state(t):
    """Pillar centre (world) and its linear velocity: slides in and out along x on the -y side."""
    x = 0.45 + 0.12 * math.cos(OMEGA * t)
    vx = -0.12 * OMEGA * math.sin(OMEGA * t)
    return (x, -0.42, 0.40), (vx, 0.0, 0.0)


def crate_present(t):
    return phase(t) >= PERIOD / 2.0


CRATE_POSITION = (0.0, BASE_RADIUS + CRATE_SIZE / 2.0 + 0.03, CRATE_SIZE / 2.0)
