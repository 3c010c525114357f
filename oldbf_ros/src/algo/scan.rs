//! Scan → points (ALGORITHM.md §1, paper III.A).
//!
//! A beam is valid iff its range p is finite and range_min ≤ p < range_max;
//! every other value (NaN, ±inf, negative, too short, at or beyond range_max)
//! is "out of range": p = +inf and its reciprocal q = 1/p = 0. Valid beams
//! become points in the robot frame through the laser's mount pose. Malformed
//! scans are rejected with a reason instead of being half-used.

use super::geometry::{Pose2, Vec2};
use super::params::LaserParams;
use std::fmt;

/// A borrowed view of a LaserScan (sensor_msgs/LaserScan fields, SI units).
/// Borrowing lets the ROS adapter and the simulator hand over their buffers
/// without copying.
#[derive(Debug, Clone, Copy)]
pub struct LaserScan<'a> {
    /// Acquisition time of the first beam (s, same clock as `now_s` given to the pipeline).
    pub stamp_s: f64,
    /// Angle of beam 0 in the laser frame (rad).
    pub angle_min_rad: f32,
    /// Angle between consecutive beams (rad); may be negative, never 0.
    pub angle_increment_rad: f32,
    /// Shortest valid range (m).
    pub range_min_m: f32,
    /// Ranges at or beyond this are "no return" (m).
    pub range_max_m: f32,
    /// One range per beam (m).
    pub ranges_m: &'a [f32],
    /// Empty, or one intensity per beam.
    pub intensities: &'a [f32],
}

/// Why a scan was not used. The pipeline commands a stop until a good scan arrives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ScanRejection {
    /// No beams at all.
    Empty,
    /// More beams than `laser.max_beams`.
    TooManyBeams { beams: usize, max: usize },
    /// Intensities present but not one per beam.
    IntensityLengthMismatch { ranges: usize, intensities: usize },
    /// angle_increment is 0 or not finite.
    BadIncrement { increment_rad: f32 },
    /// angle_min is not finite.
    BadAngleMin { angle_min_rad: f32 },
    /// range_min/range_max not finite, negative, or range_max ≤ range_min.
    BadRangeLimits { range_min_m: f32, range_max_m: f32 },
    /// The beams span more than one full turn.
    SpanTooWide { span_rad: f64 },
    /// The stamp is not a finite number.
    BadStamp,
    /// Older than `laser.scan_timeout_s`.
    Stale { age_s: f64, timeout_s: f64 },
    /// Stamped in the future by more than `laser.scan_timeout_s` (a clock jump).
    FromFuture { ahead_s: f64, timeout_s: f64 },
}

impl fmt::Display for ScanRejection {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::Empty => write!(f, "scan has no beams"),
            Self::TooManyBeams { beams, max } => write!(f, "scan has {beams} beams, more than laser.max_beams = {max}"),
            Self::IntensityLengthMismatch { ranges, intensities } => {
                write!(f, "scan has {ranges} ranges but {intensities} intensities")
            }
            Self::BadIncrement { increment_rad } => {
                write!(f, "angle_increment {increment_rad} rad is zero or not finite")
            }
            Self::BadAngleMin { angle_min_rad } => {
                write!(f, "angle_min {angle_min_rad} rad is not finite")
            }
            Self::BadRangeLimits {
                range_min_m,
                range_max_m,
            } => {
                write!(
                    f,
                    "range limits [{range_min_m}, {range_max_m}) m are not a valid interval"
                )
            }
            Self::SpanTooWide { span_rad } => {
                write!(f, "beams span {span_rad:.3} rad, more than a full turn")
            }
            Self::BadStamp => write!(f, "stamp is not finite"),
            Self::Stale { age_s, timeout_s } => {
                write!(f, "scan is {age_s:.3} s old (timeout {timeout_s} s)")
            }
            Self::FromFuture { ahead_s, timeout_s } => {
                write!(
                    f,
                    "scan is stamped {ahead_s:.3} s in the future (tolerance {timeout_s} s)"
                )
            }
        }
    }
}

impl ScanRejection {
    /// Short machine-readable name, used in CSV output and diagnostics.
    pub fn code(&self) -> &'static str {
        match self {
            Self::Empty => "empty",
            Self::TooManyBeams { .. } => "too_many_beams",
            Self::IntensityLengthMismatch { .. } => "intensity_length_mismatch",
            Self::BadIncrement { .. } => "bad_increment",
            Self::BadAngleMin { .. } => "bad_angle_min",
            Self::BadRangeLimits { .. } => "bad_range_limits",
            Self::SpanTooWide { .. } => "span_too_wide",
            Self::BadStamp => "bad_stamp",
            Self::Stale { .. } => "stale",
            Self::FromFuture { .. } => "from_future",
        }
    }
}

