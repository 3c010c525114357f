//! The selector's decision in the pipeline (ALGORITHM.md §5c): where the
//! robot is going this tick (the way round or the reference ahead), the
//! DOAA's command as the critics' guide, and the one selection.

use super::perceive::Frame;
use super::{next_points, Decision, SafetyPipeline, GOAL_SHORT_M, MOVER_NEAR_M};
use crate::algo::barrier::Barriers;
use crate::algo::clearance::Clearances;
use crate::algo::doaa::{sides_tie, DoaaState, TurnDirection};
use crate::algo::dtcbf::InputBox;
use crate::algo::geometry::{Twist, Vec2};
use crate::algo::select::{Geometry, SelectInput, Tier};
use crate::algo::unstuck::Situation;
use crate::algo::way_round::RouteAsk;

/// A waypoint within this of straight ahead (rad) says no side for the both-sides turn.
const ROUTE_SIDE_MIN_RAD: f64 = 0.1;

/// Where the robot is going this tick.
#[derive(Debug, Clone, Copy)]
struct Heading {
    /// The progress critic's target (robot frame, m).
    target: Option<Vec2>,
    /// A way round is being followed.
    following: bool,
    /// The goal lies short of what is ahead (a goal in front of a wall).
    goal_short: bool,
    /// No route to the goal: the robot rests.
    no_route: bool,
}

/// The side with more room (+1 left, −1 right): the clearer one, then the
/// less crowded one, then the right (§4b: two robots running this law
/// head-on both keep right and pass each other).
fn clearer_side(c: &Clearances) -> f64 {
    if !sides_tie(c) {
        if c.d_left_m > c.d_right_m {
            1.0
        } else {
            -1.0
        }
    } else if c.crowding_left < c.crowding_right {
        1.0
    } else {
        -1.0
    }
}

impl SafetyPipeline {
    /// Where the robot is going (§4b, §4c): the way round's waypoint while
    /// one is followed, else the point ahead on the reference; nothing
    /// without a reference. Planning in step, the route is planned here
    /// when due; beside the safety path, the latest route offered is used.
    fn heading(&mut self, now_s: f64, nominal: Twist, frame: &Frame, c: &Clearances) -> Heading {
        let p = &self.params;
        let guidance = self.guidance.take();
        let r = p.footprint.passing_half_width_m();
        let stuck = self.unstuck.take_stuck();
        self.route_ask = guidance.filter(|_| p.unstuck.enabled).map(|g| {
            // A robot already closer than the clearance to something (noise, a tight spot)
            // may move within the disc it is short by, or its own cells would be walled in.
            let clearance = r + p.barrier.d_safe_m + p.unstuck.margin_m;
            let cell = crate::algo::local_map::MAP_CELL_M;
            let nearest = self
                .points
                .points
                .iter()
                .map(|q| q.norm())
                .fold(f64::INFINITY, f64::min);
            let own_m = ((clearance - nearest).max(0.0) + 2.0 * cell)
                .min(nearest - cell)
                .max(0.0);
            RouteAsk {
                now_s,
                from: frame.pose.position(),
                goal: frame.pose.transform_point(g.end),
                direct_to: frame.pose.transform_point(g.ahead),
                own_m,
                stuck,
            }
        });
        if let Some(ask) = self.route_ask.filter(|_| !self.route_beside) {
            if self.way_round.due(&ask, p) {
                let (way, total) = (&mut self.way_round, &mut self.planner_us_total);
                self.route = Some(super::timed(self.planner_clock, total, || way.plan(&ask, p)));
            }
        }
        if !p.unstuck.enabled {
            self.way = Default::default();
            return Heading {
                target: guidance.map(|g| g.ahead),
                following: false,
                goal_short: false,
                no_route: false,
            };
        }
        // Only a mover on a collision course counts: a static object's track may look
        // like a slow mover now and then while the robot goes round it.
        let movers_near = self
            .threats
            .iter()
            .any(|t| t.position.norm() - t.radius_m < MOVER_NEAR_M + r);
        let now = Situation {
            now_s,
            nominal,
            ego: frame.pose,
            movers_near,
            movers_seen: self.tracker.tracks().iter().any(|t| t.is_moving(&p.obstacles)),
            route: self.route.as_ref(),
        };
        let way = self.unstuck.step(guidance, &now, p);
        self.way = way;
        if let Some(e) = way.event {
            log::debug!("t {now_s:.1}: way round: {}", e.as_str());
        }
        // Following with nowhere to go (boxed in): the upstream and the DOAA steer, its
        // both-sides turn at ω_0 being the paper's case of no gap.
        let following = self.unstuck.following() && way.waypoint.is_some();
        Heading {
            target: if following {
                way.waypoint
            } else {
                guidance.map(|g| g.ahead)
            },
            following,
            goal_short: guidance.is_some_and(|g| g.at_end && g.target.norm() + GOAL_SHORT_M < c.d_front_m + r),
            no_route: way.no_route,
        }
    }

