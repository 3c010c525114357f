//! The virtual drive on a real bus, in a thread: the one place it waits
//! (on the bus, and briefly after a bus error). The drive itself is pure.

use super::VirtualDrive;
use crate::bus::{BusError, BusEvent, CanBus, SendError};
use crate::time::{Clock, Timestamp};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::Duration;

/// Runs `drive` on `bus` until `stop` is set or the drive exits (fault `exit`).
/// The drive is shared so tests can inject faults and read its state.
pub fn run_virtual_drive<B: CanBus>(
    drive: &Mutex<VirtualDrive>,
    bus: &mut B,
    clock: &dyn Clock,
    stop: &AtomicBool,
) -> Result<(), BusError> {
    let lock = || drive.lock().unwrap_or_else(|e| e.into_inner());
    bus.set_rx_filters(&lock().rx_filters())?;
    let mut out = Vec::new();
    let mut last_error_log: Option<Timestamp> = None;
    while !stop.load(Ordering::Relaxed) {
        let now = clock.now();
        let deadline = {
            let mut d = lock();
            d.step(now, &mut out);
            if d.exited() {
                return Ok(());
            }
            d.next_deadline()
        };
        for f in out.drain(..) {
            match bus.send(&f) {
                Ok(()) | Err(SendError::QueueFull) => {}
                Err(e) => {
                    if last_error_log.is_none_or(|t| now - t > Duration::from_secs(1)) {
                        log::warn!("virtual drive: {e}");
                        last_error_log = Some(now);
                    }
                }
            }
        }
        let wait = (deadline - clock.now()).min(Duration::from_millis(20));
        match bus.recv(wait) {
            Ok(Some(BusEvent::Frame(f))) => lock().handle_frame(&f, clock.now()),
            Ok(_) => {}
            Err(e) => {
                if last_error_log.is_none_or(|t| now - t > Duration::from_secs(1)) {
                    log::warn!("virtual drive: {e}");
                    last_error_log = Some(now);
                }
                // A bus that fails at once (interface down): do not spin.
                std::thread::sleep(wait.min(Duration::from_millis(5)));
            }
        }
    }
    Ok(())
}
