//! Unstuck (ALGORITHM.md §4b): getting round an obstacle when reactive
//! steering alone has stalled.
//!
//! DOAA is reactive: with the reference behind an obstacle, the tracking law
//! pulls the robot at it and the barriers push it away, and it can stand
//! there for the rest of the run (no contact, no progress). This module
//! watches progress towards the reference and, when it has stalled, replaces
//! the nominal command with one that goes round:
//!
//! * **Progress** is the reference's arc length minus the robot's distance to
//!   the (governed) reference point, in m: it grows while the reference runs
//!   and while the robot closes in on it; a robot held up by an obstacle,
//!   with the governor holding the reference 2 R_c ahead, makes none.
//! * **Stalled**: the nominal asks to move, and progress has grown by less
//!   than `unstuck.progress_m` for `unstuck.stall_s`.
//! * **Follow**: the way round, planned on a grid round the robot
//!   ([`LocalPlanner`]: cells r + d_safe + `unstuck.margin_m` clear of every
//!   point but those of movers walking at 0.1 m/s or more, which the
//!   pipeline leaves out) to the point `unstuck.ahead_m` further along the reference's
//!   path: the shortest path when it is reachable (through the gap nearest
//!   the reference that the robot fits through), else to the reachable cell
//!   nearest it. The nominal becomes a turn towards the path's farthest
//!   visible cell within 1 m (`WAYPOINT_REACH_M`), at up to the nominal
//!   speed, slower the more it must turn. Not replanned every step: a new
//!   plan is made once the last is `REPLAN_S` = 0.5 s old or its waypoint is
//!   within `WAYPOINT_REACHED_M` = 0.15 m of the robot; in between, the last
//!   waypoint (fixed in the tracking frame, re-expressed in the robot frame
//!   each step) is followed. So the way slides along the obstacle's boundary
//!   as the robot goes round it. (With nowhere to go, see below, nothing is
//!   kept and every step plans again.) Each new plan keeps to the side of
//!   the line to the goal chosen first while the way on that side ends at
//!   most `SIDE_SLACK_M` = 0.3 m farther from the goal than the best way. A
//!   gap narrower than 2 (r + d_safe + margin) is not one.
//! * **Release**: progress has grown by `unstuck.progress_m` since the
//!   stall, or the reference is within the capture radius, or a tracked
//!   mover has come near (a robot held up by people waits for them to pass:
//!   DOAA and evasion deal with movers; going round them is not this).
//!   With nowhere to go (no free cell reachable), the nominal is a turn in
//!   place: the paper's ω_0 case.
//!
//! Everything still goes through the DTCBF and the passive checks.

use super::geometry::{Pose2, Twist, Vec2};
use super::local_plan::{LocalPlanner, Waypoint};
use super::params::Params;
use super::reference::{ReferenceProgress, ReferenceTrajectory};

/// The waypoint is the farthest visible path cell within this (m).
const WAYPOINT_REACH_M: f64 = 1.0;
/// The side kept may end this much farther from the goal than the best way (m).
const SIDE_SLACK_M: f64 = 0.3;
/// A plan is followed this long before planning again (s)…
const REPLAN_S: f64 = 0.5;
/// …unless its waypoint is nearer than this (m).
const WAYPOINT_REACHED_M: f64 = 0.15;

/// Where the nominal command is heading: the governed reference point and
/// how far along its path it is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Guidance {
    /// The reference point in the robot frame now (m).
    pub target: Vec2,
    /// The reference's arc length so far (m).
    pub along_m: f64,
    /// The point `unstuck.ahead_m` further along the reference's path (its
    /// end at most), robot frame (m): where the way round heads. The governed
    /// reference itself often waits inside or against the obstacle.
    pub ahead: Vec2,
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
            at_end: progress.finished(reference),
        }
    }
}