    /// The selector's command for `nominal` (inside `bx`) at clearances `c`
    /// and barriers `b`; `closing_in`: h has fallen beyond its predictions.
    pub(super) fn decide_select(
        &mut self,
        now_s: f64,
        nominal: Twist,
        (c, b): (&Clearances, &Barriers),
        bx: &InputBox,
        frame: &Frame,
        closing_in: bool,
    ) -> Decision {
        let heading = self.heading(now_s, nominal, frame, c);
        // No route to the goal (§4c): the robot rests; the checks may still move it out of harm's way.
        let nominal = if heading.no_route { Twist::ZERO } else { nominal };
        let p = &self.params;
        // Something ahead beyond the goal does not block the way to it: no both-sides turn.
        let mut c_doaa = *c;
        if heading.goal_short {
            c_doaa.d_front_m = f64::INFINITY;
        }
        // Following a way round, the both-sides turn goes the route's way (a waypoint
        // within a few degrees of straight ahead says no side).
        let route_side = heading
            .target
            .filter(|_| heading.following)
            .map(|w| w.y.atan2(w.x))
            .filter(|b| b.abs() >= ROUTE_SIDE_MIN_RAD)
            .map(|b| {
                if b > 0.0 {
                    TurnDirection::Left
                } else {
                    TurnDirection::Right
                }
            });
        self.doaa.set_route_side(route_side);
        let (doaa_cmd, doaa_state) = self.doaa.command(nominal, &c_doaa, b, p);
        let d_act = p.barrier.d_act_m();
        let since_s = match now_s - self.last_sent_s {
            s if s.is_finite() && s >= 0.0 => s,
            _ => p.control.dt_s(),
        };
        let input = SelectInput {
            nominal,
            doaa: doaa_cmd,
            // Following a way round, the route has chosen which way to turn: the DOAA's
            // both-sides turn (towards the clearer side) counts only as its steering does,
            // in proportion to speed, or at rest the two turns cancel and hold the robot.
            doaa_both_sides: doaa_state == DoaaState::BothSides && !heading.following,
            last: self.last_cmd,
            last_change: self.last_change,
            since_s,
            bx: *bx,
            target: heading.target,
            front_blocked: c.d_front_m < d_act,
            front_clear: c.d_front_m >= d_act + p.doaa.both_sides_release_m,
            following: heading.following,
            clearer_side: clearer_side(c),
            closing_in: closing_in && p.passive.enabled,
            mover_closing: !self.threats.is_empty(),
        };
        let geometry = Geometry {
            points: &self.points.points,
            points_next: next_points(self.any_advanced, &self.points_next, &self.points.points),
            filter: &mut self.filter,
            passive: &mut self.passive,
        };
        log::trace!("t {now_s:.1}: selecting for nominal {nominal:?}, DOAA {doaa_cmd:?}");
        let s = self.selector.select(&input, geometry, p);
        let state = if s.h_m < 0.0 {
            DoaaState::Escape
        } else if matches!(s.tier, Tier::LeastBad | Tier::Brake) {
            DoaaState::Stop
        } else if s.threatened && !s.passed {
            DoaaState::Evade
        } else if heading.following {
            DoaaState::Follow
        } else {
            doaa_state
        };
        Decision {
            cmd: s.cmd,
            doaa_cmd,
            h_m: s.h_m,
            h_next_m: s.h_next_m,
            changed: !s.passed,
            condition_held: s.condition_held,
            passive_changed: s.threatened && !s.passed,
            infeasibility: s.tier.infeasibility(s.h_m),
            state,
            tier: Some(s.tier),
            costs: s.costs,
            added_motion: s.added_motion,
            evading: s.threatened,
        }
    }
}
