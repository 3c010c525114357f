#!/usr/bin/env python3
"""ONE CANopen node with TWO CiA 402 axes (profile velocity), the way a
dual-channel controller such as a Roboteq carries both wheels, played by
python-canopen on a SocketCAN interface from
can_bridge/eds/oldbf_cia402_dual_drive.eds: an implementation independent
of the bridge's Rust code.

python-canopen provides the node: its object dictionary (axis 1 at the
standard objects 0x6040/0x6041/0x60FF/0x606C/..., axis 2 at +0x800:
0x6840/0x6841/0x68FF/0x686C/...), the SDO server (expedited and
segmented: 0x1008, 0x2100 are longer than 4 bytes), NMT with boot-up and
heartbeat (0x1017), EMCY, and the PDOs packed and unpacked from the maps
the bridge wrote over SDO (read back at NMT start). This script adds what
the drive does, per axis: the CiA 402 state machine (CiA 402 Tables 3 and
5, shared with cia402_drive.py), profile velocity with an instant response,
SYNC handling, and a fault injected on one axis alone.

Which axis a PDO belongs to is read from its mapped objects' indices (a
CiA 402 object of axis n sits (n - 1) x 0x800 above axis 1's), never from
the PDO number: a wrong mapping written by the bridge shows as wrong values.

  cia402_dual_drive.py --channel vcan0 --eds EDS --node 1 --out OUT.json
                       [--fault-axis 2 --fault-code 0x2310 --fault-after-s 0.6]

The fault: FAULT_AFTER_S seconds after the axis first got a non-zero target
velocity, that axis alone goes to fault (its 0x603F + offset = FAULT_CODE,
EMCY with the axis number in the manufacturer bytes); the other axis keeps
its state. On SIGTERM the script writes OUT.json: the dictionary values the
bridge wrote, per axis the state history and counters.
"""

import argparse
import json
import os
import signal
import sys
import threading
import time

import canopen

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cia402_drive import REMOTE, STATUSWORD, TRANSITIONS, VOLTAGE_ENABLED, command  # noqa: E402

AXIS_OFFSET = 0x800


def axis_of(index):
    """(axis number, axis 1's index) of a CiA 402 object; None outside 0x6000-0x6FFF."""
    if not 0x6000 <= index < 0x6000 + 2 * AXIS_OFFSET:
        return None
    k = (index - 0x6000) // AXIS_OFFSET
    return k + 1, index - k * AXIS_OFFSET


class AxisMachine:
    """One axis: the CiA 402 state machine and profile velocity."""

    def __init__(self, number, counts_per_rev):
        self.number = number
        self.counts_per_rev = counts_per_rev
        self.state = "switch_on_disabled"  # after transitions 0 and 1
        self.prev_cw = 0
        self.pending = None  # synchronous RPDO data waiting for SYNC
        self.target_rpm = 0
        self.vel_rpm = 0
        self.pos_counts = 0.0
        self.error_code = 0
        self.last_sync = None
        self.first_motion = None
        self.history = []  # (t, state, transition, controlword, target)
        self.counters = {"rpdos": 0, "enabled_with_nonzero_target": 0, "quick_stops": 0, "fault_resets": 0}

    def apply(self, cw, target):
        self.target_rpm = target
        cmd = command(cw)
        if cmd == "fault_reset":
            if self.state == "fault" and not self.prev_cw & 0x80:
                self.state = "switch_on_disabled"  # transition 15
                self.error_code = 0
                self.counters["fault_resets"] += 1
                self.history.append((time.time(), self.state, 15, cw, target))
        elif (self.state, cmd) in TRANSITIONS:
            self.state, n = TRANSITIONS[(self.state, cmd)]
            self.history.append((time.time(), self.state, n, cw, target))
            if self.state == "operation_enabled" and target != 0:
                self.counters["enabled_with_nonzero_target"] += 1
            if self.state == "quick_stop_active":
                self.counters["quick_stops"] += 1
        self.prev_cw = cw

    def statusword(self):
        s = STATUSWORD[self.state] | REMOTE
        if self.state in ("ready_to_switch_on", "switched_on", "operation_enabled", "quick_stop_active"):
            s |= VOLTAGE_ENABLED
        return s

    def advance(self, now, mode):
        """At SYNC: the quick stop ends at standstill; the motor follows the target at once."""
        if self.state == "quick_stop_active":
            self.state = "switch_on_disabled"  # quick stop option code 2: stopped, then transition 12
            self.history.append((time.time(), self.state, 12, self.prev_cw, 0))
        enabled = self.state == "operation_enabled" and mode == 3
        self.vel_rpm = self.target_rpm if enabled else 0
        if self.vel_rpm and self.first_motion is None:
            self.first_motion = now
        if self.last_sync is not None:
            self.pos_counts += self.vel_rpm / 60.0 * self.counts_per_rev * (now - self.last_sync)
        self.last_sync = now

    def report(self):
        return {"axis": self.number, "state": self.state, "history": self.history, "counters": self.counters,
                "pos_counts": self.pos_counts}


