//! What recent scans saw through (ALGORITHM.md §6): proof that a tracked
//! object moves, which no view change of a static one can fake.
//!
//! A static object's surface is never seen through: any ray that reaches a
//! point of it, from wherever the robot was, ends at that point or at
//! something nearer. The part of a post or a box that comes into view as the
//! robot drives by was hidden or out of reach before, not seen free; its
//! centroid slides by up to its size, which the filter reads as motion, but
//! its points are where no earlier ray went past. A person who walks into
//! view, across the background or towards the robot, stands where an earlier
//! ray went on beyond: that is motion.
//!
//! A few snapshots of past scans are kept, taken at least
//! [`SNAPSHOT_SPACING_S`] apart (the last [`SNAPSHOTS`], about eight
//! seconds: a person drifting at 0.03 m/s stands clear of where they were
//! within a few; one walking comes where older snapshots saw free at once):
//! per beam, how far it saw free (the range of its hit; `range_max` when it
//! saw nothing in range; 0 when it said nothing usable: unknown is not free).
//! A point *was seen free* by a snapshot when the beam through it and its
//! [`NEIGHBOURS`] on either side went on more than [`SEEN_THROUGH_M`] beyond
//! it: near an object's silhouette the nearest beams pass beside it, and a
//! beam may drop out and read "nothing in range". A proof of motion asks for
//! two snapshots that saw a point free (one could have dropped out just there).
//!
//! All buffers are reused: no allocation in steady state.

use super::geometry::{wrap_angle, FrameMap, Pose2, Vec2};
use super::scan::{BeamStatus, ScanPoints};

/// Snapshots kept.
pub const SNAPSHOTS: usize = 8;
/// The least time between two snapshots (s).
pub const SNAPSHOT_SPACING_S: f64 = 1.0;
/// How far beyond a point a beam must have seen free for the point to have
/// been seen through (m): beyond range noise (a few cm) and odometry's
/// error over a few metres, within what a person drifting at 0.03 m/s covers
/// in a few seconds.
pub const SEEN_THROUGH_M: f64 = 0.08;
/// Beams on either side of the one through a point that must have seen
/// beyond it too.
pub const NEIGHBOURS: i64 = 2;

/// One past scan: where the robot was and how far each beam saw free.
#[derive(Debug, Clone, Default)]
struct Snapshot {
    stamp_s: f64,
    /// The robot's pose in the tracking frame, mapped.
    robot: FrameMap,
    /// The sensor's origin in the robot frame.
    origin: Vec2,
    /// Bearing of beam 0 in the robot frame, and the signed step between beams (rad).
    first_rad: f64,
    step_rad: f64,
    full_circle: bool,
    /// Per beam: how far it saw free (m).
    free_m: Vec<f32>,
}

/// The snapshots.
#[derive(Debug, Clone, Default)]
pub struct SeenFree {
    /// [`SNAPSHOTS`] slots, the first `used` of them filled.
    snaps: Vec<Snapshot>,
    used: usize,
    /// The next slot to fill once all are in use.
    next: usize,
    last_stamp_s: Option<f64>,
}

impl SeenFree {
    /// Room for [`SNAPSHOTS`] scans of `beams` beams: no allocation after.
    pub fn with_capacity(beams: usize) -> Self {
        Self {
            snaps: (0..SNAPSHOTS)
                .map(|_| Snapshot {
                    free_m: Vec::with_capacity(beams),
                    ..Snapshot::default()
                })
                .collect(),
            used: 0,
            next: 0,
            last_stamp_s: None,
        }
    }

    /// Forgets every snapshot (the tracking frame changed).
    pub fn reset(&mut self) {
        self.used = 0;
        self.next = 0;
        self.last_stamp_s = None;
    }

