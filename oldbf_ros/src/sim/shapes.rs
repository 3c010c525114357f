//! Geometric primitives of the simulated world: line segments (walls, polygon
//! and box edges) and circles (posts, moving obstacles).
//!
//! Why a file of its own: both the LiDAR (ray casting) and the collision check
//! (exact point distance) need the same two queries on the same two shapes, and
//! getting them exactly right — endpoints, parallel rays, rays starting inside
//! a circle — is easier to test in isolation. All lengths are metres, in the
//! world frame.
//!
//! Both queries are total functions: degenerate input (a zero-length segment,
//! a zero direction, NaN) never panics; it yields a distance or `None`.

use crate::algo::geometry::Vec2;

/// Tolerance on the segment parameter `s ∈ [0, 1]` in [`Segment::ray_hit`], so
/// a ray through the vertex shared by two polygon edges cannot slip between
/// them through rounding.
const SEGMENT_PARAM_EPS: f64 = 1e-9;

/// 2-D cross product (z component of the 3-D cross product).
#[inline(always)]
fn cross(u: Vec2, v: Vec2) -> f64 {
    u.x * v.y - u.y * v.x
}

/// A straight line segment from `a` to `b` (world frame, m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    pub a: Vec2,
    pub b: Vec2,
}

impl Segment {
    pub const fn new(a: Vec2, b: Vec2) -> Self {
        Self { a, b }
    }

    /// Length ‖b − a‖ (m).
    pub fn length_m(&self) -> f64 {
        (self.b - self.a).norm()
    }

    /// Exact Euclidean distance from `p` to the closest point of the segment
    /// (m). A zero-length segment behaves as the point `a`.
    #[inline]
    pub fn distance_to(&self, p: Vec2) -> f64 {
        let e = self.b - self.a;
        let w = p - self.a;
        let ee = e.dot(&e);
        let s = if ee > 0.0 {
            (w.dot(&e) / ee).clamp(0.0, 1.0)
        } else {
            0.0
        };
        // `clamp` cannot panic here: the bounds are constants; a NaN `s`
        // (NaN input) just propagates to a NaN distance.
        (w - s * e).norm()
    }

    /// Distance `t ≥ 0` along the ray `origin + t·dir_unit` to its first
    /// intersection with the segment (m), `None` if the ray misses.
    ///
    /// `dir_unit` must have unit length for `t` to be metres. A ray parallel
    /// to the segment misses unless it is collinear with it, in which case the
    /// first point of the segment on the ray is returned (0 if the origin lies
    /// on the segment).
    #[inline]
    pub fn ray_hit(&self, origin: Vec2, dir_unit: Vec2) -> Option<f64> {
        // origin + t d = a + s e  ⇔  t d − s e = w, with w = a − origin.
        // Crossing with e: t (d × e) = w × e; crossing with d: s (d × e) = w × d.
        let e = self.b - self.a;
        let w = self.a - origin;
        let denom = cross(dir_unit, e);
        let t_num = cross(w, e);
        let s_num = cross(w, dir_unit);
        if denom != 0.0 {
            let t = t_num / denom;
            let s = s_num / denom;
            if t >= 0.0 && (-SEGMENT_PARAM_EPS..=1.0 + SEGMENT_PARAM_EPS).contains(&s) {
                return Some(t);
            }
            return None;
        }
        // Parallel. Collinear only if the origin lies on the segment's line.
        if t_num != 0.0 || s_num != 0.0 {
            return None;
        }
        // Collinear: project both endpoints on the ray.
        let ta = w.dot(&dir_unit);
        let tb = (self.b - origin).dot(&dir_unit);
        let (lo, hi) = if ta <= tb { (ta, tb) } else { (tb, ta) };
        if hi < 0.0 || !lo.is_finite() || !hi.is_finite() {
            None
        } else {
            Some(lo.max(0.0))
        }
    }
}

/// A filled disc: centre (world frame, m) and radius (m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Circle {
    pub center: Vec2,
    pub radius_m: f64,
}

impl Circle {
    pub const fn new(center: Vec2, radius_m: f64) -> Self {
        Self { center, radius_m }
    }

    /// ‖p − c‖ − radius (m): positive outside, zero on the boundary, negative
    /// inside (minus the penetration depth).
    #[inline]
    pub fn signed_distance_to(&self, p: Vec2) -> f64 {
        (p - self.center).norm() - self.radius_m
    }

