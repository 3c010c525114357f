//! The bridge's configuration (`config/can_bridge.yaml`), parsed strictly.
//!
//! Unknown keys, wrong types and missing keys are errors naming the file and
//! the dotted key; then every value is range-checked and the message gives
//! the allowed range, as `oldbf_ros` does for its parameters. The shipped
//! file is embedded as the defaults, so the binaries run from any directory.

use crate::kinematics::DiffDrive;
use crate::protocol::cia402::pdo::PdoPlan;
use crate::protocol::cia402::units::{Scaling, VelocityUnit};
use crate::protocol::cia402::{Cia402Protocol, Cia402Settings, PdoMapping};
use crate::protocol::generic::{GenericProtocol, MAX_BASE_ID, VEL_LIMIT_RADPS};
use crate::protocol::odrive::{OdriveProtocol, MAX_NODE_ID};
use crate::protocol::{Protocol, ProtocolKind};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::Path;
use std::time::Duration;

/// The shipped configuration.
pub const DEFAULT_CONFIG_YAML: &str = include_str!("../../config/can_bridge.yaml");
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
    pub timing: TimingConfig,
    pub kinematics: KinematicsConfig,
    pub limits: LimitsConfig,
    pub generic: GenericConfig,
    pub odrive: OdriveConfig,
    pub cia402: Cia402Config,
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
    pub wheel_separation_m: f64,
    pub wheel_radius_m: f64,
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
    pub v_max_mps: f64,
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
    pub base_id: u32,
}

/// ODrive settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OdriveConfig {
    pub left_node_id: u32,
    pub right_node_id: u32,
    pub torque_ff_nm: f64,
}

/// CANopen CiA 402 settings (`can_bridge/README.md`, "CANopen CiA 402").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Cia402Config {
    pub left_node_id: u32,
    pub right_node_id: u32,
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
        Cia402Settings {
            nodes: [u8_of(self.left_node_id), u8_of(self.right_node_id)],
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
            ProtocolKind::Odrive => Box::new(OdriveProtocol::new(
                self.odrive.left_node_id,
                self.odrive.right_node_id,
                self.odrive.torque_ff_nm,
            )),
            ProtocolKind::Cia402 => Box::new(Cia402Protocol::new(self.cia402.settings())),
        }
    }

    /// Every out-of-range value, each naming its key; empty when valid.
    pub fn validate(&self) -> Result<(), Vec<RangeError>> {
        let mut c = Check { errors: Vec::new() };
        let name = &self.interface;
        c.rule(
            !name.is_empty() && name.len() <= 15 && !name.contains('/') && !name.chars().any(char::is_whitespace),
            "interface",
            format!("{name:?}"),
            "1-15 characters, no '/' or whitespace",
        );
        let t = &self.timing;
        c.range("timing.tx_rate_hz", t.tx_rate_hz, "(0, 1000] Hz");
        c.range("timing.cmd_timeout_s", t.cmd_timeout_s, "(0, 10] s");
        if t.tx_rate_hz.is_finite() && t.tx_rate_hz > 0.0 {
            c.rule(
                t.cmd_timeout_s.is_nan() || t.cmd_timeout_s >= 1.0 / t.tx_rate_hz,
                "timing.cmd_timeout_s",
                format!("{}", t.cmd_timeout_s),
                "at least one tx period, 1/timing.tx_rate_hz",
            );
        }
        c.range("timing.feedback_timeout_s", t.feedback_timeout_s, "(0, 10] s");
        c.range("timing.heartbeat_timeout_s", t.heartbeat_timeout_s, "(0, 10] s");
        c.range("timing.startup_timeout_s", t.startup_timeout_s, "(0, 60] s");
        c.range("timing.bus_recovery_s", t.bus_recovery_s, "[0, 60] s");

        let k = &self.kinematics;
        c.range("kinematics.wheel_separation_m", k.wheel_separation_m, "(0, 10] m");
        c.range("kinematics.wheel_radius_m", k.wheel_radius_m, "(0, 5] m");
        c.range("kinematics.gear_ratio", k.gear_ratio, "(0, 1000]");
        for (key, v) in [
            ("kinematics.left_direction", k.left_direction),
            ("kinematics.right_direction", k.right_direction),
        ] {
            c.rule(v == 1 || v == -1, key, format!("{v}"), "-1 or 1");
        }

        let l = &self.limits;
        c.range("limits.v_max_mps", l.v_max_mps, "(0, 20] m/s");
        c.range("limits.omega_max_radps", l.omega_max_radps, "(0, 50] rad/s");
        c.range(
            "limits.max_wheel_speed_radps",
            l.max_wheel_speed_radps,
            "(0, 2000] rad/s",
        );
        c.range("limits.wheel_accel_radps2", l.wheel_accel_radps2, "(0, 100000] rad/s²");
        c.range("limits.wheel_decel_radps2", l.wheel_decel_radps2, "(0, 100000] rad/s²");
        if self.protocol == ProtocolKind::Generic {
            let motor_max = l.max_wheel_speed_radps * k.gear_ratio;
            c.rule(
                motor_max.is_nan() || motor_max <= VEL_LIMIT_RADPS,
                "limits.max_wheel_speed_radps",
                format!("{}", l.max_wheel_speed_radps),
                "times kinematics.gear_ratio at most 21474.83647 rad/s (the generic Vel_Cmd range)",
            );
        }

        c.rule(
            self.generic.base_id <= MAX_BASE_ID,
            "generic.base_id",
            format!("0x{:X}", self.generic.base_id),
            "[0, 0x7ED] (base + 0x12 must be a standard id)",
        );
        let o = &self.odrive;
        for (key, v) in [
            ("odrive.left_node_id", o.left_node_id),
            ("odrive.right_node_id", o.right_node_id),
        ] {
            c.rule(v <= MAX_NODE_ID, key, format!("{v}"), "[0, 63]");
        }
        c.rule(
            o.left_node_id != o.right_node_id,
            "odrive.right_node_id",
            format!("{}", o.right_node_id),
            "different from odrive.left_node_id",
        );
        c.range("odrive.torque_ff_nm", o.torque_ff_nm, "[-100, 100] Nm");
        self.validate_cia402(&mut c);
        if c.errors.is_empty() {
            Ok(())
        } else {
            Err(c.errors)
        }
    }
}

