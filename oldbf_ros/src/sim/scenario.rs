//! Scenario files (`config/scenarios/*.yaml`): a world, a robot, a LiDAR, a
//! nominal command, and parameter overrides for the filter.
//!
//! Parsed strictly like the parameter file: unknown keys, wrong types and
//! out-of-range values are errors naming the file and the key. The `oldbf:`
//! section is deep-merged over the base parameters (`config/oldbf.yaml` or
//! `--config FILE`) and validated as a whole.

use super::body::BodyPolygon;
use super::lidar::LidarSpec;
use super::robot::{RobotLimits, RobotSpec};
use super::world::{World, WorldSpec};
use crate::algo::geometry::{Pose2, Twist};
use crate::algo::params::Params;
use crate::algo::reference::ReferenceTrajectory;
use crate::config::{self, ConfigError};
use oldbf::config::{Checker, Interval, Validate};
use serde::Deserialize;
use serde_yaml::Value;
use std::path::Path;

/// Start pose in the world (YAML in degrees for readability).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StartSpec {
    pub x_m: f64,
    pub y_m: f64,
    #[serde(default)]
    pub theta_deg: f64,
}

impl StartSpec {
    pub fn pose(&self) -> Pose2 {
        Pose2::new(self.x_m, self.y_m, self.theta_deg.to_radians())
    }
}

/// Where the nominal command comes from.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum NominalSpec {
    /// Track a straight line of `length_m` from the start pose at v_r (paper's line test).
    Line { v_mps: f64, length_m: f64 },
    /// Track `laps` circles at (v_r, ω_r) from the start pose (paper's circle test).
    Circle { v_mps: f64, omega_radps: f64, laps: f64 },
    /// Track the virtual robot driven by (v_r, ω_r) for `duration_s` (paper eq. 7).
    Reference {
        v_mps: f64,
        omega_radps: f64,
        duration_s: f64,
    },
    /// No reference: a constant upstream command, as from teleop.
    Constant { v_mps: f64, omega_radps: f64 },
}

/// One robot of a multi-robot scenario.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotEntry {
    /// Its namespace in ROS (e.g. `robot1`); letters, digits and `_`.
    pub name: String,
    pub start: StartSpec,
    #[serde(default)]
    pub reference_start: Option<StartSpec>,
    pub nominal: NominalSpec,
}

/// What one robot of a scenario does: where it starts and what it is told.
#[derive(Debug, Clone, PartialEq)]
pub struct AgentPlan {
    /// Namespace (empty for a single-robot scenario).
    pub name: String,
    pub start: Pose2,
    /// The reference trajectory to track, unless the nominal is constant.
    pub reference: Option<ReferenceTrajectory>,
    /// The upstream command for `kind: constant`.
    pub constant: Option<Twist>,
}

fn default_seed() -> u64 {
    1
}
fn default_physics_dt() -> f64 {
    0.01
}
fn default_goal_tolerance() -> f64 {
    0.15
}

/// One of several LiDARs on the robot: where it sits and what it is.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MountedLidar {
    /// Its origin in the robot frame (m, forward; m, left).
    pub mount_x_m: f64,
    pub mount_y_m: f64,
    /// Its heading in the robot frame (deg, CCW).
    pub mount_yaw_deg: f64,
    pub lidar: LidarSpec,
}

/// Most LiDARs one robot may carry.
pub const MAX_LIDARS: usize = 8;

/// The scenario file as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioSpec {
    pub name: String,
    #[serde(default)]
    pub description: String,
    /// Longest simulated time (s); a run also ends when the goal is reached.
    pub duration_s: f64,
    /// Seed for sensor noise and dropouts (`--seed` overrides).
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Physics integration step (s); the control period is split into steps of at most this.
    #[serde(default = "default_physics_dt")]
    pub physics_dt_s: f64,
    pub robot: RobotSpec,
    /// The robot's start pose (single-robot scenarios).
    #[serde(default)]
    pub start: Option<StartSpec>,
    /// Where the reference trajectory starts [default: `start`], for runs that
    /// begin off the path.
    #[serde(default)]
    pub reference_start: Option<StartSpec>,
    #[serde(default)]
    pub lidar: LidarSpec,
    /// Several LiDARs on every robot (a front and a rear scanner), merged
    /// into one scan as the node merges `node.scans`; when given, they
    /// replace `lidar` and `oldbf.laser.mount_*`. All scan at the first's rate.
    #[serde(default)]
    pub lidars: Vec<MountedLidar>,
    /// The nominal command (single-robot scenarios).
    #[serde(default)]
    pub nominal: Option<NominalSpec>,
    /// Several robots in one world, each with its own namespace, start and
    /// nominal command; they see each other. Replaces `start`/`nominal`.
    #[serde(default)]
    pub robots: Vec<RobotEntry>,
    /// The goal counts as reached within this distance of the reference's end (m).
    #[serde(default = "default_goal_tolerance")]
    pub goal_tolerance_m: f64,
    #[serde(default)]
    pub world: WorldSpec,
    /// Overrides of `config/oldbf.yaml` for this scenario.
    #[serde(default)]
    pub oldbf: Option<Value>,
}

