//! The bridge against the virtual drive on an in-memory wire, in simulated
//! time: odometry through a real drive model, drive faults, the drive's own
//! watchdog. (The same scenarios on a kernel vcan bus are in vcan_*.rs.)

mod common;

use can_bridge::diagnostics::BridgeState;
use can_bridge::protocol::odrive;
use can_bridge::virtual_drive::FaultKind;
use can_bridge::{ProtocolKind, SendError, Twist, Wheel};
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

// ------------------------------------------------------------------ ODrive 0.6

/// A blocked transmit queue for 0.8 s (ENOBUFS): the bridge sees the loss
/// (`tx_blocked`) and the ODrive's own watchdog disarms the axes. When the
/// bus is back, the bridge clears the error by its restart only if it reads
/// it as the watchdog's in the drive's firmware numbering: 0x01000000 in
/// 0.6. A bridge configured for 0.5 (watchdog 0x800) latches the same code.
fn odrive_watchdog_after_a_blocked_bus(bridge_fw: odrive::Firmware) -> Sim {
    let mut c = bridge_config(ProtocolKind::Odrive);
    c.odrive.firmware = odrive::Firmware::V0_6;
    let d = drive_config(&c);
    c.odrive.firmware = bridge_fw;
    let mut sim = Sim::new(c, d);
    sim.run_s(0.5);
    sim.stream(Twist::new(0.2, 0.0), 0.5);
    assert_eq!(sim.bridge.state(), BridgeState::Running, "{:?}", sim.bridge.reasons());
    sim.bridge.bus().set_send_error(Some(SendError::QueueFull));
    sim.stream(Twist::new(0.2, 0.0), 0.8);
    assert!(sim.has_reason("tx_blocked"), "{:?}", sim.bridge.reasons());
    let a = sim.drive.axis(Wheel::Left);
    assert!(!a.running && a.error_code == 0x0100_0000, "{a:?}");
    sim.bridge.bus().set_send_error(None);
    sim.stream(Twist::new(0.2, 0.0), 1.5);
    sim
}

#[test]
fn odrive_0_6_watchdog_error_after_a_loss_is_cleared_by_the_restart() {
    let sim = odrive_watchdog_after_a_blocked_bus(odrive::Firmware::V0_6);
    assert_eq!(sim.bridge.state(), BridgeState::Running, "{:?}", sim.bridge.reasons());
    assert!(sim.drive.axis(Wheel::Left).running);
}

#[test]
fn odrive_0_6_watchdog_code_read_as_0_5_is_latched() {
    let sim = odrive_watchdog_after_a_blocked_bus(odrive::Firmware::V0_5);
    assert_eq!(sim.bridge.state(), BridgeState::Stopped, "{:?}", sim.bridge.reasons());
    assert!(
        sim.bridge.reasons().iter().any(|r| matches!(
            r,
            can_bridge::diagnostics::StopReason::DriveFault {
                error_code: 0x0100_0000,
                ..
            }
        )),
        "{:?}",
        sim.bridge.reasons()
    );
}

/// The whole 0.6 chain: the square corner's pose, the axis error latched and
/// named in the report, e-stop with 0.6's ESTOP_REQUESTED and recovery.
#[test]
fn odrive_0_6_drives_latches_names_and_recovers() {
    let mut c = bridge_config(ProtocolKind::Odrive);
    c.odrive.firmware = odrive::Firmware::V0_6;
    let d = drive_config(&c);
    let mut sim = Sim::new(c, d);
    sim.run_s(0.5);
    sim.stream(Twist::new(0.2, 0.0), 1.0);
    assert!(sim.bridge.odometry().pose.x_m > 0.1, "{:?}", sim.bridge.odometry());
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
    let events = sim.bridge.drain_events();
    let latched = events.iter().find_map(|e| match &e.event {
        BridgeEvent::DriveFaultLatched { wheel, error_code, .. } => Some((*wheel, *error_code)),
        _ => None,
    });
    assert_eq!(latched, Some((Wheel::Right, 0x20)));
    let reports: Vec<String> = events
        .iter()
        .filter_map(|e| match &e.event {
            BridgeEvent::DriveReport { message, .. } => Some(message.clone()),
            _ => None,
        })
        .collect();
    assert!(
        reports.contains(&"node 5 axis error 0x00000020 (DRV_FAULT), firmware 0.6".to_string())
            && reports.contains(&"node 5 procedure result 3 (DISARMED)".to_string()),
        "{reports:?}"
    );
    let t = sim.t;
    sim.bridge.reset(t);
    sim.stream(Twist::new(0.2, 0.0), 0.5);
    assert_eq!(sim.bridge.state(), BridgeState::Running, "{:?}", sim.bridge.reasons());
    let t = sim.t;
    sim.bridge.estop(t);
    sim.run_s(0.2);
    assert_eq!(sim.drive.axis(Wheel::Left).error_code, 0x0200_0000);
    let t = sim.t;
    sim.bridge.reset(t);
    sim.stream(Twist::new(0.2, 0.0), 0.5);
    assert_eq!(sim.bridge.state(), BridgeState::Running, "{:?}", sim.bridge.reasons());
    assert_wire_is_clean(&sim.tap.wire_log(), ProtocolKind::Odrive);
}

