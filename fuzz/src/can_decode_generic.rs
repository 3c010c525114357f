//! `can_decode_generic`: every decoder of the generic protocol (status,
//! feedback, setpoint; `GenericProtocol::decode`) on arbitrary frames, then
//! the bridge speaking it (`can_decode::run_bridge`).
//!
//! Asserts: no panic; decoded speeds and positions are finite and in their
//! fields' ranges; a frame that decodes re-encodes to the same bytes.

use crate::can_decode::{any_frame, run_bridge};
use arbitrary::Unstructured;
use can_bridge::protocol::generic::{self, GenericIds, GenericProtocol};
use can_bridge::protocol::{DriveMessage, Protocol, ProtocolKind};

/// Runs one input: the first byte picks decoders or the bridge.
pub fn run(data: &[u8]) {
    match data.split_first() {
        Some((&b, rest)) if b % 2 == 0 => decoders(rest),
        Some((_, rest)) => run_bridge(rest, ProtocolKind::Generic),
        None => {}
    }
}

/// Most frames per input.
const MAX_FRAMES: usize = 512;

fn decoders(data: &[u8]) {
    let mut u = Unstructured::new(data);
    let Ok(base) = u.arbitrary::<u16>() else { return };
    let ids = GenericIds {
        base_id: u32::from(base) % (generic::MAX_BASE_ID + 1),
    };
    let mut proto = GenericProtocol::new(ids.base_id);
    // Unstructured yields zeros once exhausted: stop at the end of the bytes.
    for _ in 0..MAX_FRAMES {
        if u.is_empty() {
            break;
        }
        let Ok(mut f) = any_frame(&mut u) else { break };
        // Half the frames on the drive's own ids.
        if u.arbitrary::<bool>().unwrap_or(false) {
            f.extended = false;
            f.id = ids.base_id + [0x01, 0x02, 0x10, 0x11, 0x12][usize::from(u.arbitrary::<u8>().unwrap_or(0) % 5)];
        }
        if u.arbitrary::<bool>().unwrap_or(false) && f.len == 8 {
            f.data[7] = generic::crc8(f.id, &f.data[..7]); // get past the CRC
        }
        if let Ok(s) = generic::decode_status(&f) {
            assert!(s.state <= generic::STATE_FAULT);
            if f.id >= 0x10 {
                let back = generic::encode_status(GenericIds { base_id: f.id - 0x10 }, &s);
                assert_eq!(back.data, f.data, "status {s:?} does not round-trip");
            }
        }
        if let Ok(fb) = generic::decode_feedback(&f) {
            // The i32 range is one count wider below zero: i32::MIN decodes to
            // -21474.83648 rad/s, beyond VEL_LIMIT_RADPS (i32::MAX's) + 1e-5 once rounded.
            assert!(fb.vel_radps.is_finite() && fb.vel_radps.abs() <= generic::raw_to_vel(i32::MIN).abs());
            assert!(fb.pos_rad.is_finite() && (0.0..generic::POS_MODULUS_RAD).contains(&fb.pos_rad));
            let back = generic::encode_feedback(ids, can_bridge::Wheel::Left, &fb);
            assert_eq!(back.data[..7], f.data[..7], "feedback {fb:?} does not round-trip");
        }
        if let Ok(Some((wheel, sp))) = generic::decode_setpoint(ids, &f) {
            assert!(sp.vel_radps.is_finite());
            assert_eq!(
                generic::encode_setpoint(ids, wheel, &sp),
                f,
                "setpoint {sp:?} does not round-trip"
            );
        }
        match proto.decode(&f) {
            Ok(Some(DriveMessage::Feedback {
                motor_pos_rad,
                motor_vel_radps,
                ..
            })) => assert!(motor_pos_rad.is_finite() && motor_vel_radps.is_finite()),
            Ok(Some(DriveMessage::Status { raw_state, .. })) => assert!(raw_state <= generic::STATE_FAULT),
            Ok(Some(other)) => panic!("the generic protocol never produces {other:?}"),
            Ok(None) | Err(_) => {}
        }
    }
}
