//! vcan groups 3 and 4: the command watchdog and the e-stop latch, on a
//! kernel vcan bus with the virtual drive. Run by tests/can_group.sh.

mod vcan_common;

use can_bridge::diagnostics::BridgeState;
use can_bridge::{Clock, ProtocolKind, Twist, Wheel};
use vcan_common::*;

/// Slack on top of the specified bounds for the bridge loop's own lateness
/// on an emulated CPU (the sniffer uses kernel timestamps).
const SLACK_S: f64 = 0.015;

fn watchdog(protocol: ProtocolKind) {
    let _serial = require_vcan();
    log_init();
    let clock = clock();
    let sniff = Sniffer::start(clock);
    let c = bridge_config(protocol);
    let drive = DriveThread::start(drive_config(&c), clock);
    let timeout = c.timing.cmd_timeout_s;
    let mut b = bridge(c, &clock);
    wait_ready(&mut b, &clock);

    let t_last = teleop(&mut b, &clock, Twist::new(0.2, 0.0), 1.0);
    assert_eq!(b.state(), BridgeState::Running);
    assert!(drive.axis(Wheel::Left).vel_radps > 10.0, "the drive moves");
    // The stream stops: zero within cmd_timeout + one tx period, and it stays zero.
    run_for(&mut b, &clock, 1.5, |_, _| {});
    assert_eq!(b.reasons(), [can_bridge::diagnostics::StopReason::CommandTimeout]);
    let t_fresh = clock.now();
    b.command(Twist::new(0.1, 0.0), t_fresh).unwrap();
    run_for(&mut b, &clock, 0.3, |_, _| {});
    let sp = setpoints(&sniff.frames(), protocol);

    let after: Vec<_> = sp.iter().filter(|s| s.t > t_last && s.wheel == 0).collect();
    let first_zero = after
        .iter()
        .find(|s| s.vel_radps == 0.0)
        .expect("a zero setpoint after the stream stopped");
    let latency = secs(t_last, first_zero.t);
    println!(
        "{protocol:?}: zero setpoint {:.1} ms after the last command (bound {:.1} ms + {:.0} ms slack)",
        latency * 1e3,
        (timeout + 0.02) * 1e3,
        SLACK_S * 1e3
    );
    assert!(latency >= timeout - 0.002, "zero too early: {latency}");
    assert!(latency <= timeout + 0.02 + SLACK_S, "zero too late: {latency}");
    // Never resumed: only zero between the first zero and the fresh command.
    let resumed: Vec<_> = sp
        .iter()
        .filter(|s| s.t >= first_zero.t && s.t <= t_fresh && s.vel_radps != 0.0)
        .collect();
    assert!(resumed.is_empty(), "old command resumed: {resumed:?}");
    // A fresh command resumes within two periods.
    let moving = sp
        .iter()
        .find(|s| s.t > t_fresh && s.vel_radps != 0.0)
        .expect("fresh command resumes");
    let dt = secs(t_fresh, moving.t);
    println!("{protocol:?}: fresh command on the wire after {:.1} ms", dt * 1e3);
    assert!(dt <= 0.04 + SLACK_S, "{dt}");
}

#[test]
fn watchdog_generic() {
    watchdog(ProtocolKind::Generic);
}

#[test]
fn watchdog_odrive() {
    watchdog(ProtocolKind::Odrive);
}

fn estop(protocol: ProtocolKind) {
    let _serial = require_vcan();
    log_init();
    let clock = clock();
    let sniff = Sniffer::start(clock);
    let c = bridge_config(protocol);
    let drive = DriveThread::start(drive_config(&c), clock);
    let mut b = bridge(c, &clock);
    wait_ready(&mut b, &clock);
    teleop(&mut b, &clock, Twist::new(0.2, 0.0), 0.6);
    assert!(drive.axis(Wheel::Left).running);

    let t_e = clock.now();
    b.estop(t_e);
    // The sender keeps streaming: latched anyway.
    teleop(&mut b, &clock, Twist::new(0.2, 0.0), 0.8);
    assert_eq!(b.state(), BridgeState::Estop);
    assert!(!drive.axis(Wheel::Left).running, "the drive is stopped by the e-stop");
    assert!(drive.drive.lock().unwrap().stats().estops >= 1);

    // Reset alone: no motion (the last command, < cmd_timeout old, is not resumed).
    let t_r = clock.now();
    b.reset(t_r);
    run_for(&mut b, &clock, 0.4, |_, _| {});
    assert_eq!(b.state(), BridgeState::Idle, "{:?}", b.reasons());
    // Reset + fresh command: moving.
    let t_f = clock.now();
    teleop(&mut b, &clock, Twist::new(0.2, 0.0), 0.5);
    assert_eq!(b.state(), BridgeState::Running);
    assert!(drive.axis(Wheel::Left).running && drive.axis(Wheel::Left).vel_radps > 1.0);

    let sp = setpoints(&sniff.frames(), protocol);
    let first_estop = sp.iter().find(|s| s.t >= t_e && s.estop).expect("e-stop on the wire");
    println!(
        "{protocol:?}: e-stop on the wire {:.2} ms after estop()",
        secs(t_e, first_estop.t) * 1e3
    );
    assert!(
        secs(t_e, first_estop.t) < 0.005 + SLACK_S,
        "sent at once, not at the next period"
    );
    let latched: Vec<_> = sp.iter().filter(|s| s.t >= first_estop.t && s.t < t_r).collect();
    assert!(latched.len() >= 40, "e-stop frames every period: {}", latched.len());
    assert!(latched.iter().all(|s| s.vel_radps == 0.0), "no velocity while latched");
    if protocol == ProtocolKind::Generic {
        assert!(latched.iter().all(|s| s.estop), "every generic setpoint carries Estop");
    }
    let after_reset: Vec<_> = sp.iter().filter(|s| s.t > t_r && s.t < t_f).collect();
    assert!(!after_reset.is_empty() && after_reset.iter().all(|s| s.vel_radps == 0.0 && !s.estop));
}

#[test]
fn estop_generic() {
    estop(ProtocolKind::Generic);
}

#[test]
fn estop_odrive() {
    estop(ProtocolKind::Odrive);
}
