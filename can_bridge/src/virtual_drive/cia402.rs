//! The virtual drive's CANopen CiA 402 side: a node with one or two axes
//! (a drive per wheel, or a dual-channel controller whose axis 2 sits at
//! +0x800), a small object dictionary, an SDO server, NMT with boot-up and
//! heartbeat producer, a heartbeat consumer (0x1016:01), PDOs packed from
//! whatever mapping the dictionary holds (with the CiA 301 rules for
//! changing it), SYNC-driven and event-driven transmission, and per axis
//! the CiA 402 state machine and profile velocity ramps (0x6083/0x6084/0x6085).
//!
//! Supported objects, the node's: 0x1000, 0x1001, 0x1016:01, 0x1017; per
//! axis (axis 2 at the offset): its PDOs (axis 1: 0x1400/0x1600,
//! 0x1800/0x1A00, 0x1801/0x1A01; axis 2: 0x1401/0x1601, 0x1802/0x1A02,
//! 0x1803/0x1A03; comm. sub 1, 2, 3, 5, mapping sub 0–4), 0x603F, 0x6040,
//! 0x6041, 0x605A (2: quick stop then switch on disabled), 0x6060 (3 only),
//! 0x6061, 0x6064, 0x606C, 0x6083, 0x6084, 0x6085, 0x60FF; and two longer
//! than 4 bytes, moved by segmented SDO: 0x1008 (device name, read only)
//! and 0x2100 (a note, writable, up to 64 bytes). Anything else aborts with
//! 0x06020000 / 0x06090011. The SDO server answers expedited and segmented
//! transfers (CiA 301: toggle checked, size checked, 0x05030000 /
//! 0x06070010 otherwise).

use crate::bus::CanFrame;
use crate::kinematics::Wheel;
use crate::protocol::cia402::axis::AxisLayout;
use crate::protocol::cia402::nmt::{self, NmtCommand, NmtState};
use crate::protocol::cia402::pdo::{self, obj};
use crate::protocol::cia402::sdo::{self, abort, ObjectAddr, SdoRequest, SdoResponse, SdoValue};
use crate::protocol::cia402::state_machine::{sw, DriveMachine, DriveState};
use crate::protocol::cia402::units::Scaling;
use crate::protocol::cia402::{ERROR_HEARTBEAT, ERROR_RPDO_TIMEOUT};
use crate::time::Timestamp;
use std::collections::BTreeMap;
use std::time::Duration;

/// 0x1000: CiA 402, servo drive (type bits 16–23 = 2).
pub const DEVICE_TYPE: u32 = 0x0002_0192;
/// 0x1008: the manufacturer device name.
pub const DEVICE_NAME: &str = "oldbf virtual CiA 402 drive";
/// 0x2100: a writable note, for segmented writes.
pub const NOTE: ObjectAddr = ObjectAddr::new(0x2100, 0);
/// The longest note 0x2100 takes (bytes).
pub const NOTE_MAX: usize = 64;

/// A segmented SDO transfer the server is in.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Segmented {
    Upload {
        data: Vec<u8>,
        offset: usize,
        toggle: bool,
    },
    Download {
        addr: ObjectAddr,
        buf: Vec<u8>,
        size: Option<usize>,
        toggle: bool,
    },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Entry {
    value: u32,
    /// Bytes (1, 2 or 4).
    len: u8,
    writable: bool,
}

/// The object dictionary: (index, sub) → value.
#[derive(Clone, Debug, PartialEq, Eq)]
struct Od(BTreeMap<ObjectAddr, Entry>);

/// What a PDO carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum PdoKind {
    /// Controlword, target velocity (the bridge's).
    Rpdo,
    /// Statusword, error code, mode display.
    TpdoState,
    /// Position, velocity.
    TpdoMotion,
}

/// One PDO of one axis: its kind and its communication / mapping indices.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Pdo {
    axis: usize,
    kind: PdoKind,
    comm: u16,
    map: u16,
}

