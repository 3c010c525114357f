//! Perception, once per scan, and its prediction to each tick (ALGORITHM
//! §1, §6, §5c "every command sees the last scan's whole perception").
//!
//! [`SafetyPipeline::perceive`] turns a new scan into points, beam memory,
//! the blind verdict, clusters and tracks. A tick, with or without a new
//! scan, then [`SafetyPipeline::advance_to`]s that perception to its own
//! time: static points are re-expressed in the robot frame of the tick (the
//! robot has moved since the scan: odometry, or dead reckoning from the
//! commands sent), and the points of moving tracks are carried along their
//! tracks' velocities. So a command computed on an upstream command between
//! two scans sees the movers where they are predicted to be, not nowhere.

use super::{SafetyPipeline, REAR_HALF_ANGLE_RAD};
use crate::algo::clusters::{Cluster, BRIDGED_BEAMS};
use crate::algo::geometry::{FrameMap, Pose2, Vec2};
use crate::algo::obstacle_tracker::ObstacleTracker;
use crate::algo::params::RangeSemantics;
use crate::algo::record::StopCause;
use crate::algo::scan::{check_scan, fill_points, BeamStatus, LaserScan};
use crate::algo::seen_free::Spread;
use crate::algo::unicycle::arc_step;

/// What the last scan gave the pipeline.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Perceived {
    /// No scan yet (or none since a reset of the clock).
    Nothing,
    /// The last scan was rejected, or its sensor is blind: every tick stops for this.
    Unusable(StopCause),
    /// A usable scan's perception, expressed as of `frame`.
    Usable(Frame),
}

/// A usable scan's perception and the robot pose and time it is expressed at.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Frame {
    /// The scan's stamp (s).
    pub stamp_s: f64,
    /// Whether the robot pose came from odometry (else dead reckoning).
    pub odom: bool,
    /// The robot pose (tracking frame) the points are expressed in now, and when (s).
    pub pose: Pose2,
    pub at_s: f64,
    /// Unknown fraction of the front sector watched for blindness.
    pub unknown_front_fraction: f64,
    /// The scan covers the rear (reversing allowed).
    pub rear_seen: bool,
    /// The scan covers a full turn.
    pub full_circle: bool,
    /// No tick has used this scan yet.
    pub fresh: bool,
}

