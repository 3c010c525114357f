//! The safety node's configuration from its private ROS parameters.
//!
//! roslaunch loads `config/oldbf.yaml` (the algorithm) and
//! `config/oldbf_node.yaml` (the node, under `node:`) into the node's private
//! namespace; command-line overrides (`_barrier/d_safe_m:=0.25`) land there
//! too. The namespace is merged over the shipped defaults and then checked
//! exactly like a file: unknown keys, wrong types and out-of-range values are
//! errors that name the key. If `node.scenario` names a scenario file, its
//! nominal command (the reference of `node.robot`) and its `oldbf:`
//! overrides apply, so the simulator and the node read one definition. If
//! `node.base_limits_file` names the base's limits (`config/base_limits.yaml`),
//! the resulting parameters may not assume more than the base can do.

use crate::algo::geometry::Twist;
use crate::algo::reference::ReferenceTrajectory;
use crate::algo::Params;
use crate::config::{self, ConfigError};
use crate::node_core::{NodeSettings, ScanInput};
use crate::sim::scenario::Scenario;
use oldbf::config::{load_base_limits_file, BaseLimitsConflict, Validate};
use serde_yaml::Value;
use std::path::Path;

/// The shipped node settings file.
pub const DEFAULT_NODE_YAML: &str = include_str!("../../config/oldbf_node.yaml");

/// The shipped base limits (`config/base_limits.yaml`), for the tests.
pub const DEFAULT_BASE_LIMITS_YAML: &str = include_str!("../../config/base_limits.yaml");

/// Everything oldbf_node needs to start.
#[derive(Debug, Clone)]
pub struct NodeConfig {
    pub params: Params,
    pub settings: NodeSettings,
    /// The reference trajectory (from the scenario), if any.
    pub reference: Option<ReferenceTrajectory>,
    /// The constant nominal command (from a `kind: constant` scenario), if any.
    pub constant: Option<Twist>,
}

/// Builds the configuration from the private namespace `ns` (a mapping, or
/// null when nothing is set). `source` names it in errors, e.g.
/// `ROS parameters of /oldbf_node`.
pub fn node_config_from_params(ns: Value, source: &str) -> Result<NodeConfig, ConfigError> {
    let mut ns = match ns {
        Value::Null => Value::Mapping(Default::default()),
        v @ Value::Mapping(_) => v,
        other => {
            return Err(ConfigError::at(
                source,
                "",
                format!("expected a mapping of parameters, got {other:?}"),
            ))
        }
    };
    let node_over = ns.as_mapping_mut().and_then(|m| m.remove("node"));

    let mut settings_value = config::parse_yaml(DEFAULT_NODE_YAML, "config/oldbf_node.yaml (built-in)")?
        .get("node")
        .cloned()
        .unwrap_or(Value::Null);
    if let Some(over) = &node_over {
        config::merge(&mut settings_value, over);
    }
    let settings: NodeSettings = config::from_value(settings_value, source, "node")?;
    settings.validate().map_err(|e| ConfigError::invalid(source, e))?;

    let (mut params_value, _) = config::base_params_value(None)?;
    config::merge(&mut params_value, &ns);
    let c = if settings.scenario.is_empty() {
        let params = config::params_from_value(params_value, source, "")?;
        NodeConfig {
            params,
            settings,
            reference: None,
            constant: None,
        }
    } else {
        with_scenario(params_value, settings, source)?
    };
    check_base_limits(&c, source)?;
    Ok(c)
}

