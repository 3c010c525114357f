use super::*;
use crate::protocol::generic::Setpoint;
use oldbf::config::Validate;

const IDS: GenericIds = GenericIds { base_id: 0x100 };

fn t(s: f64) -> Timestamp {
    Timestamp::from_secs_f64(s)
}

fn generic_drive(tau: f64, accel: f64) -> VirtualDrive {
    VirtualDrive::new(
        VirtualDriveConfig {
            time_constant_s: tau,
            max_accel_radps2: accel,
            ..Default::default()
        },
        t(0.0),
    )
}

fn sp(w: Wheel, vel: f64, counter: u8, enable: bool, estop: bool) -> CanFrame {
    generic::encode_setpoint(
        IDS,
        w,
        &Setpoint {
            vel_radps: vel,
            counter,
            enable,
            estop,
        },
    )
}

/// Sends a pair with `counter` at `now`.
fn pair(d: &mut VirtualDrive, vel: f64, counter: u8, enable: bool, estop: bool, now: f64) {
    d.handle_frame(&sp(Wheel::Left, vel, counter, enable, estop), t(now));
    d.handle_frame(&sp(Wheel::Right, -vel, counter, enable, estop), t(now));
}

#[test]
fn fault_specs_parse() {
    assert_eq!(
        "axis_error@2:0x20:left".parse::<FaultSpec>().unwrap(),
        FaultSpec {
            kind: FaultKind::AxisError {
                code: 0x20,
                wheel: Some(Wheel::Left)
            },
            start_s: 2.0,
            duration_s: None
        }
    );
    assert_eq!(
        "heartbeat_silence@3+1.5".parse::<FaultSpec>().unwrap().duration_s,
        Some(1.5)
    );
    assert_eq!(
        "feedback_delay@1+5:0.3".parse::<FaultSpec>().unwrap().kind,
        FaultKind::FeedbackDelay { delay_s: 0.3 }
    );
    assert_eq!("exit@4".parse::<FaultSpec>().unwrap().kind, FaultKind::Exit);
    assert_eq!(
        "axis_error@0".parse::<FaultSpec>().unwrap().kind,
        FaultKind::AxisError { code: 1, wheel: None }
    );
    for bad in [
        "explode@1",
        "axis_error",
        "silence@x",
        "silence@1:2",
        "axis_error@1:0",
        "feedback_delay@1",
        "axis_error@1:1:up",
        "exit@-1",
    ] {
        assert!(bad.parse::<FaultSpec>().is_err(), "{bad}");
    }
    let e = "silence@x".parse::<FaultSpec>().unwrap_err();
    assert_eq!(
        e.to_string(),
        "fault `silence@x`: start `x` is not a non-negative number"
    );
    let e = "axis_error@1:1:up".parse::<FaultSpec>().unwrap_err();
    assert_eq!(e.problem, FaultProblem::Wheel("up".into()));
    let e = "meltdown@1".parse::<FaultSpec>().unwrap_err();
    assert!(
        e.to_string()
            .starts_with("fault `meltdown@1`: unknown kind `meltdown`; allowed: "),
        "{e}"
    );
}

#[test]
fn first_order_lag_by_hand() {
    let mut d = generic_drive(0.05, 1e9);
    pair(&mut d, 0.0, 0, false, false, 0.0); // clear
    pair(&mut d, 10.0, 1, true, false, 0.0);
    let mut out = Vec::new();
    d.step(t(0.05), &mut out);
    // One time constant: 10 (1 − e^−1) = 6.3212.
    let v = d.axis(Wheel::Left).vel_radps;
    assert!((v - 6.321_205_588).abs() < 1e-6, "{v}");
    assert!((d.axis(Wheel::Right).vel_radps + v).abs() < 1e-12);
    // Position: ∫ 10(1 − e^{−t/τ}) dt over one τ = 10 τ e^−1 = 0.18394 (trapezoid on 1 ms steps).
    let p = d.axis(Wheel::Left).pos_rad;
    assert!((p - 0.183_940).abs() < 1e-4, "{p}");
}

#[test]
fn accel_and_speed_limits() {
    let mut d = VirtualDrive::new(
        VirtualDriveConfig {
            time_constant_s: 0.0,
            max_accel_radps2: 100.0,
            max_speed_radps: 8.0,
            ..Default::default()
        },
        t(0.0),
    );
    pair(&mut d, 0.0, 0, false, false, 0.0);
    pair(&mut d, 50.0, 1, true, false, 0.0);
    let mut out = Vec::new();
    d.step(t(0.05), &mut out);
    assert!(
        (d.axis(Wheel::Left).vel_radps - 5.0).abs() < 1e-9,
        "100 rad/s² × 0.05 s"
    );
    pair(&mut d, 50.0, 2, true, false, 0.05);
    d.step(t(0.2), &mut out);
    assert_eq!(d.axis(Wheel::Left).vel_radps, 8.0, "own speed limit");
}

