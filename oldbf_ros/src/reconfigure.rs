//! Run-time tuning of the safety parameters: the pure side of oldbf_node's
//! dynamic_reconfigure server (the protocol is in `ros::reconfigure`).
//!
//! One table, [`RECONFIGURABLE`], lists the dotted YAML keys that may change
//! while the node runs, each with a description. Everything else comes from
//! [`Params`] itself: a key's type and default from `Params::default()`, its
//! range from `Params::validate` (probed once with a value that must fail, the
//! interval taken from the error it returns, as data). A change is applied to a copy of
//! the running parameters through their YAML form, and the copy replaces them
//! only if `Params::validate` accepts the whole of it: so the ranges, the
//! cross-key rules and the error messages are exactly the YAML file's.
//! Adding a key is one line in the table.

use crate::algo::params::ParamError;
use crate::algo::Params;
use std::fmt;

/// The keys that can be set at run time, with the description rqt_reconfigure shows.
pub const RECONFIGURABLE: &[(&str, &str)] = &[
    (
        "barrier.d_safe_m",
        "d_safe: clearance beyond the robot radius that the filter keeps (m)",
    ),
    (
        "barrier.big_gamma",
        "Γ: barrier scale; the activation band d_act − d_safe is Γ^(2/σ) m wide",
    ),
    (
        "barrier.sigma",
        "σ: exponent on the proximity in B_d (with Γ it sets the activation band)",
    ),
    ("barrier.zeta", "ζ: weight of the speed term B_v"),
    ("doaa.gain_k_radps", "k: yaw rate per unit of B_r − B_l (rad/s)"),
    (
        "doaa.omega_0_radps",
        "ω_0: turn rate when both sides and the front are blocked (rad/s), at most ω_max",
    ),
    ("control.v_max_mps", "v_max: largest forward speed ever commanded (m/s)"),
    (
        "control.omega_max_radps",
        "ω_max: largest yaw rate ever commanded (rad/s)",
    ),
    (
        "control.v_nom_mps",
        "nominal speed without a reference or an upstream command (m/s), at most v_max",
    ),
    ("dtcbf.gamma", "γ in h(k+1) ≥ (1 − γ) h(k): 1 only asks h(k+1) ≥ 0"),
    (
        "dtcbf.noise_margin_m",
        "δ: the condition is first enforced on h − δ, so noise up to δ is absorbed (m)",
    ),
    (
        "laser.scan_timeout_s",
        "a scan older than this is stale: the robot stops (s)",
    ),
    (
        "laser.unknown_hold_s",
        "an unknown beam (NaN, below range_min) keeps its last valid reading this long (s)",
    ),
    (
        "laser.blind_fraction",
        "the sensor is blind when more than this fraction of the front reads unknown…",
    ),
    ("laser.blind_timeout_s", "…for longer than this: stop, sensor_blind (s)"),
    (
        "laser.zero_is_no_return",
        "the driver writes 0.0 for no return: 0.0 is free (else unknown)",
    ),
    (
        "laser.range_noise_m",
        "the scanner's range noise (1σ): static returns are averaged per beam over recent scans; 0 = off (m)",
    ),
    (
        "control.allow_reverse",
        "may back up (only ever on scans that see the rear)",
    ),
    ("control.v_reverse_max_mps", "largest reverse speed (m/s)"),
    (
        "passive.enabled",
        "passive motion safety: brake to rest without a closing contact; evasion",
    ),
    (
        "control.decel_mps2",
        "the base's deceleration: the window's and the braking check's (m/s²)",
    ),
    ("control.accel_mps2", "the base's acceleration limit (m/s²)"),
    (
        "control.angular_accel_radps2",
        "the base's angular acceleration limit (rad/s²)",
    ),
    (
        "passive.mover_margin_m",
        "a mover's predicted disc is inflated by this at once (m)…",
    ),
    (
        "passive.mover_growth_mps",
        "…and grows by this per second of prediction (m/s)",
    ),
    (
        "passive.seen_margin_m",
        "a polygon's braking check keeps the body this far from a seen point it moves towards (m)",
    ),
    (
        "passive.evasion_horizon_s",
        "evasion ranks commands by predicted time to contact over this (s)",
    ),
    (
        "select.weights.nominal",
        "weight of the critic of closeness to the upstream command",
    ),
    (
        "select.weights.smoothness",
        "weight of the critic of little change from the command last sent",
    ),
    (
        "select.weights.doaa",
        "weight of the critic of closeness to the DOAA's command (the paper's law)",
    ),
    (
        "select.weights.progress",
        "weight of the critic of progress towards the reference or the way round",
    ),
    (
        "select.weights.clearance",
        "weight of the critic of room to the surroundings along the horizon",
    ),
    (
        "select.weights.mover",
        "weight of the critic of time to contact with movers (evasion)",
    ),
    (
        "unstuck.enabled",
        "go round an obstacle when progress towards the reference stalls",
    ),
    (
        "unstuck.stall_s",
        "progress stalled for this long starts going round (s)",
    ),
    ("obstacles.enabled", "track moving obstacles and use their motion"),
    (
        "obstacles.lookahead_s",
        "an obstacle on a collision course within this time raises its side's barrier (s)",
    ),
];

