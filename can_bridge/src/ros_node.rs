//! can_bridge_node: the bridge as a ROS 1 node (feature `ros`), a thin
//! adapter over [`Bridge`] like `can_bridge_cli`.
//!
//! Topics (relative names): subscribes `cmd_vel` (geometry_msgs/Twist) and
//! `e_stop` (std_msgs/Bool: true latches the bridge's e-stop); publishes
//! `odom` (nav_msgs/Odometry from the wheels' measured speeds and positions,
//! with the covariance of the `odometry:` noise model, `node/odom_rate_hz`),
//! `joint_states` (sensor_msgs/JointState: the two wheel joints' angles and
//! speeds at the wheel, names `node/left_wheel_joint`, `node/right_wheel_joint`,
//! same rate and stamp), optionally `/tf` odom → base_link
//! (`node/publish_tf`, the same pose and stamp as `odom`), and `/diagnostics`
//! (1 Hz: bus state, drive state, stop reasons, last command age, frames
//! sent, tx drops, error counters).
//! Service `~reset` (std_srvs/Trigger): clears the e-stop and latched drive
//! faults (a drive error, a drive whose heartbeat was lost on a working bus)
//! once the `e_stop` input is false; motion then needs a fresh command.
//! Services `~sdo_read` (oldbf_ros/SdoRead) and `~sdo_write`
//! (oldbf_ros/SdoWrite), protocol cia402: read or write an object of a
//! drive's node while running, expedited or segmented; the transfer runs in
//! the bridge's loop and the call waits for its end (the abort code decoded
//! in the answer); a write that could change motion is refused while the
//! node's drive is enabled ([`crate::protocol::cia402::sdo_jobs`]).
//!
//! Parameters: the keys of `config/can_bridge.yaml` in the node's private
//! namespace plus `node/...` (config/can_bridge_node.yaml), checked like the
//! file (a bad or unknown key: exit status 2 naming it). With
//! `node/base_limits_file`, a ramp or clamp that contradicts the base's
//! limits (`config/base_limits.yaml`) is refused the same way, naming the
//! bridge's key and the base's. SIGINT/SIGTERM: a
//! zero setpoint, then the drive disabled, then exit 0. The bridge's own
//! watchdog zeroes the wheels if `cmd_vel` stops, whatever this node does.
//! The master lost: logged, the node runs on (cmd_vel flows peer to peer,
//! and its timeout still holds). The master back as a new run: logged, the
//! same shutdown, exit status 1 (rosrust cannot register again).
//! Odometry and diagnostics are scheduled on the monotonic clock, so a
//! wall-clock step back does not silence them.

use crate::bridge::{Bridge, BridgeError, ShutdownProgress, Spin};
use crate::bus::BusError;
use crate::config::{default_config, BridgeConfig};
use crate::diagnostics::{BridgeState, BridgeStatus};
use crate::kinematics::Twist;
use crate::odometry::covariance::{ros_pose_covariance, ros_twist_covariance};
use crate::odometry::OdometryState;
use crate::protocol::cia402::sdo_jobs::{SdoJob, SdoJobId, SdoJobResult, MAX_QUEUED_JOBS};
use crate::protocol::cia402::sdo_transfer::MAX_TRANSFER_BYTES;
use crate::ros_msgs::oldbf_ros::{SdoRead, SdoReadRes, SdoWrite, SdoWriteRes};
use crate::ros_msgs::sensor_msgs::JointState;
use crate::socketcan_bus::SocketCanBus;
use crate::time::{Clock, MonotonicClock};
use oldbf::config::{
    load_base_limits_file, load_value, merge, BaseLimits, BaseLimitsConflict, Checker, ConfigError, Interval, Validate,
};
use oldbf_ros::ros::convert::{quaternion_from_yaw, time_from_s};
use oldbf_ros::ros::leave_master::leave_master;
use oldbf_ros::ros::lifecycle::{self, now_s, MasterHealth, MasterWatch};
use oldbf_ros::ros::msg::{
    diagnostic_msgs::{DiagnosticArray, DiagnosticStatus, KeyValue},
    geometry_msgs, nav_msgs, std_msgs, std_srvs, tf2_msgs,
};
use serde::{Deserialize, Serialize};
use serde_yaml::Value;
use std::collections::HashMap;
use std::sync::mpsc;
use std::time::Duration;

