#!/usr/bin/env python3
"""candump checks of the drives legacy robots carry (issue 27), on a real
(virtual) CAN bus inside the QEMU guest (tests/vm/can_guest.sh):

  odrive06  the bridge against the virtual drive playing ODrive firmware
            0.6; every frame decoded with cantools against our 0.6 DBC
            (can_bridge/dbc/odrive-cansimple-0.6.dbc): ids, lengths, the
            start-up order, Set_Input_Vel = kinematics, the 0.6 heartbeat
            (Procedure_Result, Trajectory_Done_Flag), Get_Error, e-stop with
            0.6's ESTOP_REQUESTED (0x02000000) and the bridge's report naming it.

Shares can_checks.py's helpers (candump session, PASS/FAIL lines, the test
geometry). Prints PASS/FAIL per check; exits 1 if any failed.

  drive_variant_checks.py --bin-dir target/release [--only odrive06 ...]
"""

import argparse
import math
import os
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


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin-dir", required=True, help="directory with can_bridge_cli and virtual_drive")
    ap.add_argument("--only", nargs="*", help="run only these checks (odrive06)")
    a = ap.parse_args()
    for b in ("can_bridge_cli", "virtual_drive"):
        if not os.access(os.path.join(a.bin_dir, b), os.X_OK):
            cc.check(False, f"binary {b} in {a.bin_dir}")
    if not os.path.isdir("/sys/class/net/vcan0"):
        cc.check(False, "vcan0 exists (run inside tests/vm/run-in-vm.sh)")
    if not cc.FAILS:
        with tempfile.TemporaryDirectory() as tmp:
            for name, fn in (("odrive06", check_odrive06),):
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
