//! oldbf_sim_node: the built-in simulator as a ROS node, standing in for the
//! robot (or several robots) in real time.
//!
//! Private parameters: `~scenario` (path to a scenario file, required),
//! `~seed` (LiDAR noise; default the scenario's), `~odom_rate_hz` (50),
//! `~cmd_timeout_s` (0.5: a base with no fresh command stops, as real bases do),
//! `~motion_source`: `cmd_vel` (default: the robot follows `cmd_vel` with its
//! preset's limits) or `odom` (the robot moves at the twist that `odom` reports,
//! as published by can_bridge_node from the motor drive's wheel feedback: the
//! loop then closes through CAN; the sim publishes no `odom` of its own and
//! only base_link → laser on /tf).
//!
//! Per robot (names relative to the node's namespace; a multi-robot scenario
//! puts each robot under its name, e.g. `robot1/scan`): publishes `scan`
//! (sensor_msgs/LaserScan at the scenario's LiDAR rate), `odom`
//! (nav_msgs/Odometry, in a world-aligned odom frame) and `/tf`
//! (odom → base_link → laser); subscribes `cmd_vel`. Node-wide: publishes
//! `~world_markers` (walls, obstacles, moving obstacles), `/diagnostics`
//! (collisions, least clearance, goal per robot) and `~summary`
//! (std_msgs/String, latched, JSON, 1 Hz; `"done": true` once every robot
//! reached its goal or the scenario's duration is over). Collisions are also
//! logged when they begin.
//!
//! A robot counts as at its goal within the scenario's `goal_tolerance_m` of
//! the end of its reference, once 90% of the reference's duration has
//! passed (the node's governed reference can only run later, never earlier).

use super::convert::{prefixed, quaternion_from_yaw, time_from_s, twist_from_msg};
use super::lifecycle::{self, now_s};
use super::msg::{
    diagnostic_msgs::{DiagnosticArray, DiagnosticStatus, KeyValue},
    geometry_msgs, nav_msgs, sensor_msgs, std_msgs, tf2_msgs,
    visualization_msgs::{Marker, MarkerArray},
};
use super::params::{read_param as param, RosParamError};
use super::RosError;
use crate::algo::geometry::{Pose2, Twist};
use crate::config::ConfigError;
use crate::resubscribe::Resubscribe;
use crate::sim::fleet::{Fleet, FleetError};
use crate::sim::scenario::Scenario;
use oldbf::config::{Checker, Interval};
use serde::Serialize;
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::Duration;

#[derive(Debug, Clone, Serialize)]
struct RobotResult {
    name: String,
    collisions: usize,
    min_clearance_m: f64,
    reached_goal: bool,
    time_to_goal_s: Option<f64>,
    path_length_m: f64,
}

#[derive(Debug, Clone, Serialize)]
struct Summary {
    scenario: String,
    done: bool,
    time_s: f64,
    collisions: usize,
    reached_goal: bool,
    robots: Vec<RobotResult>,
}

struct RobotIo {
    frame_prefix: String,
    /// One per LiDAR: `scan`, or `scan_0`, `scan_1`, … with a scenario's `lidars`.
    scans: Vec<rosrust::Publisher<sensor_msgs::LaserScan>>,
    /// None when the odometry comes from elsewhere (motion_source odom).
    odom: Option<rosrust::Publisher<nav_msgs::Odometry>>,
    /// `cmd_vel`, or `odom` with motion_source odom.
    motion_topic: String,
    _motion_sub: Option<rosrust::Subscriber>,
    /// rosrust does not retry a failed connection: a link can stay dead and
    /// its robot never move, so a motion source quiet for a while is
    /// subscribed again.
    motion_retry: Resubscribe,
}

