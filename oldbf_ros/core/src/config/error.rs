//! A configuration file that cannot be used, naming the file and the keys.

use super::base_limits::BaseLimitsConflict;
use super::param_error::ParamError;
use std::fmt;

/// A configuration problem. Every variant names the file (or the source,
/// e.g. `ROS parameters of /can_bridge_node`); the keys are fields, read
/// with [`keys`](Self::keys), never recovered from the message.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("{file}: cannot read: {error}")]
    Io {
        /// The file as named to the user.
        file: String,
        /// Why not (the message includes it, so it is not also a `source`).
        error: std::io::Error,
    },
    /// Not YAML, a wrong type, an unknown or a missing key, or another
    /// problem at one key (an unknown robot preset).
    #[error("{}", ParseMessage { file, key, message })]
    Parse {
        /// The file.
        file: String,
        /// Dotted key of the offending value; empty (or `.`) for the document itself.
        key: String,
        /// What is wrong there.
        message: String,
    },
    /// Values outside what their keys allow: every one found, one per line.
    #[error("{}", InvalidMessage { file, errors })]
    Invalid {
        /// The file.
        file: String,
        /// Each value, key and rule, in check order.
        errors: Vec<ParamError>,
    },
    /// Settings that contradict the base's limits (`config/base_limits.yaml`):
    /// each conflict names the node's key and the base's.
    #[error(transparent)]
    BaseLimits(#[from] BaseLimitsConflict),
}

impl ConfigError {
    /// `file` could not be read.
    pub fn io(file: impl Into<String>, error: std::io::Error) -> Self {
        ConfigError::Io {
            file: file.into(),
            error,
        }
    }

    /// A problem at `key` of `file` (empty key: the document).
    pub fn at(file: impl Into<String>, key: impl Into<String>, message: impl Into<String>) -> Self {
        ConfigError::Parse {
            file: file.into(),
            key: key.into(),
            message: message.into(),
        }
    }

    /// Values of `file` outside what their keys allow.
    pub fn invalid(file: impl Into<String>, errors: Vec<ParamError>) -> Self {
        ConfigError::Invalid {
            file: file.into(),
            errors,
        }
    }

    /// The file (or source) the error is about.
    pub fn file(&self) -> &str {
        match self {
            ConfigError::Io { file, .. } | ConfigError::Parse { file, .. } | ConfigError::Invalid { file, .. } => file,
            ConfigError::BaseLimits(e) => &e.settings,
        }
    }

    /// The keys this error is about: none for `Io`, the one of `Parse` (empty
    /// or `.` for the document), each invalid value's for `Invalid`, each
    /// conflict's own key and base key for `BaseLimits`.
    pub fn keys(&self) -> Vec<&str> {
        match self {
            ConfigError::Io { .. } => vec![],
            ConfigError::Parse { key, .. } => vec![key.as_str()],
            ConfigError::Invalid { errors, .. } => errors.iter().map(|e| e.key.as_str()).collect(),
            ConfigError::BaseLimits(e) => e.keys(),
        }
    }
}

struct ParseMessage<'a> {
    file: &'a str,
    key: &'a str,
    message: &'a str,
}

impl fmt::Display for ParseMessage<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let Self { file, key, message } = self;
        if key.is_empty() || *key == "." {
            write!(f, "{file}: {message}")
        } else {
            write!(f, "{file}: key `{key}`: {message}")
        }
    }
}

struct InvalidMessage<'a> {
    file: &'a str,
    errors: &'a [ParamError],
}

impl fmt::Display for InvalidMessage<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, e) in self.errors.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "{}: {e}", self.file)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Interval;

    #[test]
    fn io_names_the_file() {
        let e = ConfigError::io("/no/such.yaml", std::io::Error::from(std::io::ErrorKind::NotFound));
        assert!(e.to_string().starts_with("/no/such.yaml: cannot read: "), "{e}");
        assert!(e.keys().is_empty());
        assert_eq!(e.file(), "/no/such.yaml");
    }

    #[test]
    fn parse_names_the_key_unless_it_is_the_document() {
        let e = ConfigError::at("f.yaml", "timing.tx_rate_hz", "invalid type: string \"fast\"");
        assert_eq!(
            e.to_string(),
            "f.yaml: key `timing.tx_rate_hz`: invalid type: string \"fast\""
        );
        assert_eq!(e.keys(), ["timing.tx_rate_hz"]);
        let e = ConfigError::at("f.yaml", ".", "missing field `timing`");
        assert_eq!(e.to_string(), "f.yaml: missing field `timing`");
        let e = ConfigError::at("f.yaml", "", "did not find expected key");
        assert_eq!(e.to_string(), "f.yaml: did not find expected key");
    }

    #[test]
    fn invalid_lists_every_value_one_per_line() {
        let e = ConfigError::invalid(
            "f.yaml",
            vec![
                ParamError::new("timing.tx_rate_hz", 0, Interval::open_closed(0.0, 1000.0).unit("Hz")),
                ParamError::new("odrive.right_node_id", 0, "different from odrive.left_node_id"),
            ],
        );
        assert_eq!(
            e.to_string(),
            "f.yaml: key `timing.tx_rate_hz` = 0 is out of range; allowed: (0, 1000] Hz\n\
             f.yaml: key `odrive.right_node_id` = 0 is out of range; allowed: different from odrive.left_node_id"
        );
        assert_eq!(e.keys(), ["timing.tx_rate_hz", "odrive.right_node_id"]);
    }
}
