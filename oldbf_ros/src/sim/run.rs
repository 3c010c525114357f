//! The closed loop: simulated LiDAR → controller → simulated robot, with the
//! metrics the CLI prints and the tests assert.
//!
//! Every control period Δt, for every robot: take a scan when the LiDAR is
//! due (stamped with the sim time), compute the nominal command (tracking the
//! governed reference, or the constant command) and run the controller; then
//! integrate the robots and the moving obstacles in physics sub-steps
//! ([`Fleet`]), checking each robot circle against the geometry (and the
//! other robots) exactly at each sub-step. A robot that reaches its goal
//! stops there and stays as an obstacle; the run ends when all have.
//!
//! Two CBF figures are reported. `cbf_violations` counts steps where the DTCBF
//! condition h(k+1) ≥ (1 − γ) h(k), predicted from the scan the controller
//! saw, was false for the command actually sent (the definition's logged
//! condition; with `--controller none` it is evaluated for the raw nominal
//! command). `true_cbf_violations` checks the same inequality on the
//! simulator's exact geometry after the step: it also sees sensor noise,
//! actuator lag and obstacle motion that a static one-step prediction cannot.

use super::body::BodyPolygon;
use super::figures::{InfeasibleCounts, RunFigures, StateCounts};
use super::fleet::{Contact, Fleet, FleetError, CLOSING_SPEED_MPS};
use super::motion_quality::{MeteredStep, MotionMeter};
use super::scenario::{AgentPlan, Scenario};
use super::world::World;
use crate::algo::body::polygon_clearance_after;
use crate::algo::doaa::DoaaState;
use crate::algo::dtcbf::{min_distance, predicted_displacement, InputBox};
use crate::algo::geometry::{Pose2, Twist, Vec2};
use crate::algo::record::{StepRecord, StopCause};
use crate::algo::scan::{classify_range, BeamStatus, RangeKind};
use crate::algo::scan::{LaserMount, LaserScan, ScanHeader};
use crate::algo::select::CriticCosts;
use crate::algo::tracking::TrackingError;
use crate::baselines::{vo_command, DcbfFilter, VoScene};
use crate::cpu_clock::step_clock_us;
use crate::node_core::{NodeCore, NodeSettings, ScanInput};
use serde::Serialize;

/// Which controller closes the loop.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum Controller {
    /// OLDBF barriers + DOAA steering + exact DTCBF filter, with REP 117
    /// range semantics and passive motion safety (ALGORITHM.md §1, §5b).
    Oldbf,
    /// The same with this project's checks beyond the paper off
    /// (`Params::paper_method`: every invalid range free, no braking check,
    /// no evasion, no reverse): the filter as the paper defines it.
    OldbfPaper,
    /// The standard DCBF-QP safety filter (clarabel) on the same points.
    Dcbf,
    /// ORCA velocity obstacles (dodgy_2d) on the tracked obstacles and the scan outline.
    Vo,
    /// The nominal command alone: the tracking command to the reference,
    /// without the way round (`unstuck.enabled: false`, which is part of the
    /// safety layer), in the same input box; the filter still runs, only to
    /// monitor.
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
    /// The DOAA's command before the DTCBF and passive checks (m/s, rad/s).
    pub v_doaa_mps: f64,
    pub omega_doaa_radps: f64,
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
    /// The sent command could brake to rest without a predicted closing contact (§5b).
    pub braking_held: bool,
    /// Why no command met the checks (empty when one did).
    pub infeasible: &'static str,
    /// The level of the relaxation order the command came from (§5c; empty
    /// for stops without a scan and for the paper's decision).
    pub tier: &'static str,
    /// Each critic's weighted cost for the command sent.
    pub costs: CriticCosts,
    /// The command went faster than the upstream or reversed where it did
    /// not (escape or evasion, §5c).
    pub added_motion: bool,
    /// A way round began or ended at this step, and why (§4c; empty: neither).
    pub route_event: &'static str,
    /// No route to the goal: the robot rests (§4c).
    pub no_route: bool,
    /// Beams reading unknown, and held of those.
    pub unknown_beams: usize,
    pub held_beams: usize,
    /// Driving (|v| > 0.02 m/s) while a beam whose true range was near read
    /// unknown and was taken as free.
    pub driven_blind: bool,
    pub in_collision: bool,
    /// Tracks the pipeline considers moving, and those on a collision course
    /// within the look-ahead; least time to collision among them (s, inf if none).
    pub moving_tracks: usize,
    pub threats: usize,
    pub min_ttc_s: f64,
    /// The safety path's compute for the step (scan to command, µs of the
    /// thread's CPU time, `cpu_clock`): the tick less `planner_us`, the
    /// node's own share of it.
    pub step_us: f64,
    /// The way-round work the simulator does in step (the map taking the
    /// scan, a plan when one is due; µs), which the node does in a thread
    /// of its own (§4c); 0 with `plan_beside`.
    pub planner_us: f64,
}