impl Od {
    fn defaults(id: u8, layouts: &[AxisLayout], heartbeat_ms: u16, event_ms: u16) -> Self {
        let mut m = BTreeMap::new();
        let mut put = |a: ObjectAddr, value: u32, len: u8, writable: bool| {
            m.insert(a, Entry { value, len, writable });
        };
        let at = |index: u16, sub: u8| ObjectAddr::new(index, sub);
        put(at(0x1000, 0), DEVICE_TYPE, 4, false);
        put(at(0x1001, 0), 0, 1, false);
        put(at(0x1016, 0), 1, 1, false);
        put(at(0x1016, 1), 0, 4, true);
        put(at(0x1017, 0), u32::from(heartbeat_ms), 2, true);
        for l in layouts {
            let (rc, rm) = l.rpdo_objects();
            put(at(rc, 1), l.rpdo_cob(id), 4, true);
            put(at(rc, 2), 255, 1, true);
            let rmap = l.rpdo_map();
            put(at(rm, 0), rmap.len() as u32, 1, true);
            for sub in 1..=4u8 {
                let v = rmap
                    .get(usize::from(sub) - 1)
                    .map_or(0, |(a, bits)| pdo::mapping_entry(*a, *bits));
                put(at(rm, sub), v, 4, true);
            }
            let (sc, sm) = l.tpdo_state_objects();
            let (mc, mm) = l.tpdo_motion_objects();
            for (comm, map, cob, entries) in [
                (sc, sm, l.tpdo_state_cob(id), &l.tpdo_state_map()[..]),
                (mc, mm, l.tpdo_motion_cob(id), &l.tpdo_motion_map()[..]),
            ] {
                put(at(comm, 1), cob, 4, true);
                put(at(comm, 2), 255, 1, true);
                put(at(comm, 3), 0, 2, true);
                put(at(comm, 5), u32::from(event_ms), 2, true);
                put(at(map, 0), entries.len() as u32, 1, true);
                for sub in 1..=4u8 {
                    let v = entries
                        .get(usize::from(sub) - 1)
                        .map_or(0, |(a, bits)| pdo::mapping_entry(*a, *bits));
                    put(at(map, sub), v, 4, true);
                }
            }
            let o = |a: ObjectAddr| l.obj(a);
            put(o(obj::ERROR_CODE), 0, 2, false);
            put(o(obj::CONTROLWORD), 0, 2, true);
            put(o(obj::STATUSWORD), 0, 2, false);
            put(o(ObjectAddr::new(0x605A, 0)), 2, 2, false);
            put(o(obj::MODES_OF_OPERATION), 0, 1, true);
            put(o(obj::MODES_OF_OPERATION_DISPLAY), 0, 1, false);
            put(o(obj::POSITION_ACTUAL), 0, 4, false);
            put(o(obj::VELOCITY_ACTUAL), 0, 4, false);
            put(o(obj::PROFILE_ACCELERATION), 10_000, 4, true);
            put(o(obj::PROFILE_DECELERATION), 10_000, 4, true);
            put(o(obj::QUICK_STOP_DECELERATION), 20_000, 4, true);
            put(o(obj::TARGET_VELOCITY), 0, 4, true);
        }
        Self(m)
    }

    fn get(&self, a: ObjectAddr) -> u32 {
        self.0.get(&a).map_or(0, |e| e.value)
    }

    /// Sets a value from the application (no access check).
    fn set_live(&mut self, a: ObjectAddr, v: u32) {
        if let Some(e) = self.0.get_mut(&a) {
            e.value = v;
        }
    }

    fn find(&self, a: ObjectAddr) -> Result<Entry, u32> {
        match self.0.get(&a) {
            Some(e) => Ok(*e),
            None if self.0.keys().any(|k| k.index == a.index) => Err(abort::NO_SUB_INDEX),
            None => Err(abort::NO_OBJECT),
        }
    }
}

fn sign_extend(v: u32, len: u8) -> i64 {
    match len {
        1 => i64::from(v as u8 as i8),
        2 => i64::from(v as u16 as i16),
        _ => i64::from(v as i32),
    }
}

/// What the node received that the axis model needs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NodeStats {
    pub rpdos: u64,
    pub syncs: u64,
    pub sdo_requests: u64,
    pub sdo_aborts_sent: u64,
    pub nmt_commands: u64,
    /// Enable operation reached while the target velocity was non-zero.
    pub enabled_with_nonzero_target: u64,
    pub quick_stops: u64,
    pub fault_resets: u64,
}

/// One axis of a node: its state machine and profile generator.
#[derive(Clone, Debug)]
pub struct CoAxis {
    pub wheel: Wheel,
    pub layout: AxisLayout,
    pub machine: DriveMachine,
    /// A synchronous RPDO waiting for the next SYNC.
    rpdo_pending: Option<CanFrame>,
    last_rpdo: Option<Timestamp>,
    /// Next event-timer transmission of the state and motion TPDOs.
    next_event: [Timestamp; 2],
    last_status_sent: Option<u16>,
    /// The profile generator's output (motor rad/s), what the motor tracks.
    pub demand_radps: f64,
}

impl CoAxis {
    fn new(wheel: Wheel, layout: AxisLayout, now: Timestamp) -> Self {
        Self {
            wheel,
            layout,
            machine: DriveMachine::new(),
            rpdo_pending: None,
            last_rpdo: None,
            next_event: [now; 2],
            last_status_sent: None,
            demand_radps: 0.0,
        }
    }
}

/// One CiA 402 node with its axes.
#[derive(Clone, Debug)]
pub struct CoNode {
    pub id: u8,
    pub nmt: NmtState,
    pub axes: Vec<CoAxis>,
    od: Od,
    defaults: Od,
    /// Objects longer than 4 bytes: (value, writable).
    long: BTreeMap<ObjectAddr, (Vec<u8>, bool)>,
    segmented: Option<Segmented>,
    pdos: Vec<Pdo>,
    last_bridge_heartbeat: Option<Timestamp>,
    next_heartbeat: Timestamp,
    sync_count: u32,
    pub stats: NodeStats,
    outbox: Vec<CanFrame>,
}