impl SafetyPipeline {
    /// Takes a new scan: points (REP 117, beam memory), the blind verdict,
    /// clusters and tracks, at the robot's pose at the scan's stamp
    /// (`odom_pose`, else dead-reckoned). A rejected scan, or a blind sensor,
    /// makes every following tick stop with that cause until a usable scan
    /// arrives; `now_s` only ages the stamp.
    pub fn perceive(&mut self, scan: &LaserScan<'_>, now_s: f64, odom_pose: Option<Pose2>) {
        if let Err(reason) = check_scan(scan, now_s, &self.params.laser) {
            self.points.clear();
            self.perceived = Perceived::Unusable(StopCause::Rejected(reason));
            return;
        }
        let stamp_s = scan.header.stamp_s;
        let pose = self.ego_pose(stamp_s, odom_pose);
        self.memory.begin_scan(scan.ranges_m.len(), pose, stamp_s);
        fill_points(
            scan,
            &self.params.laser,
            &self.derived.mount,
            &mut self.points,
            &mut self.memory,
            REAR_HALF_ANGLE_RAD,
        );
        let unknown_front_fraction = if self.params.laser.range_semantics == RangeSemantics::Rep117 {
            let verdict = self.blind.update(
                self.points.unknown_front,
                self.points.front_beams,
                stamp_s,
                &self.params.laser,
            );
            self.blind_fraction = verdict.unknown_fraction;
            if verdict.blind {
                self.perceived = Perceived::Unusable(StopCause::SensorBlind);
                return;
            }
            verdict.unknown_fraction
        } else {
            0.0
        };
        let span = (scan.header.angle_increment_rad as f64).abs() * scan.ranges_m.len() as f64;
        let full_circle = span >= 2.0 * std::f64::consts::PI - 1e-3;
        self.track_obstacles(stamp_s, pose, full_circle, scan.header.range_max_m as f64);
        let (sigma_m, plan) = (self.params.laser.range_noise_m, self.params.unstuck.enabled);
        if sigma_m > 0.0 || plan {
            self.mark_movers();
        }
        if sigma_m > 0.0 {
            // After tracking, which sees the raw returns (a track's motion is measured,
            // not smoothed); the returns of moving tracks pass raw.
            let origin = self.derived.mount.pose.position();
            self.beam_average
                .apply(&mut self.points, &self.on_mover, pose, origin, sigma_m);
        } else {
            // Off (it may be switched on again while the node runs): nothing is carried
            // across the time it was off.
            self.beam_average.reset();
        }
        if plan {
            // The map takes the scan less walking people (§4c).
            self.fill_plan_points();
            self.map_scan.stamp_s = stamp_s;
            self.map_scan.pose = pose;
            self.map_scan.points.clear();
            self.map_scan.points.extend_from_slice(&self.plan_points);
            self.map_scan.transient.clear();
            self.map_scan.transient.extend_from_slice(&self.slow_points);
            // Beams that saw nothing in range clear what they cross (REP 117: +inf).
            self.map_scan.open_ends.clear();
            let origin = self.derived.mount.pose.position();
            let range_m = scan.header.range_max_m as f64;
            for (i, st) in self.points.status.iter().enumerate() {
                if *st == BeamStatus::Free {
                    if let Some(d) = self.points.beam_direction(i) {
                        self.map_scan.open_ends.push(origin + d * range_m);
                    }
                }
            }
            if self.route_beside {
                self.map_scan_new = true;
            } else {
                super::timed(self.planner_clock, &mut self.planner_us_total, || {
                    self.way_round.insert(&self.map_scan)
                });
            }
        }
        self.perceived = Perceived::Usable(Frame {
            stamp_s,
            odom: odom_pose.is_some(),
            pose,
            at_s: stamp_s,
            unknown_front_fraction,
            rear_seen: self.rear_seen(scan),
            full_circle,
            fresh: true,
        });
    }

    /// The robot's pose in the tracking frame at `stamp_s`: odometry when
    /// given, else dead-reckoned from the last command sent since the last
    /// scan or tick. When the frame changes (odometry appears or goes), the
    /// tracks and the beam memory, which live in it, are dropped.
    fn ego_pose(&mut self, stamp_s: f64, odom: Option<Pose2>) -> Pose2 {
        let (pose, frame_changed) = match (odom, self.ego) {
            (Some(p), Some((_, true, _))) | (Some(p), None) => (p, false),
            (Some(p), Some((_, false, _))) => (p, true),
            // A scan stamped a little before the last tick is reckoned back to its stamp.
            (None, Some((prev, false, t))) if stamp_s != t => {
                (arc_step(prev, self.last_cmd, (stamp_s - t).clamp(-1.0, 1.0)), false)
            }
            (None, Some((prev, false, _))) => (prev, false),
            (None, Some((_, true, _))) => (Pose2::default(), true),
            (None, None) => (Pose2::default(), false),
        };
        if frame_changed {
            // Old tracks, beam memory, map and route are meaningless in the new frame.
            self.tracker.reset();
            self.seen_free.reset();
            self.memory.reset();
            self.beam_average.reset();
            self.way_round.reset(&self.params);
            self.route = None;
        }
        self.ego = Some((pose, odom.is_some(), stamp_s));
        pose
    }

