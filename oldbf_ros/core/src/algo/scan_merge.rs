//! Several scanners, one scan (ALGORITHM.md §1, "Several scanners").
//!
//! A robot with a front and a rear LiDAR (two 270° scanners, two RPLIDARs)
//! gives the filter one scan: every scanner's beams, placed by its own
//! mount, become points in the base frame and are painted into a virtual
//! 360° scan around the base's origin (`bins` beams from −π). The filter
//! then runs on that scan exactly as on one LiDAR's.
//!
//! Each scanner keeps its own semantics:
//! - **REP 117 per scanner**: each beam is read against its own scan's
//!   range_min/range_max (and its own `zero_is_no_return`): a valid reading
//!   and −inf (an obstacle at its range_min) are points; +inf or beyond its
//!   range_max is free along that beam; NaN or below range_min is unknown.
//! - **A bin takes the most cautious word**: a point beats free, and the
//!   nearest point wins; free beats unknown; a bin no live scanner speaks for
//!   stays unknown (NaN), so **unknown is not free**. Between two known
//!   beams of one scanner (less than [`GAP_FILL_MAX_RAD`] apart seen from the
//!   base, with fewer than [`MIN_UNKNOWN_RUN`] unknown beams between them)
//!   the bins in between take the nearer point, or free when both are free:
//!   a scanner off the base's origin spreads its near beams over more bins
//!   than it has beams, and a dropout spread over several bins would read as
//!   a run of unknown beams that may hide something, which the filter only
//!   takes from [`MIN_UNKNOWN_RUN`] sensor beams in a row (§1).
//! - **A silent scanner's view is unknown**: its beams are dropped once its
//!   newest scan is older than its own `timeout_s`, and so are those of a
//!   rejected scan or one without a pose; the filter's own hold then keeps
//!   its last points for `laser.unknown_hold_s`. A dead rear scanner leaves
//!   the rear unknown (no backing up: the rear-seen rule), a dead front one
//!   the front (the blind-sensor stop).
//! - **A blind scanner's free space is unknown**: when more than
//!   `laser.blind_fraction` of one scanner's beams read unknown for longer
//!   than `laser.blind_timeout_s` (over its whole field of view), its free
//!   beams no longer count; its points still do (an obstacle seen is there).
//! - The hold and the blind-sensor stop of the filter run on the merged scan
//!   as on any scan.
//!
//! Scans are taken as they come ([`ScanMerger::update`]) and merged once per
//! control step ([`ScanMerger::merge`]), stamped with the newest scan taken.
//! A scan not newer than the last merged one (the other scanner's arrived
//! first) waits for the next merge: merged stamps only move forward, and
//! each scanner's own stamps must too (the same stamp again is a frozen
//! driver, its view unknown).
//! Bearings are quantised to a bin: a point's position is off by at most
//! half a bin along its arc (0.125° at 1440 bins: 2.2 mm at 1 m), its range
//! from the base's origin is exact.

use super::blind::BlindDetector;
use super::geometry::Vec2;
use super::params::{LaserParams, RangeSemantics};
use super::scan::{
    check_scan, classify_range, LaserMount, LaserScan, RangeKind, ScanHeader, ScanRejection, MIN_UNKNOWN_RUN,
};
use std::f64::consts::PI;

/// range_min of the merged scan (m): any point the scanners give is valid.
pub const MERGED_RANGE_MIN_M: f32 = 1e-3;
/// Adjacent beams of one scanner further apart than this, seen from the
/// base's origin, leave the bins between them to others (rad): 5°.
pub const GAP_FILL_MAX_RAD: f64 = 5.0 * PI / 180.0;

/// One scanner's own settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScannerSpec {
    /// Its view is unknown once its newest scan is older than this (s).
    pub timeout_s: f64,
    /// Its driver writes 0.0 for "no return".
    pub zero_is_no_return: bool,
}

