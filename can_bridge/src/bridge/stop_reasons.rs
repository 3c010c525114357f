//! Why the robot may not move: the set of active stop reasons, the e-stop
//! latch, the command and its freshness, and the state they add up to.
//!
//! Rules:
//! * The e-stop is latched until a reset; latching it drops the command.
//! * A command older than `cmd_timeout` is `CommandTimeout`; a rejected one
//!   (NaN/inf) is `InvalidCommand` until the next valid command.
//! * Motion resumes only with a command received *after* the last instant
//!   any non-command reason held (`resume_after`), and after the last reset:
//!   an old command is never resumed, whatever stopped the robot.
//! * The state: `Estop` when latched; `Running` with no reason; `Idle` with
//!   only command reasons; `Starting` with only command and start-up
//!   reasons; else `Stopped`.

use crate::diagnostics::{BridgeEvent, BridgeState, StopReason};
use crate::kinematics::Twist;
use crate::time::Timestamp;
use std::time::Duration;

#[derive(Clone, Copy, Debug)]
struct StampedTwist {
    twist: Twist,
    received: Timestamp,
}

/// The reasons, the latch and the command.
#[derive(Debug)]
pub(crate) struct StopReasons {
    cmd_timeout: Duration,
    estop: bool,
    command: Option<StampedTwist>,
    last_command_invalid: bool,
    /// Commands received at or before this are never followed.
    resume_after: Option<Timestamp>,
    state: BridgeState,
    reasons: Vec<StopReason>,
}

impl StopReasons {
    /// Starting, no command; commands time out after `cmd_timeout`.
    pub(crate) fn new(cmd_timeout: Duration) -> Self {
        Self {
            cmd_timeout,
            estop: false,
            command: None,
            last_command_invalid: false,
            resume_after: None,
            state: BridgeState::Starting,
            reasons: Vec::new(),
        }
    }

    /// A valid (finite, already clamped) command received at `now`.
    pub(crate) fn accept(&mut self, twist: Twist, now: Timestamp) {
        self.last_command_invalid = false;
        self.command = Some(StampedTwist { twist, received: now });
    }

    /// An invalid command: zero until the next valid one.
    pub(crate) fn reject(&mut self) {
        self.command = None;
        self.last_command_invalid = true;
    }

    /// Drops the command (shutdown).
    pub(crate) fn drop_command(&mut self) {
        self.command = None;
    }

    /// Latches the e-stop and drops the command; true if it was not latched.
    pub(crate) fn latch_estop(&mut self) -> bool {
        let new = !self.estop;
        self.estop = true;
        self.command = None;
        new
    }

    /// Clears the e-stop; only a command received after `now` moves.
    pub(crate) fn reset(&mut self, now: Timestamp) {
        self.estop = false;
        self.command = None;
        self.last_command_invalid = false;
        self.resume_after = Some(now);
    }

    /// The e-stop is latched.
    pub(crate) fn estopped(&self) -> bool {
        self.estop
    }

    /// Recomputes the reasons from `faults` (the drive's and the bus's, in
    /// report order) and the command at `now`. Returns the event to report
    /// when the state or the reasons changed.
    pub(crate) fn update(&mut self, now: Timestamp, faults: Vec<StopReason>) -> Option<BridgeEvent> {
        let mut r = Vec::with_capacity(faults.len() + 2);
        if self.estop {
            r.push(StopReason::Estop);
        }
        r.extend(faults);
        if r.iter().any(|x| !x.is_command_reason()) {
            self.resume_after = Some(now);
        }
        match self.command {
            None if self.last_command_invalid => r.push(StopReason::InvalidCommand),
            None => r.push(StopReason::NoCommand),
            Some(c) if now - c.received > self.cmd_timeout => r.push(StopReason::CommandTimeout),
            Some(c) if self.resume_after.is_some_and(|t| c.received <= t) => r.push(StopReason::AwaitingFreshCommand),
            Some(_) => {}
        }
        let state = if self.estop {
            BridgeState::Estop
        } else if r.is_empty() {
            BridgeState::Running
        } else if r.iter().all(|x| x.is_command_reason()) {
            BridgeState::Idle
        } else if r.iter().all(|x| x.is_command_reason() || x.is_startup_reason()) {
            BridgeState::Starting
        } else {
            BridgeState::Stopped
        };
        if state == self.state && r == self.reasons {
            return None;
        }
        self.state = state;
        self.reasons = r.clone();
        Some(BridgeEvent::StateChanged { state, reasons: r })
    }

