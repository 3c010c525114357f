//! Wheel feedback → odometry (pose and twist), with the bridge's kinematics.
//!
//! The pose integrates wheel *position* increments, not speeds: positions
//! do not drift with feedback timing jitter or lost frames. Left and right
//! feedback arrive in separate frames; an update happens once both wheels
//! have reported since the last one, so every step uses a matched pair.
//! Each step is integrated as an exact arc (constant curvature).
//!
//! A position increment larger than the wheels could have moved (the drive
//! rebooted and its encoder count restarted) re-baselines instead of
//! teleporting the robot; it is counted and reported.
//!
//! Each step also carries the pose covariance forward and adds the wheels'
//! rotation to their joint angles (for `/joint_states`); the model is in
//! [`covariance`]. A re-baseline adds no motion and no uncertainty: the
//! unknown motion it skips is reported (the reset counter), not guessed.

pub mod covariance;

pub use covariance::{PoseCovariance, TwistCovariance, WheelNoise};

use crate::kinematics::{DiffDrive, Twist, Wheel, WheelSpeeds};
use crate::time::Timestamp;
use serde::Serialize;

/// Pose in the odometry frame (where the robot was when the bridge started).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Pose2D {
    pub x_m: f64,
    pub y_m: f64,
    /// Heading, wrapped to (−π, π] (rad).
    pub theta_rad: f64,
}

/// Wheel rotation since the first feedback (rad at the wheel, positive
/// when the wheel drives the robot forward), unwrapped.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct WheelAngles {
    pub left_rad: f64,
    pub right_rad: f64,
}

/// What odometry reports.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct OdometryState {
    pub pose: Pose2D,
    /// Covariance of (x, y, θ) from the noise model.
    pub pose_covariance: PoseCovariance,
    /// Measured twist (from the wheels' measured speeds).
    pub twist: Twist,
    /// Covariance of (v, ω) from the noise model.
    pub twist_covariance: TwistCovariance,
    /// Measured wheel speeds (rad/s at the wheel).
    pub wheels: WheelSpeeds,
    /// The wheels' joint angles.
    pub wheel_angles: WheelAngles,
    /// Integration steps done.
    pub updates: u64,
    /// Position jumps, and speeds beyond any the robot can reach, that
    /// re-baselined the integration.
    pub resets: u64,
}

#[derive(Clone, Copy, Debug, Default)]
struct WheelTrack {
    /// Last position used for integration (motor rad, as reported).
    base_pos: Option<f64>,
    /// Latest report not yet integrated.
    pending: Option<(f64, f64)>,
}

/// Odometry from motor feedback.
#[derive(Clone, Debug)]
pub struct Odometry {
    kin: DiffDrive,
    noise: WheelNoise,
    modulus_rad: Option<f64>,
    /// Largest plausible wheel speed (rad/s); beyond it a jump is a reset.
    plausible_wheel_speed_radps: f64,
    wheels: [WheelTrack; 2],
    last_update: Option<Timestamp>,
    state: OdometryState,
}

/// Slack on the plausibility bound: an increment is a jump when it exceeds
/// this factor times max speed × elapsed time, plus [`JUMP_FLOOR_RAD`].
const JUMP_FACTOR: f64 = 2.0;
/// Increments below this (wheel rad) are never treated as jumps.
const JUMP_FLOOR_RAD: f64 = 1.0;

impl Odometry {
    /// `modulus_rad`: feedback positions wrap modulo this (motor rad);
    /// `max_wheel_speed_radps`: the configured wheel speed limit, for the
    /// jump check; `noise`: the wheels' measurement noise (the covariance).
    pub fn new(kin: DiffDrive, modulus_rad: Option<f64>, max_wheel_speed_radps: f64, noise: WheelNoise) -> Self {
        let state = OdometryState {
            twist_covariance: TwistCovariance::of(&noise, kin.wheel_radius_m, kin.wheel_separation_m),
            ..OdometryState::default()
        };
        Self {
            kin,
            noise,
            modulus_rad,
            plausible_wheel_speed_radps: max_wheel_speed_radps,
            wheels: [WheelTrack::default(); 2],
            last_update: None,
            state,
        }
    }

    /// The current estimate.
    pub fn state(&self) -> OdometryState {
        self.state
    }