/// One robot's figures.
#[derive(Debug, Clone, Serialize)]
pub struct RobotSummary {
    /// Namespace (empty for a single robot).
    pub name: String,
    #[serde(flatten)]
    pub figures: RunFigures,
    /// Every contact at its onset: time (s), robot position (m) and speed
    /// towards the touched point (m/s).
    pub contacts: Vec<Contact>,
    pub final_pose: Pose2,
}

/// The run's figures; `--json` prints this. The figures are over all robots
/// ([`RunFigures::total`]); `robots` has each.
#[derive(Debug, Clone, Serialize)]
pub struct RunSummary {
    pub scenario: String,
    pub controller: Controller,
    pub seed: u64,
    pub steps: usize,
    pub sim_time_s: f64,
    #[serde(flatten)]
    pub figures: RunFigures,
    /// Mean / 99th percentile / largest wall-clock time of the pipeline per step (µs).
    pub mean_step_us: f64,
    pub p99_step_us: f64,
    pub max_step_us: f64,
    /// The planner's own time per plan, when it ran beside the safety path.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub plan_times: Option<PlanTimes>,
    /// The first robot's final pose.
    pub final_pose: Pose2,
    pub robots: Vec<RobotSummary>,
}

/// One robot's part of a run.
#[derive(Debug, Clone)]
pub struct RobotRun {
    pub name: String,
    pub summary: RobotSummary,
    /// One row per control step until the robot reached its goal.
    pub rows: Vec<StepRow>,
    /// Every contact at its onset.
    pub contacts: Vec<Contact>,
    /// The reference's end, if any.
    pub goal: Option<Vec2>,
}

/// Everything a run produced.
#[derive(Debug, Clone)]
pub struct RunResult {
    pub summary: RunSummary,
    pub robots: Vec<RobotRun>,
    /// Each moving obstacle's centre per control step, and its radius (m).
    pub mover_tracks: Vec<(Vec<Vec2>, f64)>,
    /// The world at the start (for plots).
    pub world: World,
}

/// A robot's controller and its bookkeeping.
struct AgentLoop {
    plan: AgentPlan,
    /// The safety node's logic, as `oldbf_node` runs it (nominal source,
    /// reference following, scan-order and clock rules, the pipeline).
    node: NodeCore,
    dcbf: DcbfFilter,
    /// The scan in hand, as read (m), and each beam's true range (m; +inf: no hit).
    ranges: Vec<f32>,
    truth: Vec<f32>,
    rows: Vec<StepRow>,
    counts: StateCounts,
    cbf_violations: usize,
    true_violations: usize,
    cbf_violations_feasible: usize,
    braking_violations: usize,
    braking_violations_feasible: usize,
    infeasible: InfeasibleCounts,
    blind_steps: usize,
    driven_blind_steps: usize,
    motion: MotionMeter,
    stalled_steps: usize,
    changed_steps: usize,
    max_err: f64,
    sum_err: f64,
    tracked_steps: usize,
    min_h: f64,
    time_to_goal: Option<f64>,
    /// h on the exact geometry when the step's command was chosen.
    h_true_now: f64,
    row: Option<StepRow>,
}

