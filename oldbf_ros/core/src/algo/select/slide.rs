//! The heading to drive on when the target's bearing is closed (ALGORITHM.md
//! §5c): the direction of travel nearest that bearing along which the
//! margin level (§5's condition on h − δ) still lets the robot drive at the
//! speed asked. The progress critic measures a candidate's heading against
//! it instead of the bearing.
//!
//! Why: near an obstacle the margin level forbids every speed whose step
//! would bring the robot closer than the condition allows, so a robot facing
//! its target across the corner of a bench can only turn in place. Turned
//! towards the target it stays blocked; turned along the bench it can drive
//! on, keeping its distance, and past the bench's end the bearing opens
//! again. The progress critic's heading term is what decides which way a
//! robot at rest turns, so it has to point at where the robot can go.
//!
//! A point q at distance |q| (h_q = |q| − r − d_safe beyond the unsafe set)
//! lets a step of length s at bearing ψ through when its approach
//! s cos(ψ − ∠q) is at most γ max(h_q − δ, 0), the margin level's allowance
//! linearised: q closes the headings within acos(γ max(h_q − δ, 0) / s)
//! of its bearing, π/2 at h_q ≤ δ. Points whose allowance reaches s close
//! nothing. The free heading is found by sweeping from the bearing to each
//! side past the closed arcs; only one within a right angle of the bearing
//! counts (farther, driving on leads away from the target); the nearer side
//! wins, and within
//! [`TIE_RAD`] the side preferred (the one the DOAA's law or the side kept
//! turns to), so a symmetric obstacle does not make the robot swing.

use crate::algo::geometry::{wrap_angle, Vec2};
use crate::algo::params::Params;

/// Two sides whose free headings lie within this of each other (rad) are
/// taken as equal: the preferred side wins.
pub const TIE_RAD: f64 = 0.35;

/// The farthest an open heading may lie from the target's bearing (rad) to
/// be aimed at: a right angle, beyond which driving on leads away.
pub const MAX_OFFSET_RAD: f64 = std::f64::consts::FRAC_PI_2;

/// How far past the end of a closed arc the free heading lies (rad): off
/// its edge, where rounding cannot close it again. An open gap between two
/// arcs narrower than this is stepped over: no direction to drive along.
const PAST_RAD: f64 = 1e-3;

/// The closed arcs of one step: each closing point's bearing and the
/// half-width of the headings it closes (rad). Kept between steps so the
/// scan path does not allocate.
#[derive(Debug, Clone, Default)]
pub struct Slide {
    arcs: Vec<(f64, f64)>,
}

impl Slide {
    /// Room for `points` closing points without reallocating.
    pub fn with_capacity(points: usize) -> Self {
        Self {
            arcs: Vec::with_capacity(points),
        }
    }

    /// The free heading nearest `bearing_rad` (robot frame), or `None` when
    /// the bearing itself is open, or no open heading lies within
    /// [`MAX_OFFSET_RAD`] of it (then the bearing stays the goal: nothing
    /// that gets nearer is known). `near` is the surroundings (robot frame,
    /// m) sorted by distance, nearest first; `step_m` the length of a step at
    /// the speed asked; `prefer` the side preferred on a tie (+1 left, −1
    /// right, 0 none).
    pub fn heading(&mut self, near: &[Vec2], bearing_rad: f64, step_m: f64, prefer: f64, p: &Params) -> Option<f64> {
        if step_m <= 0.0 || !bearing_rad.is_finite() {
            return None;
        }
        let required = p.robot_radius_m() + p.barrier.d_safe_m;
        let (gamma, delta) = (p.dtcbf.gamma, p.dtcbf.noise_margin_m);
        // The points that close anything: sorted by distance, so the allowance only
        // grows along `near`; the first that lets a whole step through ends them.
        let allowance = |q: &Vec2| gamma * (q.norm() - required - delta).max(0.0);
        let closing = near.partition_point(|q| allowance(q) < step_m);
        self.arcs.clear();
        self.arcs.extend(
            near[..closing]
                .iter()
                .map(|q| (q.y.atan2(q.x), (allowance(q) / step_m).acos())),
        );
        // Only a heading along which the robot still nears the target is worth turning
        // to: beyond a right angle the open side leads away, and the bearing stays.
        let left = sweep(&self.arcs, bearing_rad, 1.0, MAX_OFFSET_RAD);
        let right = sweep(&self.arcs, bearing_rad, -1.0, MAX_OFFSET_RAD);
        let (left, right) = match (left, right) {
            (Some(0.0), _) | (_, Some(0.0)) | (None, None) => return None,
            (l, r) => (l.unwrap_or(f64::INFINITY), r.unwrap_or(f64::INFINITY)),
        };
        let go_left = if (left - right).abs() <= TIE_RAD && prefer != 0.0 {
            prefer > 0.0
        } else {
            left <= right
        };
        Some(wrap_angle(if go_left {
            bearing_rad + left
        } else {
            bearing_rad - right
        }))
    }
}

