//! The process data the bridge exchanges with each drive (CiA 301 PDOs with
//! CiA 402 objects), and the SDO writes that map them.
//!
//! | PDO | COB-ID | mapping | bytes |
//! |---|---|---|---|
//! | RPDO1 (bridge → drive) | 0x200 + id | 0x6040:00 controlword u16, 0x60FF:00 target velocity i32 | 6 |
//! | TPDO1 (drive → bridge) | 0x180 + id | 0x6041:00 statusword u16, 0x603F:00 error code u16, 0x6061:00 modes of operation display i8 | 5 |
//! | TPDO2 (drive → bridge) | 0x280 + id | 0x6064:00 position actual i32, 0x606C:00 velocity actual i32 | 8 |
//!
//! Transmission types: with the bridge's SYNC producer, RPDO1 type 1 (applied
//! at the next SYNC) and TPDO1/TPDO2 type 1 (sent after every SYNC); without
//! it, type 255 (event driven: RPDO applied on receipt, TPDOs on the event
//! timer 0x1800/0x1801 sub 5, and TPDO1 also on a change of state).

use super::axis::AxisLayout;
use super::sdo::{ObjectAddr, SdoValue};
use crate::bus::CanFrame;

/// RPDO1 COB-ID base (+ node id).
pub const COB_RPDO1_BASE: u32 = 0x200;
/// TPDO1 COB-ID base (+ node id).
pub const COB_TPDO1_BASE: u32 = 0x180;
/// TPDO2 COB-ID base (+ node id).
pub const COB_TPDO2_BASE: u32 = 0x280;
/// COB-ID bit 31: the PDO is not valid (disabled).
pub const COB_ID_INVALID: u32 = 0x8000_0000;

/// Object addresses (CiA 301 and CiA 402).
pub mod obj {
    use super::ObjectAddr;
    pub const DEVICE_TYPE: ObjectAddr = ObjectAddr::new(0x1000, 0);
    pub const CONSUMER_HEARTBEAT_1: ObjectAddr = ObjectAddr::new(0x1016, 1);
    pub const PRODUCER_HEARTBEAT: ObjectAddr = ObjectAddr::new(0x1017, 0);
    pub const RPDO1_COB_ID: ObjectAddr = ObjectAddr::new(0x1400, 1);
    pub const RPDO1_TYPE: ObjectAddr = ObjectAddr::new(0x1400, 2);
    pub const RPDO1_MAP_COUNT: ObjectAddr = ObjectAddr::new(0x1600, 0);
    pub const TPDO1_COB_ID: ObjectAddr = ObjectAddr::new(0x1800, 1);
    pub const TPDO1_TYPE: ObjectAddr = ObjectAddr::new(0x1800, 2);
    pub const TPDO1_EVENT_TIMER: ObjectAddr = ObjectAddr::new(0x1800, 5);
    pub const TPDO2_COB_ID: ObjectAddr = ObjectAddr::new(0x1801, 1);
    pub const TPDO2_TYPE: ObjectAddr = ObjectAddr::new(0x1801, 2);
    pub const TPDO2_EVENT_TIMER: ObjectAddr = ObjectAddr::new(0x1801, 5);
    pub const TPDO1_MAP_COUNT: ObjectAddr = ObjectAddr::new(0x1A00, 0);
    pub const TPDO2_MAP_COUNT: ObjectAddr = ObjectAddr::new(0x1A01, 0);
    pub const ERROR_CODE: ObjectAddr = ObjectAddr::new(0x603F, 0);
    pub const CONTROLWORD: ObjectAddr = ObjectAddr::new(0x6040, 0);
    pub const STATUSWORD: ObjectAddr = ObjectAddr::new(0x6041, 0);
    pub const MODES_OF_OPERATION: ObjectAddr = ObjectAddr::new(0x6060, 0);
    pub const MODES_OF_OPERATION_DISPLAY: ObjectAddr = ObjectAddr::new(0x6061, 0);
    pub const POSITION_ACTUAL: ObjectAddr = ObjectAddr::new(0x6064, 0);
    pub const VELOCITY_ACTUAL: ObjectAddr = ObjectAddr::new(0x606C, 0);
    pub const PROFILE_ACCELERATION: ObjectAddr = ObjectAddr::new(0x6083, 0);
    pub const PROFILE_DECELERATION: ObjectAddr = ObjectAddr::new(0x6084, 0);
    pub const QUICK_STOP_DECELERATION: ObjectAddr = ObjectAddr::new(0x6085, 0);
    pub const TARGET_VELOCITY: ObjectAddr = ObjectAddr::new(0x60FF, 0);
}

