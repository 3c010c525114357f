//! Unstuck (ALGORITHM.md §4b, §4c): getting round obstacles that the
//! reactive steering alone would drive at.
//!
//! DOAA is reactive: with the reference behind an obstacle, the tracking law
//! pulls the robot at it and the barriers push it away, and it can stand
//! there for the rest of the run (no contact, no progress). This module
//! decides when the robot follows the way round planned on the rolling
//! local map ([`super::way_round`]) instead of the reference, and where on
//! that route it steers:
//!
//! * **Progress** is the reference's arc length minus the robot's distance to
//!   the (governed) reference point, in m: it grows while the reference runs
//!   and while the robot closes in on it; a robot held up by an obstacle,
//!   with the governor holding the reference, makes none.
//! * **Follow** at once when the straight way from the robot to the point
//!   `unstuck.ahead_m` further along the reference (where the tracking law
//!   is heading) runs through the map's blocked band (cells nearer than
//!   r + d_safe + `unstuck.margin_m` to something seen, walking people left
//!   out) and no moving track has been seen for [`MOVERS_QUIET_S`]: the
//!   reactive steering picks its side by the nearest surface, not by where
//!   the way through is, and at a wall with a door it drives into the
//!   wall's corner first. That follow is *blocked*. With people about, and
//!   when the straight way is clear, the follow begins only once progress
//!   has stalled: less than `unstuck.progress_m` for `unstuck.stall_s`
//!   while the nominal asks to move (*blocked* or *stalled* by the straight
//!   way). The reactive steering and evasion deal with people, and the
//!   route, which leaves walking people out, could lead into them. The
//!   nominal becomes a turn towards the route's farthest point within 1 m
//!   along that the robot sees in a straight line clear of the blocked band
//!   (the DOAA's both-sides turn goes the same way); the route itself is
//!   kept until blocked, beaten by a margin or its goal moves
//!   ([`super::route`]).
//! * **Release**, with its reason recorded: the straight way is clear again
//!   by [`RELEASE_MARGIN_M`] (a follow begun on a blocked way), progress has
//!   grown by `unstuck.progress_m` (one begun on a stall), the reference
//!   point is within the capture radius with the straight way clear or at
//!   the reference's end, or a tracked mover on a collision
//!   course has come near (a robot held up by people waits for them to
//!   pass: DOAA and evasion deal with movers; going round them is not this).
//! * **No route**: closed in by what the map knows (a narrow doorway in a
//!   closed room), the goal cannot be reached: it is reported and the robot
//!   rests (its nominal is zero). With a route but nowhere to go along it
//!   (boxed in), the nominal is a turn in place: the paper's ω_0 case.
//!
//! Everything still goes through the DTCBF and the passive checks.

use super::geometry::{wrap_angle, Pose2, Twist, Vec2};
use super::params::Params;
use super::reference::{ReferenceProgress, ReferenceTrajectory};
use super::route::RouteChange;
use super::way_round::RouteUpdate;

/// A follow begun on a blocked straight way ends once that way is clear by this (m).
pub const RELEASE_MARGIN_M: f64 = 0.05;
/// While following, neither moving `unstuck.progress_m` nor turning
/// [`STUCK_TURN_RAD`] for this fraction of `unstuck.stall_s` is stuck (a
/// robot turning to face its waypoint is not).
pub const STUCK_FRACTION: f64 = 0.5;
/// See [`STUCK_FRACTION`] (rad).
pub const STUCK_TURN_RAD: f64 = 0.5;
/// A route planned longer ago than this is not followed (s): the planner has stopped.
pub const ROUTE_STALE_S: f64 = 3.0;
/// A blocked straight way is gone round at once only when no moving track
/// has been seen for this long (s), counted from the first step: a walking
/// person's track can drop out for a scan or two, and a person needs a few
/// scans to be tracked as moving.
pub const MOVERS_QUIET_S: f64 = 5.0;
/// A route point steered at next that lies within this of the aim now (m)
/// is glided to over one `unstuck.plan_period_s`; a farther one (another
/// way) is steered at at once.
pub const GLIDE_MAX_M: f64 = 0.5;

/// The aim moving from one route point to the next (tracking frame, m; s).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Glide {
    from: Vec2,
    to: Vec2,
    since_s: f64,
}

impl Glide {
    /// Steering at `to` from `now_s` on, without a glide.
    fn at_once(to: Vec2, now_s: f64) -> Self {
        Self {
            from: to,
            to,
            since_s: now_s,
        }
    }

    /// Where the aim is at `now_s`, gliding over `period_s`.
    fn at(&self, now_s: f64, period_s: f64) -> Vec2 {
        let f = ((now_s - self.since_s) / period_s).clamp(0.0, 1.0);
        self.from + (self.to - self.from) * f
    }
}

