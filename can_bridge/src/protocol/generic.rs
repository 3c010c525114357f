//! The generic protocol: our own frame layout, for drives we program
//! ourselves. Specified in `can_bridge/README.md` and, for tools, in
//! `can_bridge/dbc/oldbf_generic.dbc` (ids for the default base 0x100).
//!
//! All frames are standard 11-bit ids at `base_id + offset`, DLC 8, little endian:
//!
//! | offset | frame | from | bytes |
//! |---|---|---|---|
//! | 0x01 / 0x02 | Setpoint_Left / _Right | bridge | 0–3 Vel_Cmd i32 (1e-5 rad/s, motor shaft); 4 Counter u8; 5 Flags (bit0 Enable, bit1 Estop); 6 reserved 0; 7 CRC-8 |
//! | 0x10 | Drive_Status | drive | 0 State u8 (0 disabled, 1 enabled, 2 e-stop, 3 fault); 1 Counter u8; 2–5 Error_Code u32; 6 Rejected_Setpoints u8; 7 CRC-8 |
//! | 0x11 / 0x12 | Feedback_Left / _Right | drive | 0–3 Vel_Meas i32 (1e-5 rad/s); 4–6 Pos_Meas u24 (1e-4 rad, wraps); 7 Counter u8 |
//!
//! Why this shape: fixed-point integers cannot carry NaN or infinity, so a
//! corrupted float can never reach the motor; 1e-5 rad/s resolution over
//! ±21 474 rad/s covers any geared motor. The counter increments with every
//! setpoint pair, so a drive detects a frozen sender (same counter again) and
//! stops refreshing its watchdog; both wheels' frames of a pair carry the same
//! counter. The CRC-8/SAE-J1850 (poly 0x1D, init 0xFF, xor-out 0xFF) covers the
//! id (low byte, high byte) and bytes 0–6, so a setpoint or status written to
//! the wrong id, or with corrupted content by software, is rejected.
//! A setpoint with Enable = 0 and Estop = 0 asks the drive to disable and to
//! clear a latched e-stop or fault (like ODrive's Clear_Errors); the bridge
//! sends it only at start-up and shutdown.

use super::{DecodeError, DriveMessage, FrameBatch, Protocol, ProtocolKind, SetpointMode, Wheels};
use crate::bus::{CanFrame, RxFilter, SFF_MAX_ID};
use crate::kinematics::{MotorSpeeds, Wheel};

/// Default base id.
pub const DEFAULT_BASE_ID: u32 = 0x100;
/// Offset of Setpoint_Left.
pub const OFFSET_SETPOINT_LEFT: u32 = 0x01;
/// Offset of Setpoint_Right.
pub const OFFSET_SETPOINT_RIGHT: u32 = 0x02;
/// Offset of Drive_Status.
pub const OFFSET_STATUS: u32 = 0x10;
/// Offset of Feedback_Left.
pub const OFFSET_FEEDBACK_LEFT: u32 = 0x11;
/// Offset of Feedback_Right.
pub const OFFSET_FEEDBACK_RIGHT: u32 = 0x12;
/// The largest offset: base_id + this must be a standard id.
pub const MAX_OFFSET: u32 = OFFSET_FEEDBACK_RIGHT;
/// Largest allowed base id.
pub const MAX_BASE_ID: u32 = SFF_MAX_ID - MAX_OFFSET;

/// Speed resolution (rad/s per bit) of Vel_Cmd and Vel_Meas.
pub const VEL_RADPS_PER_BIT: f64 = 1e-5;
/// Bits per rad/s (1 / [`VEL_RADPS_PER_BIT`], exact: dividing by it rounds correctly).
pub const VEL_BITS_PER_RADPS: f64 = 100_000.0;
/// Largest speed magnitude the i32 field holds (rad/s).
pub const VEL_LIMIT_RADPS: f64 = i32::MAX as f64 / VEL_BITS_PER_RADPS;
/// Position resolution (rad per bit) of Pos_Meas.
pub const POS_RAD_PER_BIT: f64 = 1e-4;
/// Bits per rad (1 / [`POS_RAD_PER_BIT`]).
pub const POS_BITS_PER_RAD: f64 = 10_000.0;
/// Pos_Meas counts modulo this (24 bits).
pub const POS_MODULUS_COUNTS: u32 = 1 << 24;
/// Pos_Meas wraps modulo this many radians (1677.7216).
pub const POS_MODULUS_RAD: f64 = POS_MODULUS_COUNTS as f64 / POS_BITS_PER_RAD;

