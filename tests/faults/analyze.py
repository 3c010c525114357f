#!/usr/bin/env python3
"""Measures every fault case of tests/vm/faults_guest.sh from the candump
capture, and writes the results table.

  analyze.py OUT_DIR

Reads OUT_DIR/{candump.log, events.jsonl, diag.jsonl, *.log} and the
configuration (config/can_bridge.yaml, config/oldbf.yaml, the drive's
watchdog from OUT_DIR/drive_watchdog_s). Every frame is decoded with ODrive's
DBC (tests/data/odrive-cansimple.dbc); every float on the wire must be finite.
Times: from the moment of injection (events.jsonl, realtime clock, as
candump's) to the first pair of zero Set_Input_Vel frames (both axes) after
it. A backwards clock step (the clock_jump case) is undone on both time lines.
Writes OUT_DIR/results.md and results.json; exits 1 if any check failed.
"""
import json
import math
import os
import re
import struct
import sys

import cantools
import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
OUT = sys.argv[1]
TAU = 2 * math.pi
MARGIN_S = 0.3  # emulation (QEMU TCG) and ROS transport allowance, added to every limit

bridge_cfg = yaml.safe_load(open(os.path.join(ROOT, "config", "can_bridge.yaml")))
algo_cfg = yaml.safe_load(open(os.path.join(ROOT, "config", "oldbf.yaml")))
tx_period = 1.0 / bridge_cfg["timing"]["tx_rate_hz"]
cmd_timeout = bridge_cfg["timing"]["cmd_timeout_s"]
hb_timeout = bridge_cfg["timing"]["heartbeat_timeout_s"]
bus_recovery = bridge_cfg["timing"]["bus_recovery_s"]
kin, lim = bridge_cfg["kinematics"], bridge_cfg["limits"]
ctrl_period = 1.0 / algo_cfg["control"]["rate_hz"]
scan_timeout = algo_cfg["laser"]["scan_timeout_s"]
v_nom = algo_cfg["control"]["v_nom_mps"]
scan_period = 0.1  # tests/faults/scan_source.py
hb_period = 0.1  # virtual drive heartbeat (10 Hz default)
drive_watchdog = float(open(os.path.join(OUT, "drive_watchdog_s")).read())
wheel_nom = v_nom / kin["wheel_radius_m"]  # rad/s at the wheel while driving straight
ramp = wheel_nom / lim["wheel_decel_radps2"]  # commanded slow-down to zero (bridge decel limit)
wheel_max_turns = lim["max_wheel_speed_radps"] * kin["gear_ratio"] / TAU

db = cantools.database.load_file(os.path.join(ROOT, "tests", "data", "odrive-cansimple.dbc"))
# CANSimple commands the DBC lacks, that the bridge sends without floats
# (cmd id -> name, allowed data lengths): decoded by id and length.
NOT_IN_DBC = {0x02: ("Estop", (0,)), 0x18: ("Clear_Errors", (0, 1))}
unknown_ids = {}

FAILS = []


def check(ok, what):
    print(("PASS" if ok else "FAIL") + ": " + what, flush=True)
    if not ok:
        FAILS.append(what)
    return ok


# ---------------------------------------------------------------- capture
raw = []  # [t, can_id, data]
dropped = 0  # candump -d: frames the kernel dropped from candump's socket
for line in open(os.path.join(OUT, "candump.log")):
    d = re.search(r"DROPCOUNT: dropped (\d+)", line)
    if d:
        dropped += int(d.group(1))
    m = re.match(r"\((\d+\.\d+)\) \S+ ([0-9A-F]+)#([0-9A-F]*)", line.strip())
    if m:
        raw.append([float(m.group(1)), int(m.group(2), 16), bytes.fromhex(m.group(3))])

events = [json.loads(l) for l in open(os.path.join(OUT, "events.jsonl")) if l.strip()]
# Undo the clock step: J seconds added to everything after it.
jump = next((e for e in events if e["mode"] == "clock_jump"), None)
J = jump.get("J", jump["t_before"] - jump["t"]) if jump else 0.0  # exact: from realtime - monotonic
if jump:
    idx = next((i for i in range(1, len(raw)) if raw[i][0] < raw[i - 1][0] - 5.0), None)
    if idx is not None:
        for f in raw[idx:]:
            f[0] += J
    after = False
    for e in events:
        if after:
            e["t"] += J
        if e is jump:
            after = True
            e["t_before_fix"] = e["t"]
            e["t"] = e["t_before"]  # the moment of the step, on the old time line

