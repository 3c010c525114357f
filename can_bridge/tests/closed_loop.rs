//! The bridge against the virtual drive on an in-memory wire, in simulated
//! time: odometry through a real drive model, drive faults, the drive's own
//! watchdog. (The same scenarios on a kernel vcan bus are in vcan_*.rs.)

mod common;

use can_bridge::diagnostics::BridgeState;
use can_bridge::virtual_drive::FaultKind;
use can_bridge::{ProtocolKind, Twist, Wheel};
use common::*;
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};

/// Straight 0.4 m, a quarter turn in place, straight 0.4 m: ends at
/// (0.4, 0.4, π/2). Commands stream at 20 Hz and end with an explicit zero
/// (a teleop releasing the stick); accel = decel, so ramps cancel.
fn square_corner(protocol: ProtocolKind) -> Sim {
    let mut c = bridge_config(protocol);
    c.limits.wheel_accel_radps2 = 30.0;
    c.limits.wheel_decel_radps2 = 30.0;
    let d = drive_config(&c);
    let mut sim = Sim::new(c, d);
    sim.run_s(0.5);
    assert_eq!(sim.bridge.state(), BridgeState::Idle, "{:?}", sim.bridge.reasons());
    sim.stream(Twist::new(0.2, 0.0), 2.0);
    sim.stream(Twist::ZERO, 1.0);
    sim.stream(Twist::new(0.0, FRAC_PI_4), 2.0);
    sim.stream(Twist::ZERO, 1.0);
    sim.stream(Twist::new(0.2, 0.0), 2.0);
    sim.stream(Twist::ZERO, 1.0);
    sim
}

#[test]
fn odometry_through_the_virtual_drive_gives_the_commanded_pose() {
    for protocol in ALL {
        let sim = square_corner(protocol);
        let o = sim.bridge.odometry();
        let p = o.pose;
        assert!(
            (p.x_m - 0.4).abs() < 2e-3 && (p.y_m - 0.4).abs() < 2e-3 && (p.theta_rad - FRAC_PI_2).abs() < 5e-3,
            "{protocol:?}: {p:?}"
        );
        // Feedback pairs at 100 Hz (CiA 402: TPDO2 after each SYNC, 50 Hz).
        let want = if protocol == ProtocolKind::Cia402 { 450 } else { 900 };
        assert!(o.updates > want, "{protocol:?}: {o:?}");
        assert_eq!(o.resets, 0);
        // The drive's own positions agree: each wheel turned (0.8 m ± the turn)/r × gear.
        let l = sim.drive.axis(Wheel::Left).pos_rad;
        let arc = FRAC_PI_2 * 0.08;
        assert!((l - 10.0 * (0.8 - arc) / 0.033).abs() < 0.1, "{l}");
        assert_wire_is_clean(&sim.tap.wire_log(), protocol);
    }
}

#[test]
fn setpoints_on_the_wire_equal_the_kinematics() {
    for protocol in ALL {
        let c = bridge_config(protocol);
        let d = drive_config(&c);
        let mut sim = Sim::new(c, d);
        sim.run_s(0.5);
        sim.stream(Twist::new(0.2, 0.5), 1.5);
        let speeds = assert_wire_is_clean(&sim.tap.wire_log(), protocol);
        let (l, r) = speeds.iter().rev().fold((None, None), |(l, r), (w, v)| match w {
            0 if l.is_none() => (Some(*v), r),
            1 if r.is_none() => (l, Some(*v)),
            _ => (l, r),
        });
        // (0.2 ∓ 0.5·0.08)/0.033 × 10, right motor reversed.
        let want_l = 10.0 * 0.16 / 0.033;
        let want_r = -10.0 * 0.24 / 0.033;
        // CiA 402 carries integer rpm (EPOS units): ±0.5 rpm = 0.052 rad/s.
        let tol = |w: f64| match protocol {
            ProtocolKind::Cia402 => 0.5 * std::f64::consts::TAU / 60.0 + 1e-9,
            _ => w.abs() * 1e-6 + 1e-5,
        };
        assert!((l.unwrap() - want_l).abs() < tol(want_l), "{protocol:?} {l:?}");
        assert!((r.unwrap() - want_r).abs() < tol(want_r), "{protocol:?} {r:?}");
        // The drive follows.
        assert!((sim.drive.axis(Wheel::Left).vel_radps - want_l).abs() < tol(want_l) + 1e-3);
    }
}

#[test]
fn drive_killed_stops_the_bridge_within_the_heartbeat_timeout() {
    for protocol in ALL {
        let c = bridge_config(protocol);
        let d = drive_config(&c);
        let mut sim = Sim::new(c, d);
        sim.run_s(0.5);
        sim.stream(Twist::new(0.2, 0.0), 1.0);
        assert_eq!(sim.bridge.state(), BridgeState::Running);
        sim.drive_alive = false;
        let killed = sim.s();
        let mut stopped = None;
        for _ in 0..1000 {
            sim.stream(Twist::new(0.2, 0.0), 0.001);
            if stopped.is_none() && sim.bridge.state() == BridgeState::Stopped {
                stopped = Some(sim.s());
            }
        }
        let stopped = stopped.expect("stopped");
        // Feedback (0.2 s) goes first; heartbeat (0.5 s) follows.
        assert!(
            stopped - killed <= 0.2 + 0.02 + 1e-9,
            "{protocol:?}: {}",
            stopped - killed
        );
        assert!(sim.has_reason("no_heartbeat"), "{:?}", sim.bridge.reasons());
        assert_eq!(sim.bridge.last_setpoint(), can_bridge::WheelSpeeds::ZERO);
    }
}