    /// Keeps the scan whose points are `points` (robot frame, with the sensor
    /// at `origin`), taken at `stamp_s` with the robot at `pose` (tracking
    /// frame), if the last snapshot is [`SNAPSHOT_SPACING_S`] old or more.
    pub fn record(
        &mut self,
        points: &ScanPoints,
        origin: Vec2,
        pose: Pose2,
        stamp_s: f64,
        range_max_m: f64,
        full_circle: bool,
    ) {
        if self
            .last_stamp_s
            .is_some_and(|t| stamp_s - t < SNAPSHOT_SPACING_S && stamp_s >= t)
        {
            return;
        }
        let (Some(d0), Some(d1)) = (points.beam_direction(0), points.beam_direction(1)) else {
            return;
        };
        if points.status.len() != points.beams {
            return;
        }
        if self.snaps.len() < SNAPSHOTS {
            self.snaps.resize_with(SNAPSHOTS, Snapshot::default);
        }
        // A scan with more beams than any before grows every slot at once: none later.
        let n = points.status.len();
        if self.snaps.iter().any(|s| s.free_m.capacity() < n) {
            for s in &mut self.snaps {
                s.free_m.reserve(n);
            }
        }
        self.last_stamp_s = Some(stamp_s);
        let slot = if self.used < SNAPSHOTS {
            self.used += 1;
            self.used - 1
        } else {
            let s = self.next;
            self.next = (self.next + 1) % SNAPSHOTS;
            s
        };
        let s = &mut self.snaps[slot];
        s.stamp_s = stamp_s;
        s.robot = pose.frame_map();
        s.origin = origin;
        s.first_rad = d0.y.atan2(d0.x);
        s.step_rad = wrap_angle(d1.y.atan2(d1.x) - s.first_rad);
        s.full_circle = full_circle;
        s.free_m.clear();
        s.free_m.extend(points.status.iter().map(|st| match st {
            BeamStatus::Free => range_max_m as f32,
            _ => 0.0,
        }));
        for (q, &b) in points.points.iter().zip(&points.beam_index) {
            let b = b as usize;
            if points.status.get(b) == Some(&BeamStatus::Valid) {
                s.free_m[b] = (*q - origin).norm() as f32;
            }
        }
    }

    /// How many snapshots older than `now_s` saw through `q` (tracking
    /// frame, m): the beam through it and its [`NEIGHBOURS`] on either side
    /// went on more than [`SEEN_THROUGH_M`] beyond it. The pipeline asks
    /// [`Self::add_to`]; this is each point alone, for the tests.
    #[cfg(test)]
    pub fn seen_through(&self, q: Vec2, now_s: f64) -> usize {
        self.snaps[..self.used]
            .iter()
            .filter(|s| s.stamp_s < now_s && s.through_bearing(q).is_some())
            .count()
    }

    /// Adds the point `q` (tracking frame, m) of one object to `spread`: for
    /// each snapshot older than `now_s` that saw through it, where it lay in
    /// that snapshot's view.
    pub fn add_to(&self, spread: &mut Spread, q: Vec2, now_s: f64) {
        for (k, s) in self.snaps[..self.used].iter().enumerate() {
            if s.stamp_s >= now_s {
                continue;
            }
            if let Some(b) = s.through_bearing(q) {
                spread.add(k, b, s.step_rad.abs());
            }
        }
    }
}

/// Where the points of one object that snapshots saw through lay in each
/// snapshot's view: fixed-size, no allocation.
///
/// A snapshot proves that the object was not there only if the points it saw
/// through spread over at least one step between its beams. Every beam that
/// falls inside the angle a static surface spans ends on it (or on something
/// nearer); so a static surface whose points all lie where beams went on
/// beyond spans less than one step in that view: a thin wall seen end-on, a
/// pole narrower than the beams' spacing. Seen later from the side, its
/// points stand where that snapshot saw free, but all within one step.
#[derive(Debug, Clone, Copy, Default)]
pub struct Spread {
    /// Per snapshot: the first such point's bearing, then the least and the
    /// greatest offset from it of any (rad), and the step between beams (rad);
    /// `step_rad` 0 when none.
    first_rad: [f64; SNAPSHOTS],
    lo_rad: [f64; SNAPSHOTS],
    hi_rad: [f64; SNAPSHOTS],
    step_rad: [f64; SNAPSHOTS],
}

impl Spread {
    fn add(&mut self, k: usize, bearing_rad: f64, step_rad: f64) {
        if self.step_rad[k] == 0.0 {
            self.first_rad[k] = bearing_rad;
            self.step_rad[k] = step_rad;
            return;
        }
        let off = wrap_angle(bearing_rad - self.first_rad[k]);
        self.lo_rad[k] = self.lo_rad[k].min(off);
        self.hi_rad[k] = self.hi_rad[k].max(off);
    }

    /// Snapshots whose seen-through points spread over one step between
    /// beams or more: each proves the object stands where it saw free.
    pub fn snapshots_through(&self) -> usize {
        (0..SNAPSHOTS)
            .filter(|&k| self.step_rad[k] > 0.0 && self.hi_rad[k] - self.lo_rad[k] >= self.step_rad[k])
            .count()
    }
}