# The ODrive part of the run, then the CiA 402 part (from the event co_bridge:
# the cia402 bridge starts before its drive).
co_start = next((e["t"] for e in events if e["mode"] == "co_bridge"), float("inf"))
frames = []  # (t, node, cmd, decoded dict): ODrive
co_raw = [r for r in raw if r[0] >= co_start]
nonfinite = []
undecodable = 0
for t, can_id, data in (r for r in raw if r[0] < co_start):
    if can_id & 0x20000000:
        continue  # an injected error frame
    node, cmd = can_id >> 5, can_id & 0x1F
    if cmd in NOT_IN_DBC:
        name, lengths = NOT_IN_DBC[cmd]
        if len(data) not in lengths:
            undecodable += 1
            unknown_ids[hex(can_id)] = unknown_ids.get(hex(can_id), 0) + 1
        frames.append([t, node, cmd, {"_name": name}])
        continue
    try:
        msg = db.get_message_by_frame_id(cmd)
        d = msg.decode(data.ljust(msg.length, b"\0"), decode_choices=False, scaling=True) if msg.length else {}
    except Exception:
        undecodable += 1
        unknown_ids[hex(can_id)] = unknown_ids.get(hex(can_id), 0) + 1
        d = {}
    for k, v in d.items():
        if isinstance(v, float) and not math.isfinite(v):
            nonfinite.append((t, hex(can_id), k, v))
    frames.append([t, node, cmd, d])

diag = [json.loads(l) for l in open(os.path.join(OUT, "diag.jsonl")) if l.strip()] if os.path.exists(os.path.join(OUT, "diag.jsonl")) else []
# Diagnostics: the recorder writes in arrival order; undo the step the same way.
if jump:
    idx = next((i for i in range(1, len(diag)) if diag[i]["t"] < diag[i - 1]["t"] - 5.0), None)
    if idx is not None:
        for d in diag[idx:]:
            d["t"] += J


def ev(mode):
    return next((e for e in events if e["mode"] == mode), None)


# CiA 402 (after co_start): RPDO1 = controlword u16, target velocity i32 (rpm
# at the motor, config cia402.velocity_unit); the node ids from the config.
co_cfg = bridge_cfg["cia402"]
CO_NODES = {co_cfg["left_node_id"]: 0, co_cfg["right_node_id"]: 1}
co_rpdo = []  # (t, wheel index, controlword, target)
co_bad = []
for t, can_id, data in co_raw:
    if can_id & 0x20000000:
        continue
    base, n = can_id & ~0x7F, can_id & 0x7F
    ok_len = {0x000: 2, 0x080: 0 if n == 0 else 8, 0x180: 5, 0x280: 8, 0x200: 6, 0x580: 8, 0x600: 8, 0x700: 1}.get(base)
    if ok_len is None or len(data) != ok_len or (n not in CO_NODES and can_id not in (0x000, 0x080, 0x700 + co_cfg["bridge_node_id"])):
        co_bad.append(f"0x{can_id:X}#{data.hex()}")
        continue
    if base == 0x200:
        cw, target = struct.unpack_from("<Hi", data)
        co_rpdo.append((t, CO_NODES[n], cw, target))


def setpoints(t0, t1):
    """Velocity setpoints (t, wheel index, motor turns/s) in [t0, t1): ODrive
    Set_Input_Vel (node ids 0/1), then CiA 402 RPDO1 targets (rpm / 60)."""
    out = [(f[0], f[1], f[3].get("Input_Vel")) for f in frames if f[2] == 0x0D and t0 <= f[0] < t1]
    return out + [(t, w, v / 60.0) for t, w, _, v in co_rpdo if t0 <= t < t1]


def u16(d, at):
    return struct.unpack_from("<H", d, at)[0]


def first_zero_pair(t0, t1=float("inf")):
    zero = {}
    for t, node, v in setpoints(t0, t1):
        if v == 0.0:
            zero.setdefault(node, t)
        else:
            zero.pop(node, None)
        if 0 in zero and 1 in zero:
            return max(zero.values())
    return None


