//! Getting away from movers (ALGORITHM.md §5b's evasion, as a preference,
//! §5c): the candidate, going on as its profile says (held, or braking or
//! turning on at the base's limits when it is at the window's edge), is
//! followed for `passive.evasion_horizon_s` against the movers' predicted
//! discs ([`EvasionScore`]). The cost adds three parts:
//!
//! * how soon the first contact comes, H/t − 1 for contact at t within the
//!   horizon H (0 with none; contact sooner than 0.1 s counts as at 0.1 s):
//!   small differences far off, large ones when contact is near, so evasion
//!   wins over every other preference exactly when it matters;
//! * how far the robot still stands inside the line of a mover coming at it
//!   (head-on or from behind) at the horizon's end, 1 per 0.1 m, at most 3:
//!   stepping out of a person's way, not only backing along it;
//! * how little room it keeps to the movers on the way, up to 4 for none
//!   (the mean body-to-mover distance capped at 0.5 m).
//!
//! It counts only while a mover threatens the command being made safe;
//! otherwise it is 0 and not computed.

use crate::algo::params::Params;
use crate::algo::passive::{EvasionScore, EvasionSoFar, GAP_CAP_M};

/// A line deficit of this much (m) costs 1…
const LINE_SCALE_M: f64 = 0.1;
/// …up to this much.
const LINE_MAX: f64 = 3.0;
/// Contact sooner than this counts as this soon (s).
const MIN_TIME_S: f64 = 0.1;
/// The cost of keeping no room at all to the movers.
const GAP_SHARE: f64 = 4.0;

/// The unweighted cost of a command whose evasion score is `s` (0 to about 56).
pub fn cost(s: &EvasionScore, p: &Params) -> f64 {
    let horizon = p.passive.evasion_horizon_s;
    let soon = (horizon / s.time_to_contact_s.max(MIN_TIME_S) - 1.0).max(0.0);
    let line = (s.line_deficit_m.max(0.0) / LINE_SCALE_M).min(LINE_MAX);
    let gap = if s.mover_gap_m.is_finite() {
        GAP_SHARE * (GAP_CAP_M - s.mover_gap_m.clamp(0.0, GAP_CAP_M)) / GAP_CAP_M
    } else {
        0.0
    };
    soon + line + gap
}

/// A lower bound of [`cost`] of the score a walk will end with, from what
/// it has found so far: the time term once a contact is found (it is final
/// then), the gap term with every sample still to come at the cap, none of
/// the line term. A candidate whose other costs plus this already reach the
/// best total so far cannot win, and its walk stops there.
pub fn cost_at_least(s: &EvasionSoFar, p: &Params) -> f64 {
    let horizon = p.passive.evasion_horizon_s;
    let soon = s
        .contact_s
        .map_or(0.0, |t| (horizon / t.max(MIN_TIME_S) - 1.0).max(0.0));
    let gap = if s.movers && s.samples > 0 {
        let to_come = s.samples.saturating_sub(s.samples_done) as f64;
        let most = (s.gap_sum_m + GAP_CAP_M * to_come) / s.samples as f64;
        GAP_SHARE * (GAP_CAP_M - most.clamp(0.0, GAP_CAP_M)) / GAP_CAP_M
    } else {
        0.0
    };
    soon + gap
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn later_contact_and_more_room_cost_less() {
        // Horizon 5 s; a line deficit of 0.1 m costs 1; room short of 0.5 m costs 4 per 0.5 m.
        let p = Params::default();
        let score = |t: f64, gap: f64, line: f64| EvasionScore {
            time_to_contact_s: t,
            mover_contact_s: t,
            mover_gap_m: gap,
            line_deficit_m: line,
        };
        assert_eq!(cost(&score(5.0, f64::INFINITY, 0.0), &p), 0.0);
        // Contact at 2.5 s: 5/2.5 − 1 = 1; all the room kept.
        assert!((cost(&score(2.5, 0.5, 0.0), &p) - 1.0).abs() < 1e-12);
        // Contact at once counts as at 0.1 s (49), no room (4), 0.05 m deep in a line (0.5).
        assert!((cost(&score(0.0, 0.0, 0.05), &p) - 53.5).abs() < 1e-9);
        // Deep in the line: at most 3.
        assert!((cost(&score(5.0, 0.5, 2.0), &p) - 3.0).abs() < 1e-12);
        assert!(cost(&score(3.0, 0.2, 0.0), &p) < cost(&score(2.0, 0.2, 0.0), &p));
        assert!(cost(&score(2.0, 0.3, 0.0), &p) < cost(&score(2.0, 0.2, 0.0), &p));
    }

    proptest::proptest! {
        /// The bound a walk gives as it goes never exceeds the cost it ends
        /// with: a walk stopped on it is one whose cost would have reached it.
        #[test]
        fn the_bound_on_the_way_never_exceeds_the_final_cost(
            movers in proptest::collection::vec(
                ((-2.5f64..2.5, -2.5f64..2.5), (-0.8f64..0.8, -0.8f64..0.8), 0.1f64..0.4), 0..4),
            points in proptest::collection::vec((-1.5f64..1.5, -1.5f64..1.5), 0..20),
            cmd in (-0.22f64..0.22, -0.3f64..0.3),
            goal in (-0.22f64..0.22, -0.3f64..0.3),
            held in proptest::bool::ANY,
        ) {
            use crate::algo::geometry::{Twist, Vec2};
            use crate::algo::passive::{Mover, PassiveSafety, Profile};
            let p = Params::default();
            let points: Vec<Vec2> = points.into_iter().map(|(x, y)| Vec2::new(x, y)).collect();
            let mut ps = PassiveSafety::with_capacity(4, 32);
            ps.set_movers(movers.iter().map(|&((x, y), (vx, vy), radius_m)| Mover {
                position: Vec2::new(x, y),
                velocity: Vec2::new(vx, vy),
                radius_m,
            }));
            ps.prepare(&points, &p);
            ps.select_reach(&points, &p);
            let cmd = Twist::new(cmd.0, cmd.1);
            let profile = if held {
                Profile::held(cmd)
            } else {
                Profile { cmd, goal: Twist::new(goal.0, goal.1), rates: (1.0, 1.0) }
            };
            let mut bounds = Vec::new();
            let score = ps.evasion_score_until(profile, &p, |so_far| {
                bounds.push(cost_at_least(so_far, &p));
                false
            });
            let Some(score) = score else {
                return Err(proptest::test_runner::TestCaseError::fail("walk stopped unasked"));
            };
            let c = cost(&score, &p);
            for (k, b) in bounds.iter().enumerate() {
                proptest::prop_assert!(*b <= c + 1e-12, "sample {}: bound {} > cost {}", k, b, c);
            }
            // And at the end it is the cost, but for the line term.
            let last = bounds.last().copied().unwrap_or(0.0);
            let line = (score.line_deficit_m.max(0.0) / LINE_SCALE_M).min(LINE_MAX);
            proptest::prop_assert!((last + line - c).abs() < 1e-9, "{} + {} vs {}", last, line, c);
        }
    }
}
