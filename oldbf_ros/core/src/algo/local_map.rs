//! The rolling local map (ALGORITHM.md §4c): occupied, free and unknown
//! cells around the robot, built from recent scans at the robot's pose in
//! the tracking frame (odometry, or dead reckoning from the commands sent).
//!
//! * A scan's ray clears the cells it crosses (seen free at the scan's
//!   time), short of its end by [`CLEAR_SHORT_CELLS`] cells, and marks its
//!   end cell seen occupied. The rays are cleared first and a tie of the
//!   two stamps reads free, so a cell that a point of the scan lies in and
//!   another ray of the same scan crosses reads free (a surface seen at a
//!   glancing angle loses cells this way; docs/DECISIONS.md, §4c stop 46,
//!   has what changing it measured). The points given are the scan's less
//!   those of moving tracks (a person walking is not a wall), so a walking
//!   person leaves no trail.
//! * A cell is **occupied** when it was last seen occupied within
//!   `memory_s`, **free** when last seen free within `memory_s`, and
//!   **unknown** otherwise: what went out of view is remembered for a
//!   bounded time, then forgotten; never-seen space is unknown, not free.
//! * The window is a square of `side` cells of [`MAP_CELL_M`] in the
//!   tracking frame, aligned with its axes; it moves with the robot in whole
//!   cells (keeping what it knows) once the robot is a quarter of the window
//!   from its centre.
//!
//! The map lives in the tracking frame: odometry's drift moves the
//! remembered obstacles with it, one more reason to forget them.

use super::geometry::{FrameMap, Pose2, Vec2};

/// Cell size (m).
pub const MAP_CELL_M: f64 = 0.05;
/// A ray clears up to this many cells short of its end: the end cell's
/// neighbours may hold the same surface, seen at a grazing angle.
pub const CLEAR_SHORT_CELLS: i64 = 2;
/// Never seen.
const NEVER: f64 = f64::NEG_INFINITY;
/// A cell last hit by a slowly moving track counts as occupied this long (s):
/// a person standing or shuffling is planned round where they are, and
/// leaves no trail.
pub const TRANSIENT_S: f64 = 2.0;

/// What the map knows of a cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CellState {
    /// Seen free within the memory.
    Free,
    /// Seen occupied within the memory, and not seen free since.
    Occupied,
    /// Never seen, or not within the memory.
    Unknown,
}

/// The map: per cell, when it was last seen occupied and last seen free.
#[derive(Debug, Clone, Default)]
pub struct LocalMap {
    side: usize,
    /// Integer cell coordinates (tracking frame) of the window's cell (0, 0).
    origin: (i64, i64),
    hit_s: Vec<f64>,
    free_s: Vec<f64>,
    /// Per cell: its last hit was a slowly moving track's (1.0) or not (0.0).
    transient: Vec<f64>,
    /// Scratch for moving the window.
    scratch: Vec<f64>,
    placed: bool,
}

/// Cell coordinates are kept within ± this (50 000 km): a pose or a point
/// far beyond any map (garbage odometry) cannot overflow the arithmetic on
/// them; it lands outside the window.
const CELL_LIMIT: f64 = 1e9;

/// The integer cell of a point (tracking frame); NaN gives cell 0.
pub fn cell_coords(p: Vec2) -> (i64, i64) {
    let c = |v: f64| (v / MAP_CELL_M).round().clamp(-CELL_LIMIT, CELL_LIMIT) as i64;
    (c(p.x), c(p.y))
}

impl LocalMap {
    /// A map `window_m` wide (rounded up to whole cells, at least 8).
    pub fn new(window_m: f64) -> Self {
        let side = ((window_m / MAP_CELL_M).ceil() as usize).max(8);
        Self {
            side,
            origin: (0, 0),
            hit_s: vec![NEVER; side * side],
            free_s: vec![NEVER; side * side],
            transient: vec![0.0; side * side],
            scratch: Vec::new(),
            placed: false,
        }
    }

    /// Cells per side.
    pub fn side(&self) -> usize {
        self.side
    }

