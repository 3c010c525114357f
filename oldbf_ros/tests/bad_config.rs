//! Bad configuration, table-driven, over every leaf key of every shipped
//! file of oldbf_ros: config/oldbf.yaml, config/oldbf_node.yaml,
//! config/scenarios/*.yaml and config/batch/*.yaml.
//!
//! For each file: a table row per key with a value out of its range (or of
//! its allowed set); generated cases for every key (wrong type, NaN and ±inf
//! for numbers, an unknown sibling key, the key removed where it is
//! required). Every error must name the file and the dotted key. A
//! completeness check fails when a shipped file gains a key with no row.

mod common;
mod yaml_paths;

use oldbf_ros::batch::Template;
use oldbf_ros::config::{load_params_file, DEFAULT_PARAMS_YAML};
use oldbf_ros::node_config::{node_config_from_params, DEFAULT_NODE_YAML};
use oldbf_ros::sim::scenario::Scenario;
use serde_yaml::Value;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;
use yaml_paths::{leaves, normalized, path, show, with, with_sibling, without, Seg};

/// config/oldbf.yaml: every leaf key and a value outside its range or set.
const PARAM_ROWS: &[(&str, &str)] = &[
    ("control.rate_hz", "0"),
    ("control.v_nom_mps", "-0.1"),
    ("control.v_max_mps", "0"),
    ("control.omega_max_radps", "11"),
    ("control.allow_reverse", "maybe"),
    ("control.v_reverse_max_mps", "-0.05"),
    ("footprint.semi_axis_1_m", "-0.1"),
    ("footprint.semi_axis_2_m", "5.1"),
    ("footprint.overall_dimension_m", "-1"),
    ("footprint.padding_m", "1.5"),
    ("laser.mount_x_m", "6"),
    ("laser.mount_y_m", "-6"),
    ("laser.mount_yaw_deg", "400"),
    ("laser.scan_timeout_s", "0"),
    ("laser.max_beams", "0"),
    ("laser.range_semantics", "all_free"),
    ("laser.zero_is_no_return", "sometimes"),
    ("laser.unknown_hold_s", "-1"),
    ("laser.blind_sector_deg", "0"),
    ("laser.blind_fraction", "1.5"),
    ("laser.blind_timeout_s", "61"),
    ("laser.range_noise_m", "0.2"),
    ("barrier.d_safe_m", "-0.2"),
    ("barrier.big_gamma", "0"),
    ("barrier.sigma", "0.05"),
    ("barrier.zeta", "-1"),
    ("barrier.beta", "11"),
    ("barrier.barrier_max", "1"),
    ("barrier.hemisphere_fov_deg", "0"),
    ("barrier.front_fov_deg", "361"),
    ("barrier.side_fade_deg", "91"),
    ("doaa.gain_k_radps", "-0.5"),
    ("doaa.omega_0_radps", "0"),
    ("doaa.both_sides_release_m", "-0.1"),
    ("doaa.front_stop_margin_m", "11"),
    ("doaa.both_sides_min_speed_mps", "-0.02"),
    ("doaa.front_nearest_tolerance_m", "-0.05"),
    ("doaa.full_gain_speed_mps", "0"),
    ("dtcbf.gamma", "1.5"),
    ("dtcbf.escape_epsilon_m", "0"),
    ("dtcbf.noise_margin_m", "-0.01"),
    ("dtcbf.prediction", "rk4"),
    ("dtcbf.omega_candidates", "20"),
    ("dtcbf.omega_weight_m2_per_rad2", "-1"),
    ("tracking.k_x_per_s", "-1"),
    ("tracking.k_y_per_m2", "1001"),
    ("tracking.k_theta_per_m", "-4"),
    ("tracking.capture_radius_m", "0"),
    ("tracking.k_bearing_per_s", "101"),
    ("tracking.arrive_radius_m", "-0.05"),
    ("unstuck.enabled", "2"),
    ("unstuck.stall_s", "0"),
    ("unstuck.progress_m", "0"),
    ("unstuck.window_m", "0.5"),
    ("unstuck.memory_s", "601"),
    ("unstuck.stuck_avoid_s", "-1"),
    ("unstuck.plan_period_s", "0.01"),
    ("unstuck.margin_m", "-1"),
    ("unstuck.ahead_m", "21"),
    ("passive.enabled", "yes please"),
    ("control.decel_mps2", "0"),
    ("control.accel_mps2", "-1"),
    ("control.angular_accel_radps2", "0"),
    ("passive.mover_margin_m", "-0.01"),
    ("passive.mover_growth_mps", "11"),
    ("passive.seen_margin_m", "0.3"),
    ("passive.closing_speed_mps", "2"),
    ("passive.evasion_horizon_s", "0"),
    ("passive.evasion_max_speed_mps", "-0.1"),
    ("passive.evasion_accel_mps2", "0.4"),
    ("passive.evasion_angular_accel_radps2", "0"),
    ("select.enabled", "maybe"),
    ("select.omega_samples", "2"),
    ("select.speed_samples", "51"),
    ("select.horizon_s", "0"),
    ("select.clearance_band_m", "0"),
    ("select.mover_near_m", "-1"),
    ("select.weights.nominal", "-1"),
    ("select.weights.smoothness", "1001"),
    ("select.weights.oscillation", "-0.5"),
    ("select.weights.doaa", "-2"),
    ("select.weights.progress", "nan"),
    ("select.weights.clearance", "-1"),
    ("select.weights.mover", "2000"),
    ("select.weights.side", "-1"),
    ("obstacles.enabled", "2"),
    ("obstacles.cluster_gap_m", "0"),
    ("obstacles.min_cluster_points", "0"),
    ("obstacles.max_cluster_diameter_m", "0"),
    ("obstacles.gate_m", "-0.5"),
    ("obstacles.confirm_hits", "0"),
    ("obstacles.max_misses", "1001"),
    ("obstacles.accel_noise_mps2", "0"),
    ("obstacles.measurement_noise_m", "0"),
    ("obstacles.moving_speed_mps", "-0.05"),
    ("obstacles.min_travel_m", "-0.3"),
    ("obstacles.motion_by_sight", "2"),
    ("obstacles.lookahead_s", "61"),
    ("obstacles.max_tracks", "0"),
    ("baselines.dcbf.lookahead_m", "0"),
    ("baselines.dcbf.sector_deg", "181"),
    ("baselines.dcbf.omega_weight", "0"),
    ("baselines.dcbf.slack_penalty", "-1"),
    ("baselines.vo.time_horizon_s", "0"),
    ("baselines.vo.static_time_horizon_s", "-1"),
    ("baselines.vo.heading_gain_per_s", "0"),
    ("baselines.vo.vertex_spacing_m", "1.5"),
];

