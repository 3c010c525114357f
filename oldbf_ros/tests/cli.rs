//! The `oldbf` command line as a user runs it.

mod common;

use std::process::Command;

fn oldbf() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_oldbf"));
    c.current_dir(common::repo_root()).env("RUST_LOG", "warn");
    c
}

fn stdout_of(out: &std::process::Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[test]
fn sim_prints_a_summary_and_json_on_the_last_line() {
    let out = oldbf()
        .args(["sim", "config/scenarios/paper_line.yaml", "--json"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = stdout_of(&out);
    assert!(text.contains("collisions 0"), "{text}");
    let last = text.lines().last().unwrap();
    let v: serde_json::Value = serde_json::from_str(last).unwrap();
    for key in [
        "collisions",
        "min_clearance_m",
        "cbf_violations",
        "steps",
        "reached_goal",
        "path_length_m",
        "max_tracking_error_m",
        "mean_step_us",
    ] {
        assert!(v.get(key).is_some(), "missing {key} in {last}");
    }
    assert_eq!(v["collisions"], 0);
    assert_eq!(v["reached_goal"], true);
}

#[test]
fn sim_out_writes_csv_and_plots() {
    let dir = std::env::temp_dir().join(format!("oldbf-cli-{}", std::process::id()));
    let out = oldbf()
        .args(["sim", "config/scenarios/dead_end.yaml", "--seed", "3", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let csv = std::fs::read_to_string(dir.join("steps.csv")).unwrap();
    assert!(csv.starts_with("t_s,x_m,y_m,"));
    assert_eq!(csv.lines().count(), 801, "800 steps of 0.1 s plus the header");
    for f in ["trajectory", "barriers", "velocities"] {
        for ext in ["png", "svg"] {
            let p = dir.join(format!("{f}.{ext}"));
            assert!(
                std::fs::metadata(&p).map(|m| m.len() > 1000).unwrap_or(false),
                "{}",
                p.display()
            );
        }
    }
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["seed"], 3);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn compare_runs_each_controller_on_the_same_scenario_and_plots_them() {
    let dir = std::env::temp_dir().join(format!("oldbf-compare-{}", std::process::id()));
    let out = oldbf()
        .args([
            "compare",
            "config/scenarios/crossing.yaml",
            "--controllers",
            "oldbf,vo,none",
            "--json",
            "--out",
        ])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = stdout_of(&out);
    for row in ["oldbf ", "vo ", "none "] {
        assert!(text.lines().any(|l| l.starts_with(row)), "no row {row:?} in {text}");
    }
    let figs: serde_json::Value = serde_json::from_str(text.lines().last().unwrap()).unwrap();
    let figs = figs.as_array().unwrap();
    assert_eq!(figs.len(), 3);
    assert_eq!(figs[0]["controller"], "oldbf");
    assert_eq!(figs[2]["controller"], "none");
    // The same world and seed: each row equals a plain `sim` run of that controller.
    let sim = oldbf()
        .args(["sim", "config/scenarios/crossing.yaml", "--controller", "vo", "--json"])
        .output()
        .unwrap();
    let sim: serde_json::Value = serde_json::from_str(stdout_of(&sim).lines().last().unwrap()).unwrap();
    assert_eq!(figs[1]["min_clearance_m"], sim["min_clearance_m"]);
    assert_eq!(figs[1]["path_length_m"], sim["path_length_m"]);
    for f in ["trajectories", "tracking_error", "commands"] {
        for ext in ["png", "svg"] {
            let p = dir.join(format!("{f}.{ext}"));
            assert!(
                std::fs::metadata(&p).map(|m| m.len() > 1000).unwrap_or(false),
                "{}",
                p.display()
            );
        }
    }
    assert!(dir.join("comparison.json").exists());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_configuration_exits_2_naming_file_and_key() {
    let dir = std::env::temp_dir().join(format!("oldbf-cli-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.yaml");
    let text = std::fs::read_to_string(common::repo_root().join("config/oldbf.yaml"))
        .unwrap()
        .replace("gamma: 0.2 ", "gamma: 1.5 ");
    std::fs::write(&bad, text).unwrap();
    let out = oldbf().arg("check-config").arg(&bad).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.yaml") && err.contains("dtcbf.gamma") && err.contains("(0, 1]"),
        "{err}"
    );
    // The same file as the base of a run: nothing runs.
    let out = oldbf()
        .args(["sim", "config/scenarios/paper_line.yaml", "--config"])
        .arg(&bad)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(stdout_of(&out).is_empty());
    let out = oldbf().args(["sim", "no/such/scenario.yaml"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no/such/scenario.yaml"));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn help_explains_options_with_units() {
    for sub in ["sim", "carmen", "check-config"] {
        let out = oldbf().args([sub, "--help"]).output().unwrap();
        assert!(out.status.success());
        let text = stdout_of(&out);
        assert!(text.len() > 300, "{sub}: {text}");
    }
    let text = stdout_of(&oldbf().args(["sim", "--help"]).output().unwrap());
    for needle in ["--seed", "--out", "--json", "--config", "--controller", "(m)", "(µs)"] {
        assert!(text.contains(needle), "sim --help lacks {needle}:\n{text}");
    }
    let text = stdout_of(&oldbf().args(["carmen", "--help"]).output().unwrap());
    assert!(text.contains("m/s"), "{text}");
}

#[test]
fn carmen_replays_the_real_log() {
    let out = oldbf()
        .args(["carmen", "tests/data/intel-corrected.log.gz", "--json"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = stdout_of(&out);
    let v: serde_json::Value = serde_json::from_str(text.lines().last().unwrap()).unwrap();
    assert_eq!(v["scans"], 910);
    assert_eq!(v["non_finite_commands"], 0);
}
