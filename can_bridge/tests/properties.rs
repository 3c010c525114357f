//! Property tests (fixed seed; set PROPTEST_RNG_SEED to explore).
//!
//! The main one: whatever the commands (NaN, ±inf, huge, tiny, any rate),
//! e-stops and resets, every frame the bridge puts on the wire decodes to a
//! finite setpoint within the wheel speed limit, whose twist is within
//! v_max/ω_max, and which changes from the previous one no faster than the
//! accel/decel limits allow, unless it is an immediate stop to exactly zero.

mod common;

use can_bridge::kinematics::WheelSpeeds;
use can_bridge::limits::{clamp_twist, max_change, saturate_wheels, RampLimiter};
use can_bridge::protocol::cia402::{self, pdo, sdo, state_machine};
use can_bridge::protocol::generic::{self, GenericIds};
use can_bridge::protocol::{odrive, DriveMessage, Protocol};
use can_bridge::virtual_drive::VirtualDrive;
use can_bridge::{CanFrame, ProtocolKind, Twist};
use common::*;
use proptest::prelude::*;
use proptest::test_runner::RngSeed;

fn config(cases: u32) -> ProptestConfig {
    let mut c = ProptestConfig::with_cases(cases);
    if std::env::var_os("PROPTEST_RNG_SEED").is_none() {
        c.rng_seed = RngSeed::Fixed(0xCA4B);
    }
    c.failure_persistence = None;
    c
}

/// Any f64, weighted towards the nasty ones.
fn any_speed() -> impl Strategy<Value = f64> {
    prop_oneof![
        3 => -3.0..3.0f64,
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(f64::NEG_INFINITY),
        1 => Just(f64::MAX),
        1 => Just(-f64::MAX),
        1 => Just(f64::MIN_POSITIVE),
        1 => Just(-0.0),
        2 => any::<f64>(),
    ]
}

#[derive(Clone, Debug)]
enum Op {
    Command(f64, f64),
    Wait(u16),
    Estop,
    Reset,
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        8 => (any_speed(), any_speed()).prop_map(|(v, w)| Op::Command(v, w)),
        6 => (1u16..120).prop_map(Op::Wait),
        1 => Just(Op::Estop),
        1 => Just(Op::Reset),
    ]
}

