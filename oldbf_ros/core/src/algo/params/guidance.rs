//! Where the nominal heads: reference tracking and going round obstacles (unstuck).

use serde::{Deserialize, Serialize};

/// Kanayama tracking gains (paper IV.C; eq. 8 completed).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrackingParams {
    /// k_x: along-track error gain (1/s).
    pub k_x_per_s: f64,
    /// k_y: cross-track error gain (1/m²).
    pub k_y_per_m2: f64,
    /// k_θ: heading error gain (1/m).
    pub k_theta_per_m: f64,
    /// Within this distance of the reference point Kanayama's law applies alone;
    /// beyond twice it, the go-to-point law does (m).
    pub capture_radius_m: f64,
    /// k_β: yaw rate per radian of bearing to the reference point in go-to-point mode (1/s).
    pub k_bearing_per_s: f64,
    /// Once the reference has ended, the command is zero within this distance of the goal (m).
    pub arrive_radius_m: f64,
}

impl Default for TrackingParams {
    fn default() -> Self {
        Self {
            k_x_per_s: 1.0,
            k_y_per_m2: 10.0,
            k_theta_per_m: 4.0,
            capture_radius_m: 0.5,
            k_bearing_per_s: 1.0,
            arrive_radius_m: 0.05,
        }
    }
}

/// The comparison controllers (ALGORITHM.md §8; `--controller dcbf|vo`).
/// Not used by the OLDBF filter or the ROS node.
/// Getting round an obstacle when steering alone has stalled (ALGORITHM.md §4b).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UnstuckParams {
    /// Follow free directions when progress stalls; false = reactive steering only.
    pub enabled: bool,
    /// Progress stalled: less than `progress_m` gained for this long (s).
    pub stall_s: f64,
    /// Progress that counts (m of the reference's arc length minus distance to it).
    pub progress_m: f64,
    /// Width of the square local map round the robot the way round is planned on (m).
    pub window_m: f64,
    /// The local map remembers what it saw this long (s): obstacles out of
    /// view are kept, then forgotten (§4c).
    pub memory_s: f64,
    /// The way round is planned again this often (s); the aim glides to
    /// each new waypoint over this time (§4c).
    pub plan_period_s: f64,
    /// The route keeps r + d_safe + this from everything seen (m), where it
    /// can (gaps of 2 (r + d_safe) are taken when nothing wider reaches the
    /// goal, or reaches it only through unseen space and is 1 m and 20 %
    /// longer): more than the filter's noise margin δ, the range noise and half
    /// a cell, or the route leads where the filter will not let the robot go.
    pub margin_m: f64,
    /// The way round heads for the point this far further along the
    /// reference's path than the (governed) reference point (m).
    pub ahead_m: f64,
    /// Stuck while following (§4c) at a gap the latest scan shows narrower
    /// than 2 (r + d_safe): the spot the robot steered at is closed to the
    /// route for this long (s), so it goes another way rather than rest at a
    /// gap the checks will not let it through; 0 = never closed, the route is
    /// only planned again. A gap the body fits through is never closed.
    pub stuck_avoid_s: f64,
}

impl Default for UnstuckParams {
    fn default() -> Self {
        Self {
            enabled: true,
            stall_s: 6.0,
            progress_m: 0.15,
            window_m: 12.0,
            memory_s: 30.0,
            plan_period_s: 0.5,
            margin_m: 0.08,
            ahead_m: 1.5,
            stuck_avoid_s: 30.0,
        }
    }
}