    /// Clusters of the scan's points and the tracker's update with them.
    /// Excluded from tracking: clusters of mostly held points (held points
    /// are where something was, not measurements, so a mover that steps
    /// inside range_min coasts on its velocity instead of seeming to stop).
    /// Marked partial: clusters that may not be a whole object
    /// ([`open_ended`]): a piece of wall cut off by the range limit or by
    /// something nearer in front of it slides along the wall as the robot
    /// moves, and would be taken for a mover, so it neither starts a track
    /// nor proves one moves; a person half hidden behind another is still
    /// the person, so it keeps that person's track alive.
    fn track_obstacles(&mut self, stamp_s: f64, pose: Pose2, full_circle: bool, range_max_m: f64) {
        self.clusters.clear();
        if !self.params.obstacles.enabled && !self.keep_clusters {
            return;
        }
        self.clusters.build(
            &self.points.points,
            &self.points.beam_index,
            self.points.beams,
            full_circle,
            self.params.obstacles.cluster_gap_m,
        );
        if !self.params.obstacles.enabled {
            return;
        }
        let n_points = self.points.points.len();
        for k in 0..self.clusters.len() {
            let cluster = self.clusters.as_slice()[k];
            let held = cluster
                .indices(n_points)
                .filter(|&i| self.points.status[self.points.beam_index[i] as usize] == BeamStatus::Held)
                .count();
            // The grazing rule is this project's proof of motion; the paper method keeps its own.
            let grazing = self.params.obstacles.motion_by_sight;
            let cut = open_ended(
                &cluster,
                &self.points.points,
                &self.points.beam_index,
                range_max_m,
                grazing,
            );
            if 2 * held >= cluster.len && held > 0 {
                self.clusters.exclude(k);
            } else if cut {
                self.clusters.mark_partial(k);
            }
        }
        self.tracker
            .update(self.clusters.as_slice(), stamp_s, pose, &self.params.obstacles);
        if !self.params.obstacles.motion_by_sight {
            return;
        }
        // Proof of motion (§6): a tracked object standing where earlier scans saw
        // free. A few points spread over the cluster; two snapshots each saw
        // through points of it that spread over one step between their beams
        // or more (what all of a snapshot's beams missed spans less).
        let to_tracking = pose.frame_map();
        for (k, slot) in self.tracker.cluster_track().iter().enumerate() {
            let Some(ti) = *slot else {
                continue;
            };
            if self.tracker.tracks()[ti].motion_proven(&self.params.obstacles) {
                continue;
            }
            let cluster = self.clusters.as_slice()[k];
            let stride = cluster.len.div_ceil(THROUGH_PROBES).max(1);
            let mut spread = Spread::default();
            for i in cluster.indices(n_points).step_by(stride) {
                self.seen_free
                    .add_to(&mut spread, to_tracking.point(self.points.points[i]), stamp_s);
            }
            if spread.snapshots_through() >= 2 {
                self.seen_through.push(ti);
            }
        }
        for ti in self.seen_through.drain(..) {
            self.tracker.note_seen_through(ti);
        }
        let origin = self.derived.mount.pose.position();
        self.seen_free
            .record(&self.points, origin, pose, stamp_s, range_max_m, full_circle);
    }

    /// Whether the scan lets the robot back up: its rear sector is covered
    /// by beams and not mostly unknown.
    fn rear_seen(&self, scan: &LaserScan<'_>) -> bool {
        let pts = &self.points;
        let expected = ((2.0 * REAR_HALF_ANGLE_RAD / (scan.header.angle_increment_rad as f64).abs()).floor() as usize)
            .saturating_sub(1)
            .max(1);
        pts.rear_beams >= expected && 2 * pts.unknown_rear <= pts.rear_beams
    }

