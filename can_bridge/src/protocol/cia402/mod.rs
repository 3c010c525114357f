//! CANopen CiA 402 drives in profile velocity mode, one node per wheel
//! (Maxon EPOS, Roboteq, Copley, Elmo, Nanotec, …): the bridge's side.
//!
//! One concept per file: [`nmt`] (NMT, heartbeat, SYNC, EMCY), [`sdo`]
//! (expedited SDO frames, abort codes, the client), [`pdo`] (the PDO layout
//! and its mapping), [`state_machine`] (controlword / statusword, the
//! drive's transitions), [`units`] (drive units ↔ motor SI).
//!
//! Start-up, per node, when the bridge asks for it ([`Protocol::startup`]):
//! NMT enter pre-operational; over SDO, one transfer at a time: read 0x1000
//! and check the CiA 402 profile number, write 0x1017 (the drive's
//! heartbeat), 0x1016:01 (its consumer time for the bridge's heartbeat),
//! 0x6060 = 3, 0x6083/0x6084/0x6085, and (unless the mapping is
//! preconfigured) map RPDO1/TPDO1/TPDO2; NMT start; then, from the
//! statusword, controlword shutdown → switch on → enable operation, every
//! word in an RPDO1 whose target velocity is zero (a drive found switched on
//! or enabled is shut down first, and only an operation enabled that follows
//! the bridge's own enable counts: a stale statusword cannot enable it). A fault present at
//! start-up is reset (bit 7 edges, at most [`MAX_FAULT_RESETS`]); one that
//! appears later is not. The node runs only when its last heartbeat says
//! operational, its last statusword says operation enabled and its mode
//! display says profile velocity: otherwise every target velocity is zero.
//!
//! Every period: RPDO1 to each node (enable operation + the target in
//! `Run`, enable operation + 0 in `Hold`, quick stop 0x0002 + 0 in `Estop`,
//! shutdown + 0 whenever the node is not running), then SYNC when the
//! bridge produces it. Shutdown: shutdown 0x0006 + 0 to each node.
//!
//! What the bridge learns: heartbeats are the status with liveness
//! ([`DriveMessage::Status`]); TPDO1 updates the state at once without
//! counting as a heartbeat ([`DriveMessage::State`]); TPDO2 is feedback.
//! `error_code` is 0x603F while the drive is in fault (0x1000 when it gives
//! none), or the SDO abort code that stopped the start-up. An SDO timeout
//! stops the start-up without an error (the bridge retries it after
//! `startup_timeout_s`). EMCY messages are reported, not acted on: the
//! statusword's fault bit is what stops the robot.

pub mod nmt;
pub mod pdo;
pub mod sdo;
pub mod state_machine;
pub mod units;

use super::{DecodeError, DriveMessage, FrameBatch, Protocol, ProtocolKind, ProtocolReport, SetpointMode, Wheels};
use crate::bus::{CanFrame, RxFilter};
use crate::kinematics::{MotorSpeeds, Wheel};
use crate::time::Timestamp;
use nmt::{NmtCommand, NmtState};
use pdo::{obj, PdoPlan, Rpdo1};
use sdo::{ObjectAddr, SdoError, SdoRequest, SdoResponse, SdoValue};
use serde::{Deserialize, Serialize};
use state_machine::{cw, enabling_controlword, DriveState};
use std::time::Duration;
use units::Scaling;

/// Fault resets tried in one start-up before the fault is left to latch.
pub const MAX_FAULT_RESETS: u8 = 3;
/// `error_code` for a drive in fault whose 0x603F says 0 (CiA 301 "generic error").
pub const FAULT_WITHOUT_CODE: u32 = 0x1000;
/// 0x603F / EMCY: life guard or heartbeat error (the drive lost the bridge's heartbeat).
pub const ERROR_HEARTBEAT: u32 = 0x8130;
/// 0x603F / EMCY: RPDO timeout (the drive's own command watchdog).
pub const ERROR_RPDO_TIMEOUT: u32 = 0x8250;
/// `raw_state` before any statusword.
pub const RAW_STATE_UNKNOWN: u8 = 0xFF;

