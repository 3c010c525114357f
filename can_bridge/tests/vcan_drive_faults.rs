//! vcan group 5: the drive killed or silent, and an axis error in a
//! heartbeat, on a kernel vcan bus. Run by tests/can_group.sh.

mod vcan_common;

use can_bridge::diagnostics::BridgeState;
use can_bridge::virtual_drive::FaultKind;
use can_bridge::{Clock, ProtocolKind, Twist, Wheel};
use std::io::Write;
use vcan_common::*;

fn killed(protocol: ProtocolKind) {
    let _serial = require_vcan();
    log_init();
    let clock = clock();
    let sniff = Sniffer::start(clock);
    let c = bridge_config(protocol);
    // The real binary, killed with SIGKILL: no goodbye frame.
    let dir = tempfile_dir();
    let cfg_path = dir.join("bridge.yaml");
    let mut f = std::fs::File::create(&cfg_path).unwrap();
    f.write_all(serde_yaml::to_string(&c).unwrap().as_bytes()).unwrap();
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_virtual_drive"))
        .args(["--config", cfg_path.to_str().unwrap(), "--time-constant-s", "0.02"])
        .spawn()
        .expect("virtual_drive");
    let fb_timeout = c.timing.feedback_timeout_s;
    let mut b = bridge(c, &clock);
    wait_ready(&mut b, &clock);
    teleop(&mut b, &clock, Twist::new(0.2, 0.0), 0.5);
    assert_eq!(b.state(), BridgeState::Running);

    child.kill().unwrap();
    let _ = child.wait();
    let t_k = clock.now();
    let mut stopped = None;
    let mut next = t_k;
    run_for(&mut b, &clock, 1.5, |b, now| {
        if now >= next {
            b.command(Twist::new(0.2, 0.0), now).unwrap();
            next = next + std::time::Duration::from_millis(50);
        }
        if stopped.is_none() && b.state() == BridgeState::Stopped {
            stopped = Some((now, b.reasons().to_vec()));
        }
    });
    let (t_s, why) = stopped.expect("the bridge stopped");
    let dt = secs(t_k, t_s);
    println!(
        "{protocol:?}: stopped {:.1} ms after the drive was killed: {why:?}",
        dt * 1e3
    );
    assert!(dt <= fb_timeout + 0.02 + 0.05, "{dt}");
    assert!(has_reason(&b, "no_heartbeat"), "{:?}", b.reasons());
    let moving: Vec<_> = setpoints(&sniff.frames(), protocol)
        .into_iter()
        .filter(|s| s.t > t_s && s.vel_radps != 0.0)
        .collect();
    assert!(moving.is_empty(), "zero after the stop: {moving:?}");
    let _ = std::fs::remove_dir_all(dir);
}

fn tempfile_dir() -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("vcan_drive_faults_{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn drive_killed_generic() {
    killed(ProtocolKind::Generic);
}

#[test]
fn drive_killed_odrive() {
    killed(ProtocolKind::Odrive);
}

fn silent(protocol: ProtocolKind) {
    let _serial = require_vcan();
    log_init();
    let clock = clock();
    let c = bridge_config(protocol);
    let drive = DriveThread::start(drive_config(&c), clock);
    let mut b = bridge(c, &clock);
    wait_ready(&mut b, &clock);
    teleop(&mut b, &clock, Twist::new(0.2, 0.0), 0.5);
    drive.inject(FaultKind::Silence, Some(1.0));
    let t0 = clock.now();
    teleop(&mut b, &clock, Twist::new(0.2, 0.0), 0.6);
    assert_eq!(b.state(), BridgeState::Stopped, "{:?}", b.reasons());
    assert!(has_reason(&b, "no_heartbeat") || has_reason(&b, "feedback_lost"));
    assert_eq!(b.last_setpoint(), can_bridge::WheelSpeeds::ZERO);
    // The silence ends: the lost heartbeat is latched, fresh commands alone
    // do not resume; a reset and fresh commands do.
    teleop(&mut b, &clock, Twist::new(0.2, 0.0), 1.0);
    assert_eq!(b.state(), BridgeState::Stopped, "{:?}", b.reasons());
    assert!(has_reason(&b, "heartbeat_lost"), "{:?}", b.reasons());
    b.reset(clock.now());
    let t = teleop(&mut b, &clock, Twist::new(0.2, 0.0), 1.5);
    assert_eq!(b.state(), BridgeState::Running, "{:?}", b.reasons());
    println!("{protocol:?}: silent drive stopped and resumed ({:.2} s)", secs(t0, t));
}

#[test]
fn drive_silent_generic() {
    silent(ProtocolKind::Generic);
}

#[test]
fn drive_silent_odrive() {
    silent(ProtocolKind::Odrive);
}

fn axis_error(protocol: ProtocolKind) {
    let _serial = require_vcan();
    log_init();
    let clock = clock();
    let c = bridge_config(protocol);
    let drive = DriveThread::start(drive_config(&c), clock);
    let mut b = bridge(c, &clock);
    wait_ready(&mut b, &clock);
    teleop(&mut b, &clock, Twist::new(0.2, 0.0), 0.5);
    drive.inject(
        FaultKind::AxisError {
            code: 0x20,
            wheel: Some(Wheel::Right),
        },
        None,
    );
    let t0 = clock.now();
    let mut next = t0;
    let hit = wait_until(&mut b, &clock, 1.0, |b| {
        let _ = &mut next;
        has_reason(b, "drive_fault")
    })
    .expect("drive fault reported");
    println!("{protocol:?}: axis error → stop in {:.1} ms", secs(t0, hit) * 1e3);
    assert!(
        secs(t0, hit) < 0.15 + 0.05,
        "within a heartbeat period (100 ms) + slack"
    );
    assert!(matches!(
        b.reasons()[0],
        can_bridge::diagnostics::StopReason::DriveFault { error_code: 0x20, .. }
    ));
    // Latched while the stream continues.
    teleop(&mut b, &clock, Twist::new(0.2, 0.0), 0.8);
    assert!(has_reason(&b, "drive_fault"));
    // Reset clears it through the start-up sequence (the injected error is latched in the drive).
    b.reset(clock.now());
    teleop(&mut b, &clock, Twist::new(0.2, 0.0), 1.0);
    assert_eq!(b.state(), BridgeState::Running, "{:?}", b.reasons());
    assert_eq!(drive.axis(Wheel::Right).error_code, 0);
}

#[test]
fn axis_error_generic() {
    axis_error(ProtocolKind::Generic);
}

#[test]
fn axis_error_odrive() {
    axis_error(ProtocolKind::Odrive);
}