impl BridgeConfig {
    fn validate_cia402(&self, c: &mut Check) {
        let p = &self.cia402;
        let f = |v: u32| f64::from(v);
        c.range("cia402.left_node_id", f(p.left_node_id), "[1, 127]");
        c.range("cia402.right_node_id", f(p.right_node_id), "[1, 127]");
        c.rule(
            p.left_node_id != p.right_node_id,
            "cia402.right_node_id",
            format!("{}", p.right_node_id),
            "different from cia402.left_node_id",
        );
        c.range(
            "cia402.counts_per_motor_rev",
            f(p.counts_per_motor_rev),
            "[1, 16777216]",
        );
        c.range("cia402.velocity_resolution", p.velocity_resolution, "(0, 1000]");
        let sc = p.scaling();
        if self.protocol == ProtocolKind::Cia402 && sc.units_per_radps().is_finite() {
            let max = self.limits.max_wheel_speed_radps * self.kinematics.gear_ratio * sc.units_per_radps();
            c.rule(
                max.is_nan() || max <= f64::from(i32::MAX),
                "limits.max_wheel_speed_radps",
                format!("{}", self.limits.max_wheel_speed_radps),
                "times kinematics.gear_ratio, in drive velocity units, within the i32 of 0x60FF",
            );
        }
        for (key, v) in [
            ("cia402.profile_accel_radps2", p.profile_accel_radps2),
            ("cia402.profile_decel_radps2", p.profile_decel_radps2),
            ("cia402.quick_stop_decel_radps2", p.quick_stop_decel_radps2),
        ] {
            let before = c.errors.len();
            c.range(key, v, "(0, 1000000] rad/s²");
            if c.errors.len() == before {
                c.rule(
                    sc.accel_to_drive(v).is_some(),
                    key,
                    format!("{v}"),
                    "at least one drive acceleration unit, and within the u32 of 0x6083-0x6085",
                );
            }
        }
        c.range("cia402.tpdo_event_ms", f(p.tpdo_event_ms), "[1, 65535] ms");
        let fb_ms = self.timing.feedback_timeout_s * 1000.0;
        c.rule(
            p.sync_producer || fb_ms.is_nan() || f(p.tpdo_event_ms) < fb_ms,
            "cia402.tpdo_event_ms",
            format!("{}", p.tpdo_event_ms),
            "below timing.feedback_timeout_s (without SYNC the feedback comes at this period)",
        );
        c.range("cia402.drive_heartbeat_ms", f(p.drive_heartbeat_ms), "[0, 65535] ms");
        let hb_ms = self.timing.heartbeat_timeout_s * 1000.0;
        c.rule(
            hb_ms.is_nan() || f(p.drive_heartbeat_ms) <= hb_ms / 2.0,
            "cia402.drive_heartbeat_ms",
            format!("{}", p.drive_heartbeat_ms),
            "at most half of timing.heartbeat_timeout_s",
        );
        c.range("cia402.bridge_node_id", f(p.bridge_node_id), "[1, 127]");
        c.rule(
            p.bridge_node_id != p.left_node_id && p.bridge_node_id != p.right_node_id,
            "cia402.bridge_node_id",
            format!("{}", p.bridge_node_id),
            "different from both drives' node ids",
        );
        c.range("cia402.bridge_heartbeat_ms", f(p.bridge_heartbeat_ms), "[0, 65535] ms");
        c.range(
            "cia402.drive_consumer_heartbeat_ms",
            f(p.drive_consumer_heartbeat_ms),
            "[0, 65535] ms",
        );
        c.rule(
            p.drive_consumer_heartbeat_ms == 0
                || (p.bridge_heartbeat_ms > 0 && p.drive_consumer_heartbeat_ms > p.bridge_heartbeat_ms),
            "cia402.drive_consumer_heartbeat_ms",
            format!("{}", p.drive_consumer_heartbeat_ms),
            "0, or longer than a non-zero cia402.bridge_heartbeat_ms",
        );
        c.range("cia402.sdo_timeout_s", p.sdo_timeout_s, "(0, 10] s");
        c.rule(
            p.sdo_timeout_s.is_nan()
                || self.timing.startup_timeout_s.is_nan()
                || p.sdo_timeout_s < self.timing.startup_timeout_s,
            "cia402.sdo_timeout_s",
            format!("{}", p.sdo_timeout_s),
            "shorter than timing.startup_timeout_s",
        );
    }
}