/// Who maps the PDOs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PdoMapping {
    /// The bridge writes the mapping and transmission types at start-up.
    Configure,
    /// The drive already holds exactly this layout (stored); nothing is written.
    Preconfigured,
}

/// Everything the protocol needs, in drive units (from the configuration).
#[derive(Clone, Debug, PartialEq)]
pub struct Cia402Settings {
    /// Left, right node ids (1–127).
    pub nodes: [u8; 2],
    pub scaling: Scaling,
    /// 0x6083, 0x6084, 0x6085 (velocity units / s).
    pub profile_accel: u32,
    pub profile_decel: u32,
    pub quick_stop_decel: u32,
    pub mapping: PdoMapping,
    pub plan: PdoPlan,
    /// Written to 0x1017 (0: not written).
    pub drive_heartbeat_ms: u16,
    /// The bridge's own node id (its heartbeat's COB-ID 0x700 + id).
    pub bridge_node_id: u8,
    /// The bridge's heartbeat period (0: no heartbeat).
    pub bridge_heartbeat_ms: u16,
    /// Written to 0x1016:01 with the bridge's id (0: not written).
    pub drive_consumer_heartbeat_ms: u16,
    pub sdo_timeout: Duration,
}

/// One start-up step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Step {
    /// Read 0x1000 and check the device profile is 402.
    CheckDeviceType,
    Write(ObjectAddr, SdoValue),
}

impl Step {
    fn request(&self) -> SdoRequest {
        match *self {
            Step::CheckDeviceType => SdoRequest::Upload { addr: obj::DEVICE_TYPE },
            Step::Write(addr, value) => SdoRequest::Download { addr, value },
        }
    }
}

/// The start-up SDO steps for `node`.
pub fn startup_steps(s: &Cia402Settings, node: u8) -> Vec<Step> {
    let mut v = vec![Step::CheckDeviceType];
    if s.drive_heartbeat_ms > 0 {
        v.push(Step::Write(
            obj::PRODUCER_HEARTBEAT,
            SdoValue::u16(s.drive_heartbeat_ms),
        ));
    }
    if s.drive_consumer_heartbeat_ms > 0 {
        let entry = (u32::from(s.bridge_node_id) << 16) | u32::from(s.drive_consumer_heartbeat_ms);
        v.push(Step::Write(obj::CONSUMER_HEARTBEAT_1, SdoValue::u32(entry)));
    }
    v.push(Step::Write(
        obj::MODES_OF_OPERATION,
        SdoValue::i8(pdo::MODE_PROFILE_VELOCITY),
    ));
    v.push(Step::Write(obj::PROFILE_ACCELERATION, SdoValue::u32(s.profile_accel)));
    v.push(Step::Write(obj::PROFILE_DECELERATION, SdoValue::u32(s.profile_decel)));
    v.push(Step::Write(
        obj::QUICK_STOP_DECELERATION,
        SdoValue::u32(s.quick_stop_decel),
    ));
    if s.mapping == PdoMapping::Configure {
        v.extend(
            pdo::mapping_writes(node, &s.plan)
                .into_iter()
                .map(|(a, val)| Step::Write(a, val)),
        );
    }
    v
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    /// Not started (boot, after an e-stop, a reboot or a failed start-up).
    Idle,
    /// SDO step `next` is due (or in flight).
    Configuring { next: usize },
    /// NMT start sent: the controlword sequence runs.
    Enabling,
    /// Reached operation enabled; leaving it ends here (no silent re-enable).
    Enabled,
}

