"""The monitor's status machine and events as docs/node.md gives them, for the tests that hold a
monitor's events to an oracle's distances (test_robot_oracle.py, test_catch_up.py,
test/demo/panda_demo_test.py): the oracle steps this machine over a run's stamps with its own
distances, and each event the monitor sent is matched to one the machine gives, at the same stamp
or a few later.
"""
from collision_monitor.msg import CollisionEvent, PairState

WARNING = 0.05  # the node's thresholds by default (docs/node.md)
CONTACT = 0.0
HYSTERESIS = 0.005
MAX_LAG = 4  # stamps by which an event may come late: a check that comes late passes over one
BEGIN = {PairState.WARNING: CollisionEvent.WARNING_BEGIN,
         PairState.COLLISION: CollisionEvent.COLLISION_BEGIN}
END = {PairState.WARNING: CollisionEvent.WARNING_END,
       PairState.COLLISION: CollisionEvent.COLLISION_END}


def key(a, b):
    """A pair of body ids in the order the oracle keeps them."""
    return (a, b) if a < b else (b, a)


def next_status(prev, d):
    """The status at distance d after `prev`: thresholds with hysteresis (a status is left once
    past its threshold by HYSTERESIS)."""
    if prev == PairState.COLLISION and d <= CONTACT + HYSTERESIS:
        return PairState.COLLISION
    if d <= CONTACT:
        return PairState.COLLISION
    if prev != PairState.CLEAR:
        return PairState.WARNING if d < WARNING + HYSTERESIS else PairState.CLEAR
    return PairState.WARNING if d < WARNING else PairState.CLEAR


def run(pair, status, stamps, distance):
    """The machine on `pair` from `status` over `stamps` (in order), distance(t) the pair's
    distance at stamp t: the events it gives, [(stamp, pair, type)], and {stamp: status}."""
    events, at = [], {}
    for t in stamps:
        new = next_status(status, distance(t))
        at[t] = new
        if new != status:
            if status != PairState.CLEAR:
                events.append((t, pair, END[status]))
            if new != PairState.CLEAR:
                events.append((t, pair, BEGIN[new]))
            status = new
    return events, at


class Timeline:
    """A run's stamps in order (those of /tf, which the monitor's checks see), to count by how
    many stamps an event comes after the oracle's."""

    def __init__(self, stamps):
        self.stamps = sorted(stamps)
        self.index = {t: i for i, t in enumerate(self.stamps)}

    def lag(self, item, others):
        """Stamps from the latest of `others` that is the same event as `item` (stamp, pair,
        type, ...) at or before it, to it (0: the same stamp), or None if there is none."""
        found = [self.index[item[0]] - self.index[o[0]] for o in others
                 if o[1:3] == item[1:3] and item[0] in self.index and o[0] in self.index and
                 self.index[item[0]] >= self.index[o[0]]]
        return min(found) if found else None

    def sent(self, predicted, actual, max_lag):
        """Whether one of the `actual` events is the `predicted` one, at most max_lag late."""
        return any(n is not None and n <= max_lag for n in
                   (self.lag(a, [predicted]) for a in actual))