/// Tolerance on the one-full-turn check: real 360° scanners often report
/// n·increment slightly above 2π.
const SPAN_TOLERANCE_RAD: f64 = 0.05;

/// The laser's mount pose in the robot frame, with its trigonometry cached.
#[derive(Debug, Clone, Copy)]
pub struct LaserMount {
    pub pose: Pose2,
}

impl LaserMount {
    pub fn from_params(p: &LaserParams) -> Self {
        Self {
            pose: Pose2::new(p.mount_x_m, p.mount_y_m, p.mount_yaw_deg.to_radians()),
        }
    }
}

/// The valid points of one scan, robot frame. Buffers are reused across scans
/// (cleared, never shrunk), so steady-state processing does not allocate.
#[derive(Debug, Default, Clone)]
pub struct ScanPoints {
    /// Valid points in the robot frame (m), in beam order.
    pub points: Vec<Vec2>,
    /// Beam index of each point.
    pub beam_index: Vec<u32>,
    /// Reciprocal range q_i = 1/p_i for every beam (1/m); 0 for out-of-range beams.
    pub q: Vec<f64>,
    /// Beams in the last accepted scan.
    pub beams: usize,
    /// Beam directions of the last scan geometry seen.
    directions: BeamDirections,
}

/// The unit direction of every beam in the robot frame, for one scan geometry
/// (angle_min, angle_increment, beam count, mount). A laser's geometry does not
/// change from scan to scan, so the table is computed once and reused: the
/// per-beam work is then a multiply-add instead of a rotation whose every step
/// waits for the previous one.
#[derive(Debug, Default, Clone)]
struct BeamDirections {
    /// (angle_min bits, angle_increment bits, beams, mount) of `dirs`.
    geometry: Option<(u32, u32, usize, Pose2)>,
    dirs: Vec<Vec2>,
}

impl BeamDirections {
    /// The directions for `scan` seen through `mount`, recomputed only when the
    /// geometry differs from the last call's.
    fn get(&mut self, scan: &LaserScan<'_>, mount: &LaserMount) -> &[Vec2] {
        let n = scan.ranges_m.len();
        let geometry = (
            scan.angle_min_rad.to_bits(),
            scan.angle_increment_rad.to_bits(),
            n,
            mount.pose,
        );
        if self.geometry != Some(geometry) {
            self.dirs.clear();
            self.dirs.reserve(n);
            // Beam angles by rotating a unit vector by the increment: one sin/cos
            // per geometry instead of per beam; renormalised to stop drift.
            let a0 = scan.angle_min_rad as f64 + mount.pose.theta;
            let (s0, c0) = a0.sin_cos();
            let (si, ci) = (scan.angle_increment_rad as f64).sin_cos();
            let (mut dx, mut dy) = (c0, s0);
            for i in 0..n {
                self.dirs.push(Vec2::new(dx, dy));
                let nx = dx * ci - dy * si;
                dy = dx * si + dy * ci;
                dx = nx;
                if i % 64 == 63 {
                    let norm = (dx * dx + dy * dy).sqrt();
                    dx /= norm;
                    dy /= norm;
                }
            }
            self.geometry = Some(geometry);
        }
        &self.dirs
    }
}

impl ScanPoints {
    pub fn with_capacity(beams: usize) -> Self {
        Self {
            points: Vec::with_capacity(beams),
            beam_index: Vec::with_capacity(beams),
            q: Vec::with_capacity(beams),
            beams: 0,
            directions: BeamDirections {
                geometry: None,
                dirs: Vec::with_capacity(beams),
            },
        }
    }

    pub fn clear(&mut self) {
        self.points.clear();
        self.beam_index.clear();
        self.q.clear();
        self.beams = 0;
    }

    /// Makes room for `beams` beams (no-op once the buffers are that large).
    pub fn reserve(&mut self, beams: usize) {
        self.points.reserve(beams);
        self.beam_index.reserve(beams);
        self.q.reserve(beams);
    }

    pub fn valid_count(&self) -> usize {
        self.points.len()
    }
}

/// Whether a range reading is valid under the definition above.
#[inline]
pub fn is_valid_range(p: f32, range_min: f32, range_max: f32) -> bool {
    p.is_finite() && p >= range_min && p < range_max
}

