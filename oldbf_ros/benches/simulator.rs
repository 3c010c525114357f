//! Closed-loop simulator throughput on one core: control steps per second
//! of `run_scenario` (per step: a 360-beam LiDAR scan, the OLDBF pipeline,
//! the tracking law, and 10 physics sub-steps with exact collision checks)
//! in a 10 × 10 m room with 50 obstacles: 20 posts, 10 boxes and 20 movers
//! (crossing, bouncing, looping at 0.3-1.5 × the robot's speed).
//!
//! The world is drawn by the batch generator (`oldbf_ros::batch`), so it is
//! valid by construction: world 4 of seed 1, in which the robot drives
//! 3.8 m through the crowd in 30 s (in worlds 0 and 6 it is boxed in near
//! its start, which would time a robot standing still). Each run is cut to
//! 30 s (300 control steps); criterion's throughput (elements = steps) gives
//! steps per second.
//!
//! Run: `cargo bench -p oldbf_ros --bench simulator`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use oldbf_ros::batch::Template;
use oldbf_ros::sim::run::{run_scenario, Controller};
use oldbf_ros::sim::scenario::Scenario;
use std::hint::black_box;
use std::time::Duration;

/// The benchmark world: a batch template with fixed counts.
const TEMPLATE: &str = "
name: bench_50_obstacles
duration_s: 120
room: {width_m: 10.0, height_m: 10.0}
robot: {preset: turtlebot3_burger}
lidar: {beams: 360, fov_deg: 360, range_min_m: 0.12, range_max_m: 3.5, noise_std_m: 0.01, dropout_prob: 0.01, dropout: mixed, rate_hz: 10}
nominal: {v_mps: 0.15, wall_margin_m: 0.8}
static_obstacles:
  circles: {count: [20, 20], radius_m: [0.1, 0.3]}
  boxes: {count: [10, 10], size_m: [0.3, 0.8]}
moving_obstacles:
  count: [20, 20]
  speed_fraction: [0.3, 1.5]
  radius_m: [0.12, 0.25]
  kinds: [crossing, bounce, waypoint_loop]
";

/// Simulated time per run (s).
const RUN_S: f64 = 30.0;
/// Which world of the template (seed 1).
const WORLD_INDEX: usize = 4;

fn world() -> Scenario {
    let template = Template::from_str(TEMPLATE, "simulator bench", None).unwrap_or_else(|e| panic!("{e}"));
    let mut scenario = template
        .world(1, WORLD_INDEX)
        .unwrap_or_else(|e| panic!("{e}"))
        .scenario;
    let w = &scenario.spec.world;
    assert_eq!(w.circles.len() + w.boxes.len() + w.moving.len(), 50);
    scenario.spec.duration_s = RUN_S;
    scenario
}

fn bench_simulator(c: &mut Criterion) {
    let scenario = world();
    let seed = scenario.spec.seed;
    let probe = run_scenario(&scenario, Controller::Oldbf, seed).unwrap_or_else(|e| panic!("{e}"));
    let steps = probe.summary.steps as u64;
    let s = &probe.summary;
    eprintln!(
        "simulator: {steps} steps per run, path {:.2} m, collisions {}, min clearance {:.3} m, filter changed {}, \
         pipeline {:.1} µs/step",
        s.figures.path_length_m,
        s.figures.collisions,
        s.figures.min_clearance_m,
        s.figures.filter_changed_steps,
        s.mean_step_us
    );
    let mut group = c.benchmark_group("simulator");
    group.throughput(Throughput::Elements(steps));
    group.bench_function("closed_loop_360_beams_50_obstacles", |b| {
        b.iter(|| {
            let r = run_scenario(black_box(&scenario), Controller::Oldbf, seed).expect("runs");
            assert_eq!(r.summary.steps as u64, steps, "deterministic");
            black_box(r.summary.figures.min_clearance_m)
        })
    });
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(20)
        .warm_up_time(Duration::from_secs(2))
        .measurement_time(Duration::from_secs(8));
    targets = bench_simulator
}
criterion_main!(benches);
