//! ODrive CANSimple, firmware 0.5 (`tests/data/odrive-cansimple.dbc`, ODrive's)
//! and 0.6 (`can_bridge/dbc/odrive-cansimple-0.6.dbc`, ours, from ODrive's
//! published 0.6 definitions): one node per wheel, standard ids
//! `node_id << 5 | cmd_id`, little endian. What differs between the two
//! firmware generations is in [`firmware`].
//!
//! Used messages (Estop and Clear_Errors are not in ODrive's 0.5 DBC):
//!
//! | cmd | name | dir | payload |
//! |---|---|---|---|
//! | 0x01 | Heartbeat | drive | Axis_Error u32 @0, Axis_State u8 @32 (0.5: a u32 in ODrive's DBC, only byte 4 is read); 0.6: Procedure_Result u8 @40, Trajectory_Done_Flag @48 (1 bit) |
//! | 0x02 | Estop | bridge | none (DLC 0) |
//! | 0x03 | Get_Error (0.6 only) | drive | Active_Errors u32 @0, Disarm_Reason u32 @32 (ODriveError): reported |
//! | 0x07 | Set_Axis_State | bridge | Axis_Requested_State u32 @0 (8 closed loop, 1 idle) |
//! | 0x09 | Get_Encoder_Estimates | drive | Pos_Estimate f32 @0 (turns), Vel_Estimate f32 @32 (turns/s) |
//! | 0x0B | Set_Controller_Mode | bridge | Control_Mode u32 @0 (2 velocity), Input_Mode u32 @32 (1 passthrough) |
//! | 0x0D | Set_Input_Vel | bridge | Input_Vel f32 @0 (turns/s), Input_Torque_FF f32 @32 (Nm) |
//! | 0x18 | Clear_Errors | bridge | one zero byte (0.6: `Identify` = 0, no LED blink) |
//!
//! Every bridge frame with a payload is sent with DLC 8 (the DBC's message
//! length), zero padded. Start-up per node: Clear_Errors, Set_Controller_Mode
//! (velocity, passthrough), Set_Input_Vel 0, and only then Set_Axis_State
//! CLOSED_LOOP_CONTROL, so the axis never enters closed loop with a stale
//! non-zero input. Shutdown: Set_Input_Vel 0, then Set_Axis_State IDLE.
//! The drive must be configured to send heartbeats and encoder estimates
//! periodically (ODrive `heartbeat_msg_rate_ms`/`encoder_msg_rate_ms`, or
//! `encoder_rate_ms` on 0.5.x), and on 0.6 also Get_Error
//! (`error_msg_rate_ms`) to have the disarm reason named in reports.
//!
//! Any non-zero Axis_Error is a drive error; a changed Axis_Error, a 0.6
//! Procedure_Result other than SUCCESS and a changed Get_Error are
//! reported with their names in the configured firmware's numbering.

pub mod firmware;

pub use firmware::Firmware;

use super::{DecodeError, DriveMessage, FrameBatch, Protocol, ProtocolKind, ProtocolReport, SetpointMode, Wheels};
use crate::bus::{CanFrame, RxFilter};
use crate::kinematics::{MotorSpeeds, Wheel};
use std::f64::consts::TAU;

/// Command ids (the low 5 bits of the arbitration id).
pub mod cmd {
    pub const HEARTBEAT: u32 = 0x01;
    pub const ESTOP: u32 = 0x02;
    /// 0.6: Get_Error (0.5: Get_Motor_Error, not used).
    pub const GET_ERROR: u32 = 0x03;
    pub const SET_AXIS_STATE: u32 = 0x07;
    pub const GET_ENCODER_ESTIMATES: u32 = 0x09;
    pub const SET_CONTROLLER_MODE: u32 = 0x0B;
    pub const SET_INPUT_VEL: u32 = 0x0D;
    pub const CLEAR_ERRORS: u32 = 0x18;
}

