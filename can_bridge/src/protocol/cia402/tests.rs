//! The bridge's CiA 402 side fed frames by hand: expected values from the
//! CiA 301/402 definitions (see each comment), not from the encoder.

use super::nmt::{heartbeat, NmtState};
use super::pdo::{encode_tpdo1, encode_tpdo2, Tpdo1, Tpdo2};
use super::sdo::{decode_request, encode_response, SdoRequest, SdoResponse};
use super::units::VelocityUnit;
use super::*;

fn settings() -> Cia402Settings {
    let scaling = Scaling::new(VelocityUnit::Rpm, 1.0, 4096);
    Cia402Settings {
        nodes: [3, 5],
        axes: [AxisLayout::FIRST; 2],
        scaling,
        profile_accel: scaling.accel_to_drive(1000.0).unwrap(),
        profile_decel: scaling.accel_to_drive(1000.0).unwrap(),
        quick_stop_decel: scaling.accel_to_drive(2000.0).unwrap(),
        mapping: PdoMapping::Configure,
        plan: PdoPlan {
            sync: true,
            tpdo_event_ms: 10,
        },
        drive_heartbeat_ms: 100,
        bridge_node_id: 127,
        bridge_heartbeat_ms: 100,
        drive_consumer_heartbeat_ms: 300,
        sdo_timeout: Duration::from_millis(200),
    }
}

fn t(s: f64) -> Timestamp {
    Timestamp::from_secs_f64(s)
}

fn frames(b: &FrameBatch) -> Vec<CanFrame> {
    b.as_slice().to_vec()
}

/// Answers every SDO request in `out` as a drive whose device type is `device_type`.
fn answer(p: &mut Cia402Protocol, out: &[CanFrame], device_type: u32) -> usize {
    let mut n = 0;
    for f in out.iter().filter(|f| f.id & !0x7F == 0x600) {
        let node = (f.id & 0x7F) as u8;
        let r = match decode_request(f).unwrap() {
            SdoRequest::Upload { addr } => SdoResponse::Uploaded {
                addr,
                value: SdoValue::u32(device_type),
            },
            SdoRequest::Download { addr, .. } => SdoResponse::DownloadDone { addr },
            SdoRequest::Abort { .. } => continue,
        };
        let m = p.decode(&encode_response(node, &r)).unwrap();
        assert!(matches!(m, Some(DriveMessage::Handled { .. })));
        n += 1;
    }
    n
}

/// Runs the start-up until both nodes are sent NMT start; returns every frame.
fn configure(p: &mut Cia402Protocol) -> Vec<CanFrame> {
    let mut all = Vec::new();
    let mut b = FrameBatch::new();
    p.startup(&mut b);
    all.extend(frames(&b));
    for k in 0..100 {
        b.clear();
        p.poll(t(1.0 + f64::from(k) * 0.001), &mut b);
        let out = frames(&b);
        all.extend(out.iter().copied());
        if out.iter().filter(|f| f.id == 0 && f.data[0] == 0x01).count() == 2 {
            return all;
        }
        answer(p, &out, 0x0002_0192);
    }
    panic!("start-up did not finish: {all:?}");
}

fn tpdo1(node: u8, statusword: u16, error_code: u16) -> CanFrame {
    encode_tpdo1(
        node,
        &Tpdo1 {
            statusword,
            error_code,
            mode_display: 3,
        },
    )
}

/// Controlword and target velocity of each RPDO1 of one period.
fn period(p: &mut Cia402Protocol, m: MotorSpeeds, mode: SetpointMode) -> Vec<(u32, u16, i32)> {
    let mut b = FrameBatch::new();
    p.setpoints(m, mode, &mut b);
    let f = frames(&b);
    assert_eq!(
        f.last().map(|x| (x.id, x.len)),
        Some((0x080, 0)),
        "SYNC closes the period"
    );
    f[..f.len() - 1]
        .iter()
        .map(|x| {
            let r = pdo::decode_rpdo1(x).unwrap();
            (x.id, r.controlword, r.target_velocity)
        })
        .collect()
}