#[test]
fn generic_watchdog_trips_to_fault() {
    let mut d = generic_drive(0.0, 1e9);
    pair(&mut d, 0.0, 0, false, false, 0.0);
    pair(&mut d, 3.0, 1, true, false, 0.0);
    let mut out = Vec::new();
    d.step(t(0.4), &mut out);
    assert!(d.axis(Wheel::Left).running);
    d.step(t(0.6), &mut out);
    let a = d.axis(Wheel::Left);
    assert!(!a.running && a.error_code == generic::ERR_WATCHDOG && a.target_radps == 0.0);
    assert_eq!(d.stats().watchdog_trips, 1);
    // It reports it: the last status frame says FAULT with the watchdog bit.
    out.clear();
    d.step(t(0.7), &mut out);
    let st = out.iter().find(|f| f.id == 0x110).unwrap();
    let s = generic::decode_status(st).unwrap();
    assert_eq!((s.state, s.error_code), (generic::STATE_FAULT, generic::ERR_WATCHDOG));
    // Enable alone does not clear it; a clear pair does.
    pair(&mut d, 1.0, 2, true, false, 0.7);
    assert!(!d.axis(Wheel::Left).running);
    pair(&mut d, 0.0, 3, false, false, 0.7);
    pair(&mut d, 1.0, 4, true, false, 0.7);
    assert!(d.axis(Wheel::Left).running && d.axis(Wheel::Left).error_code == 0);
}

#[test]
fn generic_rejects_frozen_counters_and_bad_crc() {
    let mut d = generic_drive(0.0, 1e9);
    pair(&mut d, 0.0, 0, false, false, 0.0);
    pair(&mut d, 3.0, 1, true, false, 0.0);
    let mut out = Vec::new();
    // The same frames again and again (a frozen sender) do not feed the watchdog.
    for i in 1..=6 {
        pair(&mut d, 3.0, 1, true, false, 0.1 * i as f64);
        d.step(t(0.1 * i as f64), &mut out);
    }
    assert!(!d.axis(Wheel::Left).running, "watchdog tripped");
    assert_eq!(d.stats().frozen_counters, 12);
    let mut bad = sp(Wheel::Left, 1.0, 9, true, false);
    bad.data[0] ^= 1;
    d.handle_frame(&bad, t(1.0));
    assert_eq!(d.stats().setpoints_rejected, 13);
}

#[test]
fn generic_estop_latches_until_a_clear_pair() {
    let mut d = generic_drive(0.0, 1e9);
    pair(&mut d, 0.0, 0, false, false, 0.0);
    pair(&mut d, 3.0, 1, true, false, 0.0);
    pair(&mut d, 0.0, 2, false, true, 0.01);
    assert!(!d.axis(Wheel::Left).running);
    pair(&mut d, 3.0, 3, true, false, 0.02);
    assert!(!d.axis(Wheel::Left).running, "enable does not clear an e-stop");
    pair(&mut d, 0.0, 4, false, false, 0.03);
    pair(&mut d, 3.0, 5, true, false, 0.03);
    assert!(d.axis(Wheel::Left).running);
    assert_eq!(d.stats().estops, 1);
}

fn odrive_drive() -> VirtualDrive {
    VirtualDrive::new(
        VirtualDriveConfig {
            protocol: ProtocolKind::Odrive,
            left_node_id: 3,
            right_node_id: 5,
            time_constant_s: 0.0,
            max_accel_radps2: 1e9,
            ..Default::default()
        },
        t(0.0),
    )
}

fn odrive_start(d: &mut VirtualDrive, node: u32, now: f64) {
    d.handle_frame(&odrive::clear_errors(node), t(now));
    d.handle_frame(
        &odrive::set_controller_mode(node, odrive::CONTROL_MODE_VELOCITY, odrive::INPUT_MODE_PASSTHROUGH),
        t(now),
    );
    d.handle_frame(&odrive::set_input_vel(node, 0.0, 0.0), t(now));
    d.handle_frame(&odrive::set_axis_state(node, odrive::AXIS_STATE_CLOSED_LOOP), t(now));
}

