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
//! * odrive: one node per wheel, firmware 0.5 or 0.6 (heartbeat layout and
//!   error numbering of [`crate::protocol::odrive::firmware`]). Clear_Errors,
//!   Set_Controller_Mode, Set_Input_Vel (feeds the watchdog), Set_Axis_State
//!   (closed loop only without error and in velocity mode), Estop (error
//!   ESTOP_REQUESTED, idle). An error that ends closed loop sets 0.6's
//!   procedure result DISARMED; Clear_Errors clears both. 0.6 sends
//!   Get_Error (active errors 0, disarm reason = the error) with each
//!   heartbeat. A closed-loop request while the input velocity is non-zero
//!   is counted as a start-up order violation.
//! * cia402: a CANopen node per wheel, or one node with both wheels' axes
//!   (axis 2 at the configured offset) ([`cia402`]): SDO server, NMT,
//!   heartbeat producer and consumer, PDOs from the mapped dictionary,
//!   SYNC, the CiA 402 state machine and profile velocity ramps. The
//!   watchdog is an RPDO timeout (error 0x8250); faults add `sdo_silence`
//!   (SDO requests unanswered) and `reboot` (boot-up, dictionary defaults).
//!
//! The type is pure (time is an argument); [`run_virtual_drive`] runs it on a bus.
//!
//! One concept per file: the drive and its axis model here, what it
//! simulates in `settings.rs`, injected faults in `faults.rs`, each
//! protocol's drive side in `generic_drive.rs`, `odrive_drive.rs` and
//! [`cia402`], and the thread loop in `runner.rs`.

pub mod cia402;
mod faults;
mod generic_drive;
mod odrive_drive;
mod runner;
mod settings;

pub use faults::{FaultKind, FaultProblem, FaultSpec, FaultSpecError};
pub use runner::run_virtual_drive;
pub use settings::{FaultClock, VirtualDriveConfig};

use crate::bus::{CanFrame, RxFilter};
use crate::kinematics::Wheel;
use crate::protocol::cia402::axis::AxisLayout;
use crate::protocol::generic::{self, GenericIds};
use crate::protocol::odrive;
use crate::protocol::ProtocolKind;
use crate::time::Timestamp;
use serde::Serialize;
use std::collections::VecDeque;
use std::f64::consts::TAU;
use std::time::Duration;

/// Integration step of the axis model.
const PHYSICS_STEP: Duration = Duration::from_millis(1);

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
    /// ODrive 0.6 procedure result (Heartbeat byte 5).
    procedure_result: u8,
}

/// The simulated drive.
#[derive(Debug)]
pub struct VirtualDrive {
    cfg: VirtualDriveConfig,
    axes: [Axis; 2],
    /// Where the fault schedule's clock started (None: `FaultClock::Running`
    /// and the wheels have not both run yet).
    fault_epoch: Option<Timestamp>,
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
    /// CiA 402 nodes (one per distinct node id); empty for the other protocols.
    co: Vec<cia402::CoNode>,
    /// CiA 402: each wheel's (node index in `co`, axis index in the node).
    co_of: [(usize, usize); 2],
}

