//! The virtual drive's CANopen CiA 402 side: one node per axis with a small
//! object dictionary, an expedited SDO server, NMT with boot-up and
//! heartbeat producer, a heartbeat consumer (0x1016:01), PDOs packed from
//! whatever mapping the dictionary holds (with the CiA 301 rules for
//! changing it), SYNC-driven and event-driven transmission, the CiA 402
//! state machine, and profile velocity ramps (0x6083/0x6084/0x6085).
//!
//! Supported objects: 0x1000, 0x1001, 0x1016:01, 0x1017, 0x1400 (sub 1, 2),
//! 0x1600 (sub 0–4), 0x1800/0x1801 (sub 1, 2, 3, 5), 0x1A00/0x1A01 (sub
//! 0–4), 0x603F, 0x6040, 0x6041, 0x605A (2: quick stop then switch on
//! disabled), 0x6060 (3 only), 0x6061, 0x6064, 0x606C, 0x6083, 0x6084,
//! 0x6085, 0x60FF. Anything else aborts with 0x06020000 / 0x06090011.

use crate::bus::CanFrame;
use crate::kinematics::Wheel;
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

impl Od {
    fn defaults(id: u8, heartbeat_ms: u16, event_ms: u16) -> Self {
        let id = u32::from(id);
        let mut m = BTreeMap::new();
        let mut put = |index: u16, sub: u8, value: u32, len: u8, writable: bool| {
            m.insert(ObjectAddr::new(index, sub), Entry { value, len, writable });
        };
        put(0x1000, 0, DEVICE_TYPE, 4, false);
        put(0x1001, 0, 0, 1, false);
        put(0x1016, 0, 1, 1, false);
        put(0x1016, 1, 0, 4, true);
        put(0x1017, 0, u32::from(heartbeat_ms), 2, true);
        put(0x1400, 1, pdo::COB_RPDO1_BASE + id, 4, true);
        put(0x1400, 2, 255, 1, true);
        put(0x1600, 0, 2, 1, true);
        put(0x1600, 1, pdo::mapping_entry(obj::CONTROLWORD, 16), 4, true);
        put(0x1600, 2, pdo::mapping_entry(obj::TARGET_VELOCITY, 32), 4, true);
        put(0x1600, 3, 0, 4, true);
        put(0x1600, 4, 0, 4, true);
        for (comm, map, cob, entries) in [
            (0x1800u16, 0x1A00u16, pdo::COB_TPDO1_BASE + id, &pdo::TPDO1_MAP[..]),
            (0x1801, 0x1A01, pdo::COB_TPDO2_BASE + id, &pdo::TPDO2_MAP[..]),
        ] {
            put(comm, 1, cob, 4, true);
            put(comm, 2, 255, 1, true);
            put(comm, 3, 0, 2, true);
            put(comm, 5, u32::from(event_ms), 2, true);
            put(map, 0, entries.len() as u32, 1, true);
            for sub in 1..=4u8 {
                let v = entries
                    .get(usize::from(sub) - 1)
                    .map_or(0, |(a, bits)| pdo::mapping_entry(*a, *bits));
                put(map, sub, v, 4, true);
            }
        }
        put(0x603F, 0, 0, 2, false);
        put(0x6040, 0, 0, 2, true);
        put(0x6041, 0, 0, 2, false);
        put(0x605A, 0, 2, 2, false);
        put(0x6060, 0, 0, 1, true);
        put(0x6061, 0, 0, 1, false);
        put(0x6064, 0, 0, 4, false);
        put(0x606C, 0, 0, 4, false);
        put(0x6083, 0, 10_000, 4, true);
        put(0x6084, 0, 10_000, 4, true);
        put(0x6085, 0, 20_000, 4, true);
        put(0x60FF, 0, 0, 4, true);
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

/// Objects that may be mapped into the RPDO / the TPDOs.
const RPDO_MAPPABLE: [ObjectAddr; 2] = [obj::CONTROLWORD, obj::TARGET_VELOCITY];
const TPDO_MAPPABLE: [ObjectAddr; 5] = [
    obj::STATUSWORD,
    obj::ERROR_CODE,
    obj::MODES_OF_OPERATION_DISPLAY,
    obj::POSITION_ACTUAL,
    obj::VELOCITY_ACTUAL,
];

/// (communication index, mapping index) of the three PDOs; RPDO first.
const PDOS: [(u16, u16); 3] = [(0x1400, 0x1600), (0x1800, 0x1A00), (0x1801, 0x1A01)];

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

/// One CiA 402 node (one axis).
#[derive(Clone, Debug)]
pub struct CoNode {
    pub id: u8,
    pub wheel: Wheel,
    pub nmt: NmtState,
    pub machine: DriveMachine,
    od: Od,
    defaults: Od,
    /// A synchronous RPDO waiting for the next SYNC.
    rpdo_pending: Option<CanFrame>,
    last_rpdo: Option<Timestamp>,
    last_bridge_heartbeat: Option<Timestamp>,
    next_heartbeat: Timestamp,
    next_event: [Timestamp; 2],
    sync_count: u32,
    last_status_sent: Option<u16>,
    /// The profile generator's output (motor rad/s), what the motor tracks.
    pub demand_radps: f64,
    pub stats: NodeStats,
    outbox: Vec<CanFrame>,
}

impl CoNode {
    /// A node that has just booted (its boot-up message is queued).
    pub fn new(id: u8, wheel: Wheel, heartbeat_ms: u16, event_ms: u16, now: Timestamp) -> Self {
        let od = Od::defaults(id, heartbeat_ms, event_ms);
        let mut n = Self {
            id,
            wheel,
            nmt: NmtState::PreOperational,
            machine: DriveMachine::new(),
            defaults: od.clone(),
            od,
            rpdo_pending: None,
            last_rpdo: None,
            last_bridge_heartbeat: None,
            next_heartbeat: now,
            next_event: [now; 2],
            sync_count: 0,
            last_status_sent: None,
            demand_radps: 0.0,
            stats: NodeStats::default(),
            outbox: Vec::new(),
        };
        n.boot(now);
        n
    }

    /// Power-on or NMT reset node: dictionary defaults, boot-up, pre-operational.
    pub fn boot(&mut self, now: Timestamp) {
        self.od = self.defaults.clone();
        self.machine = DriveMachine::new();
        self.nmt = NmtState::PreOperational;
        self.rpdo_pending = None;
        self.last_rpdo = None;
        self.last_bridge_heartbeat = None;
        self.demand_radps = 0.0;
        self.last_status_sent = None;
        self.outbox.push(nmt::heartbeat(self.id, NmtState::BootUp));
        self.next_heartbeat = now + self.heartbeat_period().unwrap_or(Duration::ZERO);
    }

    /// The state as a statusword.
    pub fn statusword(&self) -> u16 {
        let s = self.machine.state;
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

    pub fn error_code(&self) -> u16 {
        self.od.get(obj::ERROR_CODE) as u16
    }

    pub fn mode(&self) -> i8 {
        self.od.get(obj::MODES_OF_OPERATION) as u8 as i8
    }

    /// A value the bridge wrote (for tests), as its type's signed value.
    pub fn object(&self, a: ObjectAddr) -> Option<i64> {
        self.od.0.get(&a).map(|e| sign_extend(e.value, e.len))
    }

    /// The target the profile generator heads for (motor rad/s) and the
    /// ramp rate that applies (rad/s²).
    pub fn profile(&self, scaling: &Scaling) -> (f64, f64) {
        let rate = |a: ObjectAddr| f64::from(self.od.get(a)) / scaling.units_per_radps();
        match self.machine.state {
            DriveState::OperationEnabled if self.mode() == pdo::MODE_PROFILE_VELOCITY => {
                let target = scaling.velocity_from_drive(self.od.get(obj::TARGET_VELOCITY) as i32);
                let speeding_up = target.abs() > self.demand_radps.abs() && target * self.demand_radps >= 0.0;
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

    /// A fault with `code` (0x603F), signalled by EMCY.
    pub fn fault(&mut self, code: u16) {
        if self.machine.fault().is_some() {
            self.od.set_live(obj::ERROR_CODE, u32::from(code));
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
        } else if f.id == self.od.get(obj::RPDO1_COB_ID) & 0x7FF && self.pdo_enabled(0x1400) {
            if self.nmt != NmtState::Operational {
                return;
            }
            self.last_rpdo = Some(now);
            let kind = self.od.get(obj::RPDO1_TYPE);
            if kind <= 240 {
                self.rpdo_pending = Some(*f);
            } else {
                self.apply_rpdo(f);
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
        self.rpdo_pending = None;
    }

    fn on_sync(&mut self) {
        if self.nmt != NmtState::Operational {
            return;
        }
        self.stats.syncs += 1;
        if let Some(f) = self.rpdo_pending.take() {
            // Synchronous RPDO data takes effect at the SYNC after it.
            self.apply_rpdo(&f);
        }
        self.sync_count = self.sync_count.wrapping_add(1);
        for (k, (comm, _)) in PDOS[1..].iter().enumerate() {
            let kind = self.od.get(ObjectAddr::new(*comm, 2));
            if self.pdo_enabled(*comm) && kind <= 240 && self.sync_count % kind.max(1) == 0 {
                self.send_tpdo(k);
            }
        }
    }

    fn apply_rpdo(&mut self, f: &CanFrame) {
        let map = self.mapping(0x1600);
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
        let before = self.machine.state;
        let word = self.od.get(obj::CONTROLWORD) as u16;
        if word & 0x80 != 0 && before == DriveState::Fault {
            self.stats.fault_resets += 1;
        }
        if self.machine.on_controlword(word).is_some() {
            let after = self.machine.state;
            if after == DriveState::OperationEnabled && self.od.get(obj::TARGET_VELOCITY) != 0 {
                self.stats.enabled_with_nonzero_target += 1;
            }
            if after == DriveState::QuickStopActive {
                self.stats.quick_stops += 1;
            }
            if before == DriveState::Fault {
                self.od.set_live(obj::ERROR_CODE, 0);
                self.od.set_live(ObjectAddr::new(0x1001, 0), 0);
            }
        }
    }

    fn live_values(&mut self, scaling: &Scaling, pos_rad: f64, vel_radps: f64) {
        let sw = u32::from(self.statusword());
        self.od.set_live(obj::STATUSWORD, sw);
        self.od
            .set_live(obj::MODES_OF_OPERATION_DISPLAY, self.od.get(obj::MODES_OF_OPERATION));
        let counts = (pos_rad / std::f64::consts::TAU * scaling.counts_per_rev()).round();
        // Wraps like a 32-bit encoder counter.
        let counts = if counts.is_finite() { (counts as i64) as i32 } else { 0 };
        self.od.set_live(obj::POSITION_ACTUAL, counts as u32);
        self.od
            .set_live(obj::VELOCITY_ACTUAL, scaling.velocity_to_drive(vel_radps) as u32);
    }

    fn send_tpdo(&mut self, k: usize) {
        let (comm, map) = PDOS[1 + k];
        let mut data = [0u8; 8];
        let mut at = 0usize;
        for (a, bits) in self.mapping(map) {
            let n = usize::from(bits / 8).min(8 - at);
            data[at..at + n].copy_from_slice(&self.od.get(a).to_le_bytes()[..n]);
            at += n;
        }
        let cob = self.od.get(ObjectAddr::new(comm, 1)) & 0x7FF;
        self.outbox.push(CanFrame {
            id: cob,
            extended: false,
            data,
            len: at as u8,
        });
        if self.mapping(map).iter().any(|(a, _)| *a == obj::STATUSWORD) {
            self.last_status_sent = Some(self.od.get(obj::STATUSWORD) as u16);
        }
    }

    fn respond(&mut self, r: SdoResponse) {
        if matches!(r, SdoResponse::Abort { .. }) {
            self.stats.sdo_aborts_sent += 1;
        }
        self.outbox.push(sdo::encode_response(self.id, &r));
    }

    fn on_sdo(&mut self, f: &CanFrame, now: Timestamp) {
        self.stats.sdo_requests += 1;
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
        let e = self.od.find(a)?;
        if !e.writable {
            return Err(abort::READ_ONLY);
        }
        if v.len != e.len {
            return Err(abort::LENGTH_MISMATCH);
        }
        let x = v.as_u32();
        if let Some(&(comm, map)) = PDOS.iter().find(|(_, m)| *m == a.index) {
            // Mapping changes only while the PDO is disabled (CiA 301 §7.4.8.5).
            if self.pdo_enabled(comm) {
                return Err(abort::DEVICE_STATE);
            }
            let mappable: &[ObjectAddr] = if comm == 0x1400 { &RPDO_MAPPABLE } else { &TPDO_MAPPABLE };
            if a.sub == 0 {
                if x > 4 {
                    return Err(abort::VALUE_TOO_HIGH);
                }
                let bits: u32 = (1..=x as u8).map(|s| self.od.get(ObjectAddr::new(map, s)) & 0xFF).sum();
                if bits > 64 {
                    return Err(abort::PDO_LENGTH);
                }
            } else {
                if self.od.get(ObjectAddr::new(map, 0)) != 0 {
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
        if PDOS.iter().any(|(c, _)| *c == a.index) && a.sub == 2 && !(x <= 240 || x >= 254) {
            return Err(abort::INVALID_VALUE);
        }
        match a {
            obj::MODES_OF_OPERATION if x as u8 as i8 != pdo::MODE_PROFILE_VELOCITY => {
                return Err(abort::INVALID_VALUE);
            }
            obj::PROFILE_ACCELERATION | obj::PROFILE_DECELERATION | obj::QUICK_STOP_DECELERATION if x == 0 => {
                return Err(abort::VALUE_TOO_LOW);
            }
            _ => {}
        }
        self.od.set_live(a, x);
        if a == obj::PRODUCER_HEARTBEAT {
            self.next_heartbeat = now;
        }
        if a == obj::CONTROLWORD {
            self.machine.on_controlword(x as u16);
        }
        Ok(())
    }

    /// Advances timers; appends the frames due to `out`.
    #[allow(clippy::too_many_arguments)]
    pub fn step(
        &mut self,
        now: Timestamp,
        scaling: &Scaling,
        pos_rad: f64,
        vel_radps: f64,
        watchdog: Duration,
        mute_heartbeat: bool,
        mute_feedback: bool,
        out: &mut Vec<CanFrame>,
    ) -> Option<&'static str> {
        let mut tripped = None;
        self.machine.tick(vel_radps.abs() < 1e-3);
        // Heartbeat consumer: monitoring starts with the first heartbeat (CiA 301).
        let consumer = self.od.get(obj::CONSUMER_HEARTBEAT_1);
        let consumer_ms = u64::from(consumer & 0xFFFF);
        if consumer_ms > 0 && self.machine.state != DriveState::Fault {
            if let Some(t) = self.last_bridge_heartbeat {
                if now - t > Duration::from_millis(consumer_ms) {
                    self.last_bridge_heartbeat = None;
                    if self.machine.state.powered() || self.machine.state == DriveState::SwitchedOn {
                        self.fault(ERROR_HEARTBEAT as u16);
                        tripped = Some("heartbeat consumer");
                    }
                }
            }
        }
        // The command watchdog: RPDOs must keep coming while enabled.
        if self.machine.state == DriveState::OperationEnabled && self.last_rpdo.is_none_or(|t| now - t > watchdog) {
            self.fault(ERROR_RPDO_TIMEOUT as u16);
            tripped = Some("RPDO watchdog");
        }
        self.live_values(scaling, pos_rad, vel_radps);
        // The outbox (SDO answers, EMCY, boot-up, SYNC TPDOs) goes first.
        for f in self.outbox.drain(..) {
            let is_hb = f.id == nmt::COB_HEARTBEAT_BASE + u32::from(self.id);
            let is_pdo = f.id & !0x7F == pdo::COB_TPDO1_BASE || f.id & !0x7F == pdo::COB_TPDO2_BASE;
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
            for k in 0..2 {
                let (comm, map) = PDOS[1 + k];
                let kind = self.od.get(ObjectAddr::new(comm, 2));
                if !self.pdo_enabled(comm) || kind <= 240 {
                    continue;
                }
                let event_ms = self.od.get(ObjectAddr::new(comm, 5));
                let timer_due = event_ms > 0 && now >= self.next_event[k];
                let cos = self.mapping(map).iter().any(|(a, _)| *a == obj::STATUSWORD)
                    && self.last_status_sent != Some(self.od.get(obj::STATUSWORD) as u16);
                if timer_due {
                    self.next_event[k] = super::next_grid(self.next_event[k], now, 1000.0 / f64::from(event_ms));
                }
                if timer_due || cos {
                    self.send_tpdo(k);
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
            for k in 0..2 {
                let comm = PDOS[1 + k].0;
                if self.od.get(ObjectAddr::new(comm, 2)) > 240 && self.od.get(ObjectAddr::new(comm, 5)) > 0 {
                    t = t.min(self.next_event[k]);
                }
            }
        }
        t
    }
}
