//! Aggregation of per-world outcomes into one row per controller: rates,
//! percentiles and means.
//!
//! Why explicit definitions: a paper table is only comparable if its
//! statistics are stated. Percentiles interpolate linearly between order
//! statistics (numpy's default, "type 7"): the p-th percentile of n sorted
//! values x₀ ≤ … ≤ x₍ₙ₋₁₎ is x at the fractional rank p/100 · (n − 1). NaN
//! values are ignored everywhere; an empty set has no percentile or mean
//! (`None`, `null` in JSON).

use super::WorldOutcome;
use crate::sim::figures::MotionQuality;
use crate::sim::run::Controller;
use serde::Serialize;

/// The p-th percentile (p in [0, 100]) of the non-NaN `values`, linearly
/// interpolated; `None` if there are none or p is out of range.
pub fn percentile(values: impl IntoIterator<Item = f64>, p: f64) -> Option<f64> {
    let mut v: Vec<f64> = values.into_iter().filter(|x| !x.is_nan()).collect();
    v.sort_by(f64::total_cmp);
    percentile_of_sorted(&v, p)
}

/// As [`percentile`], of values already sorted ascending (no NaN).
pub fn percentile_of_sorted(sorted: &[f64], p: f64) -> Option<f64> {
    if sorted.is_empty() || !(0.0..=100.0).contains(&p) {
        return None;
    }
    let rank = p / 100.0 * (sorted.len() - 1) as f64;
    let lo = rank.floor() as usize;
    let hi = rank.ceil() as usize;
    let frac = rank - lo as f64;
    if lo == hi {
        return Some(sorted[lo]);
    }
    Some(sorted[lo] + frac * (sorted[hi] - sorted[lo]))
}

/// Mean of the non-NaN `values`; `None` if there are none.
pub fn mean(values: impl IntoIterator<Item = f64>) -> Option<f64> {
    let (sum, n) = values
        .into_iter()
        .filter(|x| !x.is_nan())
        .fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    (n > 0).then(|| sum / n as f64)
}

/// `count / total`, 0 for an empty set.
pub fn rate(count: usize, total: usize) -> f64 {
    if total == 0 {
        0.0
    } else {
        count as f64 / total as f64
    }
}