/// Modes of operation 0x6060 value for profile velocity.
pub const MODE_PROFILE_VELOCITY: i8 = 3;
/// The CiA 402 device profile number (low 16 bits of 0x1000).
pub const DEVICE_PROFILE_402: u32 = 402;
/// Transmission type: synchronous, every SYNC.
pub const TRANSMISSION_SYNC_EVERY: u8 = 1;
/// Transmission type: event driven (manufacturer / device profile specific).
pub const TRANSMISSION_EVENT: u8 = 255;

/// A mapping entry (CiA 301 §7.4.8.5): index << 16 | sub << 8 | length in bits.
pub fn mapping_entry(addr: ObjectAddr, bits: u8) -> u32 {
    (u32::from(addr.index) << 16) | (u32::from(addr.sub) << 8) | u32::from(bits)
}

/// RPDO1's mapping.
pub const RPDO1_MAP: [(ObjectAddr, u8); 2] = [(obj::CONTROLWORD, 16), (obj::TARGET_VELOCITY, 32)];
/// TPDO1's mapping.
pub const TPDO1_MAP: [(ObjectAddr, u8); 3] = [
    (obj::STATUSWORD, 16),
    (obj::ERROR_CODE, 16),
    (obj::MODES_OF_OPERATION_DISPLAY, 8),
];
/// TPDO2's mapping.
pub const TPDO2_MAP: [(ObjectAddr, u8); 2] = [(obj::POSITION_ACTUAL, 32), (obj::VELOCITY_ACTUAL, 32)];

/// RPDO1: what the bridge asks of one drive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rpdo1 {
    pub controlword: u16,
    /// Drive velocity units (see [`super::units`]).
    pub target_velocity: i32,
}

/// TPDO1: the drive's state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tpdo1 {
    pub statusword: u16,
    /// 0x603F: the last error (0 = none).
    pub error_code: u16,
    /// 0x6061.
    pub mode_display: i8,
}

/// TPDO2: the drive's motion.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tpdo2 {
    /// Encoder counts.
    pub position: i32,
    /// Drive velocity units.
    pub velocity: i32,
}

fn pdo_frame(id: u32, payload: &[u8]) -> CanFrame {
    let mut data = [0u8; 8];
    data[..payload.len()].copy_from_slice(payload);
    CanFrame {
        id,
        extended: false,
        data,
        len: payload.len() as u8,
    }
}

/// A PDO whose length is not its mapping's.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("PDO of {got} bytes, the mapping has {expected}")]
pub struct PdoLengthError {
    pub got: u8,
    pub expected: u8,
}

fn need(f: &CanFrame, n: u8) -> Result<(), PdoLengthError> {
    if f.len != n {
        return Err(PdoLengthError {
            got: f.len,
            expected: n,
        });
    }
    Ok(())
}

pub fn encode_rpdo1(node: u8, r: &Rpdo1) -> CanFrame {
    encode_rpdo(COB_RPDO1_BASE + u32::from(node), r)
}

/// Controlword and target velocity on `cob_id` (RPDO1, or RPDO2 for axis 2).
pub fn encode_rpdo(cob_id: u32, r: &Rpdo1) -> CanFrame {
    let c = r.controlword.to_le_bytes();
    let v = r.target_velocity.to_le_bytes();
    pdo_frame(cob_id, &[c[0], c[1], v[0], v[1], v[2], v[3]])
}

pub fn decode_rpdo1(f: &CanFrame) -> Result<Rpdo1, PdoLengthError> {
    need(f, 6)?;
    let d = f.data;
    Ok(Rpdo1 {
        controlword: u16::from_le_bytes([d[0], d[1]]),
        target_velocity: i32::from_le_bytes([d[2], d[3], d[4], d[5]]),
    })
}

pub fn encode_tpdo1(node: u8, t: &Tpdo1) -> CanFrame {
    let s = t.statusword.to_le_bytes();
    let e = t.error_code.to_le_bytes();
    pdo_frame(
        COB_TPDO1_BASE + u32::from(node),
        &[s[0], s[1], e[0], e[1], t.mode_display as u8],
    )
}