/// A value outside its allowed range.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RangeError {
    /// Dotted key, as in the YAML file.
    pub key: &'static str,
    /// The offending value, printed.
    pub value: String,
    /// The allowed range or rule.
    pub allowed: &'static str,
}

impl fmt::Display for RangeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "key `{}` = {} is out of range; allowed: {}",
            self.key, self.value, self.allowed
        )
    }
}

/// Parses `(0, 1]` or `[-5, 5] m` into (lo, lo_open, hi, hi_open).
fn parse_interval(allowed: &str) -> Option<(f64, bool, f64, bool)> {
    let lo_open = allowed.starts_with('(');
    let close = allowed.find([']', ')'])?;
    let hi_open = allowed[close..].starts_with(')');
    let (lo, hi) = allowed[1..close].split_once(',')?;
    Some((lo.trim().parse().ok()?, lo_open, hi.trim().parse().ok()?, hi_open))
}

struct Check {
    errors: Vec<RangeError>,
}

impl Check {
    /// `allowed` is both the message and what is checked.
    fn range(&mut self, key: &'static str, v: f64, allowed: &'static str) {
        let (lo, lo_open, hi, hi_open) = parse_interval(allowed).expect("interval literal is well formed");
        let ok = v.is_finite() && (if lo_open { v > lo } else { v >= lo }) && (if hi_open { v < hi } else { v <= hi });
        self.rule(ok, key, format!("{v}"), allowed);
    }

    fn rule(&mut self, ok: bool, key: &'static str, value: String, allowed: &'static str) {
        if !ok {
            self.errors.push(RangeError { key, value, allowed });
        }
    }
}

