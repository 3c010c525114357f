//! The closed loop: simulated LiDAR → controller → simulated robot, with the
//! metrics the CLI prints and the tests assert.
//!
//! Every control period Δt: take a scan when the LiDAR is due (stamped with
//! the sim time), compute the nominal command (tracking the governed
//! reference, or the constant command), run the controller, then integrate the robot and
//! the moving obstacles in physics sub-steps, checking the robot circle
//! against the geometry exactly at each sub-step.
//!
//! Two CBF figures are reported. `cbf_violations` counts steps where the DTCBF
//! condition h(k+1) ≥ (1 − γ) h(k), predicted from the scan the controller
//! saw, was false for the command actually sent (the definition's logged
//! condition; with `--controller none` it is evaluated for the raw nominal
//! command). `true_cbf_violations` checks the same inequality on the
//! simulator's exact geometry after the step: it also sees sensor noise,
//! actuator lag and obstacle motion that a static one-step prediction cannot.

use super::lidar::Lidar;
use super::robot::SimRobot;
use super::scenario::Scenario;
use super::world::World;
use crate::algo::doaa::DoaaState;
use crate::algo::dtcbf::{min_distance, predicted_displacement, InputBox};
use crate::algo::geometry::{Pose2, Twist, Vec2};
use crate::algo::pipeline::SafetyPipeline;
use crate::algo::record::StepRecord;
use crate::algo::reference::ReferenceProgress;
use crate::algo::scan::LaserScan;
use crate::algo::tracking::{track, TrackingError};
use serde::Serialize;
use std::time::Instant;

/// Which controller closes the loop.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum Controller {
    /// OLDBF barriers + DOAA steering + exact DTCBF filter.
    Oldbf,
    /// The nominal command alone (the filter still runs, only to monitor).
    None,
}

/// Slack on inequality checks (m).
const TOL_M: f64 = 1e-9;

/// One control step, as written to `steps.csv`.
#[derive(Debug, Clone, Serialize)]
pub struct StepRow {
    pub t_s: f64,
    pub x_m: f64,
    pub y_m: f64,
    pub theta_rad: f64,
    pub ref_x_m: f64,
    pub ref_y_m: f64,
    /// The nominal command, clamped to the input box (m/s, rad/s).
    pub v_nominal_mps: f64,
    pub omega_nominal_radps: f64,
    pub v_cmd_mps: f64,
    pub omega_cmd_radps: f64,
    pub v_actual_mps: f64,
    pub omega_actual_radps: f64,
    pub b_left: f64,
    pub b_right: f64,
    pub d_left_m: f64,
    pub d_right_m: f64,
    pub h_m: f64,
    pub h_next_pred_m: f64,
    pub h_true_m: f64,
    pub clearance_true_m: f64,
    pub state: DoaaState,
    pub filter_changed: bool,
    pub condition_held: bool,
    pub in_collision: bool,
    pub step_us: f64,
}

/// The run's figures; `--json` prints this.
#[derive(Debug, Clone, Serialize)]
pub struct RunSummary {
    pub scenario: String,
    pub controller: Controller,
    pub seed: u64,
    pub steps: usize,
    pub sim_time_s: f64,
    /// Distinct contacts between the robot circle and any obstacle.
    pub collisions: usize,
    /// Least distance between the robot's body and any obstacle over the run (m; < 0 = penetration).
    pub min_clearance_m: f64,
    /// Steps where the logged DTCBF condition was false for the sent command.
    pub cbf_violations: usize,
    /// Steps where the condition failed on the exact geometry after the step.
    pub true_cbf_violations: usize,
    pub reached_goal: bool,
    pub time_to_goal_s: Option<f64>,
    pub path_length_m: f64,
    /// Largest distance from the (governed) reference point (m); null without a reference.
    pub max_tracking_error_m: Option<f64>,
    pub mean_tracking_error_m: Option<f64>,
    /// Mean / largest wall-clock time of the pipeline per step (µs).
    pub mean_step_us: f64,
    pub max_step_us: f64,
    /// Steps where the DTCBF check changed the DOAA command.
    pub filter_changed_steps: usize,
    pub steps_by_state: StateCounts,
    /// Least h(k) the controller measured (m).
    pub min_h_m: f64,
    pub final_pose: Pose2,
}

/// How many steps were spent in each DOAA state.
#[derive(Debug, Clone, Copy, Default, Serialize, PartialEq, Eq)]
pub struct StateCounts {
    pub forward: usize,
    pub avoid: usize,
    pub both_sides: usize,
    pub stop: usize,
    pub escape: usize,
}

impl StateCounts {
    fn add(&mut self, s: DoaaState) {
        match s {
            DoaaState::Forward => self.forward += 1,
            DoaaState::Avoid => self.avoid += 1,
            DoaaState::BothSides => self.both_sides += 1,
            DoaaState::Stop => self.stop += 1,
            DoaaState::Escape => self.escape += 1,
        }
    }
}

