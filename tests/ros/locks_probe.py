#!/usr/bin/python3
"""Locks that lapse, against a running oldbf_node (tests/ros_group.sh `locks`).

    locks_probe.py NS
The node must run in NS with node/nominal_source cmd_vel_in,
node/e_stop_timeout_s 0.5 and node/disable_timeout_s 2.0. Publishes scans at
10 Hz and cmd_vel_in at 20 Hz, and e_stop (false) at 10 Hz while a phase
asks for it; watches cmd_vel, ~state and /diagnostics. Phases:
  1. no e_stop message yet: every command zero, ~state says "e_stop not heard yet"
  2. e_stop false at 10 Hz, open space, 0.1 m/s upstream: the robot moves
  3. e_stop publisher silent: a zero command 0.5 s (the timeout) after its
     last message, plus up to one tick; ~state and /diagnostics (ERROR) say
     "e_stop silent for"
  4. e_stop false again: the robot moves, without ~reset_e_stop
  5. a wall 0.3 m ahead, 0.2 m/s upstream: filtered (no forward motion);
     ~enable false: 0.2 m/s passes, /diagnostics says when it lapses; not
     renewed, filtered again (a command other than 0.2 m/s) 2.0 s after the
     call; renewed after 1.5 s, filtered again 2.0 s after the second call
Prints one JSON object with what it measured.
"""
import json
import math
import sys
import threading
import time

import rospy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Twist
from oldbf_ros.msg import BarrierState
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Bool
from std_srvs.srv import SetBool

ns = sys.argv[1].rstrip("/")
rospy.init_node("locks_probe", anonymous=True, disable_signals=True)
lock = threading.Lock()
cmds, states, diags = [], [], []
ctl = {"wall": False, "v": 0.1, "e_stop": False, "last_e_stop": None, "run": True}


def on_cmd(m):
    with lock:
        cmds.append((time.time(), m.linear.x))


def on_state(m):
    with lock:
        states.append((time.time(), m.stop_reason, m.e_stop))


def on_diag(m):
    for s in m.status:
        if s.name.startswith(ns + "/oldbf_node"):
            with lock:
                diags.append((time.time(), s.level, s.message))


rospy.Subscriber(ns + "/cmd_vel", Twist, on_cmd)
rospy.Subscriber(ns + "/oldbf_node/state", BarrierState, on_state)
rospy.Subscriber("/diagnostics", DiagnosticArray, on_diag)
scan_pub = rospy.Publisher(ns + "/scan", LaserScan, queue_size=1)
cmd_pub = rospy.Publisher(ns + "/cmd_vel_in", Twist, queue_size=1)
e_stop_pub = rospy.Publisher(ns + "/e_stop", Bool, queue_size=1)

n = 360
open_ranges = [float("inf")] * n
wall_ranges = list(open_ranges)
for i in range(170, 191):
    wall_ranges[i] = 0.3


def publish():
    k = 0
    while ctl["run"]:
        cmd = Twist()
        cmd.linear.x = ctl["v"]
        cmd_pub.publish(cmd)
        if k % 2 == 0:
            scan = LaserScan(angle_min=-math.pi, angle_increment=2 * math.pi / n,
                             angle_max=math.pi - 2 * math.pi / n, scan_time=0.1, range_min=0.12,
                             range_max=3.5, ranges=wall_ranges if ctl["wall"] else open_ranges)
            scan.header.frame_id = "laser"
            scan.header.stamp = rospy.Time.from_sec(time.time())
            scan_pub.publish(scan)
            if ctl["e_stop"]:
                ctl["last_e_stop"] = time.time()
                e_stop_pub.publish(Bool(data=False))
        k += 1
        time.sleep(0.05)


def window(items, t0, t1):
    with lock:
        return [x for x in items if t0 <= x[0] <= t1]


def first_after(items, t0, pred):
    with lock:
        return next((x[0] for x in items if x[0] >= t0 and pred(x)), None)


out = {}
threading.Thread(target=publish, daemon=True).start()
time.sleep(1.5)  # connections
# 1. Nothing heard on e_stop yet.
t = time.time()
time.sleep(1.0)
w = window(cmds, t, time.time())
s = window(states, t, time.time())
out["startup_commands"] = len(w)
out["startup_nonzero"] = sum(1 for x in w if x[1] != 0.0)
out["startup_states_not_heard"] = sum(1 for x in s if x[1].startswith("e_stop not heard yet"))
out["startup_states"] = len(s)
# 2. e_stop false at 10 Hz: free.
ctl["e_stop"] = True
t = time.time()
time.sleep(1.5)
w = window(cmds, t + 0.5, time.time())
out["alive_max_v"] = max((x[1] for x in w), default=None)
# 3. Silent.
ctl["e_stop"] = False
time.sleep(0.1)
last = ctl["last_e_stop"]
time.sleep(1.8)
stop_at = first_after(cmds, last, lambda x: x[1] == 0.0)
out["silence_stop_delay_s"] = None if stop_at is None else round(stop_at - last, 3)
out["silence_reason"] = next((x[1] for x in window(states, last, time.time()) if "e_stop silent for" in x[1]), None)
out["silence_diag"] = next(([x[1], x[2]] for x in window(diags, last + 0.6, time.time()) if "e_stop silent" in x[2]),
                           None)
out["silence_moving_after_stop"] = sum(1 for x in window(cmds, last + 0.7, time.time()) if x[1] != 0.0)
# 4. Heard again: free without a reset.
ctl["e_stop"] = True
t = time.time()
time.sleep(1.5)
out["again_max_v"] = max((x[1] for x in window(cmds, t + 0.5, time.time())), default=None)
# 5. The disable that lapses.
ctl["wall"], ctl["v"] = True, 0.2
time.sleep(1.0)
out["wall_max_v"] = max((x[1] for x in window(cmds, time.time() - 0.5, time.time())), default=None)
rospy.wait_for_service(ns + "/oldbf_node/enable", timeout=5)
enable = rospy.ServiceProxy(ns + "/oldbf_node/enable", SetBool)
t_off = time.time()
out["disable_answer"] = enable(False).message
time.sleep(1.5)
out["disabled_passes"] = sum(1 for x in window(cmds, t_off + 0.3, time.time()) if abs(x[1] - 0.2) < 1e-9)
out["disabled_diag"] = next((x[2] for x in window(diags, t_off + 0.1, time.time()) if "lapses in" in x[2]), None)
time.sleep(1.5)
# Filtered again: the first command that is not the 0.2 m/s passed through (the
# filter then brakes at control.decel_mps2 from what was sent, down to no motion).
back = first_after(cmds, t_off + 0.3, lambda x: abs(x[1] - 0.2) > 1e-9)
out["lapsed_after_s"] = None if back is None else round(back - t_off, 3)
# Renewed after 1.5 s: lapses 2.0 s after the second call.
t_r0 = time.time()
enable(False)
time.sleep(1.5)
t_r1 = time.time()
enable(False)
time.sleep(3.0)
back = first_after(cmds, t_r0 + 0.3, lambda x: abs(x[1] - 0.2) > 1e-9)
out["renewed_lapsed_after_first_s"] = None if back is None else round(back - t_r0, 3)
out["renewed_lapsed_after_second_s"] = None if back is None else round(back - t_r1, 3)
ctl["run"] = False
time.sleep(0.1)
print(json.dumps(out))