    /// Feedback of one wheel (motor angle in rad, motor speed in rad/s).
    /// Returns true when the pose was updated.
    pub fn on_feedback(&mut self, wheel: Wheel, motor_pos_rad: f64, motor_vel_radps: f64, now: Timestamp) -> bool {
        if !motor_pos_rad.is_finite() || !motor_vel_radps.is_finite() {
            return false;
        }
        self.wheels[wheel.index()].pending = Some((motor_pos_rad, motor_vel_radps));
        let (Some(l), Some(r)) = (self.wheels[0].pending, self.wheels[1].pending) else {
            return false;
        };
        self.wheels[0].pending = None;
        self.wheels[1].pending = None;
        let wheels = WheelSpeeds {
            left_radps: self.kin.motor_to_wheel(Wheel::Left, l.1),
            right_radps: self.kin.motor_to_wheel(Wheel::Right, r.1),
        };
        // A reported speed beyond any the robot can reach is garbage, not motion: it
        // would reach the filter as the robot's speed. Handled like a position jump:
        // nothing of the pair is used, the next pair starts afresh.
        let fastest = JUMP_FACTOR * self.plausible_wheel_speed_radps + JUMP_FLOOR_RAD;
        if wheels.left_radps.abs() > fastest || wheels.right_radps.abs() > fastest {
            self.state.resets += 1;
            self.rebase(l.0, r.0, now);
            return false;
        }
        self.state.wheels = wheels;
        self.state.twist = self.kin.twist(self.state.wheels);
        let (Some(bl), Some(br)) = (self.wheels[0].base_pos, self.wheels[1].base_pos) else {
            self.rebase(l.0, r.0, now);
            return false;
        };
        let dl = self.kin.motor_to_wheel(Wheel::Left, self.delta(bl, l.0));
        let dr = self.kin.motor_to_wheel(Wheel::Right, self.delta(br, r.0));
        let dt = self.last_update.map_or(0.0, |t| (now - t).as_secs_f64());
        let bound = JUMP_FACTOR * self.plausible_wheel_speed_radps * dt + JUMP_FLOOR_RAD;
        if dl.abs() > bound || dr.abs() > bound {
            self.state.resets += 1;
            self.rebase(l.0, r.0, now);
            return false;
        }
        self.integrate(dl, dr);
        self.rebase(l.0, r.0, now);
        self.state.updates += 1;
        true
    }

    fn rebase(&mut self, l: f64, r: f64, now: Timestamp) {
        self.wheels[0].base_pos = Some(l);
        self.wheels[1].base_pos = Some(r);
        self.last_update = Some(now);
    }

    /// Motor angle increment, unwrapped when positions wrap.
    fn delta(&self, from: f64, to: f64) -> f64 {
        let d = to - from;
        match self.modulus_rad {
            Some(m) => {
                let d = d.rem_euclid(m);
                if d > 0.5 * m {
                    d - m
                } else {
                    d
                }
            }
            None => d,
        }
    }

    /// Exact arc for wheel angle increments (rad at the wheel); the
    /// covariance and the joint angles follow.
    fn integrate(&mut self, dl_rad: f64, dr_rad: f64) {
        let r = self.kin.wheel_radius_m;
        let (sl, sr) = (dl_rad * r, dr_rad * r);
        let ds = 0.5 * (sl + sr);
        let dth = (sr - sl) / self.kin.wheel_separation_m;
        self.state.wheel_angles.left_rad += dl_rad;
        self.state.wheel_angles.right_rad += dr_rad;
        let th = self.state.pose.theta_rad;
        self.state
            .pose_covariance
            .step(th, sl, sr, self.kin.wheel_separation_m, &self.noise);
        let p = &mut self.state.pose;
        if dth.abs() < 1e-9 {
            // Straight (second-order term keeps tiny turns accurate).
            p.x_m += ds * (th + 0.5 * dth).cos();
            p.y_m += ds * (th + 0.5 * dth).sin();
        } else {
            let rad = ds / dth;
            p.x_m += rad * ((th + dth).sin() - th.sin());
            p.y_m += -rad * ((th + dth).cos() - th.cos());
        }
        p.theta_rad = wrap_angle(th + dth);
    }
}

