//! The soak (`oldbf soak`): random worlds run back to back until a target of
//! simulated time is reached, counting what must never happen.
//!
//! Why: a batch answers "how safe", the soak answers "does it stay sound over
//! hours": no panic, no non-finite command, no collision or CBF violation the
//! gates do not allow, and memory flat once warm (a leak in a per-scan
//! buffer shows as growth over thousands of worlds).
//!
//! The memory gated is the live heap (bytes allocated and not freed,
//! counted by [`crate::heap`]), where a leak shows and nothing else does.
//! The anonymous resident set (`RssAnon`) is reported beside it but not
//! gated: glibc's arenas make it step up by megabytes once, at a moment that
//! depends on thread scheduling (docs/SAFETY.md, "Soak").
//!
//! Worlds run in chunks of [`CHUNK_WORLDS`] in parallel; a chunk's outcomes
//! are taken in world order and the soak stops at the first world that brings
//! the simulated time to the target, so every figure except wall time and
//! memory depends only on (template, seed, target), not on the thread count.
//! A world that panics is caught (`catch_unwind`), counted and reported with
//! its message; the soak goes on.

use super::template::Template;
use crate::sim::figures::{MotionQuality, RunFigures};
use crate::sim::run::{run_scenario, Controller, RunResult};
use indicatif::ProgressBar;
use rayon::prelude::*;
use serde::Serialize;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::time::Instant;

/// Worlds per parallel chunk: fixed, so the set of worlds run does not depend
/// on the thread count.
pub const CHUNK_WORLDS: usize = 16;

/// The shipped soak template (`config/batch/soak.yaml`), so `oldbf soak` runs
/// from any directory.
pub const DEFAULT_SOAK_TEMPLATE_YAML: &str = include_str!("../../../config/batch/soak.yaml");
/// How the embedded template is named in messages.
pub const DEFAULT_SOAK_TEMPLATE_NAME: &str = "config/batch/soak.yaml (built-in)";

/// What to run and what to allow.
#[derive(Debug, Clone, PartialEq)]
pub struct SoakOptions {
    /// Simulated time to reach, summed over worlds (s).
    pub sim_time_s: f64,
    /// Seed of the world generator (world i is drawn from (seed, i)).
    pub seed: u64,
    /// Worker threads (≥ 1).
    pub threads: usize,
    /// Largest allowed growth of the live heap from warm to the end (KiB).
    pub max_heap_growth_kib: u64,
    /// Largest allowed number of collisions (contacts begun), summed over worlds.
    pub max_collisions: usize,
    /// Largest allowed number of CBF violations (steps), logged and exact geometry each.
    pub max_cbf_violations: usize,
}

/// A world that panicked.
#[derive(Debug, Clone, Serialize)]
pub struct SoakPanic {
    pub world: usize,
    pub message: String,
}

/// Memory at one point of the soak.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct MemorySample {
    /// Worlds finished when sampled.
    pub worlds: usize,
    /// Simulated time finished when sampled (s).
    pub sim_time_s: f64,
    /// Live heap (KiB; 0 when not counted).
    pub heap_kib: u64,
    /// Anonymous resident memory, RssAnon (KiB; 0 when unreadable).
    pub rss_anon_kib: u64,
}

