//! A simulated two-axis motor drive that speaks both protocols: what stands
//! in for the real drive in tests and when trying the bridge by hand.
//!
//! Each axis follows its velocity setpoint with a first-order lag (time
//! constant τ) under its own speed and acceleration limits, and integrates
//! its position. The drive sends heartbeats/status and encoder feedback at
//! fixed rates, has its own command watchdog (no valid setpoint for
//! `watchdog_s` → idle with a watchdog error, as a real ODrive does), and
//! can be told to inject faults: an axis error, heartbeat or feedback
//! silence, total silence, delayed feedback, or exiting as if killed.
//!
//! Protocol behaviour:
//! * generic: one drive for both wheels. Setpoints need a good CRC and a
//!   counter different from the previous one on that wheel (else rejected,
//!   and the watchdog is not fed). Enable=1 enables (from disabled, without
//!   error); Estop=1 latches e-stop; Enable=0, Estop=0 disables and clears a
//!   latched e-stop or error.
//! * odrive: one node per wheel. Clear_Errors, Set_Controller_Mode,
//!   Set_Input_Vel (feeds the watchdog), Set_Axis_State (closed loop only
//!   without error and in velocity mode), Estop (error ESTOP_REQUESTED,
//!   idle). A closed-loop request while the input velocity is non-zero is
//!   counted as a start-up order violation.
//! * cia402: one CANopen node per wheel ([`cia402`]): SDO server, NMT,
//!   heartbeat producer and consumer, PDOs from the mapped dictionary,
//!   SYNC, the CiA 402 state machine and profile velocity ramps. The
//!   watchdog is an RPDO timeout (error 0x8250); faults add `sdo_silence`
//!   (SDO requests unanswered) and `reboot` (boot-up, dictionary defaults).
//!
//! The type is pure (time is an argument); [`run_virtual_drive`] runs it on a bus.

use crate::bus::{BusEvent, CanBus, CanFrame, RxFilter, SendError};
use crate::kinematics::Wheel;
pub mod cia402;

use crate::protocol::cia402::units::{Scaling, VelocityUnit};
use crate::protocol::generic::{self, GenericIds};
use crate::protocol::odrive::{self, Command};
use crate::protocol::ProtocolKind;
use crate::time::{Clock, Timestamp};
use serde::Serialize;
use std::collections::VecDeque;
use std::f64::consts::TAU;
use std::str::FromStr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::Duration;

/// Integration step of the axis model.
const PHYSICS_STEP: Duration = Duration::from_millis(1);

/// How the simulated drive behaves.
#[derive(Clone, Debug, PartialEq)]
pub struct VirtualDriveConfig {
    pub protocol: ProtocolKind,
    /// Generic: base id.
    pub generic_base_id: u32,
    /// ODrive: node ids.
    pub left_node_id: u32,
    pub right_node_id: u32,
    /// First-order lag time constant τ (s); 0 = follows instantly (within the accel limit).
    pub time_constant_s: f64,
    /// The drive's own motor speed limit (rad/s).
    pub max_speed_radps: f64,
    /// The drive's own motor acceleration limit (rad/s²).
    pub max_accel_radps2: f64,
    /// No valid setpoint for this long while running → idle with a watchdog error (s).
    pub watchdog_s: f64,
    /// Heartbeat / status rate (Hz).
    pub heartbeat_rate_hz: f64,
    /// Encoder feedback rate (Hz).
    pub feedback_rate_hz: f64,
    /// Scheduled faults (times from the drive's start).
    pub faults: Vec<FaultSpec>,
    /// CiA 402: the units of the drive's velocity and position objects.
    pub cia402_scaling: Scaling,
    /// CiA 402: the bridge's node id (whose heartbeat 0x1016:01 may watch).
    pub cia402_bridge_node_id: u8,
}

impl Default for VirtualDriveConfig {
    fn default() -> Self {
        Self {
            protocol: ProtocolKind::Generic,
            generic_base_id: generic::DEFAULT_BASE_ID,
            left_node_id: 0,
            right_node_id: 1,
            time_constant_s: 0.05,
            max_speed_radps: 1000.0,
            max_accel_radps2: 10_000.0,
            watchdog_s: 0.5,
            heartbeat_rate_hz: 10.0,
            feedback_rate_hz: 100.0,
            faults: Vec::new(),
            cia402_scaling: Scaling::new(VelocityUnit::Rpm, 1.0, 4096),
            cia402_bridge_node_id: 127,
        }
    }
}

