//! The robot's body as the one-step condition (§5) sees it: the paper's
//! circle of radius r, or a padded polygon (`footprint.polygon_m`, issue 26).
//!
//! h = (least clearance from the body to a point) − d_safe. For the circle
//! the clearance of a point P is ‖P‖ − r and a turn changes nothing; for a
//! polygon it is the signed distance from the polygon, which depends on the
//! heading: after a step that moves the robot by `disp` and turns it by θ,
//! a point P of the robot's frame now is seen at R(−θ)(P − disp).
//!
//! For a fixed yaw rate the step's displacement is linear in the speed
//! (`disp = v g`, g the displacement per m/s) and the turn does not depend
//! on it, so a point's place after the step runs along a straight line in
//! v: R(−θ)P − v R(−θ)g. The speeds it forbids are where that line comes
//! within the required clearance of the polygon, found exactly by
//! [`PaddedPolygon::forbidden_on_line`].

use super::footprint::{PaddedPolygon, Span};
use super::geometry::Vec2;

/// Speeds beyond any input box (m/s): the span the polygon's forbidden
/// speeds are sought over.
const SPEED_SPAN_MPS: f64 = 100.0;

/// `q` rotated by −θ, given (cos θ, sin θ).
#[inline]
fn unturn(q: Vec2, (c, s): (f64, f64)) -> Vec2 {
    Vec2::new(c * q.x + s * q.y, -s * q.x + c * q.y)
}

/// The least signed distance from `fp` to `points` after a step that moves
/// the robot by `disp` and turns it by θ = atan2(sin, cos) (m); +inf for no
/// points. Points farther from the robot's origin than the best so far
/// plus the circumscribed radius are skipped: their distance cannot be less.
pub fn polygon_clearance_after(fp: &PaddedPolygon, points: &[Vec2], disp: Vec2, turn: (f64, f64)) -> f64 {
    polygon_clearance_below(fp, points, disp, turn, f64::INFINITY)
}

/// [`polygon_clearance_after`] where only values below `cap` matter: the
/// least signed distance when it is below `cap`, else `cap` (points that
/// cannot come below it are not measured).
pub fn polygon_clearance_below(fp: &PaddedPolygon, points: &[Vec2], disp: Vec2, turn: (f64, f64), cap: f64) -> f64 {
    let reach = fp.circumscribed_radius_m();
    let mut best = cap;
    for &q in points {
        let rel = q - disp;
        let bound = best + reach;
        // ‖rel‖ − reach ≤ signed distance: skip when even that is no better.
        if bound >= 0.0 && rel.norm_squared() >= bound * bound {
            continue;
        }
        let d = fp.signed_distance(unturn(rel, turn));
        if d < best {
            best = d;
        }
    }
    best
}

