#!/usr/bin/env python3
"""Two CiA 402 drives (profile velocity) played by python-canopen on a
SocketCAN interface, from can_bridge/eds/oldbf_cia402_drive.eds: an
implementation independent of the bridge's Rust code.

python-canopen provides the object dictionary (from the EDS), the SDO
server, NMT with boot-up and heartbeat producer (0x1017), EMCY and the PDO
machinery: after NMT start the PDO maps are read back from the dictionary
the bridge wrote over SDO, and RPDO1 / TPDO1 / TPDO2 are packed and unpacked
by python-canopen with them. This script adds what a drive does: the CiA
402 state machine, written here from CiA 402 Table 3 (controlword commands)
and Table 5 (statusword), profile velocity with an instant response, SYNC
handling (synchronous RPDOs take effect at SYNC, synchronous TPDOs are sent
after it), and one injected fault.

  cia402_drive.py --channel vcan0 --eds EDS --nodes 1 2 --out OUT.json
                  [--fault-node 1 --fault-code 0x2310 --fault-after-s 0.6]

The fault: FAULT_AFTER_S seconds after the node first got a non-zero target
velocity, the node goes to fault (0x603F = FAULT_CODE, EMCY). On SIGTERM the
script writes OUT.json: per node the dictionary values the bridge wrote,
the state history and counters.
"""

import argparse
import json
import signal
import threading
import time

import canopen

# CiA 402 Table 5: statusword bits of each state.
STATUSWORD = {
    "not_ready_to_switch_on": 0x0000,
    "switch_on_disabled": 0x0040,
    "ready_to_switch_on": 0x0021,
    "switched_on": 0x0023,
    "operation_enabled": 0x0027,
    "quick_stop_active": 0x0007,
    "fault_reaction_active": 0x000F,
    "fault": 0x0008,
}
VOLTAGE_ENABLED, REMOTE = 0x0010, 0x0200


def command(cw):
    """CiA 402 Table 3: the device control command of a controlword (bit 7 aside)."""
    if cw & 0x0080:
        return "fault_reset"
    if cw & 0x0082 == 0x0000:
        return "disable_voltage"  # x x x 0 x
    if cw & 0x0086 == 0x0002:
        return "quick_stop"  # x x 0 1 x
    if cw & 0x0087 == 0x0006:
        return "shutdown"  # x 1 1 0
    if cw & 0x008F == 0x0007:
        return "switch_on"  # 0 1 1 1 (also disable operation)
    if cw & 0x008F == 0x000F:
        return "enable_operation"  # 1 1 1 1
    return None


# CiA 402 Figure 1: (state, command) -> (next state, transition number).
TRANSITIONS = {
    ("switch_on_disabled", "shutdown"): ("ready_to_switch_on", 2),
    ("ready_to_switch_on", "switch_on"): ("switched_on", 3),
    ("ready_to_switch_on", "enable_operation"): ("operation_enabled", 4),  # 3 + 4
    ("switched_on", "enable_operation"): ("operation_enabled", 4),
    ("operation_enabled", "switch_on"): ("switched_on", 5),
    ("switched_on", "shutdown"): ("ready_to_switch_on", 6),
    ("ready_to_switch_on", "quick_stop"): ("switch_on_disabled", 7),
    ("ready_to_switch_on", "disable_voltage"): ("switch_on_disabled", 7),
    ("operation_enabled", "shutdown"): ("ready_to_switch_on", 8),
    ("operation_enabled", "disable_voltage"): ("switch_on_disabled", 9),
    ("switched_on", "disable_voltage"): ("switch_on_disabled", 10),
    ("switched_on", "quick_stop"): ("switch_on_disabled", 10),
    ("operation_enabled", "quick_stop"): ("quick_stop_active", 11),
    ("quick_stop_active", "disable_voltage"): ("switch_on_disabled", 12),
}


