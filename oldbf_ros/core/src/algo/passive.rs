//! Passive motion safety against moving obstacles (ALGORITHM.md §5b).
//!
//! The one-step DTCBF condition of §5 cannot see that a robot which can only
//! brake and turn slowly is already doomed a few steps later, nor that a
//! mover keeps coming. The promise here (Bouraine, Fraichard & Salhi 2011,
//! "passive motion safety"): if a collision happens, the robot was not
//! driving into it. So a command is admissible only if the robot, applying
//! it for one control step and then braking to rest at
//! `control.decel_mps2` (both wheels together: the curvature is kept),
//! makes no *closing contact* on the way:
//! * with a static point: its body (radius r) reaches the point while moving
//!   towards it faster than half of `passive.closing_speed_mps`;
//! * with a tracked mover: its body reaches the mover's predicted disc (the
//!   track advanced with its estimated velocity; radius grown by
//!   `passive.mover_margin_m` + `passive.mover_growth_mps`·τ for the
//!   estimate's error and the person's unmodelled turns) while moving
//!   towards its centre that fast.
//!
//! Contact with a robot at rest, or moving away, is the mover's doing: it is
//! not excluded here (nothing the robot does could), it is minimised by
//! [`PassiveSafety::evasion_score`], the predicted time to contact of a
//! command held for `passive.evasion_horizon_s`.
//!
//! A polygon body (issue 26) is swept along the same path, turns in place
//! included: [`super::braking_polygon`].
//!
//! Paths are sampled every centimetre of travel (at most 64 samples), so
//! the check costs a few hundred distance computations per command. Static
//! points are taken at the filter's r; the DTCBF already keeps d_safe from
//! them, so for static worlds this check only bites inside the unsafe set.

use super::braking_polygon::{braking_poses, closing_speed, first_polygon_contact, local, PathPose};
use super::footprint::PaddedPolygon;
use super::geometry::{Twist, Vec2};
use super::params::Params;
use super::unicycle::sinc;

/// Where something may be unseen (held or unknown beams), the body keeps this
/// much more room while moving towards it (m): it may have come closer since.
pub const UNSEEN_MARGIN_M: f64 = 0.1;
/// Path sample spacing (m).
const SAMPLE_SPACING_M: f64 = 0.01;
/// Most samples per phase (step, braking).
const MAX_STEP_SAMPLES: usize = 16;
const MAX_BRAKE_SAMPLES: usize = 48;
/// Time between samples of an evasion path (s).
const EVASION_SAMPLE_S: f64 = 0.2;
/// Movers slower than this have no line to step out of (m/s).
const LINE_MIN_SPEED_MPS: f64 = 0.05;

/// A unicycle on a constant (v, ω) from the origin, walked in equal time
/// steps: each step is the exact arc (its chord along the mid-step heading),
/// with one sine and cosine for the whole walk instead of one per sample.
#[derive(Debug, Clone, Copy)]
struct ArcWalk {
    pos: Vec2,
    /// Unit heading.
    heading: Vec2,
    /// Rotation by ω·step, and by half of it (cos, sin).
    turn: (f64, f64),
    half: (f64, f64),
    /// Chord of one step (m, signed with v).
    chord: f64,
}

/// `v` rotated by (cos, sin).
#[inline]
fn rotate(v: Vec2, (c, s): (f64, f64)) -> Vec2 {
    Vec2::new(c * v.x - s * v.y, s * v.x + c * v.y)
}

/// `v` (robot frame now) in the frame of a body whose unit heading is `heading`.
#[inline]
fn rotate_back(v: Vec2, heading: Vec2) -> Vec2 {
    Vec2::new(heading.x * v.x + heading.y * v.y, -heading.y * v.x + heading.x * v.y)
}

/// The gap (m) between the body at `pose` (the circle of `r`, or the
/// polygon `fp`) and a mover's disc of `radius_m` centred at `c`, and
/// whether `c` is within `grown` of the body (the disc grown for the
/// prediction's uncertainty). All robot frame now.
#[inline]
fn mover_gap(fp: Option<&PaddedPolygon>, r: f64, pose: &PathPose, c: Vec2, radius_m: f64, grown: f64) -> (f64, bool) {
    match fp {
        None => {
            let dist = (c - pose.pos).norm();
            (dist - r - radius_m, dist < r + grown)
        }
        Some(fp) => {
            let sd = fp.signed_distance(local(c, pose));
            (sd - radius_m, sd < grown)
        }
    }
}

/// Whether the polygon `fp` at `pose` holds the static point `q` inside
/// it while closing on it faster than `threshold` (m/s): a closing contact.
#[inline]
fn polygon_closes_on(fp: &PaddedPolygon, pose: &PathPose, q: Vec2, threshold: f64) -> bool {
    let q_local = local(q, pose);
    fp.signed_distance(q_local) < 0.0 && closing_speed(fp, pose, q, q_local, true) > threshold
}

/// One sample of a walked path: where the body is, which way it faces
/// (unit), its velocity (m/s) and yaw rate (rad/s); robot frame now.
#[derive(Debug, Clone, Copy, Default)]
struct WalkSample {
    pos: Vec2,
    heading: Vec2,
    vel: Vec2,
    omega_radps: f64,
}

impl ArcWalk {
    fn new(cmd: Twist, step_s: f64) -> Self {
        let dth = cmd.omega_radps * step_s;
        let half = 0.5 * dth;
        Self {
            pos: Vec2::zeros(),
            heading: Vec2::new(1.0, 0.0),
            turn: (dth.cos(), dth.sin()),
            half: (half.cos(), half.sin()),
            chord: cmd.v_mps * step_s * sinc(half),
        }
    }

    fn step(&mut self) {
        self.pos += rotate(self.heading, self.half) * self.chord;
        self.heading = rotate(self.heading, self.turn);
    }
}

/// How a command evolves over an evasion horizon: from `cmd`, v and ω move
/// towards `goal` at most `rates` (m/s², rad/s²) and then stay there. A
/// command held is the profile whose goal is itself.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Profile {
    /// The command now.
    pub cmd: Twist,
    /// Where v and ω go on to.
    pub goal: Twist,
    /// The rates they change at (m/s², rad/s²).
    pub rates: (f64, f64),
}

impl Profile {
    /// `cmd` held.
    pub fn held(cmd: Twist) -> Self {
        Self {
            cmd,
            goal: cmd,
            rates: (0.0, 0.0),
        }
    }

    /// The largest |v| on the way (m/s).
    fn top_speed(&self) -> f64 {
        self.cmd.v_mps.abs().max(self.goal.v_mps.abs())
    }

    /// The largest |ω| on the way (rad/s).
    fn top_turn_rate(&self) -> f64 {
        self.cmd.omega_radps.abs().max(self.goal.omega_radps.abs())
    }
}

/// A unicycle following a [`Profile`] from the origin, walked in equal time
/// steps of a few sub-steps each (each sub-step the exact arc of its mean
/// v and ω). The heading is a unit vector turned by each sub-step's small
/// rotation ([`small_turn`]), not an angle: no sine or cosine is evaluated
/// per sub-step (this walk is scored for most candidates while a mover
/// threatens, a hundred sub-steps each).
#[derive(Debug, Clone, Copy)]
struct ProfileWalk {
    pos: Vec2,
    /// Unit heading.
    heading: Vec2,
    v: f64,
    omega: f64,
    profile: Profile,
    sub_s: f64,
    subs: usize,
    /// Once v and ω have reached the goal: the rest is one arc, walked a
    /// whole step at a time.
    steady: Option<ArcWalk>,
}

/// Points looked at together by [`PassiveSafety::nearest_lower_bound_m`].
const LANES: usize = 8;
/// Its slack for f32 rounding (m).
const F32_SLACK_M: f64 = 1e-5;
/// Where its padding points lie (m): beyond any reach.
const FAR_M: f32 = 1e6;

/// Sub-steps per step of a [`ProfileWalk`].
const PROFILE_SUBSTEPS: usize = 4;

impl ProfileWalk {
    fn new(profile: Profile, step_s: f64) -> Self {
        Self {
            pos: Vec2::zeros(),
            heading: Vec2::new(1.0, 0.0),
            v: profile.cmd.v_mps,
            omega: profile.cmd.omega_radps,
            profile,
            sub_s: step_s / PROFILE_SUBSTEPS as f64,
            subs: PROFILE_SUBSTEPS,
            steady: None,
        }
    }