    /// The window's lower-left cell centre (tracking frame, m).
    pub fn origin_m(&self) -> Vec2 {
        Vec2::new(self.origin.0 as f64 * MAP_CELL_M, self.origin.1 as f64 * MAP_CELL_M)
    }

    /// Forgets everything (a new tracking frame, a reset).
    pub fn clear(&mut self) {
        self.hit_s.fill(NEVER);
        self.free_s.fill(NEVER);
        self.transient.fill(0.0);
        self.placed = false;
    }

    /// The window index of integer cell `c`, if inside.
    pub fn index(&self, c: (i64, i64)) -> Option<usize> {
        let (i, j) = (c.0 - self.origin.0, c.1 - self.origin.1);
        let n = self.side as i64;
        (i >= 0 && j >= 0 && i < n && j < n).then(|| (j * n + i) as usize)
    }

    /// The centre of window cell `k` (tracking frame, m).
    pub fn centre(&self, k: usize) -> Vec2 {
        let (i, j) = ((k % self.side) as i64, (k / self.side) as i64);
        Vec2::new(
            (i + self.origin.0) as f64 * MAP_CELL_M,
            (j + self.origin.1) as f64 * MAP_CELL_M,
        )
    }

    /// What the map knows of window cell `k` at `now_s`, remembering `memory_s`.
    pub fn state(&self, k: usize, now_s: f64, memory_s: f64) -> CellState {
        let (hit, free) = (self.hit_s[k], self.free_s[k]);
        let memory_s = if self.transient[k] > 0.0 {
            memory_s.min(TRANSIENT_S)
        } else {
            memory_s
        };
        if hit > free && now_s - hit <= memory_s {
            CellState::Occupied
        } else if free >= hit && now_s - free <= memory_s {
            CellState::Free
        } else {
            CellState::Unknown
        }
    }

    /// What the map knows of the cell holding `p` (outside the window: unknown).
    pub fn state_at(&self, p: Vec2, now_s: f64, memory_s: f64) -> CellState {
        self.index(cell_coords(p))
            .map_or(CellState::Unknown, |k| self.state(k, now_s, memory_s))
    }

    /// Where a scan taken at `pose` and `stamp_s` is drawn from: the robot's
    /// cell and the robot-to-map transform, with the window moved to follow
    /// the robot; `None` (nothing to draw) for a non-finite pose or stamp.
    fn scan_frame(&mut self, pose: Pose2, stamp_s: f64) -> Option<((i64, i64), FrameMap)> {
        if !pose.is_finite() || !stamp_s.is_finite() {
            return None;
        }
        self.follow(pose.position());
        Some((cell_coords(pose.position()), pose.frame_map()))
    }

    /// Moves the window so `centre` is in its middle once it is more than a
    /// quarter of the window from it (or on the first scan).
    fn follow(&mut self, centre: Vec2) {
        let n = self.side as i64;
        let c = cell_coords(centre);
        let wanted = (c.0 - n / 2, c.1 - n / 2);
        let off = (wanted.0 - self.origin.0, wanted.1 - self.origin.1);
        if self.placed && off.0.abs() <= n / 4 && off.1.abs() <= n / 4 {
            return;
        }
        if !self.placed {
            self.origin = wanted;
            self.placed = true;
            return;
        }
        for (layer, empty) in [
            (&mut self.hit_s, NEVER),
            (&mut self.free_s, NEVER),
            (&mut self.transient, 0.0),
        ] {
            self.scratch.clear();
            self.scratch.resize(layer.len(), empty);
            for j in 0..n {
                let sj = j + off.1;
                if !(0..n).contains(&sj) {
                    continue;
                }
                for i in 0..n {
                    let si = i + off.0;
                    if (0..n).contains(&si) {
                        self.scratch[(j * n + i) as usize] = layer[(sj * n + si) as usize];
                    }
                }
            }
            std::mem::swap(layer, &mut self.scratch);
        }
        self.origin = wanted;
    }

