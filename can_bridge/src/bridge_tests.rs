//! State machine tests with a FakeBus and simulated time: no sleeping.
//!
//! The rig plays the drive by hand (status/heartbeat and feedback frames it
//! injects every step), so each test controls exactly what the bridge sees.
//! These are the rules as seen on the wire, the parts together; each part's
//! own rules are tested in its module (`bridge/stop_reasons.rs`,
//! `bridge/drive_supervision_tests.rs`, `bridge/bus_health.rs`,
//! `bridge/shutdown.rs`, `bridge/events.rs`).

use super::*;
use crate::bus::{err, CanErrorFrame, CanFrame, SendError};
use crate::config::default_config;
use crate::fake_bus::FakeBus;
use crate::protocol::generic::{self, GenericIds};
use crate::protocol::odrive;
use crate::protocol::ProtocolKind;

const IDS: GenericIds = GenericIds { base_id: 0x100 };
const PERIOD: Duration = Duration::from_millis(20);

/// One decoded setpoint pair as sent.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Pair {
    t: Timestamp,
    left: f64,
    right: f64,
    enable: bool,
    estop: bool,
    counter: u8,
}

struct Rig {
    bridge: Bridge<FakeBus>,
    bus: FakeBus,
    t: Timestamp,
    /// The fake drive sends status/heartbeats.
    heartbeat: bool,
    /// The fake drive sends feedback.
    feedback: bool,
    /// Reported drive error.
    drive_error: u32,
    /// The drive reports running (once started).
    drive_running: bool,
    /// The drive follows the bridge: running after start-up frames.
    started: bool,
    counter: u8,
    /// Every frame the bridge sent, with the time of the step that sent it.
    sent: Vec<(Timestamp, CanFrame)>,
    protocol: ProtocolKind,
}

fn cfg(protocol: ProtocolKind) -> BridgeConfig {
    let mut c = default_config();
    c.protocol = protocol;
    c.odrive.left_node_id = 3;
    c.odrive.right_node_id = 5;
    // Large accel limits unless a test wants ramps: setpoints = kinematics at once.
    c.limits.wheel_accel_radps2 = 1e5;
    c.limits.wheel_decel_radps2 = 1e5;
    c.kinematics.gear_ratio = 10.0;
    c.limits.max_wheel_speed_radps = 20.0;
    c.limits.v_max_mps = 0.5;
    c.limits.omega_max_radps = 5.0;
    c
}

impl Rig {
    fn with(c: BridgeConfig) -> Self {
        let bus = FakeBus::new();
        let t = Timestamp::from_secs_f64(100.0);
        let protocol = c.protocol;
        let bridge = Bridge::new(c, bus.clone(), t).unwrap();
        Self {
            bridge,
            bus,
            t,
            heartbeat: true,
            feedback: true,
            drive_error: 0,
            drive_running: true,
            started: false,
            counter: 0,
            sent: Vec::new(),
            protocol,
        }
    }

    fn new() -> Self {
        Self::with(cfg(ProtocolKind::Generic))
    }

    fn odrive() -> Self {
        Self::with(cfg(ProtocolKind::Odrive))
    }

    /// The fake drive's frames for this instant.
    fn drive_frames(&mut self) {
        self.counter = self.counter.wrapping_add(1);
        let running = self.started && self.drive_running && self.drive_error == 0;
        match self.protocol {
            ProtocolKind::Generic => {
                if self.heartbeat {
                    let state = if self.drive_error != 0 {
                        generic::STATE_FAULT
                    } else if running {
                        generic::STATE_ENABLED
                    } else {
                        generic::STATE_DISABLED
                    };
                    let s = generic::Status {
                        state,
                        counter: self.counter,
                        error_code: self.drive_error,
                        rejected_setpoints: 0,
                    };
                    self.bus.inject_frame(generic::encode_status(IDS, &s));
                }
                if self.feedback {
                    for w in Wheel::BOTH {
                        let fb = generic::Feedback {
                            vel_radps: 0.0,
                            pos_rad: 0.0,
                            counter: self.counter,
                        };
                        self.bus.inject_frame(generic::encode_feedback(IDS, w, &fb));
                    }
                }
            }
            ProtocolKind::Odrive => {
                for n in [3, 5] {
                    if self.heartbeat {
                        let st = if running { 8 } else { 1 };
                        self.bus.inject_frame(odrive::heartbeat(n, self.drive_error, st));
                    }
                    if self.feedback {
                        self.bus.inject_frame(odrive::encoder_estimates(n, 0.0, 0.0));
                    }
                }
            }
            // CiA 402 needs a drive that answers SDO: tests/closed_loop.rs runs it
            // against the virtual drive; protocol/cia402/tests.rs by hand.
            ProtocolKind::Cia402 => unreachable!("the rig plays generic and ODrive drives"),
        }
    }

    /// Advances by `dt` in 1 ms steps: drive frames every 10 ms, then poll and tick.
    fn run(&mut self, dt: Duration) {
        let end = self.t + dt;
        while self.t < end {
            self.t = self.t + Duration::from_millis(1);
            if (self.t.since_epoch().as_millis()) % 10 == 0 {
                self.drive_frames();
            }
            self.bridge.poll_bus(self.t);
            self.bridge.tick(self.t);
            self.collect();
        }
    }

