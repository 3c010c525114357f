//! [`CanBus`] on a Linux SocketCAN interface: the only file that imports
//! `socketcan`.
//!
//! The socket is non-blocking: a send never blocks the control loop. A full
//! kernel queue shows up as ENOBUFS (qdisc drop) or EAGAIN (socket send
//! buffer) and both map to [`SendError::QueueFull`]. Receiving waits with
//! `poll` in whole milliseconds and sleeps the sub-millisecond rest, so the
//! bridge wakes close to its tx deadline. Kernel error frames are enabled
//! for every class (error filter), and data frames are filtered in the
//! kernel to exactly the drive's ids.

use crate::bus::{BusError, BusEvent, CanBus, CanErrorFrame, CanFrame, RxFilter, SendError};
use socketcan::{
    CanFilter, CanFrame as ScFrame, CanSocket, EmbeddedFrame, ExtendedId, Frame, Id, Socket, SocketOptions, StandardId,
};
use std::io;
use std::time::{Duration, Instant, SystemTime};

/// Linux errno ENOBUFS: the interface's transmit queue dropped the frame.
const ENOBUFS: i32 = 105;
/// `CAN_EFF_FLAG`, `CAN_RTR_FLAG`, and the id masks (linux/can.h).
const EFF_FLAG: u32 = 0x8000_0000;
const RTR_FLAG: u32 = 0x4000_0000;
const SFF_MASK: u32 = 0x7FF;
const EFF_MASK: u32 = 0x1FFF_FFFF;

/// A raw CAN socket bound to one interface.
pub struct SocketCanBus {
    socket: CanSocket,
    interface: String,
}

fn bus_err(what: &str, interface: &str, e: io::Error) -> BusError {
    BusError(format!("{what} `{interface}`: {e}"))
}

impl SocketCanBus {
    /// Opens `interface` (e.g. `vcan0`), non-blocking, with every kernel
    /// error class enabled and, until [`CanBus::set_rx_filters`], all data frames.
    pub fn open(interface: &str) -> Result<Self, BusError> {
        let socket = CanSocket::open(interface).map_err(|e| {
            let hint = match e.raw_os_error() {
                Some(19) => {
                    " (no such interface: create it, e.g. `ip link add vcan0 type vcan && ip link set vcan0 up`; \
                     on a kernel without CAN use tests/vm/run-in-vm.sh)"
                }
                Some(97) => " (this kernel has no CAN support: run inside tests/vm/run-in-vm.sh)",
                _ => "",
            };
            BusError(format!("cannot open CAN interface `{interface}`: {e}{hint}"))
        })?;
        socket
            .set_nonblocking(true)
            .map_err(|e| bus_err("cannot make the socket non-blocking on", interface, e))?;
        socket
            .set_error_filter(crate::bus::err::MASK_ALL)
            .map_err(|e| bus_err("cannot enable error frames on", interface, e))?;
        Ok(Self {
            socket,
            interface: interface.to_string(),
        })
    }

    /// The interface name.
    pub fn interface(&self) -> &str {
        &self.interface
    }

    /// Receive every data frame (a sniffer, for tests).
    pub fn accept_all(&mut self) -> Result<(), BusError> {
        self.socket
            .set_filter_accept_all()
            .map_err(|e| bus_err("cannot set filters on", &self.interface, e))
    }

    /// Sends a kernel-format error frame (tests: on vcan, other sockets
    /// with an error filter receive it as if the controller reported it).
    pub fn send_error_frame(&mut self, e: &CanErrorFrame) -> Result<(), SendError> {
        let f = socketcan::CanErrorFrame::new_error(e.class, &e.data)
            .map_err(|err| SendError::InvalidFrame(format!("error frame: {err}")))?;
        self.socket.write_frame(&f).map_err(map_send_error)
    }

    /// Switches this socket to kernel receive timestamps for
    /// [`recv_timestamped`](Self::recv_timestamped) (sniffers in tests:
    /// the time a frame reached the socket, free of the reader's scheduling).
    /// Reads on this socket then block up to their timeout.
    pub fn enable_kernel_timestamps(&mut self) -> Result<(), BusError> {
        self.socket
            .set_recv_timestamp(true)
            .and_then(|_| self.socket.set_nonblocking(false))
            .map_err(|e| bus_err("cannot enable timestamps on", &self.interface, e))
    }

