//! Shared by the host integration tests: the bridge and the virtual drive
//! on one in-memory wire, in simulated time (1 ms steps).

#![allow(dead_code)]

use can_bridge::bridge::Bridge;
use can_bridge::config::{default_config, BridgeConfig};
use can_bridge::fake_bus::FakeBus;
use can_bridge::protocol::generic::{self, GenericIds};
use can_bridge::protocol::{cia402, odrive};
use can_bridge::virtual_drive::{VirtualDrive, VirtualDriveConfig};
use can_bridge::{BusEvent, CanBus, CanFrame, ProtocolKind, Timestamp, Twist};
use std::time::Duration;

pub const STEP: Duration = Duration::from_millis(1);

pub fn bridge_config(protocol: ProtocolKind) -> BridgeConfig {
    let mut c = default_config();
    c.protocol = protocol;
    c.odrive.left_node_id = 3;
    c.odrive.right_node_id = 5;
    c.kinematics.gear_ratio = 10.0;
    c.limits.max_wheel_speed_radps = 20.0;
    c.limits.v_max_mps = 0.5;
    c.limits.omega_max_radps = 5.0;
    c
}

pub fn drive_config(c: &BridgeConfig) -> VirtualDriveConfig {
    let (left_node_id, right_node_id) = match c.protocol {
        ProtocolKind::Cia402 => (c.cia402.left_node_id, c.cia402.right_node_id),
        _ => (c.odrive.left_node_id, c.odrive.right_node_id),
    };
    VirtualDriveConfig {
        protocol: c.protocol,
        generic_base_id: c.generic.base_id,
        left_node_id,
        right_node_id,
        cia402_scaling: c.cia402.scaling(),
        cia402_bridge_node_id: c.cia402.bridge_node_id as u8,
        odrive_firmware: c.odrive.firmware,
        left_axis: c.cia402.left_axis as u8,
        right_axis: c.cia402.right_axis as u8,
        cia402_axis_offset: c.cia402.axis_offset as u16,
        ..Default::default()
    }
}

/// Every protocol.
pub const ALL: [ProtocolKind; 3] = [ProtocolKind::Generic, ProtocolKind::Odrive, ProtocolKind::Cia402];

pub struct Sim {
    pub bridge: Bridge<FakeBus>,
    pub drive: VirtualDrive,
    pub drive_bus: FakeBus,
    pub tap: FakeBus,
    pub t: Timestamp,
    pub drive_alive: bool,
    pub bridge_alive: bool,
    out: Vec<CanFrame>,
}

impl Sim {
    pub fn new(c: BridgeConfig, d: VirtualDriveConfig) -> Self {
        let bridge_bus = FakeBus::new();
        let mut drive_bus = bridge_bus.connect();
        let tap = bridge_bus.connect();
        let t = Timestamp::from_secs_f64(10.0);
        let drive = VirtualDrive::new(d, t);
        drive_bus.set_rx_filters(&drive.rx_filters()).unwrap();
        Self {
            bridge: Bridge::new(c, bridge_bus, t).unwrap(),
            drive,
            drive_bus,
            tap,
            t,
            drive_alive: true,
            bridge_alive: true,
            out: Vec::new(),
        }
    }

    /// Seconds since the start.
    pub fn s(&self) -> f64 {
        self.t.as_secs_f64() - 10.0
    }

    pub fn step(&mut self) {
        self.t = self.t + STEP;
        if self.drive_alive {
            self.drive.step(self.t, &mut self.out);
            for f in self.out.drain(..) {
                let _ = self.drive_bus.send(&f);
            }
            while let Ok(Some(BusEvent::Frame(f))) = self.drive_bus.recv(Duration::ZERO) {
                self.drive.handle_frame(&f, self.t);
            }
        } else {
            while let Ok(Some(_)) = self.drive_bus.recv(Duration::ZERO) {}
        }
        if self.bridge_alive {
            self.bridge.poll_bus(self.t);
            self.bridge.tick(self.t);
        }
    }

    pub fn run_s(&mut self, s: f64) {
        let n = (s * 1000.0).round() as usize;
        for _ in 0..n {
            self.step();
        }
    }

    /// A teleop stream: `twist` every 50 ms for `s` seconds.
    pub fn stream(&mut self, twist: Twist, s: f64) {
        let n = (s * 1000.0).round() as usize;
        for i in 0..n {
            if i % 50 == 0 && self.bridge_alive {
                self.bridge.command(twist, self.t).unwrap();
            }
            self.step();
        }
    }

    pub fn has_reason(&self, name: &str) -> bool {
        self.bridge.reasons().iter().any(|r| r.name() == name)
    }
}

/// Decodes every frame the bridge sent and checks it is well formed and
/// finite; returns the motor speeds per setpoint frame (rad/s), by wheel index.
pub fn assert_wire_is_clean(frames: &[CanFrame], protocol: ProtocolKind) -> Vec<(usize, f64)> {
    let ids = GenericIds { base_id: 0x100 };
    let mut speeds = Vec::new();
    for f in frames {
        assert!(f.is_valid(), "{f:?}");
        match protocol {
            ProtocolKind::Generic => {
                if let Some((w, sp)) = generic::decode_setpoint(ids, f).unwrap_or_else(|e| panic!("{f:?}: {e}")) {
                    assert!(sp.vel_radps.is_finite());
                    speeds.push((w.index(), sp.vel_radps));
                }
            }
            ProtocolKind::Odrive => {
                let (node, cmd) = odrive::split_id(f.id);
                if cmd == odrive::cmd::SET_INPUT_VEL {
                    match odrive::decode_command(f).unwrap() {
                        Some(odrive::Command::SetInputVel {
                            vel_turns_per_s,
                            torque_ff_nm,
                        }) => {
                            assert!(vel_turns_per_s.is_finite() && torque_ff_nm.is_finite(), "{f:?}");
                            let w = if node == 3 { 0 } else { 1 };
                            speeds.push((w, f64::from(vel_turns_per_s) * std::f64::consts::TAU));
                        }
                        other => panic!("{other:?}"),
                    }
                }
            }
            ProtocolKind::Cia402 => {
                // The bridge's frames: NMT, SYNC, SDO requests, RPDO1 (RPDO2 for
                // an axis 2), its heartbeat; the drives' (heartbeats, TPDOs,
                // SDO responses, EMCY) are skipped. Node 1 axis 1 is the left
                // wheel; node 2, or node 1's axis 2, the right.
                let base = f.id & !0x7F;
                let drive_node = matches!(f.id & 0x7F, 1 | 2);
                match base {
                    0x700 | 0x180 | 0x280 | 0x380 | 0x480 | 0x580 | 0x080 if drive_node => {}
                    0x000 => assert!(f.id == 0 && f.len == 2, "{f:?}"),
                    0x080 => assert!(f.id == 0x080 && f.len == 0, "SYNC {f:?}"),
                    0x600 => assert!(f.len == 8 && cia402::sdo::decode_request(f).is_ok(), "{f:?}"),
                    0x700 => assert!(f.id == 0x77F && f.len == 1 && f.data[0] == 5, "{f:?}"),
                    0x200 | 0x300 => {
                        let r = cia402::pdo::decode_rpdo1(f).unwrap();
                        let w = if f.id == 0x201 { 0 } else { 1 };
                        let scaling = can_bridge::config::default_config().cia402.scaling();
                        speeds.push((w, scaling.velocity_from_drive(r.target_velocity)));
                    }
                    _ => panic!("unexpected frame {f:?}"),
                }
            }
        }
    }
    speeds
}
