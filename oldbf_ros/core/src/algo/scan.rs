//! Scan → points (ALGORITHM.md §1, paper III.A, ROS REP 117).
//!
//! A beam is valid iff its range p is finite and range_min ≤ p < range_max;
//! a valid beam becomes a point in the robot frame through the laser's mount
//! pose. The invalid readings are not all alike (REP 117), and unknown is not
//! free:
//! * +inf, or finite ≥ range_max: nothing in range, free;
//! * −inf: something too close to measure: an obstacle at range_min;
//! * NaN, and finite values below range_min (0.0 and negatives included):
//!   unknown. An unknown beam keeps its last valid reading for a while
//!   ([`BeamMemory`]); a sensor whose front is mostly unknown is blind
//!   (`blind.rs`). `laser.zero_is_no_return` declares a driver that writes
//!   0.0 for "no return" (TurtleBot3's LDS): then 0.0 is free.
//!
//! `laser.range_semantics: all_invalid_free` is the paper method: every
//! invalid reading is free space (the reciprocal 1/∞ = 0), nothing is held.
//! Malformed scans are rejected with a reason instead of being half-used.

use super::beam_memory::{BeamMemory, BeamSlot, HeldView};
use super::geometry::{Pose2, Vec2};
use super::params::{LaserParams, RangeSemantics};
use std::fmt;

/// What a scan says about itself besides its readings (sensor_msgs/LaserScan
/// fields, SI units). One type from the ROS message to the pipeline: the ROS
/// adapter fills it, the node logic keeps it with its copy of the ranges, the
/// simulator and the log replay make it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScanHeader {
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
}

/// A borrowed view of a scan: its header and its readings. Borrowing lets
/// the ROS adapter and the simulator hand over their buffers without copying.
#[derive(Debug, Clone, Copy)]
pub struct LaserScan<'a> {
    /// When, which angles, which range limits.
    pub header: ScanHeader,
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
    TooManyBeams {
        /// Beams in the scan.
        beams: usize,
        /// `laser.max_beams`.
        max: usize,
    },
    /// Intensities present but not one per beam.
    IntensityLengthMismatch {
        /// Ranges in the scan.
        ranges: usize,
        /// Intensities in the scan.
        intensities: usize,
    },
    /// angle_increment is 0 or not finite.
    BadIncrement {
        /// The scan's angle_increment (rad).
        increment_rad: f32,
    },
    /// angle_min is not finite.
    BadAngleMin {
        /// The scan's angle_min (rad).
        angle_min_rad: f32,
    },
    /// range_min/range_max not finite, negative, or range_max ≤ range_min.
    BadRangeLimits {
        /// The scan's range_min (m).
        range_min_m: f32,
        /// The scan's range_max (m).
        range_max_m: f32,
    },
    /// The beams span more than one full turn.
    SpanTooWide {
        /// |angle_increment| × beams (rad).
        span_rad: f64,
    },
    /// The stamp is not a finite number.
    BadStamp,
    /// Older than `laser.scan_timeout_s`.
    Stale {
        /// How old the scan is (s).
        age_s: f64,
        /// `laser.scan_timeout_s`.
        timeout_s: f64,
    },
    /// Stamped in the future by more than `laser.scan_timeout_s` (a clock jump).
    FromFuture {
        /// How far ahead of the clock it is stamped (s).
        ahead_s: f64,
        /// `laser.scan_timeout_s`.
        timeout_s: f64,
    },
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

/// The most a scan plane may tilt from the floor's and still be taken as
/// horizontal (deg): the filter reasons in the plane of the floor, and a
/// plane tilted further meets the floor (or passes over low obstacles) within
/// a few metres, so its ranges are not distances in that plane.
pub const MAX_MOUNT_TILT_DEG: f64 = 5.0;

/// The laser's mount in the robot frame: where it sits and which way its
/// beam angles turn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LaserMount {
    /// The laser frame in the robot frame (m, rad): its origin, and the
    /// heading of its x axis (the beam at angle 0).
    pub pose: Pose2,
    /// The laser is upside down (its z axis points at the floor: a roll or
    /// pitch of π, a scanner under a deck): its beam angles turn clockwise
    /// in the robot frame, so the beam at laser angle `a` points at
    /// `pose.theta − a` instead of `pose.theta + a`. Without this a mirrored
    /// scan would swap the left and right barriers.
    pub mirrored: bool,
}

/// Why a 3-D mount cannot place a planar scan (see [`LaserMount::from_transform`]).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum MountError {
    /// A translation or rotation component is NaN or infinite.
    #[error("the transform has a non-finite translation or rotation")]
    NotFinite,
    /// The quaternion is not a rotation (its norm is off 1 by more than 0.01).
    #[error("the rotation quaternion has norm {norm:.3}, not 1")]
    NotUnit {
        /// Its norm.
        norm: f64,
    },
    /// The scan plane is not level (upright or upside down).
    #[error("the scan plane is tilted {tilt_deg:.1}° from the floor's (at most {MAX_MOUNT_TILT_DEG}°)")]
    Tilted {
        /// The angle between the laser's z axis and the vertical (deg, 0-90).
        tilt_deg: f64,
    },
}

impl LaserMount {
    /// An upright mount at `pose`.
    pub const fn upright(pose: Pose2) -> Self {
        Self { pose, mirrored: false }
    }

    /// The mount of `laser.mount_x_m`, `mount_y_m`, `mount_yaw_deg` (upright).
    pub fn from_params(p: &LaserParams) -> Self {
        Self::upright(Pose2::new(p.mount_x_m, p.mount_y_m, p.mount_yaw_deg.to_radians()))
    }

