//! The command language of `can_bridge_cli`: one action per line, typed on
//! stdin or listed with times in a script file.
//!
//! ```text
//! 0.2 0.5          twist: v (m/s) and ω (rad/s); `twist 0.2 0.5` is the same
//! estop            latch the e-stop
//! reset            clear e-stop and latched drive faults
//! status           print a status line now
//! quit             shut the drive down (zero, then disable) and exit
//! sdo_read N I S   CANopen: read object I, sub-index S of node N (numbers decimal or 0x hex)
//! sdo_write N I S HEX   write the bytes HEX (e.g. e8030000: 1000 as a u32, little endian)
//! # comment        blank lines and comments are ignored
//! ```
//!
//! A script line starts with its time in seconds from the start:
//! `1.5 0.2 0.0`, `3 estop`, and a command stream (a teleop at 1/DT Hz):
//! `T V W every DT until T_END`. NaN and infinities parse, so garbage
//! commands can be scripted (the bridge rejects them).

use crate::kinematics::Twist;

/// Largest number of steps one `every` line may expand to.
pub const MAX_EXPANDED_STEPS: usize = 1_000_000;

/// What a line asks for.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    Twist(Twist),
    Estop,
    Reset,
    Status,
    Quit,
    /// Read an object of a CANopen node.
    SdoRead {
        node: u8,
        index: u16,
        sub: u8,
    },
    /// Write bytes to an object of a CANopen node.
    SdoWrite {
        node: u8,
        index: u16,
        sub: u8,
        data: Vec<u8>,
    },
}

/// An action at a time (s from the start).
#[derive(Clone, Debug, PartialEq)]
pub struct ScriptStep {
    pub at_s: f64,
    pub action: Action,
}

/// A line that is not a command.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ScriptError {
    /// A field that should be a number.
    #[error("{what} `{text}` is not a number")]
    NotANumber {
        /// `v`, `omega`, `time`, `period` or `end time`.
        what: &'static str,
        /// What was given.
        text: String,
    },
    /// No command has these words.
    #[error(
        "cannot parse `{0}`; expected `V OMEGA`, `twist V OMEGA`, estop, reset, status, quit, `sdo_read NODE INDEX SUB` or `sdo_write NODE INDEX SUB HEX`"
    )]
    Unknown(String),
    /// An SDO argument out of its range or not a number.
    #[error("sdo: {what} `{text}` is not {allowed}")]
    BadSdo {
        /// `node`, `index`, `sub-index` or `data`.
        what: &'static str,
        text: String,
        allowed: &'static str,
    },
    /// A step before the start.
    #[error("time {0} must be a non-negative number")]
    NegativeTime(f64),
    /// `every` with a period that is not positive or an end that is not finite.
    #[error("`every` needs a positive period and a finite end")]
    BadRepeat,
    /// `every` that would expand to more than [`MAX_EXPANDED_STEPS`].
    #[error("`every` expands to more than {MAX_EXPANDED_STEPS} steps")]
    TooManySteps,
}

/// A script error and the line (from 1) it is on.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("line {line}: {error}")]
pub struct ScriptLineError {
    /// Line number, from 1.
    pub line: usize,
    /// What is wrong with it.
    pub error: ScriptError,
}

fn num(s: &str, what: &'static str) -> Result<f64, ScriptError> {
    s.parse::<f64>().map_err(|_| ScriptError::NotANumber {
        what,
        text: s.to_string(),
    })
}

/// A decimal or 0x-hex integer within `max`.
fn int(s: &str, what: &'static str, max: u32, allowed: &'static str) -> Result<u32, ScriptError> {
    let v = match s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        Some(h) => u32::from_str_radix(h, 16).ok(),
        None => s.parse().ok(),
    };
    v.filter(|v| *v <= max).ok_or(ScriptError::BadSdo {
        what,
        text: s.to_string(),
        allowed,
    })
}

