#!/usr/bin/python3
"""rostest: every invalid or wrongly typed parameter is reported once by name on /diagnostics
(level ERROR) and the monitor runs with that parameter's default: warning_distance 0.05, the
fixed frame world, markers published, min_distance beyond reach, the 50 Hz heartbeat."""
import os
import re
import signal
import subprocess
import sys
import time
import unittest

import rosgraph
import roslib.packages
import rospy
import rostest
import tf2_ros
from collision_monitor.msg import PairState
from collision_monitor.srv import ListBodies
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rosgraph_msgs.msg import Log
from visualization_msgs.msg import MarkerArray

from cm_test_util import Monitor, PoseStreamer, pose, sphere_body, tf_transform, wait_for, NS

STARTED = time.monotonic()


def fresh_node_lines(ns, args, until):
    """Starts a monitor /<ns>/cm with `args`, collects its lines from rosout's /rosout_agg until
    one contains `until` (at most 20 s), stops it; the lines' (level, text)."""
    exe = roslib.packages.find_node('collision_monitor', 'collision_monitor_node')[0]
    lines = []
    sub = rospy.Subscriber('/rosout_agg', Log,
                           lambda m: lines.append((m.level, m.msg)) if m.name == ns + '/cm'
                           else None)
    proc = subprocess.Popen([exe, '__ns:=' + ns, '__name:=cm'] + args,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        wait_for(lambda: any(until in m for _, m in list(lines)), 20.0)
    finally:
        sub.unregister()
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=30.0)
    return lines