/// config/oldbf_node.yaml (keys under `node.`).
const NODE_ROWS: &[(&str, &str)] = &[
    ("node.base_frame", "\"\""),
    ("node.nominal_source", "sometimes"),
    ("node.cmd_in_timeout_s", "0"),
    ("node.odom_timeout_s", "61"),
    ("node.publish_markers", "often"),
    ("node.scenario", "/no/such/scenario.yaml"),
    ("node.robot", "robot9"),
    ("node.e_stop_timeout_s", "-0.5"),
    ("node.disable_timeout_s", "3601"),
    ("node.plan_beside", "sometimes"),
    ("node.hardware_id", "\"two\\nlines\""),
    ("node.footprint_param", "\"two words\""),
    ("node.base_limits_file", "/no/such/base_limits.yaml"),
    ("node.laser_pose", "urdf"),
    ("node.tf_tolerance_s", "5.5"),
    ("node.scans", "often"),
    ("node.merged_beams", "100"),
];

/// Free-text keys: any string is valid there (a wrong type still is not).
const FREE_TEXT: &[&str] = &[
    "node.base_frame",
    "node.scenario",
    "node.robot",
    "node.hardware_id",
    "node.base_limits_file",
    "name",
    "description",
];

/// Keys that may be left out.
const OPTIONAL: &[&str] = &[];

