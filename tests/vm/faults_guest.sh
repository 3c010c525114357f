#!/usr/bin/env bash
# tests/vm/faults_guest.sh: runs INSIDE the QEMU guest (vcan0 up), started by
# tests/faults_group.sh. One roscore, one running system, every fault in turn:
#   roscore; candump -L vcan0; virtual_drive (ODrive CANSimple: floats on the
#   wire); can_bridge_node; oldbf_node (constant nominal 0.15 m/s);
#   tests/faults/scan_source.py (open scans, fault modes); /diagnostics recorder.
# Each injection writes {"mode", "t"} (realtime) to events.jsonl at the moment
# it is made; faults inside the drive (axis error, heartbeat silence) are
# timed from their first trace on the bus instead; the clock step records its
# exact size (realtime - monotonic before and after). tests/faults/analyze.py
# then measures onset -> zero setpoints on vcan0 and writes
# target/faults/results.md. The bridge's ~reset is called with
# tests/faults/reset.py (stdlib only: rosservice is far too slow under TCG).
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
event() { printf '{"mode": "%s", "t": %s}\n' "$1" "${2:-$EPOCHREALTIME}" >> "$EV"; }
PIDS=()
cleanup() { for p in "${PIDS[@]}"; do kill -INT "$p" 2>/dev/null || true; done; sleep 0.5; for p in "${PIDS[@]}"; do kill -KILL "$p" 2>/dev/null || true; done; }
trap cleanup EXIT
wait_log() { # file pattern timeout_s
  for _ in $(seq $(( $3 * 10 ))); do grep -q -- "$2" "$1" 2>/dev/null && return 0; sleep 0.1; done
  echo "faults: '$2' not in $1 after $3 s"; tail -20 "$1"; return 1
}
# The recorder has seen /diagnostics entries named *$1* more than $2 times.
wait_diag() { # name_part count_before timeout_s
  for _ in $(seq $(( $3 * 10 ))); do
    [ "$(count "$1" "$OUT/diag.jsonl")" -gt "$2" ] && return 0; sleep 0.1
  done
  echo "faults: no new /diagnostics '$1' after $3 s"; return 1
}
count() { local n; n=$(grep -c -- "$1" "$2" 2>/dev/null) || true; echo "${n:-0}"; }
diag_count() { count "$1" "$OUT/diag.jsonl"; }
reset_bridge() { # mode [node name]
  $ROSPY tests/faults/reset.py "/${2:-can_bridge_node}/reset" "$EV" "$1" >> "$OUT/reset.log" 2>&1 || say "reset $1 failed (see reset.log)"
}
ready_count() { count '"event":"drive_ready"' "$OUT/bridge.log"; }
wait_ready_after() { # count_before timeout_s
  for _ in $(seq $(( $2 * 10 ))); do [ "$(ready_count)" -gt "$1" ] && return 0; sleep 0.1; done
  echo "faults: the bridge did not report drive_ready again after $2 s"; tail -5 "$OUT/bridge.log"; return 1
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
start_bridge() { # [node name]
  "$BIN/can_bridge_node" __name:="${1:-can_bridge_node}" >> "$OUT/bridge.log" 2>&1 &
  bridge=$!; PIDS+=("$bridge")
}
start_node() {
  "$BIN/oldbf_node" __name:=oldbf_node >> "$OUT/oldbf_node.log" 2>&1 &
  node=$!; PIDS+=("$node")
}

start_core
say "roscore up"
rosparam load "$OUT/params.yaml" /
# A large receive buffer: under emulation candump falls behind the CiA 402
# traffic (7 frames a period) and the kernel drops what its socket cannot hold
# (-d reports it as DROPCOUNT lines).
candump -d -r 8388608 -L vcan0 > "$OUT/candump.log" 2>&1 &
PIDS+=($!)
start_drive 1
start_bridge
# The scans' frame on the robot, as its URDF would give it (oldbf_node places scans by tf).
$ROSPY tests/ros/static_tf.py base_link laser > "$OUT/static_tf.log" 2>&1 &
PIDS+=($!)
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
n_diag=$(diag_count "safety filter")
start_node
wait_log "$OUT/oldbf_node.log" "filtering (" 30
# The scan cases are reported on /diagnostics: the recorder must be connected to the new node.
wait_diag "safety filter" "$n_diag" 60
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

# -- the wall clock steps back 30 s (the step and its exact size J from one
# process: realtime - monotonic before and after)
$ROSPY - "$EV" <<'PY'
import json, sys, time
m0, r0 = time.clock_gettime(time.CLOCK_MONOTONIC), time.time()
time.clock_settime(time.CLOCK_REALTIME, r0 - 30.0)
r1, m1 = time.time(), time.clock_gettime(time.CLOCK_MONOTONIC)
open(sys.argv[1], "a").write(json.dumps({"mode": "clock_jump", "t": r1, "t_before": r0, "J": (r0 - m0) - (r1 - m1)}) + "\n")
PY
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

# -- drive faults, each in a fresh drive with the fault scheduled 15 s after
# its start. Replacing the drive is itself a lost heartbeat (latched): reset
# first, then wait for the drive to run. Onsets are taken from the bus.
kill -INT "$drive"; wait "$drive" || true
r=$(ready_count); event drive2_start; start_drive 2 --fault axis_error@15:0x1:left
sleep 3; reset_bridge drive2_reset; wait_ready_after "$r" 10
sleep 16
reset_bridge axis_reset
sleep 3
say "axis error done"
kill -INT "$drive"; wait "$drive" || true
r=$(ready_count); event drive3_start; start_drive 3 --fault heartbeat_silence@15+2
sleep 3; reset_bridge drive3_reset; wait_ready_after "$r" 10
sleep 16
reset_bridge hb_reset
sleep 3
say "drive faults done"

# -- bus-off error frame
$ROSPY tests/faults/bus_error.py vcan0 busoff "$EV"
sleep 3
say "bus-off done"

# -- CiA 402: the ODrive drive and bridge make way for a bridge with
# protocol cia402 (/can_bridge_co) and then a CANopen drive (two virtual
# CiA 402 nodes, config/can_bridge.yaml's cia402 section), with its faults
# scheduled from the moment both its axes first reach Operation Enabled
# (--faults-from running: under emulation the bridge's start-up varies by
# seconds, and a schedule from the drive's power-up once left the robot no
# time to move again between two faults): a drive fault (0x603F 0x2310) on
# the left node at 8 s, heartbeat silence at 24 s for 2 s, a reboot of both
# nodes at 40 s with the SDO server silent for 2.5 s (the restart's SDO
# times out). The resets and the bus-off follow what the bridge reports. Onsets are taken from the bus.
bridge_count() { count "$1" "$OUT/bridge.log"; }
wait_bridge() { # pattern count_before timeout_s
  for _ in $(seq $(( $3 * 10 ))); do [ "$(bridge_count "$1")" -gt "$2" ] && return 0; sleep 0.1; done
  echo "faults: no new '$1' in bridge.log after $3 s"; tail -5 "$OUT/bridge.log"; return 1
}
kill -INT "$bridge"; wait "$bridge" || true
kill -INT "$drive"; wait "$drive" || true
n=$(bridge_count "can_bridge_co: bridging")
event co_bridge
start_bridge can_bridge_co
wait_bridge "can_bridge_co: bridging" "$n" 60
r=$(ready_count); n_fault=$(bridge_count "DriveFaultLatched {"); n_hb=$(bridge_count "HeartbeatLostLatched {")
n_boot=$(bridge_count "booted (boot-up message)")
event co_start
"$BIN/virtual_drive" --interface vcan0 --protocol cia402 --config config/can_bridge.yaml --watchdog-s "$WATCHDOG_S" \
  --faults-from running --fault axis_error@8:0x2310:left --fault heartbeat_silence@24+2 --fault reboot@40 --fault sdo_silence@40+2.5 \
  > "$OUT/drive_co.log" 2>&1 &
drive=$!; PIDS+=("$drive")
wait_ready_after "$r" 20
wait_bridge "DriveFaultLatched {" "$n_fault" 30
sleep 2; reset_bridge co_axis_reset can_bridge_co
wait_bridge "HeartbeatLostLatched {" "$n_hb" 30
sleep 2.5; r=$(ready_count); reset_bridge co_hb_reset can_bridge_co
wait_ready_after "$r" 20
# The power-on boot-up was one per node; the reboot's come next.
r=$(ready_count)
wait_bridge "booted (boot-up message)" "$(( n_boot + 2 ))" 30
wait_ready_after "$r" 30
sleep 3
$ROSPY tests/faults/bus_error.py vcan0 busoff "$EV" co_busoff
sleep 3
event co_end
say "cia402 faults done"

# -- roscore killed, then started again: the nodes report the loss and run
# on; the new master (new PID): they exit 1 with a clear message (rosrust
# cannot register again; roslaunch's respawn would bring them back).
event roscore_kill; kill -KILL "$core"
wait_log "$OUT/oldbf_node.log" "lost the ROS master" 20
wait_log "$OUT/bridge.log" "lost the ROS master" 20
sleep 2
event roscore_start
start_core
event roscore_up
codes=()
for p in "$node" "$bridge"; do
  for _ in $(seq 300); do kill -0 "$p" 2>/dev/null || break; sleep 0.1; done
  if kill -0 "$p" 2>/dev/null; then codes+=(running); else c=0; wait "$p" || c=$?; codes+=("$c"); fi
done
echo "${codes[*]}" > "$OUT/exit_codes"
say "roscore restart done: exit codes ${codes[*]}"

echo quit > "$MODE"
cleanup; trap - EXIT
# tests/faults/analyze.py runs on the host (python cantools, tests/faults_group.sh).
