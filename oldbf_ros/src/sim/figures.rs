//! The figures of a run: one type for a robot's figures, the whole run's
//! (summed over robots), a batch world's and a soak world's, so a figure is
//! defined, documented and aggregated in one place.

use crate::algo::doaa::DoaaState;
use crate::algo::record::Infeasibility;
pub use crate::sim::motion_quality::MotionQuality;
use serde::Serialize;

/// What a closed-loop run measured, for one robot or summed over all of them
/// ([`RunFigures::total`]). Distances in m, times in s.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct RunFigures {
    /// Distinct contacts between the robot circle and any obstacle (other robots included).
    pub collisions: usize,
    /// Of those, contacts the robot drove into (its speed towards the touched
    /// point above 0.02 m/s at the onset), and the others (at rest, turning
    /// or moving away: the obstacle came to it).
    pub closing_contacts: usize,
    pub passive_contacts: usize,
    /// Least distance between the robot's body and any obstacle over the run (m; < 0 = penetration).
    pub min_clearance_m: f64,
    /// Steps where the logged DTCBF condition was false for the sent command.
    pub cbf_violations: usize,
    /// Steps where the condition failed on the exact geometry after the step.
    pub true_cbf_violations: usize,
    /// Logged violations on steps the filter did not mark infeasible (must be 0).
    pub cbf_violations_feasible: usize,
    /// Steps whose sent command could not brake to rest without a predicted
    /// closing contact (§5b), and those of them not marked infeasible.
    pub braking_violations: usize,
    pub braking_violations_feasible: usize,
    /// Steps the filter marked infeasible, by reason.
    pub infeasible_steps: InfeasibleCounts,
    /// Steps stopped because the sensor was blind.
    pub blind_steps: usize,
    /// Steps driven while an unknown beam whose true range was within
    /// r + d_act was taken as free.
    pub driven_blind_steps: usize,
    /// How smoothly it was commanded, and what the filter added to the
    /// upstream command ([`MotionQuality`]).
    pub motion: MotionQuality,
    /// Time with |v| < 0.02 m/s while the goal was not reached (s).
    pub stalled_s: f64,
    pub reached_goal: bool,
    pub time_to_goal_s: Option<f64>,
    pub path_length_m: f64,
    /// Largest distance from the (governed) reference point (m); null without a reference.
    pub max_tracking_error_m: Option<f64>,
    pub mean_tracking_error_m: Option<f64>,
    /// Steps where the DTCBF check changed the DOAA command.
    pub filter_changed_steps: usize,
    pub steps_by_state: StateCounts,
    /// Least h(k) the controller measured (m).
    pub min_h_m: f64,
}

impl RunFigures {
    /// The whole run's figures from each robot's: sums of counts, the least
    /// clearance and h, the worst tracking error, the mean of the robots'
    /// mean errors; the goal counts as reached when every robot reached its
    /// own, at the last robot's time.
    pub fn total(robots: &[&RunFigures]) -> RunFigures {
        let each = || robots.iter().copied();
        let sum = |f: fn(&RunFigures) -> usize| each().map(f).sum::<usize>();
        let max_opt = |f: fn(&RunFigures) -> Option<f64>| each().filter_map(f).reduce(f64::max);
        let reached_goal = each().all(|s| s.reached_goal);
        RunFigures {
            collisions: sum(|s| s.collisions),
            closing_contacts: sum(|s| s.closing_contacts),
            passive_contacts: sum(|s| s.passive_contacts),
            min_clearance_m: each().map(|s| s.min_clearance_m).fold(f64::INFINITY, f64::min),
            cbf_violations: sum(|s| s.cbf_violations),
            true_cbf_violations: sum(|s| s.true_cbf_violations),
            cbf_violations_feasible: sum(|s| s.cbf_violations_feasible),
            braking_violations: sum(|s| s.braking_violations),
            braking_violations_feasible: sum(|s| s.braking_violations_feasible),
            infeasible_steps: each().fold(InfeasibleCounts::default(), |acc, s| acc.sum(&s.infeasible_steps)),
            blind_steps: sum(|s| s.blind_steps),
            driven_blind_steps: sum(|s| s.driven_blind_steps),
            motion: each().fold(MotionQuality::default(), |acc, s| acc.sum(&s.motion)),
            stalled_s: each().map(|s| s.stalled_s).sum(),
            reached_goal,
            time_to_goal_s: if reached_goal {
                max_opt(|s| s.time_to_goal_s)
            } else {
                None
            },
            path_length_m: each().map(|s| s.path_length_m).sum(),
            max_tracking_error_m: max_opt(|s| s.max_tracking_error_m),
            mean_tracking_error_m: each()
                .map(|s| s.mean_tracking_error_m)
                .collect::<Option<Vec<f64>>>()
                .map(|v| v.iter().sum::<f64>() / robots.len() as f64),
            filter_changed_steps: sum(|s| s.filter_changed_steps),
            steps_by_state: each().fold(StateCounts::default(), |acc, s| acc.sum(&s.steps_by_state)),
            min_h_m: each().map(|s| s.min_h_m).fold(f64::INFINITY, f64::min),
        }
    }
}

