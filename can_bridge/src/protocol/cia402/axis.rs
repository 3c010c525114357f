//! Where one axis of a CANopen node lives: its CiA 402 objects and its PDOs.
//!
//! A node may carry several axes (a dual-channel controller: Roboteq's
//! dual-channel DS402 drives, CiA 402 multi-axis devices). Axis 1 uses the
//! standard objects (0x6040, 0x6041, 0x60FF, …); axis 2 the same objects
//! `offset` higher (CiA 402's multi-axis rule and Roboteq: 0x800, so
//! 0x6840, 0x6841, 0x68FF, …). Communication objects (0x1000–0x1FFF) are
//! the node's, shared by its axes.
//!
//! Each axis has its own PDOs, from the predefined connection set:
//!
//! | axis | RPDO (controlword, target velocity) | TPDO (statusword, error code, mode display) | TPDO (position, velocity) |
//! |---|---|---|---|
//! | 1 | RPDO1: 0x1400/0x1600, COB-ID 0x200 + id | TPDO1: 0x1800/0x1A00, 0x180 + id | TPDO2: 0x1801/0x1A01, 0x280 + id |
//! | 2 | RPDO2: 0x1401/0x1601, COB-ID 0x300 + id | TPDO3: 0x1802/0x1A02, 0x380 + id | TPDO4: 0x1803/0x1A03, 0x480 + id |

use super::pdo::{self, PdoObjects};
use super::sdo::ObjectAddr;

/// Largest axis number (two PDO sets of the predefined connection set).
pub const MAX_AXES: u8 = 2;
/// CiA 402's offset between the axes' object ranges.
pub const STANDARD_AXIS_OFFSET: u16 = 0x800;

/// One axis of a node: its number (1 or 2) and the offset of axis 2's objects.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AxisLayout {
    /// 1 or 2.
    pub axis: u8,
    /// Index offset of axis 2's objects (0x800 in CiA 402 and Roboteq).
    pub offset: u16,
}

impl AxisLayout {
    /// Axis 1 (the standard objects).
    pub const FIRST: AxisLayout = AxisLayout {
        axis: 1,
        offset: STANDARD_AXIS_OFFSET,
    };

    /// Axis `axis` (1 or 2; anything else is taken as 1) with `offset`.
    pub fn new(axis: u8, offset: u16) -> Self {
        Self {
            axis: axis.clamp(1, MAX_AXES),
            offset,
        }
    }

    /// 0 for axis 1, 1 for axis 2.
    fn k(&self) -> u16 {
        u16::from(self.axis.clamp(1, MAX_AXES) - 1)
    }

    /// This axis's address of a device-profile object (0x6000–0x67FF); a
    /// communication object (below 0x6000) is the node's, unchanged.
    pub fn obj(&self, a: ObjectAddr) -> ObjectAddr {
        if a.index < 0x6000 {
            return a;
        }
        ObjectAddr::new(a.index.wrapping_add(self.k().wrapping_mul(self.offset)), a.sub)
    }

    /// The axis a device-profile object belongs to (`None` below 0x6000 or
    /// beyond the last axis's range).
    pub fn axis_of(index: u16, offset: u16) -> Option<u8> {
        if index < 0x6000 || offset == 0 {
            return None;
        }
        let k = (index - 0x6000) / offset;
        (k < u16::from(MAX_AXES)).then(|| k as u8 + 1)
    }

    /// COB-ID of the RPDO carrying controlword and target velocity.
    pub fn rpdo_cob(&self, node: u8) -> u32 {
        pdo::COB_RPDO1_BASE + 0x100 * u32::from(self.k()) + u32::from(node)
    }

    /// COB-ID of the TPDO carrying statusword, error code and mode display.
    pub fn tpdo_state_cob(&self, node: u8) -> u32 {
        pdo::COB_TPDO1_BASE + 0x200 * u32::from(self.k()) + u32::from(node)
    }

    /// COB-ID of the TPDO carrying position and velocity.
    pub fn tpdo_motion_cob(&self, node: u8) -> u32 {
        pdo::COB_TPDO2_BASE + 0x200 * u32::from(self.k()) + u32::from(node)
    }

    /// (communication, mapping) indices of the RPDO.
    pub fn rpdo_objects(&self) -> (u16, u16) {
        (0x1400 + self.k(), 0x1600 + self.k())
    }

    /// (communication, mapping) indices of the state TPDO.
    pub fn tpdo_state_objects(&self) -> (u16, u16) {
        (0x1800 + 2 * self.k(), 0x1A00 + 2 * self.k())
    }

