//! /diagnostics for the safety node: scan rate and age, filter activity,
//! condition status, and why the robot is stopped, if it is.

use super::msg::diagnostic_msgs::{DiagnosticArray, DiagnosticStatus, KeyValue};
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

/// One DiagnosticArray for the node `name` at `now_s`.
pub fn diagnostics(name: &str, stamp: rosrust::Time, now_s: f64, tick: &Tick, activity: &Activity) -> DiagnosticArray {
    let rec = &tick.record;
    let scan_age = now_s - tick.scan_stamp_s;
    let (level, message) = if tick.e_stop {
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
            "filter DISABLED: cmd_vel_in passes through".to_string(),
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
        hardware_id: String::new(),
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
            kv("filter_enabled", tick.filter_enabled),
            kv("filter_active_fraction", format!("{:.2}", activity.fraction(|t| t.1))),
            kv("condition_held_fraction", format!("{:.2}", activity.fraction(|t| t.2))),
            kv("h_m", format!("{:.3}", rec.h_m)),
            kv("e_stop", tick.e_stop),
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
    let mut array = DiagnosticArray {
        status: vec![status],
        ..Default::default()
    };
    array.header.stamp = stamp;
    array
}
