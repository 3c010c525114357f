//! OLDBF + DOAA: an online LiDAR-based discrete-time barrier function safety
//! filter for differential-drive robots.
//!
//! * [`algo`] — the pure core (no ROS, no CAN): scan sanitation, clearances,
//!   barriers, DOAA steering, the exact discrete-time CBF filter, reference
//!   trajectories and Kanayama tracking.
//! * [`baselines`] — the DCBF-QP filter and ORCA velocity obstacles the
//!   paper compares against, on the same perception.
//! * [`sim`] — a 2-D simulator that stands in for the robot: walls, circles,
//!   moving obstacles, a ray-cast LiDAR, a unicycle with limits.
//! * [`config`] — YAML configuration with unknown keys and out-of-range
//!   values rejected by name.

/// The pure core, from the `oldbf` crate (no ROS, no CAN: the compiler enforces it).
pub use oldbf::algo;
pub mod baselines;
pub mod batch;
pub mod carmen;
pub mod compare;
pub mod config;
pub mod node_config;
pub mod node_core;
pub mod plot;
pub mod reconfigure;
pub mod replay;
pub mod report;
#[cfg(feature = "ros")]
pub mod ros;
pub mod sim;
