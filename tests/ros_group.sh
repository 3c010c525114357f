#!/usr/bin/env bash
# tests/ros_group.sh: the ROS 1 tests, against Debian's real ROS tools.
#
# Installs Debian's ROS 1 packages (and catkin) if missing, builds and
# installs the nodes (oldbf_ros/rospkg/install.sh: the one cargo build of the
# group; the catkin test reuses it), starts a roscore on a private port, runs
# every test below, and tears everything down even on failure. Prints
# PASS/FAIL per test and the measured figures; exits non-zero if any test
# failed. md5 runs first; then sim, bag and multi (minutes of real time at
# about a tenth of a core) run in a second lane, on a roscore of their own,
# beside the other tests; catkin and rviz run last, alone ("run" below).
#
#   md5        the ROS glue's unit tests (oldbf_ros ros::, can_bridge ros_node::,
#              built with the feature); every vendored message md5 equals
#              `rosmsg md5` / `rossrv md5`
#   scan       rostopic pub of a scan: obstacle left -> angular.z < 0; wall
#              ahead inside d_safe -> linear.x <= 0 (rostopic echo); ~state
#              (oldbf_ros/BarrierState) decoded by rostopic echo
#   tf         sensor poses from tf: Debian's robot_state_publisher with a URDF
#              (tests/ros/tf_robot.urdf) places an upright and an upside-down
#              laser; an obstacle on the laser's left turns the robot right
#              (upright) or left (upside down); a frame tf does not name gives
#              only zero commands, and the log and diagnostics name the frames
#   scanners   node/scans: a front and a rear 270° scanner (static tf) merged
#              into one scan: backing up while both are alive; the rear silent
#              or without a pose forbids it (diagnostics scanner_1 say why);
#              the front silent stops forward motion; sim.launch with
#              front_rear.yaml (two 270° LiDARs) reaches its goal over ROS
#   cpu        the node's CPU use with two 1081-beam scanners at 25 Hz (reported in
#              the figures; the check is only that every scan was answered)
#   sim        roslaunch sim.launch (headless): paper_line reaches its goal,
#              0 collisions (the sim node's ~summary); recorded with rosbag
#   stale      scans stop -> cmd_vel zero within scan_timeout + one control
#              period
#   latency    scan -> cmd_vel latency over loopback (tests/ros/latency_probe.py,
#              a base that follows any command at once):
#              every command is shown to come from the scan it is timed
#              against (~state carries its stamp); p50/p99/max reported
#   ticks      a planner at 20 and at 100 Hz beside a 10 Hz LiDAR, a person
#              walking at a robot that stands (odometry says so)
#              (tests/ros/between_scans.py): once it is a threat, every
#              command, between scans too, reports it
#   clock      cmd_vel_in at 1 kHz on the wall clock for 2 minutes beside 10 Hz
#              scans (rostopic pub, tests/ros/fast_commands.py): no clock jump
#              reported, no zero command in open space but for a scan that
#              really arrived late or an upstream the node really had not
#              processed for its cmd_in_timeout (each counted and reported)
#   simtime    /use_sim_time: the first scan is taken (no resubscription when
#              simulated time jumps from 0), and Ctrl-C ends the node after
#              /clock has stopped (tests/ros/sim_time.py)
#   locks      locks that lapse (tests/ros/locks_probe.py), node/e_stop_timeout_s
#              0.5 and node/disable_timeout_s 2.0: no e_stop heard yet -> zero;
#              e_stop false at 10 Hz -> moves; its publisher silent -> zero
#              0.5 s after its last message (+ one tick), said in ~state,
#              /diagnostics (ERROR) and the log; false again -> moves without
#              a reset. ~enable false before a wall passes 0.2 m/s, says in
#              /diagnostics when it lapses, lapses 2.0 s after the call, and
#              2.0 s after a renewal
#   diagnostics  Debian's diagnostic_aggregator (launch/diagnostics.launch with
#              config/diagnostic_analyzers.yaml): /diagnostics_agg shows each
#              node's status under /Base/Safety filter with its hardware_id (the
#              scan's frame_id by default, node/hardware_id when set), and a
#              status named as the CAN bridge names its own under /Base/CAN bridge
#   reconfigure  dynamic_reconfigure through Debian's Python client: read
#              the parameters, set d_safe 0.2 -> 0.4 and read it back, the
#              robot stops 0.2 m earlier before a wall; out-of-range values
#              refused naming the key, the running values kept
#   catkin     a fresh catkin workspace with the repository in src/:
#              catkin_make (cargo's build reused: nothing recompiled) and
#              catkin_make install; roslaunch sim.launch from devel/ and from
#              install/, each running its own space's binaries
#   bag        rosbag play of the sim run into a fresh node (use_sim_time):
#              commands produced, none NaN
#   params     YAML params, a roslaunch override, bad values and unknown keys
#              -> the node exits naming the key
#   baselimits one set of base limits (config/base_limits.yaml): oldbf_node
#              starts with the shipped file (oldbf.launch base_limits:=…); with
#              a base that brakes at only 0.8 m/s² it exits 2 naming
#              control.decel_mps2 and base.decel_mps2; can_bridge_node with a
#              bridge ramp of 20 rad/s² (0.66 m/s²) exits 2 naming
#              limits.wheel_decel_radps2 and base.decel_mps2 (the check comes
#              before the CAN interface is opened), with a speed-up ramp of
#              20 rad/s² exits 2 naming limits.wheel_accel_radps2 and
#              base.accel_mps2, and with the shipped file
#              passes it (then stops at the missing CAN interface); bringup.launch
#              gives both nodes the same file (roslaunch --dump-params)
#   footprint  a move_base costmap YAML (footprint as a string, 0.6 x 0.4 m) loaded under
#              /move_base/local_costmap: with node/footprint_param naming it the node starts
#              with a 4-vertex polygon (r = its circumscribed 0.361 m); a footprint that crosses
#              itself exits 2 naming footprint.polygon_m and the edges; an unset name exits 2
#              naming node.footprint_param
#   multi      multi_robot.launch (two_robots, the symmetric crossing) 5 times: both robots reach
#              their goals every time, 0 collisions, topics namespaced
#   carmen     the real CARMEN log played as LaserScans into the node
#   shutdown   SIGTERM -> a last zero command; no master -> clear error and retry
#   rviz       rviz under Xvfb with config/oldbf.rviz while the sim runs: two
#              screenshots metres apart along the robot's way are not blank,
#              show the safety markers, have the robot in the view's centre
#              and the B_l/B_r/state label above it
#
#   tests/ros_group.sh [TEST...]
set -Eeuo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd -P)
cd "$ROOT"
ALL=(md5 scan tf scanners cpu sim stale latency ticks clock simtime locks diagnostics reconfigure bag params baselimits footprint multi carmen shutdown catkin rviz)
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
export ROS_HOSTNAME=localhost ROS_HOME=$LOG/ros_home
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
  # The catkin test's workspace (outside the repository).
  if [ -s "$LOG/catkin_ws" ]; then rm -rf "$(cat "$LOG/catkin_ws")"; fi
}
trap cleanup EXIT
# A private port: the first one in 11400-11899 that nothing listens on, from
# an offset of our pid, so two checkouts (or CI beside a developer) running
# this group at once never share a master. If another master takes the port
# between the probe and roscore's start, ours exits and the next port is tried.
free_port() { # start: prints the first free port from start on, wrapping within 11400-11899
  $ROSPY -c '
import socket, sys
start = int(sys.argv[1])
for i in range(500):
    port = 11400 + (start - 11400 + i) % 500
    with socket.socket() as s:
        try:
            s.bind(("", port))
        except OSError:
            continue
    print(port)
    sys.exit(0)
sys.exit(1)' "$1"
}
start_master() { # name home: roscore (log $LOG/name.log, ROS_HOME=home) on a free port; prints the port
  local name=$1 home=$2 port core attempt
  mkdir -p "$home"
  for attempt in 1 2 3; do
    port=$(free_port $(( 11400 + ($$ + 97 * attempt + 31 * ${#name}) % 500 ))) || return 1
    core=$(ROS_HOME=$home spawn "$name" roscore -p "$port")
    for _ in $(seq 100); do
      kill -0 "$core" 2>/dev/null || break
      ROS_MASTER_URI=http://localhost:$port/ rostopic list > /dev/null 2>&1 && break
      sleep 0.2
    done
    if kill -0 "$core" 2>/dev/null && ROS_MASTER_URI=http://localhost:$port/ rostopic list > /dev/null 2>&1; then
      echo "$port"
      return 0
    fi
    stop_pid "$core"
  done
  return 1
}
PORT=$(start_master roscore "$ROS_HOME") || { cat "$LOG/roscore.log"; say "roscore did not come up"; exit 1; }
export ROS_MASTER_URI=http://localhost:$PORT/
say "roscore up on port $PORT"

figure() { echo "$*" >> "$LOG/figures.txt"; }
check() { [ "$1" = true ] || { say "  check failed: $2"; return 1; }; }
wait_log() { # file pattern timeout_s
  for _ in $(seq $(( $3 * 10 ))); do grep -q -- "$2" "$1" 2>/dev/null && return 0; sleep 0.1; done
  return 1
}
json() { $ROSPY -c "import json,sys; d=json.load(sys.stdin); print($1)"; }

# The checks' scans come from frame "laser" (and t_diag_laser): oldbf_node
# places each scan by tf, so they get the transforms a robot's URDF would give.
start_static_tf() { # name: on $ROS_MASTER_URI
  spawn "$1" $ROSPY tests/ros/static_tf.py base_link laser t_diag_laser > /dev/null
  wait_log "$LOG/$1.log" "static_tf:" 20 || { cat "$LOG/$1.log"; say "static_tf did not start"; return 1; }
}
start_static_tf static_tf || exit 1

# ------------------------------------------------------------------ tests
# Every test run with the ROS feature (here, and can_bridge's ros_msgs in the
# e2e group) is built by this one command line: the same packages, features
# and profile each time, so cargo resolves the dependencies once, builds once,
# and e2e's run compiles nothing. (Each different -p or --features set is a
# different feature resolution, and rebuilds the workspace.)
ROS_TESTS=(cargo test --release --locked -p oldbf_ros -p can_bridge --features oldbf_ros/ros --features can_bridge/ros)

t_md5() {
  # The ROS glue's own unit tests (message conversion, markers; the CAN
  # bridge node's odometry, parameters and SDO timing) need the feature.
  "${ROS_TESTS[@]}" --no-run --lib --test ros_msgs > "$LOG/ros_tests_build.log" 2>&1 \
    || { tail -30 "$LOG/ros_tests_build.log"; return 1; }
  "${ROS_TESTS[@]}" --lib -- ros:: ros_node:: > "$LOG/ros_unit.log" 2>&1 \
    || { tail -30 "$LOG/ros_unit.log"; return 1; }
  figure "ros glue unit tests: $(grep -o '[0-9]* passed' "$LOG/ros_unit.log" | awk '{n += $1} END {print n+0}') passed (oldbf_ros ros::, can_bridge ros_node::)"
  # A filter that matched nothing would pass: each crate's harness must have run some.
  check "$([ "$(grep -cE '^test result: ok\. [1-9][0-9]* passed' "$LOG/ros_unit.log")" = 2 ] && echo true)" \
    "the ROS glue unit tests of oldbf_ros and can_bridge did not both run: $(grep '^test result' "$LOG/ros_unit.log" | tr '\n' ' ')" || return 1
  # oldbf_ros's vendored types (can_bridge's own are checked by the e2e group).
  "${ROS_TESTS[@]}" --test ros_msgs -- --nocapture --exact vendored_messages_match_ros > "$LOG/md5.log" 2>&1 \
    || { tail -30 "$LOG/md5.log"; return 1; }
  local n
  n=$(grep -c " ours " "$LOG/md5.log")
  figure "md5: $n message and service types match rosmsg/rossrv"
  check "$([ "$n" -ge 26 ] && echo true)" "only $n types checked"
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

t_tf() {
  # robot_state_publisher gives the lasers' poses from a URDF (/tf_static):
  # an obstacle on a laser's left is on the robot's left when the laser is
  # upright, on its right when it hangs upside down; a frame tf does not
  # know is an unknown sensor (zero commands, diagnostics naming the frames).
  local rsp node pub out z frame want
  rosparam set -t tests/ros/tf_robot.urdf /t_tf/robot_description
  rsp=$(spawn tf_rsp /usr/lib/robot_state_publisher/robot_state_publisher __ns:=/t_tf)
  node=$(spawn tf_node "$BIN/oldbf_node" __ns:=/t_tf _node/nominal_source:=constant)
  wait_log "$LOG/tf_node.log" "filtering at" 10 || return 1
  for frame in deck_laser belly_laser; do
    pub=$(spawn "tf_pub_$frame" rostopic pub -r 10 -s /t_tf/scan sensor_msgs/LaserScan \
      "$($ROSPY tests/ros/make_scan.py left | sed "s/frame_id: laser/frame_id: $frame/")")
    sleep 2
    out=$(timeout 10 rostopic echo -n 3 /t_tf/cmd_vel)
    stop_pid "$pub"
    z=$(awk '/angular:/{a=1} a&&/z:/{v=$2; a=0} END{print v}' <<< "$out")
    want=$([ $frame = deck_laser ] && echo "z < 0" || echo "z > 0")
    figure "tf: obstacle on the left of $frame ($(grep -o "laser pose \"$frame\" from tf: [^:]*" "$LOG/tf_node.log" | tail -1 | sed 's/.*from tf: //')) -> angular.z = $z rad/s"
    check "$(awk -v z="$z" "BEGIN{print ($want) ? \"true\" : \"false\"}")" "$frame: angular.z = $z, want $want" || { stop_pid "$node"; stop_pid "$rsp"; return 1; }
  done
  # A scan from a frame no transform names: only zero commands, and the frames named.
  pub=$(spawn tf_pub_unknown rostopic pub -r 10 -s /t_tf/scan sensor_msgs/LaserScan \
    "$($ROSPY tests/ros/make_scan.py open | sed 's/frame_id: laser/frame_id: nowhere_laser/')")
  sleep 2
  out=$(timeout 10 rostopic echo -n 10 /t_tf/cmd_vel)
  local diag
  diag=$(timeout 10 rostopic echo -n 2 /diagnostics | grep -A1 'key: "laser_pose"' | grep value | tail -1)
  stop_pid "$pub"; stop_pid "$node"; stop_pid "$rsp"
  local moving
  moving=$(awk '/x:|z:/{ if ($2 != 0.0) n++ } END{print n+0}' <<< "$out")
  figure "tf: frame nowhere_laser: $moving non-zero values in 10 commands; diagnostics laser_pose:${diag#*value:}"
  check "$([ "$moving" = 0 ] && echo true)" "unknown frame: $moving non-zero command values" || return 1
  check "$(grep -q 'nowhere_laser.*base_link' <<< "$diag" && echo true)" "diagnostics do not name the frames: $diag" || return 1
  check "$(grep -q 'laser pose unknown: "nowhere_laser" -> "base_link"' "$LOG/tf_node.log" && echo true)" "the log does not name the frames"
}

t_scanners() {
  # Two 270° scanners (front x 0.2 m; rear x -0.2 m facing back) merged into
  # one scan: backing up while both are alive; the rear silent, or without a
  # pose on tf, forbids it; the front silent stops forward motion.
  local tfp node cmd front rear out v ns=/t_mscan
  tfp=$(spawn mscan_tf $ROSPY tests/ros/static_tf.py base_link front_laser@0.2,0,0 rear_laser@-0.2,0,180)
  wait_log "$LOG/mscan_tf.log" "static_tf:" 20 || return 1
  rosparam set $ns/oldbf_node/node/scans "[{topic: front/scan, timeout_s: 0.3}, {topic: rear/scan, timeout_s: 0.3}]"
  node=$(spawn mscan_node "$BIN/oldbf_node" __ns:=$ns)
  wait_log "$LOG/mscan_node.log" "filtering at" 10 || return 1
  front=$(spawn mscan_front rostopic pub -r 10 -s $ns/front/scan sensor_msgs/LaserScan "$($ROSPY tests/ros/make_scan.py open270 front_laser)")
  rear=$(spawn mscan_rear rostopic pub -r 10 -s $ns/rear/scan sensor_msgs/LaserScan "$($ROSPY tests/ros/make_scan.py open270 rear_laser)")
  cmd=$(spawn mscan_cmd rostopic pub -r 20 $ns/cmd_vel_in geometry_msgs/Twist '{linear: {x: -0.1}}')
  sleep 3
  last_v() { timeout 10 rostopic echo -n 5 $ns/cmd_vel | awk '/linear:/{a=1} a&&/x:/{v=$2; a=0} END{print v}'; }
  scanner_1() { timeout 10 rostopic echo -n 2 /diagnostics | grep -A1 'key: "scanner_1"' | grep value | tail -1 | sed 's/.*value: //'; }
  v=$(last_v)
  figure "scanners: both alive, upstream -0.1 m/s -> linear.x = $v m/s"
  check "$(awk -v v="$v" 'BEGIN{print (v < -0.05) ? "true" : "false"}')" "both alive: linear.x = $v, want backing up" || return 1
  stop_pid "$rear"; sleep 1.5
  v=$(last_v); out=$(scanner_1)
  figure "scanners: rear silent -> linear.x = $v m/s; scanner_1: $out"
  check "$(awk -v v="$v" 'BEGIN{print (v >= 0) ? "true" : "false"}')" "rear silent: linear.x = $v, want no backing up" || return 1
  check "$(grep -q silent <<< "$out" && echo true)" "rear silent: diagnostics say $out" || return 1
  rear=$(spawn mscan_rear_nopose rostopic pub -r 10 -s $ns/rear/scan sensor_msgs/LaserScan "$($ROSPY tests/ros/make_scan.py open270 nowhere_laser)")
  sleep 2
  v=$(last_v); out=$(scanner_1)
  figure "scanners: rear without a pose -> linear.x = $v m/s; scanner_1: $out"
  check "$(awk -v v="$v" 'BEGIN{print (v >= 0) ? "true" : "false"}')" "rear without a pose: linear.x = $v, want no backing up" || return 1
  check "$(grep -q 'no pose' <<< "$out" && echo true)" "rear without a pose: diagnostics say $out" || return 1
  stop_pid "$rear"; stop_pid "$cmd"
  rear=$(spawn mscan_rear2 rostopic pub -r 10 -s $ns/rear/scan sensor_msgs/LaserScan "$($ROSPY tests/ros/make_scan.py open270 rear_laser)")
  cmd=$(spawn mscan_cmd2 rostopic pub -r 20 $ns/cmd_vel_in geometry_msgs/Twist '{linear: {x: 0.1}}')
  sleep 2
  v=$(last_v)
  check "$(awk -v v="$v" 'BEGIN{print (v > 0.05) ? "true" : "false"}')" "both alive, forward: linear.x = $v" || return 1
  stop_pid "$front"; sleep 1.5
  v=$(last_v)
  figure "scanners: front silent, upstream +0.1 m/s -> linear.x = $v m/s"
  stop_pid "$rear"; stop_pid "$cmd"; stop_pid "$node"; stop_pid "$tfp"
  check "$(awk -v v="$v" 'BEGIN{print (v <= 0) ? "true" : "false"}')" "front silent: linear.x = $v, want no forward motion" || return 1
  # The simulator with a front and a rear 270° LiDAR (front_rear.yaml): scan_0
  # and scan_1 from laser_0 and laser_1 on /tf, merged by the node.
  local launch s
  launch=$(spawn mscan_sim roslaunch --wait oldbf_ros sim.launch scenario:="$ROOT/config/scenarios/front_rear.yaml")
  s=$($ROSPY tests/ros/wait_summary.py /oldbf_sim_node/summary 230) || { stop_pid "$launch"; say "  no summary: $s"; return 1; }
  stop_pid "$launch"
  figure "scanners: front_rear over ROS: $(json "'goal reached at %.1f s, %d collisions, least clearance %.3f m' % (d['robots'][0]['time_to_goal_s'] or -1, d['collisions'], d['robots'][0]['min_clearance_m'])" <<< "$s")"
  check "$(grep -c 'laser pose "laser_[01]" from tf' "$LOG/mscan_sim.log" | awk '{print ($1 >= 2) ? "true" : "false"}')" "front_rear: the node did not place both LiDARs by tf" || return 1
  check "$(json "str(d['reached_goal'] and d['collisions'] == 0).lower()" <<< "$s")" "front_rear over ROS: $s"
}

t_cpu() {
  # The node's CPU use with two SICK TiM-class scanners: 1081 beams over
  # 270° each at 25 Hz, merged, plus a planner at 20 Hz (reported, not
  # asserted: docs/BENCHMARKS.md). The check is that every scan was answered.
  local tfp node out ns=/t_cpu
  tfp=$(spawn cpu_tf $ROSPY tests/ros/static_tf.py base_link front_laser@0.2,0,0 rear_laser@-0.2,0,180)
  wait_log "$LOG/cpu_tf.log" "static_tf:" 20 || return 1
  rosparam set $ns/oldbf_node/node/scans "[{topic: front/scan, timeout_s: 0.2}, {topic: rear/scan, timeout_s: 0.2}]"
  node=$(spawn cpu_node "$BIN/oldbf_node" __ns:=$ns _node/publish_markers:=false)
  wait_log "$LOG/cpu_node.log" "filtering at" 10 || return 1
  out=$($ROSPY tests/ros/cpu_probe.py $ns "$node" 1081 25 30)
  stop_pid "$node"; stop_pid "$tfp"
  echo "$out" > "$LOG/cpu.json"
  figure "cpu: two scanners, 1081 beams each at 25 Hz (+ cmd_vel_in 20 Hz), 30 s: $out ($(nproc) cores: $(grep -m1 'model name' /proc/cpuinfo | sed 's/.*: //'))"
  check "$(json "str(d['commands_per_s'] >= 40).lower()" <<< "$out")" "fewer commands than scans: $out"
}

t_sim() {
  local launch bag s
  launch=$(spawn sim_launch roslaunch --wait oldbf_ros sim.launch)
  bag=$(spawn sim_bag rosbag record -O "$LOG/sim.bag" --duration=25 /scan /odom /cmd_vel)
  s=$($ROSPY tests/ros/wait_summary.py /oldbf_sim_node/summary 230) || { stop_pid "$launch"; say "  no summary: $s"; return 1; }
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
  check "$(json "str(d['commands_while_fresh'] > 10).lower()" <<< "$s")" "no motion while scans were fresh: $s" || return 1
  # 0.6 s plus 50 ms for message transport and timer jitter on a shared 2-core machine.
  check "$(json "str(d['stop_delay_s'] is not None and d['stop_delay_s'] <= 0.65).lower()" <<< "$s")" "stop delay: $s"
}

t_latency() {
  local node s
  # A base that can change its command at once (the window holds the whole input box): each
  # scan's kind of command can then be sent on that scan, which is what is traced.
  node=$(spawn latency_node "$BIN/oldbf_node" __ns:=/t_latency _node/nominal_source:=constant \
    _control/accel_mps2:=100.0 _control/decel_mps2:=100.0 _control/angular_accel_radps2:=1000.0 \
    _passive/evasion_accel_mps2:=100.0 _passive/evasion_angular_accel_radps2:=1000.0)
  wait_log "$LOG/latency_node.log" "filtering at" 10 || return 1
  s=$($ROSPY tests/ros/latency_probe.py /t_latency 200)
  stop_pid "$node"
  echo "$s" > "$LOG/latency.json"
  figure "latency scan -> cmd_vel over loopback: $(json "'p50 %s ms, p99 %s ms, max %s ms over %d scans (~state: p50 %s, p99 %s, max %s ms); %d cmd_vel messages' % (d['cmd_latency_ms']['p50'], d['cmd_latency_ms']['p99'], d['cmd_latency_ms']['max'], d['cmd_latency_ms']['n'], d['state_latency_ms']['p50'], d['state_latency_ms']['p99'], d['state_latency_ms']['max'], d['cmd_vel_messages'])" <<< "$s")"
  # Asserted: each scan's command was computed from it (not a timing bound, which is reported only).
  check "$(json "str(d['used'] >= 0.95 * d['scans'] and d['matched'] >= 0.95 * (d['scans'] - 1) and d['wrong_kind'] == 0).lower()" <<< "$s")" "commands not traced to their scans: $s"
}

t_ticks() {
  local node s hz
  node=$(spawn ticks_node "$BIN/oldbf_node" __ns:=/t_ticks)
  wait_log "$LOG/ticks_node.log" "filtering at" 10 || return 1
  for hz in 20 100; do
    s=$($ROSPY tests/ros/between_scans.py /t_ticks "$hz" 9) || { stop_pid "$node"; return 1; }
    echo "$s" > "$LOG/ticks_$hz.json"
    figure "ticks: planner at $hz Hz beside a 10 Hz LiDAR, a person walking in: $(json "'%d states, %d between scans; after the first threat (person at %.2f m) %d states, %d without it' % (d['states'], d['between'], d['first_threat_x'] or -1, d['after_threat'], d['missed'])" <<< "$s")"
    check "$(json "str(d['first_threat_x'] is not None and d['between'] > d['states'] // 3 and d['after_threat'] > 40 and d['missed'] == 0).lower()" <<< "$s")" "planner at $hz Hz: $s" || { stop_pid "$node"; return 1; }
    sleep 1
  done
  stop_pid "$node"
}

t_clock() {
  local node pub s jumps
  node=$(spawn clock_node "$BIN/oldbf_node" __ns:=/t_clock)
  wait_log "$LOG/clock_node.log" "filtering at" 10 || return 1
  pub=$(spawn clock_scans rostopic pub -r 10 -s /t_clock/scan sensor_msgs/LaserScan "$($ROSPY tests/ros/make_scan.py open)")
  s=$($ROSPY tests/ros/fast_commands.py /t_clock 1000 120) || { stop_pid "$pub"; stop_pid "$node"; return 1; }
  stop_pid "$pub"
  stop_pid "$node"
  echo "$s" > "$LOG/clock.json"
  jumps=$(grep -c "clock jumped" "$LOG/clock_node.log" || true)
  figure "clock: cmd_vel_in at $(json "d['rate_hz']" <<< "$s") Hz for 120 s: $(json "'%d commands, %d states, %d naming a clock jump, %d zero commands for a late scan, %d for a stale upstream (zero nominal), %d other zero commands' % (d['published'], d['states'], d['clock_jump'], d['zero_late_scan'], d['zero_nominal'], d['zero'])" <<< "$s"); $jumps clock-jump lines in the node's log"
  check "$(json "str(d['rate_hz'] >= 700 and d['states'] >= 0.5 * d['published'] and d['clock_jump'] == 0 and d['zero'] == 0).lower()" <<< "$s")" "1 kHz commands: $s" || return 1
  check "$([ "$jumps" = 0 ] && echo true)" "the node logged $jumps clock jumps"
}

t_simtime() {
  local node s waited=0
  rosparam set /use_sim_time true
  node=$(spawn simtime_node "$BIN/oldbf_node" __ns:=/t_simtime)
  wait_log "$LOG/simtime_node.log" "filtering at" 10 || { rosparam delete /use_sim_time; stop_pid "$node"; return 1; }
  s=$($ROSPY tests/ros/sim_time.py /t_simtime 6) || { rosparam delete /use_sim_time; stop_pid "$node"; return 1; }
  echo "$s" > "$LOG/simtime.json"
  # /clock has stopped: Ctrl-C must still end the node.
  kill -INT "$node"
  while kill -0 "$node" 2>/dev/null && [ "$waited" -lt 50 ]; do sleep 0.1; waited=$((waited + 1)); done
  local alive=false
  kill -0 "$node" 2>/dev/null && alive=true
  stop_pid "$node" KILL
  rosparam delete /use_sim_time
  figure "simtime: first scan at $(json "d['first_scan_s']" <<< "$s") s (simulated), first command from a scan at $(json "d['first_scan_state_s']" <<< "$s") s; $(json "'%d states, %d from scans' % (d['states'], d['states_with_scan'])" <<< "$s"); Ctrl-C with /clock stopped: $([ $alive = false ] && echo "exited after $((waited * 100)) ms" || echo "still running after 5 s")"
  check "$(json "str(d['first_scan_state_s'] is not None and d['first_scan_state_s'] - d['first_scan_s'] <= 0.25 and d['states_with_scan'] > 40).lower()" <<< "$s")" "sim time: $s" || return 1
  check "$(! grep -q 'subscribing to scan again' "$LOG/simtime_node.log" && echo true)" "the node subscribed to scan again under sim time" || return 1
  check "$([ $alive = false ] && echo true)" "Ctrl-C did not end the node with /clock stopped"
}

t_locks() {
  local node s
  node=$(spawn locks_node "$BIN/oldbf_node" __ns:=/t_locks _node/e_stop_timeout_s:=0.5 _node/disable_timeout_s:=2.0)
  wait_log "$LOG/locks_node.log" "filtering at" 10 || return 1
  s=$($ROSPY tests/ros/locks_probe.py /t_locks) || { stop_pid "$node"; say "  probe failed: $s"; return 1; }
  stop_pid "$node"
  echo "$s" > "$LOG/locks.json"
  figure "locks: e_stop liveness 0.5 s: $(json "'before any e_stop %d of %d commands moved (%d of %d states: not heard yet); alive: up to %s m/s; silent: zero %s s after its last message (%s), diagnostics %s; heard again: up to %s m/s, no reset' % (d['startup_nonzero'], d['startup_commands'], d['startup_states_not_heard'], d['startup_states'], d['alive_max_v'], d['silence_stop_delay_s'], d['silence_reason'], d['silence_diag'], d['again_max_v'])" <<< "$s")"
  figure "locks: disable 2.0 s before a wall (filtered: up to $(json "d['wall_max_v']" <<< "$s") m/s): $(json "'%d commands of 0.2 m/s passed; answer \"%s\"; diagnostics \"%s\"; filtered again %s s after the call; renewed after 1.5 s: %s s after the first call, %s s after the second' % (d['disabled_passes'], d['disable_answer'], d['disabled_diag'], d['lapsed_after_s'], d['renewed_lapsed_after_first_s'], d['renewed_lapsed_after_second_s'])" <<< "$s")"
  check "$(json "str(d['startup_commands'] >= 10 and d['startup_nonzero'] == 0 and d['startup_states_not_heard'] >= 5).lower()" <<< "$s")" "before the first e_stop: $s" || return 1
  check "$(json "str((d['alive_max_v'] or 0) > 0 and (d['again_max_v'] or 0) > 0).lower()" <<< "$s")" "no motion with e_stop alive: $s" || return 1
  # 0.5 s timeout, plus one tick (cmd_vel_in at 20 Hz) and transport on a shared machine.
  check "$(json "str(d['silence_stop_delay_s'] is not None and 0.5 <= d['silence_stop_delay_s'] <= 0.7 and d['silence_moving_after_stop'] == 0 and d['silence_reason'] is not None and d['silence_diag'] is not None and d['silence_diag'][0] == 2).lower()" <<< "$s")" "silent e_stop: $s" || return 1
  check "$(grep -q 'e_stop silent for' "$LOG/locks_node.log" && grep -q 'e_stop heard again' "$LOG/locks_node.log" && echo true)" "the log does not say the e_stop went silent and came back" || return 1
  check "$(json "str((d['wall_max_v'] or 1) <= 0 and d['disabled_passes'] >= 10 and d['disabled_diag'] is not None and 'for 2.0 s' in d['disable_answer']).lower()" <<< "$s")" "disable: $s" || return 1
  # 2.0 s, plus one tick (cmd_vel_in at 20 Hz) and transport on a shared machine.
  check "$(json "str(d['lapsed_after_s'] is not None and 2.0 <= d['lapsed_after_s'] <= 2.2).lower()" <<< "$s")" "the disable did not lapse after 2.0 s: $s" || return 1
  check "$(json "str(d['renewed_lapsed_after_second_s'] is not None and 2.0 <= d['renewed_lapsed_after_second_s'] <= 2.2 and d['renewed_lapsed_after_first_s'] >= 3.4).lower()" <<< "$s")" "the renewed disable: $s" || return 1
  check "$(grep -q 'lapsed at' "$LOG/locks_node.log" && echo true)" "the log does not say the disable lapsed"
}

t_diagnostics() {
  local agg node node2 pub s
  agg=$(spawn diag_agg roslaunch --wait oldbf_ros diagnostics.launch)
  wait_log "$LOG/diag_agg.log" "process\[diagnostic_aggregator" 20 || { stop_pid "$agg"; tail -20 "$LOG/diag_agg.log"; return 1; }
  # Default hardware_id: the scans' frame_id. Set: node/hardware_id.
  node=$(spawn diag_node "$BIN/oldbf_node" __ns:=/t_diag)
  node2=$(spawn diag_node2 "$BIN/oldbf_node" __ns:=/t_diag2 _node/hardware_id:=front_lidar)
  wait_log "$LOG/diag_node.log" "filtering at" 10 || { stop_pid "$agg"; stop_pid "$node"; stop_pid "$node2"; return 1; }
  pub=$(spawn diag_scans rostopic pub -r 10 -s /t_diag/scan sensor_msgs/LaserScan "$($ROSPY tests/ros/make_scan.py open | sed 's/frame_id: laser/frame_id: t_diag_laser/')")
  s=$($ROSPY tests/ros/diag_agg_probe.py 20 "/t_diag/can_bridge_node: CAN bridge" \
      "/Base/Safety filter/ t_diag oldbf_node: safety filter=t_diag_laser" \
      "/Base/Safety filter/ t_diag2 oldbf_node: safety filter=front_lidar" \
      "/Base/CAN bridge/ t_diag can_bridge_node: CAN bridge=can0") || true
  stop_pid "$pub"; stop_pid "$node"; stop_pid "$node2"; stop_pid "$agg"
  echo "$s" > "$LOG/diagnostics.json"
  figure "diagnostics: /diagnostics_agg under /Base: $(json "'; '.join('%s [%s] level %d' % (n, h, l) for n, l, h, m in d['statuses'])" <<< "$s")"
  check "$(json "str(d['found']).lower()" <<< "$s")" "the aggregated statuses or hardware_ids are not as expected: $s"
}

t_reconfigure() {
  local node s
  node=$(spawn reconfigure_node "$BIN/oldbf_node" __ns:=/t_reconf _node/nominal_source:=constant)
  wait_log "$LOG/reconfigure_node.log" "filtering at" 10 || return 1
  s=$($ROSPY tests/ros/reconfigure_probe.py /t_reconf) || { stop_pid "$node"; say "  probe failed: $s"; return 1; }
  stop_pid "$node"
  echo "$s" > "$LOG/reconfigure.json"
  figure "reconfigure: $(json "'%d parameters; d_safe %s -> 0.4 (answer %s, read back %s, param server %s): the robot stops with a wall %s m ahead, then %s m; d_safe 30 refused (running %s), {gamma 0.5, d_safe -1} refused (running %s)' % (d['parameters'], d['d_safe_initial'], d['d_safe_answer'], d['d_safe_read_back'], d['d_safe_param_server'], d['stop_at_initial_m'], d['stop_at_0.4_m'], d['refused_answer'], d['after_refusals'])" <<< "$s")"
  check "$(json "str(d['d_safe_initial'] == 0.2 and d['d_safe_answer'] == 0.4 and d['d_safe_read_back'] == 0.4 and d['d_safe_param_server'] == 0.4).lower()" <<< "$s")" "set and read: $s" || return 1
  check "$(json "str(d['d_safe_description'] == {'type': 'double', 'min': 0.0, 'max': 10.0, 'default': 0.2}).lower()" <<< "$s")" "description: $s" || return 1
  # The larger margin stops the robot earlier: by the 0.2 m added, to a centimetre.
  check "$(json "str(d['stop_at_initial_m'] is not None and d['stop_at_0.4_m'] is not None and abs(d['stop_at_0.4_m'] - d['stop_at_initial_m'] - 0.2) <= 0.015).lower()" <<< "$s")" "stop distances: $s" || return 1
  # Still in force: with the wall inside r + d_safe no forward speed (backing away is allowed: allow_reverse, rear seen).
  check "$(json "str(d['refused_answer'] == 0.4 and d['after_refusals'] == [0.2, 0.4] and d['after_refusals_param_server'] == 0.4 and d['v_at_0.5_m_after_refusals'] is not None and d['v_at_0.5_m_after_refusals'] <= 0.0).lower()" <<< "$s")" "refusals: $s" || return 1
  # shellcheck disable=SC2016 # the backticks are literal: they quote the key in the message
  check "$(grep -q 'request refused, running values kept: key `barrier.d_safe_m` = 30 is out of range; allowed: \[0, 10\] m' "$LOG/reconfigure_node.log" && echo true)" "no refusal message naming the key"
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

t_baselimits() {
  local l rc f b shipped=$ROOT/config/base_limits.yaml soft=$LOG/soft_base_limits.yaml
  # name cmd...: runs a node to its exit (at most 20 s), output in $LOG/name.log; prints its exit status.
  exit_of() { local name=$1; shift; timeout 20 "$@" > "$LOG/$name.log" 2>&1 && echo 0 || echo $?; }
  # The shipped file: the filter starts.
  l=$(spawn base_ok roslaunch --wait oldbf_ros oldbf.launch ns:=/t_base_a base_limits:="$shipped")
  wait_log "$LOG/base_ok.log" "filtering at" 15 || { stop_pid "$l"; say "  oldbf_node did not start with the shipped base limits"; return 1; }
  stop_pid "$l"
  check "$(grep -q 'exit code 2' "$LOG/base_ok.log" && echo false || echo true)" "shipped base limits refused" || return 1
  # A base that brakes at only 0.8 m/s²: the filter's braking check (1.0) would assume more.
  sed 's/^  decel_mps2: 1.0 /  decel_mps2: 0.8 /' "$shipped" > "$soft"
  check "$(grep -q '^  decel_mps2: 0.8 ' "$soft" && echo true)" "could not write $soft" || return 1
  rc=$(exit_of base_filter_refused "$BIN/oldbf_node" __ns:=/t_base_b _node/base_limits_file:="$soft")
  check "$([ "$rc" = 2 ] && grep -q 'control.decel_mps2' "$LOG/base_filter_refused.log" \
    && grep -q 'base.decel_mps2' "$LOG/base_filter_refused.log" && echo true)" "oldbf_node, soft base: exit $rc" || return 1
  # shellcheck disable=SC2016 # the backticks are literal: they quote the keys in the message
  figure "baselimits: oldbf_node exit $rc: $(grep -o 'key `control.decel_mps2`.*' "$LOG/base_filter_refused.log" | head -1)"
  # The bridge: a ramp softened to 20 rad/s² at the wheel (0.66 m/s²) against the shipped base.
  rc=$(exit_of base_bridge_refused "$BIN/can_bridge_node" __ns:=/t_base_c _node/base_limits_file:="$shipped" \
    _limits/wheel_decel_radps2:=20.0)
  check "$([ "$rc" = 2 ] && grep -q 'limits.wheel_decel_radps2' "$LOG/base_bridge_refused.log" \
    && grep -q 'base.decel_mps2' "$LOG/base_bridge_refused.log" && echo true)" "can_bridge_node, soft ramp: exit $rc" || return 1
  # shellcheck disable=SC2016
  figure "baselimits: can_bridge_node exit $rc: $(grep -o 'key `limits.wheel_decel_radps2`.*' "$LOG/base_bridge_refused.log" | head -1)"
  # A speed-up ramp of 20 rad/s² (0.66 m/s², 0.404 beside a full yaw acceleration) below the base's 2.5.
  rc=$(exit_of base_bridge_slow "$BIN/can_bridge_node" __ns:=/t_base_e _node/base_limits_file:="$shipped" \
    _limits/wheel_accel_radps2:=20.0)
  check "$([ "$rc" = 2 ] && grep -q 'limits.wheel_accel_radps2' "$LOG/base_bridge_slow.log" \
    && grep -q 'base.accel_mps2' "$LOG/base_bridge_slow.log" && echo true)" "can_bridge_node, slow speed-up ramp: exit $rc" || return 1
  # shellcheck disable=SC2016
  figure "baselimits: can_bridge_node exit $rc: $(grep -o 'key `limits.wheel_accel_radps2`.*' "$LOG/base_bridge_slow.log" | head -1)"
  # The shipped bridge passes the check; it then stops at the CAN interface this kernel lacks.
  rc=$(exit_of base_bridge_ok "$BIN/can_bridge_node" __ns:=/t_base_d _node/base_limits_file:="$shipped" _interface:=vcan0)
  check "$([ "$rc" != 2 ] && ! grep -q 'base.decel_mps2\|base.accel_mps2' "$LOG/base_bridge_ok.log" && echo true)" \
    "can_bridge_node, shipped base: exit $rc: $(tail -2 "$LOG/base_bridge_ok.log")" || return 1
  # bringup.launch loads the same file into both nodes.
  roslaunch --dump-params oldbf_ros bringup.launch > "$LOG/base_bringup_params.yaml"
  f=$(grep -o "/oldbf_node/node/base_limits_file: .*" "$LOG/base_bringup_params.yaml" | sed 's/^[^:]*: //' | tr -d "'")
  b=$(grep -o "/can_bridge_node/node/base_limits_file: .*" "$LOG/base_bringup_params.yaml" | sed 's/^[^:]*: //' | tr -d "'")
  check "$([ -n "$f" ] && [ "$f" = "$b" ] && [ "$(basename "$f")" = base_limits.yaml ] && echo true)" \
    "bringup.launch: filter '$f', bridge '$b'" || return 1
  figure "baselimits: bringup.launch gives both nodes $f"
}

t_footprint() {
  local l rc
  # move_base's costmap YAML (the footprint as a string, 0.6 x 0.4 m) loaded where move_base keeps it.
  rosparam load "$ROOT/tests/ros/move_base_costmap.yaml" /move_base/local_costmap
  l=$(spawn footprint_ok roslaunch --wait oldbf_ros oldbf.launch ns:=/t_fp_a \
    "overrides:={node: {footprint_param: /move_base/local_costmap/footprint}}")
  wait_log "$LOG/footprint_ok.log" "filtering at" 15 || { stop_pid "$l"; say "  oldbf_node did not start with the costmap footprint"; return 1; }
  stop_pid "$l"
  # Read as a polygon of 4 vertices; until the checks take the polygon, r is its circumscribed circle √0.13.
  check "$(grep -q 'footprint: a polygon of 4 vertices from /move_base/local_costmap/footprint' "$LOG/footprint_ok.log" \
    && grep -q 'r = 0.361 m' "$LOG/footprint_ok.log" && echo true)" "costmap footprint not read" || return 1
  figure "footprint: $(grep -o 'footprint: a polygon.*' "$LOG/footprint_ok.log" | head -1)"
  # A footprint that crosses itself: the node exits 2 naming footprint.polygon_m.
  rosparam set /move_base/bad_costmap/footprint "[[0.3, 0.2], [-0.3, -0.2], [0.3, -0.2], [-0.3, 0.2]]"
  set +e
  timeout 20 "$BIN/oldbf_node" __ns:=/t_fp_b _node/footprint_param:=/move_base/bad_costmap/footprint > "$LOG/footprint_bad.log" 2>&1
  rc=$?
  set -e
  check "$([ $rc = 2 ] && grep -q 'footprint.polygon_m' "$LOG/footprint_bad.log" && grep -q 'edges 0 and 2 intersect' "$LOG/footprint_bad.log" && echo true)" \
    "crossing footprint: exit $rc" || return 1
  # A name nothing is set under: exit 2 naming node.footprint_param.
  set +e
  timeout 20 "$BIN/oldbf_node" __ns:=/t_fp_c _node/footprint_param:=/move_base/nothing/footprint > "$LOG/footprint_unset.log" 2>&1
  rc=$?
  set -e
  check "$([ $rc = 2 ] && grep -q 'node.footprint_param' "$LOG/footprint_unset.log" && echo true)" "unset footprint param: exit $rc"
}

t_multi() {
  local l s topics run
  # The symmetric crossing (two_robots: timed to meet, each the other's
  # obstacle), five times: ROS timing differs from run to run, and the
  # right-of-way convention (ALGORITHM §4b) must settle every one.
  for run in 1 2 3 4 5; do
    l=$(spawn "multi_launch_$run" roslaunch --wait oldbf_ros multi_robot.launch scenario:="$ROOT/config/scenarios/two_robots.yaml")
    sleep 6
    [ "$run" -gt 1 ] || topics=$(rostopic list)
    s=$($ROSPY tests/ros/wait_summary.py /oldbf_sim_node/summary 230) || { stop_pid "$l"; say "  run $run: no summary: $s"; return 1; }
    stop_pid "$l"
    # The stopped nodes left the master clean (ros/leave_master.rs): a dead node's
    # address left there is called by the master and by subscribers, and a rosrust
    # publisher that later listens on its port stops accepting subscribers.
    local left
    left=$(rosnode list 2>/dev/null | grep -E '^/(robot1|robot2)/oldbf_node$|^/oldbf_sim_node$' || true)
    check "$([ -z "$left" ] && echo true)" "multi-robot run $run: still registered after the stop: $left" || return 1
    figure "multi run $run/5: $(json "'; '.join('%s goal %s at %.1f s, %d collisions' % (r['name'], r['reached_goal'], r['time_to_goal_s'] or -1, r['collisions']) for r in d['robots'])" <<< "$s")"
    if [ "$run" -eq 1 ]; then
      for t in /robot1/scan /robot1/cmd_vel /robot1/oldbf_node/state /robot2/scan /robot2/cmd_vel /robot2/oldbf_node/state; do
        grep -qx "$t" <<< "$topics" || { say "  topic $t missing"; return 1; }
      done
    fi
    check "$(json "str(d['reached_goal'] and d['collisions'] == 0 and len(d['robots']) == 2).lower()" <<< "$s")" "multi-robot run $run: $s" || return 1
  done
  local unsub
  unsub=$(grep -c -- '-CACHEDPARAM \[/\] by /robot[12]/oldbf_node' "$ROS_HOME"/log/latest/master.log || true)
  figure "multi: parameter subscriptions withdrawn by the stopped filters: $unsub of 10"
  check "$([ "$unsub" -ge 10 ] && echo true)" "the filters left $(( 10 - unsub )) parameter subscriptions behind" || return 1
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

t_catkin() {
  # Outside the repository: the workspace links to it, and a link back into
  # the package would make roslaunch's source-tree search loop.
  local ws
  ws=$(mktemp -d "${TMPDIR:-/tmp}/oldbf_catkin_ws.XXXXXX")
  echo "$ws" > "$LOG/catkin_ws"
  mkdir -p "$ws/src"
  ln -s "$ROOT" "$ws/src/oldbf_ros"
  # A user's shell: Debian's ROS, nothing of install.sh's layout; with
  # SPACE/setup.bash sourced unless SPACE is '-'. A script, so spawn can run it.
  local in_ws=$ws/in_ws.sh
  cat > "$in_ws" <<'SH'
#!/usr/bin/env bash
ws=$(cd "$(dirname "$0")" && pwd); space=$1; shift
unset ROS_PACKAGE_PATH PYTHONPATH CMAKE_PREFIX_PATH
cd "$ws"
[ "$space" = - ] || source "$ws/$space/setup.bash"
exec "$@"
SH
  chmod +x "$in_ws"
  local t0=$SECONDS
  # Debian's python3, not one first on PATH without catkin_pkg (TESTBED.md).
  "$in_ws" - catkin_make -DPYTHON_EXECUTABLE=/usr/bin/python3 > "$LOG/catkin_make.log" 2>&1 \
    || { tail -30 "$LOG/catkin_make.log"; return 1; }
  local build_s=$(( SECONDS - t0 ))
  t0=$SECONDS
  "$in_ws" - catkin_make install -DPYTHON_EXECUTABLE=/usr/bin/python3 > "$LOG/catkin_install.log" 2>&1 \
    || { tail -30 "$LOG/catkin_install.log"; return 1; }
  local install_s=$(( SECONDS - t0 ))
  figure "catkin: catkin_make ${build_s} s, catkin_make install ${install_s} s in a fresh workspace; cargo: $(grep -c ' Compiling ' "$LOG/catkin_make.log" || true) crates compiled ($(grep -m1 -o 'Finished .*' "$LOG/catkin_make.log"))"
  # One workspace build: cargo ran on the target dir install.sh already built.
  check "$(grep -q 'Finished `release`' "$LOG/catkin_make.log" && ! grep -q ' Compiling ' "$LOG/catkin_make.log" && echo true)" "catkin_make recompiled the workspace" || return 1
  for f in devel/lib/oldbf_ros/oldbf_node devel/lib/python3/dist-packages/oldbf_ros/msg/_BarrierState.py \
           install/lib/oldbf_ros/oldbf_node install/lib/oldbf_ros/can_bridge_node install/share/oldbf_ros/launch/sim.launch \
           install/share/oldbf_ros/config/oldbf.yaml install/share/oldbf_ros/msg/BarrierState.msg \
           install/lib/python3/dist-packages/oldbf_ros/msg/_BarrierState.py install/share/oldbf_ros/package.xml; do
    [ -e "$ws/$f" ] || { say "  $f missing"; return 1; }
  done
  [ ! -L "$ws/install/lib/oldbf_ros/oldbf_node" ] || { say "  the install space links into the source tree"; return 1; }
  # package.xml: the run dependencies rosdep would resolve.
  figure "catkin: exec_depend $($ROSPY -c "from catkin_pkg.package import parse_package; print(' '.join(d.name for d in parse_package('$ROOT').exec_depends))")"
  local space l state pids
  for space in devel install; do
    l=$(spawn "catkin_$space" "$in_ws" "$space" roslaunch --wait oldbf_ros sim.launch)
    wait_log "$LOG/catkin_$space.log" "filtering (" 30 || { stop_pid "$l"; tail -20 "$LOG/catkin_$space.log"; return 1; }
    # ~state decoded with the space's own Python class.
    state=$("$in_ws" "$space" timeout 10 rostopic echo -n 1 /oldbf_node/state) || true
    # The processes roslaunch started for this workspace (others may run on the machine).
    pids=$(ps -eo args | grep -E "^$ws/[a-z]+/lib/oldbf_ros/oldbf_(node|sim_node) " || true)
    stop_pid "$l"
    figure "catkin: roslaunch sim.launch from $space/ ran $(awk '{print $1}' <<< "$pids" | sed "s|^$ws/||" | tr '\n' ' ')"
    check "$([ "$(grep -c "^$ws/$space/lib/oldbf_ros/oldbf_" <<< "$pids")" = 2 ] && echo true)" "$space: nodes not run from $ws/$space: $pids" || return 1
    check "$(grep -q 'doaa_state_name:' <<< "$state" && echo true)" "$space: ~state not echoed: $state" || return 1
  done
  rm -rf "$ws"
}

t_rviz() {
  local xvfb l poser x1 x2 s1 s2 rc1=0 rc2=0
  # A free display, chosen by Xvfb (-displayfd 1 prints its number in the
  # log): another checkout may run this test at the same time.
  local display=
  xvfb=$(spawn xvfb Xvfb -displayfd 1 -screen 0 1024x768x24 -nolisten tcp)
  for _ in $(seq 100); do display=$(grep -m1 -x '[0-9]\+' "$LOG/xvfb.log") && break; sleep 0.1; done
  [ -n "$display" ] || { cat "$LOG/xvfb.log"; say "  Xvfb did not start"; stop_pid "$xvfb"; return 1; }
  display=:$display
  # The robot's x, from /tf, subscribed before the simulator starts.
  rm -f "$LOG/base_x"
  poser=$(spawn base_x "$ROSPY" tests/ros/base_x.py "$LOG/base_x")
  sleep 1
  l=$(DISPLAY=$display spawn rviz_launch roslaunch --wait oldbf_ros sim.launch rviz:=true)
  # rviz under software GL takes a while; the sim must be under way too.
  wait_log "$LOG/rviz_launch.log" "filtering (" 30 || true
  # Two screenshots metres apart along the robot's way: the view must follow it.
  shoot() { # name: screenshot; prints the robot's x in odom when it was taken
    xwd -root -display "$display" -silent | xwdtopnm > "$LOG/$1.ppm" 2>/dev/null
    pnmtopng "$LOG/$1.ppm" > "$LOG/$1.png" 2>/dev/null
    cat "$LOG/base_x" 2>/dev/null || echo none
  }
  sleep 8
  x1=$(shoot rviz_early)
  sleep 18
  x2=$(shoot rviz)
  stop_pid "$l"; stop_pid "$poser"; stop_pid "$xvfb"
  s1=$($ROSPY tests/ros/check_screenshot.py "$LOG/rviz_early.ppm") || rc1=$?
  s2=$($ROSPY tests/ros/check_screenshot.py "$LOG/rviz.ppm") || rc2=$?
  figure "rviz: robot at x = $x1 m: $LOG/rviz_early.png: $s1"
  figure "rviz: robot at x = $x2 m: $LOG/rviz.png: $s2"
  check "$(awk -v a="$x1" -v b="$x2" 'BEGIN{print (a != "none" && b - a >= 1.5) ? "true" : "false"}')" "the robot moved only from x = $x1 to $x2 m" || return 1
  [ $rc1 = 0 ] && [ $rc2 = 0 ] || { say "  screenshots: blank, not following the robot, or no label: $s1 / $s2"; return 1; }
}

# ------------------------------------------------------------------ run
# In three phases, each test as it would run alone:
#   1. md5, alone: its build links target/release's binaries, which the
#      other tests run.
#   2. two lanes side by side, each on its own roscore: lane B the
#      simulator's runs, which take minutes of real time and leave the CPU
#      all but idle (sim, bag, which replays sim's recording, and multi's
#      five runs: about 0.1 of a core), lane A every other test, in order.
#      Tests that set global state (/use_sim_time: simtime, bag) each have
#      their own master, so nothing of one lane reaches the other.
#   3. clock (a 1 kHz publisher for 120 s beside the node: a core's worth,
#      and its 10 Hz LiDAR must never be starved past the scan timeout;
#      beside lane B's multi it was, 902 times in one run), catkin (its cargo
#      build relinks target/release's binaries) and rviz (rviz's software
#      GL takes a core), alone.
# Each test's PASS/FAIL line goes to $LOG/results; lane B's output is
# printed after lane A's.
LANE_B=(sim bag multi)
LAST=(clock catkin rviz)
: > "$LOG/results"
in_list() { local x=$1; shift; case " $* " in *" $x "*) return 0 ;; esac; return 1; }
run_test() { # t: runs t_$t in a subshell; prints and records its PASS/FAIL line
  local t=$1 t0 rc line
  t0=$(date +%s)
  set +e
  ( set -Eeuo pipefail; "t_$t" )
  rc=$?
  set -e
  if [ $rc = 0 ]; then line="PASS $t ($(( $(date +%s) - t0 )) s)"; else line="FAIL $t ($(( $(date +%s) - t0 )) s)"; fi
  echo "$line" >> "$LOG/results"
  say "$line"
}
first=(); lane_a=(); lane_b=(); last=()
for t in "${SELECTED[@]}"; do
  case " ${ALL[*]} " in *" $t "*) ;; *) say "unknown test $t (tests: ${ALL[*]})"; exit 2 ;; esac
  if [ "$t" = md5 ]; then first+=("$t")
  elif in_list "$t" "${LANE_B[@]}"; then lane_b+=("$t")
  elif in_list "$t" "${LAST[@]}"; then last+=("$t")
  else lane_a+=("$t"); fi
done
for t in "${first[@]}"; do run_test "$t"; done
if [ ${#lane_a[@]} -gt 0 ] && [ ${#lane_b[@]} -gt 0 ]; then
  home_b=$LOG/ros_home_lane_b
  if port_b=$(start_master roscore_lane_b "$home_b"); then
    say "lane B (${lane_b[*]}) on its own roscore, port $port_b, beside lane A; its output follows lane A's"
    (
      export ROS_MASTER_URI=http://localhost:$port_b/ ROS_HOME=$home_b
      if start_static_tf static_tf_lane_b; then
        for t in "${lane_b[@]}"; do run_test "$t"; done
      else
        for t in "${lane_b[@]}"; do echo "FAIL $t (no static_tf on lane B's master)" >> "$LOG/results"; done
      fi
    ) > "$LOG/lane_b.log" 2>&1 &
    lane_b_pid=$!
    for t in "${lane_a[@]}"; do run_test "$t"; done
    wait "$lane_b_pid" || true
    say "lane B's output:"
    cat "$LOG/lane_b.log"
  else
    cat "$LOG/roscore_lane_b.log"
    say "lane B's roscore did not come up"
    for t in "${lane_b[@]}"; do echo "FAIL $t (lane B's roscore did not come up)" >> "$LOG/results"; done
    for t in "${lane_a[@]}"; do run_test "$t"; done
  fi
else
  for t in "${lane_a[@]}" "${lane_b[@]}"; do run_test "$t"; done
fi
for t in "${last[@]}"; do run_test "$t"; done
printf '\n'
RESULTS=()
for t in "${SELECTED[@]}"; do
  r=$(grep -m1 -E "^(PASS|FAIL) $t( |\$)" "$LOG/results" || echo "FAIL $t (no result)")
  RESULTS+=("$r")
done
for r in "${RESULTS[@]}"; do say "$r"; done
[ -s "$LOG/figures.txt" ] && { say "figures:"; sed 's/^/  /' "$LOG/figures.txt"; }
! printf '%s\n' "${RESULTS[@]}" | grep -q '^FAIL'
