//! `can_decode_cia402`: the CiA 402 decoders and state machines on
//! arbitrary input: `Cia402Protocol::decode` (heartbeat, TPDO1, TPDO2, SDO
//! response, EMCY) fed arbitrary frames between arbitrary start-ups,
//! periods and polls; the SDO, PDO and NMT codecs; the drive's state
//! machine under arbitrary controlwords; the virtual drive's CiA 402 nodes
//! on arbitrary frames; then the bridge speaking it (`can_decode::run_bridge`).
//!
//! Asserts: no panic; decoded feedback is finite; a frame that decodes
//! re-encodes to the same bytes (SDO, PDOs); a period's RPDOs carry a
//! non-zero target only with enable operation and only for a node whose
//! last status said running; the drive's machine enters operation enabled
//! only from ready to switch on / switched on by enable operation.

use crate::can_decode::{any_frame, run_bridge};
use arbitrary::Unstructured;
use can_bridge::config::default_config;
use can_bridge::protocol::cia402::state_machine::{self, cw, DriveMachine, DriveState};
use can_bridge::protocol::cia402::{nmt, pdo, sdo, Cia402Protocol};
use can_bridge::protocol::{DriveMessage, FrameBatch, Protocol, ProtocolKind, SetpointMode};
use can_bridge::virtual_drive::{VirtualDrive, VirtualDriveConfig};
use can_bridge::{MotorSpeeds, Timestamp, Wheel};
use std::time::Duration;

/// Runs one input: the first byte picks decoders or the bridge.
pub fn run(data: &[u8]) {
    match data.split_first() {
        Some((&b, rest)) if b % 2 == 0 => decoders(rest),
        Some((_, rest)) => run_bridge(rest, ProtocolKind::Cia402),
        None => {}
    }
}

/// Most operations per input.
const MAX_OPS: usize = 512;