// ------------------------------------------------------------------ CiA 402

use can_bridge::diagnostics::BridgeEvent;
use can_bridge::protocol::cia402::pdo::{self as co_pdo, obj};
use can_bridge::protocol::cia402::sdo::{self as co_sdo, ObjectAddr};
use can_bridge::protocol::cia402::state_machine::DriveState;
use can_bridge::{BusEvent, CanBus, CanErrorFrame, CanFrame, Timestamp};

fn cia402_sim_with(c: can_bridge::BridgeConfig, faults: Vec<can_bridge::virtual_drive::FaultSpec>) -> Sim {
    let mut d = drive_config(&c);
    d.faults = faults;
    Sim::new(c, d)
}

fn cia402_sim() -> Sim {
    cia402_sim_with(bridge_config(ProtocolKind::Cia402), Vec::new())
}

/// (time, node, controlword, target) of every RPDO1 on the wire.
fn rpdos(sim: &Sim) -> Vec<(Timestamp, u32, u16, i32)> {
    let mut out = Vec::new();
    let mut t = Timestamp::ZERO;
    for f in sim.tap.wire_log() {
        // The wire log has no times: SYNC closes each period.
        if f.id == 0x080 {
            t = t + std::time::Duration::from_millis(20);
        }
        if f.id & !0x7F == 0x200 {
            let r = co_pdo::decode_rpdo1(&f).unwrap();
            out.push((t, f.id & 0x7F, r.controlword, r.target_velocity));
        }
    }
    out
}

fn reports(sim: &mut Sim) -> Vec<String> {
    sim.bridge
        .drain_events()
        .into_iter()
        .filter_map(|e| match e.event {
            BridgeEvent::DriveReport { message, .. } => Some(message),
            _ => None,
        })
        .collect()
}

