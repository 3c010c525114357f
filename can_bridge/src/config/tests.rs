//! The shipped files, and errors naming the file, the key and the range.

use super::*;

fn with(key: &str, value: &str) -> String {
    let mut v: serde_yaml::Value = serde_yaml::from_str(DEFAULT_CONFIG_YAML).unwrap();
    let mut slot = &mut v;
    for k in key.split('.') {
        slot = slot.get_mut(k).unwrap_or_else(|| panic!("no key {k}"));
    }
    *slot = serde_yaml::from_str(value).unwrap();
    serde_yaml::to_string(&v).unwrap()
}

#[test]
fn shipped_file_is_valid_and_documented() {
    let c = default_config();
    assert_eq!(c.interface, "vcan0");
    assert_eq!(c.protocol, ProtocolKind::Generic);
    assert_eq!(c.generic.base_id, 0x100, "hex in YAML");
    assert_eq!(c.tx_period(), Duration::from_millis(20));
    assert_eq!(c.diff_drive().right_direction, -1.0);
    // Every leaf key's own line ends its comment with the allowed range:
    // an interval like `(0, 10]`, or alternatives (`-1 or 1`, `a | b`).
    let has_interval = |c: &str| {
        c.find(['[', '(']).is_some_and(|i| {
            let rest = &c[i..];
            rest.find(',').is_some_and(|j| rest[j..].contains([']', ')']))
        })
    };
    let mut leaves = 0;
    for line in DEFAULT_CONFIG_YAML.lines() {
        let l = line.trim_start();
        if l.starts_with('#') || l.is_empty() || l.ends_with(':') {
            continue;
        }
        leaves += 1;
        let (_, comment) = l.split_once('#').unwrap_or_else(|| panic!("no comment: {line}"));
        assert!(
            has_interval(comment) || comment.contains(" or ") || comment.contains(" | "),
            "no range: {line}"
        );
    }
    assert_eq!(leaves, 46, "every key of BridgeConfig is in the shipped file");
}

#[test]
fn unknown_key_is_named() {
    let text = DEFAULT_CONFIG_YAML.replace("  gear_ratio: 1.0", "  gear_ratio: 1.0\n  gear_ration: 2");
    let e = load_config_str(&text, "my.yaml").unwrap_err();
    assert_eq!(e.keys(), ["kinematics.gear_ration"], "{e}");
    assert!(
        e.to_string()
            .starts_with("my.yaml: key `kinematics.gear_ration`: unknown field"),
        "{e}"
    );
}

#[test]
fn wrong_type_and_bad_enum_are_named() {
    let e = load_config_str(&with("timing.tx_rate_hz", "\"fast\""), "f.yaml").unwrap_err();
    assert_eq!(e.keys(), ["timing.tx_rate_hz"], "{e}");
    let e = load_config_str(&with("protocol", "canopen"), "f.yaml").unwrap_err();
    assert_eq!(e.keys(), ["protocol"], "{e}");
    assert!(
        e.to_string().contains("generic") && e.to_string().contains("odrive"),
        "{e}"
    );
}

#[test]
fn odrive_firmware_is_0_5_or_0_6_quoted_or_not() {
    assert_eq!(default_config().odrive.firmware, Firmware::V0_5);
    for (text, want) in [
        ("\"0.6\"", Firmware::V0_6),
        ("0.6", Firmware::V0_6),
        ("'0.5'", Firmware::V0_5),
    ] {
        let c = load_config_str(&with("odrive.firmware", text), "f.yaml").unwrap();
        assert_eq!(c.odrive.firmware, want, "{text}");
    }
    for bad in ["\"0.7\"", "0.60001", "6", "\"v0.6\""] {
        let e = load_config_str(&with("odrive.firmware", bad), "f.yaml").unwrap_err();
        assert_eq!(e.keys(), ["odrive.firmware"], "{bad}: {e}");
        assert!(e.to_string().contains("\"0.5\" or \"0.6\""), "{bad}: {e}");
    }
}

#[test]
fn missing_key_is_named() {
    let text = DEFAULT_CONFIG_YAML.replace("  cmd_timeout_s: 0.5", "");
    let e = load_config_str(&text, "f.yaml").unwrap_err();
    assert!(e.to_string().contains("missing field `cmd_timeout_s`"), "{e}");
}

