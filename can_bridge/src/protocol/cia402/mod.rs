//! CANopen CiA 402 drives in profile velocity mode (Maxon EPOS, Roboteq,
//! Copley, Elmo, Nanotec, …): the bridge's side. Each wheel is one axis of
//! a node; a node carries one axis (one drive per wheel) or both (a
//! dual-channel controller such as Roboteq's), see [`axis`].
//!
//! One concept per file: [`nmt`] (NMT, heartbeat, SYNC, EMCY), [`sdo`]
//! (expedited SDO frames, abort codes, the client), [`pdo`] (the PDO layout
//! and its mapping), [`axis`] (an axis's objects and PDOs on its node),
//! [`state_machine`] (controlword / statusword, the drive's transitions),
//! [`units`] (drive units ↔ motor SI).
//!
//! What is per node and what per axis: NMT, the heartbeat (consumed and
//! configured), the SDO channel, the device type and the PDO configuration
//! writes go to the node; modes of operation, the profile ramps, the PDOs,
//! the CiA 402 state machine, faults and their resets belong to each axis.
//! A node's heartbeat is the liveness of every wheel it drives; a fault on
//! one axis stops the robot (both wheels) and is reported with its node and
//! axis.
//!
//! Start-up, per node, when the bridge asks for it ([`Protocol::startup`]):
//! NMT enter pre-operational; over SDO, one transfer at a time: read 0x1000
//! and check the CiA 402 profile number, write 0x1017 (the drive's
//! heartbeat), 0x1016:01 (its consumer time for the bridge's heartbeat),
//! per axis 0x6060 = 3 and 0x6083/0x6084/0x6085 (at the axis's offset), and
//! (unless the mapping is preconfigured) map each axis's three PDOs; NMT
//! start; then, per axis, from the
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

pub mod axis;
pub mod nmt;
pub mod pdo;
pub mod sdo;
pub mod sdo_jobs;
pub mod sdo_transfer;
pub mod state_machine;
pub mod units;

use super::{
    AxisStatus, DecodeError, DriveMessage, FrameBatch, Protocol, ProtocolKind, ProtocolReport, SetpointMode, Wheels,
};
use crate::bus::{CanFrame, RxFilter};
use crate::kinematics::{MotorSpeeds, Wheel};
use crate::time::Timestamp;
use axis::AxisLayout;
use nmt::{NmtCommand, NmtState};
use pdo::{obj, PdoPlan, Rpdo1};
use sdo::{ObjectAddr, SdoError, SdoRequest, SdoResponse, SdoValue};
use sdo_jobs::{changes_motion, SdoJob, SdoJobId, SdoJobResult, SdoRefusal, MAX_QUEUED_JOBS};
use sdo_transfer::{SdoTransfer, TransferKind, MAX_TRANSFER_BYTES};
use serde::{Deserialize, Serialize};
use state_machine::{cw, enabling_controlword, DriveState};
use std::collections::VecDeque;
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
    /// Left, right wheel's node id (1–127); the same node for both wheels
    /// when one node carries both axes.
    pub nodes: [u8; 2],
    /// Left, right wheel's axis on its node.
    pub axes: [AxisLayout; 2],
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

impl Cia402Settings {
    /// The distinct node ids, in wheel order (one when a node carries both wheels).
    pub fn node_ids(&self) -> Vec<u8> {
        let mut v = vec![self.nodes[0]];
        if self.nodes[1] != self.nodes[0] {
            v.push(self.nodes[1]);
        }
        v
    }