/// Everything the soak measured; `--json` prints this.
#[derive(Debug, Clone, Serialize)]
pub struct SoakReport {
    pub template: String,
    pub name: String,
    pub seed: u64,
    pub threads: usize,
    /// Target simulated time (s).
    pub target_sim_time_s: f64,
    /// Simulated time run, summed over worlds (s).
    pub sim_time_s: f64,
    pub wall_time_s: f64,
    pub worlds: usize,
    /// Control steps, summed over worlds.
    pub steps: usize,
    pub panics: Vec<SoakPanic>,
    /// Control steps whose command (v or ω) was NaN or infinite.
    pub non_finite_commands: usize,
    pub collisions: usize,
    pub worlds_with_collision: usize,
    /// Of the collisions, contacts the robot drove into (its speed towards
    /// the touched point above 0.02 m/s at the onset; every one fails the
    /// soak) and the others (at rest, turning or moving away).
    pub closing_contacts: usize,
    pub passive_contacts: usize,
    /// Steps driven while an unknown beam hiding something near was taken as free.
    pub driven_blind_steps: usize,
    /// Steps where the logged DTCBF condition failed for the sent command.
    pub cbf_violations: usize,
    /// Steps where it failed on the exact geometry.
    pub true_cbf_violations: usize,
    /// Worlds with any violation, logged or exact.
    pub worlds_with_violation: usize,
    /// Least body-to-obstacle distance over all worlds (m; negative = penetration).
    pub min_clearance_m: f64,
    pub worlds_reached_goal: usize,
    /// The motion figures of every world, summed.
    pub motion: MotionQuality,
    /// Live heap once warm (after the first chunk that reached 10 % of the
    /// target), at the end, and the largest sample (KiB); `None` when this
    /// binary does not count its heap.
    pub heap_warm_kib: Option<u64>,
    pub heap_end_kib: Option<u64>,
    pub heap_max_kib: Option<u64>,
    /// heap_end − heap_warm (KiB; negative = shrank).
    pub heap_growth_kib: i64,
    pub max_heap_growth_kib: u64,
    /// Anonymous resident memory (RssAnon) once warm and at the end (KiB;
    /// 0 when unreadable). Reported, not gated.
    pub rss_anon_warm_kib: u64,
    pub rss_anon_end_kib: u64,
    /// After every chunk.
    pub memory_samples: Vec<MemorySample>,
    /// Every gate that failed, in words; empty = pass.
    pub failures: Vec<String>,
}

/// Anonymous resident memory of this process (KiB), from `/proc/self/status`.
pub fn rss_anon_kib() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    parse_rss_anon_kib(&status)
}

/// The live heap (KiB), when this binary counts it ([`crate::heap`]).
pub fn heap_kib() -> Option<u64> {
    crate::heap::live_heap_bytes().map(|b| b.max(0) as u64 / 1024)
}

/// The `RssAnon:` line of a `/proc/<pid>/status` text (KiB).
pub fn parse_rss_anon_kib(status: &str) -> Option<u64> {
    const KEY: &str = "RssAnon:";
    let line = status.lines().find(|l| l.starts_with(KEY))?;
    let mut words = line[KEY.len()..].split_whitespace();
    let kib: u64 = words.next()?.parse().ok()?;
    (words.next() == Some("kB")).then_some(kib)
}

/// The message of a caught panic.
fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "(non-string panic payload)".to_string()
    }
}

/// One world's figures (the step rows are dropped at once).
#[derive(Debug, Clone)]
struct WorldFigures {
    sim_time_s: f64,
    steps: usize,
    non_finite_commands: usize,
    figures: RunFigures,
}

impl WorldFigures {
    fn of(result: &RunResult) -> WorldFigures {
        let s = &result.summary;
        WorldFigures {
            sim_time_s: s.sim_time_s,
            steps: s.steps,
            non_finite_commands: result
                .robots
                .iter()
                .flat_map(|r| &r.rows)
                .filter(|row| !(row.v_cmd_mps.is_finite() && row.omega_cmd_radps.is_finite()))
                .count(),
            figures: s.figures.clone(),
        }
    }
}

/// A world's outcome: its figures, a panic message, or a generation error.
enum Outcome {
    Ran(Box<WorldFigures>),
    Panicked(String),
}

/// Draws and runs world `index`, catching a panic anywhere in it.
fn run_one(template: &Template, seed: u64, index: usize) -> anyhow::Result<Outcome> {
    let caught = catch_unwind(AssertUnwindSafe(|| -> anyhow::Result<WorldFigures> {
        let w = template.world(seed, index)?;
        let result = run_scenario(&w.scenario, Controller::Oldbf, w.sensor_seed)
            .map_err(|m| anyhow::anyhow!("{}: {m}", w.scenario.file))?;
        Ok(WorldFigures::of(&result))
    }));
    match caught {
        Ok(r) => r.map(|f| Outcome::Ran(Box::new(f))),
        Err(payload) => Ok(Outcome::Panicked(panic_message(payload.as_ref()))),
    }
}