/// Appends to `out` the open speed intervals (m/s) in which a point of
/// `points` comes closer than `need_m` to `fp` after one step at a yaw rate
/// whose step turns the robot by θ = atan2(turn.1, turn.0) and moves it by
/// `g` per m/s; sorted and merged. Points farther than `need_m` plus the
/// circumscribed radius plus `max_step_m` (the longest step of any speed
/// asked about) cannot forbid such a speed and are skipped.
#[allow(clippy::too_many_arguments)]
pub fn polygon_forbidden_speeds(
    fp: &PaddedPolygon,
    points: &[Vec2],
    g: Vec2,
    turn: (f64, f64),
    need_m: f64,
    max_step_m: f64,
    events: &mut Vec<f64>,
    out: &mut Vec<(f64, f64)>,
) {
    out.clear();
    let reach = need_m + fp.circumscribed_radius_m() + max_step_m;
    let d = -unturn(g, turn);
    let span = Span {
        lo: -SPEED_SPAN_MPS,
        hi: SPEED_SPAN_MPS,
    };
    let (radius, d_norm) = (fp.circumscribed_radius_m(), d.norm());
    for &q in points {
        if reach >= 0.0 && q.norm_squared() > reach * reach {
            continue;
        }
        let a = unturn(q, turn);
        // The whole line stays farther from the origin than the circumscribed radius
        // plus need: its signed distance never falls below need (‖x‖ − R ≤ it).
        if d_norm > 0.0 && (a.x * d.y - a.y * d.x).abs() / d_norm >= radius + need_m {
            continue;
        }
        fp.forbidden_on_line(a, d, need_m, span, events, out);
    }
    out.sort_unstable_by(|x, y| x.0.total_cmp(&y.0));
    let mut n = 0;
    for i in 0..out.len() {
        let cur = out[i];
        if n > 0 && cur.0 <= out[n - 1].1 {
            out[n - 1].1 = out[n - 1].1.max(cur.1);
        } else {
            out[n] = cur;
            n += 1;
        }
    }
    out.truncate(n);
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn a_wall_ahead_forbids_the_speeds_that_bring_the_front_within_need() {
        // Straight (θ = 0), 0.1 m per m/s (Δt = 0.1 s). A point 0.6 m ahead:
        // the front (x = 0.3) keeps 0.1 m from it while 0.3 − 0.1 v ≥ 0.1, i.e.
        // v ≤ 2 m/s; beyond, forbidden until the point has passed 0.1 m
        // behind the back: 0.6 − 0.1 v > −0.4, v < 10 m/s.
        let (mut ev, mut out) = (Vec::new(), Vec::new());
        let g = Vec2::new(0.1, 0.0);
        polygon_forbidden_speeds(
            &PaddedPolygon::base_0604(),
            &[Vec2::new(0.6, 0.0)],
            g,
            (1.0, 0.0),
            0.1,
            1.0,
            &mut ev,
            &mut out,
        );
        assert_eq!(out.len(), 1, "{out:?}");
        assert!(
            (out[0].0 - 2.0).abs() < 1e-9 && (out[0].1 - 10.0).abs() < 1e-9,
            "{out:?}"
        );
        // The circle of the same corner radius √0.13 = 0.3606 m would forbid from
        // (0.6 − 0.3606 − 0.1)/0.1 = 1.39 m/s: the polygon is exact, not the circle.
        // A point 0.35 m to the left, beside the long side (0.15 m of room),
        // forbids nothing straight ahead at need 0.1 ...
        polygon_forbidden_speeds(
            &PaddedPolygon::base_0604(),
            &[Vec2::new(0.0, 0.35)],
            g,
            (1.0, 0.0),
            0.1,
            1.0,
            &mut ev,
            &mut out,
        );
        assert!(out.is_empty(), "{out:?}");
        // ... but turning towards it by 0.6 rad in the step, the corner (0.3, 0.2)
        // swings out: standing still (v = 0) is then forbidden too.
        let th: f64 = 0.6;
        polygon_forbidden_speeds(
            &PaddedPolygon::base_0604(),
            &[Vec2::new(0.0, 0.35)],
            Vec2::zeros(),
            (th.cos(), th.sin()),
            0.1,
            1.0,
            &mut ev,
            &mut out,
        );
        assert_eq!(out, [(-SPEED_SPAN_MPS, SPEED_SPAN_MPS)]);
    }

    #[test]
    fn clearance_after_a_step_by_hand() {
        let fp = PaddedPolygon::base_0604();
        // The point 0.35 m to the left: 0.15 m from the side now.
        let pts = [Vec2::new(0.0, 0.35), Vec2::new(3.0, 0.0)];
        assert!((polygon_clearance_after(&fp, &pts, Vec2::zeros(), (1.0, 0.0)) - 0.15).abs() < 1e-12);
        // After moving 0.1 m left: 0.05 m.
        let got = polygon_clearance_after(&fp, &pts, Vec2::new(0.0, 0.1), (1.0, 0.0));
        assert!((got - 0.05).abs() < 1e-12, "{got}");
        // Turned by a quarter turn: the short side (x = 0.3) faces it, 0.05 m away.
        let got = polygon_clearance_after(&fp, &pts, Vec2::zeros(), (0.0, 1.0));
        assert!((got - 0.05).abs() < 1e-12, "{got}");
        assert_eq!(
            polygon_clearance_after(&fp, &[], Vec2::zeros(), (1.0, 0.0)),
            f64::INFINITY
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]

        /// The skips change nothing: every speed agrees with the plain
        /// definition, each point's signed distance after the step.
        #[test]
        fn forbidden_speeds_and_clearance_match_the_plain_definition(
            pts in prop::collection::vec((-2.0..2.0f64, -2.0..2.0f64), 1..12),
            th in -0.3..0.3f64, gx in -0.1..0.1f64, gy in -0.02..0.02f64,
            need in 0.0..0.3f64, pad in 0.0..0.05f64,
        ) {
            let fp = PaddedPolygon { padding_m: pad, ..PaddedPolygon::base_0604() };
            let pts: Vec<Vec2> = pts.into_iter().map(|(x, y)| Vec2::new(x, y)).collect();
            let turn = (th.cos(), th.sin());
            let g = Vec2::new(gx, gy);
            let (mut ev, mut out) = (Vec::new(), Vec::new());
            // Speeds up to 1 m/s: steps up to |g|.
            polygon_forbidden_speeds(&fp, &pts, g, turn, need, g.norm(), &mut ev, &mut out);
            for k in 0..=200 {
                let v = -1.0 + 2.0 * k as f64 / 200.0;
                let plain = pts.iter().map(|&q| fp.signed_distance(unturn(q - v * g, turn))).fold(f64::INFINITY, f64::min);
                let fast = polygon_clearance_after(&fp, &pts, v * g, turn);
                prop_assert!((plain - fast).abs() <= 1e-12, "{} vs {}", plain, fast);
                if (plain - need).abs() < 1e-9 || out.iter().any(|&(a, b)| (v - a).abs() < 1e-9 || (v - b).abs() < 1e-9) {
                    continue;
                }
                let forbidden = out.iter().any(|&(a, b)| v > a && v < b);
                prop_assert_eq!(forbidden, plain < need, "v {} plain {} {:?}", v, plain, out);
            }
        }
    }
}
