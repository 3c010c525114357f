//! Command limits: curvature-keeping saturation and acceleration limits.
//!
//! Every limit here scales both wheels (or both twist components) by one
//! common factor instead of clipping one of them: clipping one wheel changes
//! the ratio ω/v, i.e. the path's curvature, so a robot told to follow an arc
//! next to a wall would cut towards it. Scaling slows the robot down on the
//! commanded path.
//!
//! Order, applied once per transmitted setpoint: clamp the twist to v_max /
//! ω_max, convert to wheel speeds, scale them into ±max_wheel_speed, then
//! move from the previous setpoint towards that target no faster than the
//! acceleration limit (speed magnitude growing) or the deceleration limit
//! (shrinking towards zero). Non-finite inputs never get here (the bridge
//! rejects them); the functions still map them to zero as a last defence.

use crate::kinematics::{Twist, WheelSpeeds};

/// Scales `t` so that |v| ≤ `v_max_mps` and |ω| ≤ `omega_max_radps`, keeping
/// ω/v. Returns the twist and whether it was scaled. Non-finite → zero, scaled.
pub fn clamp_twist(t: Twist, v_max_mps: f64, omega_max_radps: f64) -> (Twist, bool) {
    if !t.is_finite() {
        return (Twist::ZERO, true);
    }
    let mut k: f64 = 1.0;
    if t.linear_mps.abs() > v_max_mps {
        k = k.min(v_max_mps / t.linear_mps.abs());
    }
    if t.angular_radps.abs() > omega_max_radps {
        k = k.min(omega_max_radps / t.angular_radps.abs());
    }
    if k >= 1.0 {
        return (t, false);
    }
    // The final clamp only removes a rounding ulp of a product like 1e308 × (0.2 / 1e308).
    let out = Twist {
        linear_mps: (t.linear_mps * k).clamp(-v_max_mps, v_max_mps),
        angular_radps: (t.angular_radps * k).clamp(-omega_max_radps, omega_max_radps),
    };
    (out, true)
}

/// Scales both wheels so that neither exceeds `max_radps`, keeping their
/// ratio. Returns the speeds and whether they were scaled. Non-finite → zero.
pub fn saturate_wheels(w: WheelSpeeds, max_radps: f64) -> (WheelSpeeds, bool) {
    if !w.is_finite() {
        return (WheelSpeeds::ZERO, true);
    }
    let m = w.max_abs();
    if m <= max_radps {
        return (w, false);
    }
    let s = w.scaled(max_radps / m);
    (
        WheelSpeeds {
            left_radps: s.left_radps.clamp(-max_radps, max_radps),
            right_radps: s.right_radps.clamp(-max_radps, max_radps),
        },
        true,
    )
}

/// The largest change of one wheel's speed in `dt_s` going from `current`
/// towards `target`: deceleration applies while |speed| shrinks towards zero,
/// acceleration while it grows (after a zero crossing, too).
pub fn max_change(current: f64, target: f64, accel_radps2: f64, decel_radps2: f64, dt_s: f64) -> f64 {
    let towards_zero = current != 0.0 && (target - current).signum() == -current.signum();
    if !towards_zero {
        return accel_radps2 * dt_s;
    }
    let crosses = target.signum() == -current.signum() && target != 0.0;
    let decel_step = decel_radps2 * dt_s;
    if !crosses || decel_step <= current.abs() {
        return decel_step;
    }
    // Decelerate to zero, then accelerate the other way for the remaining time.
    let t_zero = current.abs() / decel_radps2;
    current.abs() + accel_radps2 * (dt_s - t_zero)
}

/// Moves wheel speeds towards a target under acceleration and deceleration
/// limits, with one common scale on both wheels' changes (from standstill
/// the ramp stays on the target's curvature).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RampLimiter {
    current: WheelSpeeds,
}

impl RampLimiter {
    /// Starting at standstill.
    pub fn new() -> Self {
        Self::default()
    }

    /// The last output.
    pub fn current(&self) -> WheelSpeeds {
        self.current
    }

    /// Forget the ramp: the wheels were commanded to stop at once (a stop
    /// reason), so the next ramp starts from zero.
    pub fn reset_to_zero(&mut self) {
        self.current = WheelSpeeds::ZERO;
    }