    fn run_s(&mut self, s: f64) {
        self.run(Duration::from_secs_f64(s));
    }

    fn collect(&mut self) {
        for f in self.bus.take_sent() {
            if self.protocol == ProtocolKind::Odrive && f.id & 0x1F == odrive::cmd::SET_AXIS_STATE {
                self.started = f.data[0] == 8;
            }
            if self.protocol == ProtocolKind::Generic && generic::decode_setpoint(IDS, &f).unwrap().is_some() {
                // Start-up "clear" pair: the drive becomes enabled at the next Hold.
                let (_, sp) = generic::decode_setpoint(IDS, &f).unwrap().unwrap();
                if sp.enable {
                    self.started = true;
                }
                if sp.estop {
                    self.started = false;
                }
            }
            self.sent.push((self.t, f));
        }
    }

    fn cmd(&mut self, v: f64, w: f64) -> Result<(), CommandError> {
        self.bridge.command(Twist::new(v, w), self.t)
    }

    /// Starts the drive and waits for Ready.
    fn ready(&mut self) {
        self.run_s(0.1);
        assert!(
            self.bridge.reasons().iter().all(|r| r.is_command_reason()),
            "{:?}",
            self.bridge.reasons()
        );
    }

    /// Generic setpoint pairs sent after `from` (strictly).
    fn pairs_since(&self, from: Timestamp) -> Vec<Pair> {
        let mut out = Vec::new();
        let mut left: Option<(Timestamp, generic::Setpoint)> = None;
        for (t, f) in self.sent.iter().filter(|(t, _)| *t > from) {
            match generic::decode_setpoint(IDS, f).expect("every sent setpoint decodes") {
                Some((Wheel::Left, sp)) => left = Some((*t, sp)),
                Some((Wheel::Right, sp)) => {
                    let (tl, l) = left.take().expect("left before right");
                    assert_eq!(l.counter, sp.counter, "a pair shares its counter");
                    assert_eq!((l.enable, l.estop), (sp.enable, sp.estop));
                    out.push(Pair {
                        t: tl,
                        left: l.vel_radps,
                        right: sp.vel_radps,
                        enable: sp.enable,
                        estop: sp.estop,
                        counter: sp.counter,
                    });
                }
                None => {}
            }
        }
        out
    }

    fn last_pair(&self) -> Pair {
        *self.pairs_since(Timestamp::ZERO).last().expect("a pair was sent")
    }

    fn has_reason(&self, name: &str) -> bool {
        self.bridge.reasons().iter().any(|r| r.name() == name)
    }

    fn events(&mut self) -> Vec<BridgeEvent> {
        self.bridge.drain_events().into_iter().map(|e| e.event).collect()
    }
}

/// Expected motor speeds for a twist with `cfg`'s geometry (gear 10, right reversed).
fn expected_motor(v: f64, w: f64) -> (f64, f64) {
    let (l_half, r) = (0.08, 0.033);
    let wl = (v - w * l_half) / r;
    let wr = (v + w * l_half) / r;
    (10.0 * wl, -10.0 * wr)
}

fn assert_close(got: f64, want: f64) {
    // The generic field quantizes to 1e-5 rad/s.
    assert!((got - want).abs() <= 0.5e-5 + 1e-12, "got {got}, want {want}");
}

// ----------------------------------------------------------------- start-up and kinematics

#[test]
fn starts_the_drive_then_follows_a_command_with_the_kinematics() {
    let mut r = Rig::new();
    assert_eq!(r.bridge.state(), BridgeState::Starting);
    r.ready();
    assert_eq!(r.bridge.state(), BridgeState::Idle);
    // The start-up "clear" pair (Enable 0) went out before any enabled pair.
    let pairs = r.pairs_since(Timestamp::ZERO);
    let first_clear = pairs.iter().position(|p| !p.enable && !p.estop).expect("clear pair");
    assert!(pairs[first_clear..].iter().skip(1).all(|p| p.enable));
    r.cmd(0.2, 0.5).unwrap();
    r.run_s(0.05);
    assert_eq!(r.bridge.state(), BridgeState::Running);
    let p = r.last_pair();
    let (l, rr) = expected_motor(0.2, 0.5);
    // By hand: (0.2 − 0.04)/0.033 × 10 = 48.4848..., −(0.24/0.033) × 10 = −72.7272...
    assert_close(p.left, l);
    assert_close(p.right, rr);
    assert!((l - 48.484_848_484_848_484).abs() < 1e-9 && (rr + 72.727_272_727_272_72).abs() < 1e-9);
    assert!(p.enable && !p.estop);
}

#[test]
fn transmits_at_tx_rate_whatever_the_command_rate() {
    let mut r = Rig::new();
    r.ready();
    // No commands at all for 1 s: 50 pairs.
    let t0 = r.t;
    r.run_s(1.0);
    let n = r.pairs_since(t0).len();
    assert!((49..=51).contains(&n), "{n}");
    // Commands at 1 kHz for 1 s: still 50 pairs, on the 20 ms grid.
    let t1 = r.t;
    for _ in 0..1000 {
        r.cmd(0.1, 0.0).unwrap();
        r.run(Duration::from_millis(1));
    }
    let pairs = r.pairs_since(t1);
    assert!((49..=51).contains(&pairs.len()), "{}", pairs.len());
    for w in pairs.windows(2) {
        assert_eq!(w[1].t - w[0].t, PERIOD);
        assert_eq!(w[1].counter, w[0].counter.wrapping_add(1), "counter +1 per pair");
    }
}