/// Where the nominal command is heading: the governed reference point and
/// how far along its path it is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Guidance {
    /// The reference point in the robot frame now (m).
    pub target: Vec2,
    /// The reference's arc length so far (m).
    pub along_m: f64,
    /// The point `unstuck.ahead_m` further along the reference's path (its
    /// end at most), robot frame (m): where the tracking law is heading.
    pub ahead: Vec2,
    /// Where the route goes, robot frame (m): the farthest point of the
    /// reference ahead that it reaches nearly straight (within
    /// [`CHORD_DEVIATION_M`] of the chord, at most [`ROUTE_GOAL_MAX_M`] along):
    /// the goal at the end of a line, a point a little ahead on a curve.
    pub end: Vec2,
    /// The reference has run to its end: `target` is the goal.
    pub at_end: bool,
}

impl Guidance {
    /// The guidance of a governed reference: its point now (`progress`), the
    /// point `ahead_m` further along, seen from the robot at `robot` (same
    /// frame as the reference, e.g. odometry).
    pub fn of_reference(
        reference: &ReferenceTrajectory,
        progress: &ReferenceProgress,
        robot: Pose2,
        ahead_m: f64,
    ) -> Guidance {
        let speed = reference.v_mps.abs().max(1e-9);
        let ahead = reference.pose_at(progress.t_s + ahead_m / speed).position();
        Guidance {
            target: robot.inverse_transform_point(reference.pose_at(progress.t_s).position()),
            along_m: progress.t_s.min(reference.duration_s) * reference.v_mps.abs(),
            ahead: robot.inverse_transform_point(ahead),
            end: robot.inverse_transform_point(straight_ahead(reference, progress.t_s)),
            at_end: progress.finished(reference),
        }
    }

    /// All coordinates finite.
    fn is_finite(&self) -> bool {
        [self.target, self.ahead, self.end]
            .iter()
            .all(|v| v.x.is_finite() && v.y.is_finite())
            && self.along_m.is_finite()
    }
}

/// The route's goal is at most this far along the reference (m): inside a
/// local map of 12 m round the robot.
pub const ROUTE_GOAL_MAX_M: f64 = 5.0;
/// The reference between its point now and the route's goal stays within
/// this of the straight line between them (m).
pub const CHORD_DEVIATION_M: f64 = 0.3;
/// Spacing of the reference samples checked (m).
const CHORD_STEP_M: f64 = 0.1;

/// The farthest point of `reference` from its point at `t_s` that it
/// reaches nearly straight: within [`CHORD_DEVIATION_M`] of the chord, at
/// most [`ROUTE_GOAL_MAX_M`] along (its end at most).
fn straight_ahead(reference: &ReferenceTrajectory, t_s: f64) -> Vec2 {
    const STEPS: usize = (ROUTE_GOAL_MAX_M / CHORD_STEP_M) as usize;
    let speed = reference.v_mps.abs().max(1e-9);
    let from = reference.pose_at(t_s).position();
    // Each sample is taken once (a pose costs a sine and a cosine); the check
    // of every chord against the samples before it is plain arithmetic.
    let mut samples = [Vec2::new(0.0, 0.0); STEPS + 1];
    let mut best = from;
    for k in 1..=STEPS {
        let end = reference.pose_at(t_s + k as f64 * CHORD_STEP_M / speed).position();
        samples[k] = end - from;
        let chord = samples[k];
        let len = chord.norm();
        let straight = len < 1e-9
            || samples[1..k]
                .iter()
                .all(|q| (q.x * chord.y - q.y * chord.x).abs() / len <= CHORD_DEVIATION_M);
        if !straight {
            break;
        }
        best = end;
        if t_s + k as f64 * CHORD_STEP_M / speed >= reference.duration_s {
            break;
        }
    }
    best
}

/// What the robot sees at one step.
#[derive(Debug, Clone, Copy)]
pub struct Situation<'a> {
    /// Time of the step (s).
    pub now_s: f64,
    /// The nominal command.
    pub nominal: Twist,
    /// The robot's pose in the tracking frame.
    pub ego: Pose2,
    /// A mover on a collision course is near: a robot held up by people waits
    /// for them to pass (DOAA and evasion deal with movers); it does not go
    /// round them.
    pub movers_near: bool,
    /// A moving track is seen (anywhere).
    pub movers_seen: bool,
    /// The way-round planner's latest outcome.
    pub route: Option<&'a RouteUpdate>,
}

