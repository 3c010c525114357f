//! Collecting every violated rule of a configuration, not just the first.

use super::interval::Interval;
use super::param_error::{Allowed, ParamError};
use std::fmt;

/// Collects every failed check, in the order checked. Keys are borrowed and
/// copied only for a failure, so checking a valid configuration allocates
/// nothing.
#[derive(Debug, Default)]
pub struct Checker {
    errors: Vec<ParamError>,
}

impl Checker {
    /// No errors yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// `v` must be finite and in `allowed`; returns whether it is. Integers
    /// convert losslessly (`u32`, `i32`, `u16`…); the value is printed as the
    /// `f64` it became (`128`, `0.5`, `NaN`).
    pub fn range(&mut self, key: &str, v: impl Into<f64>, allowed: Interval) -> bool {
        let v = v.into();
        self.rule(allowed.contains(v), key, v, allowed)
    }

    /// `v` may not exceed another key's value `limit`, e.g. `at most
    /// control.v_max_mps`. NaN passes: its own range check reports it.
    pub fn at_most(&mut self, key: &str, v: f64, limit: f64, allowed: impl Into<Allowed>) -> bool {
        self.rule(v <= limit || v.is_nan(), key, v, allowed)
    }

    /// Any rule: records `key` = `value` with `allowed` unless `ok`; returns `ok`.
    pub fn rule(&mut self, ok: bool, key: &str, value: impl fmt::Display, allowed: impl Into<Allowed>) -> bool {
        if !ok {
            self.errors.push(ParamError::new(key, value, allowed));
        }
        ok
    }

    /// Records an error found elsewhere (a section's own check).
    pub fn push(&mut self, e: ParamError) {
        self.errors.push(e);
    }

    /// The errors so far.
    pub fn errors(&self) -> &[ParamError] {
        &self.errors
    }

    /// No error so far.
    pub fn is_ok(&self) -> bool {
        self.errors.is_empty()
    }

    /// `Ok` when every check passed, else every error in check order.
    pub fn finish(self) -> Result<(), Vec<ParamError>> {
        if self.errors.is_empty() {
            Ok(())
        } else {
            Err(self.errors)
        }
    }
}

/// A configuration that knows its allowed values.
pub trait Validate {
    /// Adds every violated rule to `c`, keys as in the file.
    fn check(&self, c: &mut Checker);

    /// Every violation, each naming its key; `Ok` when there is none.
    fn validate(&self) -> Result<(), Vec<ParamError>> {
        let mut c = Checker::new();
        self.check(&mut c);
        c.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const UNIT: Interval = Interval::open_closed(0.0, 1.0);

    #[test]
    fn collects_every_failure_in_order() {
        let mut c = Checker::new();
        assert!(!c.range("a", 0.0, UNIT));
        assert!(c.range("b", 1.0, UNIT));
        assert!(!c.range("c", 1.0, Interval::closed_open(0.0, 1.0)));
        assert!(!c.range("d", f64::INFINITY, Interval::closed(0.0, 1e12)));
        assert!(!c.range("e", f64::NAN, UNIT));
        let keys: Vec<_> = c.errors().iter().map(|e| e.key.as_str()).collect();
        assert_eq!(keys, ["a", "c", "d", "e"]);
        let e = c.finish().unwrap_err();
        assert_eq!(e[3].value, "NaN");
        assert_eq!(e[0].allowed, Allowed::Interval(UNIT));
    }

    #[test]
    fn integers_are_checked_and_printed_as_integers() {
        let mut c = Checker::new();
        assert!(c.range("id", 127u32, Interval::closed(1.0, 127.0)));
        assert!(!c.range("id", 128u32, Interval::closed(1.0, 127.0)));
        assert!(!c.range("dir", -2i32, Interval::closed(-1.0, 1.0)));
        let e = c.finish().unwrap_err();
        assert_eq!(e[0].to_string(), "key `id` = 128 is out of range; allowed: [1, 127]");
        assert_eq!(e[1].value, "-2");
    }

    #[test]
    fn at_most_leaves_nan_to_the_range_check() {
        let mut c = Checker::new();
        assert!(c.at_most("v", 0.2, 0.22, "at most v_max"));
        assert!(c.at_most("v", 0.22, 0.22, "at most v_max"));
        assert!(c.at_most("v", f64::NAN, 0.22, "at most v_max"));
        assert!(!c.at_most("v", 0.3, 0.22, "at most v_max"));
        assert!(
            !c.at_most("v", 0.1, f64::NAN, "at most v_max"),
            "a NaN limit admits nothing"
        );
        assert_eq!(c.errors().len(), 2);
        assert_eq!(
            c.errors()[0].to_string(),
            "key `v` = 0.3 is out of range; allowed: at most v_max"
        );
    }

    #[test]
    fn rules_in_words_and_pushed_errors() {
        let mut c = Checker::new();
        assert!(c.rule(true, "k", 1, "anything"));
        assert!(!c.rule(false, "interface", format_args!("{:?}", "can 0"), "no whitespace"));
        c.push(ParamError::new("world.walls[2]", "(0, 0)", "non-zero length"));
        let e = c.finish().unwrap_err();
        assert_eq!(
            e[0].to_string(),
            "key `interface` = \"can 0\" is out of range; allowed: no whitespace"
        );
        assert_eq!(e[1].key, "world.walls[2]");
    }

    struct Pair {
        lo: f64,
        hi: f64,
    }

    impl Validate for Pair {
        fn check(&self, c: &mut Checker) {
            c.range("lo", self.lo, UNIT);
            c.at_most("lo", self.lo, self.hi, "at most hi");
            c.range("hi", self.hi, UNIT);
        }
    }

    #[test]
    fn validate_is_ok_only_without_errors() {
        assert_eq!(Pair { lo: 0.5, hi: 1.0 }.validate(), Ok(()));
        let e = Pair { lo: 0.9, hi: 0.5 }.validate().unwrap_err();
        assert_eq!(e.len(), 1);
        assert_eq!(e[0].allowed.to_string(), "at most hi");
        let e = Pair { lo: 0.0, hi: 2.0 }.validate().unwrap_err();
        let keys: Vec<_> = e.iter().map(|e| e.key.as_str()).collect();
        assert_eq!(keys, ["lo", "hi"]);
    }
}