impl Snapshot {
    /// `q`'s bearing in this snapshot's robot frame (rad) if the beam
    /// through it and its [`NEIGHBOURS`] all went on more than
    /// [`SEEN_THROUGH_M`] beyond it.
    fn through_bearing(&self, q: Vec2) -> Option<f64> {
        let n = self.free_m.len() as i64;
        if n < 3 || self.step_rad == 0.0 {
            return None;
        }
        let rel = self.robot.inverse_point(q) - self.origin;
        let d = rel.norm();
        let bearing = rel.y.atan2(rel.x);
        let beam = (wrap_angle(bearing - self.first_rad) / self.step_rad).round() as i64;
        let beyond = (d + SEEN_THROUGH_M) as f32;
        (beam - NEIGHBOURS..=beam + NEIGHBOURS)
            .all(|j| {
                let j = if self.full_circle { j.rem_euclid(n) } else { j };
                (0..n).contains(&j) && self.free_m[j as usize] > beyond
            })
            .then_some(bearing)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algo::beam_memory::BeamMemory;
    use crate::algo::params::LaserParams;
    use crate::algo::scan::{sanitize_scan, LaserMount, LaserScan, ScanHeader};

    /// A full-circle scan of 360 beams from the robot at `pose` (sensor at the
    /// robot's centre) of a world of discs (centre, radius), world frame.
    fn scan_of(pose: Pose2, discs: &[(Vec2, f64)], range_max: f64) -> ScanPoints {
        let map = pose.frame_map();
        let ranges: Vec<f32> = (0..360)
            .map(|i| {
                let a = (i as f64).to_radians() - std::f64::consts::PI;
                let dir = Vec2::new(a.cos(), a.sin());
                let mut best = f64::INFINITY;
                for &(c, r) in discs {
                    // Ray from the robot: |o + t dir − c| = r.
                    let oc = map.inverse_point(c);
                    let b = oc.dot(&dir);
                    let disc = b * b - oc.norm_squared() + r * r;
                    if disc >= 0.0 {
                        let t = b - disc.sqrt();
                        if t > 0.0 {
                            best = best.min(t);
                        }
                    }
                }
                if best <= range_max {
                    best as f32
                } else {
                    f32::INFINITY
                }
            })
            .collect();
        let scan = LaserScan {
            header: ScanHeader {
                stamp_s: 10.0,
                angle_min_rad: -std::f32::consts::PI,
                angle_increment_rad: 1f32.to_radians(),
                range_min_m: 0.1,
                range_max_m: range_max as f32,
            },
            ranges_m: &ranges,
            intensities: &[],
        };
        let mut out = ScanPoints::default();
        let mut memory = BeamMemory::with_capacity(360);
        memory.begin_scan(360, Pose2::default(), 10.0);
        let mount = LaserMount::upright(Pose2::default());
        sanitize_scan(&scan, 10.0, &LaserParams::default(), &mount, &mut out, &mut memory).unwrap();
        out
    }

    #[test]
    fn a_post_seen_from_a_moving_robot_is_never_seen_through() {
        // A post of radius 0.1 m at (2, 1); the robot drives by along the x axis
        // from x = 0 to 4 at 0.2 m/s. No point of the post, at any scan, was seen
        // through by an earlier one.
        let post = (Vec2::new(2.0, 1.0), 0.1);
        let mut seen = SeenFree::with_capacity(360);
        for k in 0..200 {
            let t = 0.1 * k as f64;
            let pose = Pose2::new(0.02 * k as f64, 0.0, 0.0);
            let pts = scan_of(pose, &[post], 3.5);
            let map = pose.frame_map();
            for q in &pts.points {
                assert_eq!(seen.seen_through(map.point(*q), t), 0, "scan {k}: {q:?}");
            }
            seen.record(&pts, Vec2::zeros(), pose, t, 3.5, true);
        }
    }

    #[test]
    fn a_person_walking_into_view_was_seen_through() {
        // A person (radius 0.2 m) crossing 2 m ahead at 0.5 m/s, a wall 3 m ahead
        // behind them; the robot rests.
        let mut seen = SeenFree::with_capacity(360);
        let wall: Vec<(Vec2, f64)> = (-30..=30).map(|k| (Vec2::new(3.2, 0.1 * f64::from(k)), 0.2)).collect();
        let mut first = None;
        for k in 0..25 {
            let t = 0.1 * k as f64;
            let person = (Vec2::new(2.0, -1.0 + 0.05 * k as f64), 0.2);
            let mut world = wall.clone();
            world.push(person);
            let pts = scan_of(Pose2::default(), &world, 3.5);
            let on_person = pts.points.iter().filter(|q| (**q - person.0).norm() < 0.25);
            let mut spread = Spread::default();
            for q in on_person {
                seen.add_to(&mut spread, *q, t);
            }
            if first.is_none() && spread.snapshots_through() >= 2 {
                first = Some(k);
            }
            seen.record(&pts, Vec2::zeros(), Pose2::default(), t, 3.5, true);
        }
        // Snapshots at scans 0 and 10. Two of them must have seen the point free on
        // five beams (±2°, ±7 cm at 2 m) to the wall 1.2 m beyond: by scan 13-15
        // the leading edge stands 0.15-0.25 m clear of where it was at scan 10.
        assert!(matches!(first, Some(13..=15)), "{first:?}");
    }

    #[test]
    fn a_thin_wall_seen_end_on_then_from_the_side_is_not_proven_to_move() {
        // A wall 1 cm thick from 2 to 3 m along the bearing 0.5°, between the
        // beams at 0° and 1° (1° apart) seen from the origin: each of those
        // beams and their neighbours misses it (it spans 0.5° ± 0.14°). The robot
        // rests at the origin for snapshots at 0, 1 and 2 s, then sees the wall
        // broadside from (2.5, −1.5). Its points stand where three snapshots saw
        // free, yet in their view they spread over less than one step between
        // beams: no proof.
        let dir = Vec2::new(0.5f64.to_radians().cos(), 0.5f64.to_radians().sin());
        let wall: Vec<(Vec2, f64)> = (0..=100).map(|k| (dir * (2.0 + 0.01 * f64::from(k)), 0.005)).collect();
        let mut seen = SeenFree::with_capacity(360);
        for k in 0..25 {
            let pts = scan_of(Pose2::default(), &wall, 3.5);
            seen.record(&pts, Vec2::zeros(), Pose2::default(), 0.1 * k as f64, 3.5, true);
        }
        let side = Pose2::new(2.5, -1.5, std::f64::consts::FRAC_PI_2);
        let pts = scan_of(side, &wall, 3.5);
        let map = side.frame_map();
        let on_wall: Vec<Vec2> = pts.points.iter().map(|q| map.point(*q)).collect();
        assert!(on_wall.len() > 20, "{}", on_wall.len());
        // Each point, alone, was seen through by all three snapshots…
        let through = on_wall.iter().filter(|q| seen.seen_through(**q, 3.0) == 3).count();
        assert!(through > 20, "{through}");
        // …but together they span less than a step in each: no snapshot counts.
        let mut spread = Spread::default();
        for q in &on_wall {
            seen.add_to(&mut spread, *q, 3.0);
        }
        assert_eq!(spread.snapshots_through(), 0);
    }

    #[test]
    fn snapshots_are_spaced_and_unknown_is_not_free() {
        let mut seen = SeenFree::with_capacity(360);
        let pts = scan_of(Pose2::default(), &[], 3.5); // nothing in range: all free to 3.5 m
        for k in 0..10 {
            seen.record(&pts, Vec2::zeros(), Pose2::default(), 0.1 * k as f64, 3.5, true);
        }
        assert_eq!(seen.used, 1);
        // 0.0 and 1.0 s (1 s apart at least).
        for k in 10..30 {
            seen.record(&pts, Vec2::zeros(), Pose2::default(), 0.1 * k as f64, 3.5, true);
        }
        assert_eq!(seen.used, 3);
        assert_eq!(seen.seen_through(Vec2::new(1.0, 0.0), 3.0), 3);
        // Beyond range_max less the margin: not seen free.
        assert_eq!(seen.seen_through(Vec2::new(3.45, 0.0), 3.0), 0);
        // Not by a snapshot of the same instant.
        let mut fresh = SeenFree::with_capacity(360);
        fresh.record(&pts, Vec2::zeros(), Pose2::default(), 1.0, 3.5, true);
        assert_eq!(fresh.seen_through(Vec2::new(1.0, 0.0), 1.0), 0);
    }
}