/// Largest node id (6 bits).
pub const MAX_NODE_ID: u32 = 0x3F;
/// AxisState IDLE.
pub const AXIS_STATE_IDLE: u32 = 1;
/// AxisState CLOSED_LOOP_CONTROL.
pub const AXIS_STATE_CLOSED_LOOP: u32 = 8;
/// ControlMode VELOCITY_CONTROL.
pub const CONTROL_MODE_VELOCITY: u32 = 2;
/// InputMode PASSTHROUGH.
pub const INPUT_MODE_PASSTHROUGH: u32 = 1;
/// Axis error WATCHDOG_TIMER_EXPIRED (firmware 0.5.x numbering; 0.6: [`Firmware::watchdog_error`]).
pub const AXIS_ERROR_WATCHDOG_TIMER_EXPIRED: u32 = firmware::axis_error_0_5::WATCHDOG_TIMER_EXPIRED;
/// Axis error ESTOP_REQUESTED (firmware 0.5.x numbering; 0.6: [`Firmware::estop_error`]).
pub const AXIS_ERROR_ESTOP_REQUESTED: u32 = firmware::axis_error_0_5::ESTOP_REQUESTED;
/// Largest |turns/s| ever encoded: keeps the f32 finite whatever the input.
pub const MAX_ENCODED_TURNS_PER_S: f32 = 1e6;

/// Arbitration id of `cmd_id` for `node_id`.
pub fn arb_id(node_id: u32, cmd_id: u32) -> u32 {
    ((node_id & MAX_NODE_ID) << 5) | (cmd_id & 0x1F)
}

/// (node id, cmd id) of an arbitration id.
pub fn split_id(id: u32) -> (u32, u32) {
    ((id >> 5) & MAX_NODE_ID, id & 0x1F)
}

fn frame(id: u32, payload: &[u8]) -> CanFrame {
    let mut data = [0u8; 8];
    data[..payload.len()].copy_from_slice(payload);
    CanFrame {
        id,
        extended: false,
        data,
        len: payload.len() as u8,
    }
}

fn two_u32(a: u32, b: u32) -> [u8; 8] {
    let mut d = [0u8; 8];
    d[..4].copy_from_slice(&a.to_le_bytes());
    d[4..].copy_from_slice(&b.to_le_bytes());
    d
}

/// f64 → f32 for the wire: non-finite → 0, clamped to ±`MAX_ENCODED_TURNS_PER_S`.
pub fn finite_f32(x: f64) -> f32 {
    if x.is_finite() {
        (x as f32).clamp(-MAX_ENCODED_TURNS_PER_S, MAX_ENCODED_TURNS_PER_S)
    } else {
        0.0
    }
}

fn two_f32(a: f32, b: f32) -> [u8; 8] {
    let mut d = [0u8; 8];
    d[..4].copy_from_slice(&a.to_le_bytes());
    d[4..].copy_from_slice(&b.to_le_bytes());
    d
}

/// Set_Input_Vel: velocity (turns/s) and torque feed-forward (Nm).
pub fn set_input_vel(node: u32, vel_turns_per_s: f64, torque_ff_nm: f64) -> CanFrame {
    frame(
        arb_id(node, cmd::SET_INPUT_VEL),
        &two_f32(finite_f32(vel_turns_per_s), finite_f32(torque_ff_nm)),
    )
}

/// Set_Axis_State.
pub fn set_axis_state(node: u32, state: u32) -> CanFrame {
    frame(arb_id(node, cmd::SET_AXIS_STATE), &two_u32(state, 0))
}

/// Set_Controller_Mode.
pub fn set_controller_mode(node: u32, control_mode: u32, input_mode: u32) -> CanFrame {
    frame(
        arb_id(node, cmd::SET_CONTROLLER_MODE),
        &two_u32(control_mode, input_mode),
    )
}

/// Clear_Errors (byte 0: 0.6's `Identify` = 0; 0.5 reads no payload).
pub fn clear_errors(node: u32) -> CanFrame {
    frame(arb_id(node, cmd::CLEAR_ERRORS), &[0])
}

/// Estop.
pub fn estop(node: u32) -> CanFrame {
    frame(arb_id(node, cmd::ESTOP), &[])
}

/// Heartbeat (drive side, 0.5): error, state in byte 4, bytes 5–7 zero.
pub fn heartbeat(node: u32, axis_error: u32, axis_state: u8) -> CanFrame {
    frame(
        arb_id(node, cmd::HEARTBEAT),
        &two_u32(axis_error, u32::from(axis_state)),
    )
}

/// A heartbeat's fields (0.5 leaves the last two `None`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Heartbeat {
    pub axis_error: u32,
    pub axis_state: u8,
    /// 0.6: the last procedure's result ([`firmware::procedure_result`]).
    pub procedure_result: Option<u8>,
    /// 0.6: the trapezoidal trajectory is done (not used in velocity control).
    pub trajectory_done: Option<bool>,
}