    /// The axes `node` carries, in wheel order.
    pub fn axes_of(&self, node: u8) -> Vec<(Wheel, AxisLayout)> {
        Wheel::BOTH
            .into_iter()
            .filter(|w| self.nodes[w.index()] == node)
            .map(|w| (w, self.axes[w.index()]))
            .collect()
    }
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

/// The start-up SDO steps for `node`: the node's objects, then each of its
/// axes' (at the axis's offset), then each axis's PDO mapping.
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
    let axes = s.axes_of(node);
    for (_, a) in &axes {
        v.push(Step::Write(
            a.obj(obj::MODES_OF_OPERATION),
            SdoValue::i8(pdo::MODE_PROFILE_VELOCITY),
        ));
        v.push(Step::Write(
            a.obj(obj::PROFILE_ACCELERATION),
            SdoValue::u32(s.profile_accel),
        ));
        v.push(Step::Write(
            a.obj(obj::PROFILE_DECELERATION),
            SdoValue::u32(s.profile_decel),
        ));
        v.push(Step::Write(
            a.obj(obj::QUICK_STOP_DECELERATION),
            SdoValue::u32(s.quick_stop_decel),
        ));
    }
    if s.mapping == PdoMapping::Configure {
        for (_, a) in &axes {
            v.extend(
                pdo::axis_mapping_writes(node, a, &s.plan)
                    .into_iter()
                    .map(|(a, val)| Step::Write(a, val)),
            );
        }
    }
    v
}

/// A node's part of the start-up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum NodePhase {
    /// Not started (boot, after an e-stop, a reboot or a failed start-up).
    Idle,
    /// SDO step `next` is due (or in flight).
    Configuring { next: usize },
    /// NMT start sent: its axes run their controlword sequences.
    Started,
}

/// An axis's part of the start-up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum AxisPhase {
    /// Its node is not started, or the axis stopped (no silent re-enable).
    Idle,
    /// The controlword sequence runs.
    Enabling,
    /// Reached operation enabled; leaving it ends here (no silent re-enable).
    Enabled,
}

#[derive(Clone, Debug)]
struct Node {
    id: u8,
    sdo: sdo::SdoClient,
    steps: Vec<Step>,
    phase: NodePhase,
    nmt: Option<NmtState>,
    /// The SDO abort code that ended the start-up.
    startup_error: Option<u32>,
    /// The wheels (axis indices) this node drives.
    wheels: Vec<usize>,
}

#[derive(Clone, Debug)]
struct Axis {
    wheel: Wheel,
    /// Index into the protocol's nodes.
    node: usize,
    layout: AxisLayout,
    phase: AxisPhase,
    drive_state: Option<DriveState>,
    /// 0x603F (at the axis's offset) from its state TPDO.
    error_code: u16,
    mode_display: i8,
    last_word: u16,
    /// A fault seen in this start-up may be reset (none seen clear yet).
    may_reset_fault: bool,
    /// Since NMT start, the axis reported ready to switch on: the enable
    /// sequence runs from a state the bridge saw.
    seen_ready: bool,
    fault_resets_left: u8,
}

impl Axis {
    fn reset_for_startup(&mut self) {
        self.phase = AxisPhase::Idle;
        self.drive_state = None;
        self.error_code = 0;
        self.mode_display = 0;
        self.may_reset_fault = true;
        self.fault_resets_left = MAX_FAULT_RESETS;
    }

    fn state_ok(&self, nmt: Option<NmtState>) -> bool {
        nmt == Some(NmtState::Operational)
            && self.drive_state == Some(DriveState::OperationEnabled)
            && self.mode_display == pdo::MODE_PROFILE_VELOCITY
    }
}

/// An SDO job on the bus.
#[derive(Clone, Debug)]
struct ActiveJob {
    id: SdoJobId,
    /// Index into the protocol's nodes.
    node: usize,
    job: SdoJob,
    transfer: SdoTransfer,
}

/// Finished jobs kept until drained (bounded: nobody draining cannot grow memory).
const MAX_JOB_RESULTS: usize = 64;

