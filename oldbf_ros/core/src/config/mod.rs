//! Strict configuration checks, shared by every configuration file of the
//! project (`config/oldbf.yaml`, scenarios, `config/can_bridge.yaml`, ROS
//! parameters).
//!
//! A file is read in two stages, and every problem names the file and the
//! dotted key as data (never recovered by parsing a message):
//!
//! 1. **Shape** ([`parse_yaml`], [`from_value`]): not YAML, a wrong type, an
//!    unknown or a missing key → [`ConfigError::Parse`] with the key of the
//!    offending value (`serde_path_to_error`).
//! 2. **Values** ([`Validate`], [`Checker`]): every value against its allowed
//!    [`Interval`] or rule; all violations are collected, each a
//!    [`ParamError`], and returned together as [`ConfigError::Invalid`].
//!
//! Intervals are typed constants, so what is checked and what the message
//! shows cannot disagree, and nothing is parsed at run time:
//!
//! ```
//! use oldbf::config::{Checker, Interval};
//!
//! const D_SAFE: Interval = Interval::closed(0.0, 10.0).unit("m");
//! let mut c = Checker::new();
//! c.range("barrier.d_safe_m", 0.2, D_SAFE);
//! c.range("barrier.d_safe_m", -1.0, D_SAFE);
//! let errors = c.finish().unwrap_err();
//! assert_eq!(errors[0].key, "barrier.d_safe_m");
//! assert_eq!(
//!     errors[0].to_string(),
//!     "key `barrier.d_safe_m` = -1 is out of range; allowed: [0, 10] m"
//! );
//! ```
//!
//! A whole file, strictly (unknown keys are errors with `deny_unknown_fields`):
//!
//! ```
//! use oldbf::config::{load_str, Checker, Interval, Validate};
//!
//! #[derive(serde::Deserialize)]
//! #[serde(deny_unknown_fields)]
//! struct Timing { rate_hz: f64 }
//! #[derive(serde::Deserialize)]
//! #[serde(deny_unknown_fields)]
//! struct File { timing: Timing }
//!
//! impl Validate for File {
//!     fn check(&self, c: &mut Checker) {
//!         c.range("timing.rate_hz", self.timing.rate_hz, Interval::open_closed(0.0, 1000.0).unit("Hz"));
//!     }
//! }
//!
//! let e = load_str::<File>("timing: {rate_hz: 0}", "my.yaml").err().unwrap();
//! assert_eq!(e.keys(), ["timing.rate_hz"]);
//! assert_eq!(e.to_string(), "my.yaml: key `timing.rate_hz` = 0 is out of range; allowed: (0, 1000] Hz");
//! let e = load_str::<File>("timing: {rate_hz: fast}", "my.yaml").err().unwrap();
//! assert_eq!(e.keys(), ["timing.rate_hz"]);
//! ```

mod base_limits;
mod check;
mod error;
mod interval;
mod param_error;
mod yaml;

pub use base_limits::{
    load_base_limits_file, load_base_limits_str, BaseKey, BaseLimits, BaseLimitsConflict, LimitCheck, LimitConflict,
    Relation,
};
pub use check::{Checker, Validate};
pub use error::ConfigError;
pub use interval::Interval;
pub use param_error::{Allowed, ParamError};
pub use yaml::{from_value, join_key, load_file, load_str, load_value, merge, parse_yaml, read_file};
