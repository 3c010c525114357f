//! Bad bridge configuration, table-driven over every leaf key of
//! config/can_bridge.yaml: a value out of range per key, generated wrong
//! types, NaN/±inf, unknown siblings and removed keys; the error names the
//! file and the key. The CLI rejects a bad configuration with exit 2 before
//! it opens the bus: the message appears even for an interface that does
//! not exist, so nothing can have been sent.

#[path = "../../oldbf_ros/tests/yaml_paths/mod.rs"]
mod yaml_paths;

use can_bridge::config::{load_config_file, DEFAULT_CONFIG_YAML};
use serde_yaml::Value;
use std::collections::BTreeSet;
use std::path::PathBuf;
use std::process::Command;
use yaml_paths::{leaves, path, show, with, with_sibling, without};

/// Every leaf key and a value outside its range or set.
const ROWS: &[(&str, &str)] = &[
    ("interface", "\"can 0/1\""),
    ("protocol", "canopen"),
    ("timing.tx_rate_hz", "0"),
    ("timing.cmd_timeout_s", "0.001"),
    ("timing.feedback_timeout_s", "0"),
    ("timing.heartbeat_timeout_s", "11"),
    ("timing.startup_timeout_s", "-1"),
    ("timing.bus_recovery_s", "61"),
    ("kinematics.wheel_separation_m", "0"),
    ("kinematics.wheel_radius_m", "-0.033"),
    ("kinematics.gear_ratio", "1001"),
    ("kinematics.left_direction", "0"),
    ("kinematics.right_direction", "2"),
    ("limits.v_max_mps", "0"),
    ("limits.omega_max_radps", "51"),
    ("limits.max_wheel_speed_radps", "-7"),
    ("limits.wheel_accel_radps2", "0"),
    ("limits.wheel_decel_radps2", "100001"),
    ("generic.base_id", "0x7EE"),
    ("odrive.left_node_id", "64"),
    ("odrive.right_node_id", "0"),
    ("odrive.torque_ff_nm", "101"),
    ("odrive.firmware", "\"0.4\""),
    ("cia402.left_node_id", "0"),
    ("cia402.right_node_id", "128"),
    ("cia402.left_axis", "0"),
    ("cia402.right_axis", "3"),
    ("cia402.axis_offset", "0x4000"),
    ("cia402.counts_per_motor_rev", "0"),
    ("cia402.velocity_unit", "rad_per_s"),
    ("cia402.velocity_resolution", "0"),
    ("cia402.profile_accel_radps2", "0"),
    ("cia402.profile_decel_radps2", "-1"),
    ("cia402.quick_stop_decel_radps2", "1000001"),
    ("cia402.pdo_mapping", "automatic"),
    ("cia402.sync_producer", "maybe"),
    ("cia402.tpdo_event_ms", "0"),
    ("cia402.drive_heartbeat_ms", "65536"),
    ("cia402.bridge_node_id", "1"),
    ("cia402.bridge_heartbeat_ms", "-1"),
    ("cia402.drive_consumer_heartbeat_ms", "50"),
    ("cia402.sdo_timeout_s", "0"),
    ("odometry.left_travel_variance_m2_per_m", "0"),
    ("odometry.right_travel_variance_m2_per_m", "1.5"),
    ("odometry.left_speed_sigma_radps", "-0.1"),
    ("odometry.right_speed_sigma_radps", "0"),
];

fn tmp(name: &str, doc: &Value) -> PathBuf {
    let d = std::env::temp_dir().join(format!("can-bad-config-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let p = d.join(name);
    std::fs::write(&p, serde_yaml::to_string(doc).unwrap()).unwrap();
    p
}

fn shipped() -> Value {
    serde_yaml::from_str(DEFAULT_CONFIG_YAML).unwrap()
}

fn err_of(doc: &Value, case: &str) -> (String, String) {
    // One file per test thread: the tests run in parallel.
    let name = format!("bridge_{:?}.yaml", std::thread::current().id()).replace(['(', ')'], "");
    let p = tmp(&name, doc);
    let e = load_config_file(&p)
        .expect_err(&format!("{case}: accepted"))
        .to_string();
    (e, p.display().to_string())
}

fn assert_names(e: &str, file: &str, key: &str, case: &str) {
    let want = format!("{file}: key `{key}`");
    assert!(e.contains(&want), "{case}: wanted `{want}` in:\n{e}");
}

#[test]
fn every_key_has_a_row_and_every_row_is_rejected_naming_file_and_key() {
    let d = shipped();
    let keys: BTreeSet<String> = leaves(&d).iter().map(|p| show(p)).collect();
    let rows: BTreeSet<String> = ROWS.iter().map(|(k, _)| k.to_string()).collect();
    assert_eq!(keys, rows, "config/can_bridge.yaml keys vs table rows");
    for (key, bad) in ROWS {
        let (e, f) = err_of(&with(&d, &path(key), bad), &format!("{key} = {bad}"));
        assert_names(&e, &f, key, &format!("{key} = {bad}"));
    }
}

#[test]
fn generated_cases_for_every_key() {
    let d = shipped();
    for leaf in leaves(&d) {
        let key = show(&leaf);
        let value = yaml_paths::get_mut(&mut d.clone(), &leaf).clone();
        let mut bad = vec!["[1, 2]", "{a: 1}"];
        if !value.is_string() {
            bad.push("\"abc\"");
        }
        if value.is_f64() {
            bad.extend([".nan", ".inf", "-.inf"]);
        }
        for b in bad {
            let (e, f) = err_of(&with(&d, &leaf, b), &format!("{key} = {b}"));
            assert_names(&e, &f, &key, &format!("{key} = {b}"));
        }
        let (sd, sibling) = with_sibling(&d, &leaf);
        let (e, f) = err_of(&sd, &sibling);
        assert_names(&e, &f, &sibling, "unknown key");
        // Every key is required.
        let (e, _) = err_of(&without(&d, &leaf), &format!("{key} removed"));
        let name = key.rsplit('.').next().unwrap();
        assert!(e.contains(&format!("missing field `{name}`")), "{key} removed: {e}");
    }
}

#[test]
fn the_binaries_reject_a_bad_configuration_before_opening_the_bus() {
    let p = tmp("cli.yaml", &with(&shipped(), &path("limits.v_max_mps"), ".nan"));
    let f = p.display().to_string();
    // `nocan9` does not exist: had the bus been opened first, the error would be about it.
    for (bin, extra) in [
        (env!("CARGO_BIN_EXE_can_bridge_cli"), vec!["--interface", "nocan9"]),
        (env!("CARGO_BIN_EXE_virtual_drive"), vec!["--interface", "nocan9"]),
    ] {
        let out = Command::new(bin).arg("--config").arg(&p).args(&extra).output().unwrap();
        let e = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{bin}: {e}");
        assert!(e.contains(&format!("{f}: key `limits.v_max_mps` = NaN")), "{bin}: {e}");
        assert!(!e.contains("nocan9"), "{bin} opened the bus first: {e}");
    }
    let out = Command::new(env!("CARGO_BIN_EXE_can_bridge_cli"))
        .args(["--config", "/no/such/bridge.yaml", "--interface", "nocan9"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("/no/such/bridge.yaml: cannot read"));
}
