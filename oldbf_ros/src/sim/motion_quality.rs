//! How well the robot was commanded, measured (ALGORITHM.md §5c): the
//! chatter a user sees and a drive feels, and what the safety layer added
//! to the upstream command. Fed the command sent at every control step.
//!
//! * total variation of v and ω: Σ|Δv| and Σ|Δω| over consecutive commands,
//!   per second of the run (m/s per s, rad/s per s), and the same of the
//!   upstream command: what the layer's own variation is to be read against
//!   (a tracking controller upstream varies with the robot's deviation);
//! * sign reversals of Δω with both steps above ω_max/6, and of Δv with both
//!   above 0.02 m/s: a command that swings one way and straight back;
//! * steps whose change leaves the base's dynamic window
//!   ([`oldbf::algo::select::window`]; the evasion limits while a mover
//!   threatened, the driving ones otherwise), stops for a fault (no scan, a
//!   rejected one, a blind sensor, an e-stop) aside: those cut the command
//!   at once whatever the base can follow;
//! * switches of the state (forward, avoid, …) per minute;
//! * steps whose speed exceeds the upstream (nominal) command's in its
//!   direction, beyond what braking at the window's deceleration allows
//!   (and of them, those escaping the unsafe set, which may), and
//!   steps that reverse while the upstream does not (split: escape from the
//!   unsafe set, evasion of a mover, anything else);
//! * sign changes of v: a robot that is blocked should rest, not jitter;
//! * steps with a moving track, and in `evade`.

use crate::algo::doaa::DoaaState;
use crate::algo::geometry::Twist;
use crate::algo::params::Params;
use crate::algo::select::window::{reachable, Limits, WINDOW_TOL};
use serde::Serialize;

/// A Δv beyond this (m/s) counts for a reversal.
pub const V_REVERSAL_STEP_MPS: f64 = 0.02;
/// A Δω beyond ω_max over this counts for a reversal.
pub const OMEGA_REVERSAL_FRACTION: f64 = 1.0 / 6.0;

/// The figures, summed over steps (counts) and over time.
#[derive(Debug, Clone, Copy, Default, Serialize, PartialEq)]
pub struct MotionQuality {
    /// Control steps measured and their duration (s).
    pub steps: usize,
    pub duration_s: f64,
    /// Σ|Δv| (m/s) and Σ|Δω| (rad/s).
    pub variation_v_mps: f64,
    pub variation_omega_radps: f64,
    /// The same of the upstream (nominal) command, inside the input box.
    pub upstream_variation_v_mps: f64,
    pub upstream_variation_omega_radps: f64,
    /// Δω sign reversals (both steps above ω_max/6), Δv ones (both above 0.02 m/s).
    pub omega_reversals: usize,
    pub v_reversals: usize,
    /// Steps whose change from the last command leaves the dynamic window (fault stops aside).
    pub window_exceeded: usize,
    /// Changes of state between consecutive steps.
    pub state_switches: usize,
    /// Steps faster than the upstream command (beyond braking at the deceleration),
    /// and those of them escaping the unsafe set (which may: §5c).
    pub above_upstream_steps: usize,
    pub above_upstream_escape_steps: usize,
    /// Steps reversing while the upstream does not: escaping the unsafe set,
    /// evading a mover, and otherwise. A step still reversing only because
    /// braking at the deceleration from the last command cannot reach rest
    /// yet counts with the reversing it brakes from.
    pub reverse_escape_steps: usize,
    pub reverse_evade_steps: usize,
    pub reverse_other_steps: usize,
    /// Sign changes of v between consecutive steps.
    pub v_sign_changes: usize,
    /// Steps with a moving track, and steps in `evade`.
    pub moving_track_steps: usize,
    pub evade_steps: usize,
}

impl MotionQuality {
    /// Total variation of v per second of the run (m/s per s).
    pub fn variation_v_per_s(&self) -> f64 {
        per(self.variation_v_mps, self.duration_s)
    }

    /// Total variation of ω per second of the run (rad/s per s).
    pub fn variation_omega_per_s(&self) -> f64 {
        per(self.variation_omega_radps, self.duration_s)
    }

    /// Total variation of the upstream command's v per second (m/s per s).
    pub fn upstream_variation_v_per_s(&self) -> f64 {
        per(self.upstream_variation_v_mps, self.duration_s)
    }

    /// Total variation of the upstream command's ω per second (rad/s per s).
    pub fn upstream_variation_omega_per_s(&self) -> f64 {
        per(self.upstream_variation_omega_radps, self.duration_s)
    }