#[test]
fn cia402_startup_writes_the_configuration_and_enables_only_at_zero() {
    let mut sim = cia402_sim();
    sim.run_s(0.5);
    assert_eq!(sim.bridge.state(), BridgeState::Idle, "{:?}", sim.bridge.reasons());
    for w in Wheel::BOTH {
        let n = sim.drive.cia402_node(w).unwrap();
        assert_eq!(
            sim.drive.cia402_axis(w).unwrap().machine.state,
            DriveState::OperationEnabled
        );
        // Values by hand: 1000 rad/s² = 9549 rpm/s, 2000 → 19099; 127 << 16 | 300.
        let want = [
            (obj::MODES_OF_OPERATION, 3),
            (obj::PROFILE_ACCELERATION, 9549),
            (obj::PROFILE_DECELERATION, 9549),
            (obj::QUICK_STOP_DECELERATION, 19099),
            (obj::PRODUCER_HEARTBEAT, 100),
            (obj::CONSUMER_HEARTBEAT_1, 0x007F_012C),
            (obj::RPDO1_TYPE, 1),
            (obj::TPDO1_TYPE, 1),
            (ObjectAddr::new(0x1A01, 1), 0x6064_0020),
            (ObjectAddr::new(0x1A00, 0), 3),
        ];
        for (a, v) in want {
            assert_eq!(n.object(a), Some(v), "{w:?} {a}");
        }
    }
    // Per node: NMT pre-operational, then SDO only, NMT start after the last SDO.
    let log = sim.tap.wire_log();
    for node in [1u8, 2] {
        let pre = log
            .iter()
            .position(|f| f.id == 0 && f.data[..2] == [0x80, node])
            .unwrap();
        let first_sdo = log.iter().position(|f| f.id == 0x600 + u32::from(node)).unwrap();
        let last_sdo = log.iter().rposition(|f| f.id == 0x600 + u32::from(node)).unwrap();
        let start = log
            .iter()
            .position(|f| f.id == 0 && f.data[..2] == [0x01, node])
            .unwrap();
        assert!(
            pre < first_sdo && last_sdo < start,
            "node {node}: {pre} {first_sdo} {last_sdo} {start}"
        );
    }
    // Controlwords: shutdown, switch on, enable operation, each at zero target.
    for node in [1, 2] {
        let words: Vec<(u16, i32)> = rpdos(&sim).iter().filter(|r| r.1 == node).map(|r| (r.2, r.3)).collect();
        let first_enable = words.iter().position(|w| w.0 == 0x000F).unwrap();
        assert!(words[..first_enable].contains(&(0x0006, 0)) && words[..first_enable].contains(&(0x0007, 0)));
        assert_eq!(words[first_enable].1, 0);
        assert!(words[..first_enable].iter().all(|w| w.1 == 0));
    }
    // Motion, e-stops and resets: never enabled with a non-zero target.
    for _ in 0..3 {
        sim.stream(Twist::new(0.2, 0.3), 0.5);
        let t = sim.t;
        sim.bridge.estop(t);
        sim.run_s(0.3);
        let t = sim.t;
        sim.bridge.reset(t);
        sim.run_s(0.5);
    }
    assert_eq!(sim.drive.stats().closed_loop_with_nonzero_input, 0);
    assert_eq!(sim.drive.stats().estops, 6, "one quick stop per node per e-stop");
    assert_wire_is_clean(&sim.tap.wire_log(), ProtocolKind::Cia402);
}

#[test]
fn cia402_estop_quick_stops_the_drive_at_0x6085() {
    let mut sim = cia402_sim();
    sim.run_s(0.5);
    sim.stream(Twist::new(0.2, 0.0), 1.0);
    let v0 = sim.drive.axis(Wheel::Left).vel_radps;
    assert!(v0 > 50.0, "{v0}");
    let t = sim.t;
    sim.bridge.estop(t);
    let n = sim.tap.wire_log().len();
    sim.run_s(0.001);
    let after: Vec<CanFrame> = sim.tap.wire_log()[n - 3..].to_vec();
    assert!(
        after
            .iter()
            .any(|f| f.id == 0x201 && f.data[..6] == [0x02, 0, 0, 0, 0, 0]),
        "{after:?}"
    );
    let mut slow = None;
    for i in 0..600 {
        sim.run_s(0.001);
        if slow.is_none() && sim.drive.axis(Wheel::Left).vel_radps.abs() < 1.0 {
            slow = Some(f64::from(i + 1) * 1e-3);
        }
    }
    // The demand ramps down at 2000 rad/s² (0x6085) in v0 / 2000 s; the
    // motor (first-order lag, τ = 0.05 s) follows within τ ln(v0 / 1 rad/s).
    let s = slow.expect("slowed down");
    let bound = v0 / 2000.0 + 0.05 * (v0 / 1.0).ln() + 0.02;
    assert!(s < bound, "{s} s from {v0} rad/s, bound {bound}");
    assert!(sim.drive.stats().estops >= 2);
    assert_eq!(
        sim.drive.cia402_axis(Wheel::Left).unwrap().machine.state,
        DriveState::SwitchOnDisabled
    );
}

#[test]
fn cia402_sdo_timeout_at_startup_is_reported_and_retried() {
    let faults = vec!["sdo_silence@0+1".parse().unwrap()];
    let mut sim = cia402_sim_with(bridge_config(ProtocolKind::Cia402), faults);
    sim.run_s(1.0);
    let r = reports(&mut sim);
    assert!(
        r.iter()
            .any(|m| m == "node 1 start-up failed: SDO 0x1000:00: no response within 200 ms"),
        "{r:?}"
    );
    assert_eq!(sim.bridge.state(), BridgeState::Starting, "{:?}", sim.bridge.reasons());
    // startup_timeout_s (2 s) after the first attempt: retried, and it works.
    sim.run_s(2.0);
    assert_eq!(sim.bridge.state(), BridgeState::Idle, "{:?}", sim.bridge.reasons());
    assert!(rpdos(&sim).iter().all(|r| r.3 == 0));
    sim.stream(Twist::new(0.1, 0.0), 0.3);
    assert_eq!(sim.bridge.state(), BridgeState::Running);
}

