//! oldbf_node: LaserScan in, safe cmd_vel out, as each scan arrives.
//!
//! Topics (relative names, so `__ns:=` and remapping work):
//! * subscribes `scan` (sensor_msgs/LaserScan), `odom` (nav_msgs/Odometry,
//!   optional), `cmd_vel_in` (geometry_msgs/Twist, optional), `e_stop`
//!   (std_msgs/Bool; true latches a stop; with `node/e_stop_timeout_s` above
//!   0 a silent publisher engages it too); `scan` and `odom` are subscribed
//!   again when quiet for 3 s (then 6, 12, … up to 30 s apart): rosrust does
//!   not retry a connection to a publisher that failed
//!   ([`crate::resubscribe`]);
//! * publishes `cmd_vel` (geometry_msgs/Twist) on every scan and every
//!   upstream command as it arrives, and from a watchdog whenever nothing
//!   went out for a control period (so a stale scan still turns into a stop),
//!   `~state` (oldbf_ros/BarrierState), `~markers`
//!   (visualization_msgs/MarkerArray) and `/diagnostics` (1 Hz);
//! * services `~enable` (std_srvs/SetBool: false = pass-through, reported,
//!   lapsing after `node/disable_timeout_s` unless renewed when that is
//!   above 0) and `~reset_e_stop` (std_srvs/Trigger);
//! * dynamic_reconfigure (`~set_parameters`, `~parameter_descriptions`,
//!   `~parameter_updates`) for the parameters of
//!   [`crate::reconfigure::RECONFIGURABLE`] (see [`super::reconfigure`]).
//!
//! The decisions are all in [`crate::node_core`]; this file converts and
//! publishes. A bad parameter: a message naming it, exit status 2.
//! SIGINT/SIGTERM: a last zero command, then exit 0. The master lost: logged,
//! the node runs on (connected topics flow peer to peer). The master back as
//! a new run (restarted): logged, a last zero command, exit status 1, as
//! rosrust cannot register again. The watchdog is paced on the monotonic
//! clock (see [`super::pacer`]), so a wall-clock step cannot silence it.

use super::convert::{odom_from_msg, scan_header, time_from_s, time_to_s, twist_from_msg, twist_to_msg};
use super::diagnostics::{diagnostics, Activity, Sensors};
use super::lifecycle::{self, now_s, MasterHealth, MasterWatch};
use super::markers::{markers, route_markers};
use super::msg::{
    diagnostic_msgs::DiagnosticArray, geometry_msgs, nav_msgs, oldbf_ros::BarrierState, sensor_msgs, std_msgs,
    std_srvs, tf2_msgs, visualization_msgs::MarkerArray,
};
use super::pacer::Pacer;
use super::params::{private_namespace, read_param, RosParamError};
use super::reconfigure as ros_reconfigure;
use super::RosError;
use crate::algo::select::Critic;
use crate::algo::LaserMount;
use crate::config::ConfigError;
use crate::node_config::{node_config_from_params, with_costmap_footprint, NodeConfig};
use crate::node_core::{LaserPoseSource, NodeCore, NodeSettings, Tick, WATCHDOG_POLLS_PER_PERIOD};
use crate::reconfigure;
use crate::resubscribe::Resubscribe;
use crate::tf_tree::{describe_mount, place_laser, TfTree};
use std::sync::{Arc, Mutex};
use std::time::Duration;

fn state_msg(frame: &str, now: f64, tick: &Tick) -> BarrierState {
    let r = &tick.record;
    let mut m = BarrierState {
        scan_stamp: time_from_s(tick.scan_stamp_s),
        d_left: r.d_left_m,
        d_right: r.d_right_m,
        d_min: r.d_min_m,
        d_front: r.d_front_m,
        b_left: r.b_left,
        b_right: r.b_right,
        b_velocity: r.b_velocity,
        h: r.h_m,
        h_next: r.h_next_m,
        doaa_state: r.state.code(),
        doaa_state_name: r.state.as_str().into(),
        filter_enabled: tick.filter_enabled,
        filter_active: r.filter_changed,
        condition_held: r.condition_held,
        braking_held: r.braking_held,
        infeasible: r.infeasibility.map(|i| i.code().to_string()).unwrap_or_default(),
        tier: r.tier.map(|t| t.code().to_string()).unwrap_or_default(),
        added_motion: r.added_motion,
        route_event: r.route_event.map(|e| e.as_str().to_string()).unwrap_or_default(),
        no_route: r.no_route,
        critic_names: Critic::ALL.iter().map(|c| c.name().to_string()).collect(),
        critic_costs: r.costs.0.to_vec(),
        e_stop: tick.e_stop,
        stop_reason: tick.stop_reason(),
        nominal: twist_to_msg(r.nominal),
        cmd: twist_to_msg(tick.cmd),
        beams: r.beams as u32,
        valid_beams: r.valid_beams as u32,
        unknown_beams: r.unknown_beams as u32,
        held_beams: r.held_beams as u32,
        unknown_front: r.unknown_front_fraction,
        moving_obstacles: r.tracked_obstacles as u32,
        threats: r.threats as u32,
        ..Default::default()
    };
    m.header.frame_id = frame.into();
    m.header.stamp = time_from_s(now);
    m
}

