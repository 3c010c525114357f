//! The filter's settings against the base's own limits
//! (`config/base_limits.yaml`, [`crate::config::BaseLimits`]): the speeds,
//! rates, accelerations and the braking the filter assumes may not exceed
//! what the base can do.

use super::Params;
use crate::config::{BaseKey, BaseLimits, LimitCheck, LimitConflict};

impl Params {
    /// Every setting of the filter that assumes more than the base can do,
    /// each naming its own key and the base's. Empty: they agree.
    pub fn base_conflicts(&self, base: &BaseLimits) -> Vec<LimitConflict> {
        let ctl = &self.control;
        let pa = &self.passive;
        let mut c = LimitCheck::new(base);
        // Commands beyond the base's speeds are not followed: the filter
        // would reason about motion the robot does not make.
        c.at_most(
            "control.v_max_mps",
            ctl.v_max_mps,
            BaseKey::VMax,
            "the filter would command a forward speed the base cannot reach",
        );
        c.at_most(
            "control.v_reverse_max_mps",
            ctl.v_reverse_max_mps,
            BaseKey::VReverseMax,
            "the filter would command a reverse speed the base cannot reach",
        );
        c.at_most(
            "control.omega_max_radps",
            ctl.omega_max_radps,
            BaseKey::OmegaMax,
            "the filter would command a yaw rate the base cannot reach",
        );
        // The dynamic window (§5c) takes every command in it as reachable
        // within a step; beyond the base's accelerations it is not.
        c.at_most(
            "control.accel_mps2",
            ctl.accel_mps2,
            BaseKey::Accel,
            "the dynamic window would count on acceleration the base cannot do",
        );
        c.at_most(
            "passive.evasion_accel_mps2",
            pa.evasion_accel_mps2,
            BaseKey::Accel,
            "evasion would count on acceleration the base cannot do",
        );
        c.at_most(
            "control.angular_accel_radps2",
            ctl.angular_accel_radps2,
            BaseKey::AngularAccel,
            "the dynamic window would count on yaw acceleration the base cannot do",
        );
        c.at_most(
            "passive.evasion_angular_accel_radps2",
            pa.evasion_angular_accel_radps2,
            BaseKey::AngularAccel,
            "evasion would count on yaw acceleration the base cannot do",
        );
        // The braking check (§5b) passes a command only if the robot can
        // brake to rest at control.decel_mps2 clear of everything: above the
        // base's guaranteed deceleration it would pass commands that crash.
        c.at_most(
            "control.decel_mps2",
            ctl.decel_mps2,
            BaseKey::Decel,
            "the braking check would assume braking the base cannot do",
        );
        c.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn burger() -> BaseLimits {
        BaseLimits {
            v_max_mps: 0.22,
            v_reverse_max_mps: 0.22,
            omega_max_radps: 2.84,
            accel_mps2: 2.5,
            decel_mps2: 1.0,
            angular_accel_radps2: 3.2,
        }
    }

    #[test]
    fn the_defaults_agree_with_the_burger() {
        assert_eq!(Params::default().base_conflicts(&burger()), vec![]);
    }

    /// The filter's key, the base's key, and a change that puts the first above the second.
    type Case = (&'static str, BaseKey, fn(&mut Params));

    #[test]
    fn each_filter_setting_above_the_base_is_named_with_the_base_key() {
        let cases: [Case; 8] = [
            ("control.v_max_mps", BaseKey::VMax, |p| p.control.v_max_mps = 0.3),
            ("control.v_reverse_max_mps", BaseKey::VReverseMax, |p| {
                p.control.v_reverse_max_mps = 0.25
            }),
            ("control.omega_max_radps", BaseKey::OmegaMax, |p| {
                p.control.omega_max_radps = 3.0
            }),
            ("control.accel_mps2", BaseKey::Accel, |p| p.control.accel_mps2 = 2.6),
            ("passive.evasion_accel_mps2", BaseKey::Accel, |p| {
                p.passive.evasion_accel_mps2 = 2.6
            }),
            ("control.angular_accel_radps2", BaseKey::AngularAccel, |p| {
                p.control.angular_accel_radps2 = 3.3
            }),
            ("passive.evasion_angular_accel_radps2", BaseKey::AngularAccel, |p| {
                p.passive.evasion_angular_accel_radps2 = 3.3
            }),
            ("control.decel_mps2", BaseKey::Decel, |p| p.control.decel_mps2 = 1.5),
        ];
        for (key, base_key, set) in cases {
            let mut p = Params::default();
            set(&mut p);
            let c = p.base_conflicts(&burger());
            assert_eq!(c.len(), 1, "{key}: {c:?}");
            assert_eq!(c[0].keys(), [key, base_key.key()]);
        }
        // The braking check's assumption, by hand: 1.5 m/s² > the base's 1.0.
        let mut p = Params::default();
        p.control.decel_mps2 = 1.5;
        assert_eq!(
            p.base_conflicts(&burger())[0].to_string(),
            "key `control.decel_mps2` = 1.5 m/s² is above `base.decel_mps2` = 1 m/s² of the base's limits: \
             the braking check would assume braking the base cannot do"
        );
        // Equal is agreement.
        p.control.decel_mps2 = 1.0;
        assert!(p.base_conflicts(&burger()).is_empty());
    }
}
