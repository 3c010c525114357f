//! A way round on the rolling local map (ALGORITHM.md §4c): the cheapest
//! path from the robot to a goal through gaps the robot fits through, and
//! the rule that keeps a route until there is a reason to change it.
//!
//! * **Blocked cells**: those whose centre is nearer than
//!   `clearance_m` − half a cell's diagonal to an occupied cell's centre (an
//!   exact Euclidean distance transform; the half diagonal undoes the cells'
//!   rounding, so a gap of 2 (r + d_safe) is open and a much narrower one is
//!   not). The cells within `own_m` of the robot are never blocked: it is
//!   there already; nor, within [`ESCAPE_M`] of it, those at least as far
//!   from everything as the robot is now: a robot in a tight spot can leave
//!   it the way it came.
//! * **Cost** of a step: its length, times 1 + [`UNKNOWN_COST`] through
//!   unknown cells (the route may cross what is not yet seen, which the
//!   next scans will show; the safety checks never take unknown for free),
//!   plus up to [`NEAR_COST`] times more within [`NEAR_RAMP_M`] of the
//!   blocked band, so a route keeps to the middle of a gap.
//! * **Search**: A* from the robot's cell, 8-connected, to the goal's cell
//!   (a goal beyond the window: the window's point nearest it on the line
//!   to it). Unreached, the route ends at the reached cell nearest the goal.
//!   When nothing reached touches the window's edge, the goal is inside the
//!   window and that nearest cell is more than [`NO_ROUTE_M`] from it, the
//!   robot is closed in by what it has seen: **no route**.
//! * **Keeping a route** ([`RoutePlanner::replan`]): a new plan replaces
//!   the route held only when the held one is now blocked (a cell of it
//!   nearer to the occupied cells than a new route may go by more than
//!   [`HELD_TOLERANCE_M`], or a spot avoided), its goal has
//!   moved by [`GOAL_MOVED_M`], or the new one is cheaper than what remains
//!   of it by [`BETTER_M`] and [`BETTER_FRACTION`] of it. So the route does
//!   not flip between two nearly equal ways round one obstacle, nor is it
//!   dropped, and the robot sent back, when a passage's walls flicker by a
//!   cell on the map as their noisy hits fall either side of a cell's edge.

use super::geometry::Vec2;
use super::local_map::{cell_coords, CellState, LocalMap, MAP_CELL_M};
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// Extra cost factor per metre through unknown cells.
pub const UNKNOWN_COST: f64 = 0.5;
/// Extra cost factor per metre right at the blocked band, falling to 0 at [`NEAR_RAMP_M`] beyond it.
pub const NEAR_COST: f64 = 1.0;
/// Width of the band beyond the blocked cells that costs more (m).
pub const NEAR_RAMP_M: f64 = 0.3;
/// Within this of the robot, cells as far from everything as the robot is
/// now are not blocked, even nearer than the clearance (m).
pub const ESCAPE_M: f64 = 1.0;
/// Closed in: the nearest reached cell is farther than this from a goal inside the window (m).
pub const NO_ROUTE_M: f64 = 0.5;
/// A new plan must be cheaper than the held route's remainder by this (m)…
pub const BETTER_M: f64 = 1.0;
/// …and by this fraction of it.
pub const BETTER_FRACTION: f64 = 0.2;
/// The held route's goal this far from the new goal: replanned from scratch (m).
pub const GOAL_MOVED_M: f64 = 0.5;
/// A held route is blocked only where the map closes it by more than this
/// beyond the band a new route keeps (m): one cell, what a wall's noisy hits
/// spread into the cell beside it.
pub const HELD_TOLERANCE_M: f64 = MAP_CELL_M;

/// What a plan asks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RouteRequest {
    /// Time of the plan (s; the map's cells are judged at it).
    pub now_s: f64,
    /// The robot's position (tracking frame, m).
    pub from: Vec2,
    /// Where it is going (tracking frame, m).
    pub goal: Vec2,
    /// Keep the robot's centre this far from every occupied cell (m).
    pub clearance_m: f64,
    /// Cells this near the robot are never blocked (m).
    pub own_m: f64,
    /// The map remembers cells this long (s).
    pub memory_s: f64,
}

/// A route: cell centres from the robot to its end (tracking frame, m).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Route {
    /// The cell centres (tracking frame, m).
    pub points: Vec<Vec2>,
    /// The end is the goal (within [`NO_ROUTE_M`]).
    pub reaches_goal: bool,
    /// The end is the search's target within [`NO_ROUTE_M`]: the goal, or
    /// for a goal beyond the window, where the straight line to it leaves
    /// the window.
    pub reaches_target: bool,
    /// Its cost when planned (m, weighted).
    pub cost: f64,
    /// How much of it runs through unknown cells (m): space the route
    /// assumes open that nothing has shown to be.
    pub unknown_m: f64,
    /// The goal it was planned to (tracking frame, m), and when (s).
    pub goal: Vec2,
    /// When it was planned (s).
    pub made_s: f64,
}

impl Route {
    /// Index of the route point nearest `p`.
    pub fn nearest(&self, p: Vec2) -> usize {
        let d = |q: &Vec2| (q - p).norm_squared();
        (0..self.points.len())
            .min_by(|&a, &b| d(&self.points[a]).total_cmp(&d(&self.points[b])))
            .unwrap_or(0)
    }

