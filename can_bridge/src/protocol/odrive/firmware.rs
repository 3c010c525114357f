//! What differs between ODrive firmware 0.5 (ODrive v3.x) and 0.6 (ODrive
//! Pro, S1, Micro) in the CANSimple messages the bridge uses.
//!
//! The message ids the bridge sends and the payloads of Set_Axis_State,
//! Set_Controller_Mode, Set_Input_Vel, Estop and Get_Encoder_Estimates are
//! the same in both. What differs:
//!
//! | | 0.5 | 0.6 |
//! |---|---|---|
//! | Heartbeat (0x01) bytes 0–3 | `Axis_Error`, AxisError numbering | `Axis_Error`, ODriveError bit flags |
//! | Heartbeat byte 4 | `Axis_State` (a u32 in ODrive's 0.5 DBC; only byte 4 is read) | `Axis_State` u8 |
//! | Heartbeat byte 5 | (0.5.4+: motor error flag) | `Procedure_Result` u8 |
//! | Heartbeat byte 6 bit 0 | (0.5.4+: encoder error flag) | `Trajectory_Done_Flag` |
//! | 0x03 | Get_Motor_Error | Get_Error: `Active_Errors` u32, `Disarm_Reason` u32 |
//! | 0x18 Clear_Errors | no payload the drive reads | byte 0 `Identify` (0: do not blink the LED) |
//! | watchdog expired | 0x800 | 0x0100_0000 |
//! | e-stop requested | 0x4000 | 0x0200_0000 |
//!
//! Sources: the 0.6 layouts and numbering are ODrive's own generated
//! definitions (`can_simple_messages.hpp` and `odrive_enums.h` of
//! odriverobotics/ros_odrive, the official driver for 0.6); the 0.5
//! numbering is ODrive's 0.5 DBC and `odrive-interface.yaml`. Bits 0x2–0x20
//! of the 0.5 AxisError changed meaning between 0.5 releases, so they are
//! shown as numbers, not named.

use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// The firmware generation a configuration speaks to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Firmware {
    /// 0.5.x (ODrive v3.x).
    V0_5,
    /// 0.6.x (ODrive Pro, S1, Micro).
    V0_6,
}

/// ODrive 0.5 AxisError bits the bridge names (stable across 0.5 releases).
pub mod axis_error_0_5 {
    pub const INVALID_STATE: u32 = 0x0000_0001;
    pub const MOTOR_FAILED: u32 = 0x0000_0040;
    pub const SENSORLESS_ESTIMATOR_FAILED: u32 = 0x0000_0080;
    pub const ENCODER_FAILED: u32 = 0x0000_0100;
    pub const CONTROLLER_FAILED: u32 = 0x0000_0200;
    pub const WATCHDOG_TIMER_EXPIRED: u32 = 0x0000_0800;
    pub const MIN_ENDSTOP_PRESSED: u32 = 0x0000_1000;
    pub const MAX_ENDSTOP_PRESSED: u32 = 0x0000_2000;
    pub const ESTOP_REQUESTED: u32 = 0x0000_4000;
    pub const HOMING_WITHOUT_ENDSTOP: u32 = 0x0002_0000;
    pub const OVER_TEMP: u32 = 0x0004_0000;
    pub const UNKNOWN_POSITION: u32 = 0x0008_0000;
}

