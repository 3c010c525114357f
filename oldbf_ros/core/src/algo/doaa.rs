//! DOAA steering law (ALGORITHM.md §4, paper III.C eq. 5 and Algorithm 1).
//!
//! Paper departure: eq. 5 as printed turns *towards* the nearer obstacle. The
//! text says "when B_l > B_r, a negative control input triggers a right turn",
//! which is what we implement, in one continuous expression:
//!     ω = sat_ωmax( ω_nom + k (B_r − B_l) ).
//! With no obstacle B_r = B_l and ω_nom passes unchanged; with ω_nom = 0 it is
//! exactly the paper's law. B_v is added to both sides, so it cancels here.
//!
//! Departure: the avoidance term is scaled by the nominal forward speed,
//! s = clamp(v_nom / v_full, 0, 1) with v_full = `full_gain_speed_mps`
//! (0.1 m/s, below the paper's 0.15 m/s, where s = 1 and the law is the
//! paper's). Turning in place changes no clearance of a circular robot, so at
//! a standstill the term would only fight the nominal turn towards the goal
//! and chatter at ±ω_max whenever the nearest point crosses a sector edge.
//!
//! Both sides (the paper's ω_0 case): when d_l, d_r and the front clearance
//! are all below d_act and the front obstacle is the nearest one
//! (d_front ≤ min(d_l, d_r) + tolerance), the robot turns at ±ω_0 towards the
//! side with more clearance, slowing down (to 0 below d_safe + margin), and
//! keeps turning that way until the front clearance exceeds d_act + release
//! (hysteresis). A corridor (both sides near, front clear) is not this case:
//! the differential law centres the robot.
//!
//! The turn serves forward motion: it does not stay latched while the nominal
//! command has no forward speed (e.g. the tracking law turning in place
//! towards a goal behind the robot), which a circular robot can always do
//! safely; otherwise the two turns would alternate. It starts only above
//! `both_sides_min_speed_mps` (hysteresis): a tracking law whose speed hovers
//! round zero would otherwise switch it on and off every few steps, turning
//! the robot left and right on the spot for as long as that lasts.
//!
//! Passing something dead ahead on one side (§4b) is the selector's side
//! critic, not a latch here.
//!
//! Departure from ALGORITHM.md §4: the "front is the nearest" condition is
//! ours. In a corridor narrower than 2 (r + d_act) (2.8 m at the defaults)
//! both sides are always inside d_act, so without it anything within d_act
//! ahead, such as a cabinet ahead-left, would turn the corridor into a dead end
//! and the robot round.

use super::barrier::Barriers;
use super::clearance::Clearances;
use super::geometry::Twist;
use super::params::Params;
use serde::Serialize;
use std::fmt;

/// What the avoidance logic is doing this step; published with every command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DoaaState {
    /// No obstacle inside d_act on either side: nominal command.
    Forward,
    /// Differential steering away from the nearer side.
    Avoid,
    /// Obstacles left, right and ahead: fixed turn at ω_0.
    BothSides,
    /// Zero command: rejected or missing scan, bad input, or no safe command exists.
    Stop,
    /// Inside the unsafe set (h < 0): only commands that increase h are allowed.
    Escape,
    /// A mover closes on a robot that cannot go forward: the admissible
    /// command with the latest predicted contact (§5b).
    Evade,
    /// Progress stalled: following a free direction round the obstacle (§4b).
    Follow,
}

impl DoaaState {
    /// The state's name as logged and published (`forward`, `avoid`, …).
    pub fn as_str(&self) -> &'static str {
        match self {
            Self::Forward => "forward",
            Self::Avoid => "avoid",
            Self::BothSides => "both_sides",
            Self::Stop => "stop",
            Self::Escape => "escape",
            Self::Evade => "evade",
            Self::Follow => "follow",
        }
    }

    /// Stable small integer for messages (forward 0 … escape 4, evade 5, follow 6).
    pub fn code(&self) -> u8 {
        *self as u8
    }
}

