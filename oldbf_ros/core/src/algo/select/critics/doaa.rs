//! The paper's steering law as the guide (ALGORITHM.md §4, §5c): closeness
//! to the DOAA's command, ω = ω_nom + k (B_r − B_l) (away from the nearer
//! side), or the both-sides turn at ±ω_0 with its reduced speed. When the
//! filter has to change the upstream command, this is what says which way:
//! the robot turns away from what is near, as the paper's robot does. Same
//! scale as the nominal critic: each component over its full range, squared;
//! the speed only when faster than the law's (it only ever slows: the
//! both-sides turn near the front); the yaw rate in proportion to the
//! candidate's speed up to `doaa.full_gain_speed_mps` (as the law scales its
//! term: turning in place changes no clearance), except in the both-sides
//! turn, which is meant for turning in place.

use super::{sq, Context};
use crate::algo::geometry::Twist;

/// The cost of `cmd` (about 0..2).
pub fn cost(ctx: &Context<'_>, cmd: Twist) -> f64 {
    let c = &ctx.params.control;
    // The law only ever slows (the both-sides turn near the front): faster than
    // its speed costs, slower does not (the nominal critic says how much slower).
    let speed = sq(cmd.v_mps.max(ctx.doaa.v_mps), ctx.doaa.v_mps, c.v_max_mps);
    // Its steering away from the nearer side matters as the robot moves: turning in
    // place changes no clearance of a circular robot. Its both-sides turn is meant
    // for turning in place, and with people near the heading at rest is where the
    // robot goes next: those count whatever the speed.
    let moving = if ctx.doaa_both_sides || ctx.movers_near {
        1.0
    } else {
        (cmd.v_mps.abs() / ctx.params.doaa.full_gain_speed_mps).min(1.0)
    };
    speed + moving * sq(cmd.omega_radps, ctx.doaa.omega_radps, c.omega_max_radps)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algo::params::Params;

    #[test]
    fn turning_off_the_law_and_going_faster_cost_but_slowing_does_not() {
        let p = Params::default(); // v_max 0.22, ω_max 0.3
        let ctx = Context {
            params: &p,
            nominal: Twist::new(0.22, 0.0),
            doaa: Twist::new(0.11, -0.3),
            last: Twist::ZERO,
            last_change: Twist::ZERO,
            target: None,
            slide_rad: None,
            side: None,
            guide: 1.0,
            doaa_both_sides: false,
            movers_near: false,
        };
        assert_eq!(cost(&ctx, Twist::new(0.11, -0.3)), 0.0);
        assert_eq!(cost(&ctx, Twist::new(0.0, -0.3)), 0.0);
        assert!((cost(&ctx, Twist::new(0.22, -0.3)) - 0.25).abs() < 1e-12);
        assert!((cost(&ctx, Twist::new(0.11, 0.0)) - 1.0).abs() < 1e-12);
        // At half the full-gain speed (0.1 m/s) the yaw rate counts half; at rest not at all...
        assert!((cost(&ctx, Twist::new(0.05, 0.0)) - 0.5).abs() < 1e-12);
        assert_eq!(cost(&ctx, Twist::new(0.0, 0.3)), 0.0);
        // ...but the both-sides turn counts whatever the speed.
        let both = Context {
            doaa_both_sides: true,
            ..ctx
        };
        assert!((cost(&both, Twist::new(0.0, 0.0)) - 1.0).abs() < 1e-12);
    }
}