def first_moving(t0, t1=float("inf")):
    for t, node, v in setpoints(t0, t1):
        if v not in (None, 0.0):
            return t
    return None


def reported(t0, t1, name_part, pred):
    for d in diag:
        if t0 <= d["t"] <= t1 and name_part in d["name"] and pred(d):
            return d
    return None


def log_has(name, text):
    p = os.path.join(OUT, name)
    return os.path.exists(p) and text in open(p, errors="replace").read()


ROWS = []


def row(fault, expected, limit, measured, how, ok):
    ROWS.append({"fault": fault, "expected": expected, "limit_s": limit, "measured_s": measured, "reported": how, "ok": ok})
    check(ok, f"{fault}: {expected}; measured {fmt(measured)} s, limit {fmt(limit)} s; {how}")


def fmt(x):
    return "–" if x is None else f"{x:.3f}"


def log_stamps(name, pattern):
    """Floats captured by `pattern` (one group: a time stamp) in log `name`."""
    p = os.path.join(OUT, name)
    if not os.path.exists(p):
        return []
    return [float(m.group(1)) for m in re.finditer(pattern, open(p, errors="replace").read())]


def stop_case(mode, fault, expected, limit, diag_name, diag_pred, how, end_mode=None, recover=True, t0=None, log_pred=None,
              extra_ok=True):
    e = ev(mode)
    if e is None and t0 is None:
        row(fault, expected, limit, None, "case did not run", False)
        return None
    t0 = e["t"] if t0 is None else t0
    tz = first_zero_pair(t0)
    dt = None if tz is None else tz - t0
    rep = reported(t0, t0 + 3.0, diag_name, diag_pred) if diag_name else True
    if not rep and log_pred is not None and log_pred(t0):
        rep, how = True, how + " (not in the 1 Hz diagnostics; in the log)"
    ok = dt is not None and dt <= limit and rep is not None and extra_ok
    if recover and end_mode:
        e2 = ev(end_mode)
        t_end = max(e2["t"], tz or e2["t"]) if e2 else None
        tm = first_moving(t_end) if e2 else None
        ok = ok and tm is not None
        how += f"; moving again {fmt(None if tm is None else tm - t_end)} s after " + (end_mode if end_mode != mode else "the stop")
    row(fault, expected, limit, dt, how + ("" if rep else " (NOT reported)"), ok)
    return tz


# ---------------------------------------------------------------- cases
stop_case("node_kill", "oldbf_node SIGKILL while driving", "bridge sends zero (command timeout)",
          cmd_timeout + tx_period + MARGIN_S, "CAN bridge", lambda d: "command_timeout" in d["values"].get("stop_reasons", ""),
          "bridge diagnostics stop_reasons command_timeout", recover=False)

e = ev("cmd_absurd")
if e:
    t_nan, t_inf, t_end = ev("cmd_nan")["t"], ev("cmd_inf")["t"], ev("cmd_end")["t"]
    sp = setpoints(e["t"], t_nan)
    peak = max((abs(v) for _, _, v in sp if v is not None), default=0.0)
    within = all(v is not None and abs(v) <= wheel_max_turns * (1 + 1e-6) for _, _, v in setpoints(e["t"], t_end + 1))
    ok = within and peak >= 0.9 * wheel_max_turns
    ROWS.append({"fault": "/cmd_vel 100 m/s, 50 rad/s to the bridge", "expected": f"setpoints clamped to |wheel| ≤ {lim['max_wheel_speed_radps']} rad/s ({wheel_max_turns:.4f} turns/s)",
                 "limit_s": None, "measured_s": None, "reported": f"peak {peak:.4f} turns/s over {len(sp)} setpoints; bridge counter commands_clamped", "ok": ok})
    check(ok, f"absurd command clamped: peak |Input_Vel| {peak:.4f} turns/s, limit {wheel_max_turns:.4f}; all within: {within}")
    for mode, label, t_a, t_b in (("cmd_nan", "/cmd_vel linear.x = NaN", t_nan, t_inf), ("cmd_inf", "/cmd_vel angular.z = +inf", t_inf, t_end)):
        tz = first_zero_pair(t_a, t_b)
        moving_after = [v for t, _, v in setpoints((tz or t_b), t_b) if v != 0.0]
        rep = log_has("bridge.log", "CommandRejected")
        ok = tz is not None and tz - t_a <= tx_period + MARGIN_S and not moving_after and rep
        row(label, "rejected: zero setpoints, never NaN", tx_period + MARGIN_S, None if tz is None else tz - t_a,
            "bridge log CommandRejected" + ("" if rep else " (NOT reported)"), ok)
