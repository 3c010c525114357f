//! The bridge state machine: commands in, periodic setpoint frames out,
//! drive state and feedback back in.
//!
//! Rules (each has a unit test with a [`FakeBus`](crate::fake_bus::FakeBus)):
//!
//! * Setpoints go out every 1/tx_rate_hz on a fixed grid, whatever the
//!   command rate. A late loop skips grid points instead of bursting.
//! * A command older than cmd_timeout_s gives zero setpoints. Motion resumes
//!   only with a command received after the last moment the bridge was
//!   stopped for any non-command reason (`resume_after`): an old command is
//!   never resumed, after a timeout, a fault, a bus error or an e-stop.
//! * NaN/inf commands are rejected: the current command is dropped (zero)
//!   and the rejection is reported. v and ω beyond v_max/ω_max are scaled
//!   down together (curvature kept) and reported.
//! * E-stop is latched: e-stop frames every period until [`Bridge::reset`],
//!   and then a fresh command is needed.
//! * The drive is started (protocol start-up sequence) only once every
//!   drive sends fresh heartbeats; commands are followed only once it
//!   reports running. Heartbeat or feedback older than their timeouts stop
//!   the robot. A drive error latches a fault until reset. A heartbeat that
//!   was fresh and times out while the bus is healthy (no bus fault, tx not
//!   blocked) latches too (`HeartbeatLost`): a drive that went silent is
//!   not trusted again until an explicit reset, and then a fresh command.
//!   A drive that stops running without an error is restarted. After a
//!   communication loss explained by the bus (bus error, blocked tx), a
//!   drive that now reports an error is latched, unless the error only says
//!   that its own command watchdog expired (the consequence of the loss):
//!   the restart clears that one. Other errors are cleared only by the
//!   start-up after boot or an explicit reset.
//! * Error frames: fatal ones (bus-off, no ACK, TX timeout, error passive)
//!   and I/O errors stop the robot until the bus is back (restart/active
//!   error frame, drive frames, or a send that works) and quiet for
//!   bus_recovery_s; then the drive is started again.
//! * A full kernel queue (ENOBUFS) is retried a bounded number of times;
//!   stale setpoints are dropped ([`TxQueue`]). More than two tx periods
//!   without any frame out stops the robot (`TxBlocked`).
//! * Stops are immediate (zero, not ramped); accel/decel limits shape
//!   commanded motion only. Every setpoint is finite and within limits.

use crate::bus::{BusError, BusEvent, CanBus, CanErrorFrame, ErrorSeverity};
use crate::config::{BridgeConfig, ParamError, Validate};
use crate::diagnostics::{BridgeEvent, BridgeState, BridgeStatus, Counters, DriveLinkStatus, StopReason, TimedEvent};
use crate::kinematics::{DiffDrive, MotorSpeeds, Twist, Wheel, WheelSpeeds};
use crate::limits::{clamp_twist, saturate_wheels, RampLimiter};
use crate::odometry::Odometry;
use crate::protocol::{DriveMessage, FrameBatch, Protocol, ProtocolReport, SetpointMode};
use crate::time::{Clock, Timestamp};
use crate::tx_queue::{TxKind, TxQueue};
use std::collections::VecDeque;
use std::time::Duration;

/// Events kept for [`Bridge::drain_events`]; older ones are dropped (counted).
pub const EVENT_QUEUE_CAPACITY: usize = 1024;
/// Bus events handled per [`Bridge::poll_bus`] call, so a flooding bus cannot starve transmission.
pub const MAX_EVENTS_PER_POLL: usize = 256;
/// Tx periods without any frame out before `TxBlocked`.
pub const TX_BLOCKED_PERIODS: u32 = 2;
/// Non-fatal error frames are reported at most this often (they are always counted).
pub const WARNING_REPORT_INTERVAL: Duration = Duration::from_secs(1);

