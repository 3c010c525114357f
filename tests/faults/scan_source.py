#!/usr/bin/env python3
"""Fault-injecting LaserScan source for tests/vm/faults_guest.sh.

  scan_source.py TOPIC MODE_FILE EVENTS_FILE [RATE_HZ]

Publishes 360-beam open-space scans (every beam a return at 3.0 m, outside
d_act, so the filter passes the nominal command) on TOPIC at RATE_HZ (10).
The mode is re-read from MODE_FILE before each scan; the first scan sent in
a new mode is the moment of injection, written to EVENTS_FILE as a JSON line
{"mode": ..., "t": time.time()} (the same realtime clock as candump's stamps).

Modes:
  ok           stamp = now
  frozen       the last good stamp, repeated (a frozen driver)
  out_of_order stamp 0.2 s older than the newest sent, inside the node's
               scan_timeout, going back 1 ms per scan (reordered delivery)
  nan inf zero every range NaN / +inf / 0.0, stamp = now
  silent       nothing published
Paced with time.sleep, not rospy.Rate, which raises when the clock steps back.
"""
import json
import math
import sys
import time

import rospy
from sensor_msgs.msg import LaserScan

topic, mode_file, events_file = sys.argv[1], sys.argv[2], sys.argv[3]
rate_hz = float(sys.argv[4]) if len(sys.argv) > 4 else 10.0
N = 360
RANGES = {"nan": float("nan"), "inf": float("inf"), "zero": 0.0}

rospy.init_node("fault_scan_source", anonymous=True, disable_signals=True)
pub = rospy.Publisher(topic, LaserScan, queue_size=1)
events = open(events_file, "a", buffering=1)
scan = LaserScan()
scan.header.frame_id = "laser"
scan.angle_min = -math.pi
scan.angle_increment = 2 * math.pi / N
scan.angle_max = scan.angle_min + scan.angle_increment * (N - 1)
scan.range_min = 0.12
scan.range_max = 3.5
mode = None
newest = None  # newest stamp sent (rospy.Time)
back = 0
period = 1.0 / rate_hz
next_t = time.monotonic()
while not rospy.is_shutdown():
    try:
        with open(mode_file) as f:
            want = f.read().strip() or "ok"
    except OSError:
        want = "ok"
    if want == "quit":
        break
    if want != "silent":
        now = rospy.Time.from_sec(time.time())
        if want == "frozen" and newest is not None:
            stamp = newest
        elif want == "out_of_order" and newest is not None:
            back += 1
            stamp = newest - rospy.Duration.from_sec(0.2 + 0.001 * back)
        else:
            stamp = now
            back = 0
        scan.header.stamp = stamp
        scan.ranges = [RANGES.get(want, 3.0)] * N
        pub.publish(scan)
        if want not in ("frozen", "out_of_order"):
            newest = stamp
    if want != mode:
        events.write(json.dumps({"mode": want, "t": time.time()}) + "\n")
        mode = want
    next_t += period
    delay = next_t - time.monotonic()
    if delay < 0:
        next_t = time.monotonic()
    else:
        time.sleep(delay)
