//! The bridge state machine (`can_bridge::Bridge` on a `FakeBus`) driven by
//! fuzz bytes: received frames (arbitrary and well-formed ones), kernel
//! error frames, commands, clock ticks, e-stop and reset, failing sends,
//! in any order. Shared by the three protocol targets (CiA 402: the fuzz
//! input may also answer the bridge's last SDO request correctly, so the
//! start-up can finish and the bridge reach operation enabled).
//!
//! Asserts: no panic; every frame the bridge puts on the bus is a valid
//! frame that the drive side decodes, with a finite speed within the
//! configured wheel-speed limit (times the gear ratio), zero while the
//! e-stop is latched; the reported wheel setpoint is finite and in limits;
//! the odometry is finite.

use crate::input::f64_of;
use arbitrary::{Result, Unstructured};
use can_bridge::bridge::ShutdownProgress;
use can_bridge::bus::{BusEvent, CanErrorFrame, CanFrame, SendError};
use can_bridge::config::{default_config, Validate};
use can_bridge::diagnostics::StopReason;
use can_bridge::fake_bus::FakeBus;
use can_bridge::protocol::cia402::{nmt, pdo, sdo, state_machine::cw};
use can_bridge::protocol::{generic, odrive, ProtocolKind};
use can_bridge::{Bridge, BridgeConfig, Timestamp, Twist};
use std::time::Duration;

/// Most operations per input.
const MAX_OPS: usize = 256;

/// An arbitrary classic frame: any 11- or 29-bit id, 0..=8 bytes.
pub fn any_frame(u: &mut Unstructured<'_>) -> Result<CanFrame> {
    let extended = u.arbitrary::<u8>()? % 8 == 0;
    let id = if extended {
        u.arbitrary::<u32>()? & 0x1FFF_FFFF
    } else {
        u32::from(u.arbitrary::<u16>()?) & 0x7FF
    };
    let len = u.arbitrary::<u8>()? % 9;
    let mut data = [0u8; 8];
    u.fill_buffer(&mut data[..usize::from(len)])?;
    Ok(CanFrame {
        id,
        extended,
        data,
        len,
    })
}

/// A frame from one of the drive's ids (arbitrary payload), so most
/// arbitrary frames reach the decoder rather than the "not ours" branch.
fn drive_id_frame(u: &mut Unstructured<'_>, cfg: &BridgeConfig) -> Result<CanFrame> {
    let mut f = any_frame(u)?;
    f.extended = false;
    f.id = match cfg.protocol {
        ProtocolKind::Generic => cfg.generic.base_id + [0x10, 0x11, 0x12][usize::from(u.arbitrary::<u8>()? % 3)],
        ProtocolKind::Odrive => {
            let node = if u.arbitrary::<bool>()? {
                cfg.odrive.left_node_id
            } else {
                cfg.odrive.right_node_id
            };
            odrive::arb_id(node, u32::from(u.arbitrary::<u8>()? % 32))
        }
        ProtocolKind::Cia402 => {
            let node = if u.arbitrary::<bool>()? {
                cfg.cia402.left_node_id
            } else {
                cfg.cia402.right_node_id
            };
            [0x080, 0x180, 0x280, 0x580, 0x700][usize::from(u.arbitrary::<u8>()? % 5)] + node
        }
    };
    Ok(f)
}

