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
    /// Control steps run.
    pub steps: usize,
    pub collisions: usize,
    /// Contacts the robot drove into, and contacts made on it at rest or
    /// moving away (ALGORITHM.md §5b).
    pub closing_contacts: usize,
    pub passive_contacts: usize,
    /// Least body-to-obstacle distance over the run (m; negative = penetration).
    pub min_clearance_m: f64,
    pub reached_goal: bool,
    pub time_to_goal_s: Option<f64>,
    pub path_length_m: f64,
    /// Largest distance from the reference (m).
    pub max_tracking_error_m: Option<f64>,
    /// Steps where the logged DTCBF condition failed for the sent command.
    pub cbf_violations: usize,
    /// Steps where it failed on the exact geometry.
    pub true_cbf_violations: usize,
    /// Logged violations on steps not marked infeasible (must be 0 for oldbf).
    pub cbf_violations_feasible: usize,
    /// Steps whose sent command could not brake to rest without a predicted
    /// closing contact, and those not marked infeasible.
    pub braking_violations: usize,
    pub braking_violations_feasible: usize,
    /// Steps the filter marked infeasible.
    pub infeasible_steps: usize,
    /// Steps driven while an unknown beam hiding something near was taken as free.
    pub driven_blind_steps: usize,
    /// Steps stopped for a blind sensor.
    pub blind_steps: usize,
    /// Steps whose ω differs from the previous step's by more than ω_max.
    pub steering_flips: usize,
    /// Time with |v| < 0.02 m/s while the goal was not reached (s).
    pub stalled_s: f64,
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
            steps: s.steps,
            collisions: s.collisions,
            closing_contacts: s.closing_contacts,
            passive_contacts: s.passive_contacts,
            min_clearance_m: s.min_clearance_m,
            reached_goal: s.reached_goal,
            time_to_goal_s: s.time_to_goal_s,
            path_length_m: s.path_length_m,
            max_tracking_error_m: s.max_tracking_error_m,
            cbf_violations: s.cbf_violations,
            true_cbf_violations: s.true_cbf_violations,
            cbf_violations_feasible: s.cbf_violations_feasible,
            braking_violations: s.braking_violations,
            braking_violations_feasible: s.braking_violations_feasible,
            infeasible_steps: s.infeasible_steps.total(),
            driven_blind_steps: s.driven_blind_steps,
            blind_steps: s.blind_steps,
            steering_flips: s.steering_flips,
            stalled_s: s.stalled_s,
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
