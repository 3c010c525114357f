//! YAML in, typed and checked configuration out, every error naming the file
//! and the dotted key.

use super::check::Validate;
use super::error::ConfigError;
use serde::de::DeserializeOwned;
use serde_yaml::Value;
use std::path::Path;

/// `key` inside `section`: `oldbf` + `dtcbf.gamma` = `oldbf.dtcbf.gamma`,
/// `world` + `[0]` = `world[0]`. The document itself (`""` or `.`, as
/// `serde_path_to_error` names the root) is the section; an empty section
/// leaves the key as it is.
pub fn join_key(section: &str, key: &str) -> String {
    if section.is_empty() {
        key.to_string()
    } else if key.is_empty() || key == "." {
        section.to_string()
    } else if key.starts_with('[') {
        format!("{section}{key}")
    } else {
        format!("{section}.{key}")
    }
}

/// YAML text as a document, naming `file` on a syntax error.
pub fn parse_yaml(text: &str, file: &str) -> Result<Value, ConfigError> {
    serde_yaml::from_str(text).map_err(|e| ConfigError::at(file, "", e.to_string()))
}

/// `value` as a `T`, strictly (with `deny_unknown_fields` on `T`): a wrong
/// type, an unknown or a missing key names its dotted key, inside `section`
/// (empty when `value` is the whole file; `oldbf` for a scenario's
/// `oldbf:` mapping).
pub fn from_value<T: DeserializeOwned>(value: Value, file: &str, section: &str) -> Result<T, ConfigError> {
    serde_path_to_error::deserialize(value).map_err(|e| {
        let key = join_key(section, &e.path().to_string());
        ConfigError::at(file, key, e.into_inner().to_string())
    })
}

/// `value` as a `T`, strictly, then every value checked; keys inside `section`.
pub fn load_value<T: DeserializeOwned + Validate>(value: Value, file: &str, section: &str) -> Result<T, ConfigError> {
    let t: T = from_value(value, file, section)?;
    t.validate().map_err(|errors| {
        let errors = errors.into_iter().map(|e| e.in_section(section)).collect();
        ConfigError::invalid(file, errors)
    })?;
    Ok(t)
}

/// A whole YAML file's text as a checked `T`; `file` names it in errors.
pub fn load_str<T: DeserializeOwned + Validate>(text: &str, file: &str) -> Result<T, ConfigError> {
    load_value(parse_yaml(text, file)?, file, "")
}

/// The text of `path`, or an error naming it.
pub fn read_file(path: &Path) -> Result<String, ConfigError> {
    std::fs::read_to_string(path).map_err(|error| ConfigError::io(path.display().to_string(), error))
}

/// A YAML file as a checked `T`; errors name the file as given.
pub fn load_file<T: DeserializeOwned + Validate>(path: &Path) -> Result<T, ConfigError> {
    load_str(&read_file(path)?, &path.display().to_string())
}

