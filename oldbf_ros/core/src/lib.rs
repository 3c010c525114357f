//! oldbf: the ROS-free core of the oldbf safety layer.
//!
//! * [`algo`]: the safety filter itself: scan sanitation (REP 117), clearances
//!   and barriers, DOAA steering, the exact discrete-time CBF and braking
//!   checks, obstacle tracking, evasion, reference trajectories and tracking.
//!   The simulator, the ROS node, the CLI replay and the batch all run this one
//!   control path (`oldbf_ros` re-exports it as `oldbf_ros::algo`).
//! * [`config`]: the strict configuration checks that `oldbf_ros` and
//!   `can_bridge` share (typed intervals, a checker that collects every
//!   violation, errors that carry the dotted key as data, and YAML loading that
//!   names the key of a wrong type).
//!
//! Everything here is pure: no ROS, no CAN, no I/O beyond reading a named
//! file, no clocks, no threads. Being its own crate, with only serde, YAML,
//! nalgebra and log underneath, the compiler enforces that.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod algo;
pub mod config;