/// Why a way round began or ended (steps.csv's `route_event`, `~state`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RouteEvent {
    /// Began: the straight way ahead blocked on the map (at once with no
    /// people about, else after the stall time).
    FollowBlocked,
    /// Began: no progress for the stall time, the straight way ahead clear.
    FollowStalled,
    /// Ended: the straight way ahead is clear again.
    ReleaseClear,
    /// Ended: progress resumed.
    ReleaseProgress,
    /// Ended: at the reference point.
    ReleaseArrived,
    /// Ended: a mover on a collision course is near (the robot waits for it).
    ReleaseMover,
    /// Ended or refused: no route to the goal (closed in); the robot rests.
    NoRoute,
    /// Ended: the planner's route is older than [`ROUTE_STALE_S`].
    ReleaseStale,
    /// Stuck on the route: a new route is planned at once (the spot avoided
    /// for `unstuck.stuck_avoid_s` if the route is pinched there).
    Stuck,
}

impl RouteEvent {
    /// Name for records and logs.
    pub fn as_str(self) -> &'static str {
        match self {
            RouteEvent::FollowBlocked => "follow_blocked",
            RouteEvent::FollowStalled => "follow_stalled",
            RouteEvent::ReleaseClear => "release_clear",
            RouteEvent::ReleaseProgress => "release_progress",
            RouteEvent::ReleaseArrived => "release_arrived",
            RouteEvent::ReleaseMover => "release_mover",
            RouteEvent::NoRoute => "no_route",
            RouteEvent::ReleaseStale => "release_stale",
            RouteEvent::Stuck => "stuck",
        }
    }
}

/// What the unstuck logic decided this step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct UnstuckDecision {
    /// Where the way round heads (robot frame, m), while following one.
    pub waypoint: Option<Vec2>,
    /// No route to the goal: the robot rests.
    pub no_route: bool,
    /// A follow began or ended at this step, and why.
    pub event: Option<RouteEvent>,
}

impl UnstuckDecision {
    const NONE: UnstuckDecision = UnstuckDecision {
        waypoint: None,
        no_route: false,
        event: None,
    };
}

/// Why the robot is following a way round.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Cause {
    /// The straight way was blocked.
    Blocked,
    /// Progress stalled at this much progress (m).
    Stalled { from_m: f64 },
}

/// The progress monitor and the follow state.
#[derive(Debug, Clone, Default)]
pub struct Unstuck {
    /// Best progress so far (m), and when it last grew by `progress_m` (s).
    best_progress_m: Option<f64>,
    last_gain_s: Option<f64>,
    following: Option<Cause>,
    /// The waypoint being steered at (tracking frame, m).
    aim: Option<Vec2>,
    /// How the aim moves to the route point planned last.
    glide: Option<Glide>,
    /// Whether the last step found no route.
    no_route: bool,
    /// While following: the robot's pose when it last moved
    /// `unstuck.progress_m` or turned [`STUCK_TURN_RAD`], and when (tracking frame; s).
    moved: Option<(Pose2, f64)>,
    /// Stuck on the way round, not yet told to the planner.
    stuck: bool,
    /// Since when no moving track has been seen (s; from the first step).
    quiet_since_s: Option<f64>,
}

impl Unstuck {
    /// Forgets the progress history and any way round being followed.
    pub fn reset(&mut self) {
        *self = Self::default();
    }

    /// Whether the robot is following a way round an obstacle.
    pub fn following(&self) -> bool {
        self.following.is_some()
    }

    /// No progress for `unstuck.stall_s` at `now_s`.
    fn stalled(&self, now_s: f64, p: &Params) -> bool {
        self.last_gain_s.is_some_and(|t| now_s - t >= p.unstuck.stall_s)
    }

    /// Whether the robot got stuck on the way round since last asked: it has
    /// neither moved `unstuck.progress_m` nor turned [`STUCK_TURN_RAD`] for
    /// half `unstuck.stall_s` while following.
    pub fn take_stuck(&mut self) -> bool {
        std::mem::take(&mut self.stuck)
    }

    /// Ends a follow (if any) with `event`.
    fn release(&mut self, event: RouteEvent) -> UnstuckDecision {
        let was = self.following.take().is_some();
        self.aim = None;
        self.glide = None;
        self.moved = None;
        UnstuckDecision {
            event: was.then_some(event),
            ..UnstuckDecision::NONE
        }
    }