    /// The command to follow: only when no reason holds.
    pub(crate) fn following(&self) -> Option<Twist> {
        self.command.filter(|_| self.reasons.is_empty()).map(|c| c.twist)
    }

    /// The last accepted command, followed or not.
    pub(crate) fn command(&self) -> Option<Twist> {
        self.command.map(|c| c.twist)
    }

    /// The state at the last update.
    pub(crate) fn state(&self) -> BridgeState {
        self.state
    }

    /// The reasons at the last update (empty while running).
    pub(crate) fn reasons(&self) -> &[StopReason] {
        &self.reasons
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::Wheel;

    const TIMEOUT: Duration = Duration::from_millis(500);

    fn t(s: f64) -> Timestamp {
        Timestamp::from_secs_f64(s)
    }

    fn starting() -> Vec<StopReason> {
        vec![StopReason::DriveStarting]
    }

    fn fault() -> Vec<StopReason> {
        vec![StopReason::FeedbackLost { wheel: Wheel::Left }]
    }

    #[test]
    fn a_fresh_command_with_no_fault_runs() {
        let mut s = StopReasons::new(TIMEOUT);
        assert_eq!(s.state(), BridgeState::Starting);
        s.update(t(1.0), starting());
        assert_eq!(s.reasons(), [StopReason::DriveStarting, StopReason::NoCommand]);
        assert_eq!(s.state(), BridgeState::Starting);
        s.update(t(1.1), vec![]);
        assert_eq!(
            (s.state(), s.reasons()),
            (BridgeState::Idle, &[StopReason::NoCommand][..])
        );
        assert_eq!(s.following(), None);
        s.accept(Twist::new(0.2, 0.1), t(1.2));
        s.update(t(1.2), vec![]);
        assert_eq!(s.state(), BridgeState::Running);
        assert_eq!(s.following(), Some(Twist::new(0.2, 0.1)));
    }

    #[test]
    fn a_command_times_out_after_cmd_timeout_not_before() {
        let mut s = StopReasons::new(TIMEOUT);
        s.accept(Twist::new(0.2, 0.0), t(1.0));
        s.update(t(1.5), vec![]);
        assert!(s.reasons().is_empty(), "exactly cmd_timeout old: still fresh");
        s.update(t(1.501), vec![]);
        assert_eq!(s.reasons(), [StopReason::CommandTimeout]);
        assert_eq!((s.state(), s.following()), (BridgeState::Idle, None));
    }

    #[test]
    fn a_command_from_before_a_fault_is_never_resumed() {
        let mut s = StopReasons::new(Duration::from_secs(5));
        s.accept(Twist::new(0.2, 0.0), t(1.0));
        s.update(t(1.0), vec![]);
        assert!(s.following().is_some());
        s.update(t(1.5), fault());
        assert_eq!(s.state(), BridgeState::Stopped);
        assert_eq!(s.following(), None);
        // The fault is gone; the command is young but predates it.
        s.update(t(2.0), vec![]);
        assert_eq!(s.reasons(), [StopReason::AwaitingFreshCommand]);
        // Received at the very instant of the last fault: still too old.
        s.accept(Twist::new(0.2, 0.0), t(1.5));
        s.update(t(2.1), vec![]);
        assert_eq!(s.reasons(), [StopReason::AwaitingFreshCommand]);
        s.accept(Twist::new(0.1, 0.0), t(2.2));
        s.update(t(2.2), vec![]);
        assert_eq!(s.following(), Some(Twist::new(0.1, 0.0)));
    }

    #[test]
    fn start_up_reasons_also_need_a_fresh_command() {
        // Any non-command reason moves resume_after, a normal start-up too.
        let mut s = StopReasons::new(Duration::from_secs(5));
        s.accept(Twist::new(0.2, 0.0), t(1.0));
        s.update(t(1.1), starting());
        s.update(t(1.2), vec![]);
        assert_eq!(s.reasons(), [StopReason::AwaitingFreshCommand]);
    }

    #[test]
    fn estop_is_latched_until_reset_then_needs_a_fresh_command() {
        let mut s = StopReasons::new(Duration::from_secs(5));
        s.accept(Twist::new(0.2, 0.0), t(1.0));
        s.update(t(1.0), vec![]);
        assert!(s.latch_estop());
        assert!(!s.latch_estop(), "reported once");
        s.update(t(1.1), vec![]);
        assert_eq!(s.state(), BridgeState::Estop);
        assert_eq!(s.reasons()[0], StopReason::Estop);
        // Commands while latched are kept but not followed.
        s.accept(Twist::new(0.2, 0.0), t(1.2));
        s.update(t(1.3), vec![]);
        assert_eq!((s.state(), s.following()), (BridgeState::Estop, None));
        // Reset: the command given before it is dropped.
        s.reset(t(1.4));
        assert!(!s.estopped());
        s.update(t(1.4), vec![]);
        assert_eq!(s.reasons(), [StopReason::NoCommand]);
        s.accept(Twist::new(0.2, 0.0), t(1.4));
        s.update(t(1.5), vec![]);
        assert_eq!(s.reasons(), [StopReason::AwaitingFreshCommand], "at the reset instant");
        s.accept(Twist::new(0.2, 0.0), t(1.6));
        s.update(t(1.6), vec![]);
        assert_eq!(s.state(), BridgeState::Running);
    }

    #[test]
    fn a_rejected_command_is_reported_until_a_valid_one() {
        let mut s = StopReasons::new(TIMEOUT);
        s.accept(Twist::new(0.2, 0.0), t(1.0));
        s.reject();
        s.update(t(1.0), vec![]);
        assert_eq!(s.reasons(), [StopReason::InvalidCommand]);
        assert_eq!(s.command(), None);
        s.accept(Twist::new(0.1, 0.0), t(1.1));
        s.update(t(1.1), vec![]);
        assert!(s.reasons().is_empty());
    }

    #[test]
    fn states_follow_the_kind_of_reasons() {
        let mut s = StopReasons::new(TIMEOUT);
        let never = StopReason::NoHeartbeat {
            wheel: Wheel::Right,
            ever_seen: false,
        };
        let lost = StopReason::NoHeartbeat {
            wheel: Wheel::Right,
            ever_seen: true,
        };
        s.update(t(1.0), vec![never]);
        assert_eq!(s.state(), BridgeState::Starting, "never seen: a start-up");
        s.update(t(1.0), vec![lost.clone()]);
        assert_eq!(s.state(), BridgeState::Stopped, "seen, then silent: a fault");
        s.update(t(1.0), vec![StopReason::DriveStarting, lost]);
        assert_eq!(s.state(), BridgeState::Stopped, "one fault is enough");
    }

    #[test]
    fn a_change_is_reported_once() {
        let mut s = StopReasons::new(TIMEOUT);
        let e = s.update(t(1.0), vec![]);
        assert_eq!(
            e,
            Some(BridgeEvent::StateChanged {
                state: BridgeState::Idle,
                reasons: vec![StopReason::NoCommand]
            })
        );
        assert_eq!(s.update(t(1.1), vec![]), None, "same state and reasons");
        assert!(s.update(t(1.2), fault()).is_some(), "new reasons");
        assert!(
            s.update(t(1.3), vec![StopReason::FeedbackLost { wheel: Wheel::Right }])
                .is_some(),
            "same state, other reasons"
        );
    }
}