fn tmp_dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("oldbf-bad-config-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn write(name: &str, doc: &Value) -> PathBuf {
    let p = tmp_dir().join(name);
    std::fs::write(&p, serde_yaml::to_string(doc).unwrap()).unwrap();
    p
}

fn doc(text: &str) -> Value {
    serde_yaml::from_str(text).unwrap()
}

/// The error must name the file and the key, as `FILE: key `KEY``.
fn assert_names(err: &str, file: &str, key: &str, case: &str) {
    let want = format!("{file}: key `{key}`");
    // A list names the element: `node.scans[0]`.
    let item = format!("{file}: key `{key}[");
    assert!(
        err.contains(&want) || err.contains(&item),
        "{case}: the error does not name `{want}`:\n{err}"
    );
}

/// The shipped file's leaf keys against a table's keys: every leaf has a row
/// and every row a leaf.
fn assert_complete(file: &str, leaf_keys: &BTreeSet<String>, rows: &BTreeSet<String>) {
    let missing: Vec<_> = leaf_keys.difference(rows).collect();
    let stale: Vec<_> = rows.difference(leaf_keys).collect();
    assert!(
        missing.is_empty() && stale.is_empty(),
        "{file}: keys with no table row {missing:?}; rows for keys it no longer has {stale:?}"
    );
}

/// Keys that take a number or a `[least, most]` pair: a three-element list
/// is their wrong list.
const NUMBER_OR_PAIR: &[&str] = &["room.width_m", "room.height_m"];

/// Wrong-type values for a leaf: a list and a mapping always; a string
/// unless the key is free text; NaN and ±inf for a float.
fn wrong_values(shipped: &Value, key: &str) -> Vec<&'static str> {
    let list = if NUMBER_OR_PAIR.contains(&key) {
        "[1, 2, 3]"
    } else {
        "[1, 2]"
    };
    let mut v = vec![list, "{a: 1}"];
    if !FREE_TEXT.contains(&key) && !shipped.is_string() {
        v.push("\"abc\"");
    }
    if shipped.is_f64() {
        v.extend([".nan", ".inf", "-.inf"]);
    }
    v
}

#[test]
fn params_every_key_has_a_row_and_every_row_is_rejected_naming_file_and_key() {
    let shipped = doc(DEFAULT_PARAMS_YAML);
    let keys: BTreeSet<String> = leaves(&shipped).iter().map(|p| show(p)).collect();
    let rows: BTreeSet<String> = PARAM_ROWS.iter().map(|(k, _)| k.to_string()).collect();
    assert_complete("config/oldbf.yaml", &keys, &rows);
    for (key, bad) in PARAM_ROWS {
        let p = write("oldbf.yaml", &with(&shipped, &path(key), bad));
        let e = load_params_file(&p)
            .expect_err(&format!("{key}: {bad} accepted"))
            .to_string();
        assert_names(&e, &p.display().to_string(), key, &format!("{key} = {bad}"));
    }
}