    /// `count` per minute of the run.
    pub fn per_minute(&self, count: usize) -> f64 {
        per(60.0 * count as f64, self.duration_s)
    }

    /// `count` as a fraction of the steps.
    pub fn per_step(&self, count: usize) -> f64 {
        per(count as f64, self.steps as f64)
    }

    /// Steps reversing while the upstream does not, for whatever reason.
    pub fn reverse_unasked_steps(&self) -> usize {
        self.reverse_escape_steps + self.reverse_evade_steps + self.reverse_other_steps
    }

    /// The sum of several runs' figures.
    pub fn sum(&self, o: &MotionQuality) -> MotionQuality {
        MotionQuality {
            steps: self.steps + o.steps,
            duration_s: self.duration_s + o.duration_s,
            variation_v_mps: self.variation_v_mps + o.variation_v_mps,
            variation_omega_radps: self.variation_omega_radps + o.variation_omega_radps,
            upstream_variation_v_mps: self.upstream_variation_v_mps + o.upstream_variation_v_mps,
            upstream_variation_omega_radps: self.upstream_variation_omega_radps + o.upstream_variation_omega_radps,
            omega_reversals: self.omega_reversals + o.omega_reversals,
            v_reversals: self.v_reversals + o.v_reversals,
            window_exceeded: self.window_exceeded + o.window_exceeded,
            state_switches: self.state_switches + o.state_switches,
            above_upstream_steps: self.above_upstream_steps + o.above_upstream_steps,
            above_upstream_escape_steps: self.above_upstream_escape_steps + o.above_upstream_escape_steps,
            reverse_escape_steps: self.reverse_escape_steps + o.reverse_escape_steps,
            reverse_evade_steps: self.reverse_evade_steps + o.reverse_evade_steps,
            reverse_other_steps: self.reverse_other_steps + o.reverse_other_steps,
            v_sign_changes: self.v_sign_changes + o.v_sign_changes,
            moving_track_steps: self.moving_track_steps + o.moving_track_steps,
            evade_steps: self.evade_steps + o.evade_steps,
        }
    }
}

fn per(x: f64, over: f64) -> f64 {
    if over > 0.0 {
        x / over
    } else {
        0.0
    }
}

/// One step as the meter sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeteredStep {
    /// The command sent.
    pub cmd: Twist,
    /// The upstream (nominal) command, inside the input box.
    pub nominal: Twist,
    pub state: DoaaState,
    /// The command is a stop for a fault (no usable scan, bad input, e-stop).
    pub fault_stop: bool,
    /// Moving tracks this step.
    pub moving_tracks: usize,
    /// The window was opened to the base's own limits for evasion.
    pub evading: bool,
}

/// Accumulates [`MotionQuality`] one control step at a time.
#[derive(Debug, Clone)]
pub struct MotionMeter {
    q: MotionQuality,
    dt_s: f64,
    driving: Limits,
    evading: Limits,
    omega_step: f64,
    last: Option<MeteredStep>,
    /// The last non-zero changes (Δv, Δω) above the reversal thresholds, for the reversal counts.
    last_dv: f64,
    last_domega: f64,
    /// Why the last step reversed unasked (escape, evasion, other), if it did.
    last_reverse: Option<DoaaState>,
}

impl MotionMeter {
    /// A meter for steps `dt_s` apart under the limits of `p`.
    pub fn new(p: &Params, dt_s: f64) -> Self {
        Self {
            q: MotionQuality::default(),
            dt_s,
            driving: Limits::driving(p),
            evading: Limits::evading(p),
            omega_step: OMEGA_REVERSAL_FRACTION * p.control.omega_max_radps,
            last: None,
            last_dv: 0.0,
            last_domega: 0.0,
            last_reverse: None,
        }
    }

