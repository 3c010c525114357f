#!/usr/bin/env python3
"""Records /diagnostics as JSON lines {t, name, level, message, values} for
the faults analysis (t = time.time() on arrival).

  record_diag.py OUT_FILE
"""
import json
import sys
import time

import rospy
from diagnostic_msgs.msg import DiagnosticArray

out = open(sys.argv[1], "a", buffering=1)


def on_diag(m):
    t = time.time()
    for s in m.status:
        out.write(json.dumps({"t": t, "name": s.name, "level": ord(s.level) if isinstance(s.level, bytes) else s.level,
                              "message": s.message, "values": {kv.key: kv.value for kv in s.values}}) + "\n")


rospy.init_node("fault_diag_recorder", anonymous=True, disable_signals=True)
rospy.Subscriber("/diagnostics", DiagnosticArray, on_diag, queue_size=50)
while not rospy.is_shutdown():
    time.sleep(0.2)