/// Puts a footprint read from the ROS parameter `name` (costmap_2d's
/// format: a list of `[x, y]`, or the same as a string, `"[[0.3, 0.2],
/// ...]"`) into the private namespace `ns` as `footprint.polygon_m`, where it
/// is validated with the rest (`node.footprint_param`). `value` is `None`
/// when the parameter is not set. Errors name `node.footprint_param` and the
/// parameter; a namespace that also sets `footprint.polygon_m` is refused
/// (two footprints).
pub fn with_costmap_footprint(
    ns: &mut Value,
    name: &str,
    value: Option<&Value>,
    source: &str,
) -> Result<(), ConfigError> {
    let key = "node.footprint_param";
    let err = |why: String| ConfigError::at(source, key, why);
    let value = value.ok_or_else(|| err(format!("names {name}, which is not set")))?;
    let parsed;
    let list = match value {
        Value::String(text) => {
            parsed = serde_yaml::from_str::<Value>(text)
                .map_err(|e| err(format!("{name} = {text:?} is not a list of [x, y]: {e}")))?;
            &parsed
        }
        v => v,
    };
    let bad = || {
        err(format!(
            "{name} = {value:?} is not a list of [x, y] (costmap_2d's footprint)"
        ))
    };
    let points = list.as_sequence().ok_or_else(bad)?;
    let mut polygon = Vec::with_capacity(points.len());
    for p in points {
        match p
            .as_sequence()
            .map(|xy| xy.iter().map(Value::as_f64).collect::<Vec<_>>())
        {
            Some(xy) if xy.len() == 2 && xy.iter().all(Option::is_some) => {
                polygon.push(Value::Sequence(xy.into_iter().flatten().map(Value::from).collect()))
            }
            _ => return Err(bad()),
        }
    }
    let Value::Mapping(m) = ns else {
        return Err(err("the private namespace is not a mapping".into()));
    };
    let footprint = m
        .entry("footprint".into())
        .or_insert_with(|| Value::Mapping(Default::default()));
    let Value::Mapping(fm) = footprint else {
        return Err(ConfigError::at(source, "footprint", "expected a mapping".to_string()));
    };
    if fm.contains_key("polygon_m") {
        return Err(err(format!(
            "names {name}, but footprint.polygon_m is set too: give the footprint once"
        )));
    }
    fm.insert("polygon_m".into(), Value::Sequence(polygon));
    Ok(())
}

/// The filter's parameters (the scenario's overrides included) against the
/// base's limits, when `node.base_limits_file` names a file: a conflict
/// names the filter's key and the base's, and the node does not start.
fn check_base_limits(c: &NodeConfig, source: &str) -> Result<(), ConfigError> {
    let file = &c.settings.base_limits_file;
    if file.is_empty() {
        return Ok(());
    }
    let base = load_base_limits_file(Path::new(file))?;
    BaseLimitsConflict::check(source, file, c.params.base_conflicts(&base))?;
    Ok(())
}

