//! The way-round planner as one unit (ALGORITHM.md §4c): the rolling local
//! map, the route planner on it, and when to plan. It runs either in step
//! with the scans (the simulator's reproducible mode) or beside the safety
//! path at its own rate (the node's mode): the pipeline hands it each scan
//! ([`MapScan`]) and what to plan for ([`RouteAsk`]), and takes back the
//! latest [`RouteUpdate`]; a scan's command never waits for a plan.

use super::geometry::{Pose2, Vec2};
use super::local_map::{cell_coords, LocalMap, MAP_CELL_M};
use super::params::Params;
/// The robot steers at most this far along the route (m).
pub const WAYPOINT_REACH_M: f64 = 1.0;
/// A stuck spot is judged on the route up to this far past it (m): what
/// holds the robot back lies where it was heading, a little beyond the spot.
pub const PINCH_BEYOND_M: f64 = 0.5;
/// A gap counts as pinched when its clearance is short of r + d_safe by more
/// than this (m): the range noise of a good LiDAR, so a gap of just
/// 2 (r + d_safe) is never closed for noise.
pub const PINCH_TOLERANCE_M: f64 = 0.01;

use super::route::{Route, RouteChange, RoutePlanner, RouteRequest};

/// A scan for the map: the points less walking people (robot frame at
/// `pose`, tracking frame, m) and its stamp (s).
#[derive(Debug, Default, PartialEq)]
pub struct MapScan {
    /// The scan's stamp (s).
    pub stamp_s: f64,
    /// The robot's pose at it (tracking frame).
    pub pose: Pose2,
    /// The points (robot frame at `pose`, m).
    pub points: Vec<Vec2>,
    /// The points of slowly moving tracks (robot frame at `pose`, m): planned
    /// round where they are, forgotten after [`super::local_map::TRANSIENT_S`] unless seen again.
    pub transient: Vec<Vec2>,
    /// The ends of the beams that saw nothing within their range (robot
    /// frame at `pose`, m): their rays clear what they cross, nothing is hit.
    pub open_ends: Vec<Vec2>,
}

impl Clone for MapScan {
    fn clone(&self) -> Self {
        let mut c = Self::default();
        c.clone_from(self);
        c
    }

    /// Reuses this scan's buffers: no allocation once they are large enough
    /// (the node hands the planner thread a recycled scan per scan).
    fn clone_from(&mut self, source: &Self) {
        self.stamp_s = source.stamp_s;
        self.pose = source.pose;
        self.points.clone_from(&source.points);
        self.transient.clone_from(&source.transient);
        self.open_ends.clone_from(&source.open_ends);
    }
}

/// What to plan for (tracking frame, m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RouteAsk {
    /// When asked (s).
    pub now_s: f64,
    /// The robot's position.
    pub from: Vec2,
    /// Where the route goes: the reference's end.
    pub goal: Vec2,
    /// Where the tracking law is heading: the route is needed while the
    /// straight way there is blocked.
    pub direct_to: Vec2,
    /// Cells this near the robot are never blocked (m).
    pub own_m: f64,
    /// The robot has not got on along the route for half `unstuck.stall_s`: the
    /// spot it was steering at is avoided for `unstuck.stuck_avoid_s` (if not
    /// 0), and the route planned afresh now.
    pub stuck: bool,
}

/// A plan's outcome, for the pipeline.
#[derive(Debug, Clone, PartialEq)]
pub struct RouteUpdate {
    /// The route held (None: no route, or nothing to plan yet).
    pub route: Option<Route>,
    /// Why it changed at this plan.
    pub change: RouteChange,
    /// The least margin of the straight way from `from` to `direct_to`
    /// over the blocked band (m; < 0: the way is blocked).
    pub direct_margin_m: f64,
    /// Where the robot steers (tracking frame, m): the farthest route point
    /// within [`WAYPOINT_REACH_M`] along it that the robot sees in a straight
    /// line clear of the blocked band (at least the route's next cell).
    pub carrot: Option<Vec2>,
    /// When it was planned (s).
    pub made_s: f64,
    /// The planner's own time for this plan (µs; 0 when not measured).
    pub plan_us: f64,
}

/// The map, the planner and its timing.
#[derive(Debug, Clone)]
pub struct WayRound {
    map: LocalMap,
    planner: RoutePlanner,
    last_plan_s: Option<f64>,
    window_m: f64,
    /// The last plan's carrot (tracking frame, m).
    last_carrot: Option<Vec2>,
    /// The latest scan's points (tracking frame, m): where a stuck robot's
    /// gap is measured.
    last_points: Vec<Vec2>,
}

impl WayRound {
    /// A planner with a map `p.unstuck.window_m` wide.
    pub fn new(p: &Params) -> Self {
        Self {
            map: LocalMap::new(p.unstuck.window_m),
            planner: RoutePlanner::default(),
            last_plan_s: None,
            window_m: p.unstuck.window_m,
            last_carrot: None,
            last_points: Vec::new(),
        }
    }