/// How many steps were spent in each DOAA state.
#[derive(Debug, Clone, Copy, Default, Serialize, PartialEq, Eq)]
pub struct StateCounts {
    pub forward: usize,
    pub avoid: usize,
    pub both_sides: usize,
    pub stop: usize,
    pub escape: usize,
    pub evade: usize,
    pub follow: usize,
}

impl StateCounts {
    pub(crate) fn add(&mut self, s: DoaaState) {
        match s {
            DoaaState::Forward => self.forward += 1,
            DoaaState::Avoid => self.avoid += 1,
            DoaaState::BothSides => self.both_sides += 1,
            DoaaState::Stop => self.stop += 1,
            DoaaState::Escape => self.escape += 1,
            DoaaState::Evade => self.evade += 1,
            DoaaState::Follow => self.follow += 1,
        }
    }

    fn sum(&self, o: &StateCounts) -> StateCounts {
        StateCounts {
            forward: self.forward + o.forward,
            avoid: self.avoid + o.avoid,
            both_sides: self.both_sides + o.both_sides,
            stop: self.stop + o.stop,
            escape: self.escape + o.escape,
            evade: self.evade + o.evade,
            follow: self.follow + o.follow,
        }
    }
}

/// Steps marked infeasible, by reason (`Infeasibility`).
#[derive(Debug, Clone, Copy, Default, Serialize, PartialEq, Eq)]
pub struct InfeasibleCounts {
    pub unsafe_set: usize,
    pub approaching: usize,
    pub no_passive_command: usize,
}

impl InfeasibleCounts {
    pub(crate) fn add(&mut self, r: Infeasibility) {
        match r {
            Infeasibility::UnsafeSet => self.unsafe_set += 1,
            Infeasibility::Approaching => self.approaching += 1,
            Infeasibility::NoPassiveCommand => self.no_passive_command += 1,
        }
    }

    pub fn total(&self) -> usize {
        self.unsafe_set + self.approaching + self.no_passive_command
    }

    fn sum(&self, o: &InfeasibleCounts) -> InfeasibleCounts {
        InfeasibleCounts {
            unsafe_set: self.unsafe_set + o.unsafe_set,
            approaching: self.approaching + o.approaching,
            no_passive_command: self.no_passive_command + o.no_passive_command,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn robot(collisions: usize, clearance_m: f64, goal_s: Option<f64>, mean_err_m: Option<f64>) -> RunFigures {
        RunFigures {
            collisions,
            closing_contacts: collisions,
            passive_contacts: 0,
            min_clearance_m: clearance_m,
            cbf_violations: 1,
            true_cbf_violations: 2,
            cbf_violations_feasible: 0,
            braking_violations: 3,
            braking_violations_feasible: 0,
            infeasible_steps: InfeasibleCounts {
                unsafe_set: 1,
                approaching: 0,
                no_passive_command: 2,
            },
            blind_steps: 0,
            driven_blind_steps: 0,
            motion: MotionQuality {
                steps: 10,
                omega_reversals: 1,
                ..MotionQuality::default()
            },
            stalled_s: 1.5,
            reached_goal: goal_s.is_some(),
            time_to_goal_s: goal_s,
            path_length_m: 4.0,
            max_tracking_error_m: mean_err_m.map(|e| 2.0 * e),
            mean_tracking_error_m: mean_err_m,
            filter_changed_steps: 5,
            steps_by_state: StateCounts {
                forward: 10,
                ..StateCounts::default()
            },
            min_h_m: clearance_m - 0.1,
        }
    }

    #[test]
    fn totals_sum_counts_and_take_the_worst_case() {
        let (a, b) = (
            robot(1, 0.3, Some(40.0), Some(0.1)),
            robot(2, 0.2, Some(36.0), Some(0.3)),
        );
        let t = RunFigures::total(&[&a, &b]);
        assert_eq!((t.collisions, t.closing_contacts, t.braking_violations), (3, 3, 6));
        assert_eq!(t.infeasible_steps.total(), 6);
        assert_eq!(t.steps_by_state.forward, 20);
        assert_eq!((t.motion.steps, t.motion.omega_reversals), (20, 2));
        assert_eq!((t.min_clearance_m, t.stalled_s, t.path_length_m), (0.2, 3.0, 8.0));
        assert!((t.min_h_m - 0.1).abs() < 1e-12);
        // Both reached: at the later time; the mean of the means, the worst max.
        assert_eq!(t.time_to_goal_s, Some(40.0));
        assert!((t.mean_tracking_error_m.unwrap() - 0.2).abs() < 1e-12);
        assert_eq!(t.max_tracking_error_m, Some(0.6));
        // One robot short of its goal: the run did not reach it; one without a
        // reference: no mean error for the run.
        let c = robot(0, 0.5, None, None);
        let t = RunFigures::total(&[&a, &c]);
        assert!(!t.reached_goal);
        assert_eq!((t.time_to_goal_s, t.mean_tracking_error_m), (None, None));
        assert_eq!(t.max_tracking_error_m, Some(0.2));
    }
}