#[test]
fn params_generated_cases_for_every_key() {
    let shipped = doc(DEFAULT_PARAMS_YAML);
    let file = tmp_dir().join("gen_oldbf.yaml");
    let f = file.display().to_string();
    let load = |d: &Value| {
        std::fs::write(&file, serde_yaml::to_string(d).unwrap()).unwrap();
        load_params_file(&file).map(|_| ()).map_err(|e| e.to_string())
    };
    load(&shipped).expect("the shipped file loads");
    for leaf in leaves(&shipped) {
        let key = show(&leaf);
        let value = yaml_paths::get_mut(&mut shipped.clone(), &leaf).clone();
        for bad in wrong_values(&value, &key) {
            let e = load(&with(&shipped, &leaf, bad)).expect_err(&format!("{key}: {bad} accepted"));
            assert_names(&e, &f, &key, &format!("{key} = {bad}"));
        }
        let (d, sibling) = with_sibling(&shipped, &leaf);
        let e = load(&d).expect_err(&format!("{sibling} accepted"));
        assert_names(&e, &f, &sibling, "unknown key");
        if !OPTIONAL.contains(&key.as_str()) {
            let e = load(&without(&shipped, &leaf)).expect_err(&format!("{key} removed, accepted"));
            let (parent, _) = key.rsplit_once('.').unwrap_or((&key, ""));
            assert_names(&e, &f, parent, &format!("{key} removed"));
            let name = key.rsplit('.').next().unwrap();
            assert!(e.contains(&format!("missing field `{name}`")), "{key} removed: {e}");
        }
    }
    // The optional radius override (commented out in the shipped file) is range-checked too.
    let mut d = shipped.clone();
    yaml_paths::get_mut(&mut d, &path("footprint"))
        .as_mapping_mut()
        .unwrap()
        .insert("radius_override_m".into(), (-0.1).into());
    assert_names(
        &load(&d).unwrap_err(),
        &f,
        "footprint.radius_override_m",
        "radius override",
    );
    // The optional polygon (commented out in the shipped file): one that
    // crosses itself, and one too far out, are refused naming the key.
    for (bad, why) in [
        (
            "[[0.3, 0.2], [-0.3, -0.2], [0.3, -0.2], [-0.3, 0.2]]",
            "edges 0 and 2 intersect",
        ),
        ("[[0.3, 0.2], [-0.3, 0.2]]", "at least 3 vertices"),
        ("[[6.0, 0.2], [-0.3, 0.2], [-0.3, -0.2]]", "within 5 m"),
    ] {
        let mut d = shipped.clone();
        let polygon: Value = serde_yaml::from_str(bad).unwrap();
        yaml_paths::get_mut(&mut d, &path("footprint"))
            .as_mapping_mut()
            .unwrap()
            .insert("polygon_m".into(), polygon);
        let e = load(&d).unwrap_err();
        assert_names(&e, &f, "footprint.polygon_m", bad);
        assert!(e.contains(why), "{bad}: {e}");
    }
}

