//! Shared by the vcan test groups (vcan_*.rs). They need a kernel with CAN
//! and an UP vcan0: tests/can_group.sh runs them in a QEMU guest. On a
//! machine without vcan0 every test fails at once with a message saying so;
//! they never skip silently. They are excluded from a plain `cargo test`
//! (`test = false` in Cargo.toml).
//!
//! Everything runs in real time on the kernel's vcan0: the bridge in the
//! test thread (SocketCanBus), the virtual drive in a thread or as the
//! `virtual_drive` process, and a sniffer socket that records every frame
//! with its arrival time on the same monotonic clock as the bridge.

#![allow(dead_code)]

use can_bridge::bridge::{Bridge, Spin};
use can_bridge::config::{default_config, BridgeConfig};
use can_bridge::diagnostics::BridgeState;
use can_bridge::protocol::generic::{self, GenericIds};
use can_bridge::protocol::odrive;
use can_bridge::socketcan_bus::SocketCanBus;
use can_bridge::virtual_drive::{run_virtual_drive, FaultKind, VirtualDrive, VirtualDriveConfig};
use can_bridge::{BusEvent, Clock, MonotonicClock, ProtocolKind, Timestamp, Twist};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime};

pub const IFACE: &str = "vcan0";
pub const PERIOD: Duration = Duration::from_millis(20);

static SERIAL: Mutex<()> = Mutex::new(());

/// Fails loudly without vcan0, and serializes the tests of a binary (they share the bus).
pub fn require_vcan() -> MutexGuard<'static, ()> {
    let guard = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let flags = std::fs::read_to_string(format!("/sys/class/net/{IFACE}/flags")).unwrap_or_else(|_| {
        panic!(
            "{IFACE} is missing: the vcan test groups need a kernel with CAN and {IFACE} UP. \
             Run tests/can_group.sh (it boots a QEMU guest), not a plain cargo test on this machine."
        )
    });
    let flags = u32::from_str_radix(flags.trim().trim_start_matches("0x"), 16).unwrap_or(0);
    assert!(flags & 1 == 1, "{IFACE} exists but is not UP (flags 0x{flags:x})");
    guard
}

pub fn log_init() {
    let _ = env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn"))
        .is_test(true)
        .try_init();
}

pub fn bridge_config(protocol: ProtocolKind) -> BridgeConfig {
    let mut c = default_config();
    c.interface = IFACE.into();
    c.protocol = protocol;
    c.odrive.left_node_id = 3;
    c.odrive.right_node_id = 5;
    c.kinematics.gear_ratio = 10.0;
    c.limits.max_wheel_speed_radps = 20.0;
    c.limits.v_max_mps = 0.5;
    c.limits.omega_max_radps = 5.0;
    c.limits.wheel_accel_radps2 = 30.0;
    c.limits.wheel_decel_radps2 = 30.0;
    // Emulated guest: a little more slack than on hardware.
    c.timing.feedback_timeout_s = 0.3;
    c.timing.heartbeat_timeout_s = 0.5;
    c
}

pub fn drive_config(c: &BridgeConfig) -> VirtualDriveConfig {
    VirtualDriveConfig {
        protocol: c.protocol,
        generic_base_id: c.generic.base_id,
        left_node_id: c.odrive.left_node_id,
        right_node_id: c.odrive.right_node_id,
        time_constant_s: 0.02,
        ..Default::default()
    }
}

/// One clock for every thread of a test.
pub fn clock() -> MonotonicClock {
    MonotonicClock::with_epoch(Instant::now())
}

/// Records every frame and error frame on vcan0, stamped with the kernel's
/// receive time (mapped onto the test's monotonic clock), so the sniffer
/// thread's own scheduling delays do not show in the measurements.
pub struct Sniffer {
    frames: Arc<Mutex<Vec<(Timestamp, BusEvent)>>>,
    stop: Arc<AtomicBool>,
    handle: Option<JoinHandle<()>>,
}

