//! Soft preferences (ALGORITHM.md §5c): small named critics, each scoring a
//! candidate command with a cost of about 0 (what it prefers) to 1 (what it
//! likes least), weighted by `select.weights` and summed. One file each:
//!
//! * [`nominal`]: closeness to the upstream command;
//! * [`smoothness`]: little change from the command last sent;
//! * [`oscillation`]: no swinging straight back;
//! * [`doaa`]: closeness to the DOAA's command (the paper's steering law);
//! * [`progress`]: getting nearer the reference ahead or the waypoint;
//! * [`clearance`]: room to the static surroundings along the horizon;
//! * [`mover`]: time to contact with movers and the head-on line deficit;
//! * [`side`]: keeping the side chosen to pass an obstacle ahead on.
//!
//! The selector reports each critic's weighted cost for the command sent,
//! so a user can see why the robot did what it did.

use crate::algo::geometry::{Twist, Vec2};
use crate::algo::params::{CriticWeights, Params};
use serde::Serialize;

pub mod clearance;
pub mod doaa;
pub mod mover;
pub mod nominal;
pub mod oscillation;
pub mod progress;
pub mod side;
pub mod smoothness;

/// The critics, in the order of [`CriticCosts`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Critic {
    /// [`nominal`]: closeness to the upstream command.
    Nominal,
    /// [`smoothness`]: little change from the command last sent.
    Smoothness,
    /// [`oscillation`]: no swinging straight back.
    Oscillation,
    /// [`doaa`]: closeness to the DOAA's command.
    Doaa,
    /// [`progress`]: progress towards the target.
    Progress,
    /// [`clearance`]: room kept along the horizon.
    Clearance,
    /// [`mover`]: evasion of tracked movers.
    Mover,
    /// [`side`]: keeping the side chosen.
    Side,
}

/// How many critics there are.
pub const CRITICS: usize = 8;

impl Critic {
    /// Every critic, in the order of [`CriticCosts`].
    pub const ALL: [Critic; CRITICS] = [
        Critic::Nominal,
        Critic::Smoothness,
        Critic::Oscillation,
        Critic::Doaa,
        Critic::Progress,
        Critic::Clearance,
        Critic::Mover,
        Critic::Side,
    ];

    /// Its name as logged (CSV `cost_<name>` columns, `~state`).
    pub fn name(&self) -> &'static str {
        match self {
            Self::Nominal => "nominal",
            Self::Smoothness => "smoothness",
            Self::Oscillation => "oscillation",
            Self::Doaa => "doaa",
            Self::Progress => "progress",
            Self::Clearance => "clearance",
            Self::Mover => "mover",
            Self::Side => "side",
        }
    }

    /// Its weight in `w`.
    pub fn weight(&self, w: &CriticWeights) -> f64 {
        match self {
            Self::Nominal => w.nominal,
            Self::Smoothness => w.smoothness,
            Self::Oscillation => w.oscillation,
            Self::Doaa => w.doaa,
            Self::Progress => w.progress,
            Self::Clearance => w.clearance,
            Self::Mover => w.mover,
            Self::Side => w.side,
        }
    }
}

/// Each critic's weighted cost for one command, in [`Critic::ALL`]'s order.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct CriticCosts(pub [f64; CRITICS]);

impl CriticCosts {
    /// The sum: what the selector minimises.
    pub fn total(&self) -> f64 {
        self.0.iter().sum()
    }

    /// One critic's weighted cost.
    pub fn get(&self, c: Critic) -> f64 {
        self.0[c as usize]
    }

    /// Sets one critic's weighted cost.
    pub fn set(&mut self, c: Critic, cost: f64) {
        self.0[c as usize] = cost;
    }
}

