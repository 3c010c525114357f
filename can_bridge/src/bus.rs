//! CAN frames and the bus interface the core talks to.
//!
//! The core never imports `socketcan`: it sees these plain types and the
//! [`CanBus`] trait, implemented by [`crate::socketcan_bus::SocketCanBus`]
//! (the only file that touches the kernel) and by [`crate::fake_bus::FakeBus`]
//! (unit tests). The constants are the Linux SocketCAN ABI
//! (`linux/can.h`, `linux/can/error.h`), copied here so the core stays pure.

use std::fmt;
use std::time::Duration;

/// Largest standard (11-bit) identifier.
pub const SFF_MAX_ID: u32 = 0x7FF;
/// Largest extended (29-bit) identifier.
pub const EFF_MAX_ID: u32 = 0x1FFF_FFFF;

/// Kernel error-frame classes (the bits of an error frame's CAN id).
pub mod err {
    /// TX timeout (by netdevice driver).
    pub const TX_TIMEOUT: u32 = 0x001;
    /// Lost arbitration (`data[0]` = bit position).
    pub const LOSTARB: u32 = 0x002;
    /// Controller problems (`data[1]` = `CRTL_*` bits).
    pub const CRTL: u32 = 0x004;
    /// Protocol violations (`data[2]`, `data[3]`).
    pub const PROT: u32 = 0x008;
    /// Transceiver status (`data[4]`).
    pub const TRX: u32 = 0x010;
    /// No acknowledge on transmission: nobody else is on the bus.
    pub const ACK: u32 = 0x020;
    /// Bus off: the controller stopped taking part in bus traffic.
    pub const BUSOFF: u32 = 0x040;
    /// Bus error (may flood).
    pub const BUSERROR: u32 = 0x080;
    /// Controller restarted (after bus-off).
    pub const RESTARTED: u32 = 0x100;
    /// TX/RX error counters in `data[6]`/`data[7]`.
    pub const CNT: u32 = 0x200;
    /// Every class: what the bridge subscribes to with its error filter.
    pub const MASK_ALL: u32 = 0x1FFF_FFFF;

    /// `data[1]` of a CRTL error: RX buffer overflow.
    pub const CRTL_RX_OVERFLOW: u8 = 0x01;
    /// `data[1]`: TX buffer overflow.
    pub const CRTL_TX_OVERFLOW: u8 = 0x02;
    /// `data[1]`: reached the RX warning level.
    pub const CRTL_RX_WARNING: u8 = 0x04;
    /// `data[1]`: reached the TX warning level.
    pub const CRTL_TX_WARNING: u8 = 0x08;
    /// `data[1]`: reached error passive status on RX.
    pub const CRTL_RX_PASSIVE: u8 = 0x10;
    /// `data[1]`: reached error passive status on TX.
    pub const CRTL_TX_PASSIVE: u8 = 0x20;
    /// `data[1]`: recovered to error active state.
    pub const CRTL_ACTIVE: u8 = 0x40;
}

/// A classic CAN data frame (at most 8 bytes). Bytes beyond `len` are zero.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct CanFrame {
    /// Identifier without flags: 11 bits when `!extended`, 29 bits otherwise.
    pub id: u32,
    /// 29-bit identifier.
    pub extended: bool,
    /// Payload; only the first `len` bytes are sent.
    pub data: [u8; 8],
    /// Data length code, 0..=8.
    pub len: u8,
}

/// Why a frame could not be built.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    #[error("CAN id 0x{id:X} does not fit in {bits} bits")]
    IdTooLarge { id: u32, bits: u8 },
    #[error("{0} data bytes; a classic CAN frame holds at most 8")]
    TooLong(usize),
}

impl CanFrame {
    /// A standard (11-bit id) data frame.
    pub fn standard(id: u32, payload: &[u8]) -> Result<Self, FrameError> {
        if id > SFF_MAX_ID {
            return Err(FrameError::IdTooLarge { id, bits: 11 });
        }
        Self::build(id, false, payload)
    }

    /// An extended (29-bit id) data frame.
    pub fn extended(id: u32, payload: &[u8]) -> Result<Self, FrameError> {
        if id > EFF_MAX_ID {
            return Err(FrameError::IdTooLarge { id, bits: 29 });
        }
        Self::build(id, true, payload)
    }

    fn build(id: u32, extended: bool, payload: &[u8]) -> Result<Self, FrameError> {
        if payload.len() > 8 {
            return Err(FrameError::TooLong(payload.len()));
        }
        let mut data = [0u8; 8];
        data[..payload.len()].copy_from_slice(payload);
        Ok(Self {
            id,
            extended,
            data,
            len: payload.len() as u8,
        })
    }

    /// The bytes actually sent (`data[..len]`, `len` capped at 8).
    pub fn payload(&self) -> &[u8] {
        &self.data[..usize::from(self.len.min(8))]
    }

    /// Whether the fields satisfy the invariants (id range, len ≤ 8).
    /// The adapters refuse to send a frame that does not.
    pub fn is_valid(&self) -> bool {
        let max = if self.extended { EFF_MAX_ID } else { SFF_MAX_ID };
        self.id <= max && self.len <= 8
    }
}

