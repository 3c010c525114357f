//! Trajectory tracking (paper IV.C; eq. 8 completed with Kanayama's law).
//!
//! The paper's eq. 8 gives only the rotation into the robot frame. We use the
//! standard Kanayama et al. (1990) controller on the robot-frame error
//! (e_x, e_y, e_θ):
//!   v = v_r cos e_θ + k_x e_x,
//!   ω = ω_r + v_r (k_y e_y + k_θ sin e_θ),
//! which reduces to the paper's yaw correction e = θ_ref − θ when e_x = e_y = 0.
//!
//! Kanayama's law is local: with the reference behind the robot (e_θ ≈ π after
//! an avoidance detour) it asks for reverse speed and, with sin e_θ ≈ 0, no
//! turn, so a forward-only robot would sit still. Beyond `capture_radius_m`
//! (R_c) the command therefore blends continuously, with weight
//! λ = clamp((‖e‖ − R_c) / R_c, 0, 1) on the go-to-point command (fully at
//! 2 R_c), into a go-to-point law that turns towards the reference point
//! (bearing β = atan2(e_y, e_x)) and drives while it is roughly ahead:
//!   v = (|v_r| + k_x ‖e‖) clamp(2 cos β, 0, 1),  ω = k_β β,
//! full speed for |β| ≤ 60°, none beyond 90°. Keeping the speed up while the
//! DOAA steers is what carries the robot round an obstacle standing between
//! it and the reference (the paper's robot always drives at v_r); scaling v by
//! cos β instead stalls it in front of the obstacle.
//!
//! The speed keeps the reference's sign: a robot ahead of a forward reference
//! (e_x < 0 by more than v_r / k_x) is asked to stop and wait for it, not to
//! back up; the upstream of a forward reference never asks to reverse.

use super::geometry::{wrap_angle, Pose2, Twist, Vec2};
use super::params::TrackingParams;

/// Tracking error in the robot frame: along-track, cross-track (m), heading (rad).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackingError {
    /// Reference position ahead of the robot, along its heading (m).
    pub e_x_m: f64,
    /// Reference position to the robot's left (m).
    pub e_y_m: f64,
    /// Reference heading minus the robot's, wrapped to (−π, π] (rad).
    pub e_theta_rad: f64,
}

impl TrackingError {
    /// The error of `robot` against `reference`, in the robot's frame.
    pub fn between(robot: Pose2, reference: Pose2) -> Self {
        let d = robot.inverse_transform_point(reference.position());
        Self {
            e_x_m: d.x,
            e_y_m: d.y,
            e_theta_rad: wrap_angle(reference.theta - robot.theta),
        }
    }

    /// Position error ‖p_ref − p‖ (m).
    pub fn distance_m(&self) -> f64 {
        self.e_x_m.hypot(self.e_y_m)
    }
}

/// Kanayama's tracking command toward `reference` moving at `reference_twist`.
pub fn kanayama(robot: Pose2, reference: Pose2, reference_twist: Twist, k: &TrackingParams) -> Twist {
    let e = TrackingError::between(robot, reference);
    let vr = reference_twist.v_mps;
    Twist::new(
        vr * e.e_theta_rad.cos() + k.k_x_per_s * e.e_x_m,
        reference_twist.omega_radps + vr * (k.k_y_per_m2 * e.e_y_m + k.k_theta_per_m * e.e_theta_rad.sin()),
    )
}

/// Go-to-point command towards the reference position: turn towards it, drive
/// at full speed while it is within ±60° ahead, tapering to zero at ±90°.
pub fn go_to_point(robot: Pose2, reference: Pose2, reference_twist: Twist, k: &TrackingParams) -> Twist {
    let e = TrackingError::between(robot, reference);
    let bearing = e.e_y_m.atan2(e.e_x_m);
    Twist::new(
        (reference_twist.v_mps.abs() + k.k_x_per_s * e.distance_m()) * (2.0 * bearing.cos()).clamp(0.0, 1.0),
        k.k_bearing_per_s * bearing,
    )
}

/// Towards a point at `speed_mps` (the way round's waypoint, §4b, in the
/// frame of `robot`): go-to-point, at the given speed rather than one that
/// grows with the distance: full speed while the point is within ±60°
/// ahead, tapering to zero at ±90°, turning at k_β per radian of bearing.
pub fn towards_point(robot: Pose2, point: Vec2, speed_mps: f64, k: &TrackingParams) -> Twist {
    let d = robot.inverse_transform_point(point);
    let bearing = d.y.atan2(d.x);
    Twist::new(
        speed_mps * (2.0 * bearing.cos()).clamp(0.0, 1.0),
        k.k_bearing_per_s * bearing,
    )
}

