//! One SDO transfer of any length as a client dialogue (CiA 301 §7.2.4.3):
//! expedited when the value fits in 4 bytes, segmented otherwise, for
//! reads (upload) and writes (download). Used for the requests made while
//! the bridge runs ([`super::sdo_jobs`]); the start-up's writes are all
//! expedited and use [`super::sdo::SdoClient`].
//!
//! | step | client → server (0x600 + id) | server → client (0x580 + id) |
//! |---|---|---|
//! | read, initiate | `40 idx sub 00…` | expedited `43/47/4B/4F` (or `42`: 4 bytes, size not given) with the data; or segmented `41` + size (bytes 4–7), `40` without size |
//! | read, segment | `60` / `70` (bit 4: toggle, from 0) | `0 t n c` + 7 data bytes (bits 4 toggle, 3–1 bytes without data, 0 last) |
//! | write ≤ 4 bytes | `23/27/2B/2F` + data | `60` |
//! | write > 4 bytes, initiate | `21` + size (bytes 4–7) | `60` |
//! | write, segment | `0 t n c` + 7 data bytes | `20` / `30` (the segment's toggle) |
//! | either side gives up | `80` + abort code | `80` + abort code |
//!
//! Each server answer must come within the timeout; a wrong toggle or an
//! unexpected command specifier aborts (0x05030000, 0x05040001) and the
//! client tells the server with an abort frame, as CiA 301 requires.

use super::sdo::{abort, encode_request, ObjectAddr, SdoRequest, SdoValue, COB_RX_BASE};
use crate::bus::CanFrame;
use crate::time::Timestamp;
use std::time::Duration;

/// The longest value a transfer moves (bytes): bounded memory, and far
/// beyond the strings and tables commissioning reads.
pub const MAX_TRANSFER_BYTES: usize = 1024;

/// Read or write.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum TransferKind {
    Read,
    Write(Vec<u8>),
}

/// How a transfer ended.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum TransferEnd {
    /// Done: the value read (empty for a write).
    Done(Vec<u8>),
    /// Aborted by the server (its code) or by this client (the code it sent).
    Aborted { code: u32, by_server: bool },
    /// No answer in time (the client sent abort 0x05040000).
    TimedOut,
}

#[derive(Clone, Debug, PartialEq, Eq)]
enum Stage {
    /// The initiate request is due.
    Start,
    /// Waiting for the initiate answer.
    Initiated,
    /// Segmented read: segment request with `toggle` due / sent.
    ReadSegment {
        toggle: bool,
        sent: bool,
    },
    /// Segmented write: the segment from `offset` with `toggle` due / sent.
    WriteSegment {
        offset: usize,
        toggle: bool,
        sent: bool,
    },
    Finished,
}

/// One transfer with one node.
#[derive(Clone, Debug)]
pub struct SdoTransfer {
    node: u8,
    addr: ObjectAddr,
    kind: TransferKind,
    timeout: Duration,
    stage: Stage,
    /// Bytes read so far.
    buf: Vec<u8>,
    /// The size the server announced for a segmented read.
    size: Option<usize>,
    /// When the last request went out.
    sent_at: Option<Timestamp>,
    end: Option<TransferEnd>,
}

fn frame(node: u8, cmd: u8, addr: ObjectAddr, data: [u8; 4]) -> CanFrame {
    let i = addr.index.to_le_bytes();
    CanFrame {
        id: COB_RX_BASE + u32::from(node),
        extended: false,
        data: [cmd, i[0], i[1], addr.sub, data[0], data[1], data[2], data[3]],
        len: 8,
    }
}

fn segment(node: u8, cmd: u8, payload: &[u8]) -> CanFrame {
    let mut data = [0u8; 8];
    data[0] = cmd;
    data[1..1 + payload.len()].copy_from_slice(payload);
    CanFrame {
        id: COB_RX_BASE + u32::from(node),
        extended: false,
        data,
        len: 8,
    }
}

impl SdoTransfer {
    /// A transfer of `kind` at `addr` of `node`, each answer due within `timeout`.
    pub fn new(node: u8, addr: ObjectAddr, kind: TransferKind, timeout: Duration) -> Self {
        Self {
            node,
            addr,
            kind,
            timeout,
            stage: Stage::Start,
            buf: Vec::new(),
            size: None,
            sent_at: None,
            end: None,
        }
    }

    /// The object.
    pub fn addr(&self) -> ObjectAddr {
        self.addr
    }

    /// How it ended, once it has.
    pub fn end(&self) -> Option<&TransferEnd> {
        self.end.as_ref()
    }

    /// Takes the end (the transfer is over).
    pub fn take_end(&mut self) -> Option<TransferEnd> {
        self.end.take()
    }

    fn finish(&mut self, end: TransferEnd) {
        self.stage = Stage::Finished;
        self.end = Some(end);
    }

