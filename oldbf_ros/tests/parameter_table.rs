//! The parameter table of docs/PARAMETERS.md agrees with the validated
//! defaults: `config/oldbf.yaml`, loaded by the loader the CLI uses
//! (`config::load_params_file`, as `oldbf check-config` does), and
//! `Params::default()` serialized with serde_yaml.
//!
//! Coverage rule: the table documents every leaf key of config/oldbf.yaml,
//! every section included (`baselines.*` too: the table has rows for the
//! DCBF and VO baselines, which the filter and the ROS node ignore). It does
//! not document other files (`config/oldbf_node.yaml`, the CAN bridge's):
//! those are in docs/ROS.md and can_bridge/README.md. One key is optional,
//! `footprint.radius_override_m`: left out of the YAML and `None` in
//! `Params::default()`; its row's default reads `absent`, and the test sets
//! it in a copy of the YAML to check the loader knows it.
//!
//! Rows read `| `key` | default | unit | allowed | meaning |`. A row may name
//! several keys of one section (`` `laser.mount_x_m`, `mount_y_m` ``, the
//! later keys taking the first's section), with one default per key
//! (`0, 0`). Numbers are compared as f64 with a relative tolerance of 1e-9
//! (`10⁹` reads as 1e9, `−` as `-`); booleans and strings textually.

mod common;
mod yaml_paths;

use oldbf_ros::algo::params::Params;
use oldbf_ros::config::{load_params_file, load_params_str};
use serde_yaml::Value;
use std::collections::BTreeMap;

/// One row of the table.
#[derive(Debug, PartialEq)]
struct Row {
    keys: Vec<String>,
    defaults: Vec<String>,
    unit: String,
    allowed: String,
}

/// A table row, or None for the header, the separator and anything else.
/// `\|` inside a cell is a literal bar, not a cell boundary.
fn parse_row(line: &str) -> Option<Row> {
    let line = line.trim();
    let inner = line.strip_prefix('|')?.strip_suffix('|')?;
    let inner = inner.replace("\\|", "\u{0}");
    let cells: Vec<String> = inner.split('|').map(|c| c.trim().replace('\u{0}', "|")).collect();
    if cells.len() != 5 || !cells[0].starts_with('`') {
        return None;
    }
    let mut keys: Vec<String> = Vec::new();
    for k in cells[0].split(',') {
        let k = k.trim().trim_matches('`').to_string();
        match keys.first() {
            // A later key without its section takes the first key's.
            Some(first) if !k.contains('.') => {
                let section = first.rsplit_once('.').map_or("", |(s, _)| s);
                keys.push(format!("{section}.{k}"));
            }
            _ => keys.push(k),
        }
    }
    let defaults: Vec<String> = if keys.len() == 1 {
        vec![cells[1].clone()]
    } else {
        cells[1].split(',').map(|d| d.trim().to_string()).collect()
    };
    Some(Row {
        keys,
        defaults,
        unit: cells[2].clone(),
        allowed: cells[3].clone(),
    })
}

/// The rows of the table that follows the `| key | default |` header.
fn table_rows(doc: &str) -> Vec<Row> {
    doc.lines()
        .skip_while(|l| !l.trim_start().starts_with("| key | default |"))
        .take_while(|l| l.trim_start().starts_with('|'))
        .filter_map(parse_row)
        .collect()
}

/// A number as the table writes it: `0.15`, `16384`, `−5`, `10⁹`, `1e9`.
fn number(text: &str) -> Option<f64> {
    let t = text.trim().replace('−', "-");
    if let Some(exp) = t.strip_prefix("10").filter(|e| !e.is_empty()) {
        const SUP: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];
        let digits: Option<String> = exp
            .chars()
            .map(|c| {
                if c == '⁻' {
                    Some('-')
                } else {
                    SUP.iter()
                        .position(|&s| s == c)
                        .and_then(|d| char::from_digit(d as u32, 10))
                }
            })
            .collect();
        if let Some(e) = digits {
            return e.parse::<i32>().ok().map(|e| 10f64.powi(e));
        }
    }
    t.parse::<f64>().ok()
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs())
}

/// Does the table's default text agree with a YAML value?
fn agrees(value: &Value, text: &str) -> bool {
    match value {
        Value::Number(n) => match (n.as_f64(), number(text)) {
            (Some(a), Some(b)) => close(a, b),
            _ => false,
        },
        Value::Bool(b) => text == b.to_string(),
        Value::String(s) => text == s,
        _ => false,
    }
}

