//! What the last scan's perception says at a tick (ALGORITHM.md §2, §6,
//! §5b): the clearances, the movers and threats predicted to the tick, the
//! points the way-round planner sees, and how far h has fallen beyond what
//! its predictions explained.

use super::perceive::Frame;
use super::Threat;
use super::{next_points, SafetyPipeline, PLAN_THROUGH_SPEED_MPS, SURPRISE_STEPS};
use crate::algo::clearance::{
    compute_clearances, compute_clearances_faded_polygon, compute_clearances_faded_seeded, compute_clearances_polygon,
    side_crowding, Clearances,
};
use crate::algo::collision_cone::{collision_cone, polygon_time_to_collision};
use crate::algo::doaa::sides_tie;
use crate::algo::geometry::Vec2;
use crate::algo::obstacle_tracker::ObstacleTracker;
use crate::algo::passive::Mover;

impl SafetyPipeline {
    /// The clearances at the tick of `frame` (the side fade seeded by the
    /// last tick's minimisers), with every mover predicted to it and the
    /// threats' sides lowered to their predicted clearances
    /// ([`Self::predict_threats`]); the braking check given the tick's
    /// points, phantoms and movers. `v_now` is the robot's speed (m/s).
    pub(super) fn measure(&mut self, frame: &Frame, v_now: f64) -> Clearances {
        let d = self.derived;
        let polygon = self.filter.footprint();
        let mut c = match (&d.fade, polygon) {
            // A polygon body: every point's signed distance (the seeded bounds are the circle's).
            (Some(fade), Some(fp)) => compute_clearances_faded_polygon(&self.points.points, fp, d.front, fade).0,
            (None, Some(fp)) => compute_clearances_polygon(&self.points.points, fp, d.hemisphere, d.front),
            (Some(fade), None) => {
                // Seeded by the points on the beams of the last step's minimisers.
                let beams = &self.points.beam_index;
                let seeds = self
                    .minimiser_beams
                    .map(|b| beams.binary_search(&b).unwrap_or(usize::MAX));
                let (c, at) =
                    compute_clearances_faded_seeded(&self.points.points, d.robot_radius_m, d.front, fade, &seeds);
                self.minimiser_beams = at.map(|i| beams.get(i).copied().unwrap_or(u32::MAX));
                c
            }
            (None, None) => compute_clearances(&self.points.points, d.robot_radius_m, d.hemisphere, d.front),
        };
        self.predict_threats(&mut c, v_now, frame);
        // The faded pass leaves the crowding sums out: they only break a tie between the
        // sides (both +inf: no point counts for either side, and both sums are 0).
        if let Some(fade) = &d.fade {
            if sides_tie(&c) && c.d_left_m.is_finite() {
                (c.crowding_left, c.crowding_right) = side_crowding(&self.points.points, fade);
            }
        }
        self.passive.set_phantoms(&self.points.phantoms);
        let next = next_points(self.any_advanced, &self.points_next, &self.points.points);
        self.passive.prepare(next, &self.params);
        self.last_clearances = c;
        c
    }