/// Node settings beyond the bridge's (`node:` in the private namespace).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodeSettings {
    /// Frame of the odometry's pose.
    pub odom_frame: String,
    /// Frame of the robot base (the odometry's child frame).
    pub base_frame: String,
    /// Publish odom → base_link on /tf.
    pub publish_tf: bool,
    /// Odometry (and joint state) publication rate (Hz).
    pub odom_rate_hz: f64,
    /// The left wheel's joint in `joint_states` (the URDF's name).
    pub left_wheel_joint: String,
    /// The right wheel's joint in `joint_states`.
    pub right_wheel_joint: String,
    /// The base's limits (`config/base_limits.yaml`, shared with the safety
    /// filter) the bridge's ramps and clamps must agree with; empty: none.
    pub base_limits_file: String,
}

impl Default for NodeSettings {
    fn default() -> Self {
        Self {
            odom_frame: "odom".into(),
            base_frame: "base_link".into(),
            publish_tf: false,
            odom_rate_hz: 50.0,
            left_wheel_joint: "wheel_left_joint".into(),
            right_wheel_joint: "wheel_right_joint".into(),
            base_limits_file: String::new(),
        }
    }
}

/// A joint name robot_state_publisher can match: non-empty, no whitespace.
fn joint_name_ok(n: &str) -> bool {
    !n.is_empty() && !n.chars().any(char::is_whitespace)
}

impl Validate for NodeSettings {
    fn check(&self, c: &mut Checker) {
        c.range(
            "odom_rate_hz",
            self.odom_rate_hz,
            Interval::open_closed(0.0, 1000.0).unit("Hz"),
        );
        for (key, n) in [
            ("left_wheel_joint", &self.left_wheel_joint),
            ("right_wheel_joint", &self.right_wheel_joint),
        ] {
            c.rule(
                joint_name_ok(n),
                key,
                format_args!("{n:?}"),
                "a non-empty name without whitespace",
            );
        }
        c.rule(
            self.left_wheel_joint != self.right_wheel_joint,
            "right_wheel_joint",
            format_args!("{:?}", self.right_wheel_joint),
            "different from left_wheel_joint",
        );
    }
}

/// The wheels' joint states: angle (rad) and speed (rad/s) at the wheel,
/// forward positive, in the order of the names.
pub fn joint_state_msg(stamp: rosrust::Time, s: &NodeSettings, o: &OdometryState) -> JointState {
    let mut m = JointState::default();
    m.header.stamp = stamp;
    m.name = vec![s.left_wheel_joint.clone(), s.right_wheel_joint.clone()];
    m.position = vec![o.wheel_angles.left_rad, o.wheel_angles.right_rad];
    m.velocity = vec![o.wheels.left_radps, o.wheels.right_radps];
    m
}

/// odom → base_link: the odometry's pose, for /tf.
pub fn transform_msg(stamp: rosrust::Time, s: &NodeSettings, o: &OdometryState) -> geometry_msgs::TransformStamped {
    let mut t = geometry_msgs::TransformStamped::default();
    t.header.stamp = stamp;
    t.header.frame_id = s.odom_frame.clone();
    t.child_frame_id = s.base_frame.clone();
    t.transform.translation.x = o.pose.x_m;
    t.transform.translation.y = o.pose.y_m;
    t.transform.rotation = quaternion_from_yaw(o.pose.theta_rad);
    t
}

/// nav_msgs/Odometry with the model's covariance (ROS's 6×6 layout).
pub fn odometry_msg(stamp: rosrust::Time, s: &NodeSettings, o: &OdometryState) -> nav_msgs::Odometry {
    let mut m = nav_msgs::Odometry::default();
    m.header.stamp = stamp;
    m.header.frame_id = s.odom_frame.clone();
    m.child_frame_id = s.base_frame.clone();
    m.pose.pose.position.x = o.pose.x_m;
    m.pose.pose.position.y = o.pose.y_m;
    m.pose.pose.orientation = quaternion_from_yaw(o.pose.theta_rad);
    m.pose.covariance = ros_pose_covariance(&o.pose_covariance);
    m.twist.twist.linear.x = o.twist.linear_mps;
    m.twist.twist.angular.z = o.twist.angular_radps;
    m.twist.covariance = ros_twist_covariance(&o.twist_covariance);
    m
}