    /// Moves the usable perception to time `now_s` and the robot pose then
    /// (`odom_pose` when the perception is in the odometry frame, else dead
    /// reckoning from the last command sent): every point, phantom and
    /// cluster is re-expressed in the robot frame at `now_s`, and those of
    /// moving tracks are carried by their velocity for the time elapsed.
    /// Returns the frame, or `None` when there is no usable perception.
    pub(super) fn advance_to(&mut self, now_s: f64, odom_pose: Option<Pose2>) -> Option<Frame> {
        let Perceived::Usable(mut frame) = self.perceived else {
            return None;
        };
        let elapsed_s = (now_s - frame.at_s).max(0.0);
        let pose = match odom_pose {
            Some(p) if frame.odom => p,
            _ => arc_step(frame.pose, self.last_cmd, elapsed_s.min(1.0)),
        };
        if elapsed_s > 0.0 || pose != frame.pose {
            let (from, to) = (frame.pose.frame_map(), pose.frame_map());
            let re_express = |q: &mut Vec2| *q = to.inverse_point(from.point(*q));
            self.points.points.iter_mut().for_each(re_express);
            self.points.phantoms.iter_mut().for_each(re_express);
            self.clusters.map_points(|q| to.inverse_point(from.point(q)));
            self.carry_movers(elapsed_s, &to);
            frame.pose = pose;
            frame.at_s = now_s;
            self.ego = Some((pose, frame.odom, now_s));
        }
        self.perceived = Perceived::Usable(Frame { fresh: false, ..frame });
        Some(frame)
    }

    /// Carries the points and clusters of moving tracks by their tracked
    /// velocity over `elapsed_s` (robot frame at the pose whose map is `to`).
    fn carry_movers(&mut self, elapsed_s: f64, to: &FrameMap) {
        if elapsed_s <= 0.0 || !self.params.obstacles.enabled {
            return;
        }
        let n = self.points.points.len();
        let o = &self.params.obstacles;
        for (k, track) in self.tracker.cluster_track().iter().enumerate() {
            let Some(track) = track.map(|t| self.tracker.tracks()[t]).filter(|t| t.is_moving(o)) else {
                continue;
            };
            let (_, velocity) = ObstacleTracker::predicted(&track, 0.0, to);
            let shift = velocity * elapsed_s;
            let cluster = self.clusters.as_slice()[k];
            for i in cluster.indices(n) {
                self.points.points[i] += shift;
            }
            self.clusters.shift(k, shift);
        }
    }
}

/// A cluster reaching within this of range_max may go on beyond it (m).
const RANGE_EDGE_M: f64 = 0.25;

/// Points of a tracked cluster (spread over it) tried against the scans'
/// free space for proof of motion.
const THROUGH_PROBES: usize = 6;

/// The next point along a surface seen at a grazing angle lies no farther
/// beyond the cluster's end than this many times the last step within it
/// (successive steps grow by a factor of 1 + 2 δ tan φ at a beam step δ and
/// an angle φ off the surface's normal: 1.3 at 84°)…
const CONTINUE_STEP_RATIO: f64 = 2.5;
/// …and within this angle of that last step's direction (rad): 15°, several
/// times what the range noise turns a step of a cluster's spacing by.
const CONTINUE_ANGLE_RAD: f64 = 0.26;

