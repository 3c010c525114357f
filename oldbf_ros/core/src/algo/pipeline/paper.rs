//! The paper's decision (`select.enabled: false`, the `oldbf-paper`
//! controller, ALGORITHM.md §4, §5): the DOAA command, then the DTCBF
//! filter's own search: keep ω and lower v; else the closest admissible
//! command of the box; else the least-bad or turn-in-place fallbacks. No
//! window, no braking check, no evasion, no way round: the filter as the
//! paper defines it, kept so the tables measure the difference on the same
//! worlds.

use super::{next_points, Decision, SafetyPipeline};
use crate::algo::barrier::Barriers;
use crate::algo::clearance::Clearances;
use crate::algo::doaa::DoaaState;
use crate::algo::dtcbf::InputBox;
use crate::algo::geometry::Twist;
use crate::algo::record::Infeasibility;
use crate::algo::select::CriticCosts;

impl SafetyPipeline {
    /// The paper's command for `nominal` (inside `bx`) at clearances `c`
    /// and barriers `b`.
    pub(super) fn decide_paper(&mut self, nominal: Twist, c: &Clearances, b: &Barriers, bx: &InputBox) -> Decision {
        let p = &self.params;
        let (doaa_cmd, doaa_state) = self.doaa.command(nominal, c, b, p);
        self.filter.set_closing_in(false);
        let next = next_points(self.any_advanced, &self.points_next, &self.points.points);
        let out = self.filter.filter_in(&self.points.points, next, doaa_cmd, p, bx);
        // A step is feasible only if its command meets the logged condition: inside the
        // unsafe set the filter may send an escape command that only raises h by ε.
        let infeasibility = (out.infeasible || !out.condition_held).then_some(if out.h_m < 0.0 {
            Infeasibility::UnsafeSet
        } else {
            Infeasibility::Approaching
        });
        let state = match (out.infeasible, out.escape) {
            (true, false) => DoaaState::Stop,
            (_, true) => DoaaState::Escape,
            (false, false) => doaa_state,
        };
        Decision {
            cmd: out.cmd,
            doaa_cmd,
            h_m: out.h_m,
            h_next_m: out.h_next_m,
            changed: out.changed,
            condition_held: out.condition_held,
            passive_changed: false,
            infeasibility,
            state,
            tier: None,
            costs: CriticCosts::default(),
            added_motion: false,
            evading: false,
        }
    }
}
