//! The bridge: commands in, periodic setpoint frames out, drive state and
//! feedback back in. It composes sub-state-machines, one concept per file:
//!
//! * [`stop_reasons`]: the set of reasons to stand still, the e-stop
//!   latch, the command's freshness (an old command is never resumed), and
//!   the state they add up to;
//! * [`drive_supervision`]: start-up, heartbeat and feedback watchdogs,
//!   latched drive faults;
//! * [`bus_health`]: error frames, bus-off, failed I/O, a full transmit
//!   queue (ENOBUFS), and recovery;
//! * [`shutdown`]: the last frames, retried;
//! * [`events`]: the bounded event queue;
//! * `receive.rs` / `transmit.rs`: what comes in and goes out, wired to
//!   the parts above.
//!
//! What stays here: setpoints on a fixed grid (a late loop skips grid
//! points, never bursts), commands (NaN/inf rejected to zero; v and ω beyond
//! the limits scaled together, keeping the curvature), ramps (accel/decel
//! shape commanded motion only; every stop is immediate), and wiring the
//! parts to the bus and the protocol.
//!
//! Time is an argument everywhere. [`Bridge::spin_once`] waits only in the
//! bus's `recv` (up to the next deadline) and never sleeps; a bus that fails
//! at once asks the caller to back off ([`Spin::BackOff`]), and
//! [`Bridge::shutdown`] returns when to try again. Each rule has a unit test
//! in its module, and the whole in `bridge_tests.rs` with a
//! [`FakeBus`](crate::fake_bus::FakeBus) in simulated time.

pub mod bus_health;
pub mod drive_supervision;
pub mod events;
mod receive;
pub mod shutdown;
pub mod stop_reasons;
mod transmit;

pub use bus_health::{TX_BLOCKED_PERIODS, WARNING_REPORT_INTERVAL};
pub use events::EVENT_QUEUE_CAPACITY;
pub use shutdown::ShutdownProgress;

use crate::bus::{BusError, CanBus};
use crate::config::{BridgeConfig, ParamError, Validate};
use crate::diagnostics::{BridgeEvent, BridgeState, BridgeStatus, Counters, StopReason, TimedEvent};
use crate::kinematics::{DiffDrive, MotorSpeeds, Twist, Wheel, WheelSpeeds};
use crate::limits::{clamp_twist, RampLimiter};
use crate::odometry::Odometry;
use crate::protocol::cia402::sdo_jobs::{SdoJob, SdoJobId, SdoJobResult, SdoRefusal};
use crate::protocol::{FrameBatch, Protocol};
use crate::time::{saturating_duration, Clock, Timestamp};
use crate::tx_queue::TxQueue;
use bus_health::BusHealth;
use drive_supervision::{Blockers, DriveSupervisor};
use events::EventLog;
use shutdown::ShutdownSequence;
use std::time::Duration;
use stop_reasons::StopReasons;

/// Bus events handled per [`Bridge::poll_bus`] call, so a flooding bus cannot starve transmission.
pub const MAX_EVENTS_PER_POLL: usize = 256;
/// Longest back-off [`Bridge::spin_once`] asks for after a bus that failed at once.
pub const BUS_ERROR_BACKOFF: Duration = Duration::from_millis(5);

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

/// What the loop should do after [`Bridge::spin_once`].
#[must_use = "a bus that fails at once needs the loop to back off, or it spins"]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Spin {
    /// Call again at once: the call waited on the bus up to its deadline.
    Again,
    /// The bus failed without waiting (an interface that is down): wait
    /// this long before the next call.
    BackOff(Duration),
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
    /// Commands are being clamped (reported once per episode).
    clamping: bool,
    stops: StopReasons,
    drive: DriveSupervisor,
    bus_health: BusHealth,
    shutdown: Option<ShutdownSequence>,
    last_wheels: WheelSpeeds,
    last_motors: MotorSpeeds,
    counters: Counters,
    events: EventLog,
    /// Finished run-time SDO requests, until taken.
    sdo_results: Vec<SdoJobResult>,
}

