//! CANopen SDO (CiA 301 §7.2.4.3), expedited transfers only: the frames, the
//! abort codes, and the client side of one transfer at a time per node.
//!
//! Client → server on 0x600 + node id, server → client on 0x580 + node id,
//! always 8 bytes: byte 0 the command specifier, bytes 1–2 the index (little
//! endian), byte 3 the sub-index, bytes 4–7 the data or the abort code.
//!
//! | byte 0 | meaning |
//! |---|---|
//! | 0x23 / 0x27 / 0x2B / 0x2F | expedited download (write) of 4 / 3 / 2 / 1 bytes (ccs 1, n = 4 − len, e = s = 1) |
//! | 0x60 | download response |
//! | 0x40 | upload (read) request |
//! | 0x43 / 0x47 / 0x4B / 0x4F | expedited upload response with 4 / 3 / 2 / 1 bytes |
//! | 0x41 | upload response announcing a segmented transfer (not supported here) |
//! | 0x80 | abort, bytes 4–7 the 32-bit abort code |
//!
//! Segmented and block transfers are not implemented: every object the
//! bridge needs is at most 4 bytes.

use crate::bus::CanFrame;
use crate::time::Timestamp;
use std::time::Duration;

/// Client → server COB-ID base (+ node id).
pub const COB_RX_BASE: u32 = 0x600;
/// Server → client COB-ID base (+ node id).
pub const COB_TX_BASE: u32 = 0x580;

/// Command specifiers (byte 0).
pub mod cs {
    /// Expedited download, 4 data bytes.
    pub const DOWNLOAD_4: u8 = 0x23;
    /// Expedited download, 3 data bytes.
    pub const DOWNLOAD_3: u8 = 0x27;
    /// Expedited download, 2 data bytes.
    pub const DOWNLOAD_2: u8 = 0x2B;
    /// Expedited download, 1 data byte.
    pub const DOWNLOAD_1: u8 = 0x2F;
    /// Download (write) response.
    pub const DOWNLOAD_RESPONSE: u8 = 0x60;
    /// Upload (read) request.
    pub const UPLOAD_REQUEST: u8 = 0x40;
    /// Abort transfer.
    pub const ABORT: u8 = 0x80;
}

/// An object dictionary address.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ObjectAddr {
    pub index: u16,
    pub sub: u8,
}

impl ObjectAddr {
    pub const fn new(index: u16, sub: u8) -> Self {
        Self { index, sub }
    }
}

impl std::fmt::Display for ObjectAddr {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "0x{:04X}:{:02X}", self.index, self.sub)
    }
}

/// A value of 1, 2 or 4 bytes (little endian on the wire).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SdoValue {
    pub bytes: [u8; 4],
    /// 1..=4.
    pub len: u8,
}

impl SdoValue {
    pub fn u8(v: u8) -> Self {
        Self {
            bytes: [v, 0, 0, 0],
            len: 1,
        }
    }
    pub fn i8(v: i8) -> Self {
        Self::u8(v as u8)
    }
    pub fn u16(v: u16) -> Self {
        let b = v.to_le_bytes();
        Self {
            bytes: [b[0], b[1], 0, 0],
            len: 2,
        }
    }
    pub fn u32(v: u32) -> Self {
        Self {
            bytes: v.to_le_bytes(),
            len: 4,
        }
    }
    /// The value zero-extended to 32 bits.
    pub fn as_u32(&self) -> u32 {
        u32::from_le_bytes(self.bytes)
    }
}

/// What a client sends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SdoRequest {
    /// Expedited download (write).
    Download { addr: ObjectAddr, value: SdoValue },
    /// Upload (read).
    Upload { addr: ObjectAddr },
    /// The client gives up a transfer.
    Abort { addr: ObjectAddr, code: u32 },
}

/// What a server answers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SdoResponse {
    /// The download was done.
    DownloadDone { addr: ObjectAddr },
    /// Expedited upload data.
    Uploaded { addr: ObjectAddr, value: SdoValue },
    /// The server wants a segmented upload (object longer than 4 bytes).
    SegmentedUpload { addr: ObjectAddr },
    /// The server refused or failed.
    Abort { addr: ObjectAddr, code: u32 },
}