/// What the robot sees at one step.
#[derive(Debug, Clone, Copy)]
pub struct Situation<'a> {
    /// Time of the step (s).
    pub now_s: f64,
    /// The nominal command.
    pub nominal: Twist,
    /// The scan's points (robot frame, m).
    pub points: &'a [Vec2],
    /// The robot's pose in the tracking frame.
    pub ego: Pose2,
    /// A mover on a collision course is near: a robot held up by people waits
    /// for them to pass (DOAA and evasion deal with movers); it does not go
    /// round them.
    pub movers_near: bool,
}

/// What the unstuck logic decided this step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UnstuckDecision {
    /// Where the way round heads (robot frame, m), while following one.
    pub waypoint: Option<Vec2>,
}

impl UnstuckDecision {
    const NONE: UnstuckDecision = UnstuckDecision { waypoint: None };
}

/// The progress monitor and the follow state.
#[derive(Debug, Clone, Default)]
pub struct Unstuck {
    /// Best progress so far (m), and when it last grew by `progress_m` (s).
    best_progress_m: Option<f64>,
    last_gain_s: Option<f64>,
    /// Progress when following began (m), while following.
    following_from_m: Option<f64>,
    /// The side of the robot-to-reference line the way round keeps to.
    side: Option<f64>,
    /// The last plan's waypoint (tracking frame, m) and when it was made (s).
    cached: Option<(Vec2, f64)>,
    planner: LocalPlanner,
}

impl Unstuck {
    /// Forgets the progress history and any free direction being followed.
    pub fn reset(&mut self) {
        self.best_progress_m = None;
        self.last_gain_s = None;
        self.following_from_m = None;
        self.side = None;
        self.cached = None;
    }

    /// Whether the robot is following a way round an obstacle.
    pub fn following(&self) -> bool {
        self.following_from_m.is_some()
    }

    /// Whether [`Self::step`] at `now_s` may plan a way round (and so read
    /// the points): following already, or no progress for `stall_s`. A
    /// superset: the step may still find progress, arrival or a mover near.
    pub fn may_plan(&self, now_s: f64, p: &Params) -> bool {
        self.following_from_m.is_some() || self.stalled(now_s, p)
    }

    /// No progress for `unstuck.stall_s` at `now_s`.
    fn stalled(&self, now_s: f64, p: &Params) -> bool {
        self.last_gain_s.is_some_and(|t| now_s - t >= p.unstuck.stall_s)
    }

