//! A 2-D simulator that stands in for the robot, its LiDAR and its
//! surroundings, so the safety filter can be exercised closed-loop without
//! hardware or ROS.
//!
//! One concept per file:
//! * [`shapes`] — segment and circle primitives: exact point distance and
//!   ray intersection;
//! * [`motion`] — moving discs with closed-form motion laws (constant
//!   velocity, waypoint loop, bounce), deterministic at any time;
//! * [`world`] — static walls / polygons / boxes / circles plus moving discs
//!   and a clock; nearest-obstacle distance and ray casting;
//! * [`lidar`] — a ray-cast 2-D LiDAR with `LaserScan` conventions, noise
//!   and dropouts;
//! * [`figures`] — what a closed-loop run measured, per robot and in total;
//! * [`motion_quality`] — how smoothly the robot was commanded (variation,
//!   reversals, the dynamic window, what the filter added);
//! * [`robot`] — a unicycle with speed and acceleration limits, presets for
//!   the TurtleBot3 Burger, the Quanser QBot 2e and a 0.6 x 0.4 m
//!   rectangular base, collision check;
//! * [`body`] — a polygon body's exact signed distance to the world.
//!
//! Units: m, s, rad, m/s, rad/s throughout; degrees only in YAML keys ending
//! in `_deg`. Every spec type rejects unknown YAML keys and every constructor
//! returns an error (naming the key) instead of panicking on bad values.

pub mod body;
#[cfg(feature = "eval")]
pub mod figures;
pub mod fleet;
pub mod lidar;
pub mod motion;
#[cfg(feature = "eval")]
pub mod motion_quality;
pub mod robot;
#[cfg(feature = "eval")]
pub mod run;
pub mod scenario;
pub mod shapes;
pub mod world;

pub use body::BodyPolygon;
pub use lidar::{DropoutKind, Lidar, LidarError, LidarSpec};
pub use motion::{MotionSpec, MovingObstacle, MovingObstacleError, MovingObstacleSpec};
pub use robot::{RobotLimits, RobotPreset, RobotSpec, SimRobot};
pub use shapes::{Circle, Segment};
pub use world::{BoxSpec, CircleSpec, ScanScratch, WallSpec, World, WorldError, WorldSpec};