#[test]
fn a_late_loop_skips_grid_points_instead_of_bursting() {
    let mut r = Rig::new();
    r.ready();
    let before = r.bus.send_attempts();
    // The loop stalls 95 ms: one pair at the late tick, then back on the grid.
    r.t = r.t + Duration::from_millis(95);
    r.bridge.tick(r.t);
    assert_eq!(r.bus.send_attempts() - before, 2, "one pair, not five");
    let next = r.bridge.next_deadline();
    assert!(next > r.t && next - r.t <= PERIOD);
}

// ----------------------------------------------------------------- watchdog

#[test]
fn watchdog_zero_within_timeout_plus_one_period_and_never_resumes() {
    let mut r = Rig::new();
    r.ready();
    r.cmd(0.2, 0.0).unwrap();
    let t_cmd = r.t;
    r.run_s(0.2);
    assert!(r.last_pair().left != 0.0);
    r.run_s(2.0);
    let pairs = r.pairs_since(t_cmd);
    let first_zero = pairs
        .iter()
        .find(|p| p.left == 0.0 && p.right == 0.0)
        .expect("zero sent");
    let deadline = t_cmd + Duration::from_secs_f64(0.5) + PERIOD;
    assert!(
        first_zero.t <= deadline,
        "zero at {:?}, deadline {deadline:?}",
        first_zero.t
    );
    assert!(
        first_zero.t > t_cmd + Duration::from_secs_f64(0.5),
        "not before the timeout"
    );
    // ...and it stays zero: the old command is never resumed.
    assert!(pairs
        .iter()
        .filter(|p| p.t >= first_zero.t)
        .all(|p| p.left == 0.0 && p.right == 0.0));
    assert_eq!(r.bridge.reasons(), [StopReason::CommandTimeout]);
    assert_eq!(r.bridge.state(), BridgeState::Idle);
    // A fresh command resumes at the next period.
    r.cmd(0.1, 0.0).unwrap();
    r.run(PERIOD);
    assert_close(r.last_pair().left, expected_motor(0.1, 0.0).0);
}

#[test]
fn a_command_stream_keeps_the_watchdog_fed() {
    let mut r = Rig::new();
    r.ready();
    for _ in 0..100 {
        r.cmd(0.1, 0.0).unwrap();
        r.run(Duration::from_millis(100));
    }
    let pairs = r.pairs_since(Timestamp::from_secs_f64(100.2));
    assert!(pairs.iter().all(|p| p.left != 0.0), "never zero while fed");
}

// ----------------------------------------------------------------- bad commands

#[test]
fn nan_and_inf_commands_are_rejected_to_zero_and_reported() {
    let mut r = Rig::new();
    r.ready();
    r.cmd(0.2, 0.0).unwrap();
    r.run_s(0.1);
    r.events();
    for (v, w) in [(f64::NAN, 0.0), (0.1, f64::INFINITY), (f64::NEG_INFINITY, f64::NAN)] {
        assert_eq!(r.cmd(v, w), Err(CommandError::NonFinite));
        r.run(PERIOD);
        let p = r.last_pair();
        assert_eq!((p.left, p.right), (0.0, 0.0));
        assert_eq!(r.bridge.reasons(), [StopReason::InvalidCommand]);
    }
    let ev = r.events();
    assert_eq!(
        ev.iter()
            .filter(|e| matches!(e, BridgeEvent::CommandRejected { .. }))
            .count(),
        3
    );
    assert_eq!(r.bridge.counters().commands_rejected, 3);
    // Status serializes (NaN becomes null in JSON, never a panic).
    let json = serde_json::to_string(&r.bridge.drain_events()).unwrap();
    assert!(!json.contains("NaN"));
    r.cmd(0.1, 0.0).unwrap();
    r.run(PERIOD);
    assert!(r.last_pair().left > 0.0);
}

#[test]
fn commands_beyond_the_limits_are_scaled_keeping_the_curvature() {
    let mut r = Rig::new();
    r.ready();
    // v 2.0 with v_max 0.5 → × 0.25: (0.5, 0.5); curvature ω/v = 1 kept.
    r.cmd(2.0, 2.0).unwrap();
    r.run(PERIOD * 2);
    let p = r.last_pair();
    let (l, rr) = expected_motor(0.5, 0.5);
    assert_close(p.left, l);
    assert_close(p.right, rr);
    assert!(r
        .events()
        .iter()
        .any(|e| matches!(e, BridgeEvent::CommandClamped { .. })));
    // Wheel saturation: 0.5 m/s, 5 rad/s → wheels (0.5 ∓ 0.4)/0.033 = 3.03, 27.3 > 20:
    // both scaled by 20/27.27, never just the right one clipped.
    r.cmd(0.5, 5.0).unwrap();
    r.run(PERIOD * 2);
    let p = r.last_pair();
    let (l, rr) = expected_motor(0.5, 5.0);
    let k = 200.0 / rr.abs();
    assert_close(p.left, l * k);
    assert_close(p.right, rr * k);
    assert!(
        (p.right.abs() - 200.0).abs() < 1e-4,
        "right motor at 20 rad/s × gear 10"
    );
}

// ----------------------------------------------------------------- ramps