/// The bridge and node configuration from the private namespace `ns`
/// (null when nothing is set), merged over the built-in defaults; errors
/// name `source` and the key as in the file (`node.odom_rate_hz`).
pub fn config_from_params(ns: Value, source: &str) -> Result<(BridgeConfig, NodeSettings), ConfigError> {
    let mut ns = match ns {
        Value::Null => Value::Mapping(Default::default()),
        v @ Value::Mapping(_) => v,
        other => {
            let message = format!("expected a mapping of parameters, got {other:?}");
            return Err(ConfigError::at(source, "", message));
        }
    };
    let node_over = ns.as_mapping_mut().and_then(|m| m.remove("node"));
    let mut node =
        serde_yaml::to_value(NodeSettings::default()).map_err(|e| ConfigError::at(source, "node", e.to_string()))?;
    if let Some(over) = &node_over {
        merge(&mut node, over);
    }
    let settings: NodeSettings = load_value(node, source, "node")?;
    let mut bridge = serde_yaml::to_value(default_config()).map_err(|e| ConfigError::at(source, "", e.to_string()))?;
    merge(&mut bridge, &ns);
    let cfg: BridgeConfig = load_value(bridge, source, "")?;
    if let Some(base) = base_limits(&settings)? {
        BaseLimitsConflict::check(source, &settings.base_limits_file, cfg.base_conflicts(&base))?;
    }
    Ok((cfg, settings))
}

/// The base's limits named by `node.base_limits_file`, if any.
fn base_limits(settings: &NodeSettings) -> Result<Option<BaseLimits>, ConfigError> {
    match settings.base_limits_file.as_str() {
        "" => Ok(None),
        file => load_base_limits_file(std::path::Path::new(file)).map(Some),
    }
}