/// The parameters with a scenario's overrides, and its nominal command.
fn with_scenario(params_value: Value, mut settings: NodeSettings, source: &str) -> Result<NodeConfig, ConfigError> {
    // Check the parameters on their own first, so their errors name the server.
    config::params_from_value(params_value.clone(), source, "")?;
    let scenario = Scenario::load_over(Path::new(&settings.scenario), params_value)?;
    let agent = scenario
        .agents
        .iter()
        .find(|a| a.name == settings.robot)
        .ok_or_else(|| {
            ConfigError::at(
                source,
                "node.robot",
                format!(
                    "`{}` is not a robot of {} (robots: {:?})",
                    settings.robot,
                    scenario.file,
                    scenario.agents.iter().map(|a| a.name.as_str()).collect::<Vec<_>>()
                ),
            )
        })?;
    // A scenario with several LiDARs: the simulator node publishes them as
    // `scan_0`, `scan_1`, …; merged like `node.scans` unless that is set.
    if settings.scans.is_empty() {
        settings.scans = scenario
            .spec
            .lidars
            .iter()
            .enumerate()
            .map(|(k, l)| ScanInput {
                topic: format!("scan_{k}"),
                timeout_s: 2.5 / l.lidar.rate_hz,
                zero_is_no_return: scenario.params.laser.zero_is_no_return,
            })
            .collect();
    }
    Ok(NodeConfig {
        params: scenario.params.clone(),
        reference: agent.reference,
        constant: agent.constant,
        settings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn yaml(s: &str) -> Value {
        serde_yaml::from_str(s).unwrap()
    }

    #[test]
    fn a_costmap_footprint_is_read_in_either_form_and_checked_like_polygon_m() {
        let name = "/move_base/local_costmap/footprint";
        // The string form move_base YAMLs often carry; integers are numbers too.
        for given in [
            Value::String("[[0.3, 0.2], [-0.3, 0.2], [-0.3, -0.2], [0.3, -0.2]]".into()),
            yaml("[[0.3, 0.2], [-0.3, 0.2], [-0.3, -0.2], [0.3, -0.2]]"),
        ] {
            let mut ns = yaml("barrier: {d_safe_m: 0.1}");
            with_costmap_footprint(&mut ns, name, Some(&given), "P").unwrap();
            let c = node_config_from_params(ns, "P").unwrap();
            assert_eq!(
                c.params.footprint.polygon_m,
                [[0.3, 0.2], [-0.3, 0.2], [-0.3, -0.2], [0.3, -0.2]]
            );
            // Until the checks take the polygon: its circumscribed circle, √(0.3² + 0.2²).
            assert!((c.params.robot_radius_m() - 0.13f64.sqrt()).abs() < 1e-12);
        }
        let mut ns = Value::Mapping(Default::default());
        with_costmap_footprint(&mut ns, name, Some(&yaml("[[1, 0], [0, 1], [-1, 0]]")), "P").unwrap();
        assert_eq!(
            node_config_from_params(ns, "P").unwrap().params.footprint.polygon_m,
            [[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]]
        );
        // Not set, not a list of pairs, given twice: refused naming the setting.
        let mut ns = Value::Mapping(Default::default());
        let e = with_costmap_footprint(&mut ns, name, None, "P").unwrap_err();
        assert_eq!(e.keys(), ["node.footprint_param"]);
        assert!(
            e.to_string()
                .contains("names /move_base/local_costmap/footprint, which is not set"),
            "{e}"
        );
        for bad in [
            yaml("[[0.3, 0.2, 0.0], [0, 1], [1, 1]]"),
            yaml("0.3"),
            Value::String("[[0.3, x]]".into()),
        ] {
            let e = with_costmap_footprint(&mut ns, name, Some(&bad), "P").unwrap_err();
            assert_eq!(e.keys(), ["node.footprint_param"], "{bad:?}: {e}");
        }
        let mut ns = yaml("footprint: {polygon_m: [[1, 0], [0, 1], [-1, 0]]}");
        let e = with_costmap_footprint(&mut ns, name, Some(&yaml("[[1, 0], [0, 1], [-1, 0]]")), "P").unwrap_err();
        assert!(e.to_string().contains("footprint.polygon_m is set too"), "{e}");
        // A footprint that crosses itself is refused as footprint.polygon_m.
        let mut ns = Value::Mapping(Default::default());
        let bow_tie = yaml("[[0.3, 0.2], [-0.3, -0.2], [0.3, -0.2], [-0.3, 0.2]]");
        with_costmap_footprint(&mut ns, name, Some(&bow_tie), "P").unwrap();
        let e = node_config_from_params(ns, "P").unwrap_err();
        assert_eq!(e.keys(), ["footprint.polygon_m"], "{e}");
        assert!(e.to_string().contains("edges 0 and 2 intersect"), "{e}");
    }

    #[test]
    fn nothing_set_gives_the_shipped_defaults() {
        let c = node_config_from_params(Value::Null, "ROS parameters of /n").unwrap();
        assert_eq!(c.params, Params::default());
        assert_eq!(c.settings, NodeSettings::default());
        assert!(c.reference.is_none());
    }

    #[test]
    fn overrides_apply_and_bad_ones_are_named() {
        let c = node_config_from_params(yaml("barrier: {d_safe_m: 0.3}\nnode: {base_frame: chassis}"), "P").unwrap();
        assert_eq!(c.params.barrier.d_safe_m, 0.3);
        assert_eq!(c.settings.base_frame, "chassis");
        let e = node_config_from_params(yaml("barrier: {d_safe_m: 30.0}"), "ROS parameters of /n").unwrap_err();
        assert_eq!(e.keys(), ["barrier.d_safe_m"], "{e}");
        assert!(
            e.to_string()
                .starts_with("ROS parameters of /n: key `barrier.d_safe_m` = 30"),
            "{e}"
        );
        let e = node_config_from_params(yaml("barrier: {d_saf_m: 0.3}"), "P").unwrap_err();
        assert_eq!(e.keys(), ["barrier.d_saf_m"], "{e}");
        let e = node_config_from_params(yaml("node: {cmd_in_timeout_s: -1.0}"), "P").unwrap_err();
        assert_eq!(e.keys(), ["node.cmd_in_timeout_s"], "{e}");
        assert_eq!(
            e.to_string(),
            "P: key `node.cmd_in_timeout_s` = -1 is out of range; allowed: (0, 60] s"
        );
        let e = node_config_from_params(yaml("node: {base_frame: ''}"), "P").unwrap_err();
        assert_eq!(e.keys(), ["node.base_frame"], "{e}");
        assert_eq!(
            e.to_string(),
            "P: key `node.base_frame` = \"\" is out of range; allowed: a frame name, not empty"
        );
        let e = node_config_from_params(yaml("node: {nominal_source: sometimes}"), "P").unwrap_err();
        assert_eq!(e.keys(), ["node.nominal_source"], "{e}");
    }

    #[test]
    fn a_scenario_with_several_lidars_gives_their_scan_topics() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
        let f = root.join("config/scenarios/front_rear.yaml");
        let c = node_config_from_params(yaml(&format!("node: {{scenario: '{}'}}", f.display())), "P").unwrap();
        let topics: Vec<(&str, f64)> = c
            .settings
            .scans
            .iter()
            .map(|s| (s.topic.as_str(), s.timeout_s))
            .collect();
        // Two LiDARs at 10 Hz: 2.5 periods each.
        assert_eq!(topics, [("scan_0", 0.25), ("scan_1", 0.25)]);
        // One given in node.scans wins.
        let ns = yaml(&format!(
            "node: {{scenario: '{}', scans: [{{topic: front, timeout_s: 0.3}}]}}",
            f.display()
        ));
        assert_eq!(node_config_from_params(ns, "P").unwrap().settings.scans.len(), 1);
    }

    #[test]
    fn a_scenario_gives_the_reference_and_its_overrides() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
        let f = root.join("config/scenarios/two_robots.yaml");
        let ns = yaml(&format!("node: {{scenario: '{}', robot: robot2}}", f.display()));
        let c = node_config_from_params(ns, "P").unwrap();
        let r = c.reference.unwrap();
        assert!((r.start.x - 2.5).abs() < 1e-12 && (r.start.y + 2.5).abs() < 1e-12);
        let ns = yaml(&format!("node: {{scenario: '{}', robot: robot9}}", f.display()));
        let e = node_config_from_params(ns, "P").unwrap_err();
        assert_eq!(e.keys(), ["node.robot"], "{e}");
        let ns = yaml("node: {scenario: /no/such.yaml}");
        assert!(node_config_from_params(ns, "P")
            .unwrap_err()
            .to_string()
            .contains("/no/such.yaml"));
    }

    #[test]
    fn the_shipped_base_limits_agree_and_a_contradiction_names_both_keys() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
        let shipped = root.join("config/base_limits.yaml");
        let ns = yaml(&format!("node: {{base_limits_file: '{}'}}", shipped.display()));
        node_config_from_params(ns, "P").expect("the shipped filter and base limits agree");
        // Braking the base cannot do: 1.5 m/s² assumed, 1.0 m/s² guaranteed.
        let ns = yaml(&format!(
            "control: {{decel_mps2: 1.5}}\nnode: {{base_limits_file: '{}'}}",
            shipped.display()
        ));
        let e = node_config_from_params(ns, "ROS parameters of /n").unwrap_err();
        assert!(matches!(e, ConfigError::BaseLimits(_)), "{e:?}");
        assert_eq!(e.keys(), ["control.decel_mps2", "base.decel_mps2"]);
        assert_eq!(
            e.to_string(),
            format!(
                "ROS parameters of /n: key `control.decel_mps2` = 1.5 m/s² is above `base.decel_mps2` = 1 m/s² \
                 of the base's limits: the braking check would assume braking the base cannot do ({})",
                shipped.display()
            )
        );
        // Without a file nothing is compared (today's behaviour).
        node_config_from_params(yaml("control: {decel_mps2: 1.5}"), "P").unwrap();
        // A scenario's overrides are what is compared.
        let dir = std::env::temp_dir().join(format!("oldbf-base-limits-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let soft = dir.join("soft_base.yaml");
        std::fs::write(
            &soft,
            DEFAULT_BASE_LIMITS_YAML.replace("accel_mps2: 2.5", "accel_mps2: 2.0"),
        )
        .unwrap();
        let ns = yaml(&format!("node: {{base_limits_file: '{}'}}", soft.display()));
        let e = node_config_from_params(ns, "P").unwrap_err();
        assert_eq!(e.keys(), ["passive.evasion_accel_mps2", "base.accel_mps2"], "{e}");
        let ns = yaml("node: {base_limits_file: /no/such/base_limits.yaml}");
        let e = node_config_from_params(ns, "P").unwrap_err();
        assert!(
            e.to_string().starts_with("/no/such/base_limits.yaml: cannot read"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn shipped_node_file_matches_the_built_in_settings() {
        let v = config::parse_yaml(DEFAULT_NODE_YAML, "x").unwrap();
        let s: NodeSettings = config::from_value(v.get("node").unwrap().clone(), "x", "node").unwrap();
        assert_eq!(s, NodeSettings::default());
    }
}
