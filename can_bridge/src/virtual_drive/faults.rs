//! Faults the virtual drive can be told to inject (`--fault`), their
//! parsing, and applying them on schedule.

use super::VirtualDrive;
use crate::kinematics::Wheel;
use crate::protocol::ProtocolKind;
use crate::time::Timestamp;
use std::str::FromStr;

/// A fault to inject.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FaultKind {
    /// Sets error bits on one axis or both (generic: Error_Code, state FAULT;
    /// ODrive: Axis_Error, idle). Latched until cleared by the bridge.
    AxisError {
        /// The error bits (generic Error_Code, ODrive Axis_Error, CiA 402 0x603F).
        code: u32,
        /// One wheel, or both (`None`).
        wheel: Option<Wheel>,
    },
    /// No heartbeats / status frames while active.
    HeartbeatSilence,
    /// No feedback frames while active.
    FeedbackSilence,
    /// Nothing at all is sent while active (the drive still listens).
    Silence,
    /// Feedback frames leave this late while active (s).
    FeedbackDelay {
        /// How late (s).
        delay_s: f64,
    },
    /// The drive stops sending for good, as if killed.
    Exit,
    /// CiA 402: SDO requests get no answer while active.
    SdoSilence,
    /// CiA 402: the node(s) reboot (boot-up message, dictionary defaults,
    /// switch on disabled), as after a power glitch.
    Reboot {
        /// One wheel, or both (`None`).
        wheel: Option<Wheel>,
    },
}

/// A fault at a time (from the drive's start), optionally for a duration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaultSpec {
    /// What goes wrong.
    pub kind: FaultKind,
    /// When, from the drive's start (s).
    pub start_s: f64,
    /// `None`: until the end (one-shot kinds ignore it).
    pub duration_s: Option<f64>,
}

impl FaultSpec {
    pub(super) fn active(&self, t_s: f64) -> bool {
        t_s >= self.start_s && self.duration_s.is_none_or(|d| t_s < self.start_s + d)
    }
}

/// A `--fault` spec that cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("fault `{spec}`: {problem}")]
pub struct FaultSpecError {
    /// The spec as given.
    pub spec: String,
    /// What is wrong with it.
    pub problem: FaultProblem,
}

/// What is wrong with a fault spec.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FaultProblem {
    /// No `@`.
    #[error("expected KIND@START[+DURATION][:ARGS]")]
    Syntax,
    /// A time that is not a finite non-negative number.
    #[error("{what} `{text}` is not a non-negative number")]
    NotANumber {
        /// `start`, `duration` or `delay`.
        what: &'static str,
        /// What was given.
        text: String,
    },
    /// An error code that is not a u32.
    #[error("error code `{0}` is not a u32 (decimal or 0x hex)")]
    NotACode(String),
    /// Error code 0.
    #[error("error code 0 is no error")]
    ZeroCode,
    /// A wheel that is not left, right or both.
    #[error("wheel `{0}` is not left, right or both")]
    Wheel(String),
    /// Arguments to a kind that takes none.
    #[error("{0} takes no arguments")]
    NoArguments(String),
    /// `feedback_delay` without its delay.
    #[error("feedback_delay needs :SECONDS")]
    MissingDelay,
    /// `reboot` with more than a wheel.
    #[error("reboot takes at most a wheel")]
    RebootArguments,
    /// A kind that is none of ours.
    #[error(
        "unknown kind `{0}`; allowed: axis_error, heartbeat_silence, feedback_silence, silence, feedback_delay, exit, sdo_silence, reboot"
    )]
    UnknownKind(String),
}

fn parse_num(s: &str, what: &'static str) -> Result<f64, FaultProblem> {
    s.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite() && *v >= 0.0)
        .ok_or_else(|| FaultProblem::NotANumber {
            what,
            text: s.to_string(),
        })
}

fn parse_u32(s: &str) -> Result<u32, FaultProblem> {
    let r = match s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        Some(hex) => u32::from_str_radix(hex, 16),
        None => s.parse(),
    };
    r.map_err(|_| FaultProblem::NotACode(s.to_string()))
}

fn parse_wheel(arg: Option<&str>) -> Result<Option<Wheel>, FaultProblem> {
    match arg {
        None | Some("both") => Ok(None),
        Some("left") => Ok(Some(Wheel::Left)),
        Some("right") => Ok(Some(Wheel::Right)),
        Some(w) => Err(FaultProblem::Wheel(w.to_string())),
    }
}