/// Everything a run produced.
#[derive(Debug, Clone)]
pub struct RunResult {
    pub summary: RunSummary,
    pub rows: Vec<StepRow>,
    /// Each moving obstacle's centre per control step, and its radius (m).
    pub mover_tracks: Vec<(Vec<Vec2>, f64)>,
    /// Robot positions where a collision began.
    pub collision_points: Vec<Vec2>,
    /// The reference's end, if any.
    pub goal: Option<Vec2>,
    /// The world at the start (for plots).
    pub world: World,
}

/// Runs `scenario` in closed loop with `controller`.
pub fn run_scenario(scenario: &Scenario, controller: Controller, seed: u64) -> Result<RunResult, String> {
    let spec = &scenario.spec;
    let params = &scenario.params;
    let mut world = World::new(&spec.world)?;
    let world_at_start = world.clone();
    let mut robot = SimRobot::new(spec.start.pose(), scenario.robot);
    let mut lidar = Lidar::new(spec.lidar.clone(), seed)?;
    let mut pipeline = SafetyPipeline::new(params.clone());

    let dt = params.control.dt_s();
    let substeps = (dt / spec.physics_dt_s).ceil().max(1.0) as usize;
    let h_dt = dt / substeps as f64;
    let scan_period = 1.0 / lidar.spec().rate_hz;
    let mount = Pose2::new(
        params.laser.mount_x_m,
        params.laser.mount_y_m,
        params.laser.mount_yaw_deg.to_radians(),
    );
    let (angle_min, angle_inc) = (lidar.spec().angle_min_rad(), lidar.spec().angle_increment_rad());
    let (range_min, range_max) = (lidar.spec().range_min_m as f32, lidar.spec().range_max_m as f32);
    let r = params.robot_radius_m();
    let d_safe = params.barrier.d_safe_m;
    let gamma = params.dtcbf.gamma;
    let input_box = InputBox::from_params(params);
    let true_h = |w: &World, p: Vec2| w.distance_to_nearest(p) - r - d_safe;

    let steps_max = (spec.duration_s / dt).ceil() as usize;
    let mut ranges: Vec<f32> = Vec::with_capacity(lidar.spec().beams);
    let mut scan_stamp = f64::NEG_INFINITY;
    let mut next_scan_t = 0.0;
    let goal = scenario.reference.map(|r| r.goal().position());
    let mut progress = ReferenceProgress::default();

    let mut rows = Vec::with_capacity(steps_max);
    let mut mover_tracks: Vec<(Vec<Vec2>, f64)> = world
        .moving()
        .iter()
        .map(|m| (Vec::with_capacity(steps_max), m.radius_m()))
        .collect();
    let mut collision_points = Vec::new();
    let mut counts = StateCounts::default();
    let (mut collisions, mut in_collision) = (0usize, robot.collides(&world));
    if in_collision {
        collisions += 1;
        collision_points.push(robot.pose.position());
    }
    let mut min_clearance = robot.clearance_m(&world);
    let (mut cbf_violations, mut true_violations, mut changed_steps) = (0usize, 0usize, 0usize);
    let (mut path_length, mut max_err, mut sum_err) = (0.0f64, 0.0f64, 0.0f64);
    let (mut sum_us, mut max_us) = (0.0f64, 0.0f64);
    let mut min_h = f64::INFINITY;
    let mut time_to_goal = None;
    let mut steps = 0;

    for k in 0..steps_max {
        let t = k as f64 * dt;
        steps = k + 1;
        if t + 1e-9 >= next_scan_t {
            let origin = robot.pose.transform_point(mount.position());
            let laser_pose = Pose2::new(origin.x, origin.y, robot.pose.theta + mount.theta);
            lidar.scan_into(&world, laser_pose, &mut ranges);
            scan_stamp = t;
            next_scan_t += scan_period;
        }
        let scan = LaserScan {
            stamp_s: scan_stamp,
            angle_min_rad: angle_min,
            angle_increment_rad: angle_inc,
            range_min_m: range_min,
            range_max_m: range_max,
            ranges_m: &ranges,
            intensities: &[],
        };

        let (nominal, ref_pos) = match &scenario.reference {
            Some(reference) => {
                let ref_pose = reference.pose_at(progress.t_s);
                let e = TrackingError::between(robot.pose, ref_pose).distance_m();
                max_err = max_err.max(e);
                sum_err += e;
                let rate = ReferenceProgress::rate(e, params.tracking.capture_radius_m);
                let (ref_pose, ref_twist) = progress.reference(reference, rate);
                progress.advance(dt, rate);
                (
                    track(robot.pose, ref_pose, ref_twist, &params.tracking),
                    ref_pose.position(),
                )
            }
            None => (
                scenario.constant_nominal().unwrap_or(Twist::ZERO),
                Vec2::new(f64::NAN, f64::NAN),
            ),
        };

        let t0 = Instant::now();
        let rec: StepRecord = pipeline.step(&scan, t, nominal, robot.twist.v_mps);
        let step_us = t0.elapsed().as_secs_f64() * 1e6;
        let cmd = match controller {
            Controller::Oldbf => rec.cmd,
            // Same input box as the filter, so the comparison is only about safety.
            Controller::None => input_box.clamp(nominal),
        };
        // The logged condition, recomputed here from the scan's points for the command
        // actually sent (not taken from the filter's own record).
        let (h_next_pred, held) = if rec.measured() {
            let disp = predicted_displacement(params.dtcbf.prediction, cmd, dt);
            let h_next = min_distance(pipeline.points(), disp) - r - d_safe;
            (
                h_next,
                !rec.h_m.is_finite() || h_next >= (1.0 - gamma) * rec.h_m - TOL_M,
            )
        } else {
            (f64::NAN, true)
        };
        if rec.measured() && !held {
            cbf_violations += 1;
        }
        if rec.measured() {
            min_h = min_h.min(rec.h_m);
        }
        if rec.filter_changed {
            changed_steps += 1;
        }
        counts.add(rec.state);
        sum_us += step_us;
        max_us = max_us.max(step_us);

        let h_true_now = true_h(&world, robot.pose.position());
        let start_pos = robot.pose.position();
        for _ in 0..substeps {
            let before = robot.pose.position();
            robot.step(cmd, h_dt);
            world.advance(h_dt);
            path_length += (robot.pose.position() - before).norm();
            let clearance = robot.clearance_m(&world);
            min_clearance = min_clearance.min(clearance);
            let hit = clearance < 0.0;
            if hit && !in_collision {
                collisions += 1;
                collision_points.push(robot.pose.position());
            }
            in_collision = hit;
        }
        let h_true_next = true_h(&world, robot.pose.position());
        if h_true_now.is_finite() && h_true_next < (1.0 - gamma) * h_true_now - TOL_M {
            true_violations += 1;
        }
        for (track, m) in mover_tracks.iter_mut().zip(world.moving_circles()) {
            track.0.push(m.center);
        }
        rows.push(StepRow {
            t_s: t,
            x_m: start_pos.x,
            y_m: start_pos.y,
            theta_rad: robot.pose.theta,
            ref_x_m: ref_pos.x,
            ref_y_m: ref_pos.y,
            v_nominal_mps: input_box.clamp(nominal).v_mps,
            omega_nominal_radps: input_box.clamp(nominal).omega_radps,
            v_cmd_mps: cmd.v_mps,
            omega_cmd_radps: cmd.omega_radps,
            v_actual_mps: robot.twist.v_mps,
            omega_actual_radps: robot.twist.omega_radps,
            b_left: rec.b_left,
            b_right: rec.b_right,
            d_left_m: rec.d_left_m,
            d_right_m: rec.d_right_m,
            h_m: rec.h_m,
            h_next_pred_m: h_next_pred,
            h_true_m: h_true_now,
            clearance_true_m: robot.clearance_m(&world),
            state: rec.state,
            filter_changed: rec.filter_changed,
            condition_held: held,
            in_collision,
            step_us,
        });

        // The goal counts once the (governed) reference has run to its end.
        if let (Some(reference), Some(g)) = (&scenario.reference, goal) {
            if progress.finished(reference) && (robot.pose.position() - g).norm() <= spec.goal_tolerance_m {
                time_to_goal = Some(t + dt);
                break;
            }
        }
    }

    let tracked = scenario.reference.is_some() && steps > 0;
    let summary = RunSummary {
        scenario: spec.name.clone(),
        controller,
        seed,
        steps,
        sim_time_s: steps as f64 * dt,
        collisions,
        min_clearance_m: min_clearance,
        cbf_violations,
        true_cbf_violations: true_violations,
        reached_goal: time_to_goal.is_some(),
        time_to_goal_s: time_to_goal,
        path_length_m: path_length,
        max_tracking_error_m: tracked.then_some(max_err),
        mean_tracking_error_m: tracked.then(|| sum_err / steps as f64),
        mean_step_us: if steps > 0 { sum_us / steps as f64 } else { 0.0 },
        max_step_us: max_us,
        filter_changed_steps: changed_steps,
        steps_by_state: counts,
        min_h_m: min_h,
        final_pose: robot.pose,
    };
    Ok(RunResult {
        summary,
        rows,
        mover_tracks,
        collision_points,
        goal,
        world: world_at_start,
    })
}
