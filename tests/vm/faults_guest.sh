#!/usr/bin/env bash
# tests/vm/faults_guest.sh: runs INSIDE the QEMU guest (vcan0 up), started by
# tests/faults_group.sh. One roscore, one running system, every fault in turn:
#   roscore; candump -L vcan0; virtual_drive (ODrive CANSimple: floats on the
#   wire); can_bridge_node; oldbf_node (constant nominal 0.15 m/s);
#   tests/faults/scan_source.py (open scans, fault modes); /diagnostics recorder.
# Each injection writes {"mode", "t"} to events.jsonl at the moment it is made;
# tests/faults/analyze.py then measures injection -> zero setpoints on vcan0
# and writes target/faults/results.md.
set -Eeuo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd -P)
OUT=$ROOT/target/faults
cd "$ROOT"
# shellcheck source=/dev/null
source "$ROOT/target/ros/setup.bash"
export ROS_HOSTNAME=localhost ROS_MASTER_URI=http://localhost:11311/ ROS_HOME=$OUT/ros_home RUST_LOG=info
BIN=$ROOT/target/ros/oldbf_ros/bin
ROSPY=/usr/bin/python3
EV=$OUT/events.jsonl
MODE=$OUT/scan_mode
WATCHDOG_S=0.5
echo "$WATCHDOG_S" > "$OUT/drive_watchdog_s"
: > "$EV"; echo ok > "$MODE"
t0=$(date +%s)
say() { echo "faults: [$(( $(date +%s) - t0 )) s] $*"; }
event() { printf '{"mode": "%s", "t": %s}\n' "$1" "${2:-$(date +%s.%N)}" >> "$EV"; }
PIDS=()
cleanup() { for p in "${PIDS[@]}"; do kill -INT "$p" 2>/dev/null || true; done; sleep 0.5; for p in "${PIDS[@]}"; do kill -KILL "$p" 2>/dev/null || true; done; }
trap cleanup EXIT
wait_log() { # file pattern timeout_s
  for _ in $(seq $(( $3 * 10 ))); do grep -q -- "$2" "$1" 2>/dev/null && return 0; sleep 0.1; done
  echo "faults: '$2' not in $1 after $3 s"; tail -20 "$1"; return 1
}
# The master alone: roslaunch's roscore gives up on a master that takes more
# than ~10 s to answer, which happens under emulation on a loaded machine.
start_core() {
  setsid rosmaster --core -p 11311 >> "$OUT/roscore.log" 2>&1 &
  core=$!; PIDS+=("$core")
  for _ in $(seq 600); do rostopic list > /dev/null 2>&1 && return 0; sleep 0.2; done
  echo "faults: the ROS master did not come up"; return 1
}
start_drive() { # n extra-args...
  local n=$1; shift
  "$BIN/virtual_drive" --interface vcan0 --protocol odrive --config config/can_bridge.yaml \
    --watchdog-s "$WATCHDOG_S" "$@" > "$OUT/drive$n.log" 2>&1 &
  drive=$!; PIDS+=("$drive")
}
start_bridge() {
  "$BIN/can_bridge_node" __name:=can_bridge_node >> "$OUT/bridge.log" 2>&1 &
  bridge=$!; PIDS+=("$bridge")
}
start_node() {
  "$BIN/oldbf_node" __name:=oldbf_node >> "$OUT/oldbf_node.log" 2>&1 &
  node=$!; PIDS+=("$node")
}

start_core
say "roscore up"
rosparam load "$OUT/params.yaml" /
candump -L vcan0 > "$OUT/candump.log" 2>&1 &
PIDS+=($!)
start_drive 1
start_bridge
start_node
$ROSPY tests/faults/record_diag.py "$OUT/diag.jsonl" > "$OUT/diag_recorder.log" 2>&1 &
PIDS+=($!)
$ROSPY tests/faults/scan_source.py /scan "$MODE" "$EV" > "$OUT/scan_source.log" 2>&1 &
PIDS+=($!)
wait_log "$OUT/bridge.log" DriveReady 60
wait_log "$OUT/oldbf_node.log" "filtering (" 60
sleep 2
say "driving"

# -- oldbf_node SIGKILL while driving; then absurd commands straight to the bridge
event node_kill; kill -KILL "$node"
sleep 2
$ROSPY tests/faults/pub_cmd.py /cmd_vel "$EV" > "$OUT/pub_cmd.log" 2>&1
start_node
wait_log "$OUT/oldbf_node.log" "filtering (" 30
sleep 2
say "node kill, absurd commands done"

# -- scan faults (the source writes the event when it sends the first bad scan)
for m in frozen out_of_order; do
  echo "$m" > "$MODE"; sleep 2
  event "${m}_end"; echo ok > "$MODE"; sleep 2
done
for m in nan inf zero; do
  echo "$m" > "$MODE"; sleep 2
  event "scan_${m}_end"; echo ok > "$MODE"; sleep 1
done
sed -i 's/"mode": "nan"/"mode": "scan_nan"/; s/"mode": "inf"/"mode": "scan_inf"/; s/"mode": "zero"/"mode": "scan_zero"/' "$EV"
say "scan faults done"

# -- the wall clock steps back 30 s
before=$(date +%s.%N); target=$(( ${before%.*} - 30 ))
date -s "@$target" > /dev/null
printf '{"mode": "clock_jump", "t": %s, "t_before": %s}\n' "$target" "$before" >> "$EV"
sleep 3
event clock_jump_end
say "clock step done"

# -- can_bridge_node SIGKILL: the drive's watchdog; then a new bridge
event bridge_kill; kill -KILL "$bridge"
sleep 2
start_bridge
wait_log "$OUT/bridge.log" "DriveReady" 30
sleep 2
say "bridge kill done"

# -- drive faults, each in a fresh drive with the fault scheduled 5 s after its start
kill -INT "$drive"; wait "$drive" || true
t=$(date +%s.%N); start_drive 2 --fault axis_error@5:0x1:left
event axis_error "$(echo "$t + 5" | bc)"
sleep 8
event axis_reset
rosservice call /can_bridge_node/reset > "$OUT/reset.log" 2>&1 || true
sleep 3
kill -INT "$drive"; wait "$drive" || true
t=$(date +%s.%N); start_drive 3 --fault heartbeat_silence@5+2
event hb_silence "$(echo "$t + 5" | bc)"
event hb_silence_end "$(echo "$t + 7" | bc)"
sleep 10
say "drive faults done"

# -- bus-off error frame
$ROSPY tests/faults/bus_error.py vcan0 busoff "$EV"
sleep 3
say "bus-off done"

# roscore restart: left out (rosrust's master calls block while the master is
# down, so the nodes' MasterWatch never reports; see the faults report).
echo quit > "$MODE"
cleanup; trap - EXIT
$ROSPY tests/faults/analyze.py "$OUT"
