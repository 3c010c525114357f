//! The base's own limits (`config/base_limits.yaml`), one file that the
//! safety filter and the CAN bridge both load, and the typed comparison of a
//! node's own settings against it.
//!
//! Why: the filter's braking check assumes the robot can always brake at
//! `control.decel_mps2`, and its dynamic window assumes the accelerations
//! it is given; the bridge ramps the wheels at its own rates. Two files
//! that nobody compares let a softened bridge ramp silently break the
//! filter's assumption. Each node states its rules against these limits
//! with [`LimitCheck`]; a broken rule is a [`LimitConflict`] that names the
//! node's key and the base's key, and the node refuses to start.
//!
//! The rules themselves live with the settings they are about (the filter's
//! in `algo::params::base`, the bridge's in `can_bridge::config`); this
//! module knows neither ROS nor CAN.

use super::check::{Checker, Validate};
use super::error::ConfigError;
use super::interval::Interval;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::Path;

/// The document: everything under `base:`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct BaseLimitsFile {
    base: BaseLimits,
}

/// What the base can do. Every value is positive: a speed or a rate the
/// base reaches (or, for `decel_mps2`, the braking it is guaranteed to
/// achieve on every commanded slow-down).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BaseLimits {
    /// Largest forward speed (m/s).
    pub v_max_mps: f64,
    /// Largest reverse speed, positive (m/s).
    pub v_reverse_max_mps: f64,
    /// Largest |yaw rate| (rad/s).
    pub omega_max_radps: f64,
    /// Largest linear acceleration (m/s²).
    pub accel_mps2: f64,
    /// The linear deceleration the base achieves on every commanded
    /// slow-down (m/s²): what a braking check may count on.
    pub decel_mps2: f64,
    /// Largest yaw acceleration (rad/s²).
    pub angular_accel_radps2: f64,
}

/// A key of the base-limits file, with its value's unit: the typed name a
/// [`LimitConflict`] carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BaseKey {
    /// `base.v_max_mps`
    VMax,
    /// `base.v_reverse_max_mps`
    VReverseMax,
    /// `base.omega_max_radps`
    OmegaMax,
    /// `base.accel_mps2`
    Accel,
    /// `base.decel_mps2`
    Decel,
    /// `base.angular_accel_radps2`
    AngularAccel,
}

impl BaseKey {
    /// Every key, in file order.
    pub const ALL: [BaseKey; 6] = [
        BaseKey::VMax,
        BaseKey::VReverseMax,
        BaseKey::OmegaMax,
        BaseKey::Accel,
        BaseKey::Decel,
        BaseKey::AngularAccel,
    ];

    /// The dotted key as in the file.
    pub fn key(self) -> &'static str {
        match self {
            BaseKey::VMax => "base.v_max_mps",
            BaseKey::VReverseMax => "base.v_reverse_max_mps",
            BaseKey::OmegaMax => "base.omega_max_radps",
            BaseKey::Accel => "base.accel_mps2",
            BaseKey::Decel => "base.decel_mps2",
            BaseKey::AngularAccel => "base.angular_accel_radps2",
        }
    }

    /// The unit of its value.
    pub fn unit(self) -> &'static str {
        match self {
            BaseKey::VMax | BaseKey::VReverseMax => "m/s",
            BaseKey::OmegaMax => "rad/s",
            BaseKey::Accel | BaseKey::Decel => "m/s²",
            BaseKey::AngularAccel => "rad/s²",
        }
    }

    /// The allowed range of its value: positive, and below what any
    /// wheeled base of this project's size reaches (the filter's own
    /// ranges for the same quantities).
    pub fn range(self) -> Interval {
        match self {
            BaseKey::VMax | BaseKey::VReverseMax => Interval::open_closed(0.0, 20.0),
            BaseKey::OmegaMax => Interval::open_closed(0.0, 50.0),
            BaseKey::Accel | BaseKey::Decel => Interval::open_closed(0.0, 100.0),
            BaseKey::AngularAccel => Interval::open_closed(0.0, 1000.0),
        }
        .unit(self.unit())
    }
}

impl fmt::Display for BaseKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.key())
    }
}

impl BaseLimits {
    /// The value of `key`.
    pub fn get(&self, key: BaseKey) -> f64 {
        match key {
            BaseKey::VMax => self.v_max_mps,
            BaseKey::VReverseMax => self.v_reverse_max_mps,
            BaseKey::OmegaMax => self.omega_max_radps,
            BaseKey::Accel => self.accel_mps2,
            BaseKey::Decel => self.decel_mps2,
            BaseKey::AngularAccel => self.angular_accel_radps2,
        }
    }
}

impl Validate for BaseLimits {
    fn check(&self, c: &mut Checker) {
        for k in BaseKey::ALL {
            c.range(k.key(), self.get(k), k.range());
        }
    }
}

