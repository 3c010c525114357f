//! An in-memory CAN bus for tests on any machine.
//!
//! Endpoints made with [`FakeBus::new`] and [`FakeBus::connect`] share one
//! wire: a frame sent by one is delivered to every other endpoint whose
//! receive filters accept it (a sender does not receive its own frames, as
//! with SocketCAN's default). Tests inject received frames and error frames,
//! read what was sent, and make sends fail (full queue, interface down).
//! `recv` never waits: time is simulated by the caller.

use crate::bus::{BusError, BusEvent, CanBus, CanErrorFrame, CanFrame, RxFilter, SendError};
use std::collections::VecDeque;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

/// Frames an endpoint buffers before the oldest is dropped (like a full socket receive buffer).
pub const FAKE_RX_CAPACITY: usize = 4096;

#[derive(Default)]
struct Endpoint {
    rx: VecDeque<BusEvent>,
    rx_dropped: u64,
    filters: Option<Vec<RxFilter>>,
    sent: Vec<CanFrame>,
    /// Every send fails with this while set.
    send_error: Option<SendError>,
    /// The next sends fail with these, in order.
    fail_next: VecDeque<SendError>,
    recv_error: Option<BusError>,
    send_attempts: u64,
}

impl Endpoint {
    fn accepts(&self, frame: &CanFrame) -> bool {
        match &self.filters {
            None => true,
            Some(fs) => fs.iter().any(|f| f.matches(frame)),
        }
    }

    fn deliver(&mut self, ev: BusEvent) {
        if self.rx.len() >= FAKE_RX_CAPACITY {
            self.rx.pop_front();
            self.rx_dropped += 1;
        }
        self.rx.push_back(ev);
    }
}

#[derive(Default)]
struct Wire {
    endpoints: Vec<Endpoint>,
    /// Every frame that went on the wire: (sender endpoint, frame).
    log: Vec<(usize, CanFrame)>,
}

/// One endpoint on an in-memory wire. Clones share the endpoint.
#[derive(Clone)]
pub struct FakeBus {
    wire: Arc<Mutex<Wire>>,
    index: usize,
}

impl Default for FakeBus {
    fn default() -> Self {
        Self::new()
    }
}

impl FakeBus {
    /// A new wire with this one endpoint.
    pub fn new() -> Self {
        let wire = Wire {
            endpoints: vec![Endpoint::default()],
            log: Vec::new(),
        };
        Self {
            wire: Arc::new(Mutex::new(wire)),
            index: 0,
        }
    }

    /// Another endpoint on the same wire.
    pub fn connect(&self) -> FakeBus {
        let mut w = self.lock();
        w.endpoints.push(Endpoint::default());
        FakeBus {
            wire: self.wire.clone(),
            index: w.endpoints.len() - 1,
        }
    }

    fn lock(&self) -> MutexGuard<'_, Wire> {
        // A panicking test thread must not hide the wire from the others.
        self.wire.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Frames this endpoint sent successfully, oldest first.
    pub fn sent(&self) -> Vec<CanFrame> {
        self.lock().endpoints[self.index].sent.clone()
    }

    /// Like [`sent`](Self::sent), and forgets them.
    pub fn take_sent(&self) -> Vec<CanFrame> {
        std::mem::take(&mut self.lock().endpoints[self.index].sent)
    }

    /// Every frame on the wire, from any endpoint, oldest first.
    pub fn wire_log(&self) -> Vec<CanFrame> {
        self.lock().log.iter().map(|(_, f)| *f).collect()
    }

    /// How many sends were attempted on this endpoint (successful or not).
    pub fn send_attempts(&self) -> u64 {
        self.lock().endpoints[self.index].send_attempts
    }

    /// Delivers a frame to this endpoint as if another node sent it (the
    /// endpoint's filters apply, as in the kernel).
    pub fn inject_frame(&self, frame: CanFrame) {
        let mut w = self.lock();
        let ep = &mut w.endpoints[self.index];
        if ep.accepts(&frame) {
            ep.deliver(BusEvent::Frame(frame));
        }
    }

    /// Delivers an error frame to this endpoint.
    pub fn inject_error(&self, e: CanErrorFrame) {
        self.lock().endpoints[self.index].deliver(BusEvent::Error(e));
    }

    /// Makes every send fail with `e` until called with `None`.
    pub fn set_send_error(&self, e: Option<SendError>) {
        self.lock().endpoints[self.index].send_error = e;
    }

    /// Makes the next `n` sends fail with `e` (then they work again).
    pub fn fail_next_sends(&self, n: usize, e: SendError) {
        let mut w = self.lock();
        let ep = &mut w.endpoints[self.index];
        ep.fail_next.extend(std::iter::repeat_n(e, n));
    }

    /// Makes every receive fail with `e` until called with `None`.
    pub fn set_recv_error(&self, e: Option<BusError>) {
        self.lock().endpoints[self.index].recv_error = e;
    }