/// The bridge's side of CiA 402 for the two wheels' axes on one or two nodes.
#[derive(Clone, Debug)]
pub struct Cia402Protocol {
    s: Cia402Settings,
    nodes: Vec<Node>,
    /// Left, right.
    axes: [Axis; 2],
    next_heartbeat: Option<Timestamp>,
    reports: Vec<ProtocolReport>,
    /// Run-time SDO jobs waiting for a free channel, in order.
    jobs: VecDeque<(SdoJobId, SdoJob)>,
    active: Option<ActiveJob>,
    job_results: Vec<SdoJobResult>,
    next_job: SdoJobId,
    /// Frames decided while decoding (a client abort), sent at the next poll.
    outbox: Vec<CanFrame>,
}

impl Cia402Protocol {
    /// Settings from a validated configuration.
    pub fn new(s: Cia402Settings) -> Self {
        let nodes: Vec<Node> = s
            .node_ids()
            .into_iter()
            .map(|id| Node {
                id,
                sdo: sdo::SdoClient::new(id, s.sdo_timeout),
                steps: startup_steps(&s, id),
                phase: NodePhase::Idle,
                nmt: None,
                startup_error: None,
                wheels: s.axes_of(id).iter().map(|(w, _)| w.index()).collect(),
            })
            .collect();
        let axis = |w: Wheel| Axis {
            wheel: w,
            node: nodes.iter().position(|n| n.id == s.nodes[w.index()]).unwrap_or(0),
            layout: s.axes[w.index()],
            phase: AxisPhase::Idle,
            drive_state: None,
            error_code: 0,
            mode_display: 0,
            last_word: cw::SHUTDOWN,
            may_reset_fault: false,
            seen_ready: false,
            fault_resets_left: 0,
        };
        Self {
            axes: [axis(Wheel::Left), axis(Wheel::Right)],
            nodes,
            s,
            next_heartbeat: None,
            reports: Vec::new(),
            jobs: VecDeque::new(),
            active: None,
            job_results: Vec::new(),
            next_job: 1,
            outbox: Vec::new(),
        }
    }

    /// Whether node `i` is powered or being enabled: a write that could
    /// change motion is refused then.
    fn node_in_operation(&self, i: usize) -> bool {
        self.nodes[i].wheels.iter().any(|&k| {
            let a = &self.axes[k];
            a.phase == AxisPhase::Enabling || a.drive_state.is_some_and(DriveState::powered)
        })
    }

    /// The rule a job must pass, now: Err if it would be refused.
    fn check_job(&self, job: &SdoJob) -> Result<usize, SdoRefusal> {
        let Some(i) = self.node_of(u32::from(job.node)) else {
            let known: Vec<String> = self.nodes.iter().map(|n| n.id.to_string()).collect();
            return Err(SdoRefusal::UnknownNode {
                node: job.node,
                known: known.join(", "),
            });
        };
        if let TransferKind::Write(d) = &job.kind {
            if d.is_empty() {
                return Err(SdoRefusal::Empty);
            }
            if d.len() > MAX_TRANSFER_BYTES {
                return Err(SdoRefusal::TooLong { len: d.len() });
            }
            if changes_motion(job.addr.index) && self.node_in_operation(i) {
                return Err(SdoRefusal::ChangesMotion {
                    node: job.node,
                    addr: job.addr,
                });
            }
        }
        Ok(i)
    }

    fn push_job_result(&mut self, r: SdoJobResult) {
        if self.job_results.len() < MAX_JOB_RESULTS {
            self.job_results.push(r);
        }
    }

