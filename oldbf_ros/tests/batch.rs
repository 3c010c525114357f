//! `oldbf batch` as a user runs it: a few worlds, two controllers.

mod common;

use serde_json::Value;
use std::path::PathBuf;
use std::process::{Command, Output};

fn oldbf() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_oldbf"));
    c.current_dir(common::repo_root()).env("RUST_LOG", "warn");
    c
}

fn stdout_of(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("oldbf-batch-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// Runs `oldbf batch` on the slow template with `extra` arguments; returns
/// the whole stdout and the JSON of its last line.
fn batch(extra: &[&str]) -> (String, Value) {
    let out = oldbf()
        .args([
            "batch",
            "config/batch/slow_obstacles.yaml",
            "--worlds",
            "4",
            "--seed",
            "3",
            "--json",
        ])
        .args(extra)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = stdout_of(&out);
    let last = text.lines().last().expect("some output");
    let json = serde_json::from_str(last).unwrap_or_else(|e| panic!("last line is not JSON ({e}): {last}"));
    (text, json)
}

fn f(v: &Value, key: &str) -> f64 {
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("{key} is not a number in {v}"))
}

fn u(v: &Value, key: &str) -> u64 {
    v[key].as_u64().unwrap_or_else(|| panic!("{key} is not a count in {v}"))
}

#[test]
fn batch_prints_a_table_and_the_comparison_as_json() {
    let dir = temp_dir("out");
    let (text, v) = batch(&[
        "--controllers",
        "oldbf,none",
        "--threads",
        "2",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert!(
        text.starts_with("batch slow_obstacles (config/batch/slow_obstacles.yaml) | 4 worlds | seed 3"),
        "{text}"
    );
    assert!(
        text.lines().any(|l| l.starts_with("oldbf ")) && text.lines().any(|l| l.starts_with("none ")),
        "{text}"
    );
    assert_eq!(v["worlds"], 4);
    assert_eq!(v["seed"], 3);
    assert_eq!(v["threads"], 2);
    assert_eq!(v["controllers"], serde_json::json!(["oldbf", "none"]));
    let rows = v["rows"].as_array().expect("rows");
    assert_eq!(rows.len(), 2);
    for (row, name) in rows.iter().zip(["oldbf", "none"]) {
        assert_eq!(row["controller"], name);
        assert_eq!(u(row, "worlds"), 4);
        for rate in ["collision_rate", "goal_rate"] {
            assert!((0.0..=1.0).contains(&f(row, rate)), "{rate} in {row}");
        }
        assert_eq!(f(row, "collision_rate"), u(row, "worlds_with_collision") as f64 / 4.0);
        assert!(u(row, "collisions_total") >= u(row, "worlds_with_collision"));
        let (min, p5, median) = (
            f(row, "min_clearance_min_m"),
            f(row, "min_clearance_p5_m"),
            f(row, "min_clearance_median_m"),
        );
        assert!(min <= p5 && p5 <= median && median < 10.0, "{row}");
        assert!(min > -1.0, "a body cannot be 1 m inside an obstacle: {row}");
        if u(row, "worlds_reached") > 0 {
            // The shortest line is 4.4 m at 0.15 m/s, the longest run 120 s.
            let t = f(row, "mean_time_to_goal_s");
            assert!((4.4 / 0.22..=120.0).contains(&t), "{row}");
        }
        assert!((0.0..50.0).contains(&f(row, "mean_path_length_m")), "{row}");
        assert!(u(row, "cbf_violations_total") >= u(row, "worlds_with_cbf_violation"));
        assert!(u(row, "true_cbf_violations_total") >= u(row, "worlds_with_true_cbf_violation"));
        assert!(u(row, "steps_total") >= 4 * 20, "{row}");
        let (mean, p99) = (f(row, "mean_step_us"), f(row, "p99_step_us"));
        assert!(mean > 0.0 && p99 > 0.0 && mean.is_finite() && p99.is_finite(), "{row}");
    }
    // The unfiltered nominal tracks its line almost exactly.
    assert!(f(&rows[1], "mean_max_tracking_error_m") < 0.05, "{}", rows[1]);

    // --out: the table, every outcome, the plot and the worlds.
    let csv = std::fs::read_to_string(dir.join("comparison.csv")).unwrap();
    assert_eq!(csv.lines().count(), 3, "{csv}");
    assert!(csv.starts_with("controller,worlds,"), "{csv}");
    let full: Value = serde_json::from_str(&std::fs::read_to_string(dir.join("comparison.json")).unwrap()).unwrap();
    assert_eq!(full["rows"], v["rows"]);
    assert_eq!(full["per_world"].as_array().map(Vec::len), Some(8));
    assert_eq!(
        std::fs::read_to_string(dir.join("per_world.csv"))
            .unwrap()
            .lines()
            .count(),
        9
    );
    for f in ["min_clearance.png", "min_clearance.svg"] {
        assert!(
            std::fs::metadata(dir.join(f)).map(|m| m.len() > 1000).unwrap_or(false),
            "{f}"
        );
    }
    for i in 0..4 {
        assert!(dir.join(format!("worlds/world_{i:04}.yaml")).is_file(), "world {i}");
    }

    // A saved world reruns exactly with `oldbf sim` (same sensor seed, same world).
    let world1 = |c: &str| {
        full["per_world"]
            .as_array()
            .unwrap()
            .iter()
            .find(|o| o["world"] == 1 && o["controller"] == c)
            .cloned()
            .unwrap()
    };
    let out = oldbf()
        .args(["sim", "--json", "--controller", "none"])
        .arg(dir.join("worlds/world_0001.yaml"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let sim: Value = serde_json::from_str(stdout_of(&out).lines().last().unwrap()).unwrap();
    let expected = world1("none");
    for key in [
        "collisions",
        "min_clearance_m",
        "steps",
        "cbf_violations",
        "path_length_m",
    ] {
        assert_eq!(sim[key], expected[key], "{key}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The JSON without the wall-clock figures.
fn without_timing(mut v: Value) -> Value {
    for key in ["wall_time_s", "threads"] {
        v.as_object_mut().unwrap().remove(key);
    }
    for row in v["rows"].as_array_mut().unwrap() {
        for key in ["mean_step_us", "p99_step_us", "max_step_us"] {
            row.as_object_mut().unwrap().remove(key);
        }
    }
    v
}

#[test]
fn figures_do_not_depend_on_the_thread_count() {
    let (_, one) = batch(&["--controllers", "none", "--threads", "1"]);
    let (_, two) = batch(&["--controllers", "none,none", "--threads", "2"]);
    assert_eq!(two["controllers"], serde_json::json!(["none"]), "repeats are dropped");
    assert_eq!(without_timing(one), without_timing(two));
}

fn fails_with(args: &[&str], code: i32, needles: &[&str]) {
    let out = oldbf().args(args).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(code), "{args:?}: {err}");
    assert!(stdout_of(&out).is_empty(), "{args:?} printed to stdout");
    for n in needles {
        assert!(err.contains(n), "{args:?}: stderr lacks {n}: {err}");
    }
}

#[test]
fn bad_templates_and_options_exit_2_naming_the_problem() {
    let dir = temp_dir("bad");
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.yaml");
    let text = std::fs::read_to_string(common::repo_root().join("config/batch/fast_obstacles.yaml"))
        .unwrap()
        .replace("speed_fraction: [1.1, 2.0]", "speed_fraction: [1.1, 25]");
    std::fs::write(&bad, text).unwrap();
    let bad = bad.to_str().unwrap();
    fails_with(
        &["batch", bad, "--worlds", "2"],
        2,
        &["bad.yaml", "moving_obstacles.speed_fraction[1]", "(0, 20]"],
    );
    fails_with(&["batch", "no/such/template.yaml"], 2, &["no/such/template.yaml"]);
    let good = "config/batch/slow_obstacles.yaml";
    fails_with(&["batch", good, "--worlds", "0"], 2, &["--worlds"]);
    fails_with(&["batch", good, "--threads", "0"], 2, &["--threads"]);
    fails_with(&["batch", good, "--controllers", "oldbf,magic"], 2, &["magic"]);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn batch_help_explains_every_option_with_units() {
    let out = oldbf().args(["batch", "--help"]).output().unwrap();
    assert!(out.status.success());
    let text = stdout_of(&out);
    for needle in [
        "--worlds",
        "--seed",
        "--controllers",
        "--json",
        "--out",
        "--threads",
        "--config",
        "(m)",
        "(s)",
        "(µs)",
        "oldbf",
        "none",
    ] {
        assert!(text.contains(needle), "batch --help lacks {needle}:\n{text}");
    }
}
