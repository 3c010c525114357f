//! The bus's health: error frames, failed sends and receives, a full
//! transmit queue, and when the bus counts as back.
//!
//! Rules:
//! * Fatal error frames (bus-off, no ACK, TX timeout, error passive) and
//!   I/O errors (interface down) are a bus fault: a stop reason, and a
//!   communication loss for the drive's supervisor.
//! * The bus is back on evidence of the fault's own kind: for an error
//!   frame, a restarted/error-active report or drive frames; for an I/O
//!   error, a frame sent or drive frames. The fault clears after
//!   `bus_recovery_s` of being back; another fatal error restarts that wait.
//! * Other error frames (lost arbitration, protocol errors, warning levels)
//!   are reported at most once per [`WARNING_REPORT_INTERVAL`].
//! * A full kernel queue starts an episode (reported once); the episode
//!   ends with the next frame sent. More than [`TX_BLOCKED_PERIODS`] tx
//!   periods of it without any frame out is `TxBlocked`.

use super::events::EventLog;
use crate::bus::{BusError, CanErrorFrame, ErrorSeverity};
use crate::diagnostics::{BridgeEvent, StopReason};
use crate::time::Timestamp;
use std::time::Duration;

/// Tx periods without any frame out before `TxBlocked`.
pub const TX_BLOCKED_PERIODS: u32 = 2;
/// Non-fatal error frames are reported at most this often (they are always counted).
pub const WARNING_REPORT_INTERVAL: Duration = Duration::from_secs(1);

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum FaultKind {
    /// From an error frame: back on a restart/active error frame or drive frames.
    ErrorFrame,
    /// A send or receive failed (e.g. interface down): back when I/O works again.
    Io,
}

#[derive(Clone, Debug)]
struct BusFault {
    kind: FaultKind,
    description: String,
    /// First evidence, after the last fatal error, that the bus carries frames again.
    back_since: Option<Timestamp>,
}

/// Error frames, I/O errors and the transmit queue, seen from the bridge.
#[derive(Debug)]
pub(crate) struct BusHealth {
    recovery: Duration,
    period: Duration,
    fault: Option<BusFault>,
    last_tx_ok: Timestamp,
    tx_blocked: bool,
    tx_full_episode: bool,
    last_warning_report: Option<Timestamp>,
}

impl BusHealth {
    /// Healthy at `now`; a fault clears after `recovery` of the bus being
    /// back; the tx period sets when a full queue is `TxBlocked`.
    pub(crate) fn new(recovery: Duration, period: Duration, now: Timestamp) -> Self {
        Self {
            recovery,
            period,
            fault: None,
            last_tx_ok: now,
            tx_blocked: false,
            tx_full_episode: false,
            last_warning_report: None,
        }
    }

    /// An error frame; true if it is fatal (the drive's link is lost).
    pub(crate) fn on_error_frame(&mut self, e: &CanErrorFrame, now: Timestamp, log: &mut EventLog) -> bool {
        let description = e.describe();
        match e.severity() {
            ErrorSeverity::Fatal => {
                log.push(
                    now,
                    BridgeEvent::BusError {
                        description: description.clone(),
                        fatal: true,
                    },
                );
                self.fault = Some(BusFault {
                    kind: FaultKind::ErrorFrame,
                    description,
                    back_since: None,
                });
                true
            }
            ErrorSeverity::Recovered => {
                log.push(
                    now,
                    BridgeEvent::BusError {
                        description,
                        fatal: false,
                    },
                );
                self.back(FaultKind::ErrorFrame, now);
                false
            }
            ErrorSeverity::Warning => {
                if self
                    .last_warning_report
                    .is_none_or(|t| now - t >= WARNING_REPORT_INTERVAL)
                {
                    self.last_warning_report = Some(now);
                    log.push(
                        now,
                        BridgeEvent::BusError {
                            description,
                            fatal: false,
                        },
                    );
                }
                false
            }
        }
    }

