//! The `cia402:` section: CANopen CiA 402 node ids, units and timings, the
//! protocol settings they give, and their rules (several involve `timing:`
//! and `limits:` keys, and each names the key to change).

use super::BridgeConfig;
use crate::protocol::cia402::axis::{AxisLayout, MAX_AXES};
use crate::protocol::cia402::pdo::PdoPlan;
use crate::protocol::cia402::units::{Scaling, VelocityUnit};
use crate::protocol::cia402::{Cia402Settings, PdoMapping};
use crate::protocol::ProtocolKind;
use oldbf::config::{Checker, Interval};
use serde::{Deserialize, Serialize};

/// CANopen CiA 402 settings (`can_bridge/README.md`, "CANopen CiA 402").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Cia402Config {
    /// The left wheel's drive (CANopen node id).
    pub left_node_id: u32,
    /// The left wheel's axis on its node: 1 (the standard objects) or 2 (at `axis_offset`).
    pub left_axis: u32,
    /// The right wheel's drive (CANopen node id); the left one's when one
    /// node carries both axes.
    pub right_node_id: u32,
    /// The right wheel's axis on its node.
    pub right_axis: u32,
    /// Index offset of axis 2's objects from axis 1's (CiA 402, Roboteq: 0x800).
    pub axis_offset: u32,
    /// Encoder counts per motor revolution (0x6064).
    pub counts_per_motor_rev: u32,
    /// Unit of 0x60FF / 0x606C.
    pub velocity_unit: VelocityUnit,
    /// One velocity LSB in that unit.
    pub velocity_resolution: f64,
    /// 0x6083 at the motor (rad/s²).
    pub profile_accel_radps2: f64,
    /// 0x6084 at the motor (rad/s²).
    pub profile_decel_radps2: f64,
    /// 0x6085 at the motor (rad/s²).
    pub quick_stop_decel_radps2: f64,
    /// Write the PDO mapping at start-up, or trust the drive's.
    pub pdo_mapping: PdoMapping,
    /// The bridge sends SYNC after each period's RPDOs.
    pub sync_producer: bool,
    /// Without SYNC: the drives' TPDO event timer (ms).
    pub tpdo_event_ms: u32,
    /// Written to each drive's 0x1017 (ms); 0 = not written.
    pub drive_heartbeat_ms: u32,
    /// The bridge's node id (its heartbeat COB-ID 0x700 + id).
    pub bridge_node_id: u32,
    /// The bridge's heartbeat period (ms); 0 = none.
    pub bridge_heartbeat_ms: u32,
    /// Written to each drive's 0x1016:01 (ms); 0 = not written.
    pub drive_consumer_heartbeat_ms: u32,
    /// An SDO response later than this fails the start-up (s).
    pub sdo_timeout_s: f64,
}

/// CANopen node ids (CiA 301: 1–127).
const NODE_ID: Interval = Interval::closed(1.0, 127.0);
/// A u16 time in ms, 0 allowed (0 = off).
const MS_U16: Interval = Interval::closed(0.0, 65535.0).unit("ms");

impl Cia402Config {
    /// Conversions for these units.
    pub fn scaling(&self) -> Scaling {
        Scaling::new(self.velocity_unit, self.velocity_resolution, self.counts_per_motor_rev)
    }

    /// The protocol's settings (`validate` first: out-of-range values saturate).
    pub fn settings(&self) -> Cia402Settings {
        let sc = self.scaling();
        let u16_of = |v: u32| u16::try_from(v).unwrap_or(u16::MAX);
        let u8_of = |v: u32| u8::try_from(v).unwrap_or(u8::MAX);
        let offset = u16_of(self.axis_offset);
        Cia402Settings {
            nodes: [u8_of(self.left_node_id), u8_of(self.right_node_id)],
            axes: [
                AxisLayout::new(u8_of(self.left_axis), offset),
                AxisLayout::new(u8_of(self.right_axis), offset),
            ],
            scaling: sc,
            profile_accel: sc.accel_to_drive(self.profile_accel_radps2).unwrap_or(1),
            profile_decel: sc.accel_to_drive(self.profile_decel_radps2).unwrap_or(1),
            quick_stop_decel: sc.accel_to_drive(self.quick_stop_decel_radps2).unwrap_or(1),
            mapping: self.pdo_mapping,
            plan: PdoPlan {
                sync: self.sync_producer,
                tpdo_event_ms: u16_of(self.tpdo_event_ms),
            },
            drive_heartbeat_ms: u16_of(self.drive_heartbeat_ms),
            bridge_node_id: u8_of(self.bridge_node_id),
            bridge_heartbeat_ms: u16_of(self.bridge_heartbeat_ms),
            drive_consumer_heartbeat_ms: u16_of(self.drive_consumer_heartbeat_ms),
            sdo_timeout: crate::time::saturating_duration(self.sdo_timeout_s),
        }
    }
}

