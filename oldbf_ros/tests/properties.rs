//! Property tests over the whole per-scan pipeline.
//!
//! The oracles here recompute h and h(k+1) from the raw ranges, independently
//! of the pipeline's own bookkeeping, so a bug in the record cannot hide a
//! bug in the command.

use oldbf_ros::algo::barrier::distance_barrier;
use oldbf_ros::algo::dtcbf::{predicted_displacement, InputBox};
use oldbf_ros::algo::params::{BarrierParams, Params, PredictionModel};
use oldbf_ros::algo::select::{window::Limits, Window};
use oldbf_ros::algo::{LaserScan, SafetyPipeline, ScanHeader, Twist};
use proptest::prelude::*;
use proptest::test_runner::RngSeed;

/// Fixed seed (reproducible CI) unless PROPTEST_RNG_SEED asks for another.
fn config(cases: u32) -> ProptestConfig {
    let mut c = ProptestConfig::with_cases(cases);
    if std::env::var_os("PROPTEST_RNG_SEED").is_none() {
        c.rng_seed = RngSeed::Fixed(0x01DBF);
    }
    c
}

/// Any f32 a driver might put in a range: plausible, out of range, or garbage.
fn any_range() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => 0.0f32..10.0,
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NEG_INFINITY),
        1 => -5.0f32..0.0,
        1 => Just(0.0f32),
        1 => any::<f32>(),
    ]
}

fn any_f32(lo: f32, hi: f32) -> impl Strategy<Value = f32> {
    prop_oneof![4 => lo..hi, 1 => any::<f32>(), 1 => Just(f32::NAN), 1 => Just(0.0f32)]
}

fn any_f64(lo: f64, hi: f64) -> impl Strategy<Value = f64> {
    prop_oneof![4 => lo..hi, 1 => any::<f64>(), 1 => Just(f64::NAN), 1 => Just(f64::INFINITY)]
}

/// A well-formed 360° scan of `n` beams, each a range in [0.12, 3.5) or "no return".
fn valid_scan_ranges() -> impl Strategy<Value = Vec<f32>> {
    prop::collection::vec(prop_oneof![5 => 0.12f32..3.49, 1 => Just(f32::INFINITY)], 1..400)
}

fn scan_of(ranges: &[f32], angle_min: f32, inc: f32) -> LaserScan<'_> {
    LaserScan {
        header: ScanHeader {
            stamp_s: 5.0,
            angle_min_rad: angle_min,
            angle_increment_rad: inc,
            range_min_m: 0.12,
            range_max_m: 3.5,
        },
        ranges_m: ranges,
        intensities: &[],
    }
}

/// Valid points in the robot frame (laser at the origin), computed directly.
fn points_of(ranges: &[f32], angle_min: f32, inc: f32) -> Vec<(f64, f64)> {
    ranges
        .iter()
        .enumerate()
        .filter(|(_, &p)| p.is_finite() && (0.12..3.5).contains(&p))
        .map(|(i, &p)| {
            let a = angle_min as f64 + i as f64 * inc as f64;
            (p as f64 * a.cos(), p as f64 * a.sin())
        })
        .collect()
}

/// h after moving by Δt·v along +x (the Euler model with θ = 0), from the raw points.
fn h_after(points: &[(f64, f64)], step_m: f64, p: &Params) -> f64 {
    let d = points
        .iter()
        .map(|&(x, y)| ((x - step_m).powi(2) + y * y).sqrt())
        .fold(f64::INFINITY, f64::min);
    d - p.robot_radius_m() - p.barrier.d_safe_m
}