    /// The map.
    pub fn map(&self) -> &LocalMap {
        &self.map
    }

    /// The centres of the cells the map shows occupied at `now_s` (tracking
    /// frame, m), into `out` (cleared first): for display.
    pub fn occupied_cells(&self, now_s: f64, p: &Params, out: &mut Vec<Vec2>) {
        out.clear();
        let n = self.map.side();
        for k in 0..n * n {
            if self.map.state(k, now_s, p.unstuck.memory_s) == super::local_map::CellState::Occupied {
                out.push(self.map.centre(k));
            }
        }
    }

    /// Forgets the map and the route (a new tracking frame). A new window
    /// width takes effect here.
    pub fn reset(&mut self, p: &Params) {
        if p.unstuck.window_m != self.window_m {
            *self = Self::new(p);
        } else {
            self.map.clear();
            self.planner.drop_route();
            self.planner.clear_avoid();
            self.last_plan_s = None;
            self.last_carrot = None;
            self.last_points.clear();
        }
    }

    /// Takes a scan into the map: the rays of beams that saw nothing clear
    /// what they cross, then the points' rays clear theirs and their ends
    /// are occupied (within the map's half width).
    pub fn insert(&mut self, scan: &MapScan) {
        let clear_m = 0.5 * self.window_m;
        self.map.clear_open(scan.pose, &scan.open_ends, scan.stamp_s, clear_m);
        self.map.insert(scan.pose, &scan.points, scan.stamp_s, clear_m);
        self.map.insert_transient(scan.pose, &scan.transient, scan.stamp_s);
        if scan.pose.is_finite() {
            let map = scan.pose.frame_map();
            self.last_points.clear();
            self.last_points.extend(
                scan.points
                    .iter()
                    .filter(|q| q.x.is_finite() && q.y.is_finite())
                    .map(|q| map.point(*q)),
            );
        }
    }

    /// Whether a plan for `ask` is due (`unstuck.plan_period_s` since the
    /// last, the clock went back, or the robot is stuck).
    pub fn due(&self, ask: &RouteAsk, p: &Params) -> bool {
        ask.stuck
            || self
                .last_plan_s
                .is_none_or(|t| ask.now_s - t >= p.unstuck.plan_period_s || ask.now_s < t)
    }

    /// Plans for `ask` (see [`RoutePlanner::replan`]) and measures the
    /// straight way to `ask.direct_to` on the same fields.
    pub fn plan(&mut self, ask: &RouteAsk, p: &Params) -> RouteUpdate {
        self.last_plan_s = Some(ask.now_s);
        // The body's reach to either side along its narrowest way: r for the circle, a
        // polygon's half-width (a route for the body moving lengthwise; the filter checks
        // the polygon itself wherever it has to turn).
        let half_width = p.footprint.passing_half_width_m();
        if ask.stuck && p.unstuck.stuck_avoid_s > 0.0 {
            if let Some(at) = self.last_carrot {
                // A gap the body fits through is planned through again: what held the
                // robot there passes (a turn, a margin), and the way round a partition
                // is long and unseen. A gap the scan shows too narrow is closed a while.
                let gap_m = self.gap_clearance(ask.from, ask.own_m, at);
                if gap_m < half_width + p.barrier.d_safe_m - PINCH_TOLERANCE_M {
                    log::debug!(
                        "t {:.1}: stuck at a gap too narrow ({gap_m:.3} m): avoiding {at:?}",
                        ask.now_s
                    );
                    self.planner.avoid(at, ask.now_s + p.unstuck.stuck_avoid_s);
                } else {
                    log::debug!(
                        "t {:.1}: stuck where the robot fits ({gap_m:.3} m): planning afresh",
                        ask.now_s
                    );
                    self.planner.drop_route();
                }
            }
        }
        let req = RouteRequest {
            now_s: ask.now_s,
            from: ask.from,
            goal: ask.goal,
            clearance_m: half_width + p.barrier.d_safe_m + p.unstuck.margin_m,
            own_m: ask.own_m,
            memory_s: p.unstuck.memory_s,
        };
        // Gaps narrower than 2 (r + d_safe + margin) but not than 2 (r + d_safe) are
        // taken only when no wider way reaches the goal, or only through unseen space
        // and much longer (route::relaxation_wins).
        let tight = RouteRequest {
            clearance_m: half_width + p.barrier.d_safe_m,
            ..req
        };
        let (route, change) = self.planner.replan(&self.map, &[req, tight]);
        let route = route.cloned();
        // Sight lines are judged with the clearance the route was planned with.
        let req = self.planner.chosen().copied().unwrap_or(req);
        let direct_margin_m = self.segment_margin(ask.from, ask.direct_to, ask.own_m, &req);
        let carrot = route.as_ref().and_then(|r| self.carrot(r, ask, &req));
        self.last_carrot = carrot;
        log::trace!(
            "t {:.1}: route {} points ({}), reaches {:?}, carrot {carrot:?}, direct margin {direct_margin_m:.2} m, from {:?}",
            ask.now_s,
            route.as_ref().map_or(0, |r| r.points.len()),
            change.as_str(),
            route.as_ref().map(|r| r.reaches_goal),
            ask.from
        );
        RouteUpdate {
            route,
            change,
            direct_margin_m,
            carrot,
            made_s: ask.now_s,
            plan_us: 0.0,
        }
    }

