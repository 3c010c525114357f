//! Time as an injected quantity.
//!
//! The state machine never reads a clock itself: every entry point takes
//! `now`. That makes the watchdog, timeouts and ramps testable in
//! microseconds with a [`ManualClock`], and the real loop uses
//! [`MonotonicClock`] (never wall-clock time, which can jump).

use std::cell::Cell;
use std::ops::{Add, Sub};
use std::time::{Duration, Instant};

/// A point on a monotonic time line, as the time elapsed since the clock's
/// epoch (the start of the process for [`MonotonicClock`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Timestamp(Duration);

impl Timestamp {
    /// The epoch.
    pub const ZERO: Timestamp = Timestamp(Duration::ZERO);

    /// `s` seconds after the epoch; negative or non-finite values give the epoch.
    pub fn from_secs_f64(s: f64) -> Self {
        if s.is_finite() && s > 0.0 {
            Timestamp(Duration::from_secs_f64(s.min(1e9)))
        } else {
            Timestamp::ZERO
        }
    }

    /// Seconds since the epoch.
    pub fn as_secs_f64(self) -> f64 {
        self.0.as_secs_f64()
    }

    /// Time since the epoch.
    pub fn since_epoch(self) -> Duration {
        self.0
    }

    /// `self − earlier`, or zero when `earlier` is later (never panics).
    pub fn saturating_since(self, earlier: Timestamp) -> Duration {
        self.0.saturating_sub(earlier.0)
    }
}

impl Add<Duration> for Timestamp {
    type Output = Timestamp;
    fn add(self, d: Duration) -> Timestamp {
        Timestamp(self.0.saturating_add(d))
    }
}

impl Sub<Timestamp> for Timestamp {
    type Output = Duration;
    /// Saturating difference: a clock read out of order gives zero, not a panic.
    fn sub(self, earlier: Timestamp) -> Duration {
        self.saturating_since(earlier)
    }
}

/// A source of `now`.
pub trait Clock {
    /// The current time.
    fn now(&self) -> Timestamp;
}

/// The process's monotonic clock (`std::time::Instant`).
#[derive(Clone, Copy, Debug)]
pub struct MonotonicClock {
    epoch: Instant,
}

impl MonotonicClock {
    /// A clock whose epoch is now.
    pub fn new() -> Self {
        Self { epoch: Instant::now() }
    }

    /// A clock whose epoch is `epoch` (share one epoch between threads so
    /// their timestamps compare).
    pub fn with_epoch(epoch: Instant) -> Self {
        Self { epoch }
    }
}

impl Default for MonotonicClock {
    fn default() -> Self {
        Self::new()
    }
}

impl Clock for MonotonicClock {
    fn now(&self) -> Timestamp {
        Timestamp(self.epoch.elapsed())
    }
}

/// A clock that only moves when told to (tests).
#[derive(Debug, Default)]
pub struct ManualClock {
    now: Cell<Timestamp>,
}

impl ManualClock {
    /// A clock at `t`.
    pub fn at(t: Timestamp) -> Self {
        Self { now: Cell::new(t) }
    }

    /// Moves the clock forward by `d`.
    pub fn advance(&self, d: Duration) {
        self.now.set(self.now.get() + d);
    }

    /// Sets the clock (may move it backwards, to test robustness).
    pub fn set(&self, t: Timestamp) {
        self.now.set(t);
    }
}

impl Clock for ManualClock {
    fn now(&self) -> Timestamp {
        self.now.get()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn saturating_difference_never_panics() {
        let a = Timestamp::from_secs_f64(1.0);
        let b = Timestamp::from_secs_f64(2.5);
        assert_eq!(b - a, Duration::from_millis(1500));
        assert_eq!(a - b, Duration::ZERO);
    }

    #[test]
    fn bad_seconds_give_the_epoch() {
        assert_eq!(Timestamp::from_secs_f64(f64::NAN), Timestamp::ZERO);
        assert_eq!(Timestamp::from_secs_f64(-3.0), Timestamp::ZERO);
        assert_eq!(Timestamp::from_secs_f64(0.25).as_secs_f64(), 0.25);
    }

    #[test]
    fn manual_clock_moves_only_when_told() {
        let c = ManualClock::at(Timestamp::from_secs_f64(1.0));
        assert_eq!(c.now().as_secs_f64(), 1.0);
        c.advance(Duration::from_micros(10));
        assert_eq!(c.now().since_epoch(), Duration::from_micros(1_000_010));
    }
}