impl fmt::Display for DoaaState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Direction of the latched both-sides turn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TurnDirection {
    /// Counter-clockwise (ω > 0).
    Left,
    /// Clockwise (ω < 0).
    Right,
}

impl TurnDirection {
    /// +1 for left, −1 for right: the sign of ω that turns this way.
    pub fn sign(self) -> f64 {
        match self {
            Self::Left => 1.0,
            Self::Right => -1.0,
        }
    }
}

/// Clearances closer than this (m) are treated as equal when picking a turn side.
const TIE_M: f64 = 0.01;

/// Whether the side clearances tie (within [`TIE_M`], or both +inf): only
/// then does the steering look at the crowding sums, so only then must they
/// be filled ([`super::clearance::side_crowding`]).
pub fn sides_tie(c: &Clearances) -> bool {
    // inf − inf is NaN: no clearance difference to go by, a tie.
    let gap = (c.d_left_m - c.d_right_m).abs();
    gap.is_nan() || gap <= TIE_M
}

/// The DOAA state machine: the latched both-sides turn.
#[derive(Debug, Default, Clone)]
pub struct Doaa {
    both_sides: Option<TurnDirection>,
    /// The side a way round being followed goes (§4c): the both-sides turn goes
    /// that way, whatever the clearances say.
    route_side: Option<TurnDirection>,
}

impl Doaa {
    /// No latched turn.
    pub fn new() -> Self {
        Self::default()
    }

    /// Forgets the latched turn (after a stop, a reset, or a filter toggle).
    pub fn reset(&mut self) {
        *self = Self::default();
    }

    /// While a way round is followed, the side its waypoint lies on (None: no
    /// way round, the law's own choice). The both-sides turn picks its side by
    /// the clearances near the robot; the route knows which side the way
    /// through is on, and a turn latched the other way would fight it.
    pub fn set_route_side(&mut self, side: Option<TurnDirection>) {
        self.route_side = side;
    }

    /// The turn latched while both sides are blocked, if any.
    pub fn latched_turn(&self) -> Option<TurnDirection> {
        self.both_sides
    }

