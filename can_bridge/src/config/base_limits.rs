//! The bridge's settings against the base's own limits
//! (`config/base_limits.yaml`, [`oldbf::config::BaseLimits`]), the file the
//! safety filter checks its own settings against too.
//!
//! The filter's braking check counts on the base braking at
//! `base.decel_mps2` (its own `control.decel_mps2` may not exceed it); the
//! bridge ramps every commanded slow-down at `limits.wheel_decel_radps2` at
//! the wheel, so that ramp, in body terms, may not be gentler. Likewise the
//! filter's dynamic window speeds up at the base's `accel_mps2` and
//! `angular_accel_radps2` (evasion uses them in full), so the speed-up ramp
//! may not be gentler either: every command the filter verified is one the
//! base, bridge included, can follow.

use super::BridgeConfig;
use oldbf::config::{BaseKey, BaseLimits, LimitCheck, LimitConflict, Relation};

/// The wheel's rate (rad/s²) as the body's (m/s²), with the conversion shown.
fn body_rate(wheel_radps2: f64, radius_m: f64) -> (f64, String) {
    let body = wheel_radps2 * radius_m;
    let shown = format!("{wheel_radps2} rad/s² × kinematics.wheel_radius_m {radius_m} m = {body:.4} m/s²");
    (body, shown)
}