/// The type of a parameter, as dynamic_reconfigure names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    Double,
    Int,
    Bool,
}

impl Kind {
    /// dynamic_reconfigure's type name.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Double => "double",
            Self::Int => "int",
            Self::Bool => "bool",
        }
    }
}

impl fmt::Display for Kind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A parameter value (dynamic_reconfigure ints are 32-bit).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Value {
    Double(f64),
    Int(i32),
    Bool(bool),
}

impl Value {
    pub fn kind(&self) -> Kind {
        match self {
            Self::Double(_) => Kind::Double,
            Self::Int(_) => Kind::Int,
            Self::Bool(_) => Kind::Bool,
        }
    }

    fn to_yaml(self) -> serde_yaml::Value {
        match self {
            Self::Double(v) => serde_yaml::Value::Number(v.into()),
            Self::Int(v) => serde_yaml::Value::Number(v.into()),
            Self::Bool(v) => serde_yaml::Value::Bool(v),
        }
    }
}

impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Double(v) => write!(f, "{v}"),
            Self::Int(v) => write!(f, "{v}"),
            Self::Bool(v) => write!(f, "{v}"),
        }
    }
}

/// One reconfigurable parameter.
#[derive(Debug, Clone, PartialEq)]
pub struct Spec {
    /// Dotted YAML key, e.g. `barrier.d_safe_m`; also its dynamic_reconfigure name.
    pub key: &'static str,
    pub description: &'static str,
    pub kind: Kind,
    pub default: Value,
    /// The bounds of the allowed interval (an open bound is given as is:
    /// dynamic_reconfigure cannot say "open", and the value itself is refused).
    pub min: Value,
    pub max: Value,
}

impl Spec {
    /// The YAML section of the key (`barrier` for `barrier.d_safe_m`).
    pub fn section(&self) -> &'static str {
        self.key.rsplit_once('.').map_or("", |(s, _)| s)
    }

    /// The key as a ROS parameter name under the node's private namespace
    /// (`barrier/d_safe_m`), where the YAML file loads it.
    pub fn ros_param(&self) -> String {
        self.key.replace('.', "/")
    }
}

/// A table entry that `Params` cannot back.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SpecError {
    #[error("reconfigurable key `{0}` is not a parameter")]
    NoSuchKey(&'static str),
    #[error("reconfigurable key `{0}` is not a number or a boolean")]
    NotScalar(&'static str),
    #[error("reconfigurable key `{0}`: no range found in Params::validate")]
    NoRange(&'static str),
}

/// Why a change was refused (the running values are kept).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ReconfigureError {
    #[error("key `{0}` cannot be changed at run time")]
    NotReconfigurable(String),
    #[error("key `{key}` takes a {expected} value, not {got} ({})", got.kind())]
    WrongType { key: String, expected: Kind, got: Value },
    #[error("{0}")]
    Decode(String),
    #[error("{}", .0.iter().map(ToString::to_string).collect::<Vec<_>>().join("; "))]
    Invalid(Vec<ParamError>),
}

fn lookup<'a>(v: &'a serde_yaml::Value, key: &str) -> Option<&'a serde_yaml::Value> {
    key.split('.').try_fold(v, |v, part| v.get(part))
}

