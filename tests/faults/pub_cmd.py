#!/usr/bin/env python3
"""Absurd commands straight to the bridge (tests/vm/faults_guest.sh).

  pub_cmd.py TOPIC EVENTS_FILE

Publishes geometry_msgs/Twist on TOPIC at 20 Hz: 3 s of linear.x = 100 m/s
with angular.z = 50 rad/s, then 1.5 s of linear.x = NaN, then 1.5 s of
angular.z = +inf. Each phase's start is written to EVENTS_FILE as a JSON line
{"mode": "cmd_absurd" | "cmd_nan" | "cmd_inf" | "cmd_end", "t": time.time()}.
"""
import json
import sys
import time

import rospy
from geometry_msgs.msg import Twist

topic, events_file = sys.argv[1], sys.argv[2]
rospy.init_node("fault_cmd_source", anonymous=True, disable_signals=True)
pub = rospy.Publisher(topic, Twist, queue_size=1)
events = open(events_file, "a", buffering=1)
# Wait until the bridge is connected, so the first phase is not lost.
deadline = time.time() + 20
while pub.get_num_connections() == 0 and time.time() < deadline:
    time.sleep(0.05)
for mode, v, w, seconds in (
    ("cmd_absurd", 100.0, 50.0, 3.0),
    ("cmd_nan", float("nan"), 0.0, 1.5),
    ("cmd_inf", 0.1, float("inf"), 1.5),
):
    events.write(json.dumps({"mode": mode, "t": time.time()}) + "\n")
    m = Twist()
    m.linear.x, m.angular.z = v, w
    end = time.time() + seconds
    while time.time() < end:
        pub.publish(m)
        time.sleep(0.05)
events.write(json.dumps({"mode": "cmd_end", "t": time.time()}) + "\n")