impl<B: CanBus> Bridge<B> {
    /// A bridge on `bus` for a validated configuration. Sets the bus's
    /// receive filters to the drive's ids; the first setpoints go out at `now`.
    pub fn new(cfg: BridgeConfig, mut bus: B, now: Timestamp) -> Result<Self, BridgeError> {
        cfg.validate().map_err(BridgeError::Config)?;
        let protocol = cfg.make_protocol();
        bus.set_rx_filters(&protocol.rx_filters())?;
        let kin = cfg.diff_drive();
        let period = cfg.tx_period();
        let odom = Odometry::new(
            kin,
            protocol.position_modulus_rad(),
            cfg.limits.max_wheel_speed_radps,
            cfg.odometry.noise(),
        );
        let t = &cfg.timing;
        let mut b = Self {
            kin,
            period,
            bus,
            protocol,
            limiter: RampLimiter::new(),
            odom,
            tx: TxQueue::new(),
            batch: FrameBatch::new(),
            next_tx: now,
            clamping: false,
            stops: StopReasons::new(saturating_duration(t.cmd_timeout_s)),
            drive: DriveSupervisor::new(t, period),
            bus_health: BusHealth::new(saturating_duration(t.bus_recovery_s), period, now),
            shutdown: None,
            last_wheels: WheelSpeeds::ZERO,
            last_motors: MotorSpeeds::ZERO,
            counters: Counters::default(),
            events: EventLog::new(),
            sdo_results: Vec::new(),
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
            self.stops.reject();
            let (linear_mps, angular_radps) = (twist.linear_mps, twist.angular_radps);
            self.events.push(
                now,
                BridgeEvent::CommandRejected {
                    linear_mps,
                    angular_radps,
                },
            );
            return Err(CommandError::NonFinite);
        }
        let l = &self.cfg.limits;
        let (clamped, was_clamped) = clamp_twist(twist, l.v_max_mps, l.omega_max_radps);
        if was_clamped {
            self.counters.commands_clamped += 1;
            if !self.clamping {
                let requested = twist;
                self.events
                    .push(now, BridgeEvent::CommandClamped { requested, clamped });
            }
        }
        self.clamping = was_clamped;
        self.stops.accept(clamped, now);
        Ok(())
    }

    /// Latches the e-stop and sends e-stop frames at once (and every period
    /// until [`reset`](Self::reset)).
    pub fn estop(&mut self, now: Timestamp) {
        let new = self.stops.latch_estop();
        self.drive.stop();
        self.limiter.reset_to_zero();
        self.tx.clear();
        self.update_reasons(now);
        self.transmit_setpoints(now);
        self.flush(now);
        // Reported after the frames are out: logging may be slow (a serial console).
        if new {
            self.events.push(now, BridgeEvent::EstopLatched);
        }
    }

    /// Clears the e-stop latch and latched drive faults (errors, lost
    /// heartbeats). The drive is started again (clearing its errors) and a
    /// command received after this call is needed to move.
    pub fn reset(&mut self, now: Timestamp) {
        self.stops.reset(now);
        self.drive.reset();
        self.limiter.reset_to_zero();
        self.events.push(now, BridgeEvent::Reset);
        self.update_reasons(now);
    }