proptest! {
    #![proptest_config(config(600))]

    /// Any LaserScan, however malformed, and any nominal command: a finite
    /// command inside the input box, never a panic.
    #[test]
    fn any_scan_gives_a_finite_command_in_the_box(
        ranges in prop::collection::vec(any_range(), 0..300),
        intensities_len in prop_oneof![Just(0usize), 0usize..300],
        angle_min in any_f32(-4.0, 4.0),
        inc in any_f32(-0.1, 0.1),
        range_min in any_f32(0.0, 0.5),
        range_max in any_f32(0.5, 20.0),
        stamp in any_f64(4.0, 6.0),
        v_nom in any_f64(-1.0, 1.0),
        w_nom in any_f64(-3.0, 3.0),
        v_now in any_f64(-1.0, 1.0),
        allow_reverse in any::<bool>(),
    ) {
        let intensities = vec![1.0f32; if intensities_len == 0 { 0 } else { intensities_len }];
        let scan = LaserScan { header: ScanHeader { stamp_s: stamp, angle_min_rad: angle_min, angle_increment_rad: inc, range_min_m: range_min, range_max_m: range_max }, ranges_m: &ranges, intensities: &intensities };
        let mut p = Params::default();
        p.control.allow_reverse = allow_reverse;
        let bx = InputBox::from_params(&p);
        let mut pipe = SafetyPipeline::new(p);
        for _ in 0..2 {
            let rec = pipe.step(&scan, 5.0, Twist::new(v_nom, w_nom), v_now);
            prop_assert!(rec.cmd.is_finite(), "{rec:?}");
            prop_assert!(rec.cmd.v_mps >= bx.v_lo && rec.cmd.v_mps <= bx.v_hi, "{rec:?}");
            prop_assert!(rec.cmd.omega_radps.abs() <= bx.omega_max, "{rec:?}");
            if rec.stop_cause.is_some() && !rec.measured() {
                prop_assert_eq!(rec.cmd, Twist::ZERO);
            }
        }
    }

    /// With h ≥ 0 a safe command always exists (standing still keeps h for a
    /// static scene), so the command sent must satisfy h(k+1) ≥ (1 − γ) h(k),
    /// checked here from the raw ranges. When the filter lowered v, the
    /// result is the largest admissible v: on the boundary of the condition.
    #[test]
    fn the_sent_command_satisfies_the_dtcbf_condition(
        // Scenes inside the safe set: r + d_safe ≤ 0.178 + 0.2 < 0.38 m, some points right at it.
        ranges in prop::collection::vec(prop_oneof![5 => 0.38f32..3.49, 2 => 0.38f32..0.5, 1 => Just(f32::INFINITY)], 1..400),
        v_nom in 0.0f64..0.3,
        w_nom in -0.5f64..0.5,
        gamma in 0.05f64..1.0,
        d_safe in 0.05f64..0.2,
    ) {
        let n = ranges.len();
        let inc = (2.0 * std::f64::consts::PI / n as f64) as f32;
        let angle_min = -std::f32::consts::PI;
        let mut p = Params::default();
        p.dtcbf.gamma = gamma;
        p.dtcbf.noise_margin_m = 0.0; // the plain definition
        p.barrier.d_safe_m = d_safe;
        let mut pipe = SafetyPipeline::new(p.clone());
        let rec = pipe.step(&scan_of(&ranges, angle_min, inc), 5.0, Twist::new(v_nom, w_nom), v_nom);
        let pts = points_of(&ranges, angle_min, inc);
        let h = h_after(&pts, 0.0, &p);
        prop_assume!(h >= 0.0 && h.is_finite());
        let dt = p.control.dt_s();
        let h_next = h_after(&pts, dt * rec.cmd.v_mps, &p);
        prop_assert!((rec.h_m - h).abs() < 1e-6, "h {} vs {}", rec.h_m, h);
        prop_assert!(h_next >= (1.0 - gamma) * h - 1e-7, "h {h} h_next {h_next} cmd {:?}", rec.cmd);
        prop_assert!(rec.condition_held && rec.stop_cause.is_none(), "{rec:?}");
        if rec.filter_changed && rec.cmd.omega_radps == rec.doaa_cmd.omega_radps && rec.cmd.v_mps < rec.doaa_cmd.v_mps {
            prop_assert!(h_next - (1.0 - gamma) * h < 1e-6, "not the largest admissible v: {rec:?}");
        }
    }

    /// Inside the unsafe set a safe command may or may not exist. Whenever one
    /// does among the commands the base can reach (found here by brute force
    /// over the dynamic window from rest, backing up allowed), the filter
    /// must send one that satisfies the condition.
    #[test]
    fn inside_the_unsafe_set_a_feasible_command_is_found(
        ranges in prop::collection::vec(prop_oneof![3 => 0.25f32..3.49, 1 => 0.2f32..0.4, 1 => Just(f32::INFINITY)], 1..300),
        v_nom in 0.0f64..0.22,
        gamma in 0.05f64..1.0,
        v_rev in 0.0f64..0.3,
    ) {
        let n = ranges.len();
        let inc = (2.0 * std::f64::consts::PI / n as f64) as f32;
        let angle_min = -std::f32::consts::PI;
        let mut p = Params::default();
        p.dtcbf.gamma = gamma;
        p.control.allow_reverse = true;
        p.control.v_reverse_max_mps = v_rev;
        let pts = points_of(&ranges, angle_min, inc);
        let h = h_after(&pts, 0.0, &p);
        prop_assume!(h < 0.0);
        let dt = p.control.dt_s();
        let target = (1.0 - gamma) * h;
        // Brute force: with the Euler model the yaw rate does not move the robot in one step.
        let window = Window::new(Twist::ZERO, dt, &Limits::driving(&p), &InputBox::from_params(&p));
        let (lo, hi) = window.v;
        let feasible = (0..=4000).any(|i| {
            let v = lo + (hi - lo) * i as f64 / 4000.0;
            h_after(&pts, dt * v, &p) >= target + 1e-6
        });
        let rec = SafetyPipeline::new(p.clone()).step(&scan_of(&ranges, angle_min, inc), 5.0, Twist::new(v_nom, 0.0), v_nom);
        let h_next = h_after(&pts, dt * rec.cmd.v_mps, &p);
        if feasible {
            prop_assert!(h_next >= target - 1e-7, "feasible but not found: h {h}, h_next {h_next}, {rec:?}");
            prop_assert!(rec.condition_held && rec.stop_cause.is_none(), "{rec:?}");
        }
        // Feasible or not: never closer than now by more than the escape rules allow.
        prop_assert!(rec.cmd.is_finite());
    }

    /// B_d is non-increasing in the distance, for any valid barrier shape.
    #[test]
    fn distance_barrier_is_monotone(
        big_gamma in 0.1f64..5.0,
        sigma in 0.5f64..5.0,
        d_safe in 0.0f64..1.0,
        d1 in -1.0f64..5.0,
        gap in 0.0f64..3.0,
    ) {
        let p = BarrierParams { big_gamma, sigma, d_safe_m: d_safe, ..BarrierParams::default() };
        let (b1, _) = distance_barrier(d1, &p);
        let (b2, _) = distance_barrier(d1 + gap, &p);
        prop_assert!(b1 >= b2, "B({d1}) = {b1} < B({}) = {b2}", d1 + gap);
        prop_assert!(b2 >= 1.0 && b1 <= p.barrier_max);
    }

    /// The same scan with its beams in reverse order and a negated increment
    /// describes the same points, so everything must come out the same.
    #[test]
    fn reversed_beam_order_gives_the_same_result(
        ranges in valid_scan_ranges(),
        angle_min in -3.1f32..-2.0,
        v_nom in 0.0f64..0.22,
        w_nom in -0.3f64..0.3,
    ) {
        let n = ranges.len();
        let inc = (2.0 * std::f64::consts::PI / n as f64) as f32;
        let last = (angle_min as f64 + (n - 1) as f64 * inc as f64) as f32;
        let reversed: Vec<f32> = ranges.iter().rev().copied().collect();
        let a = SafetyPipeline::new(Params::default()).step(&scan_of(&ranges, angle_min, inc), 5.0, Twist::new(v_nom, w_nom), v_nom);
        let b = SafetyPipeline::new(Params::default()).step(&scan_of(&reversed, last, -inc), 5.0, Twist::new(v_nom, w_nom), v_nom);
        let close = |x: f64, y: f64| (x == y) || (x - y).abs() <= 1e-5 * (1.0 + x.abs().max(y.abs()));
        prop_assert!(close(a.h_m, b.h_m) && close(a.d_left_m, b.d_left_m) && close(a.d_right_m, b.d_right_m), "{a:?}\n{b:?}");
        // B is compared through 1/B: near d_safe, B = Γ²/(Γ² − Δd^σ) magnifies the 1e-8 m by
        // which the two beam-direction tables place a point into 1e-3 differences of B.
        prop_assert!(close(1.0 / a.b_left, 1.0 / b.b_left) && close(1.0 / a.b_right, 1.0 / b.b_right), "{a:?}\n{b:?}");
        prop_assert!(close(a.cmd.v_mps, b.cmd.v_mps) && close(a.cmd.omega_radps, b.cmd.omega_radps), "{a:?}\n{b:?}");
        prop_assert_eq!(a.state, b.state);
        prop_assert_eq!(a.valid_beams, b.valid_beams);
    }
}

