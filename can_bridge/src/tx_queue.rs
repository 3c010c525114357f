//! The bridge's bounded transmit queue.
//!
//! When the kernel's queue is full (ENOBUFS: a real controller that cannot
//! get frames out), the frame at the head is retried a few times, at least a
//! millisecond apart, then dropped together with the rest of its group: the
//! rest of a setpoint pair (never one wheel's new speed with the other's
//! old one), or the rest of a start-up sequence (a drive is never asked for
//! closed loop after a lost zero setpoint). A new period's setpoints replace
//! any setpoints still waiting: a stale speed is never sent late. The queue
//! never holds more than [`TX_QUEUE_CAPACITY`].

use crate::bus::{BusError, CanBus, CanFrame, SendError};
use crate::time::Timestamp;
use std::collections::VecDeque;
use std::time::Duration;

/// Most frames waiting at once.
pub const TX_QUEUE_CAPACITY: usize = 16;
/// Sends tried per frame before it is dropped.
pub const TX_MAX_ATTEMPTS: u8 = 3;
/// Wait between attempts on a full kernel queue.
pub const TX_RETRY_INTERVAL: Duration = Duration::from_millis(1);

/// What a queued frame is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TxKind {
    /// Periodic setpoints: superseded by the next period's.
    Setpoint,
    /// Part of an ordered sequence (start-up): all or nothing after it.
    Control,
}

#[derive(Clone, Copy, Debug)]
struct Pending {
    frame: CanFrame,
    kind: TxKind,
    group: u64,
    attempts: u8,
    not_before: Timestamp,
}

/// What a push did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PushReport {
    /// Older setpoints removed because fresh ones came.
    pub dropped_stale: u32,
    /// Frames dropped because the queue was at capacity.
    pub dropped_overflow: u32,
}

/// What a flush did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct FlushReport {
    pub sent: u32,
    /// At least one send found the kernel queue full.
    pub queue_full: bool,
    /// Frames dropped after [`TX_MAX_ATTEMPTS`] (with the rest of their group).
    pub dropped_after_retries: u32,
    /// A send failed for another reason (the frame was dropped).
    pub failed: Option<BusError>,
}

/// Bounded FIFO of frames to send.
#[derive(Clone, Debug, Default)]
pub struct TxQueue {
    items: VecDeque<Pending>,
    next_group: u64,
}

impl TxQueue {
    /// Empty.
    pub fn new() -> Self {
        Self::default()
    }

    /// Frames waiting.
    pub fn len(&self) -> usize {
        self.items.len()
    }

    /// Nothing waiting.
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// Drops everything (e-stop: nothing queued before it matters).
    pub fn clear(&mut self) -> usize {
        let n = self.items.len();
        self.items.clear();
        n
    }

    /// When the head may be tried next (`None` if empty).
    pub fn next_attempt(&self) -> Option<Timestamp> {
        self.items.front().map(|p| p.not_before)
    }

    /// Appends `frames` as one group. Setpoints first remove older waiting setpoints.
    pub fn push(&mut self, frames: &[CanFrame], kind: TxKind, now: Timestamp) -> PushReport {
        let mut r = PushReport::default();
        if kind == TxKind::Setpoint {
            let before = self.items.len();
            self.items.retain(|p| p.kind != TxKind::Setpoint);
            r.dropped_stale = (before - self.items.len()) as u32;
        }
        let group = self.next_group;
        self.next_group += 1;
        for (i, f) in frames.iter().enumerate() {
            if self.items.len() >= TX_QUEUE_CAPACITY {
                // Make room by dropping the oldest setpoint; if there is none,
                // drop this group's remaining frames (never grow).
                if let Some(pos) = self
                    .items
                    .iter()
                    .position(|p| p.kind == TxKind::Setpoint && p.group != group)
                {
                    self.items.remove(pos);
                    r.dropped_overflow += 1;
                } else {
                    let rest = (frames.len() - i) as u32;
                    r.dropped_overflow += rest;
                    if kind == TxKind::Control {
                        let before = self.items.len();
                        self.items.retain(|p| p.group != group);
                        r.dropped_overflow += (before - self.items.len()) as u32;
                    }
                    break;
                }
            }
            self.items.push_back(Pending {
                frame: *f,
                kind,
                group,
                attempts: 0,
                not_before: now,
            });
        }
        r
    }

    /// Sends what is due, in order, stopping at the first full-queue or error.
    pub fn flush<B: CanBus + ?Sized>(&mut self, bus: &mut B, now: Timestamp) -> FlushReport {
        let mut r = FlushReport::default();
        while let Some(head) = self.items.front_mut() {
            if head.not_before > now {
                break;
            }
            match bus.send(&head.frame) {
                Ok(()) => {
                    self.items.pop_front();
                    r.sent += 1;
                }
                Err(SendError::QueueFull) => {
                    r.queue_full = true;
                    head.attempts += 1;
                    if head.attempts >= TX_MAX_ATTEMPTS {
                        r.dropped_after_retries += self.drop_head();
                    } else {
                        head.not_before = now + TX_RETRY_INTERVAL;
                    }
                    break;
                }
                Err(SendError::InvalidFrame(msg)) => {
                    // A bug upstream; never retried.
                    r.dropped_after_retries += self.drop_head();
                    r.failed = Some(BusError(format!("invalid frame {msg}")));
                }
                Err(SendError::Failed(e)) => {
                    r.dropped_after_retries += self.drop_head();
                    r.failed = Some(e);
                    break;
                }
            }
        }
        r
    }