#[test]
fn node_settings_every_key_has_a_row_and_bad_values_name_the_key() {
    let shipped = doc(DEFAULT_NODE_YAML);
    let keys: BTreeSet<String> = leaves(&shipped).iter().map(|p| show(p)).collect();
    let rows: BTreeSet<String> = NODE_ROWS.iter().map(|(k, _)| k.to_string()).collect();
    assert_complete("config/oldbf_node.yaml", &keys, &rows);
    // The ROS node reads its private namespace; the source names it in messages.
    let src = "ROS parameters of /oldbf_node";
    let load = |d: Value| node_config_from_params(d, src).map(|_| ()).map_err(|e| e.to_string());
    load(shipped.clone()).expect("the shipped settings load");
    for (key, bad) in NODE_ROWS {
        if *key == "node.base_limits_file" {
            let e = load(with(&shipped, &path(key), bad)).expect_err("missing base limits accepted");
            // The base-limits file itself is named: it cannot be read.
            assert!(e.contains("/no/such/base_limits.yaml: cannot read"), "{e}");
            continue;
        }
        if *key == "node.scenario" {
            let e = load(with(&shipped, &path(key), bad)).expect_err("missing scenario accepted");
            // The scenario file itself is named: it cannot be read.
            assert!(e.contains("/no/such/scenario.yaml: cannot read"), "{e}");
            continue;
        }
        if *key == "node.robot" {
            // A robot name only means something with a scenario.
            let scn = common::repo_root().join("config/scenarios/two_robots.yaml");
            let d = with(
                &with(&shipped, &path("node.scenario"), &format!("'{}'", scn.display())),
                &path(key),
                bad,
            );
            let e = load(d).expect_err("unknown robot accepted");
            assert_names(&e, src, key, "node.robot");
            continue;
        }
        let e = load(with(&shipped, &path(key), bad)).expect_err(&format!("{key}: {bad} accepted"));
        assert_names(&e, src, key, &format!("{key} = {bad}"));
    }
    for leaf in leaves(&shipped) {
        let key = show(&leaf);
        let value = yaml_paths::get_mut(&mut shipped.clone(), &leaf).clone();
        for bad in wrong_values(&value, &key) {
            let e = load(with(&shipped, &leaf, bad)).expect_err(&format!("{key}: {bad} accepted"));
            assert_names(&e, src, &key, &format!("{key} = {bad}"));
        }
        let (d, sibling) = with_sibling(&shipped, &leaf);
        assert_names(&load(d).unwrap_err(), src, &sibling, "unknown key");
        // Node settings may be left out: the shipped defaults apply.
        load(without(&shipped, &leaf)).unwrap_or_else(|e| panic!("{key} removed: {e}"));
    }
    // Algorithm parameters on the parameter server are checked like the file.
    let e = load(doc("barrier: {d_safe_m: .nan}")).unwrap_err();
    assert_names(&e, src, "barrier.d_safe_m", "NaN parameter");
    let e = load(doc("[1, 2]")).unwrap_err();
    assert!(e.starts_with(src), "{e}");
}

/// Every shipped scenario or template, as (path shown in messages, document).
fn shipped(dir: &str) -> Vec<(PathBuf, Value)> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(common::repo_root().join(dir))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "yaml"))
        .collect();
    v.sort();
    assert!(!v.is_empty(), "no files in {dir}");
    v.into_iter()
        .map(|p| {
            let d = doc(&std::fs::read_to_string(&p).unwrap());
            (p, d)
        })
        .collect()
}

/// Scenario keys (indices as `[]`) and a value outside the range or set.
const SCENARIO_ROWS: &[(&str, &str)] = &[
    ("name", "[1]"),
    ("description", "[1]"),
    ("duration_s", "0"),
    ("seed", "-1"),
    ("robot.preset", "roomba9000"),
    ("start.x_m", ".nan"),
    ("start.y_m", ".inf"),
    ("start.theta_deg", ".nan"),
    ("reference_start.x_m", ".nan"),
    ("reference_start.y_m", "-.inf"),
    ("reference_start.theta_deg", ".inf"),
    ("lidar.beams", "0"),
    ("lidar.fov_deg", "361"),
    ("lidar.range_min_m", "-1"),
    ("lidar.range_max_m", "0"),
    ("lidar.noise_std_m", "-0.01"),
    ("lidar.dropout_prob", "1.5"),
    ("lidar.dropout", "sometimes"),
    ("lidar.rate_hz", "0"),
    ("lidars[].mount_x_m", "5.5"),
    ("lidars[].mount_y_m", ".nan"),
    ("lidars[].mount_yaw_deg", "400"),
    ("lidars[].lidar.beams", "0"),
    ("lidars[].lidar.fov_deg", "361"),
    ("lidars[].lidar.range_min_m", "-1"),
    ("lidars[].lidar.range_max_m", "0"),
    ("lidars[].lidar.noise_std_m", "-0.01"),
    ("lidars[].lidar.dropout_prob", "1.5"),
    ("lidars[].lidar.dropout", "sometimes"),
    ("lidars[].lidar.rate_hz", "0"),
    ("nominal.kind", "spiral"),
    ("nominal.v_mps", ".nan"),
    ("nominal.length_m", "-1"),
    ("nominal.omega_radps", ".inf"),
    ("nominal.laps", "-1"),
    ("goal_tolerance_m", "0"),
    ("world.polygons[][]", "[.nan, 0]"),
    ("world.boxes[].center", "[.inf, 0]"),
    ("world.boxes[].size", "[-1, 0.3]"),
    ("world.boxes[].yaw_deg", ".nan"),
    ("world.circles[].center", "[0, .nan]"),
    ("world.circles[].radius_m", "-0.1"),
    ("world.walls[].from", "[.nan, 0]"),
    ("world.walls[].to", "[0, .inf]"),
    ("world.moving[].motion.region_min", "[.nan, 0]"),
    ("world.moving[].motion.region_max", "[0, .inf]"),
    ("world.moving[].motion.waypoints[]", "[.nan, 0]"),
    ("world.moving[].name", "[1]"),
    ("world.moving[].radius_m", "0"),
    ("world.moving[].motion.kind", "teleport"),
    ("world.moving[].motion.start", "[.nan, 0]"),
    ("world.moving[].motion.velocity_mps", "[.inf, 0]"),
    ("world.moving[].motion.speed_mps", "-0.1"),
    ("robots[].name", "\"\""),
    ("robots[].start.x_m", ".nan"),
    ("robots[].start.y_m", ".nan"),
    ("robots[].start.theta_deg", ".inf"),
    ("robots[].nominal.kind", "spiral"),
    ("robots[].nominal.v_mps", ".nan"),
    ("robots[].nominal.length_m", "-1"),
];