/// Heartbeat (drive side, 0.6): error, state, procedure result, trajectory-done bit.
pub fn heartbeat_0_6(node: u32, h: &Heartbeat) -> CanFrame {
    let e = h.axis_error.to_le_bytes();
    frame(
        arb_id(node, cmd::HEARTBEAT),
        &[
            e[0],
            e[1],
            e[2],
            e[3],
            h.axis_state,
            h.procedure_result.unwrap_or(0),
            u8::from(h.trajectory_done.unwrap_or(false)),
            0,
        ],
    )
}

/// Decodes a heartbeat in `fw`'s layout.
pub fn decode_heartbeat(f: &CanFrame, fw: Firmware) -> Result<Heartbeat, DecodeError> {
    need_len(f, fw.heartbeat_len())?;
    let six = fw == Firmware::V0_6;
    Ok(Heartbeat {
        axis_error: u32_at(f, 0),
        axis_state: f.data[4],
        procedure_result: six.then_some(f.data[5]),
        trajectory_done: six.then_some(f.data[6] & 0x01 != 0),
    })
}

/// Get_Error (0.6, drive side): active errors and disarm reason (ODriveError).
pub fn get_error(node: u32, active_errors: u32, disarm_reason: u32) -> CanFrame {
    frame(arb_id(node, cmd::GET_ERROR), &two_u32(active_errors, disarm_reason))
}

/// Decodes Get_Error (0.6): (active errors, disarm reason).
pub fn decode_get_error(f: &CanFrame) -> Result<(u32, u32), DecodeError> {
    need_len(f, 8)?;
    Ok((u32_at(f, 0), u32_at(f, 4)))
}

/// Get_Encoder_Estimates (drive side): position (turns), velocity (turns/s).
pub fn encoder_estimates(node: u32, pos_turns: f64, vel_turns_per_s: f64) -> CanFrame {
    let pos = if pos_turns.is_finite() { pos_turns as f32 } else { 0.0 };
    frame(
        arb_id(node, cmd::GET_ENCODER_ESTIMATES),
        &two_f32(pos, finite_f32(vel_turns_per_s)),
    )
}

fn u32_at(f: &CanFrame, at: usize) -> u32 {
    u32::from_le_bytes([f.data[at], f.data[at + 1], f.data[at + 2], f.data[at + 3]])
}

fn f32_at(f: &CanFrame, at: usize) -> f32 {
    f32::from_le_bytes([f.data[at], f.data[at + 1], f.data[at + 2], f.data[at + 3]])
}

fn need_len(f: &CanFrame, n: u8) -> Result<(), DecodeError> {
    if f.len < n {
        return Err(DecodeError::Length {
            id: f.id,
            len: f.len,
            expected: n,
        });
    }
    Ok(())
}

/// A command as the drive receives it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Command {
    SetInputVel {
        vel_turns_per_s: f32,
        torque_ff_nm: f32,
    },
    SetAxisState(u32),
    SetControllerMode {
        control_mode: u32,
        input_mode: u32,
    },
    /// `identify`: 0.6's byte 0 (blink the LED); 0 when absent.
    ClearErrors {
        identify: u8,
    },
    Estop,
}

/// Drive side: decodes a command frame (`Ok(None)`: a command the drive ignores).
pub fn decode_command(f: &CanFrame) -> Result<Option<Command>, DecodeError> {
    let (_, c) = split_id(f.id);
    Ok(Some(match c {
        cmd::SET_INPUT_VEL => {
            need_len(f, 8)?;
            Command::SetInputVel {
                vel_turns_per_s: f32_at(f, 0),
                torque_ff_nm: f32_at(f, 4),
            }
        }
        cmd::SET_AXIS_STATE => {
            need_len(f, 4)?;
            Command::SetAxisState(u32_at(f, 0))
        }
        cmd::SET_CONTROLLER_MODE => {
            need_len(f, 8)?;
            Command::SetControllerMode {
                control_mode: u32_at(f, 0),
                input_mode: u32_at(f, 4),
            }
        }
        cmd::CLEAR_ERRORS => Command::ClearErrors {
            identify: if f.len >= 1 { f.data[0] } else { 0 },
        },
        cmd::ESTOP => Command::Estop,
        _ => return Ok(None),
    }))
}

/// What was last reported about one node (reports go out on change).
#[derive(Clone, Copy, Debug, Default)]
struct Reported {
    axis_error: u32,
    procedure_result: Option<u8>,
    get_error: Option<(u32, u32)>,
}

/// Reports kept until drained: a drive that floods cannot grow memory.
const MAX_REPORTS: usize = 64;

