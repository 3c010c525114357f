//! CANopen network management and the small broadcast services (CiA 301):
//! NMT node control (COB-ID 0x000), heartbeat / boot-up (0x700 + node id),
//! SYNC (0x080) and EMCY (0x080 + node id).

use crate::bus::CanFrame;

/// NMT node control COB-ID (from the master).
pub const COB_NMT: u32 = 0x000;
/// SYNC COB-ID (CiA 301 default of 0x1005).
pub const COB_SYNC: u32 = 0x080;
/// EMCY COB-ID base (+ node id).
pub const COB_EMCY_BASE: u32 = 0x080;
/// Heartbeat / boot-up COB-ID base (+ node id).
pub const COB_HEARTBEAT_BASE: u32 = 0x700;
/// Largest node id.
pub const MAX_NODE_ID: u32 = 127;

/// NMT command specifiers (byte 0 of the NMT frame).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum NmtCommand {
    /// Start remote node → operational (PDOs exchanged).
    Start = 0x01,
    /// Stop remote node → stopped.
    Stop = 0x02,
    /// Enter pre-operational (SDO only; PDOs stop).
    EnterPreOperational = 0x80,
    /// Reset node (application and communication parameters).
    ResetNode = 0x81,
    /// Reset communication parameters.
    ResetCommunication = 0x82,
}

impl NmtCommand {
    /// From byte 0 of an NMT frame.
    pub fn from_byte(b: u8) -> Option<Self> {
        Some(match b {
            0x01 => Self::Start,
            0x02 => Self::Stop,
            0x80 => Self::EnterPreOperational,
            0x81 => Self::ResetNode,
            0x82 => Self::ResetCommunication,
            _ => return None,
        })
    }
}

/// The NMT frame for `node` (0 addresses every node).
pub fn nmt_command(cmd: NmtCommand, node: u8) -> CanFrame {
    let mut data = [0u8; 8];
    data[0] = cmd as u8;
    data[1] = node;
    CanFrame {
        id: COB_NMT,
        extended: false,
        data,
        len: 2,
    }
}

/// Decodes an NMT frame: (command, addressed node; 0 = all).
pub fn decode_nmt(f: &CanFrame) -> Option<(NmtCommand, u8)> {
    if f.extended || f.id != COB_NMT || f.len != 2 {
        return None;
    }
    Some((NmtCommand::from_byte(f.data[0])?, f.data[1]))
}

/// NMT states as a heartbeat reports them (byte 0, bit 7 is the toggle of
/// node guarding and is ignored).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NmtState {
    /// 0x00: the boot-up message (the node just (re)started).
    BootUp,
    /// 0x04
    Stopped,
    /// 0x05
    Operational,
    /// 0x7F
    PreOperational,
}

impl NmtState {
    /// The heartbeat byte.
    pub fn byte(self) -> u8 {
        match self {
            Self::BootUp => 0x00,
            Self::Stopped => 0x04,
            Self::Operational => 0x05,
            Self::PreOperational => 0x7F,
        }
    }

    /// From a heartbeat byte (the toggle bit masked off).
    pub fn from_byte(b: u8) -> Option<Self> {
        Some(match b & 0x7F {
            0x00 => Self::BootUp,
            0x04 => Self::Stopped,
            0x05 => Self::Operational,
            0x7F => Self::PreOperational,
            _ => return None,
        })
    }
}

/// A heartbeat (or, with [`NmtState::BootUp`], the boot-up message) of `node`.
pub fn heartbeat(node: u8, state: NmtState) -> CanFrame {
    let mut data = [0u8; 8];
    data[0] = state.byte();
    CanFrame {
        id: COB_HEARTBEAT_BASE + u32::from(node),
        extended: false,
        data,
        len: 1,
    }
}

/// A heartbeat's payload: `Err(byte)` for a state CiA 301 does not define.
pub fn decode_heartbeat(f: &CanFrame) -> Option<Result<NmtState, u8>> {
    if f.len < 1 {
        return None;
    }
    Some(NmtState::from_byte(f.data[0]).ok_or(f.data[0]))
}

/// The SYNC frame (no counter: DLC 0, CiA 301 default).
pub fn sync() -> CanFrame {
    CanFrame {
        id: COB_SYNC,
        extended: false,
        data: [0; 8],
        len: 0,
    }
}

/// An emergency message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Emcy {
    /// Emergency error code (CiA 301 Table 21 / CiA 402): 0x0000 = error reset.
    pub error_code: u16,
    /// Error register (object 0x1001).
    pub error_register: u8,
    /// Manufacturer-specific bytes.
    pub manufacturer: [u8; 5],
}

