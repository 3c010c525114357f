//! Per-beam running mean of static returns across scans (ALGORITHM §1,
//! `laser.range_noise_m`; a departure from the paper, off in its preset).
//!
//! Range noise of σ makes h, a minimum over many beams, read low by about
//! 1.5σ and jitter by about σ from scan to scan, and it makes the one-scan
//! prediction of h(k+1) for a step along a wall read as an approach on
//! about half the scans. In a gap only a few centimetres wider than the
//! robot needs, that noise alone holds h below the filter's noise margin
//! and the robot cannot go on. Averaging each beam's return over the last
//! few scans lowers both by about √[`AVERAGED_SCANS`].
//!
//! The last scan's averaged returns are carried in the tracking frame,
//! re-projected into the new scan and matched to the beam whose ray passes
//! within [`LATERAL_TOL_M`] of them; a match within [`GATE_SIGMAS`] σ of the
//! new return is averaged with it, anything else starts afresh. Returns on
//! moving tracks pass raw and are not carried: a person walking up is seen
//! where the scan sees them. A return is never reported more than
//! [`BOUND_SIGMAS`] σ beyond the raw one, so something coming closer
//! before its track moves lags by at most that; the filter's noise margin δ
//! (3σ by default) absorbs it.

use super::geometry::{wrap_angle, Pose2, Vec2};
use super::scan::{BeamStatus, ScanPoints};

/// A carried return is matched to a beam whose ray passes this near it (m).
pub const LATERAL_TOL_M: f64 = 0.004;
/// A match further than this many σ from the new return starts afresh.
pub const GATE_SIGMAS: f64 = 3.0;
/// No return is reported more than this many σ beyond the raw one.
pub const BOUND_SIGMAS: f64 = 2.0;
/// A return is averaged over at most this many scans (half a second at 10 Hz):
/// the noise falls by √5, and the mean forgets a surface that moved within that.
pub const AVERAGED_SCANS: u32 = 5;

/// The averaged returns between scans.
#[derive(Debug, Default, Clone)]
pub struct BeamAverage {
    /// The last scan's averaged returns (tracking frame, m), how many scans
    /// each averages, and the beam that saw it.
    kept: Vec<(Vec2, u32, u32)>,
    /// The robot's heading at the last scan (tracking frame, rad).
    last_theta: f64,
    /// Per beam of this scan: the carried return on its ray (range m; NaN: none) and its count.
    onto: Vec<(f64, u32)>,
}

/// Below this |tan| of a carried return's angle off its predicted beam the
/// angle is taken as t − t³/3 (error under t⁵/5, [`APPROX_ERR_RAD`]) instead of atan.
const SMALL_TAN: f64 = 0.1;
/// Bound on the error of that angle (rad).
const APPROX_ERR_RAD: f64 = 2.1e-6;

/// `x` rounded half away from zero by a conversion (f64::round is a library
/// call on the baseline x86-64 target); `x` within the i64 range.
#[inline]
fn round_i64(x: f64) -> i64 {
    (x + 0.5f64.copysign(x)) as i64
}

/// The plain rule: the index (not wrapped) of the beam whose bearing from
/// `d0`, in steps of `inc` (rad, signed), is nearest that of `p`.
fn nearest_beam(p: Vec2, d0: Vec2, inc: f64) -> i64 {
    let a = (d0.x * p.y - d0.y * p.x).atan2(d0.dot(&p));
    (a / inc).round() as i64
}

impl BeamAverage {
    /// Room for scans of up to `beams` beams, so that no scan allocates.
    pub fn with_capacity(beams: usize) -> Self {
        Self {
            kept: Vec::with_capacity(beams),
            last_theta: 0.0,
            onto: Vec::with_capacity(beams),
        }
    }

    /// Forgets the carried returns.
    pub fn reset(&mut self) {
        self.kept.clear();
    }

    /// Averages the valid returns of `pts` (robot frame, the laser at
    /// `origin`) with those carried from the last scan; the robot is at
    /// `pose` in the tracking frame. Points whose `raw` entry is nonzero
    /// (on a moving track) pass as they are and are not carried; a missing
    /// entry counts as zero. Returns how many were averaged.
    ///
    /// A carried return is looked for first on the beam it was seen by,
    /// shifted by the robot's turn since; the angle off that beam's ray
    /// (parallax from the robot's travel, a few beams at most) then gives
    /// the beam whose ray passes nearest it: no arc tangent and no rotation
    /// per point beyond one sine and cosine per scan.
    pub fn apply(&mut self, pts: &mut ScanPoints, raw: &[u8], pose: Pose2, origin: Vec2, sigma_m: f64) -> usize {
        self.apply_matching(pts, raw, pose, origin, sigma_m, false)
    }

