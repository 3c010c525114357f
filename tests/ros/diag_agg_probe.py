#!/usr/bin/python3
"""Waits for /diagnostics_agg to show statuses under given paths (tests/ros_group.sh `diagnostics`).

    diag_agg_probe.py SECONDS BRIDGE_STATUS_NAME PATH=HARDWARE_ID...
Publishes a stand-in for the CAN bridge's status, named BRIDGE_STATUS_NAME
exactly as can_bridge_node names its own ("<node>: CAN bridge"; the bridge
itself needs SocketCAN, which the ros group's kernel lacks), at 1 Hz on
/diagnostics. Succeeds when one /diagnostics_agg message holds, for every
PATH=HARDWARE_ID, a status named PATH with that hardware_id. Prints JSON:
the statuses under /Base of the last message, [name, level, hardware_id,
message], and whether all were found.
"""
import json
import sys
import time

import rospy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus

seconds, bridge_name = float(sys.argv[1]), sys.argv[2]
want = dict(a.split("=", 1) for a in sys.argv[3:])
rospy.init_node("diag_agg_probe", anonymous=True, disable_signals=True)
last = {"statuses": [], "found": False}


def on_agg(m):
    by_name = {s.name: s for s in m.status}
    last["statuses"] = [[s.name, s.level, s.hardware_id, s.message] for s in m.status if s.name.startswith("/Base")]
    if all(p in by_name and by_name[p].hardware_id == h for p, h in want.items()):
        last["found"] = True


rospy.Subscriber("/diagnostics_agg", DiagnosticArray, on_agg)
pub = rospy.Publisher("/diagnostics", DiagnosticArray, queue_size=1)
end = time.time() + seconds
while time.time() < end and not last["found"]:
    a = DiagnosticArray()
    a.header.stamp = rospy.Time.from_sec(time.time())
    a.status.append(DiagnosticStatus(level=DiagnosticStatus.OK, name=bridge_name, message="Running",
                                     hardware_id="can0"))
    pub.publish(a)
    time.sleep(1.0)
print(json.dumps(last))
sys.exit(0 if last["found"] else 1)