/// Two YAML values alike: numbers as f64 (10 and 10.0 agree), else equal.
fn same_value(a: &Value, b: &Value) -> bool {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => match (x.as_f64(), y.as_f64()) {
            (Some(x), Some(y)) => close(x, y),
            _ => false,
        },
        _ => a == b,
    }
}

/// Every leaf of a YAML document by its dotted key.
fn flatten(doc: &Value) -> BTreeMap<String, Value> {
    let mut copy = doc.clone();
    yaml_paths::leaves(doc)
        .into_iter()
        .map(|p| (yaml_paths::show(&p), yaml_paths::get_mut(&mut copy, &p).clone()))
        .collect()
}

/// What is wrong between the table in `doc` and the flattened YAML `yaml`,
/// one message each; also the keys whose rows read `absent`.
fn check(doc: &str, yaml: &BTreeMap<String, Value>) -> (Vec<String>, Vec<String>) {
    let rows = table_rows(doc);
    let mut problems = Vec::new();
    let mut absent = Vec::new();
    if rows.is_empty() {
        problems.push("no parameter table found".to_string());
    }
    let mut seen: BTreeMap<String, usize> = BTreeMap::new();
    for row in &rows {
        if row.defaults.len() != row.keys.len() {
            problems.push(format!(
                "row {:?}: {} key(s) but {} default(s)",
                row.keys,
                row.keys.len(),
                row.defaults.len()
            ));
            continue;
        }
        for (key, default) in row.keys.iter().zip(&row.defaults) {
            *seen.entry(key.clone()).or_default() += 1;
            match (yaml.get(key), default.as_str()) {
                (Some(v), "absent") => {
                    problems.push(format!("`{key}`: the table says absent, config/oldbf.yaml has {v:?}"))
                }
                (None, "absent") => absent.push(key.clone()),
                (None, _) => problems.push(format!("`{key}`: in the table, not in config/oldbf.yaml")),
                (Some(v), d) if !agrees(v, d) => problems.push(format!(
                    "`{key}`: the table's default is {d}, config/oldbf.yaml has {v:?}"
                )),
                _ => {}
            }
        }
    }
    for key in yaml.keys() {
        match seen.get(key).copied().unwrap_or(0) {
            1 => {}
            0 => problems.push(format!("`{key}`: in config/oldbf.yaml, no row in the table")),
            n => problems.push(format!("`{key}`: {n} rows in the table")),
        }
    }
    for (key, &n) in &seen {
        if n > 1 && !yaml.contains_key(key) {
            problems.push(format!("`{key}`: {n} rows in the table"));
        }
    }
    (problems, absent)
}

fn shipped() -> (String, Value) {
    let root = common::repo_root();
    let doc =
        std::fs::read_to_string(root.join("docs/PARAMETERS.md")).expect("docs/PARAMETERS.md is in the repository");
    let text = std::fs::read_to_string(root.join("config/oldbf.yaml")).expect("config/oldbf.yaml is in the repository");
    let yaml: Value = serde_yaml::from_str(&text).expect("config/oldbf.yaml is YAML");
    (doc, yaml)
}

#[test]
fn the_row_parser_reads_keys_defaults_and_escaped_bars() {
    let r = parse_row("| `barrier.zeta` | 0.5 | – | [0, 100] | ζ in B_v = Γζ\\|v\\|/(1 + \\|v\\|^β) |").unwrap();
    assert_eq!(r.keys, ["barrier.zeta"]);
    assert_eq!(r.defaults, ["0.5"]);
    assert_eq!((r.unit.as_str(), r.allowed.as_str()), ("–", "[0, 100]"));
    let r = parse_row("| `laser.mount_x_m`, `mount_y_m` | 0, 0 | m | [−5, 5] | laser origin |").unwrap();
    assert_eq!(r.keys, ["laser.mount_x_m", "laser.mount_y_m"]);
    assert_eq!(r.defaults, ["0", "0"]);
    let r = parse_row("| `dtcbf.omega_candidates` | 21 | – | odd, [3, 201] | yaw rates |").unwrap();
    assert_eq!((r.defaults[0].as_str(), r.allowed.as_str()), ("21", "odd, [3, 201]"));
    assert_eq!(parse_row("| key | default | unit | allowed | meaning |"), None);
    assert_eq!(parse_row("|---|---|---|---|---|"), None);
    assert_eq!(parse_row("text with `code`"), None);

    assert_eq!(number("10⁹"), Some(1e9));
    assert_eq!(number("10¹²"), Some(1e12));
    assert_eq!(number("−5"), Some(-5.0));
    assert_eq!(number("0.20"), Some(0.2));
    assert_eq!(number("10"), Some(10.0));
    assert_eq!(number("absent"), None);
    assert!(agrees(&Value::from(0.2), "0.20"));
    assert!(agrees(&Value::from(16384), "16384"));
    assert!(!agrees(&Value::from(0.02), "0.05"));
    assert!(agrees(&Value::from(true), "true"));
    assert!(!agrees(&Value::from(true), "1"));
    assert!(agrees(&Value::from("rep117"), "rep117"));
    assert!(!agrees(&Value::from("euler"), "arc"));
}