    /// (communication, mapping) indices of the motion TPDO.
    pub fn tpdo_motion_objects(&self) -> (u16, u16) {
        (0x1801 + 2 * self.k(), 0x1A01 + 2 * self.k())
    }

    /// The RPDO's mapping, in this axis's objects.
    pub fn rpdo_map(&self) -> [(ObjectAddr, u8); 2] {
        pdo::RPDO1_MAP.map(|(a, b)| (self.obj(a), b))
    }

    /// The state TPDO's mapping.
    pub fn tpdo_state_map(&self) -> [(ObjectAddr, u8); 3] {
        pdo::TPDO1_MAP.map(|(a, b)| (self.obj(a), b))
    }

    /// The motion TPDO's mapping.
    pub fn tpdo_motion_map(&self) -> [(ObjectAddr, u8); 2] {
        pdo::TPDO2_MAP.map(|(a, b)| (self.obj(a), b))
    }

    /// The three PDOs' configuration objects for `node`: RPDO, state TPDO, motion TPDO.
    pub(super) fn pdos(&self, node: u8) -> [PdoObjects; 3] {
        let (rc, rm) = self.rpdo_objects();
        let (sc, sm) = self.tpdo_state_objects();
        let (mc, mm) = self.tpdo_motion_objects();
        [
            PdoObjects {
                comm: rc,
                map: rm,
                cob: self.rpdo_cob(node),
                entries: self.rpdo_map().to_vec(),
                event_timer: false,
            },
            PdoObjects {
                comm: sc,
                map: sm,
                cob: self.tpdo_state_cob(node),
                entries: self.tpdo_state_map().to_vec(),
                event_timer: true,
            },
            PdoObjects {
                comm: mc,
                map: mm,
                cob: self.tpdo_motion_cob(node),
                entries: self.tpdo_motion_map().to_vec(),
                event_timer: true,
            },
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::cia402::pdo::obj;

    /// Roboteq's channel 2 and CiA 402's second axis: +0x800.
    #[test]
    fn objects_and_pdos_of_axis_2_by_hand() {
        let a2 = AxisLayout::new(2, 0x800);
        assert_eq!(a2.obj(obj::CONTROLWORD), ObjectAddr::new(0x6840, 0));
        assert_eq!(a2.obj(obj::STATUSWORD), ObjectAddr::new(0x6841, 0));
        assert_eq!(a2.obj(obj::TARGET_VELOCITY), ObjectAddr::new(0x68FF, 0));
        assert_eq!(a2.obj(obj::VELOCITY_ACTUAL), ObjectAddr::new(0x686C, 0));
        assert_eq!(a2.obj(obj::ERROR_CODE), ObjectAddr::new(0x683F, 0));
        assert_eq!(
            a2.obj(obj::PRODUCER_HEARTBEAT),
            obj::PRODUCER_HEARTBEAT,
            "the node's own"
        );
        assert_eq!(
            (a2.rpdo_cob(1), a2.tpdo_state_cob(1), a2.tpdo_motion_cob(1)),
            (0x301, 0x381, 0x481)
        );
        assert_eq!(a2.rpdo_objects(), (0x1401, 0x1601));
        assert_eq!(a2.tpdo_state_objects(), (0x1802, 0x1A02));
        assert_eq!(a2.tpdo_motion_objects(), (0x1803, 0x1A03));
        let a1 = AxisLayout::FIRST;
        assert_eq!(
            (a1.rpdo_cob(5), a1.tpdo_state_cob(5), a1.tpdo_motion_cob(5)),
            (0x205, 0x185, 0x285)
        );
        assert_eq!(a1.obj(obj::CONTROLWORD), obj::CONTROLWORD);
        assert_eq!(pdo::mapping_entry(a2.rpdo_map()[1].0, a2.rpdo_map()[1].1), 0x68FF_0020);
        // Another offset (a drive that packs its axes 0x200 apart).
        assert_eq!(AxisLayout::new(2, 0x200).obj(obj::CONTROLWORD).index, 0x6240);
        assert_eq!(AxisLayout::axis_of(0x6840, 0x800), Some(2));
        assert_eq!(AxisLayout::axis_of(0x60FF, 0x800), Some(1));
        assert_eq!(AxisLayout::axis_of(0x7000, 0x800), None);
        assert_eq!(AxisLayout::axis_of(0x2000, 0x800), None);
    }
}