impl VirtualDrive {
    /// A drive powered up at `now`, idle, without error.
    pub fn new(cfg: VirtualDriveConfig, now: Timestamp) -> Self {
        let n = cfg.faults.len();
        let mut co: Vec<cia402::CoNode> = Vec::new();
        let mut co_of = [(0, 0), (0, 0)];
        if cfg.protocol == ProtocolKind::Cia402 {
            let hb_ms = (1000.0 / cfg.heartbeat_rate_hz).round().clamp(1.0, 65535.0) as u16;
            let ev_ms = (1000.0 / cfg.feedback_rate_hz).round().clamp(1.0, 65535.0) as u16;
            let ids = [cfg.left_node_id, cfg.right_node_id].map(|id| id.clamp(1, 127) as u8);
            let layouts = [cfg.left_axis, cfg.right_axis].map(|a| AxisLayout::new(a, cfg.cia402_axis_offset));
            for w in Wheel::BOTH {
                let id = ids[w.index()];
                if co.iter().any(|n| n.id == id) {
                    continue;
                }
                let axes: Vec<(Wheel, AxisLayout)> = Wheel::BOTH
                    .into_iter()
                    .filter(|x| ids[x.index()] == id)
                    .map(|x| (x, layouts[x.index()]))
                    .collect();
                co.push(cia402::CoNode::new(id, &axes, hb_ms, ev_ms, now));
            }
            for w in Wheel::BOTH {
                let n = co.iter().position(|n| n.id == ids[w.index()]).unwrap_or(0);
                let k = co[n].axes.iter().position(|a| a.wheel == w).unwrap_or(0);
                co_of[w.index()] = (n, k);
            }
        }
        Self {
            co,
            co_of,
            fault_epoch: (cfg.faults_from == FaultClock::Start).then_some(now),
            cfg,
            axes: [Axis::default(); 2],
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
                    for a in &n.axes {
                        v.push(RxFilter::standard(a.layout.rpdo_cob(n.id)));
                    }
                }
                v
            }
        }
    }

    /// The CiA 402 node of a wheel (protocol cia402 only).
    pub fn cia402_node(&self, w: Wheel) -> Option<&cia402::CoNode> {
        self.co.get(self.co_of[w.index()].0)
    }

    /// The CiA 402 axis of a wheel (protocol cia402 only).
    pub fn cia402_axis(&self, w: Wheel) -> Option<&cia402::CoAxis> {
        let (n, k) = self.co_of[w.index()];
        self.co.get(n).and_then(|n| n.axes.get(k))
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

    fn running(&self, w: Wheel) -> bool {
        match self.cfg.protocol {
            ProtocolKind::Generic => self.generic_state == generic::STATE_ENABLED,
            ProtocolKind::Odrive => self.axes[w.index()].running,
            ProtocolKind::Cia402 => self.cia402_axis(w).is_some_and(|a| {
                a.machine.state == crate::protocol::cia402::state_machine::DriveState::OperationEnabled
            }),
        }
    }

    fn error(&self, w: Wheel) -> u32 {
        match self.cfg.protocol {
            ProtocolKind::Cia402 => {
                let (n, k) = self.co_of[w.index()];
                let node = &self.co[n];
                if matches!(
                    node.axes[k].machine.state,
                    crate::protocol::cia402::state_machine::DriveState::Fault
                        | crate::protocol::cia402::state_machine::DriveState::FaultReactionActive
                ) {
                    u32::from(node.error_code(k))
                } else {
                    0
                }
            }
            _ => self.axes[w.index()].error,
        }
    }

    fn target(&self, w: Wheel) -> f64 {
        if self.cfg.protocol == ProtocolKind::Cia402 {
            return self.cia402_axis(w).map_or(0.0, |a| a.demand_radps);
        }
        if self.running(w) {
            self.axes[w.index()]
                .input
                .clamp(-self.cfg.max_speed_radps, self.cfg.max_speed_radps)
        } else {
            0.0
        }
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
                let t_s = self.fault_time_s(now);
                let sdo_silent = self.fault_active(t_s, |k| *k == FaultKind::SdoSilence).is_some();
                let bridge = self.cfg.cia402_bridge_node_id;
                for n in &mut self.co {
                    n.handle(f, now, sdo_silent, bridge);
                }
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
                    let (n, k) = self.co_of[w.index()];
                    let node = &mut self.co[n];
                    let (target, rate) = node.profile(k, &self.cfg.cia402_scaling);
                    let step = rate * hs;
                    let a = &mut node.axes[k];
                    let d = (target - a.demand_radps).clamp(-step, step);
                    a.demand_radps = (a.demand_radps + d).clamp(-self.cfg.max_speed_radps, self.cfg.max_speed_radps);
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
                        a.disarm(self.cfg.odrive_firmware.watchdog_error());
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
        if self.fault_epoch.is_none() && Wheel::BOTH.into_iter().all(|w| self.running(w)) {
            self.fault_epoch = Some(now);
        }
        let t_s = self.fault_time_s(now);
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
            for n in 0..self.co.len() {
                let motion: Vec<(f64, f64)> = self.co[n]
                    .axes
                    .iter()
                    .map(|a| (self.axes[a.wheel.index()].pos, self.axes[a.wheel.index()].vel))
                    .collect();
                let before = out.len();
                if let Some(why) = self.co[n].step(now, &scaling, &motion, wd, mute_hb, mute_fb, out) {
                    log::warn!("node {}: {why} expired, fault", self.co[n].id);
                    self.stats.watchdog_trips += 1;
                }
                for f in &out[before..] {
                    match f.id & !0x7F {
                        0x700 => self.stats.heartbeats_sent += 1,
                        // TPDO2 (axis 1) and TPDO4 (axis 2): position and velocity.
                        0x280 | 0x480 => self.stats.feedback_sent += 1,
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
                    let node = self.node(w);
                    let state = if a.running {
                        odrive::AXIS_STATE_CLOSED_LOOP
                    } else {
                        odrive::AXIS_STATE_IDLE
                    } as u8;
                    match self.cfg.odrive_firmware {
                        odrive::Firmware::V0_5 => out.push(odrive::heartbeat(node, a.error, state)),
                        odrive::Firmware::V0_6 => {
                            // Velocity control runs no trajectory: it is always "done".
                            let h = odrive::Heartbeat {
                                axis_error: a.error,
                                axis_state: state,
                                procedure_result: Some(a.procedure_result),
                                trajectory_done: Some(true),
                            };
                            out.push(odrive::heartbeat_0_6(node, &h));
                            out.push(odrive::get_error(node, 0, a.error));
                        }
                    }
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

impl Axis {
    /// ODrive: an error ends closed loop (0.6 records the disarm).
    fn disarm(&mut self, error: u32) {
        if self.running {
            self.procedure_result = odrive::firmware::procedure_result::DISARMED;
        }
        self.running = false;
        self.input = 0.0;
        self.error |= error;
    }
}

fn next_grid(prev: Timestamp, now: Timestamp, rate_hz: f64) -> Timestamp {
    let period = crate::time::saturating_duration(1.0 / rate_hz).max(Duration::from_micros(1));
    let late = now - prev;
    let skip = u32::try_from(late.as_nanos() / period.as_nanos().max(1)).unwrap_or(u32::MAX - 1);
    prev + period * (skip + 1)
}

#[cfg(test)]
mod tests;
