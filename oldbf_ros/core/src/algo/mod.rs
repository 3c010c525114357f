//! The pure core: plain types and functions, no ROS and no CAN.
//!
//! One file per step of the line scan → points → clearances → barriers →
//! DOAA → DTCBF → twist, plus the kinematics and the reference tracking the
//! nominal command comes from. See `docs/ALGORITHM.md` for the definition
//! and where it departs from the paper.

pub mod barrier;
pub mod beam_average;
pub mod beam_memory;
pub mod blind;
pub mod body;
pub mod braking_polygon;
pub mod clearance;
pub mod clusters;
pub mod collision_cone;
pub mod doaa;
pub mod dtcbf;
pub mod footprint;
pub mod geometry;
pub mod local_map;
pub mod obstacle_tracker;
pub mod params;
pub mod passive;
pub mod pipeline;
pub mod record;
pub mod reference;
pub mod route;
pub mod scan;
pub mod scan_merge;
pub mod seen_free;
pub mod select;
pub mod tracking;
pub mod unicycle;
pub mod unstuck;
pub mod way_round;

pub use doaa::DoaaState;
pub use geometry::{Pose2, Twist, Vec2};
pub use params::Params;
pub use pipeline::SafetyPipeline;
pub use record::{StepRecord, StopCause};
pub use scan::{LaserMount, LaserScan, MountError, ScanHeader, ScanRejection};
