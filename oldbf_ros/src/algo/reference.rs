//! Reference trajectories from a virtual unicycle (paper IV.B eq. 7).
//!
//! The virtual robot starts at `start` and is driven by a constant (v_r, ω_r)
//! for `duration_s`, then holds its final pose (the goal). Its pose is the
//! exact closed-form solution, so long runs do not accumulate integration
//! error. A line is ω_r = 0; the paper's circle is v_r = 0.2 m/s,
//! ω_r = 0.13 rad/s, whose radius is v_r/ω_r ≈ 1.54 m (the paper says 0.2 m).

use super::geometry::{Pose2, Twist};
use super::unicycle::arc_step;
use serde::{Deserialize, Serialize};

/// A reference trajectory.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReferenceTrajectory {
    /// Pose of the virtual robot at t = 0 (m, m, rad).
    pub start: Pose2,
    /// v_r (m/s).
    pub v_mps: f64,
    /// ω_r (rad/s); 0 for a line.
    pub omega_radps: f64,
    /// How long the virtual robot moves (s); it then holds its pose.
    pub duration_s: f64,
}

impl ReferenceTrajectory {
    /// A straight line of `length_m` at speed v_r.
    pub fn line(start: Pose2, v_mps: f64, length_m: f64) -> Self {
        Self {
            start,
            v_mps,
            omega_radps: 0.0,
            duration_s: length_m / v_mps,
        }
    }

    /// `laps` full circles at (v_r, ω_r).
    pub fn circle(start: Pose2, v_mps: f64, omega_radps: f64, laps: f64) -> Self {
        Self {
            start,
            v_mps,
            omega_radps,
            duration_s: laps * 2.0 * std::f64::consts::PI / omega_radps.abs(),
        }
    }

    /// Reference pose at time t (s since start).
    pub fn pose_at(&self, t_s: f64) -> Pose2 {
        let t = t_s.clamp(0.0, self.duration_s);
        arc_step(self.start, Twist::new(self.v_mps, self.omega_radps), t)
    }

    /// Reference velocity (v_r, ω_r) at time t: zero once the trajectory ended.
    pub fn twist_at(&self, t_s: f64) -> Twist {
        if t_s < self.duration_s {
            Twist::new(self.v_mps, self.omega_radps)
        } else {
            Twist::ZERO
        }
    }

    /// Where the trajectory ends (the goal).
    pub fn goal(&self) -> Pose2 {
        self.pose_at(self.duration_s)
    }

    /// Radius of the path (m); +inf for a line.
    pub fn radius_m(&self) -> f64 {
        if self.omega_radps == 0.0 {
            f64::INFINITY
        } else {
            (self.v_mps / self.omega_radps).abs()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_reaches_its_length_and_holds() {
        let r = ReferenceTrajectory::line(Pose2::new(0.0, 1.0, 0.0), 0.15, 6.0);
        assert!((r.duration_s - 40.0).abs() < 1e-12);
        assert!((r.pose_at(20.0).x - 3.0).abs() < 1e-12);
        assert_eq!(r.goal(), r.pose_at(1000.0));
        assert!((r.goal().x - 6.0).abs() < 1e-12 && r.goal().y == 1.0);
        assert_eq!(r.twist_at(41.0), Twist::ZERO);
    }

    #[test]
    fn paper_circle_radius() {
        let r = ReferenceTrajectory::circle(Pose2::default(), 0.2, 0.13, 1.0);
        assert!((r.radius_m() - 1.538_461_538).abs() < 1e-6);
        assert!(r.goal().position().norm() < 1e-9);
    }
}
