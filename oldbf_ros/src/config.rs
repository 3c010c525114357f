//! Loading and validating YAML configuration.
//!
//! The algorithm parameters live in `config/oldbf.yaml` (embedded in the
//! binary as the defaults, so the CLI works from any directory). A file is
//! parsed strictly: unknown keys, wrong types and missing keys are errors that
//! name the file and the dotted key; then every value is range-checked
//! (`Params::validate`). Scenario files override parameters by deep-merging
//! their `oldbf:` mapping over the defaults before the same checks run.

use crate::algo::params::Params;
use serde_yaml::Value;
use std::path::Path;

/// The shared configuration mechanism (`oldbf::config`), so that both crates
/// have one error type and one set of loaders.
pub use oldbf::config::{from_value, join_key, merge, parse_yaml, read_file, ConfigError};

/// The shipped parameter file.
pub const DEFAULT_PARAMS_YAML: &str = include_str!("../../config/oldbf.yaml");
/// How the embedded defaults are named in error messages.
pub const DEFAULT_PARAMS_NAME: &str = "config/oldbf.yaml (built-in)";

/// An error from the world's own check (`world`: geometry, movers) that
/// carries the dotted key it is about, so that a file error can name the key
/// like any other without parsing the message.
pub trait SectionError: std::error::Error {
    /// The dotted key: `world.walls[2]`, `world.moving[1].radius_m`.
    fn key(&self) -> String;
    /// The message without the key: `zero length`.
    fn detail(&self) -> String;
}

/// A section's check error as a file error naming its key.
pub fn section_error(file: &str, e: &dyn SectionError) -> ConfigError {
    ConfigError::at(file, e.key(), e.detail())
}

/// Validated parameters from a `Value` (after any merging); keys inside
/// `section` (`oldbf` for a scenario's overrides, empty for a whole file).
pub fn params_from_value(value: Value, file: &str, section: &str) -> Result<Params, ConfigError> {
    oldbf::config::load_value(value, file, section)
}

/// The built-in defaults (`config/oldbf.yaml` as shipped).
pub fn default_params() -> Params {
    load_params_str(DEFAULT_PARAMS_YAML, DEFAULT_PARAMS_NAME).expect("the shipped config/oldbf.yaml is valid (tested)")
}

/// Validated parameters from YAML text.
pub fn load_params_str(text: &str, file: &str) -> Result<Params, ConfigError> {
    oldbf::config::load_str(text, file)
}

/// Validated parameters from a file.
pub fn load_params_file(path: &Path) -> Result<Params, ConfigError> {
    oldbf::config::load_file(path)
}

