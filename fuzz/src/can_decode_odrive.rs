//! `can_decode_odrive`: the ODrive CANSimple decoders (heartbeat and
//! encoder estimates through `OdriveProtocol::decode`, the drive side's
//! `decode_command`) on arbitrary frames, then the bridge speaking it
//! (`can_decode::run_bridge`).
//!
//! Asserts: no panic; decoded feedback is finite; ids split and rebuild.

use crate::can_decode::{any_frame, run_bridge};
use arbitrary::Unstructured;
use can_bridge::protocol::odrive::{self, OdriveProtocol};
use can_bridge::protocol::{DriveMessage, Protocol, ProtocolKind};

/// Runs one input: the first byte picks decoders or the bridge.
pub fn run(data: &[u8]) {
    match data.split_first() {
        Some((&b, rest)) if b % 2 == 0 => decoders(rest),
        Some((_, rest)) => run_bridge(rest, ProtocolKind::Odrive),
        None => {}
    }
}

/// Most frames per input.
const MAX_FRAMES: usize = 512;

fn decoders(data: &[u8]) {
    let mut u = Unstructured::new(data);
    let (Ok(l), Ok(r)) = (u.arbitrary::<u8>(), u.arbitrary::<u8>()) else {
        return;
    };
    let (left, right) = (u32::from(l) % 64, u32::from(r) % 64);
    let mut proto = OdriveProtocol::new(left, right, 0.0);
    // Unstructured yields zeros once exhausted: stop at the end of the bytes.
    for _ in 0..MAX_FRAMES {
        if u.is_empty() {
            break;
        }
        let Ok(mut f) = any_frame(&mut u) else { break };
        if u.arbitrary::<bool>().unwrap_or(false) {
            // On one of the nodes, with a command id the bridge listens to.
            let node = if u.arbitrary::<bool>().unwrap_or(false) {
                left
            } else {
                right
            };
            let cmd = [0x01, 0x09, u32::from(u.arbitrary::<u8>().unwrap_or(0) % 32)]
                [usize::from(u.arbitrary::<u8>().unwrap_or(0) % 3)];
            f.extended = false;
            f.id = odrive::arb_id(node, cmd);
        }
        if !f.extended {
            let (node, cmd) = odrive::split_id(f.id);
            assert_eq!(odrive::arb_id(node, cmd), f.id);
        }
        match proto.decode(&f) {
            Ok(Some(DriveMessage::Feedback {
                motor_pos_rad,
                motor_vel_radps,
                ..
            })) => assert!(motor_pos_rad.is_finite() && motor_vel_radps.is_finite()),
            Ok(Some(DriveMessage::Status { wheels, .. })) => {
                let _ = wheels;
            }
            Ok(Some(other)) => panic!("CANSimple never produces {other:?}"),
            Ok(None) | Err(_) => {}
        }
        if let Ok(Some(odrive::Command::SetInputVel { vel_turns_per_s, .. })) = odrive::decode_command(&f) {
            // The drive side sees raw f32s; the bridge never sends a non-finite one
            // (checked by the bridge half), here only: decoding does not panic.
            let _ = vel_turns_per_s;
        }
    }
}
