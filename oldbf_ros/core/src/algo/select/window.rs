//! The dynamic window (ALGORITHM.md §5c): the commands the base can reach
//! from the command last *sent* within the time since, at its limits.
//!
//! A speed moving away from zero grows at most `control.accel_mps2`; one
//! moving towards zero falls at most `control.decel_mps2`, the braking
//! check's deceleration (§5b); a speed that crosses zero brakes to rest at
//! the deceleration and then accelerates the other way for the rest of the
//! time. So braking towards rest at the braking check's deceleration is
//! always in the window: the window never excludes the stop the braking
//! check counts on. The yaw rate changes at most
//! `control.angular_accel_radps2` either way. While a tracked mover
//! threatens, the acceleration and yaw acceleration are the base's own,
//! `passive.evasion_accel_mps2` and `passive.evasion_angular_accel_radps2`
//! ([`Limits::evading`]): ordinary driving is gentler than the base can be,
//! evasion may use all of it. The window is then cut to the
//! input box; a window that lies wholly outside the box (the box shrank: a
//! reverse speed no longer allowed once the rear is unseen) keeps the
//! reachable value nearest the box, so it is never empty.

use crate::algo::dtcbf::InputBox;
use crate::algo::geometry::Twist;
use crate::algo::params::Params;

/// Rounding slack on the window's bounds (m/s, rad/s).
pub const WINDOW_TOL: f64 = 1e-9;

/// The interval of values reachable from `last` within `dt_s` when the
/// magnitude may grow at `up` and shrink at `down` (per second).
pub fn reachable(last: f64, dt_s: f64, up: f64, down: f64) -> (f64, f64) {
    let dt = dt_s.max(0.0);
    let towards_zero = |x: f64| {
        // Slowing from |x| for dt: rest after |x|/down, then the other way at `up`.
        let t_rest = x.abs() / down;
        if dt <= t_rest {
            x - x.signum() * down * dt
        } else {
            -x.signum() * up * (dt - t_rest)
        }
    };
    if last > 0.0 {
        (towards_zero(last), last + up * dt)
    } else if last < 0.0 {
        (last - up * dt, towards_zero(last))
    } else {
        (-up * dt, up * dt)
    }
}

/// The rates the window opens at (per second).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// |v| grows at most this fast (m/s²).
    pub accel_mps2: f64,
    /// |v| falls at most this fast (m/s²): the braking check's deceleration.
    pub decel_mps2: f64,
    /// ω changes at most this fast (rad/s²).
    pub angular_accel_radps2: f64,
}

impl Default for Limits {
    /// Those of the default parameters.
    fn default() -> Self {
        Self::driving(&Params::default())
    }
}

impl Limits {
    /// Ordinary driving: `control.accel_mps2`, `control.decel_mps2`,
    /// `control.angular_accel_radps2`.
    pub fn driving(p: &Params) -> Self {
        let c = &p.control;
        Self {
            accel_mps2: c.accel_mps2,
            decel_mps2: c.decel_mps2,
            angular_accel_radps2: c.angular_accel_radps2,
        }
    }

    /// Evading a tracked mover: the base's own acceleration and yaw
    /// acceleration; the deceleration stays the braking check's.
    pub fn evading(p: &Params) -> Self {
        Self {
            accel_mps2: p.passive.evasion_accel_mps2,
            angular_accel_radps2: p.passive.evasion_angular_accel_radps2,
            ..Self::driving(p)
        }
    }
}

/// The window of one tick: reachable speeds and yaw rates, inside the box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Window {
    /// Least and greatest speed (m/s).
    pub v: (f64, f64),
    /// Least and greatest yaw rate (rad/s).
    pub omega: (f64, f64),
}

impl Window {
    /// The window round `last` (the command sent `dt_s` ago) at the limits
    /// `c`, cut to `bx`.
    pub fn new(last: Twist, dt_s: f64, c: &Limits, bx: &InputBox) -> Self {
        let v = reachable(last.v_mps, dt_s, c.accel_mps2, c.decel_mps2);
        let a = c.angular_accel_radps2 * dt_s.max(0.0);
        let omega = (last.omega_radps - a, last.omega_radps + a);
        Self {
            v: cut(v, (bx.v_lo, bx.v_hi)),
            omega: cut(omega, (-bx.omega_max, bx.omega_max)),
        }
    }

    /// Whether `u` lies in the window (to rounding).
    pub fn contains(&self, u: Twist) -> bool {
        let inside = |x: f64, (lo, hi): (f64, f64)| x >= lo - WINDOW_TOL && x <= hi + WINDOW_TOL;
        inside(u.v_mps, self.v) && inside(u.omega_radps, self.omega)
    }

    /// The command of the window nearest `u`, component by component.
    pub fn clamp(&self, u: Twist) -> Twist {
        Twist::new(
            u.v_mps.clamp(self.v.0, self.v.1),
            u.omega_radps.clamp(self.omega.0, self.omega.1),
        )
    }
}

