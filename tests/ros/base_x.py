#!/usr/bin/python3
"""Keeps the robot's latest x in the odometry frame (from /tf, the
transform to base_link) in FILE, rewritten ten times a second.

    base_x.py FILE
Start it before the simulator: it then connects while the simulator starts,
and a later subscriber that is slow to connect cannot hold it up.
"""
import os
import sys
import time

import rospy
from tf2_msgs.msg import TFMessage

out = sys.argv[1]
rospy.init_node("base_x", anonymous=True, disable_signals=True)
last = [0.0]


def on_tf(m):
    for t in m.transforms:
        if t.child_frame_id == "base_link" and time.time() - last[0] >= 0.1:
            last[0] = time.time()
            with open(out + ".tmp", "w") as f:
                f.write("%.2f\n" % t.transform.translation.x)
            os.replace(out + ".tmp", out)


rospy.Subscriber("/tf", TFMessage, on_tf)
while not rospy.is_shutdown():
    time.sleep(0.5)