pub fn decode_tpdo1(f: &CanFrame) -> Result<Tpdo1, PdoLengthError> {
    need(f, 5)?;
    let d = f.data;
    Ok(Tpdo1 {
        statusword: u16::from_le_bytes([d[0], d[1]]),
        error_code: u16::from_le_bytes([d[2], d[3]]),
        mode_display: d[4] as i8,
    })
}

pub fn encode_tpdo2(node: u8, t: &Tpdo2) -> CanFrame {
    let mut p = [0u8; 8];
    p[..4].copy_from_slice(&t.position.to_le_bytes());
    p[4..].copy_from_slice(&t.velocity.to_le_bytes());
    pdo_frame(COB_TPDO2_BASE + u32::from(node), &p)
}

pub fn decode_tpdo2(f: &CanFrame) -> Result<Tpdo2, PdoLengthError> {
    need(f, 8)?;
    let d = f.data;
    Ok(Tpdo2 {
        position: i32::from_le_bytes([d[0], d[1], d[2], d[3]]),
        velocity: i32::from_le_bytes([d[4], d[5], d[6], d[7]]),
    })
}

/// How the PDOs are configured at start-up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PdoPlan {
    /// The bridge sends SYNC after each period's RPDOs.
    pub sync: bool,
    /// Without SYNC: the drive's TPDO event timer (ms).
    pub tpdo_event_ms: u16,
}

impl PdoPlan {
    /// Transmission type for all three PDOs.
    pub fn transmission_type(&self) -> u8 {
        if self.sync {
            TRANSMISSION_SYNC_EVERY
        } else {
            TRANSMISSION_EVENT
        }
    }
}

/// One PDO's configuration objects.
pub(super) struct PdoObjects {
    /// Communication parameter index (sub 1 COB-ID, 2 type, 5 event timer).
    pub comm: u16,
    /// Mapping parameter index (sub 0 count, 1.. entries).
    pub map: u16,
    /// Its COB-ID.
    pub cob: u32,
    pub entries: Vec<(ObjectAddr, u8)>,
    /// A TPDO: without SYNC it runs on its event timer (sub 5).
    pub event_timer: bool,
}

/// The SDO writes that map one PDO, in the order CiA 301 §7.4.8.5
/// prescribes: disable (COB-ID bit 31), mapping count 0, entries, count,
/// transmission type (and event timer), enable.
fn map_pdo(out: &mut Vec<(ObjectAddr, SdoValue)>, p: &PdoObjects, plan: &PdoPlan) {
    let cob_id_addr = ObjectAddr::new(p.comm, 1);
    let map_count = ObjectAddr::new(p.map, 0);
    out.push((cob_id_addr, SdoValue::u32(p.cob | COB_ID_INVALID)));
    out.push((map_count, SdoValue::u8(0)));
    for (i, (addr, bits)) in p.entries.iter().enumerate() {
        out.push((
            ObjectAddr::new(p.map, i as u8 + 1),
            SdoValue::u32(mapping_entry(*addr, *bits)),
        ));
    }
    out.push((map_count, SdoValue::u8(p.entries.len() as u8)));
    out.push((ObjectAddr::new(p.comm, 2), SdoValue::u8(plan.transmission_type())));
    if p.event_timer && !plan.sync {
        out.push((ObjectAddr::new(p.comm, 5), SdoValue::u16(plan.tpdo_event_ms)));
    }
    out.push((cob_id_addr, SdoValue::u32(p.cob)));
}

/// The SDO writes that configure RPDO1, TPDO1 and TPDO2 of `node` (axis 1).
pub fn mapping_writes(node: u8, plan: &PdoPlan) -> Vec<(ObjectAddr, SdoValue)> {
    axis_mapping_writes(node, &AxisLayout::FIRST, plan)
}