impl CoNode {
    /// A node that has just booted (its boot-up message is queued), driving
    /// the wheels in `axes` (one, or two on one node).
    pub fn new(id: u8, axes: &[(Wheel, AxisLayout)], heartbeat_ms: u16, event_ms: u16, now: Timestamp) -> Self {
        let layouts: Vec<AxisLayout> = axes.iter().map(|(_, l)| *l).collect();
        let od = Od::defaults(id, &layouts, heartbeat_ms, event_ms);
        let mut pdos = Vec::new();
        for (k, l) in layouts.iter().enumerate() {
            for (kind, (comm, map)) in [
                (PdoKind::Rpdo, l.rpdo_objects()),
                (PdoKind::TpdoState, l.tpdo_state_objects()),
                (PdoKind::TpdoMotion, l.tpdo_motion_objects()),
            ] {
                pdos.push(Pdo {
                    axis: k,
                    kind,
                    comm,
                    map,
                });
            }
        }
        let mut n = Self {
            id,
            nmt: NmtState::PreOperational,
            axes: axes.iter().map(|(w, l)| CoAxis::new(*w, *l, now)).collect(),
            defaults: od.clone(),
            od,
            long: BTreeMap::new(),
            segmented: None,
            pdos,
            last_bridge_heartbeat: None,
            next_heartbeat: now,
            sync_count: 0,
            stats: NodeStats::default(),
            outbox: Vec::new(),
        };
        n.boot(now);
        n
    }

    /// The axis of `wheel` on this node.
    pub fn axis(&self, wheel: Wheel) -> Option<&CoAxis> {
        self.axes.iter().find(|a| a.wheel == wheel)
    }

    /// Power-on or NMT reset node: dictionary defaults, boot-up, pre-operational.
    pub fn boot(&mut self, now: Timestamp) {
        self.od = self.defaults.clone();
        self.long = BTreeMap::from([
            (ObjectAddr::new(0x1008, 0), (DEVICE_NAME.as_bytes().to_vec(), false)),
            (NOTE, (b"none".to_vec(), true)),
        ]);
        self.segmented = None;
        self.nmt = NmtState::PreOperational;
        for a in &mut self.axes {
            a.machine = DriveMachine::new();
            a.rpdo_pending = None;
            a.last_rpdo = None;
            a.demand_radps = 0.0;
            a.last_status_sent = None;
        }
        self.last_bridge_heartbeat = None;
        self.outbox.push(nmt::heartbeat(self.id, NmtState::BootUp));
        self.next_heartbeat = now + self.heartbeat_period().unwrap_or(Duration::ZERO);
    }

    /// Axis `k`'s state as a statusword.
    pub fn statusword(&self, k: usize) -> u16 {
        let s = self.axes[k].machine.state;
        let mut w = s.statusword_bits() | sw::REMOTE;
        if matches!(
            s,
            DriveState::ReadyToSwitchOn
                | DriveState::SwitchedOn
                | DriveState::OperationEnabled
                | DriveState::QuickStopActive
        ) {
            w |= sw::VOLTAGE_ENABLED;
        }
        w
    }

    /// Axis `k`'s 0x603F.
    pub fn error_code(&self, k: usize) -> u16 {
        self.od.get(self.axes[k].layout.obj(obj::ERROR_CODE)) as u16
    }

    /// Axis `k`'s modes of operation.
    pub fn mode(&self, k: usize) -> i8 {
        self.od.get(self.axes[k].layout.obj(obj::MODES_OF_OPERATION)) as u8 as i8
    }

    /// A value the bridge wrote (for tests), as its type's signed value.
    pub fn object(&self, a: ObjectAddr) -> Option<i64> {
        self.od.0.get(&a).map(|e| sign_extend(e.value, e.len))
    }

    /// The bytes of an object longer than 4 bytes (0x1008, 0x2100).
    pub fn long_object(&self, a: ObjectAddr) -> Option<&[u8]> {
        self.long.get(&a).map(|(v, _)| v.as_slice())
    }

    /// The target axis `k`'s profile generator heads for (motor rad/s) and
    /// the ramp rate that applies (rad/s²).
    pub fn profile(&self, k: usize, scaling: &Scaling) -> (f64, f64) {
        let a = &self.axes[k];
        let l = a.layout;
        let rate = |x: ObjectAddr| f64::from(self.od.get(l.obj(x))) / scaling.units_per_radps();
        match a.machine.state {
            DriveState::OperationEnabled if self.mode(k) == pdo::MODE_PROFILE_VELOCITY => {
                let target = scaling.velocity_from_drive(self.od.get(l.obj(obj::TARGET_VELOCITY)) as i32);
                let speeding_up = target.abs() > a.demand_radps.abs() && target * a.demand_radps >= 0.0;
                let r = if speeding_up {
                    rate(obj::PROFILE_ACCELERATION)
                } else {
                    rate(obj::PROFILE_DECELERATION)
                };
                (target, r)
            }
            DriveState::QuickStopActive => (0.0, rate(obj::QUICK_STOP_DECELERATION)),
            // Power stage off: no torque; the motor model's lag brings it down.
            _ => (0.0, f64::INFINITY),
        }
    }

