//! Keeping the side chosen to pass an obstacle ahead on (ALGORITHM.md §4b,
//! §5c), instead of a latch: once the selector has steered round something
//! ahead one way, turning the other way (relative to the upstream command)
//! costs, in proportion to how far, until the front is clear again. So the
//! robot does not swing from one side of an obstacle to the other as its
//! nearest point crosses bearing 0, yet a much better way the other side
//! (a critic that outweighs this one) can still win.

use super::Context;
use crate::algo::geometry::Twist;

/// The cost of `cmd` (0..2): its turn against the side kept, relative to the
/// nominal's, over ω_max.
pub fn cost(ctx: &Context<'_>, cmd: Twist) -> f64 {
    let Some(side) = ctx.side else {
        return 0.0;
    };
    let w_max = ctx.params.control.omega_max_radps;
    (-side * (cmd.omega_radps - ctx.nominal.omega_radps)).max(0.0) / w_max
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algo::params::Params;

    #[test]
    fn only_turning_against_the_side_kept_costs() {
        let p = Params::default(); // ω_max 0.3
        let mut ctx = Context {
            params: &p,
            nominal: Twist::new(0.15, 0.1),
            doaa: Twist::ZERO,
            last: Twist::ZERO,
            last_change: Twist::ZERO,
            target: None,
            side: Some(1.0),
            guide: true,
        };
        assert_eq!(cost(&ctx, Twist::new(0.15, 0.3)), 0.0);
        assert!((cost(&ctx, Twist::new(0.15, -0.2)) - 1.0).abs() < 1e-12);
        ctx.side = None;
        assert_eq!(cost(&ctx, Twist::new(0.15, -0.2)), 0.0);
    }
}
