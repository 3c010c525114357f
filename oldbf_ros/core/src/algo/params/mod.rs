//! Every tunable of the pipeline, grouped as in `config/oldbf.yaml`.
//!
//! The defaults here are the paper's values where it gives them (TurtleBot3
//! scale) and are the same numbers `config/oldbf.yaml` documents; a test keeps
//! the two equal. `validate` checks every value against its allowed range and
//! names the offending key, so the CLI, the ROS node and the tests reject a bad
//! configuration the same way.

use serde::{Deserialize, Serialize};
use std::fmt;

mod baselines;
mod filter;
mod guidance;
mod laser;
mod obstacles;
mod robot;
pub use baselines::*;
pub use filter::*;
pub use guidance::*;
pub use laser::*;
pub use obstacles::*;
pub use robot::*;

/// All algorithm parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct Params {
    pub control: ControlParams,
    pub footprint: FootprintParams,
    pub laser: LaserParams,
    pub barrier: BarrierParams,
    pub doaa: DoaaParams,
    pub dtcbf: DtcbfParams,
    pub tracking: TrackingParams,
    pub obstacles: ObstacleParams,
    pub passive: PassiveParams,
    pub unstuck: UnstuckParams,
    pub baselines: BaselineParams,
}

/// A parameter outside its allowed range.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamError {
    /// Dotted path of the key, as in the YAML file, e.g. `barrier.d_safe_m`.
    pub key: &'static str,
    /// The offending value, printed.
    pub value: String,
    /// The allowed range or rule, e.g. `(0, 1]`.
    pub allowed: &'static str,
}

impl fmt::Display for ParamError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "key `{}` = {} is out of range; allowed: {}",
            self.key, self.value, self.allowed
        )
    }
}

impl std::error::Error for ParamError {}

/// Parses an interval written as in the messages, e.g. `(0, 1]` or
/// `[-5, 5] m` (a unit may follow), into (lo, lo_open, hi, hi_open).
fn parse_interval(allowed: &str) -> Option<(f64, bool, f64, bool)> {
    let lo_open = allowed.starts_with('(');
    let close = allowed.find([']', ')'])?;
    let hi_open = allowed[close..].starts_with(')');
    let (lo, hi) = allowed[1..close].split_once(',')?;
    Some((lo.trim().parse().ok()?, lo_open, hi.trim().parse().ok()?, hi_open))
}

/// Collects every failed check.
struct Check {
    errors: Vec<ParamError>,
}

impl Check {
    /// `allowed` is the interval the message shows, and what is checked.
    fn range(&mut self, key: &'static str, v: f64, allowed: &'static str) {
        let (lo, lo_open, hi, hi_open) = parse_interval(allowed).expect("interval literal is well formed");
        let ok = v.is_finite() && (if lo_open { v > lo } else { v >= lo }) && (if hi_open { v < hi } else { v <= hi });
        self.rule(ok, key, format!("{v}"), allowed);
    }

    /// `v` may not exceed another key's value (NaN is reported by its own range check).
    fn at_most(&mut self, key: &'static str, v: f64, limit: f64, allowed: &'static str) {
        self.rule(v <= limit || v.is_nan(), key, format!("{v}"), allowed);
    }

    fn rule(&mut self, ok: bool, key: &'static str, value: String, allowed: &'static str) {
        if !ok {
            self.errors.push(ParamError { key, value, allowed });
        }
    }
}

impl Params {
    /// Robot radius r (m).
    pub fn robot_radius_m(&self) -> f64 {
        self.footprint.radius_m()
    }

