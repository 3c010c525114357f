#!/usr/bin/python3
"""Waits for oldbf_sim_node's latched ~summary to say done; prints its JSON.

    wait_summary.py TOPIC TIMEOUT_S
Exit 0 when done arrived (whatever the result), 1 on timeout.
"""
import json
import sys
import time

import rospy
from std_msgs.msg import String

topic, timeout = sys.argv[1], float(sys.argv[2])
rospy.init_node("wait_summary", anonymous=True, disable_signals=True)
latest = {}


def on_summary(msg):
    latest["s"] = json.loads(msg.data)


rospy.Subscriber(topic, String, on_summary)
deadline = time.time() + timeout
while time.time() < deadline:
    s = latest.get("s")
    if s and s.get("done"):
        print(json.dumps(s))
        sys.exit(0)
    time.sleep(0.5)
print(json.dumps(latest.get("s", {})))
sys.exit(1)