proptest! {
    #![proptest_config(config(256))]

    #[test]
    fn no_input_ever_yields_a_bad_setpoint_on_the_wire(
        protocol in prop_oneof![Just(ProtocolKind::Generic), Just(ProtocolKind::Odrive), Just(ProtocolKind::Cia402)],
        ops in proptest::collection::vec(op(), 1..60),
    ) {
        let mut c = bridge_config(protocol);
        c.limits.wheel_accel_radps2 = 25.0;
        c.limits.wheel_decel_radps2 = 60.0;
        let lim = c.limits.clone();
        let kin = c.diff_drive();
        let period = 1.0 / c.timing.tx_rate_hz;
        let d = drive_config(&c);
        let mut sim = Sim::new(c, d);
        // CiA 402 starts over SDO (~0.25 s here): ready before the ops.
        sim.run_s(0.5);
        for o in &ops {
            match *o {
                Op::Command(v, w) => { let t = sim.t; let _ = sim.bridge.command(Twist::new(v, w), t); }
                Op::Wait(ms) => { for _ in 0..ms { sim.step(); } }
                Op::Estop => { let t = sim.t; sim.bridge.estop(t); }
                Op::Reset => { let t = sim.t; sim.bridge.reset(t); }
            }
            sim.step();
        }
        let speeds = assert_wire_is_clean(&sim.tap.wire_log(), protocol);
        // Pair up left/right in order (left is always sent first).
        let mut prev = WheelSpeeds::ZERO;
        let mut it = speeds.iter();
        while let (Some(&(0, ml)), Some(&(1, mr))) = (it.next(), it.next()) {
            let w = kin.to_wheel(can_bridge::MotorSpeeds { left_radps: ml, right_radps: mr });
            // Quantization: 1e-5 rad/s at the motor and f32 (ODrive); CiA 402:
            // half an rpm LSB (2π/120 rad/s) at the motor, over the gear.
            let eps = match protocol {
                ProtocolKind::Cia402 => std::f64::consts::TAU / 120.0 / kin.gear_ratio + 1e-9,
                _ => 1e-4,
            };
            prop_assert!(w.left_radps.abs() <= lim.max_wheel_speed_radps + eps, "{w:?}");
            prop_assert!(w.right_radps.abs() <= lim.max_wheel_speed_radps + eps, "{w:?}");
            let t = kin.twist(w);
            let r = kin.wheel_radius_m;
            prop_assert!(t.linear_mps.abs() <= lim.v_max_mps + 1e-5 + eps * r, "{t:?}");
            prop_assert!(t.angular_radps.abs() <= lim.omega_max_radps + 1e-4 + 2.0 * eps * r / kin.wheel_separation_m, "{t:?}");
            let stop = w.left_radps == 0.0 && w.right_radps == 0.0;
            if !stop {
                for (a, b) in [(prev.left_radps, w.left_radps), (prev.right_radps, w.right_radps)] {
                    let allowed = max_change(a, b, lim.wheel_accel_radps2, lim.wheel_decel_radps2, period);
                    prop_assert!((b - a).abs() <= allowed + 2.0 * eps, "{a} → {b}, allowed {allowed}");
                }
            }
            prev = w;
        }
    }

    #[test]
    fn clamping_keeps_curvature_and_limits(v in any_speed(), w in any_speed()) {
        let (t, _) = clamp_twist(Twist::new(v, w), 0.5, 2.0);
        prop_assert!(t.is_finite());
        prop_assert!(t.linear_mps.abs() <= 0.5 && t.angular_radps.abs() <= 2.0);
        let (k0, k1) = (w / v, t.angular_radps / t.linear_mps);
        if k0.is_finite() && v.abs() > 1e-3 && t.linear_mps.abs() > 1e-12 {
            // Same curvature ω/v (relative), same signs.
            prop_assert!((k0 - k1).abs() <= 1e-9 * k0.abs().max(1.0), "{k0} vs {k1}");
            prop_assert!(v.signum() == t.linear_mps.signum());
        }
    }

    #[test]
    fn wheel_saturation_keeps_the_ratio(l in any_speed(), r in any_speed()) {
        let (s, _) = saturate_wheels(WheelSpeeds { left_radps: l, right_radps: r }, 20.0);
        prop_assert!(s.is_finite() && s.max_abs() <= 20.0);
        if (l / r).is_finite() && r.abs() > 1e-6 && s.right_radps.abs() > 1e-12 {
            prop_assert!((l / r - s.left_radps / s.right_radps).abs() <= 1e-9 * (l / r).abs().max(1.0));
        }
    }

    #[test]
    fn the_ramp_respects_its_limits(
        start in (-20.0..20.0f64, -20.0..20.0f64),
        targets in proptest::collection::vec((any_speed(), any_speed()), 1..40),
    ) {
        let mut r = RampLimiter::new();
        // Walk to the start point first (large limits).
        r.step(WheelSpeeds { left_radps: start.0, right_radps: start.1 }, 1.0, 1e9, 1e9);
        for (l, rr) in targets {
            let prev = r.current();
            let next = r.step(WheelSpeeds { left_radps: l, right_radps: rr }, 0.02, 25.0, 60.0);
            prop_assert!(next.is_finite());
            for (a, b) in [(prev.left_radps, next.left_radps), (prev.right_radps, next.right_radps)] {
                prop_assert!((b - a).abs() <= max_change(a, b, 25.0, 60.0, 0.02) + 1e-9);
            }
        }
    }

    #[test]
    fn generic_speed_round_trip(v in -generic::VEL_LIMIT_RADPS..generic::VEL_LIMIT_RADPS, counter in any::<u8>()) {
        let ids = GenericIds { base_id: 0x100 };
        let f = generic::encode_setpoint(ids, can_bridge::Wheel::Left,
            &generic::Setpoint { vel_radps: v, counter, enable: true, estop: false });
        let (_, sp) = generic::decode_setpoint(ids, &f).unwrap().unwrap();
        prop_assert!((sp.vel_radps - v).abs() <= 0.5e-5 + 1e-9 * v.abs());
        prop_assert_eq!(sp.counter, counter);
    }

    #[test]
    fn decoders_never_panic_and_never_yield_non_finite(
        id in 0u32..0x800, len in 0u8..=8, data in any::<[u8; 8]>(),
    ) {
        let mut data = data;
        for b in data.iter_mut().skip(usize::from(len)) { *b = 0; }
        let f = CanFrame { id, extended: false, data, len };
        let mut g = generic::GenericProtocol::new(0x100);
        let mut o = odrive::OdriveProtocol::new(0, 1, 0.0);
        let mut o6 = odrive::OdriveProtocol::new(0, 1, 0.0).with_firmware(odrive::Firmware::V0_6);
        let mut co = cia402::Cia402Protocol::new(can_bridge::config::default_config().cia402.settings());
        for p in [&mut g as &mut dyn Protocol, &mut o, &mut o6, &mut co] {
            if let Ok(Some(DriveMessage::Feedback { motor_pos_rad, motor_vel_radps, .. })) = p.decode(&f) {
                prop_assert!(motor_pos_rad.is_finite() && motor_vel_radps.is_finite());
            }
        }
        // The virtual drive swallows garbage too.
        for (protocol, odrive_firmware) in [
            (ProtocolKind::Generic, odrive::Firmware::V0_5),
            (ProtocolKind::Odrive, odrive::Firmware::V0_5),
            (ProtocolKind::Odrive, odrive::Firmware::V0_6),
            (ProtocolKind::Cia402, odrive::Firmware::V0_5),
        ] {
            let (left_node_id, right_node_id) = if protocol == ProtocolKind::Cia402 { (1, 2) } else { (0, 1) };
            let cfg = can_bridge::virtual_drive::VirtualDriveConfig {
                protocol, left_node_id, right_node_id, odrive_firmware, ..Default::default()
            };
            let mut d = VirtualDrive::new(cfg, can_bridge::Timestamp::ZERO);
            d.handle_frame(&f, can_bridge::Timestamp::from_secs_f64(0.01));
            let mut out = Vec::new();
            d.step(can_bridge::Timestamp::from_secs_f64(0.02), &mut out);
            prop_assert!(d.axis(can_bridge::Wheel::Left).vel_radps.is_finite());
        }
    }

    #[test]
    fn cia402_sdo_frames_round_trip(
        index in any::<u16>(), sub in any::<u8>(), node in 1u8..=127, len in 1u8..=4, raw in any::<u32>(), code in any::<u32>(),
    ) {
        let addr = sdo::ObjectAddr::new(index, sub);
        let mask = if len == 4 { u32::MAX } else { (1u32 << (8 * u32::from(len))) - 1 };
        let value = sdo::SdoValue { bytes: (raw & mask).to_le_bytes(), len };
        for req in [
            sdo::SdoRequest::Download { addr, value },
            sdo::SdoRequest::Upload { addr },
            sdo::SdoRequest::Abort { addr, code },
        ] {
            let f = sdo::encode_request(node, &req);
            prop_assert_eq!((f.id, f.len), (0x600 + u32::from(node), 8));
            prop_assert_eq!(sdo::decode_request(&f), Ok(req));
        }
        for resp in [
            sdo::SdoResponse::DownloadDone { addr },
            sdo::SdoResponse::Uploaded { addr, value },
            sdo::SdoResponse::Abort { addr, code },
        ] {
            let f = sdo::encode_response(node, &resp);
            prop_assert_eq!(f.id, 0x580 + u32::from(node));
            prop_assert_eq!(sdo::decode_response(&f), Ok(resp));
        }
    }

    #[test]
    fn cia402_pdos_round_trip(node in 1u8..=127, cw in any::<u16>(), v in any::<i32>(), sw in any::<u16>(), err in any::<u16>(), mode in any::<i8>(), pos in any::<i32>()) {
        let r = pdo::Rpdo1 { controlword: cw, target_velocity: v };
        prop_assert_eq!(pdo::decode_rpdo1(&pdo::encode_rpdo1(node, &r)), Ok(r));
        let t1 = pdo::Tpdo1 { statusword: sw, error_code: err, mode_display: mode };
        prop_assert_eq!(pdo::decode_tpdo1(&pdo::encode_tpdo1(node, &t1)), Ok(t1));
        let t2 = pdo::Tpdo2 { position: pos, velocity: v };
        prop_assert_eq!(pdo::decode_tpdo2(&pdo::encode_tpdo2(node, &t2)), Ok(t2));
    }

    /// Any statusword decodes to the state whose Table 5 pattern it matches
    /// under that state's mask (0x4F or 0x6F), or to none.
    #[test]
    fn cia402_statusword_decoding_agrees_with_the_masks(word in any::<u16>()) {
        use state_machine::DriveState as S;
        let matches: Vec<S> = S::ALL
            .into_iter()
            .filter(|s| {
                let mask = match s {
                    S::NotReadyToSwitchOn | S::SwitchOnDisabled | S::FaultReactionActive | S::Fault => 0x004F,
                    _ => 0x006F,
                };
                word & mask == s.statusword_bits()
            })
            .collect();
        prop_assert!(matches.len() <= 1, "{word:#06X}: {matches:?}");
        prop_assert_eq!(S::from_statusword(word), matches.first().copied());
    }

    /// Whatever the controlwords, the drive's machine reaches operation
    /// enabled only by enable operation (0x0F pattern) from ready to switch
    /// on / switched on, and leaves fault only by a bit-7 edge.
    #[test]
    fn cia402_drive_machine_enables_only_by_the_rules(words in proptest::collection::vec(any::<u16>(), 1..80), faults in any::<u64>()) {
        use state_machine::{decode_controlword, Command, DriveMachine, DriveState as S};
        let mut m = DriveMachine::new();
        m.tick(true);
        let mut last = 0u16;
        for (i, w) in words.into_iter().enumerate() {
            if faults >> (i % 64) & 1 == 1 && i % 7 == 0 {
                m.fault();
                m.tick(true);
            }
            let before = m.state;
            m.on_controlword(w);
            let after = m.state;
            if after == S::OperationEnabled && before != S::OperationEnabled {
                prop_assert!(matches!(before, S::ReadyToSwitchOn | S::SwitchedOn), "{before:?} 0x{w:04X}");
                prop_assert_eq!(decode_controlword(w), Some(Command::EnableOperation));
            }
            if before == S::Fault && after != S::Fault {
                prop_assert!(w & 0x80 != 0 && last & 0x80 == 0, "0x{last:04X} -> 0x{w:04X}");
            }
            last = w;
        }
    }

    /// The odometry covariance stays a covariance whatever the wheel
    /// travels and the noise: finite, symmetric, positive semi-definite
    /// (principal minors ≥ 0 up to rounding), the heading's variance never
    /// shrinking; the twist covariance likewise.
    #[test]
    fn odometry_covariance_stays_symmetric_psd_and_finite(
        steps in proptest::collection::vec((-0.05..0.05f64, -0.05..0.05f64), 1..300),
        theta in -10.0..10.0f64,
        k in (1e-9..1.0f64, 1e-9..1.0f64),
        sigma in (1e-6..100.0f64, 1e-6..100.0f64),
        track in 0.05..2.0f64,
    ) {
        use can_bridge::odometry::{PoseCovariance, TwistCovariance, WheelNoise};
        let noise = WheelNoise {
            left_travel_variance_m2_per_m: k.0,
            right_travel_variance_m2_per_m: k.1,
            left_speed_sigma_radps: sigma.0,
            right_speed_sigma_radps: sigma.1,
        };
        let mut p = PoseCovariance::default();
        let mut th = theta;
        for (sl, sr) in steps {
            let before = p.0[2][2];
            p.step(th, sl, sr, track, &noise);
            th += (sr - sl) / track;
            let m = p.0;
            prop_assert!(m.iter().flatten().all(|v| v.is_finite()));
            for (a, b) in [(0, 1), (0, 2), (1, 2)] {
                prop_assert_eq!(m[a][b], m[b][a]);
            }
            let scale = m[0][0].max(m[1][1]).max(m[2][2]).max(1e-300);
            let tol = 1e-9 * scale * scale;
            prop_assert!(m[0][0] >= 0.0 && m[1][1] >= 0.0 && m[2][2] >= before);
            prop_assert!(m[0][0] * m[1][1] - m[0][1] * m[0][1] >= -tol);
            prop_assert!(m[0][0] * m[2][2] - m[0][2] * m[0][2] >= -tol);
            prop_assert!(m[1][1] * m[2][2] - m[1][2] * m[1][2] >= -tol);
        }
        let t = TwistCovariance::of(&noise, 0.05, track).0;
        prop_assert!(t[0][0] > 0.0 && t[1][1] > 0.0 && t[0][1] == t[1][0]);
        prop_assert!(t[0][0] * t[1][1] - t[0][1] * t[0][1] >= -1e-12 * t[0][0] * t[1][1]);
    }

    /// A run-time SDO transfer fed arbitrary server frames never panics,
    /// never holds more than its bound, and always either waits, or ends
    /// (data, an abort, a timeout) after which it sends nothing more but the
    /// one abort frame it may owe.
    #[test]
    fn sdo_transfer_survives_any_server(
        frames in proptest::collection::vec(any::<[u8; 8]>(), 0..40),
        write_len in 0usize..40,
        read in any::<bool>(),
    ) {
        use can_bridge::protocol::cia402::sdo::ObjectAddr;
        use can_bridge::protocol::cia402::sdo_transfer::{SdoTransfer, TransferEnd, TransferKind, MAX_TRANSFER_BYTES};
        use std::time::Duration;
        let kind = if read { TransferKind::Read } else { TransferKind::Write(vec![0xA5; write_len.max(1)]) };
        let mut x = SdoTransfer::new(1, ObjectAddr::new(0x1008, 0), kind, Duration::from_millis(200));
        let mut now = can_bridge::Timestamp::ZERO;
        for d in frames {
            if let Some(f) = x.poll(now) {
                prop_assert!(f.is_valid() && f.id == 0x601);
            }
            let f = CanFrame { id: 0x581, extended: false, data: d, len: 8 };
            if let Some(a) = x.on_response(&f) {
                prop_assert_eq!(a.data[0], 0x80);
            }
            now = now + Duration::from_millis(5);
            if !x.busy() {
                let end = x.end().cloned();
                if let Some(TransferEnd::Done(data)) = &end {
                    prop_assert!(data.len() <= MAX_TRANSFER_BYTES);
                }
                prop_assert!(end.is_some());
                prop_assert_eq!(x.poll(now), None);
            }
        }
    }
}
