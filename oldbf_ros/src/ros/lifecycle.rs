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
