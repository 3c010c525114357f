//! The control loop's period. rosrust's `Rate` sleeps until the next grid
//! point on the ROS clock: after the wall clock steps back by J seconds it
//! sleeps J seconds, and the node goes silent while the robot still moves
//! on its last command. Under wall-clock time this paces on the monotonic
//! clock instead; with `/use_sim_time` it keeps following /clock.

use std::time::{Duration, Instant};

/// Sleeps to the next period boundary.
pub enum Pacer {
    /// Monotonic: a late loop skips to the next boundary, never bursts.
    Monotonic { period: Duration, next: Instant },
    /// Simulated time (/clock).
    Ros(rosrust::api::Rate),
}

impl Pacer {
    /// A pacer at `rate_hz` (positive, checked by the config), choosing the clock as above.
    pub fn new(rate_hz: f64) -> Self {
        let sim_time = rosrust::param("/use_sim_time")
            .and_then(|p| p.get::<bool>().ok())
            .unwrap_or(false);
        if sim_time {
            Self::Ros(rosrust::rate(rate_hz))
        } else {
            Self::monotonic(rate_hz)
        }
    }

    /// A monotonic pacer (no ROS needed).
    pub fn monotonic(rate_hz: f64) -> Self {
        let period = Duration::from_secs_f64(1.0 / rate_hz.clamp(1e-3, 1e6));
        Self::Monotonic {
            period,
            next: Instant::now() + period,
        }
    }

    /// Sleeps until the next boundary.
    pub fn sleep(&mut self) {
        match self {
            Self::Monotonic { period, next } => {
                let now = Instant::now();
                if *next <= now {
                    // Late: the next boundary after now, on the same grid.
                    let late = now - *next;
                    let skip = (late.as_nanos() / period.as_nanos().max(1)) as u32;
                    *next += *period * (skip + 1);
                }
                std::thread::sleep(*next - now);
                *next += *period;
            }
            Self::Ros(rate) => rate.sleep(),
        }
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