/// A CiA 402 drive frame that makes sense: a heartbeat, a TPDO1 in some
/// state, TPDO2, or the right answer to the bridge's last SDO request.
fn well_formed_cia402(
    u: &mut Unstructured<'_>,
    cfg: &BridgeConfig,
    last_sdo: &[Option<CanFrame>; 2],
) -> Result<CanFrame> {
    let k = usize::from(u.arbitrary::<bool>()?);
    let node = [cfg.cia402.left_node_id, cfg.cia402.right_node_id][k] as u8;
    Ok(match u.arbitrary::<u8>()? % 8 {
        0 => {
            let state = [
                nmt::NmtState::Operational,
                nmt::NmtState::Operational,
                nmt::NmtState::PreOperational,
                nmt::NmtState::BootUp,
            ][usize::from(u.arbitrary::<u8>()? % 4)];
            nmt::heartbeat(node, state)
        }
        1 | 2 => {
            let states = [
                0x0027,
                0x0027,
                0x0040,
                0x0021,
                0x0023,
                0x0008,
                0x0007,
                u.arbitrary::<u16>()?,
            ];
            pdo::encode_tpdo1(
                node,
                &pdo::Tpdo1 {
                    statusword: states[usize::from(u.arbitrary::<u8>()? % 8)],
                    error_code: if u.arbitrary::<u8>()? % 4 == 0 {
                        u.arbitrary()?
                    } else {
                        0
                    },
                    mode_display: if u.arbitrary::<u8>()? % 8 == 0 {
                        u.arbitrary()?
                    } else {
                        3
                    },
                },
            )
        }
        3 => pdo::encode_tpdo2(
            node,
            &pdo::Tpdo2 {
                position: u.arbitrary()?,
                velocity: u.arbitrary()?,
            },
        ),
        _ => match last_sdo[k].map(|f| sdo::decode_request(&f)) {
            Some(Ok(sdo::SdoRequest::Upload { addr })) => sdo::encode_response(
                node,
                &sdo::SdoResponse::Uploaded {
                    addr,
                    value: sdo::SdoValue::u32(if u.arbitrary::<u8>()? % 8 == 0 {
                        u.arbitrary()?
                    } else {
                        0x0002_0192
                    }),
                },
            ),
            Some(Ok(sdo::SdoRequest::Download { addr, .. })) if u.arbitrary::<u8>()? % 8 == 0 => sdo::encode_response(
                node,
                &sdo::SdoResponse::Abort {
                    addr,
                    code: u.arbitrary()?,
                },
            ),
            Some(Ok(sdo::SdoRequest::Download { addr, .. })) => {
                sdo::encode_response(node, &sdo::SdoResponse::DownloadDone { addr })
            }
            _ => nmt::heartbeat(node, nmt::NmtState::Operational),
        },
    })
}

/// A well-formed drive frame (status or feedback with valid CRC), so the
/// bridge gets to run and send non-zero speeds.
fn well_formed(
    u: &mut Unstructured<'_>,
    cfg: &BridgeConfig,
    counter: &mut u8,
    last_sdo: &[Option<CanFrame>; 2],
) -> Result<CanFrame> {
    *counter = counter.wrapping_add(1);
    if cfg.protocol == ProtocolKind::Cia402 {
        return well_formed_cia402(u, cfg, last_sdo);
    }
    let healthy = u.arbitrary::<u8>()? % 4 != 0;
    let right = u.arbitrary::<bool>()?;
    Ok(match cfg.protocol {
        ProtocolKind::Generic => {
            let ids = generic::GenericIds {
                base_id: cfg.generic.base_id,
            };
            let wheel = if right {
                can_bridge::Wheel::Right
            } else {
                can_bridge::Wheel::Left
            };
            if u.arbitrary::<bool>()? {
                let s = generic::Status {
                    state: if healthy {
                        generic::STATE_ENABLED
                    } else {
                        u.arbitrary::<u8>()? % 4
                    },
                    counter: *counter,
                    error_code: if healthy { 0 } else { u.arbitrary()? },
                    rejected_setpoints: u.arbitrary()?,
                };
                generic::encode_status(ids, &s)
            } else {
                let fb = generic::Feedback {
                    vel_radps: f64_of(u)?,
                    pos_rad: f64_of(u)?,
                    counter: *counter,
                };
                generic::encode_feedback(ids, wheel, &fb)
            }
        }
        ProtocolKind::Odrive => {
            let node = if right {
                cfg.odrive.right_node_id
            } else {
                cfg.odrive.left_node_id
            };
            if u.arbitrary::<bool>()? {
                let (err, state) = if healthy {
                    (0, 8)
                } else {
                    (u.arbitrary()?, u.arbitrary()?)
                };
                odrive::heartbeat(node, err, state)
            } else {
                odrive::encoder_estimates(node, f64_of(u)?, f64_of(u)?)
            }
        }
        ProtocolKind::Cia402 => unreachable!("handled above"),
    })
}

/// One of a few validated configurations for `kind`.
fn config(u: &mut Unstructured<'_>, kind: ProtocolKind) -> Result<BridgeConfig> {
    let mut cfg = default_config();
    cfg.protocol = kind;
    let flags = u.arbitrary::<u8>()?;
    if flags & 1 != 0 {
        cfg.kinematics.gear_ratio = 20.0;
        cfg.kinematics.left_direction = -1;
        cfg.kinematics.right_direction = 1;
    }
    if flags & 2 != 0 {
        cfg.limits.max_wheel_speed_radps = 2000.0;
        cfg.limits.v_max_mps = 20.0;
        cfg.limits.omega_max_radps = 50.0;
        cfg.limits.wheel_accel_radps2 = 100_000.0;
    }
    if flags & 4 != 0 {
        cfg.generic.base_id = generic::MAX_BASE_ID;
        cfg.odrive.left_node_id = 63;
        cfg.odrive.right_node_id = 0;
        cfg.odrive.torque_ff_nm = -100.0;
    }
    if flags & 8 != 0 {
        cfg.timing.tx_rate_hz = 1000.0;
        cfg.timing.cmd_timeout_s = 10.0;
    }
    if flags & 16 != 0 {
        cfg.cia402.left_node_id = 127;
        cfg.cia402.right_node_id = 1;
        cfg.cia402.bridge_node_id = 64;
        cfg.cia402.sync_producer = false;
        cfg.cia402.pdo_mapping = can_bridge::protocol::cia402::PdoMapping::Preconfigured;
    }
    if flags & 32 != 0 {
        cfg.cia402.velocity_unit = can_bridge::protocol::cia402::units::VelocityUnit::CountsPerS;
        cfg.cia402.velocity_resolution = 0.1;
        cfg.cia402.counts_per_motor_rev = 1;
        cfg.cia402.bridge_heartbeat_ms = 0;
        cfg.cia402.drive_consumer_heartbeat_ms = 0;
    }
    if cfg.validate().is_err() {
        cfg = default_config();
        cfg.protocol = kind;
    }
    Ok(cfg)
}