class DualNode:
    def __init__(self, network, node_id, eds, counts_per_rev):
        self.node = canopen.LocalNode(node_id, eds)
        network.add_node(self.node)
        self.network = network
        self.id = node_id
        self.axes = {1: AxisMachine(1, counts_per_rev), 2: AxisMachine(2, counts_per_rev)}
        self.lock = threading.Lock()
        self.counters = {"syncs": 0, "tpdos": 0, "nmt_start": 0, "pdo_reads": 0, "rpdo_maps": []}
        network.subscribe(0x000, self.on_nmt)
        # Power-on: boot-up message, then pre-operational with the EDS heartbeat (0x1017).
        network.send_message(0x700 + node_id, [0x00])
        self.node.nmt.send_command(0x80)

    def on_nmt(self, can_id, data, timestamp):
        if len(data) == 2 and data[0] == 0x01 and data[1] in (0, self.id):
            # Operational: the PDO maps as the bridge wrote them into the dictionary.
            self.counters["nmt_start"] += 1
            for maps in (self.node.rpdo, self.node.tpdo):
                for m in maps.map.values():
                    if m.enabled and m.cob_id is not None:
                        self.network.unsubscribe(m.cob_id, m.on_message)
                    m.callbacks = []
            self.node.rpdo.read()
            self.node.tpdo.read()
            self.counters["pdo_reads"] += 1
            self.counters["rpdo_maps"] = []
            for m in self.node.rpdo.map.values():
                if m.enabled and len(m.map):
                    m.add_callback(self.on_rpdo)
                    self.counters["rpdo_maps"].append([hex(m.cob_id), [hex(v.index) for v in m.map]])

    def on_rpdo(self, m):
        if self.node.nmt.state != "OPERATIONAL":
            return
        values = {}
        for v in m.map:
            ax = axis_of(v.index)
            if ax is not None:
                values.setdefault(ax[0], {})[ax[1]] = v.raw
        with self.lock:
            for n, vals in values.items():
                if 0x6040 not in vals or 0x60FF not in vals or n not in self.axes:
                    continue
                a = self.axes[n]
                a.counters["rpdos"] += 1
                self.node.data_store.setdefault(0x6040 + (n - 1) * AXIS_OFFSET, {})[0] = vals[0x6040].to_bytes(2, "little")
                if m.trans_type is not None and m.trans_type <= 240:
                    a.pending = (vals[0x6040], vals[0x60FF])
                else:
                    a.apply(vals[0x6040], vals[0x60FF])

    def mode(self, n):
        raw = self.node.data_store.get(0x6060 + (n - 1) * AXIS_OFFSET, {}).get(0, b"\0")
        return int.from_bytes(raw, "little", signed=True)

    def fault(self, n, code):
        a = self.axes[n]
        with self.lock:
            a.state = "fault"  # transitions 13 and 14
            a.error_code = code
            a.history.append((time.time(), "fault", 13, a.prev_cw, a.target_rpm))
        self.node.emcy.send(code, 0x03, bytes([n, 0, 0, 0, 0]))

    def on_sync(self, now):
        if self.node.nmt.state != "OPERATIONAL":
            return
        with self.lock:
            self.counters["syncs"] += 1
            for n, a in self.axes.items():
                if a.pending is not None:
                    a.apply(*a.pending)
                    a.pending = None
                a.advance(now, self.mode(n))
            for m in self.node.tpdo.map.values():
                if not (m.enabled and m.trans_type is not None and m.trans_type <= 240):
                    continue
                for v in m.map:
                    ax = axis_of(v.index)
                    if ax is None or ax[0] not in self.axes:
                        continue
                    a = self.axes[ax[0]]
                    base = ax[1]
                    if base == 0x6041:
                        v.raw = a.statusword()
                    elif base == 0x603F:
                        v.raw = a.error_code
                    elif base == 0x6061:
                        v.raw = self.mode(ax[0])
                    elif base == 0x6064:
                        pos = int(round(a.pos_counts)) & 0xFFFFFFFF
                        v.raw = pos - (1 << 32) if pos >= 1 << 31 else pos
                    elif base == 0x606C:
                        v.raw = a.vel_rpm
        for m in self.node.tpdo.map.values():
            if m.enabled and m.trans_type is not None and m.trans_type <= 240 and len(m.map):
                m.transmit()
                self.counters["tpdos"] += 1

    def report(self):
        written = {}
        for index, subs in sorted(self.node.data_store.items()):
            for sub, raw in sorted(subs.items()):
                key = f"0x{index:04X}:{sub:02X}"
                obj = self.node.object_dictionary.get_variable(index, sub)
                if obj is not None and obj.data_type == canopen.objectdictionary.VISIBLE_STRING:
                    written[key] = raw.decode("ascii", "replace")
                else:
                    signed = axis_of(index) is not None and axis_of(index)[1] in (0x6060, 0x60FF)
                    written[key] = int.from_bytes(raw, "little", signed=signed)
        return {"node": self.id, "written": written, "nmt": self.node.nmt.state, "counters": self.counters,
                "axes": [a.report() for a in self.axes.values()]}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--channel", default="vcan0")
    ap.add_argument("--eds", required=True)
    ap.add_argument("--node", type=int, default=1)
    ap.add_argument("--counts-per-rev", type=int, default=4096)
    ap.add_argument("--out", required=True)
    ap.add_argument("--fault-axis", type=int, choices=(1, 2))
    ap.add_argument("--fault-code", type=lambda s: int(s, 0), default=0x2310)
    ap.add_argument("--fault-after-s", type=float, default=0.6)
    a = ap.parse_args()

    network = canopen.Network()
    network.connect(interface="socketcan", channel=a.channel)
    node = DualNode(network, a.node, a.eds, a.counts_per_rev)
    network.subscribe(0x080, lambda can_id, data, ts: node.on_sync(time.monotonic()))

    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    faulted = False
    print("cia402_dual_drive: ready", flush=True)
    while not stop.is_set():
        if a.fault_axis and not faulted:
            ax = node.axes[a.fault_axis]
            if ax.first_motion is not None and time.monotonic() - ax.first_motion >= a.fault_after_s:
                node.fault(a.fault_axis, a.fault_code)
                faulted = True
        stop.wait(0.01)
    with open(a.out, "w") as f:
        json.dump({"node": node.report(), "faulted": faulted}, f)
    node.node.nmt.stop_heartbeat()
    network.disconnect()


if __name__ == "__main__":
    main()