/// The bridge's side of CANSimple for two nodes.
#[derive(Clone, Debug)]
pub struct OdriveProtocol {
    nodes: [u32; 2],
    torque_ff_nm: f64,
    firmware: Firmware,
    reported: [Reported; 2],
    reports: Vec<ProtocolReport>,
}

impl OdriveProtocol {
    /// Left and right node ids (≤ 63, different), torque feed-forward sent
    /// with every non-zero velocity (Nm); firmware 0.5 (see [`with_firmware`](Self::with_firmware)).
    pub fn new(left_node_id: u32, right_node_id: u32, torque_ff_nm: f64) -> Self {
        Self {
            nodes: [left_node_id, right_node_id],
            torque_ff_nm,
            firmware: Firmware::V0_5,
            reported: [Reported::default(); 2],
            reports: Vec::new(),
        }
    }

    /// The same for drives with `firmware`.
    pub fn with_firmware(mut self, firmware: Firmware) -> Self {
        self.firmware = firmware;
        self
    }

    /// The firmware generation.
    pub fn firmware(&self) -> Firmware {
        self.firmware
    }

    fn report(&mut self, wheel: Wheel, message: String) {
        log::warn!("odrive: {message}");
        if self.reports.len() < MAX_REPORTS {
            self.reports.push(ProtocolReport {
                wheel: Some(wheel),
                message,
            });
        }
    }

    /// Reports what changed in a heartbeat: the error (named), and a 0.6
    /// procedure result other than SUCCESS.
    fn report_heartbeat(&mut self, wheel: Wheel, node: u32, h: &Heartbeat) {
        let fw = self.firmware;
        let r = self.reported[wheel.index()];
        if h.axis_error != r.axis_error && h.axis_error != 0 {
            let names = fw.error_names(h.axis_error);
            self.report(
                wheel,
                format!("node {node} axis error 0x{:08X} ({names}), firmware {fw}", h.axis_error),
            );
        }
        if let Some(p) = h.procedure_result {
            if Some(p) != r.procedure_result && p != firmware::procedure_result::SUCCESS {
                let name = firmware::procedure_result_name(p);
                self.report(wheel, format!("node {node} procedure result {p} ({name})"));
            }
        }
        let r = &mut self.reported[wheel.index()];
        r.axis_error = h.axis_error;
        r.procedure_result = h.procedure_result;
    }

    /// Node id of a wheel.
    pub fn node(&self, w: Wheel) -> u32 {
        self.nodes[w.index()]
    }

    fn wheel_of(&self, node: u32) -> Option<Wheel> {
        Wheel::BOTH.into_iter().find(|w| self.node(*w) == node)
    }
}

impl Protocol for OdriveProtocol {
    fn kind(&self) -> ProtocolKind {
        ProtocolKind::Odrive
    }

    fn rx_filters(&self) -> Vec<RxFilter> {
        Wheel::BOTH
            .iter()
            .flat_map(|w| {
                let n = self.node(*w);
                [
                    RxFilter::standard(arb_id(n, cmd::HEARTBEAT)),
                    RxFilter::standard(arb_id(n, cmd::GET_ENCODER_ESTIMATES)),
                ]
                .into_iter()
                .chain(
                    self.firmware
                        .has_get_error()
                        .then(|| RxFilter::standard(arb_id(n, cmd::GET_ERROR))),
                )
            })
            .collect()
    }

    fn startup(&mut self, out: &mut FrameBatch) {
        for w in Wheel::BOTH {
            let n = self.node(w);
            out.push(clear_errors(n));
            out.push(set_controller_mode(n, CONTROL_MODE_VELOCITY, INPUT_MODE_PASSTHROUGH));
            out.push(set_input_vel(n, 0.0, 0.0));
            out.push(set_axis_state(n, AXIS_STATE_CLOSED_LOOP));
        }
    }

    fn setpoints(&mut self, motor: MotorSpeeds, mode: SetpointMode, out: &mut FrameBatch) {
        for w in Wheel::BOTH {
            let n = self.node(w);
            match mode {
                SetpointMode::Run => {
                    let v = motor.get(w);
                    let v = if v.is_finite() { v } else { 0.0 };
                    let ff = if v == 0.0 { 0.0 } else { self.torque_ff_nm };
                    out.push(set_input_vel(n, v / TAU, ff));
                }
                SetpointMode::Hold => out.push(set_input_vel(n, 0.0, 0.0)),
                // Repeated every period while latched: one lost frame cannot
                // leave an axis running.
                SetpointMode::Estop => out.push(estop(n)),
            }
        }
    }