    /// The same parameters with what this project added beyond the paper switched
    /// off: `laser.range_semantics: all_invalid_free` (every invalid range is
    /// free space: no hold, no blindness check), `barrier.side_fade_deg: 0` (hard
    /// side sectors), `doaa.commit_turns: false`, `doaa.max_omega_change_radps:
    /// 0` (no yaw-rate step limit), `unstuck.enabled: false`, `passive.enabled:
    /// false` (no braking check or evasion) and `control.allow_reverse: false`.
    /// Everything else, obstacle tracking included, is left as given. This is the
    /// filter as it was before REP 117 semantics, passive motion safety and the
    /// liveness additions. It is the `oldbf-paper` controller (`oldbf batch
    /// --controllers oldbf-paper`, also `oldbf compare` and `oldbf sim
    /// --controller`), kept so the tables can measure the difference on the same
    /// worlds (ALGORITHM.md §8). There is no YAML file for it.
    pub fn paper_method(mut self) -> Self {
        self.laser.range_semantics = RangeSemantics::AllInvalidFree;
        self.barrier.side_fade_deg = 0.0;
        self.doaa.commit_turns = false;
        self.doaa.max_omega_change_radps = 0.0;
        self.unstuck.enabled = false;
        self.passive.enabled = false;
        self.control.allow_reverse = false;
        self
    }