    /// The route point the robot steers at (see [`RouteUpdate::carrot`]).
    fn carrot(&self, route: &Route, ask: &RouteAsk, req: &RouteRequest) -> Option<Vec2> {
        let start = route.nearest(ask.from);
        let mut walked = 0.0;
        let mut prev = *route.points.get(start)?;
        let mut best = route.points.get(start + 1).copied();
        for q in &route.points[start + 1..] {
            walked += (q - prev).norm();
            prev = *q;
            if walked > WAYPOINT_REACH_M {
                break;
            }
            if self.segment_margin(ask.from, *q, ask.own_m, req) >= 0.0 {
                best = Some(*q);
            }
        }
        best
    }

    /// The narrowest the held route gets, by the latest scan, from the robot
    /// at `from` to the spot `at` it steered at and [`PINCH_BEYOND_M`] past
    /// it: over its points, the least of the best clearance from every scan
    /// point within half a cell of the point (the route is cell centres; a
    /// 5 × 5 lattice), leaving out the points within `own_m` of the robot
    /// (m; ∞ without a route or a scan). Exact where the map is not: its
    /// cells round a gap's width by up to a cell, and a passable door can be
    /// barely wider than the body needs.
    fn gap_clearance(&self, from: Vec2, own_m: f64, at: Vec2) -> f64 {
        let Some(route) = self.planner.route() else {
            return f64::INFINITY;
        };
        let (start, spot) = (route.nearest(from), route.nearest(at));
        let h = 0.25 * MAP_CELL_M;
        let mut least2 = f64::INFINITY;
        let mut past_m = 0.0;
        for k in start..route.points.len() {
            let q = route.points[k];
            if k > spot.max(start) {
                past_m += (q - route.points[k - 1]).norm();
                if past_m > PINCH_BEYOND_M {
                    break;
                }
            }
            // The robot is where it is: only the way ahead is judged.
            if (q - from).norm() <= own_m {
                continue;
            }
            let mut best2 = 0.0_f64;
            for i in -2..=2 {
                for j in -2..=2 {
                    let c = q + Vec2::new(h * f64::from(i), h * f64::from(j));
                    best2 = best2.max(super::geometry::min_distance_squared(&self.last_points, c));
                }
            }
            least2 = least2.min(best2);
        }
        least2.sqrt()
    }