/// Enables both nodes: statusword answers to each controlword, heartbeats operational.
fn enable(p: &mut Cia402Protocol) -> Vec<u16> {
    configure(p);
    for id in [3, 5] {
        p.decode(&heartbeat(id, NmtState::Operational)).unwrap();
    }
    let mut words = Vec::new();
    let mut sw = [0x0040u16; 2]; // switch on disabled
    for _ in 0..6 {
        for (k, id) in [3u8, 5].iter().enumerate() {
            p.decode(&tpdo1(*id, sw[k], 0)).unwrap();
        }
        let per = period(p, MotorSpeeds::ZERO, SetpointMode::Hold);
        words.push(per[0].1);
        for (k, (_, word, target)) in per.iter().enumerate() {
            assert_eq!(*target, 0, "zero target while enabling");
            sw[k] = match *word {
                0x0006 => 0x0021,
                0x0007 => 0x0023,
                0x000F => 0x0027,
                w => panic!("controlword 0x{w:04X}"),
            };
        }
    }
    words
}

fn status(p: &mut Cia402Protocol, id: u8) -> (u32, bool, bool, u8) {
    match p.decode(&heartbeat(id, NmtState::Operational)).unwrap() {
        Some(DriveMessage::Status {
            error_code,
            running,
            estopped,
            raw_state,
            ..
        }) => (error_code, running, estopped, raw_state),
        m => panic!("{m:?}"),
    }
}

#[test]
fn filters_are_the_drives_cob_ids() {
    let p = Cia402Protocol::new(settings());
    let ids: Vec<u32> = p.rx_filters().iter().map(|f| f.id).collect();
    assert_eq!(
        ids,
        [0x703, 0x183, 0x283, 0x583, 0x083, 0x705, 0x185, 0x285, 0x585, 0x085]
    );
    assert_eq!(p.kind(), ProtocolKind::Cia402);
    assert!(p.is_watchdog_error(0x8130) && p.is_watchdog_error(0x8250));
    assert!(!p.is_watchdog_error(0x2310));
}

#[test]
fn startup_steps_by_hand() {
    let s = settings();
    // 1000 rad/s² × 60 / 2π = 9549.3 rpm/s; 2000 → 19098.6.
    assert_eq!((s.profile_accel, s.quick_stop_decel), (9549, 19099));
    let steps = startup_steps(&s, 3);
    assert_eq!(steps.len(), 7 + 22);
    assert_eq!(steps[0], Step::CheckDeviceType);
    let w = |i: u16, sub: u8, v: SdoValue| Step::Write(ObjectAddr::new(i, sub), v);
    assert_eq!(
        steps[1..7],
        [
            w(0x1017, 0, SdoValue::u16(100)),
            // Consumer: bridge node 127 (0x7F) << 16 | 300 ms (0x012C).
            w(0x1016, 1, SdoValue::u32(0x007F_012C)),
            w(0x6060, 0, SdoValue::i8(3)),
            w(0x6083, 0, SdoValue::u32(9549)),
            w(0x6084, 0, SdoValue::u32(9549)),
            w(0x6085, 0, SdoValue::u32(19099)),
        ]
    );
    let mut pre = s.clone();
    pre.mapping = PdoMapping::Preconfigured;
    pre.drive_heartbeat_ms = 0;
    pre.drive_consumer_heartbeat_ms = 0;
    assert_eq!(startup_steps(&pre, 3).len(), 5, "device type, 0x6060, 0x6083-0x6085");
}

#[test]
fn startup_frames_in_order() {
    let mut p = Cia402Protocol::new(settings());
    let all = configure(&mut p);
    // NMT enter pre-operational to each node first.
    assert_eq!((all[0].id, all[0].data[..2].to_vec()), (0x000, vec![0x80, 3]));
    assert_eq!(all[1].data[..2], [0x80, 5]);
    // Then, per node, upload 0x1000 (0x40 00 10 00), then the writes.
    let node3: Vec<&CanFrame> = all.iter().filter(|f| f.id == 0x603).collect();
    assert_eq!(node3[0].data, [0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]);
    assert_eq!(node3[1].data, [0x2B, 0x17, 0x10, 0x00, 100, 0, 0, 0]);
    assert_eq!(node3[3].data, [0x2F, 0x60, 0x60, 0x00, 0x03, 0, 0, 0]);
    // 9549 = 0x254D.
    assert_eq!(node3[4].data, [0x23, 0x83, 0x60, 0x00, 0x4D, 0x25, 0, 0]);
    assert_eq!(node3.len(), 29);
    // NMT start last, one per node.
    let starts: Vec<_> = all
        .iter()
        .filter(|f| f.id == 0 && f.data[0] == 1)
        .map(|f| f.data[1])
        .collect();
    assert_eq!(starts, [3, 5]);
    let last_sdo = all.iter().rposition(|f| f.id == 0x603).unwrap();
    let start3 = all.iter().position(|f| f.id == 0 && f.data[..2] == [1, 3]).unwrap();
    assert!(start3 > last_sdo);
}