#[test]
fn odrive_axis_follows_the_cansimple_sequence() {
    let mut d = odrive_drive();
    // Closed loop without velocity mode: refused.
    d.handle_frame(&odrive::set_axis_state(3, odrive::AXIS_STATE_CLOSED_LOOP), t(0.0));
    assert!(!d.axis(Wheel::Left).running);
    odrive_start(&mut d, 3, 0.0);
    assert!(d.axis(Wheel::Left).running && !d.axis(Wheel::Right).running);
    d.handle_frame(&odrive::set_input_vel(3, 2.0, 0.0), t(0.0));
    let mut out = Vec::new();
    d.step(t(0.01), &mut out);
    assert!((d.axis(Wheel::Left).vel_radps - 2.0 * TAU).abs() < 1e-9);
    // Heartbeats: node 3 closed loop, node 5 idle; encoder estimates in turns.
    let hb3 = out
        .iter()
        .find(|f| f.id == odrive::arb_id(3, odrive::cmd::HEARTBEAT))
        .unwrap();
    assert_eq!(hb3.data[4], 8);
    let hb5 = out
        .iter()
        .find(|f| f.id == odrive::arb_id(5, odrive::cmd::HEARTBEAT))
        .unwrap();
    assert_eq!(hb5.data[4], 1);
    assert_eq!(d.stats().closed_loop_with_nonzero_input, 0);
    // Asking for closed loop while a non-zero input is set is flagged.
    d.handle_frame(&odrive::set_axis_state(3, odrive::AXIS_STATE_CLOSED_LOOP), t(0.01));
    assert_eq!(d.stats().closed_loop_with_nonzero_input, 1);
    // Idle request, then e-stop.
    d.handle_frame(&odrive::set_axis_state(3, odrive::AXIS_STATE_IDLE), t(0.02));
    assert!(!d.axis(Wheel::Left).running);
    odrive_start(&mut d, 3, 0.03);
    d.handle_frame(&odrive::estop(3), t(0.04));
    let a = d.axis(Wheel::Left);
    assert!(!a.running && a.error_code == odrive::AXIS_ERROR_ESTOP_REQUESTED);
    odrive_start(&mut d, 3, 0.05);
    assert!(d.axis(Wheel::Left).running, "Clear_Errors then closed loop");
}

#[test]
fn odrive_watchdog_sets_the_watchdog_error() {
    let mut d = odrive_drive();
    odrive_start(&mut d, 3, 0.0);
    let mut out = Vec::new();
    d.step(t(0.6), &mut out);
    let a = d.axis(Wheel::Left);
    assert!(!a.running && a.error_code == odrive::AXIS_ERROR_WATCHDOG_TIMER_EXPIRED);
}

/// Firmware 0.6: the watchdog and Estop set 0.6's bits, the heartbeat
/// carries the procedure result (DISARMED after the watchdog, SUCCESS
/// after Clear_Errors) and the trajectory flag, and Get_Error follows each
/// heartbeat with the disarm reason.
#[test]
fn odrive_0_6_heartbeat_get_error_and_codes() {
    let mut d = VirtualDrive::new(
        VirtualDriveConfig {
            protocol: ProtocolKind::Odrive,
            left_node_id: 3,
            right_node_id: 5,
            odrive_firmware: odrive::Firmware::V0_6,
            heartbeat_rate_hz: 10.0,
            ..Default::default()
        },
        t(0.0),
    );
    let fw = odrive::Firmware::V0_6;
    odrive_start(&mut d, 3, 0.0);
    let mut out = Vec::new();
    d.step(t(0.6), &mut out);
    let a = d.axis(Wheel::Left);
    assert!(!a.running && a.error_code == 0x0100_0000, "{a:?}");
    out.clear();
    d.step(t(0.75), &mut out);
    let hb = out
        .iter()
        .find(|f| f.id == odrive::arb_id(3, odrive::cmd::HEARTBEAT))
        .unwrap();
    assert_eq!(
        odrive::decode_heartbeat(hb, fw).unwrap(),
        odrive::Heartbeat {
            axis_error: 0x0100_0000,
            axis_state: 1,
            procedure_result: Some(3),
            trajectory_done: Some(true),
        }
    );
    let ge = out
        .iter()
        .find(|f| f.id == odrive::arb_id(3, odrive::cmd::GET_ERROR))
        .unwrap();
    assert_eq!(odrive::decode_get_error(ge), Ok((0, 0x0100_0000)));
    // The right axis was never armed: idle, no error, procedure result SUCCESS.
    let hb5 = out
        .iter()
        .find(|f| f.id == odrive::arb_id(5, odrive::cmd::HEARTBEAT))
        .unwrap();
    assert_eq!(odrive::decode_heartbeat(hb5, fw).unwrap().procedure_result, Some(0));
    // Clear_Errors (the start-up's first frame) clears the error and the result.
    odrive_start(&mut d, 3, 0.8);
    assert!(d.axis(Wheel::Left).running);
    d.handle_frame(&odrive::estop(3), t(0.81));
    assert_eq!(d.axis(Wheel::Left).error_code, 0x0200_0000);
    out.clear();
    d.step(t(0.9), &mut out);
    let hb = out
        .iter()
        .find(|f| f.id == odrive::arb_id(3, odrive::cmd::HEARTBEAT))
        .unwrap();
    assert_eq!(odrive::decode_heartbeat(hb, fw).unwrap().procedure_result, Some(3));
    odrive_start(&mut d, 3, 0.95);
    out.clear();
    d.step(t(1.0), &mut out);
    let hb = out
        .iter()
        .find(|f| f.id == odrive::arb_id(3, odrive::cmd::HEARTBEAT))
        .unwrap();
    let h = odrive::decode_heartbeat(hb, fw).unwrap();
    assert_eq!((h.axis_error, h.axis_state, h.procedure_result), (0, 8, Some(0)));
}

