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

/// The least ‖P − c‖² over `points` (m²); +inf for none.
#[inline]
pub fn min_distance_squared(points: &[Vec2], c: Vec2) -> f64 {
    reduce_distances_squared(points, c, f64::INFINITY, |acc, x| if x < acc { x } else { acc })
}

/// The greatest ‖P − c‖² over `points` (m²); 0 for none.
#[inline]
pub fn max_distance_squared(points: &[Vec2], c: Vec2) -> f64 {
    reduce_distances_squared(points, c, 0.0, |acc, x| if x > acc { x } else { acc })
}

/// Folds ‖P − c‖² over `points` with `pick`, a min or a max that keeps `acc`
/// when `x` is NaN (as `f64::min`/`max` do, in one compare-and-select).
///
/// Four running values, one per lane of four consecutive points: with a
/// single one every comparison waits for the previous one. A min or max does
/// not depend on the order it is taken in, so the result is the same.
#[inline]
fn reduce_distances_squared(points: &[Vec2], c: Vec2, init: f64, pick: impl Fn(f64, f64) -> f64) -> f64 {
    let mut acc = [init; 4];
    let chunks = points.chunks_exact(4);
    let rest = chunks.remainder();
    for chunk in chunks {
        for (a, p) in acc.iter_mut().zip(chunk) {
            *a = pick(*a, (p - c).norm_squared());
        }
    }
    for p in rest {
        acc[0] = pick(acc[0], (p - c).norm_squared());
    }
    pick(pick(acc[0], acc[1]), pick(acc[2], acc[3]))
}

/// Pose in the plane: position (m) and heading θ (rad, CCW from +x).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Pose2 {
    /// Position x (m).
    pub x: f64,
    /// Position y (m).
    pub y: f64,
    /// Heading θ (rad, CCW from +x).
    pub theta: f64,
}

impl Pose2 {
    /// The pose at (x, y) m heading θ rad.
    pub const fn new(x: f64, y: f64, theta: f64) -> Self {
        Self { x, y, theta }
    }

    /// The position (m).
    pub fn position(&self) -> Vec2 {
        Vec2::new(self.x, self.y)
    }

    /// The pose as a nalgebra isometry (this frame into the parent).
    pub fn isometry(&self) -> Isometry2<f64> {
        Isometry2::new(self.position(), self.theta)
    }

    /// Maps a point given in this pose's frame into the parent frame.
    pub fn transform_point(&self, p: Vec2) -> Vec2 {
        self.frame_map().point(p)
    }

    /// The map from this pose's frame into the parent frame, with its sine and
    /// cosine computed once: for mapping many points.
    pub fn frame_map(&self) -> FrameMap {
        let (s, c) = self.theta.sin_cos();
        FrameMap {
            x: self.x,
            y: self.y,
            s,
            c,
        }
    }

    /// Maps a point given in the parent frame into this pose's frame.
    pub fn inverse_transform_point(&self, p: Vec2) -> Vec2 {
        self.frame_map().inverse_point(p)
    }

    /// Rotates a vector from this pose's frame into the parent frame.
    pub fn rotate_vector(&self, v: Vec2) -> Vec2 {
        let (s, c) = self.theta.sin_cos();
        Vec2::new(c * v.x - s * v.y, s * v.x + c * v.y)
    }

    /// No NaN or infinite coordinate.
    pub fn is_finite(&self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.theta.is_finite()
    }
}

/// A pose's map from its frame into the parent frame (`Pose2::frame_map`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameMap {
    x: f64,
    y: f64,
    s: f64,
    c: f64,
}

impl Default for FrameMap {
    /// The identity: the map of the default pose.
    fn default() -> Self {
        Pose2::default().frame_map()
    }
}

impl FrameMap {
    /// Maps a point given in the pose's frame into the parent frame.
    #[inline]
    pub fn point(&self, p: Vec2) -> Vec2 {
        Vec2::new(
            self.x + self.c * p.x - self.s * p.y,
            self.y + self.s * p.x + self.c * p.y,
        )
    }

    /// Maps a point given in the parent frame into the pose's frame (what
    /// `Pose2::inverse_transform_point` does, with the sine and cosine kept).
    #[inline]
    pub fn inverse_point(&self, p: Vec2) -> Vec2 {
        let d = p - Vec2::new(self.x, self.y);
        self.inverse_vector(d)
    }

    /// Rotates a vector from the parent frame into the pose's frame.
    #[inline]
    pub fn inverse_vector(&self, v: Vec2) -> Vec2 {
        Vec2::new(self.c * v.x + self.s * v.y, -self.s * v.x + self.c * v.y)
    }
}

/// A planar velocity command: linear speed along the robot's x axis (m/s) and
/// yaw rate (rad/s). Maps to geometry_msgs/Twist linear.x and angular.z.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Twist {
    /// Linear speed along the robot's x axis (m/s).
    pub v_mps: f64,
    /// Yaw rate (rad/s, CCW positive).
    pub omega_radps: f64,
}

impl Twist {
    /// At rest.
    pub const ZERO: Twist = Twist {
        v_mps: 0.0,
        omega_radps: 0.0,
    };

    /// Speed v (m/s) and yaw rate ω (rad/s).
    pub const fn new(v_mps: f64, omega_radps: f64) -> Self {
        Self { v_mps, omega_radps }
    }

    /// Neither part NaN or infinite.
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
    fn distance_reductions_match_the_plain_fold() {
        for n in 0..11 {
            let pts: Vec<Vec2> = (0..n)
                .map(|i| Vec2::new((i as f64 * 1.7).sin() * 3.0, (i as f64 * 0.9).cos() * 2.0))
                .collect();
            let c = Vec2::new(0.3, -0.2);
            let d2 = pts.iter().map(|p| (p - c).norm_squared());
            assert_eq!(min_distance_squared(&pts, c), d2.clone().fold(f64::INFINITY, f64::min));
            assert_eq!(max_distance_squared(&pts, c), d2.fold(0.0, f64::max));
        }
        // NaN points are skipped, as f64::min/max skip them.
        let pts = [Vec2::new(f64::NAN, 0.0), Vec2::new(1.0, 0.0)];
        assert_eq!(min_distance_squared(&pts, Vec2::zeros()), 1.0);
        assert_eq!(max_distance_squared(&pts, Vec2::zeros()), 1.0);
    }

    #[test]
    fn quarter_turn_maps_forward_to_left() {
        let pose = Pose2::new(0.0, 0.0, PI / 2.0);
        let p = pose.transform_point(Vec2::new(1.0, 0.0));
        assert!((p - Vec2::new(0.0, 1.0)).norm() < 1e-12);
    }
}
