//! The per-scan pipeline: scan → points → clearances → barriers → DOAA →
//! DTCBF check → command (ALGORITHM.md §1-5).
//!
//! `SafetyPipeline` owns every buffer it needs and reuses them, so after the
//! first scan of a given size a step does not allocate. The simulator, the
//! CLI, the ROS node and the tests all call `step`.

use super::barrier::compute_barriers;
use super::clearance::{compute_clearances, Clearances, Sector};
use super::doaa::{Doaa, DoaaState};
use super::dtcbf::{DtcbfFilter, InputBox};
use super::geometry::{Twist, Vec2};
use super::params::Params;
use super::record::{StepRecord, StopCause};
use super::scan::{sanitize_scan, LaserMount, LaserScan, ScanPoints};

/// Geometry derived from the parameters once.
#[derive(Debug, Clone, Copy)]
struct Derived {
    robot_radius_m: f64,
    mount: LaserMount,
    hemisphere: Sector,
    front: Sector,
    input_box: InputBox,
}

impl Derived {
    fn new(p: &Params) -> Self {
        Self {
            robot_radius_m: p.robot_radius_m(),
            mount: LaserMount::from_params(&p.laser),
            hemisphere: Sector::new(p.barrier.hemisphere_fov_deg.to_radians()),
            front: Sector::new(p.barrier.front_fov_deg.to_radians()),
            input_box: InputBox::from_params(p),
        }
    }
}

/// The whole safety filter, with its state (DOAA latch) and buffers.
#[derive(Debug, Clone)]
pub struct SafetyPipeline {
    params: Params,
    derived: Derived,
    points: ScanPoints,
    doaa: Doaa,
    filter: DtcbfFilter,
    last_cmd: Twist,
    last_clearances: Clearances,
}

impl SafetyPipeline {
    /// `params` must have passed `Params::validate`.
    pub fn new(params: Params) -> Self {
        let derived = Derived::new(&params);
        let cap = 1024;
        Self {
            params,
            derived,
            points: ScanPoints::with_capacity(cap),
            doaa: Doaa::new(),
            filter: DtcbfFilter::with_capacity(cap),
            last_cmd: Twist::ZERO,
            last_clearances: Clearances::OPEN,
        }
    }

    pub fn params(&self) -> &Params {
        &self.params
    }

    /// Valid points of the last accepted scan, robot frame (m).
    pub fn points(&self) -> &[Vec2] {
        &self.points.points
    }

    /// Clearances of the last accepted scan.
    pub fn clearances(&self) -> &Clearances {
        &self.last_clearances
    }

    pub fn last_command(&self) -> Twist {
        self.last_cmd
    }

    /// Forget latched DOAA state (after an e-stop release or a filter toggle).
    pub fn reset(&mut self) {
        self.doaa.reset();
        self.last_cmd = Twist::ZERO;
    }

    /// A stop step with no scan processing (missing scan, e-stop…).
    pub fn stop(&mut self, now_s: f64, nominal: Twist, cause: StopCause) -> StepRecord {
        self.doaa.reset();
        self.last_cmd = Twist::ZERO;
        StepRecord::stop(now_s, nominal, cause)
    }

