//! The generic protocol's drive side: one drive for both wheels, CRC and
//! frozen-counter checks, enable / e-stop / disable-and-clear.

use super::VirtualDrive;
use crate::bus::CanFrame;
use crate::protocol::generic;
use crate::time::Timestamp;

impl VirtualDrive {
    pub(super) fn generic_set_error(&mut self, code: u32) {
        for a in &mut self.axes {
            a.error |= code;
            a.input = 0.0;
        }
        self.generic_state = generic::STATE_FAULT;
    }

    pub(super) fn handle_generic(&mut self, f: &CanFrame, now: Timestamp) {
        let (w, sp) = match generic::decode_setpoint(self.generic_ids(), f) {
            Ok(Some(x)) => x,
            Ok(None) => return,
            Err(e) => {
                self.stats.setpoints_rejected += 1;
                log::warn!("rejected setpoint: {e}");
                return;
            }
        };
        let a = &mut self.axes[w.index()];
        if a.last_counter == Some(sp.counter) {
            self.stats.setpoints_rejected += 1;
            self.stats.frozen_counters += 1;
            return;
        }
        a.last_counter = Some(sp.counter);
        self.stats.setpoints_accepted += 1;
        if sp.estop {
            if self.generic_state != generic::STATE_ESTOP {
                self.stats.estops += 1;
                log::warn!("e-stop received");
            }
            self.generic_state = generic::STATE_ESTOP;
            for a in &mut self.axes {
                a.input = 0.0;
            }
            return;
        }
        if !sp.enable {
            // Disable and clear: a latched e-stop or error goes away.
            self.stats.clear_requests += 1;
            for a in &mut self.axes {
                a.error = 0;
                a.input = 0.0;
            }
            self.generic_state = generic::STATE_DISABLED;
            self.axes[w.index()].last_setpoint = Some(now);
            return;
        }
        match self.generic_state {
            // Enable (from disabled, without error).
            generic::STATE_DISABLED if self.axes.iter().all(|a| a.error == 0) => {
                self.generic_state = generic::STATE_ENABLED;
                for a in &mut self.axes {
                    a.last_setpoint = Some(now);
                }
            }
            generic::STATE_ENABLED => {}
            // E-stop or fault latched (or disabled with an error): ignored until cleared.
            _ => return,
        }
        let a = &mut self.axes[w.index()];
        a.input = sp.vel_radps;
        a.last_setpoint = Some(now);
    }
}