    fn shutdown(&mut self, out: &mut FrameBatch) {
        for w in Wheel::BOTH {
            out.push(set_input_vel(self.node(w), 0.0, 0.0));
        }
        for w in Wheel::BOTH {
            out.push(set_axis_state(self.node(w), AXIS_STATE_IDLE));
        }
    }

    fn decode(&mut self, f: &CanFrame) -> Result<Option<DriveMessage>, DecodeError> {
        if f.extended {
            return Ok(None);
        }
        let (node, c) = split_id(f.id);
        let Some(wheel) = self.wheel_of(node) else {
            return Ok(None);
        };
        match c {
            cmd::HEARTBEAT => {
                let h = decode_heartbeat(f, self.firmware)?;
                self.report_heartbeat(wheel, node, &h);
                Ok(Some(DriveMessage::Status {
                    wheels: Wheels::One(wheel),
                    error_code: h.axis_error,
                    running: u32::from(h.axis_state) == AXIS_STATE_CLOSED_LOOP,
                    estopped: false,
                    raw_state: h.axis_state,
                }))
            }
            cmd::GET_ERROR if self.firmware.has_get_error() => {
                let (active, disarm) = decode_get_error(f)?;
                let r = &mut self.reported[wheel.index()];
                if r.get_error != Some((active, disarm)) {
                    r.get_error = Some((active, disarm));
                    if active != 0 || disarm != 0 {
                        let fw = self.firmware;
                        self.report(
                            wheel,
                            format!(
                                "node {node} Get_Error: active errors 0x{active:08X} ({}), disarm reason 0x{disarm:08X} ({})",
                                fw.error_names(active),
                                fw.error_names(disarm)
                            ),
                        );
                    }
                }
                Ok(Some(DriveMessage::Handled { wheel }))
            }
            cmd::GET_ENCODER_ESTIMATES => {
                need_len(f, 8)?;
                let (pos, vel) = (f32_at(f, 0), f32_at(f, 4));
                if !pos.is_finite() || !vel.is_finite() {
                    return Err(DecodeError::NonFinite { id: f.id });
                }
                Ok(Some(DriveMessage::Feedback {
                    wheel,
                    motor_pos_rad: f64::from(pos) * TAU,
                    motor_vel_radps: f64::from(vel) * TAU,
                }))
            }
            _ => Ok(None),
        }
    }

    fn position_modulus_rad(&self) -> Option<f64> {
        None
    }

    fn is_watchdog_error(&self, error_code: u32) -> bool {
        error_code == self.firmware.watchdog_error()
    }

    fn drain_reports(&mut self, out: &mut Vec<ProtocolReport>) {
        out.append(&mut self.reports);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_are_node_shifted_by_5() {
        assert_eq!(arb_id(3, cmd::SET_INPUT_VEL), 0x6D);
        assert_eq!(arb_id(0, cmd::HEARTBEAT), 0x01);
        assert_eq!(arb_id(63, cmd::CLEAR_ERRORS), 0x7F8);
        assert_eq!(split_id(0x6D), (3, 0x0D));
    }

    // Golden bytes: python struct.pack('<ff', 1.5, 0.25) and the DBC layout
    // (Input_Vel 0|32@1 float, Input_Torque_FF 32|32@1 float).
    #[test]
    fn golden_bytes() {
        let f = set_input_vel(3, 1.5, 0.25);
        assert_eq!((f.id, f.len), (0x6D, 8));
        assert_eq!(f.data, [0x00, 0x00, 0xC0, 0x3F, 0x00, 0x00, 0x80, 0x3E]);
        let f = set_axis_state(1, AXIS_STATE_CLOSED_LOOP);
        assert_eq!((f.id, f.len), (0x27, 8));
        assert_eq!(f.data, [8, 0, 0, 0, 0, 0, 0, 0]);
        let f = set_controller_mode(1, CONTROL_MODE_VELOCITY, INPUT_MODE_PASSTHROUGH);
        assert_eq!((f.id, f.data), (0x2B, [2, 0, 0, 0, 1, 0, 0, 0]));
        assert_eq!((clear_errors(2).id, clear_errors(2).len), (0x58, 1));
        assert_eq!((estop(2).id, estop(2).len), (0x42, 0));
        let f = encoder_estimates(0, -0.75, 0.0);
        assert_eq!((f.id, f.data), (0x09, [0x00, 0x00, 0x40, 0xBF, 0, 0, 0, 0]));
        let f = heartbeat(1, 0x800, 8);
        assert_eq!((f.id, f.data), (0x21, [0x00, 0x08, 0, 0, 8, 0, 0, 0]));
    }

    #[test]
    fn never_encodes_non_finite() {
        for v in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e300] {
            let f = set_input_vel(0, v, v);
            let (a, b) = (f32_at(&f, 0), f32_at(&f, 4));
            assert!(a.is_finite() && b.is_finite(), "{v}");
        }
    }