    /// The mount of a 3-D transform of the laser frame in the robot frame
    /// (tf: translation in m, rotation as the quaternion x, y, z, w). The
    /// scan plane is the laser's x-y plane; it must be level within
    /// [`MAX_MOUNT_TILT_DEG`], upright or upside down. The height is dropped
    /// (the filter works in the floor's plane), the heading is the laser x
    /// axis projected on the floor, and a laser z axis pointing down makes
    /// the mount [`Self::mirrored`].
    pub fn from_transform(translation_m: [f64; 3], rotation_xyzw: [f64; 4]) -> Result<Self, MountError> {
        if !translation_m.iter().chain(&rotation_xyzw).all(|v| v.is_finite()) {
            return Err(MountError::NotFinite);
        }
        let [x, y, z, w] = rotation_xyzw;
        let norm = (x * x + y * y + z * z + w * w).sqrt();
        // tf's own tolerance for an unnormalised quaternion is about 1e-2.
        if (norm - 1.0).abs() > 0.01 {
            return Err(MountError::NotUnit { norm });
        }
        let (x, y, z, w) = (x / norm, y / norm, z / norm, w / norm);
        // Columns of the rotation matrix: the laser's x axis and z axis in the robot frame.
        let x_axis = [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y + w * z),
            2.0 * (x * z - w * y),
        ];
        let z_up = 1.0 - 2.0 * (x * x + y * y);
        let tilt_deg = z_up.abs().min(1.0).acos().to_degrees();
        if tilt_deg > MAX_MOUNT_TILT_DEG {
            return Err(MountError::Tilted { tilt_deg });
        }
        Ok(Self {
            pose: Pose2::new(translation_m[0], translation_m[1], x_axis[1].atan2(x_axis[0])),
            mirrored: z_up < 0.0,
        })
    }

    /// The robot-frame heading of the beam at laser angle `angle_rad` (rad).
    pub fn beam_heading(&self, angle_rad: f64) -> f64 {
        if self.mirrored {
            self.pose.theta - angle_rad
        } else {
            self.pose.theta + angle_rad
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
    /// What each beam of the last accepted scan said.
    pub status: Vec<BeamStatus>,
    /// Beams in the last accepted scan.
    pub beams: usize,
    /// Of those: unknown (held or not), held, and unknown inside the front
    /// sector watched for blindness, out of `front_beams` there.
    pub unknown: usize,
    /// Unknown beams held at their last valid reading.
    pub held: usize,
    /// Beams that read −inf.
    pub too_close: usize,
    /// Unknown beams in the front sector watched for blindness.
    pub unknown_front: usize,
    /// Beams in that sector.
    pub front_beams: usize,
    /// Beams of the rear sector a reversing robot must see, and unknown ones there.
    pub rear_beams: usize,
    /// Unknown beams in the rear sector.
    pub unknown_rear: usize,
    /// Where something may be that no beam shows now (robot frame, m): every
    /// held point (a mover last seen there may have come closer), and
    /// range_min along every beam of a run of at least [`MIN_UNKNOWN_RUN`]
    /// unknown beams with nothing held. The robot may not drive towards them
    /// (the passive-safety check and evasion keep an extra margin from them,
    /// §5b); the run points are not obstacles for h (an isolated dropout must
    /// not throw the robot into escape).
    pub phantoms: Vec<Vec2>,
    /// Beam directions of the last scan geometry seen.
    directions: BeamDirections,
}

impl ScanPoints {
    /// Beam `i`'s unit direction in the robot frame, for the last scan
    /// geometry seen (None before any, or beyond its beams).
    pub fn beam_direction(&self, i: usize) -> Option<Vec2> {
        self.directions.dirs.get(i).copied()
    }
}

/// The unit direction of every beam in the robot frame, for one scan geometry
/// (angle_min, angle_increment, beam count, mount). A laser's geometry does not
/// change from scan to scan, so the table is computed once and reused: the
/// per-beam work is then a multiply-add instead of a rotation whose every step
/// waits for the previous one.
#[derive(Debug, Default, Clone)]
struct BeamDirections {
    /// (angle_min bits, angle_increment bits, beams, mount) of `dirs`.
    geometry: Option<(u32, u32, usize, LaserMount)>,
    dirs: Vec<Vec2>,
    /// (cos_front bits, cos_rear bits) and the beams of `dirs` with x ≥ cos_front
    /// and with x ≤ −cos_rear: the front and rear sector counts, which depend on
    /// the geometry only.
    sectors: Option<(u64, u64, usize, usize)>,
}

impl BeamDirections {
    /// The directions for `scan` seen through `mount`, recomputed only when the
    /// geometry differs from the last call's.
    fn get(&mut self, scan: &LaserScan<'_>, mount: &LaserMount) -> &[Vec2] {
        let n = scan.ranges_m.len();
        let geometry = (
            scan.header.angle_min_rad.to_bits(),
            scan.header.angle_increment_rad.to_bits(),
            n,
            *mount,
        );
        if self.geometry != Some(geometry) {
            self.dirs.clear();
            self.dirs.reserve(n);
            // Beam angles by rotating a unit vector by the increment: one sin/cos
            // per geometry instead of per beam; renormalised to stop drift.
            // A mirrored mount turns the other way: the increment changes sign.
            let a0 = mount.beam_heading(scan.header.angle_min_rad as f64);
            let (s0, c0) = a0.sin_cos();
            let increment = scan.header.angle_increment_rad as f64;
            let (si, ci) = if mount.mirrored { -increment } else { increment }.sin_cos();
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
            self.sectors = None;
        }
        &self.dirs
    }

    /// The beams of the last [`Self::get`] in the front sector (x ≥ `cos_front`)
    /// and in the rear one (x ≤ −`cos_rear`), counted once per geometry.
    fn sector_counts(&mut self, cos_front: f64, cos_rear: f64) -> (usize, usize) {
        let key = (cos_front.to_bits(), cos_rear.to_bits());
        match self.sectors {
            Some((f, r, front, rear)) if (f, r) == key => (front, rear),
            _ => {
                let front = self.dirs.iter().filter(|d| d.x >= cos_front).count();
                let rear = self.dirs.iter().filter(|d| d.x <= -cos_rear).count();
                self.sectors = Some((key.0, key.1, front, rear));
                (front, rear)
            }
        }
    }
}

impl ScanPoints {
    /// Buffers for `beams` beams (no allocation per scan up to that).
    pub fn with_capacity(beams: usize) -> Self {
        Self {
            points: Vec::with_capacity(beams),
            beam_index: Vec::with_capacity(beams),
            status: Vec::with_capacity(beams),
            beams: 0,
            unknown: 0,
            held: 0,
            too_close: 0,
            unknown_front: 0,
            front_beams: 0,
            rear_beams: 0,
            unknown_rear: 0,
            // One per beam at most in the pass over the beams, one more per beam of an unknown run.
            phantoms: Vec::with_capacity(2 * beams),
            directions: BeamDirections {
                geometry: None,
                dirs: Vec::with_capacity(beams),
                sectors: None,
            },
        }
    }

    /// Empties every buffer, keeping its capacity.
    pub fn clear(&mut self) {
        self.points.clear();
        self.beam_index.clear();
        self.status.clear();
        self.clear_counts();
    }

    /// Zeroes the counts and empties the phantoms, leaving the point buffers.
    fn clear_counts(&mut self) {
        self.beams = 0;
        self.unknown = 0;
        self.held = 0;
        self.too_close = 0;
        self.unknown_front = 0;
        self.front_beams = 0;
        self.rear_beams = 0;
        self.unknown_rear = 0;
        self.phantoms.clear();
    }

    /// Makes room for `beams` beams (no-op once the buffers are that large).
    pub fn reserve(&mut self, beams: usize) {
        self.points.reserve(beams);
        self.beam_index.reserve(beams);
        self.status.reserve(beams);
        self.phantoms.reserve(2 * beams);
    }

    /// Beams with a valid reading (the points less the −inf and held ones).
    pub fn valid_count(&self) -> usize {
        self.points.len() - self.held - self.too_close
    }
}

/// Whether a range reading is valid under the definition above.
#[inline]
pub fn is_valid_range(p: f32, range_min: f32, range_max: f32) -> bool {
    p.is_finite() && p >= range_min && p < range_max
}

/// What one reading says (REP 117).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RangeKind {
    /// range_min ≤ p < range_max: an obstacle at p.
    Valid,
    /// +inf or ≥ range_max (or 0.0 under `zero_is_no_return`): nothing in range.
    Free,
    /// −inf: an obstacle too close to measure, taken at range_min.
    TooClose,
    /// NaN or below range_min: nothing known.
    Unknown,
}

