//! Unknown is not free (ALGORITHM.md §1): what an unknown beam last saw.
//!
//! A beam that reads NaN or below range_min says nothing about the space in
//! front of it; in particular a person who steps inside the LiDAR's minimum
//! range turns their beams unknown. So every beam remembers its last valid
//! reading (the range and which scan it came from) and, while it reads
//! unknown, that reading is kept as an obstacle point for up to
//! `laser.unknown_hold_s`. The point stays where it was in the world: it is
//! moved into the current robot frame with the robot's pose in the tracking
//! frame (odometry when there is any, else dead-reckoned from the commands).
//! A beam that reads +inf or ≥ range_max (REP 117: nothing in range) forgets
//! its reading: it sees through that space now.
//!
//! The spec keeps only readings that were "near"; this keeps every one. A
//! held point far away costs nothing and never makes the filter less safe.
//!
//! Storage is a range and a scan number per beam plus a ring of the robot's
//! pose per scan: no allocation once sized, and no per-beam transform unless
//! the beam is unknown.

use super::geometry::{Pose2, Vec2};

/// Scans whose robot pose is remembered; a hold longer than this many scans
/// (e.g. 2 s at 40 Hz is 80) expires early, which only shortens it.
const POSE_RING: usize = 1024;

/// Per-beam memory of the last valid reading.
#[derive(Debug, Clone)]
pub struct BeamMemory {
    /// Last valid range of each beam (m), and the scan it came from
    /// (`u32::MAX` = none).
    last: Vec<BeamSlot>,
    /// Robot pose in the tracking frame and stamp (s) of recent scans, by scan number.
    poses: Vec<(Pose2, f64)>,
    /// Number of the scan being processed.
    seq: u32,
}

/// No reading remembered.
const NONE: u32 = u32::MAX;

impl Default for BeamMemory {
    fn default() -> Self {
        Self::with_capacity(0)
    }
}

impl BeamMemory {
    /// Memory for up to `beams` beams, allocated once (the scan path allocates nothing).
    pub fn with_capacity(beams: usize) -> Self {
        Self {
            last: Vec::with_capacity(beams),
            poses: vec![(Pose2::default(), f64::NAN); POSE_RING],
            seq: 0,
        }
    }

    /// Forgets everything (the tracking frame changed, or the beam layout did).
    pub fn reset(&mut self) {
        self.last.clear();
        self.seq = 0;
        if self.poses.len() != POSE_RING {
            self.poses = vec![(Pose2::default(), f64::NAN); POSE_RING];
        }
        for p in &mut self.poses {
            p.1 = f64::NAN;
        }
    }

    /// Starts a scan of `beams` beams taken at `stamp_s` with the robot at
    /// `ego` in the tracking frame. A different beam count resets the memory.
    pub fn begin_scan(&mut self, beams: usize, ego: Pose2, stamp_s: f64) {
        if self.last.len() != beams {
            self.reset();
            self.last.resize(beams, (0.0, NONE));
        }
        self.seq = self.seq.wrapping_add(1);
        if self.seq == NONE {
            // After 4·10⁹ scans: start over rather than confuse scan numbers.
            self.reset();
            self.last.resize(beams, (0.0, NONE));
            self.seq = 1;
        }
        self.poses[self.seq as usize % POSE_RING] = (ego, stamp_s);
    }

    /// The per-beam slots of the scan begun by [`Self::begin_scan`], to be
    /// written in one pass over the beams, and the read-only rest that
    /// [`HeldView::held_point`] needs: the same as [`Self::remember`],
    /// [`Self::forget`] and [`Self::held_point`] beam by beam, without an index
    /// check per beam.
    pub fn scan_slots(&mut self) -> (&mut [BeamSlot], HeldView<'_>) {
        (
            &mut self.last,
            HeldView {
                poses: &self.poses,
                seq: self.seq,
            },
        )
    }

    /// Beam `i` read `range_m` (valid, or range_min for −inf).
    #[inline]
    pub fn remember(&mut self, i: usize, range_m: f32) {
        self.last[i] = (range_m, self.seq);
    }

    /// Beam `i` reads "nothing in range".
    #[inline]
    pub fn forget(&mut self, i: usize) {
        self.last[i].1 = NONE;
    }

    /// The point beam `i` last saw, in the current robot frame, if it was
    /// seen within `hold_s` of now; `local` maps a range on beam `i` to a
    /// point in the robot frame of the scan it was taken in.
    #[inline]
    pub fn held_point(&self, i: usize, hold_s: f64, local: impl Fn(f32) -> Vec2) -> Option<Vec2> {
        HeldView {
            poses: &self.poses,
            seq: self.seq,
        }
        .held_point(self.last[i], hold_s, local)
    }
}

