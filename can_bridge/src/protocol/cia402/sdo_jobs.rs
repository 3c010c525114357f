//! SDO requests made while the bridge runs (commissioning, diagnostics):
//! what may be asked, when the bridge refuses, and what comes back.
//!
//! Reads are always allowed. A write is refused, without a frame on the
//! bus, while any axis of the node is powered (operation enabled, quick
//! stop active, fault reaction active) or being enabled by the bridge, if
//! the object could change motion ([`changes_motion`]): the device profile
//! and manufacturer areas, and the communication objects the bridge's
//! control relies on. Such a write waits for a stopped drive (e-stop or a
//! shutdown): then the bridge's own start-up does not run under it either.
//!
//! Only one transfer is on a node's SDO channel at a time (CiA 301): a job
//! waits in a short queue until the channel is free, and the start-up's
//! next step waits for the job. Each answer must come within
//! `sdo_timeout_s`; the job then ends with the abort code and its CiA 301
//! meaning, or the data read.

use super::sdo::{abort, abort_description, ObjectAddr};
use super::sdo_transfer::{TransferEnd, TransferKind, MAX_TRANSFER_BYTES};
use crate::protocol::ProtocolKind;
use serde::Serialize;

/// Jobs queued or running at once; more are refused (0x060A0023).
pub const MAX_QUEUED_JOBS: usize = 4;

/// A request: read or write one object of one node.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SdoJob {
    pub node: u8,
    pub addr: ObjectAddr,
    pub kind: TransferKind,
}

impl SdoJob {
    /// A read.
    pub fn read(node: u8, index: u16, sub: u8) -> Self {
        Self {
            node,
            addr: ObjectAddr::new(index, sub),
            kind: TransferKind::Read,
        }
    }

    /// A write of `data` (the object's bytes, little endian for numbers).
    pub fn write(node: u8, index: u16, sub: u8, data: Vec<u8>) -> Self {
        Self {
            node,
            addr: ObjectAddr::new(index, sub),
            kind: TransferKind::Write(data),
        }
    }

    /// Whether it writes.
    pub fn is_write(&self) -> bool {
        matches!(self.kind, TransferKind::Write(_))
    }
}

/// Identifies a job between the request and its result.
pub type SdoJobId = u64;

/// How a job ended.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct SdoJobResult {
    pub id: SdoJobId,
    pub node: u8,
    pub index: u16,
    pub sub: u8,
    pub write: bool,
    pub ok: bool,
    /// The value read (empty for writes and failures).
    pub data: Vec<u8>,
    /// 0 when `ok`; else the CiA 301 abort code (the node's, or the one the
    /// bridge sent: 0x05040000 for no answer).
    pub abort_code: u32,
    /// What happened, the abort code decoded.
    pub message: String,
}

impl SdoJobResult {
    pub(super) fn of(id: SdoJobId, job: &SdoJob, end: TransferEnd, timeout_ms: u64) -> Self {
        let (ok, data, abort_code, message) = match end {
            TransferEnd::Done(data) => {
                let message = match &job.kind {
                    TransferKind::Read => format!("read {} byte(s)", data.len()),
                    TransferKind::Write(d) => format!("wrote {} byte(s)", d.len()),
                };
                (true, data, 0, message)
            }
            TransferEnd::Aborted { code, by_server } => {
                let who = if by_server {
                    format!("aborted by node {}", job.node)
                } else {
                    "aborted by the bridge".to_string()
                };
                (
                    false,
                    Vec::new(),
                    code,
                    format!("{who}: 0x{code:08X} ({})", abort_description(code)),
                )
            }
            TransferEnd::TimedOut => (
                false,
                Vec::new(),
                abort::TIMEOUT,
                format!(
                    "no answer from node {} within {timeout_ms} ms: 0x{:08X} ({}), sent to the node",
                    job.node,
                    abort::TIMEOUT,
                    abort_description(abort::TIMEOUT)
                ),
            ),
        };
        Self {
            id,
            node: job.node,
            index: job.addr.index,
            sub: job.addr.sub,
            write: job.is_write(),
            ok,
            data,
            abort_code,
            message,
        }
    }
}

