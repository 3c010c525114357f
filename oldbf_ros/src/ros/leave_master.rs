//! Leaving the ROS master clean when a node stops.
//!
//! rosrust withdraws a registration only when every handle of it is dropped
//! (a publisher shared with callbacks may outlive the shutdown), and it never
//! withdraws the parameter subscription ("/") it makes at the first parameter
//! read. A dead node's address left in the master is harmful, not just untidy:
//! the master keeps calling it (`paramUpdate` on every parameter change,
//! `publisherUpdate`), subscribers keep asking it for topics, and when the
//! port is reused by a rosrust publisher's TCPROS listener, that HTTP call is
//! read as a subscriber's connection header whose length is the bytes "POST":
//! the listener waits for ~1.4 GB that never come and accepts no subscriber
//! again. So a stopping node withdraws,
//! with direct XML-RPC calls, every publication, subscription and service
//! the master lists for it, and its parameter subscription.

use super::lifecycle::{master_addr, MASTER_PROBE_TIMEOUT};
use std::io::{Read, Write};
use std::net::ToSocketAddrs;

/// One XML-RPC call with string arguments to `uri` (std sockets, short
/// timeouts, never through rosrust). Returns the response body, `None` if
/// nothing answered.
pub fn xmlrpc_call(uri: &str, method: &str, args: &[&str]) -> Option<String> {
    let addr = master_addr(uri)?;
    let sock = addr.to_socket_addrs().ok()?.next()?;
    let mut stream = std::net::TcpStream::connect_timeout(&sock, MASTER_PROBE_TIMEOUT).ok()?;
    stream.set_read_timeout(Some(MASTER_PROBE_TIMEOUT)).ok()?;
    stream.set_write_timeout(Some(MASTER_PROBE_TIMEOUT)).ok()?;
    let params: String = args
        .iter()
        .map(|a| format!("<param><value><string>{}</string></value></param>", xml_escape(a)))
        .collect();
    let body = format!(
        "<?xml version=\"1.0\"?><methodCall><methodName>{method}</methodName><params>{params}</params></methodCall>"
    );
    let req = format!(
        "POST / HTTP/1.0\r\nHost: {addr}\r\nContent-Type: text/xml\r\nContent-Length: {}\r\n\r\n{body}",
        body.len()
    );
    stream.write_all(req.as_bytes()).ok()?;
    let mut resp = Vec::new();
    // HTTP/1.0: the server closes the connection after the answer.
    let _ = stream.take(1024 * 1024).read_to_end(&mut resp);
    (!resp.is_empty()).then(|| String::from_utf8_lossy(&resp).into_owned())
}

fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// The first `<string>` of an XML-RPC response body after its status code and
/// message (`[code, message, value]`): `lookupService`'s URI.
fn third_string(body: &str) -> Option<String> {
    let mut rest = body;
    let mut strings = Vec::new();
    while let Some(i) = rest.find("<string>") {
        let tail = &rest[i + "<string>".len()..];
        let end = tail.find("</string>")?;
        strings.push(tail[..end].to_string());
        rest = &tail[end..];
    }
    strings.into_iter().nth(1)
}

/// What [`leave_master`] withdrew.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Withdrawn {
    pub publications: usize,
    pub subscriptions: usize,
    pub services: usize,
    /// Whether the master answered the parameter unsubscription.
    pub parameters: bool,
}

/// Withdraws every registration the master holds for this node (rosrust's
/// name and URI). Call it last, after the node's final messages went out,
/// and not after the master restarted (the new one holds nothing of ours,
/// and a respawned namesake may be registered). Does nothing when the
/// master does not answer.
pub fn leave_master() -> Withdrawn {
    let master = std::env::var("ROS_MASTER_URI").unwrap_or_else(|_| "http://localhost:11311/".into());
    let (name, api) = (rosrust::name(), rosrust::uri());
    let mut done = Withdrawn::default();
    // rosrust's own calls block while the master is down: ask it directly first.
    if super::lifecycle::probe_master_pid(&master, &name).is_none() {
        return done;
    }
    let Ok(state) = rosrust::state() else {
        return done;
    };
    let ours = |nodes: &[String]| nodes.contains(&name);
    for t in state.publishers.iter().filter(|t| ours(&t.connections)) {
        if xmlrpc_call(&master, "unregisterPublisher", &[&name, &t.name, &api]).is_some() {
            done.publications += 1;
        }
    }
    for t in state.subscribers.iter().filter(|t| ours(&t.connections)) {
        if xmlrpc_call(&master, "unregisterSubscriber", &[&name, &t.name, &api]).is_some() {
            done.subscriptions += 1;
        }
    }
    for s in state.services.iter().filter(|s| ours(&s.connections)) {
        let Some(service_api) = xmlrpc_call(&master, "lookupService", &[&name, &s.name]).and_then(|b| third_string(&b))
        else {
            continue;
        };
        if xmlrpc_call(&master, "unregisterService", &[&name, &s.name, &service_api]).is_some() {
            done.services += 1;
        }
    }
    done.parameters = xmlrpc_call(&master, "unsubscribeParam", &[&name, &api, "/"]).is_some();
    log::debug!("{name}: withdrawn from the master: {done:?}");
    done
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_service_uri_is_the_string_after_the_status_message() {
        let body = "<?xml version='1.0'?><methodResponse><params><param><value><array><data>\
            <value><int>1</int></value><value><string>rosrpc URI: [rosrpc://localhost:4001]</string></value>\
            <value><string>rosrpc://localhost:4001</string></value></data></array></value></param></params></methodResponse>";
        assert_eq!(third_string(body).as_deref(), Some("rosrpc://localhost:4001"));
        assert_eq!(third_string("<methodResponse></methodResponse>"), None);
    }

    #[test]
    fn a_call_sends_one_escaped_xml_rpc_request_and_returns_the_answer() {
        let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        let port = listener.local_addr().unwrap().port();
        let server = std::thread::spawn(move || {
            let (mut s, _) = listener.accept().unwrap();
            let mut buf = [0u8; 4096];
            let n = s.read(&mut buf).unwrap();
            s.write_all(b"HTTP/1.0 200 OK\r\n\r\n<int>1</int>").unwrap();
            String::from_utf8_lossy(&buf[..n]).into_owned()
        });
        let answer = xmlrpc_call(
            &format!("http://127.0.0.1:{port}/"),
            "unsubscribeParam",
            &["/a<b", "http://x:1/", "/"],
        );
        let request = server.join().unwrap();
        assert!(answer.unwrap().contains("<int>1</int>"));
        assert!(request.starts_with("POST / HTTP/1.0"));
        assert!(request.contains("<methodName>unsubscribeParam</methodName>"));
        assert!(request.contains("<string>/a&lt;b</string>"), "{request}");
        // Nothing listening: None, promptly.
        assert_eq!(xmlrpc_call("http://127.0.0.1:1/", "getPid", &["/x"]), None);
    }
}