/// Setpoint flag: follow Vel_Cmd.
pub const FLAG_ENABLE: u8 = 0x01;
/// Setpoint flag: e-stop asserted.
pub const FLAG_ESTOP: u8 = 0x02;

/// Drive_Status.State: not following setpoints.
pub const STATE_DISABLED: u8 = 0;
/// Drive_Status.State: following setpoints.
pub const STATE_ENABLED: u8 = 1;
/// Drive_Status.State: e-stop latched.
pub const STATE_ESTOP: u8 = 2;
/// Drive_Status.State: an error is latched (Error_Code ≠ 0).
pub const STATE_FAULT: u8 = 3;

/// Error_Code bit: hardware fault (over-current, driver fault, ...).
pub const ERR_HARDWARE: u32 = 0x1;
/// Error_Code bit: the drive's own setpoint watchdog expired.
pub const ERR_WATCHDOG: u32 = 0x2;

/// CRC-8/SAE-J1850 over the id (low, high byte) then `bytes`.
pub fn crc8(id: u32, bytes: &[u8]) -> u8 {
    let mut crc: u8 = 0xFF;
    let id_bytes = [(id & 0xFF) as u8, ((id >> 8) & 0xFF) as u8];
    for &b in id_bytes.iter().chain(bytes) {
        crc ^= b;
        for _ in 0..8 {
            crc = if crc & 0x80 != 0 { (crc << 1) ^ 0x1D } else { crc << 1 };
        }
    }
    crc ^ 0xFF
}

/// Speed → Vel field, rounded; non-finite → 0, beyond the range → saturated.
pub fn vel_to_raw(radps: f64) -> i32 {
    if !radps.is_finite() {
        return 0;
    }
    // `as` saturates at the i32 range.
    (radps * VEL_BITS_PER_RADPS).round() as i32
}

/// Vel field → rad/s.
pub fn raw_to_vel(raw: i32) -> f64 {
    f64::from(raw) / VEL_BITS_PER_RADPS
}

/// Position (rad, any size) → Pos_Meas counts modulo 2^24; non-finite → 0.
pub fn pos_to_raw(rad: f64) -> u32 {
    if !rad.is_finite() {
        return 0;
    }
    let counts = (rad * POS_BITS_PER_RAD).round();
    // Keep the integer conversion exact: fold huge values first.
    let folded = counts.rem_euclid(f64::from(POS_MODULUS_COUNTS));
    (folded as u32) % POS_MODULUS_COUNTS
}

/// Pos_Meas counts → rad in [0, POS_MODULUS_RAD).
pub fn raw_to_pos(raw: u32) -> f64 {
    f64::from(raw % POS_MODULUS_COUNTS) / POS_BITS_PER_RAD
}

/// The ids of one generic drive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GenericIds {
    pub base_id: u32,
}

impl GenericIds {
    /// Setpoint id of a wheel.
    pub fn setpoint(&self, w: Wheel) -> u32 {
        self.base_id
            + match w {
                Wheel::Left => OFFSET_SETPOINT_LEFT,
                Wheel::Right => OFFSET_SETPOINT_RIGHT,
            }
    }

    /// Feedback id of a wheel.
    pub fn feedback(&self, w: Wheel) -> u32 {
        self.base_id
            + match w {
                Wheel::Left => OFFSET_FEEDBACK_LEFT,
                Wheel::Right => OFFSET_FEEDBACK_RIGHT,
            }
    }

    /// Drive_Status id.
    pub fn status(&self) -> u32 {
        self.base_id + OFFSET_STATUS
    }

    fn wheel_of(&self, id: u32, left: u32, right: u32) -> Option<Wheel> {
        if id == self.base_id + left {
            Some(Wheel::Left)
        } else if id == self.base_id + right {
            Some(Wheel::Right)
        } else {
            None
        }
    }
}

