#!/usr/bin/python3
"""Live summary of the monitor for the demo: prints every event as it happens (time, type, pair,
distance in mm) and, when the demo ends (after ~duration seconds, or on Ctrl-C), a final table:
per pair the minimum distance and its events, counts per event type, and cycle statistics from
~state (rate, compute_time). A pair's UNKNOWN_END whose UNKNOWN_BEGIN came before this summary
connected (the robot's pairs, known from its first poses) is counted, not printed, and a pair
with no other event and never near is one count under the table, not a row.

Parameters: ~monitor [/collision_monitor], ~duration [30 s; 0 = until shutdown]. When the
duration is up it prints the table and ends the launch that started it as Ctrl-C would (SIGINT to
its parent when that is a local roslaunch), then exits; started otherwise, it exits (launch it
with required="true": roslaunch then ends the launch, and says so in red).
"""
import math
import os
import signal
import sys
import threading
import time

import rospy

from collision_monitor.msg import CollisionEvent, CollisionState, PairState

EVENT_NAMES = {
    CollisionEvent.COLLISION_BEGIN: "COLLISION_BEGIN",
    CollisionEvent.COLLISION_END: "COLLISION_END",
    CollisionEvent.WARNING_BEGIN: "WARNING_BEGIN",
    CollisionEvent.WARNING_END: "WARNING_END",
    CollisionEvent.UNKNOWN_BEGIN: "UNKNOWN_BEGIN",
    CollisionEvent.UNKNOWN_END: "UNKNOWN_END",
}
STATUS_NAMES = {PairState.CLEAR: "clear", PairState.WARNING: "warning",
                PairState.COLLISION: "collision", PairState.UNKNOWN: "unknown"}


def pair_key(a, b):
    return (a, b) if a <= b else (b, a)


def mm(d):
    if d is None or math.isinf(d) or math.isnan(d):
        return "-"
    return "%.1f" % (d * 1000.0)


def percentile(sorted_values, q):
    if not sorted_values:
        return float("nan")
    i = min(len(sorted_values) - 1, max(0, int(round(q * (len(sorted_values) - 1)))))
    return sorted_values[i]