#[test]
fn one_sdo_in_flight_per_node_and_the_bridge_heartbeat() {
    let mut p = Cia402Protocol::new(settings());
    let mut b = FrameBatch::new();
    p.startup(&mut b);
    b.clear();
    p.poll(t(1.0), &mut b);
    let ids: Vec<u32> = b.as_slice().iter().map(|f| f.id).collect();
    assert_eq!(
        ids,
        [0x77F, 0x603, 0x605],
        "heartbeat of node 127, one request per node"
    );
    assert_eq!(b.as_slice()[0].data[0], 0x05, "operational");
    b.clear();
    p.poll(t(1.05), &mut b);
    assert!(
        b.is_empty(),
        "nothing answered, heartbeat not yet due: {:?}",
        b.as_slice()
    );
    p.poll(t(1.1), &mut b);
    assert_eq!(b.as_slice().iter().map(|f| f.id).collect::<Vec<_>>(), [0x77F]);
}

#[test]
fn sdo_abort_fails_the_startup_with_its_code_and_a_report() {
    let mut p = Cia402Protocol::new(settings());
    let mut b = FrameBatch::new();
    p.startup(&mut b);
    b.clear();
    p.poll(t(1.0), &mut b);
    answer(&mut p, b.as_slice(), 0x0002_0192);
    b.clear();
    p.poll(t(1.001), &mut b); // 0x1017 writes
                              // Node 3 refuses 0x1017 (read only on this drive).
    let abort = CanFrame::standard(0x583, &[0x80, 0x17, 0x10, 0x00, 0x02, 0x00, 0x01, 0x06]).unwrap();
    assert!(matches!(
        p.decode(&abort),
        Ok(Some(DriveMessage::Handled { wheel: Wheel::Left }))
    ));
    let (err, running, ..) = status(&mut p, 3);
    assert_eq!((err, running), (0x0601_0002, false));
    let mut r = Vec::new();
    p.drain_reports(&mut r);
    assert_eq!(r.len(), 1);
    assert_eq!(r[0].wheel, Some(Wheel::Left));
    assert_eq!(
        r[0].message,
        "node 3 start-up failed: SDO 0x1017:00 aborted by the drive: 0x06010002 (attempt to write a read only object)"
    );
    // Node 3 sends nothing more; node 5 goes on.
    b.clear();
    p.poll(t(1.002), &mut b);
    assert!(b.as_slice().iter().all(|f| f.id != 0x603));
    // A new start-up clears the error.
    b.clear();
    p.startup(&mut b);
    assert_eq!(status(&mut p, 3).0, 0);
}

#[test]
fn sdo_timeout_aborts_and_reports_without_an_error_code() {
    let mut p = Cia402Protocol::new(settings());
    let mut b = FrameBatch::new();
    p.startup(&mut b);
    b.clear();
    p.poll(t(1.0), &mut b);
    b.clear();
    p.poll(t(1.2), &mut b);
    assert!(
        b.as_slice().iter().all(|f| f.id & !0x7F != 0x600),
        "at the limit: waiting"
    );
    b.clear();
    p.poll(t(1.201), &mut b);
    // The client aborts with 0x05040000 (CiA 301).
    let aborts: Vec<_> = b.as_slice().iter().filter(|f| f.data[0] == 0x80).collect();
    assert_eq!(aborts.len(), 2);
    assert_eq!(aborts[0].data, [0x80, 0x00, 0x10, 0x00, 0x00, 0x00, 0x04, 0x05]);
    let mut r = Vec::new();
    p.drain_reports(&mut r);
    assert_eq!(r.len(), 2);
    assert_eq!(
        r[0].message,
        "node 3 start-up failed: SDO 0x1000:00: no response within 200 ms"
    );
    assert_eq!(status(&mut p, 3).0, 0, "a timeout is retried, not latched");
    // No request after the failure.
    b.clear();
    p.poll(t(1.3), &mut b);
    assert!(b.as_slice().iter().all(|f| f.id & !0x7F != 0x600));
}