    /// The active job: its next frame, its end; or the next job started.
    fn poll_jobs(&mut self, now: Timestamp, out: &mut FrameBatch) {
        for f in self.outbox.drain(..) {
            out.push(f);
        }
        if self.active.is_none() {
            let Some((id, job)) = self.jobs.front().cloned() else {
                return;
            };
            let Some(i) = self.node_of(u32::from(job.node)) else {
                self.jobs.pop_front();
                return;
            };
            if self.nodes[i].sdo.busy() {
                return; // the start-up's transfer first
            }
            self.jobs.pop_front();
            // The drive may have been enabled since the request: ask again.
            if let Err(refusal) = self.check_job(&job) {
                let r = SdoJobResult {
                    id,
                    node: job.node,
                    index: job.addr.index,
                    sub: job.addr.sub,
                    write: job.is_write(),
                    ok: false,
                    data: Vec::new(),
                    abort_code: refusal.abort_code(),
                    message: format!("refused by the bridge: {refusal}"),
                };
                self.push_job_result(r);
                return;
            }
            let transfer = SdoTransfer::new(job.node, job.addr, job.kind.clone(), self.s.sdo_timeout);
            self.active = Some(ActiveJob {
                id,
                node: i,
                job,
                transfer,
            });
        }
        if let Some(a) = &mut self.active {
            if let Some(f) = a.transfer.poll(now) {
                out.push(f);
            }
        }
        self.finish_active_job();
    }