impl VirtualDriveConfig {
    /// Checks rates and limits; the message names the option.
    pub fn validate(&self) -> Result<(), String> {
        let pos = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("{name} = {v} must be a positive number"))
            }
        };
        pos("max speed", self.max_speed_radps)?;
        pos("max accel", self.max_accel_radps2)?;
        // Bounded as well as positive: a period of 1 / 1e-300 s or a watchdog of
        // 1e300 s cannot be a std Duration.
        let within = |name: &str, v: f64, lo: f64, hi: f64, unit: &str| {
            if (lo..=hi).contains(&v) {
                Ok(())
            } else {
                Err(format!("{name} = {v} is out of range; allowed: [{lo}, {hi}] {unit}"))
            }
        };
        within("watchdog", self.watchdog_s, 1e-3, 3600.0, "s")?;
        within("heartbeat rate", self.heartbeat_rate_hz, 0.01, 10000.0, "Hz")?;
        within("feedback rate", self.feedback_rate_hz, 0.01, 10000.0, "Hz")?;
        if !(self.time_constant_s.is_finite() && self.time_constant_s >= 0.0) {
            return Err(format!("time constant = {} must be ≥ 0", self.time_constant_s));
        }
        if self.generic_base_id > generic::MAX_BASE_ID {
            return Err(format!("generic base id 0x{:X} > 0x7ED", self.generic_base_id));
        }
        if self.protocol == ProtocolKind::Cia402 {
            let ok = |n: u32| (1..=127).contains(&n);
            if !ok(self.left_node_id) || !ok(self.right_node_id) || !ok(u32::from(self.cia402_bridge_node_id)) {
                return Err("CANopen node ids must be in [1, 127]".into());
            }
        } else if self.left_node_id > odrive::MAX_NODE_ID || self.right_node_id > odrive::MAX_NODE_ID {
            return Err("node ids must be in [0, 63]".into());
        }
        if self.left_node_id == self.right_node_id {
            return Err("left and right node ids must differ".into());
        }
        Ok(())
    }
}

/// A fault to inject.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FaultKind {
    /// Sets error bits on one axis or both (generic: Error_Code, state FAULT;
    /// ODrive: Axis_Error, idle). Latched until cleared by the bridge.
    AxisError { code: u32, wheel: Option<Wheel> },
    /// No heartbeats / status frames while active.
    HeartbeatSilence,
    /// No feedback frames while active.
    FeedbackSilence,
    /// Nothing at all is sent while active (the drive still listens).
    Silence,
    /// Feedback frames leave this late while active (s).
    FeedbackDelay { delay_s: f64 },
    /// The drive stops sending for good, as if killed.
    Exit,
    /// CiA 402: SDO requests get no answer while active.
    SdoSilence,
    /// CiA 402: the node(s) reboot (boot-up message, dictionary defaults,
    /// switch on disabled), as after a power glitch.
    Reboot { wheel: Option<Wheel> },
}

/// A fault at a time (from the drive's start), optionally for a duration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaultSpec {
    pub kind: FaultKind,
    pub start_s: f64,
    /// `None`: until the end (one-shot kinds ignore it).
    pub duration_s: Option<f64>,
}

impl FaultSpec {
    fn active(&self, t_s: f64) -> bool {
        t_s >= self.start_s && self.duration_s.is_none_or(|d| t_s < self.start_s + d)
    }
}

fn parse_num(s: &str, what: &str) -> Result<f64, String> {
    s.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite() && *v >= 0.0)
        .ok_or_else(|| format!("{what} `{s}` is not a non-negative number"))
}

fn parse_u32(s: &str) -> Result<u32, String> {
    let r = match s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        Some(hex) => u32::from_str_radix(hex, 16),
        None => s.parse(),
    };
    r.map_err(|_| format!("error code `{s}` is not a u32 (decimal or 0x hex)"))
}

impl FromStr for FaultSpec {
    type Err = String;

