//! Drive protocols: how setpoints become frames and frames become drive state.
//!
//! A [`Protocol`] is the bridge's side of one drive protocol. It knows the
//! frame layouts and the drive's start-up, e-stop and shutdown sequences,
//! and decodes what the drive sends into protocol-neutral
//! [`DriveMessage`]s. It holds no timing or safety policy: that is
//! [`crate::bridge::Bridge`]'s job. The same modules also hold the drive's
//! side of each layout, used by [`crate::virtual_drive`].

pub mod cia402;
pub mod generic;
pub mod odrive;

use crate::bus::{CanFrame, RxFilter};
use crate::kinematics::{MotorSpeeds, Wheel};
use crate::time::Timestamp;
use cia402::sdo_jobs::{SdoJob, SdoJobId, SdoJobResult, SdoRefusal};
use serde::{Deserialize, Serialize};

/// Which protocol a configuration selects.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ProtocolKind {
    /// Our own layout (`can_bridge/dbc/oldbf_generic.dbc`).
    Generic,
    /// ODrive CANSimple, one node per wheel.
    Odrive,
    /// CANopen CiA 402 (profile velocity), one node per wheel.
    Cia402,
}

impl ProtocolKind {
    /// `generic`, `odrive` or `cia402`.
    pub fn name(self) -> &'static str {
        match self {
            ProtocolKind::Generic => "generic",
            ProtocolKind::Odrive => "odrive",
            ProtocolKind::Cia402 => "cia402",
        }
    }
}

/// A protocol name that is none of ours.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown protocol `{0}`; allowed: generic, odrive, cia402")]
pub struct UnknownProtocol(pub String);

impl std::str::FromStr for ProtocolKind {
    type Err = UnknownProtocol;
    fn from_str(s: &str) -> Result<Self, UnknownProtocol> {
        match s {
            "generic" => Ok(ProtocolKind::Generic),
            "odrive" => Ok(ProtocolKind::Odrive),
            "cia402" => Ok(ProtocolKind::Cia402),
            _ => Err(UnknownProtocol(s.to_string())),
        }
    }
}

/// The most frames one call produces (ODrive start-up: 4 per node; CiA 402
/// poll: a heartbeat and, per node, an SDO abort and the next request).
pub const FRAME_BATCH_CAPACITY: usize = 8;

/// A fixed-capacity list of frames (no allocation per period).
#[derive(Clone, Copy, Debug)]
pub struct FrameBatch {
    frames: [CanFrame; FRAME_BATCH_CAPACITY],
    len: usize,
}

impl Default for FrameBatch {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameBatch {
    /// Empty.
    pub fn new() -> Self {
        const EMPTY: CanFrame = CanFrame {
            id: 0,
            extended: false,
            data: [0; 8],
            len: 0,
        };
        Self {
            frames: [EMPTY; FRAME_BATCH_CAPACITY],
            len: 0,
        }
    }

    /// Appends a frame. Protocols never produce more than the capacity; a
    /// bug that tries is caught by tests (debug assertion) and the frame is
    /// dropped rather than panicking in a release build.
    pub fn push(&mut self, f: CanFrame) {
        debug_assert!(self.len < FRAME_BATCH_CAPACITY, "FrameBatch overflow");
        if self.len < FRAME_BATCH_CAPACITY {
            self.frames[self.len] = f;
            self.len += 1;
        }
    }

    /// The frames, in order.
    pub fn as_slice(&self) -> &[CanFrame] {
        &self.frames[..self.len]
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.len
    }

    /// No frames.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Removes every frame.
    pub fn clear(&mut self) {
        self.len = 0;
    }
}

/// What the setpoint frames of one period ask of the drive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SetpointMode {
    /// Follow the given motor speeds.
    Run,
    /// Stay enabled, at zero speed (stops caused by the command: none, timed
    /// out, awaiting a fresh one; and faults where the drive may still listen).
    Hold,
    /// E-stop asserted (latched in the bridge).
    Estop,
}

/// Which wheels a status message speaks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wheels {
    One(Wheel),
    /// One drive controls both (generic protocol).
    Both,
}

impl Wheels {
    /// Whether `w` is covered.
    pub fn covers(self, w: Wheel) -> bool {
        match self {
            Wheels::One(x) => x == w,
            Wheels::Both => true,
        }
    }
}

/// One wheel's drive state in a status that covers several wheels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AxisStatus {
    /// Drive error bits; 0 = none.
    pub error_code: u32,
    /// The axis follows velocity setpoints.
    pub running: bool,
    /// The axis itself is in e-stop (CiA 402 quick stop active).
    pub estopped: bool,
    /// The raw state value, for reports.
    pub raw_state: u8,
}