#[test]
fn cia402_sdo_abort_at_startup_latches_a_drive_fault_with_its_code() {
    // The drive answers nothing; the test answers the device type, then aborts the next write.
    let faults = vec!["sdo_silence@0+3".parse().unwrap()];
    let mut sim = cia402_sim_with(bridge_config(ProtocolKind::Cia402), faults);
    let mut answered = 0;
    for _ in 0..300 {
        sim.run_s(0.001);
        for f in sim.tap.wire_log().into_iter().skip(answered) {
            answered += 1;
            if f.id != 0x601 {
                continue;
            }
            let r = match co_sdo::decode_request(&f).unwrap() {
                co_sdo::SdoRequest::Upload { addr } => co_sdo::SdoResponse::Uploaded {
                    addr,
                    value: co_sdo::SdoValue::u32(0x0002_0192),
                },
                co_sdo::SdoRequest::Download { addr, .. } => co_sdo::SdoResponse::Abort {
                    addr,
                    code: co_sdo::abort::INVALID_VALUE,
                },
                _ => continue,
            };
            sim.tap.send(&co_sdo::encode_response(1, &r)).unwrap();
        }
    }
    let r = reports(&mut sim);
    assert!(
        r.iter().any(|m| m
            == "node 1 start-up failed: SDO 0x1017:00 aborted by the drive: 0x06090030 (invalid value for parameter)"),
        "{r:?}"
    );
    sim.run_s(2.0);
    assert!(sim.has_reason("drive_fault"), "{:?}", sim.bridge.reasons());
    let e = sim.bridge.status(sim.t);
    assert_eq!(e.left.error_code, 0x0609_0030);
    assert!(rpdos(&sim).iter().all(|r| r.3 == 0 && r.2 != 0x000F));
    // Latched until reset; after the reset (the drive answers again) it starts.
    sim.stream(Twist::new(0.1, 0.0), 1.0);
    assert!(sim.has_reason("drive_fault"));
    let t = sim.t;
    sim.bridge.reset(t);
    sim.stream(Twist::new(0.1, 0.0), 1.0);
    assert_eq!(sim.bridge.state(), BridgeState::Running, "{:?}", sim.bridge.reasons());
}

#[test]
fn cia402_reboot_while_driving_stops_within_a_period_and_restarts() {
    let mut sim = cia402_sim();
    sim.run_s(0.5);
    sim.stream(Twist::new(0.2, 0.0), 0.5);
    assert_eq!(sim.bridge.state(), BridgeState::Running);
    let t = sim.t;
    sim.drive.inject(
        FaultKind::Reboot {
            wheel: Some(Wheel::Right),
        },
        None,
        t,
    );
    let n = rpdos(&sim).len();
    sim.stream(Twist::new(0.2, 0.0), 0.045);
    // The boot-up is seen at once; the next period's RPDOs are zero.
    let after = rpdos(&sim);
    assert!(after[n..].iter().skip(2).all(|r| r.3 == 0), "{:?}", &after[n..]);
    assert!(reports(&mut sim)
        .iter()
        .any(|m| m == "node 2 booted (boot-up message): restarting it"));
    // Restarted (SDO, enable) and driving again with the fresh commands.
    sim.stream(Twist::new(0.2, 0.0), 1.0);
    assert_eq!(sim.bridge.state(), BridgeState::Running, "{:?}", sim.bridge.reasons());
}

#[test]
fn cia402_bus_off_stops_and_recovers() {
    let mut sim = cia402_sim();
    sim.run_s(0.5);
    sim.stream(Twist::new(0.2, 0.0), 0.5);
    let t = sim.t;
    sim.bridge
        .handle_bus_event(BusEvent::Error(CanErrorFrame::bus_off()), t);
    sim.stream(Twist::new(0.2, 0.0), 0.03);
    assert!(sim.has_reason("bus_error"));
    assert_eq!(sim.bridge.last_setpoint(), can_bridge::WheelSpeeds::ZERO);
    let n = rpdos(&sim).len();
    sim.stream(Twist::new(0.2, 0.0), 0.3);
    assert!(rpdos(&sim)[n..].iter().all(|r| r.3 == 0));
    // Drive frames show the bus is back: bus_recovery_s (0.5 s), restart, fresh commands.
    sim.stream(Twist::new(0.2, 0.0), 1.5);
    assert_eq!(sim.bridge.state(), BridgeState::Running, "{:?}", sim.bridge.reasons());
}