    /// `KIND@START[+DURATION][:ARG[:ARG]]`, e.g. `axis_error@2:0x20:left`,
    /// `heartbeat_silence@3+1.5`, `feedback_delay@1+5:0.3`, `exit@4`.
    fn from_str(s: &str) -> Result<Self, String> {
        let (kind, rest) = s
            .split_once('@')
            .ok_or_else(|| format!("fault `{s}`: expected KIND@START[+DURATION][:ARGS]"))?;
        let mut parts = rest.split(':');
        let when = parts.next().unwrap_or_default();
        let args: Vec<&str> = parts.collect();
        let (start, dur) = match when.split_once('+') {
            Some((a, b)) => (parse_num(a, "start")?, Some(parse_num(b, "duration")?)),
            None => (parse_num(when, "start")?, None),
        };
        let no_args = |k: FaultKind| {
            if args.is_empty() {
                Ok(k)
            } else {
                Err(format!("fault `{s}`: {kind} takes no arguments"))
            }
        };
        let kind = match kind {
            "axis_error" => {
                let code = match args.first() {
                    Some(c) => parse_u32(c)?,
                    None => 0x1,
                };
                let wheel = match args.get(1).copied() {
                    None | Some("both") => None,
                    Some("left") => Some(Wheel::Left),
                    Some("right") => Some(Wheel::Right),
                    Some(w) => return Err(format!("fault `{s}`: wheel `{w}` is not left, right or both")),
                };
                if code == 0 {
                    return Err(format!("fault `{s}`: error code 0 is no error"));
                }
                FaultKind::AxisError { code, wheel }
            }
            "heartbeat_silence" => no_args(FaultKind::HeartbeatSilence)?,
            "feedback_silence" => no_args(FaultKind::FeedbackSilence)?,
            "silence" => no_args(FaultKind::Silence)?,
            "feedback_delay" => {
                let d = args
                    .first()
                    .ok_or_else(|| format!("fault `{s}`: feedback_delay needs :SECONDS"))?;
                FaultKind::FeedbackDelay {
                    delay_s: parse_num(d, "delay")?,
                }
            }
            "exit" => no_args(FaultKind::Exit)?,
            "sdo_silence" => no_args(FaultKind::SdoSilence)?,
            "reboot" => {
                let wheel = match args.first().copied() {
                    None | Some("both") => None,
                    Some("left") => Some(Wheel::Left),
                    Some("right") => Some(Wheel::Right),
                    Some(w) => return Err(format!("fault `{s}`: wheel `{w}` is not left, right or both")),
                };
                if args.len() > 1 {
                    return Err(format!("fault `{s}`: reboot takes at most a wheel"));
                }
                FaultKind::Reboot { wheel }
            }
            k => {
                return Err(format!(
                    "fault `{s}`: unknown kind `{k}`; allowed: axis_error, heartbeat_silence, feedback_silence, silence, feedback_delay, exit, sdo_silence, reboot"
                ))
            }
        };
        Ok(FaultSpec {
            kind,
            start_s: start,
            duration_s: dur,
        })
    }
}

/// One axis as seen from outside.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct AxisSnapshot {
    /// Motor speed (rad/s).
    pub vel_radps: f64,
    /// Motor angle (rad).
    pub pos_rad: f64,
    /// What the axis is tracking (rad/s).
    pub target_radps: f64,
    /// Following setpoints (generic enabled / ODrive closed loop).
    pub running: bool,
    pub error_code: u32,
}

/// Counters of what the drive received.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct DriveStats {
    pub setpoints_accepted: u64,
    /// Bad CRC, reserved bits, frozen counter (generic) or malformed frames.
    pub setpoints_rejected: u64,
    pub frozen_counters: u64,
    pub watchdog_trips: u64,
    pub estops: u64,
    pub clear_requests: u64,
    /// ODrive: closed loop requested while the input velocity was non-zero.
    pub closed_loop_with_nonzero_input: u64,
    pub heartbeats_sent: u64,
    pub feedback_sent: u64,
}

#[derive(Clone, Copy, Debug, Default)]
struct Axis {
    vel: f64,
    pos: f64,
    /// Commanded (rad/s), before the running check.
    input: f64,
    running: bool,
    error: u32,
    last_setpoint: Option<Timestamp>,
    last_counter: Option<u8>,
    feedback_counter: u8,
    control_mode: u32,
    input_mode: u32,
}

/// The simulated drive.
#[derive(Debug)]
pub struct VirtualDrive {
    cfg: VirtualDriveConfig,
    axes: [Axis; 2],
    start: Timestamp,
    last_advance: Timestamp,
    next_heartbeat: Timestamp,
    next_feedback: Timestamp,
    /// Generic: drive state (shared by both axes).
    generic_state: u8,
    status_counter: u8,
    delayed: VecDeque<(Timestamp, CanFrame)>,
    applied: Vec<bool>,
    exited: bool,
    stats: DriveStats,
    /// CiA 402 nodes (left, right); empty for the other protocols.
    co: Vec<cia402::CoNode>,
}