    /// [`Self::apply`]; `plain`: every carried return's beam from its
    /// bearing (the reference the short way is tested against).
    fn apply_matching(
        &mut self,
        pts: &mut ScanPoints,
        raw: &[u8],
        pose: Pose2,
        origin: Vec2,
        sigma_m: f64,
        plain: bool,
    ) -> usize {
        let n = pts.beams;
        self.onto.clear();
        self.onto.resize(n, (f64::NAN, 0));
        let (Some(d0), Some(d1)) = (pts.beam_direction(0), pts.beam_direction(1)) else {
            self.kept.clear();
            return 0;
        };
        if sigma_m.is_nan() || sigma_m <= 0.0 || !pose.is_finite() {
            self.kept.clear();
            return 0;
        }
        let cross = |a: Vec2, b: Vec2| a.x * b.y - a.y * b.x;
        // The signed angle from one beam to the next.
        let inc = cross(d0, d1).atan2(d0.dot(&d1));
        if inc.abs() < 1e-6 {
            self.kept.clear();
            return 0;
        }
        let per_turn = (std::f64::consts::TAU / inc.abs()).round() as i64;
        let wrap = |k: i64| usize::try_from(k.rem_euclid(per_turn.max(1))).ok();
        let map = pose.frame_map();
        // A fixed point's bearing falls by the robot's turn: so many beams.
        let shift = wrap_angle(pose.theta - self.last_theta) / inc;
        self.last_theta = pose.theta;
        // Within this of half-way between two beams (in beams) the short way's
        // angle error could pick the other one: the plain bearing decides.
        let edge = 0.5 - 5.0 * APPROX_ERR_RAD / inc.abs();
        for &(q, c, seen_by) in &self.kept {
            let p = map.inverse_point(q) - origin;
            let guess = round_i64(seen_by as f64 - shift);
            let fast = wrap(guess)
                .filter(|_| !plain)
                .and_then(|g| pts.beam_direction(g))
                .and_then(|g| {
                    let along_g = g.dot(&p);
                    let t = cross(g, p) / along_g;
                    let off_rad = if t.abs() < SMALL_TAN {
                        t - t * t * t / 3.0
                    } else {
                        t.atan()
                    };
                    let x = off_rad / inc;
                    let k = round_i64(x);
                    (along_g > 0.0 && (x - k as f64).abs() < edge).then_some(guess + k)
                });
            let k = fast.unwrap_or_else(|| nearest_beam(p, d0, inc));
            let Some(k) = wrap(k) else { continue };
            let Some(dir) = pts.beam_direction(k) else { continue };
            let along = dir.dot(&p);
            if along > 0.0 && cross(dir, p).abs() <= LATERAL_TOL_M {
                let slot = &mut self.onto[k];
                if slot.0.is_nan() || along < slot.0 {
                    *slot = (along, c);
                }
            }
        }
        self.kept.clear();
        let mut averaged = 0;
        for j in 0..pts.points.len() {
            let k = pts.beam_index[j] as usize;
            if pts.status.get(k) != Some(&BeamStatus::Valid) || raw.get(j).is_some_and(|&m| m != 0) {
                continue;
            }
            let Some(dir) = pts.beam_direction(k) else { continue };
            let raw = (pts.points[j] - origin).dot(&dir);
            let (prev, c) = self.onto[k];
            let (r, c) = if prev.is_finite() && (raw - prev).abs() < GATE_SIGMAS * sigma_m {
                averaged += 1;
                let c = (c + 1).min(AVERAGED_SCANS);
                ((prev + (raw - prev) / c as f64).min(raw + BOUND_SIGMAS * sigma_m), c)
            } else {
                (raw, 1)
            };
            pts.points[j] = origin + dir * r;
            self.kept.push((map.point(pts.points[j]), c, k as u32));
        }
        averaged
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algo::beam_memory::BeamMemory;
    use crate::algo::params::LaserParams;
    use crate::algo::scan::{fill_points, LaserMount, LaserScan, ScanHeader};
    use proptest::prelude::*;

    const SIGMA: f64 = 0.01;

    /// 360 beams over a full turn, the laser at the robot's centre.
    fn points_of(ranges: &[f32], pose: Pose2, stamp_s: f64, memory: &mut BeamMemory, out: &mut ScanPoints) {
        let p = LaserParams::default();
        let scan = LaserScan {
            header: ScanHeader {
                stamp_s,
                angle_min_rad: -std::f32::consts::PI,
                angle_increment_rad: std::f32::consts::TAU / 360.0,
                range_min_m: 0.1,
                range_max_m: 5.0,
            },
            ranges_m: ranges,
            intensities: &[],
        };
        memory.begin_scan(ranges.len(), pose, stamp_s);
        let mount = LaserMount {
            pose: Pose2::default(),
            mirrored: false,
        };
        fill_points(&scan, &p, &mount, out, memory, 0.5);
    }

    /// An empty average, beam memory and points for 360 beams.
    fn fresh() -> (BeamAverage, BeamMemory, ScanPoints) {
        (
            BeamAverage::default(),
            BeamMemory::with_capacity(360),
            ScanPoints::with_capacity(360),
        )
    }

    /// Deterministic noise of σ = 1: a sum of three uniforms from splitmix64.
    fn noise(k: u64) -> f64 {
        let mix = |mut z: u64| {
            z = z.wrapping_add(0x9e3779b97f4a7c15);
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d049bb133111eb);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        };
        (mix(3 * k) + mix(3 * k + 1) + mix(3 * k + 2) - 1.5) * 2.0
    }

