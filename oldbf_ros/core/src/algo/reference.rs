//! Reference trajectories from a virtual unicycle (paper IV.B eq. 7).
//!
//! The virtual robot starts at `start` and is driven by a constant (v_r, ω_r)
//! for `duration_s`, then holds its final pose (the goal). Its pose is the
//! exact closed-form solution, so long runs do not accumulate integration
//! error. A line is ω_r = 0; the paper's circle is v_r = 0.2 m/s,
//! ω_r = 0.13 rad/s, whose radius is v_r/ω_r ≈ 1.54 m (the paper says 0.2 m).
//!
//! Departure: the paper's reference advances with time alone. While the robot
//! is held up by an obstacle such a reference runs away, ends up metres ahead
//! on the far side of the obstacle, and the tracking law then drags the robot
//! straight at it. [`ReferenceProgress`] governs the virtual robot instead:
//! it runs at full rate while the robot is within the capture radius R_c,
//! slows linearly, and waits when the robot is 2 R_c or more behind.
//! "Behind" is [`ReferenceProgress::lag_m`]: the distance to the virtual
//! robot without the part by which the robot is already *ahead* of it along
//! its heading. A robot that went round an obstacle and came out further
//! along the path is not waited for; the reference catches up with it
//! instead. (With the plain distance, the reference stands still behind
//! such a robot, whose tracking law then drives it back towards the
//! reference, and the robot stalls.)

use super::geometry::{Pose2, Twist};
use super::unicycle::arc_step;
use serde::{Deserialize, Serialize};

/// A reference trajectory.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReferenceTrajectory {
    /// Pose of the virtual robot at t = 0 (m, m, rad).
    pub start: Pose2,
    /// v_r (m/s).
    pub v_mps: f64,
    /// ω_r (rad/s); 0 for a line.
    pub omega_radps: f64,
    /// How long the virtual robot moves (s); it then holds its pose.
    pub duration_s: f64,
}

impl ReferenceTrajectory {
    /// A straight line of `length_m` at speed v_r.
    pub fn line(start: Pose2, v_mps: f64, length_m: f64) -> Self {
        Self {
            start,
            v_mps,
            omega_radps: 0.0,
            duration_s: length_m / v_mps,
        }
    }

    /// `laps` full circles at (v_r, ω_r).
    pub fn circle(start: Pose2, v_mps: f64, omega_radps: f64, laps: f64) -> Self {
        Self {
            start,
            v_mps,
            omega_radps,
            duration_s: laps * 2.0 * std::f64::consts::PI / omega_radps.abs(),
        }
    }

    /// Reference pose at time t (s since start).
    pub fn pose_at(&self, t_s: f64) -> Pose2 {
        let t = t_s.clamp(0.0, self.duration_s);
        arc_step(self.start, Twist::new(self.v_mps, self.omega_radps), t)
    }

    /// Reference velocity (v_r, ω_r) at time t: zero once the trajectory ended.
    pub fn twist_at(&self, t_s: f64) -> Twist {
        if t_s < self.duration_s {
            Twist::new(self.v_mps, self.omega_radps)
        } else {
            Twist::ZERO
        }
    }

    /// Where the trajectory ends (the goal).
    pub fn goal(&self) -> Pose2 {
        self.pose_at(self.duration_s)
    }

    /// Radius of the path (m); +inf for a line.
    pub fn radius_m(&self) -> f64 {
        if self.omega_radps == 0.0 {
            f64::INFINITY
        } else {
            (self.v_mps / self.omega_radps).abs()
        }
    }
}

/// Progress of the virtual robot along its trajectory (s of trajectory time),
/// governed by how far behind the real robot is.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ReferenceProgress {
    /// Trajectory time reached so far (s).
    pub t_s: f64,
}