class Summary(object):
    def __init__(self):
        self.monitor = rospy.get_param("~monitor", "/collision_monitor").rstrip("/")
        self.duration = float(rospy.get_param("~duration", 30.0))
        self.lock = threading.Lock()
        self.start = rospy.get_time()
        self.pairs = {}  # key -> dict(min=, near=, counts={type: n})
        self.unknown = set()  # pairs whose UNKNOWN_BEGIN this summary printed, until their END
        self.counts = dict((t, 0) for t in EVENT_NAMES)
        self.compute_times = []
        self.state_stamps = []
        self.num_bodies = 0
        self.pairs_checked = []
        self.printed = False
        rospy.Subscriber(self.monitor + "/events", CollisionEvent, self.on_event, queue_size=1000)
        rospy.Subscriber(self.monitor + "/state", CollisionState, self.on_state, queue_size=100)

    def elapsed(self):
        return rospy.get_time() - self.start

    def entry(self, a, b):
        return self.pairs.setdefault(pair_key(a, b), {
            "min": float("inf"), "near": False, "counts": dict((t, 0) for t in EVENT_NAMES)})

    def listed(self, e):
        """Whether a pair gets a row: an event other than an UNKNOWN_END, or near in ~state."""
        return e["near"] or any(n for t, n in e["counts"].items()
                                if t != CollisionEvent.UNKNOWN_END)

    def on_event(self, ev):
        with self.lock:
            t = self.elapsed()
            name = EVENT_NAMES.get(ev.type, "EVENT_%d" % ev.type)
            if ev.type in self.counts:
                self.counts[ev.type] += 1
            e = self.entry(ev.pair.body_a, ev.pair.body_b)
            e["counts"][ev.type] = e["counts"].get(ev.type, 0) + 1
            if ev.pair.status != PairState.UNKNOWN and not math.isinf(ev.pair.distance):
                e["min"] = min(e["min"], ev.pair.distance)
            k = pair_key(ev.pair.body_a, ev.pair.body_b)
            if ev.type == CollisionEvent.UNKNOWN_BEGIN:
                self.unknown.add(k)
            elif ev.type == CollisionEvent.UNKNOWN_END:
                if k not in self.unknown:
                    return  # known from its first poses, before this summary connected
                self.unknown.discard(k)
            if ev.pair.status == PairState.UNKNOWN:
                dist = ""
            elif math.isinf(ev.pair.distance):
                dist = "%12s" % "apart"
            else:
                dist = "%9s mm" % mm(ev.pair.distance)
            print("[%7.2f s] %-16s %-32s %s" % (
                t, name, "%s <-> %s" % (ev.pair.body_a, ev.pair.body_b), dist))
            sys.stdout.flush()

    def on_state(self, st):
        with self.lock:
            self.compute_times.append(st.compute_time)
            self.state_stamps.append(rospy.get_time())
            self.num_bodies = st.num_bodies
            self.pairs_checked.append(st.num_pairs_checked)
            for p in st.pairs:
                if p.status in (PairState.WARNING, PairState.COLLISION):
                    e = self.entry(p.body_a, p.body_b)
                    e["min"] = min(e["min"], p.distance)
                    e["near"] = True

    def report(self):
        with self.lock:
            if self.printed:
                return
            self.printed = True
            out = []
            out.append("")
            out.append("=== collision_monitor demo summary (%.1f s) ===" % self.elapsed())
            if not self.state_stamps:
                out.append("no ~state received from %s: is collision_monitor_node running?"
                           % self.monitor)
            out.append("%-34s %10s %6s %6s %6s %6s %6s %6s" % (
                "pair", "min [mm]", "COL+", "COL-", "WARN+", "WARN-", "UNK+", "UNK-"))
            order = [CollisionEvent.COLLISION_BEGIN, CollisionEvent.COLLISION_END,
                     CollisionEvent.WARNING_BEGIN, CollisionEvent.WARNING_END,
                     CollisionEvent.UNKNOWN_BEGIN, CollisionEvent.UNKNOWN_END]
            quiet = []  # (min, key): pairs with only their first UNKNOWN_END
            for key in sorted(self.pairs):
                e = self.pairs[key]
                if not self.listed(e):
                    quiet.append((e["min"], key))
                    continue
                out.append("%-34s %10s %s" % ("%s <-> %s" % key, mm(e["min"]), " ".join(
                    "%6d" % e["counts"].get(t, 0) for t in order)))
            if len(quiet) == len(self.pairs):
                out.append("(no pair came within the warning distance)")
            if quiet:
                d, key = min(quiet)
                out.append("+ %d pair%s known from the first poses (an UNKNOWN_END only), not "
                           "listed; nearest %s <-> %s at %s mm" % (
                               len(quiet), "" if len(quiet) == 1 else "s", key[0], key[1], mm(d)))
            out.append("events: " + ", ".join(
                "%s %d" % (EVENT_NAMES[t], self.counts[t]) for t in order))
            ended = [EVENT_NAMES[end] for begin, end in zip(order[0::2], order[1::2])
                     if self.counts[end] > self.counts[begin]]
            if ended:
                # ~events is not latched: the robot's pairs are UNKNOWN until its TF comes,
                # usually before this summary has connected.
                out.append("(%s without their BEGINs: those came before this summary connected%s)"
                           % (", ".join(ended), "; such UNKNOWN_ENDs are not printed above"
                              if "UNKNOWN_END" in ended else ""))
            n = len(self.compute_times)
            if n:
                ct = sorted(self.compute_times)
                span = self.state_stamps[-1] - self.state_stamps[0]
                rate = (n - 1) / span if span > 0 else float("nan")
                out.append("cycles: %d at %.1f Hz, %d bodies, %.1f narrow-phase pairs/cycle" % (
                    n, rate, self.num_bodies, sum(self.pairs_checked) / float(n)))
                out.append("compute_time [ms]: mean %.3f  p50 %.3f  p95 %.3f  max %.3f" % (
                    1000.0 * sum(ct) / n, 1000.0 * percentile(ct, 0.5),
                    1000.0 * percentile(ct, 0.95), 1000.0 * ct[-1]))
            print("\n".join(out))
            sys.stdout.flush()


LAUNCH_SHUTDOWN_WAIT = 30.0  # s: roslaunch gives each node 15 s after SIGINT, we come early


def end_launch():
    """Sends SIGINT to this process's parent when that is a local roslaunch (not a remote
    machine's `roslaunch --child`, not rostest): True when sent."""
    parent = os.getppid()
    try:
        with open("/proc/%d/cmdline" % parent, "rb") as f:
            argv = f.read().split(b"\0")
    except OSError:
        return False
    # argv: [python3,] /usr/bin/roslaunch, its arguments
    if b"roslaunch" not in [os.path.basename(a) for a in argv[:2]] or b"--child" in argv:
        return False
    os.kill(parent, signal.SIGINT)
    return True


def main():
    rospy.init_node("demo_summary")
    s = Summary()
    rospy.on_shutdown(s.report)
    print("demo_summary: watching %s/events and %s/state%s" % (
        s.monitor, s.monitor,
        "" if s.duration <= 0 else " for %.0f s" % s.duration))
    sys.stdout.flush()
    if s.duration > 0:
        deadline = rospy.get_time() + s.duration
        while not rospy.is_shutdown() and rospy.get_time() < deadline:
            rospy.sleep(0.1)
        s.report()
        if not rospy.is_shutdown() and end_launch():  # not after Ctrl-C
            # roslaunch shuts down every node, this one with SIGINT; exiting first would be a
            # required node's death, which roslaunch reports in red.
            deadline = time.monotonic() + LAUNCH_SHUTDOWN_WAIT
            while not rospy.is_shutdown() and time.monotonic() < deadline:
                time.sleep(0.1)
        rospy.signal_shutdown("demo duration reached")
    else:
        rospy.spin()


if __name__ == "__main__":
    main()
