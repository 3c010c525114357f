#!/usr/bin/python3
"""The node's CPU use with two scanners (issue: measure it, docs/BENCHMARKS.md).

    cpu_probe.py NS PID BEAMS RATE_HZ SECONDS
Publishes NS/front/scan and NS/rear/scan (BEAMS beams over 270 deg each, at
RATE_HZ, frames front_laser and rear_laser) of a 6 x 4 m room with a post
and a box near the robot, and NS/cmd_vel_in (0.1 m/s forward, 20 Hz); after
a 3 s warm-up, measures the CPU time of process PID (user + system, all
threads, and the way-round planner's thread `oldbf-route` alone) over
SECONDS of wall time, and counts the commands it sent. Prints JSON.
"""
import json
import math
import os
import sys
import time

import rospy
from geometry_msgs.msg import Twist
from sensor_msgs.msg import LaserScan

ns, pid, beams, rate, seconds = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), float(sys.argv[4]), float(sys.argv[5])
TICK = os.sysconf("SC_CLK_TCK")


def cpu_s(path):
    with open(path) as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICK  # utime, stime


def route_thread_s():
    total = 0.0
    for tid in os.listdir(f"/proc/{pid}/task"):
        try:
            with open(f"/proc/{pid}/task/{tid}/comm") as f:
                if f.read().strip() == "oldbf-route":
                    total += cpu_s(f"/proc/{pid}/task/{tid}/stat")
        except OSError:
            pass
    return total


def room_ranges(x0, yaw):
    """Ranges from a laser at (x0, 0) heading yaw in a 6 x 4 m room centred on
    the robot, a post (r 0.1 m) at (1.0, 0.6) and a box face at y = -0.8."""
    out = []
    for i in range(beams):
        a = yaw - 0.75 * math.pi + 1.5 * math.pi * i / (beams - 1)
        dx, dy = math.cos(a), math.sin(a)
        best = float("inf")
        for wall, d in (((3.0 - x0), dx), ((-3.0 - x0), dx)):
            if d != 0 and wall / d > 0:
                best = min(best, wall / d)
        for wall, d in ((2.0, dy), (-2.0, dy)):
            if d != 0 and wall / d > 0:
                best = min(best, wall / d)
        if dy < 0 and -0.8 / dy > 0:
            t = -0.8 / dy
            if -0.5 <= x0 + t * dx <= 0.5:
                best = min(best, t)
        cx, cy = 1.0 - x0, 0.6
        b = cx * dx + cy * dy
        c = cx * cx + cy * cy - 0.01
        disc = b * b - c
        if disc >= 0 and b - math.sqrt(disc) > 0:
            best = min(best, b - math.sqrt(disc))
        out.append(best if best < 10.0 else float("inf"))
    return out


def scan(frame, ranges):
    m = LaserScan()
    m.header.frame_id = frame
    m.angle_min, m.angle_max = -0.75 * math.pi, 0.75 * math.pi
    m.angle_increment = 1.5 * math.pi / (beams - 1)
    m.scan_time, m.range_min, m.range_max = 1.0 / rate, 0.05, 10.0
    m.ranges = ranges
    return m


rospy.init_node("cpu_probe", anonymous=True, disable_signals=True)
front_pub = rospy.Publisher(ns + "/front/scan", LaserScan, queue_size=2)
rear_pub = rospy.Publisher(ns + "/rear/scan", LaserScan, queue_size=2)
cmd_pub = rospy.Publisher(ns + "/cmd_vel_in", Twist, queue_size=2)
commands = [0]
rospy.Subscriber(ns + "/cmd_vel", Twist, lambda m: commands.__setitem__(0, commands[0] + 1))
front = scan("front_laser", room_ranges(0.2, 0.0))
rear = scan("rear_laser", room_ranges(-0.2, math.pi))
cmd = Twist()
cmd.linear.x = 0.1
time.sleep(1.0)
start = time.time()
period = 1.0 / rate
k = 0
measured = None
while True:
    now = time.time()
    if now - start >= 3.0 and measured is None:
        measured = (now, cpu_s(f"/proc/{pid}/stat"), route_thread_s(), commands[0])
    if measured is not None and now - measured[0] >= seconds:
        break
    stamp = rospy.Time.now()
    front.header.stamp = stamp
    front_pub.publish(front)
    # The rear scanner half a period later: two unsynchronised LiDARs.
    time.sleep(period / 2)
    rear.header.stamp = rospy.Time.now()
    rear_pub.publish(rear)
    if k % max(1, int(rate / 20)) == 0:
        cmd_pub.publish(cmd)
    k += 1
    time.sleep(max(0.0, start + k * period - time.time()))
wall = time.time() - measured[0]
total = cpu_s(f"/proc/{pid}/stat") - measured[1]
route = route_thread_s() - measured[2]
print(json.dumps({
    "beams": beams, "rate_hz": rate, "seconds": round(wall, 1),
    "node_cpu_percent": round(100 * total / wall, 1),
    "route_thread_cpu_percent": round(100 * route / wall, 1),
    "scans_per_s": round(2 * k / (time.time() - start), 1),
    "commands_per_s": round((commands[0] - measured[3]) / wall, 1),
}))