/// One beam's memory: its last valid range (m) and the scan it came from.
pub type BeamSlot = (f32, u32);

/// What a beam's slot needs to become a held point: the pose ring and the
/// current scan's number ([`BeamMemory::scan_slots`]).
#[derive(Debug, Clone, Copy)]
pub struct HeldView<'a> {
    poses: &'a [(Pose2, f64)],
    seq: u32,
}

impl HeldView<'_> {
    /// Marks `slot` as read `range_m` in this scan ([`BeamMemory::remember`]).
    #[inline]
    pub fn remember(&self, slot: &mut BeamSlot, range_m: f32) {
        *slot = (range_m, self.seq);
    }

    /// Marks `slot` as reading nothing in range ([`BeamMemory::forget`]).
    #[inline]
    pub fn forget(&self, slot: &mut BeamSlot) {
        slot.1 = NONE;
    }

    /// The point `slot` last saw, in the current robot frame, if seen within
    /// `hold_s` of now ([`BeamMemory::held_point`]).
    #[inline]
    pub fn held_point(&self, slot: BeamSlot, hold_s: f64, local: impl Fn(f32) -> Vec2) -> Option<Vec2> {
        let (range, seq) = slot;
        if seq == NONE || self.seq.wrapping_sub(seq) as usize >= POSE_RING {
            return None;
        }
        let (then_pose, then_s) = self.poses[seq as usize % POSE_RING];
        let (now_pose, now_s) = self.poses[self.seq as usize % POSE_RING];
        let age = now_s - then_s;
        // A NaN age (a reset ring slot) or a clock that went backwards: expired.
        if !(age >= 0.0 && age <= hold_s) {
            return None;
        }
        let world = then_pose.transform_point(local(range));
        Some(now_pose.inverse_transform_point(world))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    fn on_x(r: f32) -> Vec2 {
        Vec2::new(r as f64, 0.0)
    }

    #[test]
    fn a_reading_is_held_for_the_hold_time_then_expires() {
        let mut m = BeamMemory::with_capacity(3);
        m.begin_scan(3, Pose2::default(), 0.0);
        m.remember(1, 0.5);
        for (t, held) in [(0.1, true), (1.0, true), (2.0, true), (2.05, false)] {
            m.begin_scan(3, Pose2::default(), t);
            assert_eq!(m.held_point(1, 2.0, on_x).is_some(), held, "t = {t}");
            assert_eq!(m.held_point(0, 2.0, on_x), None);
        }
    }

    #[test]
    fn a_held_point_stays_put_in_the_world_while_the_robot_moves() {
        let mut m = BeamMemory::with_capacity(1);
        m.begin_scan(1, Pose2::default(), 0.0);
        m.remember(0, 0.5); // 0.5 m ahead: world (0.5, 0)
                            // The robot moved 0.2 m forward and turned left by 90°: the point is now
                            // 0.3 m to its right, i.e. at (0, −0.3) in its frame.
        m.begin_scan(1, Pose2::new(0.2, 0.0, FRAC_PI_2), 0.1);
        let p = m.held_point(0, 2.0, on_x).unwrap();
        assert!((p - Vec2::new(0.0, -0.3)).norm() < 1e-12, "{p:?}");
    }

    #[test]
    fn forgetting_and_resets() {
        let mut m = BeamMemory::with_capacity(2);
        m.begin_scan(2, Pose2::default(), 0.0);
        m.remember(0, 0.5);
        m.remember(1, 0.7);
        m.begin_scan(2, Pose2::default(), 0.1);
        m.forget(0);
        assert_eq!(m.held_point(0, 2.0, on_x), None);
        assert!(m.held_point(1, 2.0, on_x).is_some());
        // A clock that steps back expires what was held.
        m.begin_scan(2, Pose2::default(), -5.0);
        assert_eq!(m.held_point(1, 2.0, on_x), None);
        // A new beam layout forgets everything.
        m.begin_scan(2, Pose2::default(), 0.0);
        m.remember(1, 0.7);
        m.begin_scan(3, Pose2::default(), 0.1);
        assert_eq!(m.held_point(1, 2.0, on_x), None);
    }

    #[test]
    fn a_hold_longer_than_the_pose_ring_expires_early() {
        let mut m = BeamMemory::with_capacity(1);
        m.begin_scan(1, Pose2::default(), 0.0);
        m.remember(0, 0.5);
        for k in 1..POSE_RING {
            m.begin_scan(1, Pose2::default(), k as f64 * 1e-3);
        }
        assert!(m.held_point(0, 60.0, on_x).is_some());
        m.begin_scan(1, Pose2::default(), 1.5);
        assert_eq!(m.held_point(0, 60.0, on_x), None);
    }
}