    fn finish_active_job(&mut self) {
        let done = self.active.as_mut().and_then(|a| a.transfer.take_end());
        if let Some(end) = done {
            if let Some(a) = self.active.take() {
                let r = SdoJobResult::of(a.id, &a.job, end, self.s.sdo_timeout.as_millis() as u64);
                self.push_job_result(r);
            }
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

    /// How an axis is named in reports: `node 3`, or `node 1 axis 2` when
    /// its node carries both wheels.
    fn axis_label(&self, k: usize) -> String {
        let a = &self.axes[k];
        let n = &self.nodes[a.node];
        if n.wheels.len() > 1 {
            format!("node {} axis {}", n.id, a.layout.axis)
        } else {
            format!("node {}", n.id)
        }
    }

    fn running(&self, k: usize) -> bool {
        let a = &self.axes[k];
        a.phase == AxisPhase::Enabled && a.state_ok(self.nodes[a.node].nmt)
    }

    fn error(&self, k: usize) -> u32 {
        let a = &self.axes[k];
        if let Some(code) = self.nodes[a.node].startup_error {
            return code;
        }
        match a.drive_state {
            Some(DriveState::Fault | DriveState::FaultReactionActive) if a.error_code != 0 => u32::from(a.error_code),
            Some(DriveState::Fault | DriveState::FaultReactionActive) => FAULT_WITHOUT_CODE,
            _ => 0,
        }
    }

    fn axis_status(&self, k: usize) -> AxisStatus {
        let a = &self.axes[k];
        AxisStatus {
            error_code: self.error(k),
            running: self.running(k),
            estopped: a.drive_state == Some(DriveState::QuickStopActive),
            raw_state: a.drive_state.map_or(RAW_STATE_UNKNOWN, DriveState::code),
        }
    }

    /// The state of axis `k` at once (TPDO), not a sign of life.
    fn state_msg(&self, k: usize) -> DriveMessage {
        let st = self.axis_status(k);
        DriveMessage::State {
            wheels: Wheels::One(self.axes[k].wheel),
            error_code: st.error_code,
            running: st.running,
            estopped: st.estopped,
            raw_state: st.raw_state,
        }
    }

    /// A node's heartbeat: the status, with liveness, of every wheel it drives.
    fn heartbeat_msg(&self, i: usize) -> DriveMessage {
        let n = &self.nodes[i];
        if let [k] = n.wheels[..] {
            let st = self.axis_status(k);
            return DriveMessage::Status {
                wheels: Wheels::One(self.axes[k].wheel),
                error_code: st.error_code,
                running: st.running,
                estopped: st.estopped,
                raw_state: st.raw_state,
            };
        }
        let mut axes = [None; 2];
        for &k in &n.wheels {
            axes[self.axes[k].wheel.index()] = Some(self.axis_status(k));
        }
        DriveMessage::Heartbeat { axes }
    }

    fn fail_startup(&mut self, i: usize, e: SdoError) {
        let id = self.nodes[i].id;
        self.nodes[i].phase = NodePhase::Idle;
        for k in self.nodes[i].wheels.clone() {
            self.axes[k].phase = AxisPhase::Idle;
        }
        if !matches!(e, SdoError::Timeout { .. }) {
            self.nodes[i].startup_error = Some(e.code());
        }
        let wheel = self.node_wheel(i);
        self.report(wheel, format!("node {id} start-up failed: {e}"));
    }

    /// The wheel a node's own reports concern: its only one, or none (both).
    fn node_wheel(&self, i: usize) -> Option<Wheel> {
        match self.nodes[i].wheels[..] {
            [k] => Some(self.axes[k].wheel),
            _ => None,
        }
    }

    fn on_sdo(&mut self, i: usize, r: &SdoResponse) {
        let Some(outcome) = self.nodes[i].sdo.on_response(r) else {
            return;
        };
        let NodePhase::Configuring { next } = self.nodes[i].phase else {
            return;
        };
        match (outcome, self.nodes[i].steps.get(next).copied()) {
            (Err(e), _) => self.fail_startup(i, e),
            (Ok(v), Some(Step::CheckDeviceType)) => {
                let value = v.map_or(0, |v| v.as_u32());
                if value & 0xFFFF == pdo::DEVICE_PROFILE_402 {
                    self.nodes[i].phase = NodePhase::Configuring { next: next + 1 };
                } else {
                    let id = self.nodes[i].id;
                    self.nodes[i].phase = NodePhase::Idle;
                    self.nodes[i].startup_error = Some(sdo::abort::PARAMETER_INCOMPATIBLE);
                    let wheel = self.node_wheel(i);
                    self.report(
                        wheel,
                        format!("node {id} start-up failed: device type 0x{value:08X} is not a CiA 402 drive"),
                    );
                }
            }
            (Ok(_), _) => self.nodes[i].phase = NodePhase::Configuring { next: next + 1 },
        }
    }

    fn on_state_tpdo(&mut self, k: usize, t: &pdo::Tpdo1, cob: u32) -> Result<(), DecodeError> {
        let state = DriveState::from_statusword(t.statusword).ok_or(DecodeError::Invalid {
            id: cob,
            what: "statusword with an undefined state",
        })?;
        let nmt = self.nodes[self.axes[k].node].nmt;
        let label = self.axis_label(k);
        let a = &mut self.axes[k];
        let before = a.drive_state;
        a.drive_state = Some(state);
        a.error_code = t.error_code;
        a.mode_display = t.mode_display;
        let faulted = matches!(state, DriveState::Fault | DriveState::FaultReactionActive);
        match a.phase {
            AxisPhase::Enabling if !faulted => {
                // A fault that appears from here on is new: not reset.
                a.may_reset_fault = false;
                a.seen_ready |= state == DriveState::ReadyToSwitchOn;
                // Enabled by our own enable operation, after switch on from ready.
                if a.seen_ready && a.last_word == cw::ENABLE_OPERATION && a.state_ok(nmt) {
                    a.phase = AxisPhase::Enabled;
                }
            }
            AxisPhase::Enabled if state != DriveState::OperationEnabled => {
                a.phase = AxisPhase::Idle;
                let (wheel, code) = (a.wheel, a.error_code);
                self.report(
                    Some(wheel),
                    format!("{label} left operation enabled: {state:?} (0x603F = 0x{code:04X})"),
                );
            }
            _ => {}
        }
        if faulted && before != Some(state) && state == DriveState::Fault {
            let (wheel, code) = (self.axes[k].wheel, self.axes[k].error_code);
            self.report(
                Some(wheel),
                format!(
                    "{label} ({} wheel) fault, error code 0x{code:04X} ({})",
                    wheel.name(),
                    nmt::emcy_class(code)
                ),
            );
        }
        Ok(())
    }

    fn controlword(&mut self, k: usize, mode: SetpointMode) -> u16 {
        let a = &mut self.axes[k];
        if mode == SetpointMode::Estop {
            // Every period while latched; the drive is started again after reset.
            a.phase = AxisPhase::Idle;
            return cw::QUICK_STOP;
        }
        match a.phase {
            AxisPhase::Enabling => {
                let allow = a.may_reset_fault && a.fault_resets_left > 0;
                let w = enabling_controlword(a.drive_state, a.last_word, a.seen_ready, allow);
                if w == cw::FAULT_RESET {
                    a.fault_resets_left -= 1;
                }
                w
            }
            AxisPhase::Enabled if a.drive_state == Some(DriveState::OperationEnabled) => cw::ENABLE_OPERATION,
            _ => cw::SHUTDOWN,
        }
    }

    /// The axis whose PDO has COB-ID `cob`: (axis index, is the state TPDO).
    fn tpdo_axis(&self, cob: u32) -> Option<(usize, bool)> {
        self.axes.iter().enumerate().find_map(|(k, a)| {
            let id = self.nodes[a.node].id;
            if a.layout.tpdo_state_cob(id) == cob {
                Some((k, true))
            } else if a.layout.tpdo_motion_cob(id) == cob {
                Some((k, false))
            } else {
                None
            }
        })
    }
}

impl Protocol for Cia402Protocol {
    fn kind(&self) -> ProtocolKind {
        ProtocolKind::Cia402
    }

    fn rx_filters(&self) -> Vec<RxFilter> {
        let mut v = Vec::new();
        for n in &self.nodes {
            let id = u32::from(n.id);
            v.push(RxFilter::standard(nmt::COB_HEARTBEAT_BASE + id));
            for &k in &n.wheels {
                let a = &self.axes[k];
                v.push(RxFilter::standard(a.layout.tpdo_state_cob(n.id)));
                v.push(RxFilter::standard(a.layout.tpdo_motion_cob(n.id)));
            }
            v.push(RxFilter::standard(sdo::COB_TX_BASE + id));
            v.push(RxFilter::standard(nmt::COB_EMCY_BASE + id));
        }
        v
    }

    fn startup(&mut self, out: &mut FrameBatch) {
        for n in &mut self.nodes {
            n.sdo.cancel();
            n.phase = NodePhase::Configuring { next: 0 };
            n.startup_error = None;
            out.push(nmt::nmt_command(NmtCommand::EnterPreOperational, n.id));
        }
        for a in &mut self.axes {
            a.reset_for_startup();
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
        self.poll_jobs(now, out);
        for i in 0..self.nodes.len() {
            if let Some((e, abort)) = self.nodes[i].sdo.poll_timeout(now) {
                out.push(abort);
                self.fail_startup(i, e);
            }
            // One transfer at a time on a node's channel: a run-time job's first.
            let job_here = self.active.as_ref().is_some_and(|a| a.node == i);
            let n = &mut self.nodes[i];
            if let NodePhase::Configuring { next } = n.phase {
                if n.sdo.busy() || job_here {
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
                        n.phase = NodePhase::Started;
                        n.nmt = None;
                        for k in n.wheels.clone() {
                            let a = &mut self.axes[k];
                            a.phase = AxisPhase::Enabling;
                            a.drive_state = None;
                            a.seen_ready = false;
                        }
                    }
                }
            }
        }
    }

    fn setpoints(&mut self, motor: MotorSpeeds, mode: SetpointMode, out: &mut FrameBatch) {
        for k in 0..2 {
            let word = self.controlword(k, mode);
            let running = self.running(k);
            let a = &mut self.axes[k];
            let v = match mode {
                SetpointMode::Run if word == cw::ENABLE_OPERATION && running => motor.get(a.wheel),
                _ => 0.0,
            };
            a.last_word = word;
            let cob = a.layout.rpdo_cob(self.nodes[a.node].id);
            out.push(pdo::encode_rpdo(
                cob,
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
            n.phase = NodePhase::Idle;
        }
        for a in &mut self.axes {
            a.phase = AxisPhase::Idle;
            a.last_word = cw::SHUTDOWN;
            let cob = a.layout.rpdo_cob(self.nodes[a.node].id);
            out.push(pdo::encode_rpdo(
                cob,
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
        let id = self.nodes[i].id;
        // Traffic a node sends for itself is counted against its first wheel.
        let first_wheel = self.axes[self.nodes[i].wheels[0]].wheel;
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
                    n.phase = NodePhase::Idle;
                    for k in n.wheels.clone() {
                        self.axes[k].phase = AxisPhase::Idle;
                        self.axes[k].drive_state = None;
                    }
                    let wheel = self.node_wheel(i);
                    self.report(wheel, format!("node {id} booted (boot-up message): restarting it"));
                }
                self.nodes[i].nmt = Some(state);
                Ok(Some(self.heartbeat_msg(i)))
            }
            sdo::COB_TX_BASE => {
                if let Some(a) = self.active.as_mut().filter(|a| a.node == i) {
                    // A run-time job's answer (segments included).
                    if let Some(abort) = a.transfer.on_response(f) {
                        self.outbox.push(abort);
                    }
                    self.finish_active_job();
                    return Ok(Some(DriveMessage::Handled { wheel: first_wheel }));
                }
                let r = sdo::decode_response(f).map_err(|_| DecodeError::Invalid {
                    id: f.id,
                    what: "SDO response",
                })?;
                self.on_sdo(i, &r);
                Ok(Some(DriveMessage::Handled { wheel: first_wheel }))
            }
            nmt::COB_EMCY_BASE => {
                let e = nmt::decode_emcy(f).ok_or(DecodeError::Length {
                    id: f.id,
                    len: f.len,
                    expected: 8,
                })?;
                let wheel = self.node_wheel(i);
                self.report(
                    wheel,
                    format!(
                        "node {id} EMCY 0x{:04X} ({}), error register 0x{:02X}",
                        e.error_code,
                        nmt::emcy_class(e.error_code),
                        e.error_register
                    ),
                );
                Ok(Some(DriveMessage::Handled { wheel: first_wheel }))
            }
            _ => {
                let Some((k, state)) = self.tpdo_axis(f.id) else {
                    return Ok(None);
                };
                let len_err = |e: pdo::PdoLengthError| DecodeError::Length {
                    id: f.id,
                    len: e.got,
                    expected: e.expected,
                };
                if state {
                    let t = pdo::decode_tpdo1(f).map_err(len_err)?;
                    self.on_state_tpdo(k, &t, f.id)?;
                    Ok(Some(self.state_msg(k)))
                } else {
                    let t = pdo::decode_tpdo2(f).map_err(len_err)?;
                    Ok(Some(DriveMessage::Feedback {
                        wheel: self.axes[k].wheel,
                        motor_pos_rad: self.s.scaling.position_rad(t.position),
                        motor_vel_radps: self.s.scaling.velocity_from_drive(t.velocity),
                    }))
                }
            }
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

    fn sdo_request(&mut self, job: SdoJob) -> Result<SdoJobId, SdoRefusal> {
        self.check_job(&job)?;
        if self.jobs.len() + usize::from(self.active.is_some()) >= MAX_QUEUED_JOBS {
            return Err(SdoRefusal::Busy);
        }
        let id = self.next_job;
        self.next_job += 1;
        self.jobs.push_back((id, job));
        Ok(id)
    }

    fn drain_sdo_results(&mut self, out: &mut Vec<SdoJobResult>) {
        out.append(&mut self.job_results);
    }
}

#[cfg(test)]
#[path = "tests.rs"]
mod tests;

#[cfg(test)]
#[path = "two_axis_tests.rs"]
mod two_axis_tests;
