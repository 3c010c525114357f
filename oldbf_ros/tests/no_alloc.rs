//! The per-scan path must not allocate in steady state: a counting global
//! allocator proves it. Allocations are counted per thread, so the test
//! harness's other threads cannot disturb the count.

// A global allocator is an `unsafe impl`: the workspace denies unsafe code
// everywhere else.
#![allow(unsafe_code)]

use oldbf_ros::algo::{LaserScan, Params, Pose2, SafetyPipeline, ScanHeader, Twist};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

fn allocations() -> usize {
    ALLOCATIONS.with(|c| c.get())
}

fn count() {
    // `try_with`: the slot may be gone while a thread shuts down.
    let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        System.alloc(layout)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        System.realloc(ptr, layout, new_size)
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Scans of `beams` beams that exercise every branch: free space, a wall ahead
/// (filter lowers v), both sides blocked (latched turn), inside the unsafe set
/// (escape, box search), and malformed (rejection).
fn scans(beams: usize) -> Vec<Vec<f32>> {
    let ahead = |d: f32, half_width: usize| {
        let mut r = vec![f32::INFINITY; beams];
        let mid = beams / 2;
        r[mid - half_width..=mid + half_width].fill(d);
        r
    };
    let mut dead_end = ahead(0.6, beams / 8);
    for (i, r) in dead_end.iter_mut().enumerate() {
        if i > beams / 4 && i < 3 * beams / 4 {
            *r = r.min(0.7);
        }
    }
    vec![
        vec![f32::INFINITY; beams],
        ahead(0.45, beams / 36),
        dead_end,
        ahead(0.3, beams / 36),
        (0..beams)
            .map(|i| {
                if i % 7 == 0 {
                    f32::NAN
                } else {
                    1.0 + (i % 13) as f32 * 0.1
                }
            })
            .collect(),
    ]
}

fn run(pipe: &mut SafetyPipeline, scans: &[Vec<f32>], rounds: usize) {
    let beams = scans[0].len();
    let inc = 2.0 * std::f32::consts::PI / beams as f32;
    for k in 0..rounds {
        for (j, ranges) in scans.iter().enumerate() {
            let t = (k * scans.len() + j) as f64 * 0.1;
            let scan = LaserScan {
                header: ScanHeader {
                    stamp_s: if j == 4 && k % 2 == 0 { t - 10.0 } else { t },
                    angle_min_rad: -std::f32::consts::PI,
                    angle_increment_rad: inc,
                    range_min_m: 0.12,
                    range_max_m: 3.5,
                },
                ranges_m: ranges,
                intensities: &[],
            };
            let rec = pipe.step(&scan, t, Twist::new(0.15, 0.1), 0.15);
            assert!(rec.cmd.is_finite());
        }
    }
}

#[test]
fn steady_state_steps_do_not_allocate() {
    for (beams, polygon) in [
        (360, false),
        (720, false),
        (1440, false),
        (2048, false),
        (360, true),
        (1440, true),
    ] {
        let scans = scans(beams);
        let mut p = Params::default();
        p.control.allow_reverse = true; // so escape searches the whole box
        if polygon {
            // A 0.3 x 0.2 m rectangular body: the polygon's own scratch too.
            p.footprint.polygon_m = vec![[0.15, 0.1], [-0.15, 0.1], [-0.15, -0.1], [0.15, -0.1]];
        }
        let mut pipe = SafetyPipeline::new(p);
        run(&mut pipe, &scans, 2); // the first scans of this size (both stale and fresh) may grow buffers
        let before = allocations();
        run(&mut pipe, &scans, 50);
        let during = allocations() - before;
        assert_eq!(
            during, 0,
            "{beams} beams (polygon {polygon}): {during} allocations in 250 steady-state steps"
        );
    }
}

/// Ten legs (radius 0.1 m) swinging back and forth at up to 0.5 m/s around
/// fixed centres 1.2–2.6 m from a robot at the origin: a 360° scan of `ranges`
/// beams at time `t_s`, written in place.
fn ten_movers(ranges: &mut [f32], t_s: f64) {
    const LEG_M: f64 = 0.1;
    let beams = ranges.len();
    let legs: [(f64, f64, f64); 10] = std::array::from_fn(|i| {
        let bearing = i as f64 * std::f64::consts::TAU / 10.0;
        let dist = 1.2 + 0.15 * i as f64;
        let phase = (t_s + i as f64).sin(); // 1 rad/s
                                            // Even legs swing ±0.45 m across the line of sight (0.45 m/s peak), odd legs
                                            // ±0.5 m towards and away from the robot (0.5 m/s peak, on a collision
                                            // course half the time). None touches or hides another; all come where
                                            // earlier scans saw free (proof that they move, §6).
        let (s, c) = bearing.sin_cos();
        if i % 2 == 0 {
            let swing = 0.45 * phase;
            (dist * c - swing * s, dist * s + swing * c, LEG_M)
        } else {
            let swing = 0.5 * phase;
            ((dist + swing) * c, (dist + swing) * s, LEG_M)
        }
    });
    for (i, r) in ranges.iter_mut().enumerate() {
        let a = -std::f64::consts::PI + i as f64 * std::f64::consts::TAU / beams as f64;
        let (dy, dx) = a.sin_cos();
        let mut best = f64::INFINITY;
        for &(cx, cy, rad) in &legs {
            // Ray from the origin along (dx, dy) against the circle: s² − 2 s (d·c) + |c|² − r² = 0.
            let b = dx * cx + dy * cy;
            let disc = b * b - (cx * cx + cy * cy - rad * rad);
            if disc >= 0.0 && b - disc.sqrt() > 0.0 {
                best = best.min(b - disc.sqrt());
            }
        }
        *r = best as f32;
    }
}

#[test]
fn steady_state_steps_with_ten_tracked_obstacles_do_not_allocate() {
    for beams in [360, 2048] {
        let mut ranges = vec![0.0_f32; beams];
        let params = Params::default();
        let obstacles = params.obstacles.clone();
        let mut pipe = SafetyPipeline::new(params);
        let mut step = |pipe: &mut SafetyPipeline, k: usize| {
            let t = k as f64 * 0.1;
            ten_movers(&mut ranges, t);
            let scan = LaserScan {
                header: ScanHeader {
                    stamp_s: t,
                    angle_min_rad: -std::f32::consts::PI,
                    angle_increment_rad: 2.0 * std::f32::consts::PI / beams as f32,
                    range_min_m: 0.12,
                    range_max_m: 3.5,
                },
                ranges_m: &ranges,
                intensities: &[],
            };
            let rec = pipe.step_with_pose(&scan, t, Twist::new(0.15, 0.0), 0.0, Some(Pose2::default()));
            assert!(rec.cmd.is_finite());
            assert_eq!(
                pipe.tracker().tracks().len(),
                if k < 10 { pipe.tracker().tracks().len() } else { 10 }
            );
            (
                pipe.tracker()
                    .tracks()
                    .iter()
                    .filter(|tr| tr.is_moving(&obstacles))
                    .count(),
                pipe.threats().len(),
            )
        };
        for k in 0..100 {
            step(&mut pipe, k); // tracks are born and confirmed, buffers reach their size
        }
        let before = allocations();
        let (mut max_moving, mut sum_moving, mut max_threats) = (0, 0, 0);
        for k in 100..400 {
            let (moving, threats) = step(&mut pipe, k);
            max_moving = max_moving.max(moving);
            sum_moving += moving;
            max_threats = max_threats.max(threats);
        }
        let during = allocations() - before;
        assert_eq!(
            during, 0,
            "{beams} beams: {during} allocations in 300 steps with ten movers"
        );
        // The load really was ten tracked movers, some on a collision course.
        // A leg slows to a stop where it turns (and the phases differ), so not all
        // ten move at once; on average well over half do.
        assert!(max_moving >= 9, "{beams} beams: at most {max_moving} moving tracks");
        assert!(
            sum_moving >= 5 * 300,
            "{beams} beams: {} moving tracks per step on average",
            sum_moving / 300
        );
        assert!(max_threats >= 1, "{beams} beams: no mover was ever a threat");
    }
}

#[test]
fn the_counter_does_count() {
    // Guard against a test that cannot fail: an allocation is seen.
    let before = allocations();
    let v: Vec<u64> = Vec::with_capacity(std::hint::black_box(16));
    std::hint::black_box(&v);
    assert!(allocations() > before);
}
