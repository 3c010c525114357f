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
    /// Answering as a new process (its PID changed): this node's
    /// registrations are gone and rosrust cannot renew them.
    Restarted,
}

/// Socket timeout of one master probe: short, so a dead master is noticed
/// within about a second (rosrust's own master calls block while it is down).
pub const MASTER_PROBE_TIMEOUT: Duration = Duration::from_millis(700);

/// `host:port` of an `http://host:port/` master URI.
pub fn master_addr(uri: &str) -> Option<String> {
    let rest = uri.trim().strip_prefix("http://")?;
    let hostport = rest.split('/').next()?;
    if hostport.is_empty() {
        return None;
    }
    Some(if hostport.contains(':') {
        hostport.to_string()
    } else {
        format!("{hostport}:11311")
    })
}

/// The PID in an XML-RPC `getPid` response (`[code, status, pid]`).
fn parse_pid(body: &str) -> Option<u32> {
    let mut ints = Vec::new();
    let mut rest = body;
    while let Some(i) = rest
        .find("<i4>")
        .map(|i| (i, 4))
        .or_else(|| rest.find("<int>").map(|i| (i, 5)))
    {
        let tail = &rest[i.0 + i.1..];
        let end = tail.find('<')?;
        ints.push(tail[..end].trim().parse::<i64>().ok()?);
        rest = &tail[end..];
    }
    match ints.as_slice() {
        [1, pid] => u32::try_from(*pid).ok(),
        _ => None,
    }
}

/// Asks the master at `uri` for its PID with a direct XML-RPC `getPid`
/// (std sockets, [`MASTER_PROBE_TIMEOUT`]): `None` if it does not answer.
pub fn probe_master_pid(uri: &str, caller: &str) -> Option<u32> {
    parse_pid(&super::leave_master::xmlrpc_call(uri, "getPid", &[caller])?)
}

/// Watches the master once a second from a thread of its own, with a direct
/// XML-RPC probe (never through rosrust, whose calls block while the master
/// is down): reports its loss and return in the log (stderr: /rosout needs
/// the master), and flags a restart (a different PID) so the node can leave
/// cleanly (stopping the robot) instead of running on unregistered.
/// roslaunch's `respawn` then brings the node back.
#[derive(Clone)]
pub struct MasterWatch(Arc<std::sync::atomic::AtomicU8>);

impl MasterWatch {
    /// Starts the watch (the node must be connected).
    pub fn start(node: &str) -> Self {
        let flag = Arc::new(std::sync::atomic::AtomicU8::new(0));
        let f = flag.clone();
        let node = node.to_string();
        let spawned = std::thread::Builder::new().name("master-watch".into()).spawn(move || {
            let master = std::env::var("ROS_MASTER_URI").unwrap_or_else(|_| "http://localhost:11311/".into());
            let mut pid = probe_master_pid(&master, &node);
            let mut lost_since: Option<std::time::Instant> = None;
            loop {
                std::thread::sleep(Duration::from_secs(1));
                match (probe_master_pid(&master, &node), pid) {
                    (None, _) => {
                        if lost_since.is_none() {
                            log::error!(
                                "{node}: lost the ROS master at {master}; connected topics keep flowing, new ones cannot connect; waiting for it"
                            );
                            lost_since = Some(std::time::Instant::now());
                            f.store(1, Ordering::SeqCst);
                        }
                    }
                    (Some(now), Some(was)) if now != was => {
                        log::error!(
                            "{node}: the ROS master at {master} restarted (PID {was} -> {now}): this node's registrations are gone and rosrust cannot renew them; shutting down with status 1 (roslaunch respawn brings it back)"
                        );
                        f.store(2, Ordering::SeqCst);
                        return;
                    }
                    (Some(now), _) => {
                        pid = Some(now);
                        if let Some(t) = lost_since.take() {
                            log::info!(
                                "{node}: the ROS master at {master} is back (same process) after {:.1} s",
                                t.elapsed().as_secs_f64()
                            );
                            f.store(0, Ordering::SeqCst);
                        }
                    }
                }
            }
        });
        if let Err(e) = spawned {
            log::error!("cannot start the ROS master watch: {e}");
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn master_uri_and_pid_parsing() {
        assert_eq!(
            master_addr("http://localhost:11311/").as_deref(),
            Some("localhost:11311")
        );
        assert_eq!(master_addr("http://10.0.0.2").as_deref(), Some("10.0.0.2:11311"));
        assert_eq!(master_addr("localhost:11311"), None);
        let ok = "<methodResponse><params><param><value><array><data><value><int>1</int></value>\
                  <value><string></string></value><value><int>4242</int></value></data></array></value></param></params></methodResponse>";
        assert_eq!(parse_pid(ok), Some(4242));
        assert_eq!(
            parse_pid(&ok.replace("<int>", "<i4>").replace("</int>", "</i4>")),
            Some(4242)
        );
        assert_eq!(parse_pid("HTTP/1.0 500 oops"), None);
        assert_eq!(parse_pid("<int>-1</int><int>3</int>"), None);
    }

    #[test]
    fn a_master_that_is_not_there_is_not_answering_quickly() {
        // A port nobody listens on (bound then closed): refused at once.
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port();
        let t = std::time::Instant::now();
        assert_eq!(probe_master_pid(&format!("http://127.0.0.1:{port}/"), "/t"), None);
        assert!(t.elapsed() < Duration::from_secs(2));
    }

    #[test]
    fn a_fake_master_answers_its_pid() {
        use std::io::{Read, Write};
        let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        let port = l.local_addr().unwrap().port();
        let srv = std::thread::spawn(move || {
            let (mut c, _) = l.accept().unwrap();
            let mut buf = [0u8; 4096];
            let n = c.read(&mut buf).unwrap();
            assert!(String::from_utf8_lossy(&buf[..n]).contains("getPid"));
            let body = "<?xml version='1.0'?><methodResponse><params><param><value><array><data><value><int>1</int></value><value><string>x</string></value><value><int>77</int></value></data></array></value></param></params></methodResponse>";
            let _ = write!(c, "HTTP/1.0 200 OK\r\nContent-Length: {}\r\n\r\n{body}", body.len());
        });
        assert_eq!(probe_master_pid(&format!("http://127.0.0.1:{port}/"), "/t"), Some(77));
        srv.join().unwrap();
    }
}
