//! Collision cone and time to collision (ALGORITHM.md §6, paper III.A Fig. 2).
//!
//! With p_rel = c_o − p_robot, v_rel = v_robot − v_o and R = r_o + r, the
//! robot is on a collision course iff v_rel points inside the cone of
//! half-angle asin(R / ‖p_rel‖) around p_rel: equivalently, the relative
//! straight-line motion passes within R of the obstacle's centre while
//! approaching it. The time to collision is the first t ≥ 0 with
//! ‖p_rel − v_rel t‖ = R.

use super::footprint::{PaddedPolygon, Span};
use super::geometry::Vec2;

/// Collision-cone verdict for one obstacle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConeTest {
    /// v_rel lies inside the cone (or the discs already overlap).
    pub on_collision_course: bool,
    /// Time until the discs touch (s); None when not on a collision course.
    pub time_to_collision_s: Option<f64>,
    /// Half-angle of the cone, asin(R/‖p_rel‖) (rad); π/2 when overlapping.
    pub half_angle_rad: f64,
}

/// The cone test for an obstacle of combined radius `r_sum_m` = r_o + r at
/// relative position `p_rel` (m) with relative velocity `v_rel` = v_robot − v_o (m/s).
pub fn collision_cone(p_rel: Vec2, v_rel: Vec2, r_sum_m: f64) -> ConeTest {
    let dist = p_rel.norm();
    if !(dist.is_finite() && v_rel.x.is_finite() && v_rel.y.is_finite() && r_sum_m.is_finite()) {
        return ConeTest {
            on_collision_course: false,
            time_to_collision_s: None,
            half_angle_rad: 0.0,
        };
    }
    if dist <= r_sum_m {
        return ConeTest {
            on_collision_course: true,
            time_to_collision_s: Some(0.0),
            half_angle_rad: std::f64::consts::FRAC_PI_2,
        };
    }
    let half_angle_rad = (r_sum_m / dist).asin();
    let closing = p_rel.dot(&v_rel);
    let speed2 = v_rel.norm_squared();
    // Inside the cone ⟺ approaching and the miss distance |p × v| / |v| < R.
    let cross = p_rel.x * v_rel.y - p_rel.y * v_rel.x;
    let inside = closing > 0.0 && cross * cross < r_sum_m * r_sum_m * speed2;
    let time_to_collision_s = inside.then(|| {
        let disc = closing * closing - speed2 * (dist * dist - r_sum_m * r_sum_m);
        (closing - disc.max(0.0).sqrt()) / speed2
    });
    ConeTest {
        on_collision_course: inside,
        time_to_collision_s,
        half_angle_rad,
    }
}