#[test]
fn accel_and_decel_limits_ramp_the_setpoints() {
    let mut c = cfg(ProtocolKind::Generic);
    c.limits.wheel_accel_radps2 = 20.0; // 0.4 rad/s per 20 ms period
    c.limits.wheel_decel_radps2 = 40.0; // 0.8 rad/s per period
    c.kinematics.gear_ratio = 1.0;
    let mut r = Rig::with(c);
    r.ready();
    let t0 = r.t;
    // Straight at 0.1 m/s → wheels 3.0303 rad/s: ramp of 0.4 per period.
    for _ in 0..20 {
        r.cmd(0.1, 0.0).unwrap();
        r.run(PERIOD);
    }
    let pairs = r.pairs_since(t0);
    let lefts: Vec<f64> = pairs.iter().map(|p| p.left).filter(|v| *v != 0.0).collect();
    for (i, v) in lefts.iter().take(7).enumerate() {
        assert_close(*v, 0.4 * (i + 1) as f64);
    }
    assert_close(*lefts.last().unwrap(), 0.1 / 0.033);
    // A commanded stop ramps down at 0.8 per period.
    let t1 = r.t;
    for _ in 0..3 {
        r.cmd(0.0, 0.0).unwrap();
        r.run(PERIOD);
    }
    let downs: Vec<f64> = r.pairs_since(t1).iter().map(|p| p.left).collect();
    assert_close(downs[0], 0.1 / 0.033 - 0.8);
    assert_close(downs[1], 0.1 / 0.033 - 1.6);
}

// ----------------------------------------------------------------- e-stop

#[test]
fn estop_is_latched_until_reset_and_a_fresh_command() {
    let mut r = Rig::new();
    r.ready();
    r.cmd(0.2, 0.0).unwrap();
    r.run_s(0.1);
    let before = r.bus.sent().len();
    r.bridge.estop(r.t);
    // Sent at once, not at the next period.
    let now_sent = r.bus.sent();
    assert!(now_sent.len() > before, "e-stop frames went out immediately");
    r.collect();
    let p = r.last_pair();
    assert!(p.estop && !p.enable && p.left == 0.0);
    assert_eq!(r.bridge.state(), BridgeState::Estop);
    // Commands are accepted but not followed while latched.
    let t = r.t;
    for _ in 0..10 {
        r.cmd(0.2, 0.0).unwrap();
        r.run(PERIOD);
    }
    assert!(r.pairs_since(t).iter().all(|p| p.estop && p.left == 0.0));
    // Reset alone does not move the robot, even with a command given before it.
    r.cmd(0.2, 0.0).unwrap();
    r.bridge.reset(r.t);
    let t = r.t;
    r.run_s(0.3);
    assert!(r.pairs_since(t).iter().all(|p| !p.estop && p.left == 0.0));
    assert_eq!(r.bridge.state(), BridgeState::Idle);
    assert_eq!(r.bridge.reasons(), [StopReason::NoCommand]);
    // Reset + fresh command: moving.
    r.cmd(0.2, 0.0).unwrap();
    r.run(PERIOD * 2);
    assert!(r.last_pair().left > 0.0);
    assert!(r.events().iter().any(|e| matches!(e, BridgeEvent::EstopLatched)));
}

#[test]
fn odrive_estop_sends_estop_frames_and_reset_restarts_the_axis() {
    let mut r = Rig::odrive();
    r.ready();
    r.cmd(0.2, 0.0).unwrap();
    r.run_s(0.1);
    let t = r.t;
    r.bridge.estop(r.t);
    r.collect();
    r.drive_error = odrive::AXIS_ERROR_ESTOP_REQUESTED;
    r.started = false;
    r.run_s(0.1);
    let ids: Vec<u32> = r.sent.iter().filter(|(s, _)| *s > t).map(|(_, f)| f.id).collect();
    assert!(ids.contains(&odrive::arb_id(3, odrive::cmd::ESTOP)));
    assert!(ids.contains(&odrive::arb_id(5, odrive::cmd::ESTOP)));
    assert!(
        !ids.contains(&odrive::arb_id(3, odrive::cmd::SET_INPUT_VEL)),
        "no velocity while latched"
    );
    // The drive's ESTOP_REQUESTED error does not add a latched fault.
    assert_eq!(r.bridge.reasons()[0], StopReason::Estop);
    let t = r.t;
    r.bridge.reset(r.t);
    r.run_s(0.02);
    // Start-up with Clear_Errors went out; the drive clears.
    assert!(r
        .sent
        .iter()
        .any(|(s, f)| *s >= t && f.id == odrive::arb_id(3, odrive::cmd::CLEAR_ERRORS)));
    r.drive_error = 0;
    r.run_s(0.1);
    assert_eq!(r.bridge.state(), BridgeState::Idle);
    r.cmd(0.2, 0.0).unwrap();
    r.run(PERIOD * 2);
    assert_eq!(r.bridge.state(), BridgeState::Running);
}

// ----------------------------------------------------------------- drive monitoring

