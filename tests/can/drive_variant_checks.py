#!/usr/bin/env python3
"""candump checks of the drives legacy robots carry (issue 27), on a real
(virtual) CAN bus inside the QEMU guest (tests/vm/can_guest.sh):

  odrive06  the bridge against the virtual drive playing ODrive firmware
            0.6; every frame decoded with cantools against our 0.6 DBC
            (can_bridge/dbc/odrive-cansimple-0.6.dbc): ids, lengths, the
            start-up order, Set_Input_Vel = kinematics, the 0.6 heartbeat
            (Procedure_Result, Trajectory_Done_Flag), Get_Error, e-stop with
            0.6's ESTOP_REQUESTED (0x02000000) and the bridge's report naming it.
  two_axis  the bridge against ONE CANopen node with TWO CiA 402 axes
            (tests/can/cia402_dual_drive.py: python-canopen, from
            can_bridge/eds/oldbf_cia402_dual_drive.eds), frames decoded by
            hand (struct) after CiA 301/402: one NMT per node, both axes'
            start-up writes (axis 2 at +0x800, RPDO2/TPDO3/TPDO4), enabling
            per axis at zero target, targets = kinematics per wheel, a fault
            on axis 2 alone (both stop, latched and named), recovery with the
            fault reset on axis 2 only; SDO at run time through the CLI
            against python-canopen's SDO server: a segmented read (0x1008), a
            write refused while enabled (0x08000022, nothing sent), a
            segmented write accepted after the e-stop and read back.

Shares can_checks.py's helpers (candump session, PASS/FAIL lines, the test
geometry). Prints PASS/FAIL per check; exits 1 if any failed.

  drive_variant_checks.py --bin-dir target/release [--only odrive06 ...]
"""

import argparse
import json
import math
import os
import struct
import sys
import tempfile

import cantools

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import can_checks as cc  # noqa: E402  (the shared session and check helpers)

ODRIVE06_DBC = os.path.join(cc.ROOT, "can_bridge", "dbc", "odrive-cansimple-0.6.dbc")

# ----------------------------------------------------------------- odrive 0.6
ODRIVE06_SCRIPT = """# odrive firmware 0.6 check
0.0 0.2 0.5 every 0.05 until 1.5
1.5 0 0 every 0.05 until 2.0
2.0 estop
2.05 0.2 0.5 every 0.05 until 2.5
2.6 reset
3.0 -0.1 0.3 every 0.05 until 4.0
4.0 0 0 every 0.05 until 4.5
4.5 quit
"""
NODES = {3: 0, 5: 1}  # node -> wheel index (can_checks.py's config: odrive 3 and 5)
ESTOP_0_6 = 0x0200_0000  # ODriveError ESTOP_REQUESTED (0.6 numbering)
DISARMED = 3  # ProcedureResult DISARMED


