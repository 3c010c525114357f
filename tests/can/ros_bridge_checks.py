#!/usr/bin/python3
"""can_bridge_node's ROS side while the robot drives through CAN (run by
tests/vm/e2e_guest.sh during sim_can.launch, ROS's own Python):

  joint_states  sensor_msgs/JointState: the configured names; the wheels'
                speeds give the odometry's twist through the kinematics
                (same stamp); the angles advance as the speeds integrate.
  covariance    nav_msgs/Odometry: the twist covariance equals the noise
                model's, computed here by hand from config/can_bridge.yaml;
                the pose covariance is positive, grows while driving, and
                1e6 where planar odometry measures nothing.
  tf            odom -> base_link on /tf carries the Odometry's pose at the
                same stamp.
  sdo           (--sdo NODE) the ~sdo_read / ~sdo_write services through
                rospy (classes generated here by genpy from the vendored
                .srv: the connection checks the md5): a segmented read of
                0x1008, a 0x6083 write refused while driving (0x08000022),
                the drive's own abort of a read-only write decoded.

Prints PASS/FAIL per check; exits 1 if any failed.

  ros_bridge_checks.py --config config/can_bridge.yaml --node-config config/can_bridge_node.yaml
                       --bridge /can_bridge_node [--sdo 1 --device-name NAME] [--duration-s 8]
"""

import argparse
import importlib.util
import math
import os
import subprocess
import sys
import tempfile
import time

import rospy
import yaml
from sensor_msgs.msg import JointState
from tf2_msgs.msg import TFMessage

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
RMSG = os.path.join(ROOT, "oldbf_ros", "rosmsg")
FAILS = []
UNMEASURED = 1e6


def check(ok, name, detail=""):
    print(("PASS" if ok else "FAIL") + f": {name}" + (f": {detail}" if detail else ""), flush=True)
    if not ok:
        FAILS.append(name)
    return ok