/// What a scanner contributes now.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ScannerState {
    /// No scan yet: its view is unknown.
    NotYet,
    /// Its latest scan is in the merge.
    Live,
    /// Its newest scan is too old, beyond its timeout: view unknown.
    Silent {
        /// The newest scan's age (s).
        age_s: f64,
    },
    /// Its latest scan was rejected: view unknown until a good one.
    Rejected(ScanRejection),
    /// Its latest scan had no pose on the robot (tf): view unknown.
    NoPose,
    /// Its latest scan was stamped no later than the one before (a frozen
    /// or replayed driver): view unknown until a newer one.
    Frozen {
        /// That stamp (s).
        stamp_s: f64,
    },
    /// Mostly unknown for too long: its free beams do not count.
    Blind {
        /// Unknown fraction of its beams.
        unknown_fraction: f64,
    },
}

impl ScannerState {
    /// Short machine-readable name (diagnostics).
    pub fn code(&self) -> &'static str {
        match self {
            Self::NotYet => "not_yet",
            Self::Live => "live",
            Self::Silent { .. } => "silent",
            Self::Rejected(_) => "rejected",
            Self::NoPose => "no_pose",
            Self::Frozen { .. } => "frozen",
            Self::Blind { .. } => "blind",
        }
    }
}

/// A beam as the merge sees it: its bearing from the base's origin (rad)
/// and its range from there (m; +inf free, NaN unknown).
#[derive(Debug, Clone, Copy)]
struct Beam {
    bearing: f64,
    range: f32,
}

#[derive(Debug, Clone)]
struct Slot {
    spec: ScannerSpec,
    /// Stamp of the newest scan taken (s; NaN none).
    stamp_s: f64,
    /// Why its latest scan is not in the merge (None: it is).
    out: Option<ScannerState>,
    blind: BlindDetector,
    unknown_fraction: f64,
    is_blind: bool,
    /// range_max of its scans plus its distance from the base's origin (m).
    reach_m: f32,
    beams: Vec<Beam>,
}

/// The scanners' latest scans and the merged scan made from them.
#[derive(Debug, Clone)]
pub struct ScanMerger {
    slots: Vec<Slot>,
    ranges: Vec<f32>,
    header: ScanHeader,
    last_stamp_s: f64,
}

impl ScanMerger {
    /// A merger for `specs.len()` scanners into a scan of `bins` beams.
    pub fn new(specs: &[ScannerSpec], bins: usize) -> Self {
        let bins = bins.max(8);
        Self {
            slots: specs
                .iter()
                .map(|&spec| Slot {
                    spec,
                    stamp_s: f64::NAN,
                    out: Some(ScannerState::NotYet),
                    blind: BlindDetector::default(),
                    unknown_fraction: 0.0,
                    is_blind: false,
                    reach_m: 0.0,
                    beams: Vec::with_capacity(2048),
                })
                .collect(),
            ranges: vec![f32::NAN; bins],
            header: ScanHeader {
                stamp_s: f64::NAN,
                angle_min_rad: -PI as f32,
                angle_increment_rad: (2.0 * PI / bins as f64) as f32,
                range_min_m: MERGED_RANGE_MIN_M,
                range_max_m: 1.0,
            },
            last_stamp_s: f64::NAN,
        }
    }

    /// Scanners merged.
    pub fn scanners(&self) -> usize {
        self.slots.len()
    }