def check_odrive06(bins, tmp):
    db = cantools.database.load_file(ODRIVE06_DBC)
    cc.check(True, f"odrive06: cantools parses can_bridge/dbc/odrive-cansimple-0.6.dbc ({len(db.messages)} messages)")
    cc.ODRIVE_FIRMWARE = "0.6"
    try:
        frames, lines, wall = cc.run_session(bins, "odrive", ODRIVE06_SCRIPT, [], tmp)
    finally:
        cc.ODRIVE_FIRMWARE = "0.5"
    cc.RESULTS["odrive06_session_s"] = round(wall, 2)
    cc.check(len(frames) > 200, "odrive06: frames captured with candump", f"{len(frames)} frames")

    # 1. Every frame: a node of ours, a message of the 0.6 DBC with its length, finite values.
    ev, bad = [], []
    for ts, ident, ext, data in frames:
        node, cmd = ident >> 5, ident & 0x1F
        try:
            msg = db.get_message_by_frame_id(cmd)  # the DBC holds node 0 ids
        except KeyError:
            msg = None
        if ext or node not in NODES or msg is None:
            bad.append(f"0x{ident:X} (node {node}, cmd 0x{cmd:X})")
            continue
        if len(data) != msg.length:
            bad.append(f"{msg.name} DLC {len(data)} != {msg.length}")
            continue
        try:
            sig = msg.decode(data, decode_choices=False)
        except Exception as e:  # noqa: BLE001
            bad.append(f"0x{ident:X}#{data.hex()}: {e}")
            continue
        if not all(math.isfinite(float(v)) for v in sig.values()):
            bad.append(f"non-finite {msg.name} {sig}")
        ev.append((ts, node, msg.name, sig))
    names = sorted({e[2] for e in ev})
    cc.check(not bad and {"Heartbeat", "Get_Error", "Set_Input_Vel", "Clear_Errors", "Estop"} <= set(names),
             "odrive06: every frame is a message of our 0.6 DBC for node 3 or 5, with the DBC's length, all finite",
             f"messages {names}; bad {bad[:5]}")

    def seq(node):
        return [(n, s) for _, m, n, s in ev if m == node]

    # 2. Start-up per node, before every closed-loop request: Clear_Errors (Identify 0),
    #    Set_Controller_Mode(2, 1), a zero Set_Input_Vel, in this order, and no motion before.
    ok, details = True, []
    for node in NODES:
        s = seq(node)
        cl = [k for k, (n, sig) in enumerate(s) if n == "Set_Axis_State" and sig["Axis_Requested_State"] == 8]
        ok &= len(cl) >= 2
        for k in cl:
            prev = max([j + 1 for j, (n, _) in enumerate(s[:k]) if n in ("Estop", "Set_Axis_State")], default=0)
            window = s[prev:k]
            pos = {}
            for j, (n, sig) in enumerate(window):
                if n == "Clear_Errors" and sig["Identify"] == 0:
                    pos["clear"] = j
                elif n == "Set_Controller_Mode" and (sig["Control_Mode"], sig["Input_Mode"]) == (2, 1):
                    pos["mode"] = j
                elif n == "Set_Input_Vel" and sig["Input_Vel"] == 0.0:
                    pos["zero"] = j
            moving = [1 for n, sig in window if n == "Set_Input_Vel" and sig["Input_Vel"] != 0.0]
            good = len(pos) == 3 and pos["clear"] < pos["mode"] < pos["zero"] and not moving
            ok &= good
            details.append(f"node {node} request #{cl.index(k) + 1}: {pos}")
    cc.check(ok, "odrive06: start-up = Clear_Errors(Identify 0), Set_Controller_Mode(VELOCITY, PASSTHROUGH), zero "
                 "Set_Input_Vel, then Set_Axis_State(CLOSED_LOOP_CONTROL), at boot and after reset", "; ".join(details))

    # 3. Velocities = kinematics / 2π (turns/s) within 1e-6 relative.
    ok, details = True, []
    want = [cc.motor_speeds(0.2, 0.5), cc.motor_speeds(-0.1, 0.3)]
    for node, wheel in NODES.items():
        vels = [sig["Input_Vel"] for n, sig in seq(node) if n == "Set_Input_Vel"]
        nz = [(k, c) for k, c, _ in cc.runs(vels) if k != 0.0 and c >= 10]
        good = len(nz) == 2
        for (got, c), w in zip(nz, want):
            wt = w[wheel] / cc.TAU
            good &= cc.rel_ok(got, wt)
            details.append(f"node {node}: {got:.7f} turns/s x{c} (want {wt:.7f})")
        ok &= good
    cc.check(ok, "odrive06: Set_Input_Vel = direction x gear x wheel speed / 2pi within 1e-6 relative", "; ".join(details))

    # 4. The 0.6 heartbeat: closed loop with SUCCESS and the trajectory flag while driving;
    #    after the Estop, Axis_Error ESTOP_REQUESTED (0x02000000), Procedure_Result DISARMED,
    #    Get_Error's Disarm_Reason the same; after the restart both clear.
    ok, details = True, []
    t_estop = next((ts for ts, node, n, _ in ev if n == "Estop"), None)
    t_restart = next((ts for ts, node, n, sig in ev if t_estop and ts > t_estop and n == "Set_Axis_State"
                      and sig["Axis_Requested_State"] == 8), None)
    for node in NODES:
        hb = [(ts, sig) for ts, m, n, sig in ev if m == node and n == "Heartbeat"]
        ge = [(ts, sig) for ts, m, n, sig in ev if m == node and n == "Get_Error"]
        running = [s for ts, s in hb if t_estop and ts < t_estop and s["Axis_State"] == 8]
        estopped = [s for ts, s in hb if t_estop and t_restart and t_estop < ts < t_restart
                    and s["Axis_Error"] == ESTOP_0_6 and s["Procedure_Result"] == DISARMED and s["Axis_State"] == 1]
        ge_estop = [s for ts, s in ge if t_estop and t_restart and t_estop < ts < t_restart
                    and s["Disarm_Reason"] == ESTOP_0_6 and s["Active_Errors"] == 0]
        after = [s for ts, s in hb if t_restart and ts > t_restart + 0.3]
        clean_after = after and all(s["Axis_Error"] == 0 and s["Procedure_Result"] == 0 for s in after)
        good = (running and all(s["Procedure_Result"] == 0 and s["Trajectory_Done_Flag"] == 1 for s in running)
                and estopped and ge_estop and clean_after)
        ok &= bool(good)
        details.append(f"node {node}: {len(running)} closed-loop heartbeats, {len(estopped)} ESTOP_REQUESTED/DISARMED, "
                       f"{len(ge_estop)} Get_Error disarm 0x02000000, clean after restart {bool(clean_after)}")
    cc.check(ok, "odrive06: heartbeat Procedure_Result/Trajectory_Done_Flag and Get_Error decode with the 0.6 DBC; "
                 "Estop gives ESTOP_REQUESTED 0x02000000 and DISARMED; Clear_Errors and the restart clear both",
             "; ".join(details))

    # 5. What the bridge said: the e-stop named in 0.6's numbering, and no velocity between
    #    the Estop and the restart.
    reports = [l.get("message", "") for l in lines if l.get("event") == "drive_report"]
    named = [r for r in reports if "0x02000000 (ESTOP_REQUESTED), firmware 0.6" in r]
    moving = [1 for ts, _, n, sig in ev if n == "Set_Input_Vel" and sig["Input_Vel"] != 0.0
              and t_estop and t_restart and t_estop <= ts < t_restart]
    cc.check(len(named) >= 2 and not moving,
             "odrive06: the bridge reports each node's axis error by its 0.6 name; no velocity from Estop to restart",
             f"reports {reports[:4]}; moving frames {len(moving)}")


