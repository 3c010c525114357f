//! `oldbf`: run the OLDBF + DOAA safety filter in the built-in simulator,
//! replay real LiDAR logs through it, and check configuration files.

use anyhow::Context;
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use log::{info, warn};
use oldbf_ros::algo::geometry::Twist;
use oldbf_ros::algo::pipeline::SafetyPipeline;
use oldbf_ros::batch::{self, generate_worlds, run_worlds, runner::default_threads, soak, BatchOptions, Template};
use oldbf_ros::compare;
use oldbf_ros::config;
use oldbf_ros::replay::replay_carmen;
use oldbf_ros::report::{summary_text, write_outputs};
use oldbf_ros::sim::run::{run_scenario_with, Controller, RunOptions};
use oldbf_ros::sim::scenario::Scenario;
use std::path::PathBuf;
use std::process::ExitCode;

/// OLDBF + DOAA: a LiDAR safety filter for differential-drive robots.
///
/// Every LaserScan becomes a provably safe velocity command: barriers B_l and
/// B_r from the left/right clearances, DOAA steering away from the nearer
/// side, and an exact discrete-time CBF check h(k+1) ≥ (1 − γ) h(k) on the
/// one-step prediction. Units: metres, seconds, radians (degrees only where a
/// name says `_deg`). Logs go to stderr (RUST_LOG=debug for more).
/// Counts live heap bytes for the soak's memory gate (`oldbf_ros::heap`).
#[global_allocator]
static ALLOC: oldbf_ros::heap::CountingAlloc = oldbf_ros::heap::CountingAlloc;

