//! The bridge's configuration (`config/can_bridge.yaml`), parsed strictly.
//!
//! Unknown keys, wrong types and missing keys are errors naming the file and
//! the dotted key; then every value is range-checked and the message gives
//! the allowed range, with the checks `oldbf_ros` uses too
//! ([`oldbf::config`]). The shipped file is embedded as the defaults, so the
//! binaries run from any directory.
//!
//! One concept per file: the sections and loading here, the value rules in
//! `checks.rs`, the `cia402:` section (settings and rules) in `cia402.rs`,
//! the `odometry:` noise model in `odometry.rs`, the rules against the base's
//! own limits (`config/base_limits.yaml`) in `base_limits.rs`.

mod base_limits;
mod checks;
mod cia402;
mod odometry;

pub use cia402::Cia402Config;
pub use odometry::OdometryConfig;
pub use oldbf::config::{ConfigError, ParamError, Validate};

use crate::kinematics::DiffDrive;
use crate::protocol::cia402::Cia402Protocol;
use crate::protocol::generic::GenericProtocol;
use crate::protocol::odrive::{Firmware, OdriveProtocol};
use crate::protocol::{Protocol, ProtocolKind};
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::time::Duration;

/// The shipped configuration.
pub const DEFAULT_CONFIG_YAML: &str = include_str!("../../../config/can_bridge.yaml");
/// How the embedded defaults are named in messages.
pub const DEFAULT_CONFIG_NAME: &str = "config/can_bridge.yaml (built-in)";

/// Everything the bridge needs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BridgeConfig {
    /// SocketCAN interface name.
    pub interface: String,
    /// Drive protocol.
    pub protocol: ProtocolKind,
    /// Rates and timeouts.
    pub timing: TimingConfig,
    /// Wheel geometry and gearing.
    pub kinematics: KinematicsConfig,
    /// Limits on commands and wheel speeds.
    pub limits: LimitsConfig,
    /// Generic protocol ids.
    pub generic: GenericConfig,
    /// ODrive CANSimple node ids.
    pub odrive: OdriveConfig,
    /// CANopen CiA 402 node ids, units and timings.
    pub cia402: Cia402Config,
    /// The wheels' measurement noise (odometry covariance).
    pub odometry: OdometryConfig,
}

/// Rates and timeouts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimingConfig {
    /// Setpoint transmission rate (Hz).
    pub tx_rate_hz: f64,
    /// Commands older than this give zero setpoints (s).
    pub cmd_timeout_s: f64,
    /// Wheel feedback older than this stops the robot (s).
    pub feedback_timeout_s: f64,
    /// Heartbeat/status older than this stops the robot (s).
    pub heartbeat_timeout_s: f64,
    /// Time the drive gets to report running after the start-up sequence (s).
    pub startup_timeout_s: f64,
    /// Quiet time after a bus error before motion may resume (s).
    pub bus_recovery_s: f64,
}

/// Differential-drive geometry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KinematicsConfig {
    /// Distance between the wheels' contact points (m).
    pub wheel_separation_m: f64,
    /// Wheel radius (m).
    pub wheel_radius_m: f64,
    /// Motor turns per wheel turn.
    pub gear_ratio: f64,
    /// +1 or −1.
    pub left_direction: i32,
    /// +1 or −1.
    pub right_direction: i32,
}

/// Limits enforced on every command.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LimitsConfig {
    /// Largest forward speed followed (m/s); beyond it v and ω scale down together.
    pub v_max_mps: f64,
    /// Largest yaw rate followed (rad/s); beyond it v and ω scale down together.
    pub omega_max_radps: f64,
    /// At the wheel (rad/s).
    pub max_wheel_speed_radps: f64,
    /// At the wheel (rad/s²).
    pub wheel_accel_radps2: f64,
    /// At the wheel (rad/s²).
    pub wheel_decel_radps2: f64,
}

/// Generic protocol settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GenericConfig {
    /// Every frame's id is this plus its offset (standard 11-bit ids).
    pub base_id: u32,
}

/// ODrive settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OdriveConfig {
    /// The left wheel's axis (CANSimple node id).
    pub left_node_id: u32,
    /// The right wheel's axis (CANSimple node id).
    pub right_node_id: u32,
    /// Torque feed-forward sent while moving (Nm).
    pub torque_ff_nm: f64,
    /// The drives' firmware generation: message layouts and error numbering.
    pub firmware: Firmware,
}

impl BridgeConfig {
    /// The kinematics these values describe.
    pub fn diff_drive(&self) -> DiffDrive {
        let k = &self.kinematics;
        DiffDrive {
            wheel_separation_m: k.wheel_separation_m,
            wheel_radius_m: k.wheel_radius_m,
            gear_ratio: k.gear_ratio,
            left_direction: f64::from(k.left_direction.signum()),
            right_direction: f64::from(k.right_direction.signum()),
        }
    }

    /// 1 / tx_rate_hz.
    pub fn tx_period(&self) -> Duration {
        Duration::from_secs_f64(1.0 / self.timing.tx_rate_hz)
    }

    /// The selected protocol's bridge side.
    pub fn make_protocol(&self) -> Box<dyn Protocol> {
        match self.protocol {
            ProtocolKind::Generic => Box::new(GenericProtocol::new(self.generic.base_id)),
            ProtocolKind::Odrive => Box::new(
                OdriveProtocol::new(
                    self.odrive.left_node_id,
                    self.odrive.right_node_id,
                    self.odrive.torque_ff_nm,
                )
                .with_firmware(self.odrive.firmware),
            ),
            ProtocolKind::Cia402 => Box::new(Cia402Protocol::new(self.cia402.settings())),
        }
    }
}

/// Validated configuration from YAML text; `file` names it in messages.
pub fn load_config_str(text: &str, file: &str) -> Result<BridgeConfig, ConfigError> {
    oldbf::config::load_str(text, file)
}

/// Validated configuration from a file.
pub fn load_config_file(path: &Path) -> Result<BridgeConfig, ConfigError> {
    oldbf::config::load_file(path)
}

/// The shipped defaults.
pub fn default_config() -> BridgeConfig {
    load_config_str(DEFAULT_CONFIG_YAML, DEFAULT_CONFIG_NAME)
        .expect("the shipped config/can_bridge.yaml is valid (tested)")
}

#[cfg(test)]
mod tests;