fn decoders(data: &[u8]) {
    let mut u = Unstructured::new(data);
    let cfg = default_config();
    let mut p = Cia402Protocol::new(cfg.cia402.settings());
    let nodes = [cfg.cia402.left_node_id, cfg.cia402.right_node_id];
    let mut running = [false; 2];
    let mut machine = DriveMachine::new();
    let mut drive = VirtualDrive::new(
        VirtualDriveConfig {
            protocol: ProtocolKind::Cia402,
            left_node_id: nodes[0],
            right_node_id: nodes[1],
            ..Default::default()
        },
        Timestamp::ZERO,
    );
    let mut now = Timestamp::from_secs_f64(1.0);
    let mut batch = FrameBatch::new();
    let mut out = Vec::new();
    for _ in 0..MAX_OPS {
        if u.is_empty() {
            break;
        }
        let Ok(op) = u.arbitrary::<u8>() else { break };
        match op % 8 {
            0 => {
                batch.clear();
                p.startup(&mut batch);
            }
            1 => {
                batch.clear();
                now = now + Duration::from_millis(u64::from(u.arbitrary::<u8>().unwrap_or(0)));
                p.poll(now, &mut batch);
                for f in batch.as_slice() {
                    assert!(f.is_valid());
                    drive.handle_frame(f, now);
                }
            }
            2 => {
                let mode = [SetpointMode::Run, SetpointMode::Hold, SetpointMode::Estop]
                    [usize::from(u.arbitrary::<u8>().unwrap_or(0) % 3)];
                let m = MotorSpeeds {
                    left_radps: crate::input::f64_of(&mut u).unwrap_or(0.0),
                    right_radps: crate::input::f64_of(&mut u).unwrap_or(0.0),
                };
                batch.clear();
                p.setpoints(m, mode, &mut batch);
                for f in batch.as_slice().iter().filter(|f| f.id & !0x7F == 0x200) {
                    let r = pdo::decode_rpdo1(f).expect("the bridge's RPDO1 decodes");
                    let k = nodes.iter().position(|n| f.id == 0x200 + n).expect("one of our nodes");
                    if r.target_velocity != 0 {
                        assert_eq!(r.controlword, cw::ENABLE_OPERATION, "{f:?}");
                        assert!(
                            running[k] && mode == SetpointMode::Run,
                            "motion for a node not running: {f:?}"
                        );
                    }
                    if mode == SetpointMode::Estop {
                        assert_eq!((r.controlword, r.target_velocity), (cw::QUICK_STOP, 0));
                    }
                    drive.handle_frame(f, now);
                }
            }
            3 => {
                let _ = machine.on_controlword(u.arbitrary().unwrap_or(0));
                let before = machine.state;
                let word: u16 = u.arbitrary().unwrap_or(0);
                machine.on_controlword(word);
                if machine.state == DriveState::OperationEnabled && before != DriveState::OperationEnabled {
                    assert!(matches!(before, DriveState::ReadyToSwitchOn | DriveState::SwitchedOn));
                    assert_eq!(
                        state_machine::decode_controlword(word),
                        Some(state_machine::Command::EnableOperation)
                    );
                }
                if u.arbitrary::<u8>().unwrap_or(0) % 16 == 0 {
                    machine.fault();
                }
                machine.tick(u.arbitrary().unwrap_or(true));
            }
            4 => {
                now = now + Duration::from_millis(u64::from(u.arbitrary::<u8>().unwrap_or(0)));
                drive.step(now, &mut out);
                for f in out.drain(..) {
                    let _ = p.decode(&f);
                }
                assert!(drive.axis(Wheel::Left).vel_radps.is_finite());
            }
            _ => {
                let Ok(mut f) = any_frame(&mut u) else { break };
                if u.arbitrary::<bool>().unwrap_or(false) {
                    f.extended = false;
                    let n = nodes[usize::from(u.arbitrary::<bool>().unwrap_or(false))];
                    f.id = [0x080, 0x180, 0x280, 0x580, 0x700, 0x600, 0x200, 0x000]
                        [usize::from(u.arbitrary::<u8>().unwrap_or(0) % 8)]
                        + if f.id % 3 == 0 { 0 } else { n };
                }
                codecs(&f);
                drive.handle_frame(&f, now);
                match p.decode(&f) {
                    Ok(Some(DriveMessage::Feedback {
                        motor_pos_rad,
                        motor_vel_radps,
                        ..
                    })) => assert!(motor_pos_rad.is_finite() && motor_vel_radps.is_finite()),
                    Ok(Some(DriveMessage::Status { wheels, running: r, .. }))
                    | Ok(Some(DriveMessage::State { wheels, running: r, .. })) => {
                        for (k, w) in Wheel::BOTH.iter().enumerate() {
                            if wheels.covers(*w) {
                                running[k] = r;
                            }
                        }
                    }
                    Ok(_) | Err(_) => {}
                }
            }
        }
    }
    let mut reports = Vec::new();
    p.drain_reports(&mut reports);
    assert!(reports.len() <= 64, "reports are bounded");
}

/// The codecs: what decodes re-encodes to the same bytes.
fn codecs(f: &can_bridge::CanFrame) {
    if f.extended {
        return;
    }
    let node = (f.id & 0x7F) as u8;
    if let Ok(r) = sdo::decode_request(f) {
        let again = sdo::encode_request(node, &r);
        assert_eq!(sdo::decode_request(&again), Ok(r));
    }
    if let Ok(r) = sdo::decode_response(f) {
        let again = sdo::encode_response(node, &r);
        assert_eq!(sdo::decode_response(&again), Ok(r));
    }
    if let Ok(t) = pdo::decode_tpdo1(f) {
        assert_eq!(pdo::encode_tpdo1(node, &t).data, f.data);
    }
    if let Ok(t) = pdo::decode_tpdo2(f) {
        assert_eq!(pdo::encode_tpdo2(node, &t).data, f.data);
    }
    if let Ok(r) = pdo::decode_rpdo1(f) {
        assert_eq!(pdo::encode_rpdo1(node, &r).data, f.data);
    }
    if let Some((c, n)) = nmt::decode_nmt(f) {
        assert_eq!(nmt::nmt_command(c, n).data, f.data);
    }
    if let Some(e) = nmt::decode_emcy(f) {
        assert_eq!(nmt::emcy(node, &e).data, f.data);
    }
    if let Some(Ok(s)) = nmt::decode_heartbeat(f) {
        // Only the state's 7 bits are meaningful.
        assert_eq!(nmt::heartbeat(node, s).data[0], f.data[0] & 0x7F);
    }
}