/// Runs the soak, setting `progress` to the simulated seconds done.
pub fn run_soak(template: &Template, options: &SoakOptions, progress: &ProgressBar) -> anyhow::Result<SoakReport> {
    if !(options.sim_time_s.is_finite() && options.sim_time_s > 0.0) {
        anyhow::bail!("simulated time {} s is out of range; allowed: > 0", options.sim_time_s);
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(options.threads.max(1))
        .thread_name(|i| format!("soak-{i}"))
        .build()
        .map_err(|e| anyhow::anyhow!("cannot start {} worker threads: {e}", options.threads))?;
    let started = Instant::now();
    let mut r = SoakReport {
        template: template.file.clone(),
        name: template.spec.name.clone(),
        seed: options.seed,
        threads: options.threads,
        target_sim_time_s: options.sim_time_s,
        sim_time_s: 0.0,
        wall_time_s: 0.0,
        worlds: 0,
        steps: 0,
        panics: Vec::new(),
        non_finite_commands: 0,
        collisions: 0,
        worlds_with_collision: 0,
        closing_contacts: 0,
        passive_contacts: 0,
        driven_blind_steps: 0,
        cbf_violations: 0,
        true_cbf_violations: 0,
        worlds_with_violation: 0,
        min_clearance_m: f64::INFINITY,
        worlds_reached_goal: 0,
        motion: MotionQuality::default(),
        heap_warm_kib: None,
        heap_end_kib: None,
        heap_max_kib: None,
        heap_growth_kib: 0,
        max_heap_growth_kib: options.max_heap_growth_kib,
        rss_anon_warm_kib: 0,
        rss_anon_end_kib: 0,
        memory_samples: Vec::new(),
        failures: Vec::new(),
    };
    let mut warm: Option<MemorySample> = None;
    let mut next = 0usize;
    'chunks: while r.sim_time_s < options.sim_time_s {
        let indices: Vec<usize> = (next..next + CHUNK_WORLDS).collect();
        next += CHUNK_WORLDS;
        let outcomes: Vec<anyhow::Result<Outcome>> = pool.install(|| {
            indices
                .par_iter()
                .map(|&i| run_one(template, options.seed, i))
                .collect()
        });
        for (i, outcome) in indices.into_iter().zip(outcomes) {
            if r.sim_time_s >= options.sim_time_s {
                break 'chunks;
            }
            r.worlds += 1;
            match outcome? {
                Outcome::Panicked(message) => {
                    r.panics.push(SoakPanic { world: i, message });
                    // A panicked world still counts its nominal duration, so
                    // a template that always panics cannot loop for ever.
                    r.sim_time_s += template.spec.duration_s;
                }
                Outcome::Ran(f) => {
                    r.sim_time_s += f.sim_time_s;
                    r.steps += f.steps;
                    r.non_finite_commands += f.non_finite_commands;
                    r.collisions += f.figures.collisions;
                    r.worlds_with_collision += usize::from(f.figures.collisions > 0);
                    r.closing_contacts += f.figures.closing_contacts;
                    r.passive_contacts += f.figures.passive_contacts;
                    r.driven_blind_steps += f.figures.driven_blind_steps;
                    r.cbf_violations += f.figures.cbf_violations;
                    r.true_cbf_violations += f.figures.true_cbf_violations;
                    r.worlds_with_violation +=
                        usize::from(f.figures.cbf_violations + f.figures.true_cbf_violations > 0);
                    r.min_clearance_m = r.min_clearance_m.min(f.figures.min_clearance_m);
                    r.worlds_reached_goal += usize::from(f.figures.reached_goal);
                    r.motion = r.motion.sum(&f.figures.motion);
                }
            }
        }
        progress.set_position(r.sim_time_s.min(options.sim_time_s) as u64);
        let sample = MemorySample {
            worlds: r.worlds,
            sim_time_s: r.sim_time_s,
            heap_kib: heap_kib().unwrap_or(0),
            rss_anon_kib: rss_anon_kib().unwrap_or(0),
        };
        r.memory_samples.push(sample);
        if warm.is_none() && r.sim_time_s >= 0.1 * options.sim_time_s {
            warm = Some(sample);
        }
    }
    r.wall_time_s = started.elapsed().as_secs_f64();
    r.heap_end_kib = heap_kib();
    r.rss_anon_end_kib = rss_anon_kib().unwrap_or(0);
    if let Some(end) = r.heap_end_kib {
        let warm_heap = warm.map_or(end, |w| w.heap_kib);
        r.heap_warm_kib = Some(warm_heap);
        r.heap_max_kib = Some(r.memory_samples.iter().map(|s| s.heap_kib).fold(end, u64::max));
        r.heap_growth_kib = end as i64 - warm_heap as i64;
    }
    r.rss_anon_warm_kib = warm.map_or(r.rss_anon_end_kib, |w| w.rss_anon_kib);
    r.failures = gates(&r, options);
    Ok(r)
}

