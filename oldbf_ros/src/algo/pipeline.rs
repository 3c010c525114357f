//! The per-scan pipeline: scan → points → clearances → barriers → DOAA →
//! DTCBF check → command (ALGORITHM.md §1-5).
//!
//! `SafetyPipeline` owns every buffer it needs and reuses them, so after the
//! first scan of a given size a step does not allocate. The simulator, the
//! CLI, the ROS node and the tests all call `step`.

use super::barrier::compute_barriers;
use super::clearance::{compute_clearances, Clearances, Sector};
use super::clusters::{Cluster, Clusters};
use super::collision_cone::collision_cone;
use super::doaa::{Doaa, DoaaState};
use super::dtcbf::{DtcbfFilter, InputBox};
use super::geometry::Pose2;
use super::geometry::{Twist, Vec2};
use super::obstacle_tracker::ObstacleTracker;
use super::params::Params;
use super::record::{StepRecord, StopCause};
use super::scan::{sanitize_scan, LaserMount, LaserScan, ScanPoints};
use super::unicycle::arc_step;

/// Geometry derived from the parameters once.
#[derive(Debug, Clone, Copy)]
struct Derived {
    robot_radius_m: f64,
    mount: LaserMount,
    hemisphere: Sector,
    front: Sector,
    input_box: InputBox,
}

impl Derived {
    fn new(p: &Params) -> Self {
        Self {
            robot_radius_m: p.robot_radius_m(),
            mount: LaserMount::from_params(&p.laser),
            hemisphere: Sector::new(p.barrier.hemisphere_fov_deg.to_radians()),
            front: Sector::new(p.barrier.front_fov_deg.to_radians()),
            input_box: InputBox::from_params(p),
        }
    }
}

/// The whole safety filter, with its state (DOAA latch) and buffers.
#[derive(Debug, Clone)]
pub struct SafetyPipeline {
    params: Params,
    derived: Derived,
    points: ScanPoints,
    doaa: Doaa,
    filter: DtcbfFilter,
    last_cmd: Twist,
    last_clearances: Clearances,
    clusters: Clusters,
    tracker: ObstacleTracker,
    /// Where the points will be after one step (moving clusters advanced).
    points_next: Vec<Vec2>,
    /// Robot pose in the tracking frame, and whether it came from odometry.
    ego: Option<(Pose2, bool, f64)>,
    threats: Vec<Threat>,
}

/// A tracked obstacle on a collision course this step (robot frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Threat {
    pub track_id: u32,
    pub position: Vec2,
    pub velocity: Vec2,
    pub radius_m: f64,
    pub time_to_collision_s: f64,
    /// Half-angle of its collision cone (rad).
    pub cone_half_angle_rad: f64,
}

impl SafetyPipeline {
    /// `params` must have passed `Params::validate`.
    pub fn new(params: Params) -> Self {
        let derived = Derived::new(&params);
        let cap = 1024;
        let max_tracks = params.obstacles.max_tracks;
        Self {
            params,
            derived,
            points: ScanPoints::with_capacity(cap),
            doaa: Doaa::new(),
            filter: DtcbfFilter::with_capacity(cap),
            last_cmd: Twist::ZERO,
            last_clearances: Clearances::OPEN,
            clusters: Clusters::with_capacity(cap),
            tracker: ObstacleTracker::with_capacity(max_tracks, cap),
            points_next: Vec::with_capacity(cap),
            ego: None,
            threats: Vec::with_capacity(max_tracks),
        }
    }

    /// The obstacle tracker (tracks in its tracking frame; see `in_robot_frame`).
    pub fn tracker(&self) -> &ObstacleTracker {
        &self.tracker
    }

    /// The clusters of the last accepted scan (indices into `points`).
    pub fn clusters(&self) -> &[Cluster] {
        self.clusters.as_slice()
    }

    /// Where the valid points will be after one step, as the filter predicted
    /// them (moving clusters on a collision course advanced by v_o Δt).
    pub fn points_next(&self) -> &[Vec2] {
        &self.points_next
    }

