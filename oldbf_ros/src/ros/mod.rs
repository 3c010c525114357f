//! The ROS 1 adapters (feature `ros`): thin glue between rosrust topics,
//! services and parameters and the pure core. Nothing here decides anything
//! about safety; it converts, times and publishes.

pub mod carmen_play;
pub mod convert;
pub mod diagnostics;
pub mod leave_master;
pub mod lifecycle;
pub mod logging;
pub mod markers;
pub mod msg;
pub mod pacer;
pub mod params;
pub mod reconfigure;
pub mod safety_node;
pub mod sim_node;

use std::borrow::Cow;

/// A rosrust call (advertise, subscribe, serve, publish) that failed: what
/// the node was doing, and rosrust's error.
#[derive(Debug, thiserror::Error)]
#[error("{what}: {source}")]
pub struct RosError {
    /// `advertising ~state`, `subscribing to scan`, …
    pub what: Cow<'static, str>,
    /// Boxed: rosrust's error is large, and it is the rare path.
    #[source]
    pub source: Box<rosrust::error::Error>,
}

impl RosError {
    /// For `map_err`: `.map_err(RosError::doing("advertising ~state"))`.
    pub fn doing(what: impl Into<Cow<'static, str>>) -> impl FnOnce(rosrust::error::Error) -> RosError {
        let what = what.into();
        move |source| RosError {
            what,
            source: Box::new(source),
        }
    }
}

/// Drops `old` (a second subscription to the same topic would share its dead
/// connection), then subscribes again; a failure is logged, not fatal.
pub fn resubscribe(
    old: Option<rosrust::Subscriber>,
    subscribe: &dyn Fn() -> Result<rosrust::Subscriber, RosError>,
) -> Option<rosrust::Subscriber> {
    drop(old);
    subscribe().inspect_err(|e| log::warn!("{e}; trying again later")).ok()
}
