//! What goes out: the start-up sequence, the protocol's own frames, and
//! each period's setpoints (ramped; zero at once for any stop), through the
//! bounded transmit queue, whose results feed the bus's health.

use super::Bridge;
use crate::bus::CanBus;
use crate::diagnostics::BridgeEvent;
use crate::kinematics::{MotorSpeeds, WheelSpeeds};
use crate::limits::saturate_wheels;
use crate::protocol::{ProtocolReport, SetpointMode};
use crate::time::Timestamp;
use crate::tx_queue::{PushReport, TxKind};

/// Finished SDO requests kept until taken.
const MAX_SDO_RESULTS: usize = 64;

impl<B: CanBus> Bridge<B> {
    /// Queues the protocol's start-up sequence; the drive restarts from
    /// standstill, so does the ramp.
    pub(super) fn send_startup(&mut self, now: Timestamp) {
        self.batch.clear();
        self.protocol.startup(&mut self.batch);
        let r = self.tx.push(self.batch.as_slice(), TxKind::Control, now);
        self.count_push(r, now);
        self.limiter.reset_to_zero();
        self.events.push(now, BridgeEvent::StartupSent);
    }

    /// The protocol's own frames (CiA 402 SDO start-up, heartbeat) and reports.
    pub(super) fn poll_protocol(&mut self, now: Timestamp) {
        self.batch.clear();
        self.protocol.poll(now, &mut self.batch);
        if !self.batch.is_empty() {
            let r = self.tx.push(self.batch.as_slice(), TxKind::Control, now);
            self.count_push(r, now);
        }
        let mut reports = Vec::new();
        self.protocol.drain_reports(&mut reports);
        for ProtocolReport { wheel, message } in reports {
            self.events.push(now, BridgeEvent::DriveReport { wheel, message });
        }
        let mut done = Vec::new();
        self.protocol.drain_sdo_results(&mut done);
        for r in done {
            self.events.push(
                now,
                BridgeEvent::SdoDone {
                    id: r.id,
                    node: r.node,
                    index: r.index,
                    sub: r.sub,
                    write: r.write,
                    ok: r.ok,
                    abort_code: r.abort_code,
                    message: r.message.clone(),
                },
            );
            // Bounded: results nobody takes cannot grow memory.
            if self.sdo_results.len() < MAX_SDO_RESULTS {
                self.sdo_results.push(r);
            }
        }
    }

    /// Queues this period's setpoints (the previous period's, if still
    /// waiting, are dropped as stale).
    pub(super) fn transmit_setpoints(&mut self, now: Timestamp) {
        self.counters.tx_periods += 1;
        let (mode, motors) = if self.stops.estopped() {
            (SetpointMode::Estop, MotorSpeeds::ZERO)
        } else if let Some(twist) = self.stops.following() {
            let l = &self.cfg.limits;
            let target = self.kin.wheel_speeds(twist);
            let (target, _) = saturate_wheels(target, l.max_wheel_speed_radps);
            let dt = self.period.as_secs_f64();
            let wheels = self
                .limiter
                .step(target, dt, l.wheel_accel_radps2, l.wheel_decel_radps2);
            // Belt and braces: the limiter's output is finite and within limits.
            let (wheels, _) = saturate_wheels(wheels, l.max_wheel_speed_radps);
            self.last_wheels = wheels;
            (SetpointMode::Run, self.kin.to_motor(wheels))
        } else {
            (SetpointMode::Hold, MotorSpeeds::ZERO)
        };
        if mode != SetpointMode::Run {
            self.limiter.reset_to_zero();
            self.last_wheels = WheelSpeeds::ZERO;
        }
        self.last_motors = motors;
        self.batch.clear();
        self.protocol.setpoints(motors, mode, &mut self.batch);
        let r = self.tx.push(self.batch.as_slice(), TxKind::Setpoint, now);
        self.count_push(r, now);
    }

    fn count_push(&mut self, r: PushReport, now: Timestamp) {
        let stale = r.dropped_stale + r.dropped_overflow;
        if stale > 0 {
            self.counters.tx_dropped_stale += u64::from(stale);
            let after_retries = 0;
            self.events.push(now, BridgeEvent::TxDropped { stale, after_retries });
        }
    }

    pub(super) fn flush(&mut self, now: Timestamp) {
        let r = self.tx.flush(&mut self.bus, now);
        self.counters.tx_frames += u64::from(r.sent);
        if r.queue_full {
            self.counters.tx_queue_full += 1;
        }
        self.bus_health.on_flush(r.sent, r.queue_full, now, &mut self.events);
        if r.dropped_after_retries > 0 {
            let after_retries = r.dropped_after_retries;
            self.counters.tx_dropped_after_retries += u64::from(after_retries);
            self.events.push(
                now,
                BridgeEvent::TxDropped {
                    stale: 0,
                    after_retries,
                },
            );
        }
        if let Some(e) = r.failed {
            self.io_fault(e, now);
        }
        if self.bus_health.update_blocked(now) {
            self.drive.lose_link();
        }
    }
}