class Axis:
    def __init__(self, network, node_id, eds, counts_per_rev):
        self.node = canopen.LocalNode(node_id, eds)
        network.add_node(self.node)
        self.network = network
        self.id = node_id
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
        self.counters = {"rpdos": 0, "syncs": 0, "tpdos": 0, "enabled_with_nonzero_target": 0,
                         "quick_stops": 0, "fault_resets": 0, "nmt_start": 0, "pdo_reads": 0}
        self.lock = threading.Lock()
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
            self.node.rpdo[1].add_callback(self.on_rpdo)
            self.counters["pdo_reads"] += 1

    def on_rpdo(self, m):
        if self.node.nmt.state != "OPERATIONAL":
            return
        values = (m["Controlword"].raw, m["Target velocity"].raw)
        self.counters["rpdos"] += 1
        with self.lock:
            if m.trans_type is not None and m.trans_type <= 240:
                self.pending = values
            else:
                self.apply(values)

    def apply(self, values):
        cw, target = values
        self.node.data_store.setdefault(0x6040, {})[0] = cw.to_bytes(2, "little")
        self.target_rpm = target
        before = self.state
        cmd = command(cw)
        if cmd == "fault_reset":
            if self.state == "fault" and not self.prev_cw & 0x80:
                self.state, n = "switch_on_disabled", 15
                self.error_code = 0
                self.counters["fault_resets"] += 1
                self.history.append((time.time(), self.state, n, cw, target))
        elif (self.state, cmd) in TRANSITIONS:
            self.state, n = TRANSITIONS[(self.state, cmd)]
            self.history.append((time.time(), self.state, n, cw, target))
            if self.state == "operation_enabled" and target != 0:
                self.counters["enabled_with_nonzero_target"] += 1
            if self.state == "quick_stop_active":
                self.counters["quick_stops"] += 1
        self.prev_cw = cw
        return before != self.state

    def fault(self, code):
        with self.lock:
            self.state = "fault"  # transitions 13 and 14
            self.error_code = code
            self.history.append((time.time(), "fault", 13, self.prev_cw, self.target_rpm))
        self.node.emcy.send(code, 0x03)

    def statusword(self):
        s = STATUSWORD[self.state] | REMOTE
        if self.state in ("ready_to_switch_on", "switched_on", "operation_enabled", "quick_stop_active"):
            s |= VOLTAGE_ENABLED
        return s

    def on_sync(self, now):
        if self.node.nmt.state != "OPERATIONAL":
            return
        with self.lock:
            self.counters["syncs"] += 1
            if self.pending is not None:
                self.apply(self.pending)
                self.pending = None
            mode = int.from_bytes(self.node.data_store.get(0x6060, {}).get(0, b"\0"), "little", signed=True)
            enabled = self.state == "operation_enabled" and mode == 3
            if self.state == "quick_stop_active":
                self.state = "switch_on_disabled"  # quick stop option code 2: stopped, then transition 12
                self.history.append((time.time(), self.state, 12, self.prev_cw, 0))
            self.vel_rpm = self.target_rpm if enabled else 0
            if self.vel_rpm and self.first_motion is None:
                self.first_motion = now
            if self.last_sync is not None:
                self.pos_counts += self.vel_rpm / 60.0 * self.counts_per_rev * (now - self.last_sync)
            self.last_sync = now
            t1, t2 = self.node.tpdo[1], self.node.tpdo[2]
            t1["Statusword"].raw = self.statusword()
            t1["Error code"].raw = self.error_code
            t1["Modes of operation display"].raw = mode
            pos = int(round(self.pos_counts)) & 0xFFFFFFFF
            t2["Position actual value"].raw = pos - (1 << 32) if pos >= 1 << 31 else pos
            t2["Velocity actual value"].raw = self.vel_rpm
        for m in (t1, t2):
            if m.enabled and m.trans_type is not None and m.trans_type <= 240:
                m.transmit()
                self.counters["tpdos"] += 1

    def report(self):
        written = {}
        for index, subs in sorted(self.node.data_store.items()):
            for sub, raw in sorted(subs.items()):
                written[f"0x{index:04X}:{sub:02X}"] = int.from_bytes(raw, "little", signed=index in (0x6060, 0x60FF))
        return {"node": self.id, "written": written, "state": self.state, "history": self.history,
                "counters": self.counters, "nmt": self.node.nmt.state, "pos_counts": self.pos_counts}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--channel", default="vcan0")
    ap.add_argument("--eds", required=True)
    ap.add_argument("--nodes", type=int, nargs=2, default=[1, 2])
    ap.add_argument("--counts-per-rev", type=int, default=4096)
    ap.add_argument("--out", required=True)
    ap.add_argument("--fault-node", type=int)
    ap.add_argument("--fault-code", type=lambda s: int(s, 0), default=0x2310)
    ap.add_argument("--fault-after-s", type=float, default=0.6)
    a = ap.parse_args()

    network = canopen.Network()
    network.connect(interface="socketcan", channel=a.channel)
    axes = [Axis(network, n, a.eds, a.counts_per_rev) for n in a.nodes]
    network.subscribe(0x080, lambda can_id, data, ts: [x.on_sync(time.monotonic()) for x in axes])

    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    faulted = False
    print("cia402_drive: ready", flush=True)
    while not stop.is_set():
        for x in axes:
            if x.id == a.fault_node and not faulted and x.first_motion is not None \
                    and time.monotonic() - x.first_motion >= a.fault_after_s:
                x.fault(a.fault_code)
                faulted = True
        stop.wait(0.01)
    with open(a.out, "w") as f:
        json.dump({"axes": [x.report() for x in axes], "faulted": faulted}, f)
    for x in axes:
        x.node.nmt.stop_heartbeat()
    network.disconnect()


if __name__ == "__main__":
    main()