#[test]
fn cia402_without_sync_and_with_a_preconfigured_mapping() {
    let mut c = bridge_config(ProtocolKind::Cia402);
    c.cia402.sync_producer = false;
    c.cia402.pdo_mapping = can_bridge::protocol::cia402::PdoMapping::Preconfigured;
    c.limits.wheel_accel_radps2 = 30.0;
    c.limits.wheel_decel_radps2 = 30.0;
    let mut sim = cia402_sim_with(c, Vec::new());
    sim.run_s(0.5);
    assert_eq!(sim.bridge.state(), BridgeState::Idle, "{:?}", sim.bridge.reasons());
    sim.stream(Twist::new(0.2, 0.0), 2.0);
    sim.stream(Twist::ZERO, 1.0);
    let p = sim.bridge.odometry().pose;
    assert!((p.x_m - 0.4).abs() < 2e-3 && p.y_m.abs() < 1e-3, "{p:?}");
    let log = sim.tap.wire_log();
    assert!(!log.iter().any(|f| f.id == 0x080), "no SYNC");
    // No PDO configuration written: no SDO to 0x14xx-0x1Axx.
    assert!(!log
        .iter()
        .filter(|f| f.id == 0x601)
        .any(|f| (0x1400..=0x1BFF).contains(&u16::from_le_bytes([f.data[1], f.data[2]]))));
    assert!(sim.bridge.odometry().updates > 250, "TPDO2 every 10 ms");
}

// ------------------------------------------------------------------ one node, two axes

/// Both wheels on node 1: the left on axis 1, the right on axis 2 (+0x800),
/// as a Roboteq dual-channel controller carries them.
fn two_axis_sim(faults: Vec<can_bridge::virtual_drive::FaultSpec>) -> Sim {
    let mut c = bridge_config(ProtocolKind::Cia402);
    c.cia402.right_node_id = 1;
    c.cia402.right_axis = 2;
    c.limits.wheel_accel_radps2 = 30.0;
    c.limits.wheel_decel_radps2 = 30.0;
    cia402_sim_with(c, faults)
}

#[test]
fn two_axis_node_starts_both_axes_and_drives_the_square_corner() {
    let mut sim = two_axis_sim(Vec::new());
    sim.run_s(0.5);
    assert_eq!(sim.bridge.state(), BridgeState::Idle, "{:?}", sim.bridge.reasons());
    let node = sim.drive.cia402_node(Wheel::Left).unwrap();
    assert_eq!(node.id, sim.drive.cia402_node(Wheel::Right).unwrap().id);
    // Each axis's objects hold the start-up's values: 0x6060/0x6860 = 3, 0x6083/0x6883 = 9549 rpm/s;
    // axis 2's RPDO2 maps 0x6840/0x68FF, its TPDO4 0x6864/0x686C.
    for (index, want) in [
        (0x6060, 3),
        (0x6860, 3),
        (0x6083, 9549),
        (0x6883, 9549),
        (0x6885, 19099),
        (0x1401, 0x301),
        (0x1803, 0x481),
    ] {
        let sub = if index < 0x6000 { 1 } else { 0 };
        assert_eq!(node.object(ObjectAddr::new(index, sub)), Some(want), "0x{index:04X}");
    }
    assert_eq!(node.object(ObjectAddr::new(0x1601, 2)), Some(0x68FF_0020));
    assert_eq!(node.object(ObjectAddr::new(0x1A03, 2)), Some(0x686C_0020));
    for w in Wheel::BOTH {
        assert_eq!(
            sim.drive.cia402_axis(w).unwrap().machine.state,
            DriveState::OperationEnabled
        );
    }
    // One NMT start for the node.
    let starts = sim
        .tap
        .wire_log()
        .iter()
        .filter(|f| f.id == 0 && f.data[0] == 1)
        .count();
    assert_eq!(starts, 1);
    sim.stream(Twist::new(0.2, 0.0), 2.0);
    sim.stream(Twist::ZERO, 1.0);
    sim.stream(Twist::new(0.0, FRAC_PI_4), 2.0);
    sim.stream(Twist::ZERO, 1.0);
    sim.stream(Twist::new(0.2, 0.0), 2.0);
    sim.stream(Twist::ZERO, 1.0);
    let p = sim.bridge.odometry().pose;
    assert!(
        (p.x_m - 0.4).abs() < 2e-3 && (p.y_m - 0.4).abs() < 2e-3 && (p.theta_rad - FRAC_PI_2).abs() < 5e-3,
        "{p:?}"
    );
    // The right wheel's targets travel on RPDO2 (0x301), the left's on RPDO1 (0x201).
    let log = sim.tap.wire_log();
    assert!(log
        .iter()
        .any(|f| f.id == 0x301 && co_pdo::decode_rpdo1(f).unwrap().target_velocity != 0));
    assert!(!log.iter().any(|f| f.id == 0x202), "no second node");
    assert_wire_is_clean(&log, ProtocolKind::Cia402);
}

