//! ROS message types, generated at build time from the definitions vendored
//! in `oldbf_ros/rosmsg/` (so no ROS installation is needed to build). The
//! ROS test group checks every md5sum against `rosmsg md5` / `rossrv md5`.

rosrust::rosmsg_include!(
    std_msgs / Header,
    std_msgs / Bool,
    std_msgs / String,
    std_msgs / ColorRGBA,
    geometry_msgs / Twist,
    geometry_msgs / Vector3,
    geometry_msgs / Point,
    geometry_msgs / Quaternion,
    geometry_msgs / Pose,
    geometry_msgs / Transform,
    geometry_msgs / TransformStamped,
    sensor_msgs / LaserScan,
    nav_msgs / Odometry,
    visualization_msgs / Marker,
    visualization_msgs / MarkerArray,
    diagnostic_msgs / DiagnosticArray,
    diagnostic_msgs / DiagnosticStatus,
    diagnostic_msgs / KeyValue,
    rosgraph_msgs / Clock,
    tf2_msgs / TFMessage,
    std_srvs / SetBool,
    std_srvs / Trigger,
    oldbf_ros / BarrierState,
    dynamic_reconfigure / Config,
    dynamic_reconfigure / ConfigDescription,
    dynamic_reconfigure / Reconfigure
);