/// The `cia402:` rules, in `cfg` (they read `timing:`, `limits:` and
/// `kinematics:` too).
pub(super) fn check_cia402(cfg: &BridgeConfig, c: &mut Checker) {
    let p = &cfg.cia402;
    let f = |v: u32| f64::from(v);
    c.range("cia402.left_node_id", p.left_node_id, NODE_ID);
    c.range("cia402.right_node_id", p.right_node_id, NODE_ID);
    let axes = Interval::closed(1.0, f64::from(MAX_AXES));
    c.range("cia402.left_axis", p.left_axis, axes);
    c.range("cia402.right_axis", p.right_axis, axes);
    c.rule(
        (p.left_node_id, p.left_axis) != (p.right_node_id, p.right_axis),
        "cia402.right_node_id",
        p.right_node_id,
        "different from cia402.left_node_id, or the same node with another cia402.right_axis",
    );
    // Axis 2's objects stay in the device profile area (0x60FF + offset ≤ 0x9FFF)
    // and clear of axis 1's (0x6000–0x60FF used here).
    c.range(
        "cia402.axis_offset",
        p.axis_offset,
        Interval::closed(f64::from(0x100u32), f64::from(0x3F00u32)),
    );
    c.range(
        "cia402.counts_per_motor_rev",
        p.counts_per_motor_rev,
        Interval::closed(1.0, 16_777_216.0),
    );
    c.range(
        "cia402.velocity_resolution",
        p.velocity_resolution,
        Interval::open_closed(0.0, 1000.0),
    );
    let sc = p.scaling();
    if cfg.protocol == ProtocolKind::Cia402 && sc.units_per_radps().is_finite() {
        let max = cfg.limits.max_wheel_speed_radps * cfg.kinematics.gear_ratio * sc.units_per_radps();
        c.rule(
            max.is_nan() || max <= f64::from(i32::MAX),
            "limits.max_wheel_speed_radps",
            cfg.limits.max_wheel_speed_radps,
            "times kinematics.gear_ratio, in drive velocity units, within the i32 of 0x60FF",
        );
    }
    for (key, v) in [
        ("cia402.profile_accel_radps2", p.profile_accel_radps2),
        ("cia402.profile_decel_radps2", p.profile_decel_radps2),
        ("cia402.quick_stop_decel_radps2", p.quick_stop_decel_radps2),
    ] {
        if c.range(key, v, Interval::open_closed(0.0, 1e6).unit("rad/s²")) {
            c.rule(
                sc.accel_to_drive(v).is_some(),
                key,
                v,
                "at least one drive acceleration unit, and within the u32 of 0x6083-0x6085",
            );
        }
    }
    c.range(
        "cia402.tpdo_event_ms",
        p.tpdo_event_ms,
        Interval::closed(1.0, 65535.0).unit("ms"),
    );
    let fb_ms = cfg.timing.feedback_timeout_s * 1000.0;
    c.rule(
        p.sync_producer || fb_ms.is_nan() || f(p.tpdo_event_ms) < fb_ms,
        "cia402.tpdo_event_ms",
        p.tpdo_event_ms,
        "below timing.feedback_timeout_s (without SYNC the feedback comes at this period)",
    );
    c.range("cia402.drive_heartbeat_ms", p.drive_heartbeat_ms, MS_U16);
    let hb_ms = cfg.timing.heartbeat_timeout_s * 1000.0;
    c.rule(
        hb_ms.is_nan() || f(p.drive_heartbeat_ms) <= hb_ms / 2.0,
        "cia402.drive_heartbeat_ms",
        p.drive_heartbeat_ms,
        "at most half of timing.heartbeat_timeout_s",
    );
    c.range("cia402.bridge_node_id", p.bridge_node_id, NODE_ID);
    c.rule(
        p.bridge_node_id != p.left_node_id && p.bridge_node_id != p.right_node_id,
        "cia402.bridge_node_id",
        p.bridge_node_id,
        "different from both drives' node ids",
    );
    c.range("cia402.bridge_heartbeat_ms", p.bridge_heartbeat_ms, MS_U16);
    c.range(
        "cia402.drive_consumer_heartbeat_ms",
        p.drive_consumer_heartbeat_ms,
        MS_U16,
    );
    c.rule(
        p.drive_consumer_heartbeat_ms == 0
            || (p.bridge_heartbeat_ms > 0 && p.drive_consumer_heartbeat_ms > p.bridge_heartbeat_ms),
        "cia402.drive_consumer_heartbeat_ms",
        p.drive_consumer_heartbeat_ms,
        "0, or longer than a non-zero cia402.bridge_heartbeat_ms",
    );
    c.range(
        "cia402.sdo_timeout_s",
        p.sdo_timeout_s,
        Interval::open_closed(0.0, 10.0).unit("s"),
    );
    c.rule(
        p.sdo_timeout_s.is_nan()
            || cfg.timing.startup_timeout_s.is_nan()
            || p.sdo_timeout_s < cfg.timing.startup_timeout_s,
        "cia402.sdo_timeout_s",
        p.sdo_timeout_s,
        "shorter than timing.startup_timeout_s",
    );
}