    /// Advances timeouts, transmits when a period is due, retries queued frames.
    pub fn tick(&mut self, now: Timestamp) {
        if self.bus_health.update(now, &mut self.events) {
            self.drive.stop();
        }
        let blockers = Blockers {
            estop: self.stops.estopped(),
            bus_down: self.bus_health.faulted() || self.bus_health.tx_blocked(),
            bus_troubled: self.bus_health.troubled(),
        };
        let p = &self.protocol;
        if self
            .drive
            .update(now, blockers, |c| p.is_watchdog_error(c), &mut self.events)
        {
            self.send_startup(now);
        }
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
    /// deadline (at most `max_wait`), handle it, tick again. Never sleeps:
    /// a bus that fails at once returns [`Spin::BackOff`] for the caller.
    pub fn spin_once(&mut self, clock: &dyn Clock, max_wait: Duration) -> Spin {
        let now = clock.now();
        self.tick(now);
        let deadline = self.next_deadline().min(now + max_wait);
        let wait = deadline - clock.now();
        let spin = match self.bus.recv(wait) {
            Ok(Some(ev)) => {
                self.handle_bus_event(ev, clock.now());
                self.poll_bus(clock.now());
                Spin::Again
            }
            Ok(None) => Spin::Again,
            Err(e) => {
                self.io_fault(e, clock.now());
                // An interface that is down fails at once: do not spin.
                Spin::BackOff(wait.min(BUS_ERROR_BACKOFF))
            }
        };
        self.tick(clock.now());
        spin
    }

    /// Stops the drive for good: zero, then disable, each frame tried a few
    /// times. The first call starts the shutdown; while it returns
    /// [`ShutdownProgress::Pending`], call it again at `retry_at`.
    pub fn shutdown(&mut self, now: Timestamp) -> ShutdownProgress {
        if self.shutdown.is_none() {
            self.tx.clear();
            self.stops.drop_command();
            self.batch.clear();
            self.protocol.shutdown(&mut self.batch);
            self.shutdown = Some(ShutdownSequence::new(self.batch, now));
            self.drive.stop();
            self.last_wheels = WheelSpeeds::ZERO;
            self.last_motors = MotorSpeeds::ZERO;
        }
        let Some(seq) = &mut self.shutdown else {
            return ShutdownProgress::Done { failed: 0 };
        };
        let (progress, sent) = seq.step(&mut self.bus, now);
        self.counters.tx_frames += u64::from(sent);
        progress
    }

    /// Reads or writes an object of a drive's CANopen node while running
    /// (CiA 402 only): the request's id, or why it is refused (nothing is
    /// sent; see [`crate::protocol::cia402::sdo_jobs`]). The transfer runs
    /// in the loop (segmented ones segment by segment); its result comes
    /// from [`take_sdo_results`](Self::take_sdo_results) and as an event.
    pub fn sdo_request(&mut self, job: SdoJob, now: Timestamp) -> Result<SdoJobId, SdoRefusal> {
        let (node, index, sub, write) = (job.node, job.addr.index, job.addr.sub, job.is_write());
        let r = self.protocol.sdo_request(job);
        if let Err(e) = &r {
            let reason = e.to_string();
            self.events.push(
                now,
                BridgeEvent::SdoRefused {
                    node,
                    index,
                    sub,
                    write,
                    reason,
                },
            );
        }
        r
    }

    /// Takes the run-time SDO requests that ended since the last call.
    pub fn take_sdo_results(&mut self) -> Vec<SdoJobResult> {
        std::mem::take(&mut self.sdo_results)
    }

    /// The current state.
    pub fn state(&self) -> BridgeState {
        self.stops.state()
    }

    /// Why the setpoints are zero (empty while running).
    pub fn reasons(&self) -> &[StopReason] {
        self.stops.reasons()
    }

    /// Counters since start.
    pub fn counters(&self) -> Counters {
        Counters {
            events_dropped: self.events.dropped(),
            ..self.counters
        }
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
        self.events.drain()
    }

    /// A full snapshot at `now`.
    pub fn status(&self, now: Timestamp) -> BridgeStatus {
        BridgeStatus {
            t_s: now.as_secs_f64(),
            state: self.state(),
            reasons: self.reasons().to_vec(),
            command: self.stops.command(),
            setpoint_wheels: self.last_wheels,
            setpoint_motors: self.last_motors,
            odometry: self.odom.state(),
            left: self.drive.link_status(Wheel::Left, now),
            right: self.drive.link_status(Wheel::Right, now),
            counters: self.counters(),
        }
    }

    // ----------------------------------------------------------------- internals

    /// Recomputes the stop reasons and the state; reports changes.
    fn update_reasons(&mut self, now: Timestamp) {
        let mut faults = Vec::new();
        self.drive.latched_reasons(&mut faults);
        self.bus_health.reasons(&mut faults);
        self.drive.link_reasons(now, self.stops.estopped(), &mut faults);
        if let Some(e) = self.stops.update(now, faults) {
            self.events.push(now, e);
        }
    }
}

#[cfg(test)]
#[path = "bridge_tests.rs"]
mod tests;
