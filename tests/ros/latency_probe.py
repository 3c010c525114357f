#!/usr/bin/python3
"""Scan -> cmd_vel latency of oldbf_node over loopback, and proof that each
command was computed from the scan it is timed against.

    latency_probe.py NS SCANS [RATE_HZ]

Publishes SCANS scans on NS/scan (stamped now) at RATE_HZ (default 9.3, so
that against a 10 Hz control timer the phase sweeps a whole period), that
alternate between two kinds with visibly different safe commands under the
constant nominal (0.15 m/s ahead):
  open    nothing in range          -> linear.x = 0.15 (the nominal passes)
  ahead   a wall 0.3 m dead ahead   -> linear.x <= 0 (inside r + d_safe)
Each scan differs in kind from the one before, so the first cmd_vel of its
kind after its publication can only have come from it (or from a later scan,
which the window below rules out): latency = that message's arrival minus
the publication time.

The node's ~state (oldbf_ros/BarrierState) carries the stamp of the scan a
command used and what the node saw in it: a scan counts as "used" when a
~state with its stamp arrived whose h says the scan's kind (+inf for open,
below 0 for ahead). That is the assertion; the latency figures are reported,
not asserted. (The command of that ~state need not have the kind yet: two
ticks a millisecond apart leave the base's dynamic window a millisecond's
change.)

Prints JSON: cmd_latency_ms and state_latency_ms {p50, p99, max, n},
scans, used (scans with a matching ~state), matched (scans whose cmd_vel was
found), wrong_kind (~state of a scan that saw the other kind).
"""
import json
import math
import sys
import threading
import time

import rospy
from geometry_msgs.msg import Twist
from oldbf_ros.msg import BarrierState
from sensor_msgs.msg import LaserScan

ns, count = sys.argv[1].rstrip("/"), int(sys.argv[2])
rate_hz = float(sys.argv[3]) if len(sys.argv) > 3 else 9.3
rospy.init_node("latency_probe", anonymous=True, disable_signals=True)
lock = threading.Lock()
cmds = []  # (arrival, linear.x)
states = {}  # scan stamp (ns) -> (arrival, h, cmd linear.x, tier, state) of the first ~state that used it


def kind_of(v):
    if v > 0.1:
        return "open"
    if v <= 0.0:
        return "ahead"
    return None


def scene_of(h):
    """What the node saw, from the ~state's h: nothing (open) or the wall inside r + d_safe."""
    if math.isinf(h):
        return "open"
    if h < 0.0:
        return "ahead"
    return None


def on_cmd(m):
    t = time.time()
    with lock:
        cmds.append((t, m.linear.x))


def on_state(m):
    t = time.time()
    stamp = m.scan_stamp.to_nsec()
    with lock:
        states.setdefault(stamp, (t, m.h, m.cmd.linear.x, m.tier, m.doaa_state_name))


rospy.Subscriber(ns + "/cmd_vel", Twist, on_cmd, tcp_nodelay=True)
rospy.Subscriber(ns + "/oldbf_node/state", BarrierState, on_state, tcp_nodelay=True)
pub = rospy.Publisher(ns + "/scan", LaserScan, queue_size=1, tcp_nodelay=True)
time.sleep(1.5)  # connections

n = 360
base = LaserScan(angle_min=-math.pi, angle_increment=2 * math.pi / n, angle_max=math.pi - 2 * math.pi / n,
                 scan_time=0.1, range_min=0.12, range_max=3.5)
base.header.frame_id = "laser"
open_ranges = [float("inf")] * n
ahead_ranges = list(open_ranges)
for i in range(180 - 10, 180 + 11):
    ahead_ranges[i] = 0.3
published = []  # (stamp ns, wall time, kind)
for i in range(count):
    kind = "open" if i % 2 == 0 else "ahead"
    base.ranges = open_ranges if kind == "open" else ahead_ranges
    now = time.time()
    base.header.stamp = rospy.Time.from_sec(now)
    published.append((base.header.stamp.to_nsec(), time.time(), kind))
    pub.publish(base)
    time.sleep(1.0 / rate_hz)
time.sleep(0.5)


def stamp_match(stamp):
    # The node carries stamps as f64 seconds (~0.24 us resolution today): match within 10 us.
    for key, value in states.items():
        if abs(key - stamp) < 10_000:
            return value
    return None


cmd_lat, state_lat, wrong = [], [], []
used = matched = wrong_kind = 0
with lock:
    for i, (stamp, t, kind) in enumerate(published):
        s = stamp_match(stamp)
        if s is not None:
            state_lat.append(s[0] - t)
            if scene_of(s[1]) == kind:
                used += 1
            else:
                wrong_kind += 1
                wrong.append([kind] + list(s[1:]))
        if i == 0:
            continue  # no different kind before it
        # The window ends at the publication of the next scan of the same kind.
        end = published[i + 2][1] if i + 2 < len(published) else float("inf")
        for at, v in cmds:
            if t < at < end and kind_of(v) == kind:
                cmd_lat.append(at - t)
                matched += 1
                break


def stats(xs):
    xs = sorted(xs)
    if not xs:
        return {"p50": None, "p99": None, "max": None, "n": 0}
    pct = lambda p: round(1000 * xs[min(len(xs) - 1, int(p * len(xs)))], 2)  # noqa: E731
    return {"p50": pct(0.5), "p99": pct(0.99), "max": round(1000 * xs[-1], 2), "n": len(xs)}


print(json.dumps({
    "scans": len(published),
    "used": used,
    "matched": matched,
    "wrong_kind": wrong_kind,
    "cmd_latency_ms": stats(cmd_lat),
    "state_latency_ms": stats(state_lat),
    "cmd_vel_messages": len(cmds),
    "wrong_examples": wrong[:8],
}))
