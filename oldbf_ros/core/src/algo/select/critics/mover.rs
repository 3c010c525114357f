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
use crate::algo::passive::{EvasionScore, GAP_CAP_M};

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
}
