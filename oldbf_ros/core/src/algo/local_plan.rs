//! A way round (ALGORITHM.md §4b): the free gap nearest the reference, found
//! on a grid around the robot built from the scan's points.
//!
//! Cells within `clearance_m` (r + d_safe plus a little) of a point are
//! blocked; a breadth-first search from the robot's cell over the free ones
//! reaches every cell the robot could drive to keeping that clearance. When
//! the target's cell is among them, the way is the shortest path to it
//! (through the gap nearest the reference that the robot fits through);
//! otherwise it leads to the reachable cell nearest the target (shorter path
//! on a tie). Unseen space is taken as free, as a reactive layer must (the
//! next scans correct it). The waypoint is the farthest cell of that path,
//! within `reach_m`, that the robot sees in a straight line through free
//! cells.
//!
//! The grid is a square window centred on the robot (robot frame), cells of
//! [`CELL_M`]; all buffers are kept between calls, so planning allocates
//! only when the window first grows.

use super::geometry::Vec2;
use std::collections::VecDeque;

/// Cell size (m).
pub const CELL_M: f64 = 0.05;
/// Unreached.
const FAR: u32 = u32::MAX;
/// Keeping to a side blocks the other side's cells this near the robot (m)…
pub const SIDE_BLOCK_M: f64 = 1.5;
/// …but not those this near, where the robot turns (m).
const SIDE_KEEP_M: f64 = 0.15;

/// Where the planner heads and whether the target itself was reached.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Waypoint {
    /// Point to steer towards (robot frame, m).
    pub point: Vec2,
    /// The path's end (the cell nearest the target by path + straight line).
    pub end: Vec2,
    /// Path length to `end` (m).
    pub path_m: f64,
    /// Whether the straight line to the target (clipped to the window) is free.
    pub target_in_sight: bool,
}

/// The grid and its search buffers.
#[derive(Debug, Clone, Default)]
pub struct LocalPlanner {
    side: usize,
    blocked: Vec<bool>,
    dist: Vec<u32>,
    parent: Vec<u32>,
    queue: VecDeque<u32>,
    path: Vec<u32>,
    /// Cell offsets of the blocking disc, for the radius in cells it was built for.
    disc: Vec<(i32, i32)>,
    disc_for: Option<i64>,
}

impl LocalPlanner {
    fn centre_of(&self, k: u32) -> Vec2 {
        let half = (self.side / 2) as f64;
        let (i, j) = ((k as usize % self.side) as f64, (k as usize / self.side) as f64);
        Vec2::new((i - half) * CELL_M, (j - half) * CELL_M)
    }

    fn cell_of(&self, p: Vec2) -> Option<u32> {
        let half = (self.side / 2) as f64;
        let (i, j) = ((p.x / CELL_M + half).round(), (p.y / CELL_M + half).round());
        let n = self.side as f64;
        (i >= 0.0 && j >= 0.0 && i < n && j < n).then(|| (j as usize * self.side + i as usize) as u32)
    }

