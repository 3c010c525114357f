#!/usr/bin/env bash
# tests/e2e_group.sh: the end-to-end test through CAN, in ONE boot of the
# QEMU guest (this machine's kernel has no CAN): roscore + oldbf_sim_node +
# oldbf_node + can_bridge_node + virtual_drive on vcan0, where the simulated
# robot moves by the wheel speeds the virtual drive reports over CAN
# (launch/sim_can.launch). paper_line must reach its goal with 0 collisions.
#
# Installs what it needs (ROS packages, can-utils, the guest kernel), builds
# and installs the nodes, then boots the guest with tests/vm/e2e_guest.sh.
set -Eeuo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd -P)
cd "$ROOT"
t0=$(date +%s)
tests/ros/install_deps.sh
tests/vm/setup-host.sh > /dev/null
oldbf_ros/rospkg/install.sh > "$ROOT/target/e2e_install.log" 2>&1 || { tail -20 "$ROOT/target/e2e_install.log"; exit 1; }
# The ROS types can_bridge_node vendors beyond oldbf_ros's: md5 = ROS's own (genmsg, rosmsg).
# The ros group's command line for its ROS-feature tests (tests/ros_group.sh, ROS_TESTS),
# so after that group this builds nothing; the filter runs can_bridge's test alone.
cargo test --release --locked -p oldbf_ros -p can_bridge --features oldbf_ros/ros --features can_bridge/ros \
  --test ros_msgs -- --exact vendored_types_match_ros > "$ROOT/target/e2e_ros_msgs.log" 2>&1 \
  || { tail -20 "$ROOT/target/e2e_ros_msgs.log"; echo "e2e_group: can_bridge's vendored ROS types do not match ROS's md5"; exit 1; }
grep -qx 'test vendored_types_match_ros ... ok' "$ROOT/target/e2e_ros_msgs.log" \
  || { tail -20 "$ROOT/target/e2e_ros_msgs.log"; echo "e2e_group: can_bridge's ros_msgs test did not run"; exit 1; }
echo "e2e_group: prepared in $(( $(date +%s) - t0 )) s; booting the guest"
t1=$(date +%s)
OLDBF_VM_TIMEOUT=${OLDBF_VM_TIMEOUT:-600} tests/vm/run-in-vm.sh "$ROOT/tests/vm/e2e_guest.sh"
echo "e2e_group: guest run took $(( $(date +%s) - t1 )) s"
