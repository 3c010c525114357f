//! The simulated robot: a unicycle (differential drive) whose actual velocity
//! follows the commanded one within speed and acceleration limits.
//!
//! Why: the safety filter issues velocity commands; what keeps a real base
//! from executing them instantly is its speed and acceleration limits, and
//! what decides a collision is its footprint. This file holds exactly that —
//! a disc footprint, the limits (with presets for the two target robots),
//! and an exact arc integration of the resulting motion.
//!
//! Units: m, s, rad, m/s, rad/s, m/s², rad/s².

use super::world::World;
use crate::algo::geometry::{Pose2, Twist};
use crate::algo::unicycle::arc_step;
use oldbf::config::{Checker, ParamError, Validate};
use serde::{Deserialize, Serialize};

/// Robots with built-in limits (YAML: `turtlebot3_burger`, `quanser_qbot`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RobotPreset {
    /// ROBOTIS TurtleBot3 Burger. Footprint radius 0.105 m (`robot_radius`
    /// in ROBOTIS' turtlebot3_navigation costmap config), v_max 0.22 m/s and
    /// ω_max 2.84 rad/s (the Burger's documented maxima), accel 2.5 m/s² and
    /// yaw accel 3.2 rad/s² (`acc_lim_x` / `acc_lim_theta` of ROBOTIS' DWA
    /// planner config for the Burger).
    Turtlebot3Burger,
    /// Quanser QBot 2e (Kobuki base). Approximate values from the Kobuki base
    /// datasheet: footprint radius 0.175 m (351.5 mm diameter), v_max 0.7 m/s,
    /// ω_max π rad/s (180°/s); accel 1.0 m/s² and yaw accel 3.0 rad/s² are
    /// conservative approximations (the datasheet gives no acceleration
    /// limits).
    QuanserQbot,
}

impl RobotPreset {
    /// The preset's limits (see the variant docs for the sources).
    pub fn limits(self) -> RobotLimits {
        match self {
            RobotPreset::Turtlebot3Burger => RobotLimits {
                body_radius_m: 0.105,
                v_max_mps: 0.22,
                omega_max_radps: 2.84,
                accel_max_mps2: 2.5,
                omega_accel_max_radps2: 3.2,
            },
            RobotPreset::QuanserQbot => RobotLimits {
                body_radius_m: 0.175,
                v_max_mps: 0.7,
                // 180°/s in the Kobuki datasheet.
                omega_max_radps: std::f64::consts::PI,
                accel_max_mps2: 1.0,
                omega_accel_max_radps2: 3.0,
            },
        }
    }
}

/// A robot as written in a scenario file: a preset plus optional overrides.
/// (The start pose belongs to the scenario, not here.)
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotSpec {
    pub preset: RobotPreset,
    /// Footprint disc radius (m).
    #[serde(default)]
    pub body_radius_m: Option<f64>,
    /// Maximum |linear speed| (m/s), forward and reverse.
    #[serde(default)]
    pub v_max_mps: Option<f64>,
    /// Maximum |yaw rate| (rad/s).
    #[serde(default)]
    pub omega_max_radps: Option<f64>,
    /// Maximum |linear acceleration| (m/s²).
    #[serde(default)]
    pub accel_max_mps2: Option<f64>,
    /// Maximum |yaw acceleration| (rad/s²).
    #[serde(default)]
    pub omega_accel_max_radps2: Option<f64>,
}

impl RobotSpec {
    /// A spec with the preset's values and no overrides.
    pub fn from_preset(preset: RobotPreset) -> Self {
        Self {
            preset,
            body_radius_m: None,
            v_max_mps: None,
            omega_max_radps: None,
            accel_max_mps2: None,
            omega_accel_max_radps2: None,
        }
    }

    /// The preset's limits with the overrides applied, validated; every
    /// invalid value names its key (`robot.<field>`).
    pub fn resolve(&self) -> Result<RobotLimits, Vec<ParamError>> {
        let l = self.limits();
        l.validate()?;
        Ok(l)
    }