/// One controller over all worlds: a row of the comparison table. Units in
/// the names; rates are fractions of `worlds` in [0, 1].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ControllerStats {
    pub controller: Controller,
    pub worlds: usize,
    /// Worlds with at least one collision.
    pub worlds_with_collision: usize,
    pub collision_rate: f64,
    /// Collisions summed over worlds (a contact counts once when it begins).
    pub collisions_total: usize,
    /// Closing contacts (the robot drove in) and passive ones, summed over
    /// worlds, and the worlds with any.
    pub closing_contacts_total: usize,
    pub worlds_with_closing_contact: usize,
    pub passive_contacts_total: usize,
    pub worlds_with_passive_contact: usize,
    /// Least, 5th percentile and median over worlds of each world's least
    /// body-to-obstacle distance (m; negative = penetration).
    pub min_clearance_min_m: Option<f64>,
    pub min_clearance_p5_m: Option<f64>,
    pub min_clearance_median_m: Option<f64>,
    pub worlds_reached: usize,
    pub goal_rate: f64,
    /// Worlds where a path keeping r + d_safe from the static obstacles leads
    /// to the goal, and the goal rate over those: a doorway too narrow for
    /// that must be refused, not counted against the controller.
    pub worlds_with_path: usize,
    pub worlds_reached_with_path: usize,
    pub goal_rate_with_path: f64,
    /// With a time budget (`time_budget_factor`): of the worlds with a path,
    /// those where the goal was reached within it, and their fraction. None
    /// when the template sets no budget.
    pub worlds_within_budget_with_path: Option<usize>,
    pub goal_within_budget_rate_with_path: Option<f64>,
    /// Mean time to goal over the worlds where it was reached (s).
    pub mean_time_to_goal_s: Option<f64>,
    /// Mean path length over all worlds (m).
    pub mean_path_length_m: Option<f64>,
    /// Mean over worlds of each world's largest distance from the reference (m).
    pub mean_max_tracking_error_m: Option<f64>,
    /// Steps where the logged DTCBF condition failed for the sent command,
    /// summed over worlds, and the worlds with any.
    pub cbf_violations_total: usize,
    pub worlds_with_cbf_violation: usize,
    /// The same on the exact geometry after the step.
    pub true_cbf_violations_total: usize,
    pub worlds_with_true_cbf_violation: usize,
    /// Logged violations on steps the filter did not mark infeasible.
    pub cbf_violations_feasible_total: usize,
    /// Steps whose sent command could not brake to rest without a predicted
    /// closing contact, and those of them not marked infeasible.
    pub braking_violations_total: usize,
    pub braking_violations_feasible_total: usize,
    /// Steps marked infeasible.
    pub infeasible_steps_total: usize,
    /// Steps driven while an unknown beam hiding something near was taken as
    /// free, and steps stopped for a blind sensor.
    pub driven_blind_steps_total: usize,
    pub blind_steps_total: usize,
    /// Mean over worlds of the total variation of v and of ω per second
    /// (m/s per s, rad/s per s; [`MotionQuality`](crate::sim::figures::MotionQuality)).
    pub mean_variation_v_per_s: Option<f64>,
    pub mean_variation_omega_per_s: Option<f64>,
    /// The same of the upstream command (what the controller's is read against).
    pub mean_upstream_variation_v_per_s: Option<f64>,
    pub mean_upstream_variation_omega_per_s: Option<f64>,
    /// Sign reversals of Δω (both steps above ω_max/6) and of Δv (both above
    /// 0.02 m/s), as fractions of all steps.
    pub omega_reversal_rate: f64,
    pub v_reversal_rate: f64,
    /// Steps whose change left the dynamic window (fault stops aside).
    pub window_exceeded_total: usize,
    /// State switches per minute over all worlds' time.
    pub state_switches_per_min: f64,
    /// Steps faster than the upstream command (beyond braking to it).
    pub above_upstream_steps_total: usize,
    /// Of those, steps escaping the unsafe set (which may, §5c).
    pub above_upstream_escape_steps_total: usize,
    /// Steps reversing while the upstream does not: escape, evasion, other.
    pub reverse_escape_steps_total: usize,
    pub reverse_evade_steps_total: usize,
    pub reverse_other_steps_total: usize,
    /// Sign changes of v, summed over worlds.
    pub v_sign_changes_total: usize,
    /// Steps with a moving track, as a fraction of all steps; steps in `evade`.
    pub moving_track_step_rate: f64,
    pub evade_steps_total: usize,
    /// Mean over worlds of the time stalled (s).
    pub mean_stalled_s: Option<f64>,
    /// Control steps over all worlds.
    pub steps_total: usize,
    /// Mean and 99th percentile of the controller's compute per step over
    /// every step of every world (µs, wall clock).
    pub mean_step_us: Option<f64>,
    pub p99_step_us: Option<f64>,
    /// The slowest step (µs, wall clock).
    pub max_step_us: Option<f64>,
}