/// Wraps an angle to (−π, π].
pub fn wrap_angle(a: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    let w = (a + PI).rem_euclid(TAU) - PI;
    if w <= -PI {
        w + TAU
    } else {
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    fn kin() -> DiffDrive {
        DiffDrive {
            wheel_separation_m: 0.16,
            wheel_radius_m: 0.033,
            gear_ratio: 10.0,
            left_direction: 1.0,
            right_direction: -1.0,
        }
    }

    const NOISE: WheelNoise = WheelNoise {
        left_travel_variance_m2_per_m: 1e-3,
        right_travel_variance_m2_per_m: 1e-3,
        left_speed_sigma_radps: 0.1,
        right_speed_sigma_radps: 0.1,
    };

    fn t(s: f64) -> Timestamp {
        Timestamp::from_secs_f64(s)
    }

    /// Feeds wheel angles (rad at the wheel) as motor angles.
    fn feed(o: &mut Odometry, wl: f64, wr: f64, now: f64) -> bool {
        let k = kin();
        o.on_feedback(Wheel::Left, wl * k.motor_per_wheel(Wheel::Left), 0.0, t(now));
        o.on_feedback(Wheel::Right, wr * k.motor_per_wheel(Wheel::Right), 0.0, t(now))
    }

    #[test]
    fn straight_line_by_hand() {
        let mut o = Odometry::new(kin(), None, 100.0, NOISE);
        assert!(!feed(&mut o, 0.0, 0.0, 0.0), "first pair only sets the base");
        // Both wheels turn 10 rad: 10 × 0.033 = 0.33 m ahead.
        for i in 1..=10 {
            assert!(feed(&mut o, i as f64, i as f64, 0.1 * i as f64));
        }
        let p = o.state().pose;
        assert!(
            (p.x_m - 0.33).abs() < 1e-12 && p.y_m.abs() < 1e-12 && p.theta_rad.abs() < 1e-12,
            "{p:?}"
        );
    }

    /// The joint angles are the wheels' rotation at the wheel, forward
    /// positive, unwrapped (the right motor runs reversed); the covariance
    /// of a straight 0.33 m is the model's σ_x² = k·D/2, σ_θ² = 2k·D/L².
    #[test]
    fn joint_angles_and_covariance_follow_the_steps() {
        let mut o = Odometry::new(kin(), Some(100.0), 100.0, NOISE);
        feed(&mut o, 0.0, 0.0, 0.0);
        for i in 1..=10 {
            feed(&mut o, i as f64, i as f64, 0.1 * i as f64);
        }
        let s = o.state();
        assert!((s.wheel_angles.left_rad - 10.0).abs() < 1e-9 && (s.wheel_angles.right_rad - 10.0).abs() < 1e-9);
        let d = 0.33;
        assert!((s.pose_covariance.0[0][0] - 1e-3 * d / 2.0).abs() < 1e-15, "{s:?}");
        assert!(
            (s.pose_covariance.0[2][2] - 2e-3 * d / (0.16 * 0.16)).abs() < 1e-12,
            "{s:?}"
        );
        // Backwards: the angles go down again, the uncertainty keeps growing.
        feed(&mut o, 9.0, 10.0, 1.1);
        let s2 = o.state();
        assert!((s2.wheel_angles.left_rad - 9.0).abs() < 1e-9 && (s2.wheel_angles.right_rad - 10.0).abs() < 1e-9);
        assert!(s2.pose_covariance.0[2][2] > s.pose_covariance.0[2][2]);
        // The twist covariance is the model's for r = 0.033, σ = 0.1: r²·0.02/4.
        assert!((s.twist_covariance.0[0][0] - 0.033f64.powi(2) * 0.02 / 4.0).abs() < 1e-18);
    }

    #[test]
    fn turn_in_place_by_hand() {
        let mut o = Odometry::new(kin(), None, 100.0, NOISE);
        feed(&mut o, 0.0, 0.0, 0.0);
        // Quarter turn: each wheel travels (π/2)·L/2 = 0.04π m → 0.04π/0.033 rad.
        let w = 0.04 * PI / 0.033;
        for i in 1..=4 {
            let f = i as f64 / 4.0;
            feed(&mut o, -w * f, w * f, 0.1 * i as f64);
        }
        let p = o.state().pose;
        assert!((p.theta_rad - FRAC_PI_2).abs() < 1e-12 && p.x_m.abs() < 1e-12 && p.y_m.abs() < 1e-12);
    }

    #[test]
    fn arc_is_exact() {
        // Constant curvature: right wheel 2× the left. A quarter circle of
        // radius R: centre line s = R·π/2; wheels R ∓ L/2.
        let mut o = Odometry::new(kin(), None, 1000.0, NOISE);
        feed(&mut o, 0.0, 0.0, 0.0);
        let big_r = 0.24; // (R − 0.08) : (R + 0.08) = 1 : 2
        let (sl, sr) = ((big_r - 0.08) * FRAC_PI_2, (big_r + 0.08) * FRAC_PI_2);
        feed(&mut o, sl / 0.033, sr / 0.033, 1.0);
        let p = o.state().pose;
        assert!((p.x_m - big_r).abs() < 1e-12 && (p.y_m - big_r).abs() < 1e-12, "{p:?}");
        assert!((p.theta_rad - FRAC_PI_2).abs() < 1e-12);
    }

    #[test]
    fn wrapping_positions_unwrap() {
        let m = 100.0;
        let mut o = Odometry::new(kin(), Some(m), 100.0, NOISE);
        let k = kin();
        // Motor angles wrap at 100 rad: left goes 95 → 5 (+10), right −(95 → 5) i.e. 5 → 95 (−10).
        o.on_feedback(Wheel::Left, 95.0, 0.0, t(0.0));
        o.on_feedback(Wheel::Right, 5.0, 0.0, t(0.0));
        o.on_feedback(Wheel::Left, 5.0, 0.0, t(0.1));
        assert!(o.on_feedback(Wheel::Right, 95.0, 0.0, t(0.1)));
        // +10 motor rad → +1 wheel rad on both (right motor reversed).
        let expect = 1.0 * k.wheel_radius_m;
        assert!((o.state().pose.x_m - expect).abs() < 1e-12, "{:?}", o.state());
    }

    #[test]
    fn measured_twist_from_speeds() {
        let k = kin();
        let mut o = Odometry::new(k, None, 100.0, NOISE);
        // Wheel speeds 4 and 6 rad/s → v = 0.033·5 = 0.165, ω = 0.033·2/0.16 = 0.4125.
        o.on_feedback(Wheel::Left, 0.0, 4.0 * k.motor_per_wheel(Wheel::Left), t(0.0));
        o.on_feedback(Wheel::Right, 0.0, 6.0 * k.motor_per_wheel(Wheel::Right), t(0.0));
        let tw = o.state().twist;
        assert!((tw.linear_mps - 0.165).abs() < 1e-12 && (tw.angular_radps - 0.4125).abs() < 1e-12);
    }

    #[test]
    fn implausible_jump_rebaselines() {
        let mut o = Odometry::new(kin(), None, 10.0, NOISE);
        feed(&mut o, 0.0, 0.0, 0.0);
        feed(&mut o, 0.5, 0.5, 0.1);
        let before = o.state().pose;
        // 1000 wheel rad in 0.1 s at a 10 rad/s limit: a reset, not motion.
        assert!(!feed(&mut o, 1000.0, 1000.0, 0.2));
        assert_eq!(o.state().pose, before);
        assert_eq!(o.state().resets, 1);
        assert!(feed(&mut o, 1000.5, 1000.5, 0.3));
        assert!((o.state().pose.x_m - 2.0 * 0.5 * 0.033).abs() < 1e-12);
    }

    #[test]
    fn an_implausible_speed_is_a_reset_not_a_twist() {
        let k = kin();
        let mut o = Odometry::new(k, None, 10.0, NOISE);
        feed(&mut o, 0.0, 0.0, 0.0);
        // Bound: 2 × 10 + 1 = 21 wheel rad/s. The generic protocol's most negative
        // count decodes to -21474.8 motor rad/s.
        o.on_feedback(Wheel::Left, 0.0, -21474.83648, t(0.1));
        assert!(!o.on_feedback(Wheel::Right, 0.0, 0.0, t(0.1)));
        assert_eq!(o.state().twist.linear_mps, 0.0);
        assert_eq!(o.state().resets, 1);
        // Within it, the twist is taken: 20 wheel rad/s on both wheels.
        o.on_feedback(Wheel::Left, 0.0, 20.0 * k.motor_per_wheel(Wheel::Left), t(0.2));
        o.on_feedback(Wheel::Right, 0.0, 20.0 * k.motor_per_wheel(Wheel::Right), t(0.2));
        assert!((o.state().twist.linear_mps - 20.0 * 0.033).abs() < 1e-12);
        assert_eq!(o.state().resets, 1);
    }

    #[test]
    fn non_finite_feedback_is_ignored() {
        let mut o = Odometry::new(kin(), None, 10.0, NOISE);
        let before = o.state();
        assert!(!o.on_feedback(Wheel::Left, f64::NAN, 0.0, t(0.0)));
        assert_eq!(o.state(), before);
        assert_eq!((before.updates, before.pose), (0, Pose2D::default()));
    }

    #[test]
    fn wrap_angle_range() {
        assert!((wrap_angle(3.0 * PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(-PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(0.5) - 0.5).abs() < 1e-15);
        assert!((wrap_angle(-3.5 * PI) - 0.5 * PI).abs() < 1e-12);
    }
}