/// The final approach to a goal point: go-to-point, with the speed held to
/// what the turn can follow.
///
/// A unicycle at distance d from a point at bearing β reaches it along the
/// arc of radius d / (2 |sin β|); turning at |ω| it must keep
/// v ≤ |ω| d / (2 |sin β|). Faster, and with |ω| capped at ω_max
/// (`omega_max_radps`), it circles the point instead. Within
/// the bound the bearing falls at least at |ω|/2 while the robot closes in.
pub fn arrive(robot: Pose2, goal: Pose2, k: &TrackingParams, omega_max_radps: f64) -> Twist {
    let cmd = go_to_point(robot, goal, Twist::ZERO, k);
    let e = TrackingError::between(robot, goal);
    let sin_bearing = e.e_y_m.atan2(e.e_x_m).sin().abs();
    let turn_radps = cmd.omega_radps.abs().min(omega_max_radps);
    if sin_bearing == 0.0 {
        return cmd;
    }
    let v_cap_mps = turn_radps * e.distance_m() / (2.0 * sin_bearing);
    Twist::new(cmd.v_mps.min(v_cap_mps), cmd.omega_radps)
}

/// The nominal tracking command: Kanayama within `capture_radius_m` of the
/// reference, blending into `go_to_point` between one and two capture radii.
///
/// Once the reference has ended (zero reference twist) Kanayama cannot steer
/// (every yaw term is multiplied by v_r), so the goal is approached as a
/// point ([`arrive`], turning at most `omega_max_radps`), and the command is
/// zero within `arrive_radius_m`.
pub fn track(
    robot: Pose2,
    reference: Pose2,
    reference_twist: Twist,
    k: &TrackingParams,
    omega_max_radps: f64,
) -> Twist {
    let dist = TrackingError::between(robot, reference).distance_m();
    if reference_twist == Twist::ZERO {
        return if dist <= k.arrive_radius_m {
            Twist::ZERO
        } else {
            arrive(robot, reference, k, omega_max_radps)
        };
    }
    let rc = k.capture_radius_m;
    let lambda = ((dist - rc) / rc).clamp(0.0, 1.0);
    let near = kanayama(robot, reference, reference_twist, k);
    let cmd = if lambda == 0.0 {
        near
    } else {
        let far = go_to_point(robot, reference, reference_twist, k);
        Twist::new(
            (1.0 - lambda) * near.v_mps + lambda * far.v_mps,
            (1.0 - lambda) * near.omega_radps + lambda * far.omega_radps,
        )
    };
    // A robot ahead of a forward reference waits for it rather than backing up
    // (and one behind a reversing reference likewise): the reference moves on at
    // full rate while the robot is ahead ([`super::reference::ReferenceProgress`]),
    // so it catches up, and the upstream never asks the robot to reverse.
    let against_the_reference = cmd.v_mps * reference_twist.v_mps < 0.0;
    Twist::new(if against_the_reference { 0.0 } else { cmd.v_mps }, cmd.omega_radps)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_4;

    #[test]
    fn towards_a_point_turns_to_it_and_drives_only_while_it_is_ahead() {
        let k = TrackingParams::default(); // k_β = 1/s
        let robot = Pose2::new(1.0, 1.0, std::f64::consts::FRAC_PI_2);
        // 1 m straight ahead (north): full speed, no turn.
        let cmd = towards_point(robot, Vec2::new(1.0, 2.0), 0.15, &k);
        assert!(
            (cmd.v_mps - 0.15).abs() < 1e-12 && cmd.omega_radps.abs() < 1e-12,
            "{cmd:?}"
        );
        // 45° to the right: 2 cos 45° > 1, full speed, turning right at π/4 rad/s.
        let cmd = towards_point(robot, Vec2::new(2.0, 2.0), 0.15, &k);
        assert!((cmd.v_mps - 0.15).abs() < 1e-12 && (cmd.omega_radps + FRAC_PI_4).abs() < 1e-12);
        // Behind: turn in place.
        let cmd = towards_point(robot, Vec2::new(1.0, 0.0), 0.15, &k);
        assert!(cmd.v_mps.abs() < 1e-12 && cmd.omega_radps.abs() > 3.0);
    }

    #[test]
    fn zero_error_gives_the_reference_twist() {
        let p = Pose2::new(1.0, 2.0, 0.4);
        assert_eq!(
            kanayama(p, p, Twist::new(0.2, 0.13), &TrackingParams::default()),
            Twist::new(0.2, 0.13)
        );
    }

    #[test]
    fn hand_values() {
        // Robot at origin heading +x; reference 0.1 m ahead, 0.05 m left, heading 0.1 rad.
        let k = TrackingParams::default(); // k_x 1, k_y 10, k_θ 4
        let cmd = kanayama(Pose2::default(), Pose2::new(0.1, 0.05, 0.1), Twist::new(0.15, 0.0), &k);
        assert!((cmd.v_mps - (0.15 * 0.1f64.cos() + 0.1)).abs() < 1e-12);
        assert!((cmd.omega_radps - 0.15 * (10.0 * 0.05 + 4.0 * 0.1f64.sin())).abs() < 1e-12);
    }

    #[test]
    fn far_behind_reference_turns_in_place_towards_it() {
        // Reference 2 m straight behind (beyond 2 R_c = 1 m): pure go-to-point.
        // Bearing π: v = 0, ω = k_β π. Kanayama alone would ask v = −0.15 − 2 and ω = 0.
        let k = TrackingParams::default();
        let robot = Pose2::default();
        let reference = Pose2::new(-2.0, 0.0, 0.0);
        let kan = kanayama(robot, reference, Twist::new(0.15, 0.0), &k);
        // Kanayama: v = 0.15·cos 0 + 1·(−2) = −1.85, ω = 0.15·(10·0 + 4·sin 0) = 0.
        assert!((kan.v_mps + 1.85).abs() < 1e-12 && kan.omega_radps.abs() < 1e-12);
        let cmd = track(robot, reference, Twist::new(0.15, 0.0), &k, 0.3);
        assert!(cmd.v_mps.abs() < 1e-12);
        assert!((cmd.omega_radps.abs() - k.k_bearing_per_s * std::f64::consts::PI).abs() < 1e-12);
    }

    #[test]
    fn blend_is_kanayama_inside_the_capture_radius_and_linear_beyond() {
        let k = TrackingParams::default(); // R_c = 0.5 m
        let robot = Pose2::default();
        let vr = Twist::new(0.15, 0.0);
        let near = Pose2::new(0.3, 0.2, 0.1);
        assert_eq!(track(robot, near, vr, &k, 0.3), kanayama(robot, near, vr, &k));
        // 0.75 m ahead-left: λ = 0.5, the average of both laws.
        let mid = Pose2::new(0.6, 0.45, 0.0);
        let (a, b) = (kanayama(robot, mid, vr, &k), go_to_point(robot, mid, vr, &k));
        let t = track(robot, mid, vr, &k, 0.3);
        assert!((t.v_mps - 0.5 * (a.v_mps + b.v_mps)).abs() < 1e-12);
        assert!((t.omega_radps - 0.5 * (a.omega_radps + b.omega_radps)).abs() < 1e-12);
        // Go-to-point hand values: bearing atan2(0.45, 0.6) = 0.6435 rad (36.9° < 60°: full
        // speed), distance 0.75: v = 0.15 + 0.75.
        assert!((b.v_mps - (0.15 + 0.75)).abs() < 1e-12);
        // At 75° the speed is 2 cos 75° = 0.518 of it.
        let side = Pose2::new(0.75 * 75f64.to_radians().cos(), 0.75 * 75f64.to_radians().sin(), 0.0);
        let g = go_to_point(robot, side, vr, &k);
        assert!((g.v_mps - 0.9 * 2.0 * 75f64.to_radians().cos()).abs() < 1e-12);
        assert!((b.omega_radps - 0.6435).abs() < 1e-4);
    }

    #[test]
    fn ended_reference_is_approached_as_a_point_then_held() {
        let k = TrackingParams::default();
        // Goal 0.3 m to the left: Kanayama with v_r = 0 gives ω = 0 and v = k_x e_x = 0.
        let goal = Pose2::new(0.0, 0.3, 0.0);
        assert_eq!(kanayama(Pose2::default(), goal, Twist::ZERO, &k), Twist::new(0.0, 0.0));
        // Point mode turns towards it: bearing π/2 → v = 0, ω = π/2.
        let cmd = track(Pose2::default(), goal, Twist::ZERO, &k, 10.0);
        assert!(cmd.v_mps.abs() < 1e-12 && (cmd.omega_radps - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        // Within the arrive radius: zero.
        assert_eq!(
            track(Pose2::default(), Pose2::new(0.04, 0.0, 1.0), Twist::ZERO, &k, 0.3),
            Twist::ZERO
        );
    }

    #[test]
    fn final_approach_slows_to_the_turn_it_can_make() {
        let k = TrackingParams::default(); // k_x 1, k_β 1
                                           // Goal 0.6 m away at bearing 45° (left ahead): go-to-point asks
                                           // v = 1·0.6·clamp(2 cos 45°, 0, 1) = 0.6 m/s and ω = k_β π/4 = 0.785 rad/s.
        let goal = Pose2::new(0.6 * FRAC_PI_4.cos(), 0.6 * FRAC_PI_4.sin(), 0.0);
        let free = go_to_point(Pose2::default(), goal, Twist::ZERO, &k);
        assert!((free.v_mps - 0.6).abs() < 1e-12 && (free.omega_radps - FRAC_PI_4).abs() < 1e-12);
        // Turning at most 0.3 rad/s the arc through the goal (radius
        // 0.6 / (2 sin 45°) = 0.4243 m) allows v = 0.3 · 0.4243 = 0.1273 m/s.
        let cmd = arrive(Pose2::default(), goal, &k, 0.3);
        assert!(
            (cmd.v_mps - 0.3 * 0.6 / (2.0 * FRAC_PI_4.sin())).abs() < 1e-12,
            "{cmd:?}"
        );
        assert!((cmd.omega_radps - FRAC_PI_4).abs() < 1e-12);
        // Dead ahead no turn is needed: no cap.
        let ahead = arrive(Pose2::default(), Pose2::new(0.6, 0.0, 0.0), &k, 0.3);
        assert!((ahead.v_mps - 0.6).abs() < 1e-12 && ahead.omega_radps == 0.0);
    }

    #[test]
    fn final_approach_reaches_the_goal_instead_of_circling_it() {
        // A unicycle with |ω| ≤ 0.3 rad/s and v ≤ 0.22 m/s, integrated at 10 Hz,
        // from poses around a goal (the first 0.59 m away at bearing 80°).
        let k = TrackingParams::default();
        let goal = Pose2::new(2.5, 2.5, 0.0);
        for start in [
            Pose2::new(2.398, 1.911, 0.037),
            Pose2::new(2.0, 2.0, -2.0),
            Pose2::new(3.5, 2.5, 1.5),
        ] {
            let mut pose = start;
            let mut arrived_at_s = None;
            for step in 0..600 {
                let cmd = track(pose, goal, Twist::ZERO, &k, 0.3);
                if cmd == Twist::ZERO {
                    arrived_at_s = Some(step as f64 * 0.1);
                    break;
                }
                let (v, w) = (cmd.v_mps.clamp(-0.22, 0.22), cmd.omega_radps.clamp(-0.3, 0.3));
                pose = Pose2::new(
                    pose.x + v * pose.theta.cos() * 0.1,
                    pose.y + v * pose.theta.sin() * 0.1,
                    pose.theta + w * 0.1,
                );
            }
            // Turning to face it takes at most π / 0.3 = 10.5 s, the drive a few seconds.
            let t = arrived_at_s.unwrap_or_else(|| panic!("from {start:?}: still circling at {pose:?}"));
            assert!(t < 30.0, "from {start:?}: {t} s");
        }
    }

    #[test]
    fn a_robot_ahead_of_a_forward_reference_waits_instead_of_reversing() {
        let k = TrackingParams::default(); // k_x 1
        let vr = Twist::new(0.15, 0.0);
        // Reference 0.2 m behind, same heading: Kanayama asks 0.15 + 1·(−0.2) = −0.05 m/s.
        let behind = Pose2::new(-0.2, 0.0, 0.0);
        assert!((kanayama(Pose2::default(), behind, vr, &k).v_mps + 0.05).abs() < 1e-12);
        assert_eq!(track(Pose2::default(), behind, vr, &k, 0.3), Twist::new(0.0, 0.0));
        // 0.1 m behind: 0.05 m/s forward, unchanged.
        let close = Pose2::new(-0.1, 0.0, 0.0);
        assert!((track(Pose2::default(), close, vr, &k, 0.3).v_mps - 0.05).abs() < 1e-12);
        // A reversing reference 0.2 m ahead: Kanayama asks −0.15 + 0.2 = +0.05; held at 0.
        let ahead = Pose2::new(0.2, 0.0, 0.0);
        assert_eq!(
            track(Pose2::default(), ahead, Twist::new(-0.15, 0.0), &k, 0.3).v_mps,
            0.0
        );
    }

    #[test]
    fn error_is_expressed_in_the_robot_frame() {
        // Robot heading +y; a reference at +x world lies to its right (e_y < 0).
        let e = TrackingError::between(
            Pose2::new(0.0, 0.0, std::f64::consts::FRAC_PI_2),
            Pose2::new(1.0, 0.0, 0.0),
        );
        assert!(e.e_x_m.abs() < 1e-12 && (e.e_y_m + 1.0).abs() < 1e-12);
        assert!((e.e_theta_rad + std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }
}