/// ODrive 0.6 `ODriveError` bit flags (axis `active_errors`, `disarm_reason`).
pub mod odrive_error_0_6 {
    pub const INITIALIZING: u32 = 0x0000_0001;
    pub const SYSTEM_LEVEL: u32 = 0x0000_0002;
    pub const TIMING_ERROR: u32 = 0x0000_0004;
    pub const MISSING_ESTIMATE: u32 = 0x0000_0008;
    pub const BAD_CONFIG: u32 = 0x0000_0010;
    pub const DRV_FAULT: u32 = 0x0000_0020;
    pub const MISSING_INPUT: u32 = 0x0000_0040;
    pub const DC_BUS_OVER_VOLTAGE: u32 = 0x0000_0100;
    pub const DC_BUS_UNDER_VOLTAGE: u32 = 0x0000_0200;
    pub const DC_BUS_OVER_CURRENT: u32 = 0x0000_0400;
    pub const DC_BUS_OVER_REGEN_CURRENT: u32 = 0x0000_0800;
    pub const CURRENT_LIMIT_VIOLATION: u32 = 0x0000_1000;
    pub const MOTOR_OVER_TEMP: u32 = 0x0000_2000;
    pub const INVERTER_OVER_TEMP: u32 = 0x0000_4000;
    pub const VELOCITY_LIMIT_VIOLATION: u32 = 0x0000_8000;
    pub const POSITION_LIMIT_VIOLATION: u32 = 0x0001_0000;
    pub const WATCHDOG_TIMER_EXPIRED: u32 = 0x0100_0000;
    pub const ESTOP_REQUESTED: u32 = 0x0200_0000;
    pub const SPINOUT_DETECTED: u32 = 0x0400_0000;
    pub const BRAKE_RESISTOR_DISARMED: u32 = 0x0800_0000;
    pub const THERMISTOR_DISCONNECTED: u32 = 0x1000_0000;
    pub const CALIBRATION_ERROR: u32 = 0x4000_0000;
}

/// ODrive 0.6 `ProcedureResult` (Heartbeat byte 5).
pub mod procedure_result {
    pub const SUCCESS: u8 = 0;
    pub const BUSY: u8 = 1;
    pub const CANCELLED: u8 = 2;
    /// The axis was disarmed (an error, an e-stop, the watchdog).
    pub const DISARMED: u8 = 3;
}

const NAMES_0_5: [(u32, &str); 12] = {
    use axis_error_0_5::*;
    [
        (INVALID_STATE, "INVALID_STATE"),
        (MOTOR_FAILED, "MOTOR_FAILED"),
        (SENSORLESS_ESTIMATOR_FAILED, "SENSORLESS_ESTIMATOR_FAILED"),
        (ENCODER_FAILED, "ENCODER_FAILED"),
        (CONTROLLER_FAILED, "CONTROLLER_FAILED"),
        (WATCHDOG_TIMER_EXPIRED, "WATCHDOG_TIMER_EXPIRED"),
        (MIN_ENDSTOP_PRESSED, "MIN_ENDSTOP_PRESSED"),
        (MAX_ENDSTOP_PRESSED, "MAX_ENDSTOP_PRESSED"),
        (ESTOP_REQUESTED, "ESTOP_REQUESTED"),
        (HOMING_WITHOUT_ENDSTOP, "HOMING_WITHOUT_ENDSTOP"),
        (OVER_TEMP, "OVER_TEMP"),
        (UNKNOWN_POSITION, "UNKNOWN_POSITION"),
    ]
};

