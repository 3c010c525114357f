#!/usr/bin/python3
"""The robot's bringup never starts motion on its own (issue: never originate
motion; ALGORITHM §5c). Runs INSIDE the QEMU guest (vcan0 up), from
tests/vm/can_guest.sh:

  rosmaster + `roslaunch oldbf_ros bringup.launch interface:=vcan0` (the
  safety filter and the CAN bridge, as shipped) + virtual_drive on vcan0 +
  candump; scans of a room arrive at 10 Hz and nothing publishes cmd_vel_in.

Phases (times from the scan publisher, the guest's clock, as candump's):
  1. scans, no upstream command, 8 s: every setpoint frame on the bus is a
     zero wheel speed;
  2. a teleop command (0.1 m/s forward) at 10 Hz for 3 s: non-zero setpoints
     appear (the chain does carry motion, so phase 1 is not vacuous);
  3. the teleop stops: within cmd_in_timeout (0.5 s) + the bridge's ramp, the
     setpoints are zero again and stay zero.
Each setpoint's wheel speed is read as can_bridge/dbc/oldbf_generic.dbc
defines Vel_Cmd (bytes 0-3, little-endian signed, 1e-5 rad/s per bit; the
frames themselves are checked against the DBC with cantools in
can_checks.py: rospy lives in Debian's python3, cantools in pip's). Prints
PASS/FAIL lines; exit status 1 on any failure.
"""
import math
import os
import re
import signal
import struct
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BIN = os.path.join(ROOT, "target", "ros", "oldbf_ros", "bin")
PORT = 11321
OUT = os.path.join(ROOT, "target", "can_group", "bringup")
LINE = re.compile(r"^\((\d+\.\d+)\)\s+(\S+)\s+([0-9A-Fa-f]+)#([0-9A-Fa-f]*)")
FAILS = []


def check(ok, name, detail=""):
    print(("PASS" if ok else "FAIL") + f": bringup: {name}" + (f": {detail}" if detail else ""), flush=True)
    if not ok:
        FAILS.append(name)


def env():
    e = dict(os.environ)
    e.update(ROS_MASTER_URI=f"http://localhost:{PORT}/", ROS_HOSTNAME="localhost",
             ROS_HOME=os.path.join(OUT, "ros_home"))
    return e


def spawn(args, log):
    return subprocess.Popen(args, stdout=open(os.path.join(OUT, log), "w"), stderr=subprocess.STDOUT,
                            env=env(), start_new_session=True)


def stop(p, sig=signal.SIGINT, wait_s=10.0):
    if p.poll() is None:
        try:
            os.killpg(p.pid, sig)
        except ProcessLookupError:
            return
        try:
            p.wait(wait_s)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()


def room_scan(msg_cls, stamp):
    """360 beams, a wall 2 m ahead and a box 0.8 m to the left: what a robot
    standing in a room sees; the filter would let it drive if asked."""
    n = 360
    ranges = []
    for i in range(n):
        a = -math.pi + 2 * math.pi * i / n
        r = 3.0 if abs(a) < 1.0 else float("inf")
        if abs(a) < 1.0:
            r = min(r, 2.0 / math.cos(a))
        if 0.9 < a < 1.3:
            r = min(r, 0.8)
        ranges.append(r)
    m = msg_cls()
    m.header.stamp = stamp
    m.header.frame_id = "laser"
    m.angle_min, m.angle_increment = -math.pi, 2 * math.pi / n
    m.angle_max = m.angle_min + (n - 1) * m.angle_increment
    m.scan_time, m.range_min, m.range_max = 0.1, 0.12, 3.5
    m.ranges = ranges
    return m


