//! Supervising the drive: its start-up, heartbeat and feedback watchdogs,
//! and latched faults.
//!
//! Rules:
//! * The start-up sequence is sent only once every drive sends fresh
//!   heartbeats and nothing blocks (e-stop, latched fault, bus fault or
//!   blocked tx). The drive is ready once every drive reports running,
//!   without error, in a status received *after* the start-up was sent
//!   (an older one may describe the drive before a reset).
//! * A drive error latches a fault until an explicit reset. At a
//!   start-up the error may be cleared instead: always after boot or a
//!   reset; after a communication loss only when every error says just that
//!   the drive's own command watchdog expired (the loss's consequence).
//! * A heartbeat that was fresh and times out while the bus is healthy, and
//!   was healthy within the last heartbeat timeout and a period, latches
//!   too (`HeartbeatLost`): a drive that went silent on a working bus is
//!   not trusted until an explicit reset.
//! * A drive that stops running without an error, a stale heartbeat, or a
//!   start-up not confirmed within `startup_timeout_s` take it down to be
//!   started again.

use super::events::EventLog;
use crate::config::TimingConfig;
use crate::diagnostics::{BridgeEvent, DriveLinkStatus, StopReason};
use crate::kinematics::Wheel;
use crate::protocol::Wheels;
use crate::time::{saturating_duration, Timestamp};
use std::time::Duration;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    /// Not started (boot, after a stop that needs a restart).
    Down,
    /// Start-up sequence sent at `since`.
    Starting { since: Timestamp },
    /// The drive reported running.
    Ready,
}

/// What the bridge last heard from one wheel's drive.
#[derive(Clone, Copy, Debug, Default)]
struct DriveLink {
    last_status: Option<Timestamp>,
    last_feedback: Option<Timestamp>,
    error_code: u32,
    running: bool,
    estopped: bool,
    raw_state: u8,
}

impl DriveLink {
    fn has_error(&self) -> bool {
        self.error_code != 0 || self.estopped
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct LatchedFault {
    wheel: Wheel,
    error_code: u32,
    drive_estopped: bool,
}

/// A drive's state as a status message reports it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct DriveState {
    /// Drive error bits; 0 = none.
    pub error_code: u32,
    /// Following velocity setpoints.
    pub running: bool,
    /// In its own e-stop.
    pub estopped: bool,
    /// The raw state value, for reports.
    pub raw_state: u8,
}

/// What stops the drive from being started, from outside its supervision.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Blockers {
    /// The e-stop is latched.
    pub estop: bool,
    /// A bus fault, or the transmit queue is blocked.
    pub bus_down: bool,
    /// The bus keeps the drive's frames from getting through (a fault, a
    /// blocked or a full queue): a heartbeat lost now is the bus's doing.
    pub bus_troubled: bool,
}

/// Start-up, watchdogs and latched faults of both wheels' drives.
#[derive(Debug)]
pub(crate) struct DriveSupervisor {
    heartbeat_timeout: Duration,
    feedback_timeout: Duration,
    startup_timeout: Duration,
    period: Duration,
    phase: Phase,
    links: [DriveLink; 2],
    latched_fault: Option<LatchedFault>,
    /// A drive's heartbeat timed out on a healthy bus (latched until reset).
    latched_silence: Option<Wheel>,
    /// Per wheel: the heartbeat was fresh at the last check (a timeout from
    /// there is a loss; never having had one is a start-up).
    heartbeat_was_fresh: [bool; 2],
    /// The next start-up may clear drive errors (true at boot and after reset).
    may_clear_drive_errors: bool,
    /// A communication loss (bus error, blocked tx, lost heartbeat) since the
    /// drive was last ready: a watchdog error from the drive is then expected.
    comm_lost: bool,
    /// Last update with the bus troubled.
    last_bus_trouble: Option<Timestamp>,
}

impl DriveSupervisor {
    /// Down, nothing heard; timeouts from `timing`, `period` = 1 / tx rate.
    pub(crate) fn new(timing: &TimingConfig, period: Duration) -> Self {
        Self {
            heartbeat_timeout: saturating_duration(timing.heartbeat_timeout_s),
            feedback_timeout: saturating_duration(timing.feedback_timeout_s),
            startup_timeout: saturating_duration(timing.startup_timeout_s),
            period,
            phase: Phase::Down,
            links: [DriveLink::default(); 2],
            latched_fault: None,
            latched_silence: None,
            heartbeat_was_fresh: [false; 2],
            may_clear_drive_errors: true,
            comm_lost: false,
            last_bus_trouble: None,
        }
    }

