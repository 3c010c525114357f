//! No swinging back (ALGORITHM.md §5c): a command whose change from the
//! last one sent reverses the change the last step made, both beyond a
//! small step (0.02 m/s for v, ω_max/6 for ω: what the motion measures count
//! as a reversal), costs 1 per component. The smoothness critic prefers
//! small changes; this one stops the command swinging one way and straight
//! back, as a speed that the condition allows on one scan and not on the
//! next would otherwise make it do. A change below the step, or one step
//! later, is free: a real change of mind still happens, gently.

use super::Context;
use crate::algo::geometry::Twist;

/// A change of v beyond this (m/s) counts.
pub const V_STEP_MPS: f64 = 0.02;
/// A change of ω beyond ω_max over this counts.
pub const OMEGA_STEP_FRACTION: f64 = 1.0 / 6.0;

/// The cost of `cmd` (0, 1 or 2).
pub fn cost(ctx: &Context<'_>, cmd: Twist) -> f64 {
    let reverses = |now: f64, before: f64, step: f64| now.abs() > step && before.abs() > step && now * before < 0.0;
    let w_step = OMEGA_STEP_FRACTION * ctx.params.control.omega_max_radps;
    let dv = cmd.v_mps - ctx.last.v_mps;
    let dw = cmd.omega_radps - ctx.last.omega_radps;
    f64::from(u8::from(reverses(dv, ctx.last_change.v_mps, V_STEP_MPS)))
        + f64::from(u8::from(reverses(dw, ctx.last_change.omega_radps, w_step)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algo::params::Params;

    #[test]
    fn only_a_swing_back_beyond_the_step_costs() {
        let p = Params::default(); // ω step 0.05 rad/s
        let ctx = Context {
            params: &p,
            nominal: Twist::ZERO,
            doaa: Twist::ZERO,
            last: Twist::new(0.05, 0.1),
            last_change: Twist::new(-0.05, 0.1),
            target: None,
            slide_rad: None,
            side: None,
            guide: 1.0,
            doaa_both_sides: false,
            movers_near: false,
        };
        // Speeding up again by 0.03 after slowing by 0.05: a reversal; by 0.01: not.
        assert_eq!(cost(&ctx, Twist::new(0.08, 0.1)), 1.0);
        assert_eq!(cost(&ctx, Twist::new(0.06, 0.1)), 0.0);
        // Both components swing back.
        assert_eq!(cost(&ctx, Twist::new(0.08, 0.0)), 2.0);
        // Going on the same way is free.
        assert_eq!(cost(&ctx, Twist::new(0.0, 0.2)), 0.0);
    }
}
