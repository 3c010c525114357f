//! `can_bridge_cli`: runs the bridge on a CAN interface, reading commands
//! from stdin or a timed script, printing JSON lines. A thin adapter over
//! `can_bridge::Bridge`, like the ROS node will be.

use anyhow::{bail, Context, Result};
use can_bridge::bridge::{Bridge, ShutdownProgress, Spin};
use can_bridge::config::{default_config, load_config_file, BridgeConfig, ConfigError, Validate};
use can_bridge::protocol::cia402::sdo_jobs::{SdoJob, SdoJobResult};
use can_bridge::script::{parse_action, parse_script, Action, ScriptError, ScriptStep};
use can_bridge::socketcan_bus::SocketCanBus;
use can_bridge::time::{Clock, MonotonicClock, Timestamp};
use can_bridge::ProtocolKind;
use clap::Parser;
use serde_json::{json, Value};
use std::io::{BufRead, Write};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::time::Duration;

/// Runs the CAN motor bridge on a SocketCAN interface.
///
/// Commands come from stdin, one per line, or from a timed --script:
///
///   V OMEGA        velocity command: forward speed (m/s) and yaw rate (rad/s, CCW positive)
///   estop          latch the e-stop (e-stop frames every period until reset)
///   reset          clear the e-stop and latched drive faults (then a fresh command is needed)
///   status         print a status line now
///   quit           shut down: zero setpoint, then disable the drive
///   sdo_read N I S        CANopen (cia402): read object I, sub-index S of node N (0x hex or decimal)
///   sdo_write N I S HEX   write the bytes HEX (e8030000 is 1000 as a u32); refused (0x08000022)
///                         while the node's drive is enabled if the object could change motion
///
/// A script line starts with its time in seconds from the start (`1.5 0.2 0.0`, `3 estop`), and
/// `T V OMEGA every DT until T_END` repeats a command like a teleop stream.
///
/// Output on stdout, one JSON object per line, each with "type": "command" (as received),
/// "event" (state changes, rejections, faults, bus errors), "status" (periodic: state, stop
/// reasons, setpoints in rad/s, odometry in m and rad, drive link, counters), "sdo" (the end of an
/// SDO request: ok, data_hex, text, abort_code, message) and "final" (at exit).
/// Logs go to stderr (RUST_LOG=info|debug). Exit status: 0 after a clean shutdown, 2 for a bad
/// configuration or script, 1 otherwise (e.g. the interface cannot be opened).
#[derive(Parser, Debug)]
#[command(name = "can_bridge_cli", version, verbatim_doc_comment)]
struct Args {
    /// Bridge configuration (YAML); default: the built-in config/can_bridge.yaml.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// SocketCAN interface, overriding the configuration's `interface`.
    #[arg(long, value_name = "IFACE")]
    interface: Option<String>,
    /// Drive protocol, overriding the configuration's `protocol`.
    #[arg(long, value_name = "generic|odrive|cia402")]
    protocol: Option<ProtocolKind>,
    /// Timed command script instead of stdin.
    #[arg(long, value_name = "FILE")]
    script: Option<PathBuf>,
    /// After the script's last step, keep running this long before shutting down (s).
    #[arg(long, value_name = "S", value_parser = can_bridge::time::parse_cli_seconds, default_value_t = 0.5)]
    linger_s: f64,
    /// Exit (with a clean shutdown) after this long (s). With stdin, end of input no longer exits.
    #[arg(long, value_name = "S", value_parser = can_bridge::time::parse_cli_seconds)]
    duration_s: Option<f64>,
    /// Status lines per second (Hz); 0 = only the final one (events are always printed).
    #[arg(long, value_name = "HZ", value_parser = can_bridge::time::parse_cli_rate_hz, default_value_t = 10.0)]
    status_rate_hz: f64,
    /// Print the effective configuration as JSON and exit.
    #[arg(long)]
    print_config: bool,
}

/// Prints one JSON line with "type" first.
fn emit(kind: &str, mut v: Value) {
    let mut obj = serde_json::Map::new();
    obj.insert("type".into(), Value::String(kind.into()));
    if let Value::Object(m) = &mut v {
        obj.append(m);
    }
    let mut out = std::io::stdout().lock();
    // A closed stdout (reader gone) must not panic the bridge.
    let _ = writeln!(out, "{}", Value::Object(obj));
}

