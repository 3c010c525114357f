//! The launch files' help for the `protocol` argument lists every protocol
//! the bridge speaks: `roslaunch --ros-args` shows that text to a user
//! choosing one, and a protocol missing from it is one they never find.

use can_bridge::protocol::ProtocolKind;
use std::path::Path;

/// Every protocol of the bridge. The match is exhaustive: a new protocol
/// does not compile until it is listed here, and so checked below.
fn every_protocol() -> Vec<ProtocolKind> {
    let all = [ProtocolKind::Generic, ProtocolKind::Odrive, ProtocolKind::Cia402];
    for k in all {
        match k {
            ProtocolKind::Generic | ProtocolKind::Odrive | ProtocolKind::Cia402 => {}
        }
    }
    all.to_vec()
}

/// The `doc` of each `<arg name="protocol" …>` in `text`.
fn protocol_docs(text: &str) -> Vec<String> {
    text.split("<arg ")
        .skip(1)
        .map(|tag| &tag[..tag.find('>').unwrap_or(tag.len())])
        .filter(|tag| tag.contains("name=\"protocol\""))
        .filter_map(|tag| {
            let start = tag.find("doc=\"")? + 5;
            let end = start + tag[start..].find('"')?;
            Some(tag[start..end].to_string())
        })
        .collect()
}

#[test]
fn every_protocol_argument_lists_every_protocol() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../launch");
    let mut checked = Vec::new();
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "launch") {
            continue;
        }
        let text = std::fs::read_to_string(&path).unwrap();
        for doc in protocol_docs(&text) {
            let words: Vec<&str> = doc.split(|c: char| !c.is_ascii_alphanumeric()).collect();
            for kind in every_protocol() {
                assert!(
                    words.contains(&kind.name()),
                    "{}: the protocol argument's help \"{doc}\" does not list `{}`",
                    path.display(),
                    kind.name()
                );
            }
            checked.push(path.file_name().unwrap().to_string_lossy().into_owned());
        }
    }
    checked.sort();
    // The robot's bringup, the bridge alone and the chain on vcan each have one.
    assert_eq!(checked, ["bringup.launch", "can_bridge.launch", "sim_can.launch"]);
}

#[test]
fn a_protocol_argument_without_cia402_is_caught() {
    let docs = protocol_docs(
        r#"<arg name="interface" doc="x"/><arg name="protocol" default="generic" doc="generic | odrive"/>"#,
    );
    assert_eq!(docs, ["generic | odrive"]);
    assert!(!docs[0].split(" | ").any(|w| w == ProtocolKind::Cia402.name()));
}