impl VirtualDrive {
    /// A drive powered up at `now`, idle, without error.
    pub fn new(cfg: VirtualDriveConfig, now: Timestamp) -> Self {
        let n = cfg.faults.len();
        let co = if cfg.protocol == ProtocolKind::Cia402 {
            let hb_ms = (1000.0 / cfg.heartbeat_rate_hz).round().clamp(1.0, 65535.0) as u16;
            let ev_ms = (1000.0 / cfg.feedback_rate_hz).round().clamp(1.0, 65535.0) as u16;
            Wheel::BOTH
                .iter()
                .map(|w| {
                    let id = match w {
                        Wheel::Left => cfg.left_node_id,
                        Wheel::Right => cfg.right_node_id,
                    };
                    cia402::CoNode::new(id.clamp(1, 127) as u8, *w, hb_ms, ev_ms, now)
                })
                .collect()
        } else {
            Vec::new()
        };
        Self {
            co,
            cfg,
            axes: [Axis::default(); 2],
            start: now,
            last_advance: now,
            next_heartbeat: now,
            next_feedback: now,
            generic_state: generic::STATE_DISABLED,
            status_counter: 0,
            delayed: VecDeque::new(),
            applied: vec![false; n],
            exited: false,
            stats: DriveStats::default(),
        }
    }

    /// Its configuration.
    pub fn config(&self) -> &VirtualDriveConfig {
        &self.cfg
    }

    fn generic_ids(&self) -> GenericIds {
        GenericIds {
            base_id: self.cfg.generic_base_id,
        }
    }

    fn node(&self, w: Wheel) -> u32 {
        match w {
            Wheel::Left => self.cfg.left_node_id,
            Wheel::Right => self.cfg.right_node_id,
        }
    }

    /// The ids the drive listens to.
    pub fn rx_filters(&self) -> Vec<RxFilter> {
        match self.cfg.protocol {
            ProtocolKind::Generic => Wheel::BOTH
                .iter()
                .map(|w| RxFilter::standard(self.generic_ids().setpoint(*w)))
                .collect(),
            ProtocolKind::Odrive => {
                use odrive::cmd;
                Wheel::BOTH
                    .iter()
                    .flat_map(|w| {
                        let n = self.node(*w);
                        [
                            cmd::ESTOP,
                            cmd::SET_AXIS_STATE,
                            cmd::SET_CONTROLLER_MODE,
                            cmd::SET_INPUT_VEL,
                            cmd::CLEAR_ERRORS,
                        ]
                        .map(|c| RxFilter::standard(odrive::arb_id(n, c)))
                    })
                    .collect()
            }
            ProtocolKind::Cia402 => {
                let mut v = vec![
                    RxFilter::standard(crate::protocol::cia402::nmt::COB_NMT),
                    RxFilter::standard(crate::protocol::cia402::nmt::COB_SYNC),
                    RxFilter::standard(
                        crate::protocol::cia402::nmt::COB_HEARTBEAT_BASE + u32::from(self.cfg.cia402_bridge_node_id),
                    ),
                ];
                for n in &self.co {
                    let id = u32::from(n.id);
                    v.push(RxFilter::standard(crate::protocol::cia402::sdo::COB_RX_BASE + id));
                    v.push(RxFilter::standard(crate::protocol::cia402::pdo::COB_RPDO1_BASE + id));
                }
                v
            }
        }
    }

    /// The CiA 402 node of a wheel (protocol cia402 only).
    pub fn cia402_node(&self, w: Wheel) -> Option<&cia402::CoNode> {
        self.co.get(w.index())
    }

    /// Snapshot of one axis.
    pub fn axis(&self, w: Wheel) -> AxisSnapshot {
        let a = &self.axes[w.index()];
        AxisSnapshot {
            vel_radps: a.vel,
            pos_rad: a.pos,
            target_radps: self.target(w),
            running: self.running(w),
            error_code: self.error(w),
        }
    }

    /// What the drive received so far.
    pub fn stats(&self) -> DriveStats {
        let mut s = self.stats;
        for n in &self.co {
            s.setpoints_accepted += n.stats.rpdos;
            s.estops += n.stats.quick_stops;
            s.clear_requests += n.stats.fault_resets;
            s.closed_loop_with_nonzero_input += n.stats.enabled_with_nonzero_target;
        }
        s
    }

    /// The drive stopped for good (fault `exit`).
    pub fn exited(&self) -> bool {
        self.exited
    }

    /// Injects a fault now (the schedule's times are relative to the drive's start).
    pub fn inject(&mut self, kind: FaultKind, duration_s: Option<f64>, now: Timestamp) {
        let start_s = (now - self.start).as_secs_f64();
        self.cfg.faults.push(FaultSpec {
            kind,
            start_s,
            duration_s,
        });
        self.applied.push(false);
    }

    /// Ends every injected or scheduled fault (latched axis errors stay until cleared).
    pub fn clear_faults(&mut self) {
        self.cfg.faults.clear();
        self.applied.clear();
    }

