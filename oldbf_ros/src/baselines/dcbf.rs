//! The standard discrete-time CBF-QP safety filter (ALGORITHM.md §8), the
//! paper's Fig. 9 comparison.
//!
//! The unicycle's centre moves only along its heading, so a barrier on the
//! centre sees v but never ω. As is standard, the filter controls the point
//! `l = lookahead_m` ahead of the centre instead; in the robot frame at step k
//! it is p = (l, 0) and, one Euler step later,
//!
//! ```text
//! p(k+1) = p + Δt · (v, l ω)
//! ```
//!
//! which is linear in u = (v, ω). For each obstacle point o_j (the nearest
//! point of every `sector_deg` sector round the robot) the barrier is
//! h_j = ‖p − o_j‖ − R with R = r + d_safe + l: the robot's disc (radius r
//! about the centre) lies inside the disc of radius r + l about p, so h_j ≥ 0
//! keeps the centre at least r + d_safe from o_j, at the price of l of
//! conservatism. With o′_j the point one step later (tracked moving obstacles
//! advance by v_o Δt, as in the OLDBF filter's prediction), d′_j = ‖p − o′_j‖
//! and n′_j = (p − o′_j)/d′_j, the condition h_j(k+1) ≥ (1 − γ) h_j(k) is
//! linearised as
//!
//! ```text
//! d′_j + Δt n′_j · (v, l ω) − R ≥ (1 − γ) h_j − s
//! ```
//!
//! The linearisation under-estimates the convex distance, so a command that
//! satisfies it satisfies the exact condition for the Euler step. The QP:
//!
//! ```text
//! min (v − v_nom)² + w (ω − ω_nom)² + ρ s
//! s.t. the constraints above, the input box, s ≥ 0
//! ```
//!
//! The single slack s (documented departure from a hard QP) keeps the problem
//! feasible when the robot is already inside the unsafe set or boxed in; with
//! the linear (exact) penalty ρ it is zero whenever the hard QP is feasible
//! and its multipliers are below ρ. A solver failure gives a stop.

use crate::algo::dtcbf::InputBox;
use crate::algo::geometry::{Twist, Vec2};
use crate::algo::params::Params;
use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettings, DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus,
};

/// What one DCBF step decided.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DcbfOutcome {
    /// The command to send (m/s, rad/s); a stop when the solver failed.
    pub cmd: Twist,
    /// Number of barrier constraints (sectors with a point).
    pub constraints: usize,
    /// The slack's value (m); > 0 when the hard QP was infeasible.
    pub slack_m: f64,
    /// Whether the solver returned a solution.
    pub solved: bool,
}

/// The DCBF-QP filter, with its scratch buffers.
#[derive(Debug, Clone)]
pub struct DcbfFilter {
    /// Per sector: the index of its nearest point and that point's distance (m).
    nearest: Vec<Option<(usize, f64)>>,
    settings: DefaultSettings<f64>,
}

impl Default for DcbfFilter {
    fn default() -> Self {
        Self::new()
    }
}

impl DcbfFilter {
    pub fn new() -> Self {
        let settings = DefaultSettingsBuilder::default()
            .verbose(false)
            .build()
            .expect("static clarabel settings are valid");
        Self {
            nearest: Vec::new(),
            settings,
        }
    }