/// A fault on axis 2 alone (0x2310 on the right wheel): both wheels stop,
/// the fault is latched with the right wheel and its code, the report names
/// node 1 axis 2; after reset only axis 2 gets the fault reset, both run again.
#[test]
fn two_axis_node_fault_on_axis_2_stops_both_names_it_and_recovers() {
    let mut sim = two_axis_sim(Vec::new());
    sim.run_s(0.5);
    sim.stream(Twist::new(0.2, 0.0), 1.0);
    assert_eq!(sim.bridge.state(), BridgeState::Running);
    reports(&mut sim);
    let t = sim.t;
    sim.drive.inject(
        FaultKind::AxisError {
            code: 0x2310,
            wheel: Some(Wheel::Right),
        },
        None,
        t,
    );
    sim.stream(Twist::new(0.2, 0.0), 0.1);
    assert_eq!(sim.bridge.last_setpoint(), can_bridge::WheelSpeeds::ZERO);
    assert!(
        sim.bridge.reasons().iter().any(|r| matches!(
            r,
            can_bridge::diagnostics::StopReason::DriveFault {
                wheel: Wheel::Right,
                error_code: 0x2310,
                ..
            }
        )),
        "{:?}",
        sim.bridge.reasons()
    );
    assert_eq!(
        sim.drive.cia402_axis(Wheel::Left).unwrap().machine.state,
        DriveState::OperationEnabled,
        "axis 1 itself is healthy"
    );
    let r = reports(&mut sim);
    assert!(
        r.iter()
            .any(|m| m == "node 1 axis 2 (right wheel) fault, error code 0x2310 (current)"),
        "{r:?}"
    );
    // Both wheels at zero on the wire while latched.
    let n = sim.tap.wire_log().len();
    sim.stream(Twist::new(0.2, 0.0), 0.5);
    let after: Vec<CanFrame> = sim.tap.wire_log()[n..].to_vec();
    assert!(after
        .iter()
        .filter(|f| f.id == 0x201 || f.id == 0x301)
        .all(|f| co_pdo::decode_rpdo1(f).unwrap().target_velocity == 0));
    let t = sim.t;
    sim.bridge.reset(t);
    sim.stream(Twist::new(0.2, 0.0), 0.8);
    assert_eq!(sim.bridge.state(), BridgeState::Running, "{:?}", sim.bridge.reasons());
    let log = sim.tap.wire_log();
    let resets: Vec<u32> = log[n..]
        .iter()
        .filter(|f| (f.id == 0x201 || f.id == 0x301) && co_pdo::decode_rpdo1(f).unwrap().controlword == 0x0080)
        .map(|f| f.id)
        .collect();
    assert!(
        !resets.is_empty() && resets.iter().all(|id| *id == 0x301),
        "{resets:x?}"
    );
    assert_eq!(sim.drive.stats().closed_loop_with_nonzero_input, 0);
}

// ------------------------------------------------------------------ SDO at run time

use can_bridge::protocol::cia402::sdo_jobs::{SdoJob, SdoRefusal};
use can_bridge::virtual_drive::cia402::{DEVICE_NAME, NOTE};

