#!/usr/bin/python3
"""Stale-scan stop time of oldbf_node (the latency is latency_probe.py's).

    stale_scan.py NS SECONDS
Publishes open-space scans (stamped now) on NS/scan at 9.3 Hz for SECONDS,
then stops. Prints JSON with:
  stop_delay_s   time from the last scan's stamp to the first zero cmd_vel after it
  commands_while_fresh  non-zero commands received while scans flowed
"""
import json
import math
import sys
import time

import rospy
from geometry_msgs.msg import Twist
from sensor_msgs.msg import LaserScan

ns, seconds = sys.argv[1].rstrip("/"), float(sys.argv[2])
rospy.init_node("stale_scan_probe", anonymous=True, disable_signals=True)
events = {"last_stamp": None, "stop_at": None, "moving": 0}


def on_cmd(m):
    now = time.time()
    if events["last_stamp"] is None:
        if m.linear.x != 0.0:
            events["moving"] += 1
    elif events["stop_at"] is None and m.linear.x == 0.0 and m.angular.z == 0.0:
        events["stop_at"] = now


rospy.Subscriber(ns + "/cmd_vel", Twist, on_cmd)
pub = rospy.Publisher(ns + "/scan", LaserScan, queue_size=1)
time.sleep(1.5)  # connections
n = 360
scan = LaserScan(angle_min=-math.pi, angle_increment=2 * math.pi / n, angle_max=math.pi - 2 * math.pi / n,
                 scan_time=0.1, range_min=0.12, range_max=3.5, ranges=[float("inf")] * n)
scan.header.frame_id = "laser"
end = time.time() + seconds
last = None
while time.time() < end:
    now = rospy.Time.from_sec(time.time())
    scan.header.stamp = now
    pub.publish(scan)
    last = now
    time.sleep(1 / 9.3)
events["last_stamp"] = last.to_sec()
time.sleep(2.0)
print(json.dumps({
    "stop_delay_s": None if events["stop_at"] is None else round(events["stop_at"] - events["last_stamp"], 3),
    "commands_while_fresh": events["moving"],
}))
