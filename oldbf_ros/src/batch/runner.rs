//! Running a batch: generate the worlds, then run every controller on every
//! world, worlds in parallel.
//!
//! Why worlds (not controllers) are the unit of parallel work: a world's
//! controllers then run back to back on one thread with the same inputs, and
//! the results are collected in world order, so every figure except the
//! compute times is independent of the thread count.

use super::template::{GeneratedWorld, Template};
use super::{BatchReport, WorldOutcome};
use crate::config::ConfigError;
use crate::sim::fleet::FleetError;
use crate::sim::run::{run_scenario, Controller};
use indicatif::ProgressBar;
use rayon::prelude::*;
use std::time::Instant;

/// What to run.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BatchOptions {
    /// Number of worlds.
    pub worlds: usize,
    /// Seed of the world generator (world i is drawn from (seed, i)).
    pub seed: u64,
    /// Controllers to compare, each once, in table order.
    pub controllers: Vec<Controller>,
    /// Worker threads (≥ 1).
    pub threads: usize,
}

/// The machine's available parallelism (1 if unknown).
pub fn default_threads() -> usize {
    std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1)
}

/// The worker pool could not be started.
#[derive(Debug, thiserror::Error)]
#[error("cannot start {threads} worker threads: {source}")]
struct PoolError {
    threads: usize,
    #[source]
    source: rayon::ThreadPoolBuildError,
}

/// A world could not be run (its world or LiDAR could not be built).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file} with {controller:?}: {source}")]
struct WorldRunError {
    /// The world's scenario name.
    file: String,
    controller: Controller,
    #[source]
    source: FleetError,
}

fn pool(threads: usize) -> Result<rayon::ThreadPool, PoolError> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.max(1))
        .thread_name(|i| format!("batch-{i}"))
        .build()
        .map_err(|source| PoolError { threads, source })
}

/// Draws worlds 0..`options.worlds`. On failure, the error of the lowest
/// failing world index (so the message does not depend on scheduling).
pub fn generate_worlds(template: &Template, options: &BatchOptions) -> anyhow::Result<Vec<GeneratedWorld>> {
    // `msg`: the text once; as a chain, `{:#}` would print the source twice.
    let pool = pool(options.threads).map_err(anyhow::Error::msg)?;
    let drawn: Vec<Result<GeneratedWorld, ConfigError>> = pool.install(|| {
        (0..options.worlds)
            .into_par_iter()
            .map(|i| template.world(options.seed, i))
            .collect()
    });
    Ok(drawn.into_iter().collect::<Result<Vec<_>, _>>()?)
}

/// Runs every controller of `options` on every world, ticking `progress`
/// once per run, and aggregates the outcomes.
pub fn run_worlds(
    template: &Template,
    worlds: &[GeneratedWorld],
    options: &BatchOptions,
    progress: &ProgressBar,
) -> anyhow::Result<BatchReport> {
    let pool = pool(options.threads).map_err(anyhow::Error::msg)?;
    let started = Instant::now();
    let per_world: Vec<Result<Vec<WorldOutcome>, WorldRunError>> = pool.install(|| {
        worlds
            .par_iter()
            .map(|w| {
                options
                    .controllers
                    .iter()
                    .map(|&c| {
                        let result = run_scenario(&w.scenario, c, w.sensor_seed).map_err(|source| WorldRunError {
                            file: w.scenario.file.clone(),
                            controller: c,
                            source,
                        })?;
                        progress.inc(1);
                        Ok(WorldOutcome::from_run(w, &result))
                    })
                    .collect()
            })
            .collect()
    });
    let wall_time_s = started.elapsed().as_secs_f64();
    let mut outcomes = Vec::with_capacity(worlds.len() * options.controllers.len());
    for r in per_world {
        outcomes.extend(r.map_err(anyhow::Error::msg)?);
    }
    Ok(BatchReport::new(template, options, wall_time_s, outcomes))
}