    /// One step: `guidance` (None: nothing to make progress towards, nothing
    /// to do) and what the robot sees now.
    pub fn step(&mut self, guidance: Option<Guidance>, now: &Situation<'_>, p: &Params) -> UnstuckDecision {
        let Situation {
            now_s,
            nominal,
            ego,
            movers_near,
            movers_seen,
            route,
        } = *now;
        let Some(g) = guidance.filter(Guidance::is_finite) else {
            self.reset();
            return UnstuckDecision::NONE;
        };
        let u = &p.unstuck;
        let dist = g.target.norm();
        let progress = g.along_m - dist;
        let gained = match (self.best_progress_m, self.last_gain_s) {
            (Some(best), Some(t)) => progress >= best + u.progress_m || now_s < t, // or the clock went back
            _ => true,
        };
        if movers_seen || self.quiet_since_s.is_none_or(|t| now_s < t) {
            self.quiet_since_s = Some(now_s); // or the first step, or the clock went back
        }
        if gained {
            self.best_progress_m = Some(self.best_progress_m.map_or(progress, |b| b.max(progress)));
            self.last_gain_s = Some(now_s);
        }
        if !u.enabled {
            return self.release(RouteEvent::ReleaseClear);
        }
        let route = route.filter(|r| now_s - r.made_s <= ROUTE_STALE_S && now_s >= r.made_s);
        // Closed in: no way to the goal. Reported once; the robot rests.
        if route.is_some_and(|r| r.change == RouteChange::NoRoute) {
            let first = !self.no_route;
            let d = self.release(RouteEvent::NoRoute);
            self.no_route = true;
            return UnstuckDecision {
                no_route: true,
                event: first.then_some(RouteEvent::NoRoute).or(d.event),
                ..d
            };
        }
        self.no_route = false;
        let blocked = route.is_some_and(|r| r.route.is_some() && r.direct_margin_m < 0.0);
        // At the reference point there is nothing to go round, unless the straight way
        // ahead is blocked: a robot keeping up with its reference is driving at the wall.
        if dist <= p.tracking.capture_radius_m && (g.at_end || !blocked) {
            return self.release(RouteEvent::ReleaseArrived);
        }
        if movers_near {
            return self.release(RouteEvent::ReleaseMover);
        }
        let mut event = None;
        match self.following {
            None => {
                let wants_to_move = nominal.v_mps > 0.0 || nominal.omega_radps != 0.0;
                if !wants_to_move {
                    return UnstuckDecision::NONE;
                }
                let quiet = self.quiet_since_s.is_some_and(|t| now_s - t >= MOVERS_QUIET_S);
                if blocked && (quiet || self.stalled(now_s, p)) {
                    self.following = Some(Cause::Blocked);
                    event = Some(RouteEvent::FollowBlocked);
                } else if self.stalled(now_s, p) {
                    let idle_s = now_s - self.last_gain_s.unwrap_or(now_s);
                    log::debug!("t {now_s:.1}: no progress for {idle_s:.1} s: going round");
                    self.following = Some(Cause::Stalled { from_m: progress });
                    event = Some(RouteEvent::FollowStalled);
                } else {
                    return UnstuckDecision::NONE;
                }
            }
            Some(Cause::Blocked) => {
                if route.is_none_or(|r| r.direct_margin_m > RELEASE_MARGIN_M) {
                    let why = if route.is_none() {
                        RouteEvent::ReleaseStale
                    } else {
                        RouteEvent::ReleaseClear
                    };
                    return self.release(why);
                }
            }
            Some(Cause::Stalled { from_m }) => {
                if progress >= from_m + u.progress_m {
                    // Progress again: the tracking law takes over.
                    self.best_progress_m = Some(progress);
                    self.last_gain_s = Some(now_s);
                    return self.release(RouteEvent::ReleaseProgress);
                }
            }
        }
        // Not getting on along the route (the checks hold the robot where the map shows a
        // gap): the planner avoids that spot and plans afresh.
        let here = ego.position();
        match self.moved {
            Some((at, _))
                if (here - at.position()).norm() < u.progress_m
                    && wrap_angle(ego.theta - at.theta).abs() < STUCK_TURN_RAD => {}
            _ => self.moved = Some((ego, now_s)),
        }
        if self.moved.is_some_and(|(_, t)| now_s - t >= STUCK_FRACTION * u.stall_s) {
            self.stuck = true;
            self.moved = Some((ego, now_s));
            event = Some(RouteEvent::Stuck);
        }
        // Steer at the route's farthest point in sight within 1 m along; no route held
        // yet, or one that goes nowhere (boxed in): no waypoint, the DOAA's both-sides
        // turn at ω_0. That point is planned anew each plan period and moves on by a
        // step along the route each time; the aim glides there over the period
        // (continuously, as the robot drives) rather than jumping, which would jerk the
        // tracking law's yaw rate at every plan. A point on another way is taken at once.
        let carrot = route.and_then(|r| r.carrot);
        self.glide = match (carrot, self.glide) {
            (None, _) => None,
            (Some(c), Some(g)) if g.to == c => Some(g),
            (Some(c), Some(g)) => {
                let now_at = g.at(now_s, u.plan_period_s);
                Some(if (c - now_at).norm() <= GLIDE_MAX_M && now_s >= g.since_s {
                    Glide {
                        from: now_at,
                        to: c,
                        since_s: now_s,
                    }
                } else {
                    Glide::at_once(c, now_s)
                })
            }
            (Some(c), None) => Some(Glide::at_once(c, now_s)),
        };
        self.aim = self
            .glide
            .map(|g| g.at(now_s, u.plan_period_s))
            .filter(|c| (c - here).norm() > 0.5 * super::local_map::MAP_CELL_M);
        log::trace!("t {now_s:.1}: going round: aim {:?}", self.aim);
        UnstuckDecision {
            waypoint: self.aim.map(|a| ego.inverse_transform_point(a)),
            no_route: false,
            event,
        }
    }