#[test]
fn a_device_that_is_not_cia402_is_refused() {
    let mut p = Cia402Protocol::new(settings());
    let mut b = FrameBatch::new();
    p.startup(&mut b);
    b.clear();
    p.poll(t(1.0), &mut b);
    // 0x00000191: CiA 401 (generic I/O).
    answer(&mut p, b.as_slice(), 0x0000_0191);
    assert_eq!(status(&mut p, 5).0, 0x0604_0043);
    let mut r = Vec::new();
    p.drain_reports(&mut r);
    assert!(
        r[1].message.contains("device type 0x00000191 is not a CiA 402 drive"),
        "{r:?}"
    );
}

#[test]
fn enabling_goes_shutdown_switch_on_enable_with_zero_targets() {
    let mut p = Cia402Protocol::new(settings());
    let words = enable(&mut p);
    assert_eq!(words[..3], [0x0006, 0x0007, 0x000F]);
    // Not running until the drive reports operation enabled in profile velocity.
    let (err, running, estopped, raw) = status(&mut p, 3);
    assert_eq!((err, running, estopped, raw), (0, true, false, 4));
    // Run: 10 rad/s at the motor = 95.49 rpm → 95; −20 → −191.
    let m = MotorSpeeds {
        left_radps: 10.0,
        right_radps: -20.0,
    };
    let per = period(&mut p, m, SetpointMode::Run);
    assert_eq!(per, [(0x203, 0x000F, 95), (0x205, 0x000F, -191)]);
    let per = period(&mut p, m, SetpointMode::Hold);
    assert_eq!(per, [(0x203, 0x000F, 0), (0x205, 0x000F, 0)]);
    // NaN never on the wire.
    let nan = MotorSpeeds {
        left_radps: f64::NAN,
        right_radps: f64::INFINITY,
    };
    let per = period(&mut p, nan, SetpointMode::Run);
    assert_eq!(per[0].2, 0);
}

#[test]
fn not_running_without_operational_heartbeat_or_profile_velocity() {
    let mut p = Cia402Protocol::new(settings());
    enable(&mut p);
    // Pre-operational heartbeat: not running, no motion.
    let m = p.decode(&heartbeat(3, NmtState::PreOperational)).unwrap();
    assert!(matches!(m, Some(DriveMessage::Status { running: false, .. })));
    let per = period(
        &mut p,
        MotorSpeeds {
            left_radps: 10.0,
            right_radps: 10.0,
        },
        SetpointMode::Run,
    );
    assert_eq!(per[0].2, 0);
    assert_ne!(per[1].2, 0, "the other node still runs");
    // Mode display other than 3 (e.g. a drive switched to position mode).
    let mut p = Cia402Protocol::new(settings());
    enable(&mut p);
    let f = encode_tpdo1(
        5,
        &Tpdo1 {
            statusword: 0x0027,
            error_code: 0,
            mode_display: 1,
        },
    );
    assert!(matches!(
        p.decode(&f),
        Ok(Some(DriveMessage::State { running: false, .. }))
    ));
}

#[test]
fn a_fault_stops_reports_and_is_not_reset_outside_startup() {
    let mut p = Cia402Protocol::new(settings());
    enable(&mut p);
    p.drain_reports(&mut Vec::new());
    // Fault, 0x603F = 0x2310 (continuous overcurrent).
    let m = p.decode(&tpdo1(3, 0x0008, 0x2310)).unwrap();
    assert_eq!(
        m,
        Some(DriveMessage::State {
            wheels: Wheels::One(Wheel::Left),
            error_code: 0x2310,
            running: false,
            estopped: false,
            raw_state: 7
        })
    );
    let per = period(
        &mut p,
        MotorSpeeds {
            left_radps: 10.0,
            right_radps: 10.0,
        },
        SetpointMode::Run,
    );
    assert_eq!((per[0].1, per[0].2), (0x0006, 0), "shutdown, no fault reset");
    let mut r = Vec::new();
    p.drain_reports(&mut r);
    assert!(
        r.iter()
            .any(|x| x.message == "node 3 (left wheel) fault, error code 0x2310 (current)"),
        "{r:?}"
    );
    // A fault without a code reports 0x1000.
    assert_eq!(
        p.decode(&tpdo1(3, 0x0008, 0)).unwrap().map(|m| match m {
            DriveMessage::State { error_code, .. } => error_code,
            _ => 0,
        }),
        Some(0x1000)
    );
}