#[test]
fn out_of_range_messages_give_the_range() {
    let e = load_config_str(&with("timing.tx_rate_hz", "0"), "f.yaml").unwrap_err();
    assert_eq!(
        e.to_string().lines().next().unwrap(),
        "f.yaml: key `timing.tx_rate_hz` = 0 is out of range; allowed: (0, 1000] Hz"
    );
    let e = load_config_str(&with("kinematics.left_direction", "0"), "f.yaml").unwrap_err();
    assert_eq!(e.keys(), ["kinematics.left_direction"]);
    let e = load_config_str(&with("timing.cmd_timeout_s", "0.01"), "f.yaml").unwrap_err();
    assert!(e.to_string().contains("at least one tx period"), "{e}");
    let e = load_config_str(&with("generic.base_id", "0x7F0"), "f.yaml").unwrap_err();
    assert_eq!(e.keys(), ["generic.base_id"]);
    let e = load_config_str(&with("odrive.right_node_id", "0"), "f.yaml").unwrap_err();
    assert!(e.to_string().contains("different from odrive.left_node_id"), "{e}");
    let e = load_config_str(&with("odrive.left_node_id", "64"), "f.yaml").unwrap_err();
    assert_eq!(e.keys(), ["odrive.left_node_id"]);
    let e = load_config_str(&with("limits.v_max_mps", ".nan"), "f.yaml").unwrap_err();
    assert_eq!(e.keys(), ["limits.v_max_mps"]);
    let e = load_config_str(&with("interface", "\"can 0\""), "f.yaml").unwrap_err();
    assert_eq!(e.keys(), ["interface"]);
    // The generic i32 field must hold max wheel speed × gear (100 × 1000 > 21474.8).
    let text =
        with("kinematics.gear_ratio", "1000").replace("max_wheel_speed_radps: 7.0", "max_wheel_speed_radps: 100.0");
    let e = load_config_str(&text, "f.yaml").unwrap_err();
    assert_eq!(e.keys(), ["limits.max_wheel_speed_radps"], "{e}");
    let text = text.replace("protocol: generic", "protocol: odrive");
    assert!(
        load_config_str(&text, "f.yaml").is_ok(),
        "floats on ODrive have the range"
    );
}

/// The CiA 402 rules that involve two keys, each naming the key to change.
#[test]
fn cia402_cross_key_rules() {
    let cia = |t: String| t.replace("protocol: generic", "protocol: cia402");
    let case = |key: &str, value: &str, rule: &str| {
        let e = load_config_str(&cia(with(key, value)), "f.yaml").unwrap_err();
        assert_eq!(e.keys(), [key], "{key} = {value}: {e}");
        assert!(e.to_string().contains(rule), "{key} = {value}: {e}");
    };
    case("cia402.right_node_id", "1", "different from cia402.left_node_id");
    // One node, two axes (a dual-channel controller): allowed, with 0x800 as the offset.
    let two_axis = with("cia402.right_node_id", "1").replace("  right_axis: 1", "  right_axis: 2");
    let c = load_config_str(&cia(two_axis.clone()), "f").unwrap();
    let s = c.cia402.settings();
    assert_eq!(s.nodes, [1, 1]);
    assert_eq!((s.axes[0].axis, s.axes[1].axis, s.axes[1].offset), (1, 2, 0x800));
    assert_eq!(s.node_ids(), [1]);
    // …but not the same axis twice, on either side.
    let same = two_axis.replace("  left_axis: 1", "  left_axis: 2");
    let e = load_config_str(&cia(same), "f").unwrap_err();
    assert_eq!(e.keys(), ["cia402.right_node_id"], "{e}");
    case("cia402.left_axis", "3", "[1, 2]");
    case("cia402.axis_offset", "0x80", "[256, 16128]");
    case("cia402.bridge_node_id", "2", "different from both drives' node ids");
    // heartbeat_timeout_s 0.5: at most 250 ms.
    case(
        "cia402.drive_heartbeat_ms",
        "251",
        "at most half of timing.heartbeat_timeout_s",
    );
    assert!(load_config_str(&cia(with("cia402.drive_heartbeat_ms", "250")), "f").is_ok());
    case(
        "cia402.drive_consumer_heartbeat_ms",
        "100",
        "longer than a non-zero cia402.bridge_heartbeat_ms",
    );
    let t = with("cia402.bridge_heartbeat_ms", "0");
    let e = load_config_str(&cia(t.clone()), "f.yaml").unwrap_err();
    assert_eq!(e.keys(), ["cia402.drive_consumer_heartbeat_ms"]);
    let t: String = serde_yaml::to_string(&{
        let mut v: serde_yaml::Value = serde_yaml::from_str(&t).unwrap();
        v["cia402"]["drive_consumer_heartbeat_ms"] = 0.into();
        v
    })
    .unwrap();
    assert!(
        load_config_str(&cia(t), "f").is_ok(),
        "no heartbeat, nobody watching it"
    );
    // startup_timeout_s 2.0.
    case("cia402.sdo_timeout_s", "2.0", "shorter than timing.startup_timeout_s");
    // 0.01 rad/s² is 0.095 rpm/s: rounds to 0.
    case(
        "cia402.profile_accel_radps2",
        "0.01",
        "at least one drive acceleration unit",
    );
    // Without SYNC the feedback comes at the event timer: below feedback_timeout_s (0.2 s).
    let e = load_config_str(
        &cia(with("cia402.tpdo_event_ms", "200")).replace("sync_producer: true", "sync_producer: false"),
        "f.yaml",
    )
    .unwrap_err();
    assert_eq!(e.keys(), ["cia402.tpdo_event_ms"], "{e}");
    assert!(
        load_config_str(&cia(with("cia402.tpdo_event_ms", "200")), "f").is_ok(),
        "SYNC: unused"
    );
    // 7 rad/s × 1000 (gear) × 9549.3 units per rad/s at 0.001 rpm = 6.7e7: fits; at 1e-5 rpm it does not.
    let t = with("kinematics.gear_ratio", "1000").replace("velocity_resolution: 1.0", "velocity_resolution: 0.00001");
    let e = load_config_str(&cia(t.clone()), "f.yaml").unwrap_err();
    assert_eq!(e.keys(), ["limits.max_wheel_speed_radps"], "{e}");
    assert!(
        load_config_str(&t, "f").is_ok(),
        "only checked when cia402 is the protocol"
    );
}

