//! Loading and validating YAML configuration.
//!
//! The algorithm parameters live in `config/oldbf.yaml` (embedded in the
//! binary as the defaults, so the CLI works from any directory). A file is
//! parsed strictly: unknown keys, wrong types and missing keys are errors that
//! name the file and the dotted key; then every value is range-checked
//! (`Params::validate`). Scenario files override parameters by deep-merging
//! their `oldbf:` mapping over the defaults before the same checks run.

use crate::algo::params::{ParamError, Params};
use serde::de::DeserializeOwned;
use serde_yaml::Value;
use std::fmt;
use std::path::Path;

/// The shipped parameter file.
pub const DEFAULT_PARAMS_YAML: &str = include_str!("../../config/oldbf.yaml");
/// How the embedded defaults are named in error messages.
pub const DEFAULT_PARAMS_NAME: &str = "config/oldbf.yaml (built-in)";

/// A configuration problem, always naming the file and, where there is one, the key.
#[derive(Debug)]
pub enum ConfigError {
    /// The file could not be read.
    Io { file: String, error: std::io::Error },
    /// Not YAML, a wrong type, an unknown or a missing key.
    Parse { file: String, key: String, message: String },
    /// Values outside their allowed ranges; `prefix` is prepended to their
    /// keys (`oldbf.` for a scenario's overrides).
    Range {
        file: String,
        prefix: String,
        errors: Vec<ParamError>,
    },
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Io { file, error } => write!(f, "{file}: cannot read: {error}"),
            Self::Parse { file, key, message } if key.is_empty() || key == "." => {
                write!(f, "{file}: {message}")
            }
            Self::Parse { file, key, message } => write!(f, "{file}: key `{key}`: {message}"),
            Self::Range { file, prefix, errors } => {
                for (i, e) in errors.iter().enumerate() {
                    if i > 0 {
                        writeln!(f)?;
                    }
                    write!(
                        f,
                        "{file}: key `{prefix}{}` = {} is out of range; allowed: {}",
                        e.key, e.value, e.allowed
                    )?;
                }
                Ok(())
            }
        }
    }
}

impl std::error::Error for ConfigError {}

impl ConfigError {
    /// The keys this error is about (for tests and diagnostics).
    pub fn keys(&self) -> Vec<String> {
        match self {
            Self::Io { .. } => vec![],
            Self::Parse { key, .. } => vec![key.clone()],
            Self::Range { prefix, errors, .. } => errors.iter().map(|e| format!("{prefix}{}", e.key)).collect(),
        }
    }
}

/// Parses YAML text into a `Value`, naming the file on syntax errors.
pub fn parse_yaml(text: &str, file: &str) -> Result<Value, ConfigError> {
    serde_yaml::from_str(text).map_err(|e| ConfigError::Parse {
        file: file.to_string(),
        key: String::new(),
        message: e.to_string(),
    })
}

/// Deserializes `value` strictly, reporting the dotted path of the failing key.
/// `prefix` is prepended to paths (e.g. `oldbf.` inside a scenario file).
pub fn from_value<T: DeserializeOwned>(value: Value, file: &str, prefix: &str) -> Result<T, ConfigError> {
    serde_path_to_error::deserialize(value).map_err(|e| {
        let key = e.path().to_string();
        let inner = e.into_inner().to_string();
        let key = if prefix.is_empty() || key == "." {
            key
        } else {
            format!("{prefix}{key}")
        };
        ConfigError::Parse {
            file: file.to_string(),
            key,
            message: inner,
        }
    })
}

/// An error from a section's own check (`lidar`, `robot`, `world`), whose
/// message starts with the dotted key it is about (`lidar.beams must be in
/// [1, 16384] (got 0)`, `world.moving[1]: radius_m must be > 0 ...`): the key
/// is lifted out of the message so the error names it like any other;
/// `section` when the message names none.
pub fn section_error(file: &str, section: &str, message: &str) -> ConfigError {
    let is_key = |t: &str| {
        !t.is_empty()
            && t.chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '.' | '[' | ']'))
    };
    let mut key = section.to_string();
    let mut rest = message;
    let first = message.split([' ', ':']).next().unwrap_or("");
    if is_key(first) && first.starts_with(&format!("{section}.")) {
        key = first.to_string();
        rest = message[first.len()..].trim_start_matches(':').trim_start();
        // `world.moving[1]: radius_m must be ...`: the field follows the item
        // (a key: it has a unit or a section in its name; `coordinates must
        // be finite` is about the item itself).
        if let Some((field, _)) = rest.split_once(" must ") {
            if is_key(field) && !field.contains('[') && field.contains(['_', '.']) {
                key = format!("{key}.{field}");
                rest = &rest[field.len()..];
                rest = rest.trim_start();
            }
        }
    }
    ConfigError::Parse {
        file: file.to_string(),
        key,
        message: rest.to_string(),
    }
}

