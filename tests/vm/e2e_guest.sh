#!/usr/bin/env bash
# tests/vm/e2e_guest.sh: runs INSIDE the QEMU guest (vcan0 up), started by
# tests/e2e_group.sh. The whole chain, closed through CAN:
#   oldbf_sim_node (world, LiDAR) -> oldbf_node -> cmd_vel -> can_bridge_node
#   -> setpoint frames on vcan0 -> virtual_drive -> feedback frames
#   -> can_bridge_node odometry -> the simulated robot moves by it.
# paper_line must reach its goal with 0 collisions; candump shows the frames.
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

candump -t a -n 200000 vcan0 > "$OUT/candump.log" 2>&1 &
dump=$!
setsid roslaunch --wait oldbf_ros sim_can.launch > "$OUT/launch.log" 2>&1 &
launch=$!
rc=0
summary=$($ROSPY tests/ros/wait_summary.py /oldbf_sim_node/summary 300) || rc=$?
kill -INT -- -"$launch" 2>/dev/null || true
for _ in $(seq 100); do kill -0 "$launch" 2>/dev/null || break; sleep 0.1; done
kill "$dump" 2>/dev/null || true
kill -INT -- -"$core" 2>/dev/null || true
echo "e2e: summary after $(( $(date +%s) - t0 )) s: $summary"
[ "$rc" = 0 ] || { tail -40 "$OUT/launch.log"; fail "no final summary from the simulator"; }

frames() { grep -c " vcan0  $1 " "$OUT/candump.log" || true; }
setpoints_left=$(frames 101); setpoints_right=$(frames 102); feedback_left=$(frames 111); status=$(frames 110)
echo "e2e: frames on vcan0: setpoints 0x101 $setpoints_left, 0x102 $setpoints_right, feedback 0x111 $feedback_left, drive status 0x110 $status"
ok=true
if $ROSPY -c "import json,sys; d=json.loads(sys.argv[1]); sys.exit(0 if d['reached_goal'] and d['collisions'] == 0 else 1)" "$summary"; then
  echo "PASS: paper_line through CAN reached its goal with 0 collisions"
else
  echo "FAIL: paper_line through CAN: $summary"; ok=false
fi
if [ "$setpoints_left" -gt 1000 ] && [ "$setpoints_right" -gt 1000 ] && [ "$feedback_left" -gt 1000 ]; then
  echo "PASS: the loop ran over CAN (setpoint and feedback frames on vcan0)"
else
  echo "FAIL: too few CAN frames"; ok=false
fi
if grep -q "cannot reach the ROS master\|panicked" "$OUT/launch.log"; then echo "FAIL: errors in the launch log"; ok=false; fi
$ok
