#!/usr/bin/env bash
# Re-vendors the ROS message definitions the nodes use from Debian's ROS 1
# packages (ros-std-msgs, ros-geometry-msgs, ros-sensor-msgs, ros-nav-msgs,
# ros-visualization-msgs, ros-diagnostic-msgs, ros-rosgraph-msgs,
# ros-tf2-msgs, ros-std-srvs), so `cargo build --features ros` needs no ROS
# installation. The md5 test (tests/ros_group.sh) checks every type against
# `rosmsg md5` / `rossrv md5`, so a drifted or mistyped file fails the tests.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")"
copy() { # pkg kind name...
  local pkg=$1 kind=$2; shift 2
  mkdir -p "$pkg/$kind"
  for n in "$@"; do cp "/usr/share/$pkg/$kind/$n.$kind" "$pkg/$kind/"; done
}
copy std_msgs msg Header Bool String ColorRGBA
copy geometry_msgs msg Twist Vector3 Point Quaternion Pose PoseWithCovariance TwistWithCovariance Transform TransformStamped
copy sensor_msgs msg LaserScan
copy nav_msgs msg Odometry
copy visualization_msgs msg Marker MarkerArray
copy diagnostic_msgs msg DiagnosticArray DiagnosticStatus KeyValue
copy rosgraph_msgs msg Clock
copy tf2_msgs msg TFMessage
copy std_srvs srv SetBool Trigger

# dynamic_reconfigure: Debian installs no .msg/.srv files for it, only the
# Python classes (python3-dynamic-reconfigure), whose _full_text holds every
# definition verbatim. Split them out of there.
/usr/bin/python3 - <<'PY'
import os
from dynamic_reconfigure.msg import ConfigDescription
from dynamic_reconfigure.srv import ReconfigureRequest, ReconfigureResponse

SEP = "=" * 80 + "\nMSG: "
def sections(cls):
    head, *deps = cls._full_text.split(SEP)
    out = {}
    for d in deps:
        name, body = d.split("\n", 1)
        out[name.split("/")[1]] = body
    return head, out

os.makedirs("dynamic_reconfigure/msg", exist_ok=True)
os.makedirs("dynamic_reconfigure/srv", exist_ok=True)
head, deps = sections(ConfigDescription)
deps["ConfigDescription"] = head
for name, body in deps.items():
    with open("dynamic_reconfigure/msg/%s.msg" % name, "w") as f:
        f.write(body.rstrip("\n") + "\n")
req, _ = sections(ReconfigureRequest)
res, _ = sections(ReconfigureResponse)
with open("dynamic_reconfigure/srv/Reconfigure.srv", "w") as f:
    f.write(req.rstrip("\n") + "\n---\n" + res.rstrip("\n") + "\n")
PY
