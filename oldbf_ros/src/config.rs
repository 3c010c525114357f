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