    /// A status for `wheels`; `live` if it proves the link (a heartbeat, not
    /// a state carried in a PDO).
    pub(crate) fn on_status(&mut self, wheels: Wheels, s: DriveState, live: bool, now: Timestamp) {
        for w in Wheel::BOTH {
            if wheels.covers(w) {
                let l = &mut self.links[w.index()];
                if live {
                    l.last_status = Some(now);
                }
                l.error_code = s.error_code;
                l.running = s.running;
                l.estopped = s.estopped;
                l.raw_state = s.raw_state;
            }
        }
    }

    /// Wheel feedback from `wheel`'s drive.
    pub(crate) fn on_feedback(&mut self, wheel: Wheel, now: Timestamp) {
        self.links[wheel.index()].last_feedback = Some(now);
    }

    /// Takes the drive down, to be started again (e-stop, shutdown, the bus back).
    pub(crate) fn stop(&mut self) {
        self.phase = Phase::Down;
    }

    /// Takes the drive down after a communication loss the bridge saw (bus
    /// fault, blocked tx): its watchdog error is then expected.
    pub(crate) fn lose_link(&mut self) {
        self.phase = Phase::Down;
        self.comm_lost = true;
    }

    /// Clears the latched faults; the next start-up may clear drive errors.
    pub(crate) fn reset(&mut self) {
        self.latched_fault = None;
        self.latched_silence = None;
        self.may_clear_drive_errors = true;
        self.phase = Phase::Down;
    }

    /// Advances to `now`. Returns true when the start-up sequence must be
    /// sent now (the phase is then `Starting` since `now`).
    pub(crate) fn update(
        &mut self,
        now: Timestamp,
        b: Blockers,
        is_watchdog_error: impl Fn(u32) -> bool,
        log: &mut EventLog,
    ) -> bool {
        self.watch_heartbeats(now, b.bus_troubled, log);
        let all_fresh = Wheel::BOTH.iter().all(|w| self.heartbeat_fresh(*w, now));
        match self.phase {
            Phase::Down => {
                let blocked = b.estop || self.latched() || b.bus_down;
                if blocked || !all_fresh {
                    return false;
                }
                if let Some(w) = self.erroring_wheel() {
                    let only_watchdog = self
                        .links
                        .iter()
                        .all(|l| !l.estopped && (l.error_code == 0 || is_watchdog_error(l.error_code)));
                    if !(self.may_clear_drive_errors || (self.comm_lost && only_watchdog)) {
                        self.latch_fault(w, now, log);
                        return false;
                    }
                }
                self.phase = Phase::Starting { since: now };
                true
            }
            Phase::Starting { since } => {
                let confirmed = self
                    .links
                    .iter()
                    .all(|l| l.running && !l.has_error() && l.last_status.is_some_and(|t| t > since));
                if !all_fresh {
                    self.lose_link();
                } else if confirmed {
                    self.phase = Phase::Ready;
                    self.may_clear_drive_errors = false;
                    self.comm_lost = false;
                    log.push(now, BridgeEvent::DriveReady);
                } else if now - since > self.startup_timeout {
                    if let Some(w) = self.erroring_wheel() {
                        self.latch_fault(w, now, log);
                    } else {
                        log.push(now, BridgeEvent::StartupTimeout);
                        self.phase = Phase::Down;
                    }
                }
                false
            }
            Phase::Ready => {
                if !all_fresh {
                    self.lose_link();
                } else if let Some(w) = self.erroring_wheel() {
                    self.latch_fault(w, now, log);
                } else if let Some(w) = Wheel::BOTH.into_iter().find(|w| !self.links[w.index()].running) {
                    log.push(now, BridgeEvent::DriveStoppedRunning { wheel: w });
                    self.phase = Phase::Down;
                }
                false
            }
        }
    }