impl ReferenceProgress {
    /// How far the robot at `robot` lags the virtual robot at `reference` (m):
    /// the distance between them, less the along-heading part by which the
    /// robot is ahead. hypot(min(a, 0), c) with a the robot's offset along
    /// the reference heading and c across it.
    pub fn lag_m(robot: Pose2, reference: Pose2) -> f64 {
        let d = reference.inverse_transform_point(robot.position());
        d.x.min(0.0).hypot(d.y)
    }

    /// Progress rate for a lag (m, [`Self::lag_m`]): 1 within R_c, 0 beyond 2 R_c.
    pub fn rate(error_m: f64, capture_radius_m: f64) -> f64 {
        if !error_m.is_finite() {
            return 0.0;
        }
        ((2.0 * capture_radius_m - error_m) / capture_radius_m).clamp(0.0, 1.0)
    }

    /// The reference pose now, and its velocity scaled by the progress rate.
    pub fn reference(&self, r: &ReferenceTrajectory, rate: f64) -> (Pose2, Twist) {
        let tw = r.twist_at(self.t_s);
        (r.pose_at(self.t_s), Twist::new(tw.v_mps * rate, tw.omega_radps * rate))
    }

    /// Moves the virtual robot up to the real one when the real one is ahead of
    /// it along its direction of travel by a (m) and within `capture_radius_m`
    /// of its path sideways: t += a / |v_r|, up to the trajectory's end. Left
    /// behind, the reference would have the tracking law stop a robot that came
    /// out of a detour further along, or turn it back; a robot off to the side
    /// by more than R_c is left to rejoin the path first (its projection may lie
    /// beside the obstacle it went round). On an arc the tangent's a is a
    /// first-order step; repeated each tick it settles on the robot's abreast
    /// point.
    pub fn catch_up(&mut self, r: &ReferenceTrajectory, robot: Pose2, capture_radius_m: f64) {
        let speed_mps = r.v_mps.abs();
        if speed_mps == 0.0 || self.finished(r) {
            return;
        }
        let d = r.pose_at(self.t_s).inverse_transform_point(robot.position());
        let ahead_m = d.x * r.v_mps.signum();
        if ahead_m > 0.0 && d.y.abs() <= capture_radius_m {
            self.t_s = (self.t_s + ahead_m / speed_mps).min(r.duration_s);
        }
    }

    /// Advances by one control period at the given rate.
    pub fn advance(&mut self, dt_s: f64, rate: f64) {
        self.t_s += dt_s * rate;
    }