else:
    row("absurd /cmd_vel", "clamped", None, None, "case did not run", False)

scan_limit = scan_period + ctrl_period + ramp + tx_period + MARGIN_S
# The node's log names the offending scan stamp (scan time line = realtime, as events).
LOG_PATTERNS = {"frozen_stamp": r"scan stamp (\d+\.\d+) s repeated \d+ time\(s\): frozen sensor",
                "out_of_order": r"scan stamped (\d+\.\d+) s arrived after one stamped [\d.]+ s: out of order"}
for mode, fault, code in (("frozen", "scans frozen (same stamp repeated)", "frozen_stamp"),
                          ("out_of_order", "scans out of order (stamp 0.2 s older)", "out_of_order")):
    stop_case(mode, fault, "treated as stale: stop at once, resume on newer scans", scan_limit, "safety filter",
              lambda d, c=code: d["values"].get("scan_fault") == c, f"oldbf_node diagnostics scan_fault {code}",
              end_mode=f"{mode}_end",
              log_pred=lambda t0, c=code: any(t0 - 3.0 <= x <= t0 + 3.0 for x in log_stamps("oldbf_node.log", LOG_PATTERNS[c])))

e = ev("clock_jump")
if e:
    limit = ctrl_period + ramp + tx_period + MARGIN_S
    tz = first_zero_pair(e["t"])
    rep = log_has("oldbf_node.log", "clock jumped back")
    e2 = ev("clock_jump_end")
    tm = first_moving(e["t"] + (tz - e["t"] if tz else 0))
    ok = tz is not None and tz - e["t"] <= limit and rep and tm is not None
    row(f"clock stepped back {J:.1f} s (date -s)", "scans from before the step dropped: stop, held for scan_timeout_s, then resume on a new scan", limit,
        None if tz is None else tz - e["t"], "oldbf_node log 'clock jumped back'" + ("" if rep else " (NOT reported)")
        + f"; moving again {fmt(None if (tm is None or tz is None) else tm - tz)} s after the stop", ok)
else:
    row("clock jump backwards", "stop", None, None, "case did not run", False)

# REP 117 (docs/ALGORITHM.md §1): NaN and 0.0 (below range_min) are unknown,
# and unknown is not free: a front sector mostly unknown for blind_timeout_s
# is a blind sensor (stop, diagnostics sensor_blind), resumed on good scans.
blind_timeout = algo_cfg["laser"]["blind_timeout_s"]
blind_limit = blind_timeout + scan_limit
for mode in ("nan", "zero"):
    stop_case(f"scan_{mode}", f"all-{mode} scans (every beam unknown)",
              "unknown is not free: stop once blind for blind_timeout_s, resume on good scans", blind_limit, "safety filter",
              lambda d: d["values"].get("sensor_blind") == "true" and d["values"].get("valid_beams") == "0",
              "oldbf_node diagnostics sensor_blind true, valid_beams 0", end_mode=f"scan_{mode}_end")
e, e2 = ev("scan_inf"), ev("scan_inf_end")
if not e or not e2:
    row("all-inf scans", "proceed", None, None, "case did not run", False)
else:
    # +inf is "no return within range_max": free space (REP 117). Settled: from
    # one control period + ramp after the switch to its end.
    sp = setpoints(e["t"] + ctrl_period + 0.2, e2["t"])
    stops = [v for _, _, v in sp if v == 0.0]
    d = reported(e["t"] + 0.5, e2["t"] + 0.5, "safety filter",
                 lambda d: d["values"].get("valid_beams") == "0" and d["values"].get("unknown_beams") == "0")
    no_stop = d is not None and d["values"].get("stop_reason", "") == "" and d["values"].get("sensor_blind") == "false"
    ok = len(sp) > 10 and not stops and no_stop
    row("all-inf scans (no return within range_max)", "free space (REP 117): proceed at the nominal, finite", None, None,
        f"{len(sp)} setpoints, {len(stops)} zero; diagnostics valid_beams 0, unknown_beams 0, no stop reason, not blind: {no_stop}", ok)

