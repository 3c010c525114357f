//! CARMEN log reader for FLASER lines (the format of the Radish collection's
//! logs, e.g. the Intel Research Lab log in `tests/data/`).
//!
//! `FLASER n r1 … rn x y θ odom_x odom_y odom_θ timestamp host logger_timestamp`
//! with ranges in metres and angles in radians. The front laser covers 180°
//! starting at −90°: n = 180 beams are 1° apart (−90° … +89°); an odd n covers
//! −90° … +90° inclusive. Readings at the sensor maximum (81.83 m in the Intel
//! log) mean "no return"; with `range_max_m` set to that value the pipeline's
//! rule "valid iff range_min ≤ p < range_max" drops them.

use crate::algo::geometry::Pose2;
use crate::algo::scan::{LaserScan, ScanHeader};
use std::f64::consts::PI;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;

/// The sensor maximum used by SICK LMS logs in CARMEN format (m).
pub const CARMEN_NO_RETURN_M: f32 = 81.83;

/// One FLASER reading.
#[derive(Debug, Clone, PartialEq)]
pub struct CarmenScan {
    /// Ranges (m), beam 0 at −90°.
    pub ranges_m: Vec<f32>,
    /// Laser pose (corrected) in the log's world frame.
    pub laser_pose: Pose2,
    /// Raw odometry pose.
    pub odom_pose: Pose2,
    /// Acquisition time (s).
    pub timestamp_s: f64,
    /// 1-based line number in the file.
    pub line: usize,
}

impl CarmenScan {
    /// Angle of beam 0 (rad).
    pub fn angle_min_rad(&self) -> f32 {
        (-PI / 2.0) as f32
    }

    /// Angle between beams (rad): 180° over n beams (n even) or n − 1 gaps (n odd).
    pub fn angle_increment_rad(&self) -> f32 {
        let n = self.ranges_m.len().max(2);
        let gaps = if n % 2 == 1 { n - 1 } else { n };
        (PI / gaps as f64) as f32
    }

    /// The scan as the pipeline sees it.
    pub fn as_laser_scan(&self) -> LaserScan<'_> {
        LaserScan {
            header: ScanHeader {
                stamp_s: self.timestamp_s,
                angle_min_rad: self.angle_min_rad(),
                angle_increment_rad: self.angle_increment_rad(),
                range_min_m: 0.0,
                range_max_m: CARMEN_NO_RETURN_M,
            },
            ranges_m: &self.ranges_m,
            intensities: &[],
        }
    }
}