    /// Whether the virtual robot has reached the end of the trajectory.
    pub fn finished(&self, r: &ReferenceTrajectory) -> bool {
        self.t_s >= r.duration_s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_reaches_its_length_and_holds() {
        let r = ReferenceTrajectory::line(Pose2::new(0.0, 1.0, 0.0), 0.15, 6.0);
        assert!((r.duration_s - 40.0).abs() < 1e-12);
        assert!((r.pose_at(20.0).x - 3.0).abs() < 1e-12);
        assert_eq!(r.goal(), r.pose_at(1000.0));
        assert!((r.goal().x - 6.0).abs() < 1e-12 && r.goal().y == 1.0);
        assert_eq!(r.twist_at(41.0), Twist::ZERO);
    }

    #[test]
    fn progress_waits_for_a_robot_that_falls_behind() {
        // R_c = 0.5: full rate up to 0.5 m, half at 0.75 m, none from 1 m.
        assert_eq!(ReferenceProgress::rate(0.3, 0.5), 1.0);
        assert!((ReferenceProgress::rate(0.75, 0.5) - 0.5).abs() < 1e-12);
        assert_eq!(ReferenceProgress::rate(1.2, 0.5), 0.0);
        assert_eq!(ReferenceProgress::rate(f64::NAN, 0.5), 0.0);
        let r = ReferenceTrajectory::line(Pose2::default(), 0.15, 1.5);
        let mut p = ReferenceProgress::default();
        p.advance(4.0, 1.0);
        p.advance(4.0, 0.5);
        assert!((p.t_s - 6.0).abs() < 1e-12);
        let (pose, tw) = p.reference(&r, 0.5);
        assert!((pose.x - 0.9).abs() < 1e-12 && (tw.v_mps - 0.075).abs() < 1e-12);
        assert!(!p.finished(&r));
        p.advance(4.0, 1.0);
        assert!(p.finished(&r));
    }

    #[test]
    fn a_robot_ahead_along_the_path_is_not_waited_for() {
        // Reference at the origin heading +x.
        let r = Pose2::new(0.0, 0.0, 0.0);
        // 1.5 m ahead on the line: no lag (the plain distance, 1.5 m, stopped the reference).
        assert_eq!(ReferenceProgress::lag_m(Pose2::new(1.5, 0.0, 3.0), r), 0.0);
        // Ahead but 0.8 m to the side: the side offset alone.
        assert!((ReferenceProgress::lag_m(Pose2::new(1.0, 0.8, 0.0), r) - 0.8).abs() < 1e-12);
        // Behind: the whole distance, 3-4-5.
        assert!((ReferenceProgress::lag_m(Pose2::new(-0.3, 0.4, 0.0), r) - 0.5).abs() < 1e-12);
        // A reference heading -y: a robot at (0, -1) is 1 m ahead of it.
        let down = Pose2::new(0.0, 0.0, -std::f64::consts::FRAC_PI_2);
        assert!(ReferenceProgress::lag_m(Pose2::new(0.0, -1.0, 0.0), down) < 1e-12);
        assert!((ReferenceProgress::lag_m(Pose2::new(0.0, 1.0, 0.0), down) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn a_robot_ahead_near_the_path_is_caught_up_with() {
        // A line along +x from the origin at 0.15 m/s, 3 m long (20 s).
        let r = ReferenceTrajectory::line(Pose2::default(), 0.15, 3.0);
        let at = |t_s: f64, robot: Pose2| {
            let mut p = ReferenceProgress { t_s };
            p.catch_up(&r, robot, 0.5);
            p.t_s
        };
        // 0.6 m ahead, 0.3 m aside (within R_c): abreast of it, t = 0.6 / 0.15 = 4 s.
        assert!((at(0.0, Pose2::new(0.6, 0.3, 0.0)) - 4.0).abs() < 1e-12);
        // 0.8 m aside: left alone; behind: left alone.
        assert_eq!(at(0.0, Pose2::new(0.6, 0.8, 0.0)), 0.0);
        assert_eq!(at(2.0, Pose2::new(0.1, 0.0, 0.0)), 2.0);
        // Past the end: held at the end (the goal).
        assert_eq!(at(10.0, Pose2::new(3.5, 0.0, 0.0)), 20.0);
        // On the paper's circle (radius 1.54 m) a robot a quarter lap on, on the path:
        // the tangent steps settle on it within a few ticks.
        let c = ReferenceTrajectory::circle(Pose2::default(), 0.2, 0.13, 1.0);
        let quarter_s = 0.25 * c.duration_s;
        let robot = c.pose_at(quarter_s);
        let mut p = ReferenceProgress::default();
        // A quarter lap is 2.4 m along but only 1.54 m ahead along the start's tangent,
        // and beyond R_c aside from it: not caught up from the start.
        p.catch_up(&c, robot, 0.5);
        assert_eq!(p.t_s, 0.0);
        p.t_s = quarter_s - 2.0; // 0.4 m behind it on the arc
        for _ in 0..5 {
            p.catch_up(&c, robot, 0.5);
        }
        assert!((p.t_s - quarter_s).abs() < 1e-3, "{} vs {quarter_s}", p.t_s);
    }

    #[test]
    fn paper_circle_radius() {
        let r = ReferenceTrajectory::circle(Pose2::default(), 0.2, 0.13, 1.0);
        assert!((r.radius_m() - 1.538_461_538).abs() < 1e-6);
        assert!(r.goal().position().norm() < 1e-9);
    }
}