    /// Axis `k` faults with `code` (its 0x603F), signalled by EMCY.
    pub fn fault(&mut self, k: usize, code: u16) {
        if self.axes[k].machine.fault().is_some() {
            let l = self.axes[k].layout;
            self.od.set_live(l.obj(obj::ERROR_CODE), u32::from(code));
            self.od.set_live(ObjectAddr::new(0x1001, 0), 0x01);
            let e = nmt::Emcy {
                error_code: code,
                error_register: 0x01,
                manufacturer: [0; 5],
            };
            self.outbox.push(nmt::emcy(self.id, &e));
        }
    }

    fn heartbeat_period(&self) -> Option<Duration> {
        let ms = self.od.get(obj::PRODUCER_HEARTBEAT);
        (ms > 0).then(|| Duration::from_millis(u64::from(ms)))
    }

    fn pdo_enabled(&self, comm: u16) -> bool {
        self.od.get(ObjectAddr::new(comm, 1)) & pdo::COB_ID_INVALID == 0
    }

    /// Mapping entries of a PDO (index, sub, bits).
    fn mapping(&self, map: u16) -> Vec<(ObjectAddr, u8)> {
        let n = self.od.get(ObjectAddr::new(map, 0)).min(4) as u8;
        (1..=n)
            .map(|s| {
                let e = self.od.get(ObjectAddr::new(map, s));
                (ObjectAddr::new((e >> 16) as u16, (e >> 8) as u8), e as u8)
            })
            .collect()
    }

    /// The objects a PDO of `kind` of axis `k` may map.
    fn mappable(&self, k: usize, kind: PdoKind) -> Vec<ObjectAddr> {
        let l = self.axes[k].layout;
        match kind {
            PdoKind::Rpdo => vec![l.obj(obj::CONTROLWORD), l.obj(obj::TARGET_VELOCITY)],
            PdoKind::TpdoState | PdoKind::TpdoMotion => [
                obj::STATUSWORD,
                obj::ERROR_CODE,
                obj::MODES_OF_OPERATION_DISPLAY,
                obj::POSITION_ACTUAL,
                obj::VELOCITY_ACTUAL,
            ]
            .iter()
            .map(|a| l.obj(*a))
            .collect(),
        }
    }

    /// Handles a frame addressed to this node (or broadcast).
    pub fn handle(&mut self, f: &CanFrame, now: Timestamp, sdo_silent: bool, bridge_node: u8) {
        if f.extended {
            return;
        }
        let id = u32::from(self.id);
        if let Some((cmd, target)) = nmt::decode_nmt(f) {
            if target == 0 || target == self.id {
                self.stats.nmt_commands += 1;
                self.on_nmt(cmd, now);
            }
        } else if f.id == nmt::COB_SYNC {
            self.on_sync();
        } else if f.id == sdo::COB_RX_BASE + id {
            if !sdo_silent {
                self.on_sdo(f, now);
            }
        } else if f.id == nmt::COB_HEARTBEAT_BASE + u32::from(bridge_node) {
            self.last_bridge_heartbeat = Some(now);
        } else if let Some(p) = self.pdos.iter().copied().find(|p| {
            p.kind == PdoKind::Rpdo
                && f.id == self.od.get(ObjectAddr::new(p.comm, 1)) & 0x7FF
                && self.pdo_enabled(p.comm)
        }) {
            if self.nmt != NmtState::Operational {
                return;
            }
            let a = &mut self.axes[p.axis];
            a.last_rpdo = Some(now);
            if self.od.get(ObjectAddr::new(p.comm, 2)) <= 240 {
                a.rpdo_pending = Some(*f);
            } else {
                self.apply_rpdo(p, f);
            }
        }
    }

    fn on_nmt(&mut self, cmd: NmtCommand, now: Timestamp) {
        match cmd {
            NmtCommand::Start => self.nmt = NmtState::Operational,
            NmtCommand::Stop => self.nmt = NmtState::Stopped,
            NmtCommand::EnterPreOperational => self.nmt = NmtState::PreOperational,
            NmtCommand::ResetNode | NmtCommand::ResetCommunication => self.boot(now),
        }
        for a in &mut self.axes {
            a.rpdo_pending = None;
        }
    }

