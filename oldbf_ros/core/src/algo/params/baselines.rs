//! The baselines the paper compares against: DCBF-QP and VO.

use serde::{Deserialize, Serialize};

/// The `baselines` section: the controllers the paper compares against.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct BaselineParams {
    /// `baselines.dcbf`: the DCBF-QP filter.
    pub dcbf: DcbfParams,
    /// `baselines.vo`: ORCA velocity obstacles.
    pub vo: VoParams,
}

/// The standard discrete-time CBF-QP safety filter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DcbfParams {
    /// Distance of the controlled point ahead of the axle centre (m): through
    /// it, ω enters the (otherwise v-only) unicycle constraints.
    pub lookahead_m: f64,
    /// One constraint per angular sector of this width: the sector's nearest point (deg).
    pub sector_deg: f64,
    /// Cost weight of (ω − ω_nom)² relative to (v − v_nom)² ((m/s)²/(rad/s)²).
    pub omega_weight: f64,
    /// Linear penalty on the one slack that keeps the QP feasible (per m);
    /// the slack is zero whenever the hard-constrained QP is feasible.
    pub slack_penalty: f64,
}

impl Default for DcbfParams {
    fn default() -> Self {
        Self {
            lookahead_m: 0.1,
            sector_deg: 10.0,
            omega_weight: 1.0,
            slack_penalty: 1000.0,
        }
    }
}

/// The ORCA velocity-obstacle avoider (dodgy_2d) mapped to the unicycle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VoParams {
    /// Collisions with moving obstacles are avoided this far ahead (s).
    pub time_horizon_s: f64,
    /// Collisions with static geometry are avoided this far ahead (s).
    pub static_time_horizon_s: f64,
    /// Yaw rate per radian between heading and the chosen velocity (1/s).
    pub heading_gain_per_s: f64,
    /// Static scan outlines are simplified to vertices at least this far apart (m).
    pub vertex_spacing_m: f64,
}

impl Default for VoParams {
    fn default() -> Self {
        Self {
            time_horizon_s: 2.0,
            static_time_horizon_s: 1.0,
            heading_gain_per_s: 2.0,
            vertex_spacing_m: 0.05,
        }
    }
}