    /// Plans from the robot (the origin) towards `target` (robot frame, m)
    /// through a window `window_m` wide, keeping `clearance_m` from every
    /// point. The cells within `own_m` of the robot count as free whatever
    /// their clearance (it is there, and may move within what it occupies).
    /// With `keep_side` (+1: left of the line from the robot to the target, −1:
    /// right), the cells clearly on the other side within [`SIDE_BLOCK_M`]
    /// of the robot are blocked too: the way round keeps to the side chosen
    /// before instead of flipping between two nearly equal ones.
    /// `None` when no free cell is reachable at all.
    #[allow(clippy::too_many_arguments)]
    pub fn plan(
        &mut self,
        points: &[Vec2],
        target: Vec2,
        clearance_m: f64,
        own_m: f64,
        window_m: f64,
        reach_m: f64,
        keep_side: Option<f64>,
    ) -> Option<Waypoint> {
        let side = ((window_m / CELL_M).ceil() as usize) | 1; // odd: the robot in the centre cell
        let cells = side * side;
        self.side = side;
        self.blocked.clear();
        self.blocked.resize(cells, false);
        self.dist.clear();
        self.dist.resize(cells, FAR);
        self.parent.clear();
        self.parent.resize(cells, FAR);
        self.queue.clear();
        // Block every cell within the clearance of a point: a disc of cell offsets, built
        // once per clearance, checked exactly against the point's position in its cell.
        let r_cells = (clearance_m / CELL_M).ceil() as i64;
        if self.disc_for != Some(r_cells) {
            self.disc.clear();
            for dj in -r_cells..=r_cells {
                for di in -r_cells..=r_cells {
                    if ((di.abs() - 1).max(0).pow(2) + (dj.abs() - 1).max(0).pow(2)) <= r_cells * r_cells {
                        self.disc.push((di as i32, dj as i32));
                    }
                }
            }
            self.disc_for = Some(r_cells);
        }
        let half = (side / 2) as i64;
        let r2 = (clearance_m / CELL_M) * (clearance_m / CELL_M);
        let n = side as i64;
        let mut last_cell = None;
        for q in points {
            // Cell units, the robot's cell at (half, half).
            let (fx, fy) = (q.x / CELL_M + half as f64, q.y / CELL_M + half as f64);
            let (ci, cj) = (fx.round() as i64, fy.round() as i64);
            if ci < -r_cells || cj < -r_cells || ci >= n + r_cells || cj >= n + r_cells {
                continue;
            }
            // Neighbouring beams often land in one cell: stamp it once per run.
            if last_cell == Some((ci, cj)) {
                continue;
            }
            last_cell = Some((ci, cj));
            for &(di, dj) in &self.disc {
                let (i, j) = (ci + di as i64, cj + dj as i64);
                if i < 0 || j < 0 || i >= n || j >= n {
                    continue;
                }
                let (dx, dy) = (i as f64 - fx, j as f64 - fy);
                if dx * dx + dy * dy < r2 {
                    self.blocked[(j * n + i) as usize] = true;
                }
            }
        }
        if let Some(sign) = keep_side {
            let t = target / target.norm().max(1e-9);
            for k in 0..cells {
                let c = self.centre_of(k as u32);
                let across = t.x * c.y - t.y * c.x;
                let d = c.norm();
                if sign * across < -CELL_M && d > SIDE_KEEP_M && d < SIDE_BLOCK_M {
                    self.blocked[k] = true;
                }
            }
        }
        let start = self.cell_of(Vec2::zeros())?;
        let own = (own_m / CELL_M).floor() as i64;
        for dj in -own..=own {
            for di in -own..=own {
                let (i, j) = (half + di, half + dj);
                if (di * di + dj * dj) as f64 * CELL_M * CELL_M <= own_m * own_m
                    && (0..side as i64).contains(&i)
                    && (0..side as i64).contains(&j)
                {
                    self.blocked[j as usize * side + i as usize] = false;
                }
            }
        }
        self.blocked[start as usize] = false;
        self.dist[start as usize] = 0;
        self.queue.push_back(start);
        let mut best = (f64::INFINITY, start);
        while let Some(k) = self.queue.pop_front() {
            let d = self.dist[k as usize];
            // Nearest the target; breadth first, so the first found has the shorter path.
            let score = (self.centre_of(k) - target).norm();
            if score < best.0 {
                best = (score, k);
            }
            let (i, j) = (k as usize % side, k as usize / side);
            let mut visit = |i: usize, j: usize| {
                let n = (j * side + i) as u32;
                if !self.blocked[n as usize] && self.dist[n as usize] == FAR {
                    self.dist[n as usize] = d + 1;
                    self.parent[n as usize] = k;
                    self.queue.push_back(n);
                }
            };
            if i > 0 {
                visit(i - 1, j);
            }
            if i + 1 < side {
                visit(i + 1, j);
            }
            if j > 0 {
                visit(i, j - 1);
            }
            if j + 1 < side {
                visit(i, j + 1);
            }
        }
        let end = match self.cell_of(target) {
            Some(t) if self.dist[t as usize] != FAR => t,
            _ => best.1,
        };
        // The path, start first.
        self.path.clear();
        let mut k = end;
        while k != FAR {
            self.path.push(k);
            k = self.parent[k as usize];
        }
        self.path.reverse();
        // The farthest path cell within reach that is in sight through free cells.
        let mut point = self.centre_of(end);
        for &k in self.path.iter().skip(1) {
            let c = self.centre_of(k);
            if c.norm() > reach_m || !self.in_sight(c) {
                break;
            }
            point = c;
        }
        if self.path.len() <= 1 {
            point = self.centre_of(end);
        }
        let edge = 0.5 * (side - 1) as f64 * CELL_M;
        let scale = (edge / target.x.abs().max(target.y.abs()).max(1e-9)).min(1.0);
        Some(Waypoint {
            point,
            end: self.centre_of(end),
            path_m: self.dist[end as usize] as f64 * CELL_M,
            target_in_sight: self.in_sight(target * scale),
        })
    }