/// An SDO frame that is not one of the above.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SdoFrameError {
    #[error("SDO frame of {0} bytes, expected 8")]
    Length(u8),
    #[error("unsupported SDO command specifier 0x{0:02X}")]
    Command(u8),
}

fn addr_of(d: &[u8; 8]) -> ObjectAddr {
    ObjectAddr::new(u16::from_le_bytes([d[1], d[2]]), d[3])
}

fn sdo_frame(id: u32, cmd: u8, addr: ObjectAddr, data: [u8; 4]) -> CanFrame {
    let i = addr.index.to_le_bytes();
    CanFrame {
        id,
        extended: false,
        data: [cmd, i[0], i[1], addr.sub, data[0], data[1], data[2], data[3]],
        len: 8,
    }
}

/// The client's request frame to `node`.
pub fn encode_request(node: u8, r: &SdoRequest) -> CanFrame {
    let id = COB_RX_BASE + u32::from(node);
    match *r {
        SdoRequest::Download { addr, value } => {
            // ccs = 1, n = 4 − len (bytes that do not hold data), e = 1, s = 1.
            let n = 4 - value.len.clamp(1, 4);
            sdo_frame(id, 0x20 | (n << 2) | 0x03, addr, value.bytes)
        }
        SdoRequest::Upload { addr } => sdo_frame(id, cs::UPLOAD_REQUEST, addr, [0; 4]),
        SdoRequest::Abort { addr, code } => sdo_frame(id, cs::ABORT, addr, code.to_le_bytes()),
    }
}

/// A server's response frame from `node`.
pub fn encode_response(node: u8, r: &SdoResponse) -> CanFrame {
    let id = COB_TX_BASE + u32::from(node);
    match *r {
        SdoResponse::DownloadDone { addr } => sdo_frame(id, cs::DOWNLOAD_RESPONSE, addr, [0; 4]),
        SdoResponse::Uploaded { addr, value } => {
            let n = 4 - value.len.clamp(1, 4);
            sdo_frame(id, 0x40 | (n << 2) | 0x03, addr, value.bytes)
        }
        // s = 1, e = 0: the size (bytes 4–7) follows; the bridge never asks for one.
        SdoResponse::SegmentedUpload { addr } => sdo_frame(id, 0x41, addr, [0; 4]),
        SdoResponse::Abort { addr, code } => sdo_frame(id, cs::ABORT, addr, code.to_le_bytes()),
    }
}

fn need8(f: &CanFrame) -> Result<(), SdoFrameError> {
    if f.len != 8 {
        return Err(SdoFrameError::Length(f.len));
    }
    Ok(())
}

/// Expedited value from bytes 4.. with `n` unused bytes; a value with e = 1,
/// s = 0 (size unspecified) is taken as 4 bytes.
fn expedited(d: &[u8; 8], cmd: u8) -> SdoValue {
    let len = if cmd & 0x01 != 0 { 4 - ((cmd >> 2) & 0x03) } else { 4 };
    let mut bytes = [0u8; 4];
    bytes[..usize::from(len)].copy_from_slice(&d[4..4 + usize::from(len)]);
    SdoValue { bytes, len }
}

/// Server side: decodes a client request.
pub fn decode_request(f: &CanFrame) -> Result<SdoRequest, SdoFrameError> {
    need8(f)?;
    let d = &f.data;
    let addr = addr_of(d);
    let cmd = d[0];
    match cmd >> 5 {
        // Initiate download: only expedited (e = 1) is supported.
        1 if cmd & 0x02 != 0 => Ok(SdoRequest::Download {
            addr,
            value: expedited(d, cmd),
        }),
        2 => Ok(SdoRequest::Upload { addr }),
        4 => Ok(SdoRequest::Abort {
            addr,
            code: u32::from_le_bytes([d[4], d[5], d[6], d[7]]),
        }),
        _ => Err(SdoFrameError::Command(cmd)),
    }
}