/// Runs until the request `id` ends (at most 2 s); its result.
fn sdo_result(sim: &mut Sim, id: u64) -> can_bridge::protocol::cia402::sdo_jobs::SdoJobResult {
    for _ in 0..2000 {
        sim.step();
        if let Some(r) = sim.bridge.take_sdo_results().into_iter().find(|r| r.id == id) {
            return r;
        }
    }
    panic!("SDO request {id} did not end");
}

/// While driving: the drive's 27-byte device name (0x1008) comes by
/// segmented upload (4 segments) and the setpoints keep their period; a
/// write to 0x6083 or to a manufacturer object is refused with 0x08000022
/// and nothing goes on the wire. Stopped (e-stop): a 21-byte segmented write
/// of 0x2100 and a 4-byte write of 0x6083 reach the drive; the drive's own
/// refusal of a read-only object comes back decoded.
#[test]
fn sdo_at_run_time_reads_segmented_and_refuses_motion_writes_while_enabled() {
    let mut sim = cia402_sim();
    sim.run_s(0.5);
    sim.stream(Twist::new(0.2, 0.0), 0.5);
    assert_eq!(sim.bridge.state(), BridgeState::Running);
    let t = sim.t;
    let id = sim.bridge.sdo_request(SdoJob::read(2, 0x1008, 0), t).unwrap();
    let r = sdo_result(&mut sim, id);
    assert!(r.ok, "{r:?}");
    assert_eq!(r.data, DEVICE_NAME.as_bytes());
    assert_eq!(sim.bridge.state(), BridgeState::Running, "the loop kept running");
    // 27 bytes = 4 segments: request + 4 segment requests on 0x602.
    let reqs = sim.tap.wire_log().iter().filter(|f| f.id == 0x602).count();
    assert!(reqs >= 5, "{reqs}");
    // Motion-changing writes while enabled: refused, nothing sent.
    let n_sdo = sim.tap.wire_log().iter().filter(|f| f.id == 0x601).count();
    for job in [
        SdoJob::write(1, 0x6083, 0, 1000u32.to_le_bytes().to_vec()),
        SdoJob::write(1, 0x2100, 0, b"hello".to_vec()),
        SdoJob::write(1, 0x1017, 0, 50u16.to_le_bytes().to_vec()),
    ] {
        let e = sim.bridge.sdo_request(job.clone(), sim.t).unwrap_err();
        assert!(matches!(e, SdoRefusal::ChangesMotion { node: 1, .. }), "{job:?}: {e}");
        assert_eq!(e.abort_code(), 0x0800_0022);
    }
    assert_eq!(sim.tap.wire_log().iter().filter(|f| f.id == 0x601).count(), n_sdo);
    // Not a drive of ours, and nothing to write: refused too.
    assert!(matches!(
        sim.bridge.sdo_request(SdoJob::read(9, 0x1000, 0), sim.t),
        Err(SdoRefusal::UnknownNode { node: 9, .. })
    ));
    assert_eq!(
        sim.bridge.sdo_request(SdoJob::write(1, 0x1003, 0, vec![]), sim.t),
        Err(SdoRefusal::Empty)
    );
    // Still braking in quick stop (the motor model settles in about 0.6 s): refused.
    let t = sim.t;
    sim.bridge.estop(t);
    sim.run_s(0.1);
    assert!(matches!(
        sim.bridge
            .sdo_request(SdoJob::write(1, 0x2100, 0, b"x".to_vec()), sim.t),
        Err(SdoRefusal::ChangesMotion { .. })
    ));
    // Stopped (switch on disabled): the writes go through.
    sim.run_s(1.0);
    let note = b"commissioned 2026-11-2".to_vec();
    let id = sim
        .bridge
        .sdo_request(SdoJob::write(1, 0x2100, 0, note.clone()), sim.t)
        .unwrap();
    let r = sdo_result(&mut sim, id);
    assert!(r.ok && r.write, "{r:?}");
    assert_eq!(
        sim.drive.cia402_node(Wheel::Left).unwrap().long_object(NOTE),
        Some(&note[..])
    );
    let id = sim
        .bridge
        .sdo_request(SdoJob::write(1, 0x6083, 0, 5000u32.to_le_bytes().to_vec()), sim.t)
        .unwrap();
    assert!(sdo_result(&mut sim, id).ok);
    assert_eq!(
        sim.drive
            .cia402_node(Wheel::Left)
            .unwrap()
            .object(obj::PROFILE_ACCELERATION),
        Some(5000)
    );
    // The drive refuses: 0x1000 is read only.
    let id = sim
        .bridge
        .sdo_request(SdoJob::write(1, 0x1000, 0, vec![0, 0, 0, 0]), sim.t)
        .unwrap();
    let r = sdo_result(&mut sim, id);
    assert_eq!(
        (r.ok, r.abort_code, r.message.as_str()),
        (
            false,
            0x0601_0002,
            "aborted by node 1: 0x06010002 (attempt to write a read only object)"
        )
    );
    // Each request is an event too.
    let events = sim.bridge.drain_events();
    let done = events
        .iter()
        .filter(|e| matches!(e.event, BridgeEvent::SdoDone { .. }))
        .count();
    let refused = events
        .iter()
        .filter(|e| matches!(e.event, BridgeEvent::SdoRefused { .. }))
        .count();
    assert_eq!((done, refused), (4, 6));
}