    pub fn add(&mut self, s: MeteredStep) {
        let q = &mut self.q;
        q.steps += 1;
        q.duration_s += self.dt_s;
        q.moving_track_steps += usize::from(s.moving_tracks > 0);
        q.evade_steps += usize::from(s.state == DoaaState::Evade);
        let (v, v_nom) = (s.cmd.v_mps, s.nominal.v_mps);
        // The speeds the window reached from the last command (m/s).
        let l = if s.evading { &self.evading } else { &self.driving };
        let window = self
            .last
            .map(|last| reachable(last.cmd.v_mps, self.dt_s, l.accel_mps2, l.decel_mps2));
        if let (Some(last), Some((lo, hi))) = (self.last, window) {
            let dv = v - last.cmd.v_mps;
            let dw = s.cmd.omega_radps - last.cmd.omega_radps;
            q.variation_v_mps += dv.abs();
            q.variation_omega_radps += dw.abs();
            q.upstream_variation_v_mps += (v_nom - last.nominal.v_mps).abs();
            q.upstream_variation_omega_radps += (s.nominal.omega_radps - last.nominal.omega_radps).abs();
            if dv.abs() > V_REVERSAL_STEP_MPS {
                q.v_reversals += usize::from(dv * self.last_dv < 0.0);
            }
            if dw.abs() > self.omega_step {
                q.omega_reversals += usize::from(dw * self.last_domega < 0.0);
            }
            // A reversal needs both steps above the threshold, back to back.
            self.last_dv = if dv.abs() > V_REVERSAL_STEP_MPS { dv } else { 0.0 };
            self.last_domega = if dw.abs() > self.omega_step { dw } else { 0.0 };
            let dw_max = l.angular_accel_radps2 * self.dt_s;
            let outside = v < lo - WINDOW_TOL || v > hi + WINDOW_TOL || dw.abs() > dw_max + WINDOW_TOL;
            q.window_exceeded += usize::from(outside && !s.fault_stop);
            q.state_switches += usize::from(s.state != last.state);
            q.v_sign_changes += usize::from(v * last.cmd.v_mps < 0.0);
            // Faster than asked in the upstream's direction, beyond what braking at the
            // deceleration from the last command allows (reversing unasked is counted below).
            let above = if v > 0.0 {
                v > v_nom.max(0.0).max(lo) + WINDOW_TOL
            } else {
                v_nom < 0.0 && v < v_nom.min(hi) - WINDOW_TOL
            };
            q.above_upstream_steps += usize::from(above);
            q.above_upstream_escape_steps += usize::from(above && s.state == DoaaState::Escape);
        }
        let reverse = (v < -WINDOW_TOL && v_nom >= 0.0).then(|| {
            // Braking from the last step's reversing at the window's edge, rest still
            // out of reach: the reversing it brakes from.
            let braking = window.is_some_and(|(_, hi)| hi < -WINDOW_TOL && v >= hi - WINDOW_TOL);
            match (braking, self.last_reverse) {
                (true, Some(why)) => why,
                _ => s.state,
            }
        });
        match reverse {
            Some(DoaaState::Escape) => q.reverse_escape_steps += 1,
            Some(DoaaState::Evade) => q.reverse_evade_steps += 1,
            Some(_) => q.reverse_other_steps += 1,
            None => {}
        }
        self.last_reverse = reverse;
        self.last = Some(s);
    }