/// Recursively merges `over` into `base`: mappings merge key by key, anything
/// else replaces.
pub fn merge(base: &mut Value, over: &Value) {
    match (base, over) {
        (Value::Mapping(b), Value::Mapping(o)) => {
            for (k, v) in o {
                match b.get_mut(k) {
                    Some(slot) => merge(slot, v),
                    None => {
                        b.insert(k.clone(), v.clone());
                    }
                }
            }
        }
        (b, o) => *b = o.clone(),
    }
}

/// Validated parameters from a `Value` (after any merging).
pub fn params_from_value(value: Value, file: &str, prefix: &str) -> Result<Params, ConfigError> {
    let params: Params = from_value(value, file, prefix)?;
    params.validate().map_err(|errors| ConfigError::Range {
        file: file.to_string(),
        prefix: prefix.to_string(),
        errors,
    })?;
    Ok(params)
}

/// The built-in defaults (`config/oldbf.yaml` as shipped).
pub fn default_params() -> Params {
    load_params_str(DEFAULT_PARAMS_YAML, DEFAULT_PARAMS_NAME).expect("the shipped config/oldbf.yaml is valid (tested)")
}

/// Validated parameters from YAML text.
pub fn load_params_str(text: &str, file: &str) -> Result<Params, ConfigError> {
    params_from_value(parse_yaml(text, file)?, file, "")
}

/// Validated parameters from a file.
pub fn load_params_file(path: &Path) -> Result<Params, ConfigError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|error| ConfigError::Io {
        file: file.clone(),
        error,
    })?;
    load_params_str(&text, &file)
}

/// The base parameter document: a file if given, else the built-in defaults,
/// with its name for messages.
pub fn base_params_value(path: Option<&Path>) -> Result<(Value, String), ConfigError> {
    match path {
        Some(p) => {
            let file = p.display().to_string();
            let text = std::fs::read_to_string(p).map_err(|error| ConfigError::Io {
                file: file.clone(),
                error,
            })?;
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
        let e = section_error("s.yaml", "lidar", "lidar.beams must be in [1, 16384] (got 0)");
        assert_eq!(
            e.to_string(),
            "s.yaml: key `lidar.beams`: must be in [1, 16384] (got 0)"
        );
        let e = section_error(
            "s.yaml",
            "world",
            "world.moving[1]: radius_m must be > 0 and finite (got 0)",
        );
        assert_eq!(e.keys(), ["world.moving[1].radius_m"], "{e}");
        let e = section_error("s.yaml", "world", "world.walls[2]: zero length");
        assert_eq!(e.to_string(), "s.yaml: key `world.walls[2]`: zero length");
        let e = section_error("s.yaml", "world", "world.boxes[0]: coordinates must be finite");
        assert_eq!(e.keys(), ["world.boxes[0]"], "{e}");
        let e = section_error("s.yaml", "robot", "unknown preset `x`");
        assert_eq!(e.to_string(), "s.yaml: key `robot`: unknown preset `x`");
    }

    #[test]
    fn merge_overrides_nested_keys_only() {
        let mut base = parse_yaml(DEFAULT_PARAMS_YAML, "x").unwrap();
        let over = parse_yaml("barrier: {d_safe_m: 0.3}\ncontrol: {allow_reverse: true}", "o").unwrap();
        merge(&mut base, &over);
        let p = params_from_value(base, "o", "oldbf.").unwrap();
        assert_eq!(p.barrier.d_safe_m, 0.3);
        assert!(p.control.allow_reverse);
        assert_eq!(p.barrier.sigma, 2.0);
    }

    #[test]
    fn prefixed_paths_for_scenario_overrides() {
        let mut base = parse_yaml(DEFAULT_PARAMS_YAML, "x").unwrap();
        merge(&mut base, &parse_yaml("barrier: {d_sfe_m: 0.3}", "o").unwrap());
        let e = params_from_value(base, "scn.yaml", "oldbf.").unwrap_err();
        assert_eq!(e.keys(), ["oldbf.barrier.d_sfe_m"], "{e}");
        let mut base = parse_yaml(DEFAULT_PARAMS_YAML, "x").unwrap();
        merge(&mut base, &parse_yaml("dtcbf: {gamma: 0}", "o").unwrap());
        let e = params_from_value(base, "scn.yaml", "oldbf.").unwrap_err();
        assert_eq!(
            e.to_string(),
            "scn.yaml: key `oldbf.dtcbf.gamma` = 0 is out of range; allowed: (0, 1]"
        );
    }
}