/// Signed distance from `q` to the polygon `v` (any winding), written apart
/// from the core's: the least distance to each edge, negative inside by the
/// winding number.
fn polygon_sd(v: &[(f64, f64)], q: (f64, f64)) -> f64 {
    let n = v.len();
    let (mut d, mut winding) = (f64::INFINITY, 0i32);
    for i in 0..n {
        let (a, b) = (v[i], v[(i + 1) % n]);
        let (ex, ey) = (b.0 - a.0, b.1 - a.1);
        let t = (((q.0 - a.0) * ex + (q.1 - a.1) * ey) / (ex * ex + ey * ey)).clamp(0.0, 1.0);
        d = d.min(((q.0 - a.0 - t * ex).powi(2) + (q.1 - a.1 - t * ey).powi(2)).sqrt());
        let cross = ex * (q.1 - a.1) - ey * (q.0 - a.0);
        if a.1 <= q.1 && b.1 > q.1 && cross > 0.0 {
            winding += 1;
        } else if a.1 > q.1 && b.1 <= q.1 && cross < 0.0 {
            winding -= 1;
        }
    }
    if winding != 0 {
        -d
    } else {
        d
    }
}

/// h of a polygon body after a step that moves it by `disp` and turns it by
/// `theta`: the least signed distance from the polygon, less d_safe.
fn polygon_h_after(v: &[(f64, f64)], points: &[(f64, f64)], disp: (f64, f64), theta: f64, d_safe: f64) -> f64 {
    let (s, c) = theta.sin_cos();
    points
        .iter()
        .map(|&(x, y)| {
            let (rx, ry) = (x - disp.0, y - disp.1);
            polygon_sd(v, (c * rx + s * ry, -s * rx + c * ry))
        })
        .fold(f64::INFINITY, f64::min)
        - d_safe
}