fn sdo_target(node: &str, index: &str, sub: &str) -> Result<(u8, u16, u8), ScriptError> {
    let n = int(node, "node", 127, "a node id 1-127")?;
    if n == 0 {
        return Err(ScriptError::BadSdo {
            what: "node",
            text: node.to_string(),
            allowed: "a node id 1-127",
        });
    }
    let i = int(index, "index", 0xFFFF, "an index 0-0xFFFF")?;
    let s = int(sub, "sub-index", 0xFF, "a sub-index 0-0xFF")?;
    Ok((n as u8, i as u16, s as u8))
}

/// Bytes from hex (`e8030000`, optionally `0x`-prefixed), 1–1024 of them.
fn hex_bytes(s: &str) -> Result<Vec<u8>, ScriptError> {
    let bad = || ScriptError::BadSdo {
        what: "data",
        text: s.to_string(),
        allowed: "1-1024 bytes in hex (two digits each)",
    };
    let h = s.strip_prefix("0x").unwrap_or(s);
    if h.is_empty() || h.len() % 2 != 0 || h.len() > 2048 {
        return Err(bad());
    }
    (0..h.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(h.get(i..i + 2).ok_or_else(bad)?, 16).map_err(|_| bad()))
        .collect()
}

fn parse_words(words: &[&str]) -> Result<Action, ScriptError> {
    match words {
        ["sdo_read", n, i, s] => {
            let (node, index, sub) = sdo_target(n, i, s)?;
            Ok(Action::SdoRead { node, index, sub })
        }
        ["sdo_write", n, i, s, data] => {
            let (node, index, sub) = sdo_target(n, i, s)?;
            Ok(Action::SdoWrite {
                node,
                index,
                sub,
                data: hex_bytes(data)?,
            })
        }
        ["estop"] => Ok(Action::Estop),
        ["reset"] => Ok(Action::Reset),
        ["status"] => Ok(Action::Status),
        ["quit"] | ["exit"] => Ok(Action::Quit),
        ["twist", v, w] | [v, w] => Ok(Action::Twist(Twist::new(num(v, "v")?, num(w, "omega")?))),
        _ => Err(ScriptError::Unknown(words.join(" "))),
    }
}

fn content(line: &str) -> Vec<&str> {
    let line = line.split('#').next().unwrap_or_default();
    line.split_whitespace().collect()
}

/// One interactive line; `Ok(None)` for blank lines and comments.
pub fn parse_action(line: &str) -> Result<Option<Action>, ScriptError> {
    let words = content(line);
    if words.is_empty() {
        return Ok(None);
    }
    parse_words(&words).map(Some)
}

/// A whole script, `every` lines expanded, sorted by time (stable for equal times).
pub fn parse_script(text: &str) -> Result<Vec<ScriptStep>, ScriptLineError> {
    let mut steps = Vec::new();
    for (i, line) in text.lines().enumerate() {
        parse_line(line, &mut steps).map_err(|error| ScriptLineError { line: i + 1, error })?;
    }
    steps.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));
    Ok(steps)
}

