//! Every vendored message type's md5sum equals what the real ROS tools
//! compute: `rosmsg md5` / `rossrv md5` where they have a Python class for
//! the type, and ROS's genmsg library on the definitions Debian installed in
//! /usr/share for every type. A typo in a vendored definition fails here. Needs ROS 1 installed and the oldbf_ros package on
//! ROS_PACKAGE_PATH (tests/ros_group.sh arranges both); not part of the plain
//! `cargo test` run, which must work without ROS.

use ::oldbf_ros::ros::msg::{
    diagnostic_msgs, dynamic_reconfigure, geometry_msgs, nav_msgs, rosgraph_msgs, sensor_msgs, std_msgs, std_srvs,
    tf2_msgs, visualization_msgs,
};
use rosrust::Message;
use std::process::Command;

/// `rosmsg md5` / `rossrv md5`: empty when it has no Python class for the
/// type (it still exits 0), e.g. nav_msgs without python3-nav-msgs.
fn rosmsg_md5(tool: &str, name: &str) -> String {
    let out = Command::new(tool)
        .args(["md5", name])
        .output()
        .unwrap_or_else(|e| panic!("cannot run `{tool} md5 {name}`: {e} (is ROS 1 installed? see tests/ros_group.sh)"));
    String::from_utf8_lossy(&out.stdout).trim().to_string()
}

/// The md5 ROS's genmsg library computes from the installed definitions.
fn genmsg_md5(kind: &str, name: &str) -> String {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let script = root.join("../tests/ros/genmsg_md5.py");
    let ours = format!("oldbf_ros:{}", root.join("rosmsg/oldbf_ros/msg").display());
    let out = Command::new("/usr/bin/python3")
        .arg(&script)
        .args([kind, name, &ours])
        .output()
        .unwrap_or_else(|e| panic!("cannot run {}: {e}", script.display()));
    assert!(
        out.status.success(),
        "genmsg_md5 {name}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).trim().to_string()
}

/// Checks one type against both tools; returns a mismatch description.
fn check(kind: &str, name: &str, ours: &str) -> Option<String> {
    let tool = if kind == "msg" { "rosmsg" } else { "rossrv" };
    let a = rosmsg_md5(tool, name);
    let b = genmsg_md5(kind, name);
    println!(
        "{name:36} ours {ours} {tool} {:32} genmsg {b}",
        if a.is_empty() { "(no Python class)" } else { &a }
    );
    let agree = (a.is_empty() || a == ours) && b == ours;
    (!agree).then(|| format!("{name}: ours {ours}, {tool} {a:?}, genmsg {b:?}"))
}

#[test]
fn vendored_messages_match_ros() {
    let ours: Vec<(&str, String)> = vec![
        ("std_msgs/Header", std_msgs::Header::md5sum()),
        ("std_msgs/Bool", std_msgs::Bool::md5sum()),
        ("std_msgs/String", std_msgs::String::md5sum()),
        ("std_msgs/ColorRGBA", std_msgs::ColorRGBA::md5sum()),
        ("geometry_msgs/Twist", geometry_msgs::Twist::md5sum()),
        ("geometry_msgs/Vector3", geometry_msgs::Vector3::md5sum()),
        ("geometry_msgs/Point", geometry_msgs::Point::md5sum()),
        ("geometry_msgs/Quaternion", geometry_msgs::Quaternion::md5sum()),
        ("geometry_msgs/Pose", geometry_msgs::Pose::md5sum()),
        ("geometry_msgs/Transform", geometry_msgs::Transform::md5sum()),
        (
            "geometry_msgs/TransformStamped",
            geometry_msgs::TransformStamped::md5sum(),
        ),
        ("sensor_msgs/LaserScan", sensor_msgs::LaserScan::md5sum()),
        ("nav_msgs/Odometry", nav_msgs::Odometry::md5sum()),
        ("visualization_msgs/Marker", visualization_msgs::Marker::md5sum()),
        (
            "visualization_msgs/MarkerArray",
            visualization_msgs::MarkerArray::md5sum(),
        ),
        (
            "diagnostic_msgs/DiagnosticArray",
            diagnostic_msgs::DiagnosticArray::md5sum(),
        ),
        (
            "diagnostic_msgs/DiagnosticStatus",
            diagnostic_msgs::DiagnosticStatus::md5sum(),
        ),
        ("diagnostic_msgs/KeyValue", diagnostic_msgs::KeyValue::md5sum()),
        ("rosgraph_msgs/Clock", rosgraph_msgs::Clock::md5sum()),
        ("tf2_msgs/TFMessage", tf2_msgs::TFMessage::md5sum()),
        (
            "oldbf_ros/BarrierState",
            ::oldbf_ros::ros::msg::oldbf_ros::BarrierState::md5sum(),
        ),
    ];
    let mut mismatches: Vec<String> = ours.iter().filter_map(|(name, md5)| check("msg", name, md5)).collect();
    for (name, md5) in [
        ("std_srvs/SetBool", std_srvs::SetBool::md5sum()),
        ("std_srvs/Trigger", std_srvs::Trigger::md5sum()),
    ] {
        mismatches.extend(check("srv", name, &md5));
    }
    // dynamic_reconfigure: Debian installs no definitions for genmsg, only the
    // Python classes (python3-dynamic-reconfigure) that the client and
    // rqt_reconfigure use, so `rosmsg md5` / `rossrv md5` must know them and agree.
    for (kind, name, ours) in [
        (
            "msg",
            "dynamic_reconfigure/Config",
            dynamic_reconfigure::Config::md5sum(),
        ),
        (
            "msg",
            "dynamic_reconfigure/ConfigDescription",
            dynamic_reconfigure::ConfigDescription::md5sum(),
        ),
        (
            "srv",
            "dynamic_reconfigure/Reconfigure",
            dynamic_reconfigure::Reconfigure::md5sum(),
        ),
    ] {
        let tool = if kind == "msg" { "rosmsg" } else { "rossrv" };
        let theirs = rosmsg_md5(tool, name);
        println!("{name:36} ours {ours} {tool} {theirs}");
        if theirs != ours {
            mismatches.push(format!(
                "{name}: ours {ours}, {tool} {theirs:?} (python3-dynamic-reconfigure installed?)"
            ));
        }
    }
    // The values TESTBED.md records, as a cross-check of the tools themselves.
    assert_eq!(sensor_msgs::LaserScan::md5sum(), "90c7ef2dc6895d81024acba2ac42f369");
    assert_eq!(geometry_msgs::Twist::md5sum(), "9f195f881246fdfa2798d1d3eebca84a");
    assert!(mismatches.is_empty(), "md5 mismatches: {mismatches:?}");
}