e = ev("bridge_kill")
if e:
    limit = drive_watchdog + hb_period + MARGIN_S
    idle = next((f[0] for f in frames if f[0] >= e["t"] and f[2] == 0x01 and f[3].get("Axis_State") == 1
                 and f[3].get("Axis_Error", 0) != 0), None)
    still = next((f[0] for f in frames if f[0] >= e["t"] and f[2] == 0x09 and abs(f[3].get("Vel_Estimate", 1)) < 0.01), None)
    rep = log_has("drive1.log", "watchdog")
    ok = idle is not None and idle - e["t"] <= limit and rep
    row("can_bridge_node SIGKILL", "the drive's own watchdog idles the wheels", limit, None if idle is None else idle - e["t"],
        f"heartbeat Axis_State IDLE with watchdog error; |vel| < 0.01 turns/s after {fmt(None if still is None else still - e['t'])} s; drive log"
        + ("" if rep else " (NOT reported)"), ok)
else:
    row("can_bridge_node killed", "drive watchdog", None, None, "case did not run", False)

LEFT_NODE = bridge_cfg.get("odrive", {}).get("left_node_id", 0)


def heartbeats(t0, t1=float("inf")):
    return [f for f in frames if f[2] == 0x01 and t0 <= f[0] < t1]


def first_clear_errors(t0):
    return next((f[0] for f in frames if f[2] == 0x18 and f[0] >= t0), None)


def latched_recovery(label, tz, reset_mode):
    """No motion from the stop to the reset (seen on the bus: the restart's
    Clear_Errors after the reset call), motion after it."""
    r, rd = ev(reset_mode), ev(reset_mode + "_done")
    if tz is None or r is None:
        row(label, "no motion until ~reset (commands fresh all along), then moving", None, None,
            "case did not run" if r is None else "no stop", False)
        return
    t_clear = first_clear_errors(r["t"] - 0.5)
    in_call = t_clear is not None and t_clear <= (rd["t"] if rd else r["t"]) + 1.0
    moved = first_moving(tz, t_clear if t_clear else float("inf"))
    tm = first_moving(t_clear) if t_clear else None
    ok = in_call and moved is None and tm is not None
    row(label, "no motion until ~reset (commands fresh all along), then moving after a fresh command", None,
        None if tm is None else tm - t_clear,
        f"zero for {fmt(None if t_clear is None else t_clear - tz)} s until the reset (Clear_Errors on the bus, "
        f"{fmt(None if (t_clear is None or rd is None) else rd['t'] - t_clear)} s before ~reset returned); measured = reset -> moving", ok)


# Axis error: onset = the first heartbeat of the left axis carrying the injected bit.
d2 = ev("drive2_start")
onset = next((f[0] for f in heartbeats(d2["t"]) if f[1] == LEFT_NODE and int(f[3].get("Axis_Error", 0)) & 0x1), None) if d2 else None
if onset is None:
    row("axis error injected (left axis)", "stop, latched", None, None, "case did not run (no heartbeat with the error)", False)
    tz = None
else:
    tz = stop_case("axis_error", "axis error injected (left axis)", "stop, latched (onset: first heartbeat with the error)",
                   tx_period + MARGIN_S, "CAN bridge", lambda d: "drive_fault" in d["values"].get("stop_reasons", ""),
                   "bridge diagnostics drive_fault", recover=False, t0=onset)
latched_recovery("axis error: recovery", tz, "axis_reset")

# Heartbeat silence: onset = the last heartbeat before the first gap > 1 s in the new drive's heartbeats.
d3 = ev("drive3_start")
hb = heartbeats(d3["t"]) if d3 else []
gap = next((i for i in range(1, len(hb)) if hb[i][0] - hb[i - 1][0] > 1.0), None)
if gap is None:
    row("heartbeat silence", "stop, latched", None, None, "case did not run (no gap in the heartbeats)", False)
    tz = None