#[derive(Clone, Debug)]
struct Node {
    id: u8,
    wheel: Wheel,
    sdo: sdo::SdoClient,
    steps: Vec<Step>,
    phase: Phase,
    nmt: Option<NmtState>,
    drive_state: Option<DriveState>,
    /// 0x603F from TPDO1.
    error_code: u16,
    mode_display: i8,
    /// The SDO abort code that ended the start-up.
    startup_error: Option<u32>,
    last_word: u16,
    /// A fault seen in this start-up may be reset (none seen clear yet).
    may_reset_fault: bool,
    /// Since NMT start, the drive reported ready to switch on: the enable
    /// sequence runs from a state the bridge saw.
    seen_ready: bool,
    fault_resets_left: u8,
}

impl Node {
    fn running(&self) -> bool {
        self.phase == Phase::Enabled
            && self.nmt == Some(NmtState::Operational)
            && self.drive_state == Some(DriveState::OperationEnabled)
            && self.mode_display == pdo::MODE_PROFILE_VELOCITY
    }

    fn error(&self) -> u32 {
        if let Some(code) = self.startup_error {
            return code;
        }
        match self.drive_state {
            Some(DriveState::Fault | DriveState::FaultReactionActive) if self.error_code != 0 => {
                u32::from(self.error_code)
            }
            Some(DriveState::Fault | DriveState::FaultReactionActive) => FAULT_WITHOUT_CODE,
            _ => 0,
        }
    }

    fn status(&self) -> (u32, bool, bool, u8) {
        (
            self.error(),
            self.running(),
            self.drive_state == Some(DriveState::QuickStopActive),
            self.drive_state.map_or(RAW_STATE_UNKNOWN, DriveState::code),
        )
    }
}

/// The bridge's side of CiA 402 for two nodes.
#[derive(Clone, Debug)]
pub struct Cia402Protocol {
    s: Cia402Settings,
    nodes: [Node; 2],
    next_heartbeat: Option<Timestamp>,
    reports: Vec<ProtocolReport>,
}

impl Cia402Protocol {
    /// Settings from a validated configuration.
    pub fn new(s: Cia402Settings) -> Self {
        let node = |w: Wheel| {
            let id = s.nodes[w.index()];
            Node {
                id,
                wheel: w,
                sdo: sdo::SdoClient::new(id, s.sdo_timeout),
                steps: startup_steps(&s, id),
                phase: Phase::Idle,
                nmt: None,
                drive_state: None,
                error_code: 0,
                mode_display: 0,
                startup_error: None,
                last_word: cw::SHUTDOWN,
                may_reset_fault: false,
                seen_ready: false,
                fault_resets_left: 0,
            }
        };
        Self {
            nodes: [node(Wheel::Left), node(Wheel::Right)],
            s,
            next_heartbeat: None,
            reports: Vec::new(),
        }
    }

    /// The settings.
    pub fn settings(&self) -> &Cia402Settings {
        &self.s
    }

    fn report(&mut self, wheel: Option<Wheel>, message: String) {
        log::warn!("cia402: {message}");
        // Bounded: a drive that floods EMCY cannot grow memory.
        if self.reports.len() < 64 {
            self.reports.push(ProtocolReport { wheel, message });
        }
    }

    fn node_of(&self, id: u32) -> Option<usize> {
        self.nodes.iter().position(|n| u32::from(n.id) == id)
    }

    fn status_msg(&self, i: usize, live: bool) -> DriveMessage {
        let n = &self.nodes[i];
        let (error_code, running, estopped, raw_state) = n.status();
        let wheels = Wheels::One(n.wheel);
        if live {
            DriveMessage::Status {
                wheels,
                error_code,
                running,
                estopped,
                raw_state,
            }
        } else {
            DriveMessage::State {
                wheels,
                error_code,
                running,
                estopped,
                raw_state,
            }
        }
    }