/// EMCY frame of `node`.
pub fn emcy(node: u8, e: &Emcy) -> CanFrame {
    let c = e.error_code.to_le_bytes();
    let m = e.manufacturer;
    CanFrame {
        id: COB_EMCY_BASE + u32::from(node),
        extended: false,
        data: [c[0], c[1], e.error_register, m[0], m[1], m[2], m[3], m[4]],
        len: 8,
    }
}

/// Decodes an EMCY payload (8 bytes).
pub fn decode_emcy(f: &CanFrame) -> Option<Emcy> {
    if f.len != 8 {
        return None;
    }
    let d = f.data;
    Some(Emcy {
        error_code: u16::from_le_bytes([d[0], d[1]]),
        error_register: d[2],
        manufacturer: [d[3], d[4], d[5], d[6], d[7]],
    })
}

/// A short description of the error code's class (CiA 301 Table 21).
pub fn emcy_class(code: u16) -> &'static str {
    match code {
        0x0000 => "error reset or no error",
        0x8130 => "life guard or heartbeat error",
        0x8250 => "RPDO timeout",
        c if c >= 0xFF00 => "device specific",
        c => match c >> 12 {
            0x1 => "generic error",
            0x2 => "current",
            0x3 => "voltage",
            0x4 => "temperature",
            0x5 => "device hardware",
            0x6 => "device software",
            0x7 => "additional modules",
            0x8 => "monitoring (communication, control)",
            0x9 => "external error",
            0xF => "additional functions",
            _ => "unknown",
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    // CiA 301 §7.2.8.3.1: COB-ID 0, byte 0 the command, byte 1 the node.
    #[test]
    fn nmt_golden_bytes() {
        let f = nmt_command(NmtCommand::Start, 3);
        assert_eq!((f.id, f.len, f.data[..2].to_vec()), (0x000, 2, vec![0x01, 0x03]));
        assert_eq!(nmt_command(NmtCommand::Stop, 3).data[0], 0x02);
        assert_eq!(nmt_command(NmtCommand::EnterPreOperational, 5).data[..2], [0x80, 0x05]);
        assert_eq!(nmt_command(NmtCommand::ResetNode, 5).data[0], 0x81);
        assert_eq!(nmt_command(NmtCommand::ResetCommunication, 0).data[..2], [0x82, 0x00]);
        for c in [
            NmtCommand::Start,
            NmtCommand::Stop,
            NmtCommand::EnterPreOperational,
            NmtCommand::ResetNode,
            NmtCommand::ResetCommunication,
        ] {
            assert_eq!(decode_nmt(&nmt_command(c, 9)), Some((c, 9)));
        }
        assert_eq!(decode_nmt(&CanFrame::standard(0, &[0x03, 1]).unwrap()), None);
        assert_eq!(decode_nmt(&CanFrame::standard(0, &[0x01]).unwrap()), None);
    }

    #[test]
    fn heartbeat_states() {
        let f = heartbeat(3, NmtState::Operational);
        assert_eq!((f.id, f.len, f.data[0]), (0x703, 1, 0x05));
        assert_eq!(heartbeat(3, NmtState::PreOperational).data[0], 0x7F);
        assert_eq!(heartbeat(3, NmtState::Stopped).data[0], 0x04);
        assert_eq!(heartbeat(0x7F, NmtState::BootUp).id, 0x77F);
        assert_eq!(
            decode_heartbeat(&heartbeat(1, NmtState::BootUp)),
            Some(Ok(NmtState::BootUp))
        );
        // Toggle bit (node guarding) ignored; undefined states are errors.
        let f = CanFrame::standard(0x703, &[0x85]).unwrap();
        assert_eq!(decode_heartbeat(&f), Some(Ok(NmtState::Operational)));
        let f = CanFrame::standard(0x703, &[0x06]).unwrap();
        assert_eq!(decode_heartbeat(&f), Some(Err(0x06)));
        assert_eq!(decode_heartbeat(&CanFrame::standard(0x703, &[]).unwrap()), None);
    }

    #[test]
    fn sync_and_emcy() {
        let s = sync();
        assert_eq!((s.id, s.len), (0x080, 0));
        let e = Emcy {
            error_code: 0x2310,
            error_register: 0x03,
            manufacturer: [1, 2, 3, 4, 5],
        };
        let f = emcy(3, &e);
        assert_eq!((f.id, f.data), (0x083, [0x10, 0x23, 0x03, 1, 2, 3, 4, 5]));
        assert_eq!(decode_emcy(&f), Some(e));
        assert_eq!(decode_emcy(&CanFrame::standard(0x83, &[0, 0]).unwrap()), None);
        assert_eq!(emcy_class(0x2310), "current");
        assert_eq!(emcy_class(0x8130), "life guard or heartbeat error");
        assert_eq!(emcy_class(0x0000), "error reset or no error");
    }
}
