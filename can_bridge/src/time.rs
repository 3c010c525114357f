//! Time as an injected quantity.
//!
//! The state machine never reads a clock itself: every entry point takes
//! `now`. That makes the watchdog, timeouts and ramps testable in
//! microseconds with a [`ManualClock`], and the real loop uses
//! [`MonotonicClock`] (never wall-clock time, which can jump).

use oldbf::config::Interval;
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
        // +inf is not a time: the epoch, where `saturating_duration` would give 1e9 s.
        if s.is_finite() {
            Timestamp(saturating_duration(s))
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

/// Longest duration a command-line flag may ask for (s): about 11.6 days.
pub const MAX_CLI_SECONDS: f64 = 1e6;

/// `s` seconds as a [`Duration`], clamped to [0, 1e9] s; NaN gives zero.
/// `Duration::from_secs_f64` panics on NaN, negative or huge values.
pub fn saturating_duration(s: f64) -> Duration {
    if s.is_nan() {
        return Duration::ZERO;
    }
    Duration::from_secs_f64(s.clamp(0.0, 1e9))
}

/// The range of a command-line duration.
pub const CLI_SECONDS: Interval = Interval::closed(0.0, MAX_CLI_SECONDS).unit("s");
/// The range of a non-zero command-line rate (0 means off).
pub const CLI_RATE_HZ: Interval = Interval::closed(1e-3, 1e4).unit("Hz");

/// A command-line duration or rate that cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CliValueError {
    /// Not a number at all.
    #[error("`{text}` is not a {what}")]
    NotANumber {
        /// What was given.
        text: String,
        /// `number of seconds` or `rate in Hz`.
        what: &'static str,
    },
    /// A duration outside [`CLI_SECONDS`].
    #[error("{0} s is out of range; allowed: {CLI_SECONDS}")]
    Seconds(f64),
    /// A rate outside [`CLI_RATE_HZ`] and not 0.
    #[error("{0} Hz is out of range; allowed: 0 (off) or {CLI_RATE_HZ}")]
    Rate(f64),
}

/// Parses a command-line duration (s): a finite number in [`CLI_SECONDS`].
pub fn parse_cli_seconds(text: &str) -> Result<f64, CliValueError> {
    let s: f64 = text.trim().parse().map_err(|_| CliValueError::NotANumber {
        text: text.to_string(),
        what: "number of seconds",
    })?;
    if CLI_SECONDS.contains(s) {
        Ok(s)
    } else {
        Err(CliValueError::Seconds(s))
    }
}

/// Parses a command-line rate (Hz): 0 (off) or a finite number in [`CLI_RATE_HZ`].
pub fn parse_cli_rate_hz(text: &str) -> Result<f64, CliValueError> {
    let hz: f64 = text.trim().parse().map_err(|_| CliValueError::NotANumber {
        text: text.to_string(),
        what: "rate in Hz",
    })?;
    if hz == 0.0 || CLI_RATE_HZ.contains(hz) {
        Ok(hz)
    } else {
        Err(CliValueError::Rate(hz))
    }
}

#[cfg(test)]
mod tests {

    #[test]
    fn command_line_durations_and_rates_are_checked_not_panicking() {
        assert_eq!(super::parse_cli_seconds("2.5"), Ok(2.5));
        assert_eq!(super::parse_cli_seconds("0"), Ok(0.0));
        for bad in ["-1", "NaN", "inf", "1e300", "abc"] {
            assert!(super::parse_cli_seconds(bad).is_err(), "{bad}");
        }
        assert_eq!(super::parse_cli_rate_hz("0"), Ok(0.0));
        assert_eq!(super::parse_cli_rate_hz("10"), Ok(10.0));
        for bad in ["1e-300", "-5", "NaN", "inf", "1e9"] {
            assert!(super::parse_cli_rate_hz(bad).is_err(), "{bad}");
        }
        assert_eq!(super::saturating_duration(f64::NAN), Duration::ZERO);
        assert_eq!(super::saturating_duration(-3.0), Duration::ZERO);
        assert_eq!(super::saturating_duration(1e300), Duration::from_secs(1_000_000_000));
        assert_eq!(super::saturating_duration(0.25), Duration::from_millis(250));
        assert_eq!(
            super::parse_cli_seconds("-1").unwrap_err().to_string(),
            "-1 s is out of range; allowed: [0, 1000000] s"
        );
        assert_eq!(
            super::parse_cli_rate_hz("1e9").unwrap_err().to_string(),
            "1000000000 Hz is out of range; allowed: 0 (off) or [0.001, 10000] Hz"
        );
        assert_eq!(
            super::parse_cli_seconds("abc").unwrap_err().to_string(),
            "`abc` is not a number of seconds"
        );
    }
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
