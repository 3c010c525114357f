//! The passive-safety search (ALGORITHM §5b): which command to send when
//! the DTCBF's own fails the braking check, and evasion when a mover
//! closes in. A child of the pipeline module: it works on the pipeline's
//! state (points, movers, last command) as the rest of a step does.

use super::{next_points, SafetyPipeline};
use crate::algo::dtcbf::{motion_direction, DtcbfOutcome, InputBox};
use crate::algo::geometry::{Twist, Vec2};
use crate::algo::params::Params;
use crate::algo::passive::{EvasionScore, PassiveSafety};
use crate::algo::record::Infeasibility;

/// Numerical tolerance on the DTCBF condition (m), as in the filter.
pub(super) const TOL_M: f64 = 1e-9;
/// Linear speeds tried per yaw rate by the passive-safety search (plus 0).
pub(super) const PASSIVE_SPEEDS: usize = 10;
/// Evasion candidates ending within this of each other's line deficit tie (m).
const LINE_TIE_M: f64 = 0.01;
/// Yaw rates tried by evasion.
pub(super) const EVASION_OMEGAS: usize = 5;
/// Evasion must also gain this much least gap (m) when it cannot gain time.
pub(super) const EVASION_MIN_GAP_GAIN_M: f64 = 0.02;

/// One command of the passive-safety search, weighed as far as needed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Lazy {
    cmd: Twist,
    /// Its predicted displacement over one step (m), for h(k+1).
    disp: Vec2,
    /// Distance from the DOAA command (m²).
    cost: f64,
    h_next_m: f64,
    condition: bool,
    /// The braking check, once done.
    passive: Option<bool>,
}

impl Lazy {
    fn weighed(&self) -> Candidate {
        Candidate {
            cmd: self.cmd,
            h_next_m: self.h_next_m,
            condition: self.condition,
            passive: self.passive.unwrap_or(false),
        }
    }
}

/// One command the passive-safety search weighed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Candidate {
    cmd: Twist,
    h_next_m: f64,
    /// Meets the (logged) one-step condition h(k+1) ≥ (1 − γ) h(k).
    /// the escape rule h(k+1) ≥ h(k) + ε).
    condition: bool,
    /// No predicted closing contact.
    passive: bool,
}

impl SafetyPipeline {
    /// Weighs `cmd`: its predicted h(k+1) and both checks.
    fn weigh(&mut self, cmd: Twist, h: f64) -> Candidate {
        let (h_next_m, condition) = self.condition(cmd, h);
        let passive = self.passive.closing_contact(cmd, &self.params).is_none();
        Candidate {
            cmd,
            h_next_m,
            condition,
            passive,
        }
    }

    /// `cmd`'s predicted h(k+1) (m) and whether it meets the logged one-step
    /// condition, the one the record and the tests judge.
    fn condition(&self, cmd: Twist, h: f64) -> (f64, bool) {
        let p = &self.params;
        let h_next = self.filter.h_next(self.points_next(), cmd, p);
        (h_next, !h.is_finite() || h_next >= (1.0 - p.dtcbf.gamma) * h - TOL_M)
    }

    /// [`Self::condition`] of the command whose one-step displacement is `disp`
    /// (`predicted_displacement` of it), bit for bit.
    fn condition_at(&self, disp: Vec2, h: f64) -> (f64, bool) {
        let p = &self.params;
        let h_next = self.filter.h_next_at(self.points_next(), disp, p);
        (h_next, !h.is_finite() || h_next >= (1.0 - p.dtcbf.gamma) * h - TOL_M)
    }

