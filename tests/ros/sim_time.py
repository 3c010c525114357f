#!/usr/bin/python3
"""The node under /use_sim_time: it must take the first scans (not drop them
by subscribing again when simulated time first jumps from 0) and, once /clock
stops, still exit on Ctrl-C.

    sim_time.py NS SECONDS
Publishes /clock (from 1000 s, at real speed, every 10 ms), scans stamped in
simulated time at 10 Hz on NS/scan and cmd_vel_in (0.1 m/s) at 20 Hz, for
SECONDS; then stops /clock for good. Prints JSON: when the first scan was
published and when the first command computed from a scan (~state with a
scan stamp) came back, both in simulated time, and the states received.
"""
import json
import math
import sys
import threading
import time

import rospy
from geometry_msgs.msg import Twist
from oldbf_ros.msg import BarrierState
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan

ns, seconds = sys.argv[1].rstrip("/"), float(sys.argv[2])
rospy.init_node("sim_time_probe", anonymous=True, disable_signals=True)
clock_pub = rospy.Publisher("/clock", Clock, queue_size=10)
T0 = 1000.0
wall0 = time.time()
sim = {"t": T0}
stats = {"first_scan_s": None, "first_scan_state_s": None, "states": 0, "states_with_scan": 0}
lock = threading.Lock()


def on_state(m):
    with lock:
        stats["states"] += 1
        if m.scan_stamp.to_sec() > 0:
            stats["states_with_scan"] += 1
            if stats["first_scan_state_s"] is None:
                stats["first_scan_state_s"] = round(m.header.stamp.to_sec(), 3)


rospy.Subscriber(ns + "/oldbf_node/state", BarrierState, on_state, queue_size=100)
scan_pub = rospy.Publisher(ns + "/scan", LaserScan, queue_size=1)
cmd_pub = rospy.Publisher(ns + "/cmd_vel_in", Twist, queue_size=1)
N = 360
scan = LaserScan(angle_min=-math.pi, angle_increment=2 * math.pi / N, angle_max=math.pi - 2 * math.pi / N,
                 scan_time=0.1, range_min=0.12, range_max=3.5, ranges=[float("inf")] * N)
scan.header.frame_id = "laser"
cmd = Twist()
cmd.linear.x = 0.1
# The node is started by the test before this probe, so simulated time has
# stood at 0 since its start; wait for its subscriptions, then start the clock.
deadline = time.time() + 20
while scan_pub.get_num_connections() == 0 and time.time() < deadline:
    time.sleep(0.1)
k = 0
start = time.time()
while time.time() - start < seconds:
    t = T0 + (time.time() - start)
    clock_pub.publish(Clock(clock=rospy.Time.from_sec(t)))
    if k % 10 == 0:
        scan.header.stamp = rospy.Time.from_sec(t)
        scan_pub.publish(scan)
        if stats["first_scan_s"] is None:
            stats["first_scan_s"] = round(t, 3)
    if k % 5 == 0:
        cmd_pub.publish(cmd)
    k += 1
    time.sleep(0.01)
with lock:
    print(json.dumps(stats), flush=True)