/// The EPOS example is complete and valid; its units by hand: 14 rad/s
/// at the wheel × 26 = 364 rad/s at the motor = 3476 rpm; 2000 rad/s² =
/// 19099 rpm/s.
#[test]
fn the_epos_example_is_valid() {
    let text = include_str!("../../../config/can_bridge_cia402_epos.yaml");
    let c = load_config_str(text, "config/can_bridge_cia402_epos.yaml").unwrap();
    assert_eq!(c.protocol, ProtocolKind::Cia402);
    let s = c.cia402.settings();
    let motor = c.limits.max_wheel_speed_radps * c.kinematics.gear_ratio;
    assert_eq!(s.scaling.velocity_to_drive(motor), 3476);
    assert_eq!(s.profile_accel, 19099);
    assert_eq!(s.nodes, [1, 2]);
}

/// The Roboteq example: one node, the right wheel on channel 2 (+0x800);
/// by hand: 12 rad/s at the wheel × 16 = 192 rad/s = 1833.5 → 1833 RPM at
/// the motor; 2000 rad/s² = 19099 RPM/s on both channels (0x6883 too).
#[test]
fn the_roboteq_dual_channel_example_is_valid() {
    let text = include_str!("../../../config/can_bridge_cia402_roboteq.yaml");
    let c = load_config_str(text, "config/can_bridge_cia402_roboteq.yaml").unwrap();
    let s = c.cia402.settings();
    assert_eq!((s.nodes, s.node_ids()), ([1, 1], vec![1]));
    assert_eq!((s.axes[0].axis, s.axes[1].axis, s.axes[1].offset), (1, 2, 0x800));
    let motor = c.limits.max_wheel_speed_radps * c.kinematics.gear_ratio;
    assert_eq!(s.scaling.velocity_to_drive(motor), 1833);
    let steps = crate::protocol::cia402::startup_steps(&s, 1);
    assert!(steps.contains(&crate::protocol::cia402::Step::Write(
        crate::protocol::cia402::sdo::ObjectAddr::new(0x6883, 0),
        crate::protocol::cia402::sdo::SdoValue::u32(19099)
    )));
}

#[test]
fn missing_file_is_named() {
    let e = load_config_file(Path::new("/nonexistent/can_bridge.yaml")).unwrap_err();
    assert!(
        e.to_string().starts_with("/nonexistent/can_bridge.yaml: cannot read"),
        "{e}"
    );
}
