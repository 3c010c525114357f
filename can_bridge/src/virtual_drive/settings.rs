//! What the virtual drive simulates: protocol, ids, axis dynamics, rates,
//! watchdog and scheduled faults, and their allowed values.

use super::FaultSpec;
use crate::protocol::cia402::units::{Scaling, VelocityUnit};
use crate::protocol::generic;
use crate::protocol::odrive::{self, Firmware};
use crate::protocol::ProtocolKind;
use oldbf::config::{Checker, Interval, Validate};

/// Where the scheduled faults' times are counted from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum FaultClock {
    /// The drive's power-up.
    #[default]
    Start,
    /// The first moment both wheels run (generic: enabled; ODrive: closed
    /// loop; CiA 402: Operation Enabled), so a schedule means the same on a
    /// machine where the bridge takes seconds to bring the drive up. No
    /// scheduled fault fires before it.
    Running,
}

/// How the simulated drive behaves.
#[derive(Clone, Debug, PartialEq)]
pub struct VirtualDriveConfig {
    /// The protocol it speaks.
    pub protocol: ProtocolKind,
    /// Generic: base id.
    pub generic_base_id: u32,
    /// ODrive / CiA 402: the left axis's node id.
    pub left_node_id: u32,
    /// ODrive / CiA 402: the right axis's node id.
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
    /// Scheduled faults (times from `faults_from`).
    pub faults: Vec<FaultSpec>,
    /// Where the fault schedule's clock starts.
    pub faults_from: FaultClock,
    /// CiA 402: the units of the drive's velocity and position objects.
    pub cia402_scaling: Scaling,
    /// CiA 402: the bridge's node id (whose heartbeat 0x1016:01 may watch).
    pub cia402_bridge_node_id: u8,
    /// CiA 402: the left wheel's axis on its node (1, or 2 at `cia402_axis_offset`).
    pub left_axis: u8,
    /// CiA 402: the right wheel's axis on its node; with the left one's node
    /// id, one node carries both axes.
    pub right_axis: u8,
    /// CiA 402: the index offset of axis 2's objects.
    pub cia402_axis_offset: u16,
    /// ODrive: the firmware generation it plays (heartbeat layout, error
    /// numbering; 0.6 also sends Get_Error with every heartbeat).
    pub odrive_firmware: Firmware,
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
            faults_from: FaultClock::Start,
            cia402_scaling: Scaling::new(VelocityUnit::Rpm, 1.0, 4096),
            cia402_bridge_node_id: 127,
            left_axis: 1,
            right_axis: 1,
            cia402_axis_offset: crate::protocol::cia402::axis::STANDARD_AXIS_OFFSET,
            odrive_firmware: Firmware::V0_5,
        }
    }
}

/// A positive finite speed or acceleration.
const POSITIVE: Interval = Interval::open(0.0, f64::INFINITY);
/// Bounded as well as positive: a period of 1 / 1e-300 s or a watchdog of
/// 1e300 s cannot be a std Duration.
const RATE_HZ: Interval = Interval::closed(0.01, 10_000.0).unit("Hz");

impl Validate for VirtualDriveConfig {
    /// Rates, limits and ids; keys are the field names (the flags without `--`).
    fn check(&self, c: &mut Checker) {
        c.range("max_speed_radps", self.max_speed_radps, POSITIVE.unit("rad/s"));
        c.range("max_accel_radps2", self.max_accel_radps2, POSITIVE.unit("rad/s²"));
        c.range("watchdog_s", self.watchdog_s, Interval::closed(1e-3, 3600.0).unit("s"));
        c.range("heartbeat_rate_hz", self.heartbeat_rate_hz, RATE_HZ);
        c.range("feedback_rate_hz", self.feedback_rate_hz, RATE_HZ);
        c.range(
            "time_constant_s",
            self.time_constant_s,
            Interval::closed_open(0.0, f64::INFINITY).unit("s"),
        );
        c.rule(
            self.generic_base_id <= generic::MAX_BASE_ID,
            "generic_base_id",
            format_args!("0x{:X}", self.generic_base_id),
            "[0, 0x7ED]",
        );
        let node_ids = if self.protocol == ProtocolKind::Cia402 {
            c.range("cia402_bridge_node_id", self.cia402_bridge_node_id, CANOPEN_NODE_ID);
            CANOPEN_NODE_ID
        } else {
            Interval::closed(0.0, odrive::MAX_NODE_ID as f64)
        };
        c.range("left_node_id", self.left_node_id, node_ids);
        c.range("right_node_id", self.right_node_id, node_ids);
        // One CANopen node may carry both wheels on two axes; an ODrive node is one axis.
        let two_axes = self.protocol == ProtocolKind::Cia402 && self.left_axis != self.right_axis;
        c.rule(
            self.left_node_id != self.right_node_id || two_axes,
            "right_node_id",
            self.right_node_id,
            "different from left_node_id (cia402: or on another axis)",
        );
        if self.protocol == ProtocolKind::Cia402 {
            let axes = Interval::closed(1.0, 2.0);
            c.range("left_axis", self.left_axis, axes);
            c.range("right_axis", self.right_axis, axes);
            c.range(
                "cia402_axis_offset",
                self.cia402_axis_offset,
                Interval::closed(256.0, 16128.0),
            );
        }
    }
}

/// CANopen node ids.
const CANOPEN_NODE_ID: Interval = Interval::closed(1.0, 127.0);