class BadParams(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_bad_params')
        cls.m = Monitor()
        cls.poses = PoseStreamer(cls.m.poses_pub, 'world', rate=20.0)
        cls.m.add(sphere_body('a', 0.5))
        cls.m.add(sphere_body('b', 0.5))
        assert cls.m.wait_listed('a') and cls.m.wait_listed('b')
        # 4 cm apart: WARNING with the default warning_distance (0.05), CLEAR with the -0.1 given
        # (it was 0.0 then: warning_distance was set to contact_distance).
        cls.poses.set('a', pose(0, 0, 0))
        cls.poses.set('b', pose(1.04, 0, 0))

    def test_01_each_invalid_parameter_reported(self):
        self.assertTrue(wait_for(lambda: self.m.diagnostics is not None, 10.0))
        d = self.m.diagnostics
        self.assertEqual(d.level, DiagnosticStatus.ERROR, d.message)
        errors = [kv.value for kv in d.values if kv.key == 'invalid parameter']
        for key in ('rate', 'fixed_frame', 'warning_distance', 'hysteresis', 'pose_timeout',
                    'ttc_horizon', 'marker_rate', 'publish_markers', 'marker_frame_locked',
                    'check_on_pose', 'exact_min_distance', 'align_poses', 'backend',
                    'max_bodies', 'max_vertices_per_part', 'max_parts_per_body',
                    'robot_description_param', 'mesh_decomposition', 'diagnostic_period',
                    'min_check_interval', 'robot_link_padding'):
            self.assertEqual(sum(e.startswith(key) for e in errors), 1, (key, errors))
        self.assertEqual(len(errors), 21, errors)  # max_unknown_pairs = 1.0 is valid
        self.assertIn("robot_link_padding: no URDF on parameter 'robot_description': no robot "
                      "links", errors)
        self.assertIn("min_check_interval: not a number (the text '2e-3': YAML reads a number with "
                      "an exponent as text unless it has a '.' and a signed exponent, roslaunch "
                      "unless it has a '.'; write 2.0e-3); default used", errors)
        self.assertIn('diagnostic_period = 1e+300 (must be finite and within +-1e+06 s); using 1',
                      errors)
        self.assertEqual(rospy.get_param(NS + 'diagnostic_period'), 1.0)
        # roscpp threw on it: the node exited 1 with only "cannot load ...Nodelet".
        self.assertIn("robot_description_param = 'robot-description' (must be a ROS name, not "
                      "private); using robot_description", errors)
        self.assertIn('publish_markers: not a boolean', ' | '.join(errors))
        self.assertIn('marker_frame_locked: not a boolean', ' | '.join(errors))
        self.assertIn('align_poses: not a boolean', ' | '.join(errors))
        self.assertIn('max_bodies: not an integer', ' | '.join(errors))
        # Not rounded to 3 (roscpp's getParam(int) would): refused, the default (1000) used.
        self.assertIn('max_parts_per_body = 2.5 (must be a whole number > 0); using 1000', errors)
        self.assertIn('ttc_horizon = 0.000000 (must be > 0); using 10.000000', errors)
        self.assertIn("mesh_decomposition = 'convex' (must be hull or pieces); using hull", errors)
        self.assertEqual(self.m.diag_value('mesh decomposition', d), 'hull')
        self.assertEqual(self.m.state.header.frame_id, 'world')  # fixed_frame's default
        # Every parameter above is known but three names of bad_params.test (sorted).
        self.assertEqual(self.m.diag_value('unknown parameters', d),
                         "'disabled_pair' (did you mean disabled_pairs?), 'robot_description', "
                         "'warning_distanse' (did you mean warning_distance?)")

    def test_01b_checked_values_on_the_server_once_services_exist(self):
        # A client that waits for a service and then reads the parameters gets the checked
        # values: the node advertises its services after dynamic_reconfigure wrote them back.
        # They were advertised a few ms before: a client polling the master every ms read the
        # raw rate -5. Three fresh nodes, each read the moment its service is registered.
        master = rosgraph.Master('/test_bad_params')
        exe = roslib.packages.find_node('collision_monitor', 'collision_monitor_node')[0]
        seen = []
        for k in range(3):
            ns = '/fresh_%d' % k
            proc = subprocess.Popen([exe, '__ns:=' + ns, '__name:=cm', '_rate:=-5.0',
                                     '_warning_distance:=-0.1', '_publish_markers:=false'],
                                    stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            try:
                deadline = time.monotonic() + 30.0
                while time.monotonic() < deadline:
                    try:
                        master.lookupService(ns + '/cm/get_distance')
                        break
                    except rosgraph.MasterError:
                        time.sleep(0.001)
                seen.append((rospy.get_param(ns + '/cm/rate'),
                             rospy.get_param(ns + '/cm/warning_distance')))
            finally:
                proc.send_signal(signal.SIGINT)
                proc.wait(timeout=30.0)
        self.assertEqual(seen, [(50.0, 0.05)] * 3)

    def test_01c_contact_distance_alone_raises_the_default_warning_distance(self):
        # Only contact_distance given, above the default warning_distance (0.05): the warning
        # distance becomes the contact distance, the value ~set_parameters would use, without an
        # error (it was an ERROR for as long as the node ran, about a parameter nobody set).
        exe = roslib.packages.find_node('collision_monitor', 'collision_monitor_node')[0]
        ns = '/contact_only'
        proc = subprocess.Popen([exe, '__ns:=' + ns, '__name:=cm', '_contact_distance:=0.1',
                                 '_publish_markers:=false'],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        mon = Monitor.__new__(Monitor)  # only its diagnostics
        mon.node, mon.diagnostics = ns + '/cm', None
        sub = rospy.Subscriber('/diagnostics', DiagnosticArray, mon._on_diag)
        try:
            rospy.wait_for_service(ns + '/cm/get_distance', timeout=30.0)
            self.assertEqual(rospy.get_param(ns + '/cm/warning_distance'), 0.1)
            self.assertEqual(rospy.get_param(ns + '/cm/contact_distance'), 0.1)
            self.assertTrue(wait_for(lambda: mon.diagnostics is not None, 10.0))
            st = mon.diagnostics
            self.assertEqual(st.level, DiagnosticStatus.OK, st.message)
            self.assertEqual([kv.value for kv in st.values if kv.key == 'invalid parameter'], [])
        finally:
            sub.unregister()
            proc.send_signal(signal.SIGINT)
            proc.wait(timeout=30.0)

    def test_02_defaults_in_effect(self):
        r = wait_for(lambda: (lambda r: r if r.success else None)(
            self.m.get_distance('a', 'b', '')), 5.0)
        self.assertIsNotNone(r)
        self.assertAlmostEqual(r.result.distance, 0.04, places=9)
        self.assertEqual(r.result.status, PairState.WARNING)
        self.assertTrue(wait_for(lambda: any(p.status == PairState.WARNING
                                             for p in self.m.state.pairs), 3.0))
        # publish_markers: its default (true) while someone listens.
        got = []
        sub = rospy.Subscriber(NS + 'markers', MarkerArray, got.append)
        try:
            self.assertTrue(wait_for(lambda: len(got) > 0, 5.0), 'no markers')
        finally:
            sub.unregister()
        # exact_min_distance: its default (true): min_distance 0.5 m, far beyond reach.
        self.poses.set('b', pose(1.5, 0, 0))
        self.assertTrue(wait_for(lambda: abs(self.m.state.min_distance - 0.5) < 1e-9, 3.0),
                        self.m.state.min_distance)
        # rate: the 50 Hz default (-5 would be refused), as /diagnostics reports it; and states
        # come (about 50 a second; counted here, in a process a loaded machine may slow down).
        self.assertTrue(wait_for(lambda: self.m.diag_value('target rate (Hz)') == '50.0', 5.0),
                        self.m.diag_value('target rate (Hz)'))
        n0 = self.m.state_count
        t0 = time.monotonic()
        time.sleep(1.0)
        rate = (self.m.state_count - n0) / (time.monotonic() - t0)
        self.assertGreater(rate, 10.0)

    def test_03_whole_number_given_as_double(self):
        # max_unknown_pairs = 1.0: one UNKNOWN pair listed although 'c' (no pose) makes two.
        self.m.add(sphere_body('c', 0.1))
        self.assertTrue(self.m.wait_listed('c'))
        self.assertTrue(wait_for(lambda: 'c' in self.m.state.stale_bodies, 3.0))
        n0 = self.m.state_count
        self.assertTrue(wait_for(lambda: self.m.state_count >= n0 + 5, 3.0))
        state = self.m.state
        self.assertIn('c', state.stale_bodies)
        unknown = [(p.body_a, p.body_b) for p in state.pairs if p.status == PairState.UNKNOWN]
        self.assertEqual(len(unknown), 1, unknown)
        self.assertIn('c', unknown[0])

    def test_04_diagnostic_period_changed_to_nan_while_running(self):
        # diagnostic_updater re-reads it: ros::Duration threw in the diagnostics thread and the
        # process ended (SIGABRT). Now refused, set back to 1 s; the monitor runs on.
        rejected0 = int(self.m.diag_value('rejected inputs (total)') or 0)
        rospy.set_param(NS + 'diagnostic_period', float('nan'))
        self.assertTrue(wait_for(
            lambda: int(self.m.diag_value('rejected inputs (total)') or 0) > rejected0, 10.0))
        self.assertIn('diagnostic_period = nan', self.m.diag_value('last rejection'))
        self.assertTrue(wait_for(lambda: rospy.get_param(NS + 'diagnostic_period') == 1.0, 3.0))
        # Still alive: states go on, and /diagnostics with them (a new report object).
        n0, last = self.m.state_count, self.m.diagnostics
        self.assertTrue(wait_for(lambda: self.m.state_count >= n0 + 10 and
                                 self.m.diagnostics is not last, 5.0))

    def test_04b_diagnostic_period_deleted_while_running(self):
        # The master tells a cached parameter's deletion as an empty struct ("nodelet load" clears
        # the nodelet's namespace so): it was refused as "not a number", counted and written over
        # with 1 s, every time the nodelet was reloaded. Deleted is as not set: nothing refused.
        rospy.set_param(NS + 'diagnostic_period', 0.5)
        n0 = self.m.state_count
        last = self.m.diagnostics
        self.assertTrue(wait_for(lambda: self.m.diagnostics is not last, 5.0))
        rejected0 = int(self.m.diag_value('rejected inputs (total)') or 0)
        rospy.delete_param(NS + 'diagnostic_period')
        for _ in range(3):  # three reports after the deletion
            last = self.m.diagnostics
            self.assertTrue(wait_for(lambda: self.m.diagnostics is not last, 5.0))
        self.assertEqual(int(self.m.diag_value('rejected inputs (total)') or 0), rejected0,
                         self.m.diag_value('last rejection'))
        self.assertFalse(rospy.has_param(NS + 'diagnostic_period'))
        self.assertGreater(self.m.state_count, n0)
        rospy.set_param(NS + 'diagnostic_period', 1.0)  # as test_04 left it

    def test_05_first_check_at_once_with_a_long_min_check_interval(self):
        # /slow_checks (min_check_interval 20 s) started with this test: its first check waited
        # the 20 s out, /diagnostics saying 'checks (total)' 0 and OK meanwhile.
        slow = Monitor.__new__(Monitor)  # only its diagnostics
        slow.node, slow.diagnostics = '/slow_checks', None
        sub = rospy.Subscriber('/diagnostics', DiagnosticArray, slow._on_diag)
        try:
            self.assertTrue(
                wait_for(lambda: int(slow.diag_value('checks (total)') or 0) >= 1,
                         STARTED + 15.0 - time.monotonic()),
                'no check by /slow_checks %.1f s after start-up: %s' % (
                    time.monotonic() - STARTED, slow.diag_value('checks (total)')))
            # Its robot: link l keeps its box; the mesh left out is an ERROR in every report, as
            # are its diagnostic_period "abc" (reset to 1 on the parameter server), three entries
            # of its link settings and the body of its ~bodies parameter refused for a typo (one
            # report's WARN, then "ok", before the thirty-ninth session): the report after the
            # first one.
            first = slow.diagnostics
            self.assertTrue(wait_for(lambda: slow.diagnostics is not first, 5.0))
        finally:
            sub.unregister()
        st = slow.diagnostics
        self.assertEqual(st.level, DiagnosticStatus.ERROR, st.message)
        # Both in the message (then "; no check for ... s": its min_check_interval is 20 s).
        invalid = ["robot_link_padding['bad']: must be finite and >= 0, got -1; robot_padding "
                   "used", "robot_link_groups['l']: expected a string; the link is in no group",
                   "robot_link_padding: 'hand' is not a link of robot 'r'",
                   'diagnostic_period: not a number; using 1']
        self.assertTrue(st.message.startswith(
            'invalid parameters: ' + ', '.join(invalid) + "; robot geometry not monitored: URDF "
            "link l: collision 1 (mesh): mesh 'file:///nowhere/m.stl': cannot resolve "
            "'/nowhere/m.stl'"), st.message)
        self.assertEqual([kv.value for kv in st.values if kv.key == 'invalid parameter'], invalid)
        self.assertIn("; bodies of ~bodies not monitored: parameter ~bodies[1]: parts[0]: "
                      "unknown field 'dimension'", st.message)
        self.assertEqual(rospy.get_param('/slow_checks/diagnostic_period'), 1.0)
        left_out = [kv.value for kv in st.values if kv.key == 'robot geometry left out']
        self.assertEqual(len(left_out), 1, left_out)
        self.assertTrue(left_out[0].startswith(
            "URDF link l: collision 1 (mesh): mesh 'file:///nowhere/m.stl': cannot resolve "
            "'/nowhere/m.stl'"), left_out[0])
        left_out = [kv.value for kv in st.values if kv.key == 'parameter body left out']
        self.assertEqual(len(left_out), 1, left_out)
        self.assertEqual(left_out[0], "parameter ~bodies[1]: parts[0]: unknown field 'dimension'")
        listed = rospy.ServiceProxy('/slow_checks/list_bodies', ListBodies)()
        self.assertEqual(list(listed.ids), ['l', 'post'])

    def test_06_startup_errors_reach_rosout(self):
        # roscpp publishes log lines to /rosout without a queue for subscribers yet to connect:
        # the node's start-up lines, the invalid parameter's ERROR among them, reached the
        # terminal only (not /rosout, rosout.log, rqt_console). The node now waits for the
        # subscribers of /rosout the master names (rosout, one started by bad_params.test) first.
        # Read from rosout's /rosout_agg: the old node's lines all missed rosout, while a rospy
        # subscriber of /rosout missed only the first. After test_05 (15 s from start-up).
        ns = '/rosout_check'
        # A robot_description_param given with a typo: an INFO, and /diagnostics OK, before.
        lines = fresh_node_lines(ns, ['_rate:=-5.0', '_publish_markers:=false',
                                      '_robot_description_param:=robot_descripton'],
                                 'monitoring 0 bodies')
        self.assertIn((Log.ERROR, ns + '/cm: invalid parameter rate = -5.000000 (must be > 0); '
                       'using 50.000000'), lines)
        self.assertIn((Log.ERROR, ns + "/cm: invalid parameter robot_description_param: no URDF "
                       "on parameter 'robot_descripton' (looked up as "
                       "'/rosout_check/robot_descripton'): no robot bodies"), lines)
        self.assertIn(Log.INFO, [level for level, m in lines if 'monitoring 0 bodies' in m])

    def test_07_unresolved_frame_logged_once_then_resolved(self):
        # A body on a misspelled frame was UNKNOWN with no log line (only /diagnostics and
        # stale_bodies said so): after 5 s unresolved, one WARN names the frame and why, and an
        # INFO when it resolves.
        node = self.m.node
        lines = []
        sub = rospy.Subscriber('/rosout_agg', Log,
                               lambda m: lines.append((time.monotonic(), m.level, m.msg))
                               if m.name == node and 'shelf_typo' in m.msg else None)
        body = sphere_body('shelf', 0.1, frame='shelf_typo', pose_from_topic=False)
        try:
            self.m.add(body)
            added = time.monotonic()
            self.assertTrue(self.m.wait_listed('shelf'))
            self.assertTrue(wait_for(lambda: lines, 15.0), 'no line naming shelf_typo')
            at, level, msg = lines[0]
            self.assertGreaterEqual(at - added, 5.0)
            self.assertEqual(level, Log.WARN)
            # No TF at all in this test: tf2 names the fixed frame.
            self.assertEqual(msg, node + ": 1 TF frame cannot be looked up in 'world' for 5 s, "
                             "the bodies on it are UNKNOWN: 'shelf_typo': \"world\" passed to "
                             "lookupTransform argument target_frame does not exist. ")
            time.sleep(2.0)
            self.assertEqual(len(lines), 1, lines)  # once, not every check
            # /diagnostics: ERROR for the invalid parameters, the stale body after them (the
            # ERROR's message hid it before).
            d = self.m.diagnostics
            self.assertEqual(d.level, DiagnosticStatus.ERROR)
            self.assertTrue(d.message.startswith('invalid parameters: '), d.message)
            self.assertRegex(d.message, r"; \d+ stale bodies: ([a-z]+, )*shelf; 1 TF frames "
                             r"cannot be looked up in 'world' \(see unresolved TF frames\)$")
            static_tf = tf2_ros.StaticTransformBroadcaster()
            static_tf.sendTransform(tf_transform('shelf_typo', 'world'))
            self.assertTrue(wait_for(lambda: len(lines) > 1, 10.0), 'no line when resolved')
            self.assertEqual(lines[1][1:], (Log.INFO, node + ": TF frame 'shelf_typo' resolved "
                                            "in 'world'"))
        finally:
            sub.unregister()
            body.operation = body.REMOVE
            self.m.add(body)

    def test_08_adjacent_pairs_counted_among_the_links_monitored(self):
        # A parent link whose only <collision> is a missing mesh is left out: its pair with the
        # child is no pair of the monitor ("1 links ..., 1 adjacent pairs disabled" before).
        ns = '/adjacent_check'
        rospy.set_param(ns + '/robot_description', """<robot name="r2">
          <link name="base"><collision><geometry><mesh filename="file:///nowhere/b.stl"/>
          </geometry></collision></link>
          <link name="arm"><collision><geometry><box size="0.1 0.1 0.1"/></geometry>
          </collision></link>
          <joint name="j" type="fixed"><parent link="base"/><child link="arm"/></joint>
        </robot>""")
        lines = [m for _, m in fresh_node_lines(ns, ['_publish_markers:=false'], 'monitoring ')]
        self.assertIn(ns + "/cm: robot 'r2': 1 links with collision geometry, 0 adjacent pairs "
                      "disabled, 1 links or collision elements left out (errors above)", lines)

    def test_08b_tf_prefix_of_the_robots_namespace(self):
        # robot_state_publisher's tf_prefix, found as it finds it (upward from the private
        # namespace): the links on prefixed frames, the fixed frame the prefixed root link; one
        # that is not a string is an invalid parameter, and the links stay unprefixed.
        urdf = '''<robot name="r3">
          <link name="base"><collision><geometry><box size="0.1 0.1 0.1"/></geometry>
          </collision></link></robot>'''
        ns = '/prefixed'
        rospy.set_param(ns + '/robot_description', urdf)
        rospy.set_param(ns + '/tf_prefix', '/cell/left')
        lines = [m for _, m in fresh_node_lines(ns, ['_publish_markers:=false'], 'monitoring ')]
        self.assertIn(ns + "/cm: robot 'r3': 1 links with collision geometry, 0 adjacent pairs "
                      "disabled, TF frames cell/left/*", lines)
        self.assertIn("monitoring 1 bodies in frame 'cell/left/base'",
                      next(m for m in lines if 'monitoring ' in m))
        ns = '/prefix_not_a_string'
        rospy.set_param(ns + '/robot_description', urdf)
        rospy.set_param(ns + '/tf_prefix', 7)
        lines = fresh_node_lines(ns, ['_publish_markers:=false'], 'monitoring ')
        self.assertIn((Log.ERROR, ns + "/cm: invalid parameter tf_prefix (" + ns + "/tf_prefix): "
                       "not a string; the robot's links unprefixed"), lines)
        self.assertIn("monitoring 1 bodies in frame 'base'",
                      next(m for _, m in lines if 'monitoring ' in m))

    def test_08c_an_srdf_of_another_robot(self):
        # An SRDF whose robot is not the URDF's (another robot's, left by an earlier launch):
        # its rules apply by link name, as srdfdom applies them, and a WARN says whose it is (an
        # INFO line's count was all there was). The URDF's own robot: no such line.
        urdf = '''<robot name="r4">
          <link name="base"><collision><geometry><box size="0.1 0.1 0.1"/></geometry>
          </collision></link>
          <link name="arm"><collision><geometry><sphere radius="0.05"/></geometry>
          </collision></link>
          <link name="tool"><collision><geometry><sphere radius="0.05"/></geometry>
          </collision></link>
          <joint name="j1" type="fixed"><parent link="base"/><child link="arm"/></joint>
          <joint name="j2" type="fixed"><parent link="arm"/><child link="tool"/></joint>
        </robot>'''
        for robot, warned in (('panda', True), ('r4', False)):
            ns = '/srdf_of_' + robot
            rospy.set_param(ns + '/robot_description', urdf)
            rospy.set_param(ns + '/robot_description_semantic',
                            '<robot name="%s"><disable_collisions link1="base" link2="tool"/>'
                            '<disable_collisions link1="panda_link0" link2="panda_link1"/>'
                            '</robot>' % robot)
            lines = fresh_node_lines(ns, ['_publish_markers:=false'], 'monitoring ')
            self.assertIn((Log.INFO, ns + '/cm: SRDF: 1 pairs disabled, 0 links disabled by '
                           'default, 0 pairs enabled, 1 rules on links without collision '
                           'geometry or not in the URDF left out'), lines)
            warning = (Log.WARN, ns + "/cm: SRDF '" + ns + "/robot_description_semantic' is of "
                       "robot 'panda', the URDF of robot 'r4': its rules apply by link name")
            self.assertEqual([(level, m) for level, m in lines
                              if level >= Log.WARN and 'SRDF' in m], [warning] if warned else [])

    def test_09_every_documented_parameter_is_known(self):
        # The node's list of its parameters against docs/node.md's table: a fresh node given
        # each of them (any value: an invalid one is an ERROR, not an unknown name) names none as
        # unknown; one more name is.
        doc = open(os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'docs',
                                'node.md')).read()
        table = doc[doc.index('\n## Parameters\n'):doc.index('\n### Changing parameters')]
        names = re.findall(r'(?m)^\| `([a-z_]+)` \|', table)
        self.assertGreaterEqual(len(names), 29, names)
        exe = roslib.packages.find_node('collision_monitor', 'collision_monitor_node')[0]
        ns = '/every_param'
        for name in names + ['not_a_parameter']:
            rospy.set_param(ns + '/cm/' + name, 1.0)
        mon = Monitor.__new__(Monitor)  # only its diagnostics
        mon.node, mon.diagnostics = ns + '/cm', None
        sub = rospy.Subscriber('/diagnostics', DiagnosticArray, mon._on_diag)
        proc = subprocess.Popen([exe, '__ns:=' + ns, '__name:=cm'],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            self.assertTrue(wait_for(lambda: mon.diagnostics is not None, 20.0))
        finally:
            sub.unregister()
            proc.send_signal(signal.SIGINT)
            proc.wait(timeout=30.0)
        self.assertEqual(mon.diag_value('unknown parameters'), "'not_a_parameter'")

if __name__ == '__main__':
    rostest.rosrun('collision_monitor', 'bad_params', BadParams, sys.argv)
