//! The bridge's settings against the base's own limits
//! (`config/base_limits.yaml`, [`oldbf::config::BaseLimits`]), the file the
//! safety filter checks its own settings against too.
//!
//! The filter's braking check counts on the base braking at
//! `base.decel_mps2` (its own `control.decel_mps2` may not exceed it); the
//! bridge ramps every commanded slow-down at `limits.wheel_decel_radps2` at
//! the wheel, so that ramp, in body terms, may not be gentler.

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

    /// Disagreements that do not stop the node, to be logged: an
    /// acceleration ramp gentler than the base's. It breaks no braking
    /// assumption (a robot that speeds up more slowly is slower than the
    /// filter thinks), but an evasion planned at up to `base.accel_mps2`
    /// (the filter's `passive.evasion_accel_mps2`) gets less than planned.
    pub fn base_notes(&self, base: &BaseLimits) -> Vec<LimitConflict> {
        let l = &self.limits;
        let mut c = LimitCheck::new(base);
        let (body, shown) = body_rate(l.wheel_accel_radps2, self.kinematics.wheel_radius_m);
        c.compare(
            "limits.wheel_accel_radps2",
            body,
            shown,
            BaseKey::Accel,
            Relation::AtLeast,
            "the bridge ramps speed-ups more gently than the base can: evasion gets less acceleration than planned",
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
    fn the_shipped_bridge_agrees_with_the_shipped_base() {
        let text = include_str!("../../../config/base_limits.yaml");
        let b = oldbf::config::load_base_limits_str(text, "config/base_limits.yaml").unwrap();
        assert_eq!(default_config().base_conflicts(&b), vec![]);
        // The shipped accel ramp (20 rad/s² × 0.033 m = 0.66 m/s²) is gentler
        // than the burger's 2.5 m/s²: a note, not a refusal.
        let notes = default_config().base_notes(&b);
        assert_eq!(notes.len(), 1);
        assert_eq!(notes[0].keys(), ["limits.wheel_accel_radps2", "base.accel_mps2"]);
    }
}