    fn fail_startup(&mut self, i: usize, e: SdoError) {
        let (id, wheel) = (self.nodes[i].id, self.nodes[i].wheel);
        self.nodes[i].phase = Phase::Idle;
        if !matches!(e, SdoError::Timeout { .. }) {
            self.nodes[i].startup_error = Some(e.code());
        }
        self.report(Some(wheel), format!("node {id} start-up failed: {e}"));
    }

    fn on_sdo(&mut self, i: usize, r: &SdoResponse) {
        let Some(outcome) = self.nodes[i].sdo.on_response(r) else {
            return;
        };
        let Phase::Configuring { next } = self.nodes[i].phase else {
            return;
        };
        match (outcome, self.nodes[i].steps.get(next).copied()) {
            (Err(e), _) => self.fail_startup(i, e),
            (Ok(v), Some(Step::CheckDeviceType)) => {
                let value = v.map_or(0, |v| v.as_u32());
                if value & 0xFFFF == pdo::DEVICE_PROFILE_402 {
                    self.nodes[i].phase = Phase::Configuring { next: next + 1 };
                } else {
                    let (id, wheel) = (self.nodes[i].id, self.nodes[i].wheel);
                    self.nodes[i].phase = Phase::Idle;
                    self.nodes[i].startup_error = Some(sdo::abort::PARAMETER_INCOMPATIBLE);
                    self.report(
                        Some(wheel),
                        format!("node {id} start-up failed: device type 0x{value:08X} is not a CiA 402 drive"),
                    );
                }
            }
            (Ok(_), _) => self.nodes[i].phase = Phase::Configuring { next: next + 1 },
        }
    }

    fn on_tpdo1(&mut self, i: usize, t: &pdo::Tpdo1) -> Result<(), DecodeError> {
        let state = DriveState::from_statusword(t.statusword).ok_or(DecodeError::Invalid {
            id: pdo::COB_TPDO1_BASE + u32::from(self.nodes[i].id),
            what: "statusword with an undefined state",
        })?;
        let n = &mut self.nodes[i];
        let before = n.drive_state;
        n.drive_state = Some(state);
        n.error_code = t.error_code;
        n.mode_display = t.mode_display;
        let faulted = matches!(state, DriveState::Fault | DriveState::FaultReactionActive);
        match n.phase {
            Phase::Enabling if !faulted => {
                // A fault that appears from here on is new: not reset.
                n.may_reset_fault = false;
                n.seen_ready |= state == DriveState::ReadyToSwitchOn;
                // Enabled by our own enable operation, after switch on from ready.
                if n.seen_ready && n.last_word == cw::ENABLE_OPERATION && n.running_candidate() {
                    n.phase = Phase::Enabled;
                }
            }
            Phase::Enabled if state != DriveState::OperationEnabled => {
                n.phase = Phase::Idle;
                let (id, wheel, code) = (n.id, n.wheel, n.error_code);
                self.report(
                    Some(wheel),
                    format!("node {id} left operation enabled: {state:?} (0x603F = 0x{code:04X})"),
                );
            }
            _ => {}
        }
        if faulted && before != Some(state) && state == DriveState::Fault {
            let n = &self.nodes[i];
            let (id, wheel, code) = (n.id, n.wheel, n.error_code);
            self.report(
                Some(wheel),
                format!("node {id} fault, error code 0x{code:04X} ({})", nmt::emcy_class(code)),
            );
        }
        Ok(())
    }

    fn controlword(&mut self, i: usize, mode: SetpointMode) -> u16 {
        let n = &mut self.nodes[i];
        if mode == SetpointMode::Estop {
            // Every period while latched; the drive is started again after reset.
            n.phase = Phase::Idle;
            return cw::QUICK_STOP;
        }
        match n.phase {
            Phase::Enabling => {
                let allow = n.may_reset_fault && n.fault_resets_left > 0;
                let w = enabling_controlword(n.drive_state, n.last_word, n.seen_ready, allow);
                if w == cw::FAULT_RESET {
                    n.fault_resets_left -= 1;
                }
                w
            }
            Phase::Enabled if n.drive_state == Some(DriveState::OperationEnabled) => cw::ENABLE_OPERATION,
            _ => cw::SHUTDOWN,
        }
    }
}