    fn step(&mut self) {
        if let Some(arc) = &mut self.steady {
            arc.step();
            (self.pos, self.heading) = (arc.pos, arc.heading);
            return;
        }
        let towards = |x: f64, goal: f64, max: f64| x + (goal - x).clamp(-max, max);
        let (rv, rw) = self.profile.rates;
        for _ in 0..self.subs {
            let v1 = towards(self.v, self.profile.goal.v_mps, rv * self.sub_s);
            let w1 = towards(self.omega, self.profile.goal.omega_radps, rw * self.sub_s);
            let (vm, wm) = (0.5 * (self.v + v1), 0.5 * (self.omega + w1));
            let half = 0.5 * wm * self.sub_s;
            let (c, s, sinc_half) = small_turn_sinc(half);
            // The chord of the arc, along the heading at its middle; then the whole turn,
            // twice the half (cos 2a, sin 2a).
            self.pos += rotate(self.heading, (c, s)) * (vm * self.sub_s * sinc_half);
            self.heading = rotate(self.heading, (c * c - s * s, 2.0 * s * c));
            (self.v, self.omega) = (v1, w1);
        }
        let goal = self.profile.goal;
        if self.v == goal.v_mps && self.omega == goal.omega_radps {
            let mut arc = ArcWalk::new(goal, self.sub_s * self.subs as f64);
            (arc.pos, arc.heading) = (self.pos, self.heading);
            self.steady = Some(arc);
        }
    }

    fn velocity(&self) -> Vec2 {
        self.heading * self.v
    }
}

/// (cos, sin) of a small angle (rad) by their series; exact to 1e-12 below 0.05 rad.
#[inline]
fn small_turn(a: f64) -> (f64, f64) {
    let (c, s, _) = small_turn_sinc(a);
    (c, s)
}

/// (cos a, sin a, sin a / a) by their series below 0.05 rad (exact to
/// 1e-12 there), by the functions above.
#[inline]
fn small_turn_sinc(a: f64) -> (f64, f64, f64) {
    if a.abs() < 0.05 {
        let a2 = a * a;
        let sinc = 1.0 - a2 / 6.0 + a2 * a2 / 120.0;
        (1.0 - a2 / 2.0 + a2 * a2 / 24.0 - a2 * a2 * a2 / 720.0, a * sinc, sinc)
    } else {
        let (s, c) = a.sin_cos();
        (c, s, s / a)
    }
}

/// Whether ‖`d`‖ ≥ `limit` (m, ≥ 0) for certain, without the root: the
/// comparisons it replaces (‖d‖ < limit, and a gap ‖d‖ − ρ ≥ limit − ρ that a
/// cap at limit − ρ takes away) then come out the same, with a relative
/// margin of 1e-9 far beyond the rounding of either side.
#[inline]
fn surely_beyond(d: Vec2, limit: f64) -> bool {
    let far = limit * (1.0 + 1e-9);
    d.norm_squared() > far * far
}

/// A tracked moving obstacle, robot frame, now.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mover {
    /// Centre (m).
    pub position: Vec2,
    /// Estimated velocity (m/s).
    pub velocity: Vec2,
    /// Radius of its circle (m).
    pub radius_m: f64,
}

/// One point of a predicted robot path.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Sample {
    /// Time from now (s).
    t_s: f64,
    /// Robot centre (m, robot frame now).
    pos: Vec2,
    /// Robot velocity (m/s).
    vel: Vec2,
}

/// A predicted closing contact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClosingContact {
    /// When (s from now).
    pub t_s: f64,
    /// Robot speed towards the obstacle then (m/s).
    pub closing_speed_mps: f64,
    /// With a tracked mover (else a static point).
    pub mover: bool,
}

/// How good a command is for getting away from movers: later first contact
/// is better, then more room to the movers over the horizon.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EvasionScore {
    /// Predicted time to the first contact with the command held (s);
    /// the horizon when there is none.
    pub time_to_contact_s: f64,
    /// Predicted time to the first contact with a mover's grown disc alone (s);
    /// the horizon when there is none. What makes a command *threatened*: a
    /// static point ahead is the DTCBF's business, step by step.
    pub mover_contact_s: f64,
    /// Mean over the horizon (after now) of the predicted body-to-nearest-
    /// mover distance, capped at [`GAP_CAP_M`] (m; movers at their estimated
    /// radius, no margin): when contact cannot be put off, the command that
    /// keeps the movers furthest off for longest. +inf without movers.
    pub mover_gap_m: f64,
    /// At the horizon's end, how much nearer than r + r_o + margin the robot is
    /// to the predicted line of the mover coming towards it (m; ≤ 0: beside all).
    pub line_deficit_m: f64,
}

impl EvasionScore {
    /// The worst score: contact now, no room.
    fn contact_now() -> Self {
        Self {
            time_to_contact_s: 0.0,
            mover_contact_s: 0.0,
            mover_gap_m: 0.0,
            line_deficit_m: 0.0,
        }
    }
}

/// Room to a mover beyond this counts no more in [`EvasionScore::mover_gap_m`] (m).
pub const GAP_CAP_M: f64 = 0.5;

/// What a walk of the evasion horizon has found after some of its samples:
/// enough for a caller to bound the final score before the walk ends
/// ([`PassiveSafety::evasion_score_until`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EvasionSoFar {
    /// The first contact, once found (s): final from then on.
    pub contact_s: Option<f64>,
    /// The sum of the capped gaps of the samples after now so far (m).
    pub gap_sum_m: f64,
    /// Samples after now walked so far.
    pub samples_done: usize,
    /// Samples after now in all.
    pub samples: usize,
    /// There are movers: the gap counts (else the score's gap is +inf).
    pub movers: bool,
}

impl EvasionScore {
    /// Whether `self` beats `other` by at least `min_gain_s` of time to
    /// contact, or ties on it and keeps at least `min_gap_gain_m` more room.
    pub fn beats(&self, other: &EvasionScore, min_gain_s: f64, min_gap_gain_m: f64) -> bool {
        let dt = self.time_to_contact_s - other.time_to_contact_s;
        if dt.abs() <= 1e-9 {
            // No mover at all (both gaps +inf): nothing to gain.
            self.mover_gap_m.is_finite() && self.mover_gap_m >= other.mover_gap_m + min_gap_gain_m
        } else {
            dt >= min_gain_s
        }
    }
}

/// The movers of this step and scratch buffers; no allocation once sized.
#[derive(Debug, Clone, Default)]
pub struct PassiveSafety {
    movers: Vec<Mover>,
    /// The movers an evasion path of this step can come near, each with the
    /// earliest time it can (s), soonest first (all of them, from 0 s, until
    /// [`Self::select_reach`] has sorted out the others).
    near_movers: Vec<(f64, Mover)>,
    /// The movers a braking path of this step can come near (all of them
    /// until [`Self::prepare`] has sorted out the others).
    brake_movers: Vec<Mover>,
    /// Where unknown beams may hide something (robot frame, m): driven into
    /// like static points, never counted in h.
    phantoms: Vec<Vec2>,
    /// The static points and phantoms any braking path of the box can reach
    /// this step ([`Self::prepare`]).
    near_seen: Vec<Vec2>,
    near_unseen: Vec<Vec2>,
    /// The points one path can reach and their squared contact radii (m, m²).
    scratch: Vec<(Vec2, f64)>,
    path: Vec<Sample>,
    /// The polygon body, if the robot has one (else the circle of r).
    footprint: Option<PaddedPolygon>,
    /// The polygon's swept path.
    poses: Vec<PathPose>,
    reach: Vec<Vec2>,
    /// The same points as f32 coordinates, padded to whole lanes with far
    /// points: for [`Self::nearest_lower_bound_m`].
    reach_x: Vec<f32>,
    reach_y: Vec<f32>,
    /// The last few answers of [`Self::closing_contact`] and
    /// [`Self::evasion_score`] this step: the search and the step record ask
    /// about the same commands more than once. Cleared whenever an input changes.
    contact_memo: Memo<Option<ClosingContact>>,
    evasion_memo: Memo<EvasionScore>,
}

/// Answers for a few commands, the oldest replaced first.
#[derive(Debug, Clone, Copy)]
struct Memo<T: Copy> {
    entries: [Option<(Twist, T)>; MEMO_SIZE],
    next: usize,
}

/// Commands remembered per question.
const MEMO_SIZE: usize = 4;

impl<T: Copy> Default for Memo<T> {
    fn default() -> Self {
        Self {
            entries: [None; MEMO_SIZE],
            next: 0,
        }
    }
}

impl<T: Copy> Memo<T> {
    fn clear(&mut self) {
        self.entries = [None; MEMO_SIZE];
    }

    /// The answer for `cmd`, bit for bit the same command.
    fn get(&self, cmd: Twist) -> Option<T> {
        let same = |c: &Twist| {
            c.v_mps.to_bits() == cmd.v_mps.to_bits() && c.omega_radps.to_bits() == cmd.omega_radps.to_bits()
        };
        self.entries.iter().flatten().find(|(c, _)| same(c)).map(|(_, t)| *t)
    }

