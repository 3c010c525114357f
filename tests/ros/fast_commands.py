#!/usr/bin/python3
"""An upstream command at a high rate on the wall clock must never look like
a clock jump to the node.

    fast_commands.py NS RATE_HZ SECONDS
Publishes NS/cmd_vel_in (0.1 m/s forward) at RATE_HZ and open-space scans at
10 Hz on NS/scan for SECONDS, and watches NS/oldbf_node/state. Prints JSON:
commands published and the rate reached, states received, states whose stop
reason names a clock jump, and states with a zero command (open space: the
upstream command passes, so any zero is an invented stop).
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

ns, rate_hz, seconds = sys.argv[1].rstrip("/"), float(sys.argv[2]), float(sys.argv[3])
rospy.init_node("fast_commands_probe", anonymous=True, disable_signals=True)
lock = threading.Lock()
stats = {"published": 0, "states": 0, "clock_jump": 0, "zero": 0, "reasons": {}}
started = threading.Event()


def on_state(m):
    if not started.is_set():
        return
    with lock:
        stats["states"] += 1
        if "clock" in m.stop_reason:
            stats["clock_jump"] += 1
        if m.cmd.linear.x == 0.0:
            stats["zero"] += 1
            stats["reasons"][m.stop_reason or "(none)"] = stats["reasons"].get(m.stop_reason or "(none)", 0) + 1


rospy.Subscriber(ns + "/oldbf_node/state", BarrierState, on_state, queue_size=5000, tcp_nodelay=True)
scan_pub = rospy.Publisher(ns + "/scan", LaserScan, queue_size=1)
cmd_pub = rospy.Publisher(ns + "/cmd_vel_in", Twist, queue_size=1, tcp_nodelay=True)
N = 360
scan = LaserScan(angle_min=-math.pi, angle_increment=2 * math.pi / N, angle_max=math.pi - 2 * math.pi / N,
                 scan_time=0.1, range_min=0.12, range_max=3.5, ranges=[float("inf")] * N)
scan.header.frame_id = "laser"
done = threading.Event()


def scans():
    while not done.is_set():
        scan.header.stamp = rospy.Time.from_sec(time.time())
        scan_pub.publish(scan)
        time.sleep(0.1)


time.sleep(1.5)  # connections
threading.Thread(target=scans, daemon=True).start()
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
done.set()
time.sleep(0.5)
with lock:
    stats["rate_hz"] = round(stats["published"] / elapsed, 1)
    print(json.dumps(stats))