impl ControllerStats {
    /// Aggregates `outcomes` (this controller's, one per world).
    pub fn from_outcomes(controller: Controller, outcomes: &[&WorldOutcome]) -> ControllerStats {
        let n = outcomes.len();
        let count = |f: fn(&WorldOutcome) -> bool| outcomes.iter().filter(|o| f(o)).count();
        let clearances: Vec<f64> = outcomes.iter().map(|o| o.figures.min_clearance_m).collect();
        let worlds_with_collision = count(|o| o.figures.collisions > 0);
        let worlds_reached = count(|o| o.figures.reached_goal);
        let has_budget = outcomes.iter().any(|o| o.goal_within_budget.is_some());
        let mut steps_us: Vec<f64> = outcomes
            .iter()
            .flat_map(|o| o.step_us.iter().map(|&t| f64::from(t)))
            .filter(|t| !t.is_nan())
            .collect();
        steps_us.sort_by(f64::total_cmp);
        let motion = outcomes
            .iter()
            .fold(MotionQuality::default(), |acc, o| acc.sum(&o.figures.motion));
        ControllerStats {
            controller,
            worlds: n,
            worlds_with_collision,
            collision_rate: rate(worlds_with_collision, n),
            collisions_total: outcomes.iter().map(|o| o.figures.collisions).sum(),
            closing_contacts_total: outcomes.iter().map(|o| o.figures.closing_contacts).sum(),
            worlds_with_closing_contact: count(|o| o.figures.closing_contacts > 0),
            passive_contacts_total: outcomes.iter().map(|o| o.figures.passive_contacts).sum(),
            worlds_with_passive_contact: count(|o| o.figures.passive_contacts > 0),
            min_clearance_min_m: percentile(clearances.iter().copied(), 0.0),
            min_clearance_p5_m: percentile(clearances.iter().copied(), 5.0),
            min_clearance_median_m: percentile(clearances.iter().copied(), 50.0),
            worlds_reached,
            goal_rate: rate(worlds_reached, n),
            worlds_with_path: count(|o| o.path_exists),
            worlds_reached_with_path: count(|o| o.path_exists && o.figures.reached_goal),
            goal_rate_with_path: rate(
                count(|o| o.path_exists && o.figures.reached_goal),
                count(|o| o.path_exists),
            ),
            worlds_within_budget_with_path: has_budget
                .then(|| count(|o| o.path_exists && o.goal_within_budget == Some(true))),
            goal_within_budget_rate_with_path: has_budget.then(|| {
                rate(
                    count(|o| o.path_exists && o.goal_within_budget == Some(true)),
                    count(|o| o.path_exists),
                )
            }),
            mean_time_to_goal_s: mean(outcomes.iter().filter_map(|o| o.figures.time_to_goal_s)),
            mean_path_length_m: mean(outcomes.iter().map(|o| o.figures.path_length_m)),
            mean_max_tracking_error_m: mean(outcomes.iter().filter_map(|o| o.figures.max_tracking_error_m)),
            cbf_violations_total: outcomes.iter().map(|o| o.figures.cbf_violations).sum(),
            worlds_with_cbf_violation: count(|o| o.figures.cbf_violations > 0),
            true_cbf_violations_total: outcomes.iter().map(|o| o.figures.true_cbf_violations).sum(),
            worlds_with_true_cbf_violation: count(|o| o.figures.true_cbf_violations > 0),
            cbf_violations_feasible_total: outcomes.iter().map(|o| o.figures.cbf_violations_feasible).sum(),
            braking_violations_total: outcomes.iter().map(|o| o.figures.braking_violations).sum(),
            braking_violations_feasible_total: outcomes.iter().map(|o| o.figures.braking_violations_feasible).sum(),
            infeasible_steps_total: outcomes.iter().map(|o| o.figures.infeasible_steps.total()).sum(),
            driven_blind_steps_total: outcomes.iter().map(|o| o.figures.driven_blind_steps).sum(),
            blind_steps_total: outcomes.iter().map(|o| o.figures.blind_steps).sum(),
            mean_variation_v_per_s: mean(outcomes.iter().map(|o| o.figures.motion.variation_v_per_s())),
            mean_variation_omega_per_s: mean(outcomes.iter().map(|o| o.figures.motion.variation_omega_per_s())),
            mean_upstream_variation_v_per_s: mean(
                outcomes.iter().map(|o| o.figures.motion.upstream_variation_v_per_s()),
            ),
            mean_upstream_variation_omega_per_s: mean(
                outcomes
                    .iter()
                    .map(|o| o.figures.motion.upstream_variation_omega_per_s()),
            ),
            omega_reversal_rate: motion.per_step(motion.omega_reversals),
            v_reversal_rate: motion.per_step(motion.v_reversals),
            window_exceeded_total: motion.window_exceeded,
            state_switches_per_min: motion.per_minute(motion.state_switches),
            above_upstream_steps_total: motion.above_upstream_steps,
            above_upstream_escape_steps_total: motion.above_upstream_escape_steps,
            reverse_escape_steps_total: motion.reverse_escape_steps,
            reverse_evade_steps_total: motion.reverse_evade_steps,
            reverse_other_steps_total: motion.reverse_other_steps,
            v_sign_changes_total: motion.v_sign_changes,
            moving_track_step_rate: motion.per_step(motion.moving_track_steps),
            evade_steps_total: motion.evade_steps,
            mean_stalled_s: mean(outcomes.iter().map(|o| o.figures.stalled_s)),
            steps_total: outcomes.iter().map(|o| o.steps).sum(),
            mean_step_us: mean(steps_us.iter().copied()),
            p99_step_us: percentile_of_sorted(&steps_us, 99.0),
            max_step_us: steps_us.last().copied(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::figures::{InfeasibleCounts, RunFigures, StateCounts};

    fn close(a: Option<f64>, b: f64) -> bool {
        a.is_some_and(|a| (a - b).abs() < 1e-12)
    }

    #[test]
    fn percentiles_interpolate_between_order_statistics() {
        // Sorted: 1 2 3 4 5 (n − 1 = 4).
        let v = [5.0, 1.0, 4.0, 2.0, 3.0];
        assert!(close(percentile(v, 0.0), 1.0));
        assert!(close(percentile(v, 100.0), 5.0));
        assert!(close(percentile(v, 50.0), 3.0));
        assert!(close(percentile(v, 25.0), 2.0));
        // Rank 0.05 · 4 = 0.2: 1 + 0.2 · (2 − 1).
        assert!(close(percentile(v, 5.0), 1.2));
        // Rank 0.99 · 4 = 3.96: 4 + 0.96 · (5 − 4).
        assert!(close(percentile(v, 99.0), 4.96));
        // Two values: the median is their mean; NaN is ignored.
        assert!(close(percentile([10.0, f64::NAN, 20.0], 50.0), 15.0));
        assert!(close(percentile([7.0], 99.0), 7.0));
        assert_eq!(percentile([], 50.0), None);
        assert_eq!(percentile([f64::NAN], 50.0), None);
        assert_eq!(percentile([1.0], 101.0), None);
        assert_eq!(percentile([1.0], f64::NAN), None);
        // Negative values (penetration) sort below zero.
        assert!(close(percentile([0.3, -0.05, 0.1], 0.0), -0.05));
    }

    #[test]
    fn means_and_rates() {
        assert!(close(mean([1.0, 2.0, 6.0]), 3.0));
        assert!(close(mean([1.0, f64::NAN, 3.0]), 2.0));
        assert_eq!(mean([]), None);
        assert_eq!(rate(1, 4), 0.25);
        assert_eq!(rate(0, 0), 0.0);
    }

    fn outcome(world: usize, collisions: usize, clearance: f64, goal: Option<f64>, steps_us: &[f32]) -> WorldOutcome {
        WorldOutcome {
            world,
            controller: Controller::Oldbf,
            sensor_seed: 0,
            path_exists: world != 3,
            label: "room",
            time_budget_s: None,
            goal_within_budget: None,
            steps: steps_us.len(),
            figures: RunFigures {
                collisions,
                // World w: its contacts split w closing first (capped), the rest passive.
                closing_contacts: collisions.min(world),
                passive_contacts: collisions - collisions.min(world),
                min_clearance_m: clearance,
                reached_goal: goal.is_some(),
                time_to_goal_s: goal,
                path_length_m: 2.0 * world as f64,
                max_tracking_error_m: Some(0.1 * world as f64),
                mean_tracking_error_m: Some(0.05 * world as f64),
                cbf_violations: world,
                true_cbf_violations: 0,
                cbf_violations_feasible: world / 2,
                braking_violations: 2 * world,
                braking_violations_feasible: world,
                // world + 1 in all, split over the reasons.
                infeasible_steps: InfeasibleCounts {
                    unsafe_set: 1,
                    approaching: world / 2,
                    no_passive_command: world - world / 2,
                },
                driven_blind_steps: usize::from(world == 3),
                blind_steps: 0,
                motion: MotionQuality {
                    steps: steps_us.len(),
                    duration_s: 0.1 * steps_us.len() as f64,
                    omega_reversals: world % 2,
                    variation_omega_radps: 0.01 * world as f64,
                    ..MotionQuality::default()
                },
                stalled_s: 1.5 * world as f64,
                filter_changed_steps: 0,
                steps_by_state: StateCounts::default(),
                min_h_m: clearance - 0.1,
            },
            mean_step_us: 0.0,
            step_us: steps_us.to_vec(),
        }
    }

    #[test]
    fn a_row_from_hand_made_outcomes() {
        let o = [
            outcome(0, 0, 0.40, Some(30.0), &[1.0, 2.0]),
            outcome(1, 2, -0.02, None, &[3.0]),
            outcome(2, 0, 0.20, Some(50.0), &[4.0, 100.0]),
            outcome(3, 1, 0.05, None, &[]),
        ];
        let refs: Vec<&WorldOutcome> = o.iter().collect();
        let s = ControllerStats::from_outcomes(Controller::Oldbf, &refs);
        assert_eq!(s.worlds, 4);
        assert_eq!(s.worlds_with_collision, 2);
        assert_eq!(s.collision_rate, 0.5);
        assert_eq!(s.collisions_total, 3);
        // World 1: 2 contacts, 1 closing; world 3: 1 contact, closing. Feasible violations
        // world / 2: 0 + 0 + 1 + 1.
        assert_eq!((s.closing_contacts_total, s.worlds_with_closing_contact), (2, 2));
        assert_eq!((s.passive_contacts_total, s.worlds_with_passive_contact), (1, 1));
        assert_eq!((s.cbf_violations_feasible_total, s.braking_violations_total), (2, 12));
        assert_eq!((s.braking_violations_feasible_total, s.infeasible_steps_total), (6, 10));
        assert_eq!((s.driven_blind_steps_total, s.blind_steps_total), (1, 0));
        // Δω reversals in worlds 1 and 3 over 5 steps; stalled 0, 1.5, 3, 4.5 s.
        assert_eq!(s.omega_reversal_rate, 0.4);
        // Variation of ω per second, world by world: 0/0.2, 0.01/0.1, 0.02/0.2, none (no time).
        assert!(close(s.mean_variation_omega_per_s, 0.05));
        assert!(close(s.max_step_us, 100.0));
        assert!(close(s.mean_stalled_s, 2.25));
        assert!(close(s.min_clearance_min_m, -0.02));
        // Sorted −0.02 0.05 0.2 0.4, rank 0.15: −0.02 + 0.15 · 0.07.
        assert!(close(s.min_clearance_p5_m, -0.02 + 0.15 * 0.07));
        assert!(close(s.min_clearance_median_m, 0.125));
        assert_eq!((s.worlds_reached, s.goal_rate), (2, 0.5));
        // World 3 has no path: two of the other three reached.
        assert_eq!((s.worlds_with_path, s.worlds_reached_with_path), (3, 2));
        assert!((s.goal_rate_with_path - 2.0 / 3.0).abs() < 1e-12);
        assert!(close(s.mean_time_to_goal_s, 40.0));
        assert!(close(s.mean_path_length_m, 3.0));
        assert!(close(s.mean_max_tracking_error_m, 0.15));
        assert_eq!((s.cbf_violations_total, s.worlds_with_cbf_violation), (6, 3));
        assert_eq!((s.true_cbf_violations_total, s.worlds_with_true_cbf_violation), (0, 0));
        assert_eq!(s.steps_total, 5);
        // Pooled steps 1 2 3 4 100: mean 22, p99 at rank 3.96 = 4 + 0.96 · 96.
        assert!(close(s.mean_step_us, 22.0));
        assert!(close(s.p99_step_us, 4.0 + 0.96 * 96.0));
    }

    #[test]
    fn goal_within_budget_counts_worlds_with_a_path_reached_in_time() {
        // Budget 40 s everywhere: world 0 reached at 30 s (in budget), world 2 at 50 s (late),
        // world 1 not reached, world 3 has no path (reached at 10 s, not counted).
        let mut o = [
            outcome(0, 0, 0.40, Some(30.0), &[1.0]),
            outcome(1, 0, 0.40, None, &[1.0]),
            outcome(2, 0, 0.40, Some(50.0), &[1.0]),
            outcome(3, 0, 0.40, Some(10.0), &[1.0]),
        ];
        let refs: Vec<&WorldOutcome> = o.iter().collect();
        let s = ControllerStats::from_outcomes(Controller::Oldbf, &refs);
        assert_eq!(
            (s.worlds_within_budget_with_path, s.goal_within_budget_rate_with_path),
            (None, None)
        );
        for w in &mut o {
            w.time_budget_s = Some(40.0);
            w.goal_within_budget = Some(w.figures.time_to_goal_s.is_some_and(|t| t <= 40.0));
        }
        let refs: Vec<&WorldOutcome> = o.iter().collect();
        let s = ControllerStats::from_outcomes(Controller::Oldbf, &refs);
        assert_eq!((s.worlds_with_path, s.worlds_reached_with_path), (3, 2));
        assert_eq!(s.worlds_within_budget_with_path, Some(1));
        assert!(close(s.goal_within_budget_rate_with_path, 1.0 / 3.0));
    }

    #[test]
    fn an_empty_row_has_no_statistics() {
        let s = ControllerStats::from_outcomes(Controller::None, &[]);
        assert_eq!(s.worlds, 0);
        assert_eq!(s.collision_rate, 0.0);
        assert_eq!(s.min_clearance_p5_m, None);
        assert_eq!(s.mean_time_to_goal_s, None);
        assert_eq!(s.p99_step_us, None);
    }
}