    #[test]
    fn a_resting_robot_sees_a_wall_with_a_third_of_the_noise() {
        // Every beam 1 m, noise σ = 1 cm; 30 scans at rest, at most 5 averaged:
        // the spread of what is reported falls to about σ/√5 (plus the running mean's lag).
        let (mut avg, mut mem, mut out) = fresh();
        let mut errs = Vec::new();
        for s in 0..30u64 {
            let ranges: Vec<f32> = (0..360).map(|i| (1.0 + SIGMA * noise(s * 1000 + i)) as f32).collect();
            points_of(&ranges, Pose2::default(), 0.1 * s as f64, &mut mem, &mut out);
            avg.apply(&mut out, &[], Pose2::default(), Vec2::zeros(), SIGMA);
            if s >= 10 {
                errs.extend(out.points.iter().map(|q| q.norm() - 1.0));
            }
        }
        let rms = (errs.iter().map(|e| e * e).sum::<f64>() / errs.len() as f64).sqrt();
        assert!(rms < 0.55 * SIGMA, "rms {rms}");
    }

    #[test]
    fn a_jump_beyond_the_gate_is_taken_at_once() {
        let (mut avg, mut mem, mut out) = fresh();
        for s in 0..5 {
            points_of(&[2.0; 360], Pose2::default(), 0.1 * s as f64, &mut mem, &mut out);
            avg.apply(&mut out, &[], Pose2::default(), Vec2::zeros(), SIGMA);
        }
        // Something 1 m nearer on every beam: reported as it is.
        points_of(&[1.0; 360], Pose2::default(), 0.5, &mut mem, &mut out);
        assert_eq!(avg.apply(&mut out, &[], Pose2::default(), Vec2::zeros(), SIGMA), 0);
        assert!(out.points.iter().all(|q| (q.norm() - 1.0).abs() < 1e-6));
    }

    #[test]
    fn returns_marked_raw_pass_as_they_are_and_are_not_carried() {
        // Every beam at 2.00 m, then at 2.02 m (within the 3σ gate): averaged, 2.01 m,
        // except the first 10 points, marked raw (a moving track's), reported at 2.02 m.
        // On the next scan nothing was carried for those 10 beams.
        let (mut avg, mut mem, mut out) = fresh();
        points_of(&[2.0; 360], Pose2::default(), 0.0, &mut mem, &mut out);
        avg.apply(&mut out, &[], Pose2::default(), Vec2::zeros(), SIGMA);
        let mut raw = [0u8; 360];
        raw[..10].fill(1);
        points_of(&[2.02; 360], Pose2::default(), 0.1, &mut mem, &mut out);
        assert_eq!(avg.apply(&mut out, &raw, Pose2::default(), Vec2::zeros(), SIGMA), 350);
        for (j, q) in out.points.iter().enumerate() {
            let expected = if j < 10 {
                2.02f32 as f64
            } else {
                (2.0 + 2.02f32 as f64) / 2.0
            };
            assert!(
                (q.norm() - expected).abs() < 1e-6,
                "point {j}: {} against {expected}",
                q.norm()
            );
        }
        points_of(&[2.02; 360], Pose2::default(), 0.2, &mut mem, &mut out);
        assert_eq!(avg.apply(&mut out, &[], Pose2::default(), Vec2::zeros(), SIGMA), 350);
    }

