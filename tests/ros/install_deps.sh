#!/usr/bin/env bash
# Installs, if missing, the Debian packages the ROS tests use: ROS 1 core
# tools, the message definitions and Python classes rostopic needs, genpy
# (for oldbf_ros/BarrierState), catkin (the workspace build test), the
# dynamic_reconfigure Python client, rviz with Xvfb for the screenshot test,
# robot_state_publisher and tf2_ros for Python (sensor poses from tf), and
# diagnostic_aggregator (the -tools package has aggregator_node; the -dev
# package has its package.xml and analyzer plugin description, without which
# roslaunch and pluginlib cannot find it).
# python3-nav-msgs is left out on purpose (it pulls ~140 MB of boost -dev
# packages); genmsg computes its md5 instead. Idempotent.
set -Eeuo pipefail
APT=(ros-core ros-std-msgs ros-geometry-msgs ros-sensor-msgs ros-nav-msgs ros-visualization-msgs
     ros-diagnostic-msgs ros-rosgraph-msgs ros-tf2-msgs ros-std-srvs rospack-tools
     python3-std-msgs python3-geometry-msgs python3-sensor-msgs python3-diagnostic-msgs
     python3-visualization-msgs python3-tf2-msgs python3-std-srvs python3-rosgraph-msgs python3-genpy
     catkin python3-dynamic-reconfigure
     rviz xvfb x11-apps netpbm
     libdiagnostic-aggregator-tools libdiagnostic-aggregator-dev
     ros-robot-state-publisher python3-tf2-ros)
missing=()
for p in "${APT[@]}"; do
  [ "$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null || true)" = "install ok installed" ] || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: ROS packages already installed"
  exit 0
fi
echo "install_deps: installing ${missing[*]}"
policy=$(apt-cache policy ros-core 2>/dev/null || true)
grep -q 'Candidate: [^(]' <<< "$policy" || apt-get -q -o DPkg::Lock::Timeout=300 update
DEBIAN_FRONTEND=noninteractive apt-get -q -o DPkg::Lock::Timeout=300 install -y --no-install-recommends "${missing[@]}"
