#!/usr/bin/python3
"""Every command sees the last scan's whole perception (ALGORITHM §5c).

    between_scans.py NS PLANNER_HZ SECONDS
A 10 Hz LiDAR (scans on NS/scan) sees a person (a disc of radius 0.2 m) walk
straight at the robot at 0.4 m/s from 4.5 m; a planner publishes
NS/cmd_vel_in (0.1 m/s forward) at PLANNER_HZ beside it. Every tick, scan or
planner, publishes NS/oldbf_node/state. Once the person is a threat (tracked,
moving, on a collision course), every state while it is still farther than
1 m must report it. Prints JSON: states, those from ticks between scans
(same scan stamp as the state before), the ticks after the first threat and
how many of them reported none.
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

ns, planner_hz, seconds = sys.argv[1].rstrip("/"), float(sys.argv[2]), float(sys.argv[3])
rospy.init_node("between_scans_probe", anonymous=True, disable_signals=True)
N = 360
RADIUS, SPEED, START = 0.2, 0.4, 4.5
lock = threading.Lock()
stats = {"states": 0, "between": 0, "after_threat": 0, "missed": 0, "first_threat_x": None, "last_stamp": None}
person = {"x": START}


def on_state(m):
    with lock:
        stats["states"] += 1
        stamp = m.scan_stamp.to_sec()
        if stamp == stats["last_stamp"]:
            stats["between"] += 1
        stats["last_stamp"] = stamp
        x = person["x"]
        if stats["first_threat_x"] is None:
            if m.threats > 0:
                stats["first_threat_x"] = x
            return
        if x > 1.0 + RADIUS:
            stats["after_threat"] += 1
            if m.threats == 0:
                stats["missed"] += 1


rospy.Subscriber(ns + "/oldbf_node/state", BarrierState, on_state, queue_size=1000)
scan_pub = rospy.Publisher(ns + "/scan", LaserScan, queue_size=1)
cmd_pub = rospy.Publisher(ns + "/cmd_vel_in", Twist, queue_size=1)
time.sleep(1.5)  # connections


def ranges_for(cx):
    out = []
    for i in range(N):
        a = -math.pi + 2 * math.pi * i / N
        along = cx * math.cos(a)
        off2 = cx * cx - along * along
        out.append(along - math.sqrt(RADIUS * RADIUS - off2) if along > 0 and off2 <= RADIUS * RADIUS else float("inf"))
    return out


def planner():
    cmd = Twist()
    cmd.linear.x = 0.1
    period = 1.0 / planner_hz
    nxt = time.time()
    while not done.is_set():
        cmd_pub.publish(cmd)
        nxt += period
        time.sleep(max(0.0, nxt - time.time()))


done = threading.Event()
threading.Thread(target=planner, daemon=True).start()
t0 = time.time()
scan = LaserScan(angle_min=-math.pi, angle_increment=2 * math.pi / N, angle_max=math.pi - 2 * math.pi / N,
                 scan_time=0.1, range_min=0.12, range_max=3.5)
scan.header.frame_id = "laser"
while time.time() - t0 < seconds:
    now = time.time()
    with lock:
        person["x"] = START - SPEED * (now - t0)
    scan.header.stamp = rospy.Time.from_sec(now)
    scan.ranges = ranges_for(person["x"])
    scan_pub.publish(scan)
    time.sleep(0.1 - (time.time() - now) % 0.1)
done.set()
time.sleep(0.3)
with lock:
    print(json.dumps(stats))