    /// The client gives up with `code`: the abort frame to send.
    fn abort_with(&mut self, code: u32) -> CanFrame {
        self.finish(TransferEnd::Aborted { code, by_server: false });
        encode_request(self.node, &SdoRequest::Abort { addr: self.addr, code })
    }

    /// The next request to send at `now`, if one is due; or, after the
    /// timeout, the abort frame (the transfer then ends `TimedOut`).
    pub fn poll(&mut self, now: Timestamp) -> Option<CanFrame> {
        if let Some(t) = self.sent_at {
            let waiting = matches!(
                self.stage,
                Stage::Initiated | Stage::ReadSegment { sent: true, .. } | Stage::WriteSegment { sent: true, .. }
            );
            if waiting && now - t > self.timeout {
                let f = encode_request(
                    self.node,
                    &SdoRequest::Abort {
                        addr: self.addr,
                        code: abort::TIMEOUT,
                    },
                );
                self.finish(TransferEnd::TimedOut);
                return Some(f);
            }
        }
        let f = match self.stage.clone() {
            Stage::Start => {
                self.stage = Stage::Initiated;
                match &self.kind {
                    TransferKind::Read => frame(self.node, 0x40, self.addr, [0; 4]),
                    TransferKind::Write(d) if d.len() <= 4 => {
                        let mut bytes = [0u8; 4];
                        bytes[..d.len()].copy_from_slice(d);
                        let value = SdoValue {
                            bytes,
                            len: d.len().max(1) as u8,
                        };
                        encode_request(self.node, &SdoRequest::Download { addr: self.addr, value })
                    }
                    // ccs 1, e = 0, s = 1: segmented, the size in bytes 4–7.
                    TransferKind::Write(d) => frame(self.node, 0x21, self.addr, (d.len() as u32).to_le_bytes()),
                }
            }
            Stage::ReadSegment { toggle, sent: false } => {
                self.stage = Stage::ReadSegment { toggle, sent: true };
                segment(self.node, 0x60 | (u8::from(toggle) << 4), &[])
            }
            Stage::WriteSegment {
                offset,
                toggle,
                sent: false,
            } => {
                let TransferKind::Write(d) = &self.kind else {
                    return None;
                };
                let chunk = &d[offset..(offset + 7).min(d.len())];
                let last = offset + chunk.len() >= d.len();
                let n = (7 - chunk.len()) as u8;
                let cmd = (u8::from(toggle) << 4) | (n << 1) | u8::from(last);
                let f = segment(self.node, cmd, chunk);
                self.stage = Stage::WriteSegment {
                    offset,
                    toggle,
                    sent: true,
                };
                f
            }
            _ => return None,
        };
        self.sent_at = Some(now);
        Some(f)
    }

    /// A frame from the server (0x580 + id). Returns the abort frame to
    /// send when the client aborts (a wrong toggle, an unexpected answer).
    pub fn on_response(&mut self, f: &CanFrame) -> Option<CanFrame> {
        if f.len != 8 || self.stage == Stage::Finished {
            return None;
        }
        let d = f.data;
        let cmd = d[0];
        let addr = ObjectAddr::new(u16::from_le_bytes([d[1], d[2]]), d[3]);
        if cmd == 0x80 {
            // An abort names the object only on initiate answers; accept it whenever we wait.
            let code = u32::from_le_bytes([d[4], d[5], d[6], d[7]]);
            self.finish(TransferEnd::Aborted { code, by_server: true });
            return None;
        }
        match self.stage.clone() {
            Stage::Initiated => {
                if addr != self.addr {
                    return None; // an answer to something else
                }
                match (&self.kind, cmd >> 5) {
                    (TransferKind::Read, 2) if cmd & 0x02 != 0 => {
                        // Expedited: size given (s = 1) or 4 bytes.
                        let len = if cmd & 0x01 != 0 {
                            4 - usize::from((cmd >> 2) & 0x03)
                        } else {
                            4
                        };
                        self.finish(TransferEnd::Done(d[4..4 + len].to_vec()));
                        None
                    }
                    (TransferKind::Read, 2) => {
                        if cmd & 0x01 != 0 {
                            let size = u32::from_le_bytes([d[4], d[5], d[6], d[7]]) as usize;
                            if size > MAX_TRANSFER_BYTES {
                                return Some(self.abort_with(abort::OUT_OF_MEMORY));
                            }
                            self.size = Some(size);
                        }
                        self.stage = Stage::ReadSegment {
                            toggle: false,
                            sent: false,
                        };
                        None
                    }
                    (TransferKind::Write(data), 3) => {
                        if data.len() <= 4 {
                            self.finish(TransferEnd::Done(Vec::new()));
                        } else {
                            self.stage = Stage::WriteSegment {
                                offset: 0,
                                toggle: false,
                                sent: false,
                            };
                        }
                        None
                    }
                    _ => Some(self.abort_with(abort::COMMAND_SPECIFIER)),
                }
            }
            Stage::ReadSegment { toggle, sent: true } => {
                // scs 0: upload segment.
                if cmd >> 5 != 0 {
                    return Some(self.abort_with(abort::COMMAND_SPECIFIER));
                }
                if (cmd & 0x10 != 0) != toggle {
                    return Some(self.abort_with(abort::TOGGLE_BIT));
                }
                let n = usize::from((cmd >> 1) & 0x07);
                self.buf.extend_from_slice(&d[1..8 - n]);
                if self.buf.len() > MAX_TRANSFER_BYTES {
                    return Some(self.abort_with(abort::OUT_OF_MEMORY));
                }
                if cmd & 0x01 != 0 {
                    if self.size.is_some_and(|s| s != self.buf.len()) {
                        return Some(self.abort_with(abort::LENGTH_MISMATCH));
                    }
                    let data = std::mem::take(&mut self.buf);
                    self.finish(TransferEnd::Done(data));
                } else {
                    self.stage = Stage::ReadSegment {
                        toggle: !toggle,
                        sent: false,
                    };
                }
                None
            }
            Stage::WriteSegment {
                offset,
                toggle,
                sent: true,
            } => {
                // scs 1: download segment response with the segment's toggle.
                if cmd & 0xEF != 0x20 {
                    return Some(self.abort_with(abort::COMMAND_SPECIFIER));
                }
                if (cmd & 0x10 != 0) != toggle {
                    return Some(self.abort_with(abort::TOGGLE_BIT));
                }
                let TransferKind::Write(data) = &self.kind else {
                    return None;
                };
                let next = offset + 7;
                if next >= data.len() {
                    self.finish(TransferEnd::Done(Vec::new()));
                } else {
                    self.stage = Stage::WriteSegment {
                        offset: next,
                        toggle: !toggle,
                        sent: false,
                    };
                }
                None
            }
            // Nothing asked: not ours.
            _ => None,
        }
    }