    /// The least margin over the blocked band along the segment from `a`
    /// to `b`, leaving out the disc of radius `own_m` round `a` (m).
    fn segment_margin(&self, a: Vec2, b: Vec2, own_m: f64, req: &RouteRequest) -> f64 {
        let seg = b - a;
        let len = seg.norm();
        // Samples every half cell; a segment longer than the window (garbage) is
        // sampled more coarsely, the samples outside the window being skipped anyway.
        let max_steps = 4 * self.map.side();
        let steps = ((len / (0.5 * MAP_CELL_M)).ceil() as usize).min(max_steps);
        let mut least = f64::INFINITY;
        for s in 0..=steps {
            let q = a + seg * (s as f64 / steps.max(1) as f64);
            if (q - a).norm() <= own_m {
                continue;
            }
            if let Some(k) = self.map.index(cell_coords(q)) {
                least = least.min(self.planner.margin_m(k, req));
            }
        }
        least
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The route planned after the robot got stuck 0.4 m before the only
    /// door of a wall, `half_m` each side of the middle: whether it still runs
    /// through the door. The wall runs across x = 1 from y = −3 to 3; its door
    /// is a passage 1.2 m long; the way round the wall's ends is 6 m longer.
    /// Both doors below are wider than the route's tight band (2 (r + d_safe)
    /// less a cell's diagonal), so the route runs down the passage's middle.
    fn through_the_door_after_stuck(half_m: f64, stuck_avoid_s: f64) -> bool {
        let mut p = Params::default();
        p.unstuck.stuck_avoid_s = stuck_avoid_s;
        let wall = |y0: f64, y1: f64| -> Vec<Vec2> {
            let n = ((y1 - y0) / 0.02).round() as usize;
            (0..=n)
                .map(|i| Vec2::new(1.0, y0 + (y1 - y0) * i as f64 / n as f64))
                .collect()
        };
        let mut points = wall(-3.0, -half_m);
        points.extend(wall(half_m, 3.0));
        for y in [-half_m, half_m] {
            points.extend((0..=60).map(|i| Vec2::new(1.0 + 0.02 * i as f64, y)));
        }
        let mut w = WayRound::new(&p);
        w.insert(&MapScan {
            stamp_s: 0.0,
            pose: Pose2::default(),
            points,
            open_ends: vec![],
            transient: vec![],
        });
        let ask = RouteAsk {
            now_s: 0.0,
            from: Vec2::new(0.6, 0.0),
            goal: Vec2::new(3.0, 0.0),
            direct_to: Vec2::new(3.0, 0.0),
            own_m: 0.1,
            stuck: false,
        };
        let through_the_door = |u: &RouteUpdate| {
            let r = u.route.as_ref().expect("a route");
            r.reaches_goal
                && r.points
                    .iter()
                    .filter(|q| (1.0..=2.2).contains(&q.x))
                    .all(|q| q.y.abs() < 0.1)
                && r.points.iter().all(|q| q.y.abs() < 0.5)
        };
        let u = w.plan(&ask, &p);
        assert!(through_the_door(&u), "{:?}", u.route);
        let later = RouteAsk {
            now_s: 3.0,
            stuck: true,
            ..ask
        };
        assert!(w.due(&later, &p), "stuck: planned again at once");
        through_the_door(&w.plan(&later, &p))
    }

    #[test]
    fn stuck_at_a_door_the_robot_fits_through_it_is_planned_through_again() {
        // r + d_safe = 0.378 m. A door of 0.86 m leaves 0.052 m spare each side: the
        // spot is not closed, the route goes through the door again.
        let p = Params::default();
        assert!((p.robot_radius_m() + p.barrier.d_safe_m - 0.378).abs() < 1e-9);
        assert!(through_the_door_after_stuck(0.43, p.unstuck.stuck_avoid_s));
        // A door of 0.72 m is 0.018 m short each side (beyond the 0.01 m tolerance):
        // the spot is closed for stuck_avoid_s and the route goes round the wall, unless
        // stuck spots are never closed.
        assert!(!through_the_door_after_stuck(0.36, p.unstuck.stuck_avoid_s));
        assert!(through_the_door_after_stuck(0.36, 0.0));
        // 0.74 m is short by 0.008 m each side, within the tolerance: planned through.
        assert!(through_the_door_after_stuck(0.37, p.unstuck.stuck_avoid_s));
    }

    #[test]
    fn plans_at_its_period_and_sees_a_wall_across_the_direct_way() {
        let p = Params::default();
        let mut w = WayRound::new(&p);
        // A wall 1 m ahead, y from -1 to 1.
        let wall: Vec<Vec2> = (0..=100).map(|k| Vec2::new(1.0, -1.0 + 0.02 * k as f64)).collect();
        w.insert(&MapScan {
            stamp_s: 0.0,
            pose: Pose2::default(),
            points: wall,
            open_ends: vec![],
            transient: vec![],
        });
        let ask = RouteAsk {
            now_s: 0.0,
            from: Vec2::zeros(),
            goal: Vec2::new(3.0, 0.0),
            direct_to: Vec2::new(2.0, 0.0),
            own_m: 0.0,
            stuck: false,
        };
        let at = |now_s: f64| RouteAsk { now_s, ..ask };
        assert!(w.due(&ask, &p));
        let u = w.plan(&ask, &p);
        assert!(!w.due(&at(0.1), &p) && w.due(&at(p.unstuck.plan_period_s), &p));
        assert!(w.due(&RouteAsk { stuck: true, ..at(0.1) }, &p));
        assert_eq!(u.change, RouteChange::New);
        // The straight way runs through the wall: its margin is the wall's own
        // (−(r + d_safe + margin − half a diagonal) at the wall's cells).
        let block = p.robot_radius_m() + p.barrier.d_safe_m + p.unstuck.margin_m - 0.5 * 2f64.sqrt() * MAP_CELL_M;
        assert!((u.direct_margin_m + block).abs() < 1e-9, "{}", u.direct_margin_m);
        // The route goes round an end of the wall (|y| > 1 + the block distance there).
        let r = u.route.unwrap();
        let crossing = r.points.iter().find(|q| (q.x - 1.0).abs() < 1e-9).unwrap();
        assert!(crossing.y.abs() > 1.0 + block - 1e-9, "{crossing:?}");
        // A direct way clear of the wall: a positive margin.
        let side = RouteAsk {
            direct_to: Vec2::new(0.0, 2.0),
            ..ask
        };
        assert!(w.plan(&side, &p).direct_margin_m > 0.0);
    }
}
