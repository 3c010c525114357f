//! Unicycle (differential-drive) kinematics (paper IV.A eq. 6).

use super::geometry::{wrap_angle, Pose2, Twist};

/// Paper eq. 6 with Δt explicit (forward Euler): x+ = x + Δt v cos θ,
/// y+ = y + Δt v sin θ, θ+ = θ + Δt ω. This is the model F of the DTCBF
/// condition by default.
pub fn euler_step(pose: Pose2, cmd: Twist, dt_s: f64) -> Pose2 {
    let (s, c) = pose.theta.sin_cos();
    Pose2::new(
        pose.x + dt_s * cmd.v_mps * c,
        pose.y + dt_s * cmd.v_mps * s,
        wrap_angle(pose.theta + dt_s * cmd.omega_radps),
    )
}

/// sin(x)/x, with its series near 0: an arc of turn 2x and length L has the
/// chord L·sinc(x).
#[inline]
pub fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-6 {
        1.0 - x * x / 6.0
    } else {
        x.sin() / x
    }
}

/// Exact motion under a constant (v, ω) for dt_s: an arc (a line when ω = 0).
/// The simulator integrates with this.
pub fn arc_step(pose: Pose2, cmd: Twist, dt_s: f64) -> Pose2 {
    let dth = cmd.omega_radps * dt_s;
    let half = 0.5 * dth;
    let chord = cmd.v_mps * dt_s * sinc(half);
    let heading = pose.theta + half;
    Pose2::new(
        pose.x + chord * heading.cos(),
        pose.y + chord * heading.sin(),
        wrap_angle(pose.theta + dth),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn euler_moves_along_heading_and_turns() {
        let p = euler_step(Pose2::new(1.0, 2.0, PI / 2.0), Twist::new(0.5, 0.2), 0.1);
        assert!((p.x - 1.0).abs() < 1e-12 && (p.y - 2.05).abs() < 1e-12);
        assert!((p.theta - (PI / 2.0 + 0.02)).abs() < 1e-12);
    }

    #[test]
    fn arc_closes_a_full_circle() {
        // v = 0.2, ω = 0.13: radius 0.2/0.13 = 1.538 m; 100 steps over one period return to start.
        let period = 2.0 * PI / 0.13;
        let mut p = Pose2::default();
        for _ in 0..100 {
            p = arc_step(p, Twist::new(0.2, 0.13), period / 100.0);
        }
        assert!(p.position().norm() < 1e-9, "{p:?}");
        // Half way round it is at (0, 2R).
        let mut p = Pose2::default();
        for _ in 0..50 {
            p = arc_step(p, Twist::new(0.2, 0.13), period / 100.0);
        }
        assert!((p.y - 2.0 * 0.2 / 0.13).abs() < 1e-9 && p.x.abs() < 1e-9);
    }

    #[test]
    fn arc_and_euler_agree_for_straight_motion() {
        let a = arc_step(Pose2::new(0.0, 0.0, 0.3), Twist::new(0.15, 0.0), 0.1);
        let e = euler_step(Pose2::new(0.0, 0.0, 0.3), Twist::new(0.15, 0.0), 0.1);
        assert!((a.position() - e.position()).norm() < 1e-15);
    }
}
