//! Every value of a [`Params`] against its allowed range or rule; each
//! violation names the key to change. The intervals are typed constants
//! ([`Interval`]): what is checked and what the message shows are one value.

use super::Params;
use crate::config::{Allowed, Checker, Interval, Validate};

/// A speed limit or nominal speed (m/s); 0 allowed.
const SPEED: Interval = Interval::closed(0.0, 5.0).unit("m/s");
/// A positive speed bound (m/s).
const SPEED_POS: Interval = Interval::open_closed(0.0, 5.0).unit("m/s");
/// A footprint semi-axis or radius (m).
const SEMI_AXIS: Interval = Interval::closed(0.0, 5.0).unit("m");
/// A laser mount offset (m).
const MOUNT: Interval = Interval::closed(-5.0, 5.0).unit("m");
/// A distance or margin up to 10 m; 0 allowed.
const DIST_10: Interval = Interval::closed(0.0, 10.0).unit("m");
/// A positive distance up to 10 m.
const DIST_10_POS: Interval = Interval::open_closed(0.0, 10.0).unit("m");
/// A hold or timeout up to a minute (s); 0 allowed.
const HOLD_60: Interval = Interval::closed(0.0, 60.0).unit("s");
/// A positive time horizon up to a minute (s).
const TIME_60_POS: Interval = Interval::open_closed(0.0, 60.0).unit("s");
/// A sector angle, a full turn at most (deg).
const SECTOR_DEG: Interval = Interval::open_closed(0.0, 360.0).unit("deg");
/// A barrier exponent (σ, β).
const EXPONENT: Interval = Interval::closed(0.1, 10.0);
/// A tracking gain per second (1/s); 0 allowed.
const GAIN_PER_S: Interval = Interval::closed(0.0, 100.0).unit("1/s");
/// A count of up to 1000.
const COUNT_1000: Interval = Interval::closed(1.0, 1000.0);
/// A (de)celeration (m/s²).
const ACCEL: Interval = Interval::open_closed(0.0, 100.0).unit("m/s²");
/// A margin up to 1 m; 0 allowed.
/// A laser's range noise (1σ): 10 cm is far beyond any scanner worth averaging.
const RANGE_NOISE: Interval = Interval::closed(0.0, 0.1).unit("m");
const MARGIN_1: Interval = Interval::closed(0.0, 1.0).unit("m");
/// A horizon or gain up to 10 s.
const TIME_10_POS: Interval = Interval::open_closed(0.0, 10.0).unit("s");
/// A critic's weight.
const WEIGHT: Interval = Interval::closed(0.0, 1000.0);
/// DTCBF ω candidates: odd (ω = 0 is one of them), at least 3, at most 201.
const OMEGA_CANDIDATES: Interval = Interval::closed(3.0, 201.0);