/// `(lo, hi)` cut to `bounds`; if they do not meet, the point of `(lo, hi)`
/// nearest `bounds`, itself clamped into `bounds` when the bounds are
/// reachable only in part.
fn cut((lo, hi): (f64, f64), (blo, bhi): (f64, f64)) -> (f64, f64) {
    let (a, b) = (lo.max(blo), hi.min(bhi));
    if a <= b {
        (a, b)
    } else if hi < blo {
        (hi, hi)
    } else {
        (lo, lo)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algo::Params;

    fn close(a: (f64, f64), b: (f64, f64)) -> bool {
        (a.0 - b.0).abs() < 1e-12 && (a.1 - b.1).abs() < 1e-12
    }

    #[test]
    fn speeds_grow_at_the_acceleration_and_fall_at_the_deceleration() {
        // 0.5 m/s² up, 1.0 m/s² down, 0.1 s.
        assert!(close(reachable(0.2, 0.1, 0.5, 1.0), (0.1, 0.25)));
        assert!(close(reachable(-0.1, 0.1, 0.5, 1.0), (-0.15, 0.0)));
        assert!(close(reachable(0.0, 0.1, 0.5, 1.0), (-0.05, 0.05)));
        // 0.04 m/s brakes to rest in 0.04 s, then 0.06 s the other way at 0.5 m/s²: −0.03.
        assert!(close(reachable(0.04, 0.1, 0.5, 1.0), (-0.03, 0.09)));
        // No time, no change.
        assert!(close(reachable(0.3, 0.0, 0.5, 1.0), (0.3, 0.3)));
    }

    #[test]
    fn evasion_opens_the_window_to_the_bases_own_acceleration_but_brakes_as_ever() {
        // Driving: +0.5 m/s² and ±1.0 rad/s² for 0.1 s; evading: +2.5 m/s² and ±3.2 rad/s²
        // (the burger's own); both brake at 1.0 m/s².
        let p = Params::default();
        let bx = InputBox::from_params(&p);
        let last = Twist::new(0.1, 0.0);
        let drive = Window::new(last, 0.1, &Limits::driving(&p), &bx);
        let evade = Window::new(last, 0.1, &Limits::evading(&p), &bx);
        assert!(
            close(drive.v, (0.0, 0.15)) && close(drive.omega, (-0.1, 0.1)),
            "{drive:?}"
        );
        // 0.1 + 0.25 is cut to v_max 0.22; 3.2 × 0.1 = 0.32 is cut to ω_max 0.3.
        assert!(
            close(evade.v, (0.0, 0.22)) && close(evade.omega, (-0.3, 0.3)),
            "{evade:?}"
        );
        // From rest: 0.25 m/s either way, cut to the box (reverse at most 0.15).
        let evade = Window::new(Twist::ZERO, 0.1, &Limits::evading(&p), &bx);
        assert!(close(evade.v, (-0.15, 0.22)), "{evade:?}");
        // Braking is the braking check's 1.0 m/s² in both: from 0.2, 0.1 at the least.
        let evade = Window::new(Twist::new(0.2, 0.0), 0.1, &Limits::evading(&p), &bx);
        assert!((evade.v.0 - 0.1).abs() < 1e-12, "{evade:?}");
    }

    #[test]
    fn the_window_is_cut_to_the_box_and_never_empty() {
        let p = Params::default(); // accel 0.5, decel 1.0, angular 1.0; box v [−0.15, 0.22], ω ±0.3
        let bx = InputBox::from_params(&p);
        let w = Window::new(Twist::new(0.2, 0.25), 0.1, &Limits::driving(&p), &bx);
        assert!(close(w.v, (0.1, 0.22)));
        assert!(close(w.omega, (0.15, 0.3)));
        assert!(w.contains(Twist::new(0.1, 0.3)) && !w.contains(Twist::new(0.09, 0.2)));
        // Reversing at −0.1 when the rear goes unseen (box from 0): braking to −0.0 is the
        // nearest the window gets, 0 is reachable in 0.1 s at 1 m/s².
        let forward_only = InputBox { v_lo: 0.0, ..bx };
        let w = Window::new(Twist::new(-0.1, 0.0), 0.1, &Limits::driving(&p), &forward_only);
        assert!(close(w.v, (0.0, 0.0)), "{w:?}");
        // Faster reverse than can be stopped in one step: the window keeps the braking value.
        let w = Window::new(Twist::new(-0.15, 0.0), 0.1, &Limits::driving(&p), &forward_only);
        assert!((w.v.0 - -0.05).abs() < 1e-12 && w.v.0 == w.v.1, "{w:?}");
        assert_eq!(w.clamp(Twist::new(0.2, 1.0)), Twist::new(w.v.0, 0.1));
    }
}