/// The gates, each failure in words.
fn gates(r: &SoakReport, o: &SoakOptions) -> Vec<String> {
    let mut f = Vec::new();
    if !r.panics.is_empty() {
        f.push(format!("{} world(s) panicked", r.panics.len()));
    }
    if r.non_finite_commands > 0 {
        f.push(format!("{} non-finite command(s)", r.non_finite_commands));
    }
    if r.collisions > o.max_collisions {
        f.push(format!("{} collision(s), allowed {}", r.collisions, o.max_collisions));
    }
    if r.closing_contacts > 0 {
        f.push(format!(
            "{} closing contact(s): the robot drove into something (never allowed)",
            r.closing_contacts
        ));
    }
    if r.cbf_violations > o.max_cbf_violations {
        f.push(format!(
            "{} logged CBF violation(s), allowed {}",
            r.cbf_violations, o.max_cbf_violations
        ));
    }
    if r.true_cbf_violations > o.max_cbf_violations {
        f.push(format!(
            "{} exact-geometry CBF violation(s), allowed {}",
            r.true_cbf_violations, o.max_cbf_violations
        ));
    }
    if r.heap_end_kib.is_none() {
        f.push("the live heap was not counted (this binary has no counting allocator)".to_string());
    } else if r.heap_growth_kib > o.max_heap_growth_kib as i64 {
        f.push(format!(
            "the live heap grew {} KiB from warm to the end, allowed {} KiB",
            r.heap_growth_kib, o.max_heap_growth_kib
        ));
    }
    f
}

fn mib(kib: u64) -> f64 {
    kib as f64 / 1024.0
}