#[derive(Parser)]
#[command(name = "oldbf", version, about, long_about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a scenario in closed loop in the built-in 2-D simulator and report safety figures.
    ///
    /// Prints a readable summary: collisions, least clearance (m), CBF
    /// condition violations, goal reached, path length (m), tracking error
    /// (m) and pipeline time per step (µs). Exits 0 if the run completed,
    /// whatever its figures; 2 on a bad scenario or configuration.
    Sim {
        /// Scenario file (YAML), e.g. config/scenarios/paper_line.yaml.
        scenario: PathBuf,
        /// Seed for LiDAR noise and dropouts [default: the scenario's `seed`].
        #[arg(long, value_name = "N")]
        seed: Option<u64>,
        /// Write steps.csv (one row per control step), summary.json and plots
        /// (trajectory, barriers, velocities; PNG and SVG) into DIR.
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
        /// Also print the summary as one JSON object on the last stdout line.
        #[arg(long)]
        json: bool,
        /// Base parameter file [default: the built-in config/oldbf.yaml]; the
        /// scenario's `oldbf:` section is merged over it.
        #[arg(long, value_name = "FILE")]
        config: Option<PathBuf>,
        /// Plan the way round in a thread beside the safety path, as the node
        /// does, and report the planner's own time per plan: for timing the
        /// safety path in the node's mode (the simulated clock outruns the
        /// planner, so the run is not reproducible).
        #[arg(long)]
        plan_beside: bool,
        /// Controller closing the loop: `oldbf` (the filter), the baselines
        /// `dcbf` (DCBF-QP) and `vo` (ORCA velocity obstacles) on the same
        /// perception, or `none` (the nominal command unfiltered, to see what
        /// the filter prevents).
        #[arg(long, value_enum, default_value = "oldbf")]
        controller: Controller,
    },
    /// Run one scenario with several controllers and compare them side by side.
    ///
    /// Same world, same seed, same nominal command law for every controller
    /// (the paper's Fig. 9 is `compare config/scenarios/paper_circle.yaml
    /// --controllers oldbf,dcbf`). Prints one row per controller for robot 0:
    /// collisions, least clearance (m), time to goal (s), path length (m),
    /// distance to the (governed) reference point and to the reference path,
    /// max / mean (m), and compute per step (µs).
    Compare {
        /// Scenario file (YAML), e.g. config/scenarios/paper_circle.yaml.
        scenario: PathBuf,
        /// Controllers, comma-separated; the first is drawn with its safety perimeter.
        #[arg(long, value_enum, value_delimiter = ',', value_name = "LIST", default_values_t = [Controller::Oldbf, Controller::Dcbf])]
        controllers: Vec<Controller>,
        /// Seed for LiDAR noise and dropouts [default: the scenario's `seed`].
        #[arg(long, value_name = "N")]
        seed: Option<u64>,
        /// Write comparison.json and plots (trajectories overlaid, tracking
        /// error over time, commands over time; PNG and SVG) into DIR.
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
        /// Also print the figures as one JSON array on the last stdout line.
        #[arg(long)]
        json: bool,
        /// Base parameter file [default: the built-in config/oldbf.yaml]; the
        /// scenario's `oldbf:` section is merged over it.
        #[arg(long, value_name = "FILE")]
        config: Option<PathBuf>,
    },
    /// Compare controllers over N seeded random worlds drawn from a template.
    ///
    /// Draws N worlds from TEMPLATE (room, static circles, boxes and benches,
    /// moving discs whose speed is a fraction of the robot's nominal speed, a line
    /// from one wall to the opposite one; see config/batch/*.yaml), runs
    /// every controller on every world with the same world, sensor seed and
    /// nominal line, worlds in parallel, and prints one row per controller:
    /// worlds; collision rate (fraction of worlds with >= 1 contact);
    /// closing contacts (the robot drove in: its speed towards the touched
    /// point above 0.02 m/s) and passive ones (it was at rest or moving
    /// away), with the worlds having any; least clearance (m), median and
    /// 5th percentile over worlds; goal-reach rate (over the worlds with a
    /// safe path) and, when the template sets `time_budget_factor`, the rate
    /// of goals reached within that factor × the nominal line time; mean time to goal over
    /// the worlds reached (s); mean time stalled (s); total variation of v and
    /// ω per second and sign reversals of Δv and Δω (% of steps); DTCBF condition and braking
    /// check violations (steps, all and on steps not marked infeasible);
    /// infeasible steps; the safety path's compute per control step (less
    /// the way-round work done in step, which the node does in a thread of
    /// its own), in the thread's CPU time, mean and 99th percentile (µs).
    /// `oldbf-paper` is OLDBF with this project's checks beyond the paper
    /// off (every invalid range free, no braking check or evasion, no
    /// reverse): the gain of those checks on the same worlds. A progress
    /// bar goes to stderr when it is a terminal.
    /// Exits 0 when every run completed, whatever the figures; 2 on a bad
    /// template, configuration or option.
    Batch {
        /// Template file (YAML), e.g. config/batch/slow_obstacles.yaml.
        template: PathBuf,
        /// Number of random worlds to draw and run.
        #[arg(long, value_name = "N", default_value_t = 20, value_parser = clap::value_parser!(u64).range(1..=100_000))]
        worlds: u64,
        /// Seed of the world generator: world i depends only on (S, i), so a
        /// larger N keeps the first worlds. Each world's LiDAR noise seed is
        /// drawn from it too, the same for every controller.
        #[arg(long, value_name = "S", default_value_t = 1)]
        seed: u64,
        /// Controllers to compare, comma-separated, each a table row in this
        /// order (repeats are dropped).
        #[arg(long, value_enum, value_delimiter = ',', value_name = "LIST", default_values_t = [Controller::Oldbf, Controller::OldbfPaper, Controller::Dcbf, Controller::Vo, Controller::None])]
        controllers: Vec<Controller>,
        /// Also print the whole comparison as one JSON object on the last stdout line.
        #[arg(long)]
        json: bool,
        /// Write comparison.csv, comparison.json (with every world's outcome),
        /// per_world.csv, the least-clearance distributions per controller
        /// (min_clearance.png and .svg) and each world as a scenario file
        /// (worlds/world_NNNN.yaml, for `oldbf sim`) into DIR.
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
        /// Worker threads running worlds in parallel [default: the number of
        /// cores]. Figures other than compute time do not depend on it.
        #[arg(long, value_name = "K", value_parser = clap::value_parser!(u64).range(1..=1024))]
        threads: Option<u64>,
        /// Base parameter file [default: the built-in config/oldbf.yaml]; the
        /// template's `oldbf:` section is merged over it.
        #[arg(long, value_name = "FILE")]
        config: Option<PathBuf>,
    },
    /// Soak: random worlds back to back until the simulated time reaches
    /// --sim-hours, counting what must never happen.
    ///
    /// Draws worlds from TEMPLATE (default: the built-in
    /// config/batch/soak.yaml: 8 × 6 m room, posts, boxes and 2-4 blind
    /// movers at 0.1-0.3 of the robot's speed) and runs the OLDBF filter on
    /// them, worlds in parallel, 16 at a time, faster than real time. Counts:
    /// panics (each world runs under catch_unwind; the message is printed),
    /// non-finite commands (v or ω NaN or infinite), collisions (contacts
    /// begun), DTCBF condition violations logged and on the exact geometry
    /// (steps), and the least clearance (m). The live heap (bytes allocated
    /// and not freed, counted by this binary's allocator: where a leak shows)
    /// is sampled once warm (after the first chunk that reaches 10 % of the
    /// target), after every chunk and at the end; the anonymous resident set
    /// (RssAnon from /proc/self/status) is reported beside it, not gated, as
    /// glibc's arenas make it step up once at a moment that depends on thread
    /// scheduling. The
    /// figures depend only on (template, seed, --sim-hours), not on the
    /// thread count. A progress bar (simulated seconds) goes to stderr when
    /// it is a terminal. Exits 0 when every gate holds; 1 on any panic,
    /// non-finite command, more collisions or violations than allowed, or
    /// live heap growth beyond --max-heap-growth-kib; 2 on a bad template,
    /// configuration or option.
    Soak {
        /// Simulated time to reach, summed over worlds (hours of simulated time).
        #[arg(long, value_name = "H", default_value_t = 1.0, value_parser = parse_sim_hours)]
        sim_hours: f64,
        /// Template file (YAML) [default: the built-in config/batch/soak.yaml].
        #[arg(long, value_name = "FILE")]
        template: Option<PathBuf>,
        /// Seed of the world generator: world i depends only on (S, i).
        #[arg(long, value_name = "S", default_value_t = 1)]
        seed: u64,
        /// Worker threads [default: the number of cores].
        #[arg(long, value_name = "K", value_parser = clap::value_parser!(u64).range(1..=1024))]
        threads: Option<u64>,
        /// Allowed growth of the live heap from warm to the end (KiB; the
        /// soak's own report grows by about 1 KiB in 10 h).
        #[arg(long, value_name = "KIB", default_value_t = 256, value_parser = clap::value_parser!(u64).range(0..=1_000_000_000))]
        max_heap_growth_kib: u64,
        /// Allowed collisions (contacts begun) over the whole soak.
        #[arg(long, value_name = "N", default_value_t = 0)]
        max_collisions: usize,
        /// Allowed CBF condition violations (steps), logged and exact geometry each.
        #[arg(long, value_name = "N", default_value_t = 0)]
        max_cbf_violations: usize,
        /// Also print the report as one JSON object on the last stdout line.
        #[arg(long)]
        json: bool,
        /// Base parameter file [default: the built-in config/oldbf.yaml]; the
        /// template's `oldbf:` section is merged over it.
        #[arg(long, value_name = "FILE")]
        config: Option<PathBuf>,
    },
    /// Replay a CARMEN log (FLASER lines; plain or .gz) through the pipeline.
    ///
    /// Each scan is filtered with a straight nominal command at
    /// control.v_nom_mps (m/s), B_v from the logged odometry speed. Prints
    /// scans read, scans rejected (with reasons), commands changed by the
    /// filter, and the states seen. Fails if any command is not finite.
    Carmen {
        /// The log file, e.g. tests/data/intel-corrected.log.gz.
        log: PathBuf,
        /// Parameter file [default: the built-in config/oldbf.yaml].
        #[arg(long, value_name = "FILE")]
        config: Option<PathBuf>,
        /// Also print the summary as one JSON object on the last stdout line.
        #[arg(long)]
        json: bool,
    },
    /// Publish a CARMEN log (FLASER lines; plain or .gz) as
    /// sensor_msgs/LaserScan on a ROS topic, to replay real LiDAR data into
    /// oldbf_node or `rosbag record` (needs a ROS master; ROS_MASTER_URI).
    ///
    /// Scans are stamped with the time they are published. Readings at the
    /// log's sensor maximum (81.83 m) are kept: range_max is set to it, so
    /// consumers treat them as "no return". Only in builds with `--features ros`.
    #[cfg(feature = "ros")]
    CarmenPlay {
        /// The log file, e.g. tests/data/intel-corrected.log.gz.
        log: PathBuf,
        /// Topic to publish on (resolved like any ROS name; remapping works).
        #[arg(long, default_value = "scan")]
        topic: String,
        /// Scans per second (Hz); the log's own timing is not reproduced.
        #[arg(long, value_name = "HZ", default_value_t = 10.0)]
        rate: f64,
        /// frame_id of the scans.
        #[arg(long, default_value = "laser")]
        frame: String,
    },
    /// Check a parameter file: strict keys, types and ranges.
    ///
    /// Every key of config/oldbf.yaml must be present with the right type;
    /// unknown keys are errors; every value is checked against its allowed
    /// range. Each error names the file, the dotted key and the allowed range.
    /// When valid, prints the derived robot radius r (m), d_safe (m), the
    /// activation distance d_act = d_safe + Γ^(2/σ) (m) and the control period
    /// Δt (s). Exits 0 when valid, 2 otherwise.
    CheckConfig {
        /// Parameter file (YAML), e.g. config/oldbf.yaml.
        file: PathBuf,
    },
}

