//! The ROS 1 adapters (feature `ros`): thin glue between rosrust topics,
//! services and parameters and the pure core. Nothing here decides anything
//! about safety; it converts, times and publishes.

pub mod carmen_play;
pub mod convert;
pub mod diagnostics;
pub mod lifecycle;
pub mod logging;
pub mod markers;
pub mod msg;
pub mod pacer;
pub mod params;
pub mod reconfigure;
pub mod safety_node;
pub mod sim_node;
