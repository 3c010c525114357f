//! can_bridge: a velocity command (twist) → differential-drive wheel speeds
//! → CAN frames for a motor drive, with the safety rules of issue 4:
//! periodic transmission, command watchdog, latched e-stop, drive heartbeat
//! and feedback monitoring, bus error handling, bounded transmit queue, and
//! odometry from wheel feedback.
//!
//! The core is pure: no socketcan import outside `socketcan_bus.rs`, and
//! time is an argument; nothing in the bridge sleeps. Adapters (the
//! `can_bridge_cli` binary, the ROS node) own a [`bridge::Bridge`], feed it
//! commands and call [`bridge::Bridge::spin_once`] in a loop, waiting where
//! it says ([`bridge::Spin`], [`bridge::ShutdownProgress`]).
//!
//! Features: `socketcan` (the kernel adapter), `cli` (what only the
//! binaries need: clap, env_logger, ctrlc, anyhow, serde_json), `ros` (the
//! ROS node); `socketcan` and `cli` are on by default. A library user takes
//! `default-features = false, features = ["socketcan"]`.
//!
//! One concept per file:
//! [`kinematics`], [`limits`], [`protocol`] (trait, [`protocol::generic`],
//! [`protocol::odrive`], [`protocol::cia402`]), [`bus`] (frames, the
//! [`bus::CanBus`] trait), [`fake_bus`], `socketcan_bus` (feature
//! `socketcan`), [`tx_queue`], [`bridge`] (and its parts:
//! [`bridge::stop_reasons`], [`bridge::drive_supervision`],
//! [`bridge::bus_health`], [`bridge::shutdown`], [`bridge::events`]),
//! [`odometry`], [`config`] (checked with the shared [`oldbf::config`]),
//! [`diagnostics`], [`virtual_drive`], [`script`] (the CLI's command
//! scripts), [`time`].

#![forbid(unsafe_code)]

pub mod bridge;
pub mod bus;
pub mod config;
pub mod diagnostics;
pub mod fake_bus;
pub mod kinematics;
pub mod limits;
pub mod odometry;
pub mod protocol;
#[cfg(feature = "ros")]
pub mod ros_msgs;
#[cfg(feature = "ros")]
pub mod ros_node;
pub mod script;
#[cfg(feature = "socketcan")]
pub mod socketcan_bus;
pub mod time;
pub mod tx_queue;
pub mod virtual_drive;

pub use bridge::Bridge;
pub use bus::{BusEvent, CanBus, CanErrorFrame, CanFrame, RxFilter, SendError};
pub use config::BridgeConfig;
pub use kinematics::{DiffDrive, MotorSpeeds, Twist, Wheel, WheelSpeeds};
pub use protocol::{Protocol, ProtocolKind};
pub use time::{Clock, ManualClock, MonotonicClock, Timestamp};