    fn put(&mut self, cmd: Twist, answer: T) -> T {
        self.entries[self.next] = Some((cmd, answer));
        self.next = (self.next + 1) % MEMO_SIZE;
        answer
    }
}

impl PassiveSafety {
    /// Buffers for up to `max_movers` movers and `points` scan points (no allocation per scan).
    pub fn with_capacity(max_movers: usize, points: usize) -> Self {
        Self {
            movers: Vec::with_capacity(max_movers),
            near_movers: Vec::with_capacity(max_movers),
            brake_movers: Vec::with_capacity(max_movers),
            phantoms: Vec::with_capacity(points),
            near_seen: Vec::with_capacity(points),
            near_unseen: Vec::with_capacity(points),
            scratch: Vec::with_capacity(points),
            path: Vec::with_capacity(MAX_STEP_SAMPLES + MAX_BRAKE_SAMPLES + 2),
            footprint: None,
            poses: Vec::with_capacity(130),
            reach: Vec::with_capacity(points),
            reach_x: Vec::with_capacity(points + LANES),
            reach_y: Vec::with_capacity(points + LANES),
            contact_memo: Memo::default(),
            evasion_memo: Memo::default(),
        }
    }

    /// This step's movers (replaced).
    pub fn set_movers(&mut self, movers: impl Iterator<Item = Mover>) {
        self.movers.clear();
        self.movers.extend(movers);
        self.near_movers.clear();
        self.near_movers.extend(self.movers.iter().map(|m| (0.0, *m)));
        self.brake_movers.clear();
        self.brake_movers.extend_from_slice(&self.movers);
        self.forget_answers();
    }

    fn forget_answers(&mut self) {
        self.contact_memo.clear();
        self.evasion_memo.clear();
    }

    /// This step's movers.
    pub fn movers(&self) -> &[Mover] {
        &self.movers
    }

    /// This step's phantoms (replaced): points unknown beams may hide.
    pub fn set_phantoms(&mut self, phantoms: &[Vec2]) {
        self.phantoms.clear();
        self.phantoms.extend_from_slice(phantoms);
        self.forget_answers();
    }

    /// Samples `cmd` applied for one control step, then braking to rest.
    fn braking_path(&mut self, cmd: Twist, p: &Params) {
        self.path.clear();
        let v = cmd.v_mps;
        if v == 0.0 {
            return; // turning in place moves no part of a circular robot
        }
        let dt = p.control.dt_s();
        let decel = p.control.decel_mps2;
        let speed = v.abs();
        let n1 = ((speed * dt / SAMPLE_SPACING_M).ceil() as usize).clamp(1, MAX_STEP_SAMPLES);
        let mut walk = ArcWalk::new(cmd, dt / n1 as f64);
        for k in 1..=n1 {
            walk.step();
            self.path.push(Sample {
                t_s: dt * k as f64 / n1 as f64,
                pos: walk.pos,
                vel: walk.heading * v,
            });
        }
        // Braking: speed falls linearly to 0 over speed/decel, on the same curvature.
        let curvature = cmd.omega_radps / v;
        let t_brake = speed / decel;
        let s_brake = 0.5 * speed * t_brake;
        let n2 = ((s_brake / SAMPLE_SPACING_M).ceil() as usize).clamp(1, MAX_BRAKE_SAMPLES);
        let (mut pos, mut heading) = (walk.pos, walk.heading);
        let mut s_prev = 0.0;
        for k in 1..=n2 {
            let tau = t_brake * k as f64 / n2 as f64;
            let s = speed * tau - 0.5 * decel * tau * tau; // distance so far (m)
                                                           // The arc of this sample's distance: chord along the mid heading.
            let ds = (s - s_prev) * v.signum();
            let dth = ds * curvature;
            let (c, sn) = small_turn(0.5 * dth);
            let chord = if dth.abs() < 1e-9 { ds } else { ds * sn / (0.5 * dth) };
            pos += rotate(heading, (c, sn)) * chord;
            heading = rotate(heading, small_turn(dth));
            s_prev = s;
            let speed_now = (speed - decel * tau).max(0.0);
            self.path.push(Sample {
                t_s: dt + tau,
                pos,
                vel: heading * (speed_now * v.signum()),
            });
        }
    }

    /// Keeps the static points (robot frame, m) and this step's phantoms that
    /// a braking path of any command of the parameters' box can come near:
    /// [`Self::closing_contact`] then looks at those only. Call once per step,
    /// after [`Self::set_phantoms`].
    pub fn prepare(&mut self, points: &[Vec2], p: &Params) {
        let speed = p.control.v_max_mps.max(p.control.v_reverse_max_mps);
        let travel = speed * (p.control.dt_s() + speed / p.control.decel_mps2);
        let margin = UNSEEN_MARGIN_M.max(p.passive.seen_margin_m);
        let reach = self.body_radius_m(p) + margin + travel + 2.0 * SAMPLE_SPACING_M;
        let reach2 = reach * reach;
        self.near_seen.clear();
        self.near_seen
            .extend(points.iter().filter(|q| q.norm_squared() <= reach2));
        self.near_unseen.clear();
        self.near_unseen
            .extend(self.phantoms.iter().filter(|q| q.norm_squared() <= reach2));
        // A mover is out of reach of every braking path when, closing at its speed
        // from where it is while the robot travels its longest path, it stays beyond
        // its grown disc for the path's whole duration: at every sample
        // `first_closing_contact` would skip it (`surely_beyond`).
        let duration = p.control.dt_s() + speed / p.control.decel_mps2;
        let (r, pp) = (self.body_radius_m(p), &p.passive);
        self.brake_movers.clear();
        self.brake_movers.extend(self.movers.iter().filter(|m| {
            let nearest = m.position.norm() - m.velocity.norm() * duration - travel;
            let grown = r + m.radius_m + pp.mover_margin_m + pp.mover_growth_mps * duration;
            nearest <= grown * (1.0 + 1e-6) + 1e-6
        }));
        self.forget_answers();
    }

    /// The first closing contact `cmd` would make (one step, then braking to
    /// rest), or `None`: the command is passively safe. Static points are
    /// those of the last [`Self::prepare`]; the movers are this step's.
    pub fn closing_contact(&mut self, cmd: Twist, p: &Params) -> Option<ClosingContact> {
        if let Some(answer) = self.contact_memo.get(cmd) {
            return answer;
        }
        let answer = self.first_closing_contact(cmd, p);
        self.contact_memo.put(cmd, answer)
    }

    /// How far the body reaches from its origin (m): the circle's r, or the
    /// footprint polygon's circumscribed radius.
    fn body_radius_m(&self, p: &Params) -> f64 {
        self.footprint
            .as_ref()
            .map_or(p.robot_radius_m(), PaddedPolygon::circumscribed_radius_m)
    }

    /// The robot's footprint: a padded polygon swept along the braking path
    /// ([`super::braking_polygon`]), or `None` for the circle of r.
    pub fn set_footprint(&mut self, footprint: Option<PaddedPolygon>) {
        self.footprint = footprint;
        self.forget_answers();
    }

    fn first_closing_contact(&mut self, cmd: Twist, p: &Params) -> Option<ClosingContact> {
        if let Some(fp) = &self.footprint {
            braking_poses(cmd, fp.circumscribed_radius_m(), p, &mut self.poses);
            return first_polygon_contact(
                fp,
                &self.poses,
                &self.near_seen,
                &self.near_unseen,
                &self.brake_movers,
                p,
            );
        }
        self.braking_path(cmd, p);
        let last = self.path.last()?;
        let r = p.robot_radius_m();
        let threshold = 0.5 * p.passive.closing_speed_mps;
        // Only points the body can reach on this path matter: within r of a path
        // no longer than the time it takes at the starting speed.
        let reach = r + cmd.v_mps.abs() * last.t_s + SAMPLE_SPACING_M;
        let (r2, reach2) = (r * r, reach * reach);
        let ru = r + UNSEEN_MARGIN_M;
        let (ru2, reach_u2) = (ru * ru, (reach + UNSEEN_MARGIN_M).powi(2));
        // The points this path can reach, with the contact radius of each, once.
        self.scratch.clear();
        let seen = self
            .near_seen
            .iter()
            .filter(|q| q.norm_squared() <= reach2)
            .map(|q| (*q, r2));
        let unseen = self
            .near_unseen
            .iter()
            .filter(|q| q.norm_squared() <= reach_u2)
            .map(|q| (*q, ru2));
        self.scratch.extend(seen.chain(unseen));
        for s in &self.path {
            for &(q, r2) in &self.scratch {
                let d = q - s.pos;
                let d2 = d.norm_squared();
                if d2 < r2 {
                    let towards = if d2 > 0.0 {
                        s.vel.dot(&d) / d2.sqrt()
                    } else {
                        s.vel.norm()
                    };
                    if towards > threshold {
                        return Some(ClosingContact {
                            t_s: s.t_s,
                            closing_speed_mps: towards,
                            mover: false,
                        });
                    }
                }
            }
            for m in &self.brake_movers {
                let c = m.position + m.velocity * s.t_s;
                let reach_m = r + m.radius_m + p.passive.mover_margin_m + p.passive.mover_growth_mps * s.t_s;
                let d = c - s.pos;
                if surely_beyond(d, reach_m) {
                    continue;
                }
                let dist = d.norm();
                if dist < reach_m {
                    let towards = if dist > 0.0 { s.vel.dot(&d) / dist } else { s.vel.norm() };
                    if towards > threshold {
                        return Some(ClosingContact {
                            t_s: s.t_s,
                            closing_speed_mps: towards,
                            mover: true,
                        });
                    }
                }
            }
        }
        None
    }