/// Content of a setpoint frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Setpoint {
    /// Motor speed (rad/s), as sent (quantized when decoded).
    pub vel_radps: f64,
    pub counter: u8,
    pub enable: bool,
    pub estop: bool,
}

/// Builds a setpoint frame (CRC included).
pub fn encode_setpoint(ids: GenericIds, wheel: Wheel, sp: &Setpoint) -> CanFrame {
    let id = ids.setpoint(wheel);
    let mut d = [0u8; 8];
    d[0..4].copy_from_slice(&vel_to_raw(sp.vel_radps).to_le_bytes());
    d[4] = sp.counter;
    d[5] = if sp.enable { FLAG_ENABLE } else { 0 } | if sp.estop { FLAG_ESTOP } else { 0 };
    d[7] = crc8(id, &d[..7]);
    frame(id, d)
}

fn frame(id: u32, data: [u8; 8]) -> CanFrame {
    CanFrame {
        id,
        extended: false,
        data,
        len: 8,
    }
}

fn check_len(f: &CanFrame) -> Result<(), DecodeError> {
    if f.len != 8 {
        return Err(DecodeError::Length {
            id: f.id,
            len: f.len,
            expected: 8,
        });
    }
    Ok(())
}

fn check_crc(f: &CanFrame) -> Result<(), DecodeError> {
    let expected = crc8(f.id, &f.data[..7]);
    if f.data[7] != expected {
        return Err(DecodeError::Checksum {
            id: f.id,
            got: f.data[7],
            expected,
        });
    }
    Ok(())
}

/// Drive side: decodes a setpoint frame (`Ok(None)`: not a setpoint id).
/// Checks length, CRC and that reserved bits are zero.
pub fn decode_setpoint(ids: GenericIds, f: &CanFrame) -> Result<Option<(Wheel, Setpoint)>, DecodeError> {
    if f.extended {
        return Ok(None);
    }
    let Some(wheel) = ids.wheel_of(f.id, OFFSET_SETPOINT_LEFT, OFFSET_SETPOINT_RIGHT) else {
        return Ok(None);
    };
    check_len(f)?;
    check_crc(f)?;
    if f.data[5] & !(FLAG_ENABLE | FLAG_ESTOP) != 0 || f.data[6] != 0 {
        return Err(DecodeError::Invalid {
            id: f.id,
            what: "reserved bits set",
        });
    }
    let raw = i32::from_le_bytes([f.data[0], f.data[1], f.data[2], f.data[3]]);
    Ok(Some((
        wheel,
        Setpoint {
            vel_radps: raw_to_vel(raw),
            counter: f.data[4],
            enable: f.data[5] & FLAG_ENABLE != 0,
            estop: f.data[5] & FLAG_ESTOP != 0,
        },
    )))
}

/// Content of a Drive_Status frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Status {
    pub state: u8,
    pub counter: u8,
    pub error_code: u32,
    /// Setpoint frames the drive rejected (CRC, frozen counter, reserved bits), modulo 256.
    pub rejected_setpoints: u8,
}

/// Builds a Drive_Status frame (CRC included).
pub fn encode_status(ids: GenericIds, s: &Status) -> CanFrame {
    let id = ids.status();
    let mut d = [0u8; 8];
    d[0] = s.state;
    d[1] = s.counter;
    d[2..6].copy_from_slice(&s.error_code.to_le_bytes());
    d[6] = s.rejected_setpoints;
    d[7] = crc8(id, &d[..7]);
    frame(id, d)
}

/// Decodes a Drive_Status frame (length, CRC and state range checked).
pub fn decode_status(f: &CanFrame) -> Result<Status, DecodeError> {
    check_len(f)?;
    check_crc(f)?;
    if f.data[0] > STATE_FAULT {
        return Err(DecodeError::Invalid {
            id: f.id,
            what: "state > 3",
        });
    }
    Ok(Status {
        state: f.data[0],
        counter: f.data[1],
        error_code: u32::from_le_bytes([f.data[2], f.data[3], f.data[4], f.data[5]]),
        rejected_setpoints: f.data[6],
    })
}

