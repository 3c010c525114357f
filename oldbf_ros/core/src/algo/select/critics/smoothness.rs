//! Little change from the command last sent: the window already bounds the
//! change by the base's limits; within it, a smaller change is preferred,
//! so the command does not swing from one edge of the window to the other
//! (ALGORITHM.md §5c). The change in v over a·Δt and in ω over α·Δt (the
//! window's half-widths at the control period), squared: 1 at the edge.

use super::{sq, Context};
use crate::algo::geometry::Twist;

/// The cost of `cmd` (about 0..2).
pub fn cost(ctx: &Context<'_>, cmd: Twist) -> f64 {
    let c = &ctx.params.control;
    let dt = c.dt_s();
    sq(cmd.v_mps, ctx.last.v_mps, c.accel_mps2 * dt)
        + sq(cmd.omega_radps, ctx.last.omega_radps, c.angular_accel_radps2 * dt)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algo::params::Params;

    #[test]
    fn the_window_edge_costs_one() {
        let p = Params::default(); // a·Δt = 0.05 m/s, α·Δt = 0.1 rad/s
        let ctx = Context {
            params: &p,
            nominal: Twist::ZERO,
            doaa: Twist::ZERO,
            last: Twist::new(0.1, 0.1),
            last_change: Twist::ZERO,
            target: None,
            slide_rad: None,
            side: None,
            guide: 1.0,
            doaa_both_sides: false,
            movers_near: false,
        };
        assert_eq!(cost(&ctx, Twist::new(0.1, 0.1)), 0.0);
        assert!((cost(&ctx, Twist::new(0.15, 0.1)) - 1.0).abs() < 1e-12);
        assert!((cost(&ctx, Twist::new(0.1, 0.05)) - 0.25).abs() < 1e-12);
    }
}
