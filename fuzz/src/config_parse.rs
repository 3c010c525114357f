//! `config_parse`: arbitrary text as YAML through every configuration
//! loader: the algorithm parameters (`config::load_params_str`), the safety
//! node's parameters (`node_config::node_config_from_params`), the CAN
//! bridge (`can_bridge::config::load_config_str`), scenarios
//! (`Scenario::from_str`) and batch templates (`Template::from_str`, plus
//! one generated world).
//!
//! Asserts: no panic, no hang; whatever loads validates again, its numbers
//! are usable (a pipeline step on a plain scan gives a finite command inside
//! the box; the bridge starts on a fake bus).

use crate::scan_pipeline::check_command;
use can_bridge::config::Validate;
use can_bridge::fake_bus::FakeBus;
use oldbf_ros::algo::dtcbf::InputBox;
use oldbf_ros::algo::{LaserScan, Params, SafetyPipeline, ScanHeader, Twist};
use oldbf_ros::batch::template::Template;
use oldbf_ros::sim::scenario::Scenario;
use serde_yaml::Value;

/// The shipped scenarios, the only files `node.scenario` may name here (the
/// fuzzer must not read arbitrary paths such as /dev/zero).
const SCENARIOS: [&str; 7] = [
    "cluttered_room.yaml",
    "corridor.yaml",
    "crossing.yaml",
    "dead_end.yaml",
    "paper_circle.yaml",
    "paper_line.yaml",
    "two_robots.yaml",
];

/// Runs one input.
pub fn run(data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    let file = "fuzz.yaml";

    if let Ok(p) = oldbf_ros::config::load_params_str(&text, file) {
        usable(&p);
    }
    if let Ok(cfg) = can_bridge::config::load_config_str(&text, file) {
        assert!(cfg.validate().is_ok());
        assert!(!cfg.tx_period().is_zero());
        let bridge = can_bridge::Bridge::new(cfg, FakeBus::new(), can_bridge::Timestamp::ZERO);
        assert!(bridge.is_ok(), "a loaded config does not start the bridge");
    }
    if let Ok(s) = Scenario::from_str(&text, file, None) {
        usable(&s.params);
        assert!(!s.agents.is_empty());
    }
    if let Ok(t) = Template::from_str(&text, file, None) {
        usable(&t.params);
        let _ = t.world(1, 0);
    }
    if let Ok(mut ns) = serde_yaml::from_str::<Value>(&text) {
        confine_scenario(&mut ns);
        if let Ok(c) = oldbf_ros::node_config::node_config_from_params(ns, "fuzz parameters") {
            usable(&c.params);
            assert!(c.settings.validate().is_ok());
        }
    }
}

/// Rewrites `node.scenario` to a shipped scenario's absolute path when it
/// names one (by file name), else to "" (none).
fn confine_scenario(ns: &mut Value) {
    let Some(slot) = ns.get_mut("node").and_then(|n| n.get_mut("scenario")) else {
        return;
    };
    let name = slot.as_str().and_then(|s| s.rsplit('/').next()).unwrap_or("");
    *slot = match SCENARIOS.iter().find(|&&s| s == name) {
        Some(s) => Value::String(format!("{}/../config/scenarios/{s}", env!("CARGO_MANIFEST_DIR"))),
        None => Value::String(String::new()),
    };
}

/// Validated parameters give a finite command inside the box on a plain
/// scan (a wall 1 m ahead, 360 beams over a full turn).
fn usable(p: &Params) {
    assert!(p.validate().is_ok(), "loaded parameters do not validate");
    let ibox = InputBox::from_params(p);
    assert!(ibox.v_lo.is_finite() && ibox.v_hi.is_finite() && ibox.omega_max.is_finite());
    assert!(
        ibox.v_lo <= 0.0 && ibox.v_hi >= 0.0 && ibox.omega_max >= 0.0,
        "{ibox:?}"
    );
    let n = 360.min(p.laser.max_beams);
    let ranges: Vec<f32> = (0..n)
        .map(|i| if i < n / 8 || i > 7 * n / 8 { 1.0 } else { 5.0 })
        .collect();
    let scan = LaserScan {
        header: ScanHeader {
            stamp_s: 10.0,
            angle_min_rad: -std::f32::consts::PI,
            angle_increment_rad: std::f32::consts::TAU / n as f32,
            range_min_m: 0.05,
            range_max_m: 10.0,
        },
        ranges_m: &ranges,
        intensities: &[],
    };
    let mut pipeline = SafetyPipeline::new(p.clone());
    for k in 0..3 {
        let rec = pipeline.step(
            &scan,
            10.0 + 0.01 * f64::from(k),
            Twist::new(p.control.v_nom_mps, 0.1),
            0.1,
        );
        check_command(rec.cmd, &ibox);
    }
}
