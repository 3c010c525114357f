//! The decision: how one command is chosen inside the base's dynamic window
//! (ALGORITHM.md §5c).

use serde::{Deserialize, Serialize};

/// The selector: candidates sampled from the dynamic window, the hard
/// constraints as one ordered list of relaxations, soft preferences as
/// weighted critics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SelectParams {
    /// The selector decides the command; false = the paper's decision (the
    /// DOAA command, then the DTCBF filter's own search), as `oldbf-paper`
    /// runs it; that decision has no braking check, so `passive.enabled`
    /// must then be false.
    pub enabled: bool,
    /// Yaw rates sampled evenly across the window (besides the nominal's,
    /// the DOAA's and the last command's).
    pub omega_samples: usize,
    /// Speeds sampled evenly across the allowed range per yaw rate (besides
    /// the exact edges of the speeds the DTCBF condition allows).
    pub speed_samples: usize,
    /// How far ahead the clearance and progress critics follow a candidate
    /// held (s).
    pub horizon_s: f64,
    /// The clearance critic prefers keeping this much beyond d_safe along
    /// the horizon (m); nothing farther counts.
    pub clearance_band_m: f64,
    /// While a tracked mover is this near the body (m), the steering critics
    /// count even when the upstream command is safe as it is: a person near
    /// may step anywhere, and the DOAA's law keeps the robot away.
    pub mover_near_m: f64,
    /// Weights of the critics (each critic's cost is about 0..1).
    pub weights: CriticWeights,
}

/// One weight per critic (`algo/select/critics/`), dimensionless, ≥ 0.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CriticWeights {
    /// Closeness to the upstream (nominal) command.
    pub nominal: f64,
    /// Little change from the command last sent.
    pub smoothness: f64,
    /// No swinging straight back.
    pub oscillation: f64,
    /// Closeness to the DOAA's command (the paper's steering law).
    pub doaa: f64,
    /// Progress towards the reference ahead or the way-round waypoint.
    pub progress: f64,
    /// Room to the static surroundings along the horizon.
    pub clearance: f64,
    /// Time to contact with movers and the head-on line deficit (evasion).
    pub mover: f64,
    /// Keeping the side chosen to pass an obstacle ahead on.
    pub side: f64,
}

impl Default for SelectParams {
    fn default() -> Self {
        Self {
            enabled: true,
            omega_samples: 15,
            speed_samples: 6,
            horizon_s: 1.5,
            clearance_band_m: 0.3,
            mover_near_m: 1.0,
            weights: CriticWeights::default(),
        }
    }
}

impl Default for CriticWeights {
    fn default() -> Self {
        Self {
            nominal: 1.0,
            smoothness: 0.05,
            oscillation: 5.0,
            doaa: 1.0,
            progress: 2.0,
            clearance: 1.0,
            mover: 10.0,
            side: 1.0,
        }
    }
}
