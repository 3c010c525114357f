//! What `oldbf batch --out DIR` leaves behind:
//!
//! * `comparison.csv` — the table, full precision ([`super::table::csv`]);
//! * `comparison.json` — the `--json` object plus `per_world`, every
//!   (world, controller) outcome;
//! * `per_world.csv` — the same outcomes as CSV;
//! * `min_clearance.png` / `.svg` — each controller's distribution of
//!   per-world least clearance (box and dots), a dashed line at contact;
//! * `worlds/world_NNNN.yaml` — each world as a scenario file, so
//!   `oldbf sim DIR/worlds/world_0007.yaml --controller none` reruns it.

use super::template::GeneratedWorld;
use super::{controller_name, table, BatchReport, WorldOutcome};
use crate::plot::{plot_distributions, Distribution};
use anyhow::Context;
use serde::Serialize;
use std::path::Path;

/// `comparison.json`: the report with its per-world outcomes.
#[derive(Serialize)]
struct ReportWithWorlds<'a> {
    #[serde(flatten)]
    report: &'a BatchReport,
    per_world: &'a [WorldOutcome],
}

fn write(path: &Path, text: &str) -> anyhow::Result<()> {
    std::fs::write(path, text).with_context(|| format!("writing {}", path.display()))
}

/// Writes every file listed in the module docs into `dir` (created if needed).
pub fn write_outputs(dir: &Path, report: &BatchReport, worlds: &[GeneratedWorld]) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    write(&dir.join("comparison.csv"), &table::csv(report))?;
    let full = ReportWithWorlds {
        report,
        per_world: &report.per_world,
    };
    write(&dir.join("comparison.json"), &serde_json::to_string_pretty(&full)?)?;
    write(&dir.join("per_world.csv"), &table::per_world_csv(&report.per_world))?;

    let names: Vec<String> = report.controllers.iter().map(|&c| controller_name(c)).collect();
    let clearances: Vec<Vec<f64>> = report
        .controllers
        .iter()
        .map(|&c| {
            report
                .per_world
                .iter()
                .filter(|o| o.controller == c)
                .map(|o| o.figures.min_clearance_m)
                .collect()
        })
        .collect();
    let groups: Vec<Distribution<'_>> = names
        .iter()
        .zip(&clearances)
        .map(|(label, values)| Distribution { label, values })
        .collect();
    let title = format!(
        "Least clearance per world: {} ({} worlds, seed {})",
        report.name, report.worlds, report.seed
    );
    plot_distributions(
        &dir.join("min_clearance"),
        &title,
        "min clearance (m)",
        &groups,
        &[(0.0, "contact")],
    )?;

    let world_dir = dir.join("worlds");
    std::fs::create_dir_all(&world_dir).with_context(|| format!("creating {}", world_dir.display()))?;
    for w in worlds {
        write(&world_dir.join(format!("world_{:04}.yaml", w.index)), &w.yaml)?;
    }
    Ok(())
}
