"""The Panda demo's joint motion (launch/panda_demo.launch), a function of ROS time (stdlib only).

The Franka Panda of example-robot-data (primitive collision model: each link a union of
cylinders and spheres) swings its first joint between -1.2 and +1.2 rad, pausing at each end,
while its shoulder and elbow reach in and out twice a period. The obstacles are not here: they
are the monitor's `~bodies` parameter (config/panda_demo_bodies.yaml). Designed per period of
PERIOD seconds (warning_distance 0.05 m, contact_distance 0, hysteresis 0.005):
  panda_hand / ball      COLLISION from about t = 4.2 s to 6.1 s (the hand pushes 33 mm into
                         the ball at the +1.2 rad end of the swing; link7 and the right finger
                         come within warning distance of it)
  panda_hand / lamp      WARNING around t = 0 (the -1.2 rad end; 23 mm at the closest, link7
                         26 mm): never a collision
  table                  under the robot: panda_link0 and panda_link1 reach into it and are
                         disabled with it (`disabled_pairs`); nothing else comes near
"""
import math

PERIOD = 10.0  # s
OMEGA = 2.0 * math.pi / PERIOD

JOINTS = ["panda_joint1", "panda_joint2", "panda_joint3", "panda_joint4", "panda_joint5",
          "panda_joint6", "panda_joint7", "panda_finger_joint1", "panda_finger_joint2"]

# Pairs the tests expect (order-independent).
COLLISION_PAIR = ("panda_hand", "ball")
WARNING_PAIR = ("panda_hand", "lamp")


def phase(t):
    """Seconds into the current period."""
    return t % PERIOD


def _smooth(x):
    """0 -> 0, 1 -> 1 with zero slope at both ends; its derivative."""
    x = min(max(x, 0.0), 1.0)
    return x * x * (3.0 - 2.0 * x), 6.0 * x * (1.0 - x)


def _swing(ph):
    """panda_joint1 and its rate: -1.2 (1 s) -> +1.2 in 3.5 s, (1.5 s) -> -1.2 in 4 s."""
    if ph < 1.0:
        return -1.2, 0.0
    if ph < 4.5:
        s, ds = _smooth((ph - 1.0) / 3.5)
        return -1.2 + 2.4 * s, 2.4 * ds / 3.5
    if ph < 6.0:
        return 1.2, 0.0
    s, ds = _smooth((ph - 6.0) / 4.0)
    return 1.2 - 2.4 * s, -2.4 * ds / 4.0


def joint_positions(t):
    ph = phase(t)
    j1, _ = _swing(ph)
    reach = math.cos(2.0 * OMEGA * ph)
    return [j1, -0.35 + 0.25 * reach, 0.0, -2.1 + 0.25 * reach, 0.0,
            1.85 + 0.1 * math.sin(OMEGA * ph), 0.785, 0.03, 0.03]


def joint_velocities(t):
    ph = phase(t)
    _, dj1 = _swing(ph)
    dreach = -2.0 * OMEGA * math.sin(2.0 * OMEGA * ph)
    return [dj1, 0.25 * dreach, 0.0, 0.25 * dreach, 0.0, 0.1 * OMEGA * math.cos(OMEGA * ph), 0.0,
            0.0, 0.0]
