//! Barrier values B = B_d + B_v (ALGORITHM.md §3, paper III.B).
//!
//! With d_act = d_safe + Γ^(2/σ) and proximity Δd = max(0, d_act − d):
//!   B_d = Γ² / (Γ² − Δd^σ)   (= 1 for d ≥ d_act, → ∞ as d → d_safe),
//!   B_v = Γ ζ |v| / (1 + |v|^β).
//! For d ≤ d_safe B_d is +inf; it is stored saturated at `barrier_max` and the
//! side is flagged as violated.
//!
//! Paper note: B_v → ζΓ as |v| → ∞ only for β = 1. For β > 1 (default 2) B_v
//! peaks at |v| = (β − 1)^(−1/β) (1 m/s for β = 2) and decays beyond; below
//! that, in the operating range of these robots, it does grow with speed.

use super::params::BarrierParams;

/// B_d for one side: (value saturated at barrier_max, whether d ≤ d_safe).
pub fn distance_barrier(d_m: f64, p: &BarrierParams) -> (f64, bool) {
    if d_m.is_nan() {
        return (p.barrier_max, true);
    }
    let g2 = p.big_gamma * p.big_gamma;
    let proximity = (p.d_act_m() - d_m).max(0.0);
    let denom = g2 - proximity.powf(p.sigma);
    if denom <= 0.0 || d_m <= p.d_safe_m {
        return (p.barrier_max, true);
    }
    ((g2 / denom).min(p.barrier_max), false)
}

/// B_v for the current linear speed v (m/s).
pub fn velocity_barrier(v_mps: f64, p: &BarrierParams) -> f64 {
    let s = v_mps.abs();
    if !s.is_finite() {
        return 0.0;
    }
    p.big_gamma * p.zeta * s / (1.0 + s.powf(p.beta))
}

/// Left/right barrier values for one step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Barriers {
    /// B_l = B_d,l + B_v.
    pub b_left: f64,
    /// B_r = B_d,r + B_v.
    pub b_right: f64,
    /// B_v, shared by both sides (so it cancels in B_r − B_l).
    pub b_velocity: f64,
    /// Whether d_l ≤ d_safe (B_d,l saturated).
    pub left_violated: bool,
    /// Whether d_r ≤ d_safe (B_d,r saturated).
    pub right_violated: bool,
}

/// B_l and B_r from the hemisphere clearances and the current speed.
pub fn compute_barriers(d_left_m: f64, d_right_m: f64, v_mps: f64, p: &BarrierParams) -> Barriers {
    let (bl, lv) = distance_barrier(d_left_m, p);
    let (br, rv) = distance_barrier(d_right_m, p);
    let bv = velocity_barrier(v_mps, p);
    Barriers {
        b_left: (bl + bv).min(p.barrier_max),
        b_right: (br + bv).min(p.barrier_max),
        b_velocity: bv,
        left_violated: lv,
        right_violated: rv,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p() -> BarrierParams {
        BarrierParams::default() // d_safe 0.2, Γ 1, σ 2, ζ 0.5, β 2 → d_act 1.2
    }

    #[test]
    fn distance_barrier_hand_values() {
        let p = p();
        // At and beyond d_act: exactly 1.
        assert_eq!(distance_barrier(1.2, &p), (1.0, false));
        assert_eq!(distance_barrier(50.0, &p), (1.0, false));
        assert_eq!(distance_barrier(f64::INFINITY, &p), (1.0, false));
        // Halfway into the band, σ = 2: Δd = 0.5, B = 1 / (1 − 0.25) = 4/3.
        let (b, v) = distance_barrier(0.2 + 0.5, &p);
        assert!((b - 4.0 / 3.0).abs() < 1e-12 && !v);
        // Δd = 0.9: B = 1 / (1 − 0.81) = 5.263157...
        assert!((distance_barrier(0.3, &p).0 - 1.0 / 0.19).abs() < 1e-9);
        // At and inside d_safe: saturated and flagged.
        assert_eq!(distance_barrier(0.2, &p), (1000.0, true));
        assert_eq!(distance_barrier(-0.1, &p), (1000.0, true));
        assert_eq!(distance_barrier(f64::NAN, &p), (1000.0, true));
    }

    #[test]
    fn distance_barrier_with_other_shape_parameters() {
        // Γ = 2, σ = 4: band Γ^(2/σ) = 2^(0.5) = 1.41421 m; d_act = 0.2 + 1.41421.
        let mut p = p();
        p.big_gamma = 2.0;
        p.sigma = 4.0;
        let d_act = 0.2 + 2f64.sqrt();
        assert!((p.d_act_m() - d_act).abs() < 1e-12);
        // Δd = 1: B = 4 / (4 − 1) = 4/3.
        assert!((distance_barrier(d_act - 1.0, &p).0 - 4.0 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn velocity_barrier_hand_values() {
        let p = p();
        assert_eq!(velocity_barrier(0.0, &p), 0.0);
        // v = 1: 1·0.5·1 / (1 + 1) = 0.25; v = -1 the same.
        assert!((velocity_barrier(1.0, &p) - 0.25).abs() < 1e-12);
        assert!((velocity_barrier(-1.0, &p) - 0.25).abs() < 1e-12);
        // v = 0.15: 0.075 / 1.0225.
        assert!((velocity_barrier(0.15, &p) - 0.075 / 1.0225).abs() < 1e-12);
        // β = 1: tends to ζΓ = 0.5.
        let mut p1 = p.clone();
        p1.beta = 1.0;
        assert!((velocity_barrier(1e9, &p1) - 0.5).abs() < 1e-6);
        assert_eq!(velocity_barrier(f64::NAN, &p), 0.0);
    }

    #[test]
    fn combined_barriers_share_the_speed_term() {
        let b = compute_barriers(0.7, 2.0, 1.0, &p());
        assert!((b.b_left - (4.0 / 3.0 + 0.25)).abs() < 1e-12);
        assert!((b.b_right - 1.25).abs() < 1e-12);
        assert!(!b.left_violated && !b.right_violated);
    }
}