/// Runs one input against a bridge speaking `kind`.
pub fn run_bridge(data: &[u8], kind: ProtocolKind) {
    let mut u = Unstructured::new(data);
    let _ = drive_bridge(&mut u, kind);
}

fn drive_bridge(u: &mut Unstructured<'_>, kind: ProtocolKind) -> Result<()> {
    let cfg = config(u, kind)?;
    let bus = FakeBus::new();
    let mut now = Timestamp::from_secs_f64(1.0);
    let mut bridge = Bridge::new(cfg.clone(), bus.clone(), now).expect("validated config");
    let mut counter = 0u8;
    let mut last_sdo = [None; 2];
    let ops = 1 + usize::from(u.arbitrary::<u8>()?) % MAX_OPS;
    for _ in 0..ops {
        if u.is_empty() {
            break;
        }
        match u.arbitrary::<u8>()? % 16 {
            0 => bridge.handle_bus_event(BusEvent::Frame(any_frame(u)?), now),
            1 | 2 => bridge.handle_bus_event(BusEvent::Frame(drive_id_frame(u, &cfg)?), now),
            3..=5 => {
                let f = well_formed(u, &cfg, &mut counter, &last_sdo)?;
                bus.inject_frame(f);
                bridge.poll_bus(now);
            }
            6 => {
                let e = CanErrorFrame {
                    class: u.arbitrary::<u32>()? & 0x3FF,
                    data: u.arbitrary()?,
                };
                bridge.handle_bus_event(BusEvent::Error(e), now);
            }
            7 => {
                let _ = bridge.command(Twist::new(f64_of(u)?, f64_of(u)?), now);
            }
            8 => {
                let (v, w) = (
                    f64::from(u.arbitrary::<i8>()?) / 100.0,
                    f64::from(u.arbitrary::<i8>()?) / 20.0,
                );
                let _ = bridge.command(Twist::new(v, w), now);
            }
            9 => bridge.estop(now),
            10 => bridge.reset(now),
            11 => match u.arbitrary::<u8>()? % 3 {
                0 => bus.fail_next_sends(usize::from(u.arbitrary::<u8>()? % 8), SendError::QueueFull),
                1 => bus.set_send_error(Some(SendError::QueueFull)),
                _ => bus.set_send_error(None),
            },
            12 => {
                now = now + Duration::from_millis(u64::from(u.arbitrary::<u16>()?));
                bridge.tick(now);
            }
            _ => {
                now = now + Duration::from_micros(u64::from(u.arbitrary::<u16>()? % 50_000));
                bridge.tick(now);
            }
        }
        for f in check_sent(&bus, &cfg, &bridge) {
            if let Some(k) = [cfg.cia402.left_node_id, cfg.cia402.right_node_id]
                .iter()
                .position(|n| f.id == sdo::COB_RX_BASE + n)
            {
                last_sdo[k] = Some(f);
            }
        }
    }
    bus.set_send_error(None);
    // The shutdown as the binaries drive it: again at each retry time (sends
    // scripted to fail may still be queued; each frame is tried at most 3 times).
    let mut t = now;
    while let ShutdownProgress::Pending { retry_at } = bridge.shutdown(t) {
        assert!(retry_at > t, "a retry time in the future");
        t = retry_at;
    }
    for f in bus.take_sent() {
        let v = sent_speed(&f, &cfg);
        assert!(
            matches!(v, None | Some(0.0)),
            "shutdown frame {f:?} asks for {v:?} rad/s"
        );
    }
    Ok(())
}