    /// Removes the head and the rest of its group.
    fn drop_head(&mut self) -> u32 {
        let Some(head) = self.items.pop_front() else {
            return 0;
        };
        let before = self.items.len();
        self.items.retain(|p| p.group != head.group);
        1 + (before - self.items.len()) as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fake_bus::FakeBus;

    fn f(id: u32) -> CanFrame {
        CanFrame::standard(id, &[]).unwrap()
    }

    fn t(ms: u64) -> Timestamp {
        Timestamp::ZERO + Duration::from_millis(ms)
    }

    #[test]
    fn sends_in_order() {
        let mut q = TxQueue::new();
        let mut bus = FakeBus::new();
        q.push(&[f(1), f(2)], TxKind::Control, t(0));
        q.push(&[f(3)], TxKind::Setpoint, t(0));
        let r = q.flush(&mut bus, t(0));
        assert_eq!(r.sent, 3);
        assert_eq!(bus.sent().iter().map(|x| x.id).collect::<Vec<_>>(), [1, 2, 3]);
        assert!(q.is_empty());
    }

    #[test]
    fn full_kernel_queue_bounded_retry_then_drop() {
        let mut q = TxQueue::new();
        let mut bus = FakeBus::new();
        bus.set_send_error(Some(SendError::QueueFull));
        q.push(&[f(1)], TxKind::Setpoint, t(0));
        let r = q.flush(&mut bus, t(0));
        assert!(r.queue_full && r.sent == 0 && r.dropped_after_retries == 0);
        assert_eq!(q.next_attempt(), Some(t(1)), "retry 1 ms later");
        assert_eq!(q.flush(&mut bus, t(0)).sent, 0, "not before the retry time");
        assert_eq!(bus.send_attempts(), 1);
        q.flush(&mut bus, t(1));
        let r = q.flush(&mut bus, t(2));
        assert_eq!(r.dropped_after_retries, 1, "dropped after {TX_MAX_ATTEMPTS} attempts");
        assert_eq!(bus.send_attempts(), u64::from(TX_MAX_ATTEMPTS));
        assert!(q.is_empty());
    }

    #[test]
    fn fresh_setpoints_replace_stale_ones() {
        let mut q = TxQueue::new();
        let mut bus = FakeBus::new();
        bus.set_send_error(Some(SendError::QueueFull));
        q.push(&[f(1), f(2)], TxKind::Setpoint, t(0));
        q.flush(&mut bus, t(0));
        let r = q.push(&[f(11), f(12)], TxKind::Setpoint, t(20));
        assert_eq!(r.dropped_stale, 2);
        bus.set_send_error(None);
        q.flush(&mut bus, t(20));
        assert_eq!(
            bus.sent().iter().map(|x| x.id).collect::<Vec<_>>(),
            [11, 12],
            "only fresh ones"
        );
    }

    #[test]
    fn a_lost_control_frame_drops_the_rest_of_its_sequence() {
        let mut q = TxQueue::new();
        let mut bus = FakeBus::new();
        q.push(&[f(1), f(2), f(3)], TxKind::Control, t(0));
        q.push(&[f(9)], TxKind::Setpoint, t(0));
        bus.fail_next_sends(usize::from(TX_MAX_ATTEMPTS), SendError::QueueFull);
        for ms in 0..5 {
            q.flush(&mut bus, t(ms));
        }
        assert_eq!(
            bus.sent().iter().map(|x| x.id).collect::<Vec<_>>(),
            [9],
            "2 and 3 never sent after 1 was lost"
        );
    }

    #[test]
    fn a_pair_is_dropped_whole() {
        let mut q = TxQueue::new();
        let mut bus = FakeBus::new();
        q.push(&[f(1), f(2)], TxKind::Setpoint, t(0));
        bus.fail_next_sends(usize::from(TX_MAX_ATTEMPTS), SendError::QueueFull);
        for ms in 0..5 {
            q.flush(&mut bus, t(ms));
        }
        assert!(bus.sent().is_empty(), "the right wheel's frame is not sent alone");
    }

    #[test]
    fn never_grows_beyond_capacity() {
        let mut q = TxQueue::new();
        let mut bus = FakeBus::new();
        bus.set_send_error(Some(SendError::QueueFull));
        for i in 0..100 {
            q.push(&[f(i), f(i + 1000)], TxKind::Control, t(i as u64));
            q.push(&[f(2000)], TxKind::Setpoint, t(i as u64));
            q.flush(&mut bus, t(i as u64));
            assert!(q.len() <= TX_QUEUE_CAPACITY);
        }
    }

    #[test]
    fn other_errors_drop_and_report() {
        let mut q = TxQueue::new();
        let mut bus = FakeBus::new();
        bus.set_send_error(Some(SendError::Failed(BusError("ENETDOWN".into()))));
        q.push(&[f(1), f(2)], TxKind::Setpoint, t(0));
        let r = q.flush(&mut bus, t(0));
        assert_eq!(r.failed, Some(BusError("ENETDOWN".into())));
        assert_eq!(r.dropped_after_retries, 2, "the pair goes together");
        assert!(q.is_empty());
    }
}
