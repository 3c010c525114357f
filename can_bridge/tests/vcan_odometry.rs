//! vcan group 6: odometry through the virtual drive on a kernel vcan bus,
//! in real time. Run by tests/can_group.sh.

mod vcan_common;

use can_bridge::{ProtocolKind, Twist};
use std::f64::consts::{FRAC_PI_2, PI};
use vcan_common::*;

/// Straight 0.3 m, a quarter turn in place, straight 0.3 m → (0.3, 0.3, π/2).
fn square_corner(protocol: ProtocolKind) {
    let _serial = require_vcan();
    log_init();
    let clock = clock();
    let c = bridge_config(protocol);
    let _drive = DriveThread::start(drive_config(&c), clock);
    let mut b = bridge(c, &clock);
    wait_ready(&mut b, &clock);
    teleop(&mut b, &clock, Twist::new(0.2, 0.0), 1.5);
    teleop(&mut b, &clock, Twist::ZERO, 0.5);
    teleop(&mut b, &clock, Twist::new(0.0, PI / 3.0), 1.5);
    teleop(&mut b, &clock, Twist::ZERO, 0.5);
    teleop(&mut b, &clock, Twist::new(0.2, 0.0), 1.5);
    teleop(&mut b, &clock, Twist::ZERO, 0.6);
    let o = b.odometry();
    let p = o.pose;
    println!(
        "{protocol:?}: pose ({:.4} m, {:.4} m, {:.4} rad), expected (0.3, 0.3, {:.4}); {} updates",
        p.x_m, p.y_m, p.theta_rad, FRAC_PI_2, o.updates
    );
    // Real time on an emulated CPU: segment lengths vary by a tx period or
    // two (20 ms × 0.2 m/s = 4 mm, × π/3 rad/s = 21 mrad).
    assert!((p.x_m - 0.3).abs() < 0.02 && (p.y_m - 0.3).abs() < 0.02, "{p:?}");
    assert!((p.theta_rad - FRAC_PI_2).abs() < 0.05, "{p:?}");
    assert!(o.updates > 400 && o.resets == 0, "{o:?}");
    assert!(o.twist.linear_mps.abs() < 1e-3, "at rest at the end: {o:?}");
}

#[test]
fn odometry_generic() {
    square_corner(ProtocolKind::Generic);
}

#[test]
fn odometry_odrive() {
    square_corner(ProtocolKind::Odrive);
}