/// Checks every frame sent since the last call; returns them.
fn check_sent(bus: &FakeBus, cfg: &BridgeConfig, bridge: &Bridge<FakeBus>) -> Vec<CanFrame> {
    let max_wheel = cfg.limits.max_wheel_speed_radps;
    let max_motor = max_wheel * cfg.kinematics.gear_ratio;
    let estop = bridge.reasons().contains(&StopReason::Estop);
    let sent = bus.take_sent();
    for &f in &sent {
        assert!(f.is_valid(), "invalid frame sent: {f:?}");
        if let Some(v) = sent_speed(&f, cfg) {
            assert!(v.is_finite(), "non-finite speed in {f:?}");
            // 1e-5 rad/s: the generic Vel field's resolution; f32 rounding for ODrive;
            // half a drive velocity unit for CiA 402.
            let half_lsb = match cfg.protocol {
                ProtocolKind::Cia402 => 0.5 / cfg.cia402.scaling().units_per_radps(),
                _ => 0.0,
            };
            let tol = 1e-5 + max_motor * 1e-6 + half_lsb;
            assert!(
                v.abs() <= max_motor + tol,
                "motor speed {v} rad/s beyond {max_motor} in {f:?}"
            );
            if estop {
                assert_eq!(v, 0.0, "speed {v} while the e-stop is latched: {f:?}");
            }
        }
    }
    // Odometry goes to ROS: never a NaN or an infinity there either.
    let o = bridge.odometry();
    let odom = [
        o.pose.x_m,
        o.pose.y_m,
        o.pose.theta_rad,
        o.twist.linear_mps,
        o.twist.angular_radps,
    ];
    assert!(
        odom.iter().all(|x| x.is_finite()) && o.wheels.is_finite(),
        "odometry {o:?}"
    );
    let w = bridge.last_setpoint();
    assert!(w.is_finite(), "setpoint {w:?}");
    assert!(
        w.max_abs() <= max_wheel * (1.0 + 1e-12),
        "setpoint {w:?} beyond {max_wheel}"
    );
    sent
}

/// The motor speed (rad/s) a sent frame asks for, if it carries one; panics
/// if the drive side cannot decode a frame the bridge sent.
fn sent_speed(f: &CanFrame, cfg: &BridgeConfig) -> Option<f64> {
    match cfg.protocol {
        ProtocolKind::Generic => {
            let ids = generic::GenericIds {
                base_id: cfg.generic.base_id,
            };
            let (_, sp) = generic::decode_setpoint(ids, f)
                .unwrap_or_else(|e| panic!("the drive rejects a sent frame {f:?}: {e}"))
                .unwrap_or_else(|| panic!("sent frame {f:?} is not a setpoint"));
            Some(sp.vel_radps)
        }
        ProtocolKind::Odrive => {
            match odrive::decode_command(f).unwrap_or_else(|e| panic!("the drive rejects a sent frame {f:?}: {e}")) {
                Some(odrive::Command::SetInputVel {
                    vel_turns_per_s,
                    torque_ff_nm,
                }) => {
                    assert!(
                        torque_ff_nm.is_finite() && torque_ff_nm.abs() <= 100.0,
                        "torque {torque_ff_nm} in {f:?}"
                    );
                    Some(f64::from(vel_turns_per_s) * std::f64::consts::TAU)
                }
                Some(_) => None,
                None => panic!("sent frame {f:?} is no ODrive command"),
            }
        }
        ProtocolKind::Cia402 => {
            let c = &cfg.cia402;
            let ours = |n: u32| n == c.left_node_id || n == c.right_node_id;
            match (f.id & !0x7F, f.id & 0x7F) {
                (0x000, 0) => {
                    assert!(nmt::decode_nmt(f).is_some_and(|(_, n)| ours(u32::from(n))), "NMT {f:?}");
                    None
                }
                (0x080, 0) => {
                    assert!(c.sync_producer && f.len == 0, "SYNC {f:?}");
                    None
                }
                (0x600, n) if ours(n) => {
                    sdo::decode_request(f).unwrap_or_else(|e| panic!("the drive rejects SDO {f:?}: {e}"));
                    None
                }
                (0x700, n) if n == c.bridge_node_id => {
                    assert_eq!((f.len, f.data[0]), (1, 0x05), "bridge heartbeat {f:?}");
                    None
                }
                (0x200, n) if ours(n) => {
                    let r = pdo::decode_rpdo1(f).unwrap_or_else(|e| panic!("RPDO1 {f:?}: {e}"));
                    // Motion only with enable operation.
                    assert!(
                        r.target_velocity == 0 || r.controlword == cw::ENABLE_OPERATION,
                        "target {} with controlword 0x{:04X}",
                        r.target_velocity,
                        r.controlword
                    );
                    Some(c.scaling().velocity_from_drive(r.target_velocity))
                }
                _ => panic!("sent frame {f:?} is no CANopen frame of the bridge"),
            }
        }
    }
}