/// Robot `i`'s motion source: each message's twist and arrival time into `cmds[i]`.
fn subscribe_motion(
    topic: &str,
    from_odom: bool,
    i: usize,
    cmds: &Arc<Mutex<Vec<(Twist, f64)>>>,
) -> Result<rosrust::Subscriber, RosError> {
    let c = cmds.clone();
    if from_odom {
        rosrust::subscribe(topic, 1, move |m: nav_msgs::Odometry| {
            let t = Twist::new(m.twist.twist.linear.x, m.twist.twist.angular.z);
            c.lock().expect("cmd lock")[i] = (t, now_s());
        })
    } else {
        rosrust::subscribe(topic, 1, move |m: geometry_msgs::Twist| {
            c.lock().expect("cmd lock")[i] = (twist_from_msg(&m), now_s());
        })
    }
    .map_err(RosError::doing(format!(
        "subscribing to the motion source of robot {i}"
    )))
}

fn transform(parent: &str, child: &str, stamp: rosrust::Time, pose: Pose2) -> geometry_msgs::TransformStamped {
    let mut t = geometry_msgs::TransformStamped::default();
    t.header.frame_id = parent.into();
    t.header.stamp = stamp;
    t.child_frame_id = child.into();
    t.transform.translation.x = pose.x;
    t.transform.translation.y = pose.y;
    t.transform.rotation = quaternion_from_yaw(pose.theta);
    t
}

fn world_markers(fleet: &Fleet, frame: &str, stamp: rosrust::Time) -> MarkerArray {
    let mut base = Marker::default();
    base.header.frame_id = frame.into();
    base.header.stamp = stamp;
    base.ns = "world".into();
    base.action = Marker::ADD as i32;
    base.pose.orientation.w = 1.0;
    let mut walls = base.clone();
    walls.id = 0;
    walls.type_ = Marker::LINE_LIST as i32;
    walls.scale.x = 0.04;
    walls.color = std_msgs::ColorRGBA {
        r: 0.8,
        g: 0.8,
        b: 0.8,
        a: 1.0,
    };
    for s in fleet.world().segments() {
        for p in [s.a, s.b] {
            walls.points.push(geometry_msgs::Point { x: p.x, y: p.y, z: 0.0 });
        }
    }
    let mut v = vec![walls];
    let discs = fleet
        .world()
        .circles()
        .iter()
        .map(|c| (*c, false))
        .chain(fleet.world().moving_circles().map(|c| (c, true)));
    for (i, (c, moving)) in discs.enumerate() {
        let mut m = base.clone();
        m.id = 1 + i as i32;
        m.type_ = Marker::CYLINDER as i32;
        m.pose.position = geometry_msgs::Point {
            x: c.center.x,
            y: c.center.y,
            z: 0.15,
        };
        m.scale = geometry_msgs::Vector3 {
            x: 2.0 * c.radius_m,
            y: 2.0 * c.radius_m,
            z: 0.3,
        };
        m.color = if moving {
            std_msgs::ColorRGBA {
                r: 0.7,
                g: 0.3,
                b: 0.9,
                a: 0.9,
            }
        } else {
            std_msgs::ColorRGBA {
                r: 0.6,
                g: 0.6,
                b: 0.6,
                a: 0.9,
            }
        };
        v.push(m);
    }
    MarkerArray { markers: v }
}