#[test]
fn the_check_catches_a_wrong_default_a_missing_row_a_duplicate_and_a_stray_key() {
    let (doc, yaml) = shipped();
    let yaml = flatten(&yaml);
    let row = "| `obstacles.moving_speed_mps` | 0.02 |";
    assert!(doc.contains(row), "the table has the row this test edits");
    let cases = [
        (
            doc.replace(row, "| `obstacles.moving_speed_mps` | 0.05 |"),
            "the table's default is 0.05",
        ),
        (
            doc.lines()
                .filter(|l| !l.starts_with("| `obstacles.moving_speed_mps`"))
                .collect::<Vec<_>>()
                .join("\n"),
            "no row in the table",
        ),
        (
            doc.replace(row, &format!("{row} m/s | [0, 10] | x |\n{row}")),
            "2 rows in the table",
        ),
        (
            doc.replace(row, "| `obstacles.moving_speed_mps`, `typo_m` | 0.02, 1 |"),
            "`obstacles.typo_m`: in the table, not in config/oldbf.yaml",
        ),
    ];
    for (broken, expected) in cases {
        let (problems, _) = check(&broken, &yaml);
        assert!(
            problems.iter().any(|p| p.contains(expected)),
            "expected a problem containing {expected:?}, got {problems:?}"
        );
    }
}

#[test]
fn the_parameter_table_agrees_with_config_oldbf_yaml_and_params_default() {
    let root = common::repo_root();
    let (doc, yaml_doc) = shipped();
    let yaml = flatten(&yaml_doc);

    // The file loads through the CLI's loader and equals the built-in defaults.
    let loaded = load_params_file(&root.join("config/oldbf.yaml")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        loaded,
        Params::default(),
        "config/oldbf.yaml differs from Params::default()"
    );

    // Params::default(), serialized, has the same keys and values as the file.
    let defaults = flatten(&serde_yaml::to_value(Params::default()).expect("Params serializes"));
    assert_eq!(
        defaults.keys().collect::<Vec<_>>(),
        yaml.keys().collect::<Vec<_>>(),
        "keys of Params::default() and config/oldbf.yaml"
    );
    for (key, v) in &yaml {
        assert!(
            same_value(v, &defaults[key]),
            "`{key}`: config/oldbf.yaml {v:?}, Params::default() {:?}",
            defaults[key]
        );
    }

    let (problems, absent) = check(&doc, &yaml);
    assert!(
        problems.is_empty(),
        "docs/PARAMETERS.md disagrees with config/oldbf.yaml:\n{}",
        problems.join("\n")
    );

    // Rows whose default is `absent`: only the optional key, and the loader knows it.
    assert_eq!(
        absent,
        ["footprint.radius_override_m"],
        "rows whose default reads `absent`"
    );
    let rows = table_rows(&doc);
    for key in &absent {
        let row = rows.iter().find(|r| r.keys.contains(key)).expect("the row exists");
        let (lo, hi) = row
            .allowed
            .trim_matches(|c| "[]()".contains(c))
            .split_once(',')
            .and_then(|(a, b)| Some((number(a)?, number(b)?)))
            .unwrap_or_else(|| panic!("`{key}`: allowed {:?} is not an interval", row.allowed));
        let value = (lo + hi) / 2.0;
        let (section, leaf) = key.split_once('.').expect("a dotted key");
        let mut edited = yaml_doc.clone();
        edited
            .get_mut(section)
            .and_then(Value::as_mapping_mut)
            .unwrap_or_else(|| panic!("no section {section}"))
            .insert(Value::from(leaf), Value::from(value));
        let text = serde_yaml::to_string(&edited).expect("serializes");
        let params = load_params_str(&text, "edited config/oldbf.yaml").unwrap_or_else(|e| panic!("`{key}`: {e}"));
        let set = flatten(&serde_yaml::to_value(params).expect("Params serializes"));
        assert!(
            set.get(key).is_some_and(|v| same_value(v, &Value::from(value))),
            "`{key}` set to {value} did not reach Params: {:?}",
            set.get(key)
        );
    }
}
