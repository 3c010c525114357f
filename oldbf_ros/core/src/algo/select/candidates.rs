//! The candidates of one step (ALGORITHM.md §5c): a fine sample of the
//! dynamic window, with the speed exact per yaw rate where the DTCBF
//! geometry allows.
//!
//! Yaw rates: `select.omega_samples` evenly across the window's yaw rates,
//! plus the nominal's, the DOAA's and the last command's (each as near as
//! the window allows). Speeds, per yaw rate, within the allowed range (the
//! window cut to what a safety layer may command this step): `speed_samples`
//! evenly across it, the nominal's, the DOAA's, the last command's and 0
//! where they lie in it, and every edge of the speeds the strictest level's
//! requirement forbids (the DTCBF's forbidden intervals, exact for the
//! one-step model): so the fastest command that still meets the condition
//! is always a candidate, not a grid point near it.

use super::critics::{cheap_costs, unit_path, Context, CriticCosts, Look};
use super::window::Window;
use crate::algo::dtcbf::DtcbfFilter;
use crate::algo::geometry::{Twist, Vec2};
use crate::algo::params::{Params, PredictionModel};

/// Values closer than this are one sample (m/s, rad/s).
const SAME: f64 = 1e-9;

/// One candidate command, weighed as far as needed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// The command and its path over the horizon.
    pub look: Look,
    /// Predicted h(k+1) (m).
    pub h_next_m: f64,
    /// The critics that need no scan points, weighted.
    pub cheap: CriticCosts,
    /// Their sum.
    pub cheap_total: f64,
    /// The braking check (§5b), once done.
    pub braking: Option<bool>,
}

/// What to sample this step.
#[derive(Debug, Clone, Copy)]
pub struct Sampling {
    /// The window.
    pub window: Window,
    /// The speeds allowed this step, inside the window (m/s).
    pub v_range: (f64, f64),
    /// The strictest level's requirement on h(k+1) (m), whose forbidden
    /// speeds give the exact edges; `None`: nothing visible.
    pub exact_target_m: Option<f64>,
}

/// The candidates of the step and scratch buffers, reused.
#[derive(Debug, Clone, Default)]
pub struct Candidates {
    /// The candidates of the step.
    pub items: Vec<Candidate>,
    omegas: Vec<f64>,
    speeds: Vec<f64>,
}

impl Candidates {
    /// Room for a step's candidates without reallocating.
    pub fn with_capacity(p: &Params) -> Self {
        let omegas = p.select.omega_samples + 3;
        // Samples, four specials, and the edges of a few forbidden intervals.
        let speeds = p.select.speed_samples + 4 + 16;
        Self {
            items: Vec::with_capacity(omegas * speeds),
            omegas: Vec::with_capacity(omegas),
            speeds: Vec::with_capacity(speeds),
        }
    }

    /// Samples the window `s` for the critics' context `ctx`: every
    /// candidate's h(k+1) over `points_next` (the filter prepared for the
    /// step) and its cheap costs.
    pub fn sample(&mut self, s: &Sampling, filter: &mut DtcbfFilter, points_next: &[Vec2], ctx: &Context<'_>) {
        let p = ctx.params;
        self.items.clear();
        let (w0, w1) = s.window.omega;
        let n = p.select.omega_samples;
        self.omegas.clear();
        self.omegas
            .extend((0..n).map(|k| crate::algo::dtcbf::omega_grid(w0, w1, k, n)));
        for u in [ctx.nominal, ctx.doaa, ctx.last] {
            self.omegas.push(u.omega_radps.clamp(w0, w1));
        }
        dedup(&mut self.omegas);
        let (v0, v1) = s.v_range;
        let model = p.dtcbf.prediction;
        // With the paper's one-step model the step does not depend on ω: one
        // set of forbidden speeds serves every yaw rate (a circle's; a polygon turns).
        let euler_once = model == PredictionModel::Euler && !filter.has_polygon();
        let mut euler_built = false;
        for wi in 0..self.omegas.len() {
            let omega = self.omegas[wi];
            if !(euler_once && euler_built) {
                self.speeds.clear();
                let m = p.select.speed_samples;
                self.speeds
                    .extend((0..m).map(|k| v0 + (v1 - v0) * k as f64 / (m - 1) as f64));
                for v in [ctx.nominal.v_mps, ctx.doaa.v_mps, ctx.last.v_mps, 0.0] {
                    if v >= v0 && v <= v1 {
                        self.speeds.push(v);
                    }
                }
                if let Some(target) = s.exact_target_m {
                    for &(a, b) in filter.forbidden_speeds(omega, target, p) {
                        for v in [a, b] {
                            if v >= v0 && v <= v1 {
                                self.speeds.push(v);
                            }
                        }
                    }
                }
                dedup(&mut self.speeds);
                euler_built = true;
            }
            let unit = unit_path(omega, p.select.horizon_s);
            for &v in &self.speeds {
                let cmd = Twist::new(v, omega);
                let look = Look::along(cmd, &unit);
                let h_next_m = filter.h_next(points_next, cmd, p);
                let cheap = cheap_costs(ctx, &look);
                self.items.push(Candidate {
                    look,
                    h_next_m,
                    cheap,
                    cheap_total: cheap.total(),
                    braking: None,
                });
            }
        }
    }
}