fn load(args: &Args) -> Result<BridgeConfig, ConfigError> {
    let mut cfg = match &args.config {
        Some(p) => load_config_file(p)?,
        None => default_config(),
    };
    if let Some(i) = &args.interface {
        cfg.interface = i.clone();
    }
    if let Some(p) = args.protocol {
        cfg.protocol = p;
    }
    // The overrides are checked like the file; errors name the command line.
    cfg.validate().map_err(|es| ConfigError::invalid("command line", es))?;
    Ok(cfg)
}

fn main() {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    let args = Args::parse();
    match run(args) {
        Ok(code) => std::process::exit(code),
        Err(e) => {
            eprintln!("can_bridge_cli: {e:#}");
            std::process::exit(1);
        }
    }
}

fn run(args: Args) -> Result<i32> {
    let cfg = match load(&args) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("{e}");
            return Ok(2);
        }
    };
    if args.print_config {
        println!("{}", serde_json::to_string_pretty(&cfg)?);
        return Ok(0);
    }
    let script: Option<Vec<ScriptStep>> = match &args.script {
        Some(p) => {
            let text = std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
            match parse_script(&text) {
                Ok(s) => Some(s),
                Err(e) => {
                    eprintln!("{}: {e}", p.display());
                    return Ok(2);
                }
            }
        }
        None => None,
    };

    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = stop.clone();
        ctrlc::set_handler(move || stop.store(true, Ordering::Relaxed)).context("installing the signal handler")?;
    }

    let clock = MonotonicClock::new();
    let bus = SocketCanBus::open(&cfg.interface)?;
    let interface = cfg.interface.clone();
    let protocol = cfg.protocol;
    let mut bridge = Bridge::new(cfg, bus, clock.now())?;
    log::info!("bridge on {interface}, protocol {}", protocol.name());

    // stdin reader: stamps each line with its arrival time.
    let (tx, rx) = mpsc::channel::<Option<(Timestamp, Result<Action, ScriptError>)>>();
    if script.is_none() {
        std::thread::spawn(move || {
            for line in std::io::stdin().lock().lines() {
                let Ok(line) = line else { break };
                let now = clock.now();
                match parse_action(&line) {
                    Ok(Some(a)) => {
                        if tx.send(Some((now, Ok(a)))).is_err() {
                            return;
                        }
                    }
                    Ok(None) => {}
                    Err(e) => {
                        let _ = tx.send(Some((now, Err(e))));
                    }
                }
            }
            let _ = tx.send(None);
        });
    }

    let start = clock.now();
    let at = |s: f64| start + can_bridge::time::saturating_duration(s);
    let end: Option<Timestamp> = match (&script, args.duration_s) {
        (_, Some(d)) => Some(at(d)),
        (Some(s), None) => Some(at(s.last().map_or(0.0, |x| x.at_s) + args.linger_s)),
        (None, None) => None,
    };
    let status_period =
        (args.status_rate_hz > 0.0).then(|| can_bridge::time::saturating_duration(1.0 / args.status_rate_hz));
    let mut next_status = start;
    let mut next_step = 0usize;
    let mut quit = false;
    let rel = |t: Timestamp| t.saturating_since(start).as_secs_f64();

    let apply = |bridge: &mut Bridge<SocketCanBus>, action: Action, t: Timestamp, quit: &mut bool| match action {
        Action::Twist(tw) => {
            emit(
                "command",
                json!({"t_s": rel(t), "linear_mps": tw.linear_mps, "angular_radps": tw.angular_radps}),
            );
            let _ = bridge.command(tw, t);
        }
        Action::Estop => {
            emit("command", json!({"t_s": rel(t), "command": "estop"}));
            bridge.estop(t);
        }
        Action::Reset => {
            emit("command", json!({"t_s": rel(t), "command": "reset"}));
            bridge.reset(t);
        }
        Action::Status => emit("status", status_json(bridge, t, start)),
        Action::Quit => *quit = true,
        Action::SdoRead { node, index, sub } => {
            emit(
                "command",
                json!({"t_s": rel(t), "command": "sdo_read", "node": node, "index": index, "sub": sub}),
            );
            sdo(bridge, SdoJob::read(node, index, sub), t, start);
        }
        Action::SdoWrite { node, index, sub, data } => {
            emit(
                "command",
                json!({"t_s": rel(t), "command": "sdo_write", "node": node, "index": index, "sub": sub, "data_hex": hex(&data)}),
            );
            sdo(bridge, SdoJob::write(node, index, sub, data), t, start);
        }
    };

    while !quit && !stop.load(Ordering::Relaxed) {
        let now = clock.now();
        if end.is_some_and(|e| now >= e) {
            break;
        }
        if let Some(steps) = &script {
            while let Some(s) = steps.get(next_step) {
                if now < at(s.at_s) {
                    break;
                }
                apply(&mut bridge, s.action.clone(), now, &mut quit);
                next_step += 1;
            }
        }
        loop {
            match rx.try_recv() {
                Ok(Some((t, Ok(a)))) => apply(&mut bridge, a, t, &mut quit),
                Ok(Some((t, Err(e)))) => {
                    emit("input_error", json!({"t_s": rel(t), "error": e.to_string()}));
                }
                Ok(None) => {
                    if args.duration_s.is_none() {
                        quit = true;
                    }
                    break;
                }
                Err(_) => break,
            }
        }
        if quit {
            break;
        }
        // Wake for the bridge's deadline, the next script step, the next
        // status line, and at least every 2 ms for stdin.
        let mut max_wait = if script.is_some() {
            Duration::from_millis(50)
        } else {
            Duration::from_millis(2)
        };
        if let Some(s) = script.as_ref().and_then(|s| s.get(next_step)) {
            max_wait = max_wait.min(at(s.at_s) - now);
        }
        if status_period.is_some() {
            max_wait = max_wait.min(next_status - now);
        }
        if let Spin::BackOff(d) = bridge.spin_once(&clock, max_wait) {
            std::thread::sleep(d);
        }
        emit_events(&mut bridge, start);
        for r in bridge.take_sdo_results() {
            emit("sdo", sdo_json(&r, clock.now(), start));
        }
        if let Some(p) = status_period {
            let now = clock.now();
            if now >= next_status {
                emit("status", status_json(&bridge, now, start));
                while next_status <= now {
                    next_status = next_status + p;
                }
            }
        }
    }

    let now = clock.now();
    let failed = shut_down(&mut bridge, &clock);
    emit_events(&mut bridge, start);
    let mut fin = status_json(&bridge, now, start);
    fin["shutdown_frames_failed"] = json!(failed);
    emit("final", fin);
    if failed > 0 {
        bail!("{failed} shutdown frame(s) could not be sent");
    }
    Ok(0)
}

