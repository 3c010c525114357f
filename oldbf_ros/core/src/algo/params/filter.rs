//! The filter: barriers, the DOAA steering law, the exact DTCBF.

use serde::{Deserialize, Serialize};

/// OLDBF barrier B = B_d + B_v (paper III.B).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BarrierParams {
    /// d_safe: clearance (beyond r) that defines the safe set h = d_min − d_safe ≥ 0 (m).
    pub d_safe_m: f64,
    /// Γ: barrier scale; the activation band is Γ^(2/σ) metres wide.
    pub big_gamma: f64,
    /// σ: exponent on the proximity Δd in B_d.
    pub sigma: f64,
    /// ζ: weight of the speed term B_v.
    pub zeta: f64,
    /// β: exponent on |v| in the denominator of B_v.
    pub beta: f64,
    /// B values are saturated here (B_d is +inf at d ≤ d_safe).
    pub barrier_max: f64,
    /// Full angle of the left/right hemisphere sector, centred ahead (deg).
    pub hemisphere_fov_deg: f64,
    /// Full angle of the front sector used by the both-sides rule (deg). The
    /// default 30° is the robot's swept width at activation range:
    /// 2·asin((r + d_safe) / (r + d_act)) = 2·asin(0.378 / 1.378) ≈ 32°, so a
    /// corridor wall beside the robot does not count as "ahead".
    pub front_fov_deg: f64,
    /// Fade angle of the side sectors (deg): a point's contribution to a side
    /// fades out over this much bearing past bearing 0 and before the
    /// hemisphere's edge, so B_l and B_r change continuously (§4b); 0 = the
    /// hard sectors of the definition.
    pub side_fade_deg: f64,
}

impl Default for BarrierParams {
    fn default() -> Self {
        Self {
            d_safe_m: 0.20,
            big_gamma: 1.0,
            sigma: 2.0,
            zeta: 0.5,
            beta: 2.0,
            barrier_max: 1000.0,
            hemisphere_fov_deg: 180.0,
            front_fov_deg: 30.0,
            side_fade_deg: 30.0,
        }
    }
}

impl BarrierParams {
    /// d_act = d_safe + Γ^(2/σ): clearance below which B_d exceeds 1 (m).
    pub fn d_act_m(&self) -> f64 {
        self.d_safe_m + self.big_gamma.powf(2.0 / self.sigma)
    }
}

/// DOAA steering law (paper III.C, sign-corrected eq. 5).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DoaaParams {
    /// k: yaw rate per unit of barrier difference, ω = sat(ω_nom + k (B_r − B_l)) (rad/s).
    pub gain_k_radps: f64,
    /// ω_0: fixed turn rate when obstacles block both sides and the front (rad/s).
    pub omega_0_radps: f64,
    /// The both-sides turn is released when the front clearance exceeds d_act by this (m).
    pub both_sides_release_m: f64,
    /// In the both-sides turn, linear speed is 0 when the front clearance is below d_safe + this (m).
    pub front_stop_margin_m: f64,
    /// The both-sides turn starts only when the nominal forward speed exceeds this
    /// (m/s); it is released when the nominal has no forward speed.
    pub both_sides_min_speed_mps: f64,
    /// The both-sides turn needs the front obstacle to be the nearest: d_front ≤ min(d_l, d_r) + this (m).
    pub front_nearest_tolerance_m: f64,
    /// The avoidance term k (B_r − B_l) has full weight at nominal forward speeds ≥ this,
    /// and falls linearly to 0 at a standstill (m/s).
    pub full_gain_speed_mps: f64,
}

impl Default for DoaaParams {
    fn default() -> Self {
        Self {
            gain_k_radps: 0.5,
            omega_0_radps: 0.3,
            both_sides_release_m: 0.1,
            front_stop_margin_m: 0.05,
            both_sides_min_speed_mps: 0.02,
            front_nearest_tolerance_m: 0.05,
            full_gain_speed_mps: 0.1,
        }
    }
}

/// How the one-step prediction z(k+1) = F(z(k), u(k)) integrates the unicycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PredictionModel {
    /// Paper eq. 6 with Δt explicit: x+ = x + Δt v cos θ, θ+ = θ + Δt ω.
    Euler,
    /// Exact zero-order-hold solution: the robot moves along an arc.
    Arc,
}

/// The discrete-time CBF filter (paper II.E, eq. 3-4).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DtcbfParams {
    /// γ in h(k+1) ≥ (1 − γ) h(k); 1 only asks h(k+1) ≥ 0, small values approach more slowly.
    pub gamma: f64,
    /// Inside the unsafe set (h < 0) a command must raise h by at least this per step (m).
    pub escape_epsilon_m: f64,
    /// δ: the filter first enforces the condition on h − δ, so sensor noise up to δ does not
    /// push the measured h of a robot resting near the boundary below 0 (m). 0 = the definition.
    pub noise_margin_m: f64,
    /// Integration of the one-step prediction.
    pub prediction: PredictionModel,
    /// Number of yaw rates tried across [−ω_max, ω_max] when ω must change too (odd).
    pub omega_candidates: usize,
    /// w in the cost (v − v_d)² + w (ω − ω_d)² for picking the closest safe command (m²/rad²).
    pub omega_weight_m2_per_rad2: f64,
}

impl Default for DtcbfParams {
    fn default() -> Self {
        Self {
            gamma: 0.2,
            escape_epsilon_m: 0.001,
            noise_margin_m: 0.03,
            prediction: PredictionModel::Euler,
            omega_candidates: 21,
            omega_weight_m2_per_rad2: 0.05,
        }
    }
}
