//! The watchdog loop's period, on the monotonic clock. rosrust's `Rate`
//! sleeps until the next grid point on the ROS clock: after the wall clock
//! steps back by J seconds it sleeps J seconds, and under `/use_sim_time` it
//! sleeps until /clock advances, so a node whose simulator has stopped
//! cannot even see Ctrl-C. The watchdog polls on this clock and decides on
//! the ROS one ([`crate::node_core::NodeCore::watchdog_due`]).

use std::time::{Duration, Instant};

/// Sleeps to the next period boundary; a late loop skips to the next
/// boundary, never bursts.
pub struct Pacer {
    period: Duration,
    next: Instant,
}

impl Pacer {
    /// A pacer at `rate_hz` (clamped to [1e-3, 1e6] Hz).
    pub fn monotonic(rate_hz: f64) -> Self {
        let period = Duration::from_secs_f64(1.0 / rate_hz.clamp(1e-3, 1e6));
        Self {
            period,
            next: Instant::now() + period,
        }
    }

    /// Sleeps until the next boundary.
    pub fn sleep(&mut self) {
        let now = Instant::now();
        if self.next <= now {
            // Late: the next boundary after now, on the same grid.
            let late = now - self.next;
            let skip = (late.as_nanos() / self.period.as_nanos().max(1)) as u32;
            self.next += self.period * (skip + 1);
        }
        std::thread::sleep(self.next - now);
        self.next += self.period;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn monotonic_pacer_keeps_its_period_and_skips_when_late() {
        let mut p = Pacer::monotonic(100.0);
        let t0 = Instant::now();
        for _ in 0..5 {
            p.sleep();
        }
        // Five periods of 10 ms: at least 40 ms (the first boundary is one period out).
        assert!(t0.elapsed() >= Duration::from_millis(40), "{:?}", t0.elapsed());
        // A stall of 55 ms: the next sleep ends on the grid, not 5 times in a burst.
        std::thread::sleep(Duration::from_millis(55));
        let t1 = Instant::now();
        p.sleep();
        p.sleep();
        assert!(t1.elapsed() >= Duration::from_millis(10), "burst: {:?}", t1.elapsed());
    }
}