    fn running(&self, w: Wheel) -> bool {
        match self.cfg.protocol {
            ProtocolKind::Generic => self.generic_state == generic::STATE_ENABLED,
            ProtocolKind::Odrive => self.axes[w.index()].running,
            ProtocolKind::Cia402 => {
                self.co[w.index()].machine.state == crate::protocol::cia402::state_machine::DriveState::OperationEnabled
            }
        }
    }

    fn error(&self, w: Wheel) -> u32 {
        match self.cfg.protocol {
            ProtocolKind::Cia402 => {
                let n = &self.co[w.index()];
                if matches!(
                    n.machine.state,
                    crate::protocol::cia402::state_machine::DriveState::Fault
                        | crate::protocol::cia402::state_machine::DriveState::FaultReactionActive
                ) {
                    u32::from(n.error_code())
                } else {
                    0
                }
            }
            _ => self.axes[w.index()].error,
        }
    }

    fn target(&self, w: Wheel) -> f64 {
        if self.cfg.protocol == ProtocolKind::Cia402 {
            return self.co[w.index()].demand_radps;
        }
        if self.running(w) {
            self.axes[w.index()]
                .input
                .clamp(-self.cfg.max_speed_radps, self.cfg.max_speed_radps)
        } else {
            0.0
        }
    }

    fn fault_active(&self, t_s: f64, pred: impl Fn(&FaultKind) -> bool) -> Option<FaultSpec> {
        self.cfg.faults.iter().copied().find(|f| pred(&f.kind) && f.active(t_s))
    }

    /// A received frame.
    pub fn handle_frame(&mut self, f: &CanFrame, now: Timestamp) {
        if self.exited {
            return;
        }
        self.advance(now);
        match self.cfg.protocol {
            ProtocolKind::Generic => self.handle_generic(f, now),
            ProtocolKind::Odrive => self.handle_odrive(f, now),
            ProtocolKind::Cia402 => {
                let t_s = (now - self.start).as_secs_f64();
                let sdo_silent = self.fault_active(t_s, |k| *k == FaultKind::SdoSilence).is_some();
                let bridge = self.cfg.cia402_bridge_node_id;
                for n in &mut self.co {
                    n.handle(f, now, sdo_silent, bridge);
                }
            }
        }
    }

    fn generic_set_error(&mut self, code: u32) {
        for a in &mut self.axes {
            a.error |= code;
            a.input = 0.0;
        }
        self.generic_state = generic::STATE_FAULT;
    }

    fn handle_generic(&mut self, f: &CanFrame, now: Timestamp) {
        let (w, sp) = match generic::decode_setpoint(self.generic_ids(), f) {
            Ok(Some(x)) => x,
            Ok(None) => return,
            Err(e) => {
                self.stats.setpoints_rejected += 1;
                log::warn!("rejected setpoint: {e}");
                return;
            }
        };
        let a = &mut self.axes[w.index()];
        if a.last_counter == Some(sp.counter) {
            self.stats.setpoints_rejected += 1;
            self.stats.frozen_counters += 1;
            return;
        }
        a.last_counter = Some(sp.counter);
        self.stats.setpoints_accepted += 1;
        if sp.estop {
            if self.generic_state != generic::STATE_ESTOP {
                self.stats.estops += 1;
                log::warn!("e-stop received");
            }
            self.generic_state = generic::STATE_ESTOP;
            for a in &mut self.axes {
                a.input = 0.0;
            }
            return;
        }
        if !sp.enable {
            // Disable and clear: a latched e-stop or error goes away.
            self.stats.clear_requests += 1;
            for a in &mut self.axes {
                a.error = 0;
                a.input = 0.0;
            }
            self.generic_state = generic::STATE_DISABLED;
            self.axes[w.index()].last_setpoint = Some(now);
            return;
        }
        match self.generic_state {
            // Enable (from disabled, without error).
            generic::STATE_DISABLED if self.axes.iter().all(|a| a.error == 0) => {
                self.generic_state = generic::STATE_ENABLED;
                for a in &mut self.axes {
                    a.last_setpoint = Some(now);
                }
            }
            generic::STATE_ENABLED => {}
            // E-stop or fault latched (or disabled with an error): ignored until cleared.
            _ => return,
        }
        let a = &mut self.axes[w.index()];
        a.input = sp.vel_radps;
        a.last_setpoint = Some(now);
    }