const NAMES_0_6: [(u32, &str); 22] = {
    use odrive_error_0_6::*;
    [
        (INITIALIZING, "INITIALIZING"),
        (SYSTEM_LEVEL, "SYSTEM_LEVEL"),
        (TIMING_ERROR, "TIMING_ERROR"),
        (MISSING_ESTIMATE, "MISSING_ESTIMATE"),
        (BAD_CONFIG, "BAD_CONFIG"),
        (DRV_FAULT, "DRV_FAULT"),
        (MISSING_INPUT, "MISSING_INPUT"),
        (DC_BUS_OVER_VOLTAGE, "DC_BUS_OVER_VOLTAGE"),
        (DC_BUS_UNDER_VOLTAGE, "DC_BUS_UNDER_VOLTAGE"),
        (DC_BUS_OVER_CURRENT, "DC_BUS_OVER_CURRENT"),
        (DC_BUS_OVER_REGEN_CURRENT, "DC_BUS_OVER_REGEN_CURRENT"),
        (CURRENT_LIMIT_VIOLATION, "CURRENT_LIMIT_VIOLATION"),
        (MOTOR_OVER_TEMP, "MOTOR_OVER_TEMP"),
        (INVERTER_OVER_TEMP, "INVERTER_OVER_TEMP"),
        (VELOCITY_LIMIT_VIOLATION, "VELOCITY_LIMIT_VIOLATION"),
        (POSITION_LIMIT_VIOLATION, "POSITION_LIMIT_VIOLATION"),
        (WATCHDOG_TIMER_EXPIRED, "WATCHDOG_TIMER_EXPIRED"),
        (ESTOP_REQUESTED, "ESTOP_REQUESTED"),
        (SPINOUT_DETECTED, "SPINOUT_DETECTED"),
        (BRAKE_RESISTOR_DISARMED, "BRAKE_RESISTOR_DISARMED"),
        (THERMISTOR_DISCONNECTED, "THERMISTOR_DISCONNECTED"),
        (CALIBRATION_ERROR, "CALIBRATION_ERROR"),
    ]
};

impl Firmware {
    /// `"0.5"` or `"0.6"`, as in the configuration.
    pub fn name(self) -> &'static str {
        match self {
            Firmware::V0_5 => "0.5",
            Firmware::V0_6 => "0.6",
        }
    }

    /// The error bit of the axis watchdog (no Set_Input_Vel in time).
    pub fn watchdog_error(self) -> u32 {
        match self {
            Firmware::V0_5 => axis_error_0_5::WATCHDOG_TIMER_EXPIRED,
            Firmware::V0_6 => odrive_error_0_6::WATCHDOG_TIMER_EXPIRED,
        }
    }

    /// The error bit an Estop message sets.
    pub fn estop_error(self) -> u32 {
        match self {
            Firmware::V0_5 => axis_error_0_5::ESTOP_REQUESTED,
            Firmware::V0_6 => odrive_error_0_6::ESTOP_REQUESTED,
        }
    }

    /// The heartbeat's shortest valid length: 0.5 needs bytes 0–4; 0.6
    /// sends 8 (ODrive's 0.6 message length), byte 6 holding the trajectory flag.
    pub fn heartbeat_len(self) -> u8 {
        match self {
            Firmware::V0_5 => 5,
            Firmware::V0_6 => 8,
        }
    }

    /// Whether 0x03 is Get_Error (0.6) rather than Get_Motor_Error (0.5).
    pub fn has_get_error(self) -> bool {
        self == Firmware::V0_6
    }

    /// The error bits by name, in this firmware's numbering: `NONE`, or
    /// `A|B`, with bits that have no name here as hex (`0x00000004`).
    pub fn error_names(self, code: u32) -> String {
        if code == 0 {
            return "NONE".into();
        }
        let table: &[(u32, &str)] = match self {
            Firmware::V0_5 => &NAMES_0_5,
            Firmware::V0_6 => &NAMES_0_6,
        };
        let mut parts = Vec::new();
        let mut rest = code;
        for (bit, name) in table {
            if code & bit != 0 {
                parts.push((*name).to_string());
                rest &= !bit;
            }
        }
        for i in 0..32 {
            let bit = 1u32 << i;
            if rest & bit != 0 {
                parts.push(format!("0x{bit:08X}"));
            }
        }
        parts.join("|")
    }
}