    /// The command closest to the DOAA's `desired` that meets both checks,
    /// over the DTCBF's ω grid and a grid of speeds; else the passively safe
    /// one keeping h(k+1) highest (ties: the closest); else `own` if it is
    /// passively safe, else a turn in place. Candidates are weighed in the
    /// order they could win, each check only when it can still decide, which
    /// picks what weighing all of them would.
    fn closest_admissible(&mut self, out: &DtcbfOutcome, desired: Twist, bx: &InputBox, own: Candidate) -> Candidate {
        let h = out.h_m;
        let w = self.params.dtcbf.omega_weight_m2_per_rad2;
        let cost = |c: Twist| (c.v_mps - desired.v_mps).powi(2) + w * (c.omega_radps - desired.omega_radps).powi(2);
        self.candidates.clear();
        let n = self.params.dtcbf.omega_candidates;
        let omegas = [out.cmd.omega_radps, desired.omega_radps]
            .into_iter()
            .chain((0..n).map(|k| grid(-bx.omega_max, bx.omega_max, k, n)));
        let (model, dt) = (self.params.dtcbf.prediction, self.params.control.dt_s());
        for omega in omegas {
            let omega = omega.clamp(-bx.omega_max, bx.omega_max);
            // One direction per yaw rate, shared by its speeds (as `predicted_displacement`).
            let direction = motion_direction(model, omega, dt);
            for j in 0..=PASSIVE_SPEEDS + 1 {
                let v = if j == 0 {
                    0.0
                } else {
                    grid(bx.v_lo, bx.v_hi, j - 1, PASSIVE_SPEEDS + 1)
                };
                let cmd = Twist::new(v, omega);
                self.candidates.push(Lazy {
                    cmd,
                    disp: displacement(direction, v),
                    cost: cost(cmd),
                    h_next_m: f64::NAN,
                    condition: false,
                    passive: None,
                });
            }
        }
        // Every candidate's h(k+1) and condition: the second search needs them all, and
        // in most searches no candidate meets both checks, so the first weighs them all.
        for i in 0..self.candidates.len() {
            let (h_next_m, condition) = self.condition_at(self.candidates[i].disp, h);
            let c = &mut self.candidates[i];
            (c.h_next_m, c.condition) = (h_next_m, condition);
        }
        // Those meeting the condition, closest first; among equals the first generated
        // (as `min_by` would): the first passively safe one is the closest meeting both.
        order_by_cost(&self.candidates, &mut self.order);
        for k in 0..self.order.len() {
            let i = self.order[k] as u32 as usize;
            if self.passive_of(i) {
                return self.candidates[i].weighed();
            }
        }
        if own.passive {
            // The DTCBF's own fallback (least bad, or a turn in place) drives into nothing.
            return own;
        }
        // Highest h(k+1), then closest; among equals the last generated (as `max_by` would).
        // The first few by selection (the search mostly ends at the first), then the
        // rest sorted: the same order as sorting them all.
        order_by_h_next(&self.candidates, &mut self.order_h);
        let n = self.order_h.len();
        for k in 0..n {
            settle_next(&mut self.order_h, k);
            let i = (u32::MAX - self.order_h[k].2) as usize;
            if self.passive_of(i) {
                return self.candidates[i].weighed();
            }
        }
        Candidate {
            cmd: Twist::new(0.0, out.cmd.omega_radps),
            ..own
        }
    }

    /// Candidate `i`'s braking check, done once.
    fn passive_of(&mut self, i: usize) -> bool {
        if let Some(passive) = self.candidates[i].passive {
            return passive;
        }
        let passive = self
            .passive
            .closing_contact(self.candidates[i].cmd, &self.params)
            .is_none();
        self.candidates[i].passive = Some(passive);
        passive
    }