    /// Takes a scan's `points` (robot frame at `pose`, m; the scan less its
    /// movers) seen at `stamp_s`: rays from the robot's centre clear what
    /// they cross, their ends are occupied. Rays are cleared only within
    /// `clear_range_m`; non-finite points are skipped.
    pub fn insert(&mut self, pose: Pose2, points: &[Vec2], stamp_s: f64, clear_range_m: f64) {
        let Some((from, map)) = self.scan_frame(pose, stamp_s) else {
            return;
        };
        for q in points.iter().filter(|q| q.x.is_finite() && q.y.is_finite()) {
            let w = map.point(*q);
            let to = cell_coords(w);
            let len = q.norm();
            let clear_to = if len > clear_range_m {
                // Clear only the first clear_range_m of a long ray.
                cell_coords(pose.position() + (w - pose.position()) * (clear_range_m / len))
            } else {
                to
            };
            self.clear_ray(from, clear_to, to, stamp_s);
        }
        for q in points.iter().filter(|q| q.x.is_finite() && q.y.is_finite()) {
            if let Some(k) = self.index(cell_coords(map.point(*q))) {
                self.hit_s[k] = stamp_s;
                self.transient[k] = 0.0;
            }
        }
    }

    /// Marks the cells of `points` (robot frame at `pose`, m; a slowly
    /// moving track's) occupied at `stamp_s` for [`TRANSIENT_S`] only. Rays
    /// are not cleared (the same scan's [`Self::insert`] does that). A cell
    /// a static point hit in this scan stays static.
    pub fn insert_transient(&mut self, pose: Pose2, points: &[Vec2], stamp_s: f64) {
        if !pose.is_finite() || !stamp_s.is_finite() {
            return;
        }
        let map = pose.frame_map();
        for q in points.iter().filter(|q| q.x.is_finite() && q.y.is_finite()) {
            if let Some(k) = self.index(cell_coords(map.point(*q))) {
                if self.hit_s[k] != stamp_s {
                    self.hit_s[k] = stamp_s;
                    self.transient[k] = 1.0;
                }
            }
        }
    }

    /// Clears the rays from the robot at `pose` to `ends` (robot frame, m;
    /// beams that saw nothing in range, so what they cross is free up to
    /// their end), within `clear_range_m`, at `stamp_s`. Marks nothing
    /// occupied. Call before [`Self::insert`] of the same scan's points (a
    /// hit in a cell these rays cross reads free all the same: a tie).
    pub fn clear_open(&mut self, pose: Pose2, ends: &[Vec2], stamp_s: f64, clear_range_m: f64) {
        let Some((from, map)) = self.scan_frame(pose, stamp_s) else {
            return;
        };
        for q in ends.iter().filter(|q| q.x.is_finite() && q.y.is_finite()) {
            let len = q.norm().max(1e-9);
            let (q, len) = if len > clear_range_m {
                (q * (clear_range_m / len), clear_range_m)
            } else {
                (*q, len)
            };
            let to = cell_coords(map.point(q));
            // The ray's end is no surface: clear up to it (a cell beyond it is the "end").
            let beyond = cell_coords(map.point(q * (1.0 + (CLEAR_SHORT_CELLS as f64 + 1.0) * MAP_CELL_M / len)));
            self.clear_ray(from, to, beyond, stamp_s);
        }
    }

