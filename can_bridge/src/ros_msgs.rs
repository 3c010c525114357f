//! ROS message and service types can_bridge_node needs beyond oldbf_ros's,
//! generated at build time from the definitions vendored in
//! `oldbf_ros/rosmsg/` (ROSRUST_MSG_PATH, .cargo/config.toml). Their md5sums
//! are checked against ROS's own tools in `tests/ros_msgs.rs` (e2e group).

rosrust::rosmsg_include!(sensor_msgs / JointState, oldbf_ros / SdoRead, oldbf_ros / SdoWrite);