    /// Passive motion safety and evasion (§5b) on the DTCBF's outcome `out`
    /// for the DOAA command `desired`. Returns the outcome to send, whether
    /// this changed the command, and whether the robot is evading; updates
    /// `infeasibility` when no command meets both checks.
    pub(super) fn passive_safety(
        &mut self,
        out: DtcbfOutcome,
        desired: Twist,
        bx: &InputBox,
        infeasibility: &mut Option<Infeasibility>,
    ) -> (DtcbfOutcome, bool, bool) {
        let h = out.h_m;
        let stall = self.params.passive.closing_speed_mps;
        let horizon = self.params.passive.evasion_horizon_s;
        let own = self.weigh(out.cmd, h);
        // Threatened: a mover's predicted disc reaches the robot within the evasion
        // horizon if it keeps the DTCBF's command.
        let movers = !self.passive.movers().is_empty();
        if movers {
            self.passive.select_reach(
                next_points(self.any_advanced, &self.points_next, &self.points.points),
                &self.params,
            );
        }
        // Threatened: contact with a mover predicted within the collision-cone look-ahead
        // (the evasion horizon, longer, only ranks the ways out). A static point the
        // held command would reach is not a threat: the DTCBF steers round it step by
        // step, and counting it had evasion stop an escape from the unsafe set whenever
        // any mover was in sight (slow_obstacles seed 1, world 11).
        let trigger = self.params.obstacles.lookahead_s.min(horizon);
        let threatened = |ps: &mut PassiveSafety, cmd: Twist, p: &Params| {
            movers && ps.evasion_score(cmd, p).mover_contact_s < trigger
        };
        let closing_in = !self.threats.is_empty();
        let stalled = out.infeasible || out.cmd.v_mps.abs() < stall;
        if own.passive && !(closing_in && stalled) && !threatened(&mut self.passive, out.cmd, &self.params) {
            return (out, false, false);
        }
        let mut chosen = own;
        if !own.passive || out.infeasible {
            chosen = self.closest_admissible(&out, desired, bx, own);
        }
        // Evasion: a mover's predicted disc reaches the robot within the horizon, or a
        // mover closes on a robot that cannot go forward. Among the commands as
        // admissible as the chosen one: the latest predicted contact; among those with
        // none within the horizon, the closest to the DOAA command. Smooth steering
        // (§4b): a command whose yaw rate jumps by more than ω_max from the last one
        // sent is taken only if it gains `evasion_min_gain_s` of time to contact over
        // the best command that does not jump (grid neighbours score alike, and a
        // swerve that reverses the turn every step gains nothing).
        let mut evading = false;
        let chosen_stalled = out.infeasible || chosen.cmd.v_mps.abs() < stall;
        if movers && ((closing_in && chosen_stalled) || threatened(&mut self.passive, chosen.cmd, &self.params)) {
            let p = &self.params;
            let w = p.dtcbf.omega_weight_m2_per_rad2;
            let cost = |c: Twist| (c.v_mps - desired.v_mps).powi(2) + w * (c.omega_radps - desired.omega_radps).powi(2);
            let current = self.passive.evasion_score(chosen.cmd, p);
            let (min_gain_s, tier_both) = (p.passive.evasion_min_gain_s, chosen.condition && chosen.passive);
            // The DTCBF's noise margin δ (§5): evasion may replace a command that kept it
            // only by one that keeps it too. Without it, a track on a static object that
            // looked like a mover had the robot evade at the very edge of the condition,
            // and the true geometry broke it by 0.3 mm (soak_static, seed 1, world 233).
            let delta = p.dtcbf.noise_margin_m;
            let margin_target = (h.is_finite() && h >= 0.0).then_some((1.0 - p.dtcbf.gamma) * (h - delta) + delta);
            let keeps_margin = move |h_next: f64| margin_target.is_none_or(|t| h_next >= t - TOL_M);
            let tier_margin = tier_both && keeps_margin(chosen.h_next_m);
            let (last_omega, jump) = (self.last_cmd.omega_radps, p.control.omega_max_radps);
            let smooth = |c: Twist| (c.omega_radps - last_omega).abs() <= jump + 1e-9;
            let (mut best, mut best_score) = (chosen, current);
            let mut smooth_best = smooth(chosen.cmd).then_some((chosen, current));
            let speeds = [bx.v_lo, 0.5 * bx.v_hi, bx.v_hi];
            for k in 0..EVASION_OMEGAS {
                let omega = grid(-bx.omega_max, bx.omega_max, k, EVASION_OMEGAS);
                for v in speeds.into_iter().chain(std::iter::once(0.0)) {
                    let cmd = Twist::new(v, omega);
                    // A command no closer to the DOAA's than a best that keeps clear of every
                    // mover and out of every head-on line cannot displace it, whatever its
                    // score (`ahead`: a later contact is impossible, a tie goes to the cost):
                    // when that holds for both bests it may update, it is not weighed at all.
                    let settled = |b: &Candidate, s: &EvasionScore| {
                        s.time_to_contact_s >= horizon && s.line_deficit_m <= 0.0 && cost(cmd) >= cost(b.cmd)
                    };
                    if settled(&best, &best_score)
                        && (!smooth(cmd) || smooth_best.as_ref().is_some_and(|(b, s)| settled(b, s)))
                    {
                        continue;
                    }
                    // The cheap condition first: a command it rules out needs no braking check.
                    let (h_next_m, condition) = self.condition(cmd, h);
                    if (tier_both && !condition) || (tier_margin && !keeps_margin(h_next_m)) {
                        continue;
                    }
                    let passive = self.passive.closing_contact(cmd, &self.params).is_none();
                    if !passive {
                        continue;
                    }
                    let c = Candidate {
                        cmd,
                        h_next_m,
                        condition,
                        passive,
                    };
                    let score = self.passive.evasion_score(c.cmd, &self.params);
                    let ahead = |b: &Candidate, b_score: &EvasionScore| {
                        if score.time_to_contact_s >= horizon && b_score.time_to_contact_s >= horizon {
                            // Both keep clear: the one ending further out of a head-on
                            // mover's line (by 1 cm), then the closest to the DOAA command.
                            let (da, db) = (score.line_deficit_m.max(0.0), b_score.line_deficit_m.max(0.0));
                            if (da - db).abs() > LINE_TIE_M {
                                da < db
                            } else {
                                cost(c.cmd) < cost(b.cmd)
                            }
                        } else {
                            better(&score, b_score)
                        }
                    };
                    if ahead(&best, &best_score) {
                        (best, best_score) = (c, score);
                    }
                    if smooth(cmd) && smooth_best.as_ref().is_none_or(|(b, bs)| ahead(b, bs)) {
                        smooth_best = Some((c, score));
                    }
                }
            }
            if let Some((sb, sb_score)) = smooth_best {
                if !best_score.beats(&sb_score, min_gain_s, EVASION_MIN_GAP_GAIN_M) {
                    (best, best_score) = (sb, sb_score);
                }
            }
            if best_score.beats(&current, min_gain_s, EVASION_MIN_GAP_GAIN_M) {
                chosen = best;
                evading = true;
            }
        }
        if chosen.condition && chosen.passive {
            // The DTCBF's own search knows nothing of the movers' futures and uses
            // stricter targets than the logged condition: a command meeting both
            // makes the step feasible after all.
            *infeasibility = None;
        } else if infeasibility.is_none() {
            *infeasibility = Some(Infeasibility::NoPassiveCommand);
        }
        if chosen.cmd == out.cmd {
            let out = DtcbfOutcome {
                infeasible: infeasibility.is_some(),
                ..out
            };
            return (out, false, evading);
        }
        let target = (1.0 - self.params.dtcbf.gamma) * h;
        let new = DtcbfOutcome {
            cmd: chosen.cmd,
            h_next_m: chosen.h_next_m,
            changed: true,
            condition_held: !h.is_finite() || chosen.h_next_m >= target - TOL_M,
            infeasible: infeasibility.is_some(),
            ..out
        };
        (new, true, evading)
    }
}