impl fmt::Debug for CanFrame {
    /// candump's compact form, e.g. `101#A08601000301 00C5`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.extended {
            write!(f, "{:08X}#", self.id)?;
        } else {
            write!(f, "{:03X}#", self.id)?;
        }
        for b in self.payload() {
            write!(f, "{b:02X}")?;
        }
        Ok(())
    }
}

/// A kernel error frame (received only with an error filter set).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct CanErrorFrame {
    /// Error classes ([`err`] bits), from the frame's id.
    pub class: u32,
    /// Details, per class (see `linux/can/error.h`).
    pub data: [u8; 8],
}

/// How the bridge treats an error frame.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum ErrorSeverity {
    /// The bus cannot carry our frames (bus-off, no ACK, TX timeout, error
    /// passive): stop until the bus is back.
    Fatal,
    /// The controller says it is back (restarted after bus-off, or error active again).
    Recovered,
    /// Counted and reported, the bus still works (lost arbitration, a
    /// protocol error, warning levels, overflows).
    Warning,
}

impl CanErrorFrame {
    /// A bus-off report.
    pub fn bus_off() -> Self {
        Self {
            class: err::BUSOFF,
            data: [0; 8],
        }
    }

    /// A "controller restarted" report.
    pub fn restarted() -> Self {
        Self {
            class: err::RESTARTED,
            data: [0; 8],
        }
    }

    /// Whether the controller went bus-off.
    pub fn is_bus_off(&self) -> bool {
        self.class & err::BUSOFF != 0
    }

    /// Classifies the frame; fatal wins over recovery when both are set.
    pub fn severity(&self) -> ErrorSeverity {
        let crtl = if self.class & err::CRTL != 0 { self.data[1] } else { 0 };
        let fatal = self.class & (err::BUSOFF | err::ACK | err::TX_TIMEOUT) != 0
            || crtl & (err::CRTL_RX_PASSIVE | err::CRTL_TX_PASSIVE) != 0;
        if fatal {
            ErrorSeverity::Fatal
        } else if self.class & err::RESTARTED != 0 || crtl & err::CRTL_ACTIVE != 0 {
            ErrorSeverity::Recovered
        } else {
            ErrorSeverity::Warning
        }
    }

    /// A short human-readable list of the classes, e.g. `bus-off`.
    pub fn describe(&self) -> String {
        const NAMES: [(u32, &str); 10] = [
            (err::TX_TIMEOUT, "tx-timeout"),
            (err::LOSTARB, "lost-arbitration"),
            (err::CRTL, "controller"),
            (err::PROT, "protocol-violation"),
            (err::TRX, "transceiver"),
            (err::ACK, "no-ack"),
            (err::BUSOFF, "bus-off"),
            (err::BUSERROR, "bus-error"),
            (err::RESTARTED, "restarted"),
            (err::CNT, "error-counters"),
        ];
        let mut parts: Vec<String> = NAMES
            .iter()
            .filter(|(bit, _)| self.class & bit != 0)
            .map(|(_, n)| (*n).to_string())
            .collect();
        if self.class & err::CRTL != 0 {
            const CRTL: [(u8, &str); 7] = [
                (err::CRTL_RX_OVERFLOW, "rx-overflow"),
                (err::CRTL_TX_OVERFLOW, "tx-overflow"),
                (err::CRTL_RX_WARNING, "rx-warning"),
                (err::CRTL_TX_WARNING, "tx-warning"),
                (err::CRTL_RX_PASSIVE, "rx-passive"),
                (err::CRTL_TX_PASSIVE, "tx-passive"),
                (err::CRTL_ACTIVE, "active"),
            ];
            for (bit, n) in CRTL {
                if self.data[1] & bit != 0 {
                    parts.push(format!("controller:{n}"));
                }
            }
        }
        if parts.is_empty() {
            format!("error-class-0x{:X}", self.class)
        } else {
            parts.join(",")
        }
    }
}

/// What a receive yields.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum BusEvent {
    /// A data frame that passed the receive filter.
    Frame(CanFrame),
    /// A kernel error frame.
    Error(CanErrorFrame),
}

/// Accept data frames with exactly this id (and id format). Remote frames are never accepted.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Hash)]
pub struct RxFilter {
    pub id: u32,
    pub extended: bool,
}

impl RxFilter {
    /// A filter for one standard id.
    pub fn standard(id: u32) -> Self {
        Self { id, extended: false }
    }

    /// Whether `frame` passes this filter.
    pub fn matches(&self, frame: &CanFrame) -> bool {
        frame.id == self.id && frame.extended == self.extended
    }
}

/// A bus failure other than a full transmit queue (interface down, no such
/// device, permission, ...).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct BusError(pub String);

