//! What comes in: drive frames, error frames and failed receives, each
//! handed to the part it concerns (drive supervision, bus health, odometry).

use super::drive_supervision::DriveState;
use super::{Bridge, MAX_EVENTS_PER_POLL};
use crate::bus::{BusError, BusEvent, CanBus};
use crate::diagnostics::BridgeEvent;
use crate::protocol::DriveMessage;
use crate::time::Timestamp;
use std::time::Duration;

impl<B: CanBus> Bridge<B> {
    /// Handles everything already received, without waiting.
    pub fn poll_bus(&mut self, now: Timestamp) {
        for _ in 0..MAX_EVENTS_PER_POLL {
            match self.bus.recv(Duration::ZERO) {
                Ok(Some(ev)) => self.handle_bus_event(ev, now),
                Ok(None) => break,
                Err(e) => {
                    self.io_fault(e, now);
                    break;
                }
            }
        }
    }

    /// One received frame or error frame.
    pub fn handle_bus_event(&mut self, ev: BusEvent, now: Timestamp) {
        match ev {
            BusEvent::Frame(f) => {
                self.counters.rx_frames += 1;
                match self.protocol.decode(&f) {
                    Ok(Some(msg)) => {
                        self.bus_health.on_drive_frame(now);
                        self.on_drive_message(msg, now);
                    }
                    Ok(None) => self.counters.rx_ignored += 1,
                    Err(e) => {
                        self.counters.rx_invalid += 1;
                        self.events.push(now, BridgeEvent::RxInvalid { error: e.to_string() });
                    }
                }
            }
            BusEvent::Error(e) => {
                self.counters.error_frames += 1;
                if self.bus_health.on_error_frame(&e, now, &mut self.events) {
                    self.drive.lose_link();
                }
            }
        }
    }

    pub(super) fn io_fault(&mut self, e: BusError, now: Timestamp) {
        self.counters.tx_errors += 1;
        self.bus_health.on_io_error(e, now, &mut self.events);
        self.drive.lose_link();
    }

    fn on_drive_message(&mut self, msg: DriveMessage, now: Timestamp) {
        let (wheels, error_code, running, estopped, raw_state, live) = match msg {
            DriveMessage::Status {
                wheels,
                error_code,
                running,
                estopped,
                raw_state,
            } => (wheels, error_code, running, estopped, raw_state, true),
            DriveMessage::State {
                wheels,
                error_code,
                running,
                estopped,
                raw_state,
            } => (wheels, error_code, running, estopped, raw_state, false),
            DriveMessage::Feedback {
                wheel,
                motor_pos_rad,
                motor_vel_radps,
            } => {
                self.drive.on_feedback(wheel, now);
                let resets = self.odom.state().resets;
                self.odom.on_feedback(wheel, motor_pos_rad, motor_vel_radps, now);
                if self.odom.state().resets != resets {
                    self.events.push(now, BridgeEvent::OdometryReset);
                }
                return;
            }
            DriveMessage::Heartbeat { axes } => {
                for w in crate::kinematics::Wheel::BOTH {
                    if let Some(a) = axes[w.index()] {
                        let state = DriveState {
                            error_code: a.error_code,
                            running: a.running,
                            estopped: a.estopped,
                            raw_state: a.raw_state,
                        };
                        self.drive.on_status(crate::protocol::Wheels::One(w), state, true, now);
                    }
                }
                return;
            }
            DriveMessage::Handled { .. } => return,
        };
        let state = DriveState {
            error_code,
            running,
            estopped,
            raw_state,
        };
        self.drive.on_status(wheels, state, live, now);
    }
}