/// Content of a feedback frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Feedback {
    /// Measured motor speed (rad/s).
    pub vel_radps: f64,
    /// Measured motor angle (rad); sent modulo [`POS_MODULUS_RAD`].
    pub pos_rad: f64,
    pub counter: u8,
}

/// Builds a feedback frame.
pub fn encode_feedback(ids: GenericIds, wheel: Wheel, fb: &Feedback) -> CanFrame {
    let mut d = [0u8; 8];
    d[0..4].copy_from_slice(&vel_to_raw(fb.vel_radps).to_le_bytes());
    d[4..7].copy_from_slice(&pos_to_raw(fb.pos_rad).to_le_bytes()[..3]);
    d[7] = fb.counter;
    frame(ids.feedback(wheel), d)
}

/// Decodes a feedback frame; `pos_rad` is in [0, POS_MODULUS_RAD).
pub fn decode_feedback(f: &CanFrame) -> Result<Feedback, DecodeError> {
    check_len(f)?;
    let raw = i32::from_le_bytes([f.data[0], f.data[1], f.data[2], f.data[3]]);
    let pos = u32::from_le_bytes([f.data[4], f.data[5], f.data[6], 0]);
    Ok(Feedback {
        vel_radps: raw_to_vel(raw),
        pos_rad: raw_to_pos(pos),
        counter: f.data[7],
    })
}

/// The bridge's side of the generic protocol.
#[derive(Clone, Debug)]
pub struct GenericProtocol {
    ids: GenericIds,
    /// Counter of the next setpoint pair.
    counter: u8,
    last_status_counter: Option<u8>,
    last_feedback_counter: [Option<u8>; 2],
}

impl GenericProtocol {
    /// For a drive at `base_id` (≤ [`MAX_BASE_ID`]).
    pub fn new(base_id: u32) -> Self {
        Self {
            ids: GenericIds { base_id },
            counter: 0,
            last_status_counter: None,
            last_feedback_counter: [None; 2],
        }
    }

    /// The drive's ids.
    pub fn ids(&self) -> GenericIds {
        self.ids
    }

    fn pair(&mut self, motor: MotorSpeeds, enable: bool, estop: bool, out: &mut FrameBatch) {
        let c = self.counter;
        self.counter = self.counter.wrapping_add(1);
        for w in Wheel::BOTH {
            let sp = Setpoint {
                vel_radps: motor.get(w),
                counter: c,
                enable,
                estop,
            };
            out.push(encode_setpoint(self.ids, w, &sp));
        }
    }
}

/// A counter equal to the previous one means the sender froze.
fn fresh_counter(last: &mut Option<u8>, c: u8, id: u32) -> Result<(), DecodeError> {
    if *last == Some(c) {
        return Err(DecodeError::Frozen { id, counter: c });
    }
    *last = Some(c);
    Ok(())
}

impl Protocol for GenericProtocol {
    fn kind(&self) -> ProtocolKind {
        ProtocolKind::Generic
    }

    fn rx_filters(&self) -> Vec<RxFilter> {
        vec![
            RxFilter::standard(self.ids.status()),
            RxFilter::standard(self.ids.feedback(Wheel::Left)),
            RxFilter::standard(self.ids.feedback(Wheel::Right)),
        ]
    }

    fn startup(&mut self, out: &mut FrameBatch) {
        // Enable = 0, Estop = 0: clear and disable; the periodic Hold frames
        // (Enable = 1, zero speed) then enable the drive.
        self.pair(MotorSpeeds::ZERO, false, false, out);
    }

    fn setpoints(&mut self, motor: MotorSpeeds, mode: SetpointMode, out: &mut FrameBatch) {
        match mode {
            SetpointMode::Run => self.pair(motor, true, false, out),
            SetpointMode::Hold => self.pair(MotorSpeeds::ZERO, true, false, out),
            SetpointMode::Estop => self.pair(MotorSpeeds::ZERO, false, true, out),
        }
    }

    fn shutdown(&mut self, out: &mut FrameBatch) {
        self.pair(MotorSpeeds::ZERO, false, false, out);
    }