    /// The point `reach_m` further along the route than the route point
    /// nearest `p` (its end at most): where the robot steers.
    pub fn carrot(&self, p: Vec2, reach_m: f64) -> Option<Vec2> {
        let start = self.nearest(p);
        let mut left = reach_m;
        let mut at = *self.points.get(start)?;
        for q in &self.points[start + 1..] {
            let step = (q - at).norm();
            if step >= left {
                return Some(at + (q - at) * (left / step));
            }
            left -= step;
            at = *q;
        }
        Some(at)
    }
}

/// Whether the plan `relaxed`, made with less clearance, is taken over
/// `stricter`: it reaches its target (the goal, or where the line to a goal
/// beyond the window leaves it), and the stricter one either does not, or
/// reaches it only through unseen space and is much longer: it costs more
/// by [`BETTER_M`] and [`BETTER_FRACTION`] (the margin a new plan needs to
/// replace a held route) and runs [`BETTER_M`] further through unknown
/// cells. Going to look past the end of a wall, and coming back once it is
/// seen closed (and again once it is forgotten), is what a robot that
/// ignores a door it fits through does. A wider way through space seen open
/// wins, however long: the filter follows it with room to spare, where a gap
/// of just 2 (r + d_safe) can hold the robot at its mouth. A goal beyond the
/// window is judged at the window's edge like one inside: most goals are
/// farther than half the window.
pub fn relaxation_wins(relaxed: &Planned, stricter: &Planned) -> bool {
    let Planned::Route(r) = relaxed else {
        return false;
    };
    if !r.reaches_target {
        return false;
    }
    match stricter {
        Planned::Route(s) if s.reaches_target => {
            r.cost < s.cost - BETTER_M.max(BETTER_FRACTION * s.cost) && s.unknown_m > r.unknown_m + BETTER_M
        }
        _ => true,
    }
}

/// What a plan found.
#[derive(Debug, Clone, PartialEq)]
pub enum Planned {
    /// A route towards the goal (to it, or to the nearest reachable cell).
    Route(Route),
    /// Closed in by what the map knows: no way to the goal.
    NoRoute,
}

/// One line for logs: whether it reaches the goal and its target, its cost
/// and its unknown length (written straight to the log, nothing allocated).
impl std::fmt::Display for Planned {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Planned::Route(r) => write!(
                f,
                "route (goal {}, target {}, cost {:.2} m, unknown {:.2} m)",
                r.reaches_goal, r.reaches_target, r.cost, r.unknown_m
            ),
            Planned::NoRoute => f.write_str("no route"),
        }
    }
}

/// Why the route held changed at the last [`RoutePlanner::replan`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RouteChange {
    /// Kept.
    Kept,
    /// None was held.
    New,
    /// The held route runs through blocked cells now.
    Blocked,
    /// A cheaper one by the margin.
    Better,
    /// The goal moved.
    GoalMoved,
    /// No route: dropped.
    NoRoute,
}