    /// Tracked obstacles on a collision course at the last step.
    pub fn threats(&self) -> &[Threat] {
        &self.threats
    }

    pub fn params(&self) -> &Params {
        &self.params
    }

    /// Valid points of the last accepted scan, robot frame (m).
    pub fn points(&self) -> &[Vec2] {
        &self.points.points
    }

    /// Clearances of the last accepted scan.
    pub fn clearances(&self) -> &Clearances {
        &self.last_clearances
    }

    pub fn last_command(&self) -> Twist {
        self.last_cmd
    }

    /// Forget latched DOAA state (after an e-stop release or a filter toggle).
    pub fn reset(&mut self) {
        self.doaa.reset();
        self.last_cmd = Twist::ZERO;
    }

    /// New parameters while running (dynamic_reconfigure), keeping tracks,
    /// the DOAA latch and buffers. `params` must have passed
    /// `Params::validate`; buffers keep the capacity they were built with.
    pub fn set_params(&mut self, params: Params) {
        self.derived = Derived::new(&params);
        self.params = params;
    }

    /// A stop step with no scan processing (missing scan, e-stop…).
    pub fn stop(&mut self, now_s: f64, nominal: Twist, cause: StopCause) -> StepRecord {
        self.doaa.reset();
        self.last_cmd = Twist::ZERO;
        StepRecord::stop(now_s, nominal, cause)
    }

    /// One control step.
    ///
    /// `nominal` is the command to make safe (tracking law or upstream);
    /// `current_v_mps` the measured linear speed for B_v (NaN: the last
    /// command is used instead).
    pub fn step(&mut self, scan: &LaserScan<'_>, now_s: f64, nominal: Twist, current_v_mps: f64) -> StepRecord {
        self.step_with_pose(scan, now_s, nominal, current_v_mps, None)
    }

    /// The robot's pose in the tracking frame at the scan's stamp: odometry when
    /// given, else dead-reckoned from the last command since the previous scan.
    fn ego_pose(&mut self, stamp_s: f64, odom: Option<Pose2>) -> Pose2 {
        let pose = match (odom, self.ego) {
            (Some(p), Some((_, true, _))) | (Some(p), None) => p,
            (Some(p), Some((_, false, _))) => {
                self.tracker.reset(); // the frame changes: old tracks are meaningless
                p
            }
            (None, Some((prev, false, t))) if stamp_s > t => arc_step(prev, self.last_cmd, (stamp_s - t).min(1.0)),
            (None, Some((prev, false, _))) => prev,
            (None, Some((_, true, _))) => {
                self.tracker.reset();
                Pose2::default()
            }
            (None, None) => Pose2::default(),
        };
        self.ego = Some((pose, odom.is_some(), stamp_s));
        pose
    }

