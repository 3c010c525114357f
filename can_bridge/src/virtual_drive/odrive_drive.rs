//! ODrive CANSimple's drive side: one axis per node, closed loop only
//! without error and in velocity mode, Estop latched as ESTOP_REQUESTED
//! (in the configured firmware's numbering).

use super::VirtualDrive;
use crate::bus::CanFrame;
use crate::kinematics::Wheel;
use crate::protocol::odrive::{self, Command};
use crate::time::Timestamp;
use std::f64::consts::TAU;

impl VirtualDrive {
    pub(super) fn handle_odrive(&mut self, f: &CanFrame, now: Timestamp) {
        let (node, _) = odrive::split_id(f.id);
        let Some(w) = Wheel::BOTH.into_iter().find(|w| self.node(*w) == node) else {
            return;
        };
        let c = match odrive::decode_command(f) {
            Ok(Some(c)) => c,
            Ok(None) => return,
            Err(e) => {
                self.stats.setpoints_rejected += 1;
                log::warn!("rejected command: {e}");
                return;
            }
        };
        let a = &mut self.axes[w.index()];
        match c {
            Command::SetInputVel { vel_turns_per_s, .. } => {
                if !vel_turns_per_s.is_finite() {
                    // A NaN on the wire is a bridge bug: fault, never follow it.
                    self.stats.setpoints_rejected += 1;
                    a.disarm(0x1);
                    return;
                }
                self.stats.setpoints_accepted += 1;
                a.input = f64::from(vel_turns_per_s) * TAU;
                a.last_setpoint = Some(now);
            }
            Command::SetAxisState(s) if s == odrive::AXIS_STATE_CLOSED_LOOP => {
                if a.input != 0.0 {
                    self.stats.closed_loop_with_nonzero_input += 1;
                    log::warn!("{} axis: closed loop requested with input {} rad/s", w.name(), a.input);
                }
                if a.error == 0 && a.control_mode == odrive::CONTROL_MODE_VELOCITY {
                    a.running = true;
                    a.last_setpoint = Some(now);
                }
            }
            Command::SetAxisState(_) => {
                a.running = false;
                a.input = 0.0;
            }
            Command::SetControllerMode {
                control_mode,
                input_mode,
            } => {
                a.control_mode = control_mode;
                a.input_mode = input_mode;
            }
            Command::ClearErrors { .. } => {
                self.stats.clear_requests += 1;
                a.error = 0;
                a.procedure_result = odrive::firmware::procedure_result::SUCCESS;
            }
            Command::Estop => {
                let code = self.cfg.odrive_firmware.estop_error();
                if a.error & code == 0 {
                    self.stats.estops += 1;
                }
                a.disarm(code);
            }
        }
    }
}
