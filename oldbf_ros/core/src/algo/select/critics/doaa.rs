//! The paper's steering law as the guide (ALGORITHM.md §4, §5c): closeness
//! to the DOAA's command, ω = ω_nom + k (B_r − B_l) (away from the nearer
//! side), or the both-sides turn at ±ω_0 with its reduced speed. When the
//! filter has to change the upstream command, this is what says which way:
//! the robot turns away from what is near, as the paper's robot does. Same
//! scale as the nominal critic: each component over its full range, squared.

use super::{sq, Context};
use crate::algo::geometry::Twist;

/// The cost of `cmd` (about 0..2).
pub fn cost(ctx: &Context<'_>, cmd: Twist) -> f64 {
    let c = &ctx.params.control;
    sq(cmd.v_mps, ctx.doaa.v_mps, c.v_max_mps) + sq(cmd.omega_radps, ctx.doaa.omega_radps, c.omega_max_radps)
}
