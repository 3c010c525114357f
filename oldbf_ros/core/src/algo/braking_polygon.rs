//! The braking check (§5b) for a polygon body (issue 26): the padded
//! polygon swept along the path of one control step and the braking to rest
//! after it, its heading turning with the path.
//!
//! A closing contact is a point of the surroundings inside the swept body
//! (within `UNSEEN_MARGIN_M` more for a place that may be unseen; a mover's
//! grown disc overlapping it) while the part of the body nearest to it moves
//! towards it faster than half of `passive.closing_speed_mps`: the velocity
//! of that body point (the centre's velocity plus ω × its lever) along the
//! outward normal there. For the circle the nearest body point moves with
//! the centre, and this is the circle's rule.
//!
//! Unlike the circle, a polygon turning in place moves: with v = 0 the path
//! is the step's turn, then the turn braked to rest at
//! `control.angular_accel_radps2`.
//!
//! The path is sampled so that no point of the body moves more than
//! `SAMPLE_SPACING_M` between samples (the farthest vertex sets the pace of
//! the turn), as the circle's path is sampled every centimetre of travel.

use super::footprint::PaddedPolygon;
use super::geometry::{Twist, Vec2};
use super::params::Params;
use super::passive::{ClosingContact, Mover, UNSEEN_MARGIN_M};

/// Largest movement of any body point between samples (m).
const SAMPLE_SPACING_M: f64 = 0.01;
/// Most samples per phase (step, braking).
const MAX_SAMPLES: usize = 64;

/// One pose of the swept path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathPose {
    /// Time from now (s).
    pub t_s: f64,
    /// The robot's origin (m, robot frame now).
    pub pos: Vec2,
    /// Unit heading.
    pub heading: Vec2,
    /// The origin's velocity (m/s).
    pub vel: Vec2,
    /// Yaw rate (rad/s).
    pub omega_radps: f64,
}

/// Advances a unicycle by `dt_s` at (v, ω): the exact arc.
fn advance(pos: Vec2, heading: Vec2, v: f64, omega: f64, dt_s: f64) -> (Vec2, Vec2) {
    let dth = omega * dt_s;
    let half = 0.5 * dth;
    // The chord of the arc, along the heading turned by half the angle.
    let chord = if half.abs() < 1e-9 {
        v * dt_s
    } else {
        v * dt_s * half.sin() / half
    };
    let (s, c) = half.sin_cos();
    let mid = Vec2::new(c * heading.x - s * heading.y, s * heading.x + c * heading.y);
    let (s2, c2) = dth.sin_cos();
    let turned = Vec2::new(c2 * heading.x - s2 * heading.y, s2 * heading.x + c2 * heading.y);
    (pos + mid * chord, turned)
}

/// The poses of `cmd` held for one control step, then braked to rest at
/// `control.decel_mps2` on the same curvature (a turn in place: braked at
/// `control.angular_accel_radps2`), for a body whose farthest point is
/// `reach_m` from its origin. Written to `out`.
pub fn braking_poses(cmd: Twist, reach_m: f64, p: &Params, out: &mut Vec<PathPose>) {
    out.clear();
    let (v, w) = (cmd.v_mps, cmd.omega_radps);
    if v == 0.0 && w == 0.0 {
        return;
    }
    let dt = p.control.dt_s();
    // The fastest body point's speed at the start sets the sampling.
    let top = v.abs() + w.abs() * reach_m;
    let n1 = ((top * dt / SAMPLE_SPACING_M).ceil() as usize).clamp(1, MAX_SAMPLES);
    let (mut pos, mut heading) = (Vec2::zeros(), Vec2::new(1.0, 0.0));
    for k in 1..=n1 {
        (pos, heading) = advance(pos, heading, v, w, dt / n1 as f64);
        out.push(PathPose {
            t_s: dt * k as f64 / n1 as f64,
            pos,
            heading,
            vel: heading * v,
            omega_radps: w,
        });
    }
    // Braking: both rates fall linearly to 0 together (the curvature kept),
    // over |v|/decel, or over |ω|/angular_accel for a turn in place.
    let t_brake = if v != 0.0 {
        v.abs() / p.control.decel_mps2
    } else {
        w.abs() / p.control.angular_accel_radps2
    };
    let travel = 0.5 * top * t_brake;
    let n2 = ((travel / SAMPLE_SPACING_M).ceil() as usize).clamp(1, MAX_SAMPLES);
    let step = t_brake / n2 as f64;
    for k in 1..=n2 {
        // The mean rate over this sample's interval, exact for a linear fall.
        let share = 1.0 - (k as f64 - 0.5) / n2 as f64;
        (pos, heading) = advance(pos, heading, v * share, w * share, step);
        let now = 1.0 - k as f64 / n2 as f64;
        out.push(PathPose {
            t_s: dt + step * k as f64,
            pos,
            heading,
            vel: heading * (v * now),
            omega_radps: w * now,
        });
    }
}