/// Why the node could not run.
#[derive(Debug, thiserror::Error)]
pub enum NodeError {
    /// The CAN interface could not be opened.
    #[error("opening CAN interface {interface}: {source}")]
    Open {
        /// The interface.
        interface: String,
        /// Why not.
        source: BusError,
    },
    /// The bridge refused its configuration or the bus its filters.
    #[error("starting the bridge: {0}")]
    Bridge(#[from] BridgeError),
    /// A topic or service could not be set up.
    #[error("{what}: {source}")]
    Ros {
        /// `subscribing to cmd_vel`, `advertising odom`…
        what: &'static str,
        /// rosrust's error.
        source: rosrust::error::Error,
    },
}

fn ros_err(what: &'static str) -> impl FnOnce(rosrust::error::Error) -> NodeError {
    move |source| NodeError::Ros { what, source }
}

/// How an SDO request ended, for a service answer.
#[derive(Debug, Clone, PartialEq, Eq)]
struct SdoAnswer {
    success: bool,
    data: Vec<u8>,
    abort_code: u32,
    message: String,
}

impl From<SdoJobResult> for SdoAnswer {
    fn from(r: SdoJobResult) -> Self {
        Self {
            success: r.ok,
            data: r.data,
            abort_code: r.abort_code,
            message: r.message,
        }
    }
}

enum Input {
    Cmd(Twist),
    EStop(bool),
    Reset(mpsc::Sender<(bool, String)>),
    Sdo(SdoJob, mpsc::Sender<SdoAnswer>),
}

/// How long a service call waits for its transfer: every answer of the
/// longest transfer late by the SDO timeout, behind a full queue, plus a
/// second. A call that outlives it is answered as failed, not left hanging.
fn sdo_wait(data_len: usize, sdo_timeout: Duration) -> Duration {
    let exchanges = (data_len.min(MAX_TRANSFER_BYTES) / 7 + 3) as u32;
    sdo_timeout * exchanges * MAX_QUEUED_JOBS as u32 + Duration::from_secs(1)
}

/// Sends `job` to the loop and waits for its end.
fn call_sdo(tx: &mpsc::Sender<Input>, job: SdoJob, sdo_timeout: Duration) -> SdoAnswer {
    let (reply_tx, reply_rx) = mpsc::channel();
    let len = match &job.kind {
        crate::protocol::cia402::sdo_transfer::TransferKind::Write(d) => d.len(),
        crate::protocol::cia402::sdo_transfer::TransferKind::Read => MAX_TRANSFER_BYTES,
    };
    let failed = |message: &str| SdoAnswer {
        success: false,
        data: Vec::new(),
        abort_code: crate::protocol::cia402::sdo::abort::GENERAL,
        message: message.into(),
    };
    if tx.send(Input::Sdo(job, reply_tx)).is_err() {
        return failed("the bridge has stopped");
    }
    reply_rx
        .recv_timeout(sdo_wait(len, sdo_timeout))
        .unwrap_or_else(|_| failed("the bridge did not answer in time"))
}

fn kv(key: &str, value: impl ToString) -> KeyValue {
    KeyValue {
        key: key.into(),
        value: value.to_string(),
    }
}

fn diagnostics(name: &str, stamp: rosrust::Time, s: &BridgeStatus, interface: &str, cmd_age_s: f64) -> DiagnosticArray {
    let level = match s.state {
        BridgeState::Running | BridgeState::Idle => DiagnosticStatus::OK,
        BridgeState::Starting => DiagnosticStatus::WARN,
        BridgeState::Stopped | BridgeState::Estop => DiagnosticStatus::ERROR,
    };
    let state = serde_json::to_string(&s.state).unwrap_or_default();
    let reasons = serde_json::to_string(&s.reasons).unwrap_or_default();
    let c = &s.counters;
    let message = if s.reasons.is_empty() {
        state.trim_matches('"').to_string()
    } else {
        format!("{}: {reasons}", state.trim_matches('"'))
    };
    let mut array = DiagnosticArray::default();
    array.header.stamp = stamp;
    array.status.push(DiagnosticStatus {
        level,
        name: format!("{name}: CAN bridge"),
        message,
        hardware_id: interface.into(),
        values: vec![
            kv("state", state.trim_matches('"')),
            kv(
                "last_command_age_s",
                if cmd_age_s.is_finite() {
                    format!("{cmd_age_s:.3}")
                } else {
                    "no command yet".into()
                },
            ),
            kv("stop_reasons", reasons),
            kv("left_drive", serde_json::to_string(&s.left).unwrap_or_default()),
            kv("right_drive", serde_json::to_string(&s.right).unwrap_or_default()),
            kv(
                "setpoint_wheels_radps",
                serde_json::to_string(&s.setpoint_wheels).unwrap_or_default(),
            ),
            kv("commands", c.commands),
            kv("commands_rejected", c.commands_rejected),
            kv("commands_clamped", c.commands_clamped),
            kv("tx_frames", c.tx_frames),
            kv("tx_queue_full", c.tx_queue_full),
            kv("tx_dropped", c.tx_dropped_stale + c.tx_dropped_after_retries),
            kv("tx_errors", c.tx_errors),
            kv("rx_frames", c.rx_frames),
            kv("error_frames", c.error_frames),
        ],
    });
    array
}

/// Runs the node; returns the process exit status.
pub fn run() -> i32 {
    oldbf_ros::ros::logging::init();
    let stop = lifecycle::install_signal_handler();
    let name = lifecycle::node_name("can_bridge_node");
    if !lifecycle::connect(&name, &stop) {
        return 0;
    }
    let source = format!("ROS parameters of {}", rosrust::name());
    let invalid = |e: &dyn std::fmt::Display| {
        log::error!("{e}");
        log::error!("{}: invalid parameters, exiting", rosrust::name());
        std::thread::sleep(Duration::from_millis(200)); // let rosout carry the message
        leave_master();
        rosrust::shutdown();
        2
    };
    let ns = match oldbf_ros::ros::params::private_namespace() {
        Ok(ns) => ns,
        Err(e) => return invalid(&e),
    };
    let (cfg, settings) = match config_from_params(ns, &source) {
        Ok(c) => c,
        Err(e) => return invalid(&e),
    };
    match run_connected(cfg, settings, &stop) {
        Ok(true) => 0,
        Ok(false) => 1,
        Err(e) => {
            log::error!("{}: {e}", rosrust::name());
            std::thread::sleep(Duration::from_millis(200));
            leave_master();
            rosrust::shutdown();
            1
        }
    }
}

/// Ok(true): stopped by a signal; Ok(false): the master restarted.
fn run_connected(cfg: BridgeConfig, settings: NodeSettings, stop: &lifecycle::StopFlag) -> Result<bool, NodeError> {
    let interface = cfg.interface.clone();
    let bus = SocketCanBus::open(&interface).map_err(|source| NodeError::Open {
        interface: interface.clone(),
        source,
    })?;
    let clock = MonotonicClock::new();
    let mut bridge = Bridge::new(cfg, bus, clock.now())?;

    let (tx, rx) = mpsc::channel::<Input>();
    let t = tx.clone();
    let _cmd_sub = rosrust::subscribe("cmd_vel", 1, move |m: geometry_msgs::Twist| {
        let _ = t.send(Input::Cmd(Twist {
            linear_mps: m.linear.x,
            angular_radps: m.angular.z,
        }));
    })
    .map_err(ros_err("subscribing to cmd_vel"))?;
    let t = tx.clone();
    let _estop_sub = rosrust::subscribe("e_stop", 10, move |m: std_msgs::Bool| {
        let _ = t.send(Input::EStop(m.data));
    })
    .map_err(ros_err("subscribing to e_stop"))?;
    let t = tx.clone();
    let _reset_srv = rosrust::service::<std_srvs::Trigger, _>("~reset", move |_| {
        let (reply_tx, reply_rx) = mpsc::channel();
        let _ = t.send(Input::Reset(reply_tx));
        let (success, message) = reply_rx
            .recv_timeout(Duration::from_secs(2))
            .unwrap_or((false, "the bridge did not answer".into()));
        Ok(std_srvs::TriggerRes { success, message })
    })
    .map_err(ros_err("advertising ~reset"))?;
    let sdo_timeout = crate::time::saturating_duration(bridge.config().cia402.sdo_timeout_s);
    let t = tx.clone();
    let _sdo_read_srv = rosrust::service::<SdoRead, _>("~sdo_read", move |req| {
        let a = call_sdo(&t, SdoJob::read(req.node_id, req.index, req.subindex), sdo_timeout);
        Ok(SdoReadRes {
            success: a.success,
            data: a.data,
            abort_code: a.abort_code,
            message: a.message,
        })
    })
    .map_err(ros_err("advertising ~sdo_read"))?;
    let t = tx.clone();
    let _sdo_write_srv = rosrust::service::<SdoWrite, _>("~sdo_write", move |req| {
        let a = call_sdo(
            &t,
            SdoJob::write(req.node_id, req.index, req.subindex, req.data),
            sdo_timeout,
        );
        Ok(SdoWriteRes {
            success: a.success,
            abort_code: a.abort_code,
            message: a.message,
        })
    })
    .map_err(ros_err("advertising ~sdo_write"))?;
    let odom_pub = rosrust::publish::<nav_msgs::Odometry>("odom", 10).map_err(ros_err("advertising odom"))?;
    let joints_pub = rosrust::publish::<JointState>("joint_states", 10).map_err(ros_err("advertising joint_states"))?;
    let tf_pub = rosrust::publish::<tf2_msgs::TFMessage>("/tf", 50).map_err(ros_err("advertising /tf"))?;
    let diag_pub =
        rosrust::publish::<DiagnosticArray>("/diagnostics", 10).map_err(ros_err("advertising /diagnostics"))?;

    let node = rosrust::name();
    log::info!(
        "{node}: bridging cmd_vel to {interface} ({:?}), setpoints at {} Hz, command timeout {} s",
        bridge.config().protocol,
        bridge.config().timing.tx_rate_hz,
        bridge.config().timing.cmd_timeout_s
    );
    let odom_period = 1.0 / settings.odom_rate_hz;
    let (mut next_odom, mut next_diag) = (0.0f64, 0.0f64);
    let mut e_stop_input = false;
    let mut last_cmd_s = f64::NEG_INFINITY;
    let mut sdo_waiting: HashMap<SdoJobId, mpsc::Sender<SdoAnswer>> = HashMap::new();
    let watch = MasterWatch::start(&node);
    while rosrust::is_ok() && !stop.is_set() && watch.health() != MasterHealth::Restarted {
        while let Ok(input) = rx.try_recv() {
            let now = clock.now();
            match input {
                Input::Cmd(twist) => {
                    last_cmd_s = now.as_secs_f64();
                    if let Err(e) = bridge.command(twist, now) {
                        log::warn!("command rejected: {e}");
                    }
                }
                Input::EStop(active) => {
                    if active && !e_stop_input {
                        log::warn!("e-stop latched");
                    }
                    e_stop_input = active;
                    if active {
                        bridge.estop(now);
                    }
                }
                Input::Reset(reply) => {
                    let answer = if e_stop_input {
                        (false, "the e_stop input is still active".to_string())
                    } else {
                        bridge.reset(now);
                        (true, "reset: motion resumes on a fresh command".to_string())
                    };
                    let _ = reply.send(answer);
                }
                Input::Sdo(job, reply) => match bridge.sdo_request(job, now) {
                    Ok(id) => {
                        sdo_waiting.insert(id, reply);
                    }
                    Err(e) => {
                        let _ = reply.send(SdoAnswer {
                            success: false,
                            data: Vec::new(),
                            abort_code: e.abort_code(),
                            message: format!("refused by the bridge: {e}"),
                        });
                    }
                },
            }
        }
        if let Spin::BackOff(d) = bridge.spin_once(&clock, Duration::from_millis(5)) {
            std::thread::sleep(d);
        }
        for ev in bridge.drain_events() {
            log::info!("{}", serde_json::to_string(&ev).unwrap_or_default());
        }
        for r in bridge.take_sdo_results() {
            if let Some(reply) = sdo_waiting.remove(&r.id) {
                let _ = reply.send(SdoAnswer::from(r));
            }
        }
        let now = clock.now().as_secs_f64();
        if now >= next_odom {
            next_odom = now + odom_period;
            let o = bridge.odometry();
            // One stamp for odom, joint_states and tf: the same instant.
            let stamp = time_from_s(now_s());
            let _ = odom_pub.send(odometry_msg(stamp, &settings, &o));
            let _ = joints_pub.send(joint_state_msg(stamp, &settings, &o));
            if settings.publish_tf {
                let t = transform_msg(stamp, &settings, &o);
                let _ = tf_pub.send(tf2_msgs::TFMessage { transforms: vec![t] });
            }
        }
        if now >= next_diag {
            next_diag = now + 1.0;
            let status = bridge.status(clock.now());
            let _ = diag_pub.send(diagnostics(
                &node,
                time_from_s(now_s()),
                &status,
                &interface,
                now - last_cmd_s,
            ));
        }
    }
    let failed = loop {
        match bridge.shutdown(clock.now()) {
            ShutdownProgress::Done { failed } => break failed,
            ShutdownProgress::Pending { retry_at } => std::thread::sleep(retry_at - clock.now()),
        }
    };
    if failed == 0 {
        log::info!("{node}: shut down: zero setpoint and drive disable sent");
    } else {
        log::error!("{node}: shut down: {failed} frame(s) of zero setpoint and drive disable could not be sent");
    }
    let restarted = watch.health() == MasterHealth::Restarted;
    if !restarted {
        leave_master();
    }
    rosrust::shutdown();
    Ok(!restarted)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A service call waits long enough for its transfer behind a full
    /// queue: a read may be 1024 bytes, (1024 / 7 + 3) exchanges × 0.2 s × 4
    /// + 1 s = 120.2 s; a 4-byte write 3 × 0.2 × 4 + 1 = 3.4 s.
    #[test]
    fn sdo_calls_wait_for_the_worst_case_transfer() {
        let ms = Duration::from_millis;
        assert_eq!(sdo_wait(MAX_TRANSFER_BYTES, ms(200)), ms(200 * 149 * 4 + 1000));
        assert_eq!(sdo_wait(4, ms(200)), ms(3400));
        let r = SdoJobResult {
            id: 3,
            node: 1,
            index: 0x1008,
            sub: 0,
            write: false,
            ok: true,
            data: b"x".to_vec(),
            abort_code: 0,
            message: "read 1 byte(s)".into(),
        };
        assert_eq!(
            SdoAnswer::from(r),
            SdoAnswer {
                success: true,
                data: b"x".to_vec(),
                abort_code: 0,
                message: "read 1 byte(s)".into()
            }
        );
    }

    /// What goes out on `odom` and `joint_states`, from a hand-made state:
    /// the covariance in ROS's indices, the joints in the names' order.
    #[test]
    fn odometry_and_joint_state_messages() {
        use crate::odometry::{PoseCovariance, TwistCovariance, WheelAngles};
        let o = OdometryState {
            pose_covariance: PoseCovariance([[1e-4, 2e-5, 3e-5], [2e-5, 4e-4, 5e-5], [3e-5, 5e-5, 6e-3]]),
            twist_covariance: TwistCovariance([[7e-4, 0.0], [0.0, 9e-3]]),
            wheel_angles: WheelAngles {
                left_rad: 12.5,
                right_rad: -3.0,
            },
            wheels: crate::kinematics::WheelSpeeds {
                left_radps: 4.0,
                right_radps: 6.0,
            },
            ..OdometryState::default()
        };
        let s = NodeSettings::default();
        let stamp = rosrust::Time { sec: 7, nsec: 5 };
        let m = odometry_msg(stamp, &s, &o);
        assert_eq!(m.pose.covariance[0], 1e-4);
        assert_eq!(m.pose.covariance[7], 4e-4);
        assert_eq!(m.pose.covariance[35], 6e-3);
        assert_eq!(m.pose.covariance[11], 5e-5);
        assert_eq!(m.pose.covariance[14], crate::odometry::covariance::UNMEASURED_VARIANCE);
        assert_eq!((m.twist.covariance[0], m.twist.covariance[35]), (7e-4, 9e-3));
        assert_eq!(
            (m.header.frame_id.as_str(), m.child_frame_id.as_str()),
            ("odom", "base_link")
        );
        let j = joint_state_msg(stamp, &s, &o);
        assert_eq!(j.name, ["wheel_left_joint", "wheel_right_joint"]);
        assert_eq!(
            (j.position.clone(), j.velocity.clone()),
            (vec![12.5, -3.0], vec![4.0, 6.0])
        );
        assert!(j.effort.is_empty());
        assert_eq!((j.header.stamp.sec, m.header.stamp.nsec), (7, 5));
        // The tf carries the Odometry's pose and stamp.
        let o = OdometryState {
            pose: crate::odometry::Pose2D {
                x_m: 1.5,
                y_m: -0.25,
                theta_rad: 0.5,
            },
            ..o
        };
        let (m, t) = (odometry_msg(stamp, &s, &o), transform_msg(stamp, &s, &o));
        assert_eq!(
            (t.header.frame_id.as_str(), t.child_frame_id.as_str()),
            ("odom", "base_link")
        );
        assert_eq!(t.header.stamp, m.header.stamp);
        assert_eq!(
            (t.transform.translation.x, t.transform.translation.y),
            (m.pose.pose.position.x, m.pose.pose.position.y)
        );
        assert_eq!(t.transform.rotation, m.pose.pose.orientation);
        assert!(
            (t.transform.rotation.z - 0.25f64.sin()).abs() < 1e-15,
            "yaw 0.5: z = sin(0.25)"
        );
    }

    #[test]
    fn parameters_merge_over_the_defaults_and_bad_ones_are_named() {
        let ns: Value =
            serde_yaml::from_str("interface: can1\nlimits: {v_max_mps: 0.5}\nnode: {publish_tf: true}").unwrap();
        let (cfg, node) = config_from_params(ns, "P").unwrap();
        assert_eq!(cfg.interface, "can1");
        assert_eq!(cfg.limits.v_max_mps, 0.5);
        assert!(node.publish_tf);
        let (cfg, _) = config_from_params(Value::Null, "P").unwrap();
        assert_eq!(cfg, default_config());
        let bad: Value = serde_yaml::from_str("limits: {v_max_mps: -1.0}").unwrap();
        assert_eq!(config_from_params(bad, "P").unwrap_err().keys(), ["limits.v_max_mps"]);
        let unknown: Value = serde_yaml::from_str("timing: {tx_rate: 5}").unwrap();
        assert_eq!(config_from_params(unknown, "P").unwrap_err().keys(), ["timing.tx_rate"]);
        let node: Value = serde_yaml::from_str("node: {odom_rate_hz: 0}").unwrap();
        assert_eq!(
            config_from_params(node, "P").unwrap_err().to_string(),
            "P: key `node.odom_rate_hz` = 0 is out of range; allowed: (0, 1000] Hz"
        );
        let same: Value = serde_yaml::from_str("node: {right_wheel_joint: wheel_left_joint}").unwrap();
        assert_eq!(
            config_from_params(same, "P").unwrap_err().keys(),
            ["node.right_wheel_joint"]
        );
        let blank: Value = serde_yaml::from_str("node: {left_wheel_joint: \"left wheel\"}").unwrap();
        assert_eq!(
            config_from_params(blank, "P").unwrap_err().keys(),
            ["node.left_wheel_joint"]
        );
        let node_unknown: Value = serde_yaml::from_str("node: {publish_tf_typo: true}").unwrap();
        let e = config_from_params(node_unknown, "P").unwrap_err();
        assert_eq!(e.keys(), ["node.publish_tf_typo"], "{e}");
        assert!(e.to_string().starts_with("P: "), "{e}");
        let node_type: Value = serde_yaml::from_str("node: {publish_tf: [1]}").unwrap();
        let e = config_from_params(node_type, "P").unwrap_err();
        assert_eq!(e.keys(), ["node.publish_tf"], "{e}");
        let e = config_from_params(Value::from(3), "P").unwrap_err();
        assert!(e.to_string().starts_with("P: expected a mapping"), "{e}");
    }

    #[test]
    fn a_ramp_that_contradicts_the_base_limits_file_is_refused_naming_both_keys() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
        let shipped = root.join("config/base_limits.yaml");
        let ns = |extra: &str| -> Value {
            serde_yaml::from_str(&format!("{extra}node: {{base_limits_file: '{}'}}", shipped.display())).unwrap()
        };
        let (_, node) = config_from_params(ns(""), "P").expect("the shipped bridge and base agree");
        assert_eq!(node.base_limits_file, shipped.display().to_string());
        // 20 rad/s² × 0.033 m = 0.66 m/s², below the base's 1.0 m/s².
        let e = config_from_params(ns("limits: {wheel_decel_radps2: 20.0}\n"), "ROS parameters of /b").unwrap_err();
        assert!(matches!(e, ConfigError::BaseLimits(_)), "{e:?}");
        assert_eq!(e.keys(), ["limits.wheel_decel_radps2", "base.decel_mps2"]);
        assert!(
            e.to_string()
                .starts_with("ROS parameters of /b: key `limits.wheel_decel_radps2` = 20 rad/s²"),
            "{e}"
        );
        // Without a file the same ramp is accepted (today's behaviour).
        let soft: Value = serde_yaml::from_str("limits: {wheel_decel_radps2: 20.0}").unwrap();
        config_from_params(soft, "P").unwrap();
        let missing: Value = serde_yaml::from_str("node: {base_limits_file: /no/such/base.yaml}").unwrap();
        let e = config_from_params(missing, "P").unwrap_err();
        assert!(e.to_string().starts_with("/no/such/base.yaml: cannot read"), "{e}");
    }
}