#[test]
fn odrive_nan_setpoint_faults_the_axis() {
    let mut d = odrive_drive();
    odrive_start(&mut d, 3, 0.0);
    let mut f = odrive::set_input_vel(3, 1.0, 0.0);
    f.data[..4].copy_from_slice(&f32::NAN.to_le_bytes());
    d.handle_frame(&f, t(0.01));
    assert!(!d.axis(Wheel::Left).running && d.axis(Wheel::Left).error_code != 0);
}

#[test]
fn scheduled_faults() {
    let mut d = VirtualDrive::new(
        VirtualDriveConfig {
            faults: vec![
                "heartbeat_silence@1+1".parse().unwrap(),
                "feedback_delay@3+1:0.25".parse().unwrap(),
                "axis_error@5:0x40:right".parse().unwrap(),
                "exit@6".parse().unwrap(),
            ],
            protocol: ProtocolKind::Odrive,
            ..Default::default()
        },
        t(0.0),
    );
    let mut log: Vec<(f64, CanFrame)> = Vec::new();
    let mut out = Vec::new();
    for ms in 0..7000 {
        let now = ms as f64 / 1000.0;
        d.step(t(now), &mut out);
        log.extend(out.drain(..).map(|f| (now, f)));
    }
    let hb_times: Vec<f64> = log.iter().filter(|(_, f)| f.id & 0x1F == 1).map(|(t, _)| *t).collect();
    assert!(hb_times.iter().all(|t| !(1.0..2.0).contains(t)), "silent in [1, 2)");
    assert!(hb_times.iter().any(|t| (2.0..2.2).contains(t)), "back after 2");
    // Delayed feedback: frames in [3.25, 4.25) are the ones produced 0.25 s earlier;
    // none is sent in [3.0, 3.25).
    let fb_times: Vec<f64> = log.iter().filter(|(_, f)| f.id & 0x1F == 9).map(|(t, _)| *t).collect();
    assert!(fb_times.iter().all(|t| !(3.0..3.249).contains(t)));
    assert!(fb_times.iter().any(|t| (3.25..3.3).contains(t)));
    // Axis error on the right axis only.
    let hb_right_after: Vec<&CanFrame> = log
        .iter()
        .filter(|(t, f)| *t >= 5.0 && f.id == odrive::arb_id(1, 1))
        .map(|(_, f)| f)
        .collect();
    assert!(hb_right_after.iter().all(|f| f.data[0] == 0x40));
    assert!(log
        .iter()
        .filter(|(t, f)| *t >= 5.0 && f.id == odrive::arb_id(0, 1))
        .all(|(_, f)| f.data[0] == 0));
    // Exit: nothing after 6 s.
    assert!(log.iter().all(|(t, _)| *t < 6.0));
    assert!(d.exited());
}

#[test]
fn injected_faults_and_clearing() {
    let mut d = generic_drive(0.0, 1e9);
    let mut out = Vec::new();
    d.inject(FaultKind::Silence, Some(0.5), t(1.0));
    for ms in 1000..1400 {
        d.step(t(ms as f64 / 1000.0), &mut out);
    }
    assert!(out.is_empty(), "silent");
    d.clear_faults();
    d.step(t(1.5), &mut out);
    assert!(!out.is_empty());
}

