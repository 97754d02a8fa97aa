#!/usr/bin/python3
"""rostest: the demo seen through real rviz. Starts its own Xvfb (a free display, found with
-displayfd) and rviz with rviz/demo.rviz under software GL (LIBGL_ALWAYS_SOFTWARE=1), then times
screenshots (ImageMagick `import -window root`) by ~state:

  - while gripper_link/tf_box has been in COLLISION for a moment (and still is after the shot):
    red pixels in the 3D view (the colliding bodies, the witness segment, the normal);
  - while nothing has been in COLLISION for a moment: no red, and green bodies.

Also checks that rviz rendered at all (the 3D view is not one flat colour). Screenshots are kept
as build artefacts: demo_screenshot.png (collision) and demo_screenshot_clear.png in
$CM_ARTIFACTS, else in <build>/test_results (CTest), else in the ROS test results directory.
"""
import os
import shutil
import subprocess
import sys
import threading
import time
import unittest

import rospkg
import rospy
import rostest
import rosgraph

from collision_monitor.msg import CollisionState, PairState

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..",
                                "scripts"))
import demo_scene  # noqa: E402

PKG = "collision_monitor"
WIDTH, HEIGHT = 1280, 800
VIEW_X0 = 400  # the 3D view starts right of the Displays panel (rviz/demo.rviz layout)


def artefact_dir():
    """$CM_ARTIFACTS, else the build's test_results (set by cmake/demo.cmake for CTest), else the
    ROS test results directory."""
    d = (os.environ.get("CM_ARTIFACTS") or os.environ.get("CM_DEMO_ARTIFACTS") or
         os.path.join(rospkg.get_test_results_dir(), PKG))
    os.makedirs(d, exist_ok=True)
    return d


def read_ppm(path):
    """(width, height, raw RGB bytes) of a binary PPM (P6, maxval 255) as `import` writes it."""
    with open(path, "rb") as f:
        data = f.read()
    fields = []
    pos = 0
    while len(fields) < 4:
        while data[pos:pos + 1].isspace():
            pos += 1
        if data[pos:pos + 1] == b"#":
            pos = data.index(b"\n", pos) + 1
            continue
        end = pos
        while not data[end:end + 1].isspace():
            end += 1
        fields.append(data[pos:end])
        pos = end
    if fields[0] != b"P6" or fields[3] != b"255":
        raise ValueError("unexpected PPM header %r" % fields)
    w, h = int(fields[1]), int(fields[2])
    return w, h, data[pos + 1:pos + 1 + 3 * w * h]


def count_colours(ppm):
    """Red, green and distinct-colour counts in the 3D view of a screenshot."""
    w, h, raw = read_ppm(ppm)
    red = green = 0
    colours = set()
    for y in range(0, h):
        row = raw[3 * w * y:3 * w * (y + 1)]
        for x in range(VIEW_X0, w):
            r, g, b = row[3 * x], row[3 * x + 1], row[3 * x + 2]
            if r > 110 and r > 2.5 * g and r > 2.5 * b:
                red += 1
            elif g > 90 and g > 1.6 * r and g > 1.6 * b:
                green += 1
            if len(colours) < 5000 and (x + y) % 7 == 0:
                colours.add((r >> 3, g >> 3, b >> 3))
    return red, green, len(colours)


