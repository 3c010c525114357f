//! The binaries as a user runs them, on any machine (no CAN needed for
//! these: help, configuration errors, a missing interface). Their behaviour
//! on a bus is checked in the vcan group (tests/can/can_checks.py).

use std::process::Command;

fn cli() -> Command {
    Command::new(env!("CARGO_BIN_EXE_can_bridge_cli"))
}

fn drive() -> Command {
    Command::new(env!("CARGO_BIN_EXE_virtual_drive"))
}

fn tmp(name: &str, text: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("can_bridge_cli_test_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn help_explains_commands_units_and_faults() {
    let out = cli().arg("--help").output().unwrap();
    assert!(out.status.success());
    let h = String::from_utf8_lossy(&out.stdout);
    for s in [
        "V OMEGA",
        "m/s",
        "rad/s",
        "estop",
        "reset",
        "--script",
        "--config",
        "every DT until",
    ] {
        assert!(h.contains(s), "can_bridge_cli --help lacks `{s}`:\n{h}");
    }
    let out = drive().arg("--help").output().unwrap();
    assert!(out.status.success());
    let h = String::from_utf8_lossy(&out.stdout);
    for s in [
        "--time-constant-s",
        "rad/s²",
        "--watchdog-s",
        "axis_error@",
        "heartbeat_silence@",
        "feedback_delay@",
        "exit@",
        "--fault",
    ] {
        assert!(h.contains(s), "virtual_drive --help lacks `{s}`:\n{h}");
    }
}

#[test]
fn print_config_shows_the_effective_values() {
    let out = cli()
        .args(["--print-config", "--protocol", "odrive", "--interface", "can1"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["protocol"], "odrive");
    assert_eq!(v["interface"], "can1");
    assert_eq!(v["generic"]["base_id"], 256);
}

#[test]
fn a_bad_configuration_exits_2_naming_file_key_and_range() {
    let text = can_bridge::config::DEFAULT_CONFIG_YAML.replace("tx_rate_hz: 50.0", "tx_rate_hz: -5");
    let p = tmp("bad.yaml", &text);
    let out = cli().args(["--config", p.to_str().unwrap()]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(
        e.contains("bad.yaml: key `timing.tx_rate_hz` = -5 is out of range; allowed: (0, 1000] Hz"),
        "{e}"
    );
    let out = cli().args(["--interface", "a/b", "--print-config"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("key `interface`"));
    let out = drive().args(["--fault", "meltdown@1"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2), "clap rejects a bad fault spec");
    assert!(String::from_utf8_lossy(&out.stderr).contains("unknown kind `meltdown`"));
}

#[test]
fn a_bad_script_exits_2_naming_the_line() {
    let p = tmp("bad.script", "0 0.1 0\n1 fly away\n");
    let out = cli().args(["--script", p.to_str().unwrap()]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("line 2:"));
}

#[test]
fn a_missing_interface_is_a_clear_error() {
    let out = cli().args(["--interface", "nocan9"]).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(e.contains("cannot open CAN interface `nocan9`"), "{e}");
    let out = drive().args(["--interface", "nocan9"]).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
}

#[test]
fn absurd_durations_and_rates_are_usage_errors_not_panics() {
    // Duration::from_secs_f64 panics on 1e300 s or 1 / 1e-300 Hz: the flags are
    // range-checked when parsed, before any bus is opened.
    for args in [
        &["--duration-s", "1e300"][..],
        &["--linger-s", "NaN"][..],
        &["--status-rate-hz", "1e-300"][..],
        &["--duration-s=-1"][..],
    ] {
        for (name, mut cmd) in [("can_bridge_cli", cli()), ("virtual_drive", drive())] {
            if name == "virtual_drive" && args[0] == "--linger-s" {
                continue; // the drive has no script to linger after
            }
            let out = cmd.args(["--interface", "nocan9"]).args(args).output().unwrap();
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{name} {args:?}: {err}");
            let flag = args[0].split('=').next().unwrap();
            assert!(
                err.contains(flag) && err.contains("out of range"),
                "{name} {args:?}: {err}"
            );
            assert!(
                !err.contains("panicked") && !err.contains("nocan9"),
                "{name} {args:?}: {err}"
            );
        }
    }
}