/// A configuration problem, naming the file and, where there is one, the key.
#[derive(Debug)]
pub enum ConfigError {
    /// The file could not be read.
    Io { file: String, error: std::io::Error },
    /// Not YAML, a wrong type, an unknown or a missing key.
    Parse { file: String, key: String, message: String },
    /// Values outside their allowed ranges.
    Range { file: String, errors: Vec<RangeError> },
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Io { file, error } => write!(f, "{file}: cannot read: {error}"),
            Self::Parse { file, key, message } if key.is_empty() || key == "." => write!(f, "{file}: {message}"),
            Self::Parse { file, key, message } => write!(f, "{file}: key `{key}`: {message}"),
            Self::Range { file, errors } => {
                for (i, e) in errors.iter().enumerate() {
                    if i > 0 {
                        writeln!(f)?;
                    }
                    write!(f, "{file}: {e}")?;
                }
                Ok(())
            }
        }
    }
}

impl std::error::Error for ConfigError {}

impl ConfigError {
    /// The keys this error is about.
    pub fn keys(&self) -> Vec<String> {
        match self {
            Self::Io { .. } => vec![],
            Self::Parse { key, .. } => vec![key.clone()],
            Self::Range { errors, .. } => errors.iter().map(|e| e.key.to_string()).collect(),
        }
    }
}

/// Validated configuration from YAML text; `file` names it in messages.
pub fn load_config_str(text: &str, file: &str) -> Result<BridgeConfig, ConfigError> {
    let value: serde_yaml::Value = serde_yaml::from_str(text).map_err(|e| ConfigError::Parse {
        file: file.to_string(),
        key: String::new(),
        message: e.to_string(),
    })?;
    let cfg: BridgeConfig = serde_path_to_error::deserialize(value).map_err(|e| ConfigError::Parse {
        file: file.to_string(),
        key: e.path().to_string(),
        message: e.into_inner().to_string(),
    })?;
    cfg.validate().map_err(|errors| ConfigError::Range {
        file: file.to_string(),
        errors,
    })?;
    Ok(cfg)
}

/// Validated configuration from a file.
pub fn load_config_file(path: &Path) -> Result<BridgeConfig, ConfigError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|error| ConfigError::Io {
        file: file.clone(),
        error,
    })?;
    load_config_str(&text, &file)
}