/// A loaded, validated scenario.
#[derive(Debug, Clone)]
pub struct Scenario {
    /// Where it came from, for messages.
    pub file: String,
    pub spec: ScenarioSpec,
    /// Filter parameters after the scenario's overrides.
    pub params: Params,
    pub robot: RobotLimits,
    /// The robot's body polygon (`robot.body_polygon_m` or the preset's);
    /// `None`: the disc of `robot.body_radius_m`.
    pub body: Option<BodyPolygon>,
    /// The robots: one for a single-robot scenario.
    pub agents: Vec<AgentPlan>,
}

fn invalid(file: &str, key: &str, message: impl Into<String>) -> ConfigError {
    ConfigError::at(file, key, message)
}

/// Every error `c` collected as one error of `file`; `Ok` when there is none.
fn finish(c: Checker, file: &str) -> Result<(), ConfigError> {
    c.finish().map_err(|errors| ConfigError::invalid(file, errors))
}

/// A run's or a reference's length (s).
const DURATION_S: Interval = Interval::open_closed(0.0, 36_000.0).unit("s");
/// A nominal forward speed (m/s).
const SPEED: Interval = Interval::open_closed(0.0, 5.0).unit("m/s");
/// A nominal yaw rate (rad/s).
const TURN: Interval = Interval::closed(-10.0, 10.0).unit("rad/s");

impl Scenario {
    /// Loads a scenario file over the base parameters (`base_params`: a
    /// parameter file, or None for the built-in `config/oldbf.yaml`).
    pub fn load(path: &Path, base_params: Option<&Path>) -> Result<Scenario, ConfigError> {
        let (base, _) = config::base_params_value(base_params)?;
        Self::load_over(path, base)
    }

    /// Loads a scenario file over an already merged parameter document (the
    /// ROS node's parameters).
    pub fn load_over(path: &Path, base: Value) -> Result<Scenario, ConfigError> {
        let text = config::read_file(path)?;
        Self::from_str_over(&text, &path.display().to_string(), base)
    }

    /// As `load`, from text.
    pub fn from_str(text: &str, file: &str, base_params: Option<&Path>) -> Result<Scenario, ConfigError> {
        let (base, _) = config::base_params_value(base_params)?;
        Self::from_str_over(text, file, base)
    }