    /// Whether the straight line from the robot to `p` crosses only free
    /// cells (sampled every half cell).
    fn in_sight(&self, p: Vec2) -> bool {
        let n = (p.norm() / (0.5 * CELL_M)).ceil() as usize;
        (1..=n).all(|s| {
            let q = p * (s as f64 / n as f64);
            self.cell_of(q).is_some_and(|k| !self.blocked[k as usize])
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A wall across x = `x` from y = `y0` to `y1`, points 2 cm apart.
    fn wall(x: f64, y0: f64, y1: f64) -> Vec<Vec2> {
        let n = ((y1 - y0) / 0.02) as usize;
        (0..=n).map(|i| Vec2::new(x, y0 + 0.02 * i as f64)).collect()
    }

    #[test]
    fn open_space_heads_straight_for_the_target() {
        let mut lp = LocalPlanner::default();
        let w = lp.plan(&[], Vec2::new(1.0, 0.0), 0.4, 0.0, 4.0, 1.2, None).unwrap();
        assert!(w.target_in_sight);
        assert!((w.end - Vec2::new(1.0, 0.0)).norm() < 1e-9, "{w:?}");
        assert!((w.point - Vec2::new(1.0, 0.0)).norm() < 1e-9, "{w:?}");
        assert!((w.path_m - 1.0).abs() < 1e-9);
    }

    #[test]
    fn a_wall_ahead_is_gone_round_on_the_side_of_its_nearer_end() {
        let mut lp = LocalPlanner::default();
        // Wall 0.8 m ahead from y = −0.5 to 1.5: its lower end is nearer.
        let pts = wall(0.8, -0.5, 1.5);
        let w = lp.plan(&pts, Vec2::new(2.0, 0.0), 0.4, 0.0, 5.0, 1.2, None).unwrap();
        assert!(!w.target_in_sight);
        assert!(w.point.y < -0.4, "heads below the wall: {w:?}");
        // The end reaches the target: there is room round the wall.
        assert!((w.end - Vec2::new(2.0, 0.0)).norm() < 0.05, "{w:?}");
        // Made to keep to the left, it goes round the far end instead.
        let w = lp
            .plan(&pts, Vec2::new(2.0, 0.0), 0.4, 0.0, 5.0, 1.2, Some(1.0))
            .unwrap();
        assert!(w.point.y > 0.2 && (w.end - Vec2::new(2.0, 0.0)).norm() < 0.05, "{w:?}");
        // Mirror the wall: goes above.
        let pts: Vec<Vec2> = pts.iter().map(|p| Vec2::new(p.x, -p.y)).collect();
        let w = lp.plan(&pts, Vec2::new(2.0, 0.0), 0.4, 0.0, 5.0, 1.2, None).unwrap();
        assert!(w.point.y > 0.4, "{w:?}");
    }

    #[test]
    fn a_doorway_narrower_than_twice_the_clearance_is_not_a_way_through() {
        let mut lp = LocalPlanner::default();
        // A wall across x = 1 with a doorway at |y| < 0.35 (0.7 m) and one at 1.0..1.9 (0.9 m).
        let mut pts = wall(1.0, -3.0, -0.35);
        pts.extend(wall(1.0, 0.35, 1.0));
        pts.extend(wall(1.0, 1.9, 3.0));
        let w = lp.plan(&pts, Vec2::new(2.0, 0.0), 0.4, 0.0, 6.0, 1.2, None).unwrap();
        // Not straight through the narrow one: up to the wide one and through it, to the
        // target (a path of at least 0.6 + 1.45 · 2 + 1 m).
        assert!((w.end - Vec2::new(2.0, 0.0)).norm() < 1e-9 && w.path_m > 4.0, "{w:?}");
        assert!(w.point.y > 0.3, "{w:?}");
        // Only the narrow doorway: the best it can do is stop short of it, r + d_safe off its jambs.
        let mut pts = wall(1.0, -3.0, -0.35);
        pts.extend(wall(1.0, 0.35, 3.0));
        let w = lp.plan(&pts, Vec2::new(2.0, 0.0), 0.4, 0.0, 6.0, 1.2, None).unwrap();
        assert!(w.end.x < 0.9 && w.path_m < 1.0, "{w:?}");
    }

    #[test]
    fn no_allocation_once_the_window_is_sized() {
        let mut lp = LocalPlanner::default();
        let pts = wall(0.8, -0.5, 1.5);
        lp.plan(&pts, Vec2::new(2.0, 0.0), 0.4, 0.0, 5.0, 1.2, None);
        let caps = (
            lp.blocked.capacity(),
            lp.dist.capacity(),
            lp.queue.capacity(),
            lp.path.capacity(),
        );
        lp.plan(&pts, Vec2::new(2.0, 0.3), 0.4, 0.0, 5.0, 1.2, None);
        assert_eq!(
            caps,
            (
                lp.blocked.capacity(),
                lp.dist.capacity(),
                lp.queue.capacity(),
                lp.path.capacity()
            )
        );
    }
}
#[cfg(test)]
mod timing {
    use super::*;
    #[test]
    #[ignore]
    fn plan_time() {
        let mut pts = Vec::new();
        for k in 0..360 {
            let a = k as f64 * std::f64::consts::PI / 180.0;
            let d = 1.0 + 0.5 * (3.0 * a).sin();
            pts.push(Vec2::new(d * a.cos(), d * a.sin()));
        }
        let mut lp = LocalPlanner::default();
        let t0 = std::time::Instant::now();
        for _ in 0..100 {
            lp.plan(&pts, Vec2::new(2.0, 0.0), 0.428, 0.1, 5.0, 1.0, None);
        }
        eprintln!("plan: {:.1} us", t0.elapsed().as_secs_f64() * 1e4);
        let t0 = std::time::Instant::now();
        for _ in 0..100 {
            lp.plan(&pts, Vec2::new(2.0, 0.0), 0.428, 0.1, 5.0, 1.0, Some(1.0));
        }
        eprintln!("plan with side: {:.1} us", t0.elapsed().as_secs_f64() * 1e4);
    }
}
