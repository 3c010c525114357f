//! Plain 2-D types shared by the core, the simulator and the adapters.
//!
//! Frames follow ROS REP 103: x forward, y left, z up, angles counter-clockwise
//! (rad). Points are `nalgebra::Vector2<f64>` (metres): fixed-size, stack-only,
//! as fast as a hand-written pair in the hot loops.

use nalgebra::{Isometry2, Vector2};
use std::f64::consts::PI;

/// A 2-D point or vector, metres.
pub type Vec2 = Vector2<f64>;

/// Wraps an angle to (−π, π] (rad).
pub fn wrap_angle(a: f64) -> f64 {
    let w = (a + PI).rem_euclid(2.0 * PI) - PI;
    if w == -PI {
        PI
    } else {
        w
    }
}

/// Pose in the plane: position (m) and heading θ (rad, CCW from +x).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Pose2 {
    pub x: f64,
    pub y: f64,
    pub theta: f64,
}

impl Pose2 {
    pub const fn new(x: f64, y: f64, theta: f64) -> Self {
        Self { x, y, theta }
    }

    pub fn position(&self) -> Vec2 {
        Vec2::new(self.x, self.y)
    }

    pub fn isometry(&self) -> Isometry2<f64> {
        Isometry2::new(self.position(), self.theta)
    }

    /// Maps a point given in this pose's frame into the parent frame.
    pub fn transform_point(&self, p: Vec2) -> Vec2 {
        let (s, c) = self.theta.sin_cos();
        Vec2::new(self.x + c * p.x - s * p.y, self.y + s * p.x + c * p.y)
    }

    /// Maps a point given in the parent frame into this pose's frame.
    pub fn inverse_transform_point(&self, p: Vec2) -> Vec2 {
        let (s, c) = self.theta.sin_cos();
        let d = p - self.position();
        Vec2::new(c * d.x + s * d.y, -s * d.x + c * d.y)
    }

    /// Rotates a vector from this pose's frame into the parent frame.
    pub fn rotate_vector(&self, v: Vec2) -> Vec2 {
        let (s, c) = self.theta.sin_cos();
        Vec2::new(c * v.x - s * v.y, s * v.x + c * v.y)
    }

    pub fn is_finite(&self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.theta.is_finite()
    }
}

/// A planar velocity command: linear speed along the robot's x axis (m/s) and
/// yaw rate (rad/s). Maps to geometry_msgs/Twist linear.x and angular.z.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Twist {
    pub v_mps: f64,
    pub omega_radps: f64,
}

impl Twist {
    pub const ZERO: Twist = Twist {
        v_mps: 0.0,
        omega_radps: 0.0,
    };

    pub const fn new(v_mps: f64, omega_radps: f64) -> Self {
        Self { v_mps, omega_radps }
    }

    pub fn is_finite(&self) -> bool {
        self.v_mps.is_finite() && self.omega_radps.is_finite()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_angle_maps_into_half_open_interval() {
        assert!((wrap_angle(3.0 * PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(-PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(-0.5) + 0.5).abs() < 1e-12);
        assert!((wrap_angle(2.0 * PI + 0.25) - 0.25).abs() < 1e-12);
    }

    #[test]
    fn transform_round_trips_and_matches_nalgebra() {
        let pose = Pose2::new(1.0, -2.0, 0.7);
        let p = Vec2::new(0.3, 0.4);
        let world = pose.transform_point(p);
        let via_iso = pose.isometry() * nalgebra::Point2::from(p);
        assert!((world - via_iso.coords).norm() < 1e-12);
        assert!((pose.inverse_transform_point(world) - p).norm() < 1e-12);
    }

    #[test]
    fn quarter_turn_maps_forward_to_left() {
        let pose = Pose2::new(0.0, 0.0, PI / 2.0);
        let p = pose.transform_point(Vec2::new(1.0, 0.0));
        assert!((p - Vec2::new(0.0, 1.0)).norm() < 1e-12);
    }
}
