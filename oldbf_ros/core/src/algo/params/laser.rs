//! The laser: range semantics (REP 117), the hold, the blind-sensor stop, the mount.

use serde::{Deserialize, Serialize};

/// The laser's static mount pose in the robot frame and scan acceptance.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LaserParams {
    /// Laser origin x in the robot frame (m, forward).
    pub mount_x_m: f64,
    /// Laser origin y in the robot frame (m, left).
    pub mount_y_m: f64,
    /// Laser yaw in the robot frame (deg, CCW).
    pub mount_yaw_deg: f64,
    /// A scan older than this, or stamped this far in the future, is rejected (s).
    pub scan_timeout_s: f64,
    /// Scans with more beams than this are rejected (bounds memory and time).
    pub max_beams: usize,
    /// How invalid readings are read (ALGORITHM.md §1): REP 117 (unknown is
    /// not free), or the paper method's "every invalid reading is free".
    pub range_semantics: RangeSemantics,
    /// The driver writes 0.0 for "no return" (TurtleBot3's LDS): 0.0 then
    /// means free. Off by default: 0.0 is below range_min, i.e. unknown.
    pub zero_is_no_return: bool,
    /// An unknown beam keeps its last valid reading this long (s); 0 = no hold.
    pub unknown_hold_s: f64,
    /// Full angle of the front sector watched for a blinded sensor (deg).
    pub blind_sector_deg: f64,
    /// The sensor is blind when more than this fraction of that sector's beams
    /// read unknown…
    pub blind_fraction: f64,
    /// …for longer than this (s): stop and report `sensor_blind`.
    pub blind_timeout_s: f64,
    /// The laser's range noise, one standard deviation (m): each beam's
    /// static return is averaged over the last few scans within 3 of these
    /// of each other, and never reported more than 2 of these beyond the
    /// raw return (ALGORITHM §1, `algo/beam_average.rs`). 0 turns the
    /// averaging off (the paper method).
    pub range_noise_m: f64,
}

/// How a scan's invalid readings are interpreted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RangeSemantics {
    /// ROS REP 117: +inf / ≥ range_max free, −inf an obstacle at range_min,
    /// NaN and below range_min unknown (held, and blindness detected).
    Rep117,
    /// The paper method (and this project before REP 117 semantics): every
    /// invalid reading is free space.
    AllInvalidFree,
}

impl Default for LaserParams {
    fn default() -> Self {
        Self {
            mount_x_m: 0.0,
            mount_y_m: 0.0,
            mount_yaw_deg: 0.0,
            scan_timeout_s: 0.5,
            max_beams: 16384,
            range_semantics: RangeSemantics::Rep117,
            zero_is_no_return: false,
            unknown_hold_s: 2.0,
            blind_sector_deg: 180.0,
            blind_fraction: 0.5,
            blind_timeout_s: 0.3,
            range_noise_m: 0.01,
        }
    }
}
