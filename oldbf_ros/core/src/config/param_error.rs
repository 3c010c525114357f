//! One value that breaks its rule, with the key, the value and the rule as data.

use super::interval::Interval;
use std::borrow::Cow;
use std::fmt;

/// What a key allows: shown after `allowed:` in a message, and readable by
/// programs (a dynamic_reconfigure server takes its slider range from
/// [`Allowed::interval`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Allowed {
    /// A numeric interval: what was checked, and what the message shows.
    Interval(Interval),
    /// A rule in words: `-1 or 1`, `different from odrive.left_node_id`.
    Rule(Cow<'static, str>),
    /// A rule in words on a value that is also bounded: shown as
    /// `{rule}, in {interval}` (`odd, in [3, 201]`).
    RuleIn {
        /// The rule beyond the interval.
        rule: Cow<'static, str>,
        /// The interval the value must also be in.
        interval: Interval,
    },
}

impl Allowed {
    /// A rule in words on a value that must also lie in `interval`.
    pub fn rule_in(rule: impl Into<Cow<'static, str>>, interval: Interval) -> Self {
        Allowed::RuleIn {
            rule: rule.into(),
            interval,
        }
    }

    /// The interval the value must lie in, when the rule has one.
    pub fn interval(&self) -> Option<Interval> {
        match self {
            Allowed::Interval(i) | Allowed::RuleIn { interval: i, .. } => Some(*i),
            Allowed::Rule(_) => None,
        }
    }
}

impl fmt::Display for Allowed {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Allowed::Interval(i) => write!(f, "{i}"),
            Allowed::Rule(r) => f.write_str(r),
            Allowed::RuleIn { rule, interval } => write!(f, "{rule}, in {interval}"),
        }
    }
}

impl From<Interval> for Allowed {
    fn from(i: Interval) -> Self {
        Allowed::Interval(i)
    }
}

impl From<&'static str> for Allowed {
    fn from(rule: &'static str) -> Self {
        Allowed::Rule(Cow::Borrowed(rule))
    }
}

impl From<String> for Allowed {
    fn from(rule: String) -> Self {
        Allowed::Rule(Cow::Owned(rule))
    }
}

/// A value outside what its key allows.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("key `{key}` = {value} is out of range; allowed: {allowed}")]
pub struct ParamError {
    /// Dotted key, as in the file: `barrier.d_safe_m`, `world.boxes[0].size_m`.
    pub key: String,
    /// The offending value, printed (`NaN`, `0`, `"can 0"`).
    pub value: String,
    /// What the key allows.
    pub allowed: Allowed,
}

impl ParamError {
    /// `key` = `value` breaks `allowed`.
    pub fn new(key: impl Into<String>, value: impl fmt::Display, allowed: impl Into<Allowed>) -> Self {
        Self {
            key: key.into(),
            value: value.to_string(),
            allowed: allowed.into(),
        }
    }

    /// The same error with its key inside `section` (`oldbf` + `dtcbf.gamma`
    /// = `oldbf.dtcbf.gamma`): for a section checked on its own and then
    /// reported as part of a larger file.
    pub fn in_section(mut self, section: &str) -> Self {
        self.key = super::join_key(section, &self.key);
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn message_names_key_value_and_rule() {
        let e = ParamError::new("dtcbf.gamma", 0.0, Interval::open_closed(0.0, 1.0));
        assert_eq!(e.to_string(), "key `dtcbf.gamma` = 0 is out of range; allowed: (0, 1]");
        let e = ParamError::new("kinematics.left_direction", 0, "-1 or 1");
        assert_eq!(
            e.to_string(),
            "key `kinematics.left_direction` = 0 is out of range; allowed: -1 or 1"
        );
        let e = ParamError::new(
            "dtcbf.omega_candidates",
            20,
            Allowed::rule_in("odd", Interval::closed(3.0, 201.0)),
        );
        assert_eq!(
            e.to_string(),
            "key `dtcbf.omega_candidates` = 20 is out of range; allowed: odd, in [3, 201]"
        );
    }

    #[test]
    fn the_interval_is_data() {
        let i = Interval::closed(3.0, 201.0);
        assert_eq!(Allowed::from(i).interval(), Some(i));
        assert_eq!(Allowed::rule_in("odd", i).interval(), Some(i));
        assert_eq!(Allowed::from("-1 or 1").interval(), None);
        assert_eq!(Allowed::from(format!("at most {}", 3)).to_string(), "at most 3");
    }

    #[test]
    fn a_section_prefixes_the_key() {
        let e = ParamError::new("dtcbf.gamma", 0, Interval::open_closed(0.0, 1.0)).in_section("oldbf");
        assert_eq!(e.key, "oldbf.dtcbf.gamma");
        let e = ParamError::new("gamma", 0, "x").in_section("");
        assert_eq!(e.key, "gamma");
    }
}