def genpy_class(kind, pkg, name, includes, tmp):
    """Generates the Python class of a vendored type with ROS's genpy and loads it."""
    tool = "/usr/lib/genpy/genmsg_py.py" if kind == "msg" else "/usr/lib/genpy/gensrv_py.py"
    src = os.path.join(RMSG, pkg, kind, f"{name}.{kind}")
    out = os.path.join(tmp, pkg, kind)
    os.makedirs(out, exist_ok=True)
    args = ["/usr/bin/python3", tool, "-p", pkg, "-o", out]
    for inc in includes:
        args += ["-I", inc]
    subprocess.run(args + [src], check=True, capture_output=True)
    spec = importlib.util.spec_from_file_location(f"_gen_{pkg}_{name}", os.path.join(out, f"_{name}.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def stamp(h):
    return h.stamp.secs * 10**9 + h.stamp.nsecs


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--config", required=True)
    ap.add_argument("--node-config", required=True)
    ap.add_argument("--bridge", default="/can_bridge_node")
    ap.add_argument("--sdo", type=int, help="node id for the SDO service checks (cia402)")
    ap.add_argument("--device-name", default="oldbf virtual CiA 402 drive")
    ap.add_argument("--duration-s", type=float, default=8.0)
    ap.add_argument("--start-timeout-s", type=float, default=120.0)
    a = ap.parse_args()
    cfg = yaml.safe_load(open(a.config))
    node_cfg = yaml.safe_load(open(a.node_config))["node"]
    k, o = cfg["kinematics"], cfg["odometry"]
    r, L = k["wheel_radius_m"], k["wheel_separation_m"]

    tmp = tempfile.mkdtemp()
    odom_mod = genpy_class("msg", "nav_msgs", "Odometry",
                           [f"nav_msgs:{RMSG}/nav_msgs/msg", "geometry_msgs:/usr/share/geometry_msgs/msg",
                            "std_msgs:/usr/share/std_msgs/msg"], tmp)
    Odometry = odom_mod.Odometry
    rospy.init_node("ros_bridge_checks", anonymous=True, disable_signals=True)
    odoms, joints, tfs = [], [], []
    rospy.Subscriber("/odom", Odometry, lambda m: odoms.append((time.monotonic(), m)))
    rospy.Subscriber("/joint_states", JointState, lambda m: joints.append(m))
    rospy.Subscriber("/tf", TFMessage, lambda m: tfs.extend(t for t in m.transforms
                                                           if t.header.frame_id == node_cfg["odom_frame"]
                                                           and t.child_frame_id == node_cfg["base_frame"]))
    # Wait until the robot drives (the bridge runs: its drive is enabled).
    deadline = time.monotonic() + a.start_timeout_s
    while time.monotonic() < deadline and not any(abs(m.twist.twist.linear.x) > 0.05 for _, m in odoms[-5:]):
        time.sleep(0.2)
    driving = any(abs(m.twist.twist.linear.x) > 0.05 for _, m in odoms[-5:])
    check(driving, "ros: the robot drives on the bridge's odometry", f"{len(odoms)} odom messages")
    if not driving:
        sys.exit(1)
    t0 = len(odoms), len(joints)

    # SDO through the services while driving.
    if a.sdo:
        inc = [f"oldbf_ros:{RMSG}/oldbf_ros/msg", "std_msgs:/usr/share/std_msgs/msg"]
        SdoRead = genpy_class("srv", "oldbf_ros", "SdoRead", inc, tmp).SdoRead
        SdoWrite = genpy_class("srv", "oldbf_ros", "SdoWrite", inc, tmp).SdoWrite
        rospy.wait_for_service(f"{a.bridge}/sdo_read", timeout=20)
        read = rospy.ServiceProxy(f"{a.bridge}/sdo_read", SdoRead)
        write = rospy.ServiceProxy(f"{a.bridge}/sdo_write", SdoWrite)
        t_call = time.monotonic()
        name = read(node_id=a.sdo, index=0x1008, subindex=0)
        dt = time.monotonic() - t_call
        data = bytes(name.data) if isinstance(name.data, (bytes, bytearray)) else bytes(bytearray(name.data))
        check(name.success and data.decode("ascii", "replace") == a.device_name and name.abort_code == 0,
              "sdo: ~sdo_read of 0x1008 while driving returns the drive's device name (segmented, "
              f"{len(a.device_name)} bytes)", f"success {name.success}, data {data!r}, {name.message!r}, {dt:.2f} s")
        refused = write(node_id=a.sdo, index=0x6083, subindex=0, data=(1000).to_bytes(4, "little"))
        check(not refused.success and refused.abort_code == 0x08000022 and "refused by the bridge" in refused.message,
              "sdo: ~sdo_write of 0x6083 while driving is refused with 0x08000022 (motion object, drive enabled)",
              f"success {refused.success}, abort 0x{refused.abort_code:08X}, {refused.message!r}")
        ro = write(node_id=a.sdo, index=0x1000, subindex=0, data=bytes(4))
        check(not ro.success and ro.abort_code == 0x06010002
              and "attempt to write a read only object" in ro.message,
              "sdo: the drive's own abort (0x1000 is read only) comes back decoded",
              f"success {ro.success}, abort 0x{ro.abort_code:08X}, {ro.message!r}")

    time.sleep(a.duration_s)
    od = [m for _, m in odoms[t0[0]:]]
    js = joints[t0[1]:]

    # joint_states: names, and the kinematics against odom's twist at the same stamp.
    by_stamp = {stamp(m.header): m for m in od}
    pairs = [(j, by_stamp[stamp(j.header)]) for j in js if stamp(j.header) in by_stamp]
    worst = 0.0
    for j, m in pairs:
        wl, wr = j.velocity
        v, w = r * (wl + wr) / 2, r * (wr - wl) / L
        worst = max(worst, abs(v - m.twist.twist.linear.x), abs(w - m.twist.twist.angular.z))
    names_ok = all(list(j.name) == [node_cfg["left_wheel_joint"], node_cfg["right_wheel_joint"]] for j in js)
    finite = all(math.isfinite(x) for j in js for x in list(j.position) + list(j.velocity))
    # The angles advance as the speeds integrate (trapezoid over the window, within 10 %).
    wheel_ok, adv = [], ""
    if len(js) > 10:
        ts = [stamp(j.header) * 1e-9 for j in js]
        for i in range(2):
            integ = sum((js[n + 1].velocity[i] + js[n].velocity[i]) / 2 * (ts[n + 1] - ts[n]) for n in range(len(js) - 1))
            moved = js[-1].position[i] - js[0].position[i]
            adv += f"wheel {i}: moved {moved:.3f} rad, speeds integrate to {integ:.3f}; "
            wheel_ok.append(abs(moved - integ) <= 0.1 * abs(integ) + 0.05 and abs(moved) > 0.5)
    adv_ok = len(wheel_ok) == 2 and all(wheel_ok)
    check(len(js) > 100 and names_ok and finite and len(pairs) > 50 and worst < 1e-9 and adv_ok,
          "joint_states: names from config/can_bridge_node.yaml; v = r(wl + wr)/2, w = r(wr - wl)/L against odom "
          "at the same stamp; angles advance as the speeds integrate",
          f"{len(js)} messages, {len(pairs)} stamp pairs with odom, worst twist mismatch {worst:.2e}; {adv}")

    # covariance: the twist block by hand from the noise model; the pose block grows.
    sl, sr = o["left_speed_sigma_radps"] ** 2, o["right_speed_sigma_radps"] ** 2
    want = {0: r * r * (sl + sr) / 4, 35: r * r * (sl + sr) / L ** 2, 5: r * r * (sr - sl) / (2 * L),
            30: r * r * (sr - sl) / (2 * L), 7: UNMEASURED, 14: UNMEASURED, 21: UNMEASURED, 28: UNMEASURED}
    tw_bad = [(i, od[-1].twist.covariance[i], v) for i, v in want.items()
              if abs(od[-1].twist.covariance[i] - v) > 1e-12 * max(1.0, abs(v))]
    p0, p1 = od[0].pose.covariance, od[-1].pose.covariance
    grows = p1[35] > p0[35] > 0 and p1[0] >= p0[0] > 0 and p1[7] > 0
    # 2x2 principal minors of (x, y, yaw): x-y (0, 7; 1), x-yaw (0, 35; 5), y-yaw (7, 35; 11).
    psd = all(p1[a] * p1[b] - p1[c] ** 2 >= -1e-12 for a, b, c in ((0, 7, 1), (0, 35, 5), (7, 35, 11)))
    unm = all(p1[i] == UNMEASURED for i in (14, 21, 28))
    check(not tw_bad and grows and psd and unm,
          "covariance: twist = the noise model by hand (var v = r^2(sl^2+sr^2)/4, var w = r^2(sl^2+sr^2)/L^2); pose "
          "(x, y, yaw) positive and growing while driving; 1e6 for z, roll, pitch",
          f"twist [0] {od[-1].twist.covariance[0]:.6e} (want {want[0]:.6e}), [35] {od[-1].twist.covariance[35]:.6e} "
          f"(want {want[35]:.6e}); mismatches {tw_bad}; pose yaw var {p0[35]:.3e} -> {p1[35]:.3e}, "
          f"x var {p0[0]:.3e} -> {p1[0]:.3e}")

    # tf: the same pose at the same stamp.
    tf_by = {stamp(t.header): t for t in tfs}
    matched = [(m, tf_by[stamp(m.header)]) for m in od if stamp(m.header) in tf_by]
    off = max((max(abs(m.pose.pose.position.x - t.transform.translation.x),
                   abs(m.pose.pose.position.y - t.transform.translation.y),
                   abs(m.pose.pose.orientation.z - t.transform.rotation.z),
                   abs(m.pose.pose.orientation.w - t.transform.rotation.w)) for m, t in matched), default=1.0)
    check(len(matched) > 50 and off == 0.0,
          f"tf: {node_cfg['odom_frame']} -> {node_cfg['base_frame']} on /tf = the Odometry's pose at the same stamp",
          f"{len(matched)} of {len(od)} odometry messages matched on /tf, largest difference {off}")
    print(f"ros_bridge_checks: {len(FAILS)} failed" if FAILS else "ros_bridge_checks: all passed", flush=True)
    sys.exit(1 if FAILS else 0)


if __name__ == "__main__":
    main()
