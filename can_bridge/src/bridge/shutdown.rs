//! The last frames (zero, then disable), each tried a few times. Time is an
//! argument: between attempts the caller waits, never this code.

use crate::bus::CanBus;
use crate::protocol::FrameBatch;
use crate::time::Timestamp;
use crate::tx_queue::{TX_MAX_ATTEMPTS, TX_RETRY_INTERVAL};

/// Where a shutdown stands after [`Bridge::shutdown`](super::Bridge::shutdown).
#[must_use = "a pending shutdown has frames still to send: call shutdown again at retry_at"]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShutdownProgress {
    /// A frame failed and is to be tried again: call `shutdown` again at or
    /// after `retry_at`.
    Pending {
        /// When the next attempt may go.
        retry_at: Timestamp,
    },
    /// Every frame was tried; `failed` of them could not be sent after
    /// [`TX_MAX_ATTEMPTS`] attempts.
    Done {
        /// Frames given up on.
        failed: usize,
    },
}

/// The shutdown frames in order, each tried up to [`TX_MAX_ATTEMPTS`] times,
/// [`TX_RETRY_INTERVAL`] apart; a frame given up on does not stop the next
/// (the disable still goes out if the zero could not).
#[derive(Debug)]
pub(crate) struct ShutdownSequence {
    frames: FrameBatch,
    next: usize,
    attempts: u8,
    not_before: Timestamp,
    failed: usize,
}

impl ShutdownSequence {
    /// `frames` to send from `now`.
    pub(crate) fn new(frames: FrameBatch, now: Timestamp) -> Self {
        Self {
            frames,
            next: 0,
            attempts: 0,
            not_before: now,
            failed: 0,
        }
    }

    /// Sends what may go at `now`; returns the progress and the frames sent.
    pub(crate) fn step<B: CanBus>(&mut self, bus: &mut B, now: Timestamp) -> (ShutdownProgress, u32) {
        let mut sent = 0;
        while let Some(f) = self.frames.as_slice().get(self.next) {
            if now < self.not_before {
                return (
                    ShutdownProgress::Pending {
                        retry_at: self.not_before,
                    },
                    sent,
                );
            }
            if bus.send(f).is_ok() {
                sent += 1;
                self.next_frame();
            } else {
                self.attempts += 1;
                if self.attempts >= TX_MAX_ATTEMPTS {
                    self.failed += 1;
                    self.next_frame();
                } else {
                    self.not_before = now + TX_RETRY_INTERVAL;
                }
            }
        }
        (ShutdownProgress::Done { failed: self.failed }, sent)
    }

    fn next_frame(&mut self) {
        self.next += 1;
        self.attempts = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bus::{CanFrame, SendError};
    use crate::fake_bus::FakeBus;

    fn frames(n: u32) -> FrameBatch {
        let mut b = FrameBatch::new();
        for id in 0..n {
            b.push(CanFrame::standard(id, &[]).unwrap());
        }
        b
    }

    fn t(us: u64) -> Timestamp {
        Timestamp::ZERO + std::time::Duration::from_micros(us)
    }

    #[test]
    fn a_working_bus_sends_everything_at_once() {
        let mut bus = FakeBus::new();
        let mut s = ShutdownSequence::new(frames(4), t(0));
        assert_eq!(s.step(&mut bus, t(0)), (ShutdownProgress::Done { failed: 0 }, 4));
        let ids: Vec<u32> = bus.sent().iter().map(|f| f.id).collect();
        assert_eq!(ids, [0, 1, 2, 3], "in order");
    }

    #[test]
    fn a_failed_frame_is_retried_after_the_interval_not_before() {
        let mut bus = FakeBus::new();
        bus.fail_next_sends(2, SendError::QueueFull);
        let mut s = ShutdownSequence::new(frames(2), t(0));
        let (p, sent) = s.step(&mut bus, t(0));
        assert_eq!((p, sent), (ShutdownProgress::Pending { retry_at: t(1000) }, 0));
        assert_eq!(bus.send_attempts(), 1);
        let (p, _) = s.step(&mut bus, t(999));
        assert_eq!(p, ShutdownProgress::Pending { retry_at: t(1000) });
        assert_eq!(bus.send_attempts(), 1, "no attempt before retry_at");
        assert_eq!(
            s.step(&mut bus, t(1000)).0,
            ShutdownProgress::Pending { retry_at: t(2000) }
        );
        assert_eq!(s.step(&mut bus, t(2000)), (ShutdownProgress::Done { failed: 0 }, 2));
        assert_eq!(bus.sent().len(), 2, "third attempt of the first frame, then the second");
    }

    #[test]
    fn a_frame_given_up_on_does_not_stop_the_next() {
        let mut bus = FakeBus::new();
        bus.fail_next_sends(usize::from(TX_MAX_ATTEMPTS), SendError::QueueFull);
        let mut s = ShutdownSequence::new(frames(2), t(0));
        let mut now = t(0);
        let done = loop {
            match s.step(&mut bus, now).0 {
                ShutdownProgress::Pending { retry_at } => now = retry_at,
                ShutdownProgress::Done { failed } => break failed,
            }
        };
        assert_eq!(done, 1);
        assert_eq!(bus.send_attempts(), u64::from(TX_MAX_ATTEMPTS) + 1);
        assert_eq!(bus.sent()[0].id, 1, "the second frame went");
        assert_eq!(now, t(2000), "two waits of TX_RETRY_INTERVAL");
        assert_eq!(
            s.step(&mut bus, now).0,
            ShutdownProgress::Done { failed: 1 },
            "stays done"
        );
    }
}
