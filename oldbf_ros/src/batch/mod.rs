//! Batch evaluation (`oldbf batch`): many seeded random worlds from one
//! template, every controller on every world, one comparison table.
//!
//! Why: one scenario shows that a controller *can* be safe; a rate over a
//! hundred random worlds shows how often it is. Each world is run with every
//! controller under identical conditions (same world, same sensor seed, same
//! nominal line), so the rows of the table differ only by the controller.
//!
//! * [`template`] — the template file and world generation;
//! * [`runner`] — running the worlds in parallel (rayon) with a progress bar;
//! * [`stats`] — percentiles, rates, one row per controller;
//! * [`table`] — the text table and CSV;
//! * [`output`] — the `--out DIR` files (CSV, JSON, plot, world files).

pub mod output;
pub mod runner;
pub mod soak;
pub mod stats;
pub mod table;
pub mod template;

use crate::sim::figures::RunFigures;
use crate::sim::run::{Controller, RunResult};
pub use runner::{generate_worlds, run_worlds, BatchOptions};
use serde::Serialize;
pub use stats::ControllerStats;
pub use template::{GeneratedWorld, Template};

/// The controller's name as on the command line (`oldbf`, `none`, …).
pub fn controller_name(c: Controller) -> String {
    use clap::ValueEnum;
    c.to_possible_value()
        .map_or_else(|| format!("{c:?}").to_lowercase(), |v| v.get_name().to_string())
}

/// One controller on one world.
#[derive(Debug, Clone, Serialize)]
pub struct WorldOutcome {
    /// World index in the batch.
    pub world: usize,
    pub controller: Controller,
    /// LiDAR noise seed (the scenario's `seed`).
    pub sensor_seed: u64,
    /// Whether a path keeping r + d_safe from the static obstacles leads to
    /// the goal, and the world's kind (`room`, `wide_doorway`, `narrow_doorway`).
    pub path_exists: bool,
    pub label: &'static str,
    /// The template's time budget for this world (s): `time_budget_factor` ×
    /// line length / v_nom; None when the template sets none.
    pub time_budget_s: Option<f64>,
    /// Whether the goal was reached within `time_budget_s` (None without one).
    pub goal_within_budget: Option<bool>,
    /// Control steps run.
    pub steps: usize,
    /// What the run measured (the world has one robot).
    #[serde(flatten)]
    pub figures: RunFigures,
    /// Mean controller compute per step (µs).
    pub mean_step_us: f64,
    /// Compute time of every step (µs), for pooled percentiles.
    #[serde(skip)]
    pub step_us: Vec<f32>,
}

impl WorldOutcome {
    /// The figures of `result` (a single-robot run of `world`).
    pub fn from_run(world: &GeneratedWorld, result: &RunResult) -> WorldOutcome {
        let s = &result.summary;
        WorldOutcome {
            world: world.index,
            controller: s.controller,
            sensor_seed: world.sensor_seed,
            path_exists: world.path_exists,
            label: world.label,
            time_budget_s: world.time_budget_s,
            goal_within_budget: world
                .time_budget_s
                .map(|budget| s.figures.reached_goal && s.figures.time_to_goal_s.is_some_and(|t| t <= budget)),
            steps: s.steps,
            figures: s.figures.clone(),
            mean_step_us: s.mean_step_us,
            step_us: result
                .robots
                .iter()
                .flat_map(|r| r.rows.iter().map(|row| row.step_us as f32))
                .collect(),
        }
    }
}

/// The whole comparison; `--json` prints this (without `per_world`).
#[derive(Debug, Clone, Serialize)]
pub struct BatchReport {
    /// The template file.
    pub template: String,
    /// The template's `name`.
    pub name: String,
    pub seed: u64,
    pub worlds: usize,
    pub controllers: Vec<Controller>,
    pub threads: usize,
    /// Wall-clock time of the runs (s).
    pub wall_time_s: f64,
    /// One row per controller, in `controllers` order.
    pub rows: Vec<ControllerStats>,
    /// Every (world, controller) outcome, world-major.
    #[serde(skip)]
    pub per_world: Vec<WorldOutcome>,
}

impl BatchReport {
    /// Aggregates `per_world` into one row per controller of `options`.
    pub fn new(
        template: &Template,
        options: &BatchOptions,
        wall_time_s: f64,
        per_world: Vec<WorldOutcome>,
    ) -> BatchReport {
        let rows = options
            .controllers
            .iter()
            .map(|&c| {
                let mine: Vec<&WorldOutcome> = per_world.iter().filter(|o| o.controller == c).collect();
                ControllerStats::from_outcomes(c, &mine)
            })
            .collect();
        BatchReport {
            template: template.file.clone(),
            name: template.spec.name.clone(),
            seed: options.seed,
            worlds: options.worlds,
            controllers: options.controllers.clone(),
            threads: options.threads,
            wall_time_s,
            rows,
            per_world,
        }
    }
}