    fn on_sync(&mut self) {
        if self.nmt != NmtState::Operational {
            return;
        }
        self.stats.syncs += 1;
        for p in self.pdos.clone() {
            if p.kind == PdoKind::Rpdo {
                // Synchronous RPDO data takes effect at the SYNC after it.
                if let Some(f) = self.axes[p.axis].rpdo_pending.take() {
                    self.apply_rpdo(p, &f);
                }
            }
        }
        self.sync_count = self.sync_count.wrapping_add(1);
        for p in self.pdos.clone() {
            let kind = self.od.get(ObjectAddr::new(p.comm, 2));
            if p.kind != PdoKind::Rpdo && self.pdo_enabled(p.comm) && kind <= 240 && self.sync_count % kind.max(1) == 0
            {
                self.send_tpdo(p);
            }
        }
    }

    fn apply_rpdo(&mut self, p: Pdo, f: &CanFrame) {
        let map = self.mapping(p.map);
        let need: u32 = map.iter().map(|(_, b)| u32::from(*b) / 8).sum();
        if u32::from(f.len) < need {
            return; // CiA 301: too short a PDO is not processed (EMCY 0x8210 on real drives).
        }
        let mut at = 0usize;
        for (a, bits) in map {
            let n = usize::from(bits / 8);
            let mut b = [0u8; 4];
            b[..n].copy_from_slice(&f.data[at..at + n]);
            at += n;
            self.od.set_live(a, u32::from_le_bytes(b));
        }
        self.stats.rpdos += 1;
        let l = self.axes[p.axis].layout;
        let before = self.axes[p.axis].machine.state;
        let word = self.od.get(l.obj(obj::CONTROLWORD)) as u16;
        if word & 0x80 != 0 && before == DriveState::Fault {
            self.stats.fault_resets += 1;
        }
        if self.axes[p.axis].machine.on_controlword(word).is_some() {
            let after = self.axes[p.axis].machine.state;
            if after == DriveState::OperationEnabled && self.od.get(l.obj(obj::TARGET_VELOCITY)) != 0 {
                self.stats.enabled_with_nonzero_target += 1;
            }
            if after == DriveState::QuickStopActive {
                self.stats.quick_stops += 1;
            }
            if before == DriveState::Fault {
                self.od.set_live(l.obj(obj::ERROR_CODE), 0);
                if self.axes.iter().all(|a| a.machine.state != DriveState::Fault) {
                    self.od.set_live(ObjectAddr::new(0x1001, 0), 0);
                }
            }
        }
    }

    fn live_values(&mut self, scaling: &Scaling, motion: &[(f64, f64)]) {
        for k in 0..self.axes.len() {
            let l = self.axes[k].layout;
            let (pos_rad, vel_radps) = motion.get(k).copied().unwrap_or((0.0, 0.0));
            let sw = u32::from(self.statusword(k));
            self.od.set_live(l.obj(obj::STATUSWORD), sw);
            self.od.set_live(
                l.obj(obj::MODES_OF_OPERATION_DISPLAY),
                self.od.get(l.obj(obj::MODES_OF_OPERATION)),
            );
            let counts = (pos_rad / std::f64::consts::TAU * scaling.counts_per_rev()).round();
            // Wraps like a 32-bit encoder counter.
            let counts = if counts.is_finite() { (counts as i64) as i32 } else { 0 };
            self.od.set_live(l.obj(obj::POSITION_ACTUAL), counts as u32);
            self.od
                .set_live(l.obj(obj::VELOCITY_ACTUAL), scaling.velocity_to_drive(vel_radps) as u32);
        }
    }

    fn send_tpdo(&mut self, p: Pdo) {
        let mut data = [0u8; 8];
        let mut at = 0usize;
        let map = self.mapping(p.map);
        for (a, bits) in &map {
            let n = usize::from(bits / 8).min(8 - at);
            data[at..at + n].copy_from_slice(&self.od.get(*a).to_le_bytes()[..n]);
            at += n;
        }
        let cob = self.od.get(ObjectAddr::new(p.comm, 1)) & 0x7FF;
        self.outbox.push(CanFrame {
            id: cob,
            extended: false,
            data,
            len: at as u8,
        });
        let status = self.axes[p.axis].layout.obj(obj::STATUSWORD);
        if map.iter().any(|(a, _)| *a == status) {
            self.axes[p.axis].last_status_sent = Some(self.od.get(status) as u16);
        }
    }

    fn respond(&mut self, r: SdoResponse) {
        if matches!(r, SdoResponse::Abort { .. }) {
            self.stats.sdo_aborts_sent += 1;
        }
        self.outbox.push(sdo::encode_response(self.id, &r));
    }

    fn segment_frame(&self, cmd: u8, payload: &[u8]) -> CanFrame {
        let mut data = [0u8; 8];
        data[0] = cmd;
        data[1..1 + payload.len()].copy_from_slice(payload);
        CanFrame {
            id: sdo::COB_TX_BASE + u32::from(self.id),
            extended: false,
            data,
            len: 8,
        }
    }

