//! The real LiDAR log (Intel Research Lab, CARMEN format) through the pipeline:
//! every scan filtered, nothing panics, no command is NaN, and rejected scans
//! are reported with their reasons.

mod common;

use oldbf_ros::algo::record::StopCause;
use oldbf_ros::algo::{Params, SafetyPipeline, ScanRejection, Twist};
use oldbf_ros::carmen::open_log;
use oldbf_ros::replay::replay_carmen;

fn log() -> oldbf_ros::carmen::CarmenLog {
    open_log(&common::repo_root().join("tests/data/intel-corrected.log.gz")).expect("the log is in tests/data")
}

#[test]
fn every_scan_of_the_intel_log_goes_through_the_pipeline() {
    let log = log();
    assert_eq!(log.scans.len(), 910);
    assert!(log.errors.is_empty(), "{:?}", log.errors.first());
    assert!(log.scans.iter().all(|s| s.ranges_m.len() == 180));
    let p = Params::default();
    let mut pipe = SafetyPipeline::new(p.clone());
    let summary = replay_carmen(&log, &mut pipe, Twist::new(p.control.v_nom_mps, 0.0));
    println!("{}", summary.text());
    assert_eq!(summary.scans, 910);
    assert_eq!(summary.non_finite_commands, 0);
    assert_eq!(summary.rejected_total, summary.rejected.values().sum::<usize>());
    // The log is well formed, so nothing is rejected…
    assert_eq!(summary.rejected_total, 0, "{summary:?}");
    // …every scan sees something (an indoor lab), and the filter does act on real data.
    assert_eq!(summary.empty_scans, 0);
    assert!(summary.filter_changed > 0, "{summary:?}");
    assert!(summary.states.get("avoid").copied().unwrap_or(0) > 0, "{summary:?}");
    // The lab's corridors bring walls well inside d_act = 1.2 m, but the log never
    // touches anything.
    assert!(
        summary.min_clearance_m > -0.178 && summary.min_clearance_m < 1.2,
        "{summary:?}"
    );
}

#[test]
fn corrupted_real_scans_are_rejected_with_reasons() {
    // Real scans from the log, damaged the ways a driver or a network can damage them.
    let log = log();
    let p = Params::default();
    let mut pipe = SafetyPipeline::new(p.clone());
    let nominal = Twist::new(0.15, 0.0);
    let mut reasons = Vec::new();
    for (k, s) in log.scans.iter().enumerate().step_by(50) {
        let mut scan = s.as_laser_scan();
        let truncated: Vec<f32> = Vec::new();
        let two = [1.0f32, 2.0];
        let now = match k / 50 % 5 {
            0 => {
                scan.ranges_m = &truncated;
                scan.header.stamp_s
            }
            1 => {
                scan.header.angle_increment_rad = 0.0;
                scan.header.stamp_s
            }
            2 => {
                scan.intensities = &two;
                scan.header.stamp_s
            }
            3 => scan.header.stamp_s + 2.0, // 2 s old: stale
            _ => scan.header.stamp_s - 2.0, // clock jumped backwards
        };
        let rec = pipe.step(&scan, now, nominal, 0.0);
        assert_eq!(rec.cmd, Twist::ZERO, "scan {k}: {rec:?}");
        match rec.stop_cause {
            Some(StopCause::Rejected(r)) => reasons.push(r),
            other => panic!("scan {k}: expected a rejection, got {other:?}"),
        }
    }
    assert_eq!(reasons.len(), 19);
    assert!(reasons.iter().any(|r| matches!(r, ScanRejection::Empty)));
    assert!(reasons.iter().any(|r| matches!(r, ScanRejection::BadIncrement { .. })));
    assert!(reasons
        .iter()
        .any(|r| matches!(r, ScanRejection::IntensityLengthMismatch { .. })));
    assert!(reasons.iter().any(|r| matches!(r, ScanRejection::Stale { .. })));
    assert!(reasons.iter().any(|r| matches!(r, ScanRejection::FromFuture { .. })));
    // Every reason prints as a sentence for the logs.
    assert!(reasons.iter().all(|r| r.to_string().len() > 10));
}
