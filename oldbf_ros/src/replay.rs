//! Replaying recorded scans (CARMEN logs) through the pipeline, as the node
//! would see them: every scan filtered, every rejection counted by reason,
//! every command checked to be finite.

use crate::algo::doaa::DoaaState;
use crate::algo::geometry::Twist;
use crate::algo::pipeline::SafetyPipeline;
use crate::algo::record::StopCause;
use crate::carmen::CarmenLog;
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// What a replay found.
#[derive(Debug, Clone, Default, Serialize)]
pub struct ReplaySummary {
    /// FLASER scans in the log.
    pub scans: usize,
    /// Lines that were not valid FLASER records.
    pub malformed_lines: usize,
    /// Scans the pipeline rejected, by reason code.
    pub rejected: BTreeMap<String, usize>,
    pub rejected_total: usize,
    /// Commands the DTCBF check changed.
    pub filter_changed: usize,
    /// Commands whose DTCBF condition did not hold (infeasible or escape).
    pub condition_failed: usize,
    /// Steps per DOAA state.
    pub states: BTreeMap<String, usize>,
    /// Commands with a NaN or infinite component (must be 0).
    pub non_finite_commands: usize,
    /// Least clearance d_min seen over the log (m).
    pub min_clearance_m: f64,
    /// Scans with no valid beam.
    pub empty_scans: usize,
}

impl ReplaySummary {
    pub fn text(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "{} scans ({} malformed lines), {} rejected, {} commands changed by the filter, {} with the condition failing",
            self.scans, self.malformed_lines, self.rejected_total, self.filter_changed, self.condition_failed
        );
        for (reason, n) in &self.rejected {
            let _ = writeln!(s, "  rejected {n}: {reason}");
        }
        let states: Vec<String> = self.states.iter().map(|(k, v)| format!("{k} {v}")).collect();
        let _ = writeln!(s, "  states: {}", states.join(", "));
        let _ = write!(
            s,
            "  least clearance {:.3} m | scans with no valid beam {} | non-finite commands {}",
            self.min_clearance_m, self.empty_scans, self.non_finite_commands
        );
        s
    }
}

/// Runs every scan of `log` through `pipeline` with `nominal` as the command
/// to filter; B_v uses the speed derived from consecutive odometry poses.
pub fn replay_carmen(log: &CarmenLog, pipeline: &mut SafetyPipeline, nominal: Twist) -> ReplaySummary {
    let mut sum = ReplaySummary {
        scans: log.scans.len(),
        malformed_lines: log.errors.len(),
        min_clearance_m: f64::INFINITY,
        ..Default::default()
    };
    let mut prev: Option<(f64, nalgebra::Vector2<f64>)> = None;
    for scan in &log.scans {
        let pos = scan.odom_pose.position();
        let v = match prev {
            Some((t0, p0)) if scan.timestamp_s > t0 => (pos - p0).norm() / (scan.timestamp_s - t0),
            _ => 0.0,
        };
        prev = Some((scan.timestamp_s, pos));
        let rec = pipeline.step(&scan.as_laser_scan(), scan.timestamp_s, nominal, v);
        if !rec.cmd.is_finite() {
            sum.non_finite_commands += 1;
        }
        *sum.states.entry(rec.state.as_str().to_string()).or_default() += 1;
        match rec.stop_cause {
            Some(StopCause::Rejected(r)) => {
                sum.rejected_total += 1;
                *sum.rejected.entry(r.to_string()).or_default() += 1;
                continue;
            }
            Some(StopCause::NoScan | StopCause::BadNominal | StopCause::EStop) => continue,
            _ => {}
        }
        if rec.valid_beams == 0 {
            sum.empty_scans += 1;
        }
        if rec.filter_changed {
            sum.filter_changed += 1;
        }
        if !rec.condition_held {
            sum.condition_failed += 1;
        }
        if rec.d_min_m.is_finite() {
            sum.min_clearance_m = sum.min_clearance_m.min(rec.d_min_m);
        }
        debug_assert!(rec.state != DoaaState::Stop || rec.stop_cause.is_some());
    }
    sum
}
