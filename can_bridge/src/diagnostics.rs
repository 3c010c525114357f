//! What the bridge reports: its state, why it is not moving, one-shot
//! events, and counters. All serializable, so adapters (the CLI's JSON
//! lines, later the ROS node's diagnostics) print them unchanged.

use crate::kinematics::{MotorSpeeds, Twist, Wheel, WheelSpeeds};
use crate::odometry::OdometryState;
use serde::Serialize;

/// The bridge's overall state.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum BridgeState {
    /// Following a fresh command.
    Running,
    /// Healthy and ready, but no fresh command: zero setpoints.
    Idle,
    /// Waiting for the drive to appear or to finish its start-up.
    Starting,
    /// A fault stops the robot (drive, feedback, heartbeat, bus): zero setpoints.
    Stopped,
    /// E-stop latched: e-stop setpoints until reset and a fresh command.
    Estop,
}

/// Why the setpoints are zero. Several can hold at once.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(tag = "reason", rename_all = "snake_case")]
pub enum StopReason {
    /// E-stop latched; needs `reset` and a fresh command.
    Estop,
    /// The drive reported an error (or its own e-stop); latched until `reset`.
    DriveFault {
        wheel: Wheel,
        error_code: u32,
        drive_estopped: bool,
    },
    /// A bus error (error frame or failed send/receive) until the bus is back.
    BusError { description: String },
    /// Frames could not be queued (ENOBUFS) for more than two tx periods.
    TxBlocked,
    /// No fresh heartbeat/status from this wheel's drive.
    NoHeartbeat { wheel: Wheel, ever_seen: bool },
    /// This wheel's drive went silent on a working bus; latched until
    /// `reset` (a drive that vanished is not trusted to be the same after).
    HeartbeatLost { wheel: Wheel },
    /// Start-up sequence sent, waiting for the drive to report running.
    DriveStarting,
    /// No fresh wheel feedback from this wheel.
    FeedbackLost { wheel: Wheel },
    /// The last command was rejected (NaN or infinite).
    InvalidCommand,
    /// No command received yet.
    NoCommand,
    /// The last command is older than cmd_timeout_s.
    CommandTimeout,
    /// The last command predates the last stop; a new one is needed.
    AwaitingFreshCommand,
}

impl StopReason {
    /// Reasons about the command alone (the robot is otherwise healthy).
    pub fn is_command_reason(&self) -> bool {
        matches!(
            self,
            StopReason::InvalidCommand
                | StopReason::NoCommand
                | StopReason::CommandTimeout
                | StopReason::AwaitingFreshCommand
        )
    }

    /// Reasons that are part of a normal start.
    pub fn is_startup_reason(&self) -> bool {
        matches!(
            self,
            StopReason::DriveStarting | StopReason::NoHeartbeat { ever_seen: false, .. }
        )
    }

    /// A short snake_case name.
    pub fn name(&self) -> &'static str {
        match self {
            StopReason::Estop => "estop",
            StopReason::DriveFault { .. } => "drive_fault",
            StopReason::BusError { .. } => "bus_error",
            StopReason::TxBlocked => "tx_blocked",
            StopReason::NoHeartbeat { .. } => "no_heartbeat",
            StopReason::HeartbeatLost { .. } => "heartbeat_lost",
            StopReason::DriveStarting => "drive_starting",
            StopReason::FeedbackLost { .. } => "feedback_lost",
            StopReason::InvalidCommand => "invalid_command",
            StopReason::NoCommand => "no_command",
            StopReason::CommandTimeout => "command_timeout",
            StopReason::AwaitingFreshCommand => "awaiting_fresh_command",
        }
    }
}

