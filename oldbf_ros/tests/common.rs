//! Helpers shared by the integration tests.
#![allow(dead_code)]

use oldbf_ros::sim::scenario::Scenario;
use std::path::{Path, PathBuf};

/// The repository root (the workspace holds `config/` and `tests/`).
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("crate lives in the workspace")
        .to_path_buf()
}

/// A shipped scenario by name, over the built-in parameters.
pub fn scenario(name: &str) -> Scenario {
    let path = repo_root().join("config/scenarios").join(format!("{name}.yaml"));
    Scenario::load(&path, None).unwrap_or_else(|e| panic!("{e}"))
}

/// Every shipped scenario file.
pub fn shipped_scenarios() -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(repo_root().join("config/scenarios"))
        .expect("config/scenarios exists")
        .map(|e| e.expect("readable dir entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "yaml"))
        .collect();
    v.sort();
    v
}

/// Runs OLDBF on batch world `index` of `config/batch/{template}.yaml` at
/// `seed`, as `oldbf batch` does, and asserts it ends without a contact
/// (regression worlds of closed-loop tests: the contact they once had is
/// what they guard; the mechanism itself has its own hand-built unit test,
/// and whether the robot gets to its goal is the batch tables' measure).
pub fn assert_template_worlds_safe(template: &str, worlds: &[(u64, usize)]) {
    use oldbf_ros::batch::template::Template;
    use oldbf_ros::sim::run::{run_scenario, Controller};
    let path = repo_root().join(format!("config/batch/{template}.yaml"));
    let template = Template::load(&path, None).unwrap();
    for &(seed, index) in worlds {
        let w = template.world(seed, index).unwrap();
        let r = run_scenario(&w.scenario, Controller::Oldbf, w.sensor_seed).unwrap();
        let f = &r.summary.figures;
        println!(
            "seed {seed}, world {index}: collisions {}, least clearance {:.3} m",
            f.collisions, f.min_clearance_m
        );
        assert_eq!(f.collisions, 0, "seed {seed}, world {index}: {f:?}");
    }
}