impl BridgeConfig {
    /// Every setting of the bridge that contradicts the base's limits, each
    /// naming its own key and the base's: the node refuses to start.
    pub fn base_conflicts(&self, base: &BaseLimits) -> Vec<LimitConflict> {
        let l = &self.limits;
        let mut c = LimitCheck::new(base);
        // A straight-line slow-down turns both wheels down at the ramp, so
        // the body decelerates at wheel_decel × r (turns only slow a wheel
        // more gently, never faster). Below base.decel_mps2 the robot would
        // brake more slowly than the filter's braking check counts on.
        let (body, shown) = body_rate(l.wheel_decel_radps2, self.kinematics.wheel_radius_m);
        c.compare(
            "limits.wheel_decel_radps2",
            body,
            shown,
            BaseKey::Decel,
            Relation::AtLeast,
            "the bridge would not brake as fast as the filter's braking check counts on",
        );
        // Speed-ups: the filter's dynamic window may change v by up to
        // base.accel_mps2 and ω by up to base.angular_accel_radps2 in the same
        // second (evasion uses the base's own limits), which asks one wheel
        // for (accel + angular_accel × L/2) / r. The ramp scales both wheels
        // by one factor, so a gentler wheel ramp slows the whole change: the
        // base would not follow the commands the filter verified. Compared
        // as the linear acceleration left beside a full yaw acceleration.
        let half_track_m = 0.5 * self.kinematics.wheel_separation_m;
        let (body, shown) = body_rate(l.wheel_accel_radps2, self.kinematics.wheel_radius_m);
        let yaw_share = base.angular_accel_radps2 * half_track_m;
        c.compare(
            "limits.wheel_accel_radps2",
            body - yaw_share,
            format!(
                "{shown}, less base.angular_accel_radps2 {} rad/s² × kinematics.wheel_separation_m/2 {half_track_m} m \
                 = {:.4} m/s²",
                base.angular_accel_radps2,
                body - yaw_share
            ),
            BaseKey::Accel,
            Relation::AtLeast,
            "the bridge would ramp speed-ups more gently than the filter's window (and its evasion) counts on",
        );
        // The bridge's own clamps above the base's speeds promise what the
        // base cannot do (the filter's are checked against the same keys).
        c.at_most(
            "limits.v_max_mps",
            l.v_max_mps,
            BaseKey::VMax,
            "the bridge would pass forward speeds the base cannot reach",
        );
        c.at_most(
            "limits.omega_max_radps",
            l.omega_max_radps,
            BaseKey::OmegaMax,
            "the bridge would pass yaw rates the base cannot reach",
        );
        c.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::default_config;

    fn base(decel_mps2: f64) -> BaseLimits {
        BaseLimits {
            v_max_mps: 0.22,
            v_reverse_max_mps: 0.22,
            omega_max_radps: 2.84,
            accel_mps2: 2.5,
            decel_mps2,
            angular_accel_radps2: 3.2,
        }
    }

    #[test]
    fn a_softened_decel_ramp_is_refused_naming_both_keys() {
        // By hand: r = 0.033 m, 20 rad/s² at the wheel = 0.66 m/s² < 1.0 m/s².
        let mut cfg = default_config();
        cfg.kinematics.wheel_radius_m = 0.033;
        cfg.limits.wheel_decel_radps2 = 20.0;
        let c = cfg.base_conflicts(&base(1.0));
        assert_eq!(c.len(), 1, "{c:?}");
        assert_eq!(c[0].keys(), ["limits.wheel_decel_radps2", "base.decel_mps2"]);
        assert!((c[0].value - 0.66).abs() < 1e-12, "{}", c[0].value);
        assert_eq!(
            c[0].to_string(),
            "key `limits.wheel_decel_radps2` = 20 rad/s² × kinematics.wheel_radius_m 0.033 m = 0.6600 m/s² \
             is below `base.decel_mps2` = 1 m/s² of the base's limits: \
             the bridge would not brake as fast as the filter's braking check counts on"
        );
        // 31 rad/s² × 0.033 m = 1.023 m/s² ≥ 1.0: agreed; 30 (0.99) is not.
        cfg.limits.wheel_decel_radps2 = 31.0;
        assert!(cfg.base_conflicts(&base(1.0)).is_empty());
        cfg.limits.wheel_decel_radps2 = 30.0;
        assert_eq!(cfg.base_conflicts(&base(1.0)).len(), 1);
        // A bigger wheel brakes the body harder at the same wheel ramp.
        cfg.kinematics.wheel_radius_m = 0.05;
        assert!(cfg.base_conflicts(&base(1.0)).is_empty());
    }

    #[test]
    fn speeds_above_the_base_are_refused() {
        let mut cfg = default_config();
        cfg.limits.v_max_mps = 0.3;
        cfg.limits.omega_max_radps = 3.0;
        let conflicts = cfg.base_conflicts(&base(1.0));
        let keys: Vec<_> = conflicts.iter().map(|c| c.keys()).collect();
        assert_eq!(
            keys,
            [
                ["limits.v_max_mps", "base.v_max_mps"],
                ["limits.omega_max_radps", "base.omega_max_radps"]
            ]
        );
    }

    #[test]
    fn a_gentler_speed_up_ramp_is_refused_naming_both_keys() {
        // By hand: r = 0.033 m, L/2 = 0.08 m. 20 rad/s² × 0.033 = 0.66 m/s²,
        // less 3.2 × 0.08 = 0.256 for a full yaw acceleration: 0.404 m/s² of
        // linear acceleration left, below the base's 2.5.
        let mut cfg = default_config();
        cfg.kinematics.wheel_radius_m = 0.033;
        cfg.kinematics.wheel_separation_m = 0.16;
        cfg.limits.wheel_accel_radps2 = 20.0;
        let c = cfg.base_conflicts(&base(1.0));
        assert_eq!(c.len(), 1, "{c:?}");
        assert_eq!(c[0].keys(), ["limits.wheel_accel_radps2", "base.accel_mps2"]);
        assert!((c[0].value - 0.404).abs() < 1e-12, "{}", c[0].value);
        // (2.5 + 0.256) / 0.033 = 83.52 rad/s²: 84 agrees, 83 does not.
        cfg.limits.wheel_accel_radps2 = 84.0;
        assert!(cfg.base_conflicts(&base(1.0)).is_empty());
        cfg.limits.wheel_accel_radps2 = 83.0;
        assert_eq!(cfg.base_conflicts(&base(1.0)).len(), 1);
        // A wider track needs more of the wheel for the same yaw acceleration.
        cfg.limits.wheel_accel_radps2 = 84.0;
        cfg.kinematics.wheel_separation_m = 0.2;
        assert_eq!(cfg.base_conflicts(&base(1.0)).len(), 1);
    }

    #[test]
    fn the_shipped_bridge_agrees_with_the_shipped_base() {
        let text = include_str!("../../../config/base_limits.yaml");
        let b = oldbf::config::load_base_limits_str(text, "config/base_limits.yaml").unwrap();
        assert_eq!(default_config().base_conflicts(&b), vec![]);
    }
}
