//! The bridge's bounded event queue: every event is logged and kept for
//! [`Bridge::drain_events`](super::Bridge::drain_events); when nobody drains,
//! the oldest are dropped (counted), so memory stays bounded.

use crate::diagnostics::{BridgeEvent, TimedEvent};
use crate::time::Timestamp;
use std::collections::VecDeque;

/// Events kept for [`Bridge::drain_events`](super::Bridge::drain_events); older ones are dropped (counted).
pub const EVENT_QUEUE_CAPACITY: usize = 1024;

/// Timed events, oldest first, at most [`EVENT_QUEUE_CAPACITY`].
#[derive(Debug, Default)]
pub(crate) struct EventLog {
    events: VecDeque<TimedEvent>,
    dropped: u64,
}

impl EventLog {
    /// Empty.
    pub(crate) fn new() -> Self {
        Self::default()
    }

    /// Logs `event` (faults as warnings, chatter as debug) and keeps it.
    pub(crate) fn push(&mut self, now: Timestamp, event: BridgeEvent) {
        match &event {
            BridgeEvent::StateChanged { .. } | BridgeEvent::RxInvalid { .. } | BridgeEvent::TxDropped { .. } => {
                log::debug!("{event:?}")
            }
            BridgeEvent::CommandRejected { .. }
            | BridgeEvent::DriveFaultLatched { .. }
            | BridgeEvent::HeartbeatLostLatched { .. }
            | BridgeEvent::BusError { .. }
            | BridgeEvent::EstopLatched
            | BridgeEvent::DriveReport { .. }
            | BridgeEvent::TxQueueFull => log::warn!("{event:?}"),
            _ => log::info!("{event:?}"),
        }
        if self.events.len() >= EVENT_QUEUE_CAPACITY {
            self.events.pop_front();
            self.dropped += 1;
        }
        self.events.push_back(TimedEvent {
            t_s: now.as_secs_f64(),
            event,
        });
    }

    /// Takes every event, oldest first.
    pub(crate) fn drain(&mut self) -> Vec<TimedEvent> {
        self.events.drain(..).collect()
    }

    /// Events dropped because the queue was full.
    pub(crate) fn dropped(&self) -> u64 {
        self.dropped
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_order_and_drops_the_oldest_when_full() {
        let mut log = EventLog::new();
        for i in 0..EVENT_QUEUE_CAPACITY + 3 {
            log.push(Timestamp::from_secs_f64(i as f64), BridgeEvent::Reset);
        }
        assert_eq!(log.dropped(), 3);
        let events = log.drain();
        assert_eq!(events.len(), EVENT_QUEUE_CAPACITY);
        assert_eq!(events[0].t_s, 3.0, "the three oldest went");
        assert!(events.windows(2).all(|w| w[0].t_s < w[1].t_s));
        assert!(log.drain().is_empty(), "drained");
        assert_eq!(log.dropped(), 3, "the count stays");
    }
}