#[test]
fn config_validation_names_the_option() {
    let keys = |c: &VirtualDriveConfig| -> Vec<String> {
        c.validate()
            .err()
            .unwrap_or_default()
            .into_iter()
            .map(|e| e.key)
            .collect()
    };
    let mut c = VirtualDriveConfig::default();
    assert_eq!(c.validate(), Ok(()));
    c.heartbeat_rate_hz = 0.0;
    let e = c.validate().unwrap_err();
    assert_eq!(
        e[0].to_string(),
        "key `heartbeat_rate_hz` = 0 is out of range; allowed: [0.01, 10000] Hz"
    );
    let c = VirtualDriveConfig {
        left_node_id: 2,
        right_node_id: 2,
        ..Default::default()
    };
    assert_eq!(keys(&c), ["right_node_id"]);
    let c = VirtualDriveConfig {
        protocol: ProtocolKind::Cia402,
        left_node_id: 0,
        right_node_id: 1,
        ..Default::default()
    };
    assert_eq!(keys(&c), ["left_node_id"], "CANopen ids start at 1");
    // One CANopen node may carry both wheels on two axes; not on the same axis.
    let two = VirtualDriveConfig {
        protocol: ProtocolKind::Cia402,
        left_node_id: 1,
        right_node_id: 1,
        right_axis: 2,
        ..Default::default()
    };
    assert!(two.validate().is_ok());
    let same = VirtualDriveConfig {
        right_axis: 1,
        ..two.clone()
    };
    assert_eq!(keys(&same), ["right_node_id"]);
    let odrive = VirtualDriveConfig {
        protocol: ProtocolKind::Odrive,
        ..two.clone()
    };
    assert_eq!(keys(&odrive), ["right_node_id"], "an ODrive node is one axis");
    let far = VirtualDriveConfig { right_axis: 3, ..two };
    assert_eq!(keys(&far), ["right_axis"]);
    let c = VirtualDriveConfig {
        right_node_id: 64,
        ..Default::default()
    };
    assert_eq!(keys(&c), ["right_node_id"], "ODrive ids end at 63");
    // Values a std Duration cannot hold are rejected, not a panic later.
    for (watchdog_s, rate_hz, key) in [
        (1e300, 10.0, "watchdog_s"),
        (0.5, 1e-300, "heartbeat_rate_hz"),
        (f64::NAN, 10.0, "watchdog_s"),
        (0.5, f64::INFINITY, "heartbeat_rate_hz"),
    ] {
        let c = VirtualDriveConfig {
            watchdog_s,
            heartbeat_rate_hz: rate_hz,
            ..Default::default()
        };
        assert_eq!(keys(&c), [key], "{watchdog_s} {rate_hz}");
    }
    for (tau, speed) in [(-0.1, 1.0), (f64::NAN, 1.0), (0.0, 0.0), (0.0, f64::INFINITY)] {
        let c = VirtualDriveConfig {
            time_constant_s: tau,
            max_speed_radps: speed,
            ..Default::default()
        };
        assert_eq!(c.validate().unwrap_err().len(), 1, "{tau} {speed}");
    }
}

#[test]
fn fault_schedule_from_running_starts_when_both_wheels_run() {
    // Node ids 3 and 5; an axis error 1 s into the schedule. From the
    // drive's start it fires at 1 s whatever the bridge does; counted from
    // running it fires 1 s after the second axis enters closed loop (at 4 s
    // here), and a node running alone does not start the clock.
    let drive = |from: FaultClock| {
        let mut cfg = odrive_drive().cfg.clone();
        cfg.faults = vec!["axis_error@1:0x40:left".parse().unwrap()];
        cfg.faults_from = from;
        cfg.watchdog_s = 100.0;
        VirtualDrive::new(cfg, t(0.0))
    };
    let error_at = |mut d: VirtualDrive| -> Option<f64> {
        let mut out = Vec::new();
        for ms in 0..8000 {
            let now = ms as f64 / 1000.0;
            if ms == 2000 {
                odrive_start(&mut d, 3, now);
            }
            if ms == 4000 {
                odrive_start(&mut d, 5, now);
            }
            d.step(t(now), &mut out);
            if d.axis(Wheel::Left).error_code == 0x40 {
                return Some(now);
            }
        }
        None
    };
    assert_eq!(error_at(drive(FaultClock::Start)), Some(1.0));
    assert_eq!(error_at(drive(FaultClock::Running)), Some(5.0));
}