/// How a run is made beyond its scenario.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RunOptions {
    /// Plan the way round beside the safety path, in a thread, as the node
    /// does (§4c): for timing the safety path in the node's mode. The
    /// simulated clock runs faster than the planner's, so routes come late
    /// in simulated time and the run is not reproducible.
    pub plan_beside: bool,
}

/// The planner's own time per plan, in the node's mode (µs).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PlanTimes {
    pub plans: usize,
    pub p50_us: f64,
    pub p99_us: f64,
    pub max_us: f64,
}

/// The `q`-quantile of `v` (sorted in place; NaN when empty).
fn quantile(v: &mut [f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

/// Runs `scenario` in closed loop with `controller`.
pub fn run_scenario(scenario: &Scenario, controller: Controller, seed: u64) -> Result<RunResult, FleetError> {
    run_scenario_with(scenario, controller, seed, RunOptions::default())
}

/// As [`run_scenario`], with `options`.
pub fn run_scenario_with(
    scenario: &Scenario,
    controller: Controller,
    seed: u64,
    options: RunOptions,
) -> Result<RunResult, FleetError> {
    let spec = &scenario.spec;
    let own_params;
    let params = match controller {
        Controller::OldbfPaper => {
            own_params = scenario.params.clone().paper_method();
            &own_params
        }
        Controller::None => {
            // The way round is part of the safety layer: without the layer the
            // robot follows its reference line alone.
            let mut p = scenario.params.clone();
            p.unstuck.enabled = false;
            own_params = p;
            &own_params
        }
        _ => &scenario.params,
    };
    let mut fleet = Fleet::new(scenario, seed)?;
    let world_at_start = fleet.world().clone();

    let dt = params.control.dt_s();
    let substeps = (dt / spec.physics_dt_s).ceil().max(1.0) as usize;
    let h_dt = dt / substeps as f64;
    let lidar = fleet.lidar_spec().clone();
    let scan_period = 1.0 / lidar.rate_hz;
    let (angle_min, angle_inc) = (lidar.angle_min_rad(), lidar.angle_increment_rad());
    let (range_min, range_max) = (lidar.range_min_m as f32, lidar.range_max_m as f32);
    let r = params.robot_radius_m();
    let d_safe = params.barrier.d_safe_m;
    // A polygon footprint: the filter's clearances are its signed distances.
    let polygon = params.footprint.polygon().and_then(Result::ok);
    // h on the exact geometry: from the filter's footprint, the polygon's signed
    // distance to every surface (less its padding), else the centre's distance less r.
    let footprint_body = polygon
        .as_ref()
        .and_then(|fp| Some((BodyPolygon::new(&params.footprint.polygon_m).ok()?, fp.padding_m)));
    let h_true = |fleet: &mut Fleet, i: usize| match &footprint_body {
        None => fleet.distance_from_centre(i) - r - d_safe,
        Some((body, pad)) => fleet.polygon_clearance(i, body) - pad - d_safe,
    };
    let gamma = params.dtcbf.gamma;
    let input_box = InputBox::from_params(params);
    let steps_max = (spec.duration_s / dt).ceil() as usize;
    // Several LiDARs (`lidars:`): each scan goes to the node's merge, as
    // `node.scans` does on a robot; each is placed by its own mount.
    let merged = !spec.lidars.is_empty();
    let lidars: Vec<(ScanHeader, LaserMount)> = (0..fleet.lidars())
        .map(|k| {
            let (l, mount) = fleet.lidar(k);
            let header = ScanHeader {
                stamp_s: 0.0,
                angle_min_rad: l.angle_min_rad(),
                angle_increment_rad: l.angle_increment_rad(),
                range_min_m: l.range_min_m as f32,
                range_max_m: l.range_max_m as f32,
            };
            (header, LaserMount::upright(mount))
        })
        .collect();
    let scan_inputs: Vec<ScanInput> = if merged {
        (0..lidars.len())
            .map(|k| ScanInput {
                topic: format!("lidar{k}"),
                timeout_s: 2.5 * scan_period,
                zero_is_no_return: params.laser.zero_is_no_return,
            })
            .collect()
    } else {
        Vec::new()
    };

    let mut agents: Vec<AgentLoop> = scenario
        .agents
        .iter()
        .map(|plan| AgentLoop {
            plan: plan.clone(),
            // The scenario's reference, else its constant command (none: stand still).
            node: NodeCore::new(
                params.clone(),
                NodeSettings {
                    plan_beside: options.plan_beside,
                    scans: scan_inputs.clone(),
                    ..NodeSettings::for_scenario()
                },
                plan.reference,
            )
            .with_constant(plan.constant.unwrap_or(Twist::ZERO))
            .with_fixed_period()
            .with_planner_clock(step_clock_us)
            .keep_clusters(controller == Controller::Vo),
            dcbf: DcbfFilter::new(),
            ranges: Vec::with_capacity(lidar.beams),
            truth: Vec::with_capacity(lidar.beams),
            rows: Vec::with_capacity(steps_max),
            counts: StateCounts::default(),
            cbf_violations: 0,
            true_violations: 0,
            cbf_violations_feasible: 0,
            braking_violations: 0,
            braking_violations_feasible: 0,
            infeasible: InfeasibleCounts::default(),
            blind_steps: 0,
            driven_blind_steps: 0,
            motion: MotionMeter::new(params, dt),
            stalled_steps: 0,
            changed_steps: 0,
            max_err: 0.0,
            sum_err: 0.0,
            tracked_steps: 0,
            min_h: f64::INFINITY,
            time_to_goal: None,
            h_true_now: f64::NAN,
            row: None,
        })
        .collect();
    let mut mover_tracks: Vec<(Vec<Vec2>, f64)> = fleet
        .world()
        .moving()
        .iter()
        .map(|m| (Vec::with_capacity(steps_max), m.radius_m()))
        .collect();
    let (mut sum_us, mut max_us, mut timed_steps) = (0.0f64, 0.0f64, 0usize);
    let mut all_us = Vec::with_capacity(steps_max);
    let mut next_scan_t = 0.0;
    let mut steps = 0;

    for k in 0..steps_max {
        let t = k as f64 * dt;
        steps = k + 1;
        let scan_due = t + 1e-9 >= next_scan_t;
        if scan_due {
            next_scan_t += scan_period;
        }
        for (i, a) in agents.iter_mut().enumerate() {
            if a.time_to_goal.is_some() {
                fleet.set_cmd(i, Twist::ZERO);
                continue;
            }
            if scan_due && merged {
                for (k, (header, mount)) in lidars.iter().enumerate() {
                    fleet.scan_with(i, k, &mut a.ranges);
                    let scan = LaserScan {
                        header: ScanHeader { stamp_s: t, ..*header },
                        ranges_m: &a.ranges,
                        intensities: &[],
                    };
                    a.node.on_scanner_scan(k, &scan, Ok(Some(*mount)), t);
                }
            } else if scan_due {
                fleet.scan(i, &mut a.ranges);
                a.truth.clear();
                a.truth.extend_from_slice(fleet.scan_truth(i));
                a.node.on_scan(
                    ScanHeader {
                        stamp_s: t,
                        angle_min_rad: angle_min,
                        angle_increment_rad: angle_inc,
                        range_min_m: range_min,
                        range_max_m: range_max,
                    },
                    &a.ranges,
                    &[],
                );
            }
            // Odometry: the simulated robot's exact pose and velocity, fresh every step.
            let robot = &fleet.agents()[i].robot;
            let (pose, v_now) = (robot.pose, robot.twist.v_mps);
            a.node.on_odom(pose, robot.twist, t);
            if let Some(ref_pose) = a.node.reference_pose() {
                let e = TrackingError::between(pose, ref_pose).distance_m();
                a.max_err = a.max_err.max(e);
                a.sum_err += e;
                a.tracked_steps += 1;
            }

            let planned_before_us = a.node.pipeline().planner_us_total();
            let t0_us = step_clock_us();
            let tick = a.node.tick(t);
            let (rec, nominal): (StepRecord, _) = (tick.record, tick.record.nominal);
            let ref_pos = tick
                .reference_pose
                .map_or(Vec2::new(f64::NAN, f64::NAN), |p| p.position());
            // The baselines share the pipeline's perception (points, prediction, tracks)
            // and its rule that no usable scan means a stop; their time includes it.
            let cmd = match controller {
                Controller::Oldbf | Controller::OldbfPaper => tick.cmd,
                Controller::Dcbf if rec.measured() => {
                    let pl = a.node.pipeline();
                    a.dcbf.filter(pl.points(), pl.points_next(), nominal, params).cmd
                }
                Controller::Vo if rec.measured() => {
                    let pl = a.node.pipeline();
                    let scene = VoScene {
                        points: pl.points(),
                        clusters: pl.clusters(),
                        tracker: pl.tracker(),
                        v_now_mps: v_now,
                    };
                    vo_command(&scene, nominal, params).cmd
                }
                Controller::Dcbf | Controller::Vo => tick.cmd,
                // Same input box as the filter, so the comparison is only about safety.
                Controller::None => input_box.clamp(nominal),
            };
            let tick_us = step_clock_us() - t0_us;
            let planner_us = a.node.pipeline().planner_us_total() - planned_before_us;
            let step_us = (tick_us - planner_us).max(0.0);
            // The logged condition, recomputed here from the predicted points for the
            // command actually sent (not taken from the filter's own record).
            let (h_next_pred, held) = if rec.measured() {
                let disp = predicted_displacement(params.dtcbf.prediction, cmd, dt);
                // The same prediction the filter made: static points stay, tracked moving
                // obstacles on a collision course advance by v_o Δt (ALGORITHM.md §5).
                let points_next = a.node.pipeline().points_next();
                let h_next = match &polygon {
                    None => min_distance(points_next, disp) - r - d_safe,
                    Some(fp) => {
                        let (s, c) = (cmd.omega_radps * dt).sin_cos();
                        polygon_clearance_after(fp, points_next, disp, (c, s)) - d_safe
                    }
                };
                (
                    h_next,
                    !rec.h_m.is_finite() || h_next >= (1.0 - gamma) * rec.h_m - TOL_M,
                )
            } else {
                (f64::NAN, true)
            };
            if rec.measured() && !held {
                a.cbf_violations += 1;
                if rec.infeasibility.is_none() {
                    a.cbf_violations_feasible += 1;
                }
            }
            // The braking condition (§5b) for the command actually sent, from the same
            // prediction, whether or not the controller checks it.
            let braking_held = !rec.measured() || a.node.braking_check(cmd).is_none();
            if !braking_held {
                a.braking_violations += 1;
                if rec.infeasibility.is_none() {
                    a.braking_violations_feasible += 1;
                }
            }
            if let Some(r) = rec.infeasibility {
                a.infeasible.add(r);
            }
            if rec.stop_cause == Some(StopCause::SensorBlind) {
                a.blind_steps += 1;
            }
            // Per beam of the one LiDAR (the merged scan's bins are not its beams).
            let driven_blind = !merged
                && rec.measured()
                && cmd.v_mps.abs() > CLOSING_SPEED_MPS
                && driven_blind(
                    &a.ranges,
                    (range_min, range_max),
                    &a.truth,
                    a.node.pipeline().scan_points().status.as_slice(),
                    params,
                );
            a.driven_blind_steps += usize::from(driven_blind);
            a.motion.add(MeteredStep {
                cmd,
                nominal: input_box.clamp(nominal),
                state: rec.state,
                fault_stop: !rec.measured() || rec.stop_cause == Some(StopCause::EStop),
                moving_tracks: rec.tracked_obstacles,
                evading: rec.evading,
            });
            if rec.measured() {
                a.min_h = a.min_h.min(rec.h_m);
            }
            if rec.filter_changed {
                a.changed_steps += 1;
            }
            a.counts.add(rec.state);
            sum_us += step_us;
            all_us.push(step_us);
            max_us = max_us.max(step_us);
            timed_steps += 1;
            fleet.set_cmd(i, cmd);
            a.h_true_now = h_true(&mut fleet, i);
            let boxed = input_box.clamp(nominal);
            a.row = Some(StepRow {
                t_s: t,
                x_m: pose.x,
                y_m: pose.y,
                theta_rad: pose.theta,
                ref_x_m: ref_pos.x,
                ref_y_m: ref_pos.y,
                v_nominal_mps: boxed.v_mps,
                omega_nominal_radps: boxed.omega_radps,
                v_doaa_mps: rec.doaa_cmd.v_mps,
                omega_doaa_radps: rec.doaa_cmd.omega_radps,
                v_cmd_mps: cmd.v_mps,
                omega_cmd_radps: cmd.omega_radps,
                v_actual_mps: f64::NAN,
                omega_actual_radps: f64::NAN,
                b_left: rec.b_left,
                b_right: rec.b_right,
                d_left_m: rec.d_left_m,
                d_right_m: rec.d_right_m,
                h_m: rec.h_m,
                h_next_pred_m: h_next_pred,
                h_true_m: a.h_true_now,
                clearance_true_m: f64::NAN,
                state: rec.state,
                filter_changed: rec.filter_changed,
                condition_held: held,
                braking_held,
                infeasible: rec.infeasibility.map_or("", |r| r.code()),
                tier: rec.tier.map_or("", |t| t.code()),
                costs: rec.costs,
                added_motion: rec.added_motion,
                route_event: rec.route_event.map_or("", |e| e.as_str()),
                no_route: rec.no_route,
                unknown_beams: rec.unknown_beams,
                held_beams: rec.held_beams,
                driven_blind,
                in_collision: false,
                moving_tracks: rec.tracked_obstacles,
                threats: rec.threats,
                min_ttc_s: rec.min_time_to_collision_s,
                step_us,
                planner_us,
            });
        }

        for _ in 0..substeps {
            fleet.step(h_dt);
        }
        for (track, m) in mover_tracks.iter_mut().zip(fleet.world().moving_circles()) {
            track.0.push(m.center);
        }

        for (i, a) in agents.iter_mut().enumerate() {
            let Some(mut row) = a.row.take() else { continue };
            let h_true_next = h_true(&mut fleet, i);
            if a.h_true_now.is_finite() && h_true_next < (1.0 - gamma) * a.h_true_now - TOL_M {
                a.true_violations += 1;
            }
            let sim = &fleet.agents()[i];
            row.v_actual_mps = sim.robot.twist.v_mps;
            row.omega_actual_radps = sim.robot.twist.omega_radps;
            row.clearance_true_m = sim.robot.clearance_m(fleet.world());
            row.in_collision = sim.in_collision;
            if sim.robot.twist.v_mps.abs() < CLOSING_SPEED_MPS {
                a.stalled_steps += 1;
            }
            a.rows.push(row);
            // The goal counts once the (governed) reference has run to its end.
            if let Some(reference) = &a.plan.reference {
                let at_goal = (sim.robot.pose.position() - reference.goal().position()).norm() <= spec.goal_tolerance_m;
                if a.node.reference_finished() && at_goal {
                    a.time_to_goal = Some(t + dt);
                }
            }
        }
        let all_done = agents
            .iter()
            .all(|a| a.plan.reference.is_some() && a.time_to_goal.is_some());
        if all_done {
            break;
        }
    }

    let mut plan_us: Vec<f64> = agents
        .iter()
        .flat_map(|a| a.node.plan_times_us().iter().copied())
        .collect();
    let plan_times = options.plan_beside.then(|| PlanTimes {
        plans: plan_us.len(),
        p50_us: quantile(&mut plan_us, 0.5),
        p99_us: quantile(&mut plan_us, 0.99),
        max_us: quantile(&mut plan_us, 1.0),
    });
    let robots: Vec<RobotRun> = agents
        .into_iter()
        .enumerate()
        .map(|(i, a)| {
            let sim = &fleet.agents()[i];
            let tracked = a.tracked_steps > 0;
            RobotRun {
                name: a.plan.name.clone(),
                summary: RobotSummary {
                    name: a.plan.name.clone(),
                    figures: RunFigures {
                        collisions: sim.collisions,
                        closing_contacts: sim.contacts.iter().filter(|c| c.closing()).count(),
                        passive_contacts: sim.contacts.iter().filter(|c| !c.closing()).count(),
                        min_clearance_m: sim.min_clearance_m,
                        cbf_violations: a.cbf_violations,
                        true_cbf_violations: a.true_violations,
                        cbf_violations_feasible: a.cbf_violations_feasible,
                        braking_violations: a.braking_violations,
                        braking_violations_feasible: a.braking_violations_feasible,
                        infeasible_steps: a.infeasible,
                        blind_steps: a.blind_steps,
                        driven_blind_steps: a.driven_blind_steps,
                        motion: a.motion.figures(),
                        stalled_s: a.stalled_steps as f64 * dt,
                        reached_goal: a.time_to_goal.is_some(),
                        time_to_goal_s: a.time_to_goal,
                        path_length_m: sim.path_length_m,
                        max_tracking_error_m: tracked.then_some(a.max_err),
                        mean_tracking_error_m: tracked.then(|| a.sum_err / a.tracked_steps as f64),
                        filter_changed_steps: a.changed_steps,
                        steps_by_state: a.counts,
                        min_h_m: a.min_h,
                    },
                    contacts: sim.contacts.clone(),
                    final_pose: sim.robot.pose,
                },
                rows: a.rows,
                contacts: sim.contacts.clone(),
                goal: a.plan.reference.map(|r| r.goal().position()),
            }
        })
        .collect();
    let each: Vec<&RunFigures> = robots.iter().map(|r| &r.summary.figures).collect();
    let summary = RunSummary {
        scenario: spec.name.clone(),
        controller,
        seed,
        steps,
        sim_time_s: steps as f64 * dt,
        figures: RunFigures::total(&each),
        mean_step_us: if timed_steps > 0 {
            sum_us / timed_steps as f64
        } else {
            0.0
        },
        p99_step_us: quantile(&mut all_us, 0.99),
        max_step_us: max_us,
        plan_times,
        final_pose: robots[0].summary.final_pose,
        robots: robots.iter().map(|r| r.summary.clone()).collect(),
    };
    Ok(RunResult {
        summary,
        robots,
        mover_tracks,
        world: world_at_start,
    })
}

/// Whether a beam that read unknown (NaN, below range_min) while something
/// was truly within r + d_act along it was taken as free: the pipeline
/// neither held its last reading nor stopped for blindness. `ranges_m` as
/// read, `truth` the true ranges, (range_min, range_max) the sensor's (m).
fn driven_blind(
    ranges_m: &[f32],
    (range_min_m, range_max_m): (f32, f32),
    truth: &[f32],
    status: &[BeamStatus],
    p: &crate::algo::Params,
) -> bool {
    let near = (p.robot_radius_m() + p.barrier.d_act_m()) as f32;
    let zero_free = p.laser.zero_is_no_return;
    ranges_m.iter().zip(truth).zip(status).any(|((&r, &t), &s)| {
        t < near
            && matches!(s, BeamStatus::Free | BeamStatus::Unknown)
            && classify_range(r, range_min_m, range_max_m, zero_free) == RangeKind::Unknown
    })
}