    /// The figures so far.
    pub fn figures(&self) -> MotionQuality {
        self.q
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn step(v: f64, w: f64, v_nom: f64, state: DoaaState) -> MeteredStep {
        MeteredStep {
            cmd: Twist::new(v, w),
            nominal: Twist::new(v_nom, 0.0),
            state,
            fault_stop: false,
            moving_tracks: 0,
            evading: false,
        }
    }

    /// Hand values at the defaults: Δt 0.1 s, accel 0.5, decel 1.0, α 1.0,
    /// ω_max 0.3 (reversal threshold 0.05 rad/s).
    #[test]
    fn a_swerve_and_back_is_counted_and_measured() {
        let mut m = MotionMeter::new(&Params::default(), 0.1);
        use DoaaState::*;
        for (v, w, st) in [
            (0.1, 0.0, Forward),
            (0.1, 0.1, Avoid),  // Δω +0.1
            (0.1, 0.0, Avoid),  // −0.1: a reversal
            (0.1, 0.06, Avoid), // +0.06: another
            (0.1, 0.06, Forward),
            (0.15, 0.06, Forward), // Δv +0.05 within 0.05: in the window
            (0.25, 0.06, Forward), // +0.1: outside (accel 0.05 per step), and above v_nom 0.15
        ] {
            m.add(step(v, w, 0.15, st));
        }
        let q = m.figures();
        assert_eq!((q.steps, q.omega_reversals, q.v_reversals), (7, 2, 0));
        assert!((q.variation_omega_radps - 0.26).abs() < 1e-12);
        assert!((q.variation_v_mps - 0.15).abs() < 1e-12);
        assert!((q.variation_omega_per_s() - 0.26 / 0.7).abs() < 1e-12);
        assert_eq!(q.state_switches, 2);
        assert_eq!(q.window_exceeded, 1);
        assert_eq!(q.above_upstream_steps, 1);
        assert!((q.per_minute(q.state_switches) - 2.0 * 60.0 / 0.7).abs() < 1e-9);
    }

    #[test]
    fn escaping_forward_while_the_upstream_rests_is_above_it_and_counted_apart() {
        // Turning in place (upstream v 0), a noisy reading puts the robot in the unsafe
        // set and escape drives it out forward at 0.03 m/s: above the upstream, which
        // escape may (§5c); a forward step outside escape is not.
        let mut m = MotionMeter::new(&Params::default(), 0.1);
        use DoaaState::*;
        for (v, st) in [(0.0, Avoid), (0.03, Escape), (0.0, Avoid), (0.03, Avoid)] {
            m.add(step(v, 0.0, 0.0, st));
        }
        let q = m.figures();
        assert_eq!((q.above_upstream_steps, q.above_upstream_escape_steps), (2, 1));
    }

    #[test]
    fn the_upstream_commands_variation_is_measured_beside_the_commands() {
        // The upstream swings ω 0 → 0.2 → 0 → 0.2 and v 0.1 → 0.2 → 0.2 → 0.1;
        // the command holds (0.1, 0.05): its variation is 0, the upstream's
        // 0.6 rad/s and 0.2 m/s over 0.4 s.
        let mut m = MotionMeter::new(&Params::default(), 0.1);
        for (v_nom, w_nom) in [(0.1, 0.0), (0.2, 0.2), (0.2, 0.0), (0.1, 0.2)] {
            let mut s = step(0.1, 0.05, v_nom, DoaaState::Forward);
            s.nominal.omega_radps = w_nom;
            m.add(s);
        }
        let q = m.figures();
        assert_eq!((q.variation_v_mps, q.variation_omega_radps), (0.0, 0.0));
        assert!((q.upstream_variation_omega_radps - 0.6).abs() < 1e-12);
        assert!((q.upstream_variation_v_mps - 0.2).abs() < 1e-12);
        assert!((q.upstream_variation_omega_per_s() - 1.5).abs() < 1e-12);
        // Summed runs add up.
        let two = q.sum(&q);
        assert!((two.upstream_variation_omega_per_s() - 1.5).abs() < 1e-12);
    }

    #[test]
    fn braking_to_a_lower_upstream_speed_is_not_above_it_and_reversing_is_split_by_cause() {
        let mut m = MotionMeter::new(&Params::default(), 0.1);
        use DoaaState::*;
        // The upstream drops from 0.2 to 0: 0.1 then 0 is braking at 1 m/s², allowed.
        for (v, v_nom) in [(0.2, 0.2), (0.1, 0.0), (0.0, 0.0)] {
            m.add(step(v, 0.0, v_nom, Forward));
        }
        assert_eq!(m.figures().above_upstream_steps, 0);
        // Holding 0.1 when it could brake to 0 is above it.
        m.add(step(0.1, 0.0, 0.0, Forward));
        assert_eq!(m.figures().above_upstream_steps, 1);
        assert_eq!(m.figures().above_upstream_escape_steps, 0);
        // Backing up: from escape, evasion, and for no stated reason; then forward again.
        for (v, st) in [
            (-0.05, Escape),
            (-0.1, Evade),
            (-0.05, Avoid),
            (0.0, Avoid),
            (0.05, Avoid),
        ] {
            m.add(step(v, 0.0, 0.0, st));
        }
        let q = m.figures();
        assert_eq!(
            (q.reverse_escape_steps, q.reverse_evade_steps, q.reverse_other_steps),
            (1, 1, 1)
        );
        assert_eq!(
            q.v_sign_changes, 1,
            "0.1 → −0.05; through 0 to 0.05 is not a sign change step"
        );
        // Out of the unsafe set at −0.15 m/s: braking at 1 m/s² reaches −0.05 at best,
        // still escape's reversing; from −0.1 rest is in reach, and holding −0.05 is not.
        let mut m2 = MotionMeter::new(&Params::default(), 0.1);
        for (v, st) in [
            (-0.15, Escape),
            (-0.05, Follow),
            (0.0, Follow),
            (-0.1, Escape),
            (-0.05, Follow),
        ] {
            m2.add(step(v, 0.0, 0.15, st));
        }
        let q2 = m2.figures();
        assert_eq!(
            (q2.reverse_escape_steps, q2.reverse_evade_steps, q2.reverse_other_steps),
            (3, 0, 1)
        );
        // A fault stop from speed is outside the window but not counted.
        let mut s = step(0.0, 0.0, 0.2, Stop);
        m.add(step(0.2, 0.0, 0.2, Forward));
        s.fault_stop = true;
        let before = m.figures().window_exceeded;
        m.add(s);
        assert_eq!(m.figures().window_exceeded, before);
    }
}