    /// Clusters, tracks, and for every moving track on a collision course with
    /// a time to collision within `lookahead_s`: its points advanced by v_o Δt
    /// in `points_next`, and its side's clearance lowered to its clearance
    /// predicted at the time to collision.
    fn predict_obstacles(
        &mut self,
        c: &mut Clearances,
        v_now: f64,
        stamp_s: f64,
        odom: Option<Pose2>,
        full_circle: bool,
    ) {
        self.points_next.clear();
        self.points_next.extend_from_slice(&self.points.points);
        self.threats.clear();
        // Clusters always (the baselines use them), tracking only when enabled.
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
        let pose = self.ego_pose(stamp_s, odom);
        let p = &self.params;
        let (o, r, dt) = (&p.obstacles, p.robot_radius_m(), p.control.dt_s());
        let pts = &self.points.points;
        self.tracker.update(self.clusters.as_slice(), stamp_s, pose, o);
        let n = pts.len();
        for (ci, cluster) in self.clusters.as_slice().iter().enumerate() {
            let Some(ti) = self.tracker.cluster_track()[ci] else {
                continue;
            };
            let track = self.tracker.tracks()[ti];
            if !track.is_moving(o) {
                continue;
            }
            let (pos, vel) = self.tracker.in_robot_frame(&track);
            let cone = collision_cone(pos, Vec2::new(v_now, 0.0) - vel, track.radius_m + r);
            log::trace!(
                "t {stamp_s:.1}: track {} at ({:.2}, {:.2}) v ({:.3}, {:.3}) r {:.2}: cone {:?}",
                track.id,
                pos.x,
                pos.y,
                vel.x,
                vel.y,
                track.radius_m,
                cone
            );
            // Only an imminent collision counts: within the look-ahead.
            let Some(ttc) = cone.time_to_collision_s.filter(|&t| t <= o.lookahead_s) else {
                continue;
            };
            let horizon = ttc;
            let mut predicted = f64::INFINITY;
            for i in cluster.indices(n) {
                self.points_next[i] += vel * dt;
                predicted = predicted.min((pts[i] + vel * horizon).norm() - r);
            }
            if cluster.centroid.y >= 0.0 {
                c.d_left_m = c.d_left_m.min(predicted);
            } else {
                c.d_right_m = c.d_right_m.min(predicted);
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

    /// As `step`, with the robot's odometry pose when there is one (tracks
    /// are then kept in the odometry frame).
    pub fn step_with_pose(
        &mut self,
        scan: &LaserScan<'_>,
        now_s: f64,
        nominal: Twist,
        current_v_mps: f64,
        odom_pose: Option<Pose2>,
    ) -> StepRecord {
        if !nominal.is_finite() {
            return self.stop(now_s, nominal, StopCause::BadNominal);
        }
        if let Err(reason) = sanitize_scan(scan, now_s, &self.params.laser, &self.derived.mount, &mut self.points) {
            return self.stop(now_s, nominal, StopCause::Rejected(reason));
        }
        let d = self.derived;
        let mut c = compute_clearances(&self.points.points, d.robot_radius_m, d.hemisphere, d.front);
        let v_now = if current_v_mps.is_finite() {
            current_v_mps
        } else {
            self.last_cmd.v_mps
        };
        let span = (scan.angle_increment_rad as f64).abs() * scan.ranges_m.len() as f64;
        let full_circle = span >= 2.0 * std::f64::consts::PI - 1e-3;
        self.predict_obstacles(&mut c, v_now, scan.stamp_s, odom_pose, full_circle);
        self.last_clearances = c;
        let p = &self.params;
        let b = compute_barriers(c.d_left_m, c.d_right_m, v_now, &p.barrier);
        let nominal_boxed = d.input_box.clamp(nominal);
        let (doaa_cmd, doaa_state) = self.doaa.command(nominal_boxed, &c, &b, p);
        let out = self.filter.filter(&self.points.points, &self.points_next, doaa_cmd, p);

        // Infeasible inside the unsafe set: the filter turns in place (escape); infeasible
        // outside it (an approaching obstacle): the filter's command is a stop.
        let state = match (out.infeasible, out.escape) {
            (true, false) => DoaaState::Stop,
            (_, true) => DoaaState::Escape,
            (false, false) => doaa_state,
        };
        let stop_cause = out.infeasible.then_some(StopCause::Infeasible);
        let cmd = out.cmd;
        // Last line of defence: nothing non-finite leaves this function.
        let cmd = if cmd.is_finite() {
            d.input_box.clamp(cmd)
        } else {
            Twist::ZERO
        };
        self.last_cmd = cmd;
        StepRecord {
            stamp_s: now_s,
            cmd,
            nominal,
            doaa_cmd,
            state,
            h_m: out.h_m,
            h_next_m: out.h_next_m,
            filter_changed: out.changed,
            condition_held: out.condition_held,
            b_left: b.b_left,
            b_right: b.b_right,
            b_velocity: b.b_velocity,
            d_left_m: c.d_left_m,
            d_right_m: c.d_right_m,
            d_min_m: c.d_min_m,
            d_front_m: c.d_front_m,
            closest_left: c.closest_left,
            closest_right: c.closest_right,
            beams: self.points.beams,
            valid_beams: self.points.valid_count(),
            tracked_obstacles: self
                .tracker
                .tracks()
                .iter()
                .filter(|t| t.is_moving(&p.obstacles))
                .count(),
            threats: self.threats.len(),
            min_time_to_collision_s: self
                .threats
                .iter()
                .map(|t| t.time_to_collision_s)
                .fold(f64::INFINITY, f64::min),
            stop_cause,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

    /// 360 beams over a full turn starting at −π, all at `far` m, with
    /// `(beam, range)` overrides.
    fn ring(far: f32, overrides: &[(usize, f32)]) -> Vec<f32> {
        let mut r = vec![far; 360];
        for &(i, v) in overrides {
            r[i] = v;
        }
        r
    }

    fn scan(ranges: &[f32]) -> LaserScan<'_> {
        LaserScan {
            stamp_s: 1.0,
            angle_min_rad: -PI,
            angle_increment_rad: 2.0 * PI / 360.0,
            range_min_m: 0.12,
            range_max_m: 3.5,
            ranges_m: ranges,
            intensities: &[],
        }
    }

    #[test]
    fn obstacle_close_on_the_left_gives_a_right_turn() {
        // Beam 180 + 45 = 45° left, 0.6 m away.
        let ranges = ring(f32::INFINITY, &[(225, 0.6)]);
        let mut pipe = SafetyPipeline::new(Params::default());
        let rec = pipe.step(&scan(&ranges), 1.0, Twist::new(0.15, 0.0), 0.15);
        assert!(rec.cmd.omega_radps < 0.0, "{rec:?}");
        assert_eq!(rec.state, DoaaState::Avoid);
        assert!(rec.b_left > rec.b_right);
        assert!(rec.condition_held);
    }

    #[test]
    fn obstacle_dead_ahead_inside_d_safe_stops_forward_motion() {
        // Wall segment ahead at 0.3 m (beams −10°..10°): centre distance 0.3 < r + d_safe = 0.378.
        let over: Vec<_> = (170..=190).map(|i| (i, 0.3)).collect();
        let ranges = ring(f32::INFINITY, &over);
        let mut pipe = SafetyPipeline::new(Params::default());
        let rec = pipe.step(&scan(&ranges), 1.0, Twist::new(0.15, 0.0), 0.15);
        assert!(rec.cmd.v_mps <= 0.0, "{rec:?}");
        assert!(rec.h_m < 0.0);
    }

    #[test]
    fn rejected_scan_stops_with_reason() {
        let ranges = ring(1.0, &[]);
        let mut pipe = SafetyPipeline::new(Params::default());
        let mut s = scan(&ranges);
        s.stamp_s = 0.0; // 1 s old, timeout 0.5 s
        let rec = pipe.step(&s, 1.0, Twist::new(0.15, 0.0), 0.0);
        assert_eq!(rec.cmd, Twist::ZERO);
        assert_eq!(rec.state, DoaaState::Stop);
        assert!(matches!(
            rec.stop_cause,
            Some(StopCause::Rejected(crate::algo::scan::ScanRejection::Stale { .. }))
        ));
    }

    #[test]
    fn non_finite_nominal_stops() {
        let ranges = ring(1.0, &[]);
        let mut pipe = SafetyPipeline::new(Params::default());
        let rec = pipe.step(&scan(&ranges), 1.0, Twist::new(f64::NAN, 0.0), 0.0);
        assert_eq!((rec.cmd, rec.stop_cause), (Twist::ZERO, Some(StopCause::BadNominal)));
    }

    #[test]
    fn empty_world_passes_nominal() {
        let ranges = ring(f32::INFINITY, &[]);
        let mut pipe = SafetyPipeline::new(Params::default());
        let rec = pipe.step(&scan(&ranges), 1.0, Twist::new(0.15, 0.05), 0.15);
        assert_eq!(rec.cmd, Twist::new(0.15, 0.05));
        assert_eq!(rec.state, DoaaState::Forward);
        assert_eq!(rec.valid_beams, 0);
        assert!(rec.h_m.is_infinite() && rec.condition_held && !rec.filter_changed);
    }
}