/// Why the bridge refuses a job (nothing is sent).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SdoRefusal {
    #[error("SDO is CANopen's; the bridge speaks {0}")]
    NotCanopen(&'static str),
    #[error("node {node} is not one of the bridge's drives ({known})")]
    UnknownNode { node: u8, known: String },
    #[error("nothing to write")]
    Empty,
    #[error("{len} bytes; at most {MAX_TRANSFER_BYTES} per transfer")]
    TooLong { len: usize },
    #[error("{MAX_QUEUED_JOBS} SDO requests are already waiting")]
    Busy,
    #[error(
        "writing {addr} could change motion and an axis of node {node} is in operation enabled (or being enabled, or braking): stop the robot first (e-stop)"
    )]
    ChangesMotion { node: u8, addr: ObjectAddr },
}

impl SdoRefusal {
    /// The CiA 301 abort code that says the same (for answers that carry one).
    pub fn abort_code(&self) -> u32 {
        match self {
            SdoRefusal::NotCanopen(_) | SdoRefusal::UnknownNode { .. } => abort::GENERAL,
            SdoRefusal::Empty => abort::LENGTH_TOO_LOW,
            SdoRefusal::TooLong { .. } => abort::LENGTH_TOO_HIGH,
            SdoRefusal::Busy => abort::RESOURCE_NOT_AVAILABLE,
            SdoRefusal::ChangesMotion { .. } => abort::DEVICE_STATE,
        }
    }

    /// For a protocol without SDO.
    pub fn not_canopen(kind: ProtocolKind) -> Self {
        SdoRefusal::NotCanopen(kind.name())
    }
}

/// Whether writing object `index` could change how the drive moves: every
/// index but the communication objects (0x1000–0x1FFF) that do not carry
/// the bridge's control. Refused there while the drive is powered:
/// 0x1005–0x1007 (SYNC), 0x1010–0x1011 (store / restore: restoring the
/// defaults drops the mapping and heartbeats), 0x1016–0x1017 (heartbeats),
/// 0x1029 (the reaction to communication errors), 0x1400–0x1BFF (PDOs);
/// 0x2000–0x5FFF (manufacturer objects, whose meaning the bridge cannot
/// know: Roboteq's motor commands live there); 0x6000–0x9FFF (the device
/// profile: controlword, modes, targets, ramps, limits); and the rest.
pub fn changes_motion(index: u16) -> bool {
    match index {
        0x1005..=0x1007 | 0x1010..=0x1011 | 0x1016..=0x1017 | 0x1029 | 0x1400..=0x1BFF => true,
        0x1000..=0x1FFF => false,
        _ => true,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn which_objects_change_motion() {
        for i in [
            0x6040u16, 0x60FF, 0x6083, 0x6840, 0x68FF, 0x6060, 0x2000, 0x5FFF, 0x1400, 0x1A03, 0x1017, 0x1016, 0x1010,
            0x1011, 0x1005, 0x1029, 0xA000, 0x0005,
        ] {
            assert!(changes_motion(i), "0x{i:04X}");
        }
        for i in [0x1000u16, 0x1003, 0x1008, 0x1014, 0x1018, 0x1C00, 0x1FFF] {
            assert!(!changes_motion(i), "0x{i:04X}");
        }
    }

    #[test]
    fn results_name_the_abort() {
        let job = SdoJob::write(1, 0x6883, 0, vec![1, 0, 0, 0]);
        let r = SdoJobResult::of(
            7,
            &job,
            TransferEnd::Aborted {
                code: 0x0609_0031,
                by_server: true,
            },
            200,
        );
        assert_eq!(
            (r.ok, r.abort_code, r.message.as_str(), r.write, r.index),
            (
                false,
                0x0609_0031,
                "aborted by node 1: 0x06090031 (value of parameter written too high)",
                true,
                0x6883
            )
        );
        let r = SdoJobResult::of(8, &SdoJob::read(1, 0x1008, 0), TransferEnd::TimedOut, 200);
        assert_eq!(r.abort_code, 0x0504_0000);
        assert!(r
            .message
            .starts_with("no answer from node 1 within 200 ms: 0x05040000 (SDO protocol timed out)"));
        let r = SdoJobResult::of(9, &SdoJob::read(1, 0x1008, 0), TransferEnd::Done(b"abc".to_vec()), 200);
        assert_eq!((r.ok, r.data.as_slice(), r.abort_code), (true, &b"abc"[..], 0));
        assert_eq!(
            SdoRefusal::ChangesMotion {
                node: 1,
                addr: ObjectAddr::new(0x6883, 0)
            }
            .abort_code(),
            0x0800_0022
        );
        assert_eq!(SdoRefusal::Busy.abort_code(), 0x060A_0023);
    }
}