    /// For every moving track (predicted to the tick's time, in the robot
    /// frame then): a [`Mover`] for the passive-safety check; and for one on
    /// a collision course with a time to collision within `lookahead_s`: its
    /// points advanced by v_o Δt in `points_next`, and its side's clearance
    /// lowered to its clearance predicted at the time to collision.
    pub(super) fn predict_threats(&mut self, c: &mut Clearances, v_now: f64, frame: &Frame) {
        self.any_advanced = false;
        self.threats.clear();
        self.passive.set_movers(std::iter::empty());
        if !self.params.obstacles.enabled {
            return;
        }
        let p = &self.params;
        let (o, r, dt) = (&p.obstacles, p.robot_radius_m(), p.control.dt_s());
        let robot = frame.pose.frame_map();
        let ahead_s = self.tracker.last_stamp_s().map_or(0.0, |t| (frame.at_s - t).max(0.0));
        let pts = &self.points.points;
        let tracker = &self.tracker;
        self.passive
            .set_movers(tracker.tracks().iter().filter(|t| t.is_moving(o)).map(|t| {
                let (position, velocity) = ObstacleTracker::predicted_disc(t, ahead_s, &robot);
                Mover {
                    position,
                    velocity,
                    radius_m: t.radius_m,
                }
            }));
        let n = pts.len();
        let fp = self.filter.footprint();
        for (ci, cluster) in self.clusters.as_slice().iter().enumerate() {
            let Some(ti) = self.tracker.cluster_track().get(ci).copied().flatten() else {
                continue;
            };
            let track = self.tracker.tracks()[ti];
            if !track.is_moving(o) {
                continue;
            }
            let (pos, vel) = ObstacleTracker::predicted(&track, ahead_s, &robot);
            let cone = collision_cone(pos, Vec2::new(v_now, 0.0) - vel, track.radius_m + r);
            // A polygon body: the time the track's disc first reaches the polygon, its
            // centre moving relative to the robot (heading held) along pos + (v_o − v) t:
            // where that line comes within r_o of the polygon, exactly.
            let time_to_collision_s = match fp {
                None => cone.time_to_collision_s,
                Some(fp) => polygon_time_to_collision(
                    fp,
                    pos,
                    vel - Vec2::new(v_now, 0.0),
                    track.radius_m,
                    o.lookahead_s,
                    &mut self.cone_events,
                    &mut self.cone_entries,
                ),
            };
            log::trace!(
                "t {:.1}: track {} at ({:.2}, {:.2}) v ({:.3}, {:.3}) r {:.2}: cone {:?}, contact in {:?} s",
                frame.at_s,
                track.id,
                pos.x,
                pos.y,
                vel.x,
                vel.y,
                track.radius_m,
                cone,
                time_to_collision_s
            );
            // Only an imminent collision counts: within the look-ahead.
            let Some(ttc) = time_to_collision_s.filter(|&t| t <= o.lookahead_s) else {
                continue;
            };
            let horizon = ttc;
            if !self.any_advanced {
                // Sized to the points, then copied whole (a memory copy; a Vec2 is Copy).
                self.points_next.resize(n, Vec2::zeros());
                self.points_next.copy_from_slice(pts);
                self.any_advanced = true;
            }
            let mut predicted = f64::INFINITY;
            for i in cluster.indices(n) {
                self.points_next[i] += vel * dt;
                let at = pts[i] + vel * horizon;
                predicted = predicted.min(match fp {
                    None => at.norm() - r,
                    Some(fp) => fp.signed_distance(at),
                });
            }
            match &self.derived.fade {
                Some(fade) => {
                    let n = cluster.centroid.norm().max(1e-9);
                    let (pl, pr) = fade.penalties(cluster.centroid.x / n, cluster.centroid.y / n);
                    c.d_left_m = c.d_left_m.min(predicted + pl);
                    c.d_right_m = c.d_right_m.min(predicted + pr);
                    // A mover coming at the robot from ahead blocks the way ahead as a wall
                    // there would (§4b): the robot commits to a side and swerves early,
                    // rather than waiting for the mover to be within d_act.
                    if self.derived.front.contains(cluster.centroid, n) {
                        c.d_front_m = c.d_front_m.min(predicted);
                    }
                }
                None if cluster.centroid.y >= 0.0 => c.d_left_m = c.d_left_m.min(predicted),
                None => c.d_right_m = c.d_right_m.min(predicted),
            }
            self.threats.push(Threat {
                track_id: track.id,
                position: pos,
                velocity: vel,
                radius_m: track.radius_m,
                time_to_collision_s: ttc,
                cone_half_angle_rad: cone.half_angle_rad,
            });
        }
    }

    pub(super) fn forget_surprise(&mut self) {
        self.surprise = [0.0; SURPRISE_STEPS];
        self.last_h_next = f64::NAN;
    }

    /// Records this step's h (m) against the last prediction and returns
    /// whether h has fallen, over the last [`SURPRISE_STEPS`] steps, by more
    /// than the noise margin δ beyond what the predictions explain.
    pub(super) fn closing_in_unexplained(&mut self, h: f64) -> bool {
        let change = h - self.last_h_next;
        self.surprise[self.surprise_next] = if change.is_finite() { change } else { 0.0 };
        self.surprise_next = (self.surprise_next + 1) % SURPRISE_STEPS;
        self.closing_in_now()
    }

    /// Whether the unexplained falls of h recorded so far add up beyond δ
    /// ([`Self::closing_in_unexplained`] without a new measurement).
    pub(super) fn closing_in_now(&self) -> bool {
        self.surprise.iter().sum::<f64>() < -self.params.dtcbf.noise_margin_m
    }

    /// The scan's points less those of this step's moving tracks at
    /// [`PLAN_THROUGH_SPEED_MPS`] or more, for the unstuck planner (§4b):
    /// planning round people as if they were walls sent robots on long
    /// detours away from their goal while people walked through the way;
    /// evasion and the DTCBF still see every point. Reads the marks
    /// [`Self::mark_movers`] left for this scan.
    pub(super) fn fill_plan_points(&mut self) {
        self.plan_points.clear();
        self.slow_points.clear();
        for (q, m) in self.points.points.iter().zip(&self.on_mover) {
            match m {
                0 => self.plan_points.push(*q),
                1 => self.slow_points.push(*q),
                _ => {}
            }
        }
    }

    /// Marks each point of the scan by its cluster's track in `on_mover`:
    /// 0 static or untracked, 1 moving slower than PLAN_THROUGH_SPEED_MPS,
    /// 2 moving faster.
    pub(super) fn mark_movers(&mut self) {
        let n = self.points.points.len();
        self.on_mover.clear();
        self.on_mover.resize(n, 0);
        let (tracks, o) = (self.tracker.tracks(), &self.params.obstacles);
        // 2: walks off (left out); 1: a moving track slower than that (kept, transient).
        let kind = |t: usize| match tracks[t].is_moving(o) {
            true if tracks[t].velocity().norm() >= PLAN_THROUGH_SPEED_MPS => 2,
            true => 1,
            false => 0,
        };
        for (cluster, track) in self.clusters.as_slice().iter().zip(self.tracker.cluster_track()) {
            if let Some(k) = track.map(kind).filter(|&k| k > 0) {
                for i in cluster.indices(n) {
                    self.on_mover[i] = k;
                }
            }
        }
    }
}
