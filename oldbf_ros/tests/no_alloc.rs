//! The per-scan path must not allocate in steady state: a counting global
//! allocator proves it. Allocations are counted per thread, so the test
//! harness's other threads cannot disturb the count.

use oldbf_ros::algo::{LaserScan, Params, SafetyPipeline, Twist};
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
                stamp_s: if j == 4 && k % 2 == 0 { t - 10.0 } else { t },
                angle_min_rad: -std::f32::consts::PI,
                angle_increment_rad: inc,
                range_min_m: 0.12,
                range_max_m: 3.5,
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
    for beams in [360, 720, 1440, 2048] {
        let scans = scans(beams);
        let mut p = Params::default();
        p.control.allow_reverse = true; // so escape searches the whole box
        let mut pipe = SafetyPipeline::new(p);
        run(&mut pipe, &scans, 2); // the first scans of this size (both stale and fresh) may grow buffers
        let before = allocations();
        run(&mut pipe, &scans, 50);
        let during = allocations() - before;
        assert_eq!(
            during, 0,
            "{beams} beams: {during} allocations in 250 steady-state steps"
        );
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