    #[test]
    fn a_turn_of_one_beam_keeps_the_average_on_the_beam_that_now_sees_it() {
        // Robot turned by exactly one beam: every carried return lies on a ray (the next
        // beam's) and is averaged with it; a turn of half a beam matches none.
        let inc = std::f64::consts::TAU / 360.0;
        let (mut avg, mut mem, mut out) = fresh();
        points_of(&[1.5; 360], Pose2::default(), 0.0, &mut mem, &mut out);
        avg.apply(&mut out, &[], Pose2::default(), Vec2::zeros(), SIGMA);
        let turned = Pose2::new(0.0, 0.0, inc);
        points_of(&[1.5; 360], turned, 0.1, &mut mem, &mut out);
        assert_eq!(avg.apply(&mut out, &[], turned, Vec2::zeros(), SIGMA), 360);
        let half = Pose2::new(0.0, 0.0, 1.5 * inc);
        points_of(&[1.5; 360], half, 0.2, &mut mem, &mut out);
        assert_eq!(avg.apply(&mut out, &[], half, Vec2::zeros(), SIGMA), 0);
    }

    proptest! {
        /// The short way to each carried return's beam gives what the plain
        /// bearing rule gives, whatever the room and the robot's moves.
        #[test]
        fn the_short_way_to_the_beam_is_the_plain_rule(
            ranges in proptest::collection::vec(0.15f32..4.0, 360),
            moves in proptest::collection::vec((-0.05f64..0.05, -0.05f64..0.05, -0.4f64..0.4), 1..6),
            noise in proptest::collection::vec(-0.02f32..0.02, 360),
        ) {
            let ((mut fast, mut mem_f, mut out_f), (mut plain, mut mem_p, mut out_p)) = (fresh(), fresh());
            let origin = Vec2::new(0.1, -0.05);
            let mut pose = Pose2::default();
            for (s, (dx, dy, dth)) in std::iter::once((0.0, 0.0, 0.0)).chain(moves).enumerate() {
                pose = Pose2::new(pose.x + dx, pose.y + dy, pose.theta + dth);
                // The same world each scan is not needed: what matters is that both rules see the same.
                let scan: Vec<f32> = ranges.iter().zip(&noise).map(|(r, e)| r + e * (s % 2) as f32).collect();
                points_of(&scan, pose, 0.1 * s as f64, &mut mem_f, &mut out_f);
                points_of(&scan, pose, 0.1 * s as f64, &mut mem_p, &mut out_p);
                let a = fast.apply_matching(&mut out_f, &[], pose, origin, SIGMA, false);
                let b = plain.apply_matching(&mut out_p, &[], pose, origin, SIGMA, true);
                // The carried returns each beam matched (NaN: none), bit for bit.
                let bits = |o: &[(f64, u32)]| o.iter().map(|(r, c)| (r.to_bits(), *c)).collect::<Vec<_>>();
                prop_assert_eq!(bits(&fast.onto), bits(&plain.onto));
                prop_assert!(fast.onto.iter().filter(|(r, _)| r.is_finite()).count() > 0 || s == 0);
                prop_assert_eq!(a, b);
                prop_assert_eq!(&out_f.points, &out_p.points);
            }
        }

        /// Whatever the returns, no reported range is more than 2σ beyond the raw one:
        /// something coming closer slower than the gate lags by at most that.
        #[test]
        fn never_more_than_two_sigma_beyond_the_raw_return(steps in proptest::collection::vec(-0.04f64..0.04, 1..40), start in 0.5f64..3.0) {
            let (mut avg, mut mem, mut out) = fresh();
            let mut r = start;
            for (s, d) in steps.iter().enumerate() {
                r = (r + d).clamp(0.2, 4.5);
                points_of(&[r as f32; 360], Pose2::default(), 0.1 * s as f64, &mut mem, &mut out);
                avg.apply(&mut out, &[], Pose2::default(), Vec2::zeros(), SIGMA);
                for q in &out.points {
                    prop_assert!(q.norm() <= r as f32 as f64 + BOUND_SIGMAS * SIGMA + 1e-9, "{} against {}", q.norm(), r);
                }
            }
        }
    }
}