    /// As `load_over`, from text.
    pub fn from_str_over(text: &str, file: &str, mut base: Value) -> Result<Scenario, ConfigError> {
        let spec: ScenarioSpec = config::from_value(config::parse_yaml(text, file)?, file, "")?;
        if let Some(over) = &spec.oldbf {
            config::merge(&mut base, over);
        }
        let params = config::params_from_value(base, file, "oldbf")?;

        let mut c = Checker::new();
        c.range("duration_s", spec.duration_s, DURATION_S);
        c.range(
            "physics_dt_s",
            spec.physics_dt_s,
            Interval::open_closed(0.0, 0.1).unit("s"),
        );
        c.range(
            "goal_tolerance_m",
            spec.goal_tolerance_m,
            Interval::open_closed(0.0, 10.0).unit("m"),
        );
        spec.lidar.check(&mut c);
        c.range(
            "lidars",
            spec.lidars.len() as f64,
            Interval::closed(0.0, MAX_LIDARS as f64),
        );
        for (k, m) in spec.lidars.iter().enumerate() {
            let mut own = Checker::new();
            m.lidar.check(&mut own);
            for mut e in own.errors().iter().cloned() {
                e.key = format!("lidars[{k}].{}", e.key);
                c.push(e);
            }
            for (key, v) in [("mount_x_m", m.mount_x_m), ("mount_y_m", m.mount_y_m)] {
                c.range(&format!("lidars[{k}].{key}"), v, Interval::closed(-5.0, 5.0).unit("m"));
            }
            c.range(
                &format!("lidars[{k}].mount_yaw_deg"),
                m.mount_yaw_deg,
                Interval::closed(-360.0, 360.0).unit("deg"),
            );
            c.rule(
                m.lidar.rate_hz == spec.lidars[0].lidar.rate_hz,
                &format!("lidars[{k}].lidar.rate_hz"),
                m.lidar.rate_hz,
                format!(
                    "the first LiDAR's, {} Hz (they scan together)",
                    spec.lidars[0].lidar.rate_hz
                ),
            );
        }
        let robot = spec.robot.limits();
        robot.check(&mut c);
        let body = spec.robot.body().unwrap_or_else(|e| {
            c.push(e);
            None
        });
        finish(c, file)?;
        World::new(&spec.world).map_err(|e| e.in_file(file))?;
        let agents = Self::agents_of(&spec, file)?;
        Ok(Scenario {
            file: file.to_string(),
            spec,
            params,
            robot,
            body,
            agents,
        })
    }

    fn agents_of(spec: &ScenarioSpec, file: &str) -> Result<Vec<AgentPlan>, ConfigError> {
        match ((spec.start, spec.nominal), spec.robots.is_empty()) {
            ((Some(start), Some(nominal)), true) => Ok(vec![Self::agent(
                file,
                "",
                String::new(),
                start,
                spec.reference_start,
                nominal,
            )?]),
            ((None, None), false) => {
                let mut names = std::collections::HashSet::new();
                spec.robots
                    .iter()
                    .enumerate()
                    .map(|(i, r)| {
                        let key = format!("robots[{i}]");
                        let valid = !r.name.is_empty()
                            && r.name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
                            && !r.name.starts_with(|c: char| c.is_ascii_digit());
                        if !valid || !names.insert(r.name.clone()) {
                            return Err(invalid(
                                file,
                                &format!("{key}.name"),
                                format!("`{}` must be a unique ROS name (letters, digits, _)", r.name),
                            ));
                        }
                        Self::agent(
                            file,
                            &format!("{key}."),
                            r.name.clone(),
                            r.start,
                            r.reference_start,
                            r.nominal,
                        )
                    })
                    .collect()
            }
            _ => Err(invalid(
                file,
                "robots",
                "give either `start` and `nominal` (one robot) or a non-empty `robots` list",
            )),
        }
    }

    fn agent(
        file: &str,
        prefix: &str,
        name: String,
        start: StartSpec,
        reference_start: Option<StartSpec>,
        nominal: NominalSpec,
    ) -> Result<AgentPlan, ConfigError> {
        let mut c = Checker::new();
        let poses = std::iter::once(("start", start)).chain(reference_start.map(|r| ("reference_start", r)));
        for (pose, p) in poses {
            for (k, v) in [("x_m", p.x_m), ("y_m", p.y_m), ("theta_deg", p.theta_deg)] {
                c.rule(v.is_finite(), &format!("{prefix}{pose}.{k}"), v, "a finite number");
            }
        }
        let reference_start = reference_start.unwrap_or(start);
        Self::check_nominal(&mut c, nominal, prefix);
        finish(c, file)?;
        let from = reference_start.pose();
        let (reference, constant) = match nominal {
            NominalSpec::Line { v_mps, length_m } => (Some(ReferenceTrajectory::line(from, v_mps, length_m)), None),
            NominalSpec::Circle {
                v_mps,
                omega_radps,
                laps,
            } => (Some(ReferenceTrajectory::circle(from, v_mps, omega_radps, laps)), None),
            NominalSpec::Reference {
                v_mps,
                omega_radps,
                duration_s,
            } => (
                Some(ReferenceTrajectory {
                    start: from,
                    v_mps,
                    omega_radps,
                    duration_s,
                }),
                None,
            ),
            NominalSpec::Constant { v_mps, omega_radps } => (None, Some(Twist::new(v_mps, omega_radps))),
        };
        Ok(AgentPlan {
            name,
            start: start.pose(),
            reference,
            constant,
        })
    }