    /// The waypoint being followed, in the tracking frame (m): where the
    /// tracking law aims while a way round is followed.
    pub fn aim(&self) -> Option<Vec2> {
        self.aim.filter(|_| self.following())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algo::way_round::{MapScan, RouteAsk, WayRound};

    fn params() -> Params {
        Params::default() // r = 0.178, d_safe = 0.2; stall 6 s, progress 0.15 m
    }

    /// A wall of points across x = `x` from y = `y0` to `y1`, 2 cm apart.
    fn wall(x: f64, y0: f64, y1: f64) -> Vec<Vec2> {
        let n = ((y1 - y0) / 0.02) as usize;
        (0..=n).map(|i| Vec2::new(x, y0 + 0.02 * i as f64)).collect()
    }

    /// The planner's update for a robot at the origin seeing `points`, the
    /// reference's end at `goal`, the tracking law heading for `ahead`.
    fn update(points: Vec<Vec2>, goal: Vec2, ahead: Vec2, now_s: f64) -> RouteUpdate {
        let p = params();
        let mut w = WayRound::new(&p);
        w.insert(&MapScan {
            stamp_s: now_s,
            pose: Pose2::default(),
            points,
            open_ends: vec![],
            transient: vec![],
        });
        let ask = RouteAsk {
            now_s,
            from: Vec2::zeros(),
            goal,
            direct_to: ahead,
            own_m: 0.0,
            stuck: false,
        };
        w.plan(&ask, &p)
    }

    fn at<'a>(now_s: f64, nominal: Twist, route: Option<&'a RouteUpdate>, movers_near: bool) -> Situation<'a> {
        Situation {
            now_s,
            nominal,
            ego: Pose2::default(),
            movers_near,
            movers_seen: movers_near,
            route,
        }
    }

    fn guidance(along_m: f64) -> Guidance {
        Guidance {
            target: Vec2::new(1.5, 0.0),
            along_m,
            ahead: Vec2::new(2.5, 0.0),
            end: Vec2::new(4.0, 0.0),
            at_end: false,
        }
    }

    /// Steps a robot making progress `gain_m` per 0.1 s before a wall 1.5 m ahead
    /// (y = −0.6 to 2.5: the way round is to the right) from 0 s to `until_s`,
    /// a moving track seen at the steps `seen` says; returns when the follow began.
    fn blocked_follow_begins(gain_m: f64, seen: impl Fn(f64) -> bool, until_s: f64) -> Option<(f64, RouteEvent)> {
        let p = params();
        let mut u = Unstuck::default();
        let blocked = update(wall(1.5, -0.6, 2.5), Vec2::new(4.0, 0.0), Vec2::new(2.5, 0.0), 0.0);
        assert!(blocked.direct_margin_m < 0.0);
        let steps = (until_s / 0.1).round() as usize;
        (0..=steps).find_map(|k| {
            let t = 0.1 * k as f64;
            let r = RouteUpdate {
                made_s: t,
                ..blocked.clone()
            };
            let now = Situation {
                movers_seen: seen(t),
                ..at(t, Twist::new(0.15, 0.0), Some(&r), false)
            };
            let d = u.step(Some(guidance(3.0 + gain_m * k as f64)), &now, &p);
            d.event.map(|e| (t, e))
        })
    }

    #[test]
    fn a_blocked_way_is_gone_round_once_no_people_have_been_seen_for_the_quiet_time() {
        // Nobody about: from the first step, MOVERS_QUIET_S (5 s) before the stall (6 s).
        let (t, e) = blocked_follow_begins(0.0, |_| false, 10.0).unwrap();
        assert_eq!(e, RouteEvent::FollowBlocked);
        assert!((t - MOVERS_QUIET_S).abs() < 1e-9, "{t}");
        // A person's track seen at 2 s only (it dropped out after): the quiet time runs
        // from then, 7 s, and progress (0.2 m a step) keeps the stall off.
        let (t, e) = blocked_follow_begins(0.2, |t| (t - 2.0).abs() < 1e-9, 10.0).unwrap();
        assert_eq!(e, RouteEvent::FollowBlocked);
        assert!((t - 7.0).abs() < 1e-9, "{t}");
        // People about all along: the reactive steering and evasion have the stall time
        // first, and then the follow is a blocked one…
        let (t, e) = blocked_follow_begins(0.0, |_| true, 10.0).unwrap();
        assert_eq!(e, RouteEvent::FollowBlocked);
        assert!((t - 6.0).abs() < 1e-9, "{t}");
        // …and while they make progress, none at all.
        assert_eq!(blocked_follow_begins(0.2, |_| true, 20.0), None);
    }

    #[test]
    fn a_robot_keeping_up_with_its_reference_still_goes_round_a_blocked_way() {
        let p = params(); // capture radius 0.5 m
        let nominal = Twist::new(0.15, 0.0);
        let blocked = update(wall(1.5, -0.6, 2.5), Vec2::new(4.0, 0.0), Vec2::new(2.5, 0.0), 0.0);
        let clear = update(vec![], Vec2::new(4.0, 0.0), Vec2::new(2.5, 0.0), 0.0);
        // The reference point 0.3 m ahead (inside the capture radius), the line's end 4 m on.
        let keeping_up = |at_end: bool| Guidance {
            target: Vec2::new(0.3, 0.0),
            at_end,
            ..guidance(3.0)
        };
        let follow_at = |r: &RouteUpdate, at_end: bool| {
            let mut u = Unstuck::default();
            (0..=100).find_map(|k| {
                let t = 0.1 * k as f64;
                let r = RouteUpdate { made_s: t, ..r.clone() };
                let g = Guidance {
                    along_m: 3.0 + 0.015 * k as f64, // progress: no stall
                    ..keeping_up(at_end)
                };
                u.step(Some(g), &at(t, nominal, Some(&r), false), &p)
                    .event
                    .map(|e| (k, e))
            })
        };
        // The wall across the way: gone round once the quiet time has passed (5 s).
        assert_eq!(follow_at(&blocked, false), Some((50, RouteEvent::FollowBlocked)));
        // Nothing across it: nothing to go round.
        assert_eq!(follow_at(&clear, false), None);
        // At the reference's end the goal is the reference point: arrived.
        assert_eq!(follow_at(&blocked, true), None);
    }

    #[test]
    fn a_followed_way_round_heads_for_the_walls_open_end_and_is_released_once_clear() {
        let p = params();
        let mut u = Unstuck::default();
        let nominal = Twist::new(0.15, 0.0);
        // A wall 1.5 m ahead from y = −0.6 to 2.5: the way round is to the right.
        let blocked = update(wall(1.5, -0.6, 2.5), Vec2::new(4.0, 0.0), Vec2::new(2.5, 0.0), 5.0);
        let d = u.step(Some(guidance(3.0)), &at(0.0, nominal, Some(&blocked), false), &p);
        assert_eq!(d.event, None, "the first step starts the quiet time");
        let d = u.step(Some(guidance(3.0)), &at(5.0, nominal, Some(&blocked), false), &p);
        assert_eq!(d.event, Some(RouteEvent::FollowBlocked), "{d:?}");
        let w = d.waypoint.unwrap();
        assert!(w.y < -0.2 && w.x > 0.5, "towards the wall's right end: {w:?}");
        assert_eq!(u.aim(), Some(w), "robot at the origin: tracking frame = robot frame");
        // Kept while blocked…
        let d = u.step(Some(guidance(3.0)), &at(5.1, nominal, Some(&blocked), false), &p);
        assert_eq!((d.event, d.waypoint.is_some()), (None, true));
        // …released once the straight way is clear.
        let clear = update(vec![], Vec2::new(4.0, 0.0), Vec2::new(2.5, 0.0), 5.2);
        let d = u.step(Some(guidance(3.0)), &at(5.2, nominal, Some(&clear), false), &p);
        assert_eq!(
            (d.event, d.waypoint, u.following()),
            (Some(RouteEvent::ReleaseClear), None, false)
        );
        // A route planned more than ROUTE_STALE_S ago is not followed (the stall, 6 s
        // without progress, starts a follow with no waypoint).
        let d = u.step(
            Some(guidance(3.0)),
            &at(5.0 + ROUTE_STALE_S + 0.2, nominal, Some(&blocked), false),
            &p,
        );
        assert_eq!((d.event, d.waypoint), (Some(RouteEvent::FollowStalled), None));
    }

    #[test]
    fn the_aim_glides_to_the_next_route_point_over_a_plan_period_and_jumps_to_another_way() {
        let p = params(); // plan period 0.5 s
        let nominal = Twist::new(0.15, 0.0);
        let blocked = update(wall(1.5, -0.6, 2.5), Vec2::new(4.0, 0.0), Vec2::new(2.5, 0.0), 0.0);
        let c0 = blocked.carrot.unwrap();
        let with_carrot = |c: Vec2, made_s: f64| RouteUpdate {
            carrot: Some(c),
            made_s,
            ..blocked.clone()
        };
        let mut u = Unstuck::default();
        let try_step = |u: &mut Unstuck, t: f64, r: &RouteUpdate| {
            u.step(Some(guidance(3.0)), &at(t, nominal, Some(r), false), &p);
            u.aim()
        };
        let step = |u: &mut Unstuck, t: f64, r: &RouteUpdate| try_step(u, t, r).unwrap();
        let r0 = with_carrot(c0, 0.0);
        assert_eq!(try_step(&mut u, 0.0, &r0), None, "the first step starts the quiet time");
        let r0 = with_carrot(c0, 5.0);
        assert_eq!(step(&mut u, 5.0, &r0), c0, "a follow begins aiming at the route point");
        // The next plan's point, 0.1 m on: reached over the 0.5 s plan period, linearly.
        let c1 = c0 + Vec2::new(0.06, -0.08);
        let r1 = with_carrot(c1, 5.5);
        let close = |a: Vec2, b: Vec2| (a - b).norm() < 1e-12;
        assert!(close(step(&mut u, 5.5, &r1), c0));
        assert!(close(step(&mut u, 5.75, &r1), c0 + (c1 - c0) * 0.5));
        assert!(close(step(&mut u, 6.0, &r1), c1));
        assert!(close(step(&mut u, 6.2, &r1), c1), "and held there");
        // A new point half-way through a glide: from where the aim is then.
        let c2 = c1 + Vec2::new(0.1, 0.0);
        let r2 = with_carrot(c2, 6.3);
        assert!(close(step(&mut u, 6.3, &r2), c1));
        let c3 = c2 + Vec2::new(0.0, 0.1);
        let r3 = with_carrot(c3, 6.55);
        let mid = c1 + (c2 - c1) * 0.5;
        assert!(close(step(&mut u, 6.55, &r3), mid));
        assert!(close(step(&mut u, 6.8, &r3), mid + (c3 - mid) * 0.5));
        // A point farther than GLIDE_MAX_M (0.5 m): another way, steered at at once.
        let other = c3 + Vec2::new(0.0, 0.6);
        let r4 = with_carrot(other, 6.9);
        assert!(close(step(&mut u, 6.9, &r4), other));
    }

    #[test]
    fn a_stall_starts_a_follow_and_progress_ends_it() {
        let p = params();
        let mut u = Unstuck::default();
        let nominal = Twist::new(0.15, 0.0);
        // Nothing blocks the straight way (the robot is held by something the map
        // does not show): only the stall starts a follow.
        let clear = update(vec![], Vec2::new(4.0, 0.0), Vec2::new(2.5, 0.0), 0.0);
        for k in 0..60 {
            let r = RouteUpdate {
                made_s: k as f64 * 0.1,
                ..clear.clone()
            };
            let d = u.step(Some(guidance(3.0)), &at(k as f64 * 0.1, nominal, Some(&r), false), &p);
            assert_eq!(d.waypoint, None, "no stall before 6 s");
        }
        let r = RouteUpdate {
            made_s: 6.0,
            ..clear.clone()
        };
        let d = u.step(Some(guidance(3.0)), &at(6.0, nominal, Some(&r), false), &p);
        assert_eq!(d.event, Some(RouteEvent::FollowStalled));
        assert!(d.waypoint.is_some());
        // 0.1 m more progress: not enough; 0.15 m: released.
        let d = u.step(Some(guidance(3.1)), &at(6.1, nominal, Some(&r), false), &p);
        assert_eq!(d.event, None);
        let d = u.step(Some(guidance(3.15)), &at(6.2, nominal, Some(&r), false), &p);
        assert_eq!(d.event, Some(RouteEvent::ReleaseProgress));
        // A nominal at rest never starts one.
        let mut u = Unstuck::default();
        for k in 0..100 {
            let d = u.step(
                Some(guidance(3.0)),
                &at(k as f64 * 0.1, Twist::ZERO, Some(&r), false),
                &p,
            );
            assert_eq!(d.waypoint, None);
        }
    }

    #[test]
    fn closed_in_there_is_no_route_and_the_robot_rests() {
        let p = params();
        let mut u = Unstuck::default();
        // A ring of radius 1 m round the robot, the goal 3 m away outside it.
        let ring: Vec<Vec2> = (0..400)
            .map(|k| {
                let a = k as f64 * std::f64::consts::TAU / 400.0;
                Vec2::new(a.cos(), a.sin())
            })
            .collect();
        let r = update(ring, Vec2::new(3.0, 0.0), Vec2::new(2.5, 0.0), 0.0);
        assert_eq!((r.change, r.route.is_none()), (RouteChange::NoRoute, true));
        let d = u.step(
            Some(guidance(3.0)),
            &at(0.0, Twist::new(0.15, 0.0), Some(&r), false),
            &p,
        );
        assert_eq!(
            (d.no_route, d.waypoint, d.event),
            (true, None, Some(RouteEvent::NoRoute))
        );
        // Reported once.
        let d = u.step(
            Some(guidance(3.0)),
            &at(0.1, Twist::new(0.15, 0.0), Some(&r), false),
            &p,
        );
        assert_eq!((d.no_route, d.event), (true, None));
    }

    #[test]
    fn a_mover_near_or_no_guidance_ends_a_follow() {
        let p = params();
        let nominal = Twist::new(0.15, 0.0);
        let blocked = update(wall(1.5, -0.6, 2.5), Vec2::new(4.0, 0.0), Vec2::new(2.5, 0.0), 0.0);
        let blocked_at = |t: f64| RouteUpdate {
            made_s: t,
            ..blocked.clone()
        };
        let mut u = Unstuck::default();
        u.step(
            Some(guidance(3.0)),
            &at(0.0, nominal, Some(&blocked_at(0.0)), false),
            &p,
        );
        u.step(
            Some(guidance(3.0)),
            &at(6.0, nominal, Some(&blocked_at(6.0)), false),
            &p,
        );
        assert!(u.following());
        let d = u.step(Some(guidance(3.0)), &at(6.1, nominal, Some(&blocked_at(6.1)), true), &p);
        assert_eq!((d.event, d.waypoint), (Some(RouteEvent::ReleaseMover), None));
        u.step(
            Some(guidance(3.0)),
            &at(6.2, nominal, Some(&blocked_at(6.2)), false),
            &p,
        );
        assert!(u.following());
        let d = u.step(None, &at(6.3, nominal, Some(&blocked_at(6.3)), false), &p);
        assert_eq!((d.waypoint, u.following(), u.aim()), (None, false, None));
    }

    #[test]
    fn held_still_on_the_route_is_stuck_turning_is_not() {
        let p = params(); // stall 6 s: stuck after 3 s
        let nominal = Twist::new(0.15, 0.0);
        let blocked = update(wall(1.5, -0.6, 2.5), Vec2::new(4.0, 0.0), Vec2::new(2.5, 0.0), 0.0);
        let step = |u: &mut Unstuck, t: f64, ego: Pose2| {
            let r = RouteUpdate {
                made_s: t,
                ..blocked.clone()
            };
            let now = Situation {
                ego,
                ..at(t, nominal, Some(&r), false)
            };
            u.step(Some(guidance(3.0)), &now, &p).event
        };
        // Following from 5 s (the way blocked, no people about since the first step).
        // Turning in place at 0.3 rad/s: 0.5 rad every 1.7 s, never stuck.
        let mut u = Unstuck::default();
        for k in 0..160 {
            let t = 0.1 * k as f64;
            let e = step(&mut u, t, Pose2::new(0.0, 0.0, -0.03 * k as f64));
            assert_ne!(e, Some(RouteEvent::Stuck), "at {t} s");
        }
        // Held still: stuck 3 s into the follow, told once to the planner, and again 3 s later.
        let mut u = Unstuck::default();
        let mut stuck_at = vec![];
        for k in 0..130 {
            let t = 0.1 * k as f64;
            if step(&mut u, t, Pose2::default()) == Some(RouteEvent::Stuck) {
                stuck_at.push(k);
                assert!(u.take_stuck() && !u.take_stuck());
            }
        }
        assert_eq!(stuck_at, vec![80, 110]);
    }

    #[test]
    fn the_route_goes_to_the_end_of_a_line_and_a_little_ahead_on_a_circle() {
        use crate::algo::reference::ReferenceTrajectory;
        // A line of 3 m: its end, wherever the reference is.
        let line = ReferenceTrajectory::line(Pose2::default(), 0.15, 3.0);
        assert!((straight_ahead(&line, 0.0) - Vec2::new(3.0, 0.0)).norm() < 1e-9);
        // A line of 20 m: 5 m ahead.
        let long = ReferenceTrajectory::line(Pose2::default(), 0.15, 20.0);
        assert!((straight_ahead(&long, 10.0) - Vec2::new(6.5, 0.0)).norm() < 1e-6);
        // A circle of radius 1.5 m: the farthest sample whose arc stays within 0.3 m of its
        // chord. The sagitta of an arc of angle φ is r (1 − cos(φ / 2)) ≤ 0.3 for φ ≤ 73.7°,
        // an arc of 1.93 m: the goal is 1.9 m along (a chord of 1.5 · 2 sin(36.3°) = 1.78 m).
        let circle = ReferenceTrajectory::circle(Pose2::default(), 0.15, 0.1, 1.0);
        let g = straight_ahead(&circle, 0.0);
        assert!((g.norm() - 2.0 * 1.5 * (1.9f64 / 3.0).sin()).abs() < 1e-6, "{g:?}");
    }
}