    /// Takes scanner `k`'s scan placed by `mount` (None: no pose on the
    /// robot, its view unknown), for the next [`Self::merge`].
    pub fn update(
        &mut self,
        k: usize,
        scan: &LaserScan<'_>,
        mount: Option<&LaserMount>,
        now_s: f64,
        params: &LaserParams,
    ) {
        let Some(slot) = self.slots.get_mut(k) else {
            return;
        };
        slot.beams.clear();
        if let Err(why) = check_scan(scan, now_s, params) {
            slot.out = Some(ScannerState::Rejected(why));
            return;
        }
        let stamp_s = scan.header.stamp_s;
        // A scanner's stamps must move forward: the same again is a frozen driver.
        if slot.stamp_s.is_finite() && stamp_s <= slot.stamp_s {
            slot.out = Some(ScannerState::Frozen { stamp_s });
            return;
        }
        slot.stamp_s = stamp_s;
        let Some(mount) = mount else {
            slot.out = Some(ScannerState::NoPose);
            return;
        };
        slot.out = None;
        let h = &scan.header;
        let origin = mount.pose.position();
        let paper = params.range_semantics == RangeSemantics::AllInvalidFree;
        let mut unknown = 0usize;
        for (i, &r) in scan.ranges_m.iter().enumerate() {
            let heading = mount.beam_heading(h.angle_min_rad as f64 + i as f64 * h.angle_increment_rad as f64);
            let dir = Vec2::new(heading.cos(), heading.sin());
            let kind = match classify_range(r, h.range_min_m, h.range_max_m, slot.spec.zero_is_no_return) {
                RangeKind::Valid => Some(r),
                RangeKind::TooClose if !paper => Some(h.range_min_m),
                RangeKind::Unknown if !paper => {
                    unknown += 1;
                    None
                }
                _ => Some(f32::INFINITY),
            };
            let beam = match kind {
                Some(d) if d.is_finite() => {
                    let p = origin + dir * d as f64;
                    Beam {
                        bearing: p.y.atan2(p.x),
                        range: p.norm() as f32,
                    }
                }
                Some(_) => {
                    let far = origin + dir * h.range_max_m as f64;
                    Beam {
                        bearing: far.y.atan2(far.x),
                        range: f32::INFINITY,
                    }
                }
                None => Beam {
                    bearing: heading,
                    range: f32::NAN,
                },
            };
            slot.beams.push(beam);
        }
        slot.reach_m = h.range_max_m + origin.norm() as f32;
        let verdict = slot.blind.update(unknown, scan.ranges_m.len(), stamp_s, params);
        slot.unknown_fraction = verdict.unknown_fraction;
        slot.is_blind = verdict.blind;
    }

    /// Paints every live scanner into a merged scan stamped with the newest
    /// scan taken; returns whether one was made (none when nothing newer
    /// than the last merged scan came: what came is kept for the next).
    pub fn merge(&mut self, now_s: f64) -> bool {
        let stamp_s = self
            .slots
            .iter()
            .map(|s| s.stamp_s)
            .filter(|s| s.is_finite())
            .fold(f64::NAN, f64::max);
        if !stamp_s.is_finite() || (self.last_stamp_s.is_finite() && stamp_s <= self.last_stamp_s) {
            return false;
        }
        let n = self.ranges.len();
        let step = 2.0 * PI / n as f64;
        self.ranges.fill(f32::NAN);
        let mut reach = MERGED_RANGE_MIN_M * 2.0;
        for slot in &self.slots {
            if slot.out.is_some() || now_s - slot.stamp_s > slot.spec.timeout_s {
                continue;
            }
            reach = reach.max(slot.reach_m);
            let bin = |bearing: f64| (((bearing + PI) / step).round() as isize).rem_euclid(n as isize) as usize;
            // A blind scanner's free beams say nothing.
            let value = |b: &Beam| {
                if slot.is_blind && b.range.is_infinite() {
                    f32::NAN
                } else {
                    b.range
                }
            };
            // The last known beam: (beam, value, index).
            let mut prev: Option<(Beam, f32, usize)> = None;
            for (j, b) in slot.beams.iter().enumerate() {
                let v = value(b);
                if v.is_nan() {
                    continue;
                }
                paint(&mut self.ranges[bin(b.bearing)], v);
                if let Some((a, va, i)) = prev {
                    // The bins strictly between two known beams of this scanner
                    // with fewer than MIN_UNKNOWN_RUN unknown beams between them
                    // (a dropout is not a hole: the filter takes no fewer
                    // unknown beams in a row for one, §1).
                    let gap = (b.bearing - a.bearing + PI).rem_euclid(2.0 * PI) - PI;
                    if j - i <= MIN_UNKNOWN_RUN && gap.abs() <= GAP_FILL_MAX_RAD {
                        let fill = if va.is_infinite() && v.is_infinite() {
                            v
                        } else {
                            va.min(v)
                        };
                        let (from, to) = if gap >= 0.0 {
                            (a.bearing, b.bearing)
                        } else {
                            (b.bearing, a.bearing)
                        };
                        let (first, last) = (bin(from), bin(to));
                        let mut k = (first + 1) % n;
                        // Same bin, or neighbours: nothing between.
                        while first != last && k != last {
                            paint(&mut self.ranges[k], fill);
                            k = (k + 1) % n;
                        }
                    }
                }
                prev = Some((*b, v, j));
            }
        }
        self.header.stamp_s = stamp_s;
        self.header.range_max_m = reach;
        self.last_stamp_s = stamp_s;
        true
    }