/// Batch template keys and a value outside the range or set.
const TEMPLATE_ROWS: &[(&str, &str)] = &[
    ("name", "[1]"),
    ("description", "[1]"),
    ("duration_s", "0"),
    ("room.width_m", "0"),
    ("room.height_m", "-1"),
    ("robot.preset", "roomba9000"),
    ("lidar.beams", "0"),
    ("lidar.fov_deg", "361"),
    ("lidar.range_min_m", "-1"),
    ("lidar.range_max_m", "0"),
    ("lidar.noise_std_m", "-0.01"),
    ("lidar.dropout_prob", "1.5"),
    ("lidar.dropout", "sometimes"),
    ("lidar.rate_hz", "0"),
    ("nominal.v_mps", "0"),
    ("nominal.wall_margin_m", "-1"),
    ("goal_tolerance_m", "0"),
    ("start_clearance_m", "-1"),
    ("static_obstacles.circles.count", "[3, 1]"),
    ("static_obstacles.circles.radius_m", "[0, 0.3]"),
    ("static_obstacles.boxes.count", "[0, 1001]"),
    ("static_obstacles.boxes.size_m", "[0.8, 0.3]"),
    ("static_obstacles.require_path", "maybe"),
    ("static_obstacles.benches.count", "[4, 1]"),
    ("static_obstacles.benches.length_m", "[1.6, 1.0]"),
    ("static_obstacles.benches.width_m", "[-0.3, 0.5]"),
    ("static_obstacles.near_line_fraction", "1.5"),
    ("static_obstacles.near_line_m", "-0.1"),
    ("doorway.tilt_deg", "[-60, 15]"),
    ("doorway.thickness_m", "[0.25, 0.08]"),
    ("doorway.passage_m", "[0.6, 9.0]"),
    ("time_budget_factor", "0.5"),
    ("doorway.width_m", "[1.3, 0.5]"),
    ("doorway.along", "[0.05, 0.5]"),
    ("doorway.offset_m", "[-100, 0.5]"),
    ("moving_obstacles.count", "[5, 3]"),
    ("moving_obstacles.speed_fraction", "[-0.1, 0.3]"),
    ("moving_obstacles.radius_m", "[0.1, .nan]"),
    ("moving_obstacles.kinds", "[teleport]"),
];

type Loader = fn(&Path) -> Result<(), String>;