    /// The DOAA command for this step: the paper's law, or its both-sides
    /// turn (the selector's critics, and the paper's DTCBF filter, then make
    /// it safe).
    pub fn command(&mut self, nominal: Twist, c: &Clearances, b: &Barriers, p: &Params) -> (Twist, DoaaState) {
        let d_act = p.barrier.d_act_m();
        let w_max = p.control.omega_max_radps;

        let front_is_nearest = c.d_front_m <= c.d_left_m.min(c.d_right_m) + p.doaa.front_nearest_tolerance_m;
        // The turn exists to unblock forward motion: a nominal that only turns in place
        // (safe for a circular robot) neither starts nor keeps it.
        if nominal.v_mps <= 0.0 {
            self.both_sides = None;
        }
        let speed_scale = (nominal.v_mps / p.doaa.full_gain_speed_mps).clamp(0.0, 1.0);
        let avoid = p.doaa.gain_k_radps * speed_scale * (b.b_right - b.b_left);
        if self.both_sides.is_none()
            && nominal.v_mps > p.doaa.both_sides_min_speed_mps
            && c.d_left_m < d_act
            && c.d_right_m < d_act
            && c.d_front_m < d_act
            && front_is_nearest
        {
            self.both_sides = Some(pick_turn(c, nominal));
        }
        if let (Some(_), Some(side)) = (self.both_sides, self.route_side) {
            self.both_sides = Some(side);
        }
        if self.both_sides.is_some() && c.d_front_m >= d_act + p.doaa.both_sides_release_m {
            self.both_sides = None;
        }
        if let Some(dir) = self.both_sides {
            let stop_at = p.barrier.d_safe_m + p.doaa.front_stop_margin_m;
            let band = d_act - stop_at;
            let scale = if band > 0.0 {
                ((c.d_front_m - stop_at) / band).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let v = nominal.v_mps.max(0.0) * scale;
            return (
                Twist::new(v, dir.sign() * p.doaa.omega_0_radps.min(w_max)),
                DoaaState::BothSides,
            );
        }
        let omega = (nominal.omega_radps + avoid).clamp(-w_max, w_max);
        let state = if c.d_left_m < d_act || c.d_right_m < d_act {
            DoaaState::Avoid
        } else {
            DoaaState::Forward
        };
        (Twist::new(nominal.v_mps, omega), state)
    }
}

/// The side with more clearance; ties go to the less crowded side, then to
/// the way the nominal command already turns, then left.
fn pick_turn(c: &Clearances, nominal: Twist) -> TurnDirection {
    let left_better = if !sides_tie(c) {
        c.d_left_m > c.d_right_m
    } else if c.crowding_left != c.crowding_right {
        c.crowding_left < c.crowding_right
    } else {
        nominal.omega_radps >= 0.0
    };
    if left_better {
        TurnDirection::Left
    } else {
        TurnDirection::Right
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algo::barrier::compute_barriers;

    fn clear(d_left: f64, d_right: f64, d_front: f64) -> Clearances {
        Clearances {
            d_left_m: d_left,
            d_right_m: d_right,
            d_front_m: d_front,
            d_min_m: d_left.min(d_right).min(d_front),
            ..Clearances::OPEN
        }
    }

    fn run(doaa: &mut Doaa, nominal: Twist, c: Clearances) -> (Twist, DoaaState) {
        let p = Params::default();
        let b = compute_barriers(c.d_left_m, c.d_right_m, nominal.v_mps, &p.barrier);
        doaa.command(nominal, &c, &b, &p)
    }

    #[test]
    fn obstacle_on_the_left_turns_right() {
        // d_l = 0.7: B_l = 4/3 (+B_v), B_r = 1 (+B_v); ω = 0.5 (1 − 4/3) = −1/6 rad/s.
        let (cmd, state) = run(&mut Doaa::new(), Twist::new(0.15, 0.0), clear(0.7, f64::INFINITY, 2.0));
        assert!((cmd.omega_radps + 0.5 / 3.0).abs() < 1e-12, "{cmd:?}");
        assert_eq!(cmd.v_mps, 0.15);
        assert_eq!(state, DoaaState::Avoid);
    }

    #[test]
    fn obstacle_on_the_right_turns_left() {
        let (cmd, _) = run(&mut Doaa::new(), Twist::new(0.15, 0.0), clear(f64::INFINITY, 0.7, 2.0));
        assert!((cmd.omega_radps - 0.5 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn avoidance_term_scales_with_forward_speed() {
        // d_l = 0.7: k (B_r − B_l) = −1/6 at full gain (v ≥ 0.1 m/s).
        let c = clear(0.7, f64::INFINITY, 2.0);
        let (cmd, _) = run(&mut Doaa::new(), Twist::new(0.05, 0.0), c);
        assert!(
            (cmd.omega_radps + 0.5 / 6.0).abs() < 1e-12,
            "half speed, half gain: {cmd:?}"
        );
        // Turning in place towards a goal: the nominal turn passes unchanged.
        let (cmd, _) = run(&mut Doaa::new(), Twist::new(0.0, -0.2), c);
        assert_eq!(cmd, Twist::new(0.0, -0.2));
        let (cmd, _) = run(&mut Doaa::new(), Twist::new(0.22, 0.0), c);
        assert!((cmd.omega_radps + 0.5 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn nominal_passes_unchanged_when_clear() {
        let (cmd, state) = run(&mut Doaa::new(), Twist::new(0.2, 0.13), clear(3.0, 3.0, 3.0));
        assert_eq!(cmd, Twist::new(0.2, 0.13));
        assert_eq!(state, DoaaState::Forward);
    }

    #[test]
    fn yaw_rate_saturates() {
        // d_l = 0.3: B_l = 1/0.19 = 5.26; ω = 0.5·(1 − 5.26) = −2.13 → −0.3.
        let (cmd, _) = run(&mut Doaa::new(), Twist::new(0.15, 0.0), clear(0.3, f64::INFINITY, 2.0));
        assert_eq!(cmd.omega_radps, -0.3);
    }

    #[test]
    fn corridor_centres_without_both_sides_mode() {
        // Equal walls, front clear: no turn, not both-sides.
        let (cmd, state) = run(&mut Doaa::new(), Twist::new(0.15, 0.0), clear(0.5, 0.5, 5.0));
        assert_eq!(cmd.omega_radps, 0.0);
        assert_eq!(state, DoaaState::Avoid);
    }

    #[test]
    fn both_sides_turns_to_the_clearer_side_and_latches() {
        let mut doaa = Doaa::new();
        // Right has more clearance: turn right at ω_0 = 0.3. The front obstacle is the nearest.
        // Front 0.45: scale = (0.45 − 0.25) / (1.2 − 0.25) = 0.2105; v = 0.15·0.2105.
        let (cmd, state) = run(&mut doaa, Twist::new(0.15, 0.0), clear(0.45, 0.8, 0.45));
        assert_eq!(state, DoaaState::BothSides);
        assert_eq!(cmd.omega_radps, -0.3);
        assert!((cmd.v_mps - 0.15 * 0.2 / 0.95).abs() < 1e-12);
        // Sides swap while the front is still blocked: the turn stays latched.
        let (cmd, state) = run(&mut doaa, Twist::new(0.15, 0.0), clear(0.8, 0.4, 1.25));
        assert_eq!((state, cmd.omega_radps), (DoaaState::BothSides, -0.3));
        // Front clear beyond d_act + release (1.3): released.
        let (_, state) = run(&mut doaa, Twist::new(0.15, 0.0), clear(0.8, 0.4, 1.31));
        assert_eq!(state, DoaaState::Avoid);
        assert_eq!(doaa.latched_turn(), None);
    }

    #[test]
    fn a_followed_way_round_turns_the_both_sides_turn_its_way() {
        let mut doaa = Doaa::new();
        // Right has more clearance, but the route goes left: the turn goes left, at the
        // same reduced speed (front 0.45: v = 0.15 · 0.2 / 0.95).
        doaa.set_route_side(Some(TurnDirection::Left));
        let (cmd, state) = run(&mut doaa, Twist::new(0.15, 0.0), clear(0.45, 0.8, 0.45));
        assert_eq!((state, cmd.omega_radps), (DoaaState::BothSides, 0.3));
        assert!((cmd.v_mps - 0.15 * 0.2 / 0.95).abs() < 1e-12);
        // A turn latched right before the follow began goes left once it does.
        let mut doaa = Doaa::new();
        let (cmd, _) = run(&mut doaa, Twist::new(0.15, 0.0), clear(0.45, 0.8, 0.45));
        assert_eq!(cmd.omega_radps, -0.3);
        doaa.set_route_side(Some(TurnDirection::Left));
        let (cmd, _) = run(&mut doaa, Twist::new(0.15, 0.0), clear(0.45, 0.8, 0.45));
        assert_eq!((cmd.omega_radps, doaa.latched_turn()), (0.3, Some(TurnDirection::Left)));
        // The follow over, the latch stays as it is until the front clears.
        doaa.set_route_side(None);
        let (cmd, _) = run(&mut doaa, Twist::new(0.15, 0.0), clear(0.45, 0.8, 0.45));
        assert_eq!(cmd.omega_radps, 0.3);
        // A route side with nothing blocking both sides starts no turn.
        let mut doaa = Doaa::new();
        doaa.set_route_side(Some(TurnDirection::Left));
        let (_, state) = run(&mut doaa, Twist::new(0.15, 0.0), clear(0.5, 0.5, 5.0));
        assert_eq!((state, doaa.latched_turn()), (DoaaState::Avoid, None));
    }

    #[test]
    fn something_ahead_in_a_corridor_is_not_both_sides() {
        // Walls 0.35 m left and 0.85 m right, a cabinet corner 1.05 m ahead: d_front > min(d_l, d_r).
        let (cmd, state) = run(&mut Doaa::new(), Twist::new(0.15, 0.0), clear(0.35, 0.85, 1.05));
        assert_eq!(state, DoaaState::Avoid);
        // Differential law: B_l = 1/(1 − 0.85²) = 3.604, B_r = 1/(1 − 0.35²) = 1.140 → ω = 0.5·(1.140 − 3.604) → −0.3.
        assert_eq!(cmd.omega_radps, -0.3);
        // The same cabinet 0.3 m ahead, now the nearest thing: both-sides.
        let (_, state) = run(&mut Doaa::new(), Twist::new(0.15, 0.0), clear(0.35, 0.85, 0.3));
        assert_eq!(state, DoaaState::BothSides);
    }

    #[test]
    fn both_sides_needs_a_forward_nominal() {
        let mut doaa = Doaa::new();
        let (_, state) = run(&mut doaa, Twist::new(0.15, 0.0), clear(0.45, 0.8, 0.45));
        assert_eq!(state, DoaaState::BothSides);
        // The tracking law now turns in place: the latch is released and the turn passes.
        let (cmd, state) = run(&mut doaa, Twist::new(0.0, 0.25), clear(0.45, 0.8, 0.45));
        assert_eq!((cmd, state), (Twist::new(0.0, 0.25), DoaaState::Avoid));
        assert_eq!(doaa.latched_turn(), None);
    }

    #[test]
    fn both_sides_starts_above_a_speed_and_stays_until_the_nominal_stops() {
        // The tracking law hovering round v = 0 (both_sides_min_speed_mps = 0.02): no latch.
        let blocked = clear(0.45, 0.8, 0.45);
        let mut doaa = Doaa::new();
        let (cmd, state) = run(&mut doaa, Twist::new(0.01, -0.3), blocked);
        assert_eq!(state, DoaaState::Avoid);
        assert_eq!(cmd.omega_radps, -0.3, "the nominal's own turn passes");
        // Real forward intent starts it; a slower (but still forward) nominal keeps it.
        let (_, state) = run(&mut doaa, Twist::new(0.05, -0.3), blocked);
        assert_eq!(state, DoaaState::BothSides);
        let (cmd, state) = run(&mut doaa, Twist::new(0.01, -0.3), blocked);
        assert_eq!((state, cmd.omega_radps), (DoaaState::BothSides, -0.3));
        let (_, state) = run(&mut doaa, Twist::new(0.0, -0.3), blocked);
        assert_eq!(state, DoaaState::Avoid);
    }

    #[test]
    fn both_sides_stops_forward_motion_close_to_the_front() {
        let (cmd, _) = run(&mut Doaa::new(), Twist::new(0.15, 0.0), clear(0.4, 0.4, 0.24));
        assert_eq!(cmd.v_mps, 0.0);
        assert_eq!(cmd.omega_radps.abs(), 0.3);
    }

    #[test]
    fn tie_breaks_are_deterministic() {
        let mut c = clear(0.5, 0.5, 0.5);
        c.crowding_left = 3.0;
        c.crowding_right = 2.0;
        assert_eq!(pick_turn(&c, Twist::ZERO), TurnDirection::Right);
        c.crowding_right = 3.0;
        assert_eq!(pick_turn(&c, Twist::new(0.1, -0.1)), TurnDirection::Right);
        assert_eq!(pick_turn(&c, Twist::ZERO), TurnDirection::Left);
    }
}