    /// Filters `nominal` against `points` (robot frame, now) and
    /// `points_next` (the same points one step later; index-aligned).
    pub fn filter(&mut self, points: &[Vec2], points_next: &[Vec2], nominal: Twist, p: &Params) -> DcbfOutcome {
        let bx = InputBox::from_params(p);
        let nominal = bx.clamp(nominal);
        let q = &p.baselines.dcbf;
        let (l, dt, gamma) = (q.lookahead_m, p.control.dt_s(), p.dtcbf.gamma);
        let big_r = p.robot_radius_m() + p.barrier.d_safe_m + l;
        let ahead = Vec2::new(l, 0.0);

        // The nearest point of each sector.
        let sectors = (360.0 / q.sector_deg).ceil() as usize;
        self.nearest.clear();
        self.nearest.resize(sectors, None);
        for (j, o) in points.iter().enumerate() {
            let a = o.y.atan2(o.x) + std::f64::consts::PI; // [0, 2π]
            let s = ((a / std::f64::consts::TAU * sectors as f64) as usize).min(sectors - 1);
            let d = (ahead - o).norm();
            if self.nearest[s].is_none_or(|(_, best)| d < best) {
                self.nearest[s] = Some((j, d));
            }
        }

        // Rows of A x ≤ b over x = (v, ω, s), built column by column (CSC).
        let rows: Vec<(f64, f64, f64)> = self
            .nearest
            .iter()
            .flatten()
            .filter_map(|&(j, d)| {
                let h = d - big_r;
                let rel = ahead - points_next[j];
                let d_next = rel.norm();
                if d_next.is_nan() || d_next <= 1e-9 || !h.is_finite() {
                    return None;
                }
                let n = rel / d_next;
                // −Δt n·(v, l ω) − s ≤ d′ − R − (1 − γ) h
                Some((-dt * n.x, -dt * l * n.y, d_next - big_r - (1.0 - gamma) * h))
            })
            .collect();
        let m = rows.len();
        let (a_mat, b) = constraint_matrix(&rows, &bx);
        let w = q.omega_weight;
        let p_mat = CscMatrix::new(3, 3, vec![0, 1, 2, 2], vec![0, 1], vec![2.0, 2.0 * w]);
        let lin = [-2.0 * nominal.v_mps, -2.0 * w * nominal.omega_radps, q.slack_penalty];
        let cones = [NonnegativeConeT(b.len())];
        let stop = DcbfOutcome {
            cmd: Twist::ZERO,
            constraints: m,
            slack_m: f64::NAN,
            solved: false,
        };
        let Ok(mut solver) = DefaultSolver::new(&p_mat, &lin, &a_mat, &b, &cones, self.settings.clone()) else {
            return stop;
        };
        solver.solve();
        let x = &solver.solution.x;
        let ok = matches!(
            solver.solution.status,
            SolverStatus::Solved | SolverStatus::AlmostSolved
        ) && x.iter().all(|v| v.is_finite());
        if !ok {
            return stop;
        }
        DcbfOutcome {
            cmd: bx.clamp(Twist::new(x[0], x[1])),
            constraints: m,
            slack_m: x[2].max(0.0),
            solved: true,
        }
    }
}