/// Whether `cluster` (of `points`, robot frame, beam order) may be only part
/// of what it sees: a point of it within [`RANGE_EDGE_M`] of the range limit
/// (the object may go on beyond), a neighbouring beam's point nearer the
/// robot than the cluster's end next to it (something in front hides the
/// rest), or one that goes on along the cluster's end (a wall seen at a
/// grazing angle, whose returns spread beyond the cluster gap: its cluster
/// grows as the robot turns towards it). A whole object, a person or a post,
/// stands in front of what is beside it, and what lies beyond its edge is a
/// jump away, not a step on.
/// The last rule only with `grazing` (this project's proof of motion; the
/// paper method keeps the clusters it had).
fn open_ended(cluster: &Cluster, points: &[Vec2], beam_index: &[u32], range_max_m: f64, grazing: bool) -> bool {
    let n = points.len();
    if cluster.len == 0 || n < 2 {
        return false;
    }
    if cluster
        .indices(n)
        .any(|i| points[i].norm() > range_max_m - RANGE_EDGE_M)
    {
        return true;
    }
    let first = cluster.start;
    let last = (cluster.end + n - 1) % n;
    // A neighbour counts when it is (nearly) the adjacent beam: across a gap of
    // lost returns the view is open.
    let adjacent = |a: usize, b: usize| beam_index[a].abs_diff(beam_index[b]) <= 1 + BRIDGED_BEAMS;
    let hidden_by =
        |end: usize, other: usize| other != end && adjacent(end, other) && points[other].norm() < points[end].norm();
    // `other` continues the surface that reaches `end` from `inner` (the point of
    // the cluster before its end).
    let cos_max = CONTINUE_ANGLE_RAD.cos();
    let goes_on = |end: usize, inner: usize, other: usize| {
        if !grazing || other == end || cluster.len < 2 || !adjacent(end, other) {
            return false;
        }
        let (step, on) = (points[end] - points[inner], points[other] - points[end]);
        let (ls, lo) = (step.norm(), on.norm());
        ls > 0.0 && lo <= CONTINUE_STEP_RATIO * ls && step.dot(&on) >= cos_max * ls * lo
    };
    let (before, after) = ((first + n - 1) % n, (last + 1) % n);
    cluster.len < n
        && (hidden_by(first, before)
            || hidden_by(last, after)
            || goes_on(first, (first + 1) % n, before)
            || goes_on(last, (last + n - 1) % n, after))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algo::clusters::Clusters;

    /// The clusters (gap 0.15 m) of `points` on consecutive beams 0, 1, …
    fn clusters_of(points: &[Vec2]) -> Clusters {
        let idx: Vec<u32> = (0..points.len() as u32).collect();
        let mut c = Clusters::default();
        c.build(points, &idx, 360, false, 0.15);
        c
    }

    #[test]
    fn a_wall_seen_at_a_grazing_angle_is_open_where_its_returns_spread_apart() {
        // A wall along y = 0.5 m, beams 1° apart from 90° down to 10° off the x axis:
        // the point at φ is (0.5 / tan φ, 0.5), and steps grow as 0.0087 / sin²φ m, past
        // the 0.15 m gap between 14° (x = 2.005 m) and 13° (x = 2.166 m). The next step
        // (0.161 m) goes on along the last one inside (0.139 m, from 15°): the cluster
        // from 90° to 14° is a piece of something longer.
        let points: Vec<Vec2> = (0..=80)
            .map(|k| {
                let phi = (90.0 - k as f64).to_radians();
                Vec2::new(0.5 / phi.tan(), 0.5)
            })
            .collect();
        let c = clusters_of(&points);
        let first = c.as_slice()[0];
        assert_eq!((first.start, first.end), (0, 77), "{first:?}");
        assert!(open_ended(&first, &points, &(0..81).collect::<Vec<u32>>(), 10.0, true));
    }

    #[test]
    fn a_person_in_front_of_a_wall_is_whole() {
        // A disc of radius 0.2 m at (1.5, 0), a wall at x = 3 m behind it, beams 1° apart
        // from −30° to 30°: beyond the disc's edge the next return is on the wall, 1.5 m
        // on, a jump, not a step of the 2-3 cm between the disc's own returns.
        let (centre, radius) = (Vec2::new(1.5, 0.0), 0.2);
        let points: Vec<Vec2> = (-30..=30)
            .map(|deg: i32| {
                let phi = (deg as f64).to_radians();
                let u = Vec2::new(phi.cos(), phi.sin());
                let along = u.dot(&centre);
                let off2 = centre.norm_squared() - along * along;
                if off2 <= radius * radius {
                    u * (along - (radius * radius - off2).sqrt())
                } else {
                    u * (3.0 / phi.cos())
                }
            })
            .collect();
        let idx: Vec<u32> = (0..points.len() as u32).collect();
        let c = clusters_of(&points);
        let person = c
            .as_slice()
            .iter()
            .find(|k| (k.centroid - Vec2::new(1.35, 0.0)).norm() < 0.1)
            .expect("the person's cluster");
        assert!(person.len >= 10, "{person:?}");
        assert!(!open_ended(person, &points, &idx, 10.0, true));
    }
}
