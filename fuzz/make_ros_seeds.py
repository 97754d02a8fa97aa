#!/usr/bin/python3
"""Writes the seed corpus of the ROS-input fuzzer (fuzz/corpus/ros/), deterministically.

One file per input: the first byte picks the input kind (fuzz_ros_input.cpp), the rest is a
serialized message (Body, BodyPoses, CheckCollision request), a URDF, an SRDF, or an XML-RPC value
(an entry of the ~bodies parameter). Needs the package's generated Python messages: source a
build's devel/setup.bash first. Usage: fuzz/make_ros_seeds.py [out_dir]
"""
import io
import os
import sys
import xmlrpc.client

from collision_monitor.msg import Body, BodyPoses, Shape
from collision_monitor.srv import CheckCollisionRequest
from geometry_msgs.msg import Point, Pose, Twist

BODY, POSES, CHECK, URDF, SRDF, XMLRPC = range(6)


def wire(msg):
    buf = io.BytesIO()
    msg.serialize(buf)
    return buf.getvalue()


def shape(kind, dims=(), vertices=(), resource="", z=0.0, qw=1.0):
    s = Shape(type=kind, dimensions=list(dims), resource=resource)
    s.vertices = [Point(*v) for v in vertices]
    s.pose.position.z = z
    s.pose.orientation.w = qw
    return s


def body(bid, parts, frame="world", **kw):
    b = Body(id=bid, parts=parts, **kw)
    b.header.frame_id = frame
    return b


TETRA = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
CUBE = [(x, y, z) for x in (0, 1) for y in (0, 1) for z in (0, 1)]
BODIES = {
    "sphere": body("s", [shape(Shape.SPHERE, [0.5])]),
    "box": body("b", [shape(Shape.BOX, [1, 2, 3], z=0.5)]),
    "cylinder": body("c", [shape(Shape.CYLINDER, [1, 0.2])], group="g"),
    "cone": body("k", [shape(Shape.CONE, [1, 0.3], qw=0.0)], padding=0.01),
    "capsule": body("p", [shape(Shape.CAPSULE, [0.4, 0.1])], pose_from_topic=True),
    "ellipsoid": body("e", [shape(Shape.ELLIPSOID, [0.1, 0.2, 0.3])], pose_topic="/mocap/e"),
    "convex": body("h", [shape(Shape.CONVEX, vertices=CUBE), shape(Shape.CONVEX, vertices=TETRA)]),
    "mesh": body("m", [shape(Shape.MESH, resource="package://collision_monitor/meshes/x.stl")]),
    "remove": body("s", [], operation=Body.REMOVE),
}

URDF_TEXT = """<?xml version="1.0"?>
<robot name="r">
  <link name="base"><collision><geometry><box size="0.2 0.2 0.1"/></geometry></collision></link>
  <link name="arm"><collision><origin xyz="0 0 0.2" rpy="0 0 1.57"/>
    <geometry><cylinder radius="0.05" length="0.4"/></geometry></collision>
    <collision><geometry><sphere radius="0.06"/></geometry></collision></link>
  <link name="tool"><collision><geometry><mesh filename="package://p/m.stl" scale="1 1 1"/>
    </geometry></collision></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="arm"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="j2" type="fixed"><parent link="arm"/><child link="tool"/></joint>
</robot>
"""

SRDF_TEXT = """<?xml version="1.0"?>
<robot name="r">
  <disable_collisions link1="base" link2="arm" reason="Adjacent"/>
  <disable_default_collisions link="tool"/>
  <enable_collisions link1="tool" link2="base"/>
  <disable_collisions link1="" link2="arm"/>
</robot>
"""

PARAM_BODY = {"id": "wand", "pose_topic": "/mocap/wand/pose", "padding": 0.01,
              "parts": [{"type": "capsule", "dimensions": [0.3, 0.015]},
                        {"type": "sphere", "dimensions": [0.03], "pose": {"position": {"z": 0.18}}},
                        {"type": "convex", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]},
                        {"type": 2, "dimensions": [1, 1, 1],
                         "pose": {"position": [0.6, 0.0, 0.72], "orientation": [0, 0, 0, 1]}}]}


def xmlrpc_value(value):
    text = xmlrpc.client.dumps((value,))
    return text[text.index("<value>"):text.rindex("</value>") + len("</value>")]


def seeds():
    for name, b in BODIES.items():
        yield "body-" + name, BODY, wire(b)
    poses = BodyPoses(ids=["p", "e"], poses=[Pose(), Pose()], twists=[Twist(), Twist()])
    poses.header.frame_id = "world"
    for p in poses.poses:
        p.orientation.w = 1.0
    poses.twists[1].linear.x = 0.5
    yield "poses-two", POSES, wire(poses)
    yield "poses-no-twists", POSES, wire(BodyPoses(ids=["p"], poses=[Pose()]))
    req = CheckCollisionRequest(body=BODIES["box"], margin=0.1)
    req.pose.orientation.w = 1.0
    yield "check-box", CHECK, wire(req)
    yield "check-convex", CHECK, wire(CheckCollisionRequest(body=BODIES["convex"], margin=1.0))
    yield "urdf-three-links", URDF, URDF_TEXT.encode()
    yield "srdf-rules", SRDF, SRDF_TEXT.encode()
    yield "xmlrpc-body", XMLRPC, xmlrpc_value(PARAM_BODY).encode()


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "corpus", "ros")
    os.makedirs(out, exist_ok=True)
    for name, kind, payload in seeds():
        with open(os.path.join(out, name), "wb") as f:
            f.write(bytes([kind]) + payload)
    print(f"{len(list(seeds()))} seeds in {out}")


if __name__ == "__main__":
    main()
