//! oldbf_node: the OLDBF + DOAA safety filter as a ROS 1 node. See
//! `oldbf_ros::ros::safety_node` for its topics, services and parameters.

fn main() {
    std::process::exit(oldbf_ros::ros::safety_node::run());
}
