//! How uncertain the wheel odometry is: a per-wheel noise model propagated
//! through the differential-drive kinematics (docs/CAN.md, "Odometry
//! covariance").
//!
//! Model (per wheel i ∈ {l, r}, independent between wheels and between
//! integration steps, zero mean):
//! * the distance the wheel rolled in a step, s_i (m), is measured with an
//!   error of variance `k_i · |s_i|` (k_i in m²/m: variance per metre
//!   rolled; the classic model of Chong & Kleeman / Siegwart, where slip,
//!   uneven floor and radius error grow with the distance);
//! * the wheel speed ω_i (rad/s at the wheel) is measured with a standard
//!   deviation σ_i (rad/s), whatever the speed.
//!
//! Pose (x, y, θ): with Δs = (s_l + s_r)/2, Δθ = (s_r − s_l)/L and the
//! mid-step heading φ = θ + Δθ/2, each step maps the covariance P to
//! `F_p P F_pᵀ + F_s diag(k_l|s_l|, k_r|s_r|) F_sᵀ` with
//!
//! ```text
//! F_p = | 1 0 −Δs·sin φ |     F_s = | cos φ/2 + Δs·sin φ/(2L)   cos φ/2 − Δs·sin φ/(2L) |
//!       | 0 1  Δs·cos φ |           | sin φ/2 − Δs·cos φ/(2L)   sin φ/2 + Δs·cos φ/(2L) |
//!       | 0 0  1        |           | −1/L                      1/L                     |
//! ```
//!
//! (the first-order Jacobians of the midpoint step; the pose itself is
//! integrated as an exact arc, which differs from the midpoint step by
//! O(Δs·Δθ²), far below the noise for 10–20 ms steps). The start pose is
//! the odometry frame's origin: its covariance is zero.
//!
//! Twist (v, ω) with v = r(ω_l + ω_r)/2 and ω = r(ω_r − ω_l)/L:
//! `var v = r²(σ_l² + σ_r²)/4`, `var ω = r²(σ_l² + σ_r²)/L²`,
//! `cov(v, ω) = r²(σ_r² − σ_l²)/(2L)`.

use serde::Serialize;

/// The noise of each wheel's measurement (the `odometry:` configuration).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WheelNoise {
    /// Variance of the left wheel's rolled distance per metre rolled (m²/m).
    pub left_travel_variance_m2_per_m: f64,
    /// The same for the right wheel (m²/m).
    pub right_travel_variance_m2_per_m: f64,
    /// Standard deviation of the left wheel's measured speed, at the wheel (rad/s).
    pub left_speed_sigma_radps: f64,
    /// The same for the right wheel (rad/s).
    pub right_speed_sigma_radps: f64,
}

/// Covariance of (x, y, θ) in m², m·rad, rad²; symmetric, row-major.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct PoseCovariance(pub [[f64; 3]; 3]);

/// Covariance of (v, ω) in (m/s)², m·rad/s², (rad/s)²; symmetric, row-major.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct TwistCovariance(pub [[f64; 2]; 2]);

impl PoseCovariance {
    /// One integration step from heading `theta_rad` (before the step) with
    /// wheel travels `sl_m`, `sr_m` (m, signed forward) on a track of
    /// `wheel_separation_m`.
    pub fn step(&mut self, theta_rad: f64, sl_m: f64, sr_m: f64, wheel_separation_m: f64, noise: &WheelNoise) {
        let l = wheel_separation_m;
        let ds = 0.5 * (sl_m + sr_m);
        let dth = (sr_m - sl_m) / l;
        let phi = theta_rad + 0.5 * dth;
        let (s, c) = phi.sin_cos();
        let fp = [[1.0, 0.0, -ds * s], [0.0, 1.0, ds * c], [0.0, 0.0, 1.0]];
        let h = ds / (2.0 * l);
        let fs = [
            [0.5 * c + h * s, 0.5 * c - h * s],
            [0.5 * s - h * c, 0.5 * s + h * c],
            [-1.0 / l, 1.0 / l],
        ];
        let q = [
            noise.left_travel_variance_m2_per_m * sl_m.abs(),
            noise.right_travel_variance_m2_per_m * sr_m.abs(),
        ];
        let p = self.0;
        let mut out = [[0.0; 3]; 3];
        for (i, row) in out.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                let mut acc = 0.0;
                for a in 0..3 {
                    for b in 0..3 {
                        acc += fp[i][a] * p[a][b] * fp[j][b];
                    }
                }
                for (k, qk) in q.iter().enumerate() {
                    acc += fs[i][k] * qk * fs[j][k];
                }
                *v = acc;
            }
        }
        // Exactly symmetric whatever the rounding.
        for (i, j) in [(1, 0), (2, 0), (2, 1)] {
            let m = 0.5 * (out[i][j] + out[j][i]);
            out[i][j] = m;
            out[j][i] = m;
        }
        self.0 = out;
    }
}

