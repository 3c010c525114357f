#!/usr/bin/python3
"""Stale-scan stop time and scan -> command latency of oldbf_node.

    stale_scan.py NS SECONDS
Publishes open-space scans (stamped now) on NS/scan at 9.3 Hz for SECONDS,
then stops. Prints JSON with:
  stop_delay_s   time from the last scan's stamp to the first zero cmd_vel after it
  latency_ms     p50/p99/max from a scan's publication to the first ~state
                 message that used it (~state carries the scan's stamp), over
                 loopback; the node runs on a timer, so this includes up to
                 one control period of waiting for the next tick
  commands_while_fresh  non-zero commands received while scans flowed
"""
import json
import math
import sys
import time

import rospy
from geometry_msgs.msg import Twist
from oldbf_ros.msg import BarrierState
from sensor_msgs.msg import LaserScan

ns, seconds = sys.argv[1].rstrip("/"), float(sys.argv[2])
rospy.init_node("stale_scan_probe", anonymous=True, disable_signals=True)
published = {}  # stamp (ns) -> wall time of publication
latencies = []
seen = set()
events = {"last_stamp": None, "stop_at": None, "moving": 0}


def on_state(m):
    # The node carries stamps as f64 seconds (~0.24 us resolution today): match within 10 us.
    arrived = time.time()
    stamp = m.scan_stamp.to_nsec()
    for key, at in list(published.items())[-30:]:
        if abs(key - stamp) < 10_000 and key not in seen:
            seen.add(key)
            latencies.append(arrived - at)
            break


def on_cmd(m):
    now = time.time()
    if events["last_stamp"] is None:
        if m.linear.x != 0.0:
            events["moving"] += 1
    elif events["stop_at"] is None and m.linear.x == 0.0 and m.angular.z == 0.0:
        events["stop_at"] = now


rospy.Subscriber(ns + "/oldbf_node/state", BarrierState, on_state)
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
    published[now.to_nsec()] = time.time()
    pub.publish(scan)
    last = now
    # 9.3 Hz, not 10: against the node's 10 Hz timer the phase then sweeps
    # through a whole control period, so the latency percentiles cover it.
    time.sleep(1 / 9.3)
events["last_stamp"] = last.to_sec()
time.sleep(2.0)
lat = sorted(latencies)


def pct(p):
    return round(1000 * lat[min(len(lat) - 1, int(p * len(lat)))], 1) if lat else None


print(json.dumps({
    "stop_delay_s": None if events["stop_at"] is None else round(events["stop_at"] - events["last_stamp"], 3),
    "latency_ms": {"p50": pct(0.5), "p99": pct(0.99), "max": round(1000 * lat[-1], 1) if lat else None, "n": len(lat)},
    "commands_while_fresh": events["moving"],
}))