/// Why a FLASER line could not be parsed, with the offending values as data.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FlaserError {
    /// The line ends before field `index` (`what`: `beam count`, `x`, …).
    #[error("missing {what} (field {index})")]
    Missing { what: &'static str, index: usize },
    #[error("{what} `{token}` is not a number")]
    NotANumber { what: &'static str, token: String },
    #[error("beam count {beams} out of range [1, 100000]")]
    BeamCount { beams: usize },
    #[error("{fields} fields, expected at least {needed} for {beams} beams")]
    TooFewFields { fields: usize, needed: usize, beams: usize },
}

/// A malformed line: where and why.
#[derive(Debug, Clone, PartialEq)]
pub struct CarmenLineError {
    pub line: usize,
    pub reason: FlaserError,
}

/// Everything read from a log.
#[derive(Debug, Default, Clone)]
pub struct CarmenLog {
    pub scans: Vec<CarmenScan>,
    /// FLASER lines that could not be parsed.
    pub errors: Vec<CarmenLineError>,
    /// Lines of other message types (ODOM, PARAM, comments…).
    pub other_lines: usize,
}

fn field<T: std::str::FromStr>(tokens: &[&str], i: usize, what: &'static str) -> Result<T, FlaserError> {
    let tok = tokens.get(i).ok_or(FlaserError::Missing { what, index: i })?;
    tok.parse().map_err(|_| FlaserError::NotANumber {
        what,
        token: tok.to_string(),
    })
}

/// Parses one line; `Ok(None)` for lines that are not FLASER.
pub fn parse_line(text: &str, line: usize) -> Result<Option<CarmenScan>, FlaserError> {
    let tokens: Vec<&str> = text.split_ascii_whitespace().collect();
    if tokens.first() != Some(&"FLASER") {
        return Ok(None);
    }
    let n: usize = field(&tokens, 1, "beam count")?;
    if n == 0 || n > 100_000 {
        return Err(FlaserError::BeamCount { beams: n });
    }
    let needed = 2 + n + 7;
    if tokens.len() < needed {
        return Err(FlaserError::TooFewFields {
            fields: tokens.len(),
            needed,
            beams: n,
        });
    }
    let mut ranges_m = Vec::with_capacity(n);
    for i in 0..n {
        // Non-numeric ranges are kept as NaN: the pipeline treats them as "no return".
        ranges_m.push(tokens[2 + i].parse::<f32>().unwrap_or(f32::NAN));
    }
    let f = |k: usize, what: &'static str| field::<f64>(&tokens, 2 + n + k, what);
    let laser_pose = Pose2::new(f(0, "x")?, f(1, "y")?, f(2, "theta")?);
    let odom_pose = Pose2::new(f(3, "odom_x")?, f(4, "odom_y")?, f(5, "odom_theta")?);
    let timestamp_s = f(6, "timestamp")?;
    Ok(Some(CarmenScan {
        ranges_m,
        laser_pose,
        odom_pose,
        timestamp_s,
        line,
    }))
}

/// Reads every line of a log.
pub fn read_log<R: BufRead>(reader: R) -> std::io::Result<CarmenLog> {
    let mut log = CarmenLog::default();
    for (i, text) in reader.lines().enumerate() {
        let text = text?;
        match parse_line(&text, i + 1) {
            Ok(Some(scan)) => log.scans.push(scan),
            Ok(None) => log.other_lines += 1,
            Err(reason) => log.errors.push(CarmenLineError { line: i + 1, reason }),
        }
    }
    Ok(log)
}

/// Opens a log file, plain or gzip-compressed (detected by its magic bytes).
pub fn open_log(path: &Path) -> std::io::Result<CarmenLog> {
    let mut file = std::fs::File::open(path)?;
    let mut magic = [0u8; 2];
    let gz = file.read(&mut magic)? == 2 && magic == [0x1f, 0x8b];
    let file = std::fs::File::open(path)?;
    if gz {
        read_log(BufReader::new(flate2::read::MultiGzDecoder::new(file)))
    } else {
        read_log(BufReader::new(file))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_a_flaser_line() {
        let line = "FLASER 3 1.0 81.83 2.5 0.6 -0.03 -0.35 0.61 -0.04 -0.36 32.9068 pippo 32.9068";
        let s = parse_line(line, 7).unwrap().unwrap();
        assert_eq!(s.ranges_m, [1.0, 81.83, 2.5]);
        assert_eq!(s.laser_pose, Pose2::new(0.6, -0.03, -0.35));
        assert_eq!(s.odom_pose, Pose2::new(0.61, -0.04, -0.36));
        assert_eq!(s.timestamp_s, 32.9068);
        assert_eq!(s.line, 7);
        // 3 beams (odd): −90°, 0°, +90°.
        assert!((s.angle_increment_rad() as f64 - PI / 2.0).abs() < 1e-6);
        let scan = s.as_laser_scan();
        assert!(
            scan.header.range_max_m == CARMEN_NO_RETURN_M
                && !crate::algo::scan::is_valid_range(81.83, 0.0, scan.header.range_max_m)
        );
    }

    #[test]
    fn intel_convention_is_one_degree_from_minus_ninety() {
        let mut line = String::from("FLASER 180");
        for _ in 0..180 {
            line.push_str(" 1.0");
        }
        line.push_str(" 0 0 0 0 0 0 1.0 h 1.0");
        let s = parse_line(&line, 1).unwrap().unwrap();
        assert!((s.angle_increment_rad() as f64 - 1f64.to_radians()).abs() < 1e-7);
        assert!((s.angle_min_rad() as f64 + PI / 2.0).abs() < 1e-7);
    }

    #[test]
    fn other_and_malformed_lines() {
        assert_eq!(parse_line("ODOM 0 0 0 0 0 0 0.1 pippo 0.1", 1), Ok(None));
        assert_eq!(parse_line("# comment", 1), Ok(None));
        assert_eq!(parse_line("", 1), Ok(None));
        assert!(parse_line("FLASER", 1).unwrap_err().to_string().contains("beam count"));
        assert!(parse_line("FLASER 4 1 2 3 4 0 0", 1)
            .unwrap_err()
            .to_string()
            .contains("expected at least 13"));
        assert!(parse_line("FLASER 1 1 x 0 0 0 0 0 1 h 1", 1)
            .unwrap_err()
            .to_string()
            .contains("`x` is not a number"));
        // A garbage range is kept as NaN (then rejected per beam by the pipeline).
        let s = parse_line("FLASER 1 abc 0 0 0 0 0 0 1 h 1", 1).unwrap().unwrap();
        assert!(s.ranges_m[0].is_nan());
    }

    #[test]
    fn read_log_counts_lines() {
        let text = "# header\nFLASER 1 1.5 0 0 0 0 0 0 1 h 1\nODOM 0 0 0 0 0 0 1 h 1\nFLASER 2 1\n";
        let log = read_log(text.as_bytes()).unwrap();
        assert_eq!(log.scans.len(), 1);
        assert_eq!(log.other_lines, 2);
        assert_eq!(log.errors.len(), 1);
        assert_eq!(log.errors[0].line, 4);
    }
}
