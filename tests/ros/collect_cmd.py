#!/usr/bin/python3
"""Collects geometry_msgs/Twist messages on TOPIC for SECONDS; prints JSON:
count, non-finite count, non-zero count, max |linear.x|, max |angular.z|."""
import json
import math
import sys
import time

import rospy
from geometry_msgs.msg import Twist

topic, seconds = sys.argv[1], float(sys.argv[2])
rospy.init_node("collect_cmd", anonymous=True, disable_signals=True)
stats = {"count": 0, "non_finite": 0, "non_zero": 0, "max_v": 0.0, "max_w": 0.0}


def on_cmd(m):
    v, w = m.linear.x, m.angular.z
    stats["count"] += 1
    if not (math.isfinite(v) and math.isfinite(w)):
        stats["non_finite"] += 1
        return
    if v != 0.0 or w != 0.0:
        stats["non_zero"] += 1
    stats["max_v"] = max(stats["max_v"], abs(v))
    stats["max_w"] = max(stats["max_w"], abs(w))


rospy.Subscriber(topic, Twist, on_cmd)
time.sleep(seconds)
print(json.dumps(stats))