    /// The next frame with the kernel's receive time (wall clock), waiting
    /// at most `timeout` (at least 1 ms). Needs [`enable_kernel_timestamps`](Self::enable_kernel_timestamps).
    pub fn recv_timestamped(&mut self, timeout: Duration) -> Result<Option<(BusEvent, SystemTime)>, BusError> {
        self.socket
            .set_read_timeout(timeout.max(Duration::from_millis(1)))
            .map_err(|e| bus_err("cannot set a timeout on", &self.interface, e))?;
        match self.socket.read_frame_with_timestamp() {
            Ok((f, t)) => Ok(Self::convert(f).map(|ev| (ev, t))),
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut | io::ErrorKind::Interrupted
                ) =>
            {
                Ok(None)
            }
            Err(e) => Err(bus_err("receive on", &self.interface, e)),
        }
    }

    fn convert(f: ScFrame) -> Option<BusEvent> {
        match f {
            ScFrame::Data(d) => {
                let mut data = [0u8; 8];
                let payload = d.data();
                let n = payload.len().min(8);
                data[..n].copy_from_slice(&payload[..n]);
                Some(BusEvent::Frame(CanFrame {
                    id: d.raw_id(),
                    extended: d.is_extended(),
                    data,
                    len: n as u8,
                }))
            }
            // Remote frames carry nothing a drive protocol here uses.
            ScFrame::Remote(_) => None,
            ScFrame::Error(e) => {
                let mut data = [0u8; 8];
                let payload = e.data();
                let n = payload.len().min(8);
                data[..n].copy_from_slice(&payload[..n]);
                Some(BusEvent::Error(CanErrorFrame {
                    class: e.error_bits(),
                    data,
                }))
            }
        }
    }
}

fn map_send_error(e: io::Error) -> SendError {
    if e.raw_os_error() == Some(ENOBUFS) || e.kind() == io::ErrorKind::WouldBlock {
        SendError::QueueFull
    } else {
        SendError::Failed(BusError(format!("send: {e}")))
    }
}

impl CanBus for SocketCanBus {
    fn set_rx_filters(&mut self, filters: &[RxFilter]) -> Result<(), BusError> {
        let r = if filters.is_empty() {
            self.socket.set_filter_drop_all()
        } else {
            let fs: Vec<CanFilter> = filters
                .iter()
                .map(|f| {
                    // Match id, id format, and data (not remote) frames only.
                    if f.extended {
                        CanFilter::new(f.id | EFF_FLAG, EFF_MASK | EFF_FLAG | RTR_FLAG)
                    } else {
                        CanFilter::new(f.id, SFF_MASK | EFF_FLAG | RTR_FLAG)
                    }
                })
                .collect();
            self.socket.set_filters(&fs)
        };
        r.map_err(|e| bus_err("cannot set filters on", &self.interface, e))
    }

    fn send(&mut self, frame: &CanFrame) -> Result<(), SendError> {
        if !frame.is_valid() {
            return Err(SendError::InvalidFrame(format!("{frame:?}")));
        }
        let id: Id = if frame.extended {
            ExtendedId::new(frame.id).map(Id::from)
        } else {
            StandardId::new(frame.id as u16).map(Id::from)
        }
        .ok_or_else(|| SendError::InvalidFrame(format!("{frame:?}")))?;
        let f = ScFrame::new(id, frame.payload()).ok_or_else(|| SendError::InvalidFrame(format!("{frame:?}")))?;
        self.socket.write_frame(&f).map_err(map_send_error)
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<BusEvent>, BusError> {
        let deadline = Instant::now() + timeout;
        loop {
            match self.socket.read_frame() {
                Ok(f) => {
                    if let Some(ev) = Self::convert(f) {
                        return Ok(Some(ev));
                    }
                    continue;
                }
                Err(e) if e.kind() == io::ErrorKind::WouldBlock || e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(bus_err("receive on", &self.interface, e)),
            }
            let rem = deadline.saturating_duration_since(Instant::now());
            if rem.is_zero() {
                return Ok(None);
            }
            if rem >= Duration::from_millis(1) {
                // poll() takes whole milliseconds: wait the floor, then loop.
                let ms = Duration::from_millis(rem.as_millis() as u64);
                match self.socket.read_frame_timeout(ms) {
                    Ok(f) => {
                        if let Some(ev) = Self::convert(f) {
                            return Ok(Some(ev));
                        }
                    }
                    Err(e)
                        if matches!(
                            e.kind(),
                            io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted
                        ) => {}
                    Err(e) => return Err(bus_err("receive on", &self.interface, e)),
                }
            } else {
                std::thread::sleep(rem);
            }
        }
    }
}
