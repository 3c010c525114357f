//! The md5sums of the types can_bridge_node vendors beyond oldbf_ros's
//! (sensor_msgs/JointState, oldbf_ros/SdoRead, oldbf_ros/SdoWrite) equal
//! what ROS's own tools compute: genmsg from the definitions (Debian's for
//! JointState, the vendored .srv files for ours) and `rosmsg md5` where a
//! Python class exists. A mistyped definition fails here, and a client
//! (rospy, rosservice) would refuse the connection. Needs ROS 1 (Debian's
//! python3-genmsg, ros-sensor-msgs): run by tests/e2e_group.sh; not part of
//! the plain `cargo test`, which must work without ROS.

use can_bridge::ros_msgs::{oldbf_ros, sensor_msgs};
use rosrust::Message;
use std::process::Command;

/// genmsg's md5 of `name` (`msg`: from /usr/share, `srv`: from our file).
fn genmsg_md5(kind: &str, name: &str) -> String {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../oldbf_ros/rosmsg");
    let script = r#"
import glob, os, sys
import genmsg, genmsg.msg_loader
kind, name, root = sys.argv[1:4]
search = {}
for d in glob.glob("/usr/share/*/msg"):
    search.setdefault(os.path.basename(os.path.dirname(d)), []).append(d)
ctx = genmsg.MsgContext.create_default()
if kind == "msg":
    spec = genmsg.msg_loader.load_msg_by_type(ctx, name, search)
else:
    pkg, base = name.split("/")
    spec = genmsg.msg_loader.load_srv_from_file(ctx, os.path.join(root, pkg, "srv", base + ".srv"), name)
genmsg.msg_loader.load_depends(ctx, spec, search)
print(genmsg.compute_md5(ctx, spec))
"#;
    let out = Command::new("/usr/bin/python3")
        .args(["-c", script, kind, name, &root.display().to_string()])
        .output()
        .unwrap_or_else(|e| panic!("cannot run /usr/bin/python3 (ROS 1 installed? tests/ros/install_deps.sh): {e}"));
    assert!(
        out.status.success(),
        "genmsg {name}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).trim().to_string()
}

#[test]
fn vendored_types_match_ros() {
    let joint = sensor_msgs::JointState::md5sum();
    assert_eq!(genmsg_md5("msg", "sensor_msgs/JointState"), joint);
    let rosmsg = Command::new("rosmsg")
        .args(["md5", "sensor_msgs/JointState"])
        .output()
        .expect("rosmsg (ROS 1 installed?)");
    assert_eq!(String::from_utf8_lossy(&rosmsg.stdout).trim(), joint, "rosmsg md5");
    // The value ROS has always had for JointState.
    assert_eq!(joint, "3066dcd76a6cfaef579bd0f34173e9fd");
    for (name, ours) in [
        ("oldbf_ros/SdoRead", oldbf_ros::SdoRead::md5sum()),
        ("oldbf_ros/SdoWrite", oldbf_ros::SdoWrite::md5sum()),
    ] {
        let theirs = genmsg_md5("srv", name);
        println!("{name:24} ours {ours} genmsg {theirs}");
        assert_eq!(ours, theirs, "{name}");
    }
}
