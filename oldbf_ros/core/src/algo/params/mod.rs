//! Every tunable of the pipeline, grouped as in `config/oldbf.yaml`.
//!
//! The defaults here are the paper's values where it gives them (TurtleBot3
//! scale) and are the same numbers `config/oldbf.yaml` documents; a test keeps
//! the two equal. `validate` checks every value against its allowed range
//! (with the shared [`crate::config`] checks) and names the offending key, so
//! the CLI, the ROS node and the tests reject a bad configuration the same way.

pub use crate::config::ParamError;
use crate::config::Validate;
use serde::{Deserialize, Serialize};

mod base;
mod baselines;
mod checks;
mod filter;
mod guidance;
mod laser;
mod obstacles;
mod robot;
mod select;
pub use baselines::*;
pub use filter::*;
pub use guidance::*;
pub use laser::*;
pub use obstacles::*;
pub use robot::*;
pub use select::*;

/// All algorithm parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Control period and input limits.
    pub control: ControlParams,
    /// The robot's size.
    pub footprint: FootprintParams,
    /// Range semantics, hold, blindness, mount.
    pub laser: LaserParams,
    /// The barrier functions B_l, B_r (§3).
    pub barrier: BarrierParams,
    /// DOAA steering (§4).
    pub doaa: DoaaParams,
    /// The exact discrete-time CBF check (§5).
    pub dtcbf: DtcbfParams,
    /// Reference tracking (§7).
    pub tracking: TrackingParams,
    /// Obstacle tracking and collision cones (§6).
    pub obstacles: ObstacleParams,
    /// Passive motion safety and evasion (§5b).
    pub passive: PassiveParams,
    /// Liveness: unstuck (§4b).
    pub unstuck: UnstuckParams,
    /// The decision: one command chosen inside the dynamic window (§5c).
    pub select: SelectParams,
    /// The baselines the paper compares against (§8).
    pub baselines: BaselineParams,
}

impl Params {
    /// Robot radius r (m).
    pub fn robot_radius_m(&self) -> f64 {
        self.footprint.radius_m()
    }

    /// The same parameters with what this project added beyond the paper switched
    /// off: `laser.range_semantics: all_invalid_free` (every invalid range is
    /// free space: no hold, no blindness check), `barrier.side_fade_deg: 0` (hard
    /// side sectors), `select.enabled: false` (the paper's decision: the DOAA
    /// command, then the DTCBF filter's own search, no window, no critics),
    /// `unstuck.enabled: false`, `passive.enabled: false` (no braking check
    /// or evasion), `control.allow_reverse: false` and
    /// `obstacles.lookahead_s: 2` (the look-ahead it had), motion proven by
    /// travel alone (`obstacles.motion_by_sight: false`, `min_travel_m: 0.3`:
    /// the proof it had), and a polygon
    /// footprint kept as its circumscribed circle (the paper's robot is a
    /// circle). Everything else,
    /// obstacle tracking included, is left as given. This is the
    /// filter as it was before REP 117 semantics, passive motion safety and the
    /// liveness additions. It is the `oldbf-paper` controller (`oldbf batch
    /// --controllers oldbf-paper`, also `oldbf compare` and `oldbf sim
    /// --controller`), kept so the tables can measure the difference on the same
    /// worlds (ALGORITHM.md §8). There is no YAML file for it.
    pub fn paper_method(mut self) -> Self {
        self.laser.range_semantics = RangeSemantics::AllInvalidFree;
        self.laser.range_noise_m = 0.0;
        self.barrier.side_fade_deg = 0.0;
        self.unstuck.enabled = false;
        self.passive.enabled = false;
        self.select.enabled = false;
        self.control.allow_reverse = false;
        self.obstacles.lookahead_s = obstacles::PAPER_LOOKAHEAD_S;
        self.obstacles.motion_by_sight = false;
        self.obstacles.min_travel_m = obstacles::PAPER_MIN_TRAVEL_M;
        // The paper's robot is a circle: a polygon footprint becomes its
        // circumscribed circle (the radius every circle check used already).
        if !self.footprint.polygon_m.is_empty() {
            self.footprint.radius_override_m = Some(self.footprint.radius_m() - self.footprint.padding_m);
            self.footprint.polygon_m.clear();
        }
        self
    }

    /// Every out-of-range value, each naming its key; `Ok` when valid. The
    /// rules are in `checks.rs` ([`Validate`]); inherent so callers need not
    /// import the trait.
    pub fn validate(&self) -> Result<(), Vec<ParamError>> {
        Validate::validate(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid() {
        assert_eq!(Params::default().validate(), Ok(()));
    }

    #[test]
    fn the_papers_method_keeps_a_polygon_as_its_circumscribed_circle() {
        let mut p = Params::default();
        p.footprint.polygon_m = vec![[0.3, 0.2], [-0.3, 0.2], [-0.3, -0.2], [0.3, -0.2]];
        p.footprint.padding_m = 0.05;
        let r = p.robot_radius_m();
        assert!((r - (0.13f64.sqrt() + 0.05)).abs() < 1e-12);
        let paper = p.paper_method();
        assert!(paper.footprint.polygon_m.is_empty());
        assert!((paper.robot_radius_m() - r).abs() < 1e-12);
    }

    #[test]
    fn paper_radius_formula() {
        // r = max(0.089, 0.069) + 0.178 / 2 = 0.178 m.
        assert!((Params::default().robot_radius_m() - 0.178).abs() < 1e-12);
        let mut p = Params::default();
        p.footprint.radius_override_m = Some(0.105);
        assert_eq!(p.robot_radius_m(), 0.105);
    }

    #[test]
    fn activation_distance_is_d_safe_plus_gamma_power() {
        let mut b = BarrierParams::default();
        // Γ = 1: Γ^(2/σ) = 1 whatever σ.
        assert!((b.d_act_m() - 1.2).abs() < 1e-12);
        b.big_gamma = 0.25; // σ = 2: 0.25^(1) = 0.25.
        assert!((b.d_act_m() - 0.45).abs() < 1e-12);
        b.sigma = 4.0; // 0.25^(0.5) = 0.5.
        assert!((b.d_act_m() - 0.7).abs() < 1e-12);
    }

    #[test]
    fn out_of_range_values_name_their_keys() {
        let mut p = Params::default();
        p.dtcbf.gamma = 1.5;
        p.barrier.d_safe_m = f64::NAN;
        p.dtcbf.omega_candidates = 20;
        let keys: Vec<_> = p.validate().unwrap_err().into_iter().map(|e| e.key).collect();
        assert_eq!(keys, ["barrier.d_safe_m", "dtcbf.gamma", "dtcbf.omega_candidates"]);
    }

    #[test]
    fn cross_field_rules() {
        let mut p = Params::default();
        p.control.v_nom_mps = 0.3; // above v_max 0.22
        p.doaa.omega_0_radps = 0.5; // above omega_max 0.3
        let keys: Vec<_> = p.validate().unwrap_err().into_iter().map(|e| e.key).collect();
        assert_eq!(keys, ["control.v_nom_mps", "doaa.omega_0_radps"]);
    }
}
