//! Starting and stopping a node the way ROS users expect: no master
//! reachable → a clear error and a retry (never a panic); SIGINT/SIGTERM →
//! the node's own clean-up (e.g. a last zero command), then exit 0.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

/// Set when SIGINT or SIGTERM arrives.
#[derive(Clone)]
pub struct StopFlag(Arc<AtomicBool>);

impl StopFlag {
    pub fn is_set(&self) -> bool {
        self.0.load(Ordering::SeqCst)
    }
}

/// Installs the SIGINT/SIGTERM handler (rosrust's own is not used, so the
/// node can still publish after the signal).
pub fn install_signal_handler() -> StopFlag {
    let flag = StopFlag(Arc::new(AtomicBool::new(false)));
    let f = flag.0.clone();
    if let Err(e) = ctrlc::set_handler(move || f.store(true, Ordering::SeqCst)) {
        log::error!("cannot install the SIGINT/SIGTERM handler: {e}");
    }
    flag
}

/// The node name: roslaunch's `__name:=` if given (rosrust ignores it), else `default`.
pub fn node_name(default: &str) -> String {
    std::env::args()
        .find_map(|a| a.strip_prefix("__name:=").map(String::from))
        .unwrap_or_else(|| default.into())
}

/// Connects to the master, retrying every second with a clear message until
/// it answers. Returns false if a stop signal arrived first.
pub fn connect(name: &str, stop: &StopFlag) -> bool {
    let master =
        std::env::var("ROS_MASTER_URI").unwrap_or_else(|_| "http://localhost:11311/ (ROS_MASTER_URI unset)".into());
    let mut attempt = 0u32;
    loop {
        match rosrust::try_init_with_options(name, false) {
            Ok(()) => {
                if attempt > 0 {
                    log::info!("connected to the ROS master at {master}");
                }
                return true;
            }
            Err(e) => {
                if attempt % 10 == 0 {
                    log::error!("{name}: cannot reach the ROS master at {master} ({e}); retrying every 1 s");
                }
                attempt += 1;
            }
        }
        for _ in 0..10 {
            if stop.is_set() {
                return false;
            }
            std::thread::sleep(Duration::from_millis(100));
        }
    }
}

/// rosrust's clock (ROS time, or /clock with use_sim_time) in seconds.
pub fn now_s() -> f64 {
    rosrust::now().seconds()
}

/// What [`MasterWatch`] saw of the ROS master.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MasterHealth {
    Up,
    /// Not answering: topics already connected keep flowing peer to peer.
    Lost,
    /// Answering as a new run (its `/run_id` changed): this node's
    /// registrations are gone and rosrust cannot renew them.
    Restarted,
}

/// Watches the master once a second from a thread of its own: reports its
/// loss and return in the log, and flags a restart so the node can leave
/// cleanly (stopping the robot) instead of running on unregistered.
#[derive(Clone)]
pub struct MasterWatch(Arc<std::sync::atomic::AtomicU8>);

impl MasterWatch {
    /// Starts the watch (the node must be connected). A master that answers
    /// but lists none of this node's publications, subscriptions or services
    /// is a new one: registrations live only in the master that took them.
    pub fn start(node: &str) -> Self {
        let flag = Arc::new(std::sync::atomic::AtomicU8::new(0));
        let f = flag.clone();
        let node = node.to_string();
        std::thread::spawn(move || {
            let master = std::env::var("ROS_MASTER_URI").unwrap_or_default();
            let mut lost_since: Option<std::time::Instant> = None;
            loop {
                std::thread::sleep(Duration::from_secs(1));
                let state = rosrust::state();
                let known = state.as_ref().ok().map(|s| {
                    [&s.publishers, &s.subscribers, &s.services]
                        .iter()
                        .any(|list| list.iter().any(|t| t.connections.iter().any(|c| c == &node)))
                });
                match known {
                    None => {
                        if lost_since.is_none() {
                            log::error!(
                                "{node}: lost the ROS master at {master}; connected topics keep flowing, new ones cannot connect; waiting for it"
                            );
                            lost_since = Some(std::time::Instant::now());
                            f.store(1, Ordering::SeqCst);
                        }
                    }
                    Some(false) => {
                        log::error!(
                            "{node}: the ROS master at {master} restarted (run_id changed: it no longer knows this node): registrations are gone and cannot be renewed; shutting down (start the nodes again)"
                        );
                        f.store(2, Ordering::SeqCst);
                        return;
                    }
                    Some(true) => {
                        if let Some(t) = lost_since.take() {
                            log::info!(
                                "{node}: the ROS master at {master} is back (same run) after {:.1} s",
                                t.elapsed().as_secs_f64()
                            );
                            f.store(0, Ordering::SeqCst);
                        }
                    }
                }
            }
        });
        Self(flag)
    }

    pub fn health(&self) -> MasterHealth {
        match self.0.load(Ordering::SeqCst) {
            0 => MasterHealth::Up,
            1 => MasterHealth::Lost,
            _ => MasterHealth::Restarted,
        }
    }
}