    /// One limited step of `dt_s` towards `target`; returns the new setpoint.
    pub fn step(&mut self, target: WheelSpeeds, dt_s: f64, accel_radps2: f64, decel_radps2: f64) -> WheelSpeeds {
        let target = if target.is_finite() { target } else { WheelSpeeds::ZERO };
        let c = self.current;
        let dl = target.left_radps - c.left_radps;
        let dr = target.right_radps - c.right_radps;
        let al = max_change(c.left_radps, target.left_radps, accel_radps2, decel_radps2, dt_s);
        let ar = max_change(c.right_radps, target.right_radps, accel_radps2, decel_radps2, dt_s);
        let mut k: f64 = 1.0;
        if dl.abs() > al {
            k = k.min(al / dl.abs());
        }
        if dr.abs() > ar {
            k = k.min(ar / dr.abs());
        }
        self.current = if k >= 1.0 {
            target
        } else {
            WheelSpeeds {
                left_radps: c.left_radps + k * dl,
                right_radps: c.right_radps + k * dr,
            }
        };
        self.current
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ws(l: f64, r: f64) -> WheelSpeeds {
        WheelSpeeds {
            left_radps: l,
            right_radps: r,
        }
    }

    #[test]
    fn twist_clamp_keeps_curvature() {
        // v = 1.0 with v_max 0.5 → factor 0.5 on both: (0.5, 0.2), ω/v stays 0.4.
        let (t, c) = clamp_twist(Twist::new(1.0, 0.4), 0.5, 2.0);
        assert!(c);
        assert_eq!((t.linear_mps, t.angular_radps), (0.5, 0.2));
        // ω binds: (0.1, 4.0) with ω_max 1 → factor 0.25: (0.025, 1.0).
        let (t, _) = clamp_twist(Twist::new(0.1, 4.0), 0.5, 1.0);
        assert!((t.linear_mps - 0.025).abs() < 1e-15 && t.angular_radps == 1.0);
        // Within limits: untouched.
        assert_eq!(
            clamp_twist(Twist::new(-0.3, 0.9), 0.5, 1.0),
            (Twist::new(-0.3, 0.9), false)
        );
        // Huge and non-finite.
        let (t, _) = clamp_twist(Twist::new(1e308, -1e308), 0.5, 1.0);
        assert!(t.linear_mps <= 0.5 && t.angular_radps >= -1.0 && t.linear_mps > 0.0);
        assert_eq!(clamp_twist(Twist::new(f64::NAN, 0.0), 0.5, 1.0), (Twist::ZERO, true));
        assert_eq!(clamp_twist(Twist::new(0.0, f64::INFINITY), 0.5, 1.0).0, Twist::ZERO);
    }

    #[test]
    fn wheel_saturation_scales_both_never_clips_one() {
        // (30, 15) with max 20 → both × 2/3: (20, 10); ratio 2 kept.
        let (w, s) = saturate_wheels(ws(30.0, 15.0), 20.0);
        assert!(s);
        assert!((w.left_radps - 20.0).abs() < 1e-12 && (w.right_radps - 10.0).abs() < 1e-12);
        // Clipping only the left wheel would have given (20, 15): a different arc.
        assert_ne!(w, ws(20.0, 15.0));
        let (w, s) = saturate_wheels(ws(-5.0, 40.0), 20.0);
        assert!(s && w.right_radps == 20.0 && (w.left_radps + 2.5).abs() < 1e-12);
        assert_eq!(saturate_wheels(ws(3.0, -4.0), 20.0), (ws(3.0, -4.0), false));
        assert_eq!(saturate_wheels(ws(f64::NAN, 1.0), 20.0), (WheelSpeeds::ZERO, true));
    }

    #[test]
    fn max_change_by_hand() {
        // Speeding up: accel × dt = 10 × 0.02.
        assert!((max_change(0.0, 5.0, 10.0, 40.0, 0.02) - 0.2).abs() < 1e-15);
        assert!((max_change(-1.0, -5.0, 10.0, 40.0, 0.02) - 0.2).abs() < 1e-15);
        // Slowing down: decel × dt = 40 × 0.02.
        assert!((max_change(5.0, 0.0, 10.0, 40.0, 0.02) - 0.8).abs() < 1e-15);
        assert!((max_change(5.0, 1.0, 10.0, 40.0, 0.02) - 0.8).abs() < 1e-15);
        // Crossing zero from 0.4: 0.01 s to stop at 40, then 0.01 s at 10 → 0.4 + 0.1.
        assert!((max_change(0.4, -3.0, 10.0, 40.0, 0.02) - 0.5).abs() < 1e-15);
        // Crossing impossible within dt: only decel.
        assert!((max_change(2.0, -3.0, 10.0, 40.0, 0.02) - 0.8).abs() < 1e-15);
    }

    #[test]
    fn ramp_from_standstill_keeps_the_target_ratio() {
        let mut r = RampLimiter::new();
        // Target (10, 5), accel 50 rad/s² at 50 Hz: 1 rad/s per step on the faster wheel.
        let a = r.step(ws(10.0, 5.0), 0.02, 50.0, 100.0);
        assert!(
            (a.left_radps - 1.0).abs() < 1e-12 && (a.right_radps - 0.5).abs() < 1e-12,
            "{a:?}"
        );
        for _ in 0..8 {
            r.step(ws(10.0, 5.0), 0.02, 50.0, 100.0);
        }
        assert!((r.current().left_radps - 9.0).abs() < 1e-9);
        assert_eq!(r.step(ws(10.0, 5.0), 0.02, 50.0, 100.0), ws(10.0, 5.0));
        assert_eq!(
            r.step(ws(10.0, 5.0), 0.02, 50.0, 100.0),
            ws(10.0, 5.0),
            "holds at target"
        );
        // Braking uses the (larger) deceleration: 2 rad/s per step.
        let b = r.step(WheelSpeeds::ZERO, 0.02, 50.0, 100.0);
        assert!(
            (b.left_radps - 8.0).abs() < 1e-12 && (b.right_radps - 4.0).abs() < 1e-12,
            "{b:?}"
        );
        r.reset_to_zero();
        assert_eq!(r.current(), WheelSpeeds::ZERO);
    }

    #[test]
    fn ramp_never_outputs_non_finite() {
        let mut r = RampLimiter::new();
        assert_eq!(r.step(ws(f64::NAN, 1.0), 0.02, 50.0, 100.0), WheelSpeeds::ZERO);
        assert!(r.step(ws(f64::INFINITY, 1.0), 0.02, 50.0, 100.0).is_finite());
    }
}