#[test]
fn heartbeat_loss_stops_and_reports() {
    let mut r = Rig::odrive();
    r.ready();
    r.cmd(0.2, 0.0).unwrap();
    r.run_s(0.1);
    r.heartbeat = false;
    let t = r.t;
    let mut stopped_at = None;
    for _ in 0..100 {
        r.cmd(0.2, 0.0).unwrap();
        r.run(Duration::from_millis(10));
        if stopped_at.is_none() && r.bridge.state() == BridgeState::Stopped {
            stopped_at = Some(r.t);
        }
    }
    let stopped_at = stopped_at.expect("stopped");
    // Last heartbeat at ≤ t; timeout 0.5 s.
    assert!(stopped_at - t <= Duration::from_millis(520), "{:?}", stopped_at - t);
    assert!(r.has_reason("no_heartbeat"));
    let ids: Vec<_> = r
        .sent
        .iter()
        .filter(|(s, f)| *s > stopped_at + PERIOD && f.id == odrive::arb_id(3, odrive::cmd::SET_INPUT_VEL))
        .map(|(_, f)| *f)
        .collect();
    assert!(!ids.is_empty());
    assert!(ids.iter().all(|f| f.data[..4] == [0; 4]), "zero velocity");
}

#[test]
fn feedback_loss_stops_and_recovers_with_a_fresh_command() {
    let mut r = Rig::new();
    r.ready();
    r.cmd(0.2, 0.0).unwrap();
    r.run_s(0.1);
    r.feedback = false;
    r.run_s(0.25);
    assert!(r.has_reason("feedback_lost"));
    assert_eq!(r.last_pair().left, 0.0);
    r.feedback = true;
    r.run_s(0.05);
    assert_eq!(r.bridge.reasons(), [StopReason::AwaitingFreshCommand]);
    r.cmd(0.2, 0.0).unwrap();
    r.run(PERIOD * 2);
    assert!(r.last_pair().left > 0.0);
}

#[test]
fn axis_error_latches_until_reset() {
    let mut r = Rig::odrive();
    r.ready();
    r.cmd(0.2, 0.0).unwrap();
    r.run_s(0.1);
    r.drive_error = 0x40;
    r.run_s(0.05);
    assert_eq!(r.bridge.state(), BridgeState::Stopped);
    assert!(matches!(
        r.bridge.reasons()[0],
        StopReason::DriveFault { error_code: 0x40, .. }
    ));
    // The error goes away on the drive: still latched, no Clear_Errors sent by itself.
    let t = r.t;
    r.drive_error = 0;
    r.run_s(1.0);
    assert!(r.has_reason("drive_fault"));
    assert!(!r
        .sent
        .iter()
        .any(|(s, f)| *s > t && f.id == odrive::arb_id(3, odrive::cmd::CLEAR_ERRORS)));
    r.bridge.reset(r.t);
    r.run_s(0.1);
    assert_eq!(r.bridge.state(), BridgeState::Idle);
}

/// A communication loss the bus explains (bus-off: nothing in or out) and
/// recovers from by itself, as in `bus_off_stops_until_the_bus_is_back_and_quiet`.
fn bus_off_for_a_while(r: &mut Rig) {
    r.heartbeat = false;
    r.feedback = false;
    r.bus.inject_error(CanErrorFrame::bus_off());
    r.run_s(0.6);
    r.bus.inject_error(CanErrorFrame::restarted());
}

#[test]
fn a_drive_error_after_communication_loss_is_latched_not_cleared() {
    let mut r = Rig::odrive();
    r.ready();
    bus_off_for_a_while(&mut r);
    // Something else went wrong meanwhile: it comes back reporting an error.
    r.drive_error = 0x20;
    r.heartbeat = true;
    r.feedback = true;
    let t = r.t;
    r.run_s(1.0);
    assert!(r.has_reason("drive_fault"), "{:?}", r.bridge.reasons());
    assert!(!r.has_reason("heartbeat_lost"), "the bus explained the silence");
    assert!(!r
        .sent
        .iter()
        .any(|(s, f)| *s > t && f.id == odrive::arb_id(3, odrive::cmd::CLEAR_ERRORS)));
}

#[test]
fn a_watchdog_error_caused_by_a_communication_loss_is_cleared_by_the_restart() {
    for rig in [Rig::odrive as fn() -> Rig, Rig::new] {
        let mut r = rig();
        r.ready();
        bus_off_for_a_while(&mut r);
        // The drive's own watchdog tripped during the loss: expected, cleared by the restart.
        r.drive_error = match r.protocol {
            ProtocolKind::Odrive => odrive::AXIS_ERROR_WATCHDOG_TIMER_EXPIRED,
            ProtocolKind::Generic => generic::ERR_WATCHDOG,
            ProtocolKind::Cia402 => unreachable!("the rig plays generic and ODrive drives"),
        };
        r.started = false;
        r.heartbeat = true;
        r.feedback = true;
        // bus_recovery_s (0.5 s) of quiet, then the restart.
        r.run_s(0.55);
        assert!(!r.has_reason("drive_fault"), "{:?}", r.bridge.reasons());
        r.drive_error = 0; // the start-up's clear did its job
        r.run_s(0.1);
        assert_eq!(r.bridge.state(), BridgeState::Idle, "{:?}", r.bridge.reasons());
    }
}