impl Validate for Params {
    fn check(&self, c: &mut Checker) {
        let ctl = &self.control;
        c.range(
            "control.rate_hz",
            ctl.rate_hz,
            Interval::open_closed(0.0, 1000.0).unit("Hz"),
        );
        c.range("control.v_nom_mps", ctl.v_nom_mps, SPEED);
        c.at_most(
            "control.v_nom_mps",
            ctl.v_nom_mps,
            ctl.v_max_mps,
            "at most control.v_max_mps",
        );
        c.range("control.v_max_mps", ctl.v_max_mps, SPEED_POS);
        c.range(
            "control.omega_max_radps",
            ctl.omega_max_radps,
            Interval::open_closed(0.0, 10.0).unit("rad/s"),
        );
        c.range("control.v_reverse_max_mps", ctl.v_reverse_max_mps, SPEED);
        c.range("control.accel_mps2", ctl.accel_mps2, ACCEL);
        c.range("control.decel_mps2", ctl.decel_mps2, ACCEL);
        c.range(
            "control.angular_accel_radps2",
            ctl.angular_accel_radps2,
            Interval::open_closed(0.0, 1000.0).unit("rad/s²"),
        );

        let fp = &self.footprint;
        c.range("footprint.semi_axis_1_m", fp.semi_axis_1_m, SEMI_AXIS);
        c.range("footprint.semi_axis_2_m", fp.semi_axis_2_m, SEMI_AXIS);
        c.range("footprint.overall_dimension_m", fp.overall_dimension_m, DIST_10);
        if let Some(r) = fp.radius_override_m {
            c.range("footprint.radius_override_m", r, SEMI_AXIS);
        }
        c.range("footprint.padding_m", fp.padding_m, MARGIN_1);
        if let Some(Err(e)) = fp.polygon() {
            c.rule(
                false,
                "footprint.polygon_m",
                format!("{:?}", fp.polygon_m),
                e.to_string(),
            );
        } else if fp.polygon_m.iter().flatten().any(|x| x.abs() > 5.0) {
            c.rule(
                false,
                "footprint.polygon_m",
                format!("{:?}", fp.polygon_m),
                "vertices within 5 m of the robot's origin",
            );
        }

        let l = &self.laser;
        c.range("laser.mount_x_m", l.mount_x_m, MOUNT);
        c.range("laser.mount_y_m", l.mount_y_m, MOUNT);
        c.range(
            "laser.mount_yaw_deg",
            l.mount_yaw_deg,
            Interval::closed(-360.0, 360.0).unit("deg"),
        );
        c.range("laser.scan_timeout_s", l.scan_timeout_s, TIME_60_POS);
        c.range(
            "laser.max_beams",
            l.max_beams as f64,
            Interval::closed(1.0, 1_000_000.0),
        );
        c.range("laser.unknown_hold_s", l.unknown_hold_s, HOLD_60);
        c.range("laser.blind_sector_deg", l.blind_sector_deg, SECTOR_DEG);
        c.range(
            "laser.blind_fraction",
            l.blind_fraction,
            Interval::open_closed(0.0, 1.0),
        );
        c.range("laser.blind_timeout_s", l.blind_timeout_s, HOLD_60);
        c.range("laser.range_noise_m", l.range_noise_m, RANGE_NOISE);

        let b = &self.barrier;
        c.range("barrier.d_safe_m", b.d_safe_m, DIST_10);
        c.range("barrier.big_gamma", b.big_gamma, Interval::open_closed(0.0, 100.0));
        c.range("barrier.sigma", b.sigma, EXPONENT);
        c.range("barrier.zeta", b.zeta, Interval::closed(0.0, 100.0));
        c.range("barrier.beta", b.beta, EXPONENT);
        c.range("barrier.barrier_max", b.barrier_max, Interval::open_closed(1.0, 1e12));
        c.range("barrier.hemisphere_fov_deg", b.hemisphere_fov_deg, SECTOR_DEG);
        c.range("barrier.front_fov_deg", b.front_fov_deg, SECTOR_DEG);
        c.range(
            "barrier.side_fade_deg",
            b.side_fade_deg,
            Interval::closed(0.0, 90.0).unit("deg"),
        );
        if b.d_safe_m.is_finite() && b.big_gamma.is_finite() && b.sigma.is_finite() {
            let band = b.d_act_m() - b.d_safe_m;
            c.rule(
                band.is_finite() && band <= 100.0,
                "barrier.big_gamma",
                b.big_gamma,
                "Γ^(2/σ) at most 100 m",
            );
        }

        let d = &self.doaa;
        c.range(
            "doaa.gain_k_radps",
            d.gain_k_radps,
            Interval::closed(0.0, 100.0).unit("rad/s"),
        );
        c.range(
            "doaa.omega_0_radps",
            d.omega_0_radps,
            Interval::open_closed(0.0, 10.0).unit("rad/s"),
        );
        c.at_most(
            "doaa.omega_0_radps",
            d.omega_0_radps,
            ctl.omega_max_radps,
            "at most control.omega_max_radps",
        );
        c.range("doaa.both_sides_release_m", d.both_sides_release_m, DIST_10);
        c.range("doaa.front_stop_margin_m", d.front_stop_margin_m, DIST_10);
        c.range("doaa.both_sides_min_speed_mps", d.both_sides_min_speed_mps, SPEED);
        c.range("doaa.front_nearest_tolerance_m", d.front_nearest_tolerance_m, DIST_10);
        // Divides the nominal speed: 0 would make the gain weight NaN at a standstill.
        c.range("doaa.full_gain_speed_mps", d.full_gain_speed_mps, SPEED_POS);

        let f = &self.dtcbf;
        c.range("dtcbf.gamma", f.gamma, Interval::open_closed(0.0, 1.0));
        c.range(
            "dtcbf.escape_epsilon_m",
            f.escape_epsilon_m,
            Interval::open_closed(0.0, 0.1).unit("m"),
        );
        c.range("dtcbf.noise_margin_m", f.noise_margin_m, MARGIN_1);
        c.rule(
            OMEGA_CANDIDATES.contains(f.omega_candidates as f64) && f.omega_candidates % 2 == 1,
            "dtcbf.omega_candidates",
            f.omega_candidates,
            Allowed::rule_in("odd", OMEGA_CANDIDATES),
        );
        c.range(
            "dtcbf.omega_weight_m2_per_rad2",
            f.omega_weight_m2_per_rad2,
            Interval::closed(0.0, 1000.0).unit("m²/rad²"),
        );

        let t = &self.tracking;
        c.range("tracking.k_x_per_s", t.k_x_per_s, GAIN_PER_S);
        c.range(
            "tracking.k_y_per_m2",
            t.k_y_per_m2,
            Interval::closed(0.0, 1000.0).unit("1/m²"),
        );
        c.range(
            "tracking.k_theta_per_m",
            t.k_theta_per_m,
            Interval::closed(0.0, 1000.0).unit("1/m"),
        );
        c.range(
            "tracking.capture_radius_m",
            t.capture_radius_m,
            Interval::open_closed(0.0, 100.0).unit("m"),
        );
        c.range("tracking.k_bearing_per_s", t.k_bearing_per_s, GAIN_PER_S);
        c.range("tracking.arrive_radius_m", t.arrive_radius_m, DIST_10);

        let o = &self.obstacles;
        c.range(
            "obstacles.cluster_gap_m",
            o.cluster_gap_m,
            Interval::open_closed(0.0, 5.0).unit("m"),
        );
        c.range("obstacles.min_cluster_points", o.min_cluster_points as f64, COUNT_1000);
        c.range(
            "obstacles.max_cluster_diameter_m",
            o.max_cluster_diameter_m,
            DIST_10_POS,
        );
        c.range("obstacles.gate_m", o.gate_m, DIST_10_POS);
        c.range("obstacles.confirm_hits", o.confirm_hits, Interval::closed(1.0, 100.0));
        c.range("obstacles.max_misses", o.max_misses, Interval::closed(0.0, 1000.0));
        c.range("obstacles.accel_noise_mps2", o.accel_noise_mps2, ACCEL);
        c.range("obstacles.measurement_noise_m", o.measurement_noise_m, DIST_10_POS);
        c.range(
            "obstacles.moving_speed_mps",
            o.moving_speed_mps,
            Interval::closed(0.0, 10.0).unit("m/s"),
        );
        c.range(
            "obstacles.min_travel_m",
            o.min_travel_m,
            Interval::closed(0.0, 100.0).unit("m"),
        );
        c.range("obstacles.lookahead_s", o.lookahead_s, HOLD_60);
        c.range("obstacles.max_tracks", o.max_tracks as f64, COUNT_1000);

        let u = &self.unstuck;
        c.range(
            "unstuck.stall_s",
            u.stall_s,
            Interval::open_closed(0.0, 600.0).unit("s"),
        );
        c.range("unstuck.progress_m", u.progress_m, DIST_10_POS);
        c.range("unstuck.window_m", u.window_m, Interval::closed(1.0, 20.0).unit("m"));
        c.range("unstuck.memory_s", u.memory_s, Interval::closed(0.0, 600.0).unit("s"));
        c.range(
            "unstuck.stuck_avoid_s",
            u.stuck_avoid_s,
            Interval::closed(0.0, 600.0).unit("s"),
        );
        c.range(
            "unstuck.plan_period_s",
            u.plan_period_s,
            Interval::closed(0.05, 10.0).unit("s"),
        );
        c.range("unstuck.margin_m", u.margin_m, MARGIN_1);
        c.range("unstuck.ahead_m", u.ahead_m, Interval::closed(0.0, 20.0).unit("m"));

        let pa = &self.passive;
        c.range(
            "passive.mover_margin_m",
            pa.mover_margin_m,
            Interval::closed(0.0, 2.0).unit("m"),
        );
        c.range(
            "passive.mover_growth_mps",
            pa.mover_growth_mps,
            Interval::closed(0.0, 10.0).unit("m/s"),
        );
        c.range(
            "passive.seen_margin_m",
            pa.seen_margin_m,
            Interval::closed(0.0, 0.2).unit("m"),
        );
        c.range(
            "passive.closing_speed_mps",
            pa.closing_speed_mps,
            Interval::closed(0.0, 1.0).unit("m/s"),
        );
        c.range("passive.evasion_horizon_s", pa.evasion_horizon_s, TIME_10_POS);

        c.range("passive.evasion_max_speed_mps", pa.evasion_max_speed_mps, SPEED);
        if c.range("passive.evasion_accel_mps2", pa.evasion_accel_mps2, ACCEL) {
            c.rule(
                pa.evasion_accel_mps2 >= ctl.accel_mps2,
                "passive.evasion_accel_mps2",
                pa.evasion_accel_mps2,
                "at least control.accel_mps2",
            );
        }
        if c.range(
            "passive.evasion_angular_accel_radps2",
            pa.evasion_angular_accel_radps2,
            Interval::open_closed(0.0, 1000.0).unit("rad/s²"),
        ) {
            c.rule(
                pa.evasion_angular_accel_radps2 >= ctl.angular_accel_radps2,
                "passive.evasion_angular_accel_radps2",
                pa.evasion_angular_accel_radps2,
                "at least control.angular_accel_radps2",
            );
        }

        let se = &self.select;
        c.range(
            "select.omega_samples",
            se.omega_samples as f64,
            Interval::closed(3.0, 101.0),
        );
        c.range(
            "select.speed_samples",
            se.speed_samples as f64,
            Interval::closed(2.0, 50.0),
        );
        c.range("select.horizon_s", se.horizon_s, TIME_10_POS);
        c.range("select.clearance_band_m", se.clearance_band_m, DIST_10_POS);
        c.range("select.mover_near_m", se.mover_near_m, DIST_10);
        let w = &se.weights;
        for (key, weight) in [
            ("select.weights.nominal", w.nominal),
            ("select.weights.smoothness", w.smoothness),
            ("select.weights.oscillation", w.oscillation),
            ("select.weights.doaa", w.doaa),
            ("select.weights.progress", w.progress),
            ("select.weights.clearance", w.clearance),
            ("select.weights.mover", w.mover),
            ("select.weights.side", w.side),
        ] {
            c.range(key, weight, WEIGHT);
        }
        c.rule(
            se.enabled || !pa.enabled,
            "select.enabled",
            se.enabled,
            "true while passive.enabled is true: the paper's decision has no braking check",
        );

        let (dc, vo) = (&self.baselines.dcbf, &self.baselines.vo);
        c.range(
            "baselines.dcbf.lookahead_m",
            dc.lookahead_m,
            Interval::open_closed(0.0, 1.0).unit("m"),
        );
        c.range(
            "baselines.dcbf.sector_deg",
            dc.sector_deg,
            Interval::open_closed(0.0, 180.0).unit("deg"),
        );
        c.range(
            "baselines.dcbf.omega_weight",
            dc.omega_weight,
            Interval::open_closed(0.0, 1000.0),
        );
        c.range(
            "baselines.dcbf.slack_penalty",
            dc.slack_penalty,
            Interval::open_closed(0.0, 1e9),
        );
        c.range("baselines.vo.time_horizon_s", vo.time_horizon_s, TIME_60_POS);
        c.range(
            "baselines.vo.static_time_horizon_s",
            vo.static_time_horizon_s,
            TIME_60_POS,
        );
        c.range(
            "baselines.vo.heading_gain_per_s",
            vo.heading_gain_per_s,
            Interval::open_closed(0.0, 100.0).unit("1/s"),
        );
        c.range("baselines.vo.vertex_spacing_m", vo.vertex_spacing_m, MARGIN_1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The allowed text is the one the docs and the old string literals show.
    #[test]
    fn messages_show_the_allowed_interval_as_written() {
        let mut p = Params::default();
        p.barrier.d_safe_m = -1.0;
        p.barrier.barrier_max = 1.0;
        p.baselines.dcbf.slack_penalty = 0.0;
        p.laser.max_beams = 0;
        p.dtcbf.omega_candidates = 20;
        p.obstacles.confirm_hits = 0;
        let msgs: Vec<String> = p.validate().unwrap_err().iter().map(ToString::to_string).collect();
        assert_eq!(
            msgs,
            [
                "key `laser.max_beams` = 0 is out of range; allowed: [1, 1000000]",
                "key `barrier.d_safe_m` = -1 is out of range; allowed: [0, 10] m",
                "key `barrier.barrier_max` = 1 is out of range; allowed: (1, 1e12]",
                "key `dtcbf.omega_candidates` = 20 is out of range; allowed: odd, in [3, 201]",
                "key `obstacles.confirm_hits` = 0 is out of range; allowed: [1, 100]",
                "key `baselines.dcbf.slack_penalty` = 0 is out of range; allowed: (0, 1e9]",
            ]
        );
    }

    #[test]
    fn the_allowed_interval_is_data() {
        let mut p = Params::default();
        p.dtcbf.omega_candidates = 4;
        let e = p.validate().unwrap_err();
        assert_eq!(e[0].allowed.interval(), Some(OMEGA_CANDIDATES));
    }
}
