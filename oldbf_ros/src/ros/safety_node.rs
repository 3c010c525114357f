//! oldbf_node: LaserScan in, safe cmd_vel out, on a timer at control.rate_hz.
//!
//! Topics (relative names, so `__ns:=` and remapping work):
//! * subscribes `scan` (sensor_msgs/LaserScan), `odom` (nav_msgs/Odometry,
//!   optional), `cmd_vel_in` (geometry_msgs/Twist, optional), `e_stop`
//!   (std_msgs/Bool; true latches a stop);
//! * publishes `cmd_vel` (geometry_msgs/Twist) every control period,
//!   `~state` (oldbf_ros/BarrierState), `~markers`
//!   (visualization_msgs/MarkerArray) and `/diagnostics` (1 Hz);
//! * services `~enable` (std_srvs/SetBool: false = pass-through, reported)
//!   and `~reset_e_stop` (std_srvs/Trigger).
//!
//! The decisions are all in [`crate::node_core`]; this file converts and
//! publishes. A bad parameter: a message naming it, exit status 2.
//! SIGINT/SIGTERM: a last zero command, then exit 0. The master lost: logged,
//! the node runs on (connected topics flow peer to peer). The master back as
//! a new run (restarted): logged, a last zero command, exit status 1, as
//! rosrust cannot register again. The loop is paced on the monotonic clock
//! (see [`super::pacer`]), so a wall-clock step cannot silence it.

use super::convert::{odom_from_msg, scan_meta, time_from_s, twist_from_msg, twist_to_msg};
use super::diagnostics::{diagnostics, Activity};
use super::lifecycle::{self, now_s, MasterHealth, MasterWatch};
use super::markers::markers;
use super::msg::{
    diagnostic_msgs::DiagnosticArray, geometry_msgs, nav_msgs, oldbf_ros::BarrierState, sensor_msgs, std_msgs,
    std_srvs, visualization_msgs::MarkerArray,
};
use super::pacer::Pacer;
use super::params::private_namespace;
use crate::node_config::{node_config_from_params, NodeConfig};
use crate::node_core::{NodeCore, Tick};
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
        e_stop: tick.e_stop,
        stop_reason: stop_reason(tick),
        nominal: twist_to_msg(r.nominal),
        cmd: twist_to_msg(tick.cmd),
        beams: r.beams as u32,
        valid_beams: r.valid_beams as u32,
        ..Default::default()
    };
    m.header.frame_id = frame.into();
    m.header.stamp = time_from_s(now);
    m
}

/// Why the robot is stopped, with the scan-order fault when that is the cause.
pub fn stop_reason(tick: &Tick) -> String {
    match (tick.record.stop_cause, tick.scan_fault) {
        (Some(_), Some(f)) => f.to_string(),
        (Some(c), None) => c.to_string(),
        (None, _) => String::new(),
    }
}

fn load_config() -> Result<NodeConfig, String> {
    let source = format!("ROS parameters of {}", rosrust::name());
    let ns = private_namespace()?;
    node_config_from_params(ns, &source).map_err(|e| e.to_string())
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
            rosrust::shutdown();
            return 2;
        }
    };
    match run_connected(config, &stop) {
        Ok(true) => 0,
        Ok(false) => 1,
        Err(e) => {
            log::error!("{}: {e}", rosrust::name());
            rosrust::shutdown();
            1
        }
    }
}