#[test]
fn a_fault_present_at_startup_is_reset_by_bit7_edges_at_most_three_times() {
    let mut p = Cia402Protocol::new(settings());
    configure(&mut p);
    let mut words = Vec::new();
    for _ in 0..10 {
        p.decode(&tpdo1(3, 0x0008, 0x5530)).unwrap();
        words.push(period(&mut p, MotorSpeeds::ZERO, SetpointMode::Hold)[0].1);
    }
    assert_eq!(
        words,
        [0x0080, 0x0000, 0x0080, 0x0000, 0x0080, 0x0000, 0x0000, 0x0000, 0x0000, 0x0000]
    );
    // Once the drive came out of fault, a new fault is not reset.
    let mut p = Cia402Protocol::new(settings());
    configure(&mut p);
    p.decode(&tpdo1(3, 0x0008, 0x5530)).unwrap();
    assert_eq!(period(&mut p, MotorSpeeds::ZERO, SetpointMode::Hold)[0].1, 0x0080);
    p.decode(&tpdo1(3, 0x0040, 0)).unwrap();
    assert_eq!(period(&mut p, MotorSpeeds::ZERO, SetpointMode::Hold)[0].1, 0x0006);
    p.decode(&tpdo1(3, 0x0008, 0x5530)).unwrap();
    for _ in 0..3 {
        assert_eq!(period(&mut p, MotorSpeeds::ZERO, SetpointMode::Hold)[0].1, 0x0000);
    }
}

#[test]
fn estop_sends_quick_stop_and_needs_a_new_startup() {
    let mut p = Cia402Protocol::new(settings());
    enable(&mut p);
    let per = period(
        &mut p,
        MotorSpeeds {
            left_radps: 10.0,
            right_radps: 10.0,
        },
        SetpointMode::Estop,
    );
    assert_eq!(per, [(0x203, 0x0002, 0), (0x205, 0x0002, 0)]);
    // Quick stop active: estopped, not running.
    let m = p.decode(&tpdo1(3, 0x0007, 0)).unwrap();
    assert!(matches!(
        m,
        Some(DriveMessage::State {
            running: false,
            estopped: true,
            ..
        })
    ));
    // Without a new start-up the bridge only sends shutdown, never enable.
    p.decode(&tpdo1(3, 0x0040, 0)).unwrap();
    let per = period(
        &mut p,
        MotorSpeeds {
            left_radps: 10.0,
            right_radps: 10.0,
        },
        SetpointMode::Run,
    );
    assert_eq!((per[0].1, per[0].2), (0x0006, 0));
}

#[test]
fn leaving_operation_enabled_is_not_silently_undone() {
    let mut p = Cia402Protocol::new(settings());
    enable(&mut p);
    // The drive dropped to switched on by itself (e.g. its enable input).
    p.decode(&tpdo1(5, 0x0023, 0)).unwrap();
    for _ in 0..3 {
        let per = period(
            &mut p,
            MotorSpeeds {
                left_radps: 10.0,
                right_radps: 10.0,
            },
            SetpointMode::Run,
        );
        assert_eq!((per[1].1, per[1].2), (0x0006, 0), "shutdown, not enable operation");
    }
    let mut r = Vec::new();
    p.drain_reports(&mut r);
    assert!(
        r.iter()
            .any(|x| x.message.starts_with("node 5 left operation enabled: SwitchedOn")),
        "{r:?}"
    );
}

#[test]
fn shutdown_disables_with_zero() {
    let mut p = Cia402Protocol::new(settings());
    enable(&mut p);
    let mut b = FrameBatch::new();
    p.shutdown(&mut b);
    let f = frames(&b);
    assert_eq!(f.len(), 3);
    assert_eq!((f[0].id, f[0].data[..6].to_vec()), (0x203, vec![0x06, 0, 0, 0, 0, 0]));
    assert_eq!(f[1].id, 0x205);
    assert_eq!(f[2].id, 0x080);
}