    /// Marks free the cells of the line from `a` to `b` (Bresenham), but not
    /// those within [`CLEAR_SHORT_CELLS`] of the ray's end `end`, nor cells
    /// hit in this same scan.
    fn clear_ray(&mut self, a: (i64, i64), b: (i64, i64), end: (i64, i64), stamp_s: f64) {
        let (dx, dy) = ((b.0 - a.0).abs(), -(b.1 - a.1).abs());
        // No ray is longer than the window: a longer one comes of garbage (a point at
        // infinity seen from a pose far away) and clears nothing.
        if dx.max(-dy) > 2 * self.side as i64 {
            return;
        }
        let (sx, sy) = ((b.0 - a.0).signum(), (b.1 - a.1).signum());
        let (mut x, mut y, mut err) = (a.0, a.1, dx + dy);
        loop {
            if (x - end.0).abs().max((y - end.1).abs()) <= CLEAR_SHORT_CELLS {
                break;
            }
            if let Some(k) = self.index((x, y)) {
                if self.hit_s[k] != stamp_s {
                    self.free_s[k] = stamp_s;
                }
            }
            if (x, y) == b {
                break;
            }
            let e2 = 2 * err;
            if e2 >= dy {
                err += dy;
                x += sx;
            }
            if e2 <= dx {
                err += dx;
                y += sy;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(x: f64, y: f64) -> Pose2 {
        Pose2::new(x, y, 0.0)
    }

    #[test]
    fn a_ray_clears_its_way_marks_its_end_and_leaves_the_rest_unknown() {
        let mut m = LocalMap::new(4.0);
        // One point 1 m ahead of a robot at the origin.
        m.insert(at(0.0, 0.0), &[Vec2::new(1.0, 0.0)], 10.0, 5.0);
        let s = |x: f64, y: f64, now: f64| m.state_at(Vec2::new(x, y), now, 5.0);
        assert_eq!(s(1.0, 0.0, 10.0), CellState::Occupied);
        // Cleared up to 2 cells (0.1 m) short of the end.
        assert_eq!(s(0.5, 0.0, 10.0), CellState::Free);
        assert_eq!(s(0.85, 0.0, 10.0), CellState::Free);
        assert_eq!(s(0.9, 0.0, 10.0), CellState::Unknown);
        // Off the ray: never seen.
        assert_eq!(s(0.5, 0.5, 10.0), CellState::Unknown);
        // Remembered for memory_s, then forgotten.
        assert_eq!(s(1.0, 0.0, 15.0), CellState::Occupied);
        assert_eq!(s(1.0, 0.0, 15.1), CellState::Unknown);
        assert_eq!(s(0.5, 0.0, 15.1), CellState::Unknown);
    }

    #[test]
    fn what_went_away_is_cleared_by_the_next_ray_through_it() {
        let mut m = LocalMap::new(4.0);
        m.insert(at(0.0, 0.0), &[Vec2::new(1.0, 0.0)], 1.0, 5.0);
        // The obstacle gone: the next scan sees 1.5 m along the same beam.
        m.insert(at(0.0, 0.0), &[Vec2::new(1.5, 0.0)], 1.1, 5.0);
        assert_eq!(m.state_at(Vec2::new(1.0, 0.0), 1.1, 5.0), CellState::Free);
        assert_eq!(m.state_at(Vec2::new(1.5, 0.0), 1.1, 5.0), CellState::Occupied);
    }

    #[test]
    fn the_window_follows_the_robot_and_keeps_what_it_knew() {
        let mut m = LocalMap::new(4.0); // 80 cells: moves once 1 m (20 cells) off centre
        m.insert(at(0.0, 0.0), &[Vec2::new(0.0, 1.0)], 1.0, 5.0);
        let before = m.origin_m();
        m.insert(at(0.9, 0.0), &[], 1.1, 5.0);
        assert_eq!(m.origin_m(), before, "within a quarter: not moved");
        m.insert(at(1.2, 0.0), &[], 1.2, 5.0);
        assert!((m.origin_m().x - (before.x + 1.2)).abs() < 1e-9, "{:?}", m.origin_m());
        // The wall point seen from the first pose is still there, in the tracking frame.
        assert_eq!(m.state_at(Vec2::new(0.0, 1.0), 1.2, 5.0), CellState::Occupied);
        // A point that left the window is unknown.
        m.insert(at(3.0, 0.0), &[], 1.3, 5.0);
        assert_eq!(m.state_at(Vec2::new(0.0, 1.0), 1.3, 5.0), CellState::Unknown);
    }

    #[test]
    fn a_rotated_pose_puts_points_in_the_tracking_frame_and_garbage_is_ignored() {
        let mut m = LocalMap::new(4.0);
        let pose = Pose2::new(0.5, 0.0, std::f64::consts::FRAC_PI_2);
        m.insert(pose, &[Vec2::new(1.0, 0.0), Vec2::new(f64::NAN, 1.0)], 1.0, 5.0);
        assert_eq!(m.state_at(Vec2::new(0.5, 1.0), 1.0, 5.0), CellState::Occupied);
        m.insert(Pose2::new(f64::NAN, 0.0, 0.0), &[Vec2::new(1.0, 0.0)], 2.0, 5.0);
        assert_eq!(m.state_at(Vec2::new(0.5, 1.0), 2.0, 5.0), CellState::Occupied);
    }

    #[test]
    fn a_beam_that_saw_nothing_clears_a_trail_to_its_end() {
        let mut m = LocalMap::new(8.0);
        // Someone stood 1 m ahead, then walked off: the beam now sees nothing in 3.5 m.
        m.insert(at(0.0, 0.0), &[Vec2::new(1.0, 0.0)], 1.0, 5.0);
        m.clear_open(at(0.0, 0.0), &[Vec2::new(3.5, 0.0)], 1.1, 5.0);
        let s = |x: f64| m.state_at(Vec2::new(x, 0.0), 1.1, 5.0);
        assert_eq!(
            (s(1.0), s(3.4), s(3.5)),
            (CellState::Free, CellState::Free, CellState::Free)
        );
        assert_eq!(s(3.6), CellState::Unknown, "nothing beyond the range");
        // Cleared only within the clearing range.
        m.clear_open(at(0.0, 0.0), &[Vec2::new(0.0, 3.5)], 1.2, 2.0);
        let s = |y: f64| m.state_at(Vec2::new(0.0, y), 1.2, 5.0);
        assert_eq!((s(2.0), s(2.2)), (CellState::Free, CellState::Unknown));
    }

    #[test]
    fn a_slow_mover_is_occupied_where_it_is_and_leaves_no_trail() {
        let mut m = LocalMap::new(4.0);
        m.insert_transient(at(0.0, 0.0), &[Vec2::new(1.0, 0.5)], 1.0);
        let s = |now: f64| m.state_at(Vec2::new(1.0, 0.5), now, 30.0);
        assert_eq!((s(1.0), s(3.0)), (CellState::Occupied, CellState::Occupied));
        assert_eq!(s(3.1), CellState::Unknown, "forgotten after TRANSIENT_S, not memory_s");
        // A static hit on the same cell later is remembered for memory_s.
        m.insert(at(0.0, 0.0), &[Vec2::new(1.0, 0.5)], 4.0, 5.0);
        assert_eq!(m.state_at(Vec2::new(1.0, 0.5), 30.0, 30.0), CellState::Occupied);
    }

    #[test]
    fn a_pose_or_point_far_beyond_any_map_is_no_panic() {
        // Finite garbage (odometry gone wild, a fuzzer's pose): no overflow, nothing marked
        // inside the window, and the map goes on working where the robot really is.
        let mut m = LocalMap::new(4.0);
        for p in [Pose2::new(1e300, -1e300, 0.0), Pose2::new(-4e18, 4e18, 1.0)] {
            m.insert(
                p,
                &[Vec2::new(1.0, 0.0), Vec2::new(-1e308, 1e308), Vec2::new(1e308, 1e308)],
                1.0,
                5.0,
            );
            m.clear_open(p, &[Vec2::new(3.5, 0.0)], 1.0, 5.0);
            m.insert_transient(p, &[Vec2::new(1e308, 0.0)], 1.0);
        }
        m.insert(at(0.0, 0.0), &[Vec2::new(1.0, 0.0), Vec2::new(1e308, 0.0)], 2.0, 5.0);
        assert_eq!(m.state_at(Vec2::new(1.0, 0.0), 2.0, 5.0), CellState::Occupied);
        assert_eq!(m.state_at(Vec2::new(0.5, 0.0), 2.0, 5.0), CellState::Free);
    }
}