    /// Every out-of-range value, each naming its key; empty when valid.
    pub fn validate(&self) -> Result<(), Vec<ParamError>> {
        let mut c = Check { errors: Vec::new() };
        let ctl = &self.control;
        c.range("control.rate_hz", ctl.rate_hz, "(0, 1000] Hz");
        c.range("control.v_nom_mps", ctl.v_nom_mps, "[0, 5] m/s");
        c.at_most(
            "control.v_nom_mps",
            ctl.v_nom_mps,
            ctl.v_max_mps,
            "at most control.v_max_mps",
        );
        c.range("control.v_max_mps", ctl.v_max_mps, "(0, 5] m/s");
        c.range("control.omega_max_radps", ctl.omega_max_radps, "(0, 10] rad/s");
        c.range("control.v_reverse_max_mps", ctl.v_reverse_max_mps, "[0, 5] m/s");

        let fp = &self.footprint;
        c.range("footprint.semi_axis_1_m", fp.semi_axis_1_m, "[0, 5] m");
        c.range("footprint.semi_axis_2_m", fp.semi_axis_2_m, "[0, 5] m");
        c.range("footprint.overall_dimension_m", fp.overall_dimension_m, "[0, 10] m");
        if let Some(r) = fp.radius_override_m {
            c.range("footprint.radius_override_m", r, "[0, 5] m");
        }

        let l = &self.laser;
        c.range("laser.mount_x_m", l.mount_x_m, "[-5, 5] m");
        c.range("laser.mount_y_m", l.mount_y_m, "[-5, 5] m");
        c.range("laser.mount_yaw_deg", l.mount_yaw_deg, "[-360, 360] deg");
        c.range("laser.scan_timeout_s", l.scan_timeout_s, "(0, 60] s");
        c.range("laser.max_beams", l.max_beams as f64, "[1, 1000000]");
        c.range("laser.unknown_hold_s", l.unknown_hold_s, "[0, 60] s");
        c.range("laser.blind_sector_deg", l.blind_sector_deg, "(0, 360] deg");
        c.range("laser.blind_fraction", l.blind_fraction, "(0, 1]");
        c.range("laser.blind_timeout_s", l.blind_timeout_s, "[0, 60] s");

        let b = &self.barrier;
        c.range("barrier.d_safe_m", b.d_safe_m, "[0, 10] m");
        c.range("barrier.big_gamma", b.big_gamma, "(0, 100]");
        c.range("barrier.sigma", b.sigma, "[0.1, 10]");
        c.range("barrier.zeta", b.zeta, "[0, 100]");
        c.range("barrier.beta", b.beta, "[0.1, 10]");
        c.range("barrier.barrier_max", b.barrier_max, "(1, 1e12]");
        c.range("barrier.hemisphere_fov_deg", b.hemisphere_fov_deg, "(0, 360] deg");
        c.range("barrier.front_fov_deg", b.front_fov_deg, "(0, 360] deg");
        c.range("barrier.side_fade_deg", b.side_fade_deg, "[0, 90] deg");
        if b.d_safe_m.is_finite() && b.big_gamma.is_finite() && b.sigma.is_finite() {
            let band = b.d_act_m() - b.d_safe_m;
            c.rule(
                band.is_finite() && band <= 100.0,
                "barrier.big_gamma",
                format!("{}", b.big_gamma),
                "Γ^(2/σ) at most 100 m",
            );
        }

        let d = &self.doaa;
        c.range("doaa.gain_k_radps", d.gain_k_radps, "[0, 100] rad/s");
        c.range("doaa.omega_0_radps", d.omega_0_radps, "(0, 10] rad/s");
        c.at_most(
            "doaa.omega_0_radps",
            d.omega_0_radps,
            ctl.omega_max_radps,
            "at most control.omega_max_radps",
        );
        c.range("doaa.both_sides_release_m", d.both_sides_release_m, "[0, 10] m");
        c.range("doaa.front_stop_margin_m", d.front_stop_margin_m, "[0, 10] m");
        c.range(
            "doaa.both_sides_min_speed_mps",
            d.both_sides_min_speed_mps,
            "[0, 5] m/s",
        );
        c.range(
            "doaa.front_nearest_tolerance_m",
            d.front_nearest_tolerance_m,
            "[0, 10] m",
        );
        // Divides the nominal speed: 0 would make the gain weight NaN at a standstill.
        c.range("doaa.full_gain_speed_mps", d.full_gain_speed_mps, "(0, 5] m/s");
        c.range("doaa.commit_min_turn", d.commit_min_turn, "[0, 1]");
        c.range("doaa.max_omega_change_radps", d.max_omega_change_radps, "[0, 20] rad/s");

        let f = &self.dtcbf;
        c.range("dtcbf.gamma", f.gamma, "(0, 1]");
        c.range("dtcbf.escape_epsilon_m", f.escape_epsilon_m, "(0, 0.1] m");
        c.range("dtcbf.noise_margin_m", f.noise_margin_m, "[0, 1] m");
        c.rule(
            (3..=201).contains(&f.omega_candidates) && f.omega_candidates % 2 == 1,
            "dtcbf.omega_candidates",
            format!("{}", f.omega_candidates),
            "odd, in [3, 201]",
        );
        c.range(
            "dtcbf.omega_weight_m2_per_rad2",
            f.omega_weight_m2_per_rad2,
            "[0, 1000] m²/rad²",
        );

        let t = &self.tracking;
        c.range("tracking.k_x_per_s", t.k_x_per_s, "[0, 100] 1/s");
        c.range("tracking.k_y_per_m2", t.k_y_per_m2, "[0, 1000] 1/m²");
        c.range("tracking.k_theta_per_m", t.k_theta_per_m, "[0, 1000] 1/m");
        c.range("tracking.capture_radius_m", t.capture_radius_m, "(0, 100] m");
        c.range("tracking.k_bearing_per_s", t.k_bearing_per_s, "[0, 100] 1/s");
        c.range("tracking.arrive_radius_m", t.arrive_radius_m, "[0, 10] m");

        let o = &self.obstacles;
        c.range("obstacles.cluster_gap_m", o.cluster_gap_m, "(0, 5] m");
        c.range("obstacles.min_cluster_points", o.min_cluster_points as f64, "[1, 1000]");
        c.range(
            "obstacles.max_cluster_diameter_m",
            o.max_cluster_diameter_m,
            "(0, 10] m",
        );
        c.range("obstacles.gate_m", o.gate_m, "(0, 10] m");
        c.range("obstacles.confirm_hits", o.confirm_hits as f64, "[1, 100]");
        c.range("obstacles.max_misses", o.max_misses as f64, "[0, 1000]");
        c.range("obstacles.accel_noise_mps2", o.accel_noise_mps2, "(0, 100] m/s²");
        c.range("obstacles.measurement_noise_m", o.measurement_noise_m, "(0, 10] m");
        c.range("obstacles.moving_speed_mps", o.moving_speed_mps, "[0, 10] m/s");
        c.range("obstacles.min_travel_m", o.min_travel_m, "[0, 100] m");
        c.range("obstacles.lookahead_s", o.lookahead_s, "[0, 60] s");
        c.range("obstacles.max_tracks", o.max_tracks as f64, "[1, 1000]");

        let u = &self.unstuck;
        c.range("unstuck.stall_s", u.stall_s, "(0, 600] s");
        c.range("unstuck.progress_m", u.progress_m, "(0, 10] m");
        c.range("unstuck.window_m", u.window_m, "[1, 20] m");
        c.range("unstuck.margin_m", u.margin_m, "[0, 1] m");
        c.range("unstuck.ahead_m", u.ahead_m, "[0, 20] m");

        let pa = &self.passive;
        c.range("passive.brake_decel_mps2", pa.brake_decel_mps2, "(0, 100] m/s²");
        c.range("passive.mover_margin_m", pa.mover_margin_m, "[0, 2] m");
        c.range("passive.mover_growth_mps", pa.mover_growth_mps, "[0, 10] m/s");
        c.range("passive.closing_speed_mps", pa.closing_speed_mps, "[0, 1] m/s");
        c.range("passive.evasion_horizon_s", pa.evasion_horizon_s, "(0, 10] s");
        c.range("passive.evasion_min_gain_s", pa.evasion_min_gain_s, "[0, 10] s");

        let (dc, vo) = (&self.baselines.dcbf, &self.baselines.vo);
        c.range("baselines.dcbf.lookahead_m", dc.lookahead_m, "(0, 1] m");
        c.range("baselines.dcbf.sector_deg", dc.sector_deg, "(0, 180] deg");
        c.range("baselines.dcbf.omega_weight", dc.omega_weight, "(0, 1000]");
        c.range("baselines.dcbf.slack_penalty", dc.slack_penalty, "(0, 1e9]");
        c.range("baselines.vo.time_horizon_s", vo.time_horizon_s, "(0, 60] s");
        c.range(
            "baselines.vo.static_time_horizon_s",
            vo.static_time_horizon_s,
            "(0, 60] s",
        );
        c.range("baselines.vo.heading_gain_per_s", vo.heading_gain_per_s, "(0, 100] 1/s");
        c.range("baselines.vo.vertex_spacing_m", vo.vertex_spacing_m, "[0, 1] m");

        if c.errors.is_empty() {
            Ok(())
        } else {
            Err(c.errors)
        }
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
        let keys: Vec<_> = p.validate().unwrap_err().iter().map(|e| e.key).collect();
        assert_eq!(keys, ["barrier.d_safe_m", "dtcbf.gamma", "dtcbf.omega_candidates"]);
    }

    #[test]
    fn interval_literals_parse() {
        assert_eq!(parse_interval("(0, 1]"), Some((0.0, true, 1.0, false)));
        assert_eq!(parse_interval("[-5, 5] m"), Some((-5.0, false, 5.0, false)));
        assert_eq!(parse_interval("(1, 1e12)"), Some((1.0, true, 1e12, true)));
        let mut c = Check { errors: vec![] };
        c.range("k", 0.0, "(0, 1]");
        c.range("k", 1.0, "(0, 1]");
        c.range("k", 1.0, "[0, 1)");
        c.range("k", f64::INFINITY, "[0, 1e12]");
        assert_eq!(c.errors.len(), 3);
    }

    #[test]
    fn cross_field_rules() {
        let mut p = Params::default();
        p.control.v_nom_mps = 0.3; // above v_max 0.22
        p.doaa.omega_0_radps = 0.5; // above omega_max 0.3
        let keys: Vec<_> = p.validate().unwrap_err().iter().map(|e| e.key).collect();
        assert_eq!(keys, ["control.v_nom_mps", "doaa.omega_0_radps"]);
    }
}
