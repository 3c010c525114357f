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
//! * [`node_core`] — the safety node's logic (nominal source, reference
//!   following, scan-order, clock and e-stop rules): `oldbf_node` and every
//!   simulated robot run it.
//!
//! Features: `eval` (default) adds the evaluation tree — the simulator's
//! closed loop (`sim::run`), the baselines, batch, soak, compare, plots and
//! the `oldbf` CLI; `ros` adds the rosrust nodes. The ROS nodes alone build
//! with `--no-default-features --features ros`, without plotters, rayon,
//! clarabel, dodgy_2d or clap.

/// The pure core, from the `oldbf` crate (no ROS, no CAN: the compiler enforces it).
pub use oldbf::algo;
#[cfg(feature = "eval")]
pub mod baselines;
#[cfg(feature = "eval")]
pub mod batch;
pub mod carmen;
#[cfg(feature = "eval")]
pub mod compare;
pub mod config;
pub mod cpu_clock;
pub mod heap;
pub mod node_config;
pub mod node_core;
#[cfg(feature = "eval")]
pub mod plot;
pub mod reconfigure;
pub mod replay;
#[cfg(feature = "eval")]
pub mod report;
pub mod resubscribe;
#[cfg(feature = "ros")]
pub mod ros;
pub mod route_worker;
pub mod sim;
pub mod tf_tree;