/// A `--sim-hours` value that cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
enum SimHoursError {
    #[error("`{text}` is not a number of hours")]
    NotANumber {
        text: String,
        #[source]
        source: std::num::ParseFloatError,
    },
    #[error("{hours} is out of range; allowed: (0, 10000] h")]
    OutOfRange { hours: f64 },
}

/// `--sim-hours`: finite, in (0, 10000].
fn parse_sim_hours(s: &str) -> Result<f64, SimHoursError> {
    let h: f64 = s.parse().map_err(|source| SimHoursError::NotANumber {
        text: s.to_string(),
        source,
    })?;
    if h.is_finite() && h > 0.0 && h <= 10_000.0 {
        Ok(h)
    } else {
        Err(SimHoursError::OutOfRange { hours: h })
    }
}

fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("info")).init();
    let cli = Cli::parse();
    match run(cli.command) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            if e.downcast_ref::<config::ConfigError>().is_some() {
                ExitCode::from(2)
            } else {
                ExitCode::from(1)
            }
        }
    }
}

fn run(command: Command) -> anyhow::Result<ExitCode> {
    match command {
        Command::Sim {
            scenario,
            seed,
            out,
            json,
            config,
            controller,
            plan_beside,
        } => {
            let scn = Scenario::load(&scenario, config.as_deref())?;
            let seed = seed.unwrap_or(scn.spec.seed);
            info!(
                "running {} ({}) with {controller:?}, seed {seed}",
                scn.spec.name, scn.file
            );
            let options = RunOptions { plan_beside };
            let result =
                run_scenario_with(&scn, controller, seed, options).map_err(|m| anyhow::anyhow!("{}: {m}", scn.file))?;
            println!("{}", summary_text(&result.summary));
            if let Some(dir) = out {
                write_outputs(&dir, &scn, &result).with_context(|| format!("writing outputs to {}", dir.display()))?;
                println!("  wrote the per-step CSV, summary.json and plots to {}", dir.display());
            }
            if json {
                println!("{}", serde_json::to_string(&result.summary)?);
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::Compare {
            scenario,
            controllers,
            seed,
            out,
            json,
            config,
        } => {
            let scn = Scenario::load(&scenario, config.as_deref())?;
            let seed = seed.unwrap_or(scn.spec.seed);
            let mut unique = Vec::new();
            for c in controllers {
                if !unique.contains(&c) {
                    unique.push(c);
                }
            }
            info!("running {} with {unique:?}, seed {seed}", scn.spec.name);
            let runs =
                compare::run_comparison(&scn, &unique, seed).map_err(|m| anyhow::anyhow!("{}: {m}", scn.file))?;
            let figs = compare::figures(&runs);
            print!("{}", compare::comparison_text(&scn, seed, &figs));
            if let Some(dir) = out {
                compare::write_comparison(&dir, &scn, seed, &runs)
                    .with_context(|| format!("writing outputs to {}", dir.display()))?;
                println!("  wrote comparison.json and plots to {}", dir.display());
            }
            if json {
                println!("{}", serde_json::to_string(&figs)?);
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::Batch {
            template,
            worlds,
            seed,
            controllers,
            json,
            out,
            threads,
            config,
        } => {
            let tpl = Template::load(&template, config.as_deref())?;
            let mut unique = Vec::new();
            for c in controllers {
                if !unique.contains(&c) {
                    unique.push(c);
                }
            }
            let options = BatchOptions {
                worlds: worlds as usize,
                seed,
                controllers: unique,
                threads: threads.map_or_else(default_threads, |k| k as usize),
            };
            info!(
                "batch {} ({}): {} worlds, seed {seed}, {} threads",
                tpl.spec.name, tpl.file, options.worlds, options.threads
            );
            let generated = generate_worlds(&tpl, &options)?;
            let runs = (options.worlds * options.controllers.len()) as u64;
            // Drawn only when stderr is a terminal; stdout (table, JSON) is untouched.
            let progress = ProgressBar::with_draw_target(Some(runs), ProgressDrawTarget::stderr()).with_style(
                ProgressStyle::with_template("{bar:40} {pos}/{len} runs  {elapsed} elapsed, ~{eta} left")
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            let report = run_worlds(&tpl, &generated, &options, &progress)?;
            progress.finish_and_clear();
            print!("{}", batch::table::text(&report));
            if let Some(dir) = out {
                batch::output::write_outputs(&dir, &report, &generated)
                    .with_context(|| format!("writing outputs to {}", dir.display()))?;
                println!(
                    "wrote comparison.csv, comparison.json, per_world.csv, min_clearance.png/.svg and worlds/ to {}",
                    dir.display()
                );
            }
            if json {
                println!("{}", serde_json::to_string(&report)?);
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::Soak {
            sim_hours,
            template,
            seed,
            threads,
            max_heap_growth_kib,
            max_collisions,
            max_cbf_violations,
            json,
            config,
        } => {
            let tpl = match &template {
                Some(p) => Template::load(p, config.as_deref())?,
                None => Template::from_str(
                    soak::DEFAULT_SOAK_TEMPLATE_YAML,
                    soak::DEFAULT_SOAK_TEMPLATE_NAME,
                    config.as_deref(),
                )?,
            };
            let options = soak::SoakOptions {
                sim_time_s: sim_hours * 3600.0,
                seed,
                threads: threads.map_or_else(default_threads, |k| k as usize),
                max_heap_growth_kib,
                max_collisions,
                max_cbf_violations,
            };
            info!(
                "soak {} ({}): {sim_hours} h simulated, seed {seed}, {} threads",
                tpl.spec.name, tpl.file, options.threads
            );
            let progress = ProgressBar::with_draw_target(Some(options.sim_time_s as u64), ProgressDrawTarget::stderr())
                .with_style(
                    ProgressStyle::with_template("{bar:40} {pos}/{len} simulated s  {elapsed} elapsed, ~{eta} left")
                        .unwrap_or_else(|_| ProgressStyle::default_bar()),
                );
            let report = soak::run_soak(&tpl, &options, &progress)?;
            progress.finish_and_clear();
            print!("{}", soak::text(&report));
            if json {
                println!("{}", serde_json::to_string(&report)?);
            }
            Ok(if report.failures.is_empty() {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(1)
            })
        }
        Command::Carmen { log, config, json } => {
            let params = match &config {
                Some(p) => config::load_params_file(p)?,
                None => config::default_params(),
            };
            let nominal = Twist::new(params.control.v_nom_mps, 0.0);
            let mut pipeline = SafetyPipeline::new(params);
            let carmen = oldbf_ros::carmen::open_log(&log).with_context(|| format!("reading {}", log.display()))?;
            for e in &carmen.errors {
                warn!("{}:{}: {}", log.display(), e.line, e.reason);
            }
            let summary = replay_carmen(&carmen, &mut pipeline, nominal);
            println!("{}", summary.text());
            if json {
                println!("{}", serde_json::to_string(&summary)?);
            }
            Ok(if summary.non_finite_commands == 0 {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(1)
            })
        }
        #[cfg(feature = "ros")]
        Command::CarmenPlay {
            log,
            topic,
            rate,
            frame,
        } => {
            if !(rate.is_finite() && rate > 0.0 && rate <= 10_000.0) {
                anyhow::bail!("--rate {rate} is out of range; allowed: (0, 10000] Hz");
            }
            let carmen = oldbf_ros::carmen::open_log(&log).with_context(|| format!("reading {}", log.display()))?;
            // As text: rosrust's error is not `Sync`, which anyhow needs.
            let summary =
                oldbf_ros::ros::carmen_play::play(&carmen, &topic, &frame, rate).map_err(|e| anyhow::anyhow!("{e}"))?;
            println!("published {} scans on {topic}", summary.published);
            Ok(ExitCode::SUCCESS)
        }
        Command::CheckConfig { file } => {
            let p = config::load_params_file(&file)?;
            println!(
                "{}: valid. r = {:.3} m, d_safe = {:.3} m, d_act = {:.3} m, Δt = {:.3} s",
                file.display(),
                p.robot_radius_m(),
                p.barrier.d_safe_m,
                p.barrier.d_act_m(),
                p.control.dt_s()
            );
            Ok(ExitCode::SUCCESS)
        }
    }
}