/// A (CSC, 3 columns) and b for the barrier rows `(a_v, a_ω, b)` (each with
/// −1 on the slack), then the input box and s ≥ 0.
fn constraint_matrix(rows: &[(f64, f64, f64)], bx: &InputBox) -> (CscMatrix<f64>, Vec<f64>) {
    let m = rows.len();
    // Row order: barrier rows 0..m, v ≤ v_hi, −v ≤ −v_lo, ω ≤ ω_max, −ω ≤ ω_max, −s ≤ 0.
    let total = m + 5;
    let mut colptr = Vec::with_capacity(4);
    let mut rowval = Vec::with_capacity(3 * m + 5);
    let mut nzval = Vec::with_capacity(3 * m + 5);
    colptr.push(0);
    // Column v.
    for (i, r) in rows.iter().enumerate() {
        rowval.push(i);
        nzval.push(r.0);
    }
    rowval.extend([m, m + 1]);
    nzval.extend([1.0, -1.0]);
    colptr.push(rowval.len());
    // Column ω.
    for (i, r) in rows.iter().enumerate() {
        rowval.push(i);
        nzval.push(r.1);
    }
    rowval.extend([m + 2, m + 3]);
    nzval.extend([1.0, -1.0]);
    colptr.push(rowval.len());
    // Column s.
    for i in 0..m {
        rowval.push(i);
        nzval.push(-1.0);
    }
    rowval.push(m + 4);
    nzval.push(-1.0);
    colptr.push(rowval.len());

    let mut b: Vec<f64> = rows.iter().map(|r| r.2).collect();
    b.extend([bx.v_hi, -bx.v_lo, bx.omega_max, bx.omega_max, 0.0]);
    (CscMatrix::new(total, 3, colptr, rowval, nzval), b)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> Params {
        Params::default()
    }

    #[test]
    fn free_space_passes_the_nominal_command() {
        let mut f = DcbfFilter::new();
        let out = f.filter(&[], &[], Twist::new(0.15, 0.1), &params());
        assert!(out.solved);
        assert_eq!(out.constraints, 0);
        assert!((out.cmd.v_mps - 0.15).abs() < 1e-6, "{out:?}");
        assert!((out.cmd.omega_radps - 0.1).abs() < 1e-6, "{out:?}");
        assert!(out.slack_m < 1e-6);
    }

    #[test]
    fn a_wall_ahead_caps_v_at_the_hand_derived_bound() {
        // One point x m dead ahead, ω_nom = 0: n = (−1, 0), so the ω column is 0.
        // d = x − l, R = 0.178 + 0.2 + 0.1 = 0.478 m (defaults), h = d − R.
        // Static point: d′ = d, so Δt v ≤ d − R − (1 − γ) h = γ h ⇒ v ≤ γ h / Δt:
        // x = 0.6: h = 0.022, v ≤ 0.044; x = 0.65: v ≤ 0.144; x = 0.7: 0.244 → box 0.22.
        let p = params();
        let r = p.robot_radius_m() + p.barrier.d_safe_m + p.baselines.dcbf.lookahead_m;
        let gamma = p.dtcbf.gamma;
        let dt = p.control.dt_s();
        let mut f = DcbfFilter::new();
        for x in [0.6, 0.65, 0.7] {
            let pt = [Vec2::new(x, 0.0)];
            let out = f.filter(&pt, &pt, Twist::new(0.22, 0.0), &p);
            let h = x - p.baselines.dcbf.lookahead_m - r;
            let bound = (gamma * h / dt).clamp(0.0, 0.22);
            assert!(out.solved, "{out:?}");
            // (An interior-point solution: within 1e-4 of an active bound.)
            assert!(
                (out.cmd.v_mps - bound).abs() < 1e-4,
                "x = {x}: v = {} vs {bound}",
                out.cmd.v_mps
            );
            assert!(out.slack_m < 1e-6, "{out:?}");
        }
    }

    #[test]
    fn inside_the_unsafe_set_the_slack_opens_and_the_robot_does_not_advance() {
        let p = params();
        let pt = [Vec2::new(0.4, 0.0)];
        let out = DcbfFilter::new().filter(&pt, &pt, Twist::new(0.22, 0.0), &p);
        assert!(out.solved, "{out:?}");
        assert!(out.slack_m > 0.0, "{out:?}");
        assert!(out.cmd.v_mps < 1e-6, "{out:?}");
    }

    #[test]
    fn an_obstacle_to_the_side_of_the_lookahead_point_bends_omega() {
        // A point ahead and slightly left, close enough to bind: turning right
        // (ω < 0) moves the look-ahead point away from it, so the QP uses ω.
        let p = params();
        let pt = [Vec2::new(0.62, 0.1)];
        let out = DcbfFilter::new().filter(&pt, &pt, Twist::new(0.22, 0.0), &p);
        assert!(out.solved && out.slack_m < 1e-6, "{out:?}");
        assert!(out.cmd.omega_radps < -1e-3, "{out:?}");
        assert!(out.cmd.v_mps < 0.22, "{out:?}");
    }

    #[test]
    fn an_approaching_obstacle_lowers_v_further_than_a_static_one() {
        let p = params();
        let now = [Vec2::new(0.8, 0.0)];
        let next = [Vec2::new(0.77, 0.0)]; // closing at 0.3 m/s over Δt = 0.1 s
        let mut f = DcbfFilter::new();
        let v_static = f.filter(&now, &now, Twist::new(0.22, 0.0), &p).cmd.v_mps;
        let v_moving = f.filter(&now, &next, Twist::new(0.22, 0.0), &p).cmd.v_mps;
        // Hand-derived: v ≤ (d′ − R − (1 − γ) h)/Δt with d = 0.7, d′ = 0.67, R = 0.478:
        // h = 0.222, (0.67 − 0.478 − 0.8·0.222)/0.1 = 0.144 m/s.
        assert!((v_moving - 0.144).abs() < 1e-4, "{v_moving}");
        assert!(v_static > v_moving + 0.05, "{v_static} vs {v_moving}");
    }
}
