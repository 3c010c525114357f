//! The simulated robot: a unicycle (differential drive) whose actual velocity
//! follows the commanded one within speed and acceleration limits.
//!
//! Why: the safety filter issues velocity commands; what keeps a real base
//! from executing them instantly is its speed and acceleration limits, and
//! what decides a collision is its footprint. This file holds exactly that —
//! a disc footprint, or a polygon ([`super::body`]), the limits (with
//! presets for the target robots), and an exact arc integration of the
//! resulting motion.
//!
//! Units: m, s, rad, m/s, rad/s, m/s², rad/s².

use super::body::BodyPolygon;
use super::world::World;
use crate::algo::geometry::{Pose2, Twist};
use crate::algo::unicycle::arc_step;
use oldbf::config::{Checker, ParamError, Validate};
use serde::{Deserialize, Serialize};

/// Robots with built-in limits (YAML: `turtlebot3_burger`, `quanser_qbot`,
/// `rect_0604`).
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
    /// A rectangular base 0.6 m long and 0.4 m wide, centred on the wheel
    /// axis (a generic indoor platform, not a product): body polygon
    /// ±0.3 m x ±0.2 m, its disc the circumscribed one (√0.13 = 0.3606 m,
    /// what other robots see), v_max 0.5 m/s, ω_max 1.0 rad/s; accel
    /// 1.0 m/s² and yaw accel 2.0 rad/s² chosen as moderate values for such
    /// a base.
    #[serde(rename = "rect_0604")]
    Rect0604,
}

/// The [`RobotPreset::Rect0604`] body (m, robot frame): 0.6 m x 0.4 m about
/// the wheel axis.
pub const RECT_0604_POLYGON_M: [[f64; 2]; 4] = [[0.3, 0.2], [-0.3, 0.2], [-0.3, -0.2], [0.3, -0.2]];

/// Radius of the disc about the origin through a polygon's farthest vertex
/// (m); NaN for a non-finite vertex.
fn circumscribed_radius_m(vertices_m: &[[f64; 2]]) -> f64 {
    vertices_m
        .iter()
        .map(|&[x, y]| x * x + y * y)
        .fold(0.0, |a: f64, b| if b.is_nan() { b } else { a.max(b) })
        .sqrt()
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
            RobotPreset::Rect0604 => RobotLimits {
                body_radius_m: circumscribed_radius_m(&RECT_0604_POLYGON_M),
                v_max_mps: 0.5,
                omega_max_radps: 1.0,
                accel_max_mps2: 1.0,
                omega_accel_max_radps2: 2.0,
            },
        }
    }

    /// The preset's body polygon (m, robot frame); `None`: a disc.
    pub fn body_polygon_m(self) -> Option<&'static [[f64; 2]]> {
        match self {
            RobotPreset::Rect0604 => Some(&RECT_0604_POLYGON_M),
            RobotPreset::Turtlebot3Burger | RobotPreset::QuanserQbot => None,
        }
    }
}