fn lookup_mut<'a>(v: &'a mut serde_yaml::Value, key: &str) -> Option<&'a mut serde_yaml::Value> {
    key.split('.').try_fold(v, |v, part| v.get_mut(part))
}

fn params_yaml(p: &Params) -> serde_yaml::Value {
    serde_yaml::to_value(p).expect("Params serialises to YAML")
}

/// A YAML scalar as a value of `kind`.
fn value_of(v: &serde_yaml::Value, kind: Kind) -> Option<Value> {
    match kind {
        Kind::Bool => v.as_bool().map(Value::Bool),
        Kind::Int => v.as_i64().and_then(|i| i32::try_from(i).ok()).map(Value::Int),
        Kind::Double => v.as_f64().map(Value::Double),
    }
}

fn kind_of(v: &serde_yaml::Value) -> Option<Kind> {
    match v {
        serde_yaml::Value::Bool(_) => Some(Kind::Bool),
        serde_yaml::Value::Number(n) if n.is_f64() => Some(Kind::Double),
        serde_yaml::Value::Number(_) => Some(Kind::Int),
        _ => None,
    }
}

/// The allowed interval of `key`, from the error `Params::validate` gives
/// for a value that no range admits (NaN, or an integer above every bound).
fn probe_range(key: &'static str, kind: Kind) -> Result<(f64, f64), SpecError> {
    let mut v = params_yaml(&Params::default());
    let probe = match kind {
        Kind::Double => serde_yaml::Value::Number(f64::NAN.into()),
        Kind::Int => serde_yaml::Value::Number(u32::MAX.into()),
        Kind::Bool => unreachable!("booleans have no range"),
    };
    *lookup_mut(&mut v, key).ok_or(SpecError::NoSuchKey(key))? = probe;
    let p: Params = serde_yaml::from_value(v).map_err(|_| SpecError::NoRange(key))?;
    let errors = p.validate().err().unwrap_or_default();
    errors
        .iter()
        .filter(|e| e.key == key)
        .find_map(|e| e.allowed.interval())
        .map(|i| (i.lo, i.hi))
        .ok_or(SpecError::NoRange(key))
}

fn spec(key: &'static str, description: &'static str) -> Result<Spec, SpecError> {
    let defaults = params_yaml(&Params::default());
    let v = lookup(&defaults, key).ok_or(SpecError::NoSuchKey(key))?;
    let kind = kind_of(v).ok_or(SpecError::NotScalar(key))?;
    let default = value_of(v, kind).ok_or(SpecError::NotScalar(key))?;
    let (min, max) = match kind {
        Kind::Bool => (Value::Bool(false), Value::Bool(true)),
        Kind::Double => {
            let (lo, hi) = probe_range(key, kind)?;
            (Value::Double(lo), Value::Double(hi))
        }
        Kind::Int => {
            let (lo, hi) = probe_range(key, kind)?;
            let clamp = |x: f64| x.clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32;
            (Value::Int(clamp(lo)), Value::Int(clamp(hi)))
        }
    };
    Ok(Spec {
        key,
        description,
        kind,
        default,
        min,
        max,
    })
}

/// The specs of [`RECONFIGURABLE`], and the entries `Params` cannot back
/// (a unit test keeps that list empty; the node logs them and serves the rest).
pub fn specs() -> (Vec<Spec>, Vec<SpecError>) {
    let mut ok = Vec::new();
    let mut bad = Vec::new();
    for &(key, description) in RECONFIGURABLE {
        match spec(key, description) {
            Ok(s) => ok.push(s),
            Err(e) => bad.push(e),
        }
    }
    (ok, bad)
}