/// What the critics of one step judge against (robot frame now).
#[derive(Debug, Clone, Copy)]
pub struct Context<'a> {
    /// The parameters of the step.
    pub params: &'a Params,
    /// The upstream command, inside the input box.
    pub nominal: Twist,
    /// The DOAA's command for that nominal (§4).
    pub doaa: Twist,
    /// The DOAA's command is its both-sides turn.
    pub doaa_both_sides: bool,
    /// A tracked mover threatens, or is within `select.mover_near_m`.
    pub movers_near: bool,
    /// The command last sent.
    pub last: Twist,
    /// The change it made from the one sent before it.
    pub last_change: Twist,
    /// Where progress is measured to (robot frame, m), if anywhere.
    pub target: Option<Vec2>,
    /// The heading to aim at instead of the target's bearing when the
    /// margin level closes that bearing ([`super::slide`]; robot frame, rad).
    pub slide_rad: Option<f64>,
    /// The side kept for passing an obstacle ahead (+1 left, −1 right).
    pub side: Option<f64>,
    /// How much the critics that steer (DOAA, progress, clearance, side)
    /// count, 0..1, and the nominal critic's yaw rate the rest: 1 when the
    /// upstream command is not safe as it is, rising continuously from 0 as
    /// it heads into something (§5c). At 0 the selector only approaches the
    /// upstream command.
    pub guide: f64,
}

/// Points where a candidate held from now puts the robot (robot frame, m),
/// at `select.horizon_s` × (k + 1) / [`PATH_SAMPLES`]: what the progress and
/// clearance critics look at.
pub const PATH_SAMPLES: usize = 5;

/// A candidate as the critics see it: the command, and where holding it for
/// the horizon takes the robot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Look {
    /// The command.
    pub cmd: Twist,
    /// Where holding it puts the robot at each path sample (robot frame, m).
    pub path: [Vec2; PATH_SAMPLES],
}

/// For yaw rate ω, where a command of speed 1 m/s held from rest at the
/// origin is at each path sample (the exact arc: the chord t·sinc(ωt/2)
/// along the heading ωt/2): a speed v is there v times as far.
pub fn unit_path(omega_radps: f64, horizon_s: f64) -> [Vec2; PATH_SAMPLES] {
    std::array::from_fn(|k| {
        let t = horizon_s * (k + 1) as f64 / PATH_SAMPLES as f64;
        let half = 0.5 * omega_radps * t;
        Vec2::new(half.cos(), half.sin()) * (t * crate::algo::unicycle::sinc(half))
    })
}

impl Look {
    /// `cmd` with the unit path of its yaw rate ([`unit_path`]).
    pub fn along(cmd: Twist, unit: &[Vec2; PATH_SAMPLES]) -> Self {
        Self {
            cmd,
            path: unit.map(|u| u * cmd.v_mps),
        }
    }

    /// `cmd` held for the horizon of `p`.
    pub fn of(cmd: Twist, p: &Params) -> Self {
        Self::along(cmd, &unit_path(cmd.omega_radps, p.select.horizon_s))
    }

    /// Where the horizon ends.
    pub fn end(&self) -> Vec2 {
        self.path[PATH_SAMPLES - 1]
    }
}

/// The critics that need no point of the scan (all but clearance and
/// mover), weighted.
pub fn cheap_costs(ctx: &Context<'_>, look: &Look) -> CriticCosts {
    let w = &ctx.params.select.weights;
    let cmd = look.cmd;
    let mut c = CriticCosts::default();
    c.set(Critic::Nominal, w.nominal * nominal::cost(ctx, cmd));
    c.set(Critic::Smoothness, w.smoothness * smoothness::cost(ctx, cmd));
    c.set(Critic::Oscillation, w.oscillation * oscillation::cost(ctx, cmd));
    let g = ctx.guide;
    if g > 0.0 {
        c.set(Critic::Doaa, g * w.doaa * doaa::cost(ctx, cmd));
        c.set(Critic::Progress, g * w.progress * progress::cost(ctx, look));
        c.set(Critic::Side, g * w.side * side::cost(ctx, cmd));
    }
    c
}

/// ((a − b)/scale)², 0 when the scale is not positive.
#[inline]
pub(crate) fn sq(a: f64, b: f64, scale: f64) -> f64 {
    if scale > 0.0 {
        ((a - b) / scale).powi(2)
    } else {
        0.0
    }
}