    /// The preset's limits with the overrides applied, not yet checked.
    pub fn limits(&self) -> RobotLimits {
        let p = self.preset.limits();
        RobotLimits {
            body_radius_m: self.body_radius_m.unwrap_or(p.body_radius_m),
            v_max_mps: self.v_max_mps.unwrap_or(p.v_max_mps),
            omega_max_radps: self.omega_max_radps.unwrap_or(p.omega_max_radps),
            accel_max_mps2: self.accel_max_mps2.unwrap_or(p.accel_max_mps2),
            omega_accel_max_radps2: self.omega_accel_max_radps2.unwrap_or(p.omega_accel_max_radps2),
        }
    }
}

/// Footprint and motion limits of a robot. All values > 0 and finite.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RobotLimits {
    /// Footprint disc radius (m).
    pub body_radius_m: f64,
    /// Maximum |v| (m/s).
    pub v_max_mps: f64,
    /// Maximum |ω| (rad/s).
    pub omega_max_radps: f64,
    /// Maximum |dv/dt| (m/s²).
    pub accel_max_mps2: f64,
    /// Maximum |dω/dt| (rad/s²).
    pub omega_accel_max_radps2: f64,
}

impl Validate for RobotLimits {
    /// Every value > 0 and finite; keys `robot.<field>`.
    fn check(&self, c: &mut Checker) {
        for (key, value) in [
            ("robot.body_radius_m", self.body_radius_m),
            ("robot.v_max_mps", self.v_max_mps),
            ("robot.omega_max_radps", self.omega_max_radps),
            ("robot.accel_max_mps2", self.accel_max_mps2),
            ("robot.omega_accel_max_radps2", self.omega_accel_max_radps2),
        ] {
            c.rule(value.is_finite() && value > 0.0, key, value, "> 0 and finite");
        }
    }
}

/// Limits `x` to [−bound, bound] without `f64::clamp`'s panics (a bad bound
/// cannot crash the simulator). A NaN `x` gives 0.
fn limit(x: f64, bound: f64) -> f64 {
    if x.is_nan() {
        0.0
    } else {
        x.min(bound).max(-bound)
    }
}

/// The simulated robot: pose, actual velocity, limits.
#[derive(Debug, Clone, PartialEq)]
pub struct SimRobot {
    /// Pose in the world frame (m, rad).
    pub pose: Pose2,
    /// Actual (rate-limited) velocity (m/s, rad/s).
    pub twist: Twist,
    limits: RobotLimits,
}

impl SimRobot {
    /// A robot at rest at `pose`. `limits` should come from
    /// [`RobotSpec::resolve`] (or have passed [`RobotLimits::validate`]);
    /// invalid limits never panic but make the robot's motion meaningless.
    pub fn new(pose: Pose2, limits: RobotLimits) -> Self {
        Self {
            pose,
            twist: Twist::ZERO,
            limits,
        }
    }

    pub fn limits(&self) -> &RobotLimits {
        &self.limits
    }