    /// Waiting for the server or about to send.
    pub fn busy(&self) -> bool {
        self.stage != Stage::Finished
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const A: ObjectAddr = ObjectAddr::new(0x1008, 0);
    const MS: Duration = Duration::from_millis(200);

    fn t(ms: u64) -> Timestamp {
        Timestamp::ZERO + Duration::from_millis(ms)
    }

    fn resp(data: [u8; 8]) -> CanFrame {
        CanFrame {
            id: 0x581,
            extended: false,
            data,
            len: 8,
        }
    }

    /// A segmented read of the 11 bytes "oldbf drive", by hand from CiA 301:
    /// initiate answer 0x41 with size 11; segment 1: toggle 0, 7 bytes, not
    /// last (0x00); segment 2: toggle 1, n = 3 unused, last: 0x10|3<<1|1 = 0x17.
    #[test]
    fn segmented_read_by_hand() {
        let mut x = SdoTransfer::new(1, A, TransferKind::Read, MS);
        let f = x.poll(t(0)).unwrap();
        assert_eq!((f.id, f.data), (0x601, [0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0]));
        assert_eq!(x.poll(t(1)), None, "waiting");
        x.on_response(&resp([0x41, 0x08, 0x10, 0x00, 11, 0, 0, 0]));
        let f = x.poll(t(2)).unwrap();
        assert_eq!(f.data, [0x60, 0, 0, 0, 0, 0, 0, 0]);
        x.on_response(&resp([0x00, b'o', b'l', b'd', b'b', b'f', b' ', b'd']));
        let f = x.poll(t(3)).unwrap();
        assert_eq!(f.data, [0x70, 0, 0, 0, 0, 0, 0, 0], "toggle 1");
        x.on_response(&resp([0x17, b'r', b'i', b'v', b'e', 0, 0, 0]));
        assert_eq!(x.take_end(), Some(TransferEnd::Done(b"oldbf drive".to_vec())));
        assert!(!x.busy());
    }

    /// A segmented write of 9 bytes: initiate 0x21 with size 9 (answer 0x60),
    /// segment 1: toggle 0, 7 bytes, 0x00 (answer 0x20); segment 2: toggle 1,
    /// 2 bytes (n = 5), last: 0x10|5<<1|1 = 0x1B (answer 0x30).
    #[test]
    fn segmented_write_by_hand() {
        let data = b"abcdefghi".to_vec();
        let mut x = SdoTransfer::new(1, ObjectAddr::new(0x2100, 0), TransferKind::Write(data), MS);
        let f = x.poll(t(0)).unwrap();
        assert_eq!(f.data, [0x21, 0x00, 0x21, 0x00, 9, 0, 0, 0]);
        x.on_response(&resp([0x60, 0x00, 0x21, 0x00, 0, 0, 0, 0]));
        let f = x.poll(t(1)).unwrap();
        assert_eq!(f.data, [0x00, b'a', b'b', b'c', b'd', b'e', b'f', b'g']);
        x.on_response(&resp([0x20, 0, 0, 0, 0, 0, 0, 0]));
        let f = x.poll(t(2)).unwrap();
        assert_eq!(f.data, [0x1B, b'h', b'i', 0, 0, 0, 0, 0]);
        assert!(x.busy());
        x.on_response(&resp([0x30, 0, 0, 0, 0, 0, 0, 0]));
        assert_eq!(x.take_end(), Some(TransferEnd::Done(Vec::new())));
    }

    #[test]
    fn expedited_both_ways() {
        // Write 2 bytes: 0x2B; read answered 0x4B (2 bytes).
        let mut w = SdoTransfer::new(2, ObjectAddr::new(0x1017, 0), TransferKind::Write(vec![0x64, 0]), MS);
        assert_eq!(w.poll(t(0)).unwrap().data, [0x2B, 0x17, 0x10, 0x00, 0x64, 0, 0, 0]);
        w.on_response(&resp([0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0]));
        assert_eq!(w.take_end(), Some(TransferEnd::Done(Vec::new())));
        let mut r = SdoTransfer::new(2, ObjectAddr::new(0x1017, 0), TransferKind::Read, MS);
        r.poll(t(0));
        r.on_response(&resp([0x4B, 0x17, 0x10, 0x00, 0x64, 0, 0xAA, 0xBB]));
        assert_eq!(r.take_end(), Some(TransferEnd::Done(vec![0x64, 0])));
    }

    #[test]
    fn toggle_errors_aborts_and_timeouts() {
        // A segment with the wrong toggle: the client aborts with 0x05030000.
        let mut x = SdoTransfer::new(1, A, TransferKind::Read, MS);
        x.poll(t(0));
        x.on_response(&resp([0x41, 0x08, 0x10, 0x00, 20, 0, 0, 0]));
        x.poll(t(1));
        let f = x.on_response(&resp([0x10, 1, 2, 3, 4, 5, 6, 7])).unwrap();
        assert_eq!(f.data, [0x80, 0x08, 0x10, 0x00, 0x00, 0x00, 0x03, 0x05]);
        assert_eq!(
            x.take_end(),
            Some(TransferEnd::Aborted {
                code: 0x0503_0000,
                by_server: false
            })
        );
        // The server refuses: its code.
        let mut w = SdoTransfer::new(1, ObjectAddr::new(0x6083, 0), TransferKind::Write(vec![1, 0, 0, 0]), MS);
        w.poll(t(0));
        w.on_response(&resp([0x80, 0x83, 0x60, 0x00, 0x22, 0x00, 0x00, 0x08]));
        assert_eq!(
            w.take_end(),
            Some(TransferEnd::Aborted {
                code: 0x0800_0022,
                by_server: true
            })
        );
        // Silence: at the limit nothing, then the abort 0x05040000.
        let mut s = SdoTransfer::new(1, A, TransferKind::Read, MS);
        s.poll(t(0));
        assert_eq!(s.poll(t(200)), None);
        let f = s.poll(t(201)).unwrap();
        assert_eq!(f.data, [0x80, 0x08, 0x10, 0x00, 0x00, 0x00, 0x04, 0x05]);
        assert_eq!(s.take_end(), Some(TransferEnd::TimedOut));
        // A size beyond the bound: out of memory (0x05040005), nothing stored.
        let mut big = SdoTransfer::new(1, A, TransferKind::Read, MS);
        big.poll(t(0));
        let f = big
            .on_response(&resp([0x41, 0x08, 0x10, 0x00, 0x01, 0x04, 0, 0]))
            .unwrap();
        assert_eq!(
            u32::from_le_bytes([f.data[4], f.data[5], f.data[6], f.data[7]]),
            0x0504_0005
        );
        // The last segment short of the announced size: length mismatch.
        let mut short = SdoTransfer::new(1, A, TransferKind::Read, MS);
        short.poll(t(0));
        short.on_response(&resp([0x41, 0x08, 0x10, 0x00, 10, 0, 0, 0]));
        short.poll(t(1));
        short.on_response(&resp([0x0B, b'a', b'b', b'c', b'd', 0, 0, 0]));
        assert_eq!(
            short.take_end(),
            Some(TransferEnd::Aborted {
                code: 0x0607_0010,
                by_server: false
            })
        );
        // An answer for another object during the initiate is not ours.
        let mut other = SdoTransfer::new(1, A, TransferKind::Read, MS);
        other.poll(t(0));
        assert_eq!(other.on_response(&resp([0x43, 0x00, 0x10, 0x00, 1, 2, 3, 4])), None);
        assert!(other.busy());
    }
}