/// Sorts `xs` and drops values within [`SAME`] of the one before.
fn dedup(xs: &mut Vec<f64>) {
    xs.sort_unstable_by(f64::total_cmp);
    xs.dedup_by(|a, b| (*a - *b).abs() <= SAME);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algo::dtcbf::InputBox;

    fn ctx(p: &Params) -> Context<'_> {
        Context {
            params: p,
            nominal: Twist::new(0.15, 0.0),
            doaa: Twist::new(0.15, -0.05),
            last: Twist::new(0.15, 0.0),
            last_change: Twist::ZERO,
            target: None,
            slide_rad: None,
            side: None,
            guide: 1.0,
            doaa_both_sides: false,
            movers_near: false,
        }
    }

    #[test]
    fn the_fastest_speed_the_condition_allows_is_a_candidate() {
        // A point 0.45 m dead ahead: h = 0.45 − 0.378 = 0.072; margin target
        // 0.8·(0.072 − 0.03) + 0.03 = 0.0636: the centre may come to 0.4416 m,
        // so v ≤ (0.45 − 0.4416)/0.1 = 0.084 m/s (Euler, Δt = 0.1 s).
        let p = Params::default();
        let bx = InputBox::from_params(&p);
        let pts = [Vec2::new(0.45, 0.0)];
        let mut f = DtcbfFilter::new();
        let h = f.prepare(&pts, &pts, &p, &bx);
        assert!((h - 0.072).abs() < 1e-12);
        let target = crate::algo::dtcbf::margin_target(h, 0.2, 0.03);
        let window = Window::new(
            Twist::new(0.1, 0.0),
            0.1,
            &crate::algo::select::window::Limits::driving(&p),
            &bx,
        );
        let s = Sampling {
            window,
            v_range: (window.v.0.max(0.0), window.v.1.min(0.15)),
            exact_target_m: Some(target),
        };
        let mut c = Candidates::with_capacity(&p);
        c.sample(&s, &mut f, &pts, &ctx(&p));
        let fastest = c
            .items
            .iter()
            .filter(|c| c.h_next_m >= target - 1e-9)
            .map(|c| c.look.cmd.v_mps)
            .fold(f64::NEG_INFINITY, f64::max);
        assert!((fastest - 0.084).abs() < 1e-7, "{fastest}");
        // Every candidate lies in the window and the allowed range.
        for k in &c.items {
            assert!(window.contains(k.look.cmd) && k.look.cmd.v_mps <= 0.15 + 1e-12, "{k:?}");
        }
        // 15 grid yaw rates; the nominal's and the last's (0) are on it, the DOAA's is not.
        let omegas: std::collections::BTreeSet<u64> =
            c.items.iter().map(|k| k.look.cmd.omega_radps.to_bits()).collect();
        assert_eq!(omegas.len(), 16);
    }
}