#[test]
fn axis_error_in_a_heartbeat_stops_and_latches() {
    for protocol in ALL {
        let c = bridge_config(protocol);
        let d = drive_config(&c);
        let mut sim = Sim::new(c, d);
        sim.run_s(0.5);
        sim.stream(Twist::new(0.2, 0.0), 0.5);
        let t = sim.t;
        sim.drive.inject(
            FaultKind::AxisError {
                code: 0x20,
                wheel: Some(Wheel::Right),
            },
            None,
            t,
        );
        sim.stream(Twist::new(0.2, 0.0), 0.3);
        assert!(sim.has_reason("drive_fault"), "{protocol:?} {:?}", sim.bridge.reasons());
        assert_eq!(sim.bridge.last_setpoint(), can_bridge::WheelSpeeds::ZERO);
        // Latched although the command stream continues.
        sim.stream(Twist::new(0.2, 0.0), 1.0);
        assert!(sim.has_reason("drive_fault"));
        // Reset clears the error through the start-up sequence; a fresh command moves.
        let t = sim.t;
        sim.bridge.reset(t);
        sim.stream(Twist::new(0.2, 0.0), 0.5);
        assert_eq!(
            sim.bridge.state(),
            BridgeState::Running,
            "{protocol:?} {:?}",
            sim.bridge.reasons()
        );
    }
}

#[test]
fn heartbeat_silence_stops_latched_until_reset_then_a_fresh_command_resumes() {
    for protocol in ALL {
        let c = bridge_config(protocol);
        let d = drive_config(&c);
        let mut sim = Sim::new(c, d);
        sim.run_s(0.5);
        sim.stream(Twist::new(0.1, 0.0), 0.5);
        let t = sim.t;
        sim.drive.inject(FaultKind::HeartbeatSilence, Some(1.0), t);
        sim.stream(Twist::new(0.1, 0.0), 0.8);
        assert!(sim.has_reason("no_heartbeat"));
        // Heartbeats are back and commands fresh: still stopped (latched).
        sim.stream(Twist::new(0.1, 0.0), 1.0);
        assert!(
            sim.has_reason("heartbeat_lost"),
            "{protocol:?}: {:?}",
            sim.bridge.reasons()
        );
        assert_eq!(sim.bridge.state(), BridgeState::Stopped);
        // Reset, then fresh commands: running again.
        let now = sim.t;
        sim.bridge.reset(now);
        sim.stream(Twist::new(0.1, 0.0), 1.0);
        assert_eq!(
            sim.bridge.state(),
            BridgeState::Running,
            "{protocol:?}: {:?}",
            sim.bridge.reasons()
        );
    }
}

#[test]
fn the_drives_own_watchdog_idles_it_when_the_bridge_dies() {
    for protocol in ALL {
        let c = bridge_config(protocol);
        let d = drive_config(&c);
        let mut sim = Sim::new(c, d);
        sim.run_s(0.5);
        sim.stream(Twist::new(0.2, 0.0), 0.5);
        assert!(sim.drive.axis(Wheel::Left).running);
        sim.bridge_alive = false;
        sim.run_s(0.6);
        let a = sim.drive.axis(Wheel::Left);
        assert!(!a.running && a.error_code != 0, "{protocol:?}: {a:?}");
        sim.run_s(0.5);
        assert!(sim.drive.axis(Wheel::Left).vel_radps.abs() < 1e-3, "coasted to a stop");
        assert!(sim.drive.stats().watchdog_trips >= 1);
    }
}

#[test]
fn delayed_feedback_beyond_the_timeout_stops() {
    let c = bridge_config(ProtocolKind::Odrive);
    let d = drive_config(&c);
    let mut sim = Sim::new(c, d);
    sim.run_s(0.5);
    sim.stream(Twist::new(0.1, 0.0), 0.5);
    let t = sim.t;
    // Feedback 0.3 s late: a 0.3 s gap (> 0.2 s timeout) when it starts.
    sim.drive
        .inject(FaultKind::FeedbackDelay { delay_s: 0.3 }, Some(2.0), t);
    sim.stream(Twist::new(0.1, 0.0), 0.28);
    assert!(sim.has_reason("feedback_lost"));
    sim.stream(Twist::new(0.1, 0.0), 0.2);
    assert_eq!(sim.bridge.state(), BridgeState::Running, "{:?}", sim.bridge.reasons());
}

#[test]
fn the_odrive_startup_never_asks_for_closed_loop_with_a_nonzero_input() {
    let c = bridge_config(ProtocolKind::Odrive);
    let d = drive_config(&c);
    let mut sim = Sim::new(c, d);
    sim.run_s(0.5);
    for _ in 0..3 {
        sim.stream(Twist::new(0.2, 0.3), 0.5);
        let t = sim.t;
        sim.bridge.estop(t);
        sim.run_s(0.2);
        let t = sim.t;
        sim.bridge.reset(t);
        sim.run_s(0.3);
    }
    assert_eq!(sim.drive.stats().closed_loop_with_nonzero_input, 0);
    assert!(sim.drive.stats().estops >= 6);
}