/// Client side: decodes a server response.
pub fn decode_response(f: &CanFrame) -> Result<SdoResponse, SdoFrameError> {
    need8(f)?;
    let d = &f.data;
    let addr = addr_of(d);
    let cmd = d[0];
    match cmd >> 5 {
        3 => Ok(SdoResponse::DownloadDone { addr }),
        2 if cmd & 0x02 != 0 => Ok(SdoResponse::Uploaded {
            addr,
            value: expedited(d, cmd),
        }),
        2 => Ok(SdoResponse::SegmentedUpload { addr }),
        4 => Ok(SdoResponse::Abort {
            addr,
            code: u32::from_le_bytes([d[4], d[5], d[6], d[7]]),
        }),
        _ => Err(SdoFrameError::Command(cmd)),
    }
}

/// Abort codes (CiA 301 Table 22) used by this crate.
pub mod abort {
    pub const TOGGLE_BIT: u32 = 0x0503_0000;
    pub const TIMEOUT: u32 = 0x0504_0000;
    pub const COMMAND_SPECIFIER: u32 = 0x0504_0001;
    pub const OUT_OF_MEMORY: u32 = 0x0504_0005;
    pub const UNSUPPORTED_ACCESS: u32 = 0x0601_0000;
    pub const WRITE_ONLY: u32 = 0x0601_0001;
    pub const READ_ONLY: u32 = 0x0601_0002;
    pub const NO_OBJECT: u32 = 0x0602_0000;
    pub const NOT_MAPPABLE: u32 = 0x0604_0041;
    pub const PDO_LENGTH: u32 = 0x0604_0042;
    pub const PARAMETER_INCOMPATIBLE: u32 = 0x0604_0043;
    pub const LENGTH_MISMATCH: u32 = 0x0607_0010;
    pub const LENGTH_TOO_HIGH: u32 = 0x0607_0012;
    pub const LENGTH_TOO_LOW: u32 = 0x0607_0013;
    pub const NO_SUB_INDEX: u32 = 0x0609_0011;
    pub const INVALID_VALUE: u32 = 0x0609_0030;
    pub const VALUE_TOO_HIGH: u32 = 0x0609_0031;
    pub const VALUE_TOO_LOW: u32 = 0x0609_0032;
    pub const RESOURCE_NOT_AVAILABLE: u32 = 0x060A_0023;
    pub const GENERAL: u32 = 0x0800_0000;
    pub const DEVICE_STATE: u32 = 0x0800_0022;
}

/// The CiA 301 meaning of an abort code (for reports).
pub fn abort_description(code: u32) -> &'static str {
    match code {
        0x0503_0000 => "toggle bit not alternated",
        0x0504_0000 => "SDO protocol timed out",
        0x0504_0001 => "client/server command specifier not valid or unknown",
        0x0504_0002 => "invalid block size",
        0x0504_0003 => "invalid sequence number",
        0x0504_0004 => "CRC error",
        0x0504_0005 => "out of memory",
        0x0601_0000 => "unsupported access to an object",
        0x0601_0001 => "attempt to read a write only object",
        0x0601_0002 => "attempt to write a read only object",
        0x0602_0000 => "object does not exist in the object dictionary",
        0x0604_0041 => "object cannot be mapped to the PDO",
        0x0604_0042 => "the number and length of the objects to be mapped would exceed PDO length",
        0x0604_0043 => "general parameter incompatibility reason",
        0x0604_0047 => "general internal incompatibility in the device",
        0x0606_0000 => "access failed due to a hardware error",
        0x0607_0010 => "data type does not match, length of service parameter does not match",
        0x0607_0012 => "data type does not match, length of service parameter too high",
        0x0607_0013 => "data type does not match, length of service parameter too low",
        0x0609_0011 => "sub-index does not exist",
        0x0609_0030 => "invalid value for parameter",
        0x0609_0031 => "value of parameter written too high",
        0x0609_0032 => "value of parameter written too low",
        0x0609_0036 => "maximum value is less than minimum value",
        0x060A_0023 => "resource not available: SDO connection",
        0x0800_0000 => "general error",
        0x0800_0020 => "data cannot be transferred or stored to the application",
        0x0800_0021 => "data cannot be transferred or stored to the application because of local control",
        0x0800_0022 => "data cannot be transferred or stored to the application because of the present device state",
        0x0800_0023 => "object dictionary dynamic generation fails or no object dictionary is present",
        0x0800_0024 => "no data available",
        _ => "unknown abort code",
    }
}