impl TwistCovariance {
    /// From the speed noise, for wheels of `wheel_radius_m` on a track of `wheel_separation_m`.
    pub fn of(noise: &WheelNoise, wheel_radius_m: f64, wheel_separation_m: f64) -> Self {
        let (r, l) = (wheel_radius_m, wheel_separation_m);
        let (vl, vr) = (
            noise.left_speed_sigma_radps.powi(2),
            noise.right_speed_sigma_radps.powi(2),
        );
        let vv = r * r * (vl + vr) / 4.0;
        let ww = r * r * (vl + vr) / (l * l);
        let vw = r * r * (vr - vl) / (2.0 * l);
        Self([[vv, vw], [vw, ww]])
    }
}

/// The variance given to what planar wheel odometry does not measure (z,
/// roll, pitch; the lateral, vertical and roll/pitch rates): so large that
/// a filter fusing it learns nothing from it (m², rad², (m/s)², (rad/s)²).
pub const UNMEASURED_VARIANCE: f64 = 1e6;

/// Row-major 6×6 covariance of (x, y, z, roll, pitch, yaw), ROS's
/// `geometry_msgs/PoseWithCovariance` layout: the model's (x, y, yaw) block,
/// [`UNMEASURED_VARIANCE`] on the z, roll and pitch diagonal, zero elsewhere.
pub fn ros_pose_covariance(p: &PoseCovariance) -> [f64; 36] {
    let mut c = [0.0; 36];
    // Model index → ROS index: x → 0, y → 1, θ → 5 (rotation about z).
    let at = [0usize, 1, 5];
    for (i, &ri) in at.iter().enumerate() {
        for (j, &rj) in at.iter().enumerate() {
            c[ri * 6 + rj] = p.0[i][j];
        }
    }
    for k in [2usize, 3, 4] {
        c[k * 6 + k] = UNMEASURED_VARIANCE;
    }
    c
}