impl Node {
    fn running_candidate(&self) -> bool {
        self.nmt == Some(NmtState::Operational)
            && self.drive_state == Some(DriveState::OperationEnabled)
            && self.mode_display == pdo::MODE_PROFILE_VELOCITY
    }
}

impl Protocol for Cia402Protocol {
    fn kind(&self) -> ProtocolKind {
        ProtocolKind::Cia402
    }

    fn rx_filters(&self) -> Vec<RxFilter> {
        self.nodes
            .iter()
            .flat_map(|n| {
                let id = u32::from(n.id);
                [
                    nmt::COB_HEARTBEAT_BASE + id,
                    pdo::COB_TPDO1_BASE + id,
                    pdo::COB_TPDO2_BASE + id,
                    sdo::COB_TX_BASE + id,
                    nmt::COB_EMCY_BASE + id,
                ]
                .map(RxFilter::standard)
            })
            .collect()
    }

    fn startup(&mut self, out: &mut FrameBatch) {
        for n in &mut self.nodes {
            n.sdo.cancel();
            n.phase = Phase::Configuring { next: 0 };
            n.drive_state = None;
            n.error_code = 0;
            n.mode_display = 0;
            n.startup_error = None;
            n.may_reset_fault = true;
            n.fault_resets_left = MAX_FAULT_RESETS;
            out.push(nmt::nmt_command(NmtCommand::EnterPreOperational, n.id));
        }
    }

    fn poll(&mut self, now: Timestamp, out: &mut FrameBatch) {
        if self.s.bridge_heartbeat_ms > 0 {
            let period = Duration::from_millis(u64::from(self.s.bridge_heartbeat_ms));
            let due = self.next_heartbeat.is_none_or(|t| now >= t);
            if due {
                out.push(nmt::heartbeat(self.s.bridge_node_id, NmtState::Operational));
                // On a grid; a late loop skips, never bursts.
                let mut next = self.next_heartbeat.unwrap_or(now) + period;
                if next <= now {
                    next = now + period;
                }
                self.next_heartbeat = Some(next);
            }
        }
        for i in 0..2 {
            if let Some((e, abort)) = self.nodes[i].sdo.poll_timeout(now) {
                out.push(abort);
                self.fail_startup(i, e);
            }
            let n = &mut self.nodes[i];
            if let Phase::Configuring { next } = n.phase {
                if n.sdo.busy() {
                    continue;
                }
                match n.steps.get(next) {
                    Some(step) => {
                        let req = step.request();
                        out.push(n.sdo.start(req, now));
                    }
                    None => {
                        // Configured: operational. The state seen before is stale.
                        out.push(nmt::nmt_command(NmtCommand::Start, n.id));
                        n.phase = Phase::Enabling;
                        n.drive_state = None;
                        n.nmt = None;
                        n.seen_ready = false;
                    }
                }
            }
        }
    }

    fn setpoints(&mut self, motor: MotorSpeeds, mode: SetpointMode, out: &mut FrameBatch) {
        for i in 0..2 {
            let word = self.controlword(i, mode);
            let n = &mut self.nodes[i];
            let v = match mode {
                SetpointMode::Run if word == cw::ENABLE_OPERATION && n.running() => motor.get(n.wheel),
                _ => 0.0,
            };
            n.last_word = word;
            out.push(pdo::encode_rpdo1(
                n.id,
                &Rpdo1 {
                    controlword: word,
                    target_velocity: self.s.scaling.velocity_to_drive(v),
                },
            ));
        }
        if self.s.plan.sync {
            out.push(nmt::sync());
        }
    }

