//! Keeping the side chosen to pass something ahead on (ALGORITHM.md §4b,
//! §5c), instead of a latch: while something is within d_act ahead, a turn
//! (relative to the upstream command's) of less than half of ω_max towards
//! the side chosen costs, in proportion to how much less, up to 1 for half
//! of ω_max the other way and more beyond. So something dead ahead, which
//! the DOAA's law (equal barriers both sides) does not turn from, is passed
//! on one side, and the robot does not swing from one side to the other as
//! the nearest point crosses bearing 0; a much better way the other side (a
//! critic that outweighs this one) can still win.

use super::Context;
use crate::algo::geometry::Twist;

/// The turn towards the side, as a share of ω_max, that costs nothing.
pub const MIN_TURN_SHARE: f64 = 0.5;

/// The cost of `cmd` (0..2).
pub fn cost(ctx: &Context<'_>, cmd: Twist) -> f64 {
    let Some(side) = ctx.side else {
        return 0.0;
    };
    let w_max = ctx.params.control.omega_max_radps;
    let towards = side * (cmd.omega_radps - ctx.nominal.omega_radps);
    (MIN_TURN_SHARE * w_max - towards).max(0.0) / (2.0 * MIN_TURN_SHARE * w_max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algo::params::Params;

    #[test]
    fn turning_less_than_half_omega_max_towards_the_side_costs() {
        let p = Params::default(); // ω_max 0.3
        let mut ctx = Context {
            params: &p,
            nominal: Twist::new(0.15, 0.1),
            doaa: Twist::ZERO,
            last: Twist::ZERO,
            last_change: Twist::ZERO,
            target: None,
            slide_rad: None,
            side: Some(1.0),
            guide: 1.0,
            doaa_both_sides: false,
            movers_near: false,
        };
        // ω_nom 0.1, side left: 0.25 and more costs nothing; 0.1 (no turn) costs ½;
        // −0.05 (half ω_max the other way) costs 1.
        assert_eq!(cost(&ctx, Twist::new(0.15, 0.3)), 0.0);
        assert_eq!(cost(&ctx, Twist::new(0.15, 0.25)), 0.0);
        assert!((cost(&ctx, Twist::new(0.15, 0.1)) - 0.5).abs() < 1e-12);
        assert!((cost(&ctx, Twist::new(0.15, -0.05)) - 1.0).abs() < 1e-12);
        ctx.side = None;
        assert_eq!(cost(&ctx, Twist::new(0.15, -0.2)), 0.0);
    }
}