    #[test]
    fn startup_order_per_node() {
        let mut p = OdriveProtocol::new(3, 5, 0.1);
        let mut out = FrameBatch::new();
        p.startup(&mut out);
        let ids: Vec<u32> = out.as_slice().iter().map(|f| f.id).collect();
        assert_eq!(
            ids,
            [
                arb_id(3, cmd::CLEAR_ERRORS),
                arb_id(3, cmd::SET_CONTROLLER_MODE),
                arb_id(3, cmd::SET_INPUT_VEL),
                arb_id(3, cmd::SET_AXIS_STATE),
                arb_id(5, cmd::CLEAR_ERRORS),
                arb_id(5, cmd::SET_CONTROLLER_MODE),
                arb_id(5, cmd::SET_INPUT_VEL),
                arb_id(5, cmd::SET_AXIS_STATE),
            ]
        );
        assert_eq!(out.as_slice()[2].data, [0; 8], "zero velocity and torque");
        assert_eq!(out.as_slice()[3].data[0], 8);
    }

    #[test]
    fn setpoints_in_turns_per_second_and_modes() {
        let mut p = OdriveProtocol::new(3, 5, 0.1);
        let mut out = FrameBatch::new();
        let m = MotorSpeeds {
            left_radps: TAU * 2.0,
            right_radps: -TAU * 0.5,
        };
        p.setpoints(m, SetpointMode::Run, &mut out);
        let c: Vec<_> = out
            .as_slice()
            .iter()
            .map(|f| decode_command(f).unwrap().unwrap())
            .collect();
        assert_eq!(
            c[0],
            Command::SetInputVel {
                vel_turns_per_s: 2.0,
                torque_ff_nm: 0.1
            }
        );
        assert_eq!(
            c[1],
            Command::SetInputVel {
                vel_turns_per_s: -0.5,
                torque_ff_nm: 0.1
            }
        );
        out.clear();
        p.setpoints(m, SetpointMode::Hold, &mut out);
        for f in out.as_slice() {
            assert_eq!(f.data, [0; 8]);
        }
        out.clear();
        p.setpoints(m, SetpointMode::Estop, &mut out);
        assert_eq!(
            out.as_slice().iter().map(|f| f.id).collect::<Vec<_>>(),
            [arb_id(3, cmd::ESTOP), arb_id(5, cmd::ESTOP)]
        );
        out.clear();
        p.shutdown(&mut out);
        let c: Vec<_> = out
            .as_slice()
            .iter()
            .map(|f| decode_command(f).unwrap().unwrap())
            .collect();
        assert!(matches!(c[0], Command::SetInputVel { vel_turns_per_s, .. } if vel_turns_per_s == 0.0));
        assert_eq!(c[3], Command::SetAxisState(AXIS_STATE_IDLE));
    }

    #[test]
    fn decodes_heartbeat_and_encoder_estimates() {
        let mut p = OdriveProtocol::new(3, 5, 0.0);
        let hb = p.decode(&heartbeat(5, 0x40, 8)).unwrap().unwrap();
        assert_eq!(
            hb,
            DriveMessage::Status {
                wheels: Wheels::One(Wheel::Right),
                error_code: 0x40,
                running: true,
                estopped: false,
                raw_state: 8
            }
        );
        let fb = p.decode(&encoder_estimates(3, 1.0, -0.5)).unwrap().unwrap();
        match fb {
            DriveMessage::Feedback {
                wheel,
                motor_pos_rad,
                motor_vel_radps,
            } => {
                assert_eq!(wheel, Wheel::Left);
                assert!((motor_pos_rad - TAU).abs() < 1e-6 && (motor_vel_radps + TAU / 2.0).abs() < 1e-6);
            }
            m => panic!("{m:?}"),
        }
        // Unknown node, other command: not ours.
        assert_eq!(p.decode(&heartbeat(4, 0, 8)).unwrap(), None);
        assert_eq!(p.decode(&set_input_vel(3, 1.0, 0.0)).unwrap(), None);
        // Garbage from our node is an error, never a value.
        let mut nan = encoder_estimates(3, 0.0, 0.0);
        nan.data[4..8].copy_from_slice(&f32::NAN.to_le_bytes());
        assert!(matches!(p.decode(&nan), Err(DecodeError::NonFinite { .. })));
        let short = CanFrame::standard(arb_id(3, cmd::HEARTBEAT), &[0, 0, 0]).unwrap();
        assert!(matches!(p.decode(&short), Err(DecodeError::Length { .. })));
        let ids: Vec<u32> = p.rx_filters().iter().map(|f| f.id).collect();
        assert_eq!(ids, [0x61, 0x69, 0xA1, 0xA9]);
    }