/// The one-step displacement at speed `v` (m/s) along `motion_direction`'s
/// (u, κ) of the yaw rate: `predicted_displacement` of (v, ω), bit for bit.
#[inline]
fn displacement((u, kappa): (Vec2, f64), v: f64) -> Vec2 {
    u * (kappa * v)
}

/// `x` as an unsigned integer in the order of `f64::total_cmp` (the same bit
/// flips `total_cmp` makes, then the sign bit flipped so signed order becomes
/// unsigned order): sorting by it sorts as `total_cmp` does, with integer
/// comparisons instead of a comparison closure.
#[inline]
fn total_key(x: f64) -> u64 {
    let b = x.to_bits() as i64;
    let t = b ^ ((((b >> 63) as u64) >> 1) as i64);
    (t as u64) ^ (1 << 63)
}

/// The indices of the candidates meeting the condition, by cost
/// (`f64::total_cmp`), ties in index order, each in the low 32 bits of its
/// key: the unique order of
/// `sort_unstable_by(|a, b| a.cost.total_cmp(&b.cost).then(a.index.cmp(&b.index)))`.
fn order_by_cost(candidates: &[Lazy], order: &mut Vec<u128>) {
    order.clear();
    order.extend(
        candidates
            .iter()
            .enumerate()
            .filter(|(_, c)| c.condition)
            .map(|(i, c)| ((total_key(c.cost) as u128) << 32) | i as u128),
    );
    order.sort_unstable();
}

/// Keys of the candidates by highest h(k+1), then lowest cost, then highest
/// index (all by `f64::total_cmp`), whose third part is `u32::MAX − index`:
/// ascending keys are that order. Unsorted; the caller orders them.
fn order_by_h_next(candidates: &[Lazy], order: &mut Vec<(u64, u64, u32)>) {
    order.clear();
    order.extend(
        candidates
            .iter()
            .enumerate()
            .map(|(i, c)| (!total_key(c.h_next_m), total_key(c.cost), u32::MAX - i as u32)),
    );
}

/// The second search takes this many candidates by selection before sorting
/// the rest (it ends at its first candidate in about half the searches).
const SELECT_FIRST: usize = 4;

/// Puts the `k`-th smallest key at `k`, given that `keys[..k]` already hold
/// the `k` smallest in order (called for k = 0, 1, 2, … in turn): the first
/// [`SELECT_FIRST`] by selection, then the rest by one sort.
fn settle_next<K: Ord + Copy>(keys: &mut [K], k: usize) {
    if k < SELECT_FIRST {
        let least = (k..keys.len()).min_by_key(|&j| keys[j]).unwrap_or(k);
        keys.swap(k, least);
    } else if k == SELECT_FIRST {
        keys[k..].sort_unstable();
    }
}

