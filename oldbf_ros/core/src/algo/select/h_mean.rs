//! h averaged over recent steps (ALGORITHM.md §5c): the margin level lets
//! the robot come closer only by what it allows at this step's h *and* at
//! this average.
//!
//! Range noise makes the measured h jitter by about its standard deviation
//! from scan to scan. Judged on each scan alone, a robot resting near
//! something is let a little closer on every scan whose noise reads h high,
//! and is never sent back when one reads it low (resting meets the
//! requirement): the noise ratchets it in until a low reading puts h below 0
//! and the escape level backs it out, then in again, and v changes sign
//! every few steps in front of an obstacle it cannot pass. Judged also at
//! the average, a high reading grants no more than the average does, and the
//! robot rests where the average, not the highest reading, meets the
//! margin band's floor.
//!
//! The average is carried from step to step by the change of h predicted for
//! the command sent (the robot's own motion is accounted for) and moves
//! towards each new h with a time constant of [`TIME_CONSTANT_S`]; it stays
//! within δ of this step's h, so a change larger than the noise (something
//! walked off or came into view) is taken up at once. It only ever lowers
//! what the margin level allows (never below "no closer"), so it cannot make
//! a command admissible that was not.

use crate::algo::dtcbf::margin_target;

/// How fast the average follows new measurements (s).
pub const TIME_CONSTANT_S: f64 = 1.0;

/// The average's state between steps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HMean {
    /// The average at the last step (m); not finite before the first.
    mean_m: f64,
    /// The change of h predicted at the last step for the command sent (m).
    predicted_change_m: f64,
}

impl Default for HMean {
    fn default() -> Self {
        Self {
            mean_m: f64::NAN,
            predicted_change_m: 0.0,
        }
    }
}

impl HMean {
    /// Forgets the past: the next step starts afresh.
    pub fn reset(&mut self) {
        *self = Self::default();
    }

    /// The average at this step, with h measured `h_m`, `since_s` after the
    /// last step (δ = `delta_m`): the last average carried by its predicted
    /// change, moved towards h by since/τ (all the way after τ), and kept
    /// within δ of h. Equal to h on the first step and whenever either is not
    /// finite.
    pub fn update(&mut self, h_m: f64, since_s: f64, delta_m: f64) -> f64 {
        let carried = self.mean_m + self.predicted_change_m;
        let share = (since_s / TIME_CONSTANT_S).clamp(0.0, 1.0);
        self.mean_m = if carried.is_finite() && h_m.is_finite() {
            (carried + share * (h_m - carried)).clamp(h_m - delta_m, h_m + delta_m)
        } else {
            h_m
        };
        self.mean_m
    }

    /// Records the command sent: h(k) = `h_m`, predicted h(k+1) = `h_next_m`.
    pub fn sent(&mut self, h_m: f64, h_next_m: f64) {
        let change = h_next_m - h_m;
        self.predicted_change_m = if change.is_finite() { change } else { 0.0 };
    }
}

/// How much closer the margin level lets h(k+1) come than h(k) = `h_m`
/// (m, ≥ 0), with the average at `mean_m`: the smaller of what §5's margin
/// requirement allows at h and at the average (taken as 0 below 0). The
/// margin level's requirement is h minus this.
pub fn allowed_approach(h_m: f64, mean_m: f64, gamma: f64, delta_m: f64) -> f64 {
    let at = |h: f64| (h - margin_target(h, gamma, delta_m)).max(0.0);
    let mean = if mean_m.is_finite() { mean_m.max(0.0) } else { h_m };
    at(h_m).min(at(mean))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_high_reading_grants_only_what_the_average_allows() {
        // γ = 0.2, δ = 0.03. At h = 0.1 alone: 0.2·(0.1 − 0.03) = 0.014 closer.
        assert!((allowed_approach(0.1, 0.1, 0.2, 0.03) - 0.014).abs() < 1e-12);
        // The average at 0.05: 0.2·0.02 = 0.004.
        assert!((allowed_approach(0.1, 0.05, 0.2, 0.03) - 0.004).abs() < 1e-12);
        // The average below the band's floor 0.9δ = 0.027: no closer at all.
        assert_eq!(allowed_approach(0.034, 0.02, 0.2, 0.03), 0.0);
        // ... or below 0.
        assert_eq!(allowed_approach(0.034, -0.01, 0.2, 0.03), 0.0);
        // A low reading is judged at itself: h = 0.028 in the band, 1 mm above the
        // floor, may come 1 mm closer, however high the average.
        assert!((allowed_approach(0.028, 0.1, 0.2, 0.03) - 0.001).abs() < 1e-12);
        // Never more than at h: inside the band just below δ, 1 mm, but just above δ
        // the margin requirement allows only γ(h − δ).
        assert!((allowed_approach(0.0301, 0.029, 0.2, 0.03) - 0.2 * 0.0001).abs() < 1e-12);
    }

    #[test]
    fn the_average_follows_noise_slowly_and_larger_changes_at_once() {
        let mut m = HMean::default();
        // First step: h itself.
        assert_eq!(m.update(0.05, 0.1, 0.03), 0.05);
        m.sent(0.05, 0.05); // resting: no change predicted
                            // A reading 0.02 higher moves it a tenth of the way (0.1 s of τ = 1 s).
        assert!((m.update(0.07, 0.1, 0.03) - 0.052).abs() < 1e-12);
        m.sent(0.07, 0.07);
        // Driving closer: the predicted change carries it with the robot.
        m.sent(0.07, 0.06);
        assert!((m.update(0.062, 0.1, 0.03) - 0.044).abs() < 1e-12);
        // Something walked off: h up by 0.9; the average stays within δ of it.
        m.sent(0.062, 0.062);
        assert!((m.update(0.962, 0.1, 0.03) - 0.932).abs() < 1e-12);
        // Nothing visible, then something again: afresh.
        m.sent(0.962, 0.962);
        assert_eq!(m.update(f64::INFINITY, 0.1, 0.03), f64::INFINITY);
        m.sent(f64::INFINITY, f64::INFINITY);
        assert_eq!(m.update(0.3, 0.1, 0.03), 0.3);
    }
}