/// How a node's value must relate to the base's.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Relation {
    /// The node's value may not exceed the base's (it must not assume, or
    /// command, more than the base can do).
    AtMost,
    /// The node's value must reach the base's (it must not do less than
    /// what others count on the base doing).
    AtLeast,
}

/// A node setting that contradicts the base's limits: both keys, both
/// values, and why it matters.
#[derive(Debug, Clone, PartialEq)]
pub struct LimitConflict {
    /// The node's own dotted key (`control.decel_mps2`, `limits.wheel_decel_radps2`).
    pub key: String,
    /// The node's value as compared, in the base key's unit.
    pub value: f64,
    /// The node's value as the user wrote it, with any conversion shown
    /// (`20 rad/s² × kinematics.wheel_radius_m 0.033 m = 0.66 m/s²`).
    pub shown: String,
    /// The base's key it contradicts.
    pub base_key: BaseKey,
    /// The base's value.
    pub base_value: f64,
    /// The rule broken.
    pub relation: Relation,
    /// What would go wrong.
    pub why: &'static str,
}

impl fmt::Display for LimitConflict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let side = match self.relation {
            Relation::AtMost => "above",
            Relation::AtLeast => "below",
        };
        write!(
            f,
            "key `{}` = {} is {side} `{}` = {} {} of the base's limits: {}",
            self.key,
            self.shown,
            self.base_key,
            self.base_value,
            self.base_key.unit(),
            self.why
        )
    }
}

impl std::error::Error for LimitConflict {}

impl LimitConflict {
    /// Both keys: the node's, then the base's.
    pub fn keys(&self) -> [&str; 2] {
        [self.key.as_str(), self.base_key.key()]
    }
}

/// Collects a node's conflicts with the base's limits, as [`Checker`] does
/// for ranges.
#[derive(Debug)]
pub struct LimitCheck<'a> {
    base: &'a BaseLimits,
    conflicts: Vec<LimitConflict>,
}

impl<'a> LimitCheck<'a> {
    /// No conflicts yet.
    pub fn new(base: &'a BaseLimits) -> Self {
        Self {
            base,
            conflicts: Vec::new(),
        }
    }

    /// `value` (in `base_key`'s unit) must not exceed the base's. A NaN on
    /// either side is a conflict: it cannot be shown to hold.
    pub fn at_most(&mut self, key: &str, value: f64, base_key: BaseKey, why: &'static str) -> bool {
        let shown = format!("{value} {}", base_key.unit());
        self.compare(key, value, shown, base_key, Relation::AtMost, why)
    }

    /// `value` (in `base_key`'s unit) must reach the base's.
    pub fn at_least(&mut self, key: &str, value: f64, base_key: BaseKey, why: &'static str) -> bool {
        let shown = format!("{value} {}", base_key.unit());
        self.compare(key, value, shown, base_key, Relation::AtLeast, why)
    }

    /// The general form: `value` compared, `shown` as the user wrote it.
    pub fn compare(
        &mut self,
        key: &str,
        value: f64,
        shown: String,
        base_key: BaseKey,
        relation: Relation,
        why: &'static str,
    ) -> bool {
        let base_value = self.base.get(base_key);
        let ok = match relation {
            Relation::AtMost => value <= base_value,
            Relation::AtLeast => value >= base_value,
        };
        if !ok {
            self.conflicts.push(LimitConflict {
                key: key.to_string(),
                value,
                shown,
                base_key,
                base_value,
                relation,
                why,
            });
        }
        ok
    }

    /// Every conflict, in check order.
    pub fn finish(self) -> Vec<LimitConflict> {
        self.conflicts
    }
}

/// The base's limits from YAML text; `file` names it in errors. Unknown
/// keys and out-of-range values are errors naming the key.
pub fn load_base_limits_str(text: &str, file: &str) -> Result<BaseLimits, ConfigError> {
    let doc: BaseLimitsFile = super::yaml::from_value(super::yaml::parse_yaml(text, file)?, file, "")?;
    doc.base.validate().map_err(|e| ConfigError::invalid(file, e))?;
    Ok(doc.base)
}

/// The base's limits from a file.
pub fn load_base_limits_file(path: &Path) -> Result<BaseLimits, ConfigError> {
    load_base_limits_str(&super::yaml::read_file(path)?, &path.display().to_string())
}

/// A node whose settings contradict the base's limits: which source, which
/// base-limits file, and every conflict.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}", ConflictsMessage(self))]
pub struct BaseLimitsConflict {
    /// The node's settings, as named elsewhere (`ROS parameters of /oldbf_node`).
    pub settings: String,
    /// The base-limits file.
    pub base_file: String,
    /// Each conflict, in check order (never empty).
    pub conflicts: Vec<LimitConflict>,
}

impl BaseLimitsConflict {
    /// `Ok` with no conflicts, else the error.
    pub fn check(source: &str, base_file: &str, conflicts: Vec<LimitConflict>) -> Result<(), Self> {
        if conflicts.is_empty() {
            Ok(())
        } else {
            Err(Self {
                settings: source.to_string(),
                base_file: base_file.to_string(),
                conflicts,
            })
        }
    }