# ----------------------------------------------------------------- two axes on one node
DUAL_NODE = 1
NOTE = "commissioned by the oldbf bridge"
TWO_AXIS_SCRIPT = f"""# one CANopen node, two axes: the right wheel is axis 2 (+0x800)
0.0 0.2 0.5 every 0.05 until 2.5
2.5 0 0 every 0.05 until 3.0
3.0 sdo_read {DUAL_NODE} 0x1008 0
3.1 sdo_write {DUAL_NODE} 0x6883 0 {struct.pack('<I', 1000).hex()}
3.2 reset
3.6 -0.1 0.3 every 0.05 until 4.6
4.6 0 0 every 0.05 until 4.8
4.8 estop
5.4 sdo_write {DUAL_NODE} 0x2100 0 {NOTE.encode().hex()}
5.6 sdo_read {DUAL_NODE} 0x2100 0
5.9 quit
"""


def two_axis_config(path, protocol):
    """can_checks.py's configuration with both wheels on node 1: axis 1 left, axis 2 right."""
    ORIGINAL_WRITE_CONFIG(path, protocol)
    text = open(path).read()
    for old, new in ((f"  left_node_id: {cc.CO_NODES[0]}\n", f"  left_node_id: {DUAL_NODE}\n"),
                     (f"  right_node_id: {cc.CO_NODES[1]}\n  right_axis: 1\n", f"  right_node_id: {DUAL_NODE}\n  right_axis: 2\n")):
        if old not in text:
            raise RuntimeError(f"can_checks.write_config changed: no {old!r}")
        text = text.replace(old, new, 1)
    open(path, "w").write(text)