/// Classifies reading `p` of a scan with limits [range_min, range_max).
#[inline]
pub fn classify_range(p: f32, range_min: f32, range_max: f32, zero_is_no_return: bool) -> RangeKind {
    if p == 0.0 && zero_is_no_return {
        RangeKind::Free
    } else if p >= range_min {
        // Also +inf; NaN fails every comparison and falls through.
        if p < range_max {
            RangeKind::Valid
        } else {
            RangeKind::Free
        }
    } else if p == f32::NEG_INFINITY {
        RangeKind::TooClose
    } else {
        RangeKind::Unknown
    }
}

/// What became of one beam of an accepted scan.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum BeamStatus {
    /// A valid reading: a point.
    Valid,
    /// Nothing in range (or, under the paper method, any invalid reading).
    Free,
    /// −inf: a point at range_min.
    TooClose,
    /// Unknown, and its last valid reading is kept as a point.
    Held,
    /// Unknown with nothing recent to keep: no point.
    Unknown,
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
    if !scan.header.angle_increment_rad.is_finite() || scan.header.angle_increment_rad == 0.0 {
        return Err(ScanRejection::BadIncrement {
            increment_rad: scan.header.angle_increment_rad,
        });
    }
    if !scan.header.angle_min_rad.is_finite() {
        return Err(ScanRejection::BadAngleMin {
            angle_min_rad: scan.header.angle_min_rad,
        });
    }
    let (rmin, rmax) = (scan.header.range_min_m, scan.header.range_max_m);
    if !rmin.is_finite() || !rmax.is_finite() || rmin < 0.0 || rmax <= rmin {
        return Err(ScanRejection::BadRangeLimits {
            range_min_m: rmin,
            range_max_m: rmax,
        });
    }
    let span_rad = (scan.header.angle_increment_rad as f64).abs() * (n - 1) as f64;
    if span_rad > 2.0 * std::f64::consts::PI + SPAN_TOLERANCE_RAD {
        return Err(ScanRejection::SpanTooWide { span_rad });
    }
    if !scan.header.stamp_s.is_finite() || !now_s.is_finite() {
        return Err(ScanRejection::BadStamp);
    }
    let age_s = now_s - scan.header.stamp_s;
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

/// Validates `scan` and fills `out` with its points ([`fill_points`]); on
/// rejection `out` is left empty and `memory` untouched.
pub fn sanitize_scan(
    scan: &LaserScan<'_>,
    now_s: f64,
    params: &LaserParams,
    mount: &LaserMount,
    out: &mut ScanPoints,
    memory: &mut BeamMemory,
) -> Result<(), ScanRejection> {
    out.clear();
    check_scan(scan, now_s, params)?;
    fill_points(scan, params, mount, out, memory, std::f64::consts::FRAC_PI_4);
    Ok(())
}