/// The base parameter document: a file if given, else the built-in defaults,
/// with its name for messages.
pub fn base_params_value(path: Option<&Path>) -> Result<(Value, String), ConfigError> {
    match path {
        Some(p) => {
            let file = p.display().to_string();
            let text = read_file(p)?;
            // Check the base file on its own first so its errors name it.
            load_params_str(&text, &file)?;
            Ok((parse_yaml(&text, &file)?, file))
        }
        None => Ok((
            parse_yaml(DEFAULT_PARAMS_YAML, DEFAULT_PARAMS_NAME)?,
            DEFAULT_PARAMS_NAME.to_string(),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shipped_file_equals_the_built_in_defaults() {
        // config/oldbf.yaml documents the same numbers as Params::default().
        assert_eq!(default_params(), Params::default());
    }

    fn with(key_path: &[&str], value: &str) -> String {
        let mut v = parse_yaml(DEFAULT_PARAMS_YAML, "x").unwrap();
        let mut slot = &mut v;
        for k in key_path {
            slot = slot.get_mut(*k).unwrap_or_else(|| panic!("no key {k}"));
        }
        *slot = serde_yaml::from_str(value).unwrap();
        serde_yaml::to_string(&v).unwrap()
    }

    #[test]
    fn unknown_key_is_named() {
        // A misspelt key at the top of the `barrier` section.
        let text = DEFAULT_PARAMS_YAML.replacen("\nbarrier:\n", "\nbarrier:\n  d_saf_m: 0.3\n", 1);
        assert_ne!(text, DEFAULT_PARAMS_YAML);
        let e = load_params_str(&text, "my.yaml").unwrap_err();
        assert_eq!(e.keys(), ["barrier.d_saf_m"], "{e}");
        assert!(
            e.to_string()
                .starts_with("my.yaml: key `barrier.d_saf_m`: unknown field"),
            "{e}"
        );
        let e = load_params_str(&format!("{DEFAULT_PARAMS_YAML}\nbogus: 1\n"), "my.yaml").unwrap_err();
        assert_eq!(e.keys(), ["bogus"], "{e}");
    }

    #[test]
    fn wrong_type_is_named() {
        let e = load_params_str(&with(&["barrier", "sigma"], "\"two\""), "f.yaml").unwrap_err();
        assert_eq!(e.keys(), ["barrier.sigma"], "{e}");
        let e = load_params_str(&with(&["control", "allow_reverse"], "3"), "f.yaml").unwrap_err();
        assert_eq!(e.keys(), ["control.allow_reverse"], "{e}");
        let e = load_params_str(&with(&["dtcbf", "prediction"], "rk4"), "f.yaml").unwrap_err();
        assert_eq!(e.keys(), ["dtcbf.prediction"], "{e}");
    }

    #[test]
    fn missing_key_is_named() {
        let text = DEFAULT_PARAMS_YAML.replace("  zeta: 0.5", "");
        let e = load_params_str(&text, "f.yaml").unwrap_err();
        assert_eq!(e.keys(), ["barrier"], "{e}");
        assert!(e.to_string().contains("missing field `zeta`"), "{e}");
    }

    #[test]
    fn out_of_range_is_named_with_the_allowed_range() {
        let e = load_params_str(&with(&["dtcbf", "gamma"], "0"), "f.yaml").unwrap_err();
        assert_eq!(
            e.to_string(),
            "f.yaml: key `dtcbf.gamma` = 0 is out of range; allowed: (0, 1]"
        );
    }

    #[test]
    fn missing_file_is_named() {
        let e = load_params_file(Path::new("/nonexistent/oldbf.yaml")).unwrap_err();
        assert!(e.to_string().starts_with("/nonexistent/oldbf.yaml: cannot read"), "{e}");
    }

    #[test]
    fn section_errors_name_the_key_in_their_message() {
        use crate::sim::motion::{MovingObstacleError as M, PointField};
        use crate::sim::world::WorldItem;
        use crate::sim::WorldError as W;
        let moving = |source: M| W::Moving { index: 1, source };
        let cases: Vec<(Box<dyn SectionError>, &str)> = vec![
            (
                Box::new(W::NotFinite {
                    item: WorldItem::Wall(0),
                    value: [f64::NAN, 0.0],
                }),
                "key `world.walls[0]`: coordinates must be finite (got [NaN, 0.0])",
            ),
            (
                Box::new(W::NotFinite {
                    item: WorldItem::Polygon(4),
                    value: [f64::NAN, 0.0],
                }),
                "key `world.polygons[4]`: coordinates must be finite (got [NaN, 0.0])",
            ),
            (
                Box::new(W::NotFinite {
                    item: WorldItem::Circle(0),
                    value: [0.0, f64::NAN],
                }),
                "key `world.circles[0]`: coordinates must be finite (got [0.0, NaN])",
            ),
            (
                Box::new(moving(M::NotFinite {
                    field: PointField::Start,
                    value: [f64::NAN, 0.0],
                })),
                "key `world.moving[1].motion.start`: must be finite (got [NaN, 0.0])",
            ),
            (
                Box::new(moving(M::NotFinite {
                    field: PointField::VelocityMps,
                    value: [f64::INFINITY, 0.0],
                })),
                "key `world.moving[1].motion.velocity_mps`: must be finite (got [inf, 0.0])",
            ),
            (
                Box::new(moving(M::NotFinite {
                    field: PointField::RegionMin,
                    value: [f64::NAN, 0.0],
                })),
                "key `world.moving[1].motion.region_min`: must be finite (got [NaN, 0.0])",
            ),
            (Box::new(W::ZeroLengthWall { index: 2 }), "key `world.walls[2]`: zero length"),
            (
                Box::new(W::NotFinite {
                    item: WorldItem::Box(0),
                    value: [f64::INFINITY, 0.0],
                }),
                "key `world.boxes[0]`: coordinates must be finite (got [inf, 0.0])",
            ),
            (
                Box::new(W::TooFewVertices { index: 0, vertices: 2 }),
                "key `world.polygons[0]`: needs at least 3 vertices (got 2)",
            ),
            (
                Box::new(W::ZeroLengthEdge {
                    index: 0,
                    edge: 2,
                    next: 0,
                }),
                "key `world.polygons[0]`: edge 2 (vertex 2 to vertex 0) has zero length",
            ),
            (
                Box::new(W::BoxSize {
                    index: 1,
                    size: [-1.0, 0.3],
                }),
                "key `world.boxes[1]`: size must be > 0 and finite (got [-1.0, 0.3])",
            ),
            (
                Box::new(W::BoxYaw {
                    index: 1,
                    yaw_deg: f64::NAN,
                }),
                "key `world.boxes[1].yaw_deg`: must be finite",
            ),
            (
                Box::new(W::CircleRadius {
                    index: 3,
                    radius_m: -0.1,
                }),
                "key `world.circles[3].radius_m`: must be > 0 and finite (got -0.1)",
            ),
            (
                Box::new(moving(M::Radius { radius_m: 0.0 })),
                "key `world.moving[1].radius_m`: must be > 0 and finite (got 0)",
            ),
            (
                Box::new(moving(M::NotFinite {
                    field: PointField::RegionMax,
                    value: [0.0, f64::INFINITY],
                })),
                "key `world.moving[1].motion.region_max`: must be finite (got [0.0, inf])",
            ),
            (
                Box::new(moving(M::NotFinite {
                    field: PointField::Waypoint(2),
                    value: [f64::NAN, 0.0],
                })),
                "key `world.moving[1]`: motion.waypoints[2] must be finite (got [NaN, 0.0])",
            ),
            (
                Box::new(moving(M::StartTime {
                    start_time_s: f64::NAN,
                })),
                "key `world.moving[1].motion.start_time_s`: must be finite (got NaN)",
            ),
            (
                Box::new(moving(M::Speed { speed_mps: -0.1 })),
                "key `world.moving[1].motion.speed_mps`: must be >= 0 and finite (got -0.1)",
            ),
            (
                Box::new(moving(M::Waypoints {
                    points: 1,
                    loop_length_m: 0.0,
                })),
                "key `world.moving[1]`: motion.waypoints needs at least 2 distinct points (got 1 point(s), loop length 0 m)",
            ),
            (
                Box::new(moving(M::EmptyRegion {
                    region_min: [0.0, 0.0],
                    region_max: [1.0, 0.0],
                })),
                "key `world.moving[1].motion.region_min`: must be < motion.region_max on both axes (got [0.0, 0.0], [1.0, 0.0])",
            ),
            (
                Box::new(moving(M::StartOutside {
                    start: [2.0, 0.5],
                    region_min: [0.0, 0.0],
                    region_max: [1.0, 1.0],
                })),
                "key `world.moving[1]`: motion.start [2.0, 0.5] must lie inside the region [[0.0, 0.0], [1.0, 1.0]]",
            ),
        ];
        for (e, want) in &cases {
            assert_eq!(
                section_error("s.yaml", e.as_ref()).to_string(),
                format!("s.yaml: {want}")
            );
            assert_eq!(section_error("s.yaml", e.as_ref()).keys(), [e.key()]);
        }
    }

    #[test]
    fn merge_overrides_nested_keys_only() {
        let mut base = parse_yaml(DEFAULT_PARAMS_YAML, "x").unwrap();
        let over = parse_yaml("barrier: {d_safe_m: 0.3}\ncontrol: {allow_reverse: true}", "o").unwrap();
        merge(&mut base, &over);
        let p = params_from_value(base, "o", "oldbf").unwrap();
        assert_eq!(p.barrier.d_safe_m, 0.3);
        assert!(p.control.allow_reverse);
        assert_eq!(p.barrier.sigma, 2.0);
    }

    #[test]
    fn prefixed_paths_for_scenario_overrides() {
        let mut base = parse_yaml(DEFAULT_PARAMS_YAML, "x").unwrap();
        merge(&mut base, &parse_yaml("barrier: {d_sfe_m: 0.3}", "o").unwrap());
        let e = params_from_value(base, "scn.yaml", "oldbf").unwrap_err();
        assert_eq!(e.keys(), ["oldbf.barrier.d_sfe_m"], "{e}");
        let mut base = parse_yaml(DEFAULT_PARAMS_YAML, "x").unwrap();
        merge(&mut base, &parse_yaml("dtcbf: {gamma: 0}", "o").unwrap());
        let e = params_from_value(base, "scn.yaml", "oldbf").unwrap_err();
        assert_eq!(
            e.to_string(),
            "scn.yaml: key `oldbf.dtcbf.gamma` = 0 is out of range; allowed: (0, 1]"
        );
    }
}
