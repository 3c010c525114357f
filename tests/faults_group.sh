#!/usr/bin/env bash
# tests/faults_group.sh: fault injection into the running ROS + CAN system,
# in ONE boot of the QEMU guest (this machine's kernel has no CAN). The guest
# (tests/vm/faults_guest.sh) runs roscore, the virtual drive, can_bridge_node
# and oldbf_node on vcan0 and injects, in turn: oldbf_node SIGKILL, absurd
# and NaN /cmd_vel straight to the bridge, frozen / out-of-order / all-NaN /
# all-inf / all-zero scans, a wall-clock step back, can_bridge_node SIGKILL,
# an axis error and heartbeat silence in the drive, a bus-off error frame;
# then, with a CANopen CiA 402 drive and bridge (protocol cia402): a drive
# fault, heartbeat loss, a drive reboot whose SDO server stays silent (SDO
# timeout at start-up), a bus-off; and a roscore restart. Each is timed from its onset to zero setpoints on
# vcan0 (tests/faults/analyze.py) against a limit derived from config/.
# Results: target/faults/results.md (a passing copy: docs/results/faults.md).
#
# Installs what it needs (ROS packages, can-utils, the guest kernel), builds
# and installs the nodes, then boots the guest.
set -Eeuo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd -P)
cd "$ROOT"
t0=$(date +%s)
tests/ros/install_deps.sh
tests/vm/setup-host.sh > /dev/null
OUT=$ROOT/target/faults
rm -rf "$OUT"; mkdir -p "$OUT"
oldbf_ros/rospkg/install.sh > "$OUT/install.log" 2>&1 || { tail -20 "$OUT/install.log"; exit 1; }
# The nodes' parameters, as roslaunch would load them (config/ files), with
# the test's choices: ODrive protocol (float setpoints: a NaN could show), a
# constant nominal command, no markers.
/usr/bin/python3 - "$ROOT" "$OUT/params.yaml" <<'PY'
import sys, yaml
root, out = sys.argv[1], sys.argv[2]
load = lambda n: yaml.safe_load(open(f"{root}/config/{n}"))
bridge = {**load("can_bridge.yaml"), **load("can_bridge_node.yaml")}
bridge["protocol"] = "odrive"
bridge["interface"] = "vcan0"
# The CiA 402 cases: the same bridge parameters with protocol cia402, for a
# second bridge node (can_bridge_co) that replaces the ODrive one in the run.
co = dict(bridge, protocol="cia402")
node = {**load("oldbf.yaml"), **load("oldbf_node.yaml")}
node["node"]["nominal_source"] = "constant"
node["node"]["publish_markers"] = False
yaml.safe_dump({"can_bridge_node": bridge, "can_bridge_co": co, "oldbf_node": node}, open(out, "w"))
PY
echo "faults_group: prepared in $(( $(date +%s) - t0 )) s; booting the guest"
t1=$(date +%s)
guest_rc=0
OLDBF_VM_TIMEOUT=${OLDBF_VM_TIMEOUT:-600} tests/vm/run-in-vm.sh "$ROOT/tests/vm/faults_guest.sh" || guest_rc=$?
echo "faults_group: guest run took $(( $(date +%s) - t1 )) s (status $guest_rc)"
# The analysis on the host: python cantools comes with tests/vm/setup-host.sh.
python3 -c 'import cantools' 2>/dev/null || { echo "faults_group: python3 cannot import cantools: run tests/vm/setup-host.sh"; exit 1; }
rc=0
python3 tests/faults/analyze.py "$OUT" || rc=$?
echo "faults_group: total $(( $(date +%s) - t0 )) s"
[ "$guest_rc" -eq 0 ] || { echo "faults_group: the guest failed (status $guest_rc)"; exit 1; }
exit "$rc"