    fn handle_odrive(&mut self, f: &CanFrame, now: Timestamp) {
        let (node, _) = odrive::split_id(f.id);
        let Some(w) = Wheel::BOTH.into_iter().find(|w| self.node(*w) == node) else {
            return;
        };
        let c = match odrive::decode_command(f) {
            Ok(Some(c)) => c,
            Ok(None) => return,
            Err(e) => {
                self.stats.setpoints_rejected += 1;
                log::warn!("rejected command: {e}");
                return;
            }
        };
        let a = &mut self.axes[w.index()];
        match c {
            Command::SetInputVel { vel_turns_per_s, .. } => {
                if !vel_turns_per_s.is_finite() {
                    // A NaN on the wire is a bridge bug: fault, never follow it.
                    self.stats.setpoints_rejected += 1;
                    a.error |= 0x1;
                    a.running = false;
                    a.input = 0.0;
                    return;
                }
                self.stats.setpoints_accepted += 1;
                a.input = f64::from(vel_turns_per_s) * TAU;
                a.last_setpoint = Some(now);
            }
            Command::SetAxisState(s) if s == odrive::AXIS_STATE_CLOSED_LOOP => {
                if a.input != 0.0 {
                    self.stats.closed_loop_with_nonzero_input += 1;
                    log::warn!("{} axis: closed loop requested with input {} rad/s", w.name(), a.input);
                }
                if a.error == 0 && a.control_mode == odrive::CONTROL_MODE_VELOCITY {
                    a.running = true;
                    a.last_setpoint = Some(now);
                }
            }
            Command::SetAxisState(_) => {
                a.running = false;
                a.input = 0.0;
            }
            Command::SetControllerMode {
                control_mode,
                input_mode,
            } => {
                a.control_mode = control_mode;
                a.input_mode = input_mode;
            }
            Command::ClearErrors => {
                self.stats.clear_requests += 1;
                a.error = 0;
            }
            Command::Estop => {
                if a.error & odrive::AXIS_ERROR_ESTOP_REQUESTED == 0 {
                    self.stats.estops += 1;
                }
                a.error |= odrive::AXIS_ERROR_ESTOP_REQUESTED;
                a.running = false;
                a.input = 0.0;
            }
        }
    }

    /// Integrates the axes up to `now`.
    fn advance(&mut self, now: Timestamp) {
        let mut t = self.last_advance;
        while t < now {
            let h = (now - t).min(PHYSICS_STEP);
            let hs = h.as_secs_f64();
            for w in Wheel::BOTH {
                if self.cfg.protocol == ProtocolKind::Cia402 {
                    // The profile generator: the demand ramps to the target.
                    let n = &mut self.co[w.index()];
                    let (target, rate) = n.profile(&self.cfg.cia402_scaling);
                    let step = rate * hs;
                    let d = (target - n.demand_radps).clamp(-step, step);
                    n.demand_radps = (n.demand_radps + d).clamp(-self.cfg.max_speed_radps, self.cfg.max_speed_radps);
                }
                let target = self.target(w);
                let a = &mut self.axes[w.index()];
                let want = if self.cfg.time_constant_s > 0.0 {
                    (target - a.vel) * (1.0 - (-hs / self.cfg.time_constant_s).exp())
                } else {
                    target - a.vel
                };
                let max_dv = self.cfg.max_accel_radps2 * hs;
                let v0 = a.vel;
                a.vel =
                    (a.vel + want.clamp(-max_dv, max_dv)).clamp(-self.cfg.max_speed_radps, self.cfg.max_speed_radps);
                a.pos += 0.5 * (v0 + a.vel) * hs;
            }
            t = t + h;
        }
        self.last_advance = self.last_advance.max(now);
    }

    fn apply_scheduled(&mut self, t_s: f64, now: Timestamp) {
        for i in 0..self.cfg.faults.len() {
            let f = self.cfg.faults[i];
            if self.applied[i] || t_s < f.start_s {
                continue;
            }
            match f.kind {
                FaultKind::AxisError { code, wheel } => {
                    self.applied[i] = true;
                    log::warn!("injecting axis error 0x{code:X} on {wheel:?}");
                    match self.cfg.protocol {
                        ProtocolKind::Generic => self.generic_set_error(code),
                        ProtocolKind::Cia402 => {
                            for n in &mut self.co {
                                if wheel.is_none_or(|x| x == n.wheel) {
                                    n.fault(u16::try_from(code).unwrap_or(0x1000));
                                }
                            }
                        }
                        ProtocolKind::Odrive => {
                            for w in Wheel::BOTH {
                                if wheel.is_none_or(|x| x == w) {
                                    let a = &mut self.axes[w.index()];
                                    a.error |= code;
                                    a.running = false;
                                    a.input = 0.0;
                                }
                            }
                        }
                    }
                }
                FaultKind::Reboot { wheel } => {
                    self.applied[i] = true;
                    log::warn!("rebooting {wheel:?}");
                    for n in &mut self.co {
                        if wheel.is_none_or(|x| x == n.wheel) {
                            n.boot(now);
                        }
                    }
                }
                FaultKind::Exit => {
                    self.applied[i] = true;
                    log::warn!("exit fault: going silent for good");
                    self.exited = true;
                }
                _ => {}
            }
        }
    }

