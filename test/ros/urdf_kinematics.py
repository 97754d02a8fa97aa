"""A URDF's joint tree read with ElementTree (not urdfdom): its links' poses for joint positions
(forward kinematics) and joint configurations in its limits, for the tests' oracles
(test_robot_oracle.py, test/demo/panda_demo_test.py)."""
import math
import xml.etree.ElementTree as ET

import numpy as np

from sweep_oracle import Tf, rpy_to_quat

MOVING = ('revolute', 'continuous', 'prismatic')


def floats(text, default):
    return [float(x) for x in text.split()] if text else list(default)


def origin_tf(element):
    """An <origin xyz rpy> child of `element` (none: identity) as a Tf."""
    o = element.find('origin')
    xyz = floats(o.get('xyz') if o is not None else '', (0, 0, 0))
    rpy = floats(o.get('rpy') if o is not None else '', (0, 0, 0))
    return Tf.from_xyz_q(xyz, rpy_to_quat(*rpy))


class Kinematics:
    """The joints of a URDF (its text or parsed root element); fixed, floating and planar joints
    stay at their origin."""

    def __init__(self, urdf):
        root = ET.fromstring(urdf) if isinstance(urdf, str) else urdf
        self.joints = []  # dicts: name, type, parent, child, origin (Tf), axis (unit), limits
        for j in root.findall('joint'):
            a = j.find('axis')
            axis = np.array(floats(a.get('xyz') if a is not None else '', (1, 0, 0)))
            lim, m = j.find('limit'), j.find('mimic')
            lo = float(lim.get('lower', 0)) if lim is not None else 0.0
            hi = float(lim.get('upper', 0)) if lim is not None else 0.0
            if j.get('type') == 'continuous':
                lo, hi = -math.pi, math.pi
            self.joints.append(dict(
                name=j.get('name'), type=j.get('type'), parent=j.find('parent').get('link'),
                child=j.find('child').get('link'), origin=origin_tf(j),
                axis=axis / np.linalg.norm(axis), lower=lo, upper=hi,
                mimic=None if m is None else (m.get('joint'), float(m.get('multiplier', 1)),
                                              float(m.get('offset', 0)))))
        children = {j['child'] for j in self.joints}
        self.roots = [link.get('name') for link in root.findall('link')
                      if link.get('name') not in children]
        self.parent = {j['child']: j['parent'] for j in self.joints}
        # The joints in an order that poses each one's parent link before it (self.joints keeps
        # the URDF's order, which configuration() draws in).
        self.chain, posed, pending = [], set(self.roots), self.joints
        while pending:
            ready = [j for j in pending if j['parent'] in posed]
            if not ready:
                raise ValueError("the URDF's joints do not form a tree")
            pending = [j for j in pending if j['parent'] not in posed]
            self.chain += ready
            posed.update(j['child'] for j in ready)

    def position(self, joint, q):
        """The joint's position in q; a mimic joint q leaves out follows its joint (as
        robot_state_publisher does); else 0."""
        if joint['name'] in q:
            return q[joint['name']]
        if joint['mimic'] is not None and joint['mimic'][0] in q:
            name, multiplier, offset = joint['mimic']
            return multiplier * q[name] + offset
        return 0.0

    def link_poses(self, q):
        """{link: Tf} in the root link's frame for joint positions q ({joint: position})."""
        poses = {link: Tf() for link in self.roots}
        for j in self.chain:
            T = poses[j['parent']] * j['origin']
            v = self.position(j, q)
            if j['type'] in ('revolute', 'continuous'):
                s = math.sin(0.5 * v)
                T = T * Tf.from_xyz_q((0, 0, 0), tuple(j['axis'] * s) + (math.cos(0.5 * v),))
            elif j['type'] == 'prismatic':
                T = T * Tf(t=j['axis'] * v)
            poses[j['child']] = T
        return poses

    def configuration(self, rng):
        """Positions of the moving joints: random in the limits (rng), or zero clamped into them
        (rng None); a mimic joint follows its joint."""
        moving = [j for j in self.joints if j['type'] in MOVING]
        q = {}
        for j in moving:
            q[j['name']] = (rng.uniform(j['lower'], j['upper']) if rng
                            else min(max(0.0, j['lower']), j['upper']))
        for j in moving:
            if j['mimic'] is not None and j['mimic'][0] in q:
                q[j['name']] = j['mimic'][1] * q[j['mimic'][0]] + j['mimic'][2]
        return q
