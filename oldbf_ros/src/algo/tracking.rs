//! Trajectory tracking (paper IV.C; eq. 8 completed with Kanayama's law).
//!
//! The paper's eq. 8 gives only the rotation into the robot frame. We use the
//! standard Kanayama et al. (1990) controller on the robot-frame error
//! (e_x, e_y, e_θ):
//!   v = v_r cos e_θ + k_x e_x,
//!   ω = ω_r + v_r (k_y e_y + k_θ sin e_θ),
//! which reduces to the paper's yaw correction e = θ_ref − θ when e_x = e_y = 0.

use super::geometry::{wrap_angle, Pose2, Twist};
use super::params::TrackingParams;

/// Tracking error in the robot frame: along-track, cross-track (m), heading (rad).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackingError {
    pub e_x_m: f64,
    pub e_y_m: f64,
    pub e_theta_rad: f64,
}

impl TrackingError {
    pub fn between(robot: Pose2, reference: Pose2) -> Self {
        let d = robot.inverse_transform_point(reference.position());
        Self {
            e_x_m: d.x,
            e_y_m: d.y,
            e_theta_rad: wrap_angle(reference.theta - robot.theta),
        }
    }

    /// Position error ‖p_ref − p‖ (m).
    pub fn distance_m(&self) -> f64 {
        self.e_x_m.hypot(self.e_y_m)
    }
}

/// Kanayama's tracking command toward `reference` moving at `reference_twist`.
pub fn kanayama(
    robot: Pose2,
    reference: Pose2,
    reference_twist: Twist,
    k: &TrackingParams,
) -> Twist {
    let e = TrackingError::between(robot, reference);
    let vr = reference_twist.v_mps;
    Twist::new(
        vr * e.e_theta_rad.cos() + k.k_x_per_s * e.e_x_m,
        reference_twist.omega_radps
            + vr * (k.k_y_per_m2 * e.e_y_m + k.k_theta_per_m * e.e_theta_rad.sin()),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_error_gives_the_reference_twist() {
        let p = Pose2::new(1.0, 2.0, 0.4);
        assert_eq!(
            kanayama(p, p, Twist::new(0.2, 0.13), &TrackingParams::default()),
            Twist::new(0.2, 0.13)
        );
    }

    #[test]
    fn hand_values() {
        // Robot at origin heading +x; reference 0.1 m ahead, 0.05 m left, heading 0.1 rad.
        let k = TrackingParams::default(); // k_x 1, k_y 10, k_θ 4
        let cmd = kanayama(
            Pose2::default(),
            Pose2::new(0.1, 0.05, 0.1),
            Twist::new(0.15, 0.0),
            &k,
        );
        assert!((cmd.v_mps - (0.15 * 0.1f64.cos() + 0.1)).abs() < 1e-12);
        assert!((cmd.omega_radps - 0.15 * (10.0 * 0.05 + 4.0 * 0.1f64.sin())).abs() < 1e-12);
    }

    #[test]
    fn error_is_expressed_in_the_robot_frame() {
        // Robot heading +y; a reference at +x world lies to its right (e_y < 0).
        let e = TrackingError::between(
            Pose2::new(0.0, 0.0, std::f64::consts::FRAC_PI_2),
            Pose2::new(1.0, 0.0, 0.0),
        );
        assert!(e.e_x_m.abs() < 1e-12 && (e.e_y_m + 1.0).abs() < 1e-12);
        assert!((e.e_theta_rad + std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }
}