    /// The merged scan (the last one made).
    pub fn scan(&self) -> LaserScan<'_> {
        LaserScan {
            header: self.header,
            ranges_m: &self.ranges,
            intensities: &[],
        }
    }

    /// What scanner `k` contributes at `now_s`.
    pub fn state(&self, k: usize, now_s: f64) -> ScannerState {
        let Some(slot) = self.slots.get(k) else {
            return ScannerState::NotYet;
        };
        match slot.out {
            Some(s) => s,
            None if now_s - slot.stamp_s > slot.spec.timeout_s => ScannerState::Silent {
                age_s: now_s - slot.stamp_s,
            },
            None if slot.is_blind => ScannerState::Blind {
                unknown_fraction: slot.unknown_fraction,
            },
            None => ScannerState::Live,
        }
    }

    /// Forgets every scan (a clock jump backwards: stamps cannot be aged).
    pub fn reset(&mut self) {
        for slot in &mut self.slots {
            slot.stamp_s = f64::NAN;
            slot.out = Some(ScannerState::NotYet);
            slot.blind.reset();
            slot.is_blind = false;
            slot.beams.clear();
        }
        self.last_stamp_s = f64::NAN;
        self.ranges.fill(f32::NAN);
    }
}

/// The most cautious of what a bin holds and `v`: a point beats free and
/// unknown (the nearest point wins), free beats unknown.
#[inline]
fn paint(bin: &mut f32, v: f32) {
    if v.is_nan() {
        return;
    }
    if bin.is_nan() || v < *bin {
        *bin = v;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algo::geometry::Pose2;

    /// Update, then merge: whether a merged scan was made.
    fn feed(
        m: &mut ScanMerger,
        k: usize,
        scan: &LaserScan<'_>,
        mount: Option<&LaserMount>,
        now_s: f64,
        p: &LaserParams,
    ) -> bool {
        m.update(k, scan, mount, now_s, p);
        m.merge(now_s)
    }

    /// A scan of `ranges` with `header`.
    fn ls<'a>(header: ScanHeader, ranges: &'a [f32]) -> LaserScan<'a> {
        LaserScan {
            header,
            ranges_m: ranges,
            intensities: &[],
        }
    }

    const SPEC: ScannerSpec = ScannerSpec {
        timeout_s: 0.3,
        zero_is_no_return: false,
    };

    /// A 270° scan (from −135°) of `n` beams, all `fill`, with `set` applied.
    fn scan_270(n: usize, fill: f32, set: &[(usize, f32)]) -> Vec<f32> {
        let mut r = vec![fill; n];
        for &(i, v) in set {
            r[i] = v;
        }
        r
    }

    fn header(stamp_s: f64, n: usize) -> ScanHeader {
        ScanHeader {
            stamp_s,
            angle_min_rad: (-0.75 * PI) as f32,
            angle_increment_rad: (1.5 * PI / (n - 1) as f64) as f32,
            range_min_m: 0.05,
            range_max_m: 10.0,
        }
    }

    fn front() -> LaserMount {
        LaserMount::upright(Pose2::new(0.3, 0.0, 0.0))
    }
    fn rear() -> LaserMount {
        LaserMount::upright(Pose2::new(-0.3, 0.0, PI))
    }

    /// Merged bin of bearing `deg` (degrees).
    fn at(m: &ScanMerger, deg: f64) -> f32 {
        let n = m.ranges.len();
        let i = (((deg.to_radians() + PI) / (2.0 * PI / n as f64)).round() as usize) % n;
        m.ranges[i]
    }

    #[test]
    fn a_front_and_a_rear_scanner_make_one_scan_around_the_base() {
        let p = LaserParams::default();
        let n = 271; // 1° steps: beam 135 is straight ahead of each scanner
        let mut m = ScanMerger::new(&[SPEC, SPEC], 360);
        // Front: a wall 1.7 m ahead of the scanner (2.0 m from the base's origin).
        let f = scan_270(n, f32::INFINITY, &[(135, 1.7)]);
        assert!(feed(&mut m, 0, &ls(header(1.0, n), &f), Some(&front()), 1.0, &p));
        // Only the front so far: dead ahead 2.0 m, behind unknown.
        assert!((at(&m, 0.0) - 2.0).abs() < 1e-6);
        assert!(at(&m, 180.0).is_nan());
        assert!(at(&m, 90.0).is_infinite());
        // Rear: a box 0.5 m behind the rear scanner (0.8 m behind the base's origin).
        let r = scan_270(n, f32::INFINITY, &[(135, 0.5)]);
        assert!(feed(&mut m, 1, &ls(header(1.04, n), &r), Some(&rear()), 1.04, &p));
        assert!((at(&m, 180.0) - 0.8).abs() < 1e-6, "{}", at(&m, 180.0));
        assert!((at(&m, 0.0) - 2.0).abs() < 1e-6);
        let s = m.scan();
        assert_eq!(s.header.stamp_s, 1.04);
        assert_eq!(s.ranges_m.len(), 360);
        // Every bin spoken for: two 270° scanners cover the turn.
        assert_eq!(s.ranges_m.iter().filter(|r| r.is_nan()).count(), 0);
    }

    #[test]
    fn a_point_beats_free_and_the_nearest_point_wins() {
        let p = LaserParams::default();
        let n = 271;
        let mut m = ScanMerger::new(&[SPEC, SPEC], 360);
        // Both scanners at the origin facing ahead; one sees 3 m ahead, the other 1 m; one free.
        let o = LaserMount::upright(Pose2::default());
        let a = scan_270(n, f32::INFINITY, &[(135, 3.0), (225, 2.0)]);
        let b = scan_270(n, f32::INFINITY, &[(135, 1.0)]);
        feed(&mut m, 0, &ls(header(1.0, n), &a), Some(&o), 1.0, &p);
        feed(&mut m, 1, &ls(header(1.1, n), &b), Some(&o), 1.1, &p);
        assert_eq!(at(&m, 0.0), 1.0);
        assert_eq!(at(&m, 90.0), 2.0); // a's point, b free there
    }

    #[test]
    fn a_silent_rejected_or_unplaced_scanner_leaves_its_view_unknown() {
        let p = LaserParams::default();
        let n = 271;
        let mut m = ScanMerger::new(&[SPEC, SPEC], 360);
        let f = scan_270(n, f32::INFINITY, &[]);
        let r = scan_270(n, f32::INFINITY, &[]);
        feed(&mut m, 0, &ls(header(1.0, n), &f), Some(&front()), 1.0, &p);
        feed(&mut m, 1, &ls(header(1.05, n), &r), Some(&rear()), 1.05, &p);
        assert!(at(&m, 180.0).is_infinite());
        // The rear falls silent: 0.35 s on, past its 0.3 s timeout.
        feed(&mut m, 0, &ls(header(1.4, n), &f), Some(&front()), 1.4, &p);
        assert!(at(&m, 180.0).is_nan());
        assert!(matches!(m.state(1, 1.4), ScannerState::Silent { age_s } if (age_s - 0.35).abs() < 1e-9));
        assert_eq!(m.state(0, 1.4), ScannerState::Live);
        // The rear is back but without a pose: still unknown.
        feed(&mut m, 1, &ls(header(1.45, n), &r), None, 1.45, &p);
        assert!(at(&m, 180.0).is_nan());
        assert_eq!(m.state(1, 1.45), ScannerState::NoPose);
        // A garbage rear scan (no beams): rejected, still unknown, and no merge made.
        let made = feed(&mut m, 1, &ls(header(1.5, n), &[]), Some(&rear()), 1.5, &p);
        assert!(!made);
        assert!(matches!(m.state(1, 1.5), ScannerState::Rejected(ScanRejection::Empty)));
    }

    #[test]
    fn merged_stamps_only_move_forward() {
        let p = LaserParams::default();
        let n = 271;
        let mut m = ScanMerger::new(&[SPEC, SPEC], 360);
        let f = scan_270(n, f32::INFINITY, &[]);
        let r = scan_270(n, f32::INFINITY, &[(135, 0.5)]);
        assert!(feed(&mut m, 0, &ls(header(2.0, n), &f), Some(&front()), 2.0, &p));
        // The rear's scan is older than the last merge: kept, no merge of its own…
        assert!(!feed(&mut m, 1, &ls(header(1.98, n), &r), Some(&rear()), 2.0, &p));
        assert!(at(&m, 180.0).is_nan());
        // …and in the next one.
        assert!(feed(&mut m, 0, &ls(header(2.04, n), &f), Some(&front()), 2.04, &p));
        assert!((at(&m, 180.0) - 0.8).abs() < 1e-6);
    }

    #[test]
    fn a_blind_scanners_free_beams_stop_counting_its_points_do_not() {
        let p = LaserParams::default(); // blind: > 50 % unknown for 0.3 s
        let n = 271;
        let mut m = ScanMerger::new(&[SPEC], 360);
        // 200 of 271 beams NaN, one point 1 m ahead, the rest free.
        let mut set: Vec<(usize, f32)> = (0..200).map(|i| (i, f32::NAN)).collect();
        set.push((250, 1.0));
        let r = scan_270(n, f32::INFINITY, &set);
        let o = LaserMount::upright(Pose2::default());
        for (i, t) in [1.0, 1.1, 1.2, 1.3].iter().enumerate() {
            feed(&mut m, 0, &ls(header(*t, n), &r), Some(&o), *t, &p);
            let free = m.ranges.iter().filter(|v| v.is_infinite()).count();
            if i < 3 {
                assert!(free > 0, "not blind yet at {t}");
            } else {
                assert_eq!(free, 0, "blind at {t}: free beams still counted");
                assert!(matches!(m.state(0, *t), ScannerState::Blind { .. }));
            }
        }
        // The point at beam 250 (115° left) is still there.
        assert!((at(&m, 250.0 - 135.0) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn beams_spread_by_the_offset_leave_no_unknown_holes() {
        // A scanner 0.3 m behind the base's origin looking forward, a wall
        // across x = 0.2 m: its 1° beams land about 2.5° apart seen from the
        // base, ten 0.25° bins each; the bins between are the wall, not unknown.
        let p = LaserParams::default();
        let n = 271;
        let mut m = ScanMerger::new(&[SPEC], 1440);
        let h = header(1.0, n);
        let r: Vec<f32> = (0..n)
            .map(|i| {
                let a = h.angle_min_rad as f64 + i as f64 * h.angle_increment_rad as f64;
                if a.cos() > 0.3 {
                    (0.5 / a.cos()) as f32
                } else {
                    f32::INFINITY
                }
            })
            .collect();
        let mount = LaserMount::upright(Pose2::new(-0.3, 0.0, 0.0));
        feed(&mut m, 0, &ls(h, &r), Some(&mount), 1.0, &p);
        for tenth_deg in -400..=400 {
            let deg = f64::from(tenth_deg) / 10.0;
            let v = at(&m, deg);
            // The wall at x = 0.2: range 0.2 / cos(bearing), nearer by at most a half-bin's worth.
            let wall = 0.2 / deg.to_radians().cos();
            assert!(
                v.is_finite() && (v as f64) <= wall + 0.01 && (v as f64) >= 0.19,
                "{deg}°: {v} (wall {wall})"
            );
        }
    }

    #[test]
    fn rep_117_per_scanner_too_close_and_its_own_range_limits() {
        let p = LaserParams::default();
        let n = 271;
        let mut m = ScanMerger::new(
            &[
                SPEC,
                ScannerSpec {
                    timeout_s: 0.3,
                    zero_is_no_return: true,
                },
            ],
            360,
        );
        let o = LaserMount::upright(Pose2::default());
        let mut h = header(1.0, n);
        // Scanner 0: −inf straight ahead (at its range_min 0.05 m); 12 m (beyond its 10 m) to the left.
        let a = scan_270(n, f32::NAN, &[(135, f32::NEG_INFINITY), (225, 12.0)]);
        feed(&mut m, 0, &ls(h, &a), Some(&o), 1.0, &p);
        assert!((at(&m, 0.0) - 0.05).abs() < 1e-6);
        assert!(at(&m, 90.0).is_infinite());
        assert!(at(&m, -90.0).is_nan());
        // Scanner 1 writes 0.0 for no return: free, not unknown.
        h.stamp_s = 1.1;
        let b = scan_270(n, f32::NAN, &[(45, 0.0)]);
        feed(&mut m, 1, &ls(h, &b), Some(&o), 1.1, &p);
        assert!(at(&m, -90.0).is_infinite());
    }

    proptest::proptest! {
        /// Safety of the merge: every point any live scanner saw is no
        /// farther in the merged scan than it is (its bin holds it or a
        /// nearer one, never free or unknown), against a plain reference
        /// (each point's own bin).
        #[test]
        fn no_point_is_lost_or_pushed_back(
            front in proptest::collection::vec(proptest::prop_oneof![0.0f32..12.0, proptest::strategy::Just(f32::NAN), proptest::strategy::Just(f32::INFINITY), proptest::strategy::Just(f32::NEG_INFINITY)], 91),
            rear in proptest::collection::vec(proptest::prop_oneof![0.0f32..12.0, proptest::strategy::Just(f32::NAN), proptest::strategy::Just(f32::INFINITY)], 91),
            fx in -0.5f64..0.5, ry in -0.3f64..0.3, yaw in -3.2f64..3.2,
        ) {
            let p = LaserParams::default();
            let n = 91;
            let mut m = ScanMerger::new(&[SPEC, SPEC], 720);
            let mounts = [
                LaserMount::upright(Pose2::new(fx, 0.0, 0.0)),
                LaserMount::upright(Pose2::new(-0.2, ry, yaw)),
            ];
            let h = header(1.0, n);
            m.update(0, &ls(h, &front), Some(&mounts[0]), 1.0, &p);
            m.update(1, &ls(ScanHeader { stamp_s: 1.01, ..h }, &rear), Some(&mounts[1]), 1.01, &p);
            proptest::prop_assert!(m.merge(1.01));
            let step = 2.0 * PI / 720.0;
            for (ranges, mount) in [(&front, mounts[0]), (&rear, mounts[1])] {
                for (i, &r) in ranges.iter().enumerate() {
                    let d = match classify_range(r, h.range_min_m, h.range_max_m, false) {
                        RangeKind::Valid => r,
                        RangeKind::TooClose => h.range_min_m,
                        _ => continue,
                    };
                    let a = mount.beam_heading(h.angle_min_rad as f64 + i as f64 * h.angle_increment_rad as f64);
                    let q = mount.pose.position() + Vec2::new(a.cos(), a.sin()) * d as f64;
                    let b = (((q.y.atan2(q.x) + PI) / step).round() as usize) % 720;
                    let merged = m.ranges[b];
                    proptest::prop_assert!(
                        merged.is_finite() && merged <= q.norm() as f32 + 1e-4,
                        "point at {:?} ({} m) in bin {} reads {}", q, q.norm(), b, merged
                    );
                }
            }
        }
    }
}