#[test]
fn heartbeat_silence_latches_until_reset_and_a_fresh_command() {
    // Was: the bridge restarted the drive by itself when heartbeats came back.
    for rig in [Rig::odrive as fn() -> Rig, Rig::new] {
        let mut r = rig();
        r.ready();
        r.cmd(0.2, 0.0).unwrap();
        r.run_s(0.1);
        r.heartbeat = false;
        r.run_s(0.6);
        assert!(r.has_reason("heartbeat_lost"), "{:?}", r.bridge.reasons());
        assert_eq!(r.bridge.state(), BridgeState::Stopped);
        assert!(r
            .events()
            .iter()
            .any(|e| matches!(e, BridgeEvent::HeartbeatLostLatched { .. })));
        // The drive is back and commands are fresh: still zero, no restart.
        r.heartbeat = true;
        let t = r.t;
        for _ in 0..20 {
            r.cmd(0.2, 0.0).unwrap();
            r.run_s(0.05);
        }
        assert_eq!(r.bridge.state(), BridgeState::Stopped, "{:?}", r.bridge.reasons());
        assert!(r.has_reason("heartbeat_lost"));
        assert!(!r.has_reason("no_heartbeat"));
        let moving = r.sent.iter().filter(|(s, _)| *s > t).any(|(_, f)| match r.protocol {
            ProtocolKind::Odrive => f.id & 0x1F == odrive::cmd::SET_INPUT_VEL && f.data[..4] != [0; 4],
            ProtocolKind::Generic => generic::decode_setpoint(IDS, f)
                .ok()
                .flatten()
                .is_some_and(|(_, sp)| sp.vel_radps != 0.0),
            ProtocolKind::Cia402 => unreachable!("the rig plays generic and ODrive drives"),
        });
        assert!(!moving, "no motion before the reset");
        // Reset: restart, then the old command is not followed...
        r.bridge.reset(r.t);
        r.started = false;
        r.run_s(0.2);
        assert_eq!(r.bridge.reasons(), [StopReason::NoCommand], "{:?}", r.bridge.reasons());
        // ...a fresh one is.
        r.cmd(0.2, 0.0).unwrap();
        r.run(PERIOD * 2);
        assert_eq!(r.bridge.state(), BridgeState::Running, "{:?}", r.bridge.reasons());
    }
}

#[test]
fn a_heartbeat_lost_while_the_bus_was_blocked_is_not_latched() {
    // ENOBUFS blocks every sender on the interface, the drive's heartbeats
    // too. A heartbeat that times out within one heartbeat timeout of the
    // block's end is the bus's doing: not latched, recovery is automatic.
    let mut r = Rig::new();
    r.ready();
    r.cmd(0.2, 0.0).unwrap();
    r.run_s(0.1);
    r.bus.set_send_error(Some(SendError::QueueFull));
    r.heartbeat = false;
    for _ in 0..15 {
        r.cmd(0.2, 0.0).unwrap();
        r.run(PERIOD);
    }
    assert!(r.has_reason("tx_blocked"), "{:?}", r.bridge.reasons());
    // The bus is free after 0.3 s; the drive is heard again 0.3 s later,
    // after its heartbeat has timed out (0.5 s) on a bus that works.
    r.bus.set_send_error(None);
    for _ in 0..15 {
        r.cmd(0.2, 0.0).unwrap();
        r.run(PERIOD);
    }
    r.heartbeat = true;
    for _ in 0..40 {
        r.cmd(0.2, 0.0).unwrap();
        r.run(PERIOD);
    }
    assert!(!r
        .events()
        .iter()
        .any(|e| matches!(e, BridgeEvent::HeartbeatLostLatched { .. })));
    assert_eq!(r.bridge.state(), BridgeState::Running, "{:?}", r.bridge.reasons());
}

#[test]
fn odrive_startup_order_zero_before_closed_loop() {
    let mut r = Rig::odrive();
    r.run_s(0.1);
    for node in [3u32, 5] {
        let cmds: Vec<u32> = r
            .sent
            .iter()
            .filter(|(_, f)| odrive::split_id(f.id).0 == node)
            .map(|(_, f)| f.id & 0x1F)
            .collect();
        let closed = cmds.iter().position(|c| *c == odrive::cmd::SET_AXIS_STATE).unwrap();
        let clear = cmds.iter().position(|c| *c == odrive::cmd::CLEAR_ERRORS).unwrap();
        let mode = cmds
            .iter()
            .position(|c| *c == odrive::cmd::SET_CONTROLLER_MODE)
            .unwrap();
        let zero = cmds[..closed]
            .iter()
            .rposition(|c| *c == odrive::cmd::SET_INPUT_VEL)
            .unwrap();
        assert!(clear < mode && mode < zero && zero < closed, "{cmds:?}");
    }
    // Every velocity before Ready is zero.
    assert!(r
        .sent
        .iter()
        .filter(|(_, f)| f.id & 0x1F == odrive::cmd::SET_INPUT_VEL)
        .all(|(_, f)| f.data == [0; 8]));
}

#[test]
fn garbage_from_the_drive_is_rejected_and_stops_the_robot() {
    let mut r = Rig::new();
    r.ready();
    r.cmd(0.2, 0.0).unwrap();
    r.run_s(0.1);
    // The drive now sends only status frames with a broken CRC.
    r.heartbeat = false;
    for _ in 0..60 {
        let mut f = generic::encode_status(
            IDS,
            &generic::Status {
                state: generic::STATE_ENABLED,
                counter: r.counter,
                error_code: 0,
                rejected_setpoints: 0,
            },
        );
        r.counter = r.counter.wrapping_add(1);
        f.data[7] ^= 0xFF;
        r.bus.inject_frame(f);
        r.cmd(0.2, 0.0).unwrap();
        r.run(Duration::from_millis(10));
    }
    assert!(r.bridge.counters().rx_invalid >= 50);
    assert!(r.has_reason("no_heartbeat"));
    assert_eq!(r.last_pair().left, 0.0);
}

