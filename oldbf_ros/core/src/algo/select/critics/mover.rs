//! Getting away from movers (ALGORITHM.md §5b's evasion, as a preference,
//! §5c): the candidate is held for `passive.evasion_horizon_s` against the
//! movers' predicted discs ([`EvasionScore`]); the cost is mostly how soon
//! the first contact comes (1 at once, 0 with none within the horizon),
//! plus how far the robot still stands inside the line of a mover coming
//! head-on at the horizon's end, plus, a little, how little room it keeps
//! to the movers on the way. It counts only while a mover threatens the
//! upstream command; otherwise it is 0 and not computed.

use crate::algo::params::Params;
use crate::algo::passive::{EvasionScore, GAP_CAP_M};

/// A line deficit this large (m, about a person's width) costs as much as
/// contact at once.
const LINE_SCALE_M: f64 = 0.1;
/// Contact sooner than this counts as this soon (s).
const MIN_TIME_S: f64 = 0.1;
/// Weight of the room kept, against the time to contact.
const GAP_SHARE: f64 = 4.0;

/// The unweighted cost of a command whose evasion score is `s` (0..2.25).
pub fn cost(s: &EvasionScore, p: &Params) -> f64 {
    let horizon = p.passive.evasion_horizon_s;
    let soon = (horizon / s.time_to_contact_s.max(MIN_TIME_S) - 1.0).max(0.0);
    let line = (s.line_deficit_m.max(0.0) / LINE_SCALE_M).min(3.0);
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
        let p = Params::default(); // horizon 5 s
        let score = |t: f64, gap: f64, line: f64| EvasionScore {
            time_to_contact_s: t,
            mover_contact_s: t,
            mover_gap_m: gap,
            line_deficit_m: line,
        };
        assert_eq!(cost(&score(5.0, f64::INFINITY, 0.0), &p), 0.0);
        assert!((cost(&score(2.5, 0.5, 0.0), &p) - 0.5).abs() < 1e-12);
        assert!((cost(&score(0.0, 0.0, 0.25), &p) - 1.75).abs() < 1e-12);
        assert!(cost(&score(3.0, 0.2, 0.0), &p) < cost(&score(2.0, 0.2, 0.0), &p));
    }
}