else:
    silence = hb[gap][0] - hb[gap - 1][0]
    tz = stop_case("hb_silence", f"heartbeat silence ({silence:.2f} s on the bus)", "stop, latched (onset: last heartbeat before the gap)",
                   hb_timeout + tx_period + MARGIN_S, "CAN bridge",
                   lambda d: "heartbeat_lost" in d["values"].get("stop_reasons", ""),
                   "bridge diagnostics heartbeat_lost", recover=False, t0=hb[gap - 1][0])
latched_recovery("heartbeat silence: recovery", tz, "hb_reset")

stop_case("bus_busoff", "bus-off error frame on vcan0", "stop until the bus is back and quiet for bus_recovery_s",
          tx_period + MARGIN_S, "CAN bridge", lambda d: "bus_error" in d["values"].get("stop_reasons", ""),
          "bridge diagnostics bus_error", end_mode="bus_busoff",
          # The stop lasts ~bus_recovery_s: 1 Hz diagnostics may miss it; the only bus-off of the run is in the log.
          log_pred=lambda t0: log_has("bridge.log", 'BusError { description: "bus-off", fatal: true }'))

e = ev("roscore_kill")
if e:
    lost = log_has("oldbf_node.log", "lost the ROS master") and log_has("bridge.log", "lost the ROS master")
    restarted = log_has("oldbf_node.log", "restarted (PID") and log_has("bridge.log", "restarted (PID")
    codes = open(os.path.join(OUT, "exit_codes")).read().split() if os.path.exists(os.path.join(OUT, "exit_codes")) else []
    up, upd = ev("roscore_start"), ev("roscore_up")
    tz = first_zero_pair(up["t"]) if up else None
    t_up = None if not (up and upd) else upd["t"] - up["t"]
    ok = lost and restarted and codes == ["1", "1"] and tz is not None
    row("roscore killed, then restarted", "loss reported, nodes run on; new master: zero sent, exit 1 with a clear message",
        None, None if tz is None else tz - up["t"],
        f"loss logged by both: {lost}; restart logged by both: {restarted}; exit codes {codes}; time = roscore started again -> zero (includes the master's start-up, {fmt(t_up)} s until rostopic could list topics, and the nodes' 1 s probe)", ok)

# ---------------------------------------------------------------- CiA 402 cases
co_ev = ev("co_start")
CO_LEFT = co_cfg["left_node_id"]
sdo_timeout = co_cfg["sdo_timeout_s"]
startup_timeout = bridge_cfg["timing"]["startup_timeout_s"]


def co_frames(base, node=None, t0=0.0, t1=float("inf")):
    return [(t, i & 0x7F, d) for t, i, d in co_raw
            if i & ~0x7F == base and (node is None or i & 0x7F == node) and t0 <= t < t1]


def moving_before(t0, window=1.0):
    return any(v != 0 for t, _, _, v in co_rpdo if t0 - window <= t < t0)


def co_recovery(label, tz, reset_mode):
    """Zero until the reset, a fault reset / new enable after it, then moving."""
    r = ev(reset_mode)
    if tz is None or r is None:
        row(label, "no motion until ~reset, then moving", None, None, "case did not run", False)
        return
    moved = [x for x in co_rpdo if tz < x[0] < r["t"] and x[3] != 0]
    tm = first_moving(r["t"])
    enable = next((t for t, w, cw, _ in co_rpdo if t > r["t"] and cw == 0x000F), None)
    ok = not moved and tm is not None and enable is not None and enable <= tm
    row(label, "no motion until ~reset (commands fresh all along), then shutdown -> switch on -> enable operation, moving", None,
        None if tm is None else tm - r["t"],
        f"zero for {fmt(r['t'] - tz)} s until the reset; enable operation {fmt(None if enable is None else enable - r['t'])} s "
        f"after it; measured = reset -> moving", ok)


if co_ev is None:
    row("cia402 cases", "run", None, None, "case did not run", False)
