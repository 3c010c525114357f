//! /diagnostics for the safety node: scan rate and age, filter activity,
//! condition status, the e-stop and a disable (with when it lapses), and
//! why the robot is stopped, if it is. One status, named `<node>: safety
//! filter` (what `config/diagnostic_analyzers.yaml` matches), with the
//! `hardware_id` the node chose (node/hardware_id, or the scan's frame).

use super::msg::diagnostic_msgs::{DiagnosticArray, DiagnosticStatus, KeyValue};
use crate::algo::scan_merge::ScannerState;
use crate::node_core::Tick;
use std::collections::VecDeque;

/// Counts over a sliding window of ticks and scan arrivals.
#[derive(Debug, Default)]
pub struct Activity {
    scans: VecDeque<f64>,
    ticks: VecDeque<(f64, bool, bool)>,
}

/// Length of the sliding window (s).
const WINDOW_S: f64 = 2.0;

impl Activity {
    pub fn scan_arrived(&mut self, now_s: f64) {
        self.scans.push_back(now_s);
        while self.scans.front().is_some_and(|&t| now_s - t > WINDOW_S) {
            self.scans.pop_front();
        }
    }

    pub fn ticked(&mut self, now_s: f64, tick: &Tick) {
        self.ticks
            .push_back((now_s, tick.record.filter_changed, tick.record.condition_held));
        while self.ticks.front().is_some_and(|&(t, _, _)| now_s - t > WINDOW_S) {
            self.ticks.pop_front();
        }
    }

    /// When the last scan arrived (s); kept however long ago (the window
    /// drops old arrivals only when a new one comes).
    pub fn last_scan_s(&self) -> Option<f64> {
        self.scans.back().copied()
    }

    /// Scans per second over the window.
    pub fn scan_rate_hz(&self, now_s: f64) -> f64 {
        self.scans.iter().filter(|&&t| now_s - t <= WINDOW_S).count() as f64 / WINDOW_S
    }

    fn fraction(&self, pick: impl Fn(&(f64, bool, bool)) -> bool) -> f64 {
        if self.ticks.is_empty() {
            0.0
        } else {
            self.ticks.iter().filter(|t| pick(t)).count() as f64 / self.ticks.len() as f64
        }
    }
}

fn kv(key: &str, value: impl ToString) -> KeyValue {
    KeyValue {
        key: key.into(),
        value: value.to_string(),
    }
}

/// What a disable does from `now_s`: until `~enable true`, or until it lapses.
fn disable_text(now_s: f64, tick: &Tick) -> String {
    match tick.disable_lapses_at_s {
        Some(at_s) => format!(
            "lapses in {:.1} s (at {at_s:.3} s) unless renewed",
            (at_s - now_s).max(0.0)
        ),
        None => "until ~enable true".into(),
    }
}

/// Where each scan topic's laser is ([`crate::tf_tree`]) and, with several
/// scanners, what each contributes.
#[derive(Debug, Clone, Copy)]
pub struct Sensors<'a> {
    /// One line per scan topic: its pose from tf (or YAML), or why it has none.
    pub laser_poses: &'a [String],
    /// Several scanners: each one's state (empty with one scan topic).
    pub scanners: &'a [ScannerState],
}