/// `q` (robot frame now) in the body's frame at `pose`.
#[inline]
pub fn local(q: Vec2, pose: &PathPose) -> Vec2 {
    let d = q - pose.pos;
    let h = pose.heading;
    Vec2::new(h.x * d.x + h.y * d.y, -h.y * d.x + h.x * d.y)
}

/// The speed at which the body at `pose` closes on `q` (robot frame now),
/// `q_local` being `q` in the body's frame: the velocity of the body point
/// nearest to it along the outward normal there.
pub fn closing_speed(fp: &PaddedPolygon, pose: &PathPose, q: Vec2, q_local: Vec2, inside: bool) -> f64 {
    let b_local = fp.polygon.closest_boundary_point(q_local);
    let h = pose.heading;
    let lever = Vec2::new(h.x * b_local.x - h.y * b_local.y, h.y * b_local.x + h.x * b_local.y);
    let b = pose.pos + lever;
    let vel = pose.vel + Vec2::new(-pose.omega_radps * lever.y, pose.omega_radps * lever.x);
    let normal = if inside { b - q } else { q - b };
    let n = normal.norm();
    if n > 0.0 {
        vel.dot(&normal) / n
    } else {
        vel.norm()
    }
}

/// The first closing contact of the swept polygon along `poses` with the
/// static points `seen`, the possibly unseen places `unseen` and the
/// `movers` (predicted along their velocities, discs grown as the circle's
/// check grows them), or `None`.
pub fn first_polygon_contact(
    fp: &PaddedPolygon,
    poses: &[PathPose],
    seen: &[Vec2],
    unseen: &[Vec2],
    movers: &[Mover],
    p: &Params,
) -> Option<ClosingContact> {
    let threshold = 0.5 * p.passive.closing_speed_mps;
    let reach = fp.circumscribed_radius_m();
    // A closing contact of the body at `pose` with `q` (robot frame now),
    // which it may come within `margin` of.
    let contact = |pose: &PathPose, q: Vec2, margin: f64, mover: bool| {
        let far = reach + margin;
        if (q - pose.pos).norm_squared() >= far * far {
            return None;
        }
        let q_local = local(q, pose);
        let sd = fp.signed_distance(q_local);
        if sd >= margin {
            return None;
        }
        let towards = closing_speed(fp, pose, q, q_local, sd < 0.0);
        (towards > threshold).then_some(ClosingContact {
            t_s: pose.t_s,
            closing_speed_mps: towards,
            mover,
        })
    };
    poses.iter().find_map(|pose| {
        let statics = seen
            .iter()
            .map(|q| (*q, p.passive.seen_margin_m))
            .chain(unseen.iter().map(|q| (*q, UNSEEN_MARGIN_M)));
        statics
            .filter_map(|(q, margin)| contact(pose, q, margin, false))
            .chain(movers.iter().filter_map(|m| {
                let c = m.position + m.velocity * pose.t_s;
                let grown = m.radius_m + p.passive.mover_margin_m + p.passive.mover_growth_mps * pose.t_s;
                contact(pose, c, grown, true)
            }))
            .next()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> Params {
        // Δt 0.1 s, decel 1.0 m/s², angular accel 1.0 rad/s², closing speed 0.05 m/s (default);
        // seen points at the polygon exactly (the margin has a test of its own).
        let mut p = Params::default();
        p.passive.seen_margin_m = 0.0;
        p
    }

    fn contact(cmd: Twist, seen: &[Vec2]) -> Option<ClosingContact> {
        contact_with(cmd, seen, &params())
    }

    fn contact_with(cmd: Twist, seen: &[Vec2], p: &Params) -> Option<ClosingContact> {
        let fp = PaddedPolygon::base_0604();
        let mut poses = Vec::new();
        braking_poses(cmd, fp.circumscribed_radius_m(), p, &mut poses);
        first_polygon_contact(&fp, &poses, seen, &[], &[], p)
    }

    #[test]
    fn the_path_ends_where_braking_at_decel_ends() {
        // 0.2 m/s straight: 0.02 m in the step, then 0.2²/(2·1.0) = 0.02 m braking.
        let p = params();
        let mut poses = Vec::new();
        braking_poses(Twist::new(0.2, 0.0), 0.36, &p, &mut poses);
        let end = poses.last().unwrap();
        assert!((end.pos.x - 0.04).abs() < 1e-12 && end.pos.y.abs() < 1e-12, "{end:?}");
        assert!((end.t_s - 0.3).abs() < 1e-12 && end.vel.norm() < 1e-12);
        // A turn in place at 0.5 rad/s: 0.05 rad in the step, 0.5²/(2·1.0) = 0.125 rad braking.
        braking_poses(Twist::new(0.0, 0.5), 0.36, &p, &mut poses);
        let end = poses.last().unwrap();
        let turned = end.heading.y.atan2(end.heading.x);
        assert!((turned - 0.175).abs() < 1e-12, "{turned}");
        assert!(end.pos.norm() < 1e-12);
    }

    #[test]
    fn a_wall_ahead_inside_the_braking_distance_of_the_front_is_a_closing_contact() {
        // The front is at x = 0.3: a wall point 0.33 m ahead is reached after
        // 0.03 m, within the 0.04 m the robot travels at 0.2 m/s; at 0.36 m it is not.
        assert!(contact(Twist::new(0.2, 0.0), &[Vec2::new(0.33, 0.0)]).is_some());
        assert_eq!(contact(Twist::new(0.2, 0.0), &[Vec2::new(0.36, 0.0)]), None);
        // Beside the long side (0.25 m left of the centre, 0.05 m from the side) and
        // driving along it: touching nothing, closing on nothing.
        assert_eq!(contact(Twist::new(0.2, 0.0), &[Vec2::new(0.0, 0.25)]), None);
        // The circumscribed circle (0.3606 m) would call both of these contacts.
    }

    #[test]
    fn a_corner_swinging_into_a_wall_while_turning_in_place_is_a_closing_contact() {
        // A wall point 0.21 m to the left, 1 cm from the long side. Turning left at
        // 0.5 rad/s (0.175 rad to rest) swings the front-left corner (0.3, 0.2)
        // up to 0.3 sin α + 0.2 cos α = 0.2496 m at α = 0.175: into the wall
        // (the wall point at x ≈ 0.25 is crossed). A circle would not move.
        let wall: Vec<Vec2> = (-40..=40).map(|k| Vec2::new(0.01 * k as f64, 0.21)).collect();
        let hit = contact(Twist::new(0.0, 0.5), &wall);
        assert!(hit.is_some_and(|c| !c.mover), "{hit:?}");
        // Turning at 0.05 rad/s: 0.005 + 0.00125 rad, the corner rises by 2 mm: clear.
        assert_eq!(contact(Twist::new(0.0, 0.05), &wall), None);
        // Backing straight away from a point 1 cm inside the front: not closing.
        assert_eq!(contact(Twist::new(-0.1, 0.0), &[Vec2::new(0.29, 0.0)]), None);
    }

    #[test]
    fn the_body_keeps_the_seen_margin_from_a_point_it_backs_towards() {
        // The rear edge is at x = −0.3. Backing at 0.03 m/s: 3 mm in the step and
        // 0.45 mm braking. A point 8 mm behind the edge is not reached; with a 1 cm
        // margin it is already within it, closed on at 0.03 m/s (> 0.01).
        let behind = [Vec2::new(-0.308, 0.0)];
        let back = Twist::new(-0.03, 0.0);
        assert_eq!(contact(back, &behind), None);
        let mut p = params();
        p.passive.seen_margin_m = 0.01;
        assert!(contact_with(back, &behind, &p).is_some_and(|c| !c.mover));
        // 15 mm behind: 11.55 mm left at rest, beyond the margin.
        assert_eq!(contact_with(back, &[Vec2::new(-0.315, 0.0)], &p), None);
        // Beside the long side, 5 mm out, and driving along it: within the margin
        // but not closing.
        assert_eq!(contact_with(Twist::new(0.2, 0.0), &[Vec2::new(0.0, 0.205)], &p), None);
    }
}