    /// Keeps the points of `all` within reach of an evasion path (robot frame,
    /// m), for [`Self::evasion_score`]; call once per step.
    pub fn select_reach(&mut self, all: &[Vec2], p: &Params) {
        let vmax = p.control.v_max_mps.max(p.control.v_reverse_max_mps);
        let reach = self.body_radius_m(p) + vmax * p.passive.evasion_horizon_s + 0.05;
        let reach2 = reach * reach;
        self.reach.clear();
        // The points, then the phantoms (two passes: a chained one costs more per point).
        for set in [all, &self.phantoms] {
            self.reach.extend(set.iter().filter(|q| q.norm_squared() <= reach2));
        }
        self.reach_x.clear();
        self.reach_y.clear();
        self.reach_x.extend(self.reach.iter().map(|q| q.x as f32));
        self.reach_y.extend(self.reach.iter().map(|q| q.y as f32));
        let pad = self.reach.len().next_multiple_of(LANES) - self.reach.len();
        self.reach_x.extend(std::iter::repeat_n(FAR_M, pad));
        self.reach_y.extend(std::iter::repeat_n(FAR_M, pad));
        // Until a mover, closing at its speed plus the robot's from where it is, can
        // come within its radius + r + the larger of the gap cap and its grown margin,
        // `score_evasion` would skip it at every sample (`surely_beyond`): it is looked
        // at from then on, and not at all if that is beyond the horizon.
        let horizon = p.passive.evasion_horizon_s;
        let beyond = GAP_CAP_M.max(p.passive.mover_margin_m + p.passive.mover_growth_mps * horizon);
        let r = self.body_radius_m(p);
        self.near_movers.clear();
        self.near_movers.extend(self.movers.iter().filter_map(|m| {
            let room = m.position.norm() - ((r + m.radius_m + beyond) * (1.0 + 1e-6) + 1e-6);
            let from = (room / (m.velocity.norm() + vmax)).max(0.0);
            (from <= horizon).then_some((from, *m))
        }));
        self.near_movers.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        self.evasion_memo.clear();
    }

    /// Predicted time to first contact with `cmd` held for the evasion
    /// horizon: any contact with a mover's grown disc, or a closing contact
    /// with a static point selected by [`Self::select_reach`].
    pub fn evasion_score(&mut self, cmd: Twist, p: &Params) -> EvasionScore {
        if let Some(score) = self.evasion_memo.get(cmd) {
            return score;
        }
        let score = self.evasion_score_of(Profile::held(cmd), p);
        self.evasion_memo.put(cmd, score)
    }

    /// Sidestep (§5b): how far inside the swept line of a mover coming head-on
    /// (within 45° of straight at the robot, and able to reach it within the
    /// look-ahead) the robot still is when its path ends at `end` (robot
    /// frame, m).
    fn line_deficit(&self, end: Vec2, end_heading: Vec2, p: &Params) -> f64 {
        let r = p.robot_radius_m();
        let fp = self.footprint.as_ref();
        let mut line_deficit_m: f64 = 0.0;
        for m in &self.movers {
            let speed = m.velocity.norm();
            // Coming at the robot: within 45° of straight at it, from ahead (head-on) or
            // from behind (overtaking): either way the robot is in its line.
            let at_robot = -m.velocity.dot(&m.position) > std::f64::consts::FRAC_1_SQRT_2 * speed * m.position.norm();
            if speed < LINE_MIN_SPEED_MPS || !at_robot {
                continue;
            }
            // How far the body reaches across the mover's line from its origin: the
            // circle's r, or the polygon's half-extent across the line at that heading.
            let along = m.velocity / speed;
            let need_at = |heading: Vec2| {
                let across = fp.map_or(r, |fp| fp.half_extent_across_m(rotate_back(along, heading)));
                across + m.radius_m + p.passive.mover_margin_m
            };
            let need = need_at(Vec2::new(1.0, 0.0));
            if m.position.norm() - need > (speed + p.control.v_max_mps) * p.obstacles.lookahead_s {
                continue;
            }
            let lateral_of = |q: Vec2| {
                let d = q - m.position;
                (m.velocity.x * d.y - m.velocity.y * d.x).abs() / speed
            };
            // Already beside its line: nothing to step out of.
            if lateral_of(Vec2::zeros()) >= need {
                continue;
            }
            line_deficit_m = line_deficit_m.max(need_at(end_heading) - lateral_of(end));
        }
        line_deficit_m
    }

    /// [`Self::evasion_score`] of a command that changes as `profile` says
    /// (not remembered: each profile is asked about once).
    pub fn evasion_score_of(&self, profile: Profile, p: &Params) -> EvasionScore {
        match self.evasion_score_until(profile, p, |_| false) {
            Some(score) => score,
            // Never: the walk is not given up. The worst score, should it be.
            None => EvasionScore::contact_now(),
        }
    }

    /// [`Self::evasion_score_of`], or `None` as soon as `enough` says, after
    /// any sample, that what the walk has found so far is enough to tell (a
    /// caller that needs the score only while it could still be low stops
    /// the walk when a bound on it already rules that out).
    pub fn evasion_score_until(
        &self,
        profile: Profile,
        p: &Params,
        enough: impl FnMut(&EvasionSoFar) -> bool,
    ) -> Option<EvasionScore> {
        let horizon = p.passive.evasion_horizon_s;
        let n = (horizon / EVASION_SAMPLE_S).ceil().max(1.0) as usize;
        if profile.goal == profile.cmd {
            let cmd = profile.cmd;
            let mut walk = ArcWalk::new(cmd, horizon / n as f64);
            return self.score_path(
                |k| {
                    if k > 0 {
                        walk.step();
                    }
                    WalkSample {
                        pos: walk.pos,
                        heading: walk.heading,
                        vel: walk.heading * cmd.v_mps,
                        omega_radps: cmd.omega_radps,
                    }
                },
                cmd.v_mps.abs(),
                cmd.omega_radps.abs(),
                p,
                enough,
            );
        }
        let mut walk = ProfileWalk::new(profile, horizon / n as f64);
        self.score_path(
            |k| {
                if k > 0 {
                    walk.step();
                }
                WalkSample {
                    pos: walk.pos,
                    heading: walk.heading,
                    vel: walk.velocity(),
                    omega_radps: walk.omega,
                }
            },
            profile.top_speed(),
            profile.top_turn_rate(),
            p,
            enough,
        )
    }

    /// A lower bound of the distance from `pos` (robot frame, m) to the
    /// nearest point within reach (m; huge with none), computed in f32 over
    /// [`LANES`] points at a time. The f32 coordinates and arithmetic are off
    /// by less than 1e-6 m at the few metres of reach; [`F32_SLACK_M`] more
    /// than covers that, so the bound never exceeds the exact distance and a
    /// sample it clears has no contact: skipping the exact look there
    /// changes no score.
    fn nearest_lower_bound_m(&self, pos: Vec2) -> f64 {
        let (px, py) = (pos.x as f32, pos.y as f32);
        let mut least = [f32::INFINITY; LANES];
        for (xs, ys) in self.reach_x.chunks_exact(LANES).zip(self.reach_y.chunks_exact(LANES)) {
            for l in 0..LANES {
                let (dx, dy) = (xs[l] - px, ys[l] - py);
                let d2 = dx * dx + dy * dy;
                least[l] = if d2 < least[l] { d2 } else { least[l] };
            }
        }
        let d2 = least.iter().fold(f32::INFINITY, |a, &b| if b < a { b } else { a });
        f64::from(d2).sqrt() - F32_SLACK_M
    }

