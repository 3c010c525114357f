//! One CANopen node carrying both wheels (a dual-channel controller: axis 1
//! at the standard objects, axis 2 at +0x800), fed frames by hand. Expected
//! values from CiA 301/402 (objects, PDO numbers of the predefined
//! connection set) and Roboteq's channel-2 objects (0x6840, 0x68FF, …).

use super::nmt::{heartbeat, NmtState};
use super::pdo::{encode_tpdo1, encode_tpdo2, Tpdo1, Tpdo2};
use super::sdo::{decode_request, encode_response, SdoRequest, SdoResponse};
use super::units::VelocityUnit;
use super::*;

const NODE: u8 = 1;

fn settings() -> Cia402Settings {
    let scaling = Scaling::new(VelocityUnit::Rpm, 1.0, 4096);
    Cia402Settings {
        nodes: [NODE, NODE],
        axes: [AxisLayout::new(1, 0x800), AxisLayout::new(2, 0x800)],
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

/// Runs the start-up, answering every SDO request; returns every frame.
fn configure(p: &mut Cia402Protocol) -> Vec<CanFrame> {
    let mut all = Vec::new();
    let mut b = FrameBatch::new();
    p.startup(&mut b);
    all.extend_from_slice(b.as_slice());
    for k in 0..200 {
        b.clear();
        p.poll(t(1.0 + f64::from(k) * 0.001), &mut b);
        all.extend_from_slice(b.as_slice());
        if b.as_slice().iter().any(|f| f.id == 0 && f.data[0] == 0x01) {
            return all;
        }
        for f in b.as_slice().iter().filter(|f| f.id == 0x600 + u32::from(NODE)) {
            let r = match decode_request(f).unwrap() {
                SdoRequest::Upload { addr } => SdoResponse::Uploaded {
                    addr,
                    value: SdoValue::u32(0x0002_0192),
                },
                SdoRequest::Download { addr, .. } => SdoResponse::DownloadDone { addr },
                SdoRequest::Abort { .. } => continue,
            };
            p.decode(&encode_response(NODE, &r)).unwrap();
        }
    }
    panic!("start-up did not finish");
}

fn state_tpdo(cob: u32, statusword: u16, error_code: u16) -> CanFrame {
    let mut f = encode_tpdo1(
        NODE,
        &Tpdo1 {
            statusword,
            error_code,
            mode_display: 3,
        },
    );
    f.id = cob;
    f
}

/// (COB-ID, controlword, target) of each RPDO of one period.
fn period(p: &mut Cia402Protocol, m: MotorSpeeds, mode: SetpointMode) -> Vec<(u32, u16, i32)> {
    let mut b = FrameBatch::new();
    p.setpoints(m, mode, &mut b);
    let f = b.as_slice();
    assert_eq!(f.last().map(|x| x.id), Some(0x080), "SYNC closes the period");
    f[..f.len() - 1]
        .iter()
        .map(|x| {
            let r = pdo::decode_rpdo1(x).unwrap();
            (x.id, r.controlword, r.target_velocity)
        })
        .collect()
}

/// Both axes to operation enabled: each answers its own controlwords.
fn enable(p: &mut Cia402Protocol) {
    configure(p);
    p.decode(&heartbeat(NODE, NmtState::Operational)).unwrap();
    let mut sw = [0x0040u16; 2];
    for _ in 0..6 {
        p.decode(&state_tpdo(0x181, sw[0], 0)).unwrap();
        p.decode(&state_tpdo(0x381, sw[1], 0)).unwrap();
        for (cob, word, target) in period(p, MotorSpeeds::ZERO, SetpointMode::Hold) {
            assert_eq!(target, 0);
            let k = if cob == 0x201 { 0 } else { 1 };
            sw[k] = match word {
                0x0006 => 0x0021,
                0x0007 => 0x0023,
                0x000F => 0x0027,
                w => panic!("0x{w:04X}"),
            };
        }
    }
}

fn heartbeat_axes(p: &mut Cia402Protocol, state: NmtState) -> [Option<AxisStatus>; 2] {
    match p.decode(&heartbeat(NODE, state)).unwrap() {
        Some(DriveMessage::Heartbeat { axes }) => axes,
        m => panic!("{m:?}"),
    }
}

#[test]
fn one_node_listens_for_both_axes_pdos() {
    let p = Cia402Protocol::new(settings());
    let ids: Vec<u32> = p.rx_filters().iter().map(|f| f.id).collect();
    // Heartbeat, TPDO1/TPDO2 (axis 1), TPDO3/TPDO4 (axis 2), SDO, EMCY.
    assert_eq!(ids, [0x701, 0x181, 0x281, 0x381, 0x481, 0x581, 0x081]);
}

#[test]
fn startup_steps_per_node_then_per_axis_by_hand() {
    let s = settings();
    let steps = startup_steps(&s, NODE);
    let w = |i: u16, sub: u8, v: SdoValue| Step::Write(ObjectAddr::new(i, sub), v);
    assert_eq!(steps[0], Step::CheckDeviceType);
    assert_eq!(
        steps[1..11],
        [
            w(0x1017, 0, SdoValue::u16(100)),
            w(0x1016, 1, SdoValue::u32(0x007F_012C)),
            w(0x6060, 0, SdoValue::i8(3)),
            w(0x6083, 0, SdoValue::u32(9549)),
            w(0x6084, 0, SdoValue::u32(9549)),
            w(0x6085, 0, SdoValue::u32(19099)),
            w(0x6860, 0, SdoValue::i8(3)),
            w(0x6883, 0, SdoValue::u32(9549)),
            w(0x6884, 0, SdoValue::u32(9549)),
            w(0x6885, 0, SdoValue::u32(19099)),
        ]
    );
    // Axis 2's PDOs: RPDO2 (COB-ID 0x301), TPDO3 (0x381), TPDO4 (0x481), mapping
    // its own objects, in the CiA 301 order (disable, count 0, entries, count, type, enable).
    let axis2: Vec<(u16, u8, u32)> = steps[11 + 22..]
        .iter()
        .map(|s| match s {
            Step::Write(a, v) => (a.index, a.sub, v.as_u32()),
            Step::CheckDeviceType => panic!(),
        })
        .collect();
    assert_eq!(
        axis2,
        [
            (0x1401, 1, 0x8000_0301),
            (0x1601, 0, 0),
            (0x1601, 1, 0x6840_0010),
            (0x1601, 2, 0x68FF_0020),
            (0x1601, 0, 2),
            (0x1401, 2, 1),
            (0x1401, 1, 0x0000_0301),
            (0x1802, 1, 0x8000_0381),
            (0x1A02, 0, 0),
            (0x1A02, 1, 0x6841_0010),
            (0x1A02, 2, 0x683F_0010),
            (0x1A02, 3, 0x6861_0008),
            (0x1A02, 0, 3),
            (0x1802, 2, 1),
            (0x1802, 1, 0x0000_0381),
            (0x1803, 1, 0x8000_0481),
            (0x1A03, 0, 0),
            (0x1A03, 1, 0x6864_0020),
            (0x1A03, 2, 0x686C_0020),
            (0x1A03, 0, 2),
            (0x1803, 2, 1),
            (0x1803, 1, 0x0000_0481),
        ]
    );
    assert_eq!(steps.len(), 1 + 2 + 8 + 22 + 22);
}

#[test]
fn one_nmt_per_node_and_each_axis_enabled_by_its_own_rpdo() {
    let mut p = Cia402Protocol::new(settings());
    let all = configure(&mut p);
    let nmt: Vec<[u8; 2]> = all
        .iter()
        .filter(|f| f.id == 0)
        .map(|f| [f.data[0], f.data[1]])
        .collect();
    assert_eq!(nmt, [[0x80, NODE], [0x01, NODE]], "pre-operational, then start, once");
    enable(&mut p);
    let axes = heartbeat_axes(&mut p, NmtState::Operational);
    let run = AxisStatus {
        error_code: 0,
        running: true,
        estopped: false,
        raw_state: DriveState::OperationEnabled.code(),
    };
    assert_eq!(axes, [Some(run), Some(run)]);
    // 10 rad/s = 95 rpm on RPDO1 (0x201, axis 1), −20 rad/s = −191 rpm on RPDO2 (0x301, axis 2).
    let m = MotorSpeeds {
        left_radps: 10.0,
        right_radps: -20.0,
    };
    assert_eq!(
        period(&mut p, m, SetpointMode::Run),
        [(0x201, 0x000F, 95), (0x301, 0x000F, -191)]
    );
    // Feedback: TPDO4 is the right wheel's.
    match p
        .decode(&{
            let mut f = encode_tpdo2(
                NODE,
                &Tpdo2 {
                    position: 2048,
                    velocity: -191,
                },
            );
            f.id = 0x481;
            f
        })
        .unwrap()
    {
        Some(DriveMessage::Feedback {
            wheel, motor_pos_rad, ..
        }) => {
            assert_eq!(wheel, Wheel::Right);
            assert!((motor_pos_rad - std::f64::consts::PI).abs() < 1e-12);
        }
        m => panic!("{m:?}"),
    }
}

/// A fault on axis 2 alone: its wheel reports the code, axis 1 keeps its
/// state (the bridge stops both wheels for any fault), the report names the
/// node, the axis and the wheel; the next start-up resets axis 2's fault
/// with bit-7 edges on RPDO2 only.
#[test]
fn a_fault_on_axis_2_alone_is_named_and_reset_on_axis_2_only() {
    let mut p = Cia402Protocol::new(settings());
    enable(&mut p);
    p.drain_reports(&mut Vec::new());
    let m = p.decode(&state_tpdo(0x381, 0x0008, 0x2310)).unwrap();
    assert_eq!(
        m,
        Some(DriveMessage::State {
            wheels: Wheels::One(Wheel::Right),
            error_code: 0x2310,
            running: false,
            estopped: false,
            raw_state: DriveState::Fault.code(),
        })
    );
    let axes = heartbeat_axes(&mut p, NmtState::Operational);
    assert_eq!(axes[0].map(|a| (a.error_code, a.running)), Some((0, true)));
    assert_eq!(axes[1].map(|a| (a.error_code, a.running)), Some((0x2310, false)));
    let mut r = Vec::new();
    p.drain_reports(&mut r);
    assert!(
        r.iter().any(
            |x| x.message == "node 1 axis 2 (right wheel) fault, error code 0x2310 (current)"
                && x.wheel == Some(Wheel::Right)
        ),
        "{r:?}"
    );
    // No fault reset outside a start-up.
    let per = period(&mut p, MotorSpeeds::ZERO, SetpointMode::Hold);
    assert_eq!(per[1], (0x301, 0x0006, 0));
    // Start-up: RPDO2 carries the reset (0x0080 after a word without bit 7); RPDO1 does not.
    configure(&mut p);
    p.decode(&heartbeat(NODE, NmtState::Operational)).unwrap();
    p.decode(&state_tpdo(0x181, 0x0040, 0)).unwrap();
    p.decode(&state_tpdo(0x381, 0x0008, 0x2310)).unwrap();
    let per = period(&mut p, MotorSpeeds::ZERO, SetpointMode::Hold);
    assert_eq!((per[0].1, per[1].1), (0x0006, 0x0080));
}

#[test]
fn the_nodes_bootup_stops_both_axes() {
    let mut p = Cia402Protocol::new(settings());
    enable(&mut p);
    let axes = heartbeat_axes(&mut p, NmtState::BootUp);
    assert!(axes.iter().all(|a| a.is_some_and(|a| !a.running)), "{axes:?}");
    let mut r = Vec::new();
    p.drain_reports(&mut r);
    assert_eq!(
        (r.last().unwrap().message.as_str(), r.last().unwrap().wheel),
        ("node 1 booted (boot-up message): restarting it", None)
    );
    let m = MotorSpeeds {
        left_radps: 10.0,
        right_radps: 10.0,
    };
    assert!(period(&mut p, m, SetpointMode::Run).iter().all(|x| x.2 == 0));
}