else:
    # Drive fault: onset = the first TPDO1 of the left node whose statusword says fault.
    tp1 = [(t, n, struct.unpack_from("<HH", d)) for t, n, d in co_frames(0x180, CO_LEFT, co_ev["t"])]
    onset = next((t for t, n, (sw, err) in tp1 if sw & 0x4F == 0x08), None)
    err = next((err for t, n, (sw, err) in tp1 if sw & 0x4F == 0x08), None)
    tz = None
    if onset is None:
        row("cia402: drive fault (left node)", "stop, latched", None, None, "case did not run (no fault statusword)", False)
    else:
        was = moving_before(onset)
        tz = stop_case("co_fault", f"cia402: drive fault, left node (statusword fault, 0x603F 0x{err:04X}{'' if was else '; NOT moving before'})",
                       "zero target velocity, latched (onset: first TPDO1 with the fault)", tx_period + MARGIN_S, "CAN bridge",
                       lambda d: "drive_fault" in d["values"].get("stop_reasons", ""), "bridge diagnostics drive_fault",
                       recover=False, t0=onset, extra_ok=was)
    co_recovery("cia402: drive fault: recovery (fault reset 0x0080)", tz, "co_axis_reset")

    # Heartbeat loss: onset = the last heartbeat of the left node before a gap > 1 s.
    hb = co_frames(0x700, CO_LEFT, co_ev["t"])
    gap = next((i for i in range(1, len(hb)) if hb[i][0] - hb[i - 1][0] > 1.0), None)
    tz = None
    if gap is None:
        row("cia402: heartbeat loss", "stop, latched", None, None, "case did not run (no gap in the heartbeats)", False)
    else:
        silence = hb[gap][0] - hb[gap - 1][0]
        t0 = hb[gap - 1][0]
        was = moving_before(t0)
        tz = stop_case("co_hb", f"cia402: heartbeat loss ({silence:.2f} s without 0x700 + id){'' if was else '; NOT moving before'}",
                       "zero target velocity, latched (onset: last heartbeat before the gap)", hb_timeout + tx_period + MARGIN_S,
                       "CAN bridge", lambda d: "heartbeat_lost" in d["values"].get("stop_reasons", ""),
                       "bridge diagnostics heartbeat_lost", recover=False, t0=t0, extra_ok=was)
    co_recovery("cia402: heartbeat loss: recovery", tz, "co_hb_reset")

    # Reboot + SDO silence: onset = the reboot's boot-up message (0x700 + id,
    # 0x00); the first ones are the drive's power-on.
    boots = [t for t, n, d in co_frames(0x700, None, co_ev["t"]) if d == b"\x00"]
    boot = next((t for t in boots if t > boots[0] + 5.0), None) if boots else None
    if boot is None:
        row("cia402: drive reboot while driving", "stop", None, None, "case did not run (no boot-up)", False)
    else:
        was = moving_before(boot)
        stop_case("co_reboot", "cia402: drive reboot while driving (boot-up message)" + ("" if was else "; NOT moving before"),
                  "zero target velocity at once, the drive is started again", tx_period + MARGIN_S, "CAN bridge",
                  lambda d: "drive_starting" in d["values"].get("stop_reasons", ""),
                  "bridge diagnostics drive_starting, log 'booted'", recover=False, t0=boot,
                  log_pred=lambda t0: log_has("bridge.log", "booted (boot-up message)"), extra_ok=was)
        # SDO timeout at start-up: the first request after the boot-up that got no answer,
        # and the client's abort (0x80 ... 0x05040000) after sdo_timeout_s.
        req = co_frames(0x600, None, boot)
        resp = co_frames(0x580, None, boot)
        unanswered = next(((t, n, d) for t, n, d in req if d[0] != 0x80
                           and not any(n2 == n and t < t2 < t + sdo_timeout + 1.0 and d2[1:4] == d[1:4] for t2, n2, d2 in resp)), None)
        if unanswered is None:
            row("cia402: SDO timeout at start-up", "reported, retried", None, None, "case did not run (every SDO answered)", False)
        else:
            t_req, n_req, d_req = unanswered
            abort = next((t for t, n, d in req if n == n_req and t > t_req and d[0] == 0x80 and d[1:4] == d_req[1:4]
                          and struct.unpack_from("<I", d, 4)[0] == 0x05040000), None)
            moved = [x for x in co_rpdo if boot < x[0] and x[3] != 0]
            t_move = moved[0][0] if moved else None
            sdo_reported = log_has("bridge.log", "no response within")
            ok = (abort is not None and abort - t_req <= sdo_timeout + MARGIN_S and sdo_reported and t_move is not None
                  and not [x for x in co_rpdo if boot + tx_period + MARGIN_S < x[0] < t_req + sdo_timeout and x[3] != 0])
            row("cia402: SDO timeout at start-up (SDO server silent 2.5 s after the reboot)",
                "no motion; the bridge aborts the transfer (0x05040000) and reports it; start-up retried after startup_timeout_s",
                sdo_timeout + MARGIN_S, None if abort is None else abort - t_req,
                f"measured: unanswered request 0x{u16(d_req, 1):04X}:{d_req[3]:02X} -> client abort on the bus; bridge log "
                f"'no response within' {sdo_reported}; moving again {fmt(None if t_move is None else t_move - boot)} s after the boot-up "
                f"(silence 2.5 s + retries every startup_timeout_s {startup_timeout} s)", ok)

    e = ev("co_busoff")
    if e is None:
        row("cia402: bus-off", "stop", None, None, "case did not run", False)
    else:
        was = moving_before(e["t"])
        stop_case("co_busoff", "cia402: bus-off error frame on vcan0" + ("" if was else "; NOT moving before"),
                  "zero target velocity until the bus is back and quiet for bus_recovery_s, then restarted",
                  tx_period + MARGIN_S, "CAN bridge", lambda d: "bus_error" in d["values"].get("stop_reasons", ""),
                  "bridge diagnostics bus_error", end_mode="co_busoff",
                  log_pred=lambda t0: log_has("bridge.log", 'BusError { description: "bus-off", fatal: true }'),
                  extra_ok=was)
    check(not co_bad, f"cia402: every frame after co_start is a CiA 301 service of ours or of nodes {sorted(CO_NODES)} "
                      f"with its length ({len(co_raw)} frames; unexpected {co_bad[:5]})")
    check(len(co_rpdo) > 500, f"cia402: {len(co_rpdo)} RPDO1 setpoints decoded (integers: never a NaN)")