/// Row-major 6×6 covariance of (vx, vy, vz, ωx, ωy, ωz),
/// `geometry_msgs/TwistWithCovariance`: the model's (v, ω) block at (0, 5),
/// [`UNMEASURED_VARIANCE`] on the other diagonal entries.
pub fn ros_twist_covariance(t: &TwistCovariance) -> [f64; 36] {
    let mut c = [0.0; 36];
    let at = [0usize, 5];
    for (i, &ri) in at.iter().enumerate() {
        for (j, &rj) in at.iter().enumerate() {
            c[ri * 6 + rj] = t.0[i][j];
        }
    }
    for k in [1usize, 2, 3, 4] {
        c[k * 6 + k] = UNMEASURED_VARIANCE;
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ros_layout_by_index() {
        let p = PoseCovariance([[1.0, 2.0, 3.0], [2.0, 4.0, 5.0], [3.0, 5.0, 6.0]]);
        let c = ros_pose_covariance(&p);
        // (x, x) 0, (x, y) 1, (x, yaw) 5, (y, y) 7, (y, yaw) 11, (yaw, x) 30, (yaw, yaw) 35.
        assert_eq!(
            [c[0], c[1], c[5], c[6], c[7], c[11], c[30], c[31], c[35]],
            [1.0, 2.0, 3.0, 2.0, 4.0, 5.0, 3.0, 5.0, 6.0]
        );
        assert_eq!([c[14], c[21], c[28]], [UNMEASURED_VARIANCE; 3]);
        assert_eq!(c.iter().filter(|v| **v != 0.0).count(), 12);
        let t = ros_twist_covariance(&TwistCovariance([[7.0, 8.0], [8.0, 9.0]]));
        assert_eq!([t[0], t[5], t[30], t[35]], [7.0, 8.0, 8.0, 9.0]);
        assert_eq!([t[7], t[14], t[21], t[28]], [UNMEASURED_VARIANCE; 4]);
        assert_eq!(t.iter().filter(|v| **v != 0.0).count(), 8);
    }

    const L: f64 = 0.16;

    fn noise(k: f64, sigma: f64) -> WheelNoise {
        WheelNoise {
            left_travel_variance_m2_per_m: k,
            right_travel_variance_m2_per_m: k,
            left_speed_sigma_radps: sigma,
            right_speed_sigma_radps: sigma,
        }
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-12 * b.abs().max(1e-9)
    }

    /// Straight ahead, N steps of s on both wheels, k per wheel, θ = 0. By
    /// hand (the recurrences of the step with Δθ = 0):
    /// σ_x² = k·D/2, σ_θ² = 2k·D/L², σ_yθ = k·s²·N²/L²,
    /// σ_y² = (k·s³/L²)·[(N−1)N(2N−1)/3 + N(N−1) + N/2], with D = N·s.
    #[test]
    fn straight_line_by_hand() {
        let (k, s, n) = (1e-3, 0.01, 100usize);
        let nn = n as f64;
        let mut p = PoseCovariance::default();
        for _ in 0..n {
            p.step(0.0, s, s, L, &noise(k, 0.0));
        }
        let d = nn * s;
        let m = p.0;
        assert!(close(m[0][0], k * d / 2.0), "{m:?}");
        assert!(close(m[2][2], 2.0 * k * d / (L * L)), "{m:?}");
        assert!(close(m[1][2], k * s * s * nn * nn / (L * L)), "{m:?}");
        let yy = k * s.powi(3) / (L * L) * ((nn - 1.0) * nn * (2.0 * nn - 1.0) / 3.0 + nn * (nn - 1.0) + nn / 2.0);
        assert!(close(m[1][1], yy), "{} vs {yy}", m[1][1]);
        // 0.0260410 m² for 1 m: the lateral error grows with D³ through the heading error.
        assert!((m[1][1] - 0.026041015625).abs() < 1e-12);
        assert!(m[0][1] == 0.0 && m[0][2] == 0.0);
    }

    /// A quarter turn in place in one step: Δs = 0, φ = π/4, each wheel
    /// rolls s = πL/4: σ_x² = σ_y² = σ_xy = k·s/4 (cos² φ = sin φ·cos φ = ½),
    /// σ_θ² = 2k·s/L².
    #[test]
    fn turn_in_place_by_hand() {
        let k = 2e-3;
        let s = std::f64::consts::PI * L / 4.0;
        let mut p = PoseCovariance::default();
        p.step(0.0, -s, s, L, &noise(k, 0.0));
        let m = p.0;
        for v in [m[0][0], m[1][1], m[0][1], m[1][0]] {
            assert!(close(v, k * s / 4.0), "{m:?}");
        }
        assert!(close(m[2][2], 2.0 * k * s / (L * L)));
        assert!(m[0][2].abs() < 1e-18 && m[1][2].abs() < 1e-18);
    }

    /// Per-wheel noise: a noisier right wheel correlates v and ω positively.
    #[test]
    fn twist_by_hand() {
        let n = WheelNoise {
            left_speed_sigma_radps: 0.1,
            right_speed_sigma_radps: 0.2,
            ..noise(0.0, 0.0)
        };
        let r = 0.033;
        let t = TwistCovariance::of(&n, r, L).0;
        // 0.033² · (0.01 + 0.04) / 4 = 1.36125e-5; / 0.16² = 2.12695…e-3; 0.033² · 0.03 / 0.32.
        assert!(close(t[0][0], 1.36125e-5));
        assert!(close(t[1][1], r * r * 0.05 / (L * L)));
        assert!(close(t[0][1], r * r * 0.03 / 0.32) && t[0][1] == t[1][0] && t[0][1] > 0.0);
    }

    /// The covariance stays symmetric and positive semi-definite, and the
    /// heading's variance never shrinks (each step adds k_l|s_l| + k_r|s_r| over L²).
    #[test]
    fn symmetric_psd_and_growing_on_a_wiggly_path() {
        let mut p = PoseCovariance::default();
        let n = WheelNoise {
            left_travel_variance_m2_per_m: 1e-3,
            right_travel_variance_m2_per_m: 4e-3,
            ..noise(0.0, 0.0)
        };
        let mut th = 0.0;
        let mut prev = 0.0;
        for i in 0..2000 {
            let sl = 0.004 * (1.0 + (i as f64 * 0.01).sin());
            let sr = 0.004 * (1.0 + (i as f64 * 0.013).cos());
            p.step(th, sl, sr, L, &n);
            th += (sr - sl) / L;
            let m = p.0;
            for (a, b) in [(0, 1), (0, 2), (1, 2)] {
                assert_eq!(m[a][b], m[b][a]);
            }
            let det2 = m[0][0] * m[1][1] - m[0][1] * m[0][1];
            let det3 = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[1][2])
                - m[0][1] * (m[0][1] * m[2][2] - m[1][2] * m[0][2])
                + m[0][2] * (m[0][1] * m[1][2] - m[1][1] * m[0][2]);
            let tr = m[0][0] + m[1][1] + m[2][2];
            assert!(
                m[0][0] >= 0.0 && det2 >= -1e-15 * tr * tr && det3 >= -1e-12 * tr.powi(3),
                "{i}: {m:?}"
            );
            assert!(m[2][2] > prev, "{i}");
            prev = m[2][2];
        }
    }
}
