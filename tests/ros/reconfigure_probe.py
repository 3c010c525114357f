#!/usr/bin/python3
"""dynamic_reconfigure of oldbf_node through Debian's Python client
(dynamic_reconfigure.client, what rqt_reconfigure and dynparam use), and the
filter's behaviour before and after.

    reconfigure_probe.py NS

Needs oldbf_node in NS with the constant nominal (0.15 m/s ahead). An
"approach" first runs the robot up to speed on scans of a far wall (2.5 m,
beyond d_act), then publishes scans of a straight wall dead ahead (±60°) at
a distance falling from 1.0 m to 0.3 m in 1 cm steps, and reads for each
scan the command computed from it (the ~state carrying its stamp): the stop
distance is the wall distance of the first scan whose command has no forward
speed. The run-up matters: from rest the base may gain only accel x the time
since the last command, and the node also ticks between scans, so a scan
that comes just after a tick gets a command of about 0 m/s wherever the wall
is.

Steps: read the configuration and the descriptions; approach with the
running d_safe; set barrier.d_safe_m = 0.4 and read it back (answer,
~parameter_updates, parameter server); approach again; set 30 (out of range)
and then a request with one valid and one invalid value: both refused, the
running values kept and still in force. Prints JSON; exits 1 if the client
failed (the shell test checks the figures).
"""
import json
import math
import sys
import threading
import time

import rospy
from dynamic_reconfigure.client import Client
from oldbf_ros.msg import BarrierState
from sensor_msgs.msg import LaserScan

ns = sys.argv[1].rstrip("/")
node = ns + "/oldbf_node"
rospy.init_node("reconfigure_probe", anonymous=True, disable_signals=True)
lock = threading.Lock()
states = {}


def on_state(m):
    with lock:
        states.setdefault(m.scan_stamp.to_nsec(), (m.cmd.linear.x, m.h))


rospy.Subscriber(node + "/state", BarrierState, on_state, tcp_nodelay=True)
pub = rospy.Publisher(ns + "/scan", LaserScan, queue_size=10)
client = Client(node, timeout=15)
time.sleep(1.0)

n = 360
scan = LaserScan(angle_min=-math.pi, angle_increment=2 * math.pi / n, angle_max=math.pi - 2 * math.pi / n,
                 scan_time=0.05, range_min=0.12, range_max=3.5)
scan.header.frame_id = "laser"


def command_for_wall(d):
    """Publishes one scan with a wall d m ahead; the (v, h) computed from it.

    A straight wall across the front (bearings within ±60°, range d / cos φ):
    at least 1 m wide, so the node's tracker never takes it for a person (a
    narrow slab that jumps 1 cm per scan, faster than the robot drives, is
    rightly treated as a mover coming at the robot, and then the stop
    distance is about the mover, not d_safe).
    """
    ranges = [float("inf")] * n
    for i in range(n):
        phi = scan.angle_min + i * scan.angle_increment
        if abs(phi) <= math.radians(60.0) + 1e-9:
            ranges[i] = d / math.cos(phi)
    scan.ranges = ranges
    scan.header.stamp = rospy.Time.from_sec(time.time())
    stamp = scan.header.stamp.to_nsec()
    pub.publish(scan)
    deadline = time.time() + 2.0
    while time.time() < deadline:
        with lock:
            for key, value in states.items():
                if abs(key - stamp) < 10_000:
                    return value
        time.sleep(0.005)
    return None


def run_up():
    """Scans of a wall 2.5 m ahead until the command goes at least 0.1 m/s."""
    for _ in range(50):
        r = command_for_wall(2.5)
        time.sleep(0.04)
        if r is not None and r[0] >= 0.1:
            return True
    return False


def approach():
    """Wall distance (m) of the first scan whose command has no forward speed,
    the robot coming on at speed (None if it never got going)."""
    missing = 0
    if not run_up():
        return None, missing
    for cm in range(100, 29, -1):
        r = command_for_wall(cm / 100.0)
        time.sleep(0.04)
        if r is None:
            missing += 1
            continue
        if r[0] <= 1e-3:
            return cm / 100.0, missing
    return None, missing


def d_safe(cfg):
    return None if cfg is None else cfg.get("barrier.d_safe_m")


out = {}
cfg = client.get_configuration(timeout=10)
descr = {d["name"]: d for d in client.get_parameter_descriptions(timeout=10)}
dd = descr["barrier.d_safe_m"]
out["parameters"] = len(descr)
out["d_safe_description"] = {"type": dd["type"], "min": dd["min"], "max": dd["max"], "default": dd["default"]}
out["d_safe_initial"] = d_safe(cfg)
out["stop_at_initial_m"], miss1 = approach()

answer = client.update_configuration({"barrier.d_safe_m": 0.4})
out["d_safe_answer"] = d_safe(answer)
time.sleep(0.5)
out["d_safe_read_back"] = d_safe(client.get_configuration(timeout=5))
out["d_safe_param_server"] = rospy.get_param(node + "/barrier/d_safe_m")
out["stop_at_0.4_m"], miss2 = approach()

answer = client.update_configuration({"barrier.d_safe_m": 30.0})
out["refused_answer"] = d_safe(answer)
answer = client.update_configuration({"dtcbf.gamma": 0.5, "barrier.d_safe_m": -1.0})
out["refused_pair_answer"] = [answer.get("dtcbf.gamma"), d_safe(answer)]
time.sleep(0.5)
cfg = client.get_configuration(timeout=5)
out["after_refusals"] = [cfg.get("dtcbf.gamma"), d_safe(cfg)]
out["after_refusals_param_server"] = rospy.get_param(node + "/barrier/d_safe_m")
# Still in force: a wall at 0.5 m is inside r + d_safe = 0.578 m. The robot may
# still be moving (the node ticks on between scans), so the wall is shown for
# half a second, time for the base to brake, and the last command is taken.
for _ in range(12):
    r = command_for_wall(0.5)
    time.sleep(0.04)
out["v_at_0.5_m_after_refusals"] = None if r is None else r[0]
out["scans_without_state"] = miss1 + miss2
print(json.dumps(out))