    /// A send or receive failed: always fatal (reported once per description).
    pub(crate) fn on_io_error(&mut self, e: BusError, now: Timestamp, log: &mut EventLog) {
        if self.fault.as_ref().is_none_or(|f| f.description != e.0) {
            log.push(
                now,
                BridgeEvent::BusError {
                    description: e.0.clone(),
                    fatal: true,
                },
            );
        }
        self.fault = Some(BusFault {
            kind: FaultKind::Io,
            description: e.0,
            back_since: None,
        });
    }

    /// A frame from the drive: evidence for both kinds of fault.
    pub(crate) fn on_drive_frame(&mut self, now: Timestamp) {
        self.back(FaultKind::ErrorFrame, now);
        self.back(FaultKind::Io, now);
    }

    /// What a flush of the transmit queue did: frames sent, a full queue seen.
    pub(crate) fn on_flush(&mut self, sent: u32, queue_full: bool, now: Timestamp, log: &mut EventLog) {
        if sent > 0 {
            self.last_tx_ok = now;
            self.tx_full_episode = false;
            self.back(FaultKind::Io, now);
        }
        if queue_full && !self.tx_full_episode {
            self.tx_full_episode = true;
            log.push(now, BridgeEvent::TxQueueFull);
        }
    }

    /// Re-evaluates `TxBlocked` after a flush; true when it has just begun
    /// (the drive's link is lost).
    pub(crate) fn update_blocked(&mut self, now: Timestamp) -> bool {
        let blocked = self.tx_full_episode && now - self.last_tx_ok > self.period * TX_BLOCKED_PERIODS;
        let began = blocked && !self.tx_blocked;
        self.tx_blocked = blocked;
        began
    }

    /// Clears a fault the bus has been back from for `recovery`; true if it
    /// did (the drive is then started again).
    pub(crate) fn update(&mut self, now: Timestamp, log: &mut EventLog) -> bool {
        let recovered = self
            .fault
            .as_ref()
            .is_some_and(|f| f.back_since.is_some_and(|b| now - b >= self.recovery));
        if recovered {
            self.fault = None;
            log.push(now, BridgeEvent::BusRecovered);
        }
        recovered
    }

    fn back(&mut self, kind: FaultKind, now: Timestamp) {
        if let Some(f) = &mut self.fault {
            if f.kind == kind && f.back_since.is_none() {
                f.back_since = Some(now);
            }
        }
    }

    /// A bus fault holds.
    pub(crate) fn faulted(&self) -> bool {
        self.fault.is_some()
    }

    /// `TxBlocked` holds.
    pub(crate) fn tx_blocked(&self) -> bool {
        self.tx_blocked
    }

    /// Anything that keeps the drive's frames from getting through now: a
    /// fault, a blocked or a full queue (a lost heartbeat is then the bus's doing).
    pub(crate) fn troubled(&self) -> bool {
        self.fault.is_some() || self.tx_blocked || self.tx_full_episode
    }