/// Merges `over` into `base`, recursively: mappings merge key by key,
/// anything else replaces (how a scenario's `oldbf:` overrides, or ROS
/// parameters, apply over the shipped defaults).
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{Checker, Interval};
    use serde::Deserialize;

    #[derive(Debug, Deserialize, PartialEq)]
    #[serde(deny_unknown_fields)]
    struct Inner {
        rate_hz: f64,
        on: bool,
    }

    #[derive(Debug, Deserialize, PartialEq)]
    #[serde(deny_unknown_fields)]
    struct Doc {
        timing: Inner,
        ids: Vec<u32>,
    }

    impl Validate for Doc {
        fn check(&self, c: &mut Checker) {
            c.range(
                "timing.rate_hz",
                self.timing.rate_hz,
                Interval::open_closed(0.0, 1000.0).unit("Hz"),
            );
            for (i, id) in self.ids.iter().enumerate() {
                c.range(&format!("ids[{i}]"), *id, Interval::closed(1.0, 127.0));
            }
        }
    }

    const GOOD: &str = "timing: {rate_hz: 50, on: true}\nids: [1, 2]\n";

    #[test]
    fn keys_join_sections() {
        assert_eq!(join_key("", "a.b"), "a.b");
        assert_eq!(join_key("", "."), ".");
        assert_eq!(join_key("oldbf", "dtcbf.gamma"), "oldbf.dtcbf.gamma");
        assert_eq!(join_key("oldbf", "."), "oldbf");
        assert_eq!(join_key("oldbf", ""), "oldbf");
        assert_eq!(join_key("world", "[0].x"), "world[0].x");
    }

    #[test]
    fn a_good_file_loads() {
        let d: Doc = load_str(GOOD, "f.yaml").unwrap();
        assert_eq!(
            d.timing,
            Inner {
                rate_hz: 50.0,
                on: true
            }
        );
        assert_eq!(d.ids, [1, 2]);
    }

    #[test]
    fn syntax_errors_name_the_file_only() {
        let e = load_str::<Doc>("timing: [", "f.yaml").unwrap_err();
        assert!(matches!(&e, ConfigError::Parse { key, .. } if key.is_empty()), "{e:?}");
        assert!(e.to_string().starts_with("f.yaml: "), "{e}");
    }

    #[test]
    fn shape_errors_name_the_dotted_key() {
        let e = load_str::<Doc>(&GOOD.replace("50", "fast"), "f.yaml").unwrap_err();
        assert_eq!(e.keys(), ["timing.rate_hz"]);
        assert!(
            e.to_string().starts_with("f.yaml: key `timing.rate_hz`: invalid type"),
            "{e}"
        );
        let e = load_str::<Doc>(&GOOD.replace("on: true", "on: true, of: 1"), "f.yaml").unwrap_err();
        assert_eq!(e.keys(), ["timing.of"]);
        assert!(e.to_string().contains("unknown field `of`"), "{e}");
        let e = load_str::<Doc>(&GOOD.replace(", on: true", ""), "f.yaml").unwrap_err();
        assert_eq!(e.keys(), ["timing"]);
        assert!(e.to_string().contains("missing field `on`"), "{e}");
        let e = load_str::<Doc>(&GOOD.replace("[1, 2]", "[1, x]"), "f.yaml").unwrap_err();
        assert_eq!(e.keys(), ["ids[1]"]);
    }

    #[test]
    fn value_errors_are_all_listed_with_their_keys() {
        let e = load_str::<Doc>(&GOOD.replace("50", "0").replace("[1, 2]", "[0, 128]"), "f.yaml").unwrap_err();
        assert_eq!(e.keys(), ["timing.rate_hz", "ids[0]", "ids[1]"]);
        let lines: Vec<String> = e.to_string().lines().map(String::from).collect();
        assert_eq!(lines.len(), 3);
        assert_eq!(
            lines[0],
            "f.yaml: key `timing.rate_hz` = 0 is out of range; allowed: (0, 1000] Hz"
        );
        assert_eq!(
            lines[2],
            "f.yaml: key `ids[1]` = 128 is out of range; allowed: [1, 127]"
        );
    }

    #[test]
    fn a_section_prefixes_shape_and_value_errors() {
        let v = parse_yaml(&GOOD.replace("50", "0"), "s.yaml").unwrap();
        let e = load_value::<Doc>(v, "s.yaml", "oldbf").unwrap_err();
        assert_eq!(e.keys(), ["oldbf.timing.rate_hz"]);
        assert!(
            e.to_string().starts_with("s.yaml: key `oldbf.timing.rate_hz` = 0"),
            "{e}"
        );
        let v = parse_yaml(&GOOD.replace("on: true", "onn: true"), "s.yaml").unwrap();
        let e = load_value::<Doc>(v, "s.yaml", "oldbf").unwrap_err();
        assert_eq!(e.keys(), ["oldbf.timing.onn"]);
        let e = load_value::<Doc>(Value::from(3), "s.yaml", "oldbf").unwrap_err();
        assert_eq!(e.keys(), ["oldbf"], "the section itself has the wrong type");
    }

    #[test]
    fn files_are_named_when_missing() {
        let e = load_file::<Doc>(Path::new("/nonexistent/x.yaml")).unwrap_err();
        assert!(matches!(e, ConfigError::Io { .. }));
        assert!(e.to_string().starts_with("/nonexistent/x.yaml: cannot read"), "{e}");
    }

    #[test]
    fn merge_overrides_nested_keys_only() {
        let mut base = parse_yaml(GOOD, "b").unwrap();
        merge(&mut base, &parse_yaml("timing: {rate_hz: 10}\nextra: 1", "o").unwrap());
        assert_eq!(base["timing"]["rate_hz"], Value::from(10));
        assert_eq!(base["timing"]["on"], Value::from(true));
        assert_eq!(base["extra"], Value::from(1));
        merge(&mut base, &parse_yaml("ids: [5]", "o").unwrap());
        assert_eq!(base["ids"], parse_yaml("[5]", "o").unwrap(), "sequences replace");
    }
}