/// Why a client transfer failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SdoError {
    #[error("SDO {addr} aborted by the drive: 0x{code:08X} ({})", abort_description(*code))]
    Aborted { addr: ObjectAddr, code: u32 },
    #[error("SDO {addr}: no response within {timeout_ms} ms")]
    Timeout { addr: ObjectAddr, timeout_ms: u64 },
    #[error("SDO {addr}: the drive answers with a segmented transfer (only expedited is supported)")]
    Segmented { addr: ObjectAddr },
    #[error("SDO {addr}: {what}")]
    Unexpected { addr: ObjectAddr, what: &'static str },
}

impl SdoError {
    /// The abort code that describes the failure (timeouts: 0x05040000).
    pub fn code(&self) -> u32 {
        match self {
            SdoError::Aborted { code, .. } => *code,
            SdoError::Timeout { .. } => abort::TIMEOUT,
            SdoError::Segmented { .. } => abort::COMMAND_SPECIFIER,
            SdoError::Unexpected { .. } => abort::GENERAL,
        }
    }
}

/// The client side of one expedited transfer at a time with one node.
#[derive(Clone, Copy, Debug)]
pub struct SdoClient {
    node: u8,
    timeout: Duration,
    pending: Option<(SdoRequest, Timestamp)>,
}

/// How a response or a timeout ended the pending transfer.
pub type SdoOutcome = Result<Option<SdoValue>, SdoError>;

impl SdoClient {
    /// A client for `node` that gives up after `timeout`.
    pub fn new(node: u8, timeout: Duration) -> Self {
        Self {
            node,
            timeout,
            pending: None,
        }
    }

    /// A transfer is waiting for its response.
    pub fn busy(&self) -> bool {
        self.pending.is_some()
    }

    /// Forgets any pending transfer (a new start-up).
    pub fn cancel(&mut self) {
        self.pending = None;
    }

    /// Starts `req` (a download or an upload) at `now`; the frame to send.
    pub fn start(&mut self, req: SdoRequest, now: Timestamp) -> CanFrame {
        self.pending = Some((req, now));
        encode_request(self.node, &req)
    }

    /// A response from the node: `None` if it does not answer the pending
    /// transfer (none pending, or another object); else how it ended
    /// (`Ok(Some(value))` for an upload).
    pub fn on_response(&mut self, r: &SdoResponse) -> Option<SdoOutcome> {
        let (req, _) = self.pending?;
        let addr = match req {
            SdoRequest::Download { addr, .. } | SdoRequest::Upload { addr } | SdoRequest::Abort { addr, .. } => addr,
        };
        let outcome = match (*r, req) {
            (SdoResponse::Abort { addr: a, code }, _) if a == addr => Err(SdoError::Aborted { addr, code }),
            (SdoResponse::DownloadDone { addr: a }, SdoRequest::Download { .. }) if a == addr => Ok(None),
            (SdoResponse::Uploaded { addr: a, value }, SdoRequest::Upload { .. }) if a == addr => Ok(Some(value)),
            (SdoResponse::SegmentedUpload { addr: a }, SdoRequest::Upload { .. }) if a == addr => {
                Err(SdoError::Segmented { addr })
            }
            _ => return None,
        };
        self.pending = None;
        Some(outcome)
    }