def main():
    os.makedirs(OUT, exist_ok=True)
    procs = []
    master = spawn(["rosmaster", "--core", "-p", str(PORT)], "rosmaster.log")
    procs.append(master)
    try:
        for _ in range(300):
            if subprocess.run(["rostopic", "list"], env=env(), capture_output=True).returncode == 0:
                break
            time.sleep(0.2)
        else:
            check(False, "rosmaster came up")
            return
        subprocess.run(["rosparam", "set", "/run_id", "bringup-no-upstream"], env=env(), check=True)
        dump = spawn(["candump", "-L", "vcan0"], "candump.log")
        procs.append(dump)
        procs.append(spawn([os.path.join(BIN, "virtual_drive"), "--interface", "vcan0", "--protocol", "generic",
                            "--config", os.path.join(ROOT, "config", "can_bridge.yaml")], "virtual_drive.log"))
        launch = spawn(["roslaunch", "--wait", "oldbf_ros", "bringup.launch", "interface:=vcan0",
                        "publish_tf:=false"], "launch.log")
        procs.append(launch)
        # The laser's pose, as the robot's URDF gives it (the filter places scans by tf).
        procs.append(spawn([sys.executable, os.path.join(ROOT, "tests", "ros", "static_tf.py"), "base_link", "laser"],
                           "static_tf.log"))

        os.environ.update(env())
        import rospy
        from geometry_msgs.msg import Twist
        from sensor_msgs.msg import LaserScan
        rospy.init_node("bringup_probe", anonymous=True, disable_signals=True)
        scan_pub = rospy.Publisher("/scan", LaserScan, queue_size=1)
        cmd_pub = rospy.Publisher("/cmd_vel_in", Twist, queue_size=1)
        # Wait until the filter subscribes to the scan (the nodes start slowly under emulation).
        t_wait = time.time()
        while scan_pub.get_num_connections() == 0 and time.time() - t_wait < 120:
            time.sleep(0.2)
        check(scan_pub.get_num_connections() > 0, "oldbf_node subscribed to /scan",
              f"after {time.time() - t_wait:.1f} s")

        def publish_for(seconds, cmd=None):
            end = time.time() + seconds
            while time.time() < end:
                scan_pub.publish(room_scan(LaserScan, rospy.Time.now()))
                if cmd is not None:
                    cmd_pub.publish(cmd)
                time.sleep(0.1)

        # Let the bridge start the drive (start-up sequence, first status) on scans alone.
        publish_for(4.0)
        t1 = time.time()
        publish_for(8.0)
        t2 = time.time()
        teleop = Twist()
        teleop.linear.x = 0.1
        publish_for(3.0, teleop)
        t3 = time.time()
        publish_for(4.0)
        t4 = time.time()
        rospy.signal_shutdown("done")
    finally:
        for p in reversed(procs[1:]):
            stop(p)
        stop(master)

    setpoints = []
    with open(os.path.join(OUT, "candump.log")) as f:
        for line in f:
            m = LINE.match(line.strip())
            if not m:
                continue
            ts, _, ident, data = m.groups()
            ident = int(ident, 16)
            if ident in (0x101, 0x102):
                (raw,) = struct.unpack_from("<i", bytes.fromhex(data), 0)
                setpoints.append((float(ts), ident, raw * 1e-5))

    def within(a, b):
        return [s for s in setpoints if a <= s[0] < b]

    quiet = within(t1, t2)
    moving = [s for s in within(t2, t3) if s[2] != 0.0]
    settle = 0.5 + 0.5  # cmd_in_timeout_s + margin for the bridge's ramp to zero (s)
    after = within(t3 + settle, t4)
    check(len(quiet) > 100 and all(s[2] == 0.0 for s in quiet),
          "scans and no cmd_vel_in: only zero wheel speeds on the bus",
          f"{len(quiet)} setpoint frames in {t2 - t1:.1f} s, "
          f"non-zero: {sum(1 for s in quiet if s[2] != 0.0)}, largest |ω| {max((abs(s[2]) for s in quiet), default=0):.4f} rad/s")
    check(len(moving) > 20, "a teleop command on cmd_vel_in does reach the wheels",
          f"{len(moving)} non-zero setpoint frames in {t3 - t2:.1f} s, "
          f"largest |ω| {max((abs(s[2]) for s in moving), default=0):.3f} rad/s")
    check(len(after) > 50 and all(s[2] == 0.0 for s in after),
          "teleop gone: zero again and staying zero",
          f"{len(after)} frames from {settle:.1f} s after the last teleop command, "
          f"non-zero: {sum(1 for s in after if s[2] != 0.0)}")


if __name__ == "__main__":
    t0 = time.time()
    main()
    print(f"bringup: {time.time() - t0:.1f} s", flush=True)
    sys.exit(1 if FAILS else 0)
