#!/usr/bin/env bash
# tests/vm/e2e_guest.sh: runs INSIDE the QEMU guest (vcan0 up), started by
# tests/e2e_group.sh. The whole chain, closed through CAN:
#   oldbf_sim_node (world, LiDAR) -> oldbf_node -> cmd_vel -> can_bridge_node
#   -> setpoint frames on vcan0 -> virtual_drive -> feedback frames
#   -> can_bridge_node odometry -> the simulated robot moves by it.
# paper_line must reach its goal with 0 collisions; candump shows the frames.
# Two runs in this one boot: the generic protocol, then CANopen CiA 402
# (sim_can.launch protocol:=cia402: the virtual drive plays two CiA 402 nodes).
set -Eeuo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd -P)
OUT=$ROOT/target/e2e
rm -rf "$OUT"; mkdir -p "$OUT"
cd "$ROOT"
# shellcheck source=/dev/null
source "$ROOT/target/ros/setup.bash"
export ROS_HOSTNAME=localhost ROS_MASTER_URI=http://localhost:11311/ ROS_HOME=$OUT/ros_home
ROSPY=/usr/bin/python3
fail() { echo "FAIL: $*"; exit 1; }
t0=$(date +%s)

# The master alone: roscore (roslaunch + rosout) spends tens of seconds in
# Python start-up under TCG emulation and has given up under load.
setsid rosmaster --core -p 11311 > "$OUT/roscore.log" 2>&1 &
core=$!
for _ in $(seq 300); do rostopic list > /dev/null 2>&1 && break; sleep 0.2; done
rostopic list > /dev/null 2>&1 || fail "roscore did not come up"
# roscore's roslaunch would set /run_id; `roslaunch --wait` waits for it forever.
rosparam set /run_id "$(cat /proc/sys/kernel/random/uuid)"
echo "e2e: roscore up after $(( $(date +%s) - t0 )) s"

ok=true
# run_case PROTOCOL SETPOINT_ID_L SETPOINT_ID_R FEEDBACK_ID_L STATUS_ID
run_case() {
  local proto=$1 sl=$2 sr=$3 fb=$4 st=$5 dump=$OUT/candump_$1.log t1
  t1=$(date +%s)
  candump -t a -n 200000 vcan0 > "$dump" 2>&1 &
  local dump_pid=$!
  # cia402: the bridge's ROS side while the robot drives (joint_states, covariance, tf, SDO services).
  local extra=() checker=""
  if [ "$proto" = cia402 ]; then
    extra=(publish_tf:=true)
    $ROSPY tests/can/ros_bridge_checks.py --config config/can_bridge.yaml --node-config config/can_bridge_node.yaml \
      --sdo 1 > "$OUT/ros_bridge_checks.log" 2>&1 &
    checker=$!
  fi
  setsid roslaunch --wait oldbf_ros sim_can.launch protocol:="$proto" "${extra[@]}" > "$OUT/launch_$proto.log" 2>&1 &
  local launch=$!
  local rc=0 summary
  summary=$($ROSPY tests/ros/wait_summary.py /oldbf_sim_node/summary 300) || rc=$?
  if [ -n "$checker" ]; then
    if wait "$checker"; then
      echo "PASS: $proto: joint_states, odometry covariance, tf and the SDO services (tests/can/ros_bridge_checks.py)"
    else
      echo "FAIL: $proto: tests/can/ros_bridge_checks.py"; ok=false
    fi
    grep -E '^(PASS|FAIL)' "$OUT/ros_bridge_checks.log" | sed 's/^/  /' || tail -20 "$OUT/ros_bridge_checks.log"
  fi
  kill -INT -- -"$launch" 2>/dev/null || true
  for _ in $(seq 100); do kill -0 "$launch" 2>/dev/null || break; sleep 0.1; done
  kill "$dump_pid" 2>/dev/null || true
  echo "e2e[$proto]: summary after $(( $(date +%s) - t1 )) s: $summary"
  if [ "$rc" != 0 ]; then tail -40 "$OUT/launch_$proto.log"; echo "FAIL: $proto: no final summary from the simulator"; ok=false; return; fi
  frames() { grep -c " vcan0  $1 " "$dump" || true; }
  local n_sl n_sr n_fb n_st
  n_sl=$(frames "$sl"); n_sr=$(frames "$sr"); n_fb=$(frames "$fb"); n_st=$(frames "$st")
  echo "e2e[$proto]: frames on vcan0: setpoints $sl $n_sl, $sr $n_sr, feedback $fb $n_fb, drive status $st $n_st"
  if $ROSPY -c "import json,sys; d=json.loads(sys.argv[1]); sys.exit(0 if d['reached_goal'] and d['collisions'] == 0 else 1)" "$summary"; then
    echo "PASS: $proto: paper_line through CAN reached its goal with 0 collisions ($($ROSPY -c "import json,sys; d=json.loads(sys.argv[1]); r=d['robots'][0]; print(f\"time to goal {r.get('time_to_goal_s'):.1f} s, min clearance {r.get('min_clearance_m'):.3f} m\")" "$summary"))"
  else
    echo "FAIL: $proto: paper_line through CAN: $summary"; ok=false
  fi
  if [ "$n_sl" -gt 1000 ] && [ "$n_sr" -gt 1000 ] && [ "$n_fb" -gt 1000 ] && [ "$n_st" -gt 10 ]; then
    echo "PASS: $proto: the loop ran over CAN (setpoint, feedback and status frames on vcan0)"
  else
    echo "FAIL: $proto: too few CAN frames"; ok=false
  fi
  if grep -q "cannot reach the ROS master\|panicked" "$OUT/launch_$proto.log"; then echo "FAIL: $proto: errors in the launch log"; ok=false; fi
}
# generic: setpoints 0x101/0x102, feedback 0x111, status 0x110.
run_case generic 101 102 111 110
# cia402 (config/can_bridge.yaml, nodes 1 and 2): RPDO1 0x201/0x202, TPDO2 0x281, TPDO1 0x181.
run_case cia402 201 202 281 181
kill -INT -- -"$core" 2>/dev/null || true
echo "e2e: both runs done after $(( $(date +%s) - t0 )) s"
$ok
