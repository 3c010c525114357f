//! can_bridge_node: the CAN motor bridge as a ROS 1 node. See
//! `can_bridge::ros_node` for its topics, services and parameters.

fn main() {
    std::process::exit(can_bridge::ros_node::run());
}