check(dropped == 0, f"candump kept every frame (the kernel dropped {dropped} from its socket)")
check(not nonfinite, f"no NaN or infinite value in any of {len(frames)} frames on vcan0" + (f": {nonfinite[:3]}" if nonfinite else ""))
check(undecodable == 0, f"every frame decodes with ODrive's DBC (Estop, Clear_Errors by id and length; {undecodable} did not: {unknown_ids})")
for name in ("oldbf_node.log", "bridge.log", "drive1.log", "drive2.log", "drive3.log", "drive_co.log"):
    check(not log_has(name, "panicked"), f"no panic in {name}")

# ---------------------------------------------------------------- table
lines = [
    "| fault | expected | limit (s) | measured (s) | how reported | result |",
    "|---|---|---|---|---|---|",
]
for r in ROWS:
    cell = lambda x: str(x).replace("|", "\\|")  # a bare | would split the Markdown cell
    lines.append(f"| {cell(r['fault'])} | {cell(r['expected'])} | {fmt(r['limit_s'])} | {fmt(r['measured_s'])} | {cell(r['reported'])} | {'PASS' if r['ok'] else 'FAIL'} |")
limits = (f"Limits from config: cmd_timeout_s {cmd_timeout}, tx period {tx_period:.3f} s, heartbeat_timeout_s {hb_timeout}, "
          f"bus_recovery_s {bus_recovery}, control period {ctrl_period:.3f} s, scan period {scan_period} s, "
          f"ramp to zero {ramp:.3f} s ({wheel_nom:.2f} rad/s at {lim['wheel_decel_radps2']} rad/s²), drive watchdog {drive_watchdog} s, "
          f"heartbeat period {hb_period} s, + {MARGIN_S} s for emulation. Measured: injection -> first pair of zero "
          f"Set_Input_Vel frames on vcan0 (candump time stamps), QEMU TCG guest on a 2-core shared VM. "
          f"{len(frames)} frames checked, {len(nonfinite)} non-finite. CiA 402 rows: the first pair of zero target "
          f"velocities (RPDO1 0x60FF of both nodes) after the onset; sdo_timeout_s {sdo_timeout}, startup_timeout_s {startup_timeout}.")
text = "\n".join(lines) + "\n\n" + limits + "\n"
open(os.path.join(OUT, "results.md"), "w").write(text)
json.dump({"rows": ROWS, "frames": len(frames), "nonfinite": len(nonfinite), "fails": FAILS}, open(os.path.join(OUT, "results.json"), "w"), indent=1)
print(text)
sys.exit(1 if FAILS else 0)
