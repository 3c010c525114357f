//! oldbf_sim_node: the built-in 2-D simulator as a ROS 1 node standing in for
//! the robot(s). See `oldbf_ros::ros::sim_node` for topics and parameters.

fn main() {
    std::process::exit(oldbf_ros::ros::sim_node::run());
}