/// Why a bridge could not be built.
#[derive(Debug, thiserror::Error)]
pub enum BridgeError {
    #[error("invalid configuration: {}", .0.iter().map(|e| e.to_string()).collect::<Vec<_>>().join("; "))]
    Config(Vec<ParamError>),
    #[error("cannot set the CAN receive filters: {0}")]
    Bus(#[from] BusError),
}

/// Why a command was not accepted.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CommandError {
    #[error("command has a NaN or infinite component; sending zero")]
    NonFinite,
}

#[derive(Clone, Copy, Debug)]
struct StampedTwist {
    twist: Twist,
    received: Timestamp,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    /// Not started (boot, after a stop that needs a restart).
    Down,
    /// Start-up sequence sent at `since`.
    Starting { since: Timestamp },
    /// The drive reported running.
    Ready,
}

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

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum BusFaultKind {
    /// From an error frame: the bus is back on a restart/active error frame or drive frames.
    ErrorFrame,
    /// A send or receive failed (e.g. interface down): back when I/O works again.
    Io,
}

#[derive(Clone, Debug)]
struct BusFault {
    kind: BusFaultKind,
    description: String,
    /// First evidence, after the last fatal error, that the bus carries frames again.
    back_since: Option<Timestamp>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct LatchedFault {
    wheel: Wheel,
    error_code: u32,
    drive_estopped: bool,
}

/// Twist in, CAN frames out. Owns the bus; time comes in as `now`.
pub struct Bridge<B: CanBus> {
    cfg: BridgeConfig,
    kin: DiffDrive,
    period: Duration,
    bus: B,
    protocol: Box<dyn Protocol>,
    limiter: RampLimiter,
    odom: Odometry,
    tx: TxQueue,
    batch: FrameBatch,
    next_tx: Timestamp,

    command: Option<StampedTwist>,
    last_command_invalid: bool,
    clamping: bool,
    /// Commands received at or before this are never followed.
    resume_after: Option<Timestamp>,

    estop: bool,
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
    phase: Phase,
    links: [DriveLink; 2],
    bus_fault: Option<BusFault>,
    last_tx_ok: Timestamp,
    tx_blocked: bool,
    tx_full_episode: bool,
    /// Last tick with a bus fault or a full tx queue: a heartbeat lost within
    /// one heartbeat timeout of it is the bus's doing (the drive's frames were
    /// blocked too), not a drive fault, and is not latched.
    last_bus_trouble: Option<Timestamp>,
    last_warning_report: Option<Timestamp>,

    state: BridgeState,
    reasons: Vec<StopReason>,
    last_wheels: WheelSpeeds,
    last_motors: MotorSpeeds,
    counters: Counters,
    events: VecDeque<TimedEvent>,
    now: Timestamp,
}

impl<B: CanBus> Bridge<B> {
    /// A bridge on `bus` for a validated configuration. Sets the bus's
    /// receive filters to the drive's ids; the first setpoints go out at `now`.
    pub fn new(cfg: BridgeConfig, mut bus: B, now: Timestamp) -> Result<Self, BridgeError> {
        cfg.validate().map_err(BridgeError::Config)?;
        let protocol = cfg.make_protocol();
        bus.set_rx_filters(&protocol.rx_filters())?;
        let kin = cfg.diff_drive();
        let odom = Odometry::new(kin, protocol.position_modulus_rad(), cfg.limits.max_wheel_speed_radps);
        let mut b = Self {
            kin,
            period: cfg.tx_period(),
            bus,
            protocol,
            limiter: RampLimiter::new(),
            odom,
            tx: TxQueue::new(),
            batch: FrameBatch::new(),
            next_tx: now,
            command: None,
            last_command_invalid: false,
            clamping: false,
            resume_after: None,
            estop: false,
            latched_fault: None,
            latched_silence: None,
            heartbeat_was_fresh: [false; 2],
            may_clear_drive_errors: true,
            comm_lost: false,
            phase: Phase::Down,
            links: [DriveLink::default(); 2],
            bus_fault: None,
            last_tx_ok: now,
            tx_blocked: false,
            tx_full_episode: false,
            last_bus_trouble: None,
            last_warning_report: None,
            state: BridgeState::Starting,
            reasons: Vec::new(),
            last_wheels: WheelSpeeds::ZERO,
            last_motors: MotorSpeeds::ZERO,
            counters: Counters::default(),
            events: VecDeque::new(),
            now,
            cfg,
        };
        b.update_reasons(now);
        Ok(b)
    }