/// Checks the scan's structure and timing without touching the beams.
pub fn check_scan(scan: &LaserScan<'_>, now_s: f64, params: &LaserParams) -> Result<(), ScanRejection> {
    let n = scan.ranges_m.len();
    if n == 0 {
        return Err(ScanRejection::Empty);
    }
    if n > params.max_beams {
        return Err(ScanRejection::TooManyBeams {
            beams: n,
            max: params.max_beams,
        });
    }
    if !scan.intensities.is_empty() && scan.intensities.len() != n {
        return Err(ScanRejection::IntensityLengthMismatch {
            ranges: n,
            intensities: scan.intensities.len(),
        });
    }
    if !scan.angle_increment_rad.is_finite() || scan.angle_increment_rad == 0.0 {
        return Err(ScanRejection::BadIncrement {
            increment_rad: scan.angle_increment_rad,
        });
    }
    if !scan.angle_min_rad.is_finite() {
        return Err(ScanRejection::BadAngleMin {
            angle_min_rad: scan.angle_min_rad,
        });
    }
    let (rmin, rmax) = (scan.range_min_m, scan.range_max_m);
    if !rmin.is_finite() || !rmax.is_finite() || rmin < 0.0 || rmax <= rmin {
        return Err(ScanRejection::BadRangeLimits {
            range_min_m: rmin,
            range_max_m: rmax,
        });
    }
    let span_rad = (scan.angle_increment_rad as f64).abs() * (n - 1) as f64;
    if span_rad > 2.0 * std::f64::consts::PI + SPAN_TOLERANCE_RAD {
        return Err(ScanRejection::SpanTooWide { span_rad });
    }
    if !scan.stamp_s.is_finite() || !now_s.is_finite() {
        return Err(ScanRejection::BadStamp);
    }
    let age_s = now_s - scan.stamp_s;
    if age_s > params.scan_timeout_s {
        return Err(ScanRejection::Stale {
            age_s,
            timeout_s: params.scan_timeout_s,
        });
    }
    if -age_s > params.scan_timeout_s {
        return Err(ScanRejection::FromFuture {
            ahead_s: -age_s,
            timeout_s: params.scan_timeout_s,
        });
    }
    Ok(())
}