#[test]
fn bootup_heartbeat_restarts_and_feedback_is_scaled() {
    let mut p = Cia402Protocol::new(settings());
    enable(&mut p);
    let m = p.decode(&heartbeat(5, NmtState::BootUp)).unwrap();
    assert!(matches!(m, Some(DriveMessage::Status { running: false, .. })));
    let mut r = Vec::new();
    p.drain_reports(&mut r);
    assert_eq!(
        r.last().unwrap().message,
        "node 5 booted (boot-up message): restarting it"
    );
    // 2048 counts = half a turn = π rad; 955 rpm = 100.007 rad/s.
    let m = p
        .decode(&encode_tpdo2(
            3,
            &Tpdo2 {
                position: 2048,
                velocity: 955,
            },
        ))
        .unwrap();
    match m {
        Some(DriveMessage::Feedback {
            wheel,
            motor_pos_rad,
            motor_vel_radps,
        }) => {
            assert_eq!(wheel, Wheel::Left);
            assert!((motor_pos_rad - std::f64::consts::PI).abs() < 1e-12);
            assert!((motor_vel_radps - 955.0 * std::f64::consts::TAU / 60.0).abs() < 1e-9);
        }
        m => panic!("{m:?}"),
    }
    assert_eq!(p.position_modulus_rad(), Some(1_048_576.0 * std::f64::consts::TAU));
}

#[test]
fn garbage_from_a_drive_id_is_an_error_not_a_value() {
    let mut p = Cia402Protocol::new(settings());
    // Undefined statusword 0x0001, short TPDOs, a bad heartbeat state.
    assert!(matches!(
        p.decode(&tpdo1(3, 0x0001, 0)),
        Err(DecodeError::Invalid { .. })
    ));
    let short = CanFrame::standard(0x283, &[0; 4]).unwrap();
    assert!(matches!(p.decode(&short), Err(DecodeError::Length { expected: 8, .. })));
    let hb = CanFrame::standard(0x703, &[0x33]).unwrap();
    assert!(matches!(p.decode(&hb), Err(DecodeError::Invalid { .. })));
    let empty = CanFrame::standard(0x703, &[]).unwrap();
    assert!(matches!(p.decode(&empty), Err(DecodeError::Length { .. })));
    let sdo = CanFrame::standard(0x583, &[0x60, 0, 0]).unwrap();
    assert!(p.decode(&sdo).is_err());
    // Not ours: another node, our own RPDO id, extended frames.
    assert_eq!(p.decode(&tpdo1(4, 0x0027, 0)), Ok(None));
    assert_eq!(p.decode(&CanFrame::standard(0x203, &[0; 6]).unwrap()), Ok(None));
    assert_eq!(p.decode(&CanFrame::extended(0x183, &[0; 5]).unwrap()), Ok(None));
    // EMCY: reported and consumed.
    let e = nmt::emcy(
        5,
        &nmt::Emcy {
            error_code: 0x4310,
            error_register: 0x08,
            manufacturer: [0; 5],
        },
    );
    assert_eq!(p.decode(&e), Ok(Some(DriveMessage::Handled { wheel: Wheel::Right })));
    let mut r = Vec::new();
    p.drain_reports(&mut r);
    assert_eq!(r[0].message, "node 5 EMCY 0x4310 (temperature), error register 0x08");
}

/// A restart while the drive is still enabled (after a bus fault, a
/// `reset` of the other wheel's fault): the statusword the bridge sees first
/// is from before its shutdown. It must not count as enabled: the drive is
/// shut down and goes through switch on and enable again, at zero target.
#[test]
fn a_drive_found_enabled_is_shut_down_first_and_a_stale_statusword_never_enables() {
    let mut p = Cia402Protocol::new(settings());
    enable(&mut p);
    // Restart (bridge start-up again) while the drives stay enabled.
    configure(&mut p);
    for id in [3, 5] {
        p.decode(&heartbeat(id, NmtState::Operational)).unwrap();
    }
    let run = MotorSpeeds {
        left_radps: 10.0,
        right_radps: 10.0,
    };
    let mut words = Vec::new();
    for sw in [0x0027, 0x0027, 0x0021, 0x0021, 0x0023, 0x0027] {
        let m = p.decode(&tpdo1(3, sw, 0)).unwrap();
        let running = matches!(m, Some(DriveMessage::State { running: true, .. }));
        let per = period(&mut p, run, SetpointMode::Run);
        words.push((sw, per[0].1, per[0].2, running));
    }
    assert_eq!(
        words,
        [
            // Stale "operation enabled": not running, shut down.
            (0x0027, 0x0006, 0, false),
            (0x0027, 0x0006, 0, false),
            (0x0021, 0x0007, 0, false),
            (0x0021, 0x0007, 0, false),
            (0x0023, 0x000F, 0, false),
            // Operation enabled after the bridge's own enable: running, 95 rpm.
            (0x0027, 0x000F, 95, true),
        ]
    );
}
