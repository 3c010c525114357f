//! `virtual_drive`: a simulated two-axis motor drive on a CAN interface.

use anyhow::{Context, Result};
use can_bridge::config::{load_config_file, ConfigError, Validate};
use can_bridge::socketcan_bus::SocketCanBus;
use can_bridge::time::{Clock, MonotonicClock};
use can_bridge::virtual_drive::{run_virtual_drive, FaultClock, FaultSpec, VirtualDrive, VirtualDriveConfig};
use can_bridge::{ProtocolKind, Wheel};
use clap::Parser;
use serde_json::json;
use std::io::Write;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// A simulated motor drive (two axes: left and right wheel) on a SocketCAN interface.
///
/// It speaks the generic protocol (can_bridge/dbc/oldbf_generic.dbc), ODrive CANSimple or CANopen
/// CiA 402 (a node per axis, or one node with both axes: SDO, NMT, heartbeats, PDOs, SYNC, profile
/// velocity), follows
/// velocity setpoints with a first-order lag under its own speed and acceleration limits, sends
/// heartbeats/status and encoder feedback, and goes idle with a watchdog error when no valid
/// setpoint arrives for --watchdog-s. Speeds and positions are at the motor shaft.
///
/// Faults (--fault, repeatable), times in s from the drive's start (--faults-from start) or from
/// the first moment both wheels run (--faults-from running: no fault fires before it):
///
///   axis_error@T[:CODE[:left|right|both]]   latch error bits (default 0x1) until cleared
///   heartbeat_silence@T[+D]                 no heartbeat/status frames (for D s, or for good)
///   feedback_silence@T[+D]                  no feedback frames
///   silence@T[+D]                           nothing sent at all (still listening)
///   feedback_delay@T[+D]:S                  feedback frames leave S seconds late
///   exit@T                                  stop sending and exit, as if killed
///   sdo_silence@T[+D]                       cia402: SDO requests get no answer
///   reboot@T[:left|right|both]              cia402: the node(s) reboot (boot-up, defaults)
///
/// odrive: the firmware generation (0.5 or 0.6: heartbeat layout, error numbering, Get_Error) comes
/// from --config (`odrive.firmware`).
///
/// cia402: the axis error CODE is the 0x603F error code (e.g. 0x2310, overcurrent); the watchdog is
/// an RPDO timeout (0x8250); --heartbeat-rate-hz and --feedback-rate-hz are the defaults of 0x1017
/// and of the TPDO event timers; node ids, axes (cia402.left_axis, right_axis, axis_offset: one
/// node with both axes when the node ids are equal), units and the bridge's node id come from
/// --config.
///
/// With --status-rate-hz > 0 the axes' true state is printed on stdout as JSON lines (motor rad,
/// rad/s); a final line is printed at exit. Logs go to stderr (RUST_LOG=info|debug).
#[derive(Parser, Debug)]
#[command(name = "virtual_drive", version, verbatim_doc_comment)]
struct Args {
    /// SocketCAN interface.
    #[arg(long, value_name = "IFACE", default_value = "vcan0")]
    interface: String,
    /// Take the protocol, ids and node ids from this bridge configuration (flags override it).
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Protocol [default: generic, or the configuration's].
    #[arg(long, value_name = "generic|odrive|cia402")]
    protocol: Option<ProtocolKind>,
    /// Generic protocol base id, decimal or 0x hex [default: 0x100, or the configuration's].
    #[arg(long, value_name = "ID", value_parser = parse_id)]
    base_id: Option<u32>,
    /// ODrive (0-63) or CANopen (1-127) node id of the left axis [default: 0, or the configuration's].
    #[arg(long, value_name = "N")]
    left_node: Option<u32>,
    /// ODrive (0-63) or CANopen (1-127) node id of the right axis [default: 1, or the configuration's].
    #[arg(long, value_name = "N")]
    right_node: Option<u32>,
    /// First-order lag time constant τ (s); 0 = instant (within the accel limit).
    #[arg(long, value_name = "S", default_value_t = 0.05)]
    time_constant_s: f64,
    /// The drive's own motor speed limit (rad/s).
    #[arg(long, value_name = "RADPS", default_value_t = 1000.0)]
    max_speed_radps: f64,
    /// The drive's own motor acceleration limit (rad/s²).
    #[arg(long, value_name = "RADPS2", default_value_t = 10000.0)]
    max_accel_radps2: f64,
    /// Command watchdog: no valid setpoint for this long while running → idle + watchdog error (s).
    #[arg(long, value_name = "S", default_value_t = 0.5)]
    watchdog_s: f64,
    /// Heartbeat / status rate (Hz).
    #[arg(long, value_name = "HZ", default_value_t = 10.0)]
    heartbeat_rate_hz: f64,
    /// Encoder feedback rate (Hz).
    #[arg(long, value_name = "HZ", default_value_t = 100.0)]
    feedback_rate_hz: f64,
    /// Inject a fault (see above); repeatable.
    #[arg(long = "fault", value_name = "SPEC")]
    faults: Vec<FaultSpec>,
    /// Where the --fault times are counted from.
    #[arg(long, value_enum, value_name = "WHEN", default_value_t = FaultClock::Start)]
    faults_from: FaultClock,
    /// Exit after this long (s).
    #[arg(long, value_name = "S", value_parser = can_bridge::time::parse_cli_seconds)]
    duration_s: Option<f64>,
    /// Axis state lines per second on stdout (Hz); 0 = only the final line.
    #[arg(long, value_name = "HZ", value_parser = can_bridge::time::parse_cli_rate_hz, default_value_t = 0.0)]
    status_rate_hz: f64,
}

/// A `--node-id`-style value that is not a number.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("`{text}` is not an id (decimal or 0x hex)")]
struct IdError {
    text: String,
    #[source]
    source: std::num::ParseIntError,
}

fn parse_id(s: &str) -> Result<u32, IdError> {
    let r = match s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        Some(h) => u32::from_str_radix(h, 16),
        None => s.parse(),
    };
    r.map_err(|source| IdError {
        text: s.to_string(),
        source,
    })
}