/// A robot as written in a scenario file: a preset plus optional overrides.
/// (The start pose belongs to the scenario, not here.)
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotSpec {
    pub preset: RobotPreset,
    /// Footprint disc radius (m). Not with a body polygon.
    #[serde(default)]
    pub body_radius_m: Option<f64>,
    /// The body as a simple polygon in the robot frame, `[[x, y], ...]`
    /// (m, x forward, y left; either winding), instead of the disc: contacts
    /// and clearances are measured on it exactly. Absent: the preset's
    /// (a disc for all but `rect_0604`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub body_polygon_m: Option<Vec<[f64; 2]>>,
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
            body_polygon_m: None,
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

    /// The body polygon's vertices: `body_polygon_m`, else the preset's;
    /// `None` for a disc body.
    pub fn body_polygon_vertices_m(&self) -> Option<&[[f64; 2]]> {
        self.body_polygon_m.as_deref().or(self.preset.body_polygon_m())
    }

    /// The body polygon, checked; `Ok(None)` for a disc body. Errors name
    /// `robot.body_polygon_m` (not a simple polygon, or a vertex beyond
    /// 5 m) or `robot.body_radius_m` (given with a polygon).
    pub fn body(&self) -> Result<Option<BodyPolygon>, ParamError> {
        let Some(v) = self.body_polygon_vertices_m() else {
            return Ok(None);
        };
        if let Some(r) = self.body_radius_m {
            return Err(ParamError::new(
                "robot.body_radius_m",
                r,
                "absent with a body polygon (its disc is the polygon's circumscribed one)",
            ));
        }
        let key = "robot.body_polygon_m";
        let body = BodyPolygon::new(v).map_err(|e| ParamError::new(key, format!("{v:?}"), e.to_string()))?;
        if v.iter().flatten().any(|x| x.abs() > 5.0) {
            return Err(ParamError::new(
                key,
                format!("{v:?}"),
                "vertices within 5 m of the robot's origin",
            ));
        }
        Ok(Some(body))
    }

    /// The preset's limits with the overrides applied, not yet checked.
    /// With a body polygon, `body_radius_m` is its circumscribed radius.
    pub fn limits(&self) -> RobotLimits {
        let p = self.preset.limits();
        let polygon_radius_m = self.body_polygon_vertices_m().map(circumscribed_radius_m);
        RobotLimits {
            body_radius_m: polygon_radius_m.or(self.body_radius_m).unwrap_or(p.body_radius_m),
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
    /// Footprint disc radius (m); with a body polygon, its circumscribed
    /// radius (the disc other robots see).
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

/// The simulated robot: pose, actual velocity, limits, body.
#[derive(Debug, Clone, PartialEq)]
pub struct SimRobot {
    /// Pose in the world frame (m, rad).
    pub pose: Pose2,
    /// Actual (rate-limited) velocity (m/s, rad/s).
    pub twist: Twist,
    limits: RobotLimits,
    /// The body polygon; `None`: the disc of `limits.body_radius_m`.
    body: Option<BodyPolygon>,
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
            body: None,
        }
    }

    /// The same robot with `body` as its footprint (`None`: the disc).
    pub fn with_body(mut self, body: Option<BodyPolygon>) -> Self {
        self.body = body;
        self
    }

    pub fn limits(&self) -> &RobotLimits {
        &self.limits
    }

    /// The body polygon, if the footprint is one.
    pub fn body(&self) -> Option<&BodyPolygon> {
        self.body.as_ref()
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

    /// Distance (m) from the footprint to the nearest obstacle surface: for
    /// the disc `world.distance_to_nearest(position) − body_radius_m`, for a
    /// polygon [`BodyPolygon::clearance_m`]. Negative means a collision
    /// (minus the penetration depth); `+inf` in an empty world.
    pub fn clearance_m(&self, world: &World) -> f64 {
        match &self.body {
            None => world.distance_to_nearest(self.pose.position()) - self.limits.body_radius_m,
            Some(body) => body.clearance_m(self.pose, world),
        }
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
    fn the_rectangular_preset_has_its_polygon_and_bad_polygons_name_the_key() {
        let s: RobotSpec = serde_yaml::from_str("preset: rect_0604\n").expect("parses");
        let l = s.resolve().expect("valid");
        assert_eq!((l.v_max_mps, l.omega_max_radps), (0.5, 1.0));
        // The circumscribed disc: √(0.3² + 0.2²).
        assert!((l.body_radius_m - 0.13f64.sqrt()).abs() < 1e-15);
        let body = s.body().expect("valid").expect("a polygon");
        assert_eq!(body.polygon().vertices().len(), 4);
        // Disc presets have none, unless given one; then its disc is the polygon's.
        let mut q = RobotSpec::from_preset(RobotPreset::QuanserQbot);
        assert_eq!(q.body(), Ok(None));
        q.body_polygon_m = Some(vec![[0.5, 0.0], [0.0, 0.5], [-0.5, 0.0]]);
        assert!(q.body().expect("valid").is_some());
        assert_eq!(q.limits().body_radius_m, 0.5);
        let err = |s: &RobotSpec| s.body().unwrap_err().to_string();
        q.body_polygon_m = Some(vec![[0.5, 0.5], [-0.5, -0.5], [0.5, -0.5], [-0.5, 0.5]]);
        assert!(
            err(&q).starts_with("key `robot.body_polygon_m` = [[0.5, 0.5]"),
            "{}",
            err(&q)
        );
        assert!(err(&q).contains("intersect"), "{}", err(&q));
        q.body_polygon_m = Some(vec![[0.5, 0.0], [0.0, 0.5]]);
        assert!(err(&q).contains("at least 3 vertices"), "{}", err(&q));
        q.body_polygon_m = Some(vec![[6.0, 0.0], [0.0, 0.5], [-0.5, 0.0]]);
        assert!(err(&q).contains("within 5 m"), "{}", err(&q));
        q.body_polygon_m = None;
        let mut r = s.clone();
        r.body_radius_m = Some(0.3);
        assert!(err(&r).starts_with("key `robot.body_radius_m` = 0.3"), "{}", err(&r));
    }

    #[test]
    fn a_polygon_body_measures_its_clearance_on_the_polygon() {
        let w = World::new(&WorldSpec {
            walls: vec![WallSpec {
                from: [0.5, -1.0],
                to: [0.5, 1.0],
            }],
            ..WorldSpec::default()
        })
        .expect("valid");
        let spec = RobotSpec::from_preset(RobotPreset::Rect0604);
        let mut r = SimRobot::new(Pose2::default(), spec.limits()).with_body(spec.body().expect("valid"));
        // Front edge 0.2 m from the wall (the disc would say 0.5 − 0.3606).
        assert!((r.clearance_m(&w) - 0.2).abs() < 1e-12);
        r.pose = Pose2::new(0.0, 0.0, std::f64::consts::FRAC_PI_2);
        assert!((r.clearance_m(&w) - 0.3).abs() < 1e-12);
        r.pose = Pose2::new(0.21, 0.0, 0.0);
        assert!(r.collides(&w));
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