class DemoScreenshot(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("demo_screenshot_test")
        cls.timeout = rospy.get_param("~timeout", 90.0)
        cls.lock = threading.Lock()
        cls.collision_since = None  # wall time the designed pair entered COLLISION
        cls.clear_since = None      # wall time since no pair is in COLLISION
        cls.states = 0
        rospy.Subscriber("/collision_monitor/state", CollisionState, cls.on_state, queue_size=10)
        cls.procs = []
        cls.display = cls.start_xvfb()
        env = dict(os.environ, DISPLAY=cls.display, LIBGL_ALWAYS_SOFTWARE="1")
        config = os.path.join(rospkg.RosPack().get_path(PKG), "rviz", "demo.rviz")
        cls.rviz_log = open(os.path.join(artefact_dir(), "demo_screenshot_rviz.log"), "w")
        cls.procs.append(subprocess.Popen(
            ["rosrun", "rviz", "rviz", "-d", config, "__name:=rviz_screenshot"], env=env,
            stdout=cls.rviz_log, stderr=subprocess.STDOUT))

    @classmethod
    def start_xvfb(cls):
        read_fd, write_fd = os.pipe()
        xvfb = subprocess.Popen(
            ["Xvfb", "-displayfd", str(write_fd), "-screen", "0", "%dx%dx24" % (WIDTH, HEIGHT),
             "-nolisten", "tcp"], pass_fds=(write_fd,), stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL)
        os.close(write_fd)
        cls.procs.append(xvfb)
        number = b""
        with os.fdopen(read_fd, "rb") as f:
            while not number.endswith(b"\n"):
                c = f.read(1)
                if not c:
                    raise RuntimeError("Xvfb did not report a display")
                number += c
        return ":" + number.decode().strip()

    @classmethod
    def tearDownClass(cls):
        for p in reversed(cls.procs):
            p.terminate()
            try:
                p.wait(10)
            except subprocess.TimeoutExpired:
                p.kill()
        cls.rviz_log.close()

    @classmethod
    def on_state(cls, st):
        now = time.time()
        designed = set(demo_scene.COLLISION_PAIR)
        colliding = any(p.status == PairState.COLLISION and {p.body_a, p.body_b} == designed
                        for p in st.pairs)
        any_collision = any(p.status == PairState.COLLISION for p in st.pairs)
        with cls.lock:
            cls.states += 1
            if colliding:
                if cls.collision_since is None:
                    cls.collision_since = now
            else:
                cls.collision_since = None
            if any_collision:
                cls.clear_since = None
            elif cls.clear_since is None:
                cls.clear_since = now

    def rviz_ready(self):
        """rviz subscribes to the markers topic once its displays are up."""
        try:
            _, subs, _ = rosgraph.Master("/demo_screenshot_test").getSystemState()
        except Exception:  # noqa: BLE001 - master busy: try again
            return False
        for topic, nodes in subs:
            if topic == "/collision_monitor/markers" and "/rviz_screenshot" in nodes:
                return True
        return False

    def shoot(self, name):
        """Grabs the screen as PPM (fast: no compression while the moment lasts)."""
        path = os.path.join(artefact_dir(), name)
        subprocess.check_call(
            ["import", "-display", self.display, "-window", "root", "-depth", "8", path])
        return path

    def keep_png(self, ppm):
        """The artefact: the screenshot as PNG beside it (the PPM is removed)."""
        png = ppm[:-len(".ppm")] + ".png"
        subprocess.check_call(["convert", ppm, png])
        os.remove(ppm)
        return png

    def shot_while(self, condition, hold, name, deadline):
        """Takes a screenshot once `condition` (a callable on the state, under the lock) has held
        for `hold` seconds, and keeps it if the condition still holds after the shot."""
        while time.time() < deadline and not rospy.is_shutdown():
            with self.lock:
                since = condition()
            if since is not None and time.time() - since >= hold:
                path = self.shoot(name)
                time.sleep(0.05)
                with self.lock:
                    still = condition()
                if still is not None and still == since:
                    return path
            time.sleep(0.05)
        self.fail("no moment for %s within the timeout" % name)

    def test_screenshots(self):
        deadline = time.time() + self.timeout
        while not self.rviz_ready():
            self.assertLess(time.time(), deadline, "rviz did not subscribe to the markers")
            self.assertIsNone(self.procs[-1].poll(), "rviz exited")
            time.sleep(0.2)
        time.sleep(4.0)  # first frames under llvmpipe

        clear, (red, green, colours) = self.shot_showing(
            lambda: self.clear_since, 0.8, "demo_screenshot_clear.ppm", deadline,
            lambda red, green, colours: colours > 20 and green > 2000 and red < 50)
        rospy.loginfo("clear screenshot %s: red %d, green %d, colours %d", clear, red, green,
                      colours)
        self.assertGreater(colours, 20, "rviz did not render (flat 3D view)")
        self.assertGreater(green, 2000, "no green bodies while clear")
        self.assertLess(red, 50, "red pixels while nothing collides")

        hit, (red, green, colours) = self.shot_showing(
            lambda: self.collision_since, 0.3, "demo_screenshot.ppm", deadline,
            lambda red, green, colours: red > 300 and green > 500)
        rospy.loginfo("collision screenshot %s: red %d, green %d, colours %d", hit, red, green,
                      colours)
        self.assertGreater(red, 300, "no red while %s collide" % (demo_scene.COLLISION_PAIR,))
        self.assertGreater(green, 500, "the rest of the robot should stay green")

    def shot_showing(self, condition, hold, name, deadline, shows):
        """shot_while(), again while the deadline allows until `shows(red, green, colours)`:
        rviz (llvmpipe) on a loaded machine may draw the moment late. The PNG of the last shot
        and its colour counts."""
        while True:
            shot = self.shot_while(condition, hold, name, deadline)
            counts = count_colours(shot)
            if shows(*counts) or time.time() + 1.0 > deadline:
                return self.keep_png(shot), counts
            rospy.logwarn("%s: %s does not show it yet (red, green, colours): another shot",
                          name, counts)
            time.sleep(0.2)

if __name__ == "__main__":
    if shutil.which("Xvfb") is None or shutil.which("import") is None:
        print("Xvfb and ImageMagick are needed (scripts/install_deps.sh)", file=sys.stderr)
    rostest.rosrun(PKG, "demo_screenshot", DemoScreenshot, sys.argv)