/// Fills `out` with the points of a scan that passed [`check_scan`], robot
/// frame, in beam order: valid readings, −inf at range_min, and (REP 117)
/// the held last readings of unknown beams from `memory`, on which
/// [`BeamMemory::begin_scan`] must have been called for this scan. Also
/// counts the beams of the front sector watched for blindness and of the rear
/// sector (`rear_half_rad` either side of straight back) and the unknown
/// ones among them.
pub fn fill_points(
    scan: &LaserScan<'_>,
    params: &LaserParams,
    mount: &LaserMount,
    out: &mut ScanPoints,
    memory: &mut BeamMemory,
    rear_half_rad: f64,
) {
    // The point buffers keep their contents: the pass below overwrites them by
    // index and cuts them to the points made (emptied, every scan would fill
    // them anew first).
    out.clear_counts();
    out.beams = scan.ranges_m.len();
    // Grows only when a scan has more beams than any before: no allocation in steady state.
    out.phantoms.reserve(2 * out.beams);
    let (rmin, rmax) = (scan.header.range_min_m, scan.header.range_max_m);
    let origin = mount.pose.position();
    let cos_rear = rear_half_rad.cos();
    let dirs = out.directions.get(scan, mount);
    if params.range_semantics == RangeSemantics::AllInvalidFree {
        out.points.clear();
        out.beam_index.clear();
        out.status.clear();
        let n = out.beams;
        out.points.reserve(n);
        out.beam_index.reserve(n);
        out.status.reserve(n);
        for (i, (&p, dir)) in scan.ranges_m.iter().zip(dirs).enumerate() {
            out.rear_beams += (dir.x <= -cos_rear) as usize;
            if is_valid_range(p, rmin, rmax) {
                out.points.push(origin + dir * p as f64);
                out.beam_index.push(i as u32);
                out.status.push(BeamStatus::Valid);
            } else {
                out.status.push(BeamStatus::Free);
            }
        }
        return;
    }
    let cos_front = (params.blind_sector_deg.to_radians() / 2.0)
        .min(std::f64::consts::PI)
        .cos();
    let (zero_free, hold_s) = (params.zero_is_no_return, params.unknown_hold_s);
    // The sector sizes depend on the geometry only: counted once per geometry, and
    // the per-beam sector tests are made for unknown beams only.
    let (front_beams, rear_beams) = out.directions.sector_counts(cos_front, cos_rear);
    // Counters in locals and the buffers borrowed apart: the loop then keeps them in
    // registers instead of storing through `out` at every beam.
    let ScanPoints {
        points,
        beam_index,
        status,
        phantoms,
        directions,
        ..
    } = out;
    let dirs = &directions.dirs;
    let n = scan.ranges_m.len();
    // Written by index into buffers sized once per scan (a point per beam at
    // most), then cut to the points made: no capacity check per beam.
    points.resize(n, Vec2::zeros());
    beam_index.resize(n, 0);
    status.resize(n, BeamStatus::Free);
    let (slots, memory) = memory.scan_slots();
    let (points_out, beam_index_out) = (&mut points[..n], &mut beam_index[..n]);
    let mut unknowns = UnknownBeams {
        memory,
        hold_s,
        origin,
        rmin,
        cos_front,
        cos_rear,
        unknown: 0,
        unknown_front: 0,
        unknown_rear: 0,
        held: 0,
        phantoms,
    };
    let (mut too_close, mut made) = (0, 0);
    let beams = scan
        .ranges_m
        .iter()
        .zip(dirs)
        .zip(slots.iter_mut())
        .zip(status.iter_mut());
    // Beam numbers as u32, as `beam_index` keeps them (a checked scan has at
    // most `laser.max_beams` ≤ 10⁶ beams).
    let mut i = 0u32;
    for (((&p, dir), slot), beam_status) in beams {
        *beam_status = match classify_range(p, rmin, rmax, zero_free) {
            RangeKind::Valid => {
                memory.remember(slot, p);
                points_out[made] = origin + dir * p as f64;
                beam_index_out[made] = i;
                made += 1;
                BeamStatus::Valid
            }
            RangeKind::TooClose => {
                memory.remember(slot, rmin);
                too_close += 1;
                points_out[made] = origin + dir * rmin as f64;
                beam_index_out[made] = i;
                made += 1;
                BeamStatus::TooClose
            }
            RangeKind::Free => {
                memory.forget(slot);
                BeamStatus::Free
            }
            RangeKind::Unknown => match unknowns.take(p, dir, *slot) {
                Some(q) => {
                    points_out[made] = q;
                    beam_index_out[made] = i;
                    made += 1;
                    BeamStatus::Held
                }
                None => BeamStatus::Unknown,
            },
        };
        i = i.wrapping_add(1);
    }
    points.truncate(made);
    beam_index.truncate(made);
    let (unknown, held) = (unknowns.unknown, unknowns.held);
    (out.front_beams, out.rear_beams, out.unknown) = (front_beams, rear_beams, unknown);
    (out.unknown_front, out.unknown_rear) = (unknowns.unknown_front, unknowns.unknown_rear);
    (out.held, out.too_close) = (held, too_close);
    // Runs of unknown beams with nothing held: something may be right there.
    // (Every unknown beam held: there are none, and no pass over the beams.)
    if unknown == held {
        return;
    }
    let mut run_start = None;
    for i in 0..=out.status.len() {
        let unknown = out.status.get(i) == Some(&BeamStatus::Unknown);
        match (unknown, run_start) {
            (true, None) => run_start = Some(i),
            (false, Some(start)) => {
                if i - start >= MIN_UNKNOWN_RUN {
                    out.phantoms
                        .extend(dirs[start..i].iter().map(|d| origin + d * rmin as f64));
                }
                run_start = None;
            }
            _ => {}
        }
    }
}

/// The unknown beams of a scan in [`fill_points`]: their counts, phantoms and
/// held points. Out of line: unknown beams are few in a working sensor, and
/// the valid beams' loop keeps its registers.
struct UnknownBeams<'a> {
    memory: HeldView<'a>,
    hold_s: f64,
    /// Laser origin in the robot frame (m).
    origin: Vec2,
    rmin: f32,
    cos_front: f64,
    cos_rear: f64,
    unknown: usize,
    unknown_front: usize,
    unknown_rear: usize,
    held: usize,
    phantoms: &'a mut Vec<Vec2>,
}

impl UnknownBeams<'_> {
    /// An unknown reading `p` on the beam of direction `dir` whose memory is
    /// `slot`: counted, its phantom kept, and its held point if any.
    #[cold]
    #[inline(never)]
    fn take(&mut self, p: f32, dir: &Vec2, slot: BeamSlot) -> Option<Vec2> {
        let (origin, rmin) = (self.origin, self.rmin);
        self.unknown += 1;
        self.unknown_front += (dir.x >= self.cos_front) as usize;
        self.unknown_rear += (dir.x <= -self.cos_rear) as usize;
        // A positive reading below range_min is no measurement, but it says
        // something is that close (REP 117: too close to measure): the braking
        // check keeps off this beam there, not where the beam last saw
        // something (a person who stepped inside range_min).
        let too_close = (p > 0.0).then(|| origin + dir * (p as f64).max(TOO_CLOSE_FLOOR * rmin as f64));
        match self.memory.held_point(slot, self.hold_s, |r| origin + dir * r as f64) {
            Some(q) => {
                self.held += 1;
                // Where it was: it may have come closer since.
                self.phantoms.push(too_close.unwrap_or(q));
                Some(q)
            }
            None => {
                self.phantoms.extend(too_close);
                None
            }
        }
    }
}