    /// The segmented part of the SDO server (CiA 301 §7.2.4.3.3–.3.8):
    /// `true` if the frame was one of its requests.
    fn on_segmented_sdo(&mut self, f: &CanFrame) -> bool {
        let d = f.data;
        let cmd = d[0];
        let addr = ObjectAddr::new(u16::from_le_bytes([d[1], d[2]]), d[3]);
        match cmd >> 5 {
            // Upload initiate of a long object: segmented if over 4 bytes.
            2 if self.long.contains_key(&addr) => {
                let value = self.long[&addr].0.clone();
                if value.len() <= 4 {
                    let mut bytes = [0u8; 4];
                    bytes[..value.len()].copy_from_slice(&value);
                    let len = value.len().max(1) as u8;
                    self.respond(SdoResponse::Uploaded {
                        addr,
                        value: SdoValue { bytes, len },
                    });
                } else {
                    let size = (value.len() as u32).to_le_bytes();
                    let i = addr.index.to_le_bytes();
                    let frame = CanFrame {
                        id: sdo::COB_TX_BASE + u32::from(self.id),
                        extended: false,
                        data: [0x41, i[0], i[1], addr.sub, size[0], size[1], size[2], size[3]],
                        len: 8,
                    };
                    self.outbox.push(frame);
                    self.segmented = Some(Segmented::Upload {
                        data: value,
                        offset: 0,
                        toggle: false,
                    });
                }
                true
            }
            // Upload segment request.
            3 => {
                let t = cmd & 0x10 != 0;
                match self.segmented.take() {
                    Some(Segmented::Upload { data, offset, toggle }) if toggle == t => {
                        let chunk = data[offset..(offset + 7).min(data.len())].to_vec();
                        let last = offset + chunk.len() >= data.len();
                        let n = (7 - chunk.len()) as u8;
                        let f = self.segment_frame((u8::from(t) << 4) | (n << 1) | u8::from(last), &chunk);
                        self.outbox.push(f);
                        if !last {
                            self.segmented = Some(Segmented::Upload {
                                data,
                                offset: offset + 7,
                                toggle: !toggle,
                            });
                        }
                    }
                    Some(Segmented::Upload { .. }) => self.abort_seg(addr, abort::TOGGLE_BIT),
                    _ => self.abort_seg(addr, abort::COMMAND_SPECIFIER),
                }
                true
            }
            // Download initiate without e: segmented.
            1 if cmd & 0x02 == 0 => {
                match self.long.get(&addr) {
                    None => self.respond(SdoResponse::Abort {
                        addr,
                        code: if self.od.find(addr).is_ok() {
                            abort::LENGTH_TOO_HIGH
                        } else {
                            abort::NO_OBJECT
                        },
                    }),
                    Some((_, false)) => self.respond(SdoResponse::Abort {
                        addr,
                        code: abort::READ_ONLY,
                    }),
                    Some(_) => {
                        let size = (cmd & 0x01 != 0).then(|| u32::from_le_bytes([d[4], d[5], d[6], d[7]]) as usize);
                        if size.is_some_and(|s| s > NOTE_MAX) {
                            self.respond(SdoResponse::Abort {
                                addr,
                                code: abort::LENGTH_TOO_HIGH,
                            });
                        } else {
                            self.respond(SdoResponse::DownloadDone { addr });
                            self.segmented = Some(Segmented::Download {
                                addr,
                                buf: Vec::new(),
                                size,
                                toggle: false,
                            });
                        }
                    }
                }
                true
            }
            // Download segment.
            0 => {
                let t = cmd & 0x10 != 0;
                match self.segmented.take() {
                    Some(Segmented::Download {
                        addr: target,
                        mut buf,
                        size,
                        toggle,
                    }) if toggle == t => {
                        let n = usize::from((cmd >> 1) & 0x07);
                        buf.extend_from_slice(&d[1..8 - n]);
                        if buf.len() > NOTE_MAX {
                            self.abort_seg(target, abort::LENGTH_TOO_HIGH);
                            return true;
                        }
                        if cmd & 0x01 != 0 {
                            if size.is_some_and(|s| s != buf.len()) {
                                self.abort_seg(target, abort::LENGTH_MISMATCH);
                                return true;
                            }
                            if let Some(e) = self.long.get_mut(&target) {
                                e.0 = buf;
                            }
                        } else {
                            self.segmented = Some(Segmented::Download {
                                addr: target,
                                buf,
                                size,
                                toggle: !toggle,
                            });
                        }
                        let f = self.segment_frame(0x20 | (u8::from(t) << 4), &[]);
                        self.outbox.push(f);
                    }
                    Some(Segmented::Download { addr: target, .. }) => self.abort_seg(target, abort::TOGGLE_BIT),
                    _ => self.abort_seg(addr, abort::COMMAND_SPECIFIER),
                }
                true
            }
            _ => false,
        }
    }