/// Why the node cannot run: a private parameter, the scenario, or a ROS call.
#[derive(Debug, thiserror::Error)]
enum SimNodeError {
    #[error(transparent)]
    Param(#[from] RosParamError),
    #[error("the private parameter ~scenario (a scenario file) is required")]
    NoScenario,
    #[error(transparent)]
    Scenario(#[from] ConfigError),
    #[error(transparent)]
    Fleet(#[from] FleetError),
    #[error(transparent)]
    Ros(#[from] RosError),
}

/// Runs the node; returns the process exit status.
pub fn run() -> i32 {
    super::logging::init();
    let stop = lifecycle::install_signal_handler();
    let name = lifecycle::node_name("oldbf_sim_node");
    if !lifecycle::connect(&name, &stop) {
        return 0;
    }
    match run_connected(&stop) {
        Ok(()) => 0,
        Err(e) => {
            log::error!("{}: {e}", rosrust::name());
            std::thread::sleep(Duration::from_millis(200));
            super::leave_master::leave_master();
            rosrust::shutdown();
            2
        }
    }
}

fn run_connected(stop: &lifecycle::StopFlag) -> Result<(), SimNodeError> {
    let path: String = param("~scenario")?.ok_or(SimNodeError::NoScenario)?;
    let scenario = Scenario::load(Path::new(&path), None)?;
    let seed: u64 = param::<i64>("~seed")?.map_or(scenario.spec.seed, |s| s as u64);
    let odom_rate_hz: f64 = param("~odom_rate_hz")?.unwrap_or(50.0);
    let cmd_timeout_s: f64 = param("~cmd_timeout_s")?.unwrap_or(0.5);
    let motion_source: String = param("~motion_source")?.unwrap_or_else(|| "cmd_vel".into());
    let from_odom = motion_source == "odom";
    let mut c = Checker::new();
    c.rule(
        from_odom || motion_source == "cmd_vel",
        "~motion_source",
        format_args!("{motion_source:?}"),
        "cmd_vel or odom",
    );
    c.range(
        "~odom_rate_hz",
        odom_rate_hz,
        Interval::open_closed(0.0, 1000.0).unit("Hz"),
    );
    c.range(
        "~cmd_timeout_s",
        cmd_timeout_s,
        Interval::open_closed(0.0, 60.0).unit("s"),
    );
    c.finish()
        .map_err(|errors| ConfigError::invalid("private parameters", errors))?;
    let mut fleet = Fleet::new(&scenario, seed)?;
    let n = fleet.agents().len();
    let multi = n > 1;
    let world_frame = if multi { "map" } else { "odom" };

    let cmds: Arc<Mutex<Vec<(Twist, f64)>>> = Arc::new(Mutex::new(vec![(Twist::ZERO, f64::NEG_INFINITY); n]));
    // (topic, frame) of each LiDAR: one as `scan` from `laser`, several as
    // `scan_k` from `laser_k` (the node merges them: node_config reads the
    // scenario's `lidars` into node.scans).
    let lidar_names: Vec<(String, String)> = if scenario.spec.lidars.is_empty() {
        vec![("scan".into(), "laser".into())]
    } else {
        (0..fleet.lidars())
            .map(|k| (format!("scan_{k}"), format!("laser_{k}")))
            .collect()
    };
    let mut io = Vec::with_capacity(n);
    let started_s = now_s();
    for (i, agent) in fleet.agents().iter().enumerate() {
        let topic = |t: &str| {
            if agent.name.is_empty() {
                t.to_string()
            } else {
                format!("{}/{t}", agent.name)
            }
        };
        let motion_topic = topic(if from_odom { "odom" } else { "cmd_vel" });
        let odom = if from_odom {
            None
        } else {
            Some(rosrust::publish(&topic("odom"), 5).map_err(RosError::doing("advertising odom"))?)
        };
        io.push(RobotIo {
            frame_prefix: agent.name.clone(),
            scans: (0..lidar_names.len())
                .map(|k| {
                    rosrust::publish(&topic(&lidar_names[k].0), 5).map_err(RosError::doing("advertising a scan topic"))
                })
                .collect::<Result<_, _>>()?,
            odom,
            _motion_sub: Some(subscribe_motion(&motion_topic, from_odom, i, &cmds)?),
            motion_retry: Resubscribe::standard(started_s),
            motion_topic,
        });
    }
    let tf_pub = rosrust::publish::<tf2_msgs::TFMessage>("/tf", 50).map_err(RosError::doing("advertising /tf"))?;
    let markers_pub =
        rosrust::publish::<MarkerArray>("~world_markers", 2).map_err(RosError::doing("advertising ~world_markers"))?;
    let diag_pub = rosrust::publish::<DiagnosticArray>("/diagnostics", 10).map_err(RosError::doing("diagnostics"))?;
    let mut summary_pub = rosrust::publish::<std_msgs::String>("~summary", 1).map_err(RosError::doing("~summary"))?;
    summary_pub.set_latching(true);

    let lidar = fleet.lidar_spec().clone();
    let physics_dt = scenario.spec.physics_dt_s;
    let scan_period = 1.0 / lidar.rate_hz;
    let odom_period = 1.0 / odom_rate_hz;
    log::info!(
        "{}: simulating {} ({} robot{}), LiDAR {} beams at {} Hz, physics every {} s",
        rosrust::name(),
        scenario.spec.name,
        n,
        if multi { "s" } else { "" },
        lidar.beams,
        lidar.rate_hz,
        physics_dt
    );

    let mut ranges = Vec::with_capacity(lidar.beams);
    let (mut next_scan, mut next_odom, mut next_slow) = (0.0, 0.0, 0.0);
    let mut reported_collisions = vec![0usize; n];
    let mut time_to_goal: Vec<Option<f64>> = vec![None; n];
    let mut done = false;
    let rate = rosrust::rate(1.0 / physics_dt);
    while rosrust::is_ok() && !stop.is_set() {
        let now = now_s();
        let t = fleet.time_s();
        {
            let cmds = cmds.lock().expect("cmd lock");
            for (i, &(cmd, at)) in cmds.iter().enumerate() {
                let fresh = now - at <= cmd_timeout_s;
                let twist = if fresh && cmd.is_finite() { cmd } else { Twist::ZERO };
                if from_odom {
                    fleet.set_measured_velocity(i, twist);
                } else {
                    fleet.set_cmd(i, twist);
                }
            }
        }
        for (i, robot) in io.iter_mut().enumerate() {
            let at = cmds.lock().expect("cmd lock")[i].1;
            if robot.motion_retry.due(now, at.is_finite().then_some(at)) {
                log::warn!("no message on {} for a while: subscribing again", robot.motion_topic);
                robot._motion_sub = super::resubscribe(robot._motion_sub.take(), &|| {
                    subscribe_motion(&robot.motion_topic, from_odom, i, &cmds)
                });
            }
        }
        fleet.step(physics_dt);
        let stamp = time_from_s(now);

        for (i, a) in fleet.agents().iter().enumerate() {
            if a.collisions > reported_collisions[i] {
                let p = a.robot.pose;
                log::warn!(
                    "COLLISION of robot {:?} at ({:.2}, {:.2}) m, t = {t:.1} s",
                    a.name,
                    p.x,
                    p.y
                );
                reported_collisions[i] = a.collisions;
            }
            if let Some(reference) = &scenario.agents[i].reference {
                let near =
                    (a.robot.pose.position() - reference.goal().position()).norm() <= scenario.spec.goal_tolerance_m;
                if time_to_goal[i].is_none() && near && t >= 0.9 * reference.duration_s {
                    log::info!("robot {:?} reached its goal at t = {t:.1} s", a.name);
                    time_to_goal[i] = Some(t);
                }
            }
        }

        if t + 1e-9 >= next_scan {
            next_scan += scan_period;
            for (i, robot) in io.iter().enumerate() {
                for (k, (_, frame)) in lidar_names.iter().enumerate() {
                    fleet.scan_with(i, k, &mut ranges);
                    let (lidar, _) = fleet.lidar(k);
                    let mut m = sensor_msgs::LaserScan {
                        angle_min: lidar.angle_min_rad(),
                        angle_increment: lidar.angle_increment_rad(),
                        angle_max: lidar.angle_min_rad()
                            + lidar.angle_increment_rad() * (lidar.beams.saturating_sub(1)) as f32,
                        time_increment: 0.0,
                        scan_time: scan_period as f32,
                        range_min: lidar.range_min_m as f32,
                        range_max: lidar.range_max_m as f32,
                        ranges: ranges.clone(),
                        ..Default::default()
                    };
                    m.header.stamp = stamp;
                    m.header.frame_id = prefixed(&robot.frame_prefix, frame);
                    let _ = robot.scans[k].send(m);
                }
            }
        }
        if t + 1e-9 >= next_odom {
            next_odom += odom_period;
            let mut tfs = Vec::with_capacity(3 * n);
            for (i, robot) in io.iter().enumerate() {
                let a = &fleet.agents()[i];
                let (odom_frame, base) = (
                    prefixed(&robot.frame_prefix, "odom"),
                    prefixed(&robot.frame_prefix, "base_link"),
                );
                let mut m = nav_msgs::Odometry::default();
                m.header.stamp = stamp;
                m.header.frame_id = odom_frame.clone();
                m.child_frame_id = base.clone();
                m.pose.pose.position.x = a.robot.pose.x;
                m.pose.pose.position.y = a.robot.pose.y;
                m.pose.pose.orientation = quaternion_from_yaw(a.robot.pose.theta);
                m.twist.twist.linear.x = a.robot.twist.v_mps;
                m.twist.twist.angular.z = a.robot.twist.omega_radps;
                if let Some(publisher) = &robot.odom {
                    let _ = publisher.send(m);
                    tfs.push(transform(&odom_frame, &base, stamp, a.robot.pose));
                }
                for (k, (_, frame)) in lidar_names.iter().enumerate() {
                    let (_, mount) = fleet.lidar(k);
                    tfs.push(transform(&base, &prefixed(&robot.frame_prefix, frame), stamp, mount));
                }
                if multi {
                    tfs.push(transform(world_frame, &odom_frame, stamp, Pose2::default()));
                }
            }
            let _ = tf_pub.send(tf2_msgs::TFMessage { transforms: tfs });
        }
        if t + 1e-9 >= next_slow {
            next_slow += 1.0;
            let _ = markers_pub.send(world_markers(&fleet, world_frame, stamp));
            let robots: Vec<RobotResult> = fleet
                .agents()
                .iter()
                .enumerate()
                .map(|(i, a)| RobotResult {
                    name: a.name.clone(),
                    collisions: a.collisions,
                    min_clearance_m: a.min_clearance_m,
                    reached_goal: time_to_goal[i].is_some(),
                    time_to_goal_s: time_to_goal[i],
                    path_length_m: a.path_length_m,
                })
                .collect();
            let all_goals =
                scenario.agents.iter().all(|a| a.reference.is_some()) && time_to_goal.iter().all(Option::is_some);
            if !done && (all_goals || t >= scenario.spec.duration_s) {
                done = true;
                log::info!(
                    "{}: scenario finished at t = {t:.1} s (goals {})",
                    scenario.spec.name,
                    if all_goals { "reached" } else { "not all reached" }
                );
            }
            let summary = Summary {
                scenario: scenario.spec.name.clone(),
                done,
                time_s: t,
                collisions: robots.iter().map(|r| r.collisions).sum(),
                reached_goal: all_goals,
                robots: robots.clone(),
            };
            let json = serde_json::to_string(&summary).unwrap_or_default();
            let _ = summary_pub.send(std_msgs::String { data: json });
            let mut diag = DiagnosticArray::default();
            diag.header.stamp = stamp;
            for r in &robots {
                diag.status.push(DiagnosticStatus {
                    level: if r.collisions > 0 {
                        DiagnosticStatus::ERROR
                    } else {
                        DiagnosticStatus::OK
                    },
                    name: format!(
                        "{}: robot {}",
                        rosrust::name(),
                        if r.name.is_empty() { "0" } else { &r.name }
                    ),
                    message: format!(
                        "{} collision(s), least clearance {:.3} m, goal {}",
                        r.collisions,
                        r.min_clearance_m,
                        if r.reached_goal { "reached" } else { "not reached" }
                    ),
                    hardware_id: "simulator".into(),
                    values: vec![
                        KeyValue {
                            key: "collisions".into(),
                            value: r.collisions.to_string(),
                        },
                        KeyValue {
                            key: "min_clearance_m".into(),
                            value: format!("{:.3}", r.min_clearance_m),
                        },
                        KeyValue {
                            key: "reached_goal".into(),
                            value: r.reached_goal.to_string(),
                        },
                        KeyValue {
                            key: "sim_time_s".into(),
                            value: format!("{t:.1}"),
                        },
                    ],
                });
            }
            let _ = diag_pub.send(diag);
        }
        rate.sleep();
    }
    super::leave_master::leave_master();
    rosrust::shutdown();
    Ok(())
}
