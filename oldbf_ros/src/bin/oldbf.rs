//! `oldbf`: run the OLDBF + DOAA safety filter in the built-in simulator,
//! replay real LiDAR logs through it, and check configuration files.

use anyhow::Context;
use clap::{Parser, Subcommand};
use log::{info, warn};
use oldbf_ros::algo::geometry::Twist;
use oldbf_ros::algo::pipeline::SafetyPipeline;
use oldbf_ros::config;
use oldbf_ros::replay::replay_carmen;
use oldbf_ros::report::{summary_text, write_outputs};
use oldbf_ros::sim::run::{run_scenario, Controller};
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
        /// Controller closing the loop: `oldbf` (the filter) or `none` (the
        /// nominal command unfiltered, to see what the filter prevents).
        #[arg(long, value_enum, default_value = "oldbf")]
        controller: Controller,
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
        } => {
            let scn = Scenario::load(&scenario, config.as_deref())?;
            let seed = seed.unwrap_or(scn.spec.seed);
            info!(
                "running {} ({}) with {controller:?}, seed {seed}",
                scn.spec.name, scn.file
            );
            let result = run_scenario(&scn, controller, seed).map_err(|m| anyhow::anyhow!("{}: {m}", scn.file))?;
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
            let summary =
                oldbf_ros::ros::carmen_play::play(&carmen, &topic, &frame, rate).map_err(anyhow::Error::msg)?;
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