/// A node that stops answering: the request ends after sdo_timeout_s with
/// 0x05040000 and the bridge's abort frame; the start-up waits for the
/// channel and still completes after a reset.
#[test]
fn sdo_at_run_time_times_out_with_the_abort_and_shares_the_channel_with_the_startup() {
    let c = bridge_config(ProtocolKind::Cia402);
    let silence = can_bridge::virtual_drive::FaultSpec {
        kind: FaultKind::SdoSilence,
        start_s: 1.5,
        duration_s: Some(0.5),
    };
    let mut sim = cia402_sim_with(c, vec![silence]);
    sim.run_s(1.6);
    let id = sim.bridge.sdo_request(SdoJob::read(1, 0x1008, 0), sim.t).unwrap();
    let r = sdo_result(&mut sim, id);
    assert_eq!(r.abort_code, 0x0504_0000, "{r:?}");
    assert!(r.message.contains("within 200 ms"), "{}", r.message);
    let abort = sim
        .tap
        .wire_log()
        .into_iter()
        .rev()
        .find(|f| f.id == 0x601 && f.data[0] == 0x80)
        .unwrap();
    assert_eq!(abort.data, [0x80, 0x08, 0x10, 0x00, 0x00, 0x00, 0x04, 0x05]);
    // A reset runs the start-up over SDO; requests made during it wait their turn.
    sim.run_s(0.5);
    let t = sim.t;
    sim.bridge.reset(t);
    sim.step();
    let ids: Vec<u64> = (0..3)
        .map(|_| sim.bridge.sdo_request(SdoJob::read(1, 0x1000, 0), sim.t).unwrap())
        .collect();
    for id in ids {
        let r = sdo_result(&mut sim, id);
        assert_eq!((r.ok, r.data.as_slice()), (true, &0x0002_0192u32.to_le_bytes()[..]));
    }
    sim.stream(Twist::new(0.1, 0.0), 0.5);
    assert_eq!(sim.bridge.state(), BridgeState::Running, "{:?}", sim.bridge.reasons());
    let r = reports(&mut sim);
    assert!(!r.iter().any(|m| m.contains("start-up failed")), "{r:?}");
    // Never two requests in flight on a node's channel: each request to 0x601
    // is answered on 0x581 before the next (CiA 301).
    let mut waiting = false;
    for f in sim.tap.wire_log() {
        if f.id == 0x601 && f.data[0] != 0x80 {
            assert!(!waiting, "a second request in flight: {f:?}");
            waiting = true;
        } else if f.id == 0x581 || (f.id == 0x601 && f.data[0] == 0x80) {
            waiting = false;
        }
    }
}

#[test]
fn sdo_is_refused_on_protocols_without_it() {
    for protocol in [ProtocolKind::Generic, ProtocolKind::Odrive] {
        let c = bridge_config(protocol);
        let d = drive_config(&c);
        let mut sim = Sim::new(c, d);
        let e = sim.bridge.sdo_request(SdoJob::read(1, 0x1000, 0), sim.t).unwrap_err();
        assert_eq!(e, SdoRefusal::NotCanopen(protocol.name()));
        assert_eq!(
            e.to_string(),
            format!("SDO is CANopen's; the bridge speaks {}", protocol.name())
        );
    }
}