/// Why a send failed.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SendError {
    /// The kernel's transmit queue (or the socket's send buffer) is full:
    /// ENOBUFS or EAGAIN. Transient; the caller decides whether to retry.
    #[error("transmit queue full (ENOBUFS)")]
    QueueFull,
    /// The frame violates the frame invariants; not sent.
    #[error("invalid frame {0}")]
    InvalidFrame(String),
    /// Anything else, e.g. ENETDOWN.
    #[error("send failed: {0}")]
    Failed(BusError),
}

/// A CAN interface as the core sees it.
pub trait CanBus {
    /// Receive only data frames matching one of `filters` (plus error frames,
    /// always). An empty list receives no data frames.
    fn set_rx_filters(&mut self, filters: &[RxFilter]) -> Result<(), BusError>;

    /// Queues one frame for transmission without blocking.
    fn send(&mut self, frame: &CanFrame) -> Result<(), SendError>;

    /// The next frame or error frame, waiting at most `timeout`; `Ok(None)`
    /// when nothing arrived in time. A zero timeout only polls.
    fn recv(&mut self, timeout: Duration) -> Result<Option<BusEvent>, BusError>;
}

impl<B: CanBus + ?Sized> CanBus for Box<B> {
    fn set_rx_filters(&mut self, filters: &[RxFilter]) -> Result<(), BusError> {
        (**self).set_rx_filters(filters)
    }
    fn send(&mut self, frame: &CanFrame) -> Result<(), SendError> {
        (**self).send(frame)
    }
    fn recv(&mut self, timeout: Duration) -> Result<Option<BusEvent>, BusError> {
        (**self).recv(timeout)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_constructors_check_id_and_length() {
        let f = CanFrame::standard(0x7FF, &[1, 2, 3]).unwrap();
        assert_eq!(f.payload(), &[1, 2, 3]);
        assert_eq!(f.data, [1, 2, 3, 0, 0, 0, 0, 0]);
        assert!(f.is_valid());
        assert_eq!(
            CanFrame::standard(0x800, &[]),
            Err(FrameError::IdTooLarge { id: 0x800, bits: 11 })
        );
        assert!(CanFrame::extended(0x1FFF_FFFF, &[]).is_ok());
        assert!(CanFrame::extended(0x2000_0000, &[]).is_err());
        assert_eq!(CanFrame::standard(1, &[0; 9]), Err(FrameError::TooLong(9)));
        let bad = CanFrame {
            id: 0x800,
            extended: false,
            data: [0; 8],
            len: 2,
        };
        assert!(!bad.is_valid());
        let bad_len = CanFrame { len: 9, ..f };
        assert!(!bad_len.is_valid());
        assert_eq!(bad_len.payload().len(), 8, "payload never panics");
    }

    #[test]
    fn debug_is_candump_style() {
        let f = CanFrame::standard(0x101, &[0xDE, 0xAD]).unwrap();
        assert_eq!(format!("{f:?}"), "101#DEAD");
        let e = CanFrame::extended(0x1234, &[]).unwrap();
        assert_eq!(format!("{e:?}"), "00001234#");
    }

    #[test]
    fn error_frames_are_classified() {
        assert_eq!(CanErrorFrame::bus_off().severity(), ErrorSeverity::Fatal);
        assert_eq!(CanErrorFrame::restarted().severity(), ErrorSeverity::Recovered);
        let ack = CanErrorFrame {
            class: err::ACK,
            data: [0; 8],
        };
        assert_eq!(ack.severity(), ErrorSeverity::Fatal);
        let passive = CanErrorFrame {
            class: err::CRTL,
            data: [0, err::CRTL_TX_PASSIVE, 0, 0, 0, 0, 0, 0],
        };
        assert_eq!(passive.severity(), ErrorSeverity::Fatal);
        let warning = CanErrorFrame {
            class: err::CRTL,
            data: [0, err::CRTL_RX_WARNING, 0, 0, 0, 0, 0, 0],
        };
        assert_eq!(warning.severity(), ErrorSeverity::Warning);
        let active = CanErrorFrame {
            class: err::CRTL,
            data: [0, err::CRTL_ACTIVE, 0, 0, 0, 0, 0, 0],
        };
        assert_eq!(active.severity(), ErrorSeverity::Recovered);
        let both = CanErrorFrame {
            class: err::BUSOFF | err::RESTARTED,
            data: [0; 8],
        };
        assert_eq!(both.severity(), ErrorSeverity::Fatal, "fatal wins");
        let lostarb = CanErrorFrame {
            class: err::LOSTARB,
            data: [0; 8],
        };
        assert_eq!(lostarb.severity(), ErrorSeverity::Warning);
        assert_eq!(CanErrorFrame::bus_off().describe(), "bus-off");
        assert_eq!(passive.describe(), "controller,controller:tx-passive");
    }

    #[test]
    fn filters_match_id_and_format() {
        let f = RxFilter::standard(0x110);
        assert!(f.matches(&CanFrame::standard(0x110, &[]).unwrap()));
        assert!(!f.matches(&CanFrame::standard(0x111, &[]).unwrap()));
        assert!(!f.matches(&CanFrame::extended(0x110, &[]).unwrap()));
    }
}