/// A reading below range_min puts its phantom at least this fraction of
/// range_min out: the reading itself may be any garbage down to 0, and a
/// phantom at the laser's origin would give no direction to keep off.
pub const TOO_CLOSE_FLOOR: f64 = 0.5;

/// Unknown beams in a row, with nothing held, that may hide something; fewer
/// are taken for dropouts (at 1 % dropouts, three in a row happen once in a
/// million beams).
pub const MIN_UNKNOWN_RUN: usize = 3;

/// [`fill_points`] as it was before the sector counts were cached: the
/// plain reference its property test compares it with.
#[cfg(test)]
pub(crate) fn reference_fill_points(
    scan: &LaserScan<'_>,
    params: &LaserParams,
    mount: &LaserMount,
    out: &mut ScanPoints,
    memory: &mut BeamMemory,
    rear_half_rad: f64,
) {
    out.clear();
    out.beams = scan.ranges_m.len();
    // Grows only when a scan has more beams than any before: no allocation in steady state.
    out.reserve(out.beams);
    let (rmin, rmax) = (scan.header.range_min_m, scan.header.range_max_m);
    let origin = mount.pose.position();
    let cos_rear = rear_half_rad.cos();
    let dirs = out.directions.get(scan, mount);
    if params.range_semantics == RangeSemantics::AllInvalidFree {
        for (i, (&p, dir)) in scan.ranges_m.iter().zip(dirs).enumerate() {
            out.rear_beams += (dir.x <= -cos_rear) as usize;
            if is_valid_range(p, rmin, rmax) {
                out.points.push(origin + dir * p as f64);
                out.beam_index.push(i as u32);
                out.status.push(BeamStatus::Valid);
            } else {
                out.status.push(BeamStatus::Free);
            }
        }
        return;
    }
    let cos_front = (params.blind_sector_deg.to_radians() / 2.0)
        .min(std::f64::consts::PI)
        .cos();
    let (zero_free, hold_s) = (params.zero_is_no_return, params.unknown_hold_s);
    // Counters in locals and the buffers borrowed apart: the loop then keeps them in
    // registers instead of storing through `out` at every beam.
    let ScanPoints {
        points,
        beam_index,
        status,
        phantoms,
        ..
    } = out;
    let (mut front_beams, mut rear_beams, mut unknown, mut unknown_front, mut unknown_rear) = (0, 0, 0, 0, 0);
    let (mut held, mut too_close) = (0, 0);
    for (i, (&p, dir)) in scan.ranges_m.iter().zip(dirs).enumerate() {
        let in_front = dir.x >= cos_front;
        let in_rear = dir.x <= -cos_rear;
        front_beams += in_front as usize;
        rear_beams += in_rear as usize;
        let beam_status = match classify_range(p, rmin, rmax, zero_free) {
            RangeKind::Valid => {
                memory.remember(i, p);
                points.push(origin + dir * p as f64);
                beam_index.push(i as u32);
                BeamStatus::Valid
            }
            RangeKind::TooClose => {
                memory.remember(i, rmin);
                too_close += 1;
                points.push(origin + dir * rmin as f64);
                beam_index.push(i as u32);
                BeamStatus::TooClose
            }
            RangeKind::Free => {
                memory.forget(i);
                BeamStatus::Free
            }
            RangeKind::Unknown => {
                unknown += 1;
                unknown_front += in_front as usize;
                unknown_rear += in_rear as usize;
                // A positive reading below range_min is no measurement, but it says
                // something is that close (REP 117: too close to measure): the braking
                // check keeps off this beam there, not where the beam last saw
                // something (a person who stepped inside range_min).
                let too_close = (p > 0.0).then(|| origin + dir * (p as f64).max(TOO_CLOSE_FLOOR * rmin as f64));
                match memory.held_point(i, hold_s, |r| origin + dir * r as f64) {
                    Some(q) => {
                        held += 1;
                        points.push(q);
                        beam_index.push(i as u32);
                        // Where it was: it may have come closer since.
                        phantoms.push(too_close.unwrap_or(q));
                        BeamStatus::Held
                    }
                    None => {
                        phantoms.extend(too_close);
                        BeamStatus::Unknown
                    }
                }
            }
        };
        status.push(beam_status);
    }
    (out.front_beams, out.rear_beams, out.unknown) = (front_beams, rear_beams, unknown);
    (out.unknown_front, out.unknown_rear) = (unknown_front, unknown_rear);
    (out.held, out.too_close) = (held, too_close);
    // Runs of unknown beams with nothing held: something may be right there.
    // (Every unknown beam held: there are none, and no pass over the beams.)
    if unknown == held {
        return;
    }
    let mut run_start = None;
    for i in 0..=out.status.len() {
        let unknown = out.status.get(i) == Some(&BeamStatus::Unknown);
        match (unknown, run_start) {
            (true, None) => run_start = Some(i),
            (false, Some(start)) => {
                if i - start >= MIN_UNKNOWN_RUN {
                    out.phantoms
                        .extend(dirs[start..i].iter().map(|d| origin + d * rmin as f64));
                }
                run_start = None;
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn scan<'a>(ranges: &'a [f32], angle_min: f32, inc: f32) -> LaserScan<'a> {
        LaserScan {
            header: ScanHeader {
                stamp_s: 10.0,
                angle_min_rad: angle_min,
                angle_increment_rad: inc,
                range_min_m: 0.1,
                range_max_m: 5.0,
            },
            ranges_m: ranges,
            intensities: &[],
        }
    }

    /// The quaternion (x, y, z, w) of a rotation by `angle` about `axis` (a unit vector).
    fn quat(axis: [f64; 3], angle: f64) -> [f64; 4] {
        let (s, c) = (angle / 2.0).sin_cos();
        [axis[0] * s, axis[1] * s, axis[2] * s, c]
    }

    /// q1 · q2 (x, y, z, w): rotate by q2, then by q1.
    fn quat_mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
        let [ax, ay, az, aw] = a;
        let [bx, by, bz, bw] = b;
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ]
    }

    #[test]
    fn mount_from_transform_upright_and_upside_down() {
        const X: [f64; 3] = [1.0, 0.0, 0.0];
        const Y: [f64; 3] = [0.0, 1.0, 0.0];
        const Z: [f64; 3] = [0.0, 0.0, 1.0];
        let t = [0.2, -0.1, 0.35];
        let close = |m: LaserMount, theta: f64, mirrored: bool| {
            let d = (m.pose.theta - theta + PI).rem_euclid(2.0 * PI) - PI;
            m.mirrored == mirrored && d.abs() < 1e-9 && (m.pose.x, m.pose.y) == (0.2, -0.1)
        };
        // Upright, turned 30° left: the height is dropped.
        let m = LaserMount::from_transform(t, quat(Z, PI / 6.0)).unwrap();
        assert!(close(m, PI / 6.0, false), "{m:?}");
        // Roll π (under a deck, facing forward): heading 0, mirrored.
        let m = LaserMount::from_transform(t, quat(X, PI)).unwrap();
        assert!(close(m, 0.0, true), "{m:?}");
        // Pitch π: the laser's x axis points backwards, mirrored.
        let m = LaserMount::from_transform(t, quat(Y, PI)).unwrap();
        assert!(close(m, PI, true), "{m:?}");
        // Roll π, then yaw 90° (upside down facing left).
        let m = LaserMount::from_transform(t, quat_mul(quat(Z, PI / 2.0), quat(X, PI))).unwrap();
        assert!(close(m, PI / 2.0, true), "{m:?}");
        // 3° of pitch is level enough; 10° is not, upright or upside down.
        assert!(LaserMount::from_transform(t, quat(Y, 3f64.to_radians())).is_ok());
        let tilted = LaserMount::from_transform(t, quat(Y, 10f64.to_radians()));
        assert!(matches!(tilted, Err(MountError::Tilted { tilt_deg }) if (tilt_deg - 10.0).abs() < 1e-6));
        let tilted = LaserMount::from_transform(t, quat_mul(quat(X, PI), quat(Y, 10f64.to_radians())));
        assert!(matches!(tilted, Err(MountError::Tilted { tilt_deg }) if (tilt_deg - 10.0).abs() < 1e-6));
        // Garbage.
        assert_eq!(
            LaserMount::from_transform(t, [0.0, 0.0, 0.0, 0.5]),
            Err(MountError::NotUnit { norm: 0.5 })
        );
        assert_eq!(
            LaserMount::from_transform([f64::NAN, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]),
            Err(MountError::NotFinite)
        );
    }

    #[test]
    fn an_upside_down_laser_sees_its_left_on_the_robots_right() {
        // One hit 1 m away at the laser's +90° (its left), nothing else in range.
        let n = 360;
        let inc = (2.0 * PI / n as f64) as f32;
        let mut ranges = vec![f32::INFINITY; n];
        ranges[270] = 1.0; // angle −π + 270·(π/180) = +π/2 (f32 angles: 1e-5 m tolerance)
        let s = scan(&ranges, -PI as f32, inc);
        let run = |mount: LaserMount| {
            let mut out = ScanPoints::default();
            let mut memory = BeamMemory::with_capacity(n);
            memory.begin_scan(n, Pose2::default(), 10.0);
            sanitize_scan(&s, 10.0, &LaserParams::default(), &mount, &mut out, &mut memory).unwrap();
            assert_eq!(out.points.len(), 1);
            out.points[0]
        };
        let upright = run(LaserMount::upright(Pose2::new(0.1, 0.0, 0.0)));
        assert!((upright - Vec2::new(0.1, 1.0)).norm() < 1e-5, "{upright:?}");
        // Rolled over: the same beam now points at the robot's right.
        let rolled = run(LaserMount::from_transform([0.1, 0.0, 0.2], quat([1.0, 0.0, 0.0], PI)).unwrap());
        assert!((rolled - Vec2::new(0.1, -1.0)).norm() < 1e-5, "{rolled:?}");
    }

    fn run_with(s: &LaserScan<'_>, mount: Pose2, p: &LaserParams) -> Result<ScanPoints, ScanRejection> {
        let mut out = ScanPoints::default();
        let mut memory = BeamMemory::with_capacity(s.ranges_m.len());
        memory.begin_scan(s.ranges_m.len(), Pose2::default(), s.header.stamp_s);
        sanitize_scan(s, 10.0, p, &LaserMount::upright(mount), &mut out, &mut memory).map(|_| out)
    }

    fn run(s: &LaserScan<'_>, mount: Pose2) -> Result<ScanPoints, ScanRejection> {
        run_with(s, mount, &LaserParams::default())
    }

    #[test]
    fn phantoms_mark_where_unknown_beams_may_hide_something() {
        // 8 beams 1° apart from 0 rad, range_min 0.1 m. First scan: all see a wall at 1 m.
        let inc = 1f32.to_radians();
        let mut out = ScanPoints::default();
        let mut memory = BeamMemory::with_capacity(8);
        let params = LaserParams::default();
        let mount = LaserMount::upright(Pose2::default());
        memory.begin_scan(8, Pose2::default(), 10.0);
        sanitize_scan(&scan(&[1.0; 8], 0.0, inc), 10.0, &params, &mount, &mut out, &mut memory).unwrap();
        assert!(out.phantoms.is_empty());
        // Second scan, 0.1 s later: beam 0 NaN (held: phantom where it was, 1 m),
        // beam 2 reads 0.06 (below range_min: something that close, whatever was
        // held), beam 4 reads 0.01 (garbage: kept at half range_min, 0.05 m),
        // beams 5-7 valid.
        let ranges = [f32::NAN, 1.0, 0.06, 1.0, 0.01, 1.0, 1.0, 1.0];
        memory.begin_scan(8, Pose2::default(), 10.1);
        let mut s2 = scan(&ranges, 0.0, inc);
        s2.header.stamp_s = 10.1;
        sanitize_scan(&s2, 10.1, &params, &mount, &mut out, &mut memory).unwrap();
        let at = |beam: f64, r: f64| {
            Vec2::new(
                r * (beam * 1f64.to_radians()).cos(),
                r * (beam * 1f64.to_radians()).sin(),
            )
        };
        let expected = [at(0.0, 1.0), at(2.0, 0.06), at(4.0, 0.05)];
        assert_eq!(out.phantoms.len(), 3, "{:?}", out.phantoms);
        for (got, want) in out.phantoms.iter().zip(expected) {
            assert!((got - want).norm() < 1e-6, "{got:?} vs {want:?}");
        }
        // Held points stay obstacles where they were (all three beams held the wall).
        assert_eq!(out.held, 3);
    }

    #[test]
    fn unknown_runs_without_a_hold_put_phantoms_at_range_min() {
        // Fresh memory: nothing held. Beams 1-3 NaN (a run of 3: phantoms at
        // range_min 0.1 m), beams 5-6 NaN (2: a dropout, none); a reading below
        // range_min gets its own phantom even alone (beam 8, 0.07 m).
        let ranges = [
            1.0,
            f32::NAN,
            f32::NAN,
            f32::NAN,
            1.0,
            f32::NAN,
            f32::NAN,
            1.0,
            0.07,
            1.0,
        ];
        let out = run(&scan(&ranges, 0.0, 1f32.to_radians()), Pose2::default()).unwrap();
        let mut got: Vec<(i64, i64)> = out
            .phantoms
            .iter()
            .map(|q| {
                (
                    (q.y.atan2(q.x).to_degrees()).round() as i64,
                    (q.norm() * 1000.0).round() as i64,
                )
            })
            .collect();
        got.sort();
        assert_eq!(got, [(1, 100), (2, 100), (3, 100), (8, 70)]);
    }

    /// NaN, +inf, −inf, negative, 0, below range_min, exactly range_max, beyond, valid.
    const EVERY_KIND: [f32; 9] = [
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        -1.0,
        0.0,
        0.05,
        5.0,
        7.0,
        2.0,
    ];

    #[test]
    fn rep117_reads_each_kind_of_invalid_range_as_its_own_thing() {
        use BeamStatus::*;
        let out = run(&scan(&EVERY_KIND, 0.0, 0.1), Pose2::default()).unwrap();
        // No history: unknown beams have nothing to hold.
        assert_eq!(
            out.status,
            [Unknown, Free, TooClose, Unknown, Unknown, Unknown, Free, Free, Valid]
        );
        assert_eq!((out.valid_count(), out.too_close, out.unknown, out.held), (1, 1, 4, 0));
        assert_eq!(out.beam_index, [2, 8]);
        // −inf: an obstacle at range_min (0.1 m) on beam 2, at 0.2 rad.
        assert!((out.points[0] - Vec2::new(0.1 * 0.2f64.cos(), 0.1 * 0.2f64.sin())).norm() < 1e-6);
        // Beam 8 at 0.8 rad, 2 m.
        assert!((out.points[1] - Vec2::new(2.0 * 0.8f64.cos(), 2.0 * 0.8f64.sin())).norm() < 1e-6);
    }

    #[test]
    fn a_driver_that_writes_zero_for_no_return_can_say_so() {
        let p = LaserParams {
            zero_is_no_return: true,
            ..LaserParams::default()
        };
        let out = run_with(&scan(&EVERY_KIND, 0.0, 0.1), Pose2::default(), &p).unwrap();
        assert_eq!(out.status[4], BeamStatus::Free);
        // Only exactly zero: negatives and other short readings stay unknown.
        assert_eq!(
            (out.status[3], out.status[5]),
            (BeamStatus::Unknown, BeamStatus::Unknown)
        );
        assert_eq!(classify_range(0.0, 0.0, 5.0, true), RangeKind::Free);
        assert_eq!(classify_range(0.0, 0.0, 5.0, false), RangeKind::Valid);
    }

    #[test]
    fn the_paper_method_reads_every_invalid_range_as_free() {
        let p = LaserParams {
            range_semantics: RangeSemantics::AllInvalidFree,
            ..LaserParams::default()
        };
        let out = run_with(&scan(&EVERY_KIND, 0.0, 0.1), Pose2::default(), &p).unwrap();
        assert_eq!(out.beam_index, [8]);
        assert_eq!((out.valid_count(), out.unknown), (1, 0));
        assert!(out.status[..8].iter().all(|&s| s == BeamStatus::Free));
    }

    #[test]
    fn unknown_beams_keep_their_last_reading_and_blindness_is_counted_in_front() {
        let p = LaserParams::default(); // hold 2 s, blind sector 180°
        let mount = LaserMount::upright(Pose2::default());
        // Beam 0 ahead, beam 1 behind (increment π).
        let first = [0.5f32, 0.6];
        let mut s = scan(&first, 0.0, std::f32::consts::PI);
        let (mut out, mut memory) = (ScanPoints::default(), BeamMemory::default());
        memory.begin_scan(2, Pose2::default(), 10.0);
        sanitize_scan(&s, 10.0, &p, &mount, &mut out, &mut memory).unwrap();
        assert_eq!((out.front_beams, out.unknown_front), (1, 0));
        // Both go unknown 0.1 s later while the robot has moved 0.1 m forward: the
        // obstacle ahead is now 0.4 m ahead, the one behind 0.7 m behind.
        let second = [f32::NAN, 0.01];
        s.ranges_m = &second;
        s.header.stamp_s = 10.1;
        memory.begin_scan(2, Pose2::new(0.1, 0.0, 0.0), 10.1);
        sanitize_scan(&s, 10.1, &p, &mount, &mut out, &mut memory).unwrap();
        assert_eq!(out.status, [BeamStatus::Held, BeamStatus::Held]);
        assert_eq!(
            (out.unknown, out.held, out.unknown_front, out.valid_count()),
            (2, 2, 1, 0)
        );
        assert!((out.points[0] - Vec2::new(0.4, 0.0)).norm() < 1e-6, "{:?}", out.points);
        assert!((out.points[1] - Vec2::new(-0.7, 0.0)).norm() < 1e-6, "{:?}", out.points);
        // +inf on beam 0: it sees through now, and forgets.
        let third = [f32::INFINITY, f32::NAN];
        s.ranges_m = &third;
        s.header.stamp_s = 10.2;
        memory.begin_scan(2, Pose2::new(0.1, 0.0, 0.0), 10.2);
        sanitize_scan(&s, 10.2, &p, &mount, &mut out, &mut memory).unwrap();
        let fourth = [f32::NAN, f32::NAN];
        s.ranges_m = &fourth;
        s.header.stamp_s = 10.3;
        memory.begin_scan(2, Pose2::new(0.1, 0.0, 0.0), 10.3);
        sanitize_scan(&s, 10.3, &p, &mount, &mut out, &mut memory).unwrap();
        assert_eq!(out.status, [BeamStatus::Unknown, BeamStatus::Held]);
        assert_eq!(out.beam_index, [1]);
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
        s.header.range_max_m = 0.05;
        assert!(matches!(
            run(&s, Pose2::default()),
            Err(ScanRejection::BadRangeLimits { .. })
        ));
        let mut s = scan(&ok, 0.0, 0.1);
        s.header.range_min_m = f32::NAN;
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

/// The fast paths of this module against their plain references, bit for bit.
#[cfg(test)]
mod fast_path_properties {
    use super::*;
    use proptest::prelude::*;

    /// Every kind of reading: NaN, ±inf, ±0, negative, around range_min (0.1) and range_max (5).
    fn range() -> impl Strategy<Value = f32> {
        prop_oneof![
            prop::sample::select(vec![
                f32::NAN,
                f32::INFINITY,
                f32::NEG_INFINITY,
                0.0,
                -0.0,
                -1.0,
                0.05,
                0.1,
                0.099_999,
                4.999_999,
                5.0,
                7.0,
            ]),
            0.0f32..6.0,
            any::<f32>(),
        ]
    }

    fn scan_of(ranges: &[f32], angle_min: f32, inc: f32, stamp_s: f64) -> LaserScan<'_> {
        LaserScan {
            header: ScanHeader {
                stamp_s,
                angle_min_rad: angle_min,
                angle_increment_rad: inc,
                range_min_m: 0.1,
                range_max_m: 5.0,
            },
            ranges_m: ranges,
            intensities: &[],
        }
    }

    fn bits(v: &[Vec2]) -> Vec<(u64, u64)> {
        v.iter().map(|p| (p.x.to_bits(), p.y.to_bits())).collect()
    }

    fn counts(s: &ScanPoints) -> [usize; 8] {
        [
            s.beams,
            s.unknown,
            s.held,
            s.too_close,
            s.unknown_front,
            s.front_beams,
            s.rear_beams,
            s.unknown_rear,
        ]
    }

    /// A sequence of scans: (ranges, robot pose, seconds since the last scan,
    /// blind sector (deg)), sometimes with a new beam count or geometry.
    #[allow(clippy::type_complexity)]
    fn scans() -> impl Strategy<Value = Vec<(Vec<f32>, (f64, f64, f64), f64, f64)>> {
        (1usize..300).prop_flat_map(|n| {
            prop::collection::vec(
                (
                    prop_oneof![
                        4 => prop::collection::vec(range(), n),
                        1 => prop::collection::vec(range(), 1..300),
                    ],
                    (-0.3f64..0.3, -0.3f64..0.3, -0.5f64..0.5),
                    prop_oneof![Just(0.1), 0.0f64..3.0],
                    prop::sample::select(vec![180.0, 90.0, 400.0, 0.0]),
                ),
                1..6,
            )
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(400))]

        #[test]
        fn fill_points_matches_its_reference(
            seq in scans(),
            angle_min in -3.2f32..3.2,
            inc in prop_oneof![0.0005f32..0.03, -0.03f32..-0.0005, Just(std::f32::consts::TAU / 360.0)],
            mount in (-0.2f64..0.2, -0.2f64..0.2, -3.2f64..3.2),
            zero_free in any::<bool>(),
            hold_s in 0.0f64..2.5,
            paper in prop::sample::select(vec![false, false, false, true]),
            rear_half in prop::sample::select(vec![std::f64::consts::FRAC_PI_4, 0.3, std::f64::consts::PI]),
        ) {
            let mount = LaserMount::upright(Pose2::new(mount.0, mount.1, mount.2));
            let (mut fast, mut reference) = (ScanPoints::default(), ScanPoints::default());
            let (mut mem_fast, mut mem_ref) = (BeamMemory::default(), BeamMemory::default());
            let mut stamp = 10.0;
            for (ranges, pose, gap_s, blind_deg) in &seq {
                stamp += gap_s;
                let params = LaserParams {
                    zero_is_no_return: zero_free,
                    unknown_hold_s: hold_s,
                    blind_sector_deg: *blind_deg,
                    range_semantics: if paper { RangeSemantics::AllInvalidFree } else { RangeSemantics::Rep117 },
                    ..LaserParams::default()
                };
                let scan = scan_of(ranges, angle_min, inc, stamp);
                let pose = Pose2::new(pose.0, pose.1, pose.2);
                mem_fast.begin_scan(ranges.len(), pose, stamp);
                mem_ref.begin_scan(ranges.len(), pose, stamp);
                fill_points(&scan, &params, &mount, &mut fast, &mut mem_fast, rear_half);
                reference_fill_points(&scan, &params, &mount, &mut reference, &mut mem_ref, rear_half);
                prop_assert_eq!(bits(&fast.points), bits(&reference.points));
                prop_assert_eq!(&fast.beam_index, &reference.beam_index);
                prop_assert_eq!(&fast.status, &reference.status);
                prop_assert_eq!(bits(&fast.phantoms), bits(&reference.phantoms));
                prop_assert_eq!(counts(&fast), counts(&reference));
                prop_assert_eq!(format!("{mem_fast:?}"), format!("{mem_ref:?}"));
            }
        }
    }
}