fn load_scenario(p: &Path) -> Result<(), String> {
    Scenario::load(p, None).map(|_| ()).map_err(|e| e.to_string())
}

fn load_template(p: &Path) -> Result<(), String> {
    Template::load(p, None).map(|_| ()).map_err(|e| e.to_string())
}

/// Whether the error names `file` and `key` or, for keys inside a
/// sequence, an ancestor (a motion or a nominal's variant is checked as a
/// whole): returns the key it named.
fn named_key(err: &str, file: &str) -> Option<String> {
    let start = err.find(&format!("{file}: key `"))? + file.len() + ": key `".len();
    let len = err[start..].find('`')?;
    Some(err[start..start + len].to_string())
}

/// Internally tagged items (`nominal: {kind: line, ...}`, `motion: {kind:
/// ...}`): serde checks their fields as a whole, so an error inside one names
/// the item (`world.moving[0].motion`), and the message names the field.
fn tagged_item(want: &str) -> Option<&str> {
    ["nominal", ".motion", "].nominal"]
        .iter()
        .filter_map(|t| want.find(t).map(|i| &want[..i + t.len()]))
        .find(|item| want.len() > item.len() && want[item.len()..].starts_with('.'))
}

/// Table rows and generated cases over every shipped file of `dir`.
fn check_dir(dir: &str, rows: &[(&str, &str)], load: Loader) {
    let files = shipped(dir);
    let mut keys = BTreeSet::new();
    let mut problems = Vec::new();
    let out = tmp_dir().join(format!("{}.yaml", dir.replace('/', "_")));
    let f = out.display().to_string();
    let try_doc = |d: &Value| {
        std::fs::write(&out, serde_yaml::to_string(d).unwrap()).unwrap();
        load(&out)
    };
    for (p, d) in &files {
        try_doc(d).unwrap_or_else(|e| panic!("{} does not load: {e}", p.display()));
        for leaf in leaves(d) {
            let key = show(&leaf);
            keys.insert(normalized(&leaf));
            let value = yaml_paths::get_mut(&mut d.clone(), &leaf).clone();
            let mut cases: Vec<(String, Value, String)> = wrong_values(&value, &key)
                .into_iter()
                .filter(|bad| !(value.is_sequence() && bad.starts_with('[')))
                .map(|bad| (format!("{key} = {bad}"), with(d, &leaf, bad), key.clone()))
                .collect();
            if let Some(Seg::Key(_)) = leaf.last() {
                let (sd, sibling) = with_sibling(d, &leaf);
                cases.push((format!("unknown {sibling}"), sd, sibling));
            }
            if let Some((_, bad)) = rows.iter().find(|(k, _)| *k == normalized(&leaf)) {
                cases.push((format!("{key} = {bad} (table)"), with(d, &leaf, bad), key.clone()));
            }
            for (case, bad_doc, want) in cases {
                match try_doc(&bad_doc) {
                    Ok(()) => problems.push(format!("{}: {case}: accepted", p.display())),
                    Err(e) => match named_key(&e, &f) {
                        // A pair or list names the element: `radius_m[0]`.
                        Some(k) if k == want || k.starts_with(&format!("{want}[")) => {}
                        Some(k) if tagged_item(&want) == Some(k.as_str()) => {}
                        // A point `[x, y]` is checked as a whole.
                        Some(k)
                            if k.ends_with(']')
                                && (want.starts_with(&format!("{k}.")) || want.starts_with(&format!("{k}["))) => {}
                        // The `oldbf:` section is checked as parameters, under its prefix.
                        Some(k) => problems.push(format!("{}: {case}: names `{k}`, not `{want}`: {e}", p.display())),
                        None => problems.push(format!("{}: {case}: names no key: {e}", p.display())),
                    },
                }
            }
        }
    }
    let rows: BTreeSet<String> = rows.iter().map(|(k, _)| k.to_string()).collect();
    let missing: Vec<_> = keys
        .iter()
        .filter(|k| !rows.contains(*k) && !k.starts_with("oldbf."))
        .collect();
    problems.extend(missing.iter().map(|k| format!("{dir}: key `{k}` has no table row")));
    problems.extend(
        rows.iter()
            .filter(|k| !keys.contains(*k))
            .map(|k| format!("{dir}: table row `{k}` is no key of any shipped file")),
    );
    assert!(
        problems.is_empty(),
        "{} problems:\n{}",
        problems.len(),
        problems.join("\n")
    );
}