    fn watchdog(&mut self, now: Timestamp) {
        let wd = crate::time::saturating_duration(self.cfg.watchdog_s);
        match self.cfg.protocol {
            ProtocolKind::Generic => {
                if self.generic_state == generic::STATE_ENABLED
                    && self.axes.iter().any(|a| a.last_setpoint.is_none_or(|t| now - t > wd))
                {
                    log::warn!("watchdog: no valid setpoint for {} s, disabling", self.cfg.watchdog_s);
                    self.stats.watchdog_trips += 1;
                    self.generic_set_error(generic::ERR_WATCHDOG);
                }
            }
            // CiA 402: the nodes' RPDO timeout, in `step`.
            ProtocolKind::Cia402 => {}
            ProtocolKind::Odrive => {
                for w in Wheel::BOTH {
                    let a = &mut self.axes[w.index()];
                    if a.running && a.last_setpoint.is_none_or(|t| now - t > wd) {
                        log::warn!("{} axis watchdog expired, idle", w.name());
                        self.stats.watchdog_trips += 1;
                        a.running = false;
                        a.input = 0.0;
                        a.error |= odrive::AXIS_ERROR_WATCHDOG_TIMER_EXPIRED;
                    }
                }
            }
        }
    }

    /// Advances to `now`: physics, faults, watchdog; appends the frames due.
    pub fn step(&mut self, now: Timestamp, out: &mut Vec<CanFrame>) {
        if self.exited {
            return;
        }
        self.advance(now);
        let t_s = (now - self.start).as_secs_f64();
        self.apply_scheduled(t_s, now);
        if self.exited {
            return;
        }
        self.watchdog(now);
        let silent = self.fault_active(t_s, |k| *k == FaultKind::Silence).is_some();
        if self.cfg.protocol == ProtocolKind::Cia402 {
            let mute_hb = silent || self.fault_active(t_s, |k| *k == FaultKind::HeartbeatSilence).is_some();
            let mute_fb = silent || self.fault_active(t_s, |k| *k == FaultKind::FeedbackSilence).is_some();
            let wd = crate::time::saturating_duration(self.cfg.watchdog_s);
            let scaling = self.cfg.cia402_scaling;
            for w in Wheel::BOTH {
                let (pos, vel) = (self.axes[w.index()].pos, self.axes[w.index()].vel);
                let before = out.len();
                if let Some(why) = self.co[w.index()].step(now, &scaling, pos, vel, wd, mute_hb, mute_fb, out) {
                    log::warn!("{} node: {why} expired, fault", w.name());
                    self.stats.watchdog_trips += 1;
                }
                for f in &out[before..] {
                    match f.id & !0x7F {
                        0x700 => self.stats.heartbeats_sent += 1,
                        0x280 => self.stats.feedback_sent += 1,
                        _ => {}
                    }
                }
            }
            return;
        }
        if now >= self.next_heartbeat {
            self.next_heartbeat = next_grid(self.next_heartbeat, now, self.cfg.heartbeat_rate_hz);
            let muted = silent || self.fault_active(t_s, |k| *k == FaultKind::HeartbeatSilence).is_some();
            if !muted {
                self.push_heartbeats(out);
            }
        }
        if now >= self.next_feedback {
            self.next_feedback = next_grid(self.next_feedback, now, self.cfg.feedback_rate_hz);
            let muted = silent || self.fault_active(t_s, |k| *k == FaultKind::FeedbackSilence).is_some();
            if !muted {
                let delay = self
                    .fault_active(t_s, |k| matches!(k, FaultKind::FeedbackDelay { .. }))
                    .map(|f| match f.kind {
                        FaultKind::FeedbackDelay { delay_s } => delay_s,
                        _ => 0.0,
                    });
                let mut fb = Vec::new();
                self.push_feedback(&mut fb);
                match delay {
                    Some(d) if d > 0.0 => {
                        let due = now + crate::time::saturating_duration(d);
                        self.delayed.extend(fb.into_iter().map(|f| (due, f)));
                    }
                    _ => out.extend(fb),
                }
            }
        }
        while let Some((due, f)) = self.delayed.front().copied() {
            if due > now {
                break;
            }
            self.delayed.pop_front();
            if !silent {
                out.push(f);
            }
        }
    }