    // 0.6 heartbeat by hand from ODrive's 0.6 layout: Axis_Error 0x01000000
    // (WATCHDOG_TIMER_EXPIRED) little endian, Axis_State 1 (IDLE),
    // Procedure_Result 3 (DISARMED), Trajectory_Done_Flag bit 48 = 1.
    #[test]
    fn heartbeat_0_6_golden_bytes_and_fields() {
        let h = Heartbeat {
            axis_error: 0x0100_0000,
            axis_state: 1,
            procedure_result: Some(3),
            trajectory_done: Some(true),
        };
        let f = heartbeat_0_6(3, &h);
        assert_eq!((f.id, f.len), (0x61, 8));
        assert_eq!(f.data, [0x00, 0x00, 0x00, 0x01, 0x01, 0x03, 0x01, 0x00]);
        assert_eq!(decode_heartbeat(&f, Firmware::V0_6), Ok(h));
        // Read as 0.5, the same bytes give no procedure result and no flag.
        let h5 = decode_heartbeat(&f, Firmware::V0_5).unwrap();
        assert_eq!(
            (h5.axis_error, h5.axis_state, h5.procedure_result),
            (0x0100_0000, 1, None)
        );
        // Other bits of byte 6 are not the flag.
        let mut g = f;
        g.data[6] = 0xFE;
        assert_eq!(
            decode_heartbeat(&g, Firmware::V0_6).unwrap().trajectory_done,
            Some(false)
        );
        // 0.6 heartbeats are 8 bytes; a 5-byte 0.5 heartbeat is refused.
        let short = heartbeat(3, 0, 8);
        let mut short = short;
        short.len = 5;
        assert!(decode_heartbeat(&short, Firmware::V0_5).is_ok());
        assert!(matches!(
            decode_heartbeat(&short, Firmware::V0_6),
            Err(DecodeError::Length { expected: 8, .. })
        ));
        // Get_Error: active 0x20 (DRV_FAULT), disarm 0x02000000 (ESTOP_REQUESTED).
        let f = get_error(5, 0x20, 0x0200_0000);
        assert_eq!((f.id, f.len), (0xA3, 8));
        assert_eq!(f.data, [0x20, 0, 0, 0, 0, 0, 0, 0x02]);
        assert_eq!(decode_get_error(&f), Ok((0x20, 0x0200_0000)));
        assert_eq!(
            decode_command(&clear_errors(5)).unwrap(),
            Some(Command::ClearErrors { identify: 0 })
        );
    }