    fn abort_seg(&mut self, addr: ObjectAddr, code: u32) {
        self.segmented = None;
        self.respond(SdoResponse::Abort { addr, code });
    }

    fn on_sdo(&mut self, f: &CanFrame, now: Timestamp) {
        self.stats.sdo_requests += 1;
        if f.len == 8 && f.data[0] >> 5 == 4 {
            // The client gave up: forget any segmented transfer.
            self.segmented = None;
            return;
        }
        if f.len == 8 && self.on_segmented_sdo(f) {
            return;
        }
        let req = match sdo::decode_request(f) {
            Ok(r) => r,
            Err(_) => {
                let addr = ObjectAddr::new(u16::from_le_bytes([f.data[1], f.data[2]]), f.data[3]);
                return self.respond(SdoResponse::Abort {
                    addr,
                    code: abort::COMMAND_SPECIFIER,
                });
            }
        };
        match req {
            SdoRequest::Upload { addr } => match self.od.find(addr) {
                Ok(e) => self.respond(SdoResponse::Uploaded {
                    addr,
                    value: SdoValue {
                        bytes: e.value.to_le_bytes(),
                        len: e.len,
                    },
                }),
                Err(code) => self.respond(SdoResponse::Abort { addr, code }),
            },
            SdoRequest::Download { addr, value } => match self.write(addr, value, now) {
                Ok(()) => self.respond(SdoResponse::DownloadDone { addr }),
                Err(code) => self.respond(SdoResponse::Abort { addr, code }),
            },
            SdoRequest::Abort { .. } => {}
        }
    }

    /// An SDO download, with the dictionary's and CiA 301's rules.
    fn write(&mut self, a: ObjectAddr, v: SdoValue, now: Timestamp) -> Result<(), u32> {
        if let Some((value, writable)) = self.long.get_mut(&a) {
            if !*writable {
                return Err(abort::READ_ONLY);
            }
            *value = v.bytes[..usize::from(v.len.clamp(1, 4))].to_vec();
            return Ok(());
        }
        let e = self.od.find(a)?;
        if !e.writable {
            return Err(abort::READ_ONLY);
        }
        if v.len != e.len {
            return Err(abort::LENGTH_MISMATCH);
        }
        let x = v.as_u32();
        if let Some(p) = self.pdos.iter().copied().find(|p| p.map == a.index) {
            // Mapping changes only while the PDO is disabled (CiA 301 §7.4.8.5).
            if self.pdo_enabled(p.comm) {
                return Err(abort::DEVICE_STATE);
            }
            let mappable = self.mappable(p.axis, p.kind);
            if a.sub == 0 {
                if x > 4 {
                    return Err(abort::VALUE_TOO_HIGH);
                }
                let bits: u32 = (1..=x as u8)
                    .map(|s| self.od.get(ObjectAddr::new(p.map, s)) & 0xFF)
                    .sum();
                if bits > 64 {
                    return Err(abort::PDO_LENGTH);
                }
            } else {
                if self.od.get(ObjectAddr::new(p.map, 0)) != 0 {
                    return Err(abort::DEVICE_STATE);
                }
                let target = ObjectAddr::new((x >> 16) as u16, (x >> 8) as u8);
                let bits = x & 0xFF;
                let len_ok = self.od.find(target).is_ok_and(|t| u32::from(t.len) * 8 == bits);
                if x != 0 && (!mappable.contains(&target) || !len_ok) {
                    return Err(abort::NOT_MAPPABLE);
                }
            }
        }
        if self.pdos.iter().any(|p| p.comm == a.index) && a.sub == 2 && !(x <= 240 || x >= 254) {
            return Err(abort::INVALID_VALUE);
        }
        for l in self.axes.iter().map(|ax| ax.layout) {
            if a == l.obj(obj::MODES_OF_OPERATION) && x as u8 as i8 != pdo::MODE_PROFILE_VELOCITY {
                return Err(abort::INVALID_VALUE);
            }
            let ramps = [
                obj::PROFILE_ACCELERATION,
                obj::PROFILE_DECELERATION,
                obj::QUICK_STOP_DECELERATION,
            ];
            if ramps.iter().any(|r| l.obj(*r) == a) && x == 0 {
                return Err(abort::VALUE_TOO_LOW);
            }
        }
        self.od.set_live(a, x);
        if a == obj::PRODUCER_HEARTBEAT {
            self.next_heartbeat = now;
        }
        if let Some(k) = self.axes.iter().position(|ax| ax.layout.obj(obj::CONTROLWORD) == a) {
            self.axes[k].machine.on_controlword(x as u16);
        }
        Ok(())
    }