#[test]
fn a_frozen_drive_counter_is_not_a_heartbeat() {
    let mut r = Rig::new();
    r.ready();
    r.heartbeat = false;
    let frozen = generic::encode_status(
        IDS,
        &generic::Status {
            state: generic::STATE_ENABLED,
            counter: 42,
            error_code: 0,
            rejected_setpoints: 0,
        },
    );
    for _ in 0..60 {
        r.bus.inject_frame(frozen);
        r.run(Duration::from_millis(10));
    }
    assert!(r.has_reason("no_heartbeat"));
}

#[test]
fn receive_filters_accept_only_the_drive_ids() {
    let r = Rig::new();
    let ids: Vec<u32> = r.bus.rx_filters().unwrap().iter().map(|f| f.id).collect();
    assert_eq!(ids, [0x110, 0x111, 0x112]);
    let r = Rig::odrive();
    let ids: Vec<u32> = r.bus.rx_filters().unwrap().iter().map(|f| f.id).collect();
    assert_eq!(ids, [0x61, 0x69, 0xA1, 0xA9]);
}

// ----------------------------------------------------------------- bus errors

#[test]
fn bus_off_stops_until_the_bus_is_back_and_quiet() {
    let mut c = cfg(ProtocolKind::Generic);
    c.timing.cmd_timeout_s = 5.0;
    let mut r = Rig::with(c);
    r.ready();
    r.cmd(0.2, 0.0).unwrap();
    r.run_s(0.1);
    // No frames from the drive while bus-off (the controller is off).
    r.heartbeat = false;
    r.feedback = false;
    r.bus.inject_error(CanErrorFrame::bus_off());
    r.run(PERIOD);
    assert!(r.has_reason("bus_error"));
    assert_eq!(r.bridge.state(), BridgeState::Stopped);
    assert_eq!(r.last_pair().left, 0.0);
    r.run_s(1.0);
    assert!(r.has_reason("bus_error"), "not back without evidence");
    // Controller restarted; drive frames flow again; quiet for bus_recovery_s.
    r.bus.inject_error(CanErrorFrame::restarted());
    r.heartbeat = true;
    r.feedback = true;
    r.run_s(0.3);
    assert!(r.has_reason("bus_error"), "still within bus_recovery_s");
    r.run_s(0.4);
    assert!(!r.has_reason("bus_error"), "{:?}", r.bridge.reasons());
    assert_eq!(r.bridge.reasons(), [StopReason::AwaitingFreshCommand]);
    r.cmd(0.2, 0.0).unwrap();
    r.run(PERIOD * 2);
    assert!(r.last_pair().left > 0.0);
    let ev = r.events();
    assert!(ev.iter().any(|e| matches!(e, BridgeEvent::BusRecovered)));
    assert!(ev
        .iter()
        .any(|e| matches!(e, BridgeEvent::BusError { fatal: true, description } if description == "bus-off")));
}

#[test]
fn warning_error_frames_are_counted_but_do_not_stop() {
    let mut r = Rig::new();
    r.ready();
    r.cmd(0.2, 0.0).unwrap();
    for _ in 0..20 {
        r.bus.inject_error(CanErrorFrame {
            class: err::LOSTARB | err::PROT,
            data: [0; 8],
        });
        r.cmd(0.2, 0.0).unwrap();
        r.run(PERIOD);
    }
    assert_eq!(r.bridge.state(), BridgeState::Running);
    assert_eq!(r.bridge.counters().error_frames, 20);
    let reported = r
        .events()
        .iter()
        .filter(|e| matches!(e, BridgeEvent::BusError { fatal: false, .. }))
        .count();
    assert_eq!(reported, 1, "rate-limited to one per second");
}

#[test]
fn interface_down_stops_and_recovers_when_io_works() {
    let mut c = cfg(ProtocolKind::Generic);
    c.timing.cmd_timeout_s = 5.0;
    let mut r = Rig::with(c);
    r.ready();
    r.cmd(0.2, 0.0).unwrap();
    r.run_s(0.1);
    let down = crate::bus::BusError("send: Network is down (os error 100)".into());
    r.bus.set_send_error(Some(SendError::Failed(down.clone())));
    r.bus.set_recv_error(Some(down));
    r.run_s(0.5);
    assert!(r.has_reason("bus_error"));
    r.bus.set_send_error(None);
    r.bus.set_recv_error(None);
    r.run_s(0.7);
    assert!(!r.has_reason("bus_error"), "{:?}", r.bridge.reasons());
    assert_eq!(r.bridge.reasons(), [StopReason::AwaitingFreshCommand]);
}

// ----------------------------------------------------------------- ENOBUFS