/// Ok(true): stopped by a signal; Ok(false): the master restarted.
fn run_connected(config: NodeConfig, stop: &lifecycle::StopFlag) -> Result<bool, String> {
    let params = config.params.clone();
    let settings = config.settings.clone();
    let mut core = NodeCore::new(config.params, config.settings, config.reference);
    if let Some(c) = config.constant {
        core = core.with_constant(c);
    }
    let core = Arc::new(Mutex::new(core));
    let activity = Arc::new(Mutex::new(Activity::default()));
    fn err(what: &'static str) -> impl Fn(rosrust::error::Error) -> String {
        move |e| format!("{what}: {e}")
    }

    let cmd_pub = rosrust::publish::<geometry_msgs::Twist>("cmd_vel", 1).map_err(err("advertising cmd_vel"))?;
    let state_pub = rosrust::publish::<BarrierState>("~state", 1).map_err(err("advertising ~state"))?;
    let markers_pub = rosrust::publish::<MarkerArray>("~markers", 1).map_err(err("advertising ~markers"))?;
    let diag_pub = rosrust::publish::<DiagnosticArray>("/diagnostics", 10).map_err(err("advertising /diagnostics"))?;

    let c = core.clone();
    let a = activity.clone();
    let _scan_sub = rosrust::subscribe("scan", 1, move |m: sensor_msgs::LaserScan| {
        let now = now_s();
        c.lock()
            .expect("node state lock")
            .on_scan(scan_meta(&m), &m.ranges, &m.intensities);
        a.lock().expect("activity lock").scan_arrived(now);
    })
    .map_err(err("subscribing to scan"))?;
    let c = core.clone();
    let _odom_sub = rosrust::subscribe("odom", 1, move |m: nav_msgs::Odometry| {
        let (pose, twist) = odom_from_msg(&m);
        c.lock().expect("node state lock").on_odom(pose, twist, now_s());
    })
    .map_err(err("subscribing to odom"))?;
    let c = core.clone();
    let _cmd_in_sub = rosrust::subscribe("cmd_vel_in", 1, move |m: geometry_msgs::Twist| {
        c.lock()
            .expect("node state lock")
            .on_cmd_in(twist_from_msg(&m), now_s());
    })
    .map_err(err("subscribing to cmd_vel_in"))?;
    let c = core.clone();
    let _e_stop_sub = rosrust::subscribe("e_stop", 10, move |m: std_msgs::Bool| {
        c.lock().expect("node state lock").on_e_stop(m.data);
    })
    .map_err(err("subscribing to e_stop"))?;
    let c = core.clone();
    let _enable_srv = rosrust::service::<std_srvs::SetBool, _>("~enable", move |req| {
        c.lock().expect("node state lock").set_enabled(req.data);
        let message = if req.data {
            "safety filter enabled"
        } else {
            "safety filter DISABLED: pass-through"
        };
        Ok(std_srvs::SetBoolRes {
            success: true,
            message: message.into(),
        })
    })
    .map_err(err("advertising ~enable"))?;
    let c = core.clone();
    let _reset_srv = rosrust::service::<std_srvs::Trigger, _>("~reset_e_stop", move |_| {
        Ok(match c.lock().expect("node state lock").reset_e_stop() {
            Ok(()) => std_srvs::TriggerRes {
                success: true,
                message: "e-stop released".into(),
            },
            Err(why) => std_srvs::TriggerRes {
                success: false,
                message: why.into(),
            },
        })
    })
    .map_err(err("advertising ~reset_e_stop"))?;

    log::info!(
        "{}: filtering at {} Hz; r = {:.3} m, d_safe = {:.2} m, d_act = {:.2} m; nominal source {:?}",
        rosrust::name(),
        params.control.rate_hz,
        params.robot_radius_m(),
        params.barrier.d_safe_m,
        params.barrier.d_act_m(),
        settings.nominal_source
    );
    let node = rosrust::name();
    let mut pacer = Pacer::new(params.control.rate_hz);
    let watch = MasterWatch::start(&node);
    let mut last_diag = f64::NEG_INFINITY;
    let mut last_status: Option<&'static str> = None;
    while rosrust::is_ok() && !stop.is_set() && watch.health() != MasterHealth::Restarted {
        let now = now_s();
        let (tick, threats) = {
            let mut core = core.lock().expect("node state lock");
            let tick = core.tick(now);
            (tick, core.threats().to_vec())
        };
        if let Err(e) = cmd_pub.send(twist_to_msg(tick.cmd)) {
            log::warn!("publishing cmd_vel: {e}");
        }
        let _ = state_pub.send(state_msg(&settings.base_frame, now, &tick));
        if settings.publish_markers {
            let _ = markers_pub.send(markers(
                &settings.base_frame,
                time_from_s(now),
                &tick,
                &threats,
                &params,
            ));
        }
        let mut act = activity.lock().expect("activity lock");
        act.ticked(now, &tick);
        // |Δ| so that a clock stepped back does not silence the diagnostics.
        if (now - last_diag).abs() >= 1.0 {
            let _ = diag_pub.send(diagnostics(&node, time_from_s(now), now, &tick, &act));
            last_diag = now;
        }
        drop(act);
        // Log changes of stop status once (by kind: the details change every tick).
        let status = tick
            .scan_fault
            .map(|f| f.code())
            .or(tick.record.stop_cause.map(|c| c.code()));
        if status != last_status {
            match tick.record.stop_cause {
                Some(_) => log::warn!("commanding a stop: {}", stop_reason(&tick)),
                None => log::info!("filtering ({})", tick.nominal_used),
            }
            last_status = status;
        }
        pacer.sleep();
    }
    // Leave the robot stopped: a last zero command, sent a few times.
    log::info!("{node}: shutting down; sending a zero command");
    for _ in 0..3 {
        let _ = cmd_pub.send(twist_to_msg(crate::algo::Twist::ZERO));
        std::thread::sleep(Duration::from_millis(30));
    }
    rosrust::shutdown();
    Ok(watch.health() != MasterHealth::Restarted)
}