/// Validates `scan` and fills `out` with its valid points in the robot frame.
/// On rejection `out` is left empty.
pub fn sanitize_scan(
    scan: &LaserScan<'_>,
    now_s: f64,
    params: &LaserParams,
    mount: &LaserMount,
    out: &mut ScanPoints,
) -> Result<(), ScanRejection> {
    out.clear();
    check_scan(scan, now_s, params)?;
    out.beams = scan.ranges_m.len();
    // Grows only when a scan has more beams than any before: no allocation in steady state.
    out.reserve(out.beams);
    let (rmin, rmax) = (scan.range_min_m, scan.range_max_m);
    out.q.extend(scan.ranges_m.iter().map(|&p| {
        if is_valid_range(p, rmin, rmax) {
            1.0 / p as f64
        } else {
            0.0
        }
    }));
    let origin = mount.pose.position();
    let dirs = out.directions.get(scan, mount);
    for (i, (&p, dir)) in scan.ranges_m.iter().zip(dirs).enumerate() {
        if is_valid_range(p, rmin, rmax) {
            out.points.push(origin + dir * p as f64);
            out.beam_index.push(i as u32);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn scan<'a>(ranges: &'a [f32], angle_min: f32, inc: f32) -> LaserScan<'a> {
        LaserScan {
            stamp_s: 10.0,
            angle_min_rad: angle_min,
            angle_increment_rad: inc,
            range_min_m: 0.1,
            range_max_m: 5.0,
            ranges_m: ranges,
            intensities: &[],
        }
    }

    fn run(s: &LaserScan<'_>, mount: Pose2) -> Result<ScanPoints, ScanRejection> {
        let mut out = ScanPoints::default();
        sanitize_scan(s, 10.0, &LaserParams::default(), &LaserMount { pose: mount }, &mut out).map(|_| out)
    }

    #[test]
    fn invalid_readings_become_infinite_with_zero_reciprocal() {
        // NaN, +inf, -inf, negative, below range_min, exactly range_max, beyond, valid.
        let ranges = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -1.0, 0.05, 5.0, 7.0, 2.0];
        let out = run(&scan(&ranges, 0.0, 0.1), Pose2::default()).unwrap();
        assert_eq!(out.q, [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5]);
        assert_eq!(out.valid_count(), 1);
        assert_eq!(out.beam_index, [7]);
        // Beam 7 at 0.7 rad, 2 m.
        let p = out.points[0];
        assert!((p.x - 2.0 * 0.7f64.cos()).abs() < 1e-6 && (p.y - 2.0 * 0.7f64.sin()).abs() < 1e-6);
    }

    #[test]
    fn range_min_is_inclusive_and_range_max_exclusive() {
        assert!(is_valid_range(0.1, 0.1, 5.0));
        assert!(!is_valid_range(5.0, 0.1, 5.0));
        assert!(is_valid_range(4.999, 0.1, 5.0));
    }

    #[test]
    fn beam_angles_follow_negative_increment() {
        // Beam 0 at +90° (left), beam 2 at -90° (right), increment -90°.
        let ranges = [1.0, 1.0, 1.0];
        let out = run(&scan(&ranges, (PI / 2.0) as f32, (-PI / 2.0) as f32), Pose2::default()).unwrap();
        assert!((out.points[0] - Vec2::new(0.0, 1.0)).norm() < 1e-6);
        assert!((out.points[1] - Vec2::new(1.0, 0.0)).norm() < 1e-6);
        assert!((out.points[2] - Vec2::new(0.0, -1.0)).norm() < 1e-6);
    }

    #[test]
    fn mount_transform_is_applied() {
        // Laser 0.1 m ahead, mounted backwards (yaw 180°): its beam 0 sees 1 m behind it.
        let out = run(&scan(&[1.0], 0.0, 0.1), Pose2::new(0.1, 0.0, PI)).unwrap();
        assert!((out.points[0] - Vec2::new(-0.9, 0.0)).norm() < 1e-6);
    }

    #[test]
    fn incremental_angles_stay_accurate_over_many_beams() {
        let n = 4000;
        let inc = (2.0 * PI / n as f64) as f32;
        let ranges = vec![1.0f32; n];
        let a0 = -PI as f32;
        let out = run(&scan(&ranges, a0, inc), Pose2::default()).unwrap();
        for (k, p) in out.points.iter().enumerate() {
            let a = a0 as f64 + k as f64 * inc as f64;
            assert!((p - Vec2::new(a.cos(), a.sin())).norm() < 1e-9, "beam {k}");
        }
    }

    #[test]
    fn malformed_scans_are_rejected_with_reasons() {
        let ok = [1.0f32; 4];
        assert_eq!(
            run(&scan(&[], 0.0, 0.1), Pose2::default()).unwrap_err(),
            ScanRejection::Empty
        );
        assert!(matches!(
            run(&scan(&ok, 0.0, 0.0), Pose2::default()),
            Err(ScanRejection::BadIncrement { .. })
        ));
        assert!(matches!(
            run(&scan(&ok, 0.0, f32::NAN), Pose2::default()),
            Err(ScanRejection::BadIncrement { .. })
        ));
        assert!(matches!(
            run(&scan(&ok, f32::INFINITY, 0.1), Pose2::default()),
            Err(ScanRejection::BadAngleMin { .. })
        ));
        assert!(matches!(
            run(&scan(&ok, 0.0, 3.0), Pose2::default()),
            Err(ScanRejection::SpanTooWide { .. })
        ));
        let mut s = scan(&ok, 0.0, 0.1);
        s.intensities = &[1.0, 2.0];
        assert_eq!(
            run(&s, Pose2::default()).unwrap_err(),
            ScanRejection::IntensityLengthMismatch {
                ranges: 4,
                intensities: 2
            }
        );
        let mut s = scan(&ok, 0.0, 0.1);
        s.range_max_m = 0.05;
        assert!(matches!(
            run(&s, Pose2::default()),
            Err(ScanRejection::BadRangeLimits { .. })
        ));
        let mut s = scan(&ok, 0.0, 0.1);
        s.range_min_m = f32::NAN;
        assert!(matches!(
            run(&s, Pose2::default()),
            Err(ScanRejection::BadRangeLimits { .. })
        ));
    }

    #[test]
    fn timing_checks() {
        let ok = [1.0f32; 4];
        let p = LaserParams::default(); // timeout 0.5 s
        let s = scan(&ok, 0.0, 0.1); // stamp 10.0
        assert_eq!(check_scan(&s, 10.5, &p), Ok(()));
        assert!(matches!(check_scan(&s, 10.6, &p), Err(ScanRejection::Stale { .. })));
        assert!(matches!(check_scan(&s, 9.4, &p), Err(ScanRejection::FromFuture { .. })));
        assert_eq!(check_scan(&s, f64::NAN, &p), Err(ScanRejection::BadStamp));
    }
}
