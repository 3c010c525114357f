#!/usr/bin/env bash
# tests/ros_group.sh: the ROS 1 tests, against Debian's real ROS tools.
#
# Installs Debian's ROS 1 packages if missing, builds and installs the nodes
# (oldbf_ros/rospkg/install.sh), starts a roscore on a private port, runs every
# test below, and tears everything down even on failure. Prints PASS/FAIL per
# test and the measured figures; exits non-zero if any test failed.
#
#   md5        every vendored message md5 equals `rosmsg md5` / `rossrv md5`
#   scan       rostopic pub of a scan: obstacle left -> angular.z < 0; wall
#              ahead inside d_safe -> linear.x <= 0 (rostopic echo); ~state
#              (oldbf_ros/BarrierState) decoded by rostopic echo
#   sim        roslaunch sim.launch (headless): paper_line reaches its goal,
#              0 collisions (the sim node's ~summary); recorded with rosbag
#   stale      scans stop -> cmd_vel zero within scan_timeout + one control
#              period; scan -> command latency over loopback
#   bag        rosbag play of the sim run into a fresh node (use_sim_time):
#              commands produced, none NaN
#   params     YAML params, a roslaunch override, bad values and unknown keys
#              -> the node exits naming the key
#   multi      multi_robot.launch (two_robots_offset): both robots reach their goals, topics namespaced
#   carmen     the real CARMEN log played as LaserScans into the node
#   shutdown   SIGTERM -> a last zero command; no master -> clear error and retry
#   rviz       rviz under Xvfb with config/oldbf.rviz while the sim runs: the
#              screenshot is not blank and shows the safety markers
#
#   tests/ros_group.sh [TEST...]
set -Eeuo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd -P)
cd "$ROOT"
ALL=(md5 scan sim stale bag params multi carmen shutdown rviz)
SELECTED=("$@")
[ ${#SELECTED[@]} -gt 0 ] || SELECTED=("${ALL[@]}")
LOG=$ROOT/target/ros-tests
rm -rf "$LOG"; mkdir -p "$LOG"
ROSPY=/usr/bin/python3
say() { printf '%s\n' "ros_group: $*"; }

# ------------------------------------------------------------------ install
t0=$(date +%s)
tests/ros/install_deps.sh
say "ROS packages ready ($(( $(date +%s) - t0 )) s)"
t0=$(date +%s)
PREFIX=$ROOT/target/ros
oldbf_ros/rospkg/install.sh "$PREFIX" > "$LOG/install.log" 2>&1 || { tail -20 "$LOG/install.log"; say "install failed"; exit 1; }
say "nodes built and installed ($(( $(date +%s) - t0 )) s)"
# shellcheck source=/dev/null
source "$PREFIX/setup.bash"
BIN=$PREFIX/oldbf_ros/bin

# ------------------------------------------------------------------ roscore
PORT=$(( 11400 + $$ % 500 ))
export ROS_HOSTNAME=localhost ROS_MASTER_URI=http://localhost:$PORT/ ROS_HOME=$LOG/ros_home
unset ROS_NAMESPACE ROS_IP
mkdir -p "$ROS_HOME"
# Background processes are registered in a file (tests run in subshells), so
# cleanup finds them all, whatever failed.
PIDFILE=$LOG/pids
: > "$PIDFILE"
spawn() { # name cmd... : background process in its own process group; prints its pid
  local name=$1; shift
  setsid "$@" > "$LOG/$name.log" 2>&1 &
  echo $! >> "$PIDFILE"
  echo $!
}
stop_pid() { # pid [signal]
  kill -"${2:-INT}" -- -"$1" 2>/dev/null || true
  for _ in $(seq 50); do kill -0 "$1" 2>/dev/null || return 0; sleep 0.1; done
  kill -KILL -- -"$1" 2>/dev/null || true
}
cleanup() {
  tac "$PIDFILE" 2>/dev/null | while read -r p; do stop_pid "$p" INT; done
}
trap cleanup EXIT
spawn roscore roscore -p "$PORT" > /dev/null
for _ in $(seq 100); do rostopic list > /dev/null 2>&1 && break; sleep 0.2; done
rostopic list > /dev/null 2>&1 || { cat "$LOG/roscore.log"; say "roscore did not come up"; exit 1; }
say "roscore up on port $PORT"

RESULTS=()
figure() { echo "$*" >> "$LOG/figures.txt"; }
check() { [ "$1" = true ] || { say "  check failed: $2"; return 1; }; }
wait_log() { # file pattern timeout_s
  for _ in $(seq $(( $3 * 10 ))); do grep -q -- "$2" "$1" 2>/dev/null && return 0; sleep 0.1; done
  return 1
}
json() { $ROSPY -c "import json,sys; d=json.load(sys.stdin); print($1)"; }

# ------------------------------------------------------------------ tests
t_md5() {
  # The ROS glue's own unit tests (message conversion, markers) need the feature.
  cargo test --release --locked -p oldbf_ros --features oldbf_ros/ros --lib ros:: > "$LOG/ros_unit.log" 2>&1 \
    || { tail -30 "$LOG/ros_unit.log"; return 1; }
  figure "ros glue unit tests: $(grep -o '[0-9]* passed' "$LOG/ros_unit.log" | head -1)"
  cargo test --release --locked -p oldbf_ros --features oldbf_ros/ros --test ros_msgs -- --nocapture > "$LOG/md5.log" 2>&1 \
    || { tail -30 "$LOG/md5.log"; return 1; }
  local n
  n=$(grep -c " ours " "$LOG/md5.log")
  figure "md5: $n message and service types match rosmsg/rossrv"
  check "$([ "$n" -ge 23 ] && echo true)" "only $n types checked"
}

t_scan() {
  local node pub out z x
  node=$(spawn scan_node "$BIN/oldbf_node" __ns:=/t_scan _node/nominal_source:=constant)
  wait_log "$LOG/scan_node.log" "filtering at" 10 || return 1
  pub=$(spawn scan_pub_left rostopic pub -r 10 -s /t_scan/scan sensor_msgs/LaserScan "$($ROSPY tests/ros/make_scan.py left)")
  sleep 2
  out=$(timeout 10 rostopic echo -n 3 /t_scan/cmd_vel)
  # The custom message round-trips through rostopic echo (genpy module from install.sh).
  local state
  state=$(timeout 10 rostopic echo -n 1 /t_scan/oldbf_node/state)
  stop_pid "$pub"
  if ! { grep -q 'doaa_state_name: "avoid"' <<< "$state" && grep -q 'condition_held: True' <<< "$state"; }; then
    say "  ~state via rostopic echo: $state"
    return 1
  fi
  figure "scan: ~state via rostopic echo: $(grep -E '^(d_left|b_left|b_right|doaa_state_name):' <<< "$state" | tr '\n' ' ')"
  z=$(awk '/angular:/{a=1} a&&/z:/{v=$2; a=0} END{print v}' <<< "$out")
  figure "scan: obstacle left -> angular.z = $z rad/s"
  check "$(awk -v z="$z" 'BEGIN{print (z < 0) ? "true" : "false"}')" "angular.z = $z not negative" || return 1
  pub=$(spawn scan_pub_ahead rostopic pub -r 10 -s /t_scan/scan sensor_msgs/LaserScan "$($ROSPY tests/ros/make_scan.py ahead)")
  sleep 2
  out=$(timeout 10 rostopic echo -n 3 /t_scan/cmd_vel)
  stop_pid "$pub"; stop_pid "$node"
  x=$(awk '/linear:/{a=1} a&&/x:/{v=$2; a=0} END{print v}' <<< "$out")
  figure "scan: wall 0.3 m ahead -> linear.x = $x m/s"
  check "$(awk -v x="$x" 'BEGIN{print (x <= 0) ? "true" : "false"}')" "linear.x = $x > 0"
}

t_sim() {
  local launch bag s
  launch=$(spawn sim_launch roslaunch --wait oldbf_ros sim.launch)
  bag=$(spawn sim_bag rosbag record -O "$LOG/sim.bag" --duration=25 /scan /odom /cmd_vel)
  s=$($ROSPY tests/ros/wait_summary.py /oldbf_sim_node/summary 150) || { stop_pid "$launch"; say "  no summary: $s"; return 1; }
  stop_pid "$launch"
  for _ in $(seq 300); do kill -0 "$bag" 2>/dev/null || break; sleep 0.1; done
  figure "sim: $(json "'goal reached at %.1f s, %d collisions, least clearance %.3f m' % (d['robots'][0]['time_to_goal_s'] or -1, d['collisions'], d['robots'][0]['min_clearance_m'])" <<< "$s")"
  check "$(json "str(d['reached_goal'] and d['collisions'] == 0).lower()" <<< "$s")" "paper_line over ROS: $s"
}

t_stale() {
  local node s delay
  node=$(spawn stale_node "$BIN/oldbf_node" __ns:=/t_stale _node/nominal_source:=constant)
  wait_log "$LOG/stale_node.log" "filtering at" 10 || return 1
  s=$($ROSPY tests/ros/stale_scan.py /t_stale 8)
  stop_pid "$node"
  echo "$s" > "$LOG/stale.json"
  delay=$(json "d['stop_delay_s']" <<< "$s")
  figure "stale: zero command ${delay} s after the last scan (limit scan_timeout 0.5 + period 0.1 s)"
  figure "latency scan -> ~state over loopback: $(json "'p50 %s ms, p99 %s ms, max %s ms over %d scans' % (d['latency_ms']['p50'], d['latency_ms']['p99'], d['latency_ms']['max'], d['latency_ms']['n'])" <<< "$s")"
  check "$(json "str(d['commands_while_fresh'] > 10).lower()" <<< "$s")" "no motion while scans were fresh: $s" || return 1
  # 0.6 s plus 50 ms for message transport and timer jitter on a shared 2-core machine.
  check "$(json "str(d['stop_delay_s'] is not None and d['stop_delay_s'] <= 0.65).lower()" <<< "$s")" "stop delay: $s"
}

t_bag() {
  [ -s "$LOG/sim.bag" ] || { say "  no bag from the sim test (run 'sim' first)"; return 1; }
  local node play s
  rosparam set /use_sim_time true
  node=$(spawn bag_node "$BIN/oldbf_node" __ns:=/replay _node/nominal_source:=constant)
  wait_log "$LOG/bag_node.log" "filtering at" 10 || { rosparam delete /use_sim_time; return 1; }
  play=$(spawn bag_play rosbag play --clock -d 1 "$LOG/sim.bag" /scan:=/replay/scan /odom:=/replay/odom /cmd_vel:=/recorded/cmd_vel)
  s=$($ROSPY tests/ros/collect_cmd.py /replay/cmd_vel 20)
  stop_pid "$play"; stop_pid "$node"
  rosparam delete /use_sim_time
  figure "bag: replayed into a fresh node: $(json "'%d commands, %d non-zero, %d non-finite' % (d['count'], d['non_zero'], d['non_finite'])" <<< "$s")"
  check "$(json "str(d['count'] > 50 and d['non_zero'] > 10 and d['non_finite'] == 0).lower()" <<< "$s")" "bag replay: $s"
}

t_params() {
  local l
  l=$(spawn params_yaml roslaunch --wait oldbf_ros oldbf.launch ns:=/t_params_a)
  wait_log "$LOG/params_yaml.log" "filtering at" 15 || { stop_pid "$l"; return 1; }
  check "$(grep -q 'd_safe = 0.20 m' "$LOG/params_yaml.log" && echo true)" "YAML value d_safe 0.20 not used" || { stop_pid "$l"; return 1; }
  check "$([ "$(rosparam get /t_params_a/oldbf_node/barrier/d_safe_m)" = 0.2 ] && echo true)" "rosparam d_safe_m" || { stop_pid "$l"; return 1; }
  stop_pid "$l"
  l=$(spawn params_override roslaunch --wait oldbf_ros oldbf.launch ns:=/t_params_b "overrides:={barrier: {d_safe_m: 0.25}}")
  wait_log "$LOG/params_override.log" "filtering at" 15 || { stop_pid "$l"; return 1; }
  check "$(grep -q 'd_safe = 0.25 m' "$LOG/params_override.log" && echo true)" "roslaunch override not applied" || { stop_pid "$l"; return 1; }
  stop_pid "$l"
  l=$(spawn params_bad roslaunch --wait oldbf_ros oldbf.launch ns:=/t_params_c "overrides:={barrier: {d_safe_m: 30.0}}")
  wait_log "$LOG/params_bad.log" "process has died" 15 || { stop_pid "$l"; say "  node did not exit on a bad value"; return 1; }
  stop_pid "$l"
  check "$(grep -q 'barrier.d_safe_m' "$LOG/params_bad.log" && grep -q 'exit code 2' "$LOG/params_bad.log" && echo true)" "bad value: message or exit code" || return 1
  # shellcheck disable=SC2016 # the backticks are literal: they quote the key in the message
  figure "params: $(grep -o 'key `barrier.d_safe_m`[^;]*; allowed: [^ ]* [^ ]*' "$LOG/params_bad.log" | head -1)"
  l=$(spawn params_unknown roslaunch --wait oldbf_ros oldbf.launch ns:=/t_params_d "overrides:={barrier: {d_saf_m: 0.3}}")
  wait_log "$LOG/params_unknown.log" "process has died" 15 || { stop_pid "$l"; say "  node did not exit on an unknown key"; return 1; }
  stop_pid "$l"
  check "$(grep -q 'barrier.d_saf_m' "$LOG/params_unknown.log" && echo true)" "unknown key not named" || return 1
  # A private parameter on the node's own command line (rosrun style).
  set +e
  timeout 20 "$BIN/oldbf_node" __ns:=/t_params_e _dtcbf/gamma:=2.0 > "$LOG/params_cli.log" 2>&1
  local rc=$?
  set -e
  check "$([ $rc = 2 ] && grep -q 'dtcbf.gamma' "$LOG/params_cli.log" && echo true)" "_dtcbf/gamma:=2.0: exit $rc"
}

t_multi() {
  local l s topics
  # The offset crossing: the symmetric one can end in a stand-off (README, Status).
  l=$(spawn multi_launch roslaunch --wait oldbf_ros multi_robot.launch scenario:="$ROOT/config/scenarios/two_robots_offset.yaml")
  sleep 6
  topics=$(rostopic list)
  s=$($ROSPY tests/ros/wait_summary.py /oldbf_sim_node/summary 150) || { stop_pid "$l"; say "  no summary: $s"; return 1; }
  stop_pid "$l"
  figure "multi: $(json "'; '.join('%s goal %s at %s s, %d collisions' % (r['name'], r['reached_goal'], r['time_to_goal_s'], r['collisions']) for r in d['robots'])" <<< "$s")"
  for t in /robot1/scan /robot1/cmd_vel /robot1/oldbf_node/state /robot2/scan /robot2/cmd_vel /robot2/oldbf_node/state; do
    grep -qx "$t" <<< "$topics" || { say "  topic $t missing"; return 1; }
  done
  check "$(json "str(d['reached_goal'] and d['collisions'] == 0 and len(d['robots']) == 2).lower()" <<< "$s")" "multi-robot: $s"
}

t_carmen() {
  local node s
  node=$(spawn carmen_node "$BIN/oldbf_node" __ns:=/t_carmen _node/nominal_source:=constant)
  wait_log "$LOG/carmen_node.log" "filtering at" 10 || return 1
  local collector
  collector=$(spawn carmen_collect "$ROSPY" tests/ros/collect_cmd.py /t_carmen/cmd_vel 24)
  "$BIN/oldbf" carmen-play tests/data/intel-corrected.log.gz --topic /t_carmen/scan --rate 50 > "$LOG/carmen_play.log" 2>&1
  for _ in $(seq 300); do kill -0 "$collector" 2>/dev/null || break; sleep 0.1; done
  stop_pid "$node"
  s=$(tail -1 "$LOG/carmen_collect.log")
  figure "carmen: $(tail -1 "$LOG/carmen_play.log"); node: $(json "'%d commands, %d non-zero, %d non-finite' % (d['count'], d['non_zero'], d['non_finite'])" <<< "$s")"
  check "$(grep -q 'published 910 scans' "$LOG/carmen_play.log" && echo true)" "not all 910 scans published" || return 1
  check "$(json "str(d['count'] > 100 and d['non_zero'] > 10 and d['non_finite'] == 0).lower()" <<< "$s")" "carmen replay: $s"
}

t_shutdown() {
  local node pub out
  node=$(spawn shutdown_node "$BIN/oldbf_node" __ns:=/t_shut _node/nominal_source:=constant)
  wait_log "$LOG/shutdown_node.log" "filtering at" 10 || return 1
  pub=$(spawn shutdown_pub rostopic pub -r 10 -s /t_shut/scan sensor_msgs/LaserScan "$($ROSPY tests/ros/make_scan.py open)")
  sleep 2
  local echo_pid
  echo_pid=$(spawn shutdown_echo rostopic echo /t_shut/cmd_vel)
  sleep 1
  kill -TERM "$node"
  for _ in $(seq 50); do kill -0 "$node" 2>/dev/null || break; sleep 0.1; done
  sleep 0.5
  stop_pid "$echo_pid"; stop_pid "$pub"
  out=$(cat "$LOG/shutdown_echo.log")
  check "$(! kill -0 "$node" 2>/dev/null && echo true)" "node still running after SIGTERM" || return 1
  # The last command echoed must be zero (the node sends zeros on the way out).
  local last
  last=$(awk '/linear:/{a=1} a&&/x:/{v=$2; a=0} END{print v}' <<< "$out")
  check "$([ "$last" = 0.0 ] && echo true)" "last command after SIGTERM was linear.x = $last" || return 1
  check "$(grep -q 'sending a zero command' "$LOG/shutdown_node.log" && echo true)" "no shutdown message" || return 1
  # No master: a clear error, retried, and a clean exit on SIGINT.
  local rc=0
  set +e
  ROS_MASTER_URI=http://localhost:1/ timeout --preserve-status -s INT 3 "$BIN/oldbf_node" > "$LOG/nomaster.log" 2>&1
  rc=$?
  set -e
  figure "no master: $(grep -m1 -o 'cannot reach the ROS master[^;]*' "$LOG/nomaster.log")"
  check "$(grep -q 'cannot reach the ROS master at http://localhost:1/' "$LOG/nomaster.log" && [ "$rc" = 0 ] && ! grep -q panicked "$LOG/nomaster.log" && echo true)" "no-master behaviour (exit $rc)"
}

t_rviz() {
  local xvfb l shot
  xvfb=$(spawn xvfb Xvfb :97 -screen 0 1024x768x24 -nolisten tcp)
  sleep 1
  l=$(DISPLAY=:97 spawn rviz_launch roslaunch --wait oldbf_ros sim.launch rviz:=true)
  # rviz under software GL takes a while; the sim must be under way too.
  wait_log "$LOG/rviz_launch.log" "filtering (" 30 || true
  sleep 20
  shot=$LOG/rviz.ppm
  xwd -root -display :97 -silent | xwdtopnm > "$shot" 2>/dev/null
  pnmtopng "$shot" > "$LOG/rviz.png" 2>/dev/null
  stop_pid "$l"; stop_pid "$xvfb"
  local s rc=0
  s=$($ROSPY tests/ros/check_screenshot.py "$shot") || rc=$?
  figure "rviz: screenshot $LOG/rviz.png: $s"
  [ $rc = 0 ] || { say "  screenshot looks blank: $s"; return 1; }
}

for t in "${SELECTED[@]}"; do
  case " ${ALL[*]} " in *" $t "*) ;; *) say "unknown test $t (tests: ${ALL[*]})"; exit 2 ;; esac
  t0=$(date +%s)
  set +e
  ( set -Eeuo pipefail; "t_$t" )
  rc=$?
  set -e
  if [ $rc = 0 ]; then RESULTS+=("PASS $t ($(( $(date +%s) - t0 )) s)"); else RESULTS+=("FAIL $t ($(( $(date +%s) - t0 )) s)"); fi
  say "${RESULTS[-1]}"
done
printf '\n'
for r in "${RESULTS[@]}"; do say "$r"; done
[ -s "$LOG/figures.txt" ] && { say "figures:"; sed 's/^/  /' "$LOG/figures.txt"; }
! printf '%s\n' "${RESULTS[@]}" | grep -q '^FAIL'