/// Zero, then disable, waiting between retries; how many frames failed.
fn shut_down(bridge: &mut Bridge<SocketCanBus>, clock: &MonotonicClock) -> usize {
    loop {
        match bridge.shutdown(clock.now()) {
            ShutdownProgress::Done { failed } => return failed,
            ShutdownProgress::Pending { retry_at } => std::thread::sleep(retry_at - clock.now()),
        }
    }
}

fn hex(data: &[u8]) -> String {
    data.iter().map(|b| format!("{b:02x}")).collect()
}

/// A request to the bridge; a refusal is printed at once as its "sdo" line.
fn sdo(bridge: &mut Bridge<SocketCanBus>, job: SdoJob, t: Timestamp, start: Timestamp) {
    let (node, index, sub, write) = (job.node, job.addr.index, job.addr.sub, job.is_write());
    if let Err(e) = bridge.sdo_request(job, t) {
        emit(
            "sdo",
            json!({"t_s": t.saturating_since(start).as_secs_f64(), "node": node, "index": index, "sub": sub,
                   "write": write, "ok": false, "refused": true, "abort_code": e.abort_code(),
                   "message": format!("refused by the bridge: {e}")}),
        );
    }
}

/// An SDO result: the bytes as hex, and as text when they are printable.
fn sdo_json(r: &SdoJobResult, now: Timestamp, start: Timestamp) -> Value {
    let text = std::str::from_utf8(&r.data)
        .ok()
        .filter(|s| !s.is_empty() && s.chars().all(|c| !c.is_control()));
    json!({"t_s": now.saturating_since(start).as_secs_f64(), "id": r.id, "node": r.node, "index": r.index,
           "sub": r.sub, "write": r.write, "ok": r.ok, "refused": false, "data_hex": hex(&r.data), "text": text,
           "abort_code": r.abort_code, "message": r.message})
}

/// Prints the bridge's events, times relative to the CLI's start.
fn emit_events(bridge: &mut Bridge<SocketCanBus>, start: Timestamp) {
    for e in bridge.drain_events() {
        let mut v = serde_json::to_value(&e).unwrap_or(Value::Null);
        v["t_s"] = json!(e.t_s - start.as_secs_f64());
        emit("event", v);
    }
}

/// A status snapshot with times relative to the CLI's start.
fn status_json(bridge: &Bridge<SocketCanBus>, now: Timestamp, start: Timestamp) -> Value {
    let mut v = serde_json::to_value(bridge.status(now)).unwrap_or(Value::Null);
    v["t_s"] = json!(now.saturating_since(start).as_secs_f64());
    v
}