#[test]
fn full_tx_queue_bounded_retry_stale_dropped_then_fresh_frames_only() {
    let mut r = Rig::new();
    r.ready();
    r.cmd(0.2, 0.0).unwrap();
    r.run_s(0.1);
    let last_counter = r.last_pair().counter;
    let attempts0 = r.bus.send_attempts();
    r.bus.set_send_error(Some(SendError::QueueFull));
    for _ in 0..20 {
        r.cmd(0.2, 0.0).unwrap();
        r.run(PERIOD);
    }
    // 20 periods: each period's pair is tried at most TX_MAX_ATTEMPTS times,
    // then dropped whole (never the right wheel alone).
    let attempts = r.bus.send_attempts() - attempts0;
    let max = 20 * u64::from(crate::tx_queue::TX_MAX_ATTEMPTS);
    assert!(attempts >= 20 && attempts <= max, "bounded: {attempts}");
    assert!(r.has_reason("tx_blocked"));
    assert_eq!(r.bridge.state(), BridgeState::Stopped);
    let c = r.bridge.counters();
    assert!(c.tx_queue_full > 0 && c.tx_dropped_after_retries + c.tx_dropped_stale > 0);
    // The queue is free again: what goes out is this period's pair, not a backlog.
    r.bus.set_send_error(None);
    let t = r.t;
    r.run(PERIOD - Duration::from_millis(1));
    // This period's pair (retried) and the drive's start-up pair (Enable 0),
    // nothing from earlier periods.
    let pairs = r.pairs_since(t);
    let hold: Vec<_> = pairs.iter().filter(|p| p.enable).collect();
    assert_eq!(hold.len(), 1, "no backlog: {pairs:?}");
    assert_eq!(hold[0].left, 0.0, "stopped: zero, not the old command");
    assert!(hold[0].t - t <= Duration::from_millis(2), "the current pair, retried");
    assert!(
        hold[0].counter.wrapping_sub(last_counter) > 10,
        "the dropped pairs' counters were skipped"
    );
    // The drive is restarted and a fresh command is needed.
    r.run_s(0.1);
    assert_eq!(r.bridge.reasons(), [StopReason::AwaitingFreshCommand]);
    r.cmd(0.2, 0.0).unwrap();
    r.run(PERIOD * 2);
    assert!(r.last_pair().left > 0.0);
    assert!(r.events().iter().any(|e| matches!(e, BridgeEvent::TxQueueFull)));
}

#[test]
fn a_single_full_queue_is_absorbed_by_the_retry() {
    let mut r = Rig::new();
    r.ready();
    r.cmd(0.2, 0.0).unwrap();
    r.run_s(0.1);
    r.bus.fail_next_sends(2, SendError::QueueFull);
    let t = r.t;
    r.cmd(0.2, 0.0).unwrap();
    r.run(PERIOD + Duration::from_millis(5));
    assert_eq!(r.pairs_since(t).len(), 1, "sent on the third attempt");
    assert_eq!(r.bridge.state(), BridgeState::Running);
}

// ----------------------------------------------------------------- odometry and status

#[test]
fn feedback_feeds_odometry_and_status_serializes() {
    let mut r = Rig::new();
    r.ready();
    // Feedback with the right motor reversed (direction −1) and gear 10:
    // both wheels +1 rad → 0.033 m straight ahead.
    r.feedback = false;
    for (i, (l, rr)) in [(0.0, 0.0), (10.0, -10.0)].into_iter().enumerate() {
        for (w, pos) in [(Wheel::Left, l), (Wheel::Right, rr)] {
            let fb = generic::Feedback {
                vel_radps: 0.0,
                pos_rad: pos,
                counter: 200 + i as u8,
            };
            r.bus.inject_frame(generic::encode_feedback(IDS, w, &fb));
        }
        r.run(Duration::from_millis(10));
    }
    let o = r.bridge.odometry();
    assert!((o.pose.x_m - 0.033).abs() < 1e-9, "{o:?}");
    let s = r.bridge.status(r.t);
    let json = serde_json::to_value(&s).unwrap();
    assert_eq!(json["state"], "idle");
    assert!(json["odometry"]["pose"]["x_m"].as_f64().unwrap() > 0.03);
}

#[test]
fn shutdown_sends_zero_then_disable() {
    let mut r = Rig::odrive();
    r.ready();
    r.bus.take_sent();
    assert_eq!(r.bridge.shutdown(r.t), ShutdownProgress::Done { failed: 0 });
    let sent = r.bus.sent();
    let cmds: Vec<u32> = sent.iter().map(|f| f.id & 0x1F).collect();
    assert_eq!(
        cmds,
        [
            odrive::cmd::SET_INPUT_VEL,
            odrive::cmd::SET_INPUT_VEL,
            odrive::cmd::SET_AXIS_STATE,
            odrive::cmd::SET_AXIS_STATE
        ]
    );
    assert_eq!(sent[2].data[0], 1, "IDLE");
}

#[test]
fn bad_config_is_refused() {
    let mut c = cfg(ProtocolKind::Generic);
    c.timing.tx_rate_hz = f64::NAN;
    assert!(matches!(
        Bridge::new(c, FakeBus::new(), Timestamp::ZERO),
        Err(BridgeError::Config(_))
    ));
}

#[test]
fn the_clock_going_backwards_does_not_panic_or_move() {
    let mut r = Rig::new();
    r.ready();
    r.cmd(0.2, 0.0).unwrap();
    r.run_s(0.1);
    r.bridge.tick(Timestamp::from_secs_f64(1.0));
    r.bridge.poll_bus(Timestamp::ZERO);
    r.bridge.tick(Timestamp::ZERO);
    let _ = r.bridge.status(Timestamp::ZERO);
}