    /// The filters last set on this endpoint (`None`: never set, accepts everything).
    pub fn rx_filters(&self) -> Option<Vec<RxFilter>> {
        self.lock().endpoints[self.index].filters.clone()
    }

    /// Events waiting to be received by this endpoint.
    pub fn pending_rx(&self) -> usize {
        self.lock().endpoints[self.index].rx.len()
    }
}

impl CanBus for FakeBus {
    fn set_rx_filters(&mut self, filters: &[RxFilter]) -> Result<(), BusError> {
        let mut w = self.lock();
        let ep = &mut w.endpoints[self.index];
        ep.filters = Some(filters.to_vec());
        // The kernel applies a new filter to frames not yet queued; drop
        // queued frames the new filter would reject, to be strict.
        let keep: VecDeque<BusEvent> = ep
            .rx
            .drain(..)
            .filter(|ev| match ev {
                BusEvent::Frame(f) => filters.iter().any(|x| x.matches(f)),
                BusEvent::Error(_) => true,
            })
            .collect();
        ep.rx = keep;
        Ok(())
    }

    fn send(&mut self, frame: &CanFrame) -> Result<(), SendError> {
        let mut w = self.lock();
        let me = self.index;
        {
            let ep = &mut w.endpoints[me];
            ep.send_attempts += 1;
            if !frame.is_valid() {
                return Err(SendError::InvalidFrame(format!("{frame:?}")));
            }
            if let Some(e) = ep.fail_next.pop_front() {
                return Err(e);
            }
            if let Some(e) = &ep.send_error {
                return Err(e.clone());
            }
            ep.sent.push(*frame);
        }
        w.log.push((me, *frame));
        for (i, ep) in w.endpoints.iter_mut().enumerate() {
            if i != me && ep.accepts(frame) {
                ep.deliver(BusEvent::Frame(*frame));
            }
        }
        Ok(())
    }

    fn recv(&mut self, _timeout: Duration) -> Result<Option<BusEvent>, BusError> {
        let mut w = self.lock();
        let ep = &mut w.endpoints[self.index];
        if let Some(e) = &ep.recv_error {
            return Err(e.clone());
        }
        Ok(ep.rx.pop_front())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn f(id: u32) -> CanFrame {
        CanFrame::standard(id, &[id as u8]).unwrap()
    }

    #[test]
    fn frames_reach_other_endpoints_through_their_filters() {
        let mut a = FakeBus::new();
        let mut b = a.connect();
        let mut c = a.connect();
        b.set_rx_filters(&[RxFilter::standard(0x10)]).unwrap();
        a.send(&f(0x10)).unwrap();
        a.send(&f(0x11)).unwrap();
        let got_b: Vec<_> = std::iter::from_fn(|| b.recv(Duration::ZERO).unwrap()).collect();
        assert_eq!(got_b, vec![BusEvent::Frame(f(0x10))]);
        let got_c: Vec<_> = std::iter::from_fn(|| c.recv(Duration::ZERO).unwrap()).collect();
        assert_eq!(got_c.len(), 2, "no filter: everything");
        assert_eq!(a.recv(Duration::ZERO).unwrap(), None, "no own frames");
        assert_eq!(a.sent(), vec![f(0x10), f(0x11)]);
        assert_eq!(c.wire_log().len(), 2);
    }

    #[test]
    fn send_failures_can_be_scripted() {
        let mut a = FakeBus::new();
        a.fail_next_sends(2, SendError::QueueFull);
        assert_eq!(a.send(&f(1)), Err(SendError::QueueFull));
        assert_eq!(a.send(&f(1)), Err(SendError::QueueFull));
        assert_eq!(a.send(&f(1)), Ok(()));
        a.set_send_error(Some(SendError::Failed(BusError("down".into()))));
        assert!(a.send(&f(1)).is_err());
        a.set_send_error(None);
        assert!(a.send(&f(1)).is_ok());
        assert_eq!(a.send_attempts(), 5);
        assert_eq!(a.sent().len(), 2);
        let bad = CanFrame { len: 9, ..f(1) };
        assert!(matches!(a.send(&bad), Err(SendError::InvalidFrame(_))));
    }

    #[test]
    fn injected_frames_pass_the_filter_and_errors_always_do() {
        let mut a = FakeBus::new();
        a.set_rx_filters(&[RxFilter::standard(5)]).unwrap();
        a.inject_frame(f(6));
        a.inject_frame(f(5));
        a.inject_error(CanErrorFrame::bus_off());
        assert_eq!(a.recv(Duration::ZERO).unwrap(), Some(BusEvent::Frame(f(5))));
        assert_eq!(
            a.recv(Duration::ZERO).unwrap(),
            Some(BusEvent::Error(CanErrorFrame::bus_off()))
        );
        assert_eq!(a.recv(Duration::ZERO).unwrap(), None);
        a.set_recv_error(Some(BusError("down".into())));
        assert!(a.recv(Duration::ZERO).is_err());
    }
}