    fn decode(&mut self, f: &CanFrame) -> Result<Option<DriveMessage>, DecodeError> {
        if f.extended {
            return Ok(None);
        }
        if f.id == self.ids.status() {
            let s = decode_status(f)?;
            fresh_counter(&mut self.last_status_counter, s.counter, f.id)?;
            return Ok(Some(DriveMessage::Status {
                wheels: Wheels::Both,
                error_code: s.error_code,
                running: s.state == STATE_ENABLED,
                estopped: s.state == STATE_ESTOP,
                raw_state: s.state,
            }));
        }
        if let Some(wheel) = self.ids.wheel_of(f.id, OFFSET_FEEDBACK_LEFT, OFFSET_FEEDBACK_RIGHT) {
            let fb = decode_feedback(f)?;
            fresh_counter(&mut self.last_feedback_counter[wheel.index()], fb.counter, f.id)?;
            return Ok(Some(DriveMessage::Feedback {
                wheel,
                motor_pos_rad: fb.pos_rad,
                motor_vel_radps: fb.vel_radps,
            }));
        }
        Ok(None)
    }

    fn position_modulus_rad(&self) -> Option<f64> {
        Some(POS_MODULUS_RAD)
    }

    fn is_watchdog_error(&self, error_code: u32) -> bool {
        error_code == ERR_WATCHDOG
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const IDS: GenericIds = GenericIds { base_id: 0x100 };

    /// The shipped DBC describes these constants (python cantools decodes the
    /// wire with it in the vcan group; this keeps the two in step on any machine).
    #[test]
    fn the_dbc_file_matches_the_layout() {
        let dbc = include_str!("../../dbc/oldbf_generic.dbc");
        for (off, name, dir) in [
            (OFFSET_SETPOINT_LEFT, "Setpoint_Left", "Bridge"),
            (OFFSET_SETPOINT_RIGHT, "Setpoint_Right", "Bridge"),
            (OFFSET_STATUS, "Drive_Status", "Drive"),
            (OFFSET_FEEDBACK_LEFT, "Feedback_Left", "Drive"),
            (OFFSET_FEEDBACK_RIGHT, "Feedback_Right", "Drive"),
        ] {
            let line = format!("BO_ {} {name}: 8 {dir}", DEFAULT_BASE_ID + off);
            assert!(dbc.contains(&line), "missing `{line}`");
        }
        let vel = format!("0|32@1- ({VEL_RADPS_PER_BIT:E},0)").replace("E-5", "E-005");
        assert_eq!(dbc.matches(&format!("SG_ Vel_Cmd : {vel}")).count(), 2, "{vel}");
        assert_eq!(dbc.matches(&format!("SG_ Vel_Meas : {vel}")).count(), 2);
        assert_eq!(dbc.matches("SG_ Pos_Meas : 32|24@1+ (0.0001,0)").count(), 2);
        assert_eq!(POS_RAD_PER_BIT, 0.0001);
        assert_eq!(dbc.matches("SG_ Counter : 32|8@1+").count(), 2);
        assert_eq!(dbc.matches("SG_ Enable : 40|1@1+").count(), 2);
        assert_eq!(FLAG_ENABLE, 1 << (40 - 40));
        assert_eq!(dbc.matches("SG_ Estop : 41|1@1+").count(), 2);
        assert_eq!(FLAG_ESTOP, 1 << (41 - 40));
        assert_eq!(dbc.matches("SG_ Crc : 56|8@1+").count(), 3);
        assert!(dbc.contains("SG_ Error_Code : 16|32@1+"));
        assert!(dbc.contains(r#"VAL_ 272 State 0 "DISABLED" 1 "ENABLED" 2 "ESTOP" 3 "FAULT" ;"#));
        assert_eq!((STATE_DISABLED, STATE_ENABLED, STATE_ESTOP, STATE_FAULT), (0, 1, 2, 3));
    }

    #[test]
    fn crc_check_value() {
        // CRC-8/SAE-J1850 check value over "123456789" is 0x4B; our id
        // prefix is two bytes, so feed "12" as the id (0x3231) and the rest.
        assert_eq!(crc8(0x3231, b"3456789"), 0x4B);
    }

    // Golden bytes computed independently (python struct + a bitwise CRC)
    // and matching the DBC layout: Vel_Cmd 0|32@1-, Counter 32|8, Enable 40|1,
    // Estop 41|1, Crc 56|8.
    #[test]
    fn setpoint_golden_bytes() {
        let f = encode_setpoint(
            IDS,
            Wheel::Left,
            &Setpoint {
                vel_radps: 1.5,
                counter: 3,
                enable: true,
                estop: false,
            },
        );
        assert_eq!((f.id, f.len, f.extended), (0x101, 8, false));
        assert_eq!(f.data, [0xF0, 0x49, 0x02, 0x00, 0x03, 0x01, 0x00, 0xE7]);
        let f = encode_setpoint(
            IDS,
            Wheel::Right,
            &Setpoint {
                vel_radps: -2.25,
                counter: 3,
                enable: true,
                estop: false,
            },
        );
        assert_eq!(f.id, 0x102);
        assert_eq!(f.data, [0x18, 0x91, 0xFC, 0xFF, 0x03, 0x01, 0x00, 0x47]);
    }

    #[test]
    fn status_and_feedback_golden_bytes() {
        let f = encode_status(
            IDS,
            &Status {
                state: STATE_ENABLED,
                counter: 7,
                error_code: 0,
                rejected_setpoints: 0,
            },
        );
        assert_eq!(f.id, 0x110);
        assert_eq!(f.data, [0x01, 0x07, 0, 0, 0, 0, 0, 0xAF]);
        let f = encode_feedback(
            IDS,
            Wheel::Left,
            &Feedback {
                vel_radps: 12.34567,
                pos_rad: 2.5,
                counter: 9,
            },
        );
        assert_eq!(f.id, 0x111);
        assert_eq!(f.data, [0x87, 0xD6, 0x12, 0x00, 0xA8, 0x61, 0x00, 0x09]);
    }

    #[test]
    fn setpoint_round_trip_and_rejections() {
        let sp = Setpoint {
            vel_radps: -123.45678,
            counter: 200,
            enable: false,
            estop: true,
        };
        let f = encode_setpoint(IDS, Wheel::Right, &sp);
        let (w, got) = decode_setpoint(IDS, &f).unwrap().unwrap();
        assert_eq!(w, Wheel::Right);
        assert!((got.vel_radps - sp.vel_radps).abs() <= 0.5 * VEL_RADPS_PER_BIT + 1e-12);
        assert_eq!((got.counter, got.enable, got.estop), (200, false, true));
        // One flipped bit anywhere → checksum error.
        for byte in 0..7 {
            let mut bad = f;
            bad.data[byte] ^= 0x10;
            assert!(
                matches!(decode_setpoint(IDS, &bad), Err(DecodeError::Checksum { .. })),
                "byte {byte}"
            );
        }
        // The same payload under the other wheel's id fails its CRC.
        let mut moved = f;
        moved.id = IDS.setpoint(Wheel::Left);
        assert!(matches!(
            decode_setpoint(IDS, &moved),
            Err(DecodeError::Checksum { .. })
        ));
        // Short frame.
        let mut short = f;
        short.len = 7;
        assert!(matches!(decode_setpoint(IDS, &short), Err(DecodeError::Length { .. })));
        // Not a setpoint id.
        assert_eq!(
            decode_setpoint(IDS, &CanFrame::standard(0x110, &[0; 8]).unwrap()),
            Ok(None)
        );
    }

    #[test]
    fn non_finite_and_huge_speeds_never_reach_the_wire_as_such() {
        assert_eq!(vel_to_raw(f64::NAN), 0);
        assert_eq!(vel_to_raw(f64::INFINITY), 0);
        assert_eq!(vel_to_raw(1e300), i32::MAX);
        assert_eq!(vel_to_raw(-1e300), i32::MIN);
        assert!((raw_to_vel(i32::MAX) - VEL_LIMIT_RADPS).abs() < 1e-9);
    }

    #[test]
    fn position_wraps_modulo_2_pow_24_counts() {
        assert_eq!(pos_to_raw(0.0), 0);
        assert_eq!(pos_to_raw(-POS_RAD_PER_BIT), POS_MODULUS_COUNTS - 1);
        assert_eq!(pos_to_raw(POS_MODULUS_RAD + 0.5), 5000);
        assert_eq!(pos_to_raw(1e12), pos_to_raw(1e12 - 1e4 * POS_MODULUS_RAD));
        assert_eq!(pos_to_raw(f64::NAN), 0);
        assert!((raw_to_pos(5000) - 0.5).abs() < 1e-12);
    }

    #[test]
    fn bridge_side_encodes_modes_and_counts_pairs() {
        let mut p = GenericProtocol::new(0x100);
        let mut out = FrameBatch::new();
        let m = MotorSpeeds {
            left_radps: 1.5,
            right_radps: -2.25,
        };
        p.setpoints(m, SetpointMode::Run, &mut out);
        p.setpoints(m, SetpointMode::Hold, &mut out);
        p.setpoints(m, SetpointMode::Estop, &mut out);
        p.startup(&mut out);
        let d: Vec<_> = out
            .as_slice()
            .iter()
            .map(|f| decode_setpoint(IDS, f).unwrap().unwrap())
            .collect();
        assert_eq!(d.len(), 8);
        assert_eq!((d[0].1.vel_radps, d[1].1.vel_radps), (1.5, -2.25));
        assert!(d[0].1.enable && !d[0].1.estop);
        assert_eq!((d[2].1.vel_radps, d[3].1.vel_radps), (0.0, 0.0));
        assert!(d[2].1.enable);
        assert!(d[4].1.estop && !d[4].1.enable && d[4].1.vel_radps == 0.0);
        assert!(!d[6].1.estop && !d[6].1.enable);
        let counters: Vec<u8> = d.iter().map(|(_, s)| s.counter).collect();
        assert_eq!(counters, [0, 0, 1, 1, 2, 2, 3, 3]);
        // Wraps 255 → 0.
        p.counter = 255;
        out.clear();
        p.setpoints(m, SetpointMode::Hold, &mut out);
        p.setpoints(m, SetpointMode::Hold, &mut out);
        assert_eq!(out.as_slice()[0].data[4], 255);
        assert_eq!(out.as_slice()[2].data[4], 0);
    }

    #[test]
    fn bridge_side_decodes_drive_frames_and_detects_frozen_counters() {
        let mut p = GenericProtocol::new(0x100);
        let st = |c| {
            encode_status(
                IDS,
                &Status {
                    state: STATE_ENABLED,
                    counter: c,
                    error_code: 0x2,
                    rejected_setpoints: 0,
                },
            )
        };
        match p.decode(&st(1)).unwrap().unwrap() {
            DriveMessage::Status {
                wheels,
                error_code,
                running,
                estopped,
                ..
            } => {
                assert_eq!((wheels, error_code, running, estopped), (Wheels::Both, 2, true, false));
            }
            m => panic!("{m:?}"),
        }
        assert!(matches!(p.decode(&st(1)), Err(DecodeError::Frozen { .. })));
        assert!(p.decode(&st(2)).unwrap().is_some());
        let fb = |c| {
            encode_feedback(
                IDS,
                Wheel::Right,
                &Feedback {
                    vel_radps: -3.0,
                    pos_rad: 10.0,
                    counter: c,
                },
            )
        };
        assert_eq!(
            p.decode(&fb(0)).unwrap(),
            Some(DriveMessage::Feedback {
                wheel: Wheel::Right,
                motor_pos_rad: 10.0,
                motor_vel_radps: -3.0
            })
        );
        assert!(matches!(p.decode(&fb(0)), Err(DecodeError::Frozen { .. })));
        let mut bad = st(3);
        bad.data[2] ^= 1;
        assert!(matches!(p.decode(&bad), Err(DecodeError::Checksum { .. })));
        assert_eq!(p.decode(&CanFrame::standard(0x101, &[0; 8]).unwrap()), Ok(None));
        let filters = p.rx_filters();
        assert_eq!(filters.iter().map(|f| f.id).collect::<Vec<_>>(), [0x110, 0x111, 0x112]);
    }
}