    /// The configuration in use.
    pub fn config(&self) -> &BridgeConfig {
        &self.cfg
    }

    /// The bus (e.g. a FakeBus handle in tests).
    pub fn bus(&self) -> &B {
        &self.bus
    }

    /// A new velocity command, received at `now`. Non-finite → rejected:
    /// the bridge sends zero until the next valid command.
    pub fn command(&mut self, twist: Twist, now: Timestamp) -> Result<(), CommandError> {
        self.counters.commands += 1;
        if !twist.is_finite() {
            self.counters.commands_rejected += 1;
            self.command = None;
            self.last_command_invalid = true;
            self.push_event(
                now,
                BridgeEvent::CommandRejected {
                    linear_mps: twist.linear_mps,
                    angular_radps: twist.angular_radps,
                },
            );
            return Err(CommandError::NonFinite);
        }
        let l = &self.cfg.limits;
        let (clamped, was_clamped) = clamp_twist(twist, l.v_max_mps, l.omega_max_radps);
        if was_clamped {
            self.counters.commands_clamped += 1;
            if !self.clamping {
                self.push_event(
                    now,
                    BridgeEvent::CommandClamped {
                        requested: twist,
                        clamped,
                    },
                );
            }
        }
        self.clamping = was_clamped;
        self.last_command_invalid = false;
        self.command = Some(StampedTwist {
            twist: clamped,
            received: now,
        });
        Ok(())
    }

    /// Latches the e-stop and sends e-stop frames at once (and every period
    /// until [`reset`](Self::reset)).
    pub fn estop(&mut self, now: Timestamp) {
        let new = !self.estop;
        self.estop = true;
        self.command = None;
        self.phase = Phase::Down;
        self.limiter.reset_to_zero();
        self.tx.clear();
        self.update_reasons(now);
        self.transmit_setpoints(now);
        self.flush(now);
        // Reported after the frames are out: logging may be slow (a serial console).
        if new {
            self.push_event(now, BridgeEvent::EstopLatched);
        }
    }