/// A decoded message from the drive, protocol-neutral.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DriveMessage {
    /// Heartbeat / status.
    Status {
        wheels: Wheels,
        /// Drive error bits; 0 = none (ODrive Axis_Error, generic Error_Code).
        error_code: u32,
        /// The drive follows velocity setpoints (ODrive CLOSED_LOOP_CONTROL,
        /// generic ENABLED).
        running: bool,
        /// The drive itself is in e-stop (generic state ESTOP).
        estopped: bool,
        /// The raw state value, for reports.
        raw_state: u8,
    },
    /// The same as `Status`, without being a sign of life: the drive's state
    /// at once (CiA 402 TPDO1), while only heartbeats prove the link.
    State {
        wheels: Wheels,
        error_code: u32,
        running: bool,
        estopped: bool,
        raw_state: u8,
    },
    /// A heartbeat of a node that drives several wheels (a CiA 402 node
    /// with two axes): a sign of life for each wheel present, with its own
    /// state (by wheel index: left, right).
    Heartbeat { axes: [Option<AxisStatus>; 2] },
    /// A frame the protocol consumed itself (an SDO response, an EMCY):
    /// traffic from the drive, nothing for the bridge's state.
    Handled { wheel: Wheel },
    /// Measured motor position and speed of one wheel.
    Feedback {
        wheel: Wheel,
        /// Motor shaft angle (rad), possibly wrapping: see [`Protocol::position_modulus_rad`].
        motor_pos_rad: f64,
        /// Motor shaft speed (rad/s).
        motor_vel_radps: f64,
    },
}

/// A frame from a drive id that could not be accepted.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    #[error("id 0x{id:X}: {len} data bytes, expected {expected}")]
    Length { id: u32, len: u8, expected: u8 },
    #[error("id 0x{id:X}: checksum 0x{got:02X}, expected 0x{expected:02X}")]
    Checksum { id: u32, got: u8, expected: u8 },
    #[error("id 0x{id:X}: non-finite value")]
    NonFinite { id: u32 },
    #[error("id 0x{id:X}: counter {counter} repeated (frozen sender)")]
    Frozen { id: u32, counter: u8 },
    #[error("id 0x{id:X}: invalid field: {what}")]
    Invalid { id: u32, what: &'static str },
}

/// Something the protocol wants reported (an SDO abort, an EMCY, a drive
/// that rebooted): an event, not a state of its own.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct ProtocolReport {
    pub wheel: Option<Wheel>,
    pub message: String,
}

/// The bridge's side of a drive protocol.
pub trait Protocol: Send {
    /// Which protocol.
    fn kind(&self) -> ProtocolKind;

    /// Exactly the ids the drive(s) send that this protocol decodes; the bus
    /// receives nothing else (error frames aside).
    fn rx_filters(&self) -> Vec<RxFilter>;

    /// Frames that take the drive from any non-error state to following
    /// velocity setpoints, in the order they must be sent.
    fn startup(&mut self, out: &mut FrameBatch);

    /// One period's setpoint frames. `motor` is ignored unless `mode` is
    /// [`SetpointMode::Run`]; a non-finite speed is sent as zero.
    fn setpoints(&mut self, motor: MotorSpeeds, mode: SetpointMode, out: &mut FrameBatch);

    /// Frames that stop the drive for good: zero, then disable.
    fn shutdown(&mut self, out: &mut FrameBatch);

    /// Frames the protocol sends on its own schedule (CiA 402: the SDO
    /// start-up steps, NMT start, the bridge's heartbeat); called on every
    /// tick. Sent in order, as a group.
    fn poll(&mut self, _now: Timestamp, _out: &mut FrameBatch) {}

    /// Moves the pending reports to `out`.
    fn drain_reports(&mut self, _out: &mut Vec<ProtocolReport>) {}

    /// Starts an SDO read or write at run time (CANopen only,
    /// [`cia402::sdo_jobs`]): its id, or why it is refused (nothing sent).
    /// The transfer runs in [`poll`](Self::poll); its end comes out of
    /// [`drain_sdo_results`](Self::drain_sdo_results).
    fn sdo_request(&mut self, _job: SdoJob) -> Result<SdoJobId, SdoRefusal> {
        Err(SdoRefusal::not_canopen(self.kind()))
    }

    /// Moves the finished SDO requests to `out`.
    fn drain_sdo_results(&mut self, _out: &mut Vec<SdoJobResult>) {}

    /// Decodes a received frame: `Ok(None)` if the id is not one of ours.
    fn decode(&mut self, frame: &CanFrame) -> Result<Option<DriveMessage>, DecodeError>;

    /// `Some(m)` if feedback positions wrap modulo `m` radians.
    fn position_modulus_rad(&self) -> Option<f64>;

    /// Whether `error_code` says only that the drive's own command watchdog
    /// expired: the expected result of a communication loss the bridge saw
    /// itself, which the restart after it may clear.
    fn is_watchdog_error(&self, error_code: u32) -> bool;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn batch_keeps_order_and_clears() {
        let mut b = FrameBatch::new();
        assert!(b.is_empty());
        for i in 0..3 {
            b.push(CanFrame::standard(i, &[]).unwrap());
        }
        assert_eq!(b.len(), 3);
        assert_eq!(b.as_slice()[2].id, 2);
        b.clear();
        assert!(b.is_empty());
    }

    #[test]
    fn protocol_names_parse() {
        assert_eq!("odrive".parse::<ProtocolKind>(), Ok(ProtocolKind::Odrive));
        assert_eq!("generic".parse::<ProtocolKind>().unwrap().name(), "generic");
        assert_eq!("cia402".parse::<ProtocolKind>(), Ok(ProtocolKind::Cia402));
        assert!("canopen".parse::<ProtocolKind>().is_err());
    }
}
