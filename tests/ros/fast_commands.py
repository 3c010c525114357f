#!/usr/bin/python3
"""An upstream command at a high rate on the wall clock must never look like
a clock jump to the node.

    fast_commands.py NS RATE_HZ SECONDS
Publishes NS/cmd_vel_in (0.1 m/s forward) at RATE_HZ for SECONDS while
open-space scans arrive at 10 Hz on NS/scan from another process (so a busy
command loop cannot starve them), and watches NS/oldbf_node/state. Prints
JSON: commands published and the rate reached, states received, states whose
stop reason names a clock jump, and states with a zero command, split into
those stopped for a late scan (`zero_late_scan`: the scans really were late,
a correct stop), those whose nominal was zero after the node had had no live
upstream for the node's 0.5 s cmd_in_timeout (`zero_nominal`: no state with
the 0.1 m/s nominal for that long on the node's own stamps, so it really did
not process a command in that time, which a loaded machine can do; the
filter passed the zero it was given) and all others (`zero`: open space and
a live upstream, so any other zero is a stop the node invented), with every
stop reason seen.
"""
import json
import re
import sys
import threading
import time

import rospy
from geometry_msgs.msg import Twist
from oldbf_ros.msg import BarrierState

ns, rate_hz, seconds = sys.argv[1].rstrip("/"), float(sys.argv[2]), float(sys.argv[3])
rospy.init_node("fast_commands_probe", anonymous=True, disable_signals=True)
lock = threading.Lock()
stats = {"published": 0, "states": 0, "clock_jump": 0, "zero": 0, "zero_late_scan": 0, "zero_nominal": 0, "reasons": {}}
started = threading.Event()
CMD_IN_TIMEOUT_S = 0.5  # the node's default node.cmd_in_timeout_s
last_live = [None]  # stamp of the last state with the upstream's nominal (s)


def on_state(m):
    if not started.is_set():
        return
    stamp = m.header.stamp.to_sec()
    with lock:
        if m.nominal.linear.x != 0.0:
            last_live[0] = stamp
        stats["states"] += 1
        if "clock" in m.stop_reason:
            stats["clock_jump"] += 1
        if m.cmd.linear.x == 0.0:
            late = m.stop_reason.startswith("scan rejected: scan is") and "old (timeout" in m.stop_reason
            stale_upstream = (not m.stop_reason and m.nominal.linear.x == 0.0
                              and last_live[0] is not None and stamp - last_live[0] >= CMD_IN_TIMEOUT_S)
            stats["zero_late_scan" if late else "zero_nominal" if stale_upstream else "zero"] += 1
            kind = re.sub(r"[0-9.]+ s\b", "N s", m.stop_reason) or ("(zero nominal)" if stale_upstream else "(none)")
            stats["reasons"][kind] = stats["reasons"].get(kind, 0) + 1


rospy.Subscriber(ns + "/oldbf_node/state", BarrierState, on_state, queue_size=5000, tcp_nodelay=True)
cmd_pub = rospy.Publisher(ns + "/cmd_vel_in", Twist, queue_size=1, tcp_nodelay=True)
time.sleep(1.5)  # connections
cmd = Twist()
cmd.linear.x = 0.1
# A second of commands before counting: the node starts from "no upstream yet".
end_warm = time.time() + 1.0
while time.time() < end_warm:
    cmd_pub.publish(cmd)
    time.sleep(1.0 / rate_hz)
started.set()
t0 = time.time()
nxt = t0
period = 1.0 / rate_hz
while time.time() - t0 < seconds:
    cmd_pub.publish(cmd)
    stats["published"] += 1
    nxt += period
    delay = nxt - time.time()
    if delay > 0:
        time.sleep(delay)
elapsed = time.time() - t0
time.sleep(0.5)
with lock:
    stats["rate_hz"] = round(stats["published"] / elapsed, 1)
    print(json.dumps(stats))
