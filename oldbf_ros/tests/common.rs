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