    /// Every key named: each conflict's own key, then its base key.
    pub fn keys(&self) -> Vec<&str> {
        self.conflicts.iter().flat_map(|c| c.keys()).collect()
    }
}

struct ConflictsMessage<'a>(&'a BaseLimitsConflict);

impl fmt::Display for ConflictsMessage<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let e = self.0;
        for (i, c) in e.conflicts.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "{}: {c} ({})", e.settings, e.base_file)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const BURGER: &str = "base:\n  v_max_mps: 0.22\n  v_reverse_max_mps: 0.22\n  omega_max_radps: 2.84\n  \
                          accel_mps2: 2.5\n  decel_mps2: 1.0\n  angular_accel_radps2: 3.2\n";

    #[test]
    fn a_good_file_loads() {
        let b = load_base_limits_str(BURGER, "b.yaml").unwrap();
        assert_eq!(b.decel_mps2, 1.0);
        assert_eq!(b.get(BaseKey::AngularAccel), 3.2);
    }

    #[test]
    fn unknown_missing_and_out_of_range_keys_are_named() {
        let e = load_base_limits_str(
            &BURGER.replace("decel_mps2: 1.0", "decel_mps2: 1.0\n  jerk: 3"),
            "b.yaml",
        )
        .unwrap_err();
        assert_eq!(e.keys(), ["base.jerk"], "{e}");
        assert!(e.to_string().contains("unknown field `jerk`"), "{e}");
        let e = load_base_limits_str(&format!("{BURGER}extra: 1\n"), "b.yaml").unwrap_err();
        assert_eq!(e.keys(), ["extra"], "{e}");
        let e = load_base_limits_str(&BURGER.replace("  accel_mps2: 2.5\n", ""), "b.yaml").unwrap_err();
        assert!(e.to_string().contains("missing field `accel_mps2`"), "{e}");
        // Every key, out of range in turn (0 is never a limit), named with its range.
        for k in BaseKey::ALL {
            let name = k.key().trim_start_matches("base.");
            let text: String = BURGER
                .lines()
                .map(|l| {
                    if l.trim_start().starts_with(&format!("{name}:")) {
                        format!("  {name}: 0\n")
                    } else {
                        format!("{l}\n")
                    }
                })
                .collect();
            let e = load_base_limits_str(&text, "b.yaml").unwrap_err();
            assert_eq!(e.keys(), [k.key()], "{e}");
            assert_eq!(
                e.to_string(),
                format!("b.yaml: key `{k}` = 0 is out of range; allowed: {}", k.range())
            );
        }
        let e = load_base_limits_str(&BURGER.replace("2.84", ".nan"), "b.yaml").unwrap_err();
        assert_eq!(e.keys(), ["base.omega_max_radps"]);
    }

    #[test]
    fn a_conflict_names_both_keys_and_both_values() {
        let b = load_base_limits_str(BURGER, "b.yaml").unwrap();
        let mut c = LimitCheck::new(&b);
        assert!(c.at_most("control.decel_mps2", 1.0, BaseKey::Decel, "braking"));
        assert!(!c.at_most("control.decel_mps2", 1.5, BaseKey::Decel, "braking the base cannot do"));
        assert!(c.at_least("x", 2.5, BaseKey::Accel, "w"));
        assert!(!c.at_least("x", 2.4, BaseKey::Accel, "w"));
        assert!(!c.at_most("y", f64::NAN, BaseKey::VMax, "w"), "NaN never holds");
        let conflicts = c.finish();
        assert_eq!(conflicts.len(), 3);
        assert_eq!(conflicts[0].keys(), ["control.decel_mps2", "base.decel_mps2"]);
        assert_eq!(
            conflicts[0].to_string(),
            "key `control.decel_mps2` = 1.5 m/s² is above `base.decel_mps2` = 1 m/s² of the base's limits: \
             braking the base cannot do"
        );
        assert_eq!(conflicts[1].relation, Relation::AtLeast);
        assert!(conflicts[1]
            .to_string()
            .contains("is below `base.accel_mps2` = 2.5 m/s²"));
        let e = BaseLimitsConflict::check("P", "b.yaml", conflicts).unwrap_err();
        assert_eq!(
            e.keys(),
            [
                "control.decel_mps2",
                "base.decel_mps2",
                "x",
                "base.accel_mps2",
                "y",
                "base.v_max_mps"
            ]
        );
        let lines: Vec<_> = e.to_string().lines().map(String::from).collect();
        assert_eq!(lines.len(), 3);
        assert!(
            lines[0].starts_with("P: key `control.decel_mps2` = 1.5 m/s²"),
            "{}",
            lines[0]
        );
        assert!(lines[0].ends_with("(b.yaml)"), "{}", lines[0]);
        assert_eq!(BaseLimitsConflict::check("P", "b.yaml", vec![]), Ok(()));
    }
}