/// The running value of every spec.
pub fn values(params: &Params, specs: &[Spec]) -> Vec<(&'static str, Value)> {
    let v = params_yaml(params);
    specs
        .iter()
        .filter_map(|s| Some((s.key, value_of(lookup(&v, s.key)?, s.kind)?)))
        .collect()
}

/// `params` with `changes` applied, if `Params::validate` accepts the result
/// as a whole; otherwise every reason, and nothing applied.
pub fn apply(params: &Params, specs: &[Spec], changes: &[(String, Value)]) -> Result<Params, ReconfigureError> {
    let mut v = params_yaml(params);
    for (key, value) in changes {
        let spec = specs
            .iter()
            .find(|s| s.key == key)
            .ok_or_else(|| ReconfigureError::NotReconfigurable(key.clone()))?;
        // An int where a double is expected is fine (YAML does the same).
        let value = match (spec.kind, *value) {
            (Kind::Double, Value::Int(i)) => Value::Double(f64::from(i)),
            (k, v) if k == v.kind() => v,
            (_, got) => {
                return Err(ReconfigureError::WrongType {
                    key: key.clone(),
                    expected: spec.kind,
                    got,
                })
            }
        };
        *lookup_mut(&mut v, spec.key).ok_or_else(|| ReconfigureError::NotReconfigurable(key.clone()))? =
            value.to_yaml();
    }
    let p: Params = serde_path_to_error::deserialize(v)
        .map_err(|e| ReconfigureError::Decode(format!("key `{}`: {}", e.path(), e.inner())))?;
    p.validate().map_err(ReconfigureError::Invalid)?;
    Ok(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec_of(key: &str) -> Spec {
        specs().0.into_iter().find(|s| s.key == key).unwrap()
    }

    #[test]
    fn every_table_entry_is_backed_by_params() {
        let (ok, bad) = specs();
        assert!(bad.is_empty(), "{bad:?}");
        assert_eq!(ok.len(), RECONFIGURABLE.len());
        // Unique keys: dynamic_reconfigure names are a flat namespace.
        let mut keys: Vec<_> = ok.iter().map(|s| s.key).collect();
        keys.sort();
        keys.dedup();
        assert_eq!(keys.len(), ok.len());
        // Every default lies within its own range.
        for s in &ok {
            match (s.default, s.min, s.max) {
                (Value::Double(d), Value::Double(lo), Value::Double(hi)) => assert!(lo <= d && d <= hi, "{s:?}"),
                (Value::Int(d), Value::Int(lo), Value::Int(hi)) => assert!(lo <= d && d <= hi, "{s:?}"),
                (Value::Bool(_), Value::Bool(false), Value::Bool(true)) => {}
                _ => panic!("mixed kinds: {s:?}"),
            }
        }
    }

    /// Types, defaults and ranges are Params' own: `[0, 10] m` for d_safe,
    /// `(0, 1]` for γ, the ω_max range, a boolean.
    #[test]
    fn types_defaults_and_ranges_come_from_params() {
        let d = spec_of("barrier.d_safe_m");
        assert_eq!(
            (d.kind, d.default, d.min, d.max),
            (
                Kind::Double,
                Value::Double(0.2),
                Value::Double(0.0),
                Value::Double(10.0)
            )
        );
        assert_eq!(
            (d.section(), d.ros_param()),
            ("barrier", "barrier/d_safe_m".to_string())
        );
        let g = spec_of("dtcbf.gamma");
        assert_eq!(
            (g.default, g.min, g.max),
            (Value::Double(0.2), Value::Double(0.0), Value::Double(1.0))
        );
        let w = spec_of("control.omega_max_radps");
        assert_eq!(
            (w.default, w.min, w.max),
            (Value::Double(0.3), Value::Double(0.0), Value::Double(10.0))
        );
        let e = spec_of("obstacles.enabled");
        assert_eq!((e.kind, e.default), (Kind::Bool, Value::Bool(true)));
    }

    #[test]
    fn integer_keys_get_integer_ranges() {
        // Not in the table today; the probe must still work when one is added.
        let s = spec("obstacles.confirm_hits", "").unwrap();
        assert_eq!(
            (s.kind, s.default, s.min, s.max),
            (Kind::Int, Value::Int(3), Value::Int(1), Value::Int(100))
        );
        let s = spec("dtcbf.omega_candidates", "").unwrap();
        assert_eq!((s.min, s.max), (Value::Int(3), Value::Int(201)));
        assert_eq!(spec("barrier.nope", ""), Err(SpecError::NoSuchKey("barrier.nope")));
        assert_eq!(spec("barrier", ""), Err(SpecError::NotScalar("barrier")));
    }

    #[test]
    fn a_valid_change_is_applied_and_reads_back() {
        let (specs, _) = specs();
        let p = Params::default();
        let q = apply(
            &p,
            &specs,
            &[
                ("barrier.d_safe_m".into(), Value::Double(0.35)),
                ("obstacles.enabled".into(), Value::Bool(false)),
                // An int for a double key, as a YAML file may write it.
                ("barrier.zeta".into(), Value::Int(1)),
            ],
        )
        .unwrap();
        assert_eq!(
            (q.barrier.d_safe_m, q.obstacles.enabled, q.barrier.zeta),
            (0.35, false, 1.0)
        );
        let mut expected = p.clone();
        expected.barrier.d_safe_m = 0.35;
        expected.obstacles.enabled = false;
        expected.barrier.zeta = 1.0;
        assert_eq!(q, expected, "nothing else changed");
        let read = values(&q, &specs);
        assert!(read.contains(&("barrier.d_safe_m", Value::Double(0.35))));
        assert!(read.contains(&("obstacles.enabled", Value::Bool(false))));
        assert_eq!(read.len(), specs.len());
    }

    /// The same checks and messages as the YAML file; one bad value refuses the whole request.
    #[test]
    fn an_invalid_change_is_refused_naming_the_key() {
        let (specs, _) = specs();
        let p = Params::default();
        let e = apply(
            &p,
            &specs,
            &[
                ("dtcbf.gamma".into(), Value::Double(0.5)),
                ("barrier.d_safe_m".into(), Value::Double(30.0)),
            ],
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "key `barrier.d_safe_m` = 30 is out of range; allowed: [0, 10] m"
        );
        let e = apply(&p, &specs, &[("dtcbf.gamma".into(), Value::Double(f64::NAN))]).unwrap_err();
        assert!(e.to_string().contains("key `dtcbf.gamma` = NaN"), "{e}");
        // Cross-key rules hold too: v_nom above a lowered v_max.
        let e = apply(&p, &specs, &[("control.v_max_mps".into(), Value::Double(0.1))]).unwrap_err();
        assert!(e.to_string().contains("control.v_nom_mps"), "{e}");
        // Not in the table, wrong type.
        assert_eq!(
            apply(&p, &specs, &[("control.rate_hz".into(), Value::Double(20.0))]),
            Err(ReconfigureError::NotReconfigurable("control.rate_hz".into()))
        );
        assert!(matches!(
            apply(&p, &specs, &[("obstacles.enabled".into(), Value::Double(1.0))]),
            Err(ReconfigureError::WrongType {
                expected: Kind::Bool,
                ..
            })
        ));
    }

    #[test]
    fn a_negative_count_is_refused_by_decoding() {
        let specs = vec![spec("obstacles.confirm_hits", "").unwrap()];
        let e = apply(
            &Params::default(),
            &specs,
            &[("obstacles.confirm_hits".into(), Value::Int(-1))],
        )
        .unwrap_err();
        assert!(e.to_string().contains("obstacles.confirm_hits"), "{e}");
    }
}