impl Sniffer {
    pub fn start(clock: MonotonicClock) -> Self {
        let frames = Arc::new(Mutex::new(Vec::new()));
        let stop = Arc::new(AtomicBool::new(false));
        let mut bus = SocketCanBus::open(IFACE).expect("sniffer socket");
        bus.accept_all().unwrap();
        bus.enable_kernel_timestamps().unwrap();
        // Wall clock ↔ monotonic clock: the tightest of a few bracketed samples
        // (a preemption between the two reads would shift every time).
        let (wall0, mono0) = (0..20)
            .map(|_| {
                let a = clock.now();
                let w = SystemTime::now();
                let b = clock.now();
                (b - a, w, a + (b - a) / 2)
            })
            .min_by_key(|x| x.0)
            .map(|(_, w, m)| (w, m))
            .unwrap();
        let (f, s) = (frames.clone(), stop.clone());
        let handle = std::thread::spawn(move || {
            while !s.load(Ordering::Relaxed) {
                match bus.recv_timestamped(Duration::from_millis(10)) {
                    Ok(Some((ev, wall))) => {
                        let t = match wall.duration_since(wall0) {
                            Ok(d) => mono0 + d,
                            Err(_) => mono0,
                        };
                        f.lock().unwrap().push((t, ev));
                    }
                    Ok(None) => {}
                    Err(_) => std::thread::sleep(Duration::from_millis(2)),
                }
            }
        });
        Self {
            frames,
            stop,
            handle: Some(handle),
        }
    }

    pub fn frames(&self) -> Vec<(Timestamp, BusEvent)> {
        self.frames.lock().unwrap().clone()
    }
}

impl Drop for Sniffer {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}

/// The virtual drive in a thread, on its own socket.
pub struct DriveThread {
    pub drive: Arc<Mutex<VirtualDrive>>,
    stop: Arc<AtomicBool>,
    handle: Option<JoinHandle<()>>,
    clock: MonotonicClock,
}

impl DriveThread {
    pub fn start(cfg: VirtualDriveConfig, clock: MonotonicClock) -> Self {
        let drive = Arc::new(Mutex::new(VirtualDrive::new(cfg, clock.now())));
        let stop = Arc::new(AtomicBool::new(false));
        let mut bus = SocketCanBus::open(IFACE).expect("drive socket");
        let (d, s) = (drive.clone(), stop.clone());
        let handle = std::thread::spawn(move || {
            run_virtual_drive(&d, &mut bus, &clock, &s).expect("virtual drive");
        });
        Self {
            drive,
            stop,
            handle: Some(handle),
            clock,
        }
    }

    pub fn inject(&self, kind: FaultKind, duration_s: Option<f64>) {
        let now = self.clock.now();
        self.drive.lock().unwrap().inject(kind, duration_s, now);
    }

    pub fn axis(&self, w: can_bridge::Wheel) -> can_bridge::virtual_drive::AxisSnapshot {
        self.drive.lock().unwrap().axis(w)
    }
}

impl Drop for DriveThread {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}

pub fn bridge(c: BridgeConfig, clock: &MonotonicClock) -> Bridge<SocketCanBus> {
    let bus = SocketCanBus::open(IFACE).expect("bridge socket");
    Bridge::new(c, bus, clock.now()).expect("bridge")
}

/// One loop step as the binaries take it: spin, back off if the bus failed at once.
pub fn spin(b: &mut Bridge<SocketCanBus>, clock: &MonotonicClock) {
    if let Spin::BackOff(d) = b.spin_once(clock, Duration::from_millis(2)) {
        std::thread::sleep(d);
    }
}

/// Spins the bridge for `s` seconds, calling `each` every iteration.
pub fn run_for<F: FnMut(&mut Bridge<SocketCanBus>, Timestamp)>(
    b: &mut Bridge<SocketCanBus>,
    clock: &MonotonicClock,
    s: f64,
    mut each: F,
) {
    let end = clock.now() + Duration::from_secs_f64(s);
    while clock.now() < end {
        spin(b, clock);
        each(b, clock.now());
    }
}

/// A teleop stream: `twist` every 50 ms for `s` seconds; returns the time of the last command.
pub fn teleop(b: &mut Bridge<SocketCanBus>, clock: &MonotonicClock, twist: Twist, s: f64) -> Timestamp {
    let mut next = clock.now();
    let mut last = clock.now();
    run_for(b, clock, s, |b, now| {
        if now >= next {
            b.command(twist, now).unwrap();
            last = now;
            next = next + Duration::from_millis(50);
        }
    });
    last
}

/// Spins until `pred` holds (returns when) or `timeout_s` passes (None).
pub fn wait_until<P: FnMut(&Bridge<SocketCanBus>) -> bool>(
    b: &mut Bridge<SocketCanBus>,
    clock: &MonotonicClock,
    timeout_s: f64,
    mut pred: P,
) -> Option<Timestamp> {
    let end = clock.now() + Duration::from_secs_f64(timeout_s);
    while clock.now() < end {
        spin(b, clock);
        if pred(b) {
            return Some(clock.now());
        }
    }
    None
}