fn main() {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    // roslaunch appends `__name:=…` and `__log:=…` to every command line it starts.
    let args = Args::parse_from(std::env::args().filter(|a| !(a.starts_with("__") && a.contains(":="))));
    match run(args) {
        Ok(code) => std::process::exit(code),
        Err(e) => {
            eprintln!("virtual_drive: {e:#}");
            std::process::exit(1);
        }
    }
}

fn print_state(drive: &VirtualDrive, t_s: f64, kind: &str) {
    let line = json!({
        "type": kind,
        "t_s": t_s,
        "left": drive.axis(Wheel::Left),
        "right": drive.axis(Wheel::Right),
        "stats": drive.stats(),
    });
    let _ = writeln!(std::io::stdout().lock(), "{line}");
}

fn run(args: Args) -> Result<i32> {
    let mut cfg = VirtualDriveConfig {
        time_constant_s: args.time_constant_s,
        max_speed_radps: args.max_speed_radps,
        max_accel_radps2: args.max_accel_radps2,
        watchdog_s: args.watchdog_s,
        heartbeat_rate_hz: args.heartbeat_rate_hz,
        feedback_rate_hz: args.feedback_rate_hz,
        faults: args.faults.clone(),
        faults_from: args.faults_from,
        ..Default::default()
    };
    if let Some(p) = &args.config {
        let b = match load_config_file(p) {
            Ok(b) => b,
            Err(e) => {
                eprintln!("{e}");
                return Ok(2);
            }
        };
        cfg.protocol = args.protocol.unwrap_or(b.protocol);
        cfg.generic_base_id = b.generic.base_id;
        (cfg.left_node_id, cfg.right_node_id) = match cfg.protocol {
            ProtocolKind::Cia402 => (b.cia402.left_node_id, b.cia402.right_node_id),
            _ => (b.odrive.left_node_id, b.odrive.right_node_id),
        };
        cfg.cia402_scaling = b.cia402.scaling();
        cfg.cia402_bridge_node_id = u8::try_from(b.cia402.bridge_node_id).unwrap_or(0);
        cfg.odrive_firmware = b.odrive.firmware;
        cfg.left_axis = u8::try_from(b.cia402.left_axis).unwrap_or(0);
        cfg.right_axis = u8::try_from(b.cia402.right_axis).unwrap_or(0);
        cfg.cia402_axis_offset = u16::try_from(b.cia402.axis_offset).unwrap_or(0);
    }
    if let Some(p) = args.protocol {
        cfg.protocol = p;
    }
    if cfg.protocol == ProtocolKind::Cia402 && args.config.is_none() && args.left_node.is_none() {
        // The shipped configuration's CANopen ids (ODrive's defaults 0/1 are not node ids).
        let b = can_bridge::config::default_config();
        (cfg.left_node_id, cfg.right_node_id) = (b.cia402.left_node_id, b.cia402.right_node_id);
    }
    if let Some(b) = args.base_id {
        cfg.generic_base_id = b;
    }
    if let Some(n) = args.left_node {
        cfg.left_node_id = n;
    }
    if let Some(n) = args.right_node {
        cfg.right_node_id = n;
    }
    if let Err(errors) = cfg.validate() {
        // Keys are the flags' names: `heartbeat_rate_hz` is --heartbeat-rate-hz.
        eprintln!("{}", ConfigError::invalid("virtual_drive", errors));
        return Ok(2);
    }

    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = stop.clone();
        ctrlc::set_handler(move || stop.store(true, Ordering::Relaxed)).context("installing the signal handler")?;
    }
    let clock = MonotonicClock::new();
    let mut bus = SocketCanBus::open(&args.interface)?;
    log::info!(
        "virtual drive on {} ({}), τ = {} s, watchdog {} s",
        args.interface,
        cfg.protocol.name(),
        cfg.time_constant_s,
        cfg.watchdog_s
    );
    let drive = Arc::new(Mutex::new(VirtualDrive::new(cfg, clock.now())));

    // Ends the run at --duration-s, and prints state lines.
    let reporter = {
        let (drive, stop) = (drive.clone(), stop.clone());
        let period =
            (args.status_rate_hz > 0.0).then(|| can_bridge::time::saturating_duration(1.0 / args.status_rate_hz));
        let end = args
            .duration_s
            .map(|d| clock.now() + can_bridge::time::saturating_duration(d));
        std::thread::spawn(move || {
            let mut next = clock.now();
            while !stop.load(Ordering::Relaxed) {
                let now = clock.now();
                if end.is_some_and(|e| now >= e) {
                    stop.store(true, Ordering::Relaxed);
                    break;
                }
                if let Some(p) = period {
                    if now >= next {
                        let d = drive.lock().unwrap_or_else(|e| e.into_inner());
                        print_state(&d, now.as_secs_f64(), "state");
                        next = next + p;
                    }
                }
                std::thread::sleep(Duration::from_millis(5));
            }
        })
    };
    let result = run_virtual_drive(&drive, &mut bus, &clock, &stop);
    stop.store(true, Ordering::Relaxed);
    let _ = reporter.join();
    let d = drive.lock().unwrap_or_else(|e| e.into_inner());
    print_state(&d, clock.now().as_secs_f64(), "final");
    result?;
    Ok(0)
}