/// Why the node's configuration could not be loaded (the text is theirs).
#[derive(Debug, thiserror::Error)]
enum LoadConfigError {
    #[error(transparent)]
    Params(#[from] RosParamError),
    #[error(transparent)]
    Config(#[from] ConfigError),
}

fn load_config() -> Result<NodeConfig, LoadConfigError> {
    let source = format!("ROS parameters of {}", rosrust::name());
    let mut ns = private_namespace()?;
    // node.footprint_param: a footprint in costmap_2d's format kept elsewhere
    // on the server (move_base's), read once here.
    let name = ns
        .get("node")
        .and_then(|n| n.get("footprint_param"))
        .and_then(serde_yaml::Value::as_str)
        .unwrap_or("")
        .to_string();
    if !name.is_empty() {
        let value = read_param::<serde_yaml::Value>(&name)?;
        with_costmap_footprint(&mut ns, &name, value.as_ref(), &source)?;
    }
    Ok(node_config_from_params(ns, &source)?)
}

/// Runs the node; returns the process exit status.
pub fn run() -> i32 {
    super::logging::init();
    let stop = lifecycle::install_signal_handler();
    let name = lifecycle::node_name("oldbf_node");
    if !lifecycle::connect(&name, &stop) {
        return 0;
    }
    let config = match load_config() {
        Ok(c) => c,
        Err(e) => {
            log::error!("{e}");
            log::error!("{}: invalid parameters, exiting", rosrust::name());
            std::thread::sleep(Duration::from_millis(200)); // let rosout carry the message
            super::leave_master::leave_master();
            rosrust::shutdown();
            return 2;
        }
    };
    match run_connected(config, &stop) {
        Ok(true) => 0,
        Ok(false) => 1,
        Err(e) => {
            log::error!("{}: {e}", rosrust::name());
            super::leave_master::leave_master();
            rosrust::shutdown();
            1
        }
    }
}

/// Everything a tick touches, behind one lock: the scan and upstream-command
/// callbacks and the watchdog all tick through [`Node::tick`], so outputs
/// never interleave and each goes out in the order it was computed.
struct Node {
    core: NodeCore,
    cmd_pub: rosrust::Publisher<geometry_msgs::Twist>,
    state_pub: rosrust::Publisher<BarrierState>,
    markers_pub: rosrust::Publisher<MarkerArray>,
    diag_pub: rosrust::Publisher<DiagnosticArray>,
    settings: NodeSettings,
    name: String,
    activity: Activity,
    last_diag: f64,
    /// The stop status last logged, and whether the robot was sent motion
    /// (None: nothing logged yet, so the first tick's is).
    last_status: Option<(Option<&'static str>, bool)>,
    /// `hardware_id` of the diagnostics: `node/hardware_id`, or when that is
    /// empty the latest scan's frame_id, or the node's name before a scan.
    hardware_id: String,
    /// When a scan (per scan topic) and odometry last arrived (s, [`mono_s`]).
    scan_heard: Vec<Option<f64>>,
    odom_heard: Option<f64>,
    /// The odometry's frame_id (the frame routes are planned in), and the
    /// stamp of the last route drawn (s).
    odom_frame: String,
    route_drawn_s: f64,
    /// Set on the way out: no tick publishes after the last zero command.
    stopping: bool,
    /// Where each scan topic's laser was last placed, or why it could not be
    /// (`node/laser_pose`): diagnostics values, logged when they change.
    laser_pose_lines: Vec<String>,
    /// Per scan topic: the frame and mount its last scan was placed with.
    placed_last: Vec<Option<(String, LaserMount)>>,
}

impl Node {
    /// One tick at `now`: the command first (what the robot waits for), then
    /// ~state, ~markers, and /diagnostics once a second.
    fn tick(&mut self, now: f64) {
        if self.stopping {
            return;
        }
        let tick = self.core.tick(now);
        if let Err(e) = self.cmd_pub.send(twist_to_msg(tick.cmd)) {
            log::warn!("publishing cmd_vel: {e}");
        }
        let _ = self.state_pub.send(state_msg(&self.settings.base_frame, now, &tick));
        if self.settings.publish_markers {
            let yaw = self.core.odom().map(|o| o.pose.theta);
            let _ = self.markers_pub.send(markers(
                &self.settings.base_frame,
                time_from_s(now),
                &tick,
                self.core.threats(),
                self.core.params(),
                yaw,
            ));
            // The way round, when there is one to draw: a new plan or a new map snapshot.
            let cells = self.core.take_map_cells();
            let made_s = self.core.route().map_or(f64::NAN, |u| u.made_s);
            let new_plan = made_s.to_bits() != self.route_drawn_s.to_bits();
            if !self.odom_frame.is_empty() && (new_plan || cells.is_some()) {
                self.route_drawn_s = made_s;
                let following = tick.record.state == crate::algo::DoaaState::Follow;
                let _ = self.markers_pub.send(route_markers(
                    &self.odom_frame,
                    time_from_s(now),
                    self.core.route(),
                    following,
                    cells.as_deref(),
                ));
            }
        }
        self.activity.ticked(now, &tick);
        // |Δ| so that a clock stepped back does not silence the diagnostics.
        if (now - self.last_diag).abs() >= 1.0 {
            let hardware_id = if self.hardware_id.is_empty() {
                &self.name
            } else {
                &self.hardware_id
            };
            let _ = self.diag_pub.send(diagnostics(
                &self.name,
                hardware_id,
                time_from_s(now),
                now,
                &tick,
                &self.activity,
                &Sensors {
                    laser_poses: &self.laser_pose_lines,
                    scanners: &self.core.scanner_states(now),
                },
            ));
            self.last_diag = now;
        }
        // Log changes of stop status once (by kind: the details change every tick).
        let code = tick
            .scan_fault
            .map(|f| f.code())
            .or(tick.record.stop_cause.map(|c| c.code()));
        let status = (code, tick.cmd != crate::algo::Twist::ZERO);
        if self.last_status != Some(status) {
            match tick.record.stop_cause {
                Some(_) => log::warn!("{}", tick.status_line()),
                None => log::info!("{}", tick.status_line()),
            }
            self.last_status = Some(status);
        }
    }
}

/// Seconds on the monotonic clock since the node started: for timing that
/// must not follow the ROS clock (simulated time stands still at 0 until
/// /clock arrives, and may stop altogether).
fn mono_s() -> f64 {
    static START: std::sync::OnceLock<std::time::Instant> = std::sync::OnceLock::new();
    START.get_or_init(std::time::Instant::now).elapsed().as_secs_f64()
}

/// The node's lock. A panic elsewhere while holding it leaves consistent
/// data (each step is one call): carry on rather than take the node down.
fn lock(n: &Mutex<Node>) -> std::sync::MutexGuard<'_, Node> {
    n.lock().unwrap_or_else(|p| p.into_inner())
}

/// Ok(true): stopped by a signal; Ok(false): the master restarted.
fn run_connected(config: NodeConfig, stop: &lifecycle::StopFlag) -> Result<bool, RosError> {
    let params = config.params.clone();
    let settings = config.settings.clone();
    let mut core = NodeCore::new(config.params, config.settings, config.reference);
    if let Some(c) = config.constant {
        core = core.with_constant(c);
    }
    let cmd_pub =
        rosrust::publish::<geometry_msgs::Twist>("cmd_vel", 1).map_err(RosError::doing("advertising cmd_vel"))?;
    let node = Arc::new(Mutex::new(Node {
        core,
        cmd_pub: cmd_pub.clone(),
        state_pub: rosrust::publish("~state", 1).map_err(RosError::doing("advertising ~state"))?,
        markers_pub: rosrust::publish("~markers", 1).map_err(RosError::doing("advertising ~markers"))?,
        diag_pub: rosrust::publish("/diagnostics", 10).map_err(RosError::doing("advertising /diagnostics"))?,
        settings: settings.clone(),
        name: rosrust::name(),
        hardware_id: settings.hardware_id.clone(),
        activity: Activity::default(),
        last_diag: f64::NEG_INFINITY,
        last_status: None,
        scan_heard: Vec::new(),
        odom_heard: None,
        odom_frame: String::new(),
        route_drawn_s: f64::NAN,
        stopping: false,
        laser_pose_lines: Vec::new(),
        placed_last: Vec::new(),
    }));
    // tf, on the global topics whatever the node's namespace (as tf2 does).
    let tf = Arc::new(Mutex::new(TfTree::default()));
    let mut tf_subs = Vec::new();
    if settings.laser_pose != LaserPoseSource::Yaml {
        for (topic, fixed) in [("/tf", false), ("/tf_static", true)] {
            let tree = tf.clone();
            let sub = rosrust::subscribe(topic, 100, move |m: tf2_msgs::TFMessage| {
                let mut tree = tree.lock().unwrap_or_else(|p| p.into_inner());
                for t in &m.transforms {
                    let (v, q) = (&t.transform.translation, &t.transform.rotation);
                    // A refused transform is left out: lookups through it then fail, naming the frames.
                    let _ = tree.set(
                        &t.header.frame_id,
                        &t.child_frame_id,
                        time_to_s(t.header.stamp),
                        [v.x, v.y, v.z],
                        [q.x, q.y, q.z, q.w],
                        fixed,
                    );
                }
            })
            .map_err(RosError::doing(format!("subscribing to {topic}")))?;
            tf_subs.push(sub);
        }
    }

    // A scan is filtered, and its command published, as it arrives. With
    // several scanners (node/scans) each is merged with the others' latest,
    // and a merged scan made is filtered.
    let topics: Vec<String> = if settings.scans.is_empty() {
        vec!["scan".to_string()]
    } else {
        settings.scans.iter().map(|s| s.topic.clone()).collect()
    };
    let several = !settings.scans.is_empty();
    lock(&node).laser_pose_lines = vec![String::new(); topics.len()];
    lock(&node).scan_heard = vec![None; topics.len()];
    lock(&node).placed_last = vec![None; topics.len()];
    let subscribe_scan = |k: usize| {
        let n = node.clone();
        let tf = tf.clone();
        let topic = topics[k].clone();
        rosrust::subscribe(&topic, 1, move |m: sensor_msgs::LaserScan| {
            // The clock is read under the lock: ticks then come in time order, and the
            // node never takes a callback that waited for the lock for a clock jump.
            let header = scan_header(&m);
            let mut node = lock(&n);
            let now = now_s();
            let placed = {
                let tree = tf.lock().unwrap_or_else(|p| p.into_inner());
                let s = &node.settings;
                place_laser(
                    &tree,
                    s.laser_pose,
                    &s.base_frame,
                    &m.header.frame_id,
                    header.stamp_s,
                    s.tf_tolerance_s,
                )
            };
            // The line is made only when the placement changes: the scan's path does not allocate.
            let resolved = match &placed {
                Ok(Some(mount)) => Some(*mount),
                Ok(None) => Some(LaserMount::from_params(&node.core.params().laser)),
                Err(_) => None,
            };
            let same = match (&node.placed_last[k], resolved) {
                (Some((frame, was)), Some(now)) => *was == now && *frame == m.header.frame_id,
                _ => false,
            };
            let line = if same {
                None
            } else {
                node.placed_last[k] = resolved.map(|r| (m.header.frame_id.clone(), r));
                Some(match &placed {
                    Ok(Some(mount)) => format!("\"{}\" from tf: {}", m.header.frame_id, describe_mount(mount)),
                    Ok(None) => format!(
                        "\"{}\" from the YAML mount: {}",
                        m.header.frame_id,
                        describe_mount(&LaserMount::from_params(&node.core.params().laser))
                    ),
                    Err((_, line)) => format!("unknown: {line}"),
                })
            };
            if let Some(line) = line.filter(|l| *l != node.laser_pose_lines[k]) {
                match (&placed, several) {
                    (Ok(_), _) => log::info!("laser pose {line}"),
                    (Err(_), false) => log::warn!("laser pose {line}: the scan's view is unknown, the robot stops"),
                    (Err(_), true) => log::warn!("laser pose {line}: this scanner's view is unknown"),
                }
                node.laser_pose_lines[k] = line;
            }
            if several {
                let scan = crate::algo::LaserScan {
                    header,
                    ranges_m: &m.ranges,
                    intensities: &m.intensities,
                };
                node.core.on_scanner_scan(k, &scan, placed.map_err(|(why, _)| why), now);
            } else {
                match placed {
                    Ok(Some(mount)) => {
                        node.core.set_laser_mount(mount);
                        node.core.on_scan(header, &m.ranges, &m.intensities);
                    }
                    Ok(None) => node.core.on_scan(header, &m.ranges, &m.intensities),
                    Err((why, _)) => node.core.on_scan_without_pose(header, why),
                }
            }
            // The (first) LiDAR's frame names the hardware, unless node/hardware_id does.
            if k == 0 && node.settings.hardware_id.is_empty() && node.hardware_id != m.header.frame_id {
                node.hardware_id.clone_from(&m.header.frame_id);
            }
            node.scan_heard[k] = Some(mono_s());
            node.activity.scan_arrived(now);
            node.tick(now);
        })
        .map_err(RosError::doing(format!("subscribing to {topic}")))
    };
    let subscribe_odom = || {
        let n = node.clone();
        rosrust::subscribe("odom", 1, move |m: nav_msgs::Odometry| {
            let (pose, twist) = odom_from_msg(&m);
            let mut node = lock(&n);
            let now = now_s();
            node.core.on_odom(pose, twist, now);
            node.odom_heard = Some(mono_s());
            if node.odom_frame != m.header.frame_id {
                node.odom_frame.clone_from(&m.header.frame_id);
            }
        })
        .map_err(RosError::doing("subscribing to odom"))
    };
    let mut scan_subs = Vec::with_capacity(topics.len());
    for k in 0..topics.len() {
        scan_subs.push(Some(subscribe_scan(k)?));
    }
    let mut odom_sub = Some(subscribe_odom()?);
    // rosrust does not retry a failed connection: quiet subscriptions are made again.
    // On the monotonic clock: simulated time stands at 0 until /clock first
    // arrives, and a jump from there must not look like a quiet topic.
    let started_s = mono_s();
    let mut scan_retries: Vec<Resubscribe> = topics.iter().map(|_| Resubscribe::standard(started_s)).collect();
    let mut odom_retry = Resubscribe::standard(started_s);
    // So is a new upstream command, against the latest scan.
    let n = node.clone();
    let _cmd_in_sub = rosrust::subscribe("cmd_vel_in", 1, move |m: geometry_msgs::Twist| {
        let mut node = lock(&n);
        let now = now_s();
        node.core.on_cmd_in(twist_from_msg(&m), now);
        node.tick(now);
    })
    .map_err(RosError::doing("subscribing to cmd_vel_in"))?;
    // An e-stop goes out at once too, and so does the release of a liveness
    // stop by a fresh false.
    let n = node.clone();
    let _e_stop_sub = rosrust::subscribe("e_stop", 10, move |m: std_msgs::Bool| {
        let mut node = lock(&n);
        let now = now_s();
        let was_silent = node.core.e_stop_silence(now).is_some();
        node.core.on_e_stop(m.data, now);
        if m.data || was_silent {
            node.tick(now);
        }
    })
    .map_err(RosError::doing("subscribing to e_stop"))?;
    let n = node.clone();
    let _enable_srv = rosrust::service::<std_srvs::SetBool, _>("~enable", move |req| {
        let mut node = lock(&n);
        let now = now_s();
        let lapses_at = node.core.set_enabled(req.data, now);
        let message = match (req.data, lapses_at) {
            (true, _) => "safety filter enabled".to_string(),
            (false, Some(at)) => format!(
                "safety filter DISABLED: pass-through for {:.1} s (until {at:.3} s) unless renewed by another ~enable false",
                at - now
            ),
            (false, None) => "safety filter DISABLED: pass-through until ~enable true".to_string(),
        };
        Ok(std_srvs::SetBoolRes {
            success: true,
            message,
        })
    })
    .map_err(RosError::doing("advertising ~enable"))?;
    let n = node.clone();
    let _reset_srv = rosrust::service::<std_srvs::Trigger, _>("~reset_e_stop", move |_| {
        let mut node = lock(&n);
        let now = now_s();
        Ok(match node.core.reset_e_stop(now) {
            Ok(()) => std_srvs::TriggerRes {
                success: true,
                message: "e-stop released".into(),
            },
            Err(why) => std_srvs::TriggerRes {
                success: false,
                message: why.to_string(),
            },
        })
    })
    .map_err(RosError::doing("advertising ~reset_e_stop"))?;

    // dynamic_reconfigure: the parameters of reconfigure::RECONFIGURABLE.
    let (specs, problems) = reconfigure::specs();
    for p in &problems {
        log::error!("dynamic_reconfigure: {p} (left out)");
    }
    let initial = reconfigure::values(&params, &specs);
    let n = node.clone();
    let table = specs.clone();
    let _reconfigure = ros_reconfigure::start(
        specs,
        &initial,
        Box::new(move |changes| {
            let mut node = lock(&n);
            let outcome = reconfigure::apply(node.core.params(), &table, changes)
                .and_then(|p| node.core.set_params(p).map_err(reconfigure::ReconfigureError::Invalid));
            (outcome, reconfigure::values(node.core.params(), &table))
        }),
    )?;

    if let Some(Ok(fp)) = params.footprint.polygon() {
        log::info!(
            "{}: footprint: a polygon of {} vertices{}, padding {} m; the checks that still use a circle keep \
             its circumscribed circle (r = {:.4} m) clear",
            rosrust::name(),
            fp.polygon.vertices().len(),
            if settings.footprint_param.is_empty() {
                String::new()
            } else {
                format!(" from {}", settings.footprint_param)
            },
            fp.padding_m,
            params.robot_radius_m()
        );
    }
    log::info!(
        "{}: filtering at {} Hz; r = {:.3} m, d_safe = {:.2} m, d_act = {:.2} m; nominal source {:?}",
        rosrust::name(),
        params.control.rate_hz,
        params.robot_radius_m(),
        params.barrier.d_safe_m,
        params.barrier.d_act_m(),
        settings.nominal_source
    );
    if settings.e_stop_timeout_s > 0.0 {
        log::info!(
            "e_stop liveness on: silent for more than {} s, or not heard yet, engages the stop until a fresh false",
            settings.e_stop_timeout_s
        );
    }
    if settings.disable_timeout_s > 0.0 {
        log::info!(
            "~enable false lapses after {} s unless renewed",
            settings.disable_timeout_s
        );
    }
    let name = rosrust::name();
    // The watchdog: polls a few times a period and ticks when nothing has
    // gone out for about a period (node_core::NodeCore::watchdog_due).
    // Paced on the monotonic clock even under /use_sim_time: a loop that slept on
    // /clock would not see a signal while the simulated clock stands still.
    let mut pacer = Pacer::monotonic(params.control.rate_hz * f64::from(WATCHDOG_POLLS_PER_PERIOD));
    let watch = MasterWatch::start(&name);
    while rosrust::is_ok() && !stop.is_set() && watch.health() != MasterHealth::Restarted {
        let mut node = lock(&node);
        let now = now_s();
        if node.core.watchdog_due(now) {
            node.tick(now);
        }
        let (last_scan_s, last_odom_s) = (node.scan_heard.clone(), node.odom_heard);
        drop(node);
        let mono = mono_s();
        // Only with the master up: rosrust's calls fail or block while it is away, and
        // a subscription that could not be made again is tried again at the next due time.
        if watch.health() == MasterHealth::Up {
            for (k, retry) in scan_retries.iter_mut().enumerate() {
                if retry.due(mono, last_scan_s[k]) {
                    log::warn!("{name}: no scan for a while: subscribing to {} again", topics[k]);
                    let old = scan_subs[k].take();
                    scan_subs[k] = super::resubscribe(old, &|| subscribe_scan(k));
                }
            }
            if odom_retry.due(mono, last_odom_s) {
                log::debug!("{name}: no odometry for a while: subscribing to odom again");
                odom_sub = super::resubscribe(odom_sub, &subscribe_odom);
            }
        }
        pacer.sleep();
    }
    // Leave the robot stopped: a last zero command, sent a few times, and
    // nothing after it (scans may still be arriving).
    lock(&node).stopping = true;
    log::info!("{name}: shutting down; sending a zero command");
    for _ in 0..3 {
        let _ = cmd_pub.send(twist_to_msg(crate::algo::Twist::ZERO));
        std::thread::sleep(Duration::from_millis(30));
    }
    let restarted = watch.health() == MasterHealth::Restarted;
    if !restarted {
        super::leave_master::leave_master();
    }
    rosrust::shutdown();
    Ok(!restarted)
}
