//! Progress towards where the robot is going (ALGORITHM.md §4b, §5c): the
//! point ahead on the reference, or the way-round waypoint while one is
//! followed. The candidate is held for `select.horizon_s` along its arc; the
//! cost is the mean of two parts, each 0..1: how much nearer the target
//! that leaves the robot, over the most a horizon at v_max could (0 for a
//! full approach at v_max, ½ for none, 1 for backing straight away); and
//! how far the heading then is from the target's bearing, over π (so a
//! robot that cannot drive on still prefers to turn towards where it is
//! going). When the margin level closes that bearing, the heading is
//! measured against the open heading nearest it instead ([`super::super::slide`]):
//! a robot at rest turns to where it can drive on, not to face a corner
//! it may not approach. No target (an upstream `cmd_vel_in` alone): 0.

use super::{Context, Look};
use crate::algo::geometry::wrap_angle;

/// The cost of the candidate `look` (0..1).
pub fn cost(ctx: &Context<'_>, look: &Look) -> f64 {
    let Some(target) = ctx.target else {
        return 0.0;
    };
    let reach = ctx.params.control.v_max_mps * ctx.params.select.horizon_s;
    if reach <= 0.0 {
        return 0.0;
    }
    let to = target - look.end();
    let gained = target.norm() - to.norm();
    let approach = (0.5 * (1.0 - gained / reach)).clamp(0.0, 1.0);
    let heading = look.cmd.omega_radps * ctx.params.select.horizon_s;
    let misalign = match ctx.slide_rad {
        Some(open) => wrap_angle(open - heading).abs() / std::f64::consts::PI,
        None if to.norm() > 1e-9 => wrap_angle(to.y.atan2(to.x) - heading).abs() / std::f64::consts::PI,
        None => 0.0,
    };
    0.5 * (approach + misalign)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algo::geometry::{Twist, Vec2};
    use crate::algo::params::Params;

    fn cost(ctx: &Context<'_>, cmd: Twist) -> f64 {
        super::cost(ctx, &Look::of(cmd, ctx.params))
    }

    #[test]
    fn straight_at_the_target_at_full_speed_costs_nothing() {
        let p = Params::default(); // v_max 0.22, horizon 1.5 s: reach 0.33 m
        let mut ctx = Context {
            params: &p,
            nominal: Twist::ZERO,
            doaa: Twist::ZERO,
            last: Twist::ZERO,
            last_change: Twist::ZERO,
            target: Some(Vec2::new(3.0, 0.0)),
            slide_rad: None,
            side: None,
            guide: 1.0,
            doaa_both_sides: false,
            movers_near: false,
        };
        assert!(cost(&ctx, Twist::new(0.22, 0.0)).abs() < 1e-12);
        assert!((cost(&ctx, Twist::ZERO) - 0.25).abs() < 1e-12);
        // Half speed: 0.165 m of 0.33: a quarter of the first part, an eighth in all.
        assert!((cost(&ctx, Twist::new(0.11, 0.0)) - 0.125).abs() < 1e-12);
        // A target to the left: turning left beats turning right at the same speed,
        // and turning in place towards it beats standing (heading 0.45 rad nearer π/2).
        ctx.target = Some(Vec2::new(0.0, 2.0));
        assert!(cost(&ctx, Twist::new(0.15, 0.3)) < cost(&ctx, Twist::new(0.15, -0.3)));
        let turned = 0.5 * (0.5 + (std::f64::consts::FRAC_PI_2 - 0.45) / std::f64::consts::PI);
        assert!((cost(&ctx, Twist::new(0.0, 0.3)) - turned).abs() < 1e-12);
        // The same target with its bearing closed and the open heading at −π/2: the
        // heading term measures against that, so turning in place to the right wins.
        ctx.slide_rad = Some(-std::f64::consts::FRAC_PI_2);
        assert!(cost(&ctx, Twist::new(0.0, -0.3)) < cost(&ctx, Twist::new(0.0, 0.3)));
        let slid = 0.5 * (0.5 + (std::f64::consts::FRAC_PI_2 - 0.45) / std::f64::consts::PI);
        assert!((cost(&ctx, Twist::new(0.0, -0.3)) - slid).abs() < 1e-12);
        ctx.slide_rad = None;
        ctx.target = None;
        assert_eq!(cost(&ctx, Twist::new(-0.1, 0.0)), 0.0);
    }
}