/// How far (rad) from `bearing` towards `side` (+1 left, −1 right) the first
/// heading no closed arc (bearing, half-width) holds lies: 0 for an open
/// bearing, `None` when it lies beyond `limit_rad` (or nowhere).
fn sweep(arcs: &[(f64, f64)], bearing: f64, side: f64, limit_rad: f64) -> Option<f64> {
    let mut offset = 0.0;
    // Each pass leaves every arc holding the heading; an arc once left is not
    // met again before the whole circle is swept, so `arcs.len()` passes suffice
    // (one more to check the limit itself).
    for _ in 0..=arcs.len() + 1 {
        let at = bearing + side * offset;
        let mut exit = 0.0_f64;
        for &(centre, w) in arcs {
            let off = wrap_angle(centre - at);
            if off.abs() < w {
                // Leaving towards `side` means reaching the arc's edge on that side.
                exit = exit.max(w + side * off);
            }
        }
        if exit == 0.0 {
            return Some(offset);
        }
        // An edge short of the limit leaves open headings within it, even when
        // stepping past the edge overshoots: the limit itself is taken.
        let edge = offset + exit;
        if edge >= limit_rad {
            return None;
        }
        offset = (edge + PAST_RAD).min(limit_rad);
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};

    fn heading(near: &[Vec2], bearing_rad: f64, step_m: f64, prefer: f64, p: &Params) -> Option<f64> {
        Slide::default().heading(near, bearing_rad, step_m, prefer, p)
    }

    /// A point at h = `h` (beyond r + d_safe of the defaults, 0.378 m) and
    /// bearing `angle`. The defaults also have δ = 0.03 m, γ = 0.2.
    fn at(h: f64, angle: f64) -> Vec2 {
        let p = Params::default();
        let d = p.robot_radius_m() + p.barrier.d_safe_m + h;
        Vec2::new(d * angle.cos(), d * angle.sin())
    }

    #[test]
    fn an_open_bearing_is_kept() {
        let p = Params::default();
        // Ahead at h = 0.03: it closes ±90° round straight ahead; the bearing behind is open.
        let near = [at(0.03, 0.0)];
        assert_eq!(heading(&near, 3.0, 0.022, 0.0, &p), None);
        // Far enough that its allowance γ(h − δ) lets a whole step through: nothing closed.
        let far = [at(0.03 + 0.12, 0.0)];
        assert_eq!(heading(&far, 0.0, 0.022, 0.0, &p), None);
    }

    #[test]
    fn at_the_margin_a_point_closes_the_half_circle_towards_it() {
        let p = Params::default();
        // A point 45° to the right at h = δ: headings within 90° of it are closed. A
        // target straight ahead is reached by sliding along at 45° left (the other edge,
        // 135° right, leads away).
        let near = [at(0.03, -FRAC_PI_4)];
        let psi = heading(&near, 0.0, 0.022, 0.0, &p).unwrap();
        assert!((psi - FRAC_PI_4).abs() < 2e-3, "{psi}");
        // A target at its very bearing: both edges a right angle away, neither nears it.
        assert_eq!(heading(&near, -FRAC_PI_4, 0.022, 0.0, &p), None);
        // A target 100° right: the edge at 135° right is 35° from it.
        let psi = heading(&near, -100f64.to_radians(), 0.022, 0.0, &p).unwrap();
        assert!((psi + 3.0 * FRAC_PI_4).abs() < 2e-3, "{psi}");
    }

    #[test]
    fn farther_points_close_narrower_arcs() {
        let p = Params::default();
        // h = 0.085: allowance 0.2 × 0.055 = 0.011 m of a 0.022 m step: acos(0.5) = 60°.
        let near = [at(0.085, 0.0)];
        let psi = heading(&near, 0.2, 0.022, 0.0, &p).unwrap();
        assert!((psi - std::f64::consts::FRAC_PI_3).abs() < 2e-3, "{psi}");
    }

    #[test]
    fn a_post_ahead_is_passed_on_the_preferred_side_and_a_nearer_edge_wins() {
        let p = Params::default();
        // A post dead ahead at h = 0.085: it closes ±60° (see above).
        let near = [at(0.085, 0.0)];
        let edge = std::f64::consts::FRAC_PI_3;
        let left = heading(&near, 0.0, 0.022, 1.0, &p).unwrap();
        assert!((left - edge).abs() < 2e-3, "{left}");
        let right = heading(&near, 0.0, 0.022, -1.0, &p).unwrap();
        assert!((right + edge).abs() < 2e-3, "{right}");
        // A target 0.3 rad to the right, no preference: the nearer edge, right.
        assert!((heading(&near, -0.3, 0.022, 0.0, &p).unwrap() + edge).abs() < 2e-3);
        // Within the tie (0.6 rad apart is not), a preference for the farther side
        // does not count.
        assert!(heading(&near, -0.3, 0.022, 1.0, &p).unwrap() < 0.0);
        assert!(heading(&near, -0.1, 0.022, 1.0, &p).unwrap() > 0.0);
    }

    #[test]
    fn a_wall_ahead_at_the_margin_leaves_the_bearing() {
        let p = Params::default();
        // A wall across the path at h = δ, from −20° to 20°: it closes −110°..110°. Every
        // open heading leads away from a target straight ahead: nothing to slide along.
        let mut wall: Vec<Vec2> = (-5..=5).map(|k| at(0.03, k as f64 * 0.07)).collect();
        wall.sort_by(|a, b| a.norm().total_cmp(&b.norm()));
        assert_eq!(heading(&wall, 0.0, 0.022, 1.0, &p), None);
        // A target 60° to the left: the left edge lies 50° from it.
        let psi = heading(&wall, std::f64::consts::FRAC_PI_3, 0.022, 0.0, &p).unwrap();
        assert!((psi - (FRAC_PI_2 + 0.35)).abs() < 2e-3, "{psi}");
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(300))]

        /// Against a plain reference, headings sampled every 0.5 mrad: the
        /// heading returned is open, none nearer the bearing on its side is,
        /// the other side has none nearer by more than the tie, and it lies
        /// within a right angle; `None` only for an open bearing or when
        /// nothing open lies within a right angle on either side.
        #[test]
        fn the_sweep_finds_the_nearest_open_heading(
            pts in proptest::collection::vec((-3.2..3.2f64, 0.0..0.14f64), 1..10),
            bearing in -3.2..3.2f64,
            prefer in -1i32..=1,
        ) {
            let p = Params::default();
            let mut near: Vec<Vec2> = pts.iter().map(|&(a, h)| at(h, a)).collect();
            near.sort_by(|a, b| a.norm().total_cmp(&b.norm()));
            let step = 0.022;
            let required = p.robot_radius_m() + p.barrier.d_safe_m;
            let closed = |psi: f64| near.iter().any(|q| {
                let allow = p.dtcbf.gamma * (q.norm() - required - p.dtcbf.noise_margin_m).max(0.0);
                allow < step && step * wrap_angle(psi - q.y.atan2(q.x)).cos() > allow + 1e-9
            });
            // The nearest open offset on each side within a right angle, sampled: any
            // open heading (`strict`), and one open across 2 PAST_RAD (`wide`). Gaps
            // narrower than PAST_RAD are stepped over, so the sweep's answer lies
            // between the two.
            let first_open = |side: f64, width: f64| (0..=3142).map(|k| f64::from(k) * 5e-4)
                .find(|&o| (0..=4).all(|j| !closed(bearing + side * (o + width * f64::from(j) / 4.0))));
            let got = heading(&near, bearing, step, f64::from(prefer), &p);
            let strict = |side: f64| first_open(side, 0.0);
            let wide = |side: f64| first_open(side, 2.0 * PAST_RAD);
            match got {
                None => proptest::prop_assert!(
                    strict(1.0) == Some(0.0) || (wide(1.0).is_none() && wide(-1.0).is_none()),
                    "None with open offsets {:?} {:?}", wide(1.0), wide(-1.0)),
                Some(psi) => {
                    let off = wrap_angle(psi - bearing);
                    let side = off.signum();
                    proptest::prop_assert!(off.abs() <= MAX_OFFSET_RAD + 1e-9);
                    proptest::prop_assert!(!closed(psi), "{psi} is closed");
                    let nearest = strict(side).expect("the heading returned is open");
                    proptest::prop_assert!(off.abs() >= nearest - 2e-3, "sampled {nearest}, swept {off}");
                    if let Some(w) = wide(side) {
                        proptest::prop_assert!(off.abs() <= w + 2e-3, "a gap at {w} skipped, swept {off}");
                    }
                    if let Some(o) = wide(-side) {
                        proptest::prop_assert!(o >= off.abs() - TIE_RAD - 2e-3, "the other side {o} beats {off}");
                    }
                }
            }
        }
    }

    #[test]
    fn a_gap_narrower_than_the_step_past_an_edge_is_stepped_over() {
        let p = Params::default();
        // Found by the property test: the arc of a point at h = 0 ends about 1 mrad
        // before that of a point at h = 0.06 begins. The sweep steps over that sliver;
        // the next open heading lies beyond a right angle, so the bearing stays.
        let mut near = vec![
            at(0.059_819_215_016_854_42, -0.141_594_325_434_426_35),
            at(0.0, -3.009_377_441_608_440_7),
        ];
        near.sort_by(|a, b| a.norm().total_cmp(&b.norm()));
        assert_eq!(heading(&near, -2.442_965_363_390_515_5, 0.022, 0.0, &p), None);
    }

    #[test]
    fn a_robot_hemmed_in_all_round_keeps_the_bearing() {
        let p = Params::default();
        let mut ring: Vec<Vec2> = (0..8).map(|k| at(0.03, k as f64 * FRAC_PI_4)).collect();
        ring.sort_by(|a, b| a.norm().total_cmp(&b.norm()));
        assert_eq!(heading(&ring, 0.3, 0.022, 1.0, &p), None);
    }
}