/// Point k of n evenly spaced over [lo, hi] (n ≥ 2).
fn grid(lo: f64, hi: f64, k: usize, n: usize) -> f64 {
    lo + (hi - lo) * k as f64 / (n - 1) as f64
}

/// Strictly better evasion score: later contact, or the same and more room.
fn better(a: &EvasionScore, b: &EvasionScore) -> bool {
    let dt = a.time_to_contact_s - b.time_to_contact_s;
    if dt.abs() > 1e-9 {
        dt > 0.0
    } else {
        a.mover_gap_m > b.mover_gap_m + 1e-9
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algo::dtcbf::predicted_displacement;
    use crate::algo::params::PredictionModel;
    use proptest::prelude::*;

    /// The orderings as they were first written: comparison closures over (index, key).
    fn reference_by_cost(candidates: &[Lazy]) -> Vec<u32> {
        let mut order: Vec<(u32, f64)> = candidates.iter().enumerate().map(|(i, c)| (i as u32, c.cost)).collect();
        order.sort_unstable_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
        order.into_iter().map(|(i, _)| i).collect()
    }

    fn reference_by_h_next(candidates: &[Lazy]) -> Vec<u32> {
        let mut order: Vec<(u32, f64)> = candidates
            .iter()
            .enumerate()
            .map(|(i, c)| (i as u32, c.h_next_m))
            .collect();
        order.sort_unstable_by(|a, b| {
            let (ca, cb) = (&candidates[a.0 as usize], &candidates[b.0 as usize]);
            cb.h_next_m
                .total_cmp(&ca.h_next_m)
                .then(ca.cost.total_cmp(&cb.cost))
                .then(b.0.cmp(&a.0))
        });
        order.into_iter().map(|(i, _)| i).collect()
    }

    /// Values with many ties and every special case `total_cmp` orders.
    fn key() -> impl Strategy<Value = f64> {
        prop_oneof![
            prop::sample::select(vec![
                0.0,
                -0.0,
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::NAN,
                -f64::NAN,
                f64::MIN_POSITIVE,
                -f64::MIN_POSITIVE,
                5e-324,
                -5e-324,
                f64::MAX,
                f64::MIN,
                1.0,
                -1.0,
            ]),
            (-4i32..4).prop_map(|k| k as f64 * 0.25),
            any::<f64>(),
        ]
    }

    fn lazy(cost: f64, h_next_m: f64, condition: bool) -> Lazy {
        Lazy {
            cmd: Twist::ZERO,
            disp: Vec2::zeros(),
            cost,
            h_next_m,
            condition,
            passive: None,
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]

        #[test]
        fn integer_keys_order_the_candidates_as_the_comparison_closures(
            keys in prop::collection::vec((key(), key(), any::<bool>()), 0..300)
        ) {
            let candidates: Vec<Lazy> = keys.iter().map(|&(c, h, ok)| lazy(c, h, ok)).collect();
            let mut order = Vec::new();
            order_by_cost(&candidates, &mut order);
            let got: Vec<u32> = order.iter().map(|&k| k as u32).collect();
            let meeting: Vec<u32> = reference_by_cost(&candidates)
                .into_iter()
                .filter(|&i| candidates[i as usize].condition)
                .collect();
            prop_assert_eq!(got, meeting);
            let mut order_h = Vec::new();
            order_by_h_next(&candidates, &mut order_h);
            for k in 0..order_h.len() {
                settle_next(&mut order_h, k);
            }
            let got: Vec<u32> = order_h.iter().map(|k| u32::MAX - k.2).collect();
            prop_assert_eq!(got, reference_by_h_next(&candidates));
        }

        #[test]
        fn one_direction_per_yaw_rate_gives_each_speed_its_displacement_bit_for_bit(
            v in prop_oneof![Just(0.0), Just(-0.0), -2.0f64..2.0, any::<f64>()],
            omega in prop_oneof![Just(0.0), -1e-5f64..1e-5, -4.0f64..4.0],
            dt in 0.01f64..0.5,
            arc in any::<bool>(),
        ) {
            let model = if arc { PredictionModel::Arc } else { PredictionModel::Euler };
            let fast = displacement(motion_direction(model, omega, dt), v);
            // As `predicted_displacement` was written, and as it is.
            let (u, kappa) = motion_direction(model, omega, dt);
            for reference in [u * (kappa * v), predicted_displacement(model, Twist::new(v, omega), dt)] {
                prop_assert_eq!(fast.x.to_bits(), reference.x.to_bits());
                prop_assert_eq!(fast.y.to_bits(), reference.y.to_bits());
            }
        }
    }
}