/// One-shot happenings, in order.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum BridgeEvent {
    /// The state or the set of reasons changed.
    StateChanged {
        state: BridgeState,
        reasons: Vec<StopReason>,
    },
    /// A command with a NaN or infinite component; the bridge now sends zero.
    CommandRejected {
        linear_mps: f64,
        angular_radps: f64,
    },
    /// Commands started being clamped to v_max/ω_max (reported once per episode).
    CommandClamped {
        requested: Twist,
        clamped: Twist,
    },
    EstopLatched,
    /// E-stop and drive faults cleared by an explicit reset.
    Reset,
    /// The start-up sequence was queued.
    StartupSent,
    /// The drive reports running: ready for commands.
    DriveReady,
    /// The drive did not report running within startup_timeout_s; retrying.
    StartupTimeout,
    /// A drive error was latched.
    DriveFaultLatched {
        wheel: Wheel,
        error_code: u32,
        drive_estopped: bool,
    },
    /// A drive's heartbeat timed out on a working bus: latched until reset.
    HeartbeatLostLatched {
        wheel: Wheel,
    },
    /// The drive left the running state without an error; restarting it.
    DriveStoppedRunning {
        wheel: Wheel,
    },
    /// An error frame or a bus I/O error.
    BusError {
        description: String,
        fatal: bool,
    },
    /// The bus is back (after bus_recovery_s of quiet).
    BusRecovered,
    /// The kernel transmit queue was full (start of an episode).
    TxQueueFull,
    /// Frames dropped: stale setpoints replaced by fresh ones, or frames
    /// that failed `attempts` times.
    TxDropped {
        stale: u32,
        after_retries: u32,
    },
    /// A frame from a drive id that failed to decode (length, CRC, NaN, frozen counter).
    RxInvalid {
        error: String,
    },
    /// Odometry re-baselined after an implausible position jump.
    OdometryReset,
    /// The protocol reports something about a drive (CiA 402: an SDO abort
    /// or timeout at start-up, an EMCY, a fault, a reboot).
    DriveReport {
        wheel: Option<Wheel>,
        message: String,
    },
    /// A run-time SDO request ended (read or written, or aborted: the code decoded).
    SdoDone {
        id: u64,
        node: u8,
        index: u16,
        sub: u8,
        write: bool,
        ok: bool,
        abort_code: u32,
        message: String,
    },
    /// A run-time SDO request the bridge refused; nothing was sent.
    SdoRefused {
        node: u8,
        index: u16,
        sub: u8,
        write: bool,
        reason: String,
    },
}

/// An event with its time (s on the bridge's clock).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TimedEvent {
    pub t_s: f64,
    #[serde(flatten)]
    pub event: BridgeEvent,
}

/// Monotonic counters since start.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Counters {
    pub commands: u64,
    pub commands_rejected: u64,
    pub commands_clamped: u64,
    pub tx_periods: u64,
    pub tx_frames: u64,
    pub tx_queue_full: u64,
    pub tx_dropped_stale: u64,
    pub tx_dropped_after_retries: u64,
    pub tx_errors: u64,
    pub rx_frames: u64,
    pub rx_ignored: u64,
    pub rx_invalid: u64,
    pub error_frames: u64,
    pub events_dropped: u64,
}

/// What the bridge last heard from one wheel's drive.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct DriveLinkStatus {
    /// Age of the last heartbeat/status (s), `None` if never received.
    pub heartbeat_age_s: Option<f64>,
    /// Age of the last wheel feedback (s).
    pub feedback_age_s: Option<f64>,
    pub error_code: u32,
    pub running: bool,
    pub raw_state: u8,
}

/// A snapshot for reports.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BridgeStatus {
    pub t_s: f64,
    pub state: BridgeState,
    pub reasons: Vec<StopReason>,
    /// The last accepted command, after the v/ω clamp.
    pub command: Option<Twist>,
    /// The last transmitted setpoint at the wheels (rad/s).
    pub setpoint_wheels: WheelSpeeds,
    /// The same at the motors (rad/s), as encoded.
    pub setpoint_motors: MotorSpeeds,
    pub odometry: OdometryState,
    pub left: DriveLinkStatus,
    pub right: DriveLinkStatus,
    pub counters: Counters,
}