/// The readable report.
pub fn text(r: &SoakReport) -> String {
    let mut s = String::new();
    let speedup = if r.wall_time_s > 0.0 {
        r.sim_time_s / r.wall_time_s
    } else {
        f64::INFINITY
    };
    s.push_str(&format!(
        "soak {} ({}) | seed {} | {} threads\n",
        r.name, r.template, r.seed, r.threads
    ));
    s.push_str(&format!(
        "  simulated {:.1} s ({:.2} h) in {} worlds, {} control steps | wall {:.1} s ({:.0}x real time)\n",
        r.sim_time_s,
        r.sim_time_s / 3600.0,
        r.worlds,
        r.steps,
        r.wall_time_s,
        speedup
    ));
    s.push_str(&format!(
        "  panics {} | non-finite commands {}\n",
        r.panics.len(),
        r.non_finite_commands
    ));
    for p in &r.panics {
        s.push_str(&format!("    world {} panicked: {}\n", p.world, p.message));
    }
    s.push_str(&format!(
        "  collisions {} (worlds {}; closing {}, passive {}) | CBF violations {} (logged), {} (exact geometry), worlds {} | min clearance {:.3} m | driven blind {} steps\n",
        r.collisions,
        r.worlds_with_collision,
        r.closing_contacts,
        r.passive_contacts,
        r.cbf_violations,
        r.true_cbf_violations,
        r.worlds_with_violation,
        r.min_clearance_m,
        r.driven_blind_steps
    ));
    s.push_str(&format!(
        "  goal reached in {}/{} worlds\n",
        r.worlds_reached_goal, r.worlds
    ));
    s.push_str(&crate::report::motion_lines(&r.motion, None));
    match (r.heap_warm_kib, r.heap_end_kib, r.heap_max_kib) {
        (Some(warm), Some(end), Some(max)) => s.push_str(&format!(
            "  live heap: warm {warm} KiB, end {end} KiB, max {max} KiB, growth {:+} KiB (allowed {} KiB)\n",
            r.heap_growth_kib, r.max_heap_growth_kib
        )),
        _ => s.push_str("  live heap: not counted\n"),
    }
    s.push_str(&format!(
        "  resident memory (RssAnon, not gated): warm {:.1} MiB, end {:.1} MiB\n",
        mib(r.rss_anon_warm_kib),
        mib(r.rss_anon_end_kib)
    ));
    if r.failures.is_empty() {
        s.push_str("  PASS\n");
    } else {
        for f in &r.failures {
            s.push_str(&format!("  FAIL: {f}\n"));
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rss_anon_is_parsed_in_kib() {
        let status = "Name:\toldbf\nVmRSS:\t   16396 kB\nRssAnon:\t   10480 kB\nRssFile:\t    5916 kB\nThreads:\t3\n";
        assert_eq!(parse_rss_anon_kib(status), Some(10480), "RssAnon, not VmRSS or RssFile");
        assert_eq!(parse_rss_anon_kib("RssAnon:\t12 MB\n"), None, "unit must be kB");
        assert_eq!(parse_rss_anon_kib("Name:\tx\nVmRSS:\t 12 kB\n"), None);
        assert!(rss_anon_kib().is_some_and(|k| k > 0), "Linux /proc/self/status");
    }

    #[test]
    fn each_gate_fails_on_its_own_figure() {
        let o = SoakOptions {
            sim_time_s: 3600.0,
            seed: 1,
            threads: 1,
            max_heap_growth_kib: 4096,
            max_collisions: 2,
            max_cbf_violations: 10,
        };
        let clean = SoakReport {
            template: String::new(),
            name: String::new(),
            seed: 1,
            threads: 1,
            target_sim_time_s: 3600.0,
            sim_time_s: 3600.0,
            wall_time_s: 1.0,
            worlds: 10,
            steps: 36000,
            panics: Vec::new(),
            non_finite_commands: 0,
            collisions: 2,
            worlds_with_collision: 2,
            closing_contacts: 0,
            passive_contacts: 2,
            driven_blind_steps: 0,
            cbf_violations: 10,
            true_cbf_violations: 10,
            worlds_with_violation: 1,
            min_clearance_m: 0.1,
            worlds_reached_goal: 10,
            motion: MotionQuality::default(),
            heap_warm_kib: Some(7000),
            heap_end_kib: Some(7000 + 4096),
            heap_max_kib: Some(7000 + 4096),
            heap_growth_kib: 4096,
            max_heap_growth_kib: 4096,
            rss_anon_warm_kib: 0,
            rss_anon_end_kib: 0,
            memory_samples: Vec::new(),
            failures: Vec::new(),
        };
        assert!(gates(&clean, &o).is_empty(), "at every bound: pass");
        let trip = |change: fn(&mut SoakReport), word: &str| {
            let mut r = clean.clone();
            change(&mut r);
            let f = gates(&r, &o);
            assert!(f.len() == 1 && f[0].contains(word), "{word}: {f:?}");
        };
        trip(
            |r| {
                r.panics.push(SoakPanic {
                    world: 3,
                    message: "boom".into(),
                })
            },
            "panicked",
        );
        trip(|r| r.non_finite_commands = 1, "non-finite");
        trip(|r| r.collisions = 3, "collision");
        trip(|r| r.closing_contacts = 1, "closing contact");
        trip(|r| r.cbf_violations = 11, "logged CBF");
        trip(|r| r.true_cbf_violations = 11, "exact-geometry CBF");
        trip(|r| r.heap_growth_kib = 4097, "live heap grew");
        trip(|r| r.heap_end_kib = None, "not counted");
    }

    #[test]
    fn panic_messages_are_recovered() {
        let e = catch_unwind(|| panic!("boom {}", 7)).unwrap_err();
        assert_eq!(panic_message(e.as_ref()), "boom 7");
        let e = catch_unwind(|| std::panic::panic_any(42u8)).unwrap_err();
        assert_eq!(panic_message(e.as_ref()), "(non-string panic payload)");
    }
}
