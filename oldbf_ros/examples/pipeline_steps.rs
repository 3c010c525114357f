//! A fixed run of `SafetyPipeline::step_with_pose` on the benchmark's scans,
//! for instruction counts: the same inputs as `benches/pipeline.rs`
//! (`benches/common`), one cycle of warm-up, then `STEPS` measured steps.
//! Deterministic, so callgrind's counts repeat exactly:
//!
//! ```sh
//! cargo build --release -p oldbf_ros --example pipeline_steps
//! valgrind --tool=callgrind --toggle-collect='*measured_steps*' \
//!     target/release/examples/pipeline_steps 360 people
//! ```
//!
//! Arguments: beams (360, 720, 1440 or 2048), `people` or `off` (tracking),
//! and how many times to repeat the measured steps (default 1; more for a
//! sampling profiler such as `perf record`).

#[path = "../benches/common/mod.rs"]
mod common;

use common::{robot_speed_mps, ScanCycle, FRAMES, SCAN_PERIOD_S};
use oldbf_ros::algo::{LaserScan, Params, SafetyPipeline, ScanHeader, StepRecord, Twist};
use std::hint::black_box;

/// Measured steps: two cycles of the scans.
const STEPS: usize = 2 * FRAMES;

fn step(pipe: &mut SafetyPipeline, cycle: &ScanCycle, k: usize) -> StepRecord {
    let t = k as f64 * SCAN_PERIOD_S;
    let scan = LaserScan {
        header: ScanHeader {
            stamp_s: t,
            angle_min_rad: cycle.spec.angle_min_rad(),
            angle_increment_rad: cycle.spec.angle_increment_rad(),
            range_min_m: cycle.spec.range_min_m as f32,
            range_max_m: cycle.spec.range_max_m as f32,
        },
        ranges_m: &cycle.ranges[k % FRAMES],
        intensities: &[],
    };
    let v = robot_speed_mps();
    let nominal = Twist::new(v.min(0.22), v / common::ROBOT_CIRCLE_RADIUS_M);
    pipe.step_with_pose(&scan, t, nominal, v, Some(cycle.poses[k % FRAMES]))
}

/// The measured part (callgrind's `--toggle-collect` target).
#[inline(never)]
fn measured_steps(pipe: &mut SafetyPipeline, cycle: &ScanCycle, first: usize) -> f64 {
    let mut sum = 0.0;
    for k in first..first + STEPS {
        let rec = step(pipe, black_box(cycle), k);
        sum += rec.cmd.v_mps + rec.cmd.omega_radps;
    }
    sum
}

fn main() {
    let mut args = std::env::args().skip(1);
    let beams: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(360);
    let tracking = args.next().as_deref() != Some("off");
    let cycle = ScanCycle::generate(beams);
    let mut params = Params::default();
    params.obstacles.enabled = tracking;
    let mut pipe = SafetyPipeline::new(params);
    for k in 0..FRAMES {
        step(&mut pipe, &cycle, k);
    }
    let repeats: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(1);
    let mut checksum = 0.0;
    for rep in 0..repeats {
        // Time runs on: each repeat continues the cycle where the last one left it.
        checksum += measured_steps(&mut pipe, &cycle, FRAMES + rep * STEPS);
    }
    println!(
        "{beams} beams, tracking {tracking}: {} steps, checksum {checksum:.12}",
        repeats * STEPS
    );
}