    /// Clears the e-stop latch and latched drive faults (errors, lost
    /// heartbeats). The drive is started again (clearing its errors) and a
    /// command received after this call is needed to move.
    pub fn reset(&mut self, now: Timestamp) {
        self.estop = false;
        self.latched_fault = None;
        self.latched_silence = None;
        self.may_clear_drive_errors = true;
        self.command = None;
        self.last_command_invalid = false;
        self.resume_after = Some(now);
        self.phase = Phase::Down;
        self.limiter.reset_to_zero();
        self.push_event(now, BridgeEvent::Reset);
        self.update_reasons(now);
    }

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
                        self.bus_traffic_seen(BusFaultKind::ErrorFrame, now);
                        self.bus_traffic_seen(BusFaultKind::Io, now);
                        self.on_drive_message(msg, now);
                    }
                    Ok(None) => self.counters.rx_ignored += 1,
                    Err(e) => {
                        self.counters.rx_invalid += 1;
                        self.push_event(now, BridgeEvent::RxInvalid { error: e.to_string() });
                    }
                }
            }
            BusEvent::Error(e) => self.on_error_frame(e, now),
        }
    }

    /// Advances timeouts, transmits when a period is due, retries queued frames.
    pub fn tick(&mut self, now: Timestamp) {
        self.now = now;
        self.update_bus_fault(now);
        self.update_phase(now);
        self.poll_protocol(now);
        self.update_reasons(now);
        if now >= self.next_tx {
            self.transmit_setpoints(now);
            // Next grid point after now: a late loop skips, never bursts.
            let late = now - self.next_tx;
            let skip = (late.as_nanos() / self.period.as_nanos().max(1)) as u32;
            self.next_tx = self.next_tx + self.period * (skip + 1);
        }
        self.flush(now);
    }

    /// When [`tick`](Self::tick) next has work: the next period or a retry.
    pub fn next_deadline(&self) -> Timestamp {
        match self.tx.next_attempt() {
            Some(t) => t.min(self.next_tx),
            None => self.next_tx,
        }
    }

    /// Real-time loop step: tick, wait for one bus event until the next
    /// deadline (at most `max_wait`), handle it, tick again.
    pub fn spin_once(&mut self, clock: &dyn Clock, max_wait: Duration) {
        let now = clock.now();
        self.tick(now);
        let deadline = self.next_deadline().min(now + max_wait);
        let wait = deadline - clock.now();
        match self.bus.recv(wait) {
            Ok(Some(ev)) => {
                self.handle_bus_event(ev, clock.now());
                self.poll_bus(clock.now());
            }
            Ok(None) => {}
            Err(e) => {
                self.io_fault(e, clock.now());
                // An interface that is down fails at once: do not spin.
                std::thread::sleep(wait.min(Duration::from_millis(5)));
            }
        }
        self.tick(clock.now());
    }

    /// Stops the drive for good: zero, then disable. Each frame is tried a
    /// few times; returns how many could not be sent.
    pub fn shutdown(&mut self, now: Timestamp) -> usize {
        self.tx.clear();
        self.command = None;
        self.batch.clear();
        self.protocol.shutdown(&mut self.batch);
        let mut failed = 0;
        for f in self.batch.as_slice() {
            let ok = (0..crate::tx_queue::TX_MAX_ATTEMPTS).any(|attempt| {
                if attempt > 0 {
                    std::thread::sleep(crate::tx_queue::TX_RETRY_INTERVAL);
                }
                self.bus.send(f).is_ok()
            });
            if ok {
                self.counters.tx_frames += 1;
            } else {
                failed += 1;
            }
        }
        self.phase = Phase::Down;
        self.last_wheels = WheelSpeeds::ZERO;
        self.last_motors = MotorSpeeds::ZERO;
        self.now = now;
        failed
    }

    /// The current state.
    pub fn state(&self) -> BridgeState {
        self.state
    }

    /// Why the setpoints are zero (empty while running).
    pub fn reasons(&self) -> &[StopReason] {
        &self.reasons
    }

    /// Counters since start.
    pub fn counters(&self) -> Counters {
        self.counters
    }

    /// The last transmitted setpoint, at the wheels.
    pub fn last_setpoint(&self) -> WheelSpeeds {
        self.last_wheels
    }

    /// Odometry from wheel feedback.
    pub fn odometry(&self) -> crate::odometry::OdometryState {
        self.odom.state()
    }

    /// Takes the events since the last call, oldest first.
    pub fn drain_events(&mut self) -> Vec<TimedEvent> {
        self.events.drain(..).collect()
    }

    /// A full snapshot at `now`.
    pub fn status(&self, now: Timestamp) -> BridgeStatus {
        let link = |w: Wheel| {
            let l = &self.links[w.index()];
            DriveLinkStatus {
                heartbeat_age_s: l.last_status.map(|t| (now - t).as_secs_f64()),
                feedback_age_s: l.last_feedback.map(|t| (now - t).as_secs_f64()),
                error_code: l.error_code,
                running: l.running,
                raw_state: l.raw_state,
            }
        };
        BridgeStatus {
            t_s: now.as_secs_f64(),
            state: self.state,
            reasons: self.reasons.clone(),
            command: self.command.map(|c| c.twist),
            setpoint_wheels: self.last_wheels,
            setpoint_motors: self.last_motors,
            odometry: self.odom.state(),
            left: link(Wheel::Left),
            right: link(Wheel::Right),
            counters: self.counters,
        }
    }

    // ----------------------------------------------------------------- internals

    fn push_event(&mut self, now: Timestamp, event: BridgeEvent) {
        match &event {
            BridgeEvent::StateChanged { .. } | BridgeEvent::RxInvalid { .. } | BridgeEvent::TxDropped { .. } => {
                log::debug!("{event:?}")
            }
            BridgeEvent::CommandRejected { .. }
            | BridgeEvent::DriveFaultLatched { .. }
            | BridgeEvent::HeartbeatLostLatched { .. }
            | BridgeEvent::BusError { .. }
            | BridgeEvent::EstopLatched
            | BridgeEvent::DriveReport { .. }
            | BridgeEvent::TxQueueFull => log::warn!("{event:?}"),
            _ => log::info!("{event:?}"),
        }
        if self.events.len() >= EVENT_QUEUE_CAPACITY {
            self.events.pop_front();
            self.counters.events_dropped += 1;
        }
        self.events.push_back(TimedEvent {
            t_s: now.as_secs_f64(),
            event,
        });
    }

    /// The protocol's own frames (CiA 402 SDO start-up, heartbeat) and reports.
    fn poll_protocol(&mut self, now: Timestamp) {
        self.batch.clear();
        self.protocol.poll(now, &mut self.batch);
        if !self.batch.is_empty() {
            let r = self.tx.push(self.batch.as_slice(), TxKind::Control, now);
            self.count_push(r, now);
        }
        let mut reports = Vec::new();
        self.protocol.drain_reports(&mut reports);
        for ProtocolReport { wheel, message } in reports {
            self.push_event(now, BridgeEvent::DriveReport { wheel, message });
        }
    }

    fn on_drive_message(&mut self, msg: DriveMessage, now: Timestamp) {
        match msg {
            DriveMessage::Status {
                wheels,
                error_code,
                running,
                estopped,
                raw_state,
            }
            | DriveMessage::State {
                wheels,
                error_code,
                running,
                estopped,
                raw_state,
            } => {
                let live = matches!(msg, DriveMessage::Status { .. });
                for w in Wheel::BOTH {
                    if wheels.covers(w) {
                        let l = &mut self.links[w.index()];
                        if live {
                            l.last_status = Some(now);
                        }
                        l.error_code = error_code;
                        l.running = running;
                        l.estopped = estopped;
                        l.raw_state = raw_state;
                    }
                }
            }
            DriveMessage::Feedback {
                wheel,
                motor_pos_rad,
                motor_vel_radps,
            } => {
                self.links[wheel.index()].last_feedback = Some(now);
                let resets = self.odom.state().resets;
                self.odom.on_feedback(wheel, motor_pos_rad, motor_vel_radps, now);
                if self.odom.state().resets != resets {
                    self.push_event(now, BridgeEvent::OdometryReset);
                }
            }
            DriveMessage::Handled { .. } => {}
        }
    }

    fn on_error_frame(&mut self, e: CanErrorFrame, now: Timestamp) {
        self.counters.error_frames += 1;
        let description = e.describe();
        match e.severity() {
            ErrorSeverity::Fatal => {
                self.push_event(
                    now,
                    BridgeEvent::BusError {
                        description: description.clone(),
                        fatal: true,
                    },
                );
                self.bus_fault = Some(BusFault {
                    kind: BusFaultKind::ErrorFrame,
                    description,
                    back_since: None,
                });
                self.phase = Phase::Down;
                self.comm_lost = true;
            }
            ErrorSeverity::Recovered => {
                self.push_event(
                    now,
                    BridgeEvent::BusError {
                        description,
                        fatal: false,
                    },
                );
                self.bus_traffic_seen(BusFaultKind::ErrorFrame, now);
            }
            ErrorSeverity::Warning => {
                let due = self
                    .last_warning_report
                    .is_none_or(|t| now - t >= WARNING_REPORT_INTERVAL);
                if due {
                    self.last_warning_report = Some(now);
                    self.push_event(
                        now,
                        BridgeEvent::BusError {
                            description,
                            fatal: false,
                        },
                    );
                }
            }
        }
    }

    fn io_fault(&mut self, e: BusError, now: Timestamp) {
        self.counters.tx_errors += 1;
        let new = self.bus_fault.as_ref().is_none_or(|bf| bf.description != e.0);
        if new {
            self.push_event(
                now,
                BridgeEvent::BusError {
                    description: e.0.clone(),
                    fatal: true,
                },
            );
        }
        self.bus_fault = Some(BusFault {
            kind: BusFaultKind::Io,
            description: e.0,
            back_since: None,
        });
        self.phase = Phase::Down;
        self.comm_lost = true;
    }

    fn bus_traffic_seen(&mut self, kind: BusFaultKind, now: Timestamp) {
        if let Some(bf) = &mut self.bus_fault {
            if bf.kind == kind && bf.back_since.is_none() {
                bf.back_since = Some(now);
            }
        }
    }

    /// Clears a bus fault once the bus has been back for bus_recovery_s
    /// without another fatal error (a fatal error resets `back_since`).
    fn update_bus_fault(&mut self, now: Timestamp) {
        let recovery = Duration::from_secs_f64(self.cfg.timing.bus_recovery_s);
        if let Some(bf) = &self.bus_fault {
            if bf.back_since.is_some_and(|b| now - b >= recovery) {
                self.bus_fault = None;
                self.phase = Phase::Down;
                self.push_event(now, BridgeEvent::BusRecovered);
            }
        }
    }

    fn heartbeat_fresh(&self, w: Wheel, now: Timestamp) -> bool {
        let timeout = Duration::from_secs_f64(self.cfg.timing.heartbeat_timeout_s);
        self.links[w.index()].last_status.is_some_and(|t| now - t <= timeout)
    }

    fn feedback_fresh(&self, w: Wheel, now: Timestamp) -> bool {
        let timeout = Duration::from_secs_f64(self.cfg.timing.feedback_timeout_s);
        self.links[w.index()].last_feedback.is_some_and(|t| now - t <= timeout)
    }

    fn erroring_wheel(&self) -> Option<Wheel> {
        Wheel::BOTH.into_iter().find(|w| self.links[w.index()].has_error())
    }

    fn latch_fault(&mut self, w: Wheel, now: Timestamp) {
        let l = self.links[w.index()];
        let f = LatchedFault {
            wheel: w,
            error_code: l.error_code,
            drive_estopped: l.estopped,
        };
        self.latched_fault = Some(f);
        self.phase = Phase::Down;
        self.push_event(
            now,
            BridgeEvent::DriveFaultLatched {
                wheel: f.wheel,
                error_code: f.error_code,
                drive_estopped: f.drive_estopped,
            },
        );
    }

    /// Latches a heartbeat that was fresh and timed out, unless the bus
    /// explains it (a bus fault or a full tx queue now or within the last
    /// heartbeat timeout: recovery is then automatic). The window matters at
    /// the end of a blocked episode: the bus is free again, but the drive's
    /// next heartbeat is still on its way.
    fn watch_heartbeats(&mut self, now: Timestamp) {
        if self.bus_fault.is_some() || self.tx_blocked || self.tx_full_episode {
            self.last_bus_trouble = Some(now);
        }
        let window = Duration::from_secs_f64(self.cfg.timing.heartbeat_timeout_s) + self.period;
        let explained = self.last_bus_trouble.is_some_and(|t| now - t <= window);
        for w in Wheel::BOTH {
            let i = w.index();
            let fresh = self.heartbeat_fresh(w, now);
            let lost = self.heartbeat_was_fresh[i] && !fresh;
            self.heartbeat_was_fresh[i] = fresh;
            if lost && !explained && self.latched_silence.is_none() {
                self.latched_silence = Some(w);
                self.phase = Phase::Down;
                self.push_event(now, BridgeEvent::HeartbeatLostLatched { wheel: w });
            }
        }
    }

    fn update_phase(&mut self, now: Timestamp) {
        self.watch_heartbeats(now);
        let all_fresh = Wheel::BOTH.iter().all(|w| self.heartbeat_fresh(*w, now));
        let blocked = self.estop
            || self.latched_fault.is_some()
            || self.latched_silence.is_some()
            || self.bus_fault.is_some()
            || self.tx_blocked;
        match self.phase {
            Phase::Down => {
                if blocked || !all_fresh {
                    return;
                }
                if let Some(w) = self.erroring_wheel() {
                    let only_watchdog = self
                        .links
                        .iter()
                        .all(|l| !l.estopped && (l.error_code == 0 || self.protocol.is_watchdog_error(l.error_code)));
                    let may_clear = self.may_clear_drive_errors || (self.comm_lost && only_watchdog);
                    if !may_clear {
                        self.latch_fault(w, now);
                        return;
                    }
                }
                self.batch.clear();
                self.protocol.startup(&mut self.batch);
                let r = self.tx.push(self.batch.as_slice(), TxKind::Control, now);
                self.count_push(r, now);
                // The drive restarts from standstill, so does the ramp.
                self.limiter.reset_to_zero();
                self.phase = Phase::Starting { since: now };
                self.push_event(now, BridgeEvent::StartupSent);
            }
            Phase::Starting { since } => {
                // Only a status sent after the start-up sequence counts: one
                // from before it may describe the drive before a reset.
                let confirmed = self
                    .links
                    .iter()
                    .all(|l| l.running && !l.has_error() && l.last_status.is_some_and(|t| t > since));
                if !all_fresh {
                    self.phase = Phase::Down;
                    self.comm_lost = true;
                } else if confirmed {
                    self.phase = Phase::Ready;
                    self.may_clear_drive_errors = false;
                    self.comm_lost = false;
                    self.push_event(now, BridgeEvent::DriveReady);
                } else if now - since > Duration::from_secs_f64(self.cfg.timing.startup_timeout_s) {
                    if let Some(w) = self.erroring_wheel() {
                        self.latch_fault(w, now);
                    } else {
                        self.push_event(now, BridgeEvent::StartupTimeout);
                        self.phase = Phase::Down;
                    }
                }
            }
            Phase::Ready => {
                if !all_fresh {
                    self.phase = Phase::Down;
                    self.comm_lost = true;
                } else if let Some(w) = self.erroring_wheel() {
                    self.latch_fault(w, now);
                } else if let Some(w) = Wheel::BOTH.into_iter().find(|w| !self.links[w.index()].running) {
                    self.push_event(now, BridgeEvent::DriveStoppedRunning { wheel: w });
                    self.phase = Phase::Down;
                }
            }
        }
    }

    /// Recomputes the stop reasons and the state; reports changes.
    fn update_reasons(&mut self, now: Timestamp) {
        let mut r = Vec::new();
        if self.estop {
            r.push(StopReason::Estop);
        }
        if let Some(f) = self.latched_fault {
            r.push(StopReason::DriveFault {
                wheel: f.wheel,
                error_code: f.error_code,
                drive_estopped: f.drive_estopped,
            });
        }
        if let Some(w) = self.latched_silence {
            r.push(StopReason::HeartbeatLost { wheel: w });
        }
        if let Some(bf) = &self.bus_fault {
            r.push(StopReason::BusError {
                description: bf.description.clone(),
            });
        }
        if self.tx_blocked {
            r.push(StopReason::TxBlocked);
        }
        for w in Wheel::BOTH {
            if !self.heartbeat_fresh(w, now) {
                r.push(StopReason::NoHeartbeat {
                    wheel: w,
                    ever_seen: self.links[w.index()].last_status.is_some(),
                });
            }
        }
        match self.phase {
            Phase::Ready => {
                for w in Wheel::BOTH {
                    if !self.feedback_fresh(w, now) {
                        r.push(StopReason::FeedbackLost { wheel: w });
                    }
                }
            }
            _ if !self.estop && self.latched_fault.is_none() && self.latched_silence.is_none() => {
                r.push(StopReason::DriveStarting)
            }
            _ => {}
        }
        if r.iter().any(|x| !x.is_command_reason()) {
            self.resume_after = Some(now);
        }
        let timeout = Duration::from_secs_f64(self.cfg.timing.cmd_timeout_s);
        match self.command {
            None if self.last_command_invalid => r.push(StopReason::InvalidCommand),
            None => r.push(StopReason::NoCommand),
            Some(c) if now - c.received > timeout => r.push(StopReason::CommandTimeout),
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
        if state != self.state || r != self.reasons {
            self.state = state;
            self.reasons = r.clone();
            self.push_event(now, BridgeEvent::StateChanged { state, reasons: r });
        }
    }

    /// Queues this period's setpoints (the previous period's, if still
    /// waiting, are dropped as stale).
    fn transmit_setpoints(&mut self, now: Timestamp) {
        self.counters.tx_periods += 1;
        let (mode, motors) = if self.estop {
            (SetpointMode::Estop, MotorSpeeds::ZERO)
        } else if let (true, Some(c)) = (self.reasons.is_empty(), self.command) {
            let l = &self.cfg.limits;
            let target = self.kin.wheel_speeds(c.twist);
            let (target, _) = saturate_wheels(target, l.max_wheel_speed_radps);
            let wheels = self.limiter.step(
                target,
                self.period.as_secs_f64(),
                l.wheel_accel_radps2,
                l.wheel_decel_radps2,
            );
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

    fn count_push(&mut self, r: crate::tx_queue::PushReport, now: Timestamp) {
        let stale = r.dropped_stale + r.dropped_overflow;
        if stale > 0 {
            self.counters.tx_dropped_stale += u64::from(stale);
            self.push_event(
                now,
                BridgeEvent::TxDropped {
                    stale,
                    after_retries: 0,
                },
            );
        }
    }

    fn flush(&mut self, now: Timestamp) {
        let r = self.tx.flush(&mut self.bus, now);
        self.counters.tx_frames += u64::from(r.sent);
        if r.sent > 0 {
            self.last_tx_ok = now;
            self.tx_full_episode = false;
            self.bus_traffic_seen(BusFaultKind::Io, now);
        }
        if r.queue_full {
            self.counters.tx_queue_full += 1;
            if !self.tx_full_episode {
                self.tx_full_episode = true;
                self.push_event(now, BridgeEvent::TxQueueFull);
            }
        }
        if r.dropped_after_retries > 0 {
            self.counters.tx_dropped_after_retries += u64::from(r.dropped_after_retries);
            self.push_event(
                now,
                BridgeEvent::TxDropped {
                    stale: 0,
                    after_retries: r.dropped_after_retries,
                },
            );
        }
        if let Some(e) = r.failed {
            self.io_fault(e, now);
        }
        // Blocked: sends have been failing with a full queue and nothing got
        // out for more than TX_BLOCKED_PERIODS periods.
        let blocked = self.tx_full_episode && now - self.last_tx_ok > self.period * TX_BLOCKED_PERIODS;
        if blocked && !self.tx_blocked {
            self.phase = Phase::Down;
            self.comm_lost = true;
        }
        self.tx_blocked = blocked;
    }
}

#[cfg(test)]
#[path = "bridge_tests.rs"]
mod tests;
