//! `oldbf soak` as a user runs it: gates, determinism, report, bad options.

mod common;

use std::process::{Command, Output};

fn oldbf() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_oldbf"));
    c.current_dir(common::repo_root()).env("RUST_LOG", "warn");
    c
}

fn json_of(out: &Output) -> serde_json::Value {
    let text = String::from_utf8_lossy(&out.stdout);
    let last = text.lines().last().unwrap_or_default();
    serde_json::from_str(last).unwrap_or_else(|e| panic!("no JSON last line ({e}):\n{text}"))
}

fn soak(args: &[&str]) -> Output {
    oldbf().arg("soak").args(args).arg("--json").output().unwrap()
}

#[test]
fn static_soak_passes_every_gate_and_reports_memory() {
    let out = soak(&["--sim-hours", "0.3", "--template", "config/batch/soak_static.yaml"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("PASS"), "{text}");
    let v = json_of(&out);
    assert!(v["sim_time_s"].as_f64().unwrap() >= 0.3 * 3600.0, "{v}");
    assert!(v["worlds"].as_u64().unwrap() >= 5, "{v}");
    for key in [
        "collisions",
        "cbf_violations",
        "true_cbf_violations",
        "non_finite_commands",
    ] {
        assert_eq!(v[key], 0, "{key}: {v}");
    }
    assert_eq!(v["panics"].as_array().unwrap().len(), 0);
    // The heap is counted (a world's buffers alone are tens of KiB) and the
    // resident set is read.
    assert!(v["heap_warm_kib"].as_u64().unwrap() > 16, "live heap counted: {v}");
    assert!(v["heap_end_kib"].as_u64().unwrap() > 16, "live heap counted: {v}");
    assert!(v["rss_anon_end_kib"].as_u64().unwrap() > 1024, "RssAnon read: {v}");
    assert!(!v["memory_samples"].as_array().unwrap().is_empty());
    // The motion figures cover every step. Among static things the layer adds
    // nothing to the upstream command: no moving track, no evasion, never
    // faster than asked, no reversing outside escape (issue criteria for
    // static worlds, ALGORITHM §5c).
    let m = &v["motion"];
    assert_eq!(m["steps"], v["steps"], "{m}");
    for key in [
        "moving_track_steps",
        "evade_steps",
        "above_upstream_steps",
        "reverse_evade_steps",
        "reverse_other_steps",
        "window_exceeded",
    ] {
        assert_eq!(m[key], 0, "{key}: {m}");
    }
    assert!(m["upstream_variation_omega_radps"].as_f64().unwrap() > 0.0, "{m}");
}

#[test]
fn figures_do_not_depend_on_the_thread_count() {
    let a = json_of(&soak(&["--sim-hours", "0.5", "--threads", "1", "--seed", "3"]));
    let b = json_of(&soak(&["--sim-hours", "0.5", "--threads", "2", "--seed", "3"]));
    for key in [
        "worlds",
        "steps",
        "sim_time_s",
        "collisions",
        "cbf_violations",
        "true_cbf_violations",
        "min_clearance_m",
        "worlds_reached_goal",
    ] {
        assert_eq!(a[key], b[key], "{key}");
    }
}

#[test]
fn violations_and_collisions_fail_the_gates_unless_allowed() {
    // Moving obstacles at seed 2: the first hour has CBF violations (blind
    // movers walk into the robot; docs/SAFETY.md "Soak"), so the strict default fails.
    let out = soak(&["--sim-hours", "1", "--seed", "2"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{text}");
    let v = json_of(&out);
    let logged = v["cbf_violations"].as_u64().unwrap();
    assert!(logged > 0, "{v}");
    assert!(
        text.contains(&format!("FAIL: {logged} logged CBF violation(s), allowed 0")),
        "{text}"
    );
    // Allowing them (and whatever collisions there are) passes.
    let out = soak(&[
        "--sim-hours",
        "1",
        "--seed",
        "2",
        "--max-cbf-violations",
        "1000000",
        "--max-collisions",
        "1000000",
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stdout));
    // An hour of the `mixed` template at seed 1 includes contacts (11, all passive,
    // when measured): with violations allowed, the collision gate alone fails the
    // run, and allowing exactly that many passes it.
    let hours_with_contacts = [
        "--sim-hours",
        "1",
        "--seed",
        "1",
        "--template",
        "config/batch/mixed.yaml",
        "--max-cbf-violations",
        "100000000",
    ];
    let out = soak(&hours_with_contacts);
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{text}");
    let collisions = json_of(&out)["collisions"].as_u64().unwrap();
    assert!(collisions > 0, "{text}");
    assert!(
        text.contains(&format!("FAIL: {collisions} collision(s), allowed 0")),
        "{text}"
    );
    let allowed = collisions.to_string();
    let out = soak(&[&hours_with_contacts[..], &["--max-collisions", &allowed]].concat());
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stdout));
}

#[test]
fn bad_options_and_templates_exit_2_naming_the_problem() {
    for h in ["0", "-1", "nan", "inf", "20000", "x"] {
        let out = oldbf().arg("soak").arg(format!("--sim-hours={h}")).output().unwrap();
        assert_eq!(out.status.code(), Some(2), "--sim-hours {h}");
        assert!(String::from_utf8_lossy(&out.stderr).contains("--sim-hours"), "{h}");
    }
    let dir = std::env::temp_dir().join(format!("oldbf-soak-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad_soak.yaml");
    let text = std::fs::read_to_string(common::repo_root().join("config/batch/soak.yaml"))
        .unwrap()
        .replace("duration_s: 120", "duration_s: -4");
    std::fs::write(&bad, text).unwrap();
    let out = oldbf().args(["soak", "--template"]).arg(&bad).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(e.contains("bad_soak.yaml: key `duration_s`"), "{e}");
    let out = oldbf()
        .args(["soak", "--template", "/no/such/soak.yaml"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("/no/such/soak.yaml: cannot read"));
}

#[test]
fn help_explains_the_gates_and_units() {
    let out = oldbf().args(["soak", "--help"]).output().unwrap();
    assert!(out.status.success());
    let h = String::from_utf8_lossy(&out.stdout);
    for s in [
        "--sim-hours",
        "live heap",
        "RssAnon",
        "catch_unwind",
        "non-finite",
        "--max-heap-growth-kib",
        "--max-collisions",
        "--max-cbf-violations",
        "config/batch/soak.yaml",
    ] {
        assert!(h.contains(s), "oldbf soak --help lacks `{s}`:\n{h}");
    }
}