    /// The nominal command's values, keys under `prefix` (`robots[1].`).
    fn check_nominal(c: &mut Checker, nominal: NominalSpec, prefix: &str) {
        let key = |k: &str| format!("{prefix}nominal.{k}");
        match nominal {
            NominalSpec::Line { v_mps, length_m } => {
                c.range(&key("v_mps"), v_mps, SPEED);
                c.range(
                    &key("length_m"),
                    length_m,
                    Interval::open_closed(0.0, 10_000.0).unit("m"),
                );
            }
            NominalSpec::Circle {
                v_mps,
                omega_radps,
                laps,
            } => {
                c.range(&key("v_mps"), v_mps, SPEED);
                if c.range(&key("omega_radps"), omega_radps, TURN) {
                    c.rule(
                        omega_radps != 0.0,
                        &key("omega_radps"),
                        omega_radps,
                        "non-zero: a circle needs a yaw rate",
                    );
                }
                c.range(&key("laps"), laps, Interval::open_closed(0.0, 1000.0));
            }
            NominalSpec::Reference {
                v_mps,
                omega_radps,
                duration_s,
            } => {
                c.range(&key("v_mps"), v_mps, SPEED);
                c.range(&key("omega_radps"), omega_radps, TURN);
                c.range(&key("duration_s"), duration_s, DURATION_S);
            }
            NominalSpec::Constant { v_mps, omega_radps } => {
                c.range(&key("v_mps"), v_mps, Interval::closed(-5.0, 5.0).unit("m/s"));
                c.range(&key("omega_radps"), omega_radps, TURN);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = "
name: t
duration_s: 10
robot: {preset: turtlebot3_burger}
start: {x_m: 0, y_m: 0}
nominal: {kind: line, v_mps: 0.15, length_m: 1.0}
";

    #[test]
    fn minimal_scenario_loads_with_defaults() {
        let s = Scenario::from_str(MINIMAL, "t.yaml", None).unwrap();
        assert_eq!(s.params, Params::default());
        assert_eq!(s.agents.len(), 1);
        let r = s.agents[0].reference.unwrap();
        assert!((r.duration_s - 1.0 / 0.15).abs() < 1e-12);
        assert_eq!(s.spec.seed, 1);
    }

    #[test]
    fn overrides_merge_and_are_validated_by_name() {
        let text = format!("{MINIMAL}oldbf: {{barrier: {{d_safe_m: 0.3}}}}\n");
        let s = Scenario::from_str(&text, "t.yaml", None).unwrap();
        assert_eq!(s.params.barrier.d_safe_m, 0.3);
        let text = format!("{MINIMAL}oldbf: {{dtcbf: {{gamma: 2}}}}\n");
        let e = Scenario::from_str(&text, "t.yaml", None).unwrap_err();
        assert_eq!(e.keys(), ["oldbf.dtcbf.gamma"], "{e}");
        assert!(e.to_string().starts_with("t.yaml: key `oldbf.dtcbf.gamma`"), "{e}");
        let text = format!("{MINIMAL}oldbf: {{dtcbf: {{gama: 0.5}}}}\n");
        let e = Scenario::from_str(&text, "t.yaml", None).unwrap_err();
        assert_eq!(e.keys(), ["oldbf.dtcbf.gama"], "{e}");
    }

    #[test]
    fn nominal_values_are_all_listed_with_their_allowed_range() {
        let text = MINIMAL.replace("v_mps: 0.15, length_m: 1.0", "v_mps: 0, length_m: 0");
        let e = Scenario::from_str(&text, "t.yaml", None).unwrap_err();
        assert_eq!(e.keys(), ["nominal.v_mps", "nominal.length_m"], "{e}");
        assert_eq!(
            e.to_string().lines().next(),
            Some("t.yaml: key `nominal.v_mps` = 0 is out of range; allowed: (0, 5] m/s")
        );
        let text = MINIMAL.replace(
            "kind: line, v_mps: 0.15, length_m: 1.0",
            "kind: circle, v_mps: 0.1, omega_radps: 0, laps: 1",
        );
        let e = Scenario::from_str(&text, "t.yaml", None).unwrap_err();
        assert_eq!(e.keys(), ["nominal.omega_radps"], "{e}");
    }

    #[test]
    fn reference_may_start_elsewhere() {
        let text = format!("{MINIMAL}reference_start: {{x_m: 1.0, y_m: 2.0, theta_deg: 90}}\n");
        let r = Scenario::from_str(&text, "t.yaml", None).unwrap().agents[0]
            .reference
            .unwrap();
        assert!((r.goal().x - 1.0).abs() < 1e-12 && (r.goal().y - 3.0).abs() < 1e-12);
    }

    #[test]
    fn multi_robot_scenarios_name_their_robots() {
        let text = "
name: two
duration_s: 10
robot: {preset: turtlebot3_burger}
robots:
  - {name: robot1, start: {x_m: 0, y_m: 0}, nominal: {kind: line, v_mps: 0.15, length_m: 2}}
  - {name: robot2, start: {x_m: 0, y_m: 2}, nominal: {kind: constant, v_mps: 0.1, omega_radps: 0}}
";
        let s = Scenario::from_str(text, "t.yaml", None).unwrap();
        assert_eq!(s.agents.len(), 2);
        assert_eq!(s.agents[1].name, "robot2");
        assert_eq!(s.agents[1].constant, Some(Twist::new(0.1, 0.0)));
        assert!(s.agents[0].reference.is_some() && s.agents[1].reference.is_none());
        let dup = text.replace("name: robot2", "name: robot1");
        let e = Scenario::from_str(&dup, "t.yaml", None).unwrap_err();
        assert_eq!(e.keys(), ["robots[1].name"], "{e}");
        let bad = text.replace("length_m: 2", "length_m: -2");
        let e = Scenario::from_str(&bad, "t.yaml", None).unwrap_err();
        assert_eq!(e.keys(), ["robots[0].nominal.length_m"], "{e}");
        let both =
            format!("{text}start: {{x_m: 0, y_m: 0}}\nnominal: {{kind: constant, v_mps: 0.1, omega_radps: 0}}\n");
        let e = Scenario::from_str(&both, "t.yaml", None).unwrap_err();
        assert_eq!(e.keys(), ["robots"], "{e}");
    }

    #[test]
    fn a_body_polygon_is_loaded_and_a_bad_one_names_its_key() {
        assert!(Scenario::from_str(MINIMAL, "t.yaml", None).unwrap().body.is_none());
        let rect = MINIMAL.replace("preset: turtlebot3_burger", "preset: rect_0604");
        let s = Scenario::from_str(&rect, "t.yaml", None).unwrap();
        assert_eq!(s.body.expect("the preset's").polygon().vertices().len(), 4);
        let own = MINIMAL.replace(
            "preset: turtlebot3_burger",
            "preset: turtlebot3_burger, body_polygon_m: [[0.1, 0.1], [-0.1, 0.1], [0.1, -0.1], [-0.1, -0.1]]",
        );
        let e = Scenario::from_str(&own, "t.yaml", None).unwrap_err();
        assert_eq!(e.keys(), ["robot.body_polygon_m"], "{e}");
        assert!(e.to_string().contains("intersect"), "{e}");
    }

    #[test]
    fn scenario_keys_are_checked() {
        let e = Scenario::from_str(&format!("{MINIMAL}speed: 3\n"), "t.yaml", None).unwrap_err();
        assert_eq!(e.keys(), ["speed"], "{e}");
        let e = Scenario::from_str(&MINIMAL.replace("duration_s: 10", "duration_s: -1"), "t.yaml", None).unwrap_err();
        assert_eq!(e.keys(), ["duration_s"], "{e}");
        let e = Scenario::from_str(
            &MINIMAL.replace("length_m: 1.0", "length_m: 1.0, omega_radps: 1"),
            "t.yaml",
            None,
        )
        .unwrap_err();
        // Inside a tagged enum serde names the field in the message, not the path.
        assert_eq!(e.keys(), ["nominal"], "{e}");
        assert!(e.to_string().contains("unknown field `omega_radps`"), "{e}");
        let e = Scenario::from_str(&MINIMAL.replace("v_mps: 0.15", "v_mps: .nan"), "t.yaml", None).unwrap_err();
        assert_eq!(e.keys(), ["nominal.v_mps"], "{e}");
    }
}