/// One script line's steps, appended to `steps`.
fn parse_line(line: &str, steps: &mut Vec<ScriptStep>) -> Result<(), ScriptError> {
    let words = content(line);
    let Some((t, rest)) = words.split_first() else {
        return Ok(());
    };
    let at = num(t, "time")?;
    if !(at.is_finite() && at >= 0.0) {
        return Err(ScriptError::NegativeTime(at));
    }
    if let [v, w, "every", dt, "until", end] = rest {
        let action = parse_words(&[v, w])?;
        let (dt, end) = (num(dt, "period")?, num(end, "end time")?);
        if !(dt.is_finite() && dt > 0.0 && end.is_finite()) {
            return Err(ScriptError::BadRepeat);
        }
        let n = ((end - at) / dt).ceil().max(0.0);
        if n > MAX_EXPANDED_STEPS as f64 {
            return Err(ScriptError::TooManySteps);
        }
        for k in 0..n as usize {
            let t_k = at + k as f64 * dt;
            if t_k < end {
                steps.push(ScriptStep {
                    at_s: t_k,
                    action: action.clone(),
                });
            }
        }
    } else {
        let action = parse_words(rest)?;
        steps.push(ScriptStep { at_s: at, action });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interactive_lines() {
        assert_eq!(
            parse_action("0.2 0.5").unwrap(),
            Some(Action::Twist(Twist::new(0.2, 0.5)))
        );
        assert_eq!(
            parse_action("twist -0.1 0").unwrap(),
            Some(Action::Twist(Twist::new(-0.1, 0.0)))
        );
        assert_eq!(parse_action("  estop  # now").unwrap(), Some(Action::Estop));
        assert_eq!(parse_action("# nothing").unwrap(), None);
        assert_eq!(parse_action("").unwrap(), None);
        match parse_action("NaN inf").unwrap() {
            Some(Action::Twist(t)) => assert!(t.linear_mps.is_nan() && t.angular_radps.is_infinite()),
            a => panic!("{a:?}"),
        }
        assert_eq!(
            parse_action("go fast"),
            Err(ScriptError::NotANumber {
                what: "v",
                text: "go".into()
            })
        );
        assert_eq!(parse_action("0.2"), Err(ScriptError::Unknown("0.2".into())));
    }

    #[test]
    fn scripts_expand_and_sort() {
        let s = parse_script("# demo\n1.0 estop\n0 0.2 0.0 every 0.25 until 1.0\n2 reset\n").unwrap();
        let times: Vec<f64> = s.iter().map(|x| x.at_s).collect();
        assert_eq!(times, [0.0, 0.25, 0.5, 0.75, 1.0, 2.0]);
        assert_eq!(s[4].action, Action::Estop);
        assert_eq!(s[5].action, Action::Reset);
    }

    #[test]
    fn script_errors_name_the_line() {
        let e = parse_script("0 estop\nx 0.1 0.1\n").unwrap_err();
        assert_eq!(e.line, 2);
        assert_eq!(e.to_string(), "line 2: time `x` is not a number");
        assert_eq!(
            parse_script("-1 estop").unwrap_err().error,
            ScriptError::NegativeTime(-1.0)
        );
        assert_eq!(
            parse_script("0 0.1 0.1 every 0 until 1").unwrap_err().error,
            ScriptError::BadRepeat
        );
        assert_eq!(
            parse_script("\n0 0.1 0.1 every 1e-9 until 1e9").unwrap_err(),
            ScriptLineError {
                line: 2,
                error: ScriptError::TooManySteps
            }
        );
        assert_eq!(
            parse_script("0 fly").unwrap_err().to_string(),
            "line 1: cannot parse `fly`; expected `V OMEGA`, `twist V OMEGA`, estop, reset, status, quit, `sdo_read NODE INDEX SUB` or `sdo_write NODE INDEX SUB HEX`"
        );
    }

    #[test]
    fn sdo_lines() {
        assert_eq!(
            parse_action("sdo_read 1 0x1008 0").unwrap(),
            Some(Action::SdoRead {
                node: 1,
                index: 0x1008,
                sub: 0
            })
        );
        assert_eq!(
            parse_action("sdo_write 0x7F 0x6883 0 e8030000").unwrap(),
            Some(Action::SdoWrite {
                node: 127,
                index: 0x6883,
                sub: 0,
                data: vec![0xE8, 0x03, 0, 0]
            })
        );
        for (line, what) in [
            ("sdo_read 0 0x1000 0", "node"),
            ("sdo_read 128 0x1000 0", "node"),
            ("sdo_read 1 0x10000 0", "index"),
            ("sdo_read 1 0x1000 256", "sub-index"),
            ("sdo_write 1 0x1000 0 abc", "data"),
            ("sdo_write 1 0x1000 0 zz", "data"),
            ("sdo_write 1 0x1000 0 0x", "data"),
        ] {
            match parse_action(line) {
                Err(ScriptError::BadSdo { what: w, .. }) => assert_eq!(w, what, "{line}"),
                r => panic!("{line}: {r:?}"),
            }
        }
        assert!(parse_action(&format!("sdo_write 1 0x2100 0 {}", "ab".repeat(1025))).is_err());
        assert!(parse_action(&format!("sdo_write 1 0x2100 0 {}", "ab".repeat(1024))).is_ok());
        let s = parse_script("2.5 sdo_read 2 0x1008 0\n").unwrap();
        assert_eq!(s[0].at_s, 2.5);
    }
}
