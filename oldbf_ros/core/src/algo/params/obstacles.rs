//! Moving obstacles: tracking, and passive motion safety with evasion.

use serde::{Deserialize, Serialize};

/// Moving obstacles: clustering, tracking and the collision cone (ALGORITHM.md §6).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObstacleParams {
    /// Track clusters and use their motion in the DTCBF prediction and the barriers.
    pub enabled: bool,
    /// Neighbouring points closer than this belong to one cluster (m).
    pub cluster_gap_m: f64,
    /// Clusters with fewer points are not tracked.
    pub min_cluster_points: usize,
    /// Clusters wider than this (walls, furniture) are not tracked (m).
    pub max_cluster_diameter_m: f64,
    /// A cluster is associated with a track within this distance of its prediction (m).
    pub gate_m: f64,
    /// Associations in a row that confirm a track.
    pub confirm_hits: u32,
    /// A confirmed track coasts this many missed scans before it is deleted.
    pub max_misses: u32,
    /// Process noise: white acceleration standard deviation (m/s²).
    pub accel_noise_mps2: f64,
    /// Centroid measurement noise standard deviation (m).
    pub measurement_noise_m: f64,
    /// A confirmed track faster than this is moving (m/s)…
    pub moving_speed_mps: f64,
    /// …once seen where an earlier scan saw free (with `motion_by_sight`), or once
    /// this far from where it was first seen (m; kept when it turns round): more
    /// than `max_cluster_diameter_m`, farther than a view change slides a static
    /// object's centre estimate.
    pub min_travel_m: f64,
    /// Prove a track's motion by sight: its object stands where earlier scans saw
    /// free (ALGORITHM.md §6), with a wall seen at a grazing angle partial and the
    /// travel restarted after a far jump across scans without a whole view.
    /// false = by travel alone, as the paper method had it (with
    /// [`PAPER_MIN_TRAVEL_M`]).
    pub motion_by_sight: bool,
    /// Horizon over which an obstacle on a collision course raises its side's barrier (s).
    /// 6 s: a robot turning at 0.3 rad/s needs 8-9 s to step 0.6 m off a person's line
    /// (ALGORITHM.md §6); the paper method keeps [`PAPER_LOOKAHEAD_S`].
    pub lookahead_s: f64,
    /// At most this many tracks (bounds memory and time).
    pub max_tracks: usize,
}

/// The look-ahead the filter had before passive motion safety (s): the paper
/// method's ([`super::Params::paper_method`]).
pub const PAPER_LOOKAHEAD_S: f64 = 2.0;

/// The travel that proved a track's motion before motion was proven by sight
/// (m): the paper method's ([`super::Params::paper_method`]).
pub const PAPER_MIN_TRAVEL_M: f64 = 0.3;

impl Default for ObstacleParams {
    fn default() -> Self {
        Self {
            enabled: true,
            cluster_gap_m: 0.15,
            min_cluster_points: 3,
            max_cluster_diameter_m: 0.7,
            gate_m: 0.5,
            confirm_hits: 3,
            max_misses: 5,
            accel_noise_mps2: 1.0,
            measurement_noise_m: 0.05,
            moving_speed_mps: 0.02,
            min_travel_m: 0.75,
            motion_by_sight: true,
            lookahead_s: 6.0,
            max_tracks: 32,
        }
    }
}

/// Passive motion safety and evasion (ALGORITHM.md §5b).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PassiveParams {
    /// The braking check and evasion; false = the paper's one-step condition only.
    pub enabled: bool,
    /// A moving obstacle's predicted disc is inflated by this at once (m)…
    pub mover_margin_m: f64,
    /// …and grows by this per second of prediction (m/s): unmodelled turns
    /// and accelerations of people.
    pub mover_growth_mps: f64,
    /// With a polygon footprint, the braking check keeps the body this far
    /// from a seen point it moves towards (m): a point is one noisy sample of
    /// a surface, which may lie nearer than read, and between two beams (a
    /// corner) nearer than both; near the polygon's corners the feature a
    /// point is nearest to (an edge, the corner) changes from one point to
    /// the next. The circle keeps none: its direction to a point is the
    /// centre's, which does not jump between neighbouring points.
    pub seen_margin_m: f64,
    /// Robot speed towards an obstacle above which a contact is "closing" (m/s).
    pub closing_speed_mps: f64,
    /// Evasion scores a command by the predicted time to contact with the
    /// command held this long (s); with `obstacles.lookahead_s`, also how soon a
    /// predicted contact triggers it. About the time a turn of π/2 takes at
    /// ω_max = 0.3 rad/s (5.2 s): a robot that sees a person later cannot turn
    /// out of the way in time.
    pub evasion_horizon_s: f64,
    /// While a tracked mover threatens the upstream command, evasion may
    /// command speeds up to this either way (m/s), faster than the upstream
    /// or reversing where it does not (reversing only where the input box
    /// allows: the rear seen); 0 = evasion only slows, steers and stops.
    pub evasion_max_speed_mps: f64,
    /// While a tracked mover threatens, the dynamic window opens to the
    /// base's own linear acceleration (m/s²), not the gentler
    /// `control.accel_mps2` of ordinary driving: getting out of a person's
    /// way is worth a jolt. At least `control.accel_mps2`.
    pub evasion_accel_mps2: f64,
    /// …and to the base's own yaw acceleration (rad/s²). At least
    /// `control.angular_accel_radps2`.
    pub evasion_angular_accel_radps2: f64,
}

impl Default for PassiveParams {
    fn default() -> Self {
        Self {
            enabled: true,
            mover_margin_m: 0.05,
            mover_growth_mps: 0.1,
            seen_margin_m: 0.01,
            closing_speed_mps: 0.02,
            evasion_horizon_s: 5.0,
            evasion_max_speed_mps: 0.22,
            evasion_accel_mps2: 2.5,
            evasion_angular_accel_radps2: 3.2,
        }
    }
}