impl RouteChange {
    /// Name for logs and records.
    pub fn as_str(self) -> &'static str {
        match self {
            RouteChange::Kept => "kept",
            RouteChange::New => "new",
            RouteChange::Blocked => "blocked",
            RouteChange::Better => "better",
            RouteChange::GoalMoved => "goal_moved",
            RouteChange::NoRoute => "no_route",
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Open {
    f: f64,
    cell: u32,
}
impl Eq for Open {}
impl Ord for Open {
    fn cmp(&self, o: &Self) -> Ordering {
        o.f.total_cmp(&self.f).then(o.cell.cmp(&self.cell))
    }
}
impl PartialOrd for Open {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}

/// The planner's buffers (kept between plans: it allocates only when the
/// map's window first grows) and the route it holds.
#[derive(Debug, Clone, Default)]
pub struct RoutePlanner {
    /// Squared distance to the nearest occupied cell (cells²).
    dist2: Vec<f64>,
    /// Per cell: unknown at the last plan.
    unknown: Vec<bool>,
    /// Per cell: extra cost factor (∞: blocked).
    factor: Vec<f64>,
    g: Vec<f64>,
    parent: Vec<u32>,
    closed: Vec<bool>,
    heap: BinaryHeap<Open>,
    col: Vec<f64>,
    out: Vec<f64>,
    v: Vec<usize>,
    z: Vec<f64>,
    held: Option<Route>,
    last_change: Option<RouteChange>,
    /// Spots the robot got stuck at while following a route, and until when
    /// they count as blocked (tracking frame, m; s).
    avoid: Vec<(Vec2, f64)>,
    /// The request of the last replan's route (its fields are the last built).
    chosen: Option<RouteRequest>,
}

/// Cells within this of a spot the robot got stuck at are blocked (m).
pub const AVOID_RADIUS_M: f64 = 0.3;

/// Squared distance of a cell with no occupied cell in reach (cells²).
const FAR2: f64 = 1e12;
const NONE: u32 = u32::MAX;

/// Felzenszwalb's 1-D squared distance transform of `f` into `d`.
fn dt1d(f: &[f64], d: &mut [f64], v: &mut [usize], z: &mut [f64]) {
    let n = f.len();
    let mut k = 0usize;
    v[0] = 0;
    z[0] = f64::NEG_INFINITY;
    z[1] = f64::INFINITY;
    for q in 1..n {
        let qf = q as f64;
        loop {
            let vk = v[k] as f64;
            let s = ((f[q] + qf * qf) - (f[v[k]] + vk * vk)) / (2.0 * qf - 2.0 * vk);
            if s <= z[k] && k > 0 {
                k -= 1;
                continue;
            }
            if s <= z[k] {
                // k == 0: the new parabola replaces the first.
                v[0] = q;
                z[0] = f64::NEG_INFINITY;
                z[1] = f64::INFINITY;
                break;
            }
            k += 1;
            v[k] = q;
            z[k] = s;
            z[k + 1] = f64::INFINITY;
            break;
        }
    }
    k = 0;
    for (q, dq) in d.iter_mut().enumerate().take(n) {
        while z[k + 1] < q as f64 {
            k += 1;
        }
        let dv = q as f64 - v[k] as f64;
        *dq = dv * dv + f[v[k]];
    }
}

/// Cells nearer an occupied cell than this are blocked (m).
fn block_m(req: &RouteRequest) -> f64 {
    req.clearance_m - 0.5 * std::f64::consts::SQRT_2 * MAP_CELL_M
}

impl RoutePlanner {
    /// Window cell `k`'s distance beyond the blocked band at the last plan
    /// (m; < 0: blocked).
    pub fn margin_m(&self, k: usize, req: &RouteRequest) -> f64 {
        self.dist2.get(k).map_or(f64::INFINITY, |d2| d2.sqrt() * MAP_CELL_M) - block_m(req)
    }

    /// The request (of the relaxation given to [`Self::replan`]) the last
    /// route was planned with: [`Self::margin_m`] is on its fields.
    pub fn chosen(&self) -> Option<&RouteRequest> {
        self.chosen.as_ref()
    }

    /// The route held, if any.
    pub fn route(&self) -> Option<&Route> {
        self.held.as_ref()
    }

    /// Why the route changed at the last replan.
    pub fn last_change(&self) -> Option<RouteChange> {
        self.last_change
    }

    /// Drops the route held.
    pub fn drop_route(&mut self) {
        self.held = None;
    }

    /// Drops the route held and blocks the cells within [`AVOID_RADIUS_M`]
    /// of `at` until `until_s`: the robot could not get through there (the
    /// safety checks hold it back where the map shows a gap), so the next
    /// plan looks for another way.
    pub fn avoid(&mut self, at: Vec2, until_s: f64) {
        self.held = None;
        if at.x.is_finite() && at.y.is_finite() && until_s.is_finite() {
            self.avoid.push((at, until_s));
        }
    }

    /// Forgets the spots to avoid.
    pub fn clear_avoid(&mut self) {
        self.avoid.clear();
    }

    /// Distances and step-cost factors of every cell for `req`.
    fn fields(&mut self, map: &LocalMap, req: &RouteRequest) {
        self.distances(map, req);
        self.costs(map, req);
    }

    /// The map's squared distances to the nearest occupied cell and its
    /// unknown cells at `req.now_s` (independent of the clearance).
    fn distances(&mut self, map: &LocalMap, req: &RouteRequest) {
        let n = map.side();
        let cells = n * n;
        self.dist2.clear();
        self.dist2.resize(cells, FAR2);
        self.unknown.clear();
        self.unknown.resize(cells, false);
        for k in 0..cells {
            match map.state(k, req.now_s, req.memory_s) {
                CellState::Occupied => self.dist2[k] = 0.0,
                CellState::Unknown => self.unknown[k] = true,
                CellState::Free => {}
            }
        }
        self.col.resize(n, 0.0);
        self.out.resize(n, 0.0);
        self.v.resize(n, 0);
        self.z.resize(n + 1, 0.0);
        // Columns, then rows.
        for i in 0..n {
            for j in 0..n {
                self.col[j] = self.dist2[j * n + i];
            }
            dt1d(&self.col, &mut self.out, &mut self.v, &mut self.z);
            for j in 0..n {
                self.dist2[j * n + i] = self.out[j];
            }
        }
        for j in 0..n {
            self.col.copy_from_slice(&self.dist2[j * n..(j + 1) * n]);
            dt1d(&self.col, &mut self.out, &mut self.v, &mut self.z);
            self.dist2[j * n..(j + 1) * n].copy_from_slice(&self.out);
        }
    }

    /// The step-cost factor of every cell for `req`'s clearance, on the
    /// last [`Self::distances`].
    fn costs(&mut self, map: &LocalMap, req: &RouteRequest) {
        let n = map.side();
        let cells = n * n;
        let block_m = block_m(req);
        self.factor.clear();
        self.factor.resize(cells, 1.0);
        let own2 = req.own_m * req.own_m;
        // A robot nearer than the clearance to something (it got into a tight spot) may
        // leave through cells no nearer to anything than it is now, within ESCAPE_M.
        let here_m = map
            .index(cell_coords(req.from))
            .map_or(block_m, |k| self.dist2[k].sqrt() * MAP_CELL_M);
        let escape_block_m = block_m.min(here_m - MAP_CELL_M);
        let escape2 = ESCAPE_M * ESCAPE_M;
        // Beyond the ramp no distance matters: no square root there.
        let far2 = ((block_m + NEAR_RAMP_M) / MAP_CELL_M).powi(2);
        let origin = map.centre(0);
        for j in 0..n {
            let dy = origin.y + j as f64 * MAP_CELL_M - req.from.y;
            for i in 0..n {
                let k = j * n + i;
                let extra = if self.unknown[k] { UNKNOWN_COST } else { 0.0 };
                if self.dist2[k] >= far2 {
                    self.factor[k] = 1.0 + extra;
                    continue;
                }
                let d_m = self.dist2[k].sqrt() * MAP_CELL_M;
                let dx = origin.x + i as f64 * MAP_CELL_M - req.from.x;
                let from2 = dx * dx + dy * dy;
                let block_here_m = if from2 <= escape2 { escape_block_m } else { block_m };
                self.factor[k] = if d_m < block_here_m && from2 > own2 {
                    f64::INFINITY
                } else {
                    let near = ((NEAR_RAMP_M - (d_m - block_m)) / NEAR_RAMP_M).clamp(0.0, 1.0);
                    1.0 + extra + NEAR_COST * near
                };
            }
        }
        self.avoid.retain(|&(_, until_s)| req.now_s <= until_s);
        let reach = (AVOID_RADIUS_M / MAP_CELL_M).ceil() as i64;
        for &(at, _) in &self.avoid {
            let c = cell_coords(at);
            for dj in -reach..=reach {
                for di in -reach..=reach {
                    let Some(k) = map.index((c.0 + di, c.1 + dj)) else {
                        continue;
                    };
                    let centre = map.centre(k);
                    if (centre - at).norm() <= AVOID_RADIUS_M && (centre - req.from).norm_squared() > own2 {
                        self.factor[k] = f64::INFINITY;
                    }
                }
            }
        }
    }

    /// The cheapest route for `req` on `map` (A*, 8-connected), without
    /// touching the route held.
    pub fn plan(&mut self, map: &LocalMap, req: &RouteRequest) -> Planned {
        self.fields(map, req);
        self.search(map, req)
    }

    fn search(&mut self, map: &LocalMap, req: &RouteRequest) -> Planned {
        let n = map.side();
        let cells = n * n;
        let Some(start) = map.index(cell_coords(req.from)) else {
            return Planned::NoRoute;
        };
        // A goal beyond the window: the window's point nearest it on the line to it.
        let lo = map.centre(0);
        let hi = map.centre(cells - 1);
        let inside = |p: Vec2| p.x >= lo.x && p.y >= lo.y && p.x <= hi.x && p.y <= hi.y;
        let goal_inside = inside(req.goal);
        let mut goal = req.goal;
        if !goal_inside {
            let d = req.goal - req.from;
            let mut t = 1.0f64;
            for (o, dv, lo, hi) in [(req.from.x, d.x, lo.x, hi.x), (req.from.y, d.y, lo.y, hi.y)] {
                if dv > 0.0 {
                    t = t.min((hi - o) / dv);
                } else if dv < 0.0 {
                    t = t.min((lo - o) / dv);
                }
            }
            goal = req.from + d * t.clamp(0.0, 1.0);
        }
        let goal_cell = map.index(cell_coords(goal));
        self.g.clear();
        self.g.resize(cells, f64::INFINITY);
        self.parent.clear();
        self.parent.resize(cells, NONE);
        self.closed.clear();
        self.closed.resize(cells, false);
        self.heap.clear();
        let h = |k: usize| (map.centre(k) - goal).norm();
        self.g[start] = 0.0;
        self.factor[start] = self.factor[start].min(1.0 + UNKNOWN_COST + NEAR_COST);
        self.heap.push(Open {
            f: h(start),
            cell: start as u32,
        });
        let mut best = (f64::INFINITY, f64::INFINITY, start);
        let mut touched_edge = false;
        let ni = n as i64;
        while let Some(Open { cell, .. }) = self.heap.pop() {
            let k = cell as usize;
            if self.closed[k] {
                continue;
            }
            self.closed[k] = true;
            let hk = h(k);
            if (hk, self.g[k]) < (best.0, best.1) {
                best = (hk, self.g[k], k);
            }
            if Some(k) == goal_cell {
                break;
            }
            let (i, j) = ((k % n) as i64, (k / n) as i64);
            if i == 0 || j == 0 || i == ni - 1 || j == ni - 1 {
                touched_edge = true;
            }
            for (di, dj) in [(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)] {
                let (a, b) = (i + di, j + dj);
                if a < 0 || b < 0 || a >= ni || b >= ni {
                    continue;
                }
                let m = (b * ni + a) as usize;
                if self.closed[m] || self.factor[m].is_infinite() {
                    continue;
                }
                // A diagonal step may not cut a blocked corner.
                if di != 0 && dj != 0 {
                    let (c1, c2) = ((j * ni + a) as usize, (b * ni + i) as usize);
                    if self.factor[c1].is_infinite() || self.factor[c2].is_infinite() {
                        continue;
                    }
                }
                let len = if di != 0 && dj != 0 {
                    std::f64::consts::SQRT_2
                } else {
                    1.0
                } * MAP_CELL_M;
                let g = self.g[k] + len * 0.5 * (self.factor[k] + self.factor[m]);
                if g < self.g[m] {
                    self.g[m] = g;
                    self.parent[m] = k as u32;
                    self.heap.push(Open {
                        f: g + h(m),
                        cell: m as u32,
                    });
                }
            }
        }
        let (gap_m, cost, end) = best;
        let end_to_goal = (map.centre(end) - req.goal).norm();
        if goal_inside && !touched_edge && end_to_goal > NO_ROUTE_M {
            return Planned::NoRoute;
        }
        let mut points = Vec::new();
        let mut unknown_m = 0.0;
        let mut k = end as u32;
        while k != NONE {
            let c = map.centre(k as usize);
            let parent = self.parent[k as usize];
            if parent != NONE && (self.unknown[k as usize] || self.unknown[parent as usize]) {
                unknown_m += (c - map.centre(parent as usize)).norm();
            }
            points.push(c);
            k = parent;
        }
        points.reverse();
        Planned::Route(Route {
            points,
            reaches_goal: goal_inside && gap_m <= NO_ROUTE_M,
            reaches_target: gap_m <= NO_ROUTE_M,
            cost,
            unknown_m,
            goal: req.goal,
            made_s: req.now_s,
        })
    }

    /// The cost of what remains of `route` from the point nearest `req.from`
    /// on the last fields (∞: it runs through a cell blocked by more than
    /// [`HELD_TOLERANCE_M`], or a spot avoided).
    fn remaining_cost(&self, map: &LocalMap, route: &Route, req: &RouteRequest) -> f64 {
        let start = route.nearest(req.from);
        let mut cost = 0.0;
        let mut prev: Option<(Vec2, f64)> = None;
        for p in &route.points[start..] {
            let f = map.index(cell_coords(*p)).map_or(1.0 + UNKNOWN_COST, |k| {
                let f = self.factor[k];
                if f.is_infinite()
                    && self.dist2[k].sqrt() * MAP_CELL_M >= block_m(req) - HELD_TOLERANCE_M
                    && !self
                        .avoid
                        .iter()
                        .any(|(at, _)| (map.centre(k) - at).norm() <= AVOID_RADIUS_M)
                {
                    1.0 + NEAR_COST
                } else {
                    f
                }
            });
            if let Some((q, fq)) = prev {
                cost += (p - q).norm() * 0.5 * (f + fq);
            }
            prev = Some((*p, f));
        }
        cost
    }

    /// Plans for `req` on fresh fields.
    fn plan_fresh(&mut self, map: &LocalMap, req: &RouteRequest) -> Planned {
        self.costs(map, req);
        self.search(map, req)
    }

    /// Plans every relaxation of `reqs` and picks one as
    /// [`relaxation_wins`] says: the plan, the index of its request and
    /// the index of the request whose fields were built last.
    fn plan_relaxations(&mut self, map: &LocalMap, reqs: &[RouteRequest]) -> (Planned, usize, usize) {
        let mut planned = self.plan_fresh(map, &reqs[0]);
        let (mut chosen, mut fields_of) = (0, 0);
        for (i, relaxed) in reqs.iter().enumerate().skip(1) {
            let p = self.plan_fresh(map, relaxed);
            fields_of = i;
            log::trace!(
                "t {:.1}: relaxation {i} ({:.3} m): {} against {}",
                relaxed.now_s,
                relaxed.clearance_m,
                p,
                planned
            );
            if relaxation_wins(&p, &planned) {
                planned = p;
                chosen = i;
            }
        }
        (planned, chosen, fields_of)
    }

    /// Plans and decides whether the new plan replaces the route held (see
    /// the module's rule). `reqs` is an ordered relaxation of one request
    /// (the same goal, less clearance each): each is planned, and a later
    /// one is taken over the one chosen so far only as
    /// [`relaxation_wins`] says. Returns the route now held (None: no
    /// route) and why it changed.
    pub fn replan(&mut self, map: &LocalMap, reqs: &[RouteRequest]) -> (Option<&Route>, RouteChange) {
        let Some(first) = reqs.first() else {
            return (self.held.as_ref(), RouteChange::Kept);
        };
        self.distances(map, first);
        let (mut planned, mut chosen, mut fields_of) = self.plan_relaxations(map, reqs);
        let reaches_target = |p: &Planned| matches!(p, Planned::Route(r) if r.reaches_target);
        if !reaches_target(&planned) && !self.avoid.is_empty() {
            // Closed in (from the target, not only from the goal) by the spots the robot
            // got stuck at: those are not what the map shows, so they are forgotten
            // rather than the way given up.
            self.avoid.clear();
            (planned, chosen, fields_of) = self.plan_relaxations(map, reqs);
        }
        let req = &reqs[chosen];
        self.chosen = Some(*req);
        if fields_of != chosen {
            // The held route's cost is taken on the chosen request's fields.
            self.costs(map, req);
        }
        let held = self.held.as_ref().map(|r| {
            let at_end = r.nearest(req.from) + 1 >= r.points.len();
            (
                self.remaining_cost(map, r, req),
                (r.goal - req.goal).norm(),
                r.reaches_goal,
                at_end,
            )
        });
        let change = match (planned, held) {
            (Planned::NoRoute, _) => {
                self.held = None;
                RouteChange::NoRoute
            }
            (Planned::Route(r), None) => {
                self.held = Some(r);
                RouteChange::New
            }
            (Planned::Route(r), Some((_, moved, _, _))) if moved > GOAL_MOVED_M => {
                self.held = Some(r);
                RouteChange::GoalMoved
            }
            (Planned::Route(r), Some((c, _, _, _))) if c.is_infinite() => {
                self.held = Some(r);
                RouteChange::Blocked
            }
            // The robot is at the end of a route that stopped short of the goal.
            (Planned::Route(r), Some((_, _, _, true))) => {
                self.held = Some(r);
                RouteChange::New
            }
            (Planned::Route(r), Some((c, _, held_reaches, _)))
                if (r.reaches_goal && !held_reaches) || r.cost < c - BETTER_M.max(BETTER_FRACTION * c) =>
            {
                self.held = Some(r);
                RouteChange::Better
            }
            (Planned::Route(_), Some(_)) => RouteChange::Kept,
        };
        self.last_change = Some(change);
        (self.held.as_ref(), change)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algo::geometry::Pose2;

    /// A map 8 m wide round the origin, every cell seen free at t = 0,
    /// then `occupied` cells (tracking frame points) seen occupied.
    fn map_with(occupied: &[Vec2]) -> LocalMap {
        map_seen(occupied, 3.9)
    }

    /// The same, every cell within `seen_m` of the origin seen free (the rest unknown).
    fn map_seen(occupied: &[Vec2], seen_m: f64) -> LocalMap {
        let mut m = LocalMap::new(8.0);
        // Rays in every direction, cleared for `seen_m`, end outside the window…
        let ring: Vec<Vec2> = (0..2000)
            .map(|k| {
                let a = k as f64 * std::f64::consts::TAU / 2000.0;
                Vec2::new(6.0 * a.cos(), 6.0 * a.sin())
            })
            .collect();
        m.insert(Pose2::default(), &ring, 0.0, seen_m);
        // …then the obstacles are seen (a later scan with no rays cleared).
        m.insert(Pose2::default(), occupied, 0.1, 0.0);
        m
    }

    fn req(goal: Vec2) -> RouteRequest {
        RouteRequest {
            now_s: 0.2,
            from: Vec2::zeros(),
            goal,
            clearance_m: 0.378, // r + d_safe
            own_m: 0.0,
            memory_s: 30.0,
        }
    }

    /// A wall of points across x = `x` for y in [y0, y1], 2 cm apart.
    fn wall(x: f64, y0: f64, y1: f64) -> Vec<Vec2> {
        let n = ((y1 - y0) / 0.02).round() as usize;
        (0..=n).map(|i| Vec2::new(x, y0 + 0.02 * i as f64)).collect()
    }

    #[test]
    fn an_open_map_gives_the_straight_line() {
        let mut p = RoutePlanner::default();
        let Planned::Route(r) = p.plan(&map_with(&[]), &req(Vec2::new(2.0, 0.0))) else {
            panic!("no route")
        };
        assert!(r.reaches_goal);
        // 40 cells of 5 cm: 2 m, every point on y = 0.
        assert!((r.cost - 2.0).abs() < 1e-9, "{}", r.cost);
        assert!(r.points.iter().all(|q| q.y.abs() < 1e-9));
        let c = r.carrot(Vec2::zeros(), 0.8).unwrap();
        assert!((c - Vec2::new(0.8, 0.0)).norm() < 1e-9, "{c:?}");
    }

    #[test]
    fn a_wall_with_a_doorway_is_passed_through_its_middle_when_wide_enough() {
        // A wall across x = 1 with a door from y = -0.4 to 0.4 (0.8 m ≥ 2 (r + d_safe) = 0.756).
        let mut pts = wall(1.0, -3.5, -0.4);
        pts.extend(wall(1.0, 0.4, 3.5));
        let mut p = RoutePlanner::default();
        let Planned::Route(r) = p.plan(&map_with(&pts), &req(Vec2::new(2.5, 0.0))) else {
            panic!("no route")
        };
        assert!(r.reaches_goal);
        let at_door = r.points.iter().find(|q| (q.x - 1.0).abs() < 1e-9).unwrap();
        assert!(at_door.y.abs() < 0.051, "through the middle: {at_door:?}");
        // The wall across the whole window with a 0.6 m door: the window's edge is open (unknown beyond),
        // so not closed in, but the route does not go through the door.
        let mut pts = wall(1.0, -4.5, -0.3);
        pts.extend(wall(1.0, 0.3, 4.5));
        let planned = p.plan(&map_with(&pts), &req(Vec2::new(2.5, 0.0)));
        let Planned::Route(r) = planned else {
            panic!("the window's edge is open: a route to the nearest reachable cell")
        };
        assert!(!r.reaches_goal);
        // It ends in the door's mouth: the cells at least 0.343 m (the clearance less half a
        // cell's diagonal) from the door's posts at (1, ±0.3), x ≤ 1 − √(0.343² − 0.3²) = 0.834.
        assert!(r.points.iter().all(|q| q.x < 0.84), "{:?}", r.points.last());
        assert!(r.points.last().unwrap().x > 0.75, "{:?}", r.points.last());
    }

    #[test]
    fn a_gap_only_just_wide_enough_is_taken_when_the_wider_way_is_long_and_unseen() {
        // A wall across x = 1 with a 0.8 m door (y from −0.4 to 0.4): open at the tight
        // clearance r + d_safe = 0.378, closed at 0.458 (the route's margin of 0.08 added).
        let wide = |goal| RouteRequest {
            clearance_m: 0.458,
            ..req(goal)
        };
        let goal = Vec2::new(2.5, 0.0);
        let through_door = |r: &Route| {
            let at = r.points.iter().find(|q| (q.x - 1.0).abs() < 1e-9).unwrap();
            at.y.abs() < 0.051
        };
        let mut pts = wall(1.0, -3.9, -0.4);
        pts.extend(wall(1.0, 0.4, 2.6));
        // The wall's upper part ends at y = 2.6 and only what lies within 2.5 m has been
        // seen: the wider way round its end (about 6.6 m) crosses unseen space there; the
        // door's way is about 2.5 m plus what its narrowness costs, all of it seen.
        let map = map_seen(&pts, 2.5);
        let mut p = RoutePlanner::default();
        let Planned::Route(round) = p.plan(&map, &wide(goal)) else {
            panic!("no route")
        };
        assert!(
            round.reaches_goal && !through_door(&round) && round.unknown_m > 1.0,
            "{}",
            round.unknown_m
        );
        let (r, why) = p.replan(&map, &[wide(goal), req(goal)]);
        assert_eq!(why, RouteChange::New);
        let r = r.unwrap();
        assert!(through_door(r), "cost {} against {} round", r.cost, round.cost);
        assert_eq!(r.unknown_m, 0.0);
        assert_eq!(p.chosen().map(|q| q.clearance_m), Some(0.378));
        // The same wall seen to 3.9 m: the way round its end is as long, but seen open
        // all the way: it keeps the margin, and is taken.
        let map = map_seen(&pts, 3.9);
        let mut p = RoutePlanner::default();
        let (r, _) = p.replan(&map, &[wide(goal), req(goal)]);
        let r = r.unwrap();
        assert!(r.reaches_goal && !through_door(r) && r.unknown_m == 0.0);
        assert_eq!(p.chosen().map(|q| q.clearance_m), Some(0.458));
        // A post of 0.1 m (y from 0.4 to 0.5) beside the door, open above it, only 2.5 m
        // seen: the way round (about 3.8) is not longer by 1 m and 20 %: taken.
        let mut pts = wall(1.0, -3.9, -0.4);
        pts.extend(wall(1.0, 0.4, 0.5));
        let map = map_seen(&pts, 2.5);
        let mut p = RoutePlanner::default();
        let Planned::Route(door) = p.plan(&map, &req(goal)) else {
            panic!("no route")
        };
        let (r, _) = p.replan(&map, &[wide(goal), req(goal)]);
        let r = r.unwrap();
        assert!(
            r.reaches_goal && !through_door(r),
            "cost {} against {} by the door",
            r.cost,
            door.cost
        );
        assert_eq!(p.chosen().map(|q| q.clearance_m), Some(0.458));
    }

    #[test]
    fn a_goal_beyond_the_window_is_judged_where_the_line_to_it_leaves_the_window() {
        // The wall and 0.8 m door above, only 2.5 m seen, the goal 6 m away: beyond the
        // window (8 m wide round the robot), so no route reaches the goal itself. Both
        // reach where the line to it leaves the window (x = 3.975, the last cell
        // centre), and the door's way wins as it does for a goal inside.
        let goal = Vec2::new(6.0, 0.0);
        let wide = RouteRequest {
            clearance_m: 0.458,
            ..req(goal)
        };
        let mut pts = wall(1.0, -3.9, -0.4);
        pts.extend(wall(1.0, 0.4, 2.6));
        let map = map_seen(&pts, 2.5);
        let mut p = RoutePlanner::default();
        let Planned::Route(round) = p.plan(&map, &wide) else {
            panic!("no route")
        };
        assert!(!round.reaches_goal && round.reaches_target, "{:?}", round.points.last());
        assert!(round.unknown_m > 1.0, "{}", round.unknown_m);
        let (r, _) = p.replan(&map, &[wide, req(goal)]);
        let r = r.unwrap();
        assert!(!r.reaches_goal && r.reaches_target);
        let end = r.points.last().unwrap();
        assert!((end - Vec2::new(3.975, 0.0)).norm() <= NO_ROUTE_M, "{end:?}");
        let at = r.points.iter().find(|q| (q.x - 1.0).abs() < 1e-9).unwrap();
        assert!(
            at.y.abs() < 0.051,
            "through the door: {at:?}, cost {} against {}",
            r.cost,
            round.cost
        );
        assert_eq!(p.chosen().map(|q| q.clearance_m), Some(0.378));
    }

    #[test]
    fn closed_in_by_what_it_has_seen_there_is_no_route() {
        // A ring of radius 1.5 m round the robot, the goal outside it.
        let ring: Vec<Vec2> = (0..600)
            .map(|k| {
                let a = k as f64 * std::f64::consts::TAU / 600.0;
                Vec2::new(1.5 * a.cos(), 1.5 * a.sin())
            })
            .collect();
        let mut p = RoutePlanner::default();
        assert_eq!(p.plan(&map_with(&ring), &req(Vec2::new(3.0, 0.0))), Planned::NoRoute);
        let (held, why) = p.replan(&map_with(&ring), &[req(Vec2::new(3.0, 0.0))]);
        assert_eq!((held, why), (None, RouteChange::NoRoute));
    }

    #[test]
    fn a_held_route_is_kept_until_blocked_or_beaten_by_the_margin() {
        // A post at (1.5, 0.1): round it to the right (y < 0), slightly shorter.
        let post: Vec<Vec2> = (0..40)
            .map(|k| {
                let a = k as f64 * std::f64::consts::TAU / 40.0;
                Vec2::new(1.5 + 0.15 * a.cos(), 0.1 + 0.15 * a.sin())
            })
            .collect();
        let mut p = RoutePlanner::default();
        let goal = Vec2::new(3.0, 0.0);
        let (r, why) = p.replan(&map_with(&post), &[req(goal)]);
        assert_eq!(why, RouteChange::New);
        let first = r.unwrap().clone();
        let side = first.points.iter().find(|q| (q.x - 1.5).abs() < 1e-9).unwrap().y;
        assert!(side < 0.0, "the shorter side: {side}");
        // The post moves to (1.5, -0.1): the left is now a little shorter, not by 1 m.
        let post2: Vec<Vec2> = post.iter().map(|q| q - Vec2::new(0.0, 0.2)).collect();
        let (r, why) = p.replan(&map_with(&post2), &[req(goal)]);
        assert_eq!(why, RouteChange::Kept);
        assert_eq!(r.unwrap(), &first);
        // A wall now stands across the held route's side: blocked, a new route.
        let mut pts = post2.clone();
        pts.extend((0..60).map(|k| Vec2::new(1.5, -0.3 - 0.02 * k as f64)));
        let (r, why) = p.replan(&map_with(&pts), &[req(goal)]);
        assert_eq!(why, RouteChange::Blocked);
        let side = r.unwrap().points.iter().find(|q| (q.x - 1.5).abs() < 1e-9).unwrap().y;
        assert!(side > 0.0, "round the other side: {side}");
        // Stuck at the held route's crossing: that spot is blocked, and the next plan
        // (the wall gone again) goes round the other way.
        let crossing = *r.unwrap().points.iter().find(|q| (q.x - 1.5).abs() < 1e-9).unwrap();
        p.avoid(crossing, 10.0);
        let (r, why) = p.replan(&map_with(&post2), &[req(goal)]);
        assert_eq!(why, RouteChange::New);
        let side = r.unwrap().points.iter().find(|q| (q.x - 1.5).abs() < 1e-9).unwrap().y;
        assert!(side < 0.0, "round the right again, the left's spot avoided: {side}");
        // The goal moves 1 m: planned afresh.
        let (_, why) = p.replan(&map_with(&pts), &[req(Vec2::new(3.0, 1.0))]);
        assert_eq!(why, RouteChange::GoalMoved);
    }

    #[test]
    fn a_held_route_is_kept_while_a_doors_posts_creep_in_by_less_than_a_cell() {
        // A wall across x = 1 (y from −1.5 to 1.5) with a door of 2 × `half` m.
        let door = |half: f64| {
            let mut pts = wall(1.0, -1.5, -half);
            pts.extend(wall(1.0, half, 1.5));
            pts
        };
        let goal = Vec2::new(2.5, 0.0);
        let through = |r: &Route| r.points.iter().any(|q| (q.x - 1.0).abs() < 1e-9 && q.y.abs() < 0.051);
        let mut p = RoutePlanner::default();
        let (r, why) = p.replan(&map_with(&door(0.4)), &[req(goal)]);
        assert_eq!(why, RouteChange::New);
        assert!(through(r.unwrap()));
        // The posts seen 8 cm further in: their cells 0.30 m from the middle's, inside the
        // band a new route keeps (0.378 less half a diagonal = 0.343 m) by less than a cell.
        // A new route goes round the wall…
        let Planned::Route(fresh) = RoutePlanner::default().plan(&map_with(&door(0.32)), &req(goal)) else {
            panic!("no route")
        };
        assert!(fresh.reaches_goal && !through(&fresh));
        // …the one held through the door is kept.
        let (r, why) = p.replan(&map_with(&door(0.32)), &[req(goal)]);
        assert_eq!(why, RouteChange::Kept);
        assert!(through(r.unwrap()));
        // 13 cm in (cells 0.25 m from the middle, more than a cell inside): blocked.
        let (r, why) = p.replan(&map_with(&door(0.27)), &[req(goal)]);
        assert_eq!(why, RouteChange::Blocked);
        assert!(!through(r.unwrap()));
    }

    #[test]
    fn spots_that_alone_close_the_way_to_a_goal_beyond_the_window_are_forgotten() {
        // An open 8 m map round the robot; the goal 6 m ahead, beyond the window, so an
        // unreached search still gives a route (to the cell nearest the target at
        // (4, 0)), not "no route". Spots the robot got stuck at, 0.3 m round each, every
        // 0.25 m on a circle of 0.8 m round it, close it in: they are forgotten and the
        // route reaches the target again.
        let mut p = RoutePlanner::default();
        for k in 0..21 {
            let a = k as f64 * std::f64::consts::TAU / 21.0;
            p.avoid(Vec2::new(0.8 * a.cos(), 0.8 * a.sin()), 10.0);
        }
        let goal = Vec2::new(6.0, 0.0);
        let Planned::Route(closed) = p.plan(&map_with(&[]), &req(goal)) else {
            panic!("a route to the cell nearest the target")
        };
        assert!(
            !closed.reaches_target,
            "the spots close the way: {:?}",
            closed.points.last()
        );
        let (r, _) = p.replan(&map_with(&[]), &[req(goal)]);
        let r = r.expect("a route");
        assert!(r.reaches_target, "{:?}", r.points.last());
        assert!(r.points.iter().all(|q| q.y.abs() < 1e-9), "the straight line");
        // Forgotten: the next plan is the straight line too.
        assert!(matches!(p.plan(&map_with(&[]), &req(goal)), Planned::Route(r) if r.reaches_target));
    }

    #[test]
    fn the_distance_transform_is_exact() {
        // Occupied cells at 0 and 7 of a row of 10: squared distances 0,1,4,9,9,4,1,0,1,4.
        let f: Vec<f64> = (0..10).map(|q| if q == 0 || q == 7 { 0.0 } else { FAR2 }).collect();
        let mut d = vec![0.0; 10];
        let (mut v, mut z) = (vec![0; 10], vec![0.0; 11]);
        dt1d(&f, &mut d, &mut v, &mut z);
        assert_eq!(d, vec![0.0, 1.0, 4.0, 9.0, 9.0, 4.0, 1.0, 0.0, 1.0, 4.0]);
    }
}