proptest! {
    #![proptest_config(config(300))]

    /// A rectangular robot (any size, off-centre on its axle), both
    /// prediction models: from inside the safe set, the command sent keeps
    /// the one-step condition on the polygon, so no corner or edge comes
    /// inside d_safe of a static point at the next step (checked from the
    /// raw ranges with a plain signed distance, the turn included).
    #[test]
    fn a_polygon_robot_never_brings_a_corner_or_edge_inside_d_safe_in_one_step(
        ranges in prop::collection::vec(prop_oneof![5 => 0.5f32..3.49, 3 => 0.3f32..0.7, 1 => Just(f32::INFINITY)], 1..360),
        v_nom in -0.1f64..0.3,
        w_nom in -0.5f64..0.5,
        gamma in 0.05f64..1.0,
        d_safe in 0.05f64..0.15,
        length in 0.3f64..0.6,
        width in 0.2f64..0.4,
        offset in -0.05f64..0.05,
        arc in any::<bool>(),
    ) {
        let n = ranges.len();
        let inc = (2.0 * std::f64::consts::PI / n as f64) as f32;
        let angle_min = -std::f32::consts::PI;
        let (hx, hy) = (0.5 * length, 0.5 * width);
        let v = [(offset + hx, hy), (offset - hx, hy), (offset - hx, -hy), (offset + hx, -hy)];
        let mut p = Params::default();
        p.dtcbf.gamma = gamma;
        p.dtcbf.noise_margin_m = 0.0; // the plain definition
        p.barrier.d_safe_m = d_safe;
        p.control.omega_max_radps = 1.0;
        p.dtcbf.prediction = if arc { PredictionModel::Arc } else { PredictionModel::Euler };
        p.footprint.polygon_m = v.iter().map(|&(x, y)| [x, y]).collect();
        let pts = points_of(&ranges, angle_min, inc);
        let h = polygon_h_after(&v, &pts, (0.0, 0.0), 0.0, d_safe);
        prop_assume!(h >= 0.0 && h.is_finite());
        let rec = SafetyPipeline::new(p.clone()).step(&scan_of(&ranges, angle_min, inc), 5.0, Twist::new(v_nom, w_nom), v_nom);
        let dt = p.control.dt_s();
        let disp = predicted_displacement(p.dtcbf.prediction, rec.cmd, dt);
        let h_next = polygon_h_after(&v, &pts, (disp.x, disp.y), rec.cmd.omega_radps * dt, d_safe);
        prop_assert!((rec.h_m - h).abs() < 1e-6, "h {} vs {}", rec.h_m, h);
        prop_assert!(h_next >= (1.0 - gamma) * h - 1e-7, "h {h} h_next {h_next} cmd {:?}", rec.cmd);
        prop_assert!(h_next >= -1e-7, "a corner or edge inside d_safe: {h_next}");
    }
}