    #[test]
    fn the_watchdog_rule_and_reports_follow_the_firmware() {
        let mut p5 = OdriveProtocol::new(3, 5, 0.0);
        let mut p6 = OdriveProtocol::new(3, 5, 0.0).with_firmware(Firmware::V0_6);
        assert!(p5.is_watchdog_error(0x800) && !p5.is_watchdog_error(0x0100_0000));
        assert!(p6.is_watchdog_error(0x0100_0000) && !p6.is_watchdog_error(0x800));
        // 0.6 listens to Get_Error too; 0.5's 0x03 is Get_Motor_Error and not ours.
        let ids: Vec<u32> = p6.rx_filters().iter().map(|f| f.id).collect();
        assert_eq!(ids, [0x61, 0x69, 0x63, 0xA1, 0xA9, 0xA3]);
        assert_eq!(p5.decode(&get_error(3, 1, 1)).unwrap(), None);
        // A 0.6 watchdog trip: the status carries the code; the reports name it.
        let h = Heartbeat {
            axis_error: 0x0100_0000,
            axis_state: 1,
            procedure_result: Some(3),
            trajectory_done: Some(true),
        };
        match p6.decode(&heartbeat_0_6(5, &h)).unwrap().unwrap() {
            DriveMessage::Status {
                wheels,
                error_code,
                running,
                raw_state,
                ..
            } => {
                assert_eq!(
                    (wheels, error_code, running, raw_state),
                    (Wheels::One(Wheel::Right), 0x0100_0000, false, 1)
                );
            }
            m => panic!("{m:?}"),
        }
        assert_eq!(
            p6.decode(&get_error(5, 0, 0x0100_0000)).unwrap(),
            Some(DriveMessage::Handled { wheel: Wheel::Right })
        );
        let mut r = Vec::new();
        p6.drain_reports(&mut r);
        let msgs: Vec<&str> = r.iter().map(|x| x.message.as_str()).collect();
        assert_eq!(
            msgs,
            [
                "node 5 axis error 0x01000000 (WATCHDOG_TIMER_EXPIRED), firmware 0.6",
                "node 5 procedure result 3 (DISARMED)",
                "node 5 Get_Error: active errors 0x00000000 (NONE), disarm reason 0x01000000 (WATCHDOG_TIMER_EXPIRED)",
            ]
        );
        // Reported once: the same heartbeat again adds nothing.
        p6.decode(&heartbeat_0_6(5, &h)).unwrap();
        p6.decode(&get_error(5, 0, 0x0100_0000)).unwrap();
        p6.drain_reports(&mut r);
        assert_eq!(r.len(), 3);
        // 0.5 names in its own numbering: 0x4000 is ESTOP_REQUESTED there.
        p5.decode(&heartbeat(3, 0x4000, 1)).unwrap();
        let mut r = Vec::new();
        p5.drain_reports(&mut r);
        assert_eq!(
            r[0].message,
            "node 3 axis error 0x00004000 (ESTOP_REQUESTED), firmware 0.5"
        );
    }

    /// `can_bridge/dbc/odrive-cansimple-0.6.dbc` describes what the code
    /// sends and reads: every message and signal the bridge uses, at the
    /// code's bit positions and lengths.
    #[test]
    fn the_0_6_dbc_matches_the_code() {
        let dbc = include_str!("../../../dbc/odrive-cansimple-0.6.dbc");
        for line in [
            "BO_ 1 Heartbeat: 8 ODrive",
            " SG_ Axis_Error : 0|32@1+ (1,0)",
            " SG_ Axis_State : 32|8@1+ (1,0)",
            " SG_ Procedure_Result : 40|8@1+ (1,0)",
            " SG_ Trajectory_Done_Flag : 48|1@1+ (1,0)",
            "BO_ 2 Estop: 0 Master",
            "BO_ 3 Get_Error: 8 ODrive",
            " SG_ Active_Errors : 0|32@1+ (1,0)",
            " SG_ Disarm_Reason : 32|32@1+ (1,0)",
            "BO_ 7 Set_Axis_State: 8 Master",
            " SG_ Axis_Requested_State : 0|32@1+ (1,0)",
            "BO_ 9 Get_Encoder_Estimates: 8 ODrive",
            " SG_ Pos_Estimate : 0|32@1- (1,0)",
            " SG_ Vel_Estimate : 32|32@1- (1,0)",
            "BO_ 11 Set_Controller_Mode: 8 Master",
            " SG_ Control_Mode : 0|32@1+ (1,0)",
            " SG_ Input_Mode : 32|32@1+ (1,0)",
            "BO_ 13 Set_Input_Vel: 8 Master",
            " SG_ Input_Vel : 0|32@1- (1,0)",
            " SG_ Input_Torque_FF : 32|32@1- (1,0)",
            "BO_ 24 Clear_Errors: 1 Master",
            " SG_ Identify : 0|8@1+ (1,0)",
            "SIG_VALTYPE_ 13 Input_Vel : 1;",
            "SIG_VALTYPE_ 9 Pos_Estimate : 1;",
            "8 \"CLOSED_LOOP_CONTROL\"",
            "3 \"DISARMED\"",
        ] {
            assert!(dbc.contains(line), "missing `{line}`");
        }
        for (bit, name) in [
            (0x0100_0000u32, "WATCHDOG_TIMER_EXPIRED"),
            (0x0200_0000, "ESTOP_REQUESTED"),
        ] {
            assert!(dbc.contains(&format!("0x{bit:X} {name}")), "{name}");
        }
        // The frame lengths the code sends are the DBC's.
        assert_eq!(set_input_vel(0, 0.0, 0.0).len, 8);
        assert_eq!(clear_errors(0).len, 1);
        assert_eq!(estop(0).len, 0);
    }
}