ORIGINAL_WRITE_CONFIG = cc.write_config


def check_two_axis(bins, tmp):
    import canopen  # noqa: F401 (the independent drive's library)
    eds = os.path.join(cc.ROOT, "can_bridge", "eds", "oldbf_cia402_dual_drive.eds")
    report = os.path.join(tmp, "cia402_dual_drive.json")
    drive_cmd = [sys.executable, os.path.join(cc.ROOT, "tests", "can", "cia402_dual_drive.py"), "--channel", "vcan0",
                 "--eds", eds, "--node", str(DUAL_NODE), "--out", report,
                 "--fault-axis", "2", "--fault-code", hex(cc.CO_FAULT_CODE), "--fault-after-s", "0.6"]
    cc.write_config = two_axis_config
    try:
        frames, lines, wall = cc.run_session(bins, "cia402", TWO_AXIS_SCRIPT, [], tmp, drive_cmd=drive_cmd)
    finally:
        cc.write_config = ORIGINAL_WRITE_CONFIG
    cc.RESULTS["two_axis_session_s"] = round(wall, 2)
    rep = json.load(open(report)) if os.path.exists(report) else None
    cc.check(rep is not None, "two_axis: the python-canopen two-axis node ran and wrote its report",
             f"python-canopen {canopen.__version__}, EDS can_bridge/eds/oldbf_cia402_dual_drive.eds")
    if rep is None:
        return
    node = rep["node"]
    n = DUAL_NODE

    # 1. Every frame: NMT, SYNC, the bridge's heartbeat, or node 1's service with its length.
    kinds = {(0x700 + n, 1): "hb", (0x600 + n, 8): "sdo_req", (0x580 + n, 8): "sdo_resp", (0x080 + n, 8): "emcy",
             (0x200 + n, 6): "rpdo1", (0x300 + n, 6): "rpdo2", (0x180 + n, 5): "tpdo1", (0x280 + n, 8): "tpdo2",
             (0x380 + n, 5): "tpdo3", (0x480 + n, 8): "tpdo4"}
    ev, bad = [], []
    for ts, ident, ext, data in frames:
        if ext:
            kind = None
        elif ident == 0x000 and len(data) == 2:
            kind = "nmt"
        elif ident == 0x080 and len(data) == 0:
            kind = "sync"
        elif ident == 0x700 + cc.CO_BRIDGE_ID and len(data) == 1:
            kind = "bridge_hb"
        else:
            kind = kinds.get((ident, len(data)))
        if kind is None:
            bad.append(f"0x{ident:X}#{data.hex()}")
            continue
        ev.append((ts, kind, data))
    cc.check(not bad and len(ev) > 500, "two_axis: every frame is NMT, SYNC, a heartbeat, SDO, EMCY, RPDO1/RPDO2 or "
             "TPDO1-4 of node 1 with its length; nothing for a second node", f"{len(ev)} frames; unexpected {bad[:5]}")

    def u16(d, at):
        return struct.unpack_from("<H", d, at)[0]

    def i32(d, at):
        return struct.unpack_from("<i", d, at)[0]

    rpdo = {k: [(t, u16(d, 0), i32(d, 2)) for t, kk, d in ev if kk == k] for k in ("rpdo1", "rpdo2")}
    tpdo = {k: [(t, u16(d, 0), u16(d, 2)) for t, kk, d in ev if kk == k] for k in ("tpdo1", "tpdo3")}
    nmt = [(t, d[0], d[1]) for t, k, d in ev if k == "nmt"]

    # 2. Start-up: per start-up one NMT pre-operational and one start for the node; both axes' writes.
    pre = [t for t, c, m in nmt if c == 0x80 and m == n]
    start = [t for t, c, m in nmt if c == 0x01 and m == n]
    first_start = start[0] if start else None
    writes = {}
    for t, k, d in ev:
        if k == "sdo_req" and first_start and t <= first_start and d[0] in (0x23, 0x27, 0x2B, 0x2F):
            size = 4 - ((d[0] >> 2) & 3)
            writes[(u16(d, 1), d[3])] = int.from_bytes(d[4:4 + size], "little")
    accel = cc.round_half_away(cc.CO_ACCEL * cc.CO_RPM_PER_RADPS)
    qs = cc.round_half_away(cc.CO_QS * cc.CO_RPM_PER_RADPS)
    want = {(0x6060, 0): 3, (0x6083, 0): accel, (0x6085, 0): qs,
            (0x6860, 0): 3, (0x6883, 0): accel, (0x6884, 0): accel, (0x6885, 0): qs,
            (0x1600, 1): 0x60400010, (0x1600, 2): 0x60FF0020,
            (0x1401, 1): 0x300 + n, (0x1601, 1): 0x68400010, (0x1601, 2): 0x68FF0020, (0x1601, 0): 2,
            (0x1802, 1): 0x380 + n, (0x1A02, 1): 0x68410010, (0x1A02, 2): 0x683F0010, (0x1A02, 3): 0x68610008,
            (0x1803, 1): 0x480 + n, (0x1A03, 1): 0x68640020, (0x1A03, 2): 0x686C0020,
            (0x1016, 1): (cc.CO_BRIDGE_ID << 16) | cc.CO_CONSUMER_MS, (0x1017, 0): cc.CO_DRIVE_HB_MS}
    wrong = {f"0x{i:04X}:{s:02X}": (writes.get((i, s)), v) for (i, s), v in want.items() if writes.get((i, s)) != v}
    held = {f"0x{i:04X}:{s:02X}": (node["written"].get(f"0x{i:04X}:{s:02X}"), v) for (i, s), v in want.items()
            if node["written"].get(f"0x{i:04X}:{s:02X}") != v}
    ok = len(pre) >= 2 and len(start) == len(pre) and not wrong and not held and node["counters"]["pdo_reads"] >= 1
    cc.check(ok, "two_axis: start-up = one NMT pre-operational and start for the node; SDO writes of both axes "
             "(0x6060/0x6860 = 3, 0x6083/0x6883 = 9549 rpm/s, RPDO2 0x301 -> 0x6840/0x68FF, TPDO3 0x381, TPDO4 0x481) "
             "held by python-canopen's dictionary",
             f"{len(pre)} pre-op, {len(start)} start; written mismatches {wrong}; dictionary mismatches {held}; "
             f"python-canopen's RPDO maps {node['counters']['rpdo_maps']}")

    # 3. Each axis enabled by its own RPDO: 0x0006 -> 0x0007 -> 0x000F at zero target, no motion
    #    before its own statusword (TPDO1 / TPDO3) says operation enabled.
    ok, details = True, []
    for rk, tk in (("rpdo1", "tpdo1"), ("rpdo2", "tpdo3")):
        r = rpdo[rk]
        enables = [j for j in range(len(r)) if r[j][1] == 0x000F and (j == 0 or r[j - 1][1] != 0x000F)]
        for j in enables:
            k = max([m for m in range(j) if r[m][1] in (0x0002, 0x0080, 0x000F)], default=-1)
            seq = [x[1] for x in r[k + 1:j]]
            good = 0x0006 in seq and 0x0007 in seq and all(x[2] == 0 for x in r[k + 1:j + 1])
            t_on = next((t for t, sw, _ in tpdo[tk] if t > r[j][0] and cc.co_state(sw) == "operation_enabled"), None)
            early = [x for x in r[j:] if x[2] != 0 and (t_on is None or x[0] < t_on)]
            good &= not early
            ok &= good
            details.append(f"{rk} enable #{enables.index(j) + 1}: early motion {len(early)}")
        ok &= len(enables) >= 2
    nonzero = sum(a["counters"]["enabled_with_nonzero_target"] for a in node["axes"])
    cc.check(ok and nonzero == 0, "two_axis: each axis 0x0006 -> 0x0007 -> 0x000F on its own RPDO at zero target; "
             "no motion before its own statusword says operation enabled (boot, after the fault reset)",
             "; ".join(details) + f"; enabled with a non-zero target {nonzero}")

    # 4. Targets: RPDO1 carries the left wheel's rpm, RPDO2 the right wheel's.
    ok, details = True, []
    for rk, wheel in (("rpdo1", 0), ("rpdo2", 1)):
        vals = [x[2] for x in rpdo[rk]]
        got = [k for k, c, _ in cc.runs(vals) if k != 0 and c >= 5]
        exp = [cc.round_half_away(cc.motor_speeds(v, w)[wheel] * cc.CO_RPM_PER_RADPS) for v, w in ((0.2, 0.5), (-0.1, 0.3))]
        good = exp[0] in got and exp[1] in got and set(got) <= set(exp)
        ok &= good
        details.append(f"{rk}: runs {got}, want {exp} rpm")
    cc.check(ok, "two_axis: RPDO1 target = left wheel, RPDO2 target = right wheel, direction x gear x wheel speed "
             "x 60/2pi rpm, rounded", "; ".join(details))

    # 5. The fault on axis 2 alone: TPDO3 fault with 0x683F = 0x2310 while TPDO1 still says
    #    operation enabled; both targets zero within 2 periods; latched with the right wheel; named.
    T = 1.0 / cc.TX_RATE_HZ
    t_fault = next((t for t, sw, _ in tpdo["tpdo3"] if cc.co_state(sw) == "fault"), None)
    err = next((e for t, sw, e in tpdo["tpdo3"] if cc.co_state(sw) == "fault"), None)
    ok = rep.get("faulted") and t_fault is not None
    if ok:
        axis1_then = [sw for t, sw, _ in tpdo["tpdo1"] if t_fault - 0.1 <= t <= t_fault + 0.1]
        first_reset = next((x for x in rpdo["rpdo2"] if x[0] > t_fault and x[1] == 0x0080), None)
        until = first_reset[0] if first_reset else float("inf")
        moving = [x for k in ("rpdo1", "rpdo2") for x in rpdo[k] if t_fault + 2 * T < x[0] < until and x[2] != 0]
        latched = [l for l in lines if l.get("event") == "drive_fault_latched"]
        named = [l for l in lines if "node 1 axis 2 (right wheel) fault, error code 0x2310" in (l.get("message") or "")]
        emcy = [d for t, k, d in ev if k == "emcy"]
        ok = (err == cc.CO_FAULT_CODE and axis1_then and all(cc.co_state(sw) == "operation_enabled" for sw in axis1_then)
              and not moving and latched and latched[0]["wheel"] == "right" and latched[0]["error_code"] == cc.CO_FAULT_CODE
              and named and emcy and u16(emcy[0], 0) == cc.CO_FAULT_CODE and emcy[0][3] == 2)
        cc.check(ok, "two_axis: a fault on axis 2 alone (TPDO3 fault, 0x683F = 0x2310, EMCY naming axis 2; axis 1 "
                     "still operation enabled) -> both wheels' targets zero within 2 periods, drive_fault latched for the "
                     "right wheel with 0x2310, reported as node 1 axis 2",
                 f"fault at {t_fault:.3f}; axis 1 around it {[hex(x) for x in axis1_then[:3]]}; non-zero targets after "
                 f"{len(moving)}; latched {[(l['wheel'], hex(l['error_code'])) for l in latched]}; named {len(named)}; "
                 f"EMCY {[d.hex() for d in emcy]}")
        # 6. Recovery: the fault reset goes to RPDO2 only, then both axes run segment 2.
        resets1 = [x for x in rpdo["rpdo1"] if x[1] == 0x0080]
        after = {k: [x[2] for x in rpdo[k] if first_reset and x[0] > first_reset[0]] for k in ("rpdo1", "rpdo2")}
        exp2 = [cc.round_half_away(cc.motor_speeds(-0.1, 0.3)[w] * cc.CO_RPM_PER_RADPS) for w in (0, 1)]
        ok = (first_reset is not None and not resets1 and exp2[0] in after["rpdo1"] and exp2[1] in after["rpdo2"]
              and node["axes"][1]["counters"]["fault_resets"] == 1 and node["axes"][0]["counters"]["fault_resets"] == 0)
        cc.check(ok, "two_axis: after ~reset the fault reset (0x0080) goes on RPDO2 only and both axes drive again",
                 f"fault reset on RPDO1 {len(resets1)}, python axis resets "
                 f"{[a['counters']['fault_resets'] for a in node['axes']]}, targets after {exp2} seen "
                 f"{[exp2[0] in after['rpdo1'], exp2[1] in after['rpdo2']]}")
    else:
        cc.check(False, "two_axis: fault injected on axis 2 by the python node", f"faulted {rep.get('faulted')}, seen {t_fault}")

    # 7. SDO at run time through the CLI, against python-canopen's SDO server.
    sdo = [l for l in lines if l.get("type") == "sdo"]
    name = next((l for l in sdo if l.get("index") == 0x1008), None)
    refused = next((l for l in sdo if l.get("index") == 0x6883), None)
    wrote = next((l for l in sdo if l.get("index") == 0x2100 and l.get("write")), None)
    readback = next((l for l in sdo if l.get("index") == 0x2100 and not l.get("write")), None)
    seg_init = [d for t, k, d in ev if k == "sdo_resp" and d[0] == 0x41 and u16(d, 1) == 0x1008]
    # The refused value (1000) never on the wire; the start-ups' own 9549 is.
    sent_6883 = [d for t, k, d in ev if k == "sdo_req" and u16(d, 1) == 0x6883 and i32(d, 4) == 1000]
    seg_down = [d for t, k, d in ev if k == "sdo_req" and d[0] == 0x21 and u16(d, 1) == 0x2100]
    ok = (name and name["ok"] and name.get("text") == "oldbf dual-axis CiA 402 test drive" and seg_init
          and refused and not refused["ok"] and refused["refused"] and refused["abort_code"] == 0x08000022 and not sent_6883
          and wrote and wrote["ok"] and seg_down and node["written"].get("0x2100:00") == NOTE
          and readback and readback["ok"] and readback.get("text") == NOTE)
    cc.check(ok, "two_axis: SDO at run time: 0x1008 read by segmented upload (python-canopen answers 0x41 + size); "
                 "a 0x6883 write refused while axis 1 is enabled (0x08000022, no frame); after the e-stop a 32-byte "
                 "segmented write of 0x2100 stored by python-canopen and read back",
             f"read {name and (name['ok'], name.get('text'))}; refused {refused and (refused['abort_code'], refused['message'])}; "
             f"write {wrote and (wrote['ok'], wrote['message'])}, python holds {node['written'].get('0x2100:00')!r}; "
             f"read back {readback and readback.get('text')!r}; 0x6883 = 1000 frames {len(sent_6883)}")

    # 8. Odometry from TPDO2 and TPDO4.
    final = [l for l in lines if l.get("type") == "final"]
    odo = final[0].get("odometry") if final else None
    cc.check(bool(odo) and odo["updates"] > 50 and all(math.isfinite(v) for v in odo["pose"].values()),
             "two_axis: odometry integrates TPDO2 (left) and TPDO4 (right)", f"{odo and odo['updates']} updates")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin-dir", required=True, help="directory with can_bridge_cli and virtual_drive")
    ap.add_argument("--only", nargs="*", help="run only these checks (odrive06, two_axis)")
    a = ap.parse_args()
    for b in ("can_bridge_cli", "virtual_drive"):
        if not os.access(os.path.join(a.bin_dir, b), os.X_OK):
            cc.check(False, f"binary {b} in {a.bin_dir}")
    if not os.path.isdir("/sys/class/net/vcan0"):
        cc.check(False, "vcan0 exists (run inside tests/vm/run-in-vm.sh)")
    if not cc.FAILS:
        with tempfile.TemporaryDirectory() as tmp:
            for name, fn in (("odrive06", check_odrive06), ("two_axis", check_two_axis)):
                if a.only and name not in a.only:
                    continue
                try:
                    fn(a.bin_dir, tmp)
                except Exception as e:  # noqa: BLE001
                    cc.check(False, f"{name}: check crashed", repr(e))
    print(f"drive_variant_checks: {len(cc.FAILS)} failed" if cc.FAILS else "drive_variant_checks: all passed", flush=True)
    sys.exit(1 if cc.FAILS else 0)


if __name__ == "__main__":
    main()