    /// Latches a heartbeat that was fresh and timed out, unless the bus
    /// explains it (troubled now or within the last heartbeat timeout and a
    /// period: at the end of a blocked episode the bus is free again, but
    /// the drive's next heartbeat is still on its way).
    fn watch_heartbeats(&mut self, now: Timestamp, bus_troubled: bool, log: &mut EventLog) {
        if bus_troubled {
            self.last_bus_trouble = Some(now);
        }
        let window = self.heartbeat_timeout + self.period;
        let explained = self.last_bus_trouble.is_some_and(|t| now - t <= window);
        for w in Wheel::BOTH {
            let i = w.index();
            let fresh = self.heartbeat_fresh(w, now);
            let lost = self.heartbeat_was_fresh[i] && !fresh;
            self.heartbeat_was_fresh[i] = fresh;
            if lost && !explained && self.latched_silence.is_none() {
                self.latched_silence = Some(w);
                self.phase = Phase::Down;
                log.push(now, BridgeEvent::HeartbeatLostLatched { wheel: w });
            }
        }
    }

    fn latch_fault(&mut self, w: Wheel, now: Timestamp, log: &mut EventLog) {
        let l = self.links[w.index()];
        self.latched_fault = Some(LatchedFault {
            wheel: w,
            error_code: l.error_code,
            drive_estopped: l.estopped,
        });
        self.phase = Phase::Down;
        log.push(
            now,
            BridgeEvent::DriveFaultLatched {
                wheel: w,
                error_code: l.error_code,
                drive_estopped: l.estopped,
            },
        );
    }

    fn heartbeat_fresh(&self, w: Wheel, now: Timestamp) -> bool {
        self.links[w.index()]
            .last_status
            .is_some_and(|t| now - t <= self.heartbeat_timeout)
    }

    fn feedback_fresh(&self, w: Wheel, now: Timestamp) -> bool {
        self.links[w.index()]
            .last_feedback
            .is_some_and(|t| now - t <= self.feedback_timeout)
    }

    fn erroring_wheel(&self) -> Option<Wheel> {
        Wheel::BOTH.into_iter().find(|w| self.links[w.index()].has_error())
    }

    fn latched(&self) -> bool {
        self.latched_fault.is_some() || self.latched_silence.is_some()
    }

    /// The latched reasons: `DriveFault`, then `HeartbeatLost`.
    pub(crate) fn latched_reasons(&self, out: &mut Vec<StopReason>) {
        if let Some(f) = self.latched_fault {
            out.push(StopReason::DriveFault {
                wheel: f.wheel,
                error_code: f.error_code,
                drive_estopped: f.drive_estopped,
            });
        }
        if let Some(w) = self.latched_silence {
            out.push(StopReason::HeartbeatLost { wheel: w });
        }
    }

    /// The link reasons at `now`: `NoHeartbeat` per wheel, then
    /// `FeedbackLost` per wheel when ready, or `DriveStarting` when not (and
    /// nothing latched, `estop` included, explains the wait better).
    pub(crate) fn link_reasons(&self, now: Timestamp, estop: bool, out: &mut Vec<StopReason>) {
        for w in Wheel::BOTH {
            if !self.heartbeat_fresh(w, now) {
                out.push(StopReason::NoHeartbeat {
                    wheel: w,
                    ever_seen: self.links[w.index()].last_status.is_some(),
                });
            }
        }
        if self.phase == Phase::Ready {
            for w in Wheel::BOTH {
                if !self.feedback_fresh(w, now) {
                    out.push(StopReason::FeedbackLost { wheel: w });
                }
            }
        } else if !estop && !self.latched() {
            out.push(StopReason::DriveStarting);
        }
    }

    /// What was last heard from `w`'s drive, ages at `now`.
    pub(crate) fn link_status(&self, w: Wheel, now: Timestamp) -> DriveLinkStatus {
        let l = &self.links[w.index()];
        DriveLinkStatus {
            heartbeat_age_s: l.last_status.map(|t| (now - t).as_secs_f64()),
            feedback_age_s: l.last_feedback.map(|t| (now - t).as_secs_f64()),
            error_code: l.error_code,
            running: l.running,
            raw_state: l.raw_state,
        }
    }
}

#[cfg(test)]
#[path = "drive_supervision_tests.rs"]
mod tests;