/// For a polygon body (heading held): the first time t in [0, `horizon_s`]
/// at which an obstacle of radius `radius_m` at relative position `p_rel`
/// (m), moving relative to the robot at `v_rel_obstacle` = v_o − v_robot
/// (m/s), comes within its radius of the polygon; `None` if it does not.
/// Exact: where the line p_rel + t·v_rel_obstacle comes within `radius_m`
/// of the polygon ([`PaddedPolygon::forbidden_on_line`]). `events` and
/// `entries` are scratch.
pub fn polygon_time_to_collision(
    fp: &PaddedPolygon,
    p_rel: Vec2,
    v_rel_obstacle: Vec2,
    radius_m: f64,
    horizon_s: f64,
    events: &mut Vec<f64>,
    entries: &mut Vec<(f64, f64)>,
) -> Option<f64> {
    let span = Span { lo: 0.0, hi: horizon_s };
    entries.clear();
    fp.forbidden_on_line(p_rel, v_rel_obstacle, radius_m, span, events, entries);
    entries.first().map(|&(from, _)| from.max(0.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rectangle_is_reached_by_its_outline_not_its_circle() {
        let fp = PaddedPolygon::base_0604();
        let (mut ev, mut out) = (Vec::new(), Vec::new());
        // Head-on: a person of 0.2 m 2 m ahead at 0.5 m/s reaches the front (x = 0.3)
        // when its centre is at 0.5 m: t = 3 s (the circle of 0.3606 m: 2.879 s).
        let t = polygon_time_to_collision(
            &fp,
            Vec2::new(2.0, 0.0),
            Vec2::new(-0.5, 0.0),
            0.2,
            6.0,
            &mut ev,
            &mut out,
        );
        assert!((t.unwrap() - 3.0).abs() < 1e-9, "{t:?}");
        let circle = collision_cone(Vec2::new(2.0, 0.0), Vec2::new(0.5, 0.0), 0.3606 + 0.2);
        assert!((circle.time_to_collision_s.unwrap() - (2.0 - 0.5606) / 0.5).abs() < 1e-9);
        // Passing 0.5 m beside the centre line, 0.3 m from the long side: no contact
        // for the rectangle (radius 0.15 m), one for its circle (0.5106 m > 0.5 m).
        let beside = polygon_time_to_collision(
            &fp,
            Vec2::new(1.0, 0.5),
            Vec2::new(-0.3, 0.0),
            0.15,
            6.0,
            &mut ev,
            &mut out,
        );
        assert_eq!(beside, None);
        assert!(collision_cone(Vec2::new(1.0, 0.5), Vec2::new(0.3, 0.0), 0.3606 + 0.15).on_collision_course);
        // Already touching the side: now.
        let touching = polygon_time_to_collision(
            &fp,
            Vec2::new(0.0, 0.3),
            Vec2::new(0.1, 0.0),
            0.15,
            6.0,
            &mut ev,
            &mut out,
        );
        assert_eq!(touching, Some(0.0));
        // Reached only after the horizon: none.
        assert_eq!(
            polygon_time_to_collision(
                &fp,
                Vec2::new(2.0, 0.0),
                Vec2::new(-0.5, 0.0),
                0.2,
                2.5,
                &mut ev,
                &mut out
            ),
            None
        );
    }

    #[test]
    fn head_on_hand_values() {
        // Obstacle 2 m ahead, R = 0.5; closing at 0.5 m/s: contact when 1.5 m is closed, t = 3 s.
        let t = collision_cone(Vec2::new(2.0, 0.0), Vec2::new(0.5, 0.0), 0.5);
        assert!(t.on_collision_course);
        assert!((t.time_to_collision_s.unwrap() - 3.0).abs() < 1e-12);
        assert!((t.half_angle_rad - (0.25f64).asin()).abs() < 1e-12);
    }

    #[test]
    fn the_cone_edge() {
        // Half-angle asin(0.5/2) = 14.48°: a relative velocity at 14° is inside, at 15° outside.
        for (deg, inside) in [(14.0f64, true), (15.0, false)] {
            let v = Vec2::new(deg.to_radians().cos(), deg.to_radians().sin());
            assert_eq!(
                collision_cone(Vec2::new(2.0, 0.0), v, 0.5).on_collision_course,
                inside,
                "{deg}°"
            );
        }
    }

    #[test]
    fn receding_or_passing_is_not_a_collision_course() {
        assert!(!collision_cone(Vec2::new(2.0, 0.0), Vec2::new(-0.5, 0.0), 0.5).on_collision_course);
        // A crossing obstacle that moves out of the way fast enough.
        assert!(!collision_cone(Vec2::new(2.0, 0.0), Vec2::new(0.1, 1.0), 0.5).on_collision_course);
        assert!(!collision_cone(Vec2::new(2.0, 0.0), Vec2::zeros(), 0.5).on_collision_course);
    }

    #[test]
    fn overlap_and_garbage() {
        let t = collision_cone(Vec2::new(0.3, 0.0), Vec2::new(-1.0, 0.0), 0.5);
        assert_eq!((t.on_collision_course, t.time_to_collision_s), (true, Some(0.0)));
        assert!(!collision_cone(Vec2::new(f64::NAN, 0.0), Vec2::new(1.0, 0.0), 0.5).on_collision_course);
    }
}
