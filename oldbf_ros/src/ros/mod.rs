//! The ROS 1 adapters (feature `ros`): thin glue between rosrust topics,
//! services and parameters and the pure core. Nothing here decides anything
//! about safety; it converts, times and publishes.

pub mod msg;
