//! Typed intervals: the allowed range of a numeric key, checked and shown
//! from one constant.

use std::fmt;

/// A numeric interval with open or closed ends and an optional unit,
/// written as in the messages: `[0, 10] m`, `(0, 1000] Hz`, `(0, 1]`.
///
/// Built in `const` context, so the ranges of a configuration are constants
/// and never parsed from text:
///
/// ```
/// use oldbf::config::Interval;
/// const RATE: Interval = Interval::open_closed(0.0, 1000.0).unit("Hz");
/// assert_eq!(RATE.to_string(), "(0, 1000] Hz");
/// assert!(RATE.contains(50.0) && !RATE.contains(0.0) && !RATE.contains(f64::NAN));
/// ```
///
/// An interval whose `lo` exceeds its `hi` contains nothing (every value is
/// rejected, loudly), rather than panicking.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval {
    /// Lower bound.
    pub lo: f64,
    /// Upper bound.
    pub hi: f64,
    /// `lo` itself is excluded: `(`.
    pub lo_open: bool,
    /// `hi` itself is excluded: `)`.
    pub hi_open: bool,
    /// Unit shown after the interval (`m`, `rad/s²`); empty for none.
    pub unit: &'static str,
}

impl Interval {
    /// `[lo, hi]`.
    pub const fn closed(lo: f64, hi: f64) -> Self {
        Self::new(lo, false, hi, false)
    }

    /// `(lo, hi)`.
    pub const fn open(lo: f64, hi: f64) -> Self {
        Self::new(lo, true, hi, true)
    }

    /// `(lo, hi]`: the usual range of a rate, a timeout or a length.
    pub const fn open_closed(lo: f64, hi: f64) -> Self {
        Self::new(lo, true, hi, false)
    }

    /// `[lo, hi)`.
    pub const fn closed_open(lo: f64, hi: f64) -> Self {
        Self::new(lo, false, hi, true)
    }

    const fn new(lo: f64, lo_open: bool, hi: f64, hi_open: bool) -> Self {
        Self {
            lo,
            hi,
            lo_open,
            hi_open,
            unit: "",
        }
    }

    /// The same interval with a unit (shown after it: `[0, 10] m`).
    pub const fn unit(mut self, unit: &'static str) -> Self {
        self.unit = unit;
        self
    }

    /// `v` is finite and within the bounds. NaN and ±inf are never
    /// contained, whatever the bounds: a configuration value must be a number.
    pub fn contains(&self, v: f64) -> bool {
        let above = if self.lo_open { v > self.lo } else { v >= self.lo };
        let below = if self.hi_open { v < self.hi } else { v <= self.hi };
        v.is_finite() && above && below
    }
}

/// A bound as written in the messages: `{}` of the number, but in exponent
/// form from 1e9 on (`1e12`, not `1000000000000`), as people write such limits.
struct Bound(f64);

impl fmt::Display for Bound {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.0.is_finite() && self.0.abs() >= 1e9 {
            write!(f, "{:e}", self.0)
        } else {
            write!(f, "{}", self.0)
        }
    }
}

impl fmt::Display for Interval {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let open = if self.lo_open { '(' } else { '[' };
        let close = if self.hi_open { ')' } else { ']' };
        write!(f, "{open}{}, {}{close}", Bound(self.lo), Bound(self.hi))?;
        if !self.unit.is_empty() {
            write!(f, " {}", self.unit)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ends_are_open_or_closed_as_written() {
        let c = Interval::closed(0.0, 1.0);
        assert!(c.contains(0.0) && c.contains(1.0) && c.contains(0.5));
        assert!(!c.contains(-1e-12) && !c.contains(1.0 + 1e-12));
        let o = Interval::open(0.0, 1.0);
        assert!(!o.contains(0.0) && !o.contains(1.0) && o.contains(1e-12));
        let oc = Interval::open_closed(0.0, 1.0);
        assert!(!oc.contains(0.0) && oc.contains(1.0));
        let co = Interval::closed_open(0.0, 1.0);
        assert!(co.contains(0.0) && !co.contains(1.0));
    }

    #[test]
    fn non_finite_values_are_never_contained() {
        let all = Interval::closed(f64::NEG_INFINITY, f64::INFINITY);
        assert!(all.contains(0.0));
        for v in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            assert!(!all.contains(v), "{v}");
        }
    }

    #[test]
    fn an_inverted_interval_contains_nothing() {
        let bad = Interval::closed(1.0, 0.0);
        assert!(!bad.contains(0.5) && !bad.contains(0.0) && !bad.contains(1.0));
    }

    #[test]
    fn shown_as_in_the_messages() {
        assert_eq!(Interval::closed(0.0, 10.0).unit("m").to_string(), "[0, 10] m");
        assert_eq!(Interval::open_closed(0.0, 1.0).to_string(), "(0, 1]");
        assert_eq!(Interval::closed_open(-5.0, 0.5).to_string(), "[-5, 0.5)");
        assert_eq!(Interval::open(1.0, 1e12).to_string(), "(1, 1e12)");
        assert_eq!(Interval::open_closed(0.0, 1e9).to_string(), "(0, 1e9]");
        assert_eq!(Interval::closed(1.0, 16_777_216.0).to_string(), "[1, 16777216]");
        assert_eq!(
            Interval::open_closed(0.0, 1e6).unit("rad/s²").to_string(),
            "(0, 1000000] rad/s²"
        );
        assert_eq!(Interval::closed(-100.0, 100.0).unit("Nm").to_string(), "[-100, 100] Nm");
    }

    #[test]
    fn const_constructible() {
        const R: Interval = Interval::open_closed(0.0, 60.0).unit("s");
        assert_eq!(
            (R.lo, R.hi, R.lo_open, R.hi_open, R.unit),
            (0.0, 60.0, true, false, "s")
        );
    }
}