/// Waits for the drive to be started (Idle), failing the test if it takes over 5 s.
pub fn wait_ready(b: &mut Bridge<SocketCanBus>, clock: &MonotonicClock) {
    wait_until(b, clock, 5.0, |b| b.state() == BridgeState::Idle)
        .unwrap_or_else(|| panic!("drive not ready in 5 s: {:?}", b.reasons()));
}

pub fn has_reason(b: &Bridge<SocketCanBus>, name: &str) -> bool {
    b.reasons().iter().any(|r| r.name() == name)
}

/// A setpoint frame as seen on the wire.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WireSetpoint {
    pub t: Timestamp,
    /// 0 left, 1 right.
    pub wheel: usize,
    /// Motor speed (rad/s).
    pub vel_radps: f64,
    pub estop: bool,
    /// Generic counter (0 for ODrive).
    pub counter: u8,
    /// Generic Enable flag (true for ODrive velocity frames; CiA 402: enable operation).
    pub enable: bool,
}

/// Decodes the bridge's setpoint frames (and e-stops) from a capture;
/// panics on any malformed or non-finite setpoint.
pub fn setpoints(frames: &[(Timestamp, BusEvent)], protocol: ProtocolKind) -> Vec<WireSetpoint> {
    let ids = GenericIds { base_id: 0x100 };
    let mut out = Vec::new();
    for (t, ev) in frames {
        let BusEvent::Frame(f) = ev else { continue };
        match protocol {
            ProtocolKind::Generic => {
                if let Some((w, sp)) = generic::decode_setpoint(ids, f).unwrap_or_else(|e| panic!("{f:?}: {e}")) {
                    assert!(sp.vel_radps.is_finite());
                    out.push(WireSetpoint {
                        t: *t,
                        wheel: w.index(),
                        vel_radps: sp.vel_radps,
                        estop: sp.estop,
                        counter: sp.counter,
                        enable: sp.enable,
                    });
                }
            }
            ProtocolKind::Cia402 => {
                // RPDO1 of the shipped configuration's nodes 1 and 2.
                let wheel = match f.id {
                    0x201 => 0,
                    0x202 => 1,
                    _ => continue,
                };
                let r = can_bridge::protocol::cia402::pdo::decode_rpdo1(f).unwrap_or_else(|e| panic!("{f:?}: {e}"));
                let scaling = can_bridge::config::default_config().cia402.scaling();
                out.push(WireSetpoint {
                    t: *t,
                    wheel,
                    vel_radps: scaling.velocity_from_drive(r.target_velocity),
                    estop: r.controlword == 0x0002,
                    counter: 0,
                    enable: r.controlword == 0x000F,
                });
            }
            ProtocolKind::Odrive => {
                let (node, cmd) = odrive::split_id(f.id);
                let wheel = match node {
                    3 => 0,
                    5 => 1,
                    _ => continue,
                };
                match odrive::decode_command(f).unwrap_or_else(|e| panic!("{f:?}: {e}")) {
                    Some(odrive::Command::SetInputVel { vel_turns_per_s, .. }) => {
                        assert!(vel_turns_per_s.is_finite(), "{f:?}");
                        out.push(WireSetpoint {
                            t: *t,
                            wheel,
                            vel_radps: f64::from(vel_turns_per_s) * std::f64::consts::TAU,
                            estop: false,
                            counter: 0,
                            enable: true,
                        });
                    }
                    Some(odrive::Command::Estop) if cmd == odrive::cmd::ESTOP => out.push(WireSetpoint {
                        t: *t,
                        wheel,
                        vel_radps: 0.0,
                        estop: true,
                        counter: 0,
                        enable: false,
                    }),
                    _ => {}
                }
            }
        }
    }
    out
}

/// Runs a command (ip, tc) and fails the test with its output if it fails.
pub fn sh(args: &[&str]) {
    let out = std::process::Command::new(args[0])
        .args(&args[1..])
        .output()
        .unwrap_or_else(|e| panic!("cannot run {args:?}: {e}"));
    assert!(
        out.status.success(),
        "{args:?} failed: {}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Restores vcan0 (qdisc removed, link up) when dropped, even if the test panics.
pub struct RestoreVcan;

impl Drop for RestoreVcan {
    fn drop(&mut self) {
        let _ = std::process::Command::new("tc")
            .args(["qdisc", "del", "dev", IFACE, "root"])
            .output();
        let _ = std::process::Command::new("ip")
            .args(["link", "set", IFACE, "up"])
            .output();
    }
}

/// Seconds between two timestamps (b − a, may be negative).
pub fn secs(a: Timestamp, b: Timestamp) -> f64 {
    b.as_secs_f64() - a.as_secs_f64()
}