/// The SDO writes that configure one axis's three PDOs ([`AxisLayout`]).
pub fn axis_mapping_writes(node: u8, axis: &AxisLayout, plan: &PdoPlan) -> Vec<(ObjectAddr, SdoValue)> {
    let mut out = Vec::new();
    for p in axis.pdos(node) {
        map_pdo(&mut out, &p, plan);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mapping_entries_by_hand() {
        assert_eq!(mapping_entry(obj::CONTROLWORD, 16), 0x6040_0010);
        assert_eq!(mapping_entry(obj::TARGET_VELOCITY, 32), 0x60FF_0020);
        assert_eq!(mapping_entry(obj::STATUSWORD, 16), 0x6041_0010);
        assert_eq!(mapping_entry(obj::ERROR_CODE, 16), 0x603F_0010);
        assert_eq!(mapping_entry(obj::MODES_OF_OPERATION_DISPLAY, 8), 0x6061_0008);
        assert_eq!(mapping_entry(obj::POSITION_ACTUAL, 32), 0x6064_0020);
        assert_eq!(mapping_entry(obj::VELOCITY_ACTUAL, 32), 0x606C_0020);
    }

    #[test]
    fn pdo_golden_bytes() {
        // Enable operation, target −1000 (0xFFFFFC18) to node 3.
        let f = encode_rpdo1(
            3,
            &Rpdo1 {
                controlword: 0x000F,
                target_velocity: -1000,
            },
        );
        assert_eq!((f.id, f.len), (0x203, 6));
        assert_eq!(f.data[..6], [0x0F, 0x00, 0x18, 0xFC, 0xFF, 0xFF]);
        assert_eq!(
            decode_rpdo1(&f),
            Ok(Rpdo1 {
                controlword: 0x000F,
                target_velocity: -1000
            })
        );
        let t1 = Tpdo1 {
            statusword: 0x0637,
            error_code: 0x2310,
            mode_display: 3,
        };
        let f = encode_tpdo1(5, &t1);
        assert_eq!((f.id, f.len), (0x185, 5));
        assert_eq!(f.data[..5], [0x37, 0x06, 0x10, 0x23, 0x03]);
        assert_eq!(decode_tpdo1(&f), Ok(t1));
        let t2 = Tpdo2 {
            position: 0x0102_0304,
            velocity: -2,
        };
        let f = encode_tpdo2(5, &t2);
        assert_eq!((f.id, f.len), (0x285, 8));
        assert_eq!(f.data, [0x04, 0x03, 0x02, 0x01, 0xFE, 0xFF, 0xFF, 0xFF]);
        assert_eq!(decode_tpdo2(&f), Ok(t2));
        let short = CanFrame::standard(0x285, &[0; 7]).unwrap();
        assert_eq!(decode_tpdo2(&short), Err(PdoLengthError { got: 7, expected: 8 }));
        assert!(decode_tpdo1(&CanFrame::standard(0x185, &[0; 6]).unwrap()).is_err());
    }

    #[test]
    fn mapping_writes_follow_cia301_order() {
        let sync = mapping_writes(
            3,
            &PdoPlan {
                sync: true,
                tpdo_event_ms: 10,
            },
        );
        let show: Vec<(u16, u8, u32)> = sync.iter().map(|(a, v)| (a.index, a.sub, v.as_u32())).collect();
        assert_eq!(
            show[..7],
            [
                (0x1400, 1, 0x8000_0203),
                (0x1600, 0, 0),
                (0x1600, 1, 0x6040_0010),
                (0x1600, 2, 0x60FF_0020),
                (0x1600, 0, 2),
                (0x1400, 2, 1),
                (0x1400, 1, 0x0000_0203),
            ]
        );
        assert_eq!(show[7], (0x1800, 1, 0x8000_0183));
        assert_eq!(show[13], (0x1800, 2, 1));
        assert_eq!(show[14], (0x1800, 1, 0x183));
        assert_eq!(show.last(), Some(&(0x1801, 1, 0x283)));
        assert_eq!(sync.len(), 7 + 8 + 7);
        // Without SYNC: type 255 and the event timers.
        let event = mapping_writes(
            3,
            &PdoPlan {
                sync: false,
                tpdo_event_ms: 10,
            },
        );
        assert_eq!(event.len(), 7 + 9 + 8);
        assert!(event.contains(&(obj::TPDO1_EVENT_TIMER, SdoValue::u16(10))));
        assert!(event.contains(&(obj::RPDO1_TYPE, SdoValue::u8(255))));
        // Sizes as the objects' types: u32 COB-IDs and entries, u8 counts and types, u16 timer.
        for (a, v) in &event {
            let mapping = (0x1600..=0x17FF).contains(&a.index) || (0x1A00..=0x1BFF).contains(&a.index);
            let want = match a.sub {
                0 => 1,
                _ if mapping => 4,
                1 => 4,
                2 => 1,
                5 => 2,
                _ => 0,
            };
            assert_eq!(v.len, want, "{a}");
        }
    }
}