    /// Distance `t ≥ 0` along `origin + t·dir_unit` to the first point of the
    /// circle boundary (m); `Some(0.0)` if the origin is inside or on the
    /// circle (the sensor is within the obstacle); `None` on a miss.
    #[inline]
    pub fn ray_hit(&self, origin: Vec2, dir_unit: Vec2) -> Option<f64> {
        // |f + t d|² = r², f = origin − c, |d| = 1:  t² + 2 b t + c0 = 0 with
        // b = f·d, c0 = |f|² − r². Roots −b ± √(b² − c0).
        let f = origin - self.center;
        let r2 = self.radius_m * self.radius_m;
        let ff = f.dot(&f);
        if ff <= r2 {
            return Some(0.0);
        }
        let b = f.dot(&dir_unit);
        if b >= 0.0 {
            // Outside and heading away (or sideways): no hit ahead.
            return None;
        }
        // b² − c0 = r² − |f − b d|² (squared distance of the centre from the
        // ray's line), written so it does not cancel for far circles.
        let perp = f - dir_unit * b;
        let disc = r2 - perp.dot(&perp);
        if disc >= 0.0 {
            // Smaller root −b − √disc = c0 / (−b + √disc), with
            // c0 = (|f| − r)(|f| + r): no cancellation near the boundary
            // either. (NaN input fails the tests above → None.)
            let fnorm = ff.sqrt();
            let c0 = (fnorm - self.radius_m) * (fnorm + self.radius_m);
            Some(c0 / (-b + disc.sqrt()))
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64, y: f64) -> Vec2 {
        Vec2::new(x, y)
    }

    fn unit(x: f64, y: f64) -> Vec2 {
        v(x, y).normalize()
    }

    #[test]
    fn segment_distance_interior_and_endpoints() {
        let s = Segment::new(v(0.0, 0.0), v(4.0, 0.0));
        // Interior: perpendicular foot at (1, 0).
        assert_eq!(s.distance_to(v(1.0, 3.0)), 3.0);
        assert_eq!(s.distance_to(v(2.5, -0.5)), 0.5);
        // Beyond b: distance to (4,0) from (7,4) is the 3-4-5 triangle.
        assert!((s.distance_to(v(7.0, 4.0)) - 5.0).abs() < 1e-12);
        // Before a: (−3, −4) → 5.
        assert!((s.distance_to(v(-3.0, -4.0)) - 5.0).abs() < 1e-12);
        // On the segment.
        assert_eq!(s.distance_to(v(3.0, 0.0)), 0.0);
        // Slanted: segment (0,0)-(2,2), point (2,0) → √2.
        let d = Segment::new(v(0.0, 0.0), v(2.0, 2.0));
        assert!((d.distance_to(v(2.0, 0.0)) - 2f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn zero_length_segment_is_a_point() {
        let s = Segment::new(v(1.0, 1.0), v(1.0, 1.0));
        assert!((s.distance_to(v(4.0, 5.0)) - 5.0).abs() < 1e-12);
        assert_eq!(s.ray_hit(v(0.0, 0.0), unit(1.0, 0.0)), None);
    }

    #[test]
    fn ray_hits_segment_head_on_and_slanted() {
        let wall = Segment::new(v(2.0, -1.0), v(2.0, 1.0));
        assert_eq!(wall.ray_hit(v(0.0, 0.0), v(1.0, 0.0)), Some(2.0));
        // 45°: y = x meets x = 2 at y = 2, beyond the end → miss.
        assert_eq!(wall.ray_hit(v(0.0, 0.0), unit(1.0, 1.0)), None);
        // Towards (2, 0.5): t = √(4 + 0.25).
        let t = wall.ray_hit(v(0.0, 0.0), unit(2.0, 0.5)).unwrap();
        assert!((t - 4.25f64.sqrt()).abs() < 1e-12);
        // From the other side.
        assert_eq!(wall.ray_hit(v(5.0, 0.0), v(-1.0, 0.0)), Some(3.0));
    }

    #[test]
    fn ray_misses_parallel_and_behind() {
        let wall = Segment::new(v(2.0, -1.0), v(2.0, 1.0));
        // Behind the origin.
        assert_eq!(wall.ray_hit(v(0.0, 0.0), v(-1.0, 0.0)), None);
        // Parallel, offset.
        assert_eq!(wall.ray_hit(v(0.0, 0.0), v(0.0, 1.0)), None);
        // Passing beside the segment.
        assert_eq!(wall.ray_hit(v(0.0, 3.0), v(1.0, 0.0)), None);
    }

    #[test]
    fn ray_hits_segment_endpoint() {
        let wall = Segment::new(v(2.0, -1.0), v(2.0, 1.0));
        // Exactly through b = (2, 1): t = √5.
        let t = wall.ray_hit(v(0.0, 0.0), unit(2.0, 1.0)).unwrap();
        assert!((t - 5f64.sqrt()).abs() < 1e-12);
        // And through a = (2, −1).
        let t = wall.ray_hit(v(0.0, 0.0), unit(2.0, -1.0)).unwrap();
        assert!((t - 5f64.sqrt()).abs() < 1e-12);
        // Just past the end misses.
        assert_eq!(wall.ray_hit(v(0.0, 0.0), unit(2.0, 1.01)), None);
    }

    #[test]
    fn collinear_ray_hits_nearest_point() {
        let s = Segment::new(v(3.0, 0.0), v(5.0, 0.0));
        assert_eq!(s.ray_hit(v(0.0, 0.0), v(1.0, 0.0)), Some(3.0));
        assert_eq!(s.ray_hit(v(4.0, 0.0), v(1.0, 0.0)), Some(0.0));
        assert_eq!(s.ray_hit(v(6.0, 0.0), v(1.0, 0.0)), None);
        assert_eq!(s.ray_hit(v(6.0, 0.0), v(-1.0, 0.0)), Some(1.0));
    }

    #[test]
    fn circle_signed_distance() {
        let c = Circle::new(v(1.0, 1.0), 0.5);
        assert!((c.signed_distance_to(v(4.0, 5.0)) - 4.5).abs() < 1e-12);
        assert!((c.signed_distance_to(v(1.0, 1.2)) + 0.3).abs() < 1e-12);
        assert!(c.signed_distance_to(v(1.5, 1.0)).abs() < 1e-12);
    }

    #[test]
    fn ray_hits_circle_from_outside() {
        let c = Circle::new(v(3.0, 0.0), 0.5);
        // On axis: ‖c − o‖ − R = 2.5.
        let t = c.ray_hit(v(0.0, 0.0), v(1.0, 0.0)).unwrap();
        assert!((t - 2.5).abs() < 1e-12);
        // Off axis: ray along y = 0.3 hits x = 3 − √(0.25 − 0.09) = 2.6.
        let t = c.ray_hit(v(0.0, 0.3), v(1.0, 0.0)).unwrap();
        assert!((t - 2.6).abs() < 1e-12);
        // Far away, on axis: no cancellation.
        let far = Circle::new(v(1.0e6, 0.0), 0.1);
        let t = far.ray_hit(v(0.0, 0.0), v(1.0, 0.0)).unwrap();
        assert!((t - (1.0e6 - 0.1)).abs() < 1e-6);
    }

    #[test]
    fn ray_misses_circle() {
        let c = Circle::new(v(3.0, 0.0), 0.5);
        assert_eq!(c.ray_hit(v(0.0, 0.0), v(-1.0, 0.0)), None);
        assert_eq!(c.ray_hit(v(0.0, 0.6), v(1.0, 0.0)), None);
        assert_eq!(c.ray_hit(v(0.0, 0.0), v(0.0, 1.0)), None);
    }

    #[test]
    fn ray_from_inside_circle_is_zero() {
        let c = Circle::new(v(3.0, 0.0), 0.5);
        assert_eq!(c.ray_hit(v(3.2, 0.1), v(1.0, 0.0)), Some(0.0));
        assert_eq!(c.ray_hit(v(3.2, 0.1), v(-1.0, 0.0)), Some(0.0));
    }

    #[test]
    fn nan_input_does_not_panic() {
        let s = Segment::new(v(0.0, 0.0), v(1.0, 0.0));
        let n = v(f64::NAN, 0.0);
        assert!(s.distance_to(n).is_nan());
        assert_eq!(s.ray_hit(n, v(1.0, 0.0)), None);
        let c = Circle::new(v(0.0, 0.0), 1.0);
        assert_eq!(c.ray_hit(n, v(1.0, 0.0)), None);
    }
}