    /// One step: `guidance` (None: nothing to make progress towards, nothing
    /// to do) and what the robot sees now.
    pub fn step(&mut self, guidance: Option<Guidance>, now: &Situation<'_>, p: &Params) -> UnstuckDecision {
        let Situation {
            now_s,
            nominal,
            points,
            ego,
            movers_near,
        } = *now;
        let Some(g) = guidance.filter(|g| g.target.x.is_finite() && g.target.y.is_finite() && g.along_m.is_finite())
        else {
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
        if gained {
            self.best_progress_m = Some(self.best_progress_m.map_or(progress, |b| b.max(progress)));
            self.last_gain_s = Some(now_s);
        }
        let arrived = dist <= p.tracking.capture_radius_m;
        if arrived || movers_near {
            self.following_from_m = None;
            self.side = None;
            self.cached = None;
            return UnstuckDecision::NONE;
        }
        if self.following_from_m.is_none() {
            let wants_to_move = nominal.v_mps > 0.0 || nominal.omega_radps != 0.0;
            if !u.enabled || !wants_to_move || !self.stalled(now_s, p) {
                return UnstuckDecision::NONE;
            }
            let idle_s = now_s - self.last_gain_s.unwrap_or(now_s);
            log::debug!("t {now_s:.1}: no progress for {idle_s:.1} s: going round");
            self.following_from_m = Some(progress);
            self.side = None;
        }
        let from = self.following_from_m.unwrap_or(progress);
        if progress >= from + u.progress_m {
            // Progress again: the tracking law takes over.
            self.side = None;
            self.following_from_m = None;
            self.cached = None;
            self.best_progress_m = Some(progress);
            self.last_gain_s = Some(now_s);
            return UnstuckDecision::NONE;
        }
        // The last plan's waypoint still ahead and recent: no need to plan again.
        if let Some((world, planned_s)) = self.cached {
            let point = ego.inverse_transform_point(world);
            if now_s - planned_s < REPLAN_S && now_s >= planned_s && point.norm() > WAYPOINT_REACHED_M {
                return UnstuckDecision { waypoint: Some(point) };
            }
        }
        let cell = super::local_plan::CELL_M;
        let clearance = p.robot_radius_m() + p.barrier.d_safe_m + u.margin_m;
        // A robot already closer than that to something (noise, a tight spot) may move
        // within the disc it is short by, or its own neighbourhood would be walled in.
        let nearest = points.iter().map(|q| q.norm()).fold(f64::INFINITY, f64::min);
        let own_m = ((clearance - nearest).max(0.0) + 2.0 * cell)
            .min(nearest - cell)
            .max(0.0);
        // Keep to the side chosen first while that side is about as good (ends as near
        // the goal, within SIDE_SLACK_M); else take the best way and its side.
        let goal = g.ahead;
        let reaches = |w: &Waypoint| (w.end - goal).norm() < 2.0 * cell;
        let free = self
            .planner
            .plan(points, goal, clearance, own_m, u.window_m, WAYPOINT_REACH_M, None);
        let kept = match (self.side, free) {
            (Some(sign), Some(f)) => self
                .planner
                .plan(points, goal, clearance, own_m, u.window_m, WAYPOINT_REACH_M, Some(sign))
                .filter(|k| (k.end - goal).norm() <= (f.end - goal).norm() + SIDE_SLACK_M),
            _ => None,
        };
        let way = kept.or_else(|| {
            if let Some(w) = free {
                let t = goal / goal.norm().max(1e-9);
                let across = t.x * w.point.y - t.y * w.point.x;
                self.side = (across.abs() > cell).then_some(across.signum());
            }
            free
        });
        // Somewhere to go: a way that leaves the disc the robot is short by. Nowhere
        // (boxed in): no waypoint; the DOAA's both-sides turn at ω_0 is the paper's case.
        let waypoint = match way {
            Some(w) if w.point.norm() > 0.5 * cell && (w.end.norm() > own_m + cell || reaches(&w)) => {
                self.cached = Some((ego.transform_point(w.point), now_s));
                Some(w.point)
            }
            _ => {
                self.cached = None;
                None
            }
        };
        log::trace!(
            "t {now_s:.1}: going round: ahead {:?} way {way:?} side {:?}",
            g.ahead,
            self.side
        );
        UnstuckDecision { waypoint }
    }

    /// The waypoint being followed, in the tracking frame (m): where the
    /// tracking law aims while a way round is followed.
    pub fn aim(&self) -> Option<Vec2> {
        self.cached.filter(|_| self.following()).map(|(w, _)| w)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The robot at the origin at `now_s` with `nominal`, seeing `points`.
    fn at(now_s: f64, nominal: Twist, points: &[Vec2], movers_near: bool) -> Situation<'_> {
        Situation {
            now_s,
            nominal,
            points,
            ego: Pose2::default(),
            movers_near,
        }
    }

    fn params() -> Params {
        Params::default() // r = 0.178, d_safe = 0.2; stall 6 s, progress 0.15 m
    }

    /// A wall of points across x = `x` from y = `y0` to `y1`, 2 cm apart.
    fn wall(x: f64, y0: f64, y1: f64) -> Vec<Vec2> {
        let n = ((y1 - y0) / 0.02) as usize;
        (0..=n).map(|i| Vec2::new(x, y0 + 0.02 * i as f64)).collect()
    }

    #[test]
    fn no_progress_for_the_stall_time_starts_going_round_and_progress_ends_it() {
        let p = params();
        let mut u = Unstuck::default();
        // A wall 0.8 m ahead from y = −0.6 to 2: the reference 1.5 m ahead, behind it.
        let pts = wall(0.8, -0.6, 2.0);
        let g = Guidance {
            target: Vec2::new(1.5, 0.0),
            along_m: 3.0,
            ahead: Vec2::new(3.0, 0.0),
            at_end: false,
        };
        let nominal = Twist::new(0.15, 0.0);
        for k in 0..60 {
            let d = u.step(Some(g), &at(k as f64 * 0.1, nominal, &pts, false), &p);
            assert_eq!(d.waypoint, None, "no stall before 6 s");
        }
        let d = u.step(Some(g), &at(6.0, nominal, &pts, false), &p);
        assert!(u.following());
        // The wall ends 0.6 m to the right: the way round is to the right.
        let w = d.waypoint.unwrap();
        assert!(w.y < -0.4, "{d:?}");
        assert_eq!(u.aim().map(|a| (a - w).norm() < 1e-12), Some(true), "{d:?}");
        // Progress made and the reference in sight: released.
        let g2 = Guidance {
            target: Vec2::new(1.2, -1.2),
            along_m: 3.4,
            ahead: Vec2::new(2.4, -1.2),
            at_end: false,
        };
        let d = u.step(Some(g2), &at(8.0, nominal, &[], false), &p);
        assert_eq!((d.waypoint, u.following()), (None, false));
    }

    #[test]
    fn boxed_in_it_turns_in_place_and_without_guidance_it_does_nothing() {
        let p = params();
        let mut u = Unstuck::default();
        let g = Guidance {
            target: Vec2::new(1.5, 0.3),
            along_m: 3.0,
            ahead: Vec2::new(3.0, 0.3),
            at_end: false,
        };
        // Points all round at 0.3 m: nowhere to go.
        let ring: Vec<Vec2> = (0..72)
            .map(|k| {
                let a = k as f64 * std::f64::consts::PI / 36.0;
                Vec2::new(0.3 * a.cos(), 0.3 * a.sin())
            })
            .collect();
        u.step(Some(g), &at(0.0, Twist::new(0.15, 0.0), &ring, false), &p);
        let d = u.step(Some(g), &at(7.0, Twist::new(0.15, 0.0), &ring, false), &p);
        assert_eq!((d.waypoint, u.following(), u.aim()), (None, true, None));
        let d = u.step(None, &at(7.1, Twist::new(0.15, 0.0), &ring, false), &p);
        assert_eq!((d.waypoint, u.following()), (None, false));
        // A mover near: no going round.
        u.step(Some(g), &at(0.0, Twist::new(0.15, 0.0), &ring, false), &p);
        let d = u.step(Some(g), &at(7.0, Twist::new(0.15, 0.0), &ring, true), &p);
        assert_eq!((d.waypoint, u.following()), (None, false));
    }

    #[test]
    fn progress_keeps_it_from_starting_and_so_does_a_nominal_at_rest() {
        let p = params();
        let mut u = Unstuck::default();
        let pts = wall(0.8, -0.6, 2.0);
        for k in 0..200 {
            // The reference runs on at 0.15 m/s: progress all the time.
            let g = Guidance {
                target: Vec2::new(1.5, 0.0),
                along_m: 0.015 * k as f64,
                ahead: Vec2::new(3.0, 0.0),
                at_end: false,
            };
            assert_eq!(
                u.step(Some(g), &at(k as f64 * 0.1, Twist::new(0.15, 0.0), &pts, false), &p)
                    .waypoint,
                None
            );
        }
        let mut u = Unstuck::default();
        let g = Guidance {
            target: Vec2::new(1.5, 0.0),
            along_m: 3.0,
            ahead: Vec2::new(3.0, 0.0),
            at_end: false,
        };
        for k in 0..200 {
            assert_eq!(
                u.step(Some(g), &at(k as f64 * 0.1, Twist::ZERO, &pts, false), &p)
                    .waypoint,
                None
            );
        }
    }
}