/// `KIND@START[+DURATION][:ARG[:ARG]]` without the error's spec.
fn parse_spec(s: &str) -> Result<FaultSpec, FaultProblem> {
    let (kind, rest) = s.split_once('@').ok_or(FaultProblem::Syntax)?;
    let mut parts = rest.split(':');
    let when = parts.next().unwrap_or_default();
    let args: Vec<&str> = parts.collect();
    let (start, dur) = match when.split_once('+') {
        Some((a, b)) => (parse_num(a, "start")?, Some(parse_num(b, "duration")?)),
        None => (parse_num(when, "start")?, None),
    };
    let no_args = |k: FaultKind| {
        if args.is_empty() {
            Ok(k)
        } else {
            Err(FaultProblem::NoArguments(kind.to_string()))
        }
    };
    let kind = match kind {
        "axis_error" => {
            let code = match args.first() {
                Some(c) => parse_u32(c)?,
                None => 0x1,
            };
            let wheel = parse_wheel(args.get(1).copied())?;
            if code == 0 {
                return Err(FaultProblem::ZeroCode);
            }
            FaultKind::AxisError { code, wheel }
        }
        "heartbeat_silence" => no_args(FaultKind::HeartbeatSilence)?,
        "feedback_silence" => no_args(FaultKind::FeedbackSilence)?,
        "silence" => no_args(FaultKind::Silence)?,
        "feedback_delay" => {
            let d = args.first().ok_or(FaultProblem::MissingDelay)?;
            FaultKind::FeedbackDelay {
                delay_s: parse_num(d, "delay")?,
            }
        }
        "exit" => no_args(FaultKind::Exit)?,
        "sdo_silence" => no_args(FaultKind::SdoSilence)?,
        "reboot" => {
            let wheel = parse_wheel(args.first().copied())?;
            if args.len() > 1 {
                return Err(FaultProblem::RebootArguments);
            }
            FaultKind::Reboot { wheel }
        }
        k => return Err(FaultProblem::UnknownKind(k.to_string())),
    };
    Ok(FaultSpec {
        kind,
        start_s: start,
        duration_s: dur,
    })
}

impl FromStr for FaultSpec {
    type Err = FaultSpecError;

    /// `KIND@START[+DURATION][:ARG[:ARG]]`, e.g. `axis_error@2:0x20:left`,
    /// `heartbeat_silence@3+1.5`, `feedback_delay@1+5:0.3`, `exit@4`.
    fn from_str(s: &str) -> Result<Self, FaultSpecError> {
        parse_spec(s).map_err(|problem| FaultSpecError {
            spec: s.to_string(),
            problem,
        })
    }
}

impl VirtualDrive {
    /// The fault schedule's time at `now` (s); −∞ while its clock has not
    /// started, so no scheduled fault is active.
    pub(super) fn fault_time_s(&self, now: Timestamp) -> f64 {
        self.fault_epoch.map_or(f64::NEG_INFINITY, |e| (now - e).as_secs_f64())
    }

    /// Injects a fault now (starting the schedule's clock if it has not started).
    pub fn inject(&mut self, kind: FaultKind, duration_s: Option<f64>, now: Timestamp) {
        let epoch = *self.fault_epoch.get_or_insert(now);
        let start_s = (now - epoch).as_secs_f64();
        self.cfg.faults.push(FaultSpec {
            kind,
            start_s,
            duration_s,
        });
        self.applied.push(false);
    }

    /// Ends every injected or scheduled fault (latched axis errors stay until cleared).
    pub fn clear_faults(&mut self) {
        self.cfg.faults.clear();
        self.applied.clear();
    }

    pub(super) fn fault_active(&self, t_s: f64, pred: impl Fn(&FaultKind) -> bool) -> Option<FaultSpec> {
        self.cfg.faults.iter().copied().find(|f| pred(&f.kind) && f.active(t_s))
    }

    pub(super) fn apply_scheduled(&mut self, t_s: f64, now: Timestamp) {
        for i in 0..self.cfg.faults.len() {
            let f = self.cfg.faults[i];
            if self.applied[i] || t_s < f.start_s {
                continue;
            }
            match f.kind {
                FaultKind::AxisError { code, wheel } => {
                    self.applied[i] = true;
                    log::warn!("injecting axis error 0x{code:X} on {wheel:?}");
                    match self.cfg.protocol {
                        ProtocolKind::Generic => self.generic_set_error(code),
                        ProtocolKind::Cia402 => {
                            for w in Wheel::BOTH {
                                if wheel.is_none_or(|x| x == w) {
                                    let (n, k) = self.co_of[w.index()];
                                    self.co[n].fault(k, u16::try_from(code).unwrap_or(0x1000));
                                }
                            }
                        }
                        ProtocolKind::Odrive => {
                            for w in Wheel::BOTH {
                                if wheel.is_none_or(|x| x == w) {
                                    self.axes[w.index()].disarm(code);
                                }
                            }
                        }
                    }
                }
                FaultKind::Reboot { wheel } => {
                    self.applied[i] = true;
                    log::warn!("rebooting {wheel:?}");
                    // A reboot is the node's: every axis on it restarts.
                    for n in &mut self.co {
                        if n.axes.iter().any(|a| wheel.is_none_or(|x| x == a.wheel)) {
                            n.boot(now);
                        }
                    }
                }
                FaultKind::Exit => {
                    self.applied[i] = true;
                    log::warn!("exit fault: going silent for good");
                    self.exited = true;
                }
                _ => {}
            }
        }
    }
}
