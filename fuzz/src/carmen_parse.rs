//! `carmen_parse`: arbitrary bytes as a CARMEN log through `read_log` and
//! `parse_line`; the first parsed FLASER scan goes through the pipeline.
//!
//! Asserts: no panic; both readers agree on valid UTF-8; every parsed scan
//! has 1 to 100000 ranges, a finite positive beam spacing, and gives a
//! finite command inside the input box.

use crate::scan_pipeline::check_command;
use oldbf_ros::algo::dtcbf::InputBox;
use oldbf_ros::algo::{SafetyPipeline, Twist};
use oldbf_ros::carmen::{parse_line, read_log, CarmenScan};

/// Runs one input.
pub fn run(data: &[u8]) {
    let log = read_log(std::io::Cursor::new(data));
    let text = String::from_utf8_lossy(data);
    let mut first: Option<CarmenScan> = None;
    let mut parsed = 0usize;
    for (i, line) in text.lines().enumerate() {
        if let Ok(Some(scan)) = parse_line(line, i + 1) {
            check_scan_shape(&scan);
            parsed += 1;
            first.get_or_insert(scan);
        }
    }
    match log {
        Ok(log) => {
            // `lines()` of BufRead and of str split alike on valid UTF-8.
            assert_eq!(log.scans.len(), parsed, "read_log and parse_line disagree");
            for s in &log.scans {
                check_scan_shape(s);
            }
        }
        // Invalid UTF-8 is an I/O error of `read_log`, never a panic.
        Err(e) => assert_eq!(e.kind(), std::io::ErrorKind::InvalidData),
    }
    if let Some(scan) = first {
        let p = oldbf_ros::config::default_params();
        let ibox = InputBox::from_params(&p);
        let mut pipeline = SafetyPipeline::new(p);
        let ls = scan.as_laser_scan();
        let rec = pipeline.step_with_pose(&ls, scan.timestamp_s, Twist::new(0.15, 0.0), 0.1, Some(scan.odom_pose));
        check_command(rec.cmd, &ibox);
    }
}

fn check_scan_shape(scan: &CarmenScan) {
    let n = scan.ranges_m.len();
    assert!((1..=100_000).contains(&n), "{n} beams");
    let inc = scan.angle_increment_rad();
    assert!(inc.is_finite() && inc > 0.0, "increment {inc}");
    assert!(scan.angle_min_rad().is_finite());
}
