//! `SafetyPipeline::step` per scan (sanitise → clusters and tracks →
//! barriers → DOAA → exact DTCBF filter) on realistic scans: a room with
//! walls, boxes, posts and 10 people walking through it, seen by a robot
//! driving a circle among them, at 360, 720, 1440 and 2048 beams.
//!
//! The scans are ray-cast once (`common::ScanCycle`) and cycled through, with
//! the robot's pose as odometry, so the pipeline sees a continuous world:
//! people approach, pass within d_act and sometimes within d_safe (the
//! filter then changes the command; the set-up prints how often).
//!
//! Each variant is a parameter change only; add one to [`VARIANTS`].
//!
//! Group `baseline_per_step` times the DCBF-QP and VO baselines' own work
//! per step on the same inputs, for the ratio.
//!
//! Run: `cargo bench -p oldbf_ros --bench pipeline`.

mod common;

use common::{robot_speed_mps, ScanCycle, FRAMES, SCAN_PERIOD_S};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use oldbf_ros::algo::{DoaaState, LaserScan, Params, SafetyPipeline, ScanHeader, Twist};
use oldbf_ros::baselines::{vo_command, DcbfFilter, VoScene};
use std::hint::black_box;
use std::time::{Duration, Instant};

/// Beam counts measured.
const BEAMS: [usize; 4] = [360, 720, 1440, 2048];

/// A pipeline configuration: a name and a change of the default parameters.
struct Variant {
    name: &'static str,
    configure: fn(&mut Params),
}

/// Pipeline configurations measured. Moving-obstacle tracking is
/// `obstacles.enabled`.
const VARIANTS: [Variant; 2] = [
    // The static-world filter of the paper: no tracking.
    Variant {
        name: "tracking_off",
        configure: |p| p.obstacles.enabled = false,
    },
    // With 10 tracked obstacles (the people): clusters, Kalman tracks, collision cones.
    Variant {
        name: "tracking_10_people",
        configure: |p| p.obstacles.enabled = true,
    },
];

/// The scan of frame `k` (of an endless sequence) as the pipeline takes it.
fn scan<'a>(cycle: &'a ScanCycle, k: usize) -> (LaserScan<'a>, f64) {
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
    (scan, t)
}

/// The command the robot is asked to follow: its circle.
fn nominal() -> Twist {
    let v = robot_speed_mps();
    Twist::new(v.min(0.22), v / common::ROBOT_CIRCLE_RADIUS_M)
}

/// One step of frame `k`.
fn step(pipe: &mut SafetyPipeline, cycle: &ScanCycle, k: usize) -> oldbf_ros::algo::StepRecord {
    let (scan, t) = scan(cycle, k);
    pipe.step_with_pose(&scan, t, nominal(), robot_speed_mps(), Some(cycle.poses[k % FRAMES]))
}

/// Prints what two cycles through the scans exercise, so a reader can see
/// the filter is active (and a change of the inputs that stops it shows).
fn describe(name: &str, params: &Params, cycle: &ScanCycle) {
    let mut pipe = SafetyPipeline::new(params.clone());
    let (mut changed, mut avoid, mut stop_or_escape, mut threats) = (0, 0, 0, 0);
    for k in 0..2 * FRAMES {
        let rec = step(&mut pipe, cycle, k);
        if k >= FRAMES {
            changed += usize::from(rec.filter_changed);
            avoid += usize::from(matches!(rec.state, DoaaState::Avoid | DoaaState::BothSides));
            stop_or_escape += usize::from(matches!(rec.state, DoaaState::Stop | DoaaState::Escape));
            threats += pipe.threats().len();
        }
    }
    eprintln!(
        "pipeline/{name}/{}: per {FRAMES} scans: filter changed {changed}, avoiding {avoid}, \
         stop/escape {stop_or_escape}, obstacles on a collision course {threats}",
        cycle.spec.beams
    );
}

fn bench_pipeline(c: &mut Criterion) {
    let mut group = c.benchmark_group("pipeline");
    group.throughput(Throughput::Elements(1));
    for beams in BEAMS {
        let cycle = ScanCycle::generate(beams);
        for Variant { name, configure } in VARIANTS {
            let mut params = Params::default();
            configure(&mut params);
            describe(name, &params, &cycle);
            let mut pipe = SafetyPipeline::new(params);
            // Warm the buffers and the tracks up over one cycle.
            for k in 0..FRAMES {
                step(&mut pipe, &cycle, k);
            }
            let mut k = FRAMES;
            group.bench_function(BenchmarkId::new(name, beams), |b| {
                b.iter(|| {
                    let rec = step(&mut pipe, black_box(&cycle), k);
                    k += 1;
                    black_box(rec)
                })
            });
        }
    }
    group.finish();
}

/// The baselines' own work per step, on the inputs the pipeline perceives
/// (same scans, same points, prediction and tracks, same nominal command):
/// the DCBF-QP solve (constraints built and solved by clarabel) and one ORCA
/// step (dodgy_2d). The pipeline step that produces their inputs runs
/// outside the timed region. For the ratio with `pipeline/tracking_10_people`.
fn bench_baselines(c: &mut Criterion) {
    let mut group = c.benchmark_group("baseline_per_step");
    group.throughput(Throughput::Elements(1));
    let beams = 360;
    let cycle = ScanCycle::generate(beams);
    let params = Params::default();
    let mut pipe = SafetyPipeline::new(params.clone());
    for k in 0..FRAMES {
        step(&mut pipe, &cycle, k);
    }
    let mut k = FRAMES;
    let mut dcbf = DcbfFilter::new();
    group.bench_function(BenchmarkId::new("dcbf_qp", beams), |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                step(&mut pipe, &cycle, k);
                k += 1;
                let t0 = Instant::now();
                black_box(dcbf.filter(pipe.points(), pipe.points_next(), black_box(nominal()), &params));
                total += t0.elapsed();
            }
            total
        })
    });
    group.bench_function(BenchmarkId::new("vo_orca", beams), |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                step(&mut pipe, &cycle, k);
                k += 1;
                let scene = VoScene {
                    points: pipe.points(),
                    clusters: pipe.clusters(),
                    tracker: pipe.tracker(),
                    v_now_mps: robot_speed_mps(),
                };
                let t0 = Instant::now();
                black_box(vo_command(&scene, black_box(nominal()), &params));
                total += t0.elapsed();
            }
            total
        })
    });
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(50)
        .warm_up_time(Duration::from_secs(2))
        .measurement_time(Duration::from_secs(4));
    targets = bench_pipeline, bench_baselines
}
criterion_main!(benches);