    /// After the timeout: the error and the abort frame that tells the node
    /// (CiA 301: the client aborts with 0x05040000).
    pub fn poll_timeout(&mut self, now: Timestamp) -> Option<(SdoError, CanFrame)> {
        let (req, since) = self.pending?;
        if now - since <= self.timeout {
            return None;
        }
        self.pending = None;
        let addr = match req {
            SdoRequest::Download { addr, .. } | SdoRequest::Upload { addr } | SdoRequest::Abort { addr, .. } => addr,
        };
        let frame = encode_request(
            self.node,
            &SdoRequest::Abort {
                addr,
                code: abort::TIMEOUT,
            },
        );
        Some((
            SdoError::Timeout {
                addr,
                timeout_ms: self.timeout.as_millis() as u64,
            },
            frame,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const A: ObjectAddr = ObjectAddr::new(0x6060, 0);

    // Hand-derived from CiA 301: ccs 1 << 5 | n << 2 | e << 1 | s.
    #[test]
    fn expedited_download_golden_bytes() {
        let f = encode_request(
            3,
            &SdoRequest::Download {
                addr: A,
                value: SdoValue::i8(3),
            },
        );
        assert_eq!((f.id, f.len), (0x603, 8));
        assert_eq!(f.data, [0x2F, 0x60, 0x60, 0x00, 0x03, 0, 0, 0]);
        let f = encode_request(
            5,
            &SdoRequest::Download {
                addr: ObjectAddr::new(0x1017, 0),
                value: SdoValue::u16(100),
            },
        );
        assert_eq!((f.id, f.data), (0x605, [0x2B, 0x17, 0x10, 0x00, 0x64, 0x00, 0, 0]));
        let f = encode_request(
            1,
            &SdoRequest::Download {
                addr: ObjectAddr::new(0x1600, 1),
                value: SdoValue::u32(0x6040_0010),
            },
        );
        assert_eq!(f.data, [0x23, 0x00, 0x16, 0x01, 0x10, 0x00, 0x40, 0x60]);
        let three = SdoValue {
            bytes: [1, 2, 3, 0],
            len: 3,
        };
        let f = encode_request(1, &SdoRequest::Download { addr: A, value: three });
        assert_eq!(f.data[0], 0x27);
        let f = encode_request(
            0x7F,
            &SdoRequest::Upload {
                addr: ObjectAddr::new(0x1000, 0),
            },
        );
        assert_eq!((f.id, f.data), (0x67F, [0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]));
        let f = encode_request(
            2,
            &SdoRequest::Abort {
                addr: A,
                code: abort::TIMEOUT,
            },
        );
        assert_eq!(f.data, [0x80, 0x60, 0x60, 0x00, 0x00, 0x00, 0x04, 0x05]);
    }

    #[test]
    fn responses_golden_bytes_and_decoding() {
        let f = encode_response(3, &SdoResponse::DownloadDone { addr: A });
        assert_eq!((f.id, f.data), (0x583, [0x60, 0x60, 0x60, 0x00, 0, 0, 0, 0]));
        assert_eq!(decode_response(&f), Ok(SdoResponse::DownloadDone { addr: A }));
        // Device type 0x00020192 (CiA 402, servo) read from 0x1000.
        let addr = ObjectAddr::new(0x1000, 0);
        let f = encode_response(
            3,
            &SdoResponse::Uploaded {
                addr,
                value: SdoValue::u32(0x0002_0192),
            },
        );
        assert_eq!(f.data, [0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00]);
        assert_eq!(
            decode_response(&f),
            Ok(SdoResponse::Uploaded {
                addr,
                value: SdoValue::u32(0x0002_0192)
            })
        );
        let f = encode_response(
            3,
            &SdoResponse::Uploaded {
                addr,
                value: SdoValue::u16(7),
            },
        );
        assert_eq!(f.data[0], 0x4B);
        let f = encode_response(
            3,
            &SdoResponse::Uploaded {
                addr,
                value: SdoValue::u8(7),
            },
        );
        assert_eq!(f.data[0], 0x4F);
        // Abort 0x06090030 on 0x6060:00.
        let raw = CanFrame::standard(0x583, &[0x80, 0x60, 0x60, 0x00, 0x30, 0x00, 0x09, 0x06]).unwrap();
        assert_eq!(
            decode_response(&raw),
            Ok(SdoResponse::Abort {
                addr: A,
                code: 0x0609_0030
            })
        );
        assert_eq!(abort_description(0x0609_0030), "invalid value for parameter");
        assert_eq!(
            abort_description(0x0602_0000),
            "object does not exist in the object dictionary"
        );
        assert_eq!(abort_description(0x1234_5678), "unknown abort code");
        let seg = CanFrame::standard(0x583, &[0x41, 0x08, 0x10, 0x00, 20, 0, 0, 0]).unwrap();
        assert_eq!(
            decode_response(&seg),
            Ok(SdoResponse::SegmentedUpload {
                addr: ObjectAddr::new(0x1008, 0)
            })
        );
    }

    #[test]
    fn server_decodes_requests() {
        let f = CanFrame::standard(0x603, &[0x2B, 0x17, 0x10, 0x00, 0x64, 0x00, 0xAA, 0xBB]).unwrap();
        assert_eq!(
            decode_request(&f),
            Ok(SdoRequest::Download {
                addr: ObjectAddr::new(0x1017, 0),
                value: SdoValue::u16(100)
            }),
            "bytes beyond the size are not data"
        );
        let f = CanFrame::standard(0x603, &[0x40, 0x41, 0x60, 0x00, 0, 0, 0, 0]).unwrap();
        assert_eq!(
            decode_request(&f),
            Ok(SdoRequest::Upload {
                addr: ObjectAddr::new(0x6041, 0)
            })
        );
        // Segmented download initiation (e = 0) and block commands are refused.
        let f = CanFrame::standard(0x603, &[0x21, 0x08, 0x10, 0x00, 9, 0, 0, 0]).unwrap();
        assert_eq!(decode_request(&f), Err(SdoFrameError::Command(0x21)));
        let f = CanFrame::standard(0x603, &[0xC0, 0, 0, 0, 0, 0, 0, 0]).unwrap();
        assert_eq!(decode_request(&f), Err(SdoFrameError::Command(0xC0)));
        let short = CanFrame::standard(0x603, &[0x40, 0x41, 0x60]).unwrap();
        assert_eq!(decode_request(&short), Err(SdoFrameError::Length(3)));
        assert_eq!(decode_response(&short), Err(SdoFrameError::Length(3)));
    }

    #[test]
    fn client_matches_responses_and_times_out() {
        let t0 = Timestamp::from_secs_f64(1.0);
        let mut c = SdoClient::new(3, Duration::from_millis(200));
        assert!(!c.busy());
        let f = c.start(
            SdoRequest::Download {
                addr: A,
                value: SdoValue::i8(3),
            },
            t0,
        );
        assert_eq!(f.id, 0x603);
        // A response for another object is not ours.
        assert_eq!(
            c.on_response(&SdoResponse::DownloadDone {
                addr: ObjectAddr::new(0x6061, 0)
            }),
            None
        );
        assert_eq!(c.on_response(&SdoResponse::DownloadDone { addr: A }), Some(Ok(None)));
        assert!(!c.busy());
        assert_eq!(
            c.on_response(&SdoResponse::DownloadDone { addr: A }),
            None,
            "nothing pending"
        );
        c.start(SdoRequest::Upload { addr: A }, t0);
        assert_eq!(
            c.on_response(&SdoResponse::Abort {
                addr: A,
                code: 0x0601_0001
            }),
            Some(Err(SdoError::Aborted {
                addr: A,
                code: 0x0601_0001
            }))
        );
        c.start(SdoRequest::Upload { addr: A }, t0);
        assert_eq!(
            c.poll_timeout(t0 + Duration::from_millis(200)),
            None,
            "at the limit: not yet"
        );
        let (e, abort_frame) = c.poll_timeout(t0 + Duration::from_millis(201)).unwrap();
        assert_eq!(
            e,
            SdoError::Timeout {
                addr: A,
                timeout_ms: 200
            }
        );
        assert_eq!(abort_frame.data, [0x80, 0x60, 0x60, 0x00, 0x00, 0x00, 0x04, 0x05]);
        assert!(!c.busy());
    }

    #[test]
    fn error_codes_and_messages() {
        let e = SdoError::Aborted {
            addr: A,
            code: abort::NO_OBJECT,
        };
        assert_eq!(
            e.to_string(),
            "SDO 0x6060:00 aborted by the drive: 0x06020000 (object does not exist in the object dictionary)"
        );
        assert_eq!(e.code(), 0x0602_0000);
        let t = SdoError::Timeout {
            addr: A,
            timeout_ms: 200,
        };
        assert_eq!(t.code(), 0x0504_0000);
        assert_eq!(t.to_string(), "SDO 0x6060:00: no response within 200 ms");
    }
}