/// One DiagnosticArray for the node `name` at `now_s`.
pub fn diagnostics(
    name: &str,
    hardware_id: &str,
    stamp: rosrust::Time,
    now_s: f64,
    tick: &Tick,
    activity: &Activity,
    sensors: &Sensors<'_>,
) -> DiagnosticArray {
    let Sensors { laser_poses, scanners } = *sensors;
    let rec = &tick.record;
    let scan_age = now_s - tick.scan_stamp_s;
    // A silent lock is a fault (ERROR); a latch someone pressed is a state (WARN).
    let (level, message) = if tick.e_stop_silence.is_some() {
        (DiagnosticStatus::ERROR, format!("stopped: {}", tick.stop_reason()))
    } else if tick.e_stop {
        (
            DiagnosticStatus::WARN,
            "e-stop latched: stopped until reset".to_string(),
        )
    } else if let (Some(_), Some(fault)) = (rec.stop_cause, tick.scan_fault) {
        (DiagnosticStatus::ERROR, format!("stopped: {fault}"))
    } else if let (Some(cause), false) = (rec.stop_cause, rec.measured()) {
        (DiagnosticStatus::ERROR, format!("stopped: {cause}"))
    } else if !tick.filter_enabled {
        (
            DiagnosticStatus::WARN,
            format!(
                "filter DISABLED: cmd_vel_in passes through; {}",
                disable_text(now_s, tick)
            ),
        )
    } else if let Some(cause) = rec.stop_cause {
        (DiagnosticStatus::WARN, format!("stopped: {cause}"))
    } else if !rec.condition_held {
        (
            DiagnosticStatus::WARN,
            format!("{}: DTCBF condition not held", rec.state),
        )
    } else {
        (DiagnosticStatus::OK, format!("{}", rec.state))
    };
    let status = DiagnosticStatus {
        level,
        name: format!("{name}: safety filter"),
        message,
        hardware_id: hardware_id.into(),
        values: vec![
            kv("scan_rate_hz", format!("{:.1}", activity.scan_rate_hz(now_s))),
            kv(
                "scan_age_s",
                if scan_age.is_finite() {
                    format!("{scan_age:.3}")
                } else {
                    "no scan yet".into()
                },
            ),
            kv("doaa_state", rec.state),
            kv(
                "laser_pose",
                if laser_poses.iter().all(String::is_empty) {
                    "no scan yet".to_string()
                } else {
                    laser_poses.join("; ")
                },
            ),
            kv("filter_enabled", tick.filter_enabled),
            kv("filter_active_fraction", format!("{:.2}", activity.fraction(|t| t.1))),
            kv("condition_held_fraction", format!("{:.2}", activity.fraction(|t| t.2))),
            kv("h_m", format!("{:.3}", rec.h_m)),
            kv(
                "filter_disabled",
                if tick.filter_enabled {
                    String::new()
                } else {
                    disable_text(now_s, tick)
                },
            ),
            kv(
                "disable_lapses_in_s",
                tick.disable_lapses_at_s
                    .map(|at| format!("{:.1}", (at - now_s).max(0.0)))
                    .unwrap_or_default(),
            ),
            kv("e_stop", tick.e_stop),
            kv("e_stop_latched", tick.e_stop_latched),
            kv(
                "e_stop_silent",
                tick.e_stop_silence.map(|s| s.to_string()).unwrap_or_default(),
            ),
            kv("stop_reason", rec.stop_cause.map(|c| c.to_string()).unwrap_or_default()),
            kv("scan_fault", tick.scan_fault.map(|f| f.code()).unwrap_or_default()),
            kv("nominal_source", tick.nominal_used),
            kv("valid_beams", rec.valid_beams),
            kv("unknown_beams", rec.unknown_beams),
            kv("held_beams", rec.held_beams),
            kv("unknown_front_fraction", format!("{:.2}", rec.unknown_front_fraction)),
            kv(
                "sensor_blind",
                rec.stop_cause == Some(crate::algo::StopCause::SensorBlind),
            ),
            kv("braking_held", rec.braking_held),
            kv("infeasible", rec.infeasibility.map(|i| i.code()).unwrap_or_default()),
        ],
    };
    // Several scanners: what each contributes (live, silent, blind, no pose, …).
    let mut status = status;
    for (k, state) in scanners.iter().enumerate() {
        let text = match state {
            ScannerState::Silent { age_s } => format!("silent for {age_s:.3} s: its view unknown"),
            ScannerState::Blind { unknown_fraction } => {
                format!(
                    "blind ({:.0} % unknown): its free beams do not count",
                    100.0 * unknown_fraction
                )
            }
            ScannerState::Rejected(why) => format!("rejected ({}): its view unknown", why.code()),
            ScannerState::NoPose => "no pose on the robot (tf): its view unknown".to_string(),
            ScannerState::Frozen { stamp_s } => {
                format!("stamp {stamp_s:.3} s not newer than its last: frozen, its view unknown")
            }
            ScannerState::NotYet => "no scan yet: its view unknown".to_string(),
            ScannerState::Live => "live".to_string(),
        };
        status.values.push(kv(&format!("scanner_{k}"), text));
    }
    let mut array = DiagnosticArray {
        status: vec![status],
        ..Default::default()
    };
    array.header.stamp = stamp;
    array
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algo::geometry::Twist;
    use crate::algo::scan::ScanHeader;
    use crate::algo::Params;
    use crate::node_core::{NodeCore, NodeSettings};

    fn status(n: &mut NodeCore, now_s: f64) -> DiagnosticStatus {
        let header = ScanHeader {
            stamp_s: now_s,
            angle_min_rad: -std::f32::consts::PI,
            angle_increment_rad: std::f32::consts::TAU / 360.0,
            range_min_m: 0.12,
            range_max_m: 3.5,
        };
        n.on_scan(header, &[f32::INFINITY; 360], &[]);
        n.on_cmd_in(Twist::new(0.1, 0.0), now_s);
        let tick = n.tick(now_s);
        let stamp = rosrust::Time::default();
        let mut a = diagnostics(
            "/n",
            "front_laser",
            stamp,
            now_s,
            &tick,
            &Activity::default(),
            &Sensors {
                laser_poses: &[],
                scanners: &[],
            },
        );
        a.status.remove(0)
    }

    fn value<'a>(s: &'a DiagnosticStatus, key: &str) -> &'a str {
        &s.values.iter().find(|kv| kv.key == key).unwrap().value
    }

    #[test]
    fn the_status_names_the_node_and_its_hardware() {
        let mut n = NodeCore::new(Params::default(), NodeSettings::default(), None);
        let s = status(&mut n, 1.0);
        assert_eq!(
            (s.name.as_str(), s.hardware_id.as_str()),
            ("/n: safety filter", "front_laser")
        );
        assert_eq!(s.level, DiagnosticStatus::OK);
    }

    /// Disabled at 1.0 s with disable_timeout_s 30: at 3.0 s it lapses in 28 s.
    #[test]
    fn a_disable_says_when_it_lapses() {
        let settings = NodeSettings {
            disable_timeout_s: 30.0,
            ..NodeSettings::default()
        };
        let mut n = NodeCore::new(Params::default(), settings, None);
        n.set_enabled(false, 1.0);
        let s = status(&mut n, 3.0);
        assert_eq!(s.level, DiagnosticStatus::WARN);
        assert_eq!(
            s.message,
            "filter DISABLED: cmd_vel_in passes through; lapses in 28.0 s (at 31.000 s) unless renewed"
        );
        assert_eq!(value(&s, "disable_lapses_in_s"), "28.0");
        let mut n = NodeCore::new(Params::default(), NodeSettings::default(), None);
        n.set_enabled(false, 1.0);
        let s = status(&mut n, 3.0);
        assert_eq!(
            s.message,
            "filter DISABLED: cmd_vel_in passes through; until ~enable true"
        );
        assert_eq!(value(&s, "disable_lapses_in_s"), "");
    }

    #[test]
    fn a_silent_e_stop_is_an_error_that_says_why() {
        let settings = NodeSettings {
            e_stop_timeout_s: 0.5,
            ..NodeSettings::default()
        };
        let mut n = NodeCore::new(Params::default(), settings, None);
        n.on_e_stop(false, 1.0);
        let s = status(&mut n, 1.75);
        assert_eq!(s.level, DiagnosticStatus::ERROR);
        assert_eq!(
            s.message,
            "stopped: e_stop silent for 0.750 s (liveness timeout 0.500 s): stopped until a fresh false arrives"
        );
        assert_eq!((value(&s, "e_stop"), value(&s, "e_stop_latched")), ("true", "false"));
    }
}
