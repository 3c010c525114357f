//! Closeness to the upstream command: the filter changes a safe command as
//! little as it can (ALGORITHM.md §5c). The deviation in v and in ω, each
//! over its full range (v_max, ω_max), squared: 1 for a command a whole
//! range away. The yaw rate counts in proportion to 1 − guide: as far as the
//! steering critics count, the DOAA critic's command (which already holds the
//! nominal's yaw rate) stands for it. (A nominal that meets every constraint
//! and lies in the window is not scored at all: it is sent unchanged.)

use super::{sq, Context};
use crate::algo::geometry::Twist;

/// The cost of `cmd` (about 0..2).
pub fn cost(ctx: &Context<'_>, cmd: Twist) -> f64 {
    let c = &ctx.params.control;
    // While the steering critics count, the DOAA's command (the nominal's yaw rate
    // plus the law's avoidance term) stands for the nominal's yaw rate: counting it
    // twice would pull the robot back at what the law steers it from.
    let turn = (1.0 - ctx.guide) * sq(cmd.omega_radps, ctx.nominal.omega_radps, c.omega_max_radps);
    sq(cmd.v_mps, ctx.nominal.v_mps, c.v_max_mps) + turn
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algo::params::Params;

    #[test]
    fn a_full_range_away_costs_one_per_component() {
        let p = Params::default(); // v_max 0.22, ω_max 0.3
        let ctx = Context {
            params: &p,
            nominal: Twist::new(0.22, 0.3),
            doaa: Twist::ZERO,
            last: Twist::ZERO,
            last_change: Twist::ZERO,
            target: None,
            slide_rad: None,
            side: None,
            guide: 0.0,
            doaa_both_sides: false,
            movers_near: false,
        };
        assert_eq!(cost(&ctx, Twist::new(0.22, 0.3)), 0.0);
        assert!((cost(&ctx, Twist::new(0.0, 0.3)) - 1.0).abs() < 1e-12);
        assert!((cost(&ctx, Twist::new(0.11, 0.0)) - 1.25).abs() < 1e-12);
    }
}