    /// `BusError`, then `TxBlocked`, when they hold.
    pub(crate) fn reasons(&self, out: &mut Vec<StopReason>) {
        if let Some(f) = &self.fault {
            out.push(StopReason::BusError {
                description: f.description.clone(),
            });
        }
        if self.tx_blocked {
            out.push(StopReason::TxBlocked);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bus::err;
    use crate::diagnostics::TimedEvent;

    const RECOVERY: Duration = Duration::from_millis(500);
    const PERIOD: Duration = Duration::from_millis(20);

    fn t(ms: u64) -> Timestamp {
        Timestamp::ZERO + Duration::from_millis(ms)
    }

    fn health() -> (BusHealth, EventLog) {
        (BusHealth::new(RECOVERY, PERIOD, t(0)), EventLog::new())
    }

    fn events(log: &mut EventLog) -> Vec<BridgeEvent> {
        log.drain().into_iter().map(|e: TimedEvent| e.event).collect()
    }

    fn names(h: &BusHealth) -> Vec<&'static str> {
        let mut r = Vec::new();
        h.reasons(&mut r);
        r.iter().map(StopReason::name).collect()
    }

    #[test]
    fn bus_off_holds_until_the_bus_is_back_and_quiet() {
        let (mut h, mut log) = health();
        assert!(h.on_error_frame(&CanErrorFrame::bus_off(), t(0), &mut log));
        assert_eq!(names(&h), ["bus_error"]);
        assert!(!h.update(t(5000), &mut log), "no evidence: never back by itself");
        // A frame sent is not evidence against an error frame: the controller
        // may queue it without ever getting it on the wire.
        h.on_flush(1, false, t(5000), &mut log);
        assert!(!h.update(t(6000), &mut log));
        assert!(!h.on_error_frame(&CanErrorFrame::restarted(), t(6000), &mut log));
        assert!(!h.update(t(6499), &mut log), "within bus_recovery_s");
        assert!(h.update(t(6500), &mut log));
        assert!(names(&h).is_empty());
        let ev = events(&mut log);
        assert!(matches!(&ev[0], BridgeEvent::BusError { fatal: true, description } if description == "bus-off"));
        assert_eq!(ev.last(), Some(&BridgeEvent::BusRecovered));
    }

    #[test]
    fn drive_frames_are_evidence_for_either_kind() {
        let (mut h, mut log) = health();
        h.on_error_frame(&CanErrorFrame::bus_off(), t(0), &mut log);
        h.on_drive_frame(t(100));
        assert!(h.update(t(600), &mut log));
        h.on_io_error(BusError("down".into()), t(700), &mut log);
        h.on_drive_frame(t(800));
        assert!(h.update(t(1300), &mut log));
    }

    #[test]
    fn a_fatal_error_restarts_the_quiet_time() {
        let (mut h, mut log) = health();
        h.on_error_frame(&CanErrorFrame::bus_off(), t(0), &mut log);
        h.on_drive_frame(t(100));
        let passive = CanErrorFrame {
            class: err::CRTL,
            data: [0, err::CRTL_TX_PASSIVE, 0, 0, 0, 0, 0, 0],
        };
        assert!(h.on_error_frame(&passive, t(400), &mut log));
        assert!(!h.update(t(700), &mut log), "back_since was reset by error passive");
        h.on_drive_frame(t(700));
        assert!(!h.update(t(1199), &mut log));
        assert!(h.update(t(1200), &mut log));
    }

    #[test]
    fn an_io_fault_is_back_when_a_frame_goes_out() {
        let (mut h, mut log) = health();
        h.on_io_error(BusError("Network is down".into()), t(0), &mut log);
        h.on_io_error(BusError("Network is down".into()), t(10), &mut log);
        assert_eq!(events(&mut log).len(), 1, "the same error is reported once");
        assert_eq!(names(&h), ["bus_error"]);
        h.on_flush(0, false, t(20), &mut log);
        assert!(!h.update(t(1000), &mut log), "nothing sent: not back");
        h.on_flush(2, false, t(1000), &mut log);
        assert!(h.update(t(1500), &mut log));
    }

    #[test]
    fn warnings_are_rate_limited_and_never_stop() {
        let (mut h, mut log) = health();
        let warn = CanErrorFrame {
            class: err::LOSTARB | err::PROT,
            data: [0; 8],
        };
        for ms in (0..2000).step_by(20) {
            assert!(!h.on_error_frame(&warn, t(ms), &mut log));
        }
        assert!(names(&h).is_empty());
        assert_eq!(events(&mut log).len(), 2, "one per second over 2 s");
    }

    #[test]
    fn a_full_queue_is_tx_blocked_after_two_periods_without_a_frame_out() {
        let (mut h, mut log) = health();
        h.on_flush(2, false, t(100), &mut log);
        h.on_flush(0, true, t(110), &mut log);
        assert!(h.troubled(), "a full queue is trouble at once");
        assert!(!h.update_blocked(t(140)), "exactly two periods: not yet");
        assert!(h.update_blocked(t(141)), "begins");
        assert!(!h.update_blocked(t(160)), "reported as beginning once");
        assert_eq!(names(&h), ["tx_blocked"]);
        h.on_flush(0, true, t(170), &mut log);
        assert_eq!(events(&mut log), [BridgeEvent::TxQueueFull], "one episode, one report");
        h.on_flush(1, false, t(180), &mut log);
        assert!(!h.update_blocked(t(180)));
        assert!(names(&h).is_empty() && !h.troubled());
    }
}