    fn push_heartbeats(&mut self, out: &mut Vec<CanFrame>) {
        match self.cfg.protocol {
            ProtocolKind::Generic => {
                let s = generic::Status {
                    state: self.generic_state,
                    counter: self.status_counter,
                    error_code: self.axes[0].error | self.axes[1].error,
                    rejected_setpoints: (self.stats.setpoints_rejected & 0xFF) as u8,
                };
                self.status_counter = self.status_counter.wrapping_add(1);
                out.push(generic::encode_status(self.generic_ids(), &s));
                self.stats.heartbeats_sent += 1;
            }
            // CiA 402 nodes send their own (in `step`).
            ProtocolKind::Cia402 => {}
            ProtocolKind::Odrive => {
                for w in Wheel::BOTH {
                    let a = &self.axes[w.index()];
                    let state = if a.running {
                        odrive::AXIS_STATE_CLOSED_LOOP
                    } else {
                        odrive::AXIS_STATE_IDLE
                    };
                    out.push(odrive::heartbeat(self.node(w), a.error, state as u8));
                    self.stats.heartbeats_sent += 1;
                }
            }
        }
    }

    fn push_feedback(&mut self, out: &mut Vec<CanFrame>) {
        for w in Wheel::BOTH {
            let ids = self.generic_ids();
            let node = self.node(w);
            let a = &mut self.axes[w.index()];
            match self.cfg.protocol {
                ProtocolKind::Generic => {
                    let fb = generic::Feedback {
                        vel_radps: a.vel,
                        pos_rad: a.pos,
                        counter: a.feedback_counter,
                    };
                    a.feedback_counter = a.feedback_counter.wrapping_add(1);
                    out.push(generic::encode_feedback(ids, w, &fb));
                }
                ProtocolKind::Cia402 => {}
                ProtocolKind::Odrive => out.push(odrive::encoder_estimates(node, a.pos / TAU, a.vel / TAU)),
            }
            self.stats.feedback_sent += 1;
        }
    }

    /// When [`step`](Self::step) next has frames to send.
    pub fn next_deadline(&self) -> Timestamp {
        if self.cfg.protocol == ProtocolKind::Cia402 {
            let now = self.last_advance;
            return self.co.iter().map(|n| n.next_deadline(now)).min().unwrap_or(now);
        }
        let mut t = self.next_heartbeat.min(self.next_feedback);
        if let Some((due, _)) = self.delayed.front() {
            t = t.min(*due);
        }
        t
    }
}

fn next_grid(prev: Timestamp, now: Timestamp, rate_hz: f64) -> Timestamp {
    let period = crate::time::saturating_duration(1.0 / rate_hz).max(Duration::from_micros(1));
    let late = now - prev;
    let skip = u32::try_from(late.as_nanos() / period.as_nanos().max(1)).unwrap_or(u32::MAX - 1);
    prev + period * (skip + 1)
}

/// Runs `drive` on `bus` until `stop` is set or the drive exits (fault `exit`).
/// The drive is shared so tests can inject faults and read its state.
pub fn run_virtual_drive<B: CanBus>(
    drive: &Mutex<VirtualDrive>,
    bus: &mut B,
    clock: &dyn Clock,
    stop: &AtomicBool,
) -> Result<(), crate::bus::BusError> {
    let lock = || drive.lock().unwrap_or_else(|e| e.into_inner());
    bus.set_rx_filters(&lock().rx_filters())?;
    let mut out = Vec::new();
    let mut last_error_log: Option<Timestamp> = None;
    while !stop.load(Ordering::Relaxed) {
        let now = clock.now();
        let deadline = {
            let mut d = lock();
            d.step(now, &mut out);
            if d.exited() {
                return Ok(());
            }
            d.next_deadline()
        };
        for f in out.drain(..) {
            match bus.send(&f) {
                Ok(()) | Err(SendError::QueueFull) => {}
                Err(e) => {
                    if last_error_log.is_none_or(|t| now - t > Duration::from_secs(1)) {
                        log::warn!("virtual drive: {e}");
                        last_error_log = Some(now);
                    }
                }
            }
        }
        let wait = (deadline - clock.now()).min(Duration::from_millis(20));
        match bus.recv(wait) {
            Ok(Some(BusEvent::Frame(f))) => lock().handle_frame(&f, clock.now()),
            Ok(_) => {}
            Err(e) => {
                if last_error_log.is_none_or(|t| now - t > Duration::from_secs(1)) {
                    log::warn!("virtual drive: {e}");
                    last_error_log = Some(now);
                }
                std::thread::sleep(wait.min(Duration::from_millis(5)));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
#[path = "virtual_drive_tests.rs"]
mod tests;