    fn shutdown(&mut self, out: &mut FrameBatch) {
        for n in &mut self.nodes {
            n.phase = Phase::Idle;
            n.last_word = cw::SHUTDOWN;
            out.push(pdo::encode_rpdo1(
                n.id,
                &Rpdo1 {
                    controlword: cw::SHUTDOWN,
                    target_velocity: 0,
                },
            ));
        }
        if self.s.plan.sync {
            out.push(nmt::sync());
        }
    }

    fn decode(&mut self, f: &CanFrame) -> Result<Option<DriveMessage>, DecodeError> {
        if f.extended {
            return Ok(None);
        }
        let base = f.id & !0x7F;
        let Some(i) = self.node_of(f.id & 0x7F) else {
            return Ok(None);
        };
        let (id, wheel) = (self.nodes[i].id, self.nodes[i].wheel);
        match base {
            nmt::COB_HEARTBEAT_BASE => {
                let state = match nmt::decode_heartbeat(f) {
                    Some(Ok(s)) => s,
                    Some(Err(b)) => {
                        return Err(DecodeError::Invalid {
                            id: f.id,
                            what: if b == 0 {
                                "heartbeat"
                            } else {
                                "heartbeat with an undefined NMT state"
                            },
                        })
                    }
                    None => {
                        return Err(DecodeError::Length {
                            id: f.id,
                            len: f.len,
                            expected: 1,
                        })
                    }
                };
                if state == NmtState::BootUp {
                    let n = &mut self.nodes[i];
                    n.sdo.cancel();
                    n.phase = Phase::Idle;
                    n.drive_state = None;
                    self.report(
                        Some(wheel),
                        format!("node {id} booted (boot-up message): restarting it"),
                    );
                }
                self.nodes[i].nmt = Some(state);
                Ok(Some(self.status_msg(i, true)))
            }
            pdo::COB_TPDO1_BASE => {
                let t = pdo::decode_tpdo1(f).map_err(|e| DecodeError::Length {
                    id: f.id,
                    len: e.got,
                    expected: e.expected,
                })?;
                self.on_tpdo1(i, &t)?;
                Ok(Some(self.status_msg(i, false)))
            }
            pdo::COB_TPDO2_BASE => {
                let t = pdo::decode_tpdo2(f).map_err(|e| DecodeError::Length {
                    id: f.id,
                    len: e.got,
                    expected: e.expected,
                })?;
                Ok(Some(DriveMessage::Feedback {
                    wheel,
                    motor_pos_rad: self.s.scaling.position_rad(t.position),
                    motor_vel_radps: self.s.scaling.velocity_from_drive(t.velocity),
                }))
            }
            sdo::COB_TX_BASE => {
                let r = sdo::decode_response(f).map_err(|_| DecodeError::Invalid {
                    id: f.id,
                    what: "SDO response",
                })?;
                self.on_sdo(i, &r);
                Ok(Some(DriveMessage::Handled { wheel }))
            }
            nmt::COB_EMCY_BASE => {
                let e = nmt::decode_emcy(f).ok_or(DecodeError::Length {
                    id: f.id,
                    len: f.len,
                    expected: 8,
                })?;
                self.report(
                    Some(wheel),
                    format!(
                        "node {id} EMCY 0x{:04X} ({}), error register 0x{:02X}",
                        e.error_code,
                        nmt::emcy_class(e.error_code),
                        e.error_register
                    ),
                );
                Ok(Some(DriveMessage::Handled { wheel }))
            }
            _ => Ok(None),
        }
    }

    fn position_modulus_rad(&self) -> Option<f64> {
        Some(self.s.scaling.position_modulus_rad())
    }

    fn is_watchdog_error(&self, error_code: u32) -> bool {
        error_code == ERROR_HEARTBEAT || error_code == ERROR_RPDO_TIMEOUT
    }

    fn drain_reports(&mut self, out: &mut Vec<ProtocolReport>) {
        out.append(&mut self.reports);
    }
}

#[cfg(test)]
#[path = "tests.rs"]
mod tests;