    /// The score of the path whose pose and velocity at sample k (of the
    /// horizon's samples, 0 = now) `at` gives, called for k = 0, 1, … in
    /// turn; `speed` and `turn_rate` bound the path's |v| (m/s) and |ω|
    /// (rad/s). A polygon footprint is posed at each sample: its signed
    /// distance to a mover's centre, and its closing contacts with static
    /// points (a turn alone swings a corner), replace the circle's.
    fn score_path(
        &self,
        mut at: impl FnMut(usize) -> WalkSample,
        speed: f64,
        turn_rate: f64,
        p: &Params,
        mut enough: impl FnMut(&EvasionSoFar) -> bool,
    ) -> Option<EvasionScore> {
        let fp = self.footprint.as_ref();
        // The body lies within `r` of its origin (the bound every prefilter below uses).
        let r = self.body_radius_m(p);
        // No body point moves faster than this (m/s).
        let body_speed = speed + fp.map_or(0.0, |_| turn_rate * r);
        let horizon = p.passive.evasion_horizon_s;
        let threshold = 0.5 * p.passive.closing_speed_mps;
        let n = (horizon / EVASION_SAMPLE_S).ceil().max(1.0) as usize;
        let mut contact: Option<f64> = None;
        let mut mover_contact: Option<f64> = None;
        let mut gap_sum = 0.0;
        // No static point can be reached before this: the body closes on any point no
        // faster than its fastest point moves, so the nearest one, d − r away from the
        // circle of r about the origin, takes (d − r)/that speed.
        let mut static_clear_until = 0.0;
        let mut end = WalkSample::default();
        for k in 0..=n {
            let t = horizon * k as f64 / n as f64;
            let sample = at(k);
            let pos = sample.pos;
            end = sample;
            let pose = PathPose {
                t_s: t,
                pos,
                heading: sample.heading,
                vel: sample.vel,
                omega_radps: sample.omega_radps,
            };
            let mut gap = f64::INFINITY;
            // A mover farther than this beyond r + its radius is past the gap cap and
            // its grown disc: it changes neither, and its distance needs no root.
            let beyond = GAP_CAP_M.max(p.passive.mover_margin_m + p.passive.mover_growth_mps * t);
            for (from, m) in &self.near_movers {
                if t < *from {
                    break; // it and every later one are still too far
                }
                let c = m.position + m.velocity * t;
                let d = c - pos;
                if surely_beyond(d, r + m.radius_m + beyond) {
                    continue;
                }
                let grown = m.radius_m + p.passive.mover_margin_m + p.passive.mover_growth_mps * t;
                // The body's distance to the mover's centre: the circle's, or the posed
                // polygon's signed distance.
                let (body_gap, touches) = mover_gap(fp, r, &pose, c, m.radius_m, grown);
                gap = gap.min(body_gap);
                if touches {
                    contact = contact.or(Some(t));
                    mover_contact = mover_contact.or(Some(t));
                }
            }
            if k > 0 {
                gap_sum += gap.min(GAP_CAP_M);
                if contact.is_none() && body_speed > 0.0 && t >= static_clear_until {
                    // Most samples are nowhere near a point: a bound in f32 over all of
                    // them at once says so, and only a sample it cannot clear is
                    // looked at exactly.
                    let near_lb = self.nearest_lower_bound_m(pos);
                    if near_lb >= r {
                        static_clear_until = t + (near_lb - r) / body_speed;
                    } else {
                        let mut nearest2 = f64::INFINITY;
                        let static_hit = self.reach.iter().any(|q| {
                            let d = q - pos;
                            let d2 = d.norm_squared();
                            nearest2 = nearest2.min(d2);
                            if d2 >= r * r {
                                return false;
                            }
                            match fp {
                                None => sample.vel.dot(&d) > threshold * d2.sqrt(),
                                Some(fp) => polygon_closes_on(fp, &pose, *q, threshold),
                            }
                        });
                        if static_hit {
                            contact = Some(t);
                        } else {
                            static_clear_until = t + (nearest2.sqrt() - r).max(0.0) / body_speed;
                        }
                    }
                }
            }
            let so_far = EvasionSoFar {
                contact_s: contact,
                gap_sum_m: gap_sum,
                samples_done: k,
                samples: n,
                movers: !self.movers.is_empty(),
            };
            if enough(&so_far) {
                return None;
            }
        }
        Some(EvasionScore {
            line_deficit_m: self.line_deficit(end.pos, end.heading, p),
            time_to_contact_s: contact.unwrap_or(horizon),
            mover_contact_s: mover_contact.unwrap_or(horizon),
            mover_gap_m: if self.movers.is_empty() {
                f64::INFINITY
            } else {
                gap_sum / n as f64
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// r = 0.178 m, Δt = 0.1 s, decel 1 m/s², closing threshold 0.02 m/s; seen
    /// points at r exactly (the margin has a test of its own).
    fn params() -> Params {
        let mut p = Params::default();
        p.passive.seen_margin_m = 0.0;
        p
    }

    /// `cmd`'s first closing contact with the static `points` and `ps`'s movers.
    fn contact(ps: &mut PassiveSafety, cmd: Twist, points: &[Vec2], p: &Params) -> Option<ClosingContact> {
        ps.prepare(points, p);
        ps.closing_contact(cmd, p)
    }

    /// The profile walk as plainly as it can be written: the heading an angle,
    /// each sub-step's arc by cos, sin and sinc.
    fn plain_profile_walk(profile: Profile, step_s: f64, steps: usize) -> Vec<(Vec2, Vec2)> {
        use crate::algo::unicycle::sinc;
        let towards = |x: f64, goal: f64, max: f64| x + (goal - x).clamp(-max, max);
        let sub = step_s / PROFILE_SUBSTEPS as f64;
        let (mut pos, mut theta) = (Vec2::zeros(), 0.0f64);
        let (mut v, mut w) = (profile.cmd.v_mps, profile.cmd.omega_radps);
        let mut out = vec![(pos, Vec2::new(theta.cos(), theta.sin()) * v)];
        for _ in 0..steps {
            for _ in 0..PROFILE_SUBSTEPS {
                let v1 = towards(v, profile.goal.v_mps, profile.rates.0 * sub);
                let w1 = towards(w, profile.goal.omega_radps, profile.rates.1 * sub);
                let (vm, wm) = (0.5 * (v + v1), 0.5 * (w + w1));
                let half = 0.5 * wm * sub;
                let heading = theta + half;
                pos += Vec2::new(heading.cos(), heading.sin()) * (vm * sub * sinc(half));
                theta += wm * sub;
                (v, w) = (v1, w1);
            }
            out.push((pos, Vec2::new(theta.cos(), theta.sin()) * v));
        }
        out
    }

    proptest::proptest! {
        /// The trig-free profile walk stays on the plain one's path: within 1e-9 m
        /// and 1e-9 m/s over a 5 s horizon, at every yaw rate and rate of change
        /// the window allows and beyond.
        #[test]
        fn the_profile_walk_matches_the_plain_walk(
            v0 in -0.3f64..0.3, w0 in -3.0f64..3.0, v1 in -0.3f64..0.3, w1 in -3.0f64..3.0,
            rv in 0.0f64..3.0, rw in 0.0f64..4.0,
        ) {
            let profile = Profile { cmd: Twist::new(v0, w0), goal: Twist::new(v1, w1), rates: (rv, rw) };
            let plain = plain_profile_walk(profile, 0.2, 25);
            let mut walk = ProfileWalk::new(profile, 0.2);
            for (k, (pos, vel)) in plain.iter().enumerate() {
                if k > 0 {
                    walk.step();
                }
                proptest::prop_assert!((walk.pos - pos).norm() < 1e-9, "step {}: {:?} vs {:?}", k, walk.pos, pos);
                proptest::prop_assert!((walk.velocity() - vel).norm() < 1e-9, "step {}", k);
            }
        }
    }

    #[test]
    fn arc_walks_match_the_closed_form_arc() {
        use crate::algo::geometry::Pose2;
        use crate::algo::unicycle::arc_step;
        for cmd in [
            Twist::new(0.2, 0.3),
            Twist::new(-0.15, -0.3),
            Twist::new(0.22, 0.0),
            Twist::new(0.1, 2.0),
        ] {
            let mut w = ArcWalk::new(cmd, 0.1);
            for k in 1..=40 {
                w.step();
                let pose = arc_step(Pose2::default(), cmd, 0.1 * k as f64);
                assert!((w.pos - pose.position()).norm() < 1e-9, "{cmd:?} step {k}");
                assert!((w.heading - Vec2::new(pose.theta.cos(), pose.theta.sin())).norm() < 1e-9);
            }
        }
        for a in [0.0, 1e-3, 0.049, -0.03, 0.2] {
            let (c, s) = small_turn(a);
            assert!((c - a.cos()).abs() < 1e-12 && (s - a.sin()).abs() < 1e-12, "{a}");
        }
    }

    #[test]
    fn braking_distance_decides_against_a_static_point_ahead() {
        // v = 0.2: 2 cm in the step, then 0.2²/2 = 2 cm braking: the centre stops 4 cm on.
        // A point at r + 4.5 cm ahead is not reached; at r + 3.5 cm it is, head-on.
        let p = params();
        let mut ps = PassiveSafety::default();
        let cmd = Twist::new(0.2, 0.0);
        assert_eq!(contact(&mut ps, cmd, &[Vec2::new(0.178 + 0.045, 0.0)], &p), None);
        let c = contact(&mut ps, cmd, &[Vec2::new(0.178 + 0.035, 0.0)], &p).unwrap();
        assert!(!c.mover && c.t_s > 0.1 && c.t_s < 0.3, "{c:?}");
        // Reached during braking, after 1.5 cm of it (v² = 0.04 − 2·0.015: 0.1 m/s), seen at
        // the first sample past it, up to a centimetre on (0.2 − √… ≥ 0.05 m/s).
        assert!(c.closing_speed_mps > 0.05 && c.closing_speed_mps <= 0.1 + 1e-9, "{c:?}");
        // Stronger brakes: stops after 2 cm + 1 cm and does not reach it.
        let mut strong = params();
        strong.control.decel_mps2 = 2.0;
        assert_eq!(contact(&mut ps, cmd, &[Vec2::new(0.178 + 0.035, 0.0)], &strong), None);
        // Standing still and turning in place are always passively safe.
        assert_eq!(contact(&mut ps, Twist::new(0.0, 0.3), &[Vec2::new(0.1, 0.0)], &p), None);
    }

    #[test]
    fn the_circle_keeps_no_seen_margin() {
        // v = 0.03 m/s: 3 mm in the step, then 0.03²/2 = 0.45 mm braking: 3.45 mm in all.
        // A point 8 mm ahead of the rim is not reached, whatever `seen_margin_m` (a
        // polygon's alone, braking_polygon.rs).
        let mut p = params();
        let mut ps = PassiveSafety::default();
        let cmd = Twist::new(0.03, 0.0);
        let near = [Vec2::new(0.178 + 0.008, 0.0)];
        assert_eq!(contact(&mut ps, cmd, &near, &p), None);
        p.passive.seen_margin_m = 0.01;
        assert_eq!(contact(&mut ps, cmd, &near, &p), None);
        // 2 mm ahead of the rim it is reached.
        assert!(contact(&mut ps, cmd, &[Vec2::new(0.178 + 0.002, 0.0)], &p).is_some());
    }

    #[test]
    fn moving_away_from_a_touching_point_is_not_closing() {
        let p = params();
        let mut ps = PassiveSafety::default();
        // A point behind, already inside r: forward motion moves away from it.
        assert_eq!(
            contact(&mut ps, Twist::new(0.2, 0.0), &[Vec2::new(-0.15, 0.0)], &p),
            None
        );
        // Backing up into it is closing.
        assert!(contact(&mut ps, Twist::new(-0.05, 0.0), &[Vec2::new(-0.15, 0.0)], &p).is_some());
        // Sliding past, barely approaching (tangential) is not.
        assert_eq!(
            contact(&mut ps, Twist::new(0.2, 0.0), &[Vec2::new(0.0, 0.17)], &p),
            None
        );
    }

    #[test]
    fn a_mover_crossing_ahead_forbids_driving_into_its_predicted_disc() {
        let p = params();
        let mut ps = PassiveSafety::default();
        // A person (radius 0.2 m) 0.2 m ahead-left walking right at 1 m/s: in 0.3 s
        // its centre is at (0.45, 0.1) - in the way of a robot driving on.
        ps.set_movers(std::iter::once(Mover {
            position: Vec2::new(0.45, 0.4),
            velocity: Vec2::new(0.0, -1.0),
            radius_m: 0.2,
        }));
        let c = contact(&mut ps, Twist::new(0.22, 0.0), &[], &p).unwrap();
        assert!(c.mover, "{c:?}");
        // Standing still is passively safe even though it will be hit.
        assert_eq!(contact(&mut ps, Twist::ZERO, &[], &p), None);
        // Backing away from it (velocity away from its centre) is not closing either.
        assert_eq!(contact(&mut ps, Twist::new(-0.05, 0.0), &[], &p), None);
        // The same mover walking away is no obstacle.
        ps.set_movers(std::iter::once(Mover {
            position: Vec2::new(0.45, 0.5),
            velocity: Vec2::new(0.0, 1.0),
            radius_m: 0.2,
        }));
        assert_eq!(contact(&mut ps, Twist::new(0.22, 0.0), &[], &p), None);
    }

    #[test]
    fn the_grown_margin_is_what_makes_a_near_miss_inadmissible() {
        // A (standing) mover 3 cm beyond where the robot comes to rest (4 cm on,
        // at 0.2 m/s) is not touched at its estimated size, but is with a margin.
        let mut p = params();
        let mut ps = PassiveSafety::default();
        ps.set_movers(std::iter::once(Mover {
            position: Vec2::new(0.04 + 0.178 + 0.2 + 0.03, 0.0),
            velocity: Vec2::zeros(),
            radius_m: 0.2,
        }));
        p.passive.mover_margin_m = 0.0;
        p.passive.mover_growth_mps = 0.0;
        assert_eq!(contact(&mut ps, Twist::new(0.2, 0.0), &[], &p), None);
        p.passive.mover_margin_m = 0.025;
        assert_eq!(contact(&mut ps, Twist::new(0.2, 0.0), &[], &p), None);
        p.passive.mover_margin_m = 0.06;
        let c = contact(&mut ps, Twist::new(0.2, 0.0), &[], &p).unwrap();
        assert!(c.mover && (c.closing_speed_mps - 0.2).abs() < 1e-9, "{c:?}");
        // Growth alone does it too: 3 cm by t ≈ 0.14 s needs 0.2 m/s of growth.
        p.passive.mover_margin_m = 0.0;
        p.passive.mover_growth_mps = 0.25;
        assert!(contact(&mut ps, Twist::new(0.2, 0.0), &[], &p).is_some());
    }

    #[test]
    fn evasion_scores_a_rectangle_by_its_own_outline() {
        // A 0.6 x 0.4 m base at rest (circumscribed circle 0.3606 m). A person of
        // radius 0.15 m walks past its left side at 0.3 m/s, 0.5 m from its centre
        // line; margin 0.05 m, no growth, so the grown disc is 0.2 m.
        let mut p = params();
        p.passive.mover_growth_mps = 0.0;
        let mut ps = PassiveSafety::default();
        ps.set_movers(std::iter::once(Mover {
            position: Vec2::new(1.0, 0.5),
            velocity: Vec2::new(-0.3, 0.0),
            radius_m: 0.15,
        }));
        let rectangle = PaddedPolygon::base_0604();
        ps.set_footprint(Some(rectangle.clone()));
        ps.select_reach(&[], &p);
        // The side is at y = 0.2: the person's centre stays 0.3 m from the body, beyond
        // 0.2: no contact in the horizon, and its gap is 0.3 − 0.15 = 0.15 m at closest.
        let rest = ps.evasion_score(Twist::ZERO, &p);
        assert_eq!(rest.time_to_contact_s, 5.0, "{rest:?}");
        // The circle of 0.3606 m: contact once |c| < 0.5606, (1 − 0.3 t)² < 0.0643, t > 2.488
        // (sampled 2.6 s).
        let mut circle = params();
        circle.passive.mover_growth_mps = 0.0;
        circle.footprint.radius_override_m = Some(rectangle.circumscribed_radius_m());
        let mut round = PassiveSafety::default();
        round.set_movers(ps.movers().iter().copied());
        round.select_reach(&[], &circle);
        let disc = round.evasion_score(Twist::ZERO, &circle);
        assert!((disc.time_to_contact_s - 2.6).abs() < 1e-9, "{disc:?}");
        // Turning in place towards it swings the front-left corner into its path: at
        // 0.3 rad/s the corner (0.3, 0.2) is at (0.0, 0.36) at 0.98 rad (3.28 s), as the
        // person passes x = 0.016: 0.14 m from its centre, inside the 0.2 m disc.
        let turn = ps.evasion_score(Twist::new(0.0, 0.3), &p);
        assert!(turn.mover_contact_s < 5.0, "{turn:?}");
        // Backing off straight: the side never comes nearer; no contact.
        assert_eq!(ps.evasion_score(Twist::new(-0.05, 0.0), &p).time_to_contact_s, 5.0);
    }

    #[test]
    fn evasion_prefers_the_command_that_keeps_contact_furthest_off() {
        let mut p = params();
        p.control.allow_reverse = true;
        let mut ps = PassiveSafety::default();
        // Head-on: a person 1 m ahead walking at the robot at 0.3 m/s.
        ps.set_movers(std::iter::once(Mover {
            position: Vec2::new(1.0, 0.0),
            velocity: Vec2::new(-0.3, 0.0),
            radius_m: 0.2,
        }));
        ps.select_reach(&[], &p);
        let stay = ps.evasion_score(Twist::ZERO, &p);
        let back = ps.evasion_score(Twist::new(-0.05, 0.0), &p);
        let ahead = ps.evasion_score(Twist::new(0.22, 0.0), &p);
        // Margin 0.05 m, growth 0.1 m/s, samples 0.2 s apart. Stay: contact when
        // 1 − 0.3 t = 0.178 + 0.2 + 0.05 + 0.1 t → t = 1.43 s (sampled up to 1.6); backing off
        // at 0.05: 1 − 0.25 t = 0.428 + 0.1 t → 1.63 s (1.8); ahead at 0.22: 0.92 s (1.0).
        assert!((stay.time_to_contact_s - 1.6).abs() < 1e-9, "{stay:?}");
        assert!((back.time_to_contact_s - 1.8).abs() < 1e-9, "{back:?}");
        assert!((ahead.time_to_contact_s - 1.0).abs() < 1e-9, "{ahead:?}");
        assert!(back.beats(&stay, 0.1, 0.0), "{back:?} {stay:?}");
        assert!(stay.beats(&ahead, 0.1, 0.0), "{stay:?} {ahead:?}");
        // Every contact here is with the mover.
        for s in [stay, back, ahead] {
            assert_eq!(s.mover_contact_s, s.time_to_contact_s, "{s:?}");
        }
        // Backing off at 0.15 m/s towards a wall 0.378 m behind: the body reaches it after
        // 0.2 / 0.15 = 1.33 s (sampled 1.4 s), before the mover could (1 − 0.15 t =
        // 0.428 + 0.1 t → 2.29 s, sampled 2.4); only the mover's contact is a threat (§5b).
        let wall: Vec<Vec2> = (-5..=5).map(|k| Vec2::new(-0.378, 0.05 * k as f64)).collect();
        ps.select_reach(&wall, &p);
        let flee = ps.evasion_score(Twist::new(-0.15, 0.0), &p);
        assert!((flee.time_to_contact_s - 1.4).abs() < 1e-9, "{flee:?}");
        assert!((flee.mover_contact_s - 2.4).abs() < 1e-9, "{flee:?}");
        // No mover: every command scores the horizon, and none beats another.
        ps.set_movers(std::iter::empty());
        let a = ps.evasion_score(Twist::ZERO, &p);
        let b = ps.evasion_score(Twist::new(0.2, 0.1), &p);
        assert_eq!(a.time_to_contact_s, 5.0);
        assert!(!a.beats(&b, 0.2, 0.02) && !b.beats(&a, 0.2, 0.02));
    }

    #[test]
    fn line_deficit_measures_how_far_a_command_leaves_the_line_of_a_mover_coming_at_it() {
        let p = params();
        let mut ps = PassiveSafety::default();
        let one = |ps: &mut PassiveSafety, position: Vec2, velocity: Vec2| {
            ps.set_movers(std::iter::once(Mover {
                position,
                velocity,
                radius_m: 0.2,
            }));
            ps.select_reach(&[], &p);
        };
        // A person 1 m ahead walking at the robot at 0.1 m/s: reaches it within the
        // 6 s look-ahead (1 − 0.428 = 0.572 ≤ (0.1 + 0.22)·6 = 1.92 m). Room needed beside
        // its line: r + r_o + margin = 0.178 + 0.2 + 0.05 = 0.428 m.
        one(&mut ps, Vec2::new(1.0, 0.0), Vec2::new(-0.1, 0.0));
        let stay = ps.evasion_score(Twist::ZERO, &p);
        let back = ps.evasion_score(Twist::new(-0.1, 0.0), &p);
        // Backing on an arc, v = −0.1, ω = 0.3 for the 5 s horizon: y = (v/ω)(1 − cos 1.5)
        // = −0.3098 m off the line, so 0.428 − 0.3098 = 0.1182 m still inside it.
        let arc = ps.evasion_score(Twist::new(-0.1, 0.3), &p);
        assert!((stay.line_deficit_m - 0.428).abs() < 1e-9, "{stay:?}");
        assert!((back.line_deficit_m - 0.428).abs() < 1e-9, "{back:?}");
        let y = (-0.1 / 0.3) * (1.0 - 1.5f64.cos());
        assert!((arc.line_deficit_m - (0.428 + y)).abs() < 1e-9, "{arc:?}");
        assert!((arc.line_deficit_m - 0.1182).abs() < 1e-3, "{arc:?}");
        // The same from behind (overtaking) or straight from the side: the robot is in
        // the line either way.
        for (pos, vel) in [
            (Vec2::new(-1.0, 0.0), Vec2::new(0.1, 0.0)),
            (Vec2::new(0.0, 1.0), Vec2::new(0.0, -0.1)),
        ] {
            one(&mut ps, pos, vel);
            let s = ps.evasion_score(Twist::ZERO, &p);
            assert!((s.line_deficit_m - 0.428).abs() < 1e-9, "{pos:?} {vel:?} {s:?}");
        }
        // No line to leave: the robot already beside it (0.5 ≥ 0.428 m), the mover
        // walking away, crossing ahead (more than 45° off straight at the robot), or too
        // far to arrive within the look-ahead.
        for (pos, vel) in [
            (Vec2::new(1.0, 0.5), Vec2::new(-0.1, 0.0)),
            (Vec2::new(1.0, 0.0), Vec2::new(0.1, 0.0)),
            (Vec2::new(1.5, 1.0), Vec2::new(0.0, -0.1)),
            (Vec2::new(2.4, 0.0), Vec2::new(-0.1, 0.0)), // 2.4 − 0.428 > 1.92 m
        ] {
            one(&mut ps, pos, vel);
            let s = ps.evasion_score(Twist::ZERO, &p);
            assert_eq!(s.line_deficit_m, 0.0, "{pos:?} {vel:?} {s:?}");
        }
    }
}

/// The braking check and the evasion score as first written, every mover
/// looked at at every sample with its root: the plain references the fast
/// paths (movers out of reach left out, roots only where they decide) are
/// compared with, bit for bit.
#[cfg(test)]
impl PassiveSafety {
    fn reference_closing_contact(&mut self, cmd: Twist, p: &Params) -> Option<ClosingContact> {
        self.braking_path(cmd, p);
        let last = self.path.last()?;
        let r = p.robot_radius_m();
        let threshold = 0.5 * p.passive.closing_speed_mps;
        // Only points the body can reach on this path matter: within r of a path
        // no longer than the time it takes at the starting speed.
        let reach = r + cmd.v_mps.abs() * last.t_s + SAMPLE_SPACING_M;
        let (r2, reach2) = (r * r, reach * reach);
        let ru = r + UNSEEN_MARGIN_M;
        let (ru2, reach_u2) = (ru * ru, (reach + UNSEEN_MARGIN_M).powi(2));
        // The points this path can reach, with the contact radius of each, once.
        self.scratch.clear();
        let seen = self
            .near_seen
            .iter()
            .filter(|q| q.norm_squared() <= reach2)
            .map(|q| (*q, r2));
        let unseen = self
            .near_unseen
            .iter()
            .filter(|q| q.norm_squared() <= reach_u2)
            .map(|q| (*q, ru2));
        self.scratch.extend(seen.chain(unseen));
        for s in &self.path {
            for &(q, r2) in &self.scratch {
                let d = q - s.pos;
                let d2 = d.norm_squared();
                if d2 < r2 {
                    let towards = if d2 > 0.0 {
                        s.vel.dot(&d) / d2.sqrt()
                    } else {
                        s.vel.norm()
                    };
                    if towards > threshold {
                        return Some(ClosingContact {
                            t_s: s.t_s,
                            closing_speed_mps: towards,
                            mover: false,
                        });
                    }
                }
            }
            for m in &self.movers {
                let c = m.position + m.velocity * s.t_s;
                let reach_m = r + m.radius_m + p.passive.mover_margin_m + p.passive.mover_growth_mps * s.t_s;
                let d = c - s.pos;
                let dist = d.norm();
                if dist < reach_m {
                    let towards = if dist > 0.0 { s.vel.dot(&d) / dist } else { s.vel.norm() };
                    if towards > threshold {
                        return Some(ClosingContact {
                            t_s: s.t_s,
                            closing_speed_mps: towards,
                            mover: true,
                        });
                    }
                }
            }
        }
        None
    }

    fn reference_evasion_score(&self, cmd: Twist, p: &Params) -> EvasionScore {
        let fp = self.footprint.as_ref();
        let r = p.robot_radius_m();
        let horizon = p.passive.evasion_horizon_s;
        let threshold = 0.5 * p.passive.closing_speed_mps;
        let n = (horizon / EVASION_SAMPLE_S).ceil().max(1.0) as usize;
        let mut contact: Option<f64> = None;
        let mut mover_contact: Option<f64> = None;
        let mut gap_sum = 0.0;
        let speed = cmd.v_mps.abs();
        let mut walk = ArcWalk::new(cmd, horizon / n as f64);
        for k in 0..=n {
            let t = horizon * k as f64 / n as f64;
            if k > 0 {
                walk.step();
            }
            let pos = walk.pos;
            let vel = walk.heading * cmd.v_mps;
            let pose = PathPose {
                t_s: t,
                pos,
                heading: walk.heading,
                vel,
                omega_radps: cmd.omega_radps,
            };
            let mut gap = f64::INFINITY;
            for m in &self.movers {
                let c = m.position + m.velocity * t;
                let grown = m.radius_m + p.passive.mover_margin_m + p.passive.mover_growth_mps * t;
                let (body_gap, touches) = mover_gap(fp, r, &pose, c, m.radius_m, grown);
                gap = gap.min(body_gap);
                if touches {
                    contact = contact.or(Some(t));
                    mover_contact = mover_contact.or(Some(t));
                }
            }
            if k > 0 {
                gap_sum += gap.min(GAP_CAP_M);
                // Every sample, every point: no skip and no bound.
                let moving = speed > 0.0 || (fp.is_some() && cmd.omega_radps != 0.0);
                if contact.is_none() && moving {
                    let static_hit = self.reach.iter().any(|q| match fp {
                        None => {
                            let d = q - pos;
                            let d2 = d.norm_squared();
                            d2 < r * r && vel.dot(&d) > threshold * d2.sqrt()
                        }
                        Some(fp) => polygon_closes_on(fp, &pose, *q, threshold),
                    });
                    if static_hit {
                        contact = Some(t);
                    }
                }
            }
        }
        // The sidestep part has no fast path: shared with `score_evasion`.
        EvasionScore {
            line_deficit_m: self.line_deficit(walk.pos, walk.heading, p),
            time_to_contact_s: contact.unwrap_or(horizon),
            mover_contact_s: mover_contact.unwrap_or(horizon),
            mover_gap_m: if self.movers.is_empty() {
                f64::INFINITY
            } else {
                gap_sum / n as f64
            },
        }
    }
}

#[cfg(test)]
mod fast_path_properties {
    use super::*;
    use proptest::prelude::*;

    /// Movers anywhere in a room, and movers right at the edge of reach:
    /// 0.4-0.8 m out, where the braking path's own travel decides.
    fn mover() -> impl Strategy<Value = Mover> {
        let position = prop_oneof![
            (-4.0f64..4.0, -4.0f64..4.0),
            (0.4f64..0.8, -std::f64::consts::PI..std::f64::consts::PI).prop_map(|(d, a)| (d * a.cos(), d * a.sin())),
        ];
        (position, -0.4f64..0.4, -0.4f64..0.4, 0.05f64..0.3).prop_map(|((x, y), vx, vy, r)| Mover {
            position: Vec2::new(x, y),
            velocity: Vec2::new(vx, vy),
            radius_m: r,
        })
    }

    fn command() -> impl Strategy<Value = Twist> {
        (
            prop_oneof![Just(0.0), Just(0.22), Just(-0.15), -0.15f64..0.22],
            prop_oneof![Just(0.0), Just(0.3), Just(-0.3), -0.3f64..0.3],
        )
            .prop_map(|(v, w)| Twist::new(v, w))
    }

    fn bits(s: &EvasionScore) -> [u64; 4] {
        [
            s.time_to_contact_s.to_bits(),
            s.mover_contact_s.to_bits(),
            s.mover_gap_m.to_bits(),
            s.line_deficit_m.to_bits(),
        ]
    }

    #[test]
    fn a_mover_reached_only_by_the_robots_own_travel_is_still_checked() {
        // At rest 0.47 m ahead, radius 0.2: its disc grown for the braking path's
        // 0.32 s reaches 0.178 + 0.2 + 0.05 + 0.1 · 0.32 = 0.46 m, so it is out of
        // reach of a robot standing still. Driving at it at 0.22 m/s, the robot is
        // 0.039 m on at 0.2 s, still closing at 0.12 m/s, within 0.448 m of it.
        let p = Params::default();
        let mut ps = PassiveSafety::with_capacity(4, 4);
        ps.set_movers(std::iter::once(Mover {
            position: Vec2::new(0.47, 0.0),
            velocity: Vec2::zeros(),
            radius_m: 0.2,
        }));
        ps.set_phantoms(&[]);
        ps.prepare(&[], &p);
        let cmd = Twist::new(0.22, 0.0);
        let reference = ps.reference_closing_contact(cmd, &p);
        assert!(reference.is_some_and(|c| c.mover), "{reference:?}");
        assert_eq!(ps.closing_contact(cmd, &p), reference);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(1500))]

        #[test]
        fn braking_checks_and_evasion_scores_match_their_references(
            movers in prop::collection::vec(mover(), 0..12),
            points in prop::collection::vec((-2.0f64..2.0, -2.0f64..2.0), 0..40),
            phantoms in prop::collection::vec((-1.0f64..1.0, -1.0f64..1.0), 0..4),
            commands in prop::collection::vec(command(), 1..6),
            growth in prop_oneof![Just(0.1), 0.0f64..1.0],
            horizon in prop_oneof![Just(4.0), 0.5f64..10.0],
            rectangle in prop_oneof![Just(None), (0.2f64..0.9, 0.2f64..0.7, -0.2f64..0.2, 0.0f64..0.05).prop_map(Some)],
        ) {
            let mut p = Params::default();
            p.passive.mover_growth_mps = growth;
            p.passive.evasion_horizon_s = horizon;
            let points: Vec<Vec2> = points.into_iter().map(|(x, y)| Vec2::new(x, y)).collect();
            let phantoms: Vec<Vec2> = phantoms.into_iter().map(|(x, y)| Vec2::new(x, y)).collect();
            let mut ps = PassiveSafety::with_capacity(16, 64);
            // A rectangular footprint (length, width, centre ahead, padding) or the circle.
            let footprint = rectangle.map(|(l, w, cx, padding_m)| PaddedPolygon {
                polygon: crate::algo::footprint::Polygon::rectangle(l, w, cx).unwrap(),
                padding_m,
            });
            ps.set_footprint(footprint.clone());
            ps.set_movers(movers.iter().copied());
            ps.set_phantoms(&phantoms);
            ps.prepare(&points, &p);
            // The polygon's braking check has tests of its own (braking_polygon.rs).
            if footprint.is_none() {
                for &cmd in &commands {
                    let fast = ps.closing_contact(cmd, &p);
                    prop_assert_eq!(fast, ps.reference_closing_contact(cmd, &p), "{:?}", cmd);
                }
            }
            ps.select_reach(&points, &p);
            for &cmd in &commands {
                let fast = ps.evasion_score(cmd, &p);
                prop_assert_eq!(bits(&fast), bits(&ps.reference_evasion_score(cmd, &p)), "{:?}", cmd);
            }
        }

        /// The f32 bound on the nearest point never exceeds the exact distance
        /// (so a sample it clears has no contact), and is within 2 × its slack of
        /// it (so it clears what it can).
        #[test]
        fn the_nearest_point_bound_is_a_tight_lower_bound(
            points in prop::collection::vec((-1.5f64..1.5, -1.5f64..1.5), 1..40),
            pos in (-1.2f64..1.2, -1.2f64..1.2),
            near in prop_oneof![Just(None), (0.0f64..std::f64::consts::TAU, 0.17f64..0.19).prop_map(Some)],
        ) {
            let p = Params::default();
            let pos = Vec2::new(pos.0, pos.1);
            let mut points: Vec<Vec2> = points.into_iter().map(|(x, y)| Vec2::new(x, y)).collect();
            // One point right at the contact radius from the sample, where it matters.
            if let Some((a, d)) = near {
                points.push(pos + Vec2::new(a.cos(), a.sin()) * d);
            }
            let mut ps = PassiveSafety::with_capacity(1, 64);
            ps.select_reach(&points, &p);
            let exact = ps.reach.iter().map(|q| (q - pos).norm()).fold(f64::INFINITY, f64::min);
            let bound = ps.nearest_lower_bound_m(pos);
            prop_assert!(bound <= exact, "{} > {}", bound, exact);
            if exact.is_finite() {
                prop_assert!(bound >= exact - 2.0 * F32_SLACK_M, "{} vs {}", bound, exact);
            }
        }
    }
}