/// The shipped defaults.
pub fn default_config() -> BridgeConfig {
    load_config_str(DEFAULT_CONFIG_YAML, DEFAULT_CONFIG_NAME)
        .expect("the shipped config/can_bridge.yaml is valid (tested)")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn with(key: &str, value: &str) -> String {
        let mut v: serde_yaml::Value = serde_yaml::from_str(DEFAULT_CONFIG_YAML).unwrap();
        let mut slot = &mut v;
        for k in key.split('.') {
            slot = slot.get_mut(k).unwrap_or_else(|| panic!("no key {k}"));
        }
        *slot = serde_yaml::from_str(value).unwrap();
        serde_yaml::to_string(&v).unwrap()
    }

    #[test]
    fn shipped_file_is_valid_and_documented() {
        let c = default_config();
        assert_eq!(c.interface, "vcan0");
        assert_eq!(c.protocol, ProtocolKind::Generic);
        assert_eq!(c.generic.base_id, 0x100, "hex in YAML");
        assert_eq!(c.tx_period(), Duration::from_millis(20));
        assert_eq!(c.diff_drive().right_direction, -1.0);
        // Every leaf key's own line ends its comment with the allowed range:
        // an interval like `(0, 10]`, or alternatives (`-1 or 1`, `a | b`).
        let has_interval = |c: &str| {
            c.find(['[', '(']).is_some_and(|i| {
                let rest = &c[i..];
                rest.find(',').is_some_and(|j| rest[j..].contains([']', ')']))
            })
        };
        let mut leaves = 0;
        for line in DEFAULT_CONFIG_YAML.lines() {
            let l = line.trim_start();
            if l.starts_with('#') || l.is_empty() || l.ends_with(':') {
                continue;
            }
            leaves += 1;
            let (_, comment) = l.split_once('#').unwrap_or_else(|| panic!("no comment: {line}"));
            assert!(
                has_interval(comment) || comment.contains(" or ") || comment.contains(" | "),
                "no range: {line}"
            );
        }
        assert_eq!(leaves, 38, "every key of BridgeConfig is in the shipped file");
    }

    #[test]
    fn unknown_key_is_named() {
        let text = DEFAULT_CONFIG_YAML.replace("  gear_ratio: 1.0", "  gear_ratio: 1.0\n  gear_ration: 2");
        let e = load_config_str(&text, "my.yaml").unwrap_err();
        assert_eq!(e.keys(), ["kinematics.gear_ration"], "{e}");
        assert!(
            e.to_string()
                .starts_with("my.yaml: key `kinematics.gear_ration`: unknown field"),
            "{e}"
        );
    }

    #[test]
    fn wrong_type_and_bad_enum_are_named() {
        let e = load_config_str(&with("timing.tx_rate_hz", "\"fast\""), "f.yaml").unwrap_err();
        assert_eq!(e.keys(), ["timing.tx_rate_hz"], "{e}");
        let e = load_config_str(&with("protocol", "canopen"), "f.yaml").unwrap_err();
        assert_eq!(e.keys(), ["protocol"], "{e}");
        assert!(
            e.to_string().contains("generic") && e.to_string().contains("odrive"),
            "{e}"
        );
    }

    #[test]
    fn missing_key_is_named() {
        let text = DEFAULT_CONFIG_YAML.replace("  cmd_timeout_s: 0.5", "");
        let e = load_config_str(&text, "f.yaml").unwrap_err();
        assert!(e.to_string().contains("missing field `cmd_timeout_s`"), "{e}");
    }

    #[test]
    fn out_of_range_messages_give_the_range() {
        let e = load_config_str(&with("timing.tx_rate_hz", "0"), "f.yaml").unwrap_err();
        assert_eq!(
            e.to_string().lines().next().unwrap(),
            "f.yaml: key `timing.tx_rate_hz` = 0 is out of range; allowed: (0, 1000] Hz"
        );
        let e = load_config_str(&with("kinematics.left_direction", "0"), "f.yaml").unwrap_err();
        assert_eq!(e.keys(), ["kinematics.left_direction"]);
        let e = load_config_str(&with("timing.cmd_timeout_s", "0.01"), "f.yaml").unwrap_err();
        assert!(e.to_string().contains("at least one tx period"), "{e}");
        let e = load_config_str(&with("generic.base_id", "0x7F0"), "f.yaml").unwrap_err();
        assert_eq!(e.keys(), ["generic.base_id"]);
        let e = load_config_str(&with("odrive.right_node_id", "0"), "f.yaml").unwrap_err();
        assert!(e.to_string().contains("different from odrive.left_node_id"), "{e}");
        let e = load_config_str(&with("odrive.left_node_id", "64"), "f.yaml").unwrap_err();
        assert_eq!(e.keys(), ["odrive.left_node_id"]);
        let e = load_config_str(&with("limits.v_max_mps", ".nan"), "f.yaml").unwrap_err();
        assert_eq!(e.keys(), ["limits.v_max_mps"]);
        let e = load_config_str(&with("interface", "\"can 0\""), "f.yaml").unwrap_err();
        assert_eq!(e.keys(), ["interface"]);
        // The generic i32 field must hold max wheel speed × gear (100 × 1000 > 21474.8).
        let text =
            with("kinematics.gear_ratio", "1000").replace("max_wheel_speed_radps: 7.0", "max_wheel_speed_radps: 100.0");
        let e = load_config_str(&text, "f.yaml").unwrap_err();
        assert_eq!(e.keys(), ["limits.max_wheel_speed_radps"], "{e}");
        let text = text.replace("protocol: generic", "protocol: odrive");
        assert!(
            load_config_str(&text, "f.yaml").is_ok(),
            "floats on ODrive have the range"
        );
    }

    /// The CiA 402 rules that involve two keys, each naming the key to change.
    #[test]
    fn cia402_cross_key_rules() {
        let cia = |t: String| t.replace("protocol: generic", "protocol: cia402");
        let case = |key: &str, value: &str, rule: &str| {
            let e = load_config_str(&cia(with(key, value)), "f.yaml").unwrap_err();
            assert_eq!(e.keys(), [key], "{key} = {value}: {e}");
            assert!(e.to_string().contains(rule), "{key} = {value}: {e}");
        };
        case("cia402.right_node_id", "1", "different from cia402.left_node_id");
        case("cia402.bridge_node_id", "2", "different from both drives' node ids");
        // heartbeat_timeout_s 0.5: at most 250 ms.
        case(
            "cia402.drive_heartbeat_ms",
            "251",
            "at most half of timing.heartbeat_timeout_s",
        );
        assert!(load_config_str(&cia(with("cia402.drive_heartbeat_ms", "250")), "f").is_ok());
        case(
            "cia402.drive_consumer_heartbeat_ms",
            "100",
            "longer than a non-zero cia402.bridge_heartbeat_ms",
        );
        let t = with("cia402.bridge_heartbeat_ms", "0");
        let e = load_config_str(&cia(t.clone()), "f.yaml").unwrap_err();
        assert_eq!(e.keys(), ["cia402.drive_consumer_heartbeat_ms"]);
        let t: String = serde_yaml::to_string(&{
            let mut v: serde_yaml::Value = serde_yaml::from_str(&t).unwrap();
            v["cia402"]["drive_consumer_heartbeat_ms"] = 0.into();
            v
        })
        .unwrap();
        assert!(
            load_config_str(&cia(t), "f").is_ok(),
            "no heartbeat, nobody watching it"
        );
        // startup_timeout_s 2.0.
        case("cia402.sdo_timeout_s", "2.0", "shorter than timing.startup_timeout_s");
        // 0.01 rad/s² is 0.095 rpm/s: rounds to 0.
        case(
            "cia402.profile_accel_radps2",
            "0.01",
            "at least one drive acceleration unit",
        );
        // Without SYNC the feedback comes at the event timer: below feedback_timeout_s (0.2 s).
        let e = load_config_str(
            &cia(with("cia402.tpdo_event_ms", "200")).replace("sync_producer: true", "sync_producer: false"),
            "f.yaml",
        )
        .unwrap_err();
        assert_eq!(e.keys(), ["cia402.tpdo_event_ms"], "{e}");
        assert!(
            load_config_str(&cia(with("cia402.tpdo_event_ms", "200")), "f").is_ok(),
            "SYNC: unused"
        );
        // 7 rad/s × 1000 (gear) × 9549.3 units per rad/s at 0.001 rpm = 6.7e7: fits; at 1e-5 rpm it does not.
        let t =
            with("kinematics.gear_ratio", "1000").replace("velocity_resolution: 1.0", "velocity_resolution: 0.00001");
        let e = load_config_str(&cia(t.clone()), "f.yaml").unwrap_err();
        assert_eq!(e.keys(), ["limits.max_wheel_speed_radps"], "{e}");
        assert!(
            load_config_str(&t, "f").is_ok(),
            "only checked when cia402 is the protocol"
        );
    }

    /// The EPOS example is complete and valid; its units by hand: 14 rad/s
    /// at the wheel × 26 = 364 rad/s at the motor = 3476 rpm; 2000 rad/s² =
    /// 19099 rpm/s.
    #[test]
    fn the_epos_example_is_valid() {
        let text = include_str!("../../config/can_bridge_cia402_epos.yaml");
        let c = load_config_str(text, "config/can_bridge_cia402_epos.yaml").unwrap();
        assert_eq!(c.protocol, ProtocolKind::Cia402);
        let s = c.cia402.settings();
        let motor = c.limits.max_wheel_speed_radps * c.kinematics.gear_ratio;
        assert_eq!(s.scaling.velocity_to_drive(motor), 3476);
        assert_eq!(s.profile_accel, 19099);
        assert_eq!(s.nodes, [1, 2]);
    }

    #[test]
    fn missing_file_is_named() {
        let e = load_config_file(Path::new("/nonexistent/can_bridge.yaml")).unwrap_err();
        assert!(
            e.to_string().starts_with("/nonexistent/can_bridge.yaml: cannot read"),
            "{e}"
        );
    }
}