    /// Advances by `dt_s` (s) under the command `cmd`:
    /// 1. non-finite command components are treated as 0 (garbage stops it);
    /// 2. the command is clamped to ±v_max and ±ω_max (reverse allowed);
    /// 3. the actual twist moves toward it by at most accel·dt and
    ///    yaw_accel·dt;
    /// 4. the pose follows the exact arc of that twist held over dt.
    ///
    /// A non-finite or non-positive `dt_s` does nothing.
    pub fn step(&mut self, cmd: Twist, dt_s: f64) {
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return;
        }
        let finite_or_zero = |x: f64| if x.is_finite() { x } else { 0.0 };
        let l = &self.limits;
        let v_cmd = limit(finite_or_zero(cmd.v_mps), l.v_max_mps);
        let w_cmd = limit(finite_or_zero(cmd.omega_radps), l.omega_max_radps);
        let v = self.twist.v_mps + limit(v_cmd - self.twist.v_mps, l.accel_max_mps2 * dt_s);
        let w = self.twist.omega_radps + limit(w_cmd - self.twist.omega_radps, l.omega_accel_max_radps2 * dt_s);
        self.twist = Twist::new(v, w);
        self.pose = arc_step(self.pose, self.twist, dt_s);
    }

    /// Distance (m) from the footprint disc to the nearest obstacle surface:
    /// `world.distance_to_nearest(position) − body_radius_m`. Negative means
    /// a collision (the penetration depth); `+inf` in an empty world.
    pub fn clearance_m(&self, world: &World) -> f64 {
        world.distance_to_nearest(self.pose.position()) - self.limits.body_radius_m
    }

    /// True if the footprint overlaps an obstacle (clearance strictly < 0).
    pub fn collides(&self, world: &World) -> bool {
        self.clearance_m(world) < 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::world::{CircleSpec, WallSpec, WorldSpec};

    fn burger() -> SimRobot {
        SimRobot::new(Pose2::default(), RobotPreset::Turtlebot3Burger.limits())
    }

    #[test]
    fn presets_and_overrides_resolve() {
        let l = RobotSpec::from_preset(RobotPreset::Turtlebot3Burger)
            .resolve()
            .expect("valid");
        assert_eq!(l.body_radius_m, 0.105);
        assert_eq!(l.v_max_mps, 0.22);
        assert_eq!(l.omega_max_radps, 2.84);
        assert_eq!(l.accel_max_mps2, 2.5);
        assert_eq!(l.omega_accel_max_radps2, 3.2);
        let q: RobotSpec = serde_yaml::from_str("preset: quanser_qbot\nv_max_mps: 0.5\n").expect("parses");
        let l = q.resolve().expect("valid");
        assert_eq!(l.v_max_mps, 0.5);
        assert_eq!(l.body_radius_m, 0.175);
        assert_eq!(l.omega_max_radps, std::f64::consts::PI);
        assert!(serde_yaml::from_str::<RobotSpec>("preset: quanser_qbot\nstart: [0, 0, 0]\n").is_err());
        assert!(serde_yaml::from_str::<RobotSpec>("preset: roomba\n").is_err());
    }

    #[test]
    fn bad_overrides_name_the_key() {
        let err = |s: &RobotSpec| s.resolve().unwrap_err()[0].to_string();
        let mut s = RobotSpec::from_preset(RobotPreset::QuanserQbot);
        s.accel_max_mps2 = Some(-1.0);
        let e = err(&s);
        assert_eq!(
            e,
            "key `robot.accel_max_mps2` = -1 is out of range; allowed: > 0 and finite"
        );
        s.accel_max_mps2 = None;
        s.body_radius_m = Some(f64::NAN);
        assert!(err(&s).starts_with("key `robot.body_radius_m` = NaN"));
        s.body_radius_m = None;
        s.omega_accel_max_radps2 = Some(0.0);
        assert!(err(&s).starts_with("key `robot.omega_accel_max_radps2`"));
    }

    #[test]
    fn acceleration_limited_ramp() {
        // Burger: 2.5 m/s² · 0.02 s = 0.05 m/s per step towards 0.22 m/s.
        let mut r = burger();
        let expect_v = [0.05, 0.10, 0.15, 0.20, 0.22, 0.22];
        // x += v·dt: 0.001, 0.003, 0.006, 0.010, 0.0144, 0.0188.
        let expect_x = [0.001, 0.003, 0.006, 0.010, 0.0144, 0.0188];
        for k in 0..6 {
            r.step(Twist::new(1.0, 0.0), 0.02);
            assert!((r.twist.v_mps - expect_v[k]).abs() < 1e-12, "step {k}");
            assert!((r.pose.x - expect_x[k]).abs() < 1e-12, "step {k}");
            assert_eq!(r.pose.y, 0.0);
        }
        // Braking from 0.22 to 0: 0.17, 0.12, …
        r.step(Twist::ZERO, 0.02);
        assert!((r.twist.v_mps - 0.17).abs() < 1e-12);
        // Reverse is limited to −v_max.
        for _ in 0..50 {
            r.step(Twist::new(-3.0, 0.0), 0.02);
        }
        assert!((r.twist.v_mps + 0.22).abs() < 1e-12);
    }

    #[test]
    fn turning_is_rate_limited_and_clamped() {
        // 3.2 rad/s² · 0.1 s = 0.32 rad/s per step towards 1.0 rad/s.
        let mut r = burger();
        let expect_w = [0.32, 0.64, 0.96, 1.0];
        let expect_th = [0.032, 0.096, 0.192, 0.292];
        for k in 0..4 {
            r.step(Twist::new(0.0, 1.0), 0.1);
            assert!((r.twist.omega_radps - expect_w[k]).abs() < 1e-12);
            assert!((r.pose.theta - expect_th[k]).abs() < 1e-12);
        }
        assert_eq!(r.pose.position(), crate::algo::geometry::Vec2::zeros());
        for _ in 0..100 {
            r.step(Twist::new(0.0, -100.0), 0.1);
        }
        assert!((r.twist.omega_radps + 2.84).abs() < 1e-12);
    }

    #[test]
    fn steady_arc_follows_the_circle() {
        // At v = 0.2, ω = 0.5 (reached within one step for the QBot: 1 m/s²·0.2 s,
        // 3 rad/s²·0.2 s), the turning radius is 0.4 m; a quarter period
        // π/(2·0.5) = π s later the robot is at (R, R) relative to the start
        // (heading +x, turning left).
        let mut r = SimRobot::new(Pose2::default(), RobotPreset::QuanserQbot.limits());
        r.step(Twist::new(0.2, 0.5), 0.2);
        assert_eq!(r.twist, Twist::new(0.2, 0.5));
        let start = r.pose;
        let n = 100;
        for _ in 0..n {
            r.step(Twist::new(0.2, 0.5), std::f64::consts::PI / n as f64);
        }
        let rel = start.inverse_transform_point(r.pose.position());
        assert!((rel.x - 0.4).abs() < 1e-9 && (rel.y - 0.4).abs() < 1e-9, "{rel:?}");
    }

    #[test]
    fn garbage_command_stops_and_bad_dt_is_ignored() {
        let mut r = burger();
        r.twist = Twist::new(0.2, 1.0);
        r.step(Twist::new(f64::NAN, f64::INFINITY), 0.02);
        // Decelerate towards 0: 0.2 − 0.05, 1.0 − 0.064.
        assert!((r.twist.v_mps - 0.15).abs() < 1e-12);
        assert!((r.twist.omega_radps - 0.936).abs() < 1e-12);
        let before = r.clone();
        r.step(Twist::new(0.1, 0.0), f64::NAN);
        r.step(Twist::new(0.1, 0.0), -0.1);
        r.step(Twist::new(0.1, 0.0), 0.0);
        assert_eq!(r, before);
        // Invalid limits do not panic.
        let mut bad = SimRobot::new(
            Pose2::default(),
            RobotLimits {
                body_radius_m: 0.1,
                v_max_mps: -1.0,
                omega_max_radps: f64::NAN,
                accel_max_mps2: 1.0,
                omega_accel_max_radps2: 1.0,
            },
        );
        bad.step(Twist::new(1.0, 1.0), 0.1);
    }

    #[test]
    fn clearance_and_collision() {
        let w = World::new(&WorldSpec {
            walls: vec![WallSpec {
                from: [1.0, -1.0],
                to: [1.0, 1.0],
            }],
            circles: vec![CircleSpec {
                center: [-1.0, 0.0],
                radius_m: 0.5,
            }],
            ..WorldSpec::default()
        })
        .expect("valid");
        let mut r = burger();
        // Circle surface 0.5 m away, wall 1 m: 0.5 − 0.105.
        assert!((r.clearance_m(&w) - 0.395).abs() < 1e-12);
        assert!(!r.collides(&w));
        r.pose = Pose2::new(0.9, 0.0, 0.0);
        assert!((r.clearance_m(&w) + 0.005).abs() < 1e-12);
        assert!(r.collides(&w));
        r.pose = Pose2::new(0.895, 0.0, 0.0);
        assert!(r.clearance_m(&w).abs() < 1e-12);
        let empty = World::new(&WorldSpec::default()).expect("valid");
        assert_eq!(r.clearance_m(&empty), f64::INFINITY);
        assert!(!r.collides(&empty));
    }
}