    /// Advances timers; appends the frames due to `out`. `motion`: each
    /// axis's motor (angle rad, speed rad/s), in the order of `axes`.
    /// Returns why an axis faulted by itself (a watchdog), if one did.
    #[allow(clippy::too_many_arguments)]
    pub fn step(
        &mut self,
        now: Timestamp,
        scaling: &Scaling,
        motion: &[(f64, f64)],
        watchdog: Duration,
        mute_heartbeat: bool,
        mute_feedback: bool,
        out: &mut Vec<CanFrame>,
    ) -> Option<&'static str> {
        let mut tripped = None;
        for (k, a) in self.axes.iter_mut().enumerate() {
            let still = motion.get(k).is_none_or(|m| m.1.abs() < 1e-3);
            a.machine.tick(still);
        }
        // Heartbeat consumer: monitoring starts with the first heartbeat (CiA 301).
        let consumer = self.od.get(obj::CONSUMER_HEARTBEAT_1);
        let consumer_ms = u64::from(consumer & 0xFFFF);
        if consumer_ms > 0 {
            if let Some(t) = self.last_bridge_heartbeat {
                if now - t > Duration::from_millis(consumer_ms) {
                    self.last_bridge_heartbeat = None;
                    for k in 0..self.axes.len() {
                        let s = self.axes[k].machine.state;
                        if s.powered() || s == DriveState::SwitchedOn {
                            self.fault(k, ERROR_HEARTBEAT as u16);
                            tripped = Some("heartbeat consumer");
                        }
                    }
                }
            }
        }
        // The command watchdog: RPDOs must keep coming while enabled.
        for k in 0..self.axes.len() {
            let a = &self.axes[k];
            if a.machine.state == DriveState::OperationEnabled && a.last_rpdo.is_none_or(|t| now - t > watchdog) {
                self.fault(k, ERROR_RPDO_TIMEOUT as u16);
                tripped = Some("RPDO watchdog");
            }
        }
        self.live_values(scaling, motion);
        // The outbox (SDO answers, EMCY, boot-up, SYNC TPDOs) goes first.
        let tpdo_cobs: Vec<u32> = self
            .pdos
            .iter()
            .filter(|p| p.kind != PdoKind::Rpdo)
            .map(|p| self.od.get(ObjectAddr::new(p.comm, 1)) & 0x7FF)
            .collect();
        for f in self.outbox.drain(..) {
            let is_hb = f.id == nmt::COB_HEARTBEAT_BASE + u32::from(self.id);
            let is_pdo = tpdo_cobs.contains(&f.id);
            let muted = (is_hb && mute_heartbeat) || (is_pdo && mute_feedback);
            if !muted {
                out.push(f);
            }
        }
        if let Some(p) = self.heartbeat_period() {
            if now >= self.next_heartbeat {
                self.next_heartbeat = super::next_grid(self.next_heartbeat, now, 1.0 / p.as_secs_f64());
                if !mute_heartbeat {
                    out.push(nmt::heartbeat(self.id, self.nmt));
                }
            }
        }
        if self.nmt == NmtState::Operational {
            for p in self.pdos.clone() {
                let slot = match p.kind {
                    PdoKind::Rpdo => continue,
                    PdoKind::TpdoState => 0,
                    PdoKind::TpdoMotion => 1,
                };
                let kind = self.od.get(ObjectAddr::new(p.comm, 2));
                if !self.pdo_enabled(p.comm) || kind <= 240 {
                    continue;
                }
                let event_ms = self.od.get(ObjectAddr::new(p.comm, 5));
                let a = &self.axes[p.axis];
                let timer_due = event_ms > 0 && now >= a.next_event[slot];
                let status = a.layout.obj(obj::STATUSWORD);
                let cos = self.mapping(p.map).iter().any(|(x, _)| *x == status)
                    && a.last_status_sent != Some(self.od.get(status) as u16);
                if timer_due {
                    let a = &mut self.axes[p.axis];
                    a.next_event[slot] = super::next_grid(a.next_event[slot], now, 1000.0 / f64::from(event_ms));
                }
                if timer_due || cos {
                    self.send_tpdo(p);
                    if let Some(f) = self.outbox.pop() {
                        if !mute_feedback {
                            out.push(f);
                        }
                    }
                }
            }
        }
        tripped
    }

    /// When [`step`](Self::step) next has frames to send.
    pub fn next_deadline(&self, now: Timestamp) -> Timestamp {
        if !self.outbox.is_empty() {
            return now;
        }
        let mut t = now + Duration::from_millis(20);
        if self.heartbeat_period().is_some() {
            t = t.min(self.next_heartbeat);
        }
        if self.nmt == NmtState::Operational {
            for p in &self.pdos {
                let slot = match p.kind {
                    PdoKind::Rpdo => continue,
                    PdoKind::TpdoState => 0,
                    PdoKind::TpdoMotion => 1,
                };
                if self.od.get(ObjectAddr::new(p.comm, 2)) > 240 && self.od.get(ObjectAddr::new(p.comm, 5)) > 0 {
                    t = t.min(self.axes[p.axis].next_event[slot]);
                }
            }
        }
        t
    }
}