/// The 0.6 ProcedureResult by name (ODrive's `odrive_enums.h`).
pub fn procedure_result_name(r: u8) -> &'static str {
    match r {
        0 => "SUCCESS",
        1 => "BUSY",
        2 => "CANCELLED",
        3 => "DISARMED",
        4 => "NO_RESPONSE",
        5 => "POLE_PAIR_CPR_MISMATCH",
        6 => "PHASE_RESISTANCE_OUT_OF_RANGE",
        7 => "PHASE_INDUCTANCE_OUT_OF_RANGE",
        8 => "UNBALANCED_PHASES",
        9 => "INVALID_MOTOR_TYPE",
        10 => "ILLEGAL_HALL_STATE",
        11 => "TIMEOUT",
        12 => "HOMING_WITHOUT_ENDSTOP",
        13 => "INVALID_STATE",
        14 => "NOT_CALIBRATED",
        15 => "NOT_CONVERGING",
        _ => "unknown",
    }
}

impl std::fmt::Display for Firmware {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Firmware {
    type Err = UnknownFirmware;
    fn from_str(s: &str) -> Result<Self, UnknownFirmware> {
        match s {
            "0.5" => Ok(Firmware::V0_5),
            "0.6" => Ok(Firmware::V0_6),
            _ => Err(UnknownFirmware(s.to_string())),
        }
    }
}

/// A firmware version that is neither 0.5 nor 0.6.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown ODrive firmware `{0}`; allowed: \"0.5\", \"0.6\"")]
pub struct UnknownFirmware(pub String);

impl Serialize for Firmware {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// `"0.5"`/`"0.6"` as strings, or the YAML numbers 0.5 / 0.6 (an unquoted
/// `firmware: 0.6` is a float to YAML, and means the same).
impl<'de> Deserialize<'de> for Firmware {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl serde::de::Visitor<'_> for V {
            type Value = Firmware;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("\"0.5\" or \"0.6\"")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Firmware, E> {
                v.parse()
                    .map_err(|_| E::invalid_value(serde::de::Unexpected::Str(v), &self))
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<Firmware, E> {
                if v == 0.5 {
                    Ok(Firmware::V0_5)
                } else if v == 0.6 {
                    Ok(Firmware::V0_6)
                } else {
                    Err(E::invalid_value(serde::de::Unexpected::Float(v), &self))
                }
            }
        }
        d.deserialize_any(V)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_per_version() {
        assert_eq!(Firmware::V0_5.watchdog_error(), 0x800);
        assert_eq!(Firmware::V0_6.watchdog_error(), 1 << 24);
        assert_eq!(Firmware::V0_5.estop_error(), 0x4000);
        assert_eq!(Firmware::V0_6.estop_error(), 1 << 25);
    }

    #[test]
    fn names_of_error_bits() {
        assert_eq!(Firmware::V0_6.error_names(0), "NONE");
        assert_eq!(
            Firmware::V0_6.error_names(0x0100_0020),
            "DRV_FAULT|WATCHDOG_TIMER_EXPIRED"
        );
        // The same bits mean other things in 0.5: 0x20 has no stable name there.
        assert_eq!(
            Firmware::V0_5.error_names(0x0000_0820),
            "WATCHDOG_TIMER_EXPIRED|0x00000020"
        );
        assert_eq!(Firmware::V0_6.error_names(0x0000_0800), "DC_BUS_OVER_REGEN_CURRENT");
        assert_eq!(Firmware::V0_6.error_names(0x8000_0000), "0x80000000");
        assert_eq!(procedure_result_name(procedure_result::DISARMED), "DISARMED");
    }

    #[test]
    fn parses_strings_and_the_yaml_numbers() {
        let f: Firmware = serde_yaml::from_str("\"0.6\"").unwrap();
        assert_eq!(f, Firmware::V0_6);
        let f: Firmware = serde_yaml::from_str("0.5").unwrap();
        assert_eq!(f, Firmware::V0_5);
        for bad in ["0.7", "\"0.6.1\"", "six", "1"] {
            let e = serde_yaml::from_str::<Firmware>(bad).unwrap_err().to_string();
            assert!(e.contains("\"0.5\" or \"0.6\""), "{bad}: {e}");
        }
        assert_eq!(serde_yaml::to_string(&Firmware::V0_6).unwrap().trim(), "'0.6'");
    }
}