#[test]
fn scenarios_every_key_has_a_row_and_bad_values_name_file_and_key() {
    check_dir("config/scenarios", SCENARIO_ROWS, load_scenario);
}

#[test]
fn templates_every_key_has_a_row_and_bad_values_name_file_and_key() {
    check_dir("config/batch", TEMPLATE_ROWS, load_template);
}

fn oldbf() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_oldbf"));
    c.current_dir(common::repo_root()).env("RUST_LOG", "warn");
    c
}

#[test]
fn cli_bad_params_missing_files_and_bad_scenarios_exit_2_naming_file_and_key() {
    let shipped = doc(DEFAULT_PARAMS_YAML);
    let bad = write("cli_params.yaml", &with(&shipped, &path("barrier.d_safe_m"), "-0.2"));
    let b = bad.display().to_string();
    let scn = "config/scenarios/paper_line.yaml";
    let cases: Vec<(Vec<String>, String)> = vec![
        (
            vec!["sim".into(), scn.into(), "--config".into(), b.clone()],
            format!("{b}: key `barrier.d_safe_m` = -0.2 is out of range"),
        ),
        (
            vec!["check-config".into(), b.clone()],
            format!("{b}: key `barrier.d_safe_m`"),
        ),
        (
            vec![
                "batch".into(),
                "config/batch/slow_obstacles.yaml".into(),
                "--config".into(),
                b.clone(),
            ],
            format!("{b}: key `barrier.d_safe_m`"),
        ),
        (
            vec![
                "sim".into(),
                scn.into(),
                "--config".into(),
                "/no/such/oldbf.yaml".into(),
            ],
            "/no/such/oldbf.yaml: cannot read".into(),
        ),
        (
            vec!["sim".into(), "/no/such/scenario.yaml".into()],
            "/no/such/scenario.yaml: cannot read".into(),
        ),
        (
            vec![
                "carmen".into(),
                "tests/data/none.log".into(),
                "--config".into(),
                b.clone(),
            ],
            format!("{b}: key `barrier.d_safe_m`"),
        ),
    ];
    for (args, want) in cases {
        let out = oldbf().args(&args).output().unwrap();
        let e = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {e}");
        assert!(e.contains(&want), "{args:?}: wanted `{want}` in:\n{e}");
        assert!(out.stdout.is_empty(), "{args:?}: printed a result");
    }
    // A scenario with a bad key and one with a bad override.
    let s = doc(&std::fs::read_to_string(common::repo_root().join(scn)).unwrap());
    for (key, bad, named) in [("duration_s", "-1", "duration_s"), ("lidar.beams", "0", "lidar.beams")] {
        let p = write("cli_scn.yaml", &with(&s, &path(key), bad));
        let out = oldbf().arg("sim").arg(&p).output().unwrap();
        let e = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{e}");
        assert!(e.contains(&format!("{}: key `{named}`", p.display())), "{e}");
    }
    let mut s2 = s.clone();
    s2.as_mapping_mut()
        .unwrap()
        .insert("oldbf".into(), doc("{dtcbf: {gamma: 0}}"));
    let p = write("cli_scn_over.yaml", &s2);
    let out = oldbf().arg("sim").arg(&p).output().unwrap();
    let e = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{e}");
    assert!(
        e.contains(&format!("{}: key `oldbf.dtcbf.gamma` = 0", p.display())),
        "{e}"
    );
}