    /// One control step.
    ///
    /// `nominal` is the command to make safe (tracking law or upstream);
    /// `current_v_mps` the measured linear speed for B_v (NaN: the last
    /// command is used instead).
    pub fn step(&mut self, scan: &LaserScan<'_>, now_s: f64, nominal: Twist, current_v_mps: f64) -> StepRecord {
        if !nominal.is_finite() {
            return self.stop(now_s, nominal, StopCause::BadNominal);
        }
        if let Err(reason) = sanitize_scan(scan, now_s, &self.params.laser, &self.derived.mount, &mut self.points) {
            return self.stop(now_s, nominal, StopCause::Rejected(reason));
        }
        let d = &self.derived;
        let p = &self.params;
        let c = compute_clearances(&self.points.points, d.robot_radius_m, d.hemisphere, d.front);
        self.last_clearances = c;
        let v_now = if current_v_mps.is_finite() {
            current_v_mps
        } else {
            self.last_cmd.v_mps
        };
        let b = compute_barriers(c.d_left_m, c.d_right_m, v_now, &p.barrier);
        let nominal_boxed = d.input_box.clamp(nominal);
        let (doaa_cmd, doaa_state) = self.doaa.command(nominal_boxed, &c, &b, p);
        let pts = &self.points.points;
        let out = self.filter.filter(pts, pts, doaa_cmd, p);

        // Infeasible inside the unsafe set: the filter turns in place (escape); infeasible
        // outside it (an approaching obstacle): the filter's command is a stop.
        let state = match (out.infeasible, out.escape) {
            (true, false) => DoaaState::Stop,
            (_, true) => DoaaState::Escape,
            (false, false) => doaa_state,
        };
        let stop_cause = out.infeasible.then_some(StopCause::Infeasible);
        let cmd = out.cmd;
        // Last line of defence: nothing non-finite leaves this function.
        let cmd = if cmd.is_finite() {
            d.input_box.clamp(cmd)
        } else {
            Twist::ZERO
        };
        self.last_cmd = cmd;
        StepRecord {
            stamp_s: now_s,
            cmd,
            nominal,
            doaa_cmd,
            state,
            h_m: out.h_m,
            h_next_m: out.h_next_m,
            filter_changed: out.changed,
            condition_held: out.condition_held,
            b_left: b.b_left,
            b_right: b.b_right,
            b_velocity: b.b_velocity,
            d_left_m: c.d_left_m,
            d_right_m: c.d_right_m,
            d_min_m: c.d_min_m,
            d_front_m: c.d_front_m,
            closest_left: c.closest_left,
            closest_right: c.closest_right,
            beams: self.points.beams,
            valid_beams: self.points.valid_count(),
            stop_cause,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

    /// 360 beams over a full turn starting at −π, all at `far` m, with
    /// `(beam, range)` overrides.
    fn ring(far: f32, overrides: &[(usize, f32)]) -> Vec<f32> {
        let mut r = vec![far; 360];
        for &(i, v) in overrides {
            r[i] = v;
        }
        r
    }

    fn scan(ranges: &[f32]) -> LaserScan<'_> {
        LaserScan {
            stamp_s: 1.0,
            angle_min_rad: -PI,
            angle_increment_rad: 2.0 * PI / 360.0,
            range_min_m: 0.12,
            range_max_m: 3.5,
            ranges_m: ranges,
            intensities: &[],
        }
    }

    #[test]
    fn obstacle_close_on_the_left_gives_a_right_turn() {
        // Beam 180 + 45 = 45° left, 0.6 m away.
        let ranges = ring(f32::INFINITY, &[(225, 0.6)]);
        let mut pipe = SafetyPipeline::new(Params::default());
        let rec = pipe.step(&scan(&ranges), 1.0, Twist::new(0.15, 0.0), 0.15);
        assert!(rec.cmd.omega_radps < 0.0, "{rec:?}");
        assert_eq!(rec.state, DoaaState::Avoid);
        assert!(rec.b_left > rec.b_right);
        assert!(rec.condition_held);
    }

    #[test]
    fn obstacle_dead_ahead_inside_d_safe_stops_forward_motion() {
        // Wall segment ahead at 0.3 m (beams −10°..10°): centre distance 0.3 < r + d_safe = 0.378.
        let over: Vec<_> = (170..=190).map(|i| (i, 0.3)).collect();
        let ranges = ring(f32::INFINITY, &over);
        let mut pipe = SafetyPipeline::new(Params::default());
        let rec = pipe.step(&scan(&ranges), 1.0, Twist::new(0.15, 0.0), 0.15);
        assert!(rec.cmd.v_mps <= 0.0, "{rec:?}");
        assert!(rec.h_m < 0.0);
    }

    #[test]
    fn rejected_scan_stops_with_reason() {
        let ranges = ring(1.0, &[]);
        let mut pipe = SafetyPipeline::new(Params::default());
        let mut s = scan(&ranges);
        s.stamp_s = 0.0; // 1 s old, timeout 0.5 s
        let rec = pipe.step(&s, 1.0, Twist::new(0.15, 0.0), 0.0);
        assert_eq!(rec.cmd, Twist::ZERO);
        assert_eq!(rec.state, DoaaState::Stop);
        assert!(matches!(
            rec.stop_cause,
            Some(StopCause::Rejected(crate::algo::scan::ScanRejection::Stale { .. }))
        ));
    }

    #[test]
    fn non_finite_nominal_stops() {
        let ranges = ring(1.0, &[]);
        let mut pipe = SafetyPipeline::new(Params::default());
        let rec = pipe.step(&scan(&ranges), 1.0, Twist::new(f64::NAN, 0.0), 0.0);
        assert_eq!((rec.cmd, rec.stop_cause), (Twist::ZERO, Some(StopCause::BadNominal)));
    }

    #[test]
    fn empty_world_passes_nominal() {
        let ranges = ring(f32::INFINITY, &[]);
        let mut pipe = SafetyPipeline::new(Params::default());
        let rec = pipe.step(&scan(&ranges), 1.0, Twist::new(0.15, 0.05), 0.15);
        assert_eq!(rec.cmd, Twist::new(0.15, 0.05));
        assert_eq!(rec.state, DoaaState::Forward);
        assert_eq!(rec.valid_beams, 0);
        assert!(rec.h_m.is_infinite() && rec.condition_held && !rec.filter_changed);
    }
}
